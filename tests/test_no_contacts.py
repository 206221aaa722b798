"""A run whose dumped frames hold no contacts (a dilute start: the disks grown to a few
per cent of the annulus) is a run with frames without contacts, in every path: LAMMPS
in-process with in-situ averages, under ``mpirun`` (its raw contact dump converted),
and the dumps read back. Its averages are held to the contact rows summed here."""

import gzip

import numpy as np
import pytest

from granavg.io.profiles_io import read_profiles
from granavg.pipeline.runs import average_run

from .conftest import run_cli

#: The new user's command (issue 51): 230 disks in the paper's annulus, few contacts.
DILUTE = ["packing=", "n_small=200", "n_large=30", "t_grow=0.05", "t_relax=0.05",
          "t_end=0.05", "t_dump_start=0", "dump_dt=0.01"]


def dump_frames(path):
    """(column names, rows) of every frame of a gzip dump, read here."""
    text = gzip.open(path, "rt").read()
    out = []
    for block in text.split("ITEM: TIMESTEP\n")[1:]:
        lines = block.splitlines()
        k = next(i for i, ln in enumerate(lines) if ln.startswith(("ITEM: ATOMS",
                                                                    "ITEM: ENTRIES")))
        cols = lines[k].split()[2:]
        end = next((i for i in range(k + 1, len(lines)) if lines[i].startswith("ITEM:")),
                   len(lines))
        rows = [ln.split() for ln in lines[k + 1:end] if ln.strip()]
        out.append((cols, np.array(rows, float).reshape(len(rows), len(cols))))
    return out


def contact_virial(run):
    """sum_c f . l over each frame's contacts (l to the contact point, a pair's l_1 - l_2
    its centre distance), per frame: what sum_k V_k tr sigma_k holds."""
    atoms, contacts = (dump_frames(run / f"{n}.dump.gz") for n in ("atoms", "contacts"))
    out = []
    for (acols, arows), (ccols, crows) in zip(atoms, contacts):
        radius = dict(zip(arows[:, acols.index("id")].astype(int),
                          arows[:, acols.index("radius")]))
        c = {name: crows[:, k] for k, name in enumerate(ccols)}
        f_n = (c["fnx"] + c["ftx"]) * c["nx"] + (c["fny"] + c["fty"]) * c["ny"]
        a1 = np.array([radius[int(i)] for i in c["id1"]])
        a2 = np.array([radius.get(int(i), 0.0) for i in c["id2"]])
        pair = c["wall"] == 0
        reach = np.where(pair, a1 + a2 - c["overlap"], a1 - 0.5 * c["overlap"])
        out.append(float(np.sum(f_n * reach)))
    return np.array(out), [len(rows) for _, rows in contacts]


@pytest.fixture(scope="module")
def dilute(tmp_path_factory):
    """The command in-process with in-situ averages over 4 rings, and under mpirun."""
    runs = {}
    for name, extra in (("serial", ["--average", "4", "--t-min", "0"]), ("mpi", ["--np", "2"])):
        runs[name] = tmp_path_factory.mktemp(name) / "run"
        sets = [a for s in DILUTE for a in ("--set", s)]
        proc = run_cli("simulate", "--preset", "demo", "--out", runs[name], *sets,
                       "--no-progress", *extra)
        assert proc.returncode == 0, proc.stderr
        assert "Traceback" not in proc.stderr
    return runs


@pytest.mark.parametrize("name", ["serial", "mpi"])
def test_frames_without_contacts_average_as_frames_without_contacts(dilute, name):
    """Frames with no contact rows are read and averaged (a frame's static stress 0):
    the summed stress over rings covering the annulus is the frames' mean contact virial
    summed here, to the dumps' 12 digits; the frame count is the dumps'."""
    run = dilute[name]
    virial, rows = contact_virial(run)
    assert 0 in rows and max(rows) > 0                      # frames with and without
    p = average_run(run, bins=4, t_min=0.0, progress=False)
    assert p.n_frames == len(rows)
    ours = np.sum(p.cells.volume * (p.values["sigma_rr"] + p.values["sigma_phiphi"]))
    assert ours == pytest.approx(np.mean(virial), rel=1e-9, abs=1e-20)
    assert np.all(p.values["sigma_rr"][np.all(p.values["coordination"] == 0)] == 0)


def test_in_situ_frames_without_contacts_equal_their_dumps(dilute):
    insitu = read_profiles(dilute["serial"] / "profiles_4.csv")
    dumps = average_run(dilute["serial"], bins=4, t_min=0.0, progress=False)
    assert insitu.n_frames == dumps.n_frames
    # the paper's fields (sums that cancel, such as the net couples, are round-off here)
    for q in ("nu", "rho", "v_r", "v_phi", "omega", "coordination", "F_rr", "F_rphi",
              "sigma_rr", "sigma_rphi", "sigma_phir", "dsigma_rr", "eps_rr"):
        v = dumps.values[q]
        scale = np.nanmax(np.abs(v)) + 1e-300
        # the dumps hold 12 significant digits; in situ has LAMMPS' doubles
        assert np.nanmax(np.abs(insitu.values[q] - v)) < 1e-8 * scale, q
