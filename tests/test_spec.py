"""One spec for an average (granavg.pipeline.spec): built once from the options, validated
as it is made, written whole into the sidecar, and ``granavg average --spec FILE``
remakes an output bit for bit; no averaging option travels as a loose parameter."""

import ast
import os
import json
from collections import defaultdict
from pathlib import Path

import pytest

import granavg
from granavg.cells import Rings
from granavg.engine.spec import Averaging, TimeAxis
from granavg.errors import ParameterError, UserError
from granavg.examples import pile_3d
from granavg.pipeline.spec import Execution, Spec

from .conftest import run_cli

ROOT = Path(__file__).resolve().parent.parent
E = "granavg/examples/data"
MAP3 = ",".join(f"{k}={v}" for k, v in pile_3d.contact_map.items())
#: Commands whose outputs --spec remakes: anyone's dumps with gravity and a format's
#: option (slabs), a run directory resolved in time (rings, windows), a smoothing kernel
#: on a polar grid.
CASES = {
    "slabs": ["--atoms", f"{E}/pile_3d/atoms.dump.gz", "--contacts",
              f"{E}/pile_3d/contacts.dump.gz", "--contact-columns", MAP3, "--slabs", "z",
              "--range", 0, 0.024, "--bins", 6, "--gravity", 0, 0, -9.81,
              "--quantities", "nu,sigma,v"],
    "windows": [f"{E}/couette_2d", "--bins", 5, "--t-min", 1, "--windows", 0.5,
                "--sectors", "off"],
    "kernel": [f"{E}/couette_2d", "--polar-grid", 3, 4, "--t-min", 1, "--kernel", "lucy",
               "--width", 0.008, "--branch", "paper", "--quantities", "nu,sigma,v"],
}


def specs():
    """Specs of every part's kinds of values."""
    return [
        Spec.of("run_a", bins=8, t_min=1.5, block_time=0.25, quantities=["nu", "v"]),
        Spec.of("atoms.dump", contacts="contacts.dump", contact_map={"fnx": "c_f[1]"},
                gravity=(0, 0, -9.81), density=2500.0, cells={"grid": (4, 4, 6)},
                kernel="lucy", width=0.002, time_kernel="gauss", time_width=0.1,
                times=(0.4, 0.8, 0.1), t_min=0.0, branch="paper", sectors=None,
                species="small=1 large=2", workers=2),
        Spec.of(cells=Rings.count(5, 0.1, 0.25, 0.006), window_frames=4, sectors=8),
    ]


@pytest.mark.parametrize("k", range(3))
def test_a_spec_round_trips_through_its_json(k):
    spec = specs()[k]
    again = Spec.from_dict(json.loads(json.dumps(spec.to_dict())))
    assert again.to_dict() == spec.to_dict()
    if k < 2:                                    # (cells given whole compare as described)
        assert again == spec


def test_options_are_sorted_into_their_parts_and_unknown_ones_refused():
    spec = Spec.of("atoms.dump", bins=8, t_min=1.0, dt=0.001, workers=3, branch="paper")
    assert spec.cells == {"bins": 8}
    assert spec.source.options == {"dt": 0.001} and spec.source.atoms == "atoms.dump"
    assert spec.averaging == Averaging.of(t_min=1.0, branch="paper")
    assert spec.execution == Execution(workers=3)
    with pytest.raises(ParameterError, match="not an option"):
        Spec.of("atoms.dump", bogus=1)


@pytest.mark.parametrize("options, param", [
    (dict(t_min=float("nan")), "t_min"), (dict(block_time=0.0), "block_time"),
    (dict(branch="middle"), "branch"), (dict(sectors=3), "sectors"),
    (dict(workers=0), "workers"), (dict(density=-1.0), "density"), (dict(dt=0.0), "dt"),
    (dict(width=-2.0), "width"), (dict(windows=1.0, time_kernel="gauss"), "windows"),
    (dict(times=(1, 0, 1), time_kernel="gauss", time_width=0.1), "times"),
    (dict(t_min=2.0, t_max=1.0), "t_max")])
