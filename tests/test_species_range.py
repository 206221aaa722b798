"""A mixture's partial fields at a slab do not depend on the range the slabs cover.

The field at a cell is a sum over the particles and contacts weighted at that cell: it
cannot depend on which other cells are averaged. In particular the force density
between species, f_inter, places each contact with a particle of another species at
its contact point, in the cell of that point; a point beyond the range belongs to a
cell that is not averaged, not to the edge cell (only a wall's contact points, which
lie on the wall just beyond the packing's cells, are taken into the edge cell).

A real pile at rest of our own deck: tests/decks/pile_3d_si.lmp with ``bidisperse yes``
(odd ids large, type 2: d = 2.4 mm, the others 1.6 mm; periodic in x and y, about 25 mm
high) on its floor of fixed type-3 spheres, dumped with 17 digits, split by type, in
2.5 mm slabs along z: over the whole pile (0 to 30 mm) and over ranges that cut the
pile, whose slabs are among the whole's.
"""

import numpy as np
import pytest

import granavg

from .helpers import MAP3, run_pile3d

pytestmark = pytest.mark.slow

MAP3D = dict(kv.split("=") for kv in MAP3.split(","))
WIDTH = 0.0025
WHOLE = (0.0, 0.03)
#: Ranges that cut the pile: at the top (as the issue's), at both ends.
CUTS = [(0.0, 0.015), (0.005, 0.0175)]
#: Agreement of the shared slabs, of each field's largest magnitude over them (measured:
#: 0, bit for bit). The slabs' edges may differ by the rounding of lo + k (hi - lo) /
#: bins (an ulp, about 1e-18 m here), which moves a particle's exact weight by about
#: 1e-15 relative; a contact taken into or left out of a slab moves f_inter by a whole
#: contact's force, 1e-3 to 1 of its largest value (measured before the fix: up to 0.63
#: at the top slab of (0, 15 mm), 3.2 at the end slabs of (5, 17.5 mm)).
TOL = 1e-12


@pytest.fixture(scope="module")
def pile(tmp_path_factory):
    out = tmp_path_factory.mktemp("species_range") / "pile"
    run_pile3d(out, bidisperse="yes", precise="yes", floor="spheres")
    return out


def _slabs(pile, lo, hi):
    return granavg.average(pile / "atoms.dump", contacts=pile / "contacts.dump",
                           contact_map=MAP3D, gravity=(0, 0, -9.81), wall_types=[3],
                           cells={"slabs": "z", "range": (lo, hi),
                                  "bins": round((hi - lo) / WIDTH)},
                           species="type")


@pytest.fixture(scope="module")
def whole(pile):
    return _slabs(pile, *WHOLE)


@pytest.mark.parametrize("cut", CUTS, ids=["top", "both-ends"])
def test_partial_fields_at_a_slab_do_not_depend_on_the_range(pile, whole, cut):
    """f_inter of each species (and every other field: nu, sigma, c, seg, ...) at the
    slabs the cut range shares with the whole pile's agree to 1e-12 of their largest
    value (measured: 0); before the fix f_inter_z differed by 0.20 (small) and 0.43
    (large) of its largest value at the top slab of (0, 15 mm), the contact points up to
    a radius beyond the range taken into its edge slab."""
    part = _slabs(pile, *cut)
    first = round((cut[0] - WHOLE[0]) / WIDTH)
    shared = slice(first, first + part.cells.n)
    assert part.species == whole.species == ("all", "type1", "type2")
    # the slabs are the same (to the rounding of their edges)
    for c in ("z_lo", "z_hi"):
        assert np.allclose(part.cells.coordinates()[c], whole.cells.coordinates()[c][shared],
                           rtol=0, atol=1e-15)
    # the range cuts the pile: particles, and contacts between species, on both sides of
    # its top, and the species push on each other in its top slab
    nu = np.asarray(whole.of("all").values["nu"])
    assert nu[shared.stop] > 0.3 and nu[shared.stop - 1] > 0.3
    assert np.all(np.asarray(part.of("type2").values["f_inter_z"])[-1:] != 0)

    checked = set()
    for s in whole.species:
        a, b = part.of(s).values, whole.of(s).values
        assert set(a) == set(b)
        for name in a:
            x, y = np.asarray(a[name], float), np.asarray(b[name], float)[shared]
            assert np.array_equal(np.isnan(x), np.isnan(y)), (s, name)
            scale = np.nanmax(np.abs(y), initial=0.0)
            diff = np.nanmax(np.abs(x - y), initial=0.0)
            assert diff <= TOL * scale, (s, name, diff / scale)
            checked.add(name)
    for name in ("f_inter_x", "f_inter_y", "f_inter_z", "nu", "rho", "sigma_zz",
                 "sigma_xz", "c", "seg_z", "dsigma_mix_zz", "F_inter_zz",
                 "coordination_inter", "boundary_z"):
        assert name in checked, name
