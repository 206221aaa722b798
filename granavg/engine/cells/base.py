"""What every kind of averaging cells declares (:class:`Cells`), what they share, and the
space the data give them (:class:`Space`).

A geometry is one class in one module of :mod:`granavg.engine.cells` (freud's ``Box`` in
spirit): its cells' volumes, the exact volume weights of particles in them, the basis in
which vectors and tensors are expressed, the cell of a point, the profile's coordinate
columns, its description for the sidecar and back, the sectors of the errors' spatial
replicas, the array its cells form in field files and the VTK mesh, the finite-volume
balance of forces, and how it is built from options. Nothing outside the module switches
on its kind.

Lengths are in the frames' units (m for granavg's own runs). Positions are handed over as
a tuple of coordinate arrays, ``(x, y)`` in 2D, ``(x, y, z)`` in 3D.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import Callable, ClassVar

import numpy as np

from granavg.engine.channels import Layout
from granavg.engine.plugins import Option
from granavg.errors import ParameterError, UserError

#: Equal cells when neither a count nor edges are given.
DEFAULT_BINS = 20
#: Most cells accepted (a 60-ring profile is the paper's finest).
MAX_CELLS = 100_000
#: How far (a share of the period) cells may reach past a periodic box's faces and
#: still be within it, and their edges still span it: the dumps' printed bounds.
PERIOD_SLACK = 1e-9


@dataclass(frozen=True)
class Space:
    """What the data say about the space the cells are built in, asked only where an
    option leaves a length to it.

    Attributes
    ----------
    dim : int
        2 (disks) or 3 (spheres).
    box : callable
        ``box()`` -> one (lo, hi) per axis: the bounds of the first frame's cell (of a
        tilted box its brick, its own lengths, not its bounding box).
    periodic : callable
        ``periodic()`` -> per axis, whether the box is periodic along it.
    why_2d : str or None
        Why the data were read as 2D, for the message that asks for the disks' height.
    """

    dim: int = 2
    box: Callable = None
    periodic: Callable = lambda: (False,) * 3
    why_2d: str | None = None

    def span(self, axis: str, given=None) -> tuple:
        """The range along ``axis``: ``given``, else the box's."""
        if given is not None:
            return tuple(float(v) for v in given)
        return tuple(float(v) for v in self.box()["xyz".index(axis)])

    def period(self, axis: str, given=None, name=None):
        """The periodic span along ``axis`` where the box is periodic along it, else
        None: the particles' images across its faces then reach every cell and kernel
        node near them, whether the cells span the box (``given`` None) or a range of it
        (``given``, the option ``name``: refused if it reaches beyond the box, where
        cells would repeat it). A tilted box's span is its own length from its lower
        corner: that brick tiles space as the box does (:class:`Shear`)."""
        if not self.periodic()["xyz".index(axis)]:
            return None
        if given is None:
            return self.span(axis)
        lo, hi = self.span(axis)
        g_lo, g_hi = (float(v) for v in given)
        slack = PERIOD_SLACK * (hi - lo)
        if g_lo < lo - slack or g_hi > hi + slack:
            raise ParameterError(name or f"{axis}_range", f"{{param}} {g_lo:g} {g_hi:g}: "
                                 f"the box is periodic along {axis} over {lo:g} {hi:g}, "
                                 "and cells beyond it would repeat it; give a range "
                                 "within the box")
        return lo, hi


#: Options several kinds of cells take.
THICKNESS = Option("thickness", "2D: the disks' height h (a disk's volume pi h a^2); "
                   "required in 2D", metavar="H")
BINS = Option("bins", "the number of equal cells across (rings from R_i to R_o of a run, "
              "default 20, or over {r_range}; slabs over {range})", "int", runs=True)
EDGES = Option("edges", "the cells' edges across, increasing (m for a run)", nargs="+",
               metavar="E", runs=True)
CENTER = Option("center", "the centre of rings (3D: the axis of cylindrical shells, "
                "parallel to z; default 0 0)", nargs=2, metavar=("X", "Y"))
R_RANGE = Option("r_range", "rings (3D: cylindrical shells): {bins} equal ones from R1 to "
                 "R2", nargs=2, metavar=("R1", "R2"))
SLABS = Option("slabs", "Cartesian slabs across x, y (or z in 3D): {bins} over {range}, or "
               "{edges}", "str", choices=("x", "y", "z"))
