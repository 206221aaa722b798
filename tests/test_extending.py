"""docs/extending.md's recipe is a test: its blocks, run in order, register a quantity, a
kernel and a geometry of our own, and average with them on the shipped example run;
the unit follows from the quantity's declared dimension in any unit system, and a
plug-in that breaks its registry's contract is refused with the reason."""

import math
import re
from pathlib import Path

import numpy as np
import pytest

from granavg.engine import cells, quantities, smoothing, timing
from granavg.engine.smoothing.base import Kernel
from granavg.engine.unit_system import UnitSystem
from granavg.io import formats

PAGE = Path(__file__).resolve().parent.parent / "docs" / "extending.md"


@pytest.fixture
def recipe():
    """The page's blocks run in one namespace; what they registered removed after."""
    namespace = {}
    try:
        for k, code in enumerate(re.findall(r"```python\n(.*?)```", PAGE.read_text(), re.S)):
            exec(compile(code, f"docs/extending.md, block {k + 1}", "exec"), namespace)
        yield namespace
    finally:
        quantities.unregister("momentum_density")
        smoothing.KERNELS.unregister("biweight")
        timing.TIME_KERNELS.unregister("triweight")
        cells.CELLS.unregister("cubes")
        formats.FORMATS.unregister("csv-scaled")


def test_the_recipe_averages_with_a_quantity_a_kernel_and_a_geometry_of_its_own(recipe):
    fields = recipe["fields"]
    assert fields.cells.kind == "cubes" and fields.cells.n == 64
    assert fields.meta["geometry"]["kind"] == "cubes" and fields.cells.kernel.name == \
        "biweight"
    assert fields.units["momentum_density_x"] == "kg/(m^2 s)"
    rho_v = fields.values["rho"] * fields.values["v_x"]
    assert np.nanmax(np.abs(fields.values["momentum_density_x"] - rho_v)) <= \
        1e-12 * np.nanmax(np.abs(rho_v))
    assert "cubes" in cells.registry() and "biweight" in smoothing.registry()
    assert "biweight" in smoothing.catalogue()
    assert cells.option_specs()["cubes"].help.startswith("N x N x N cubes")


def test_a_unit_follows_from_its_dimension_in_any_system(recipe):
    q = quantities.QUANTITIES["momentum_density"]
    lj = UnitSystem("lj", "sigma", "tau", "mass", "epsilon/sigma", "epsilon/sigma^3")
    assert lj.unit(q.unit) == "mass/(sigma^2 tau)"


def test_a_plug_in_that_breaks_its_contract_is_refused():
    cone = Kernel("cone", 1.0, ((0.0, (1.0, -1.0)),),
                  {1: 1.0, 2: 3.0 / math.pi, 3: 3.0 / math.pi}, True, 1, help="a cone",
                  width_is="the support radius")
    with pytest.raises(ValueError, match="flat at q = 0"):
        smoothing.register(cone)
    wrong = Kernel("flat", 1.0, ((0.0, (1.0,)),), {1: 1.0, 2: 1.0, 3: 1.0}, False, 0,
                   help="a top hat with wrong norms", width_is="the support radius")
    with pytest.raises(ValueError, match="integrate to"):
        smoothing.register(wrong)
    with pytest.raises(ValueError, match="not a channel block"):
        quantities.register(quantities.Quantity("x", ("nope",), "scalar", None, unit="1",
                                                help="x"))
    with pytest.raises(ValueError, match="named units"):
        quantities.register(quantities.Quantity("y", ("vol",), "scalar", None,
                                                unit="{furlong}", help="y"))
    assert "cone" not in smoothing.registry() and "x" not in quantities.QUANTITIES


def test_the_recipe_s_format_and_time_kernel_are_used(recipe):
    """The format's option reached it: two disks of radius 5 mm in slabs 50 mm x 10 mm
    (their extent in y) give nu = pi 25 / 500 each, only with the lengths in mm; the
    time kernel gave fields in time."""
    in_mm = recipe["in_mm"]
    assert np.allclose(in_mm.values["nu"], math.pi * 25.0 / 500.0, rtol=1e-12)
    assert in_mm.meta["inputs"]["length_unit"] == 1e-3
    assert recipe["in_time"].dims == ("time", "z")
    assert recipe["in_time"].meta["time"]["kernel"] == "triweight"