def test_a_spec_is_validated_when_it_is_made(options, param):
    with pytest.raises(ParameterError) as refused:
        Spec.of("atoms.dump", **options)
    assert refused.value.param == param


@pytest.mark.parametrize("case", list(CASES))
def test_spec_remakes_the_output_bit_for_bit(case, tmp_path):
    first, again = tmp_path / "first.csv", tmp_path / "again.csv"
    made = run_cli("average", *CASES[case], "--out", first, "--no-progress", cwd=ROOT)
    assert made.returncode == 0, made.stderr
    remade = run_cli("average", "--spec", f"{first}.json", "--out", again, "--no-progress",
                     cwd=ROOT)
    assert remade.returncode == 0, remade.stderr
    written = sorted(p.name[len("first"):] for p in tmp_path.glob("first.csv*"))
    assert written == sorted(p.name[len("again"):] for p in tmp_path.glob("again.csv*"))
    for suffix in written:
        assert (tmp_path / f"first{suffix}").read_bytes() == \
            (tmp_path / f"again{suffix}").read_bytes(), suffix
    spec = json.loads(Path(f"{first}.json").read_text())["spec"]
    assert Spec.from_dict(spec).to_dict() == spec       # the sidecar holds the spec whole


def test_spec_remakes_the_same_fields_on_dask(tmp_path):
    """The execution is not the fields': --workers on a spec gives the same table."""
    pytest.importorskip("distributed")
    first, again = tmp_path / "first.csv", tmp_path / "again.csv"
    assert run_cli("average", *CASES["windows"], "--out", first, "--no-progress",
                   cwd=ROOT).returncode == 0
    remade = run_cli("average", "--spec", f"{first}.json", "--out", again, "--workers", 2,
                     "--no-progress", cwd=ROOT, env={**os.environ, "GRANAVG_COST_MODEL": "off"})
    assert remade.returncode == 0, remade.stderr
    assert first.read_bytes() == again.read_bytes()


@pytest.mark.parametrize("extra, flag", [(["--bins", 5], "--bins"),
                                         (["--t-min", 2], "--t-min"),
                                         (["--t-min", 0], "--t-min"),
                                         (["--sectors", "off"], "--sectors"),
                                         (["--branch", "paper"], "--branch"),
                                         ([f"{E}/couette_2d"], "the run directory")])
def test_spec_beside_another_option_of_the_average_is_refused(extra, flag, tmp_path):
    first = tmp_path / "first.csv"
    assert run_cli("average", *CASES["windows"], "--out", first, "--no-progress",
                   cwd=ROOT).returncode == 0
    proc = run_cli("average", "--spec", f"{first}.json", *extra, "--out", tmp_path / "b.csv",
                   cwd=ROOT)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and flag in lines[0] and "--spec" in lines[0], proc.stderr


@pytest.mark.parametrize("text, said", [
    (None, "no such file"), ("{not json", "not JSON"),
    ('{"spec": {"version": 99}}', "not a granavg spec"),
    ('{"spec": {"version": 1, "time": {"t_min": "soon"}}}', "damaged spec")])
def test_a_missing_or_damaged_spec_is_refused_in_one_line(text, said, tmp_path):
    path = tmp_path / "s.json"
    if text is not None:
        path.write_text(text)
    proc = run_cli("average", "--spec", path, "--out", tmp_path / "o.csv")
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1 and said in lines[0] and str(path) in lines[0], proc.stderr


def test_an_empty_selection_of_frames_is_refused_in_one_line():
    frames = granavg.open(pile_3d.atoms, contacts=pile_3d.contacts,
                          contact_map=pile_3d.contact_map)
    with pytest.raises(UserError, match="no frame to average"):
        granavg.average(frames.between(1e6, 2e6), cells={"slabs": "z", "bins": 4})