RANGE = Option("range", "slabs: from LO to HI (default the box)", nargs=2,
               metavar=("LO", "HI"))
GRID = Option("grid", "a grid: NX NY rectangles (2D) or NX NY NZ boxes (3D) over "
              "{x_range}, {y_range} ({z_range})", "int", nargs="+", metavar="N")
X_RANGE, Y_RANGE, Z_RANGE = (Option(f"{a}_range", f"the cells' range along {a} (default the "
                                    "box)", nargs=2, metavar=(f"{a.upper()}1",
                                                              f"{a.upper()}2"))
                             for a in "xyz")


class Cells(ABC):
    """The cells of one geometry. Subclasses are frozen dataclasses of their edges.

    Class attributes
    ----------------
    kind : str
        The name in the registry and the sidecar (``describe()["kind"]``).
    title : str
        The cells in words, in messages ("rings", "a box grid").
    dim : int
        2 or 3.
    axes : tuple of str
        The basis' axes, naming vector and tensor components (``("r", "phi")``, ...).
    position_names : tuple of str
        The atoms' coordinate columns the cells read.
    selector : str or None
        The option that chooses these cells among those of their dimension (``slabs``,
        ``grid``, ...); None for the default of the dimension.
    option_specs : tuple of Option
        The options :meth:`from_options` takes, declared (:class:`Option`);
        ``options`` names them.

    The error model's spatial replicas (:mod:`granavg.engine.uncertainty.structure`):
    ``symmetry`` (the direction along which a cell splits into sectors, or None),
    ``sectors_close`` (whether its sectors close on themselves), ``across`` (the
    direction across the cells, or None) and :meth:`sector_shares`.
    """

    kind: ClassVar[str]
    title: ClassVar[str]
    dim: ClassVar[int]
    axes: ClassVar[tuple]
    position_names: ClassVar[tuple]
    selector: ClassVar[str | None] = None
    option_specs: ClassVar[tuple] = ()
    options: ClassVar[frozenset] = frozenset()
    symmetry = None
    sectors_close = False
    across = None

    def __init_subclass__(cls, **kwargs):
        super().__init_subclass__(**kwargs)
        cls.options = frozenset(o.name for o in cls.option_specs)

    # -- built from options, described and restored ------------------------------------
    @classmethod
    @abstractmethod
    def from_options(cls, space: Space, **options) -> "Cells":
        """The cells the options describe (those given; :attr:`options` names them),
        lengths defaulting to the ``space``'s box."""

    @classmethod
    @abstractmethod
    def restore(cls, d: dict) -> "Cells":
        """The cells :meth:`describe` described (lengths in the sidecar's units)."""

    @abstractmethod
    def describe(self) -> dict:
        """The cells for the sidecar: ``kind`` and what :meth:`restore` needs."""

    # -- the cells ---------------------------------------------------------------------
    @property
    @abstractmethod
    def n(self) -> int:
        """Number of cells."""

    @property
    @abstractmethod
    def volume(self) -> np.ndarray:
        """Cell volumes, shape (n,)."""

    @property
    def layout(self) -> Layout:
        """The channels of the cell sums in this basis (every block)."""
        return layout_of(self.axes)

    @abstractmethod
    def particle_volume(self, a) -> np.ndarray:
        """V^p of each particle of radius ``a``."""

    @abstractmethod
    def def_factor(self, a) -> np.ndarray:
        """Eq. 7's V^p / a^2 of each particle."""

    @abstractmethod
    def weights(self, pos, a) -> tuple:
        """(particle, cell, fraction of the particle's volume in it), exact."""

    @abstractmethod
    def cell_of(self, pos, slack: float = 0.0) -> np.ndarray:
        """The cell holding each point, -1 outside; points less than ``slack`` beyond an
        outer edge (a wall's contact points) go to the edge cell."""

    @abstractmethod
    def basis(self, pos) -> np.ndarray:
        """Unit vectors e_i (rows) at each point, shape (P, D, D)."""

    @abstractmethod
    def coordinates(self) -> dict:
        """The profile table's coordinate columns, name -> shape (n,)."""

    #: Axes of the cells that are angles (their coordinates in rad, not lengths).
    angles: ClassVar[tuple] = ()

    def coordinate_units(self) -> dict:
        """The physical dimension of each coordinate column
        (:meth:`granavg.engine.unit_system.UnitSystem.unit`): lengths, or rad along
        :attr:`angles`."""
        def axis(c):
            return c[:-3] if c.endswith(("_lo", "_hi")) else c
        return {c: "rad" if axis(c) in self.angles else "{length}" for c in self.coordinates()}

    def sector_shares(self, pos, a, k: int) -> tuple:
        """Each particle's sector (of ``k`` along :attr:`symmetry`) and its neighbours',
        and its volume share in each: (sector, share), shapes (P, 3); rows of share sum
        to 1."""
        raise UserError(f"{self.title} have no direction to split into sectors")

    # -- as arrays of cells: field files, maps, the balance of forces --------------------
    @abstractmethod
    def grid(self) -> tuple:
        """(dimension names, shape, edges per dimension) of the cells as an array, the
        cell index k being the C-order flat index."""

    def mesh(self):
        """The cells as a VTK mesh: (points (M, 3), [(cell type, connectivity)], the
        profile cell of each mesh cell, the angle of each mesh cell for cylindrical
        components or None). Only cells that fill a grid in space have one."""
        raise ParameterError("vtk", f"{{param}}: {self.kind} are not a grid; VTK output is "
                             "for grids, polar grids, boxes and cylindrical shells (cells "
                             "that fill a grid in space; tables and NetCDF hold every kind)")

    @abstractmethod
    def residuals(self, T: dict, f: dict, closed: bool) -> tuple:
        """The balance of forces per cell and component, in finite-volume form: the net
        force on the cell over the area of its face, one array (n,) per axis
        (:mod:`granavg.analysis.balance`). ``T``: the stress components (``rr``,
        ``rphi``, ... or ``xx``, ...), ``f``: the force density per axis; ``closed``:
        no flux through the outer faces (else the edge cells are NaN)."""

    @abstractmethod
    def nodes(self) -> tuple:
        """Where a smoothing kernel evaluates the fields of these cells (their centres;
        :class:`granavg.engine.smoothing.smoothed.Smoothed`): ``("lattice", (x, y[, z]))`` points on
        a rectilinear lattice of node coordinates (node k the C-order index),
        ``("planes", axis, u, section)`` planes across the axis (index 0, 1, 2) at u,
        of the cells' extent along them (length in 2D, area in 3D),
        ``("circles", center, radii, heights)`` circles about the axis (node k = ring *
        n_heights + layer; 2D: one height, 0), ``("polar", center, radii, phis)`` points
        of a polar lattice (node k = ring * n_phi + sector)."""

    def position(self):
        """(name, coordinate per cell) where the cells form a line, else None."""
        return None

    def planes(self) -> list:
        """The planes to draw as maps: (title, (horizontal name, edges), (vertical name,
        edges), a function of a per-cell array giving the plane's values, shape
        (n_vertical, n_horizontal))."""
        return []


class Disks:
    """What the 2D cells share: disks of height ``h`` (volume pi h a^2, Eq. 7's factor
    V^p / a^2 = pi h), positions ``(x, y)``."""

    dim = 2
    position_names = ("x", "y")

    def particle_volume(self, a):
        """V^p = pi h a^2 of each disk."""
        return np.pi * self.h * a * a

    def def_factor(self, a):
        """Eq. 7's pi h = V^p / a^2, one per disk."""
        return np.full(len(a), np.pi * self.h)


class Spheres:
    """What the 3D cells share: spheres (volume 4/3 pi a^3), positions ``(x, y, z)``."""

    dim = 3
    position_names = ("x", "y", "z")

    def particle_volume(self, a):
        """V^p = 4/3 pi a^3 of each sphere."""
        return 4.0 / 3.0 * np.pi * a * a * a

    def def_factor(self, a):
        """Eq. 7's V^p / a^2 = 4/3 pi a of each sphere."""
        return 4.0 / 3.0 * np.pi * a


def disk_height(space: Space, h) -> float:
    """The disks' height h of a 2D average: given (finite > 0), else a refusal saying why
    the data were read as 2D."""
    if h is None:
        why = f" (read as 2D disks: {space.why_2d}; for spheres give {{dim}} 3)" \
            if space.why_2d and space.why_2d != "given" else ""
        raise ParameterError("thickness", "{param} H: give the disks' height, in the "
                             "dump's length unit (2D disks have volume pi h a^2)" + why)
    return positive("thickness", h)