def test_the_data_s_own_times_are_no_options():
    """The frames' spacing and the first window's start are resolved from the data (a
    client for its workers), never given."""
    for name in ("interval", "window_start"):
        with pytest.raises(ParameterError, match="not an option of granavg.average"):
            Spec.of("atoms.dump", **{name: 1.0})


def test_frames_in_this_process_are_named_in_the_spec_and_not_remade(tmp_path):
    frames = granavg.open(pile_3d.atoms, contacts=pile_3d.contacts,
                          contact_map=pile_3d.contact_map)
    fields = granavg.average(frames[::5], cells={"slabs": "z", "range": (0, 0.024),
                                                  "bins": 4}, quantities=["nu"])
    spec = fields.meta["spec"]
    assert spec["source"]["frames"] == "a selection of granavg.open's frames"
    assert spec["cells"] == {"slabs": "z", "range": [0, 0.024], "bins": 4}
    with pytest.raises(UserError, match="a spec cannot hold"):
        Spec.from_dict(json.loads(json.dumps(spec)))


#: Every option of an average, as the spec's parts name them.
OPTIONS = ("branch", "t_min", "t_max", "block_time", "windows", "window_frames",
           "time_kernel", "time_width", "sectors", "workers", "scheduler", "density",
           "gravity", "check_cells", "kernel", "width")
#: Parameters of these names that are not the option: a kernel object given to its
#: registry or held by its nodes, a kernel's own width in its formulas, argparse's and
#: the prefetch queue's widths.
OTHER_MEANING = {
    ("kernel", "register"), ("kernel", "_half"), ("kernel", "__init__"),
    ("width", "cutoff"), ("width", "value"), ("width", "weights"), ("width", "__init__"),
    ("width", "_split_lines"), ("width", "in_order")}


def test_no_averaging_option_is_a_parameter_of_more_than_three_functions():
    """The options travel in the spec: each is a parameter of its builders alone
    (``granavg.average``, ``Spec.of`` or ``Averaging.of``, and the one function that
    turns it into an object: ``smooth``)."""
    where = defaultdict(list)
    for path in (ROOT / "granavg").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
                a = node.args
                for arg in a.posonlyargs + a.args + a.kwonlyargs:
                    if arg.arg in OPTIONS and (arg.arg, node.name) not in OTHER_MEANING:
                        where[arg.arg].append(f"{path.relative_to(ROOT)}:{node.name}")
    crowded = {k: v for k, v in where.items() if len(v) > 3}
    assert not crowded, crowded
    assert where["t_min"] == ["granavg/pipeline/api.py:average"]


def test_the_time_axis_is_resolved_not_mutated():
    time = TimeAxis(t_min=1.0)
    averaging = Averaging(time=time)
    resolved = averaging.with_time(block_time=0.5, interval=0.1)
    assert averaging.time.block_time is None and resolved.time.block_time == 0.5
    with pytest.raises(Exception):
        time.t_min = 2.0                              # frozen


def test_the_reports_profiles_hold_their_run_and_remake(tmp_path):
    """The demo's and the report's profiles (made from a spec without a source) name
    their run in the sidecar, and --spec remakes them."""
    from granavg.pipeline.reporting import report_run

    run = ROOT / E / "couette_2d"
    report_run(run, tmp_path / "report", Spec.of(t_min=1.0), bins=(8, 12))
    first = tmp_path / "report" / "profiles8.csv"
    spec = json.loads(Path(f"{first}.json").read_text())["spec"]
    assert spec["source"]["runs"] == [str(run)] and spec["cells"] == {"bins": 8}
    again = tmp_path / "again.csv"
    proc = run_cli("average", "--spec", f"{first}.json", "--out", again, "--no-progress")
    assert proc.returncode == 0, proc.stderr
    assert first.read_bytes() == again.read_bytes()