# -- shared pieces -------------------------------------------------------------------------

_LAYOUTS = {}


def layout_of(axes, blocks=None) -> Layout:
    """One Layout per set of axes and blocks (they are immutable); every block by
    default."""
    key = (tuple(axes), None if blocks is None else tuple(sorted(blocks)))
    if key not in _LAYOUTS:
        _LAYOUTS[key] = Layout(tuple(axes), key[1])
    return _LAYOUTS[key]


def checked_edges(values, what) -> np.ndarray:
    """Cell edges as a float array: finite, increasing, at least two."""
    e = np.asarray(values, dtype=float)
    if e.ndim != 1 or len(e) < 2 or not np.all(np.isfinite(e)) or not np.all(np.diff(e) > 0):
        shown = " ".join(f"{v:g}" for v in np.ravel(e))
        raise UserError(f"{what} must be finite and increasing, at least two (got {shown})")
    return e


def radii_edges(values, what) -> np.ndarray:
    """:func:`checked_edges`, >= 0 (radii)."""
    e = checked_edges(values, what)
    if e[0] < 0:
        raise UserError(f"{what} must be >= 0 and increasing (got "
                        f"{' '.join(f'{v:g}' for v in e)})")
    return e


def cell_index(u, edges, slack=0.0):
    """Index of the cell [e_k, e_k+1) holding each u; -1 outside. A point at most
    ``slack`` beyond the first or last edge is clamped to that cell: a wall's contact
    points lie on the wall, just beyond the cells of the packing."""
    u = np.asarray(u, float)
    k = np.searchsorted(edges, u, side="right") - 1
    n = len(edges) - 1
    k = np.where((u < edges[0]) & (u >= edges[0] - slack), 0, k)
    k = np.where((u >= edges[-1]) & (u <= edges[-1] + slack), n - 1, k)
    return np.where((k >= 0) & (k < n), k, -1)


def cartesian_basis(n, dim):
    """The Cartesian basis at n points, shape (n, dim, dim)."""
    return np.broadcast_to(np.eye(dim), (n, dim, dim))


def polar_basis(dx, dy):
    """e_r and e_phi (rows) of the points at (dx, dy) from the axis, shape (P, 2, 2)."""
    r = np.hypot(dx, dy)
    E = np.empty((len(r), 2, 2))
    with np.errstate(invalid="ignore", divide="ignore"):
        E[:, 0, 0], E[:, 0, 1] = dx / r, dy / r
    E[:, 1, 0], E[:, 1, 1] = -E[:, 0, 1], E[:, 0, 0]
    return E


def edge_coordinates(cuts: dict) -> dict:
    """Each cell's lower and upper edge along each axis, then its centres: ``cuts`` maps
    an axis name to (its edges, the cells' index along it, shape (n_cells,)); returns
    ``{name_lo, name_hi, ..., name, ...}``, arrays of shape (n_cells,)."""
    out = {}
    for name, (e, m) in cuts.items():
        out[f"{name}_lo"], out[f"{name}_hi"] = e[m], e[m + 1]
    for name, (e, m) in cuts.items():
        out[name] = 0.5 * (e[m] + e[m + 1])
    return out


def equal_edges(lo: float, hi: float, bins: int | None) -> np.ndarray:
    """Edges of ``bins`` (default :data:`DEFAULT_BINS`) equal cells from lo to hi."""
    return np.linspace(lo, hi, (DEFAULT_BINS if bins is None else bins) + 1)


def cuts(bins, edges, lo_hi, *, radial=False) -> np.ndarray:
    """Cell edges from the options: ``edges`` as given, else ``bins`` equal cells over
    ``lo_hi`` (checked: a count within 1..:data:`MAX_CELLS`; edges finite, increasing,
    and >= 0 for radii)."""
    if bins is not None and edges is not None:
        raise ParameterError("edges", "{param} and {bins} both set the cells across: give "
                             "one")
    if bins is not None and not 1 <= bins <= MAX_CELLS:
        raise ParameterError("bins", f"{{param}} {bins}: give between 1 and {MAX_CELLS} "
                             "cells")
    if edges is not None:
        shown = " ".join(f"{float(v):g}" for v in edges)
        if len(edges) < 2 or not all(np.isfinite(edges)):
            raise ParameterError("edges", f"{{param}} {shown}: give at least two finite "
                                 "edges")
        if any(b <= a for a, b in zip(edges, edges[1:])) or (radial and edges[0] < 0):
            raise ParameterError("edges", f"{{param}} {shown}: edges must be "
                                 + (">= 0 and " if radial else "") + "increasing")
        return np.asarray(edges, float)
    return equal_edges(*lo_hi, bins)


def counts(name, values, dim, what) -> tuple:
    """A grid's counts per axis: ``dim`` of them, each >= 1, their product at most
    :data:`MAX_CELLS`."""
    shown = " ".join(map(str, values))
    if len(values) != dim:
        raise ParameterError(name, f"{{param}} {shown}: give {what}")
    if min(values) < 1 or int(np.prod(values)) > MAX_CELLS:
        raise ParameterError(name, f"{{param}} {shown}: give between 1 and {MAX_CELLS} "
                             "cells")
    return tuple(int(v) for v in values)


def check_range(name, pair, nonnegative=False):
    """A (lo, hi) option: finite, lo < hi (and lo >= 0 for radii); None passes."""
    if pair is None:
        return None
    lo, hi = (float(v) for v in pair)
    if not (np.isfinite(lo) and np.isfinite(hi)):
        raise ParameterError(name, f"{{param}} {lo:g} {hi:g}: give finite numbers")
    if not lo < hi:
        raise ParameterError(name, f"{{param}} {lo:g} {hi:g}: the first must be below the "
                             "second")
    if nonnegative and lo < 0:
        raise ParameterError(name, f"{{param}} {lo:g} {hi:g}: radii are >= 0")
    return lo, hi


def positive(name, value):
    """A finite number > 0, or a one-line refusal naming the option."""
    if value is not None and not (np.isfinite(value) and value > 0):
        raise ParameterError(name, f"{{param}} {float(value):g}: must be a finite number > 0")
    return value


# -- periodic images ---------------------------------------------------------------------

@dataclass(frozen=True)
class Shear:
    """A sheared (tilted) periodic box at one frame: its tilt factors and their rates
    (Lees-Edwards boundaries: LAMMPS' ``fix deform xy erate ... remap v``).

    The lattice of images is spanned by the edge vectors a = (lx, 0, 0), b = (xy, ly, 0)
    and c = (xz, yz, lz): an image one step across the y faces lies at x + xy, y + ly
    and moves with v_x + d(xy)/dt; one across the z faces at x + xz, y + yz, z + lz,
    moving with v + (d(xz)/dt, d(yz)/dt, 0). The box's own lengths (the brick lx ly lz
    from its lower corner, which tiles space as its parallelepiped does, its rows sliding
    by the tilt) are the cells' periods.

    Attributes
    ----------
    tilt, rate : tuple of 3 float
        (xy, xz, yz) and their time derivatives.
    """

    tilt: tuple = (0.0, 0.0, 0.0)
    rate: tuple = (0.0, 0.0, 0.0)

    def column(self, k: int, which: str) -> dict:
        """The off-diagonal entries of edge vector k (0 a, 1 b, 2 c) of the ``tilt`` or
        its ``rate``, by axis: b {x: xy}, c {x: xz, y: yz}."""
        xy, xz, yz = getattr(self, which)
        return {0: {}, 1: {0: xy}, 2: {0: xz, 1: yz}}[k]

    @property
    def moving(self) -> bool:
        return any(r != 0.0 for r in self.rate)


@dataclass
class Images:
    """Particles and their periodic images within reach of the cells
    (:func:`with_images`).

    Attributes
    ----------
    pos : tuple of D ndarray, shape (E,)
        The entries' centres: the P particles first, then their images.
    a : ndarray, shape (E,)
        Their reach (radius, or a kernel's).
    index : ndarray, shape (E,)
        The particle each entry is of.
    row : ndarray, shape (E,)
        Each entry's row among the per-particle values: its particle's, or, for an image
        that moves with a velocity shift (a sheared box), a row after the P particles'
        that holds the particle's values at the shifted velocity (:meth:`extend`).
    moving : list of (ndarray (D,), ndarray (U,))
        Each velocity shift and the particles (sorted) whose images move with it, in the
        order of their rows.
    """

    pos: tuple
    a: np.ndarray
    index: np.ndarray
    row: np.ndarray
    moving: list

    def take(self, values):
        """Per-particle ``values`` (first axis P) with the moving images' rows after them
        (their particles' values: velocity-free quantities)."""
        if not self.moving:
            return values
        return np.concatenate([values, *(values[u] for _, u in self.moving)])

    def extend(self, q, atoms: dict, channels):
        """Per-particle channels ``q`` (P, C) of ``atoms`` with the moving images' rows
        after them: ``channels(atoms)`` -> (P, C), taken of the atoms moving with
        v + dv for each velocity shift dv."""
        if not self.moving:
            return q
        return np.concatenate([q, *(channels(_shifted(atoms, dv))[u]
                                    for dv, u in self.moving)])


def _shifted(atoms: dict, dv) -> dict:
    """The ``atoms`` (their columns ``vx vy [vz]``) moving with v + ``dv``."""
    out = dict(atoms)
    for axis, d in zip("xyz", dv):
        if d != 0.0 and f"v{axis}" in atoms:
            out[f"v{axis}"] = np.asarray(atoms[f"v{axis}"], float) + d
    return out


def with_images(pos, a, periods, shear: Shear | None = None) -> Images:
    """The particles and, along each axis with a period (the cells spanning a periodic
    box), the images of those that reach across its ends, so that their volume beyond
    one end lands in the cells at the other.

    In a sheared box (``shear`` with a tilt) an image across the y (z) faces is also
    moved along x (x, y) by the tilt and folded back into the periods there, the axes
    taken from the last; with a tilt rate it moves with the velocity shift of its steps
    (:class:`Shear`), and has its own row (:attr:`Images.row`).

    Parameters
    ----------
    pos : tuple of D ndarray, shape (P,)
    a : ndarray, shape (P,)
        How far each particle reaches.
    periods : tuple of D (lo, hi) or None
        The periodic span along each axis.
    shear : Shear, optional

    Returns
    -------
    Images
    """
    n = len(a)
    index = np.arange(n)
    pos = [np.asarray(u, float) for u in pos]
    a = np.asarray(a, float)
    D = len(pos)
    tilted = shear is not None and any(shear.tilt)
    steps = np.zeros((n, 3), np.int64)         # steps along the edge vectors a, b, c
    for k in (reversed(range(D)) if tilted else range(D)):
        span = periods[k] if k < len(periods) else None
        if span is None:
            continue
        lo, hi = span
        low, high = pos[k] - a < lo, pos[k] + a > hi
        if not (low.any() or high.any()):
            continue
        extra = np.concatenate([np.flatnonzero(low), np.flatnonzero(high)])
        step = np.concatenate([np.ones(low.sum(), np.int64), -np.ones(high.sum(), np.int64)])
        new = [u[extra] for u in pos]
        new[k] = new[k] + step * (hi - lo)
        new_steps = steps[extra].copy()
        new_steps[:, k] += step
        if tilted:
            _tilt_and_fold(new, new_steps, step, k, periods, shear)
        pos = [np.concatenate([u, v]) for u, v in zip(pos, new)]
        a = np.concatenate([a, a[extra]])
        index = np.concatenate([index, index[extra]])
        steps = np.concatenate([steps, new_steps])
    return _rows(tuple(pos), a, index, steps, n, shear, D)


def _tilt_and_fold(new, steps, step, k, periods, shear) -> None:
    """Move images one ``step`` across axis k's faces along the lower axes by the tilt,
    then fold them into the periods there (from the highest lower axis down: a step
    along an edge vector moves the axes below it)."""
    for j, t in shear.column(k, "tilt").items():
        new[j] = new[j] + step * t
    for j in reversed(range(k)):
        span = periods[j] if j < len(periods) else None
        if span is None:
            continue
        lo, hi = span
        m = np.floor((new[j] - lo) / (hi - lo)).astype(np.int64)
        if not m.any():
            continue
        new[j] = new[j] - m * (hi - lo)
        for i, t in shear.column(j, "tilt").items():
            new[i] = new[i] - m * t
        steps[:, j] -= m


def _rows(pos, a, index, steps, n, shear, D) -> Images:
    """:class:`Images` with the rows of the images that move (a tilt rate)."""
    if shear is None or not shear.moving or len(index) == n:
        return Images(pos, a, index, index, [])
    dv = np.zeros((len(index), D))
    for k in (1, 2):
        for j, r in shear.column(k, "rate").items():
            if j < D:
                dv[:, j] += steps[:, k] * r
    row = index.copy()
    moving = []
    shifts, group = np.unique(dv[n:], axis=0, return_inverse=True)
    base = n
    for g, s in enumerate(shifts):
        if not np.any(s):
            continue
        mine = n + np.flatnonzero(group.ravel() == g)
        u = np.unique(index[mine])
        row[mine] = base + np.searchsorted(u, index[mine])
        moving.append((s, u))
        base += len(u)
    return Images(pos, a, index, row, moving)


class Imaged:
    """Cells that may span a periodic box: ``periods``, per axis, the span over which the
    packing is periodic (the cells then take the particles' images across its ends,
    :func:`with_images`), or None."""

    def images(self, pos, a, shear: Shear | None = None) -> Images | None:
        """The particles' images within reach ``a`` of the cells, or None without
        periods."""
        periods = getattr(self, "periods", None)
        if not periods or all(p is None for p in periods):
            return None
        return with_images(pos, a, periods, shear)

    def _imaged(self, weigh, pos, a, images=None):
        """``weigh`` of the particles and their images (``images``, else those of an
        unsheared box): rows as :attr:`Images.row`."""
        if images is None:
            images = self.images(pos, a)
        if images is None:
            return weigh(pos, a)
        particle, cell, w = weigh(images.pos, images.a)
        return images.row[particle], cell, w

    def wraps(self, axis: str) -> bool:
        """Whether the cells span the periodic box along ``axis`` (x, y or z), end to
        end: their first cell then neighbours their last across its faces."""
        periods = getattr(self, "periods", None)
        k = "xyz".index(axis)
        if not (periods and k < len(periods) and periods[k] is not None):
            return False
        names, _, edges = self.grid()
        if axis not in names:
            return False
        e = edges[names.index(axis)]
        lo, hi = periods[k]
        slack = PERIOD_SLACK * (hi - lo)
        return abs(e[0] - lo) <= slack and abs(e[-1] - hi) <= slack


def spans_of(periods):
    """The periods for the sidecar (lists, None where not periodic)."""
    return None if periods is None else [None if p is None else list(p) for p in periods]


def periods_of(periods):
    """Periods as tuples of floats (None where not periodic), or None."""
    return None if periods is None else tuple(None if p is None else
                                              tuple(float(v) for v in p) for p in periods)


def without_suffix(d: dict) -> dict:
    """A description's keys without the ``_m`` suffix of older sidecars."""
    return {k[:-2] if k.endswith("_m") else k: v for k, v in d.items()}


# -- finite volumes (the balance of forces) ---------------------------------------------

def faces(T, closed, periodic=False):
    """Face values between neighbouring cells, (T_k + T_k+1) / 2, with the outer faces
    0 where ``closed`` (nothing of the packing beyond: a wall, whose action is the
    boundary force density, or empty space), the mean of the two end cells where
    ``periodic``, and NaN otherwise; shape (n + 1,)."""
    if periodic:
        wrap = 0.5 * (T[0] + T[-1])
        return np.concatenate([[wrap], 0.5 * (T[1:] + T[:-1]), [wrap]])
    outer = 0.0 if closed else np.nan
    return np.concatenate([[outer], 0.5 * (T[1:] + T[:-1]), [outer]])


def radial_flux(T, edges, closed, power):
    """(1/r^power) d(r^power T)/dr by the faces' fluxes, for cells in rings: ``T`` of
    shape (n_r, m), ``edges`` the n_r + 1 radii; the outer faces as :func:`faces`."""
    r = (0.5 * (edges[1:] + edges[:-1]))[:, None]
    dr = np.diff(edges)[:, None]
    values = np.apply_along_axis(faces, 0, T, closed)
    return np.diff(edges[:, None] ** power * values, axis=0) / dr / r ** power


def divergence(T, widths, closed, periodic):
    """d T / d u along axis 0 of an array of cells in finite-volume form: the difference
    of the face values over the cell width (:func:`faces` at the ends)."""
    values = np.apply_along_axis(faces, 0, T, closed, periodic)
    shape = (-1,) + (1,) * (T.ndim - 1)
    return np.diff(values, axis=0) / widths.reshape(shape)
