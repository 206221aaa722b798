"""Profile tables on disk: the CSV (or Parquet) table, its JSON sidecar, the replicates
and the per-frame time series, written together and read back with checks (SI units;
docs/profiles.md)."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np

from granavg.engine.fields import Fields, columns_of
from granavg.engine.cells import restore_sidecar
from granavg.engine.uncertainty.blocking import Replicates
from granavg.errors import ParameterError, UserError
from granavg.io.output_set import OutputSet

#: Suffix of the replicate profiles written beside a profiles table.
REPLICATES = ".replicates.npz"
#: Suffix of the per-frame time series written beside a profiles table.
TIMESERIES = ".timeseries.csv"


def read_profiles(path) -> Fields:
    """Fields written by :func:`write_profiles` (CSV or Parquet, with its JSON sidecar),
    checked: a damaged table or sidecar is a one-line error naming the file."""
    import pandas as pd

    path = Path(path)
    side = path.with_name(path.name + ".json")
    for f in (path, side):
        if not f.exists():
            raise UserError(f"{f}: not found; write profiles with 'granavg average' (the "
                            "table and its .json sidecar)")
        if not f.is_file():
            raise UserError(f"{f}: is a directory; give a profiles table")
    try:
        table = pd.read_parquet(path) if path.suffix == ".parquet" else pd.read_csv(path)
    except (pd.errors.EmptyDataError, pd.errors.ParserError, UnicodeDecodeError,
            ValueError, OSError) as exc:
        raise UserError(f"{path}: not a readable profiles table ({str(exc).splitlines()[0]})"
                        "; average again with 'granavg average'") from None
    try:
        meta = json.loads(side.read_text())
    except json.JSONDecodeError as exc:
        raise UserError(f"{side}:{exc.lineno}: damaged JSON ({exc.msg}); average again "
                        "with 'granavg average'") from None
    except UnicodeDecodeError:
        raise UserError(f"{side}: not a text file; average again with 'granavg "
                        "average'") from None
    try:
        rings = restore_sidecar(meta)
    except (KeyError, TypeError, ValueError, AttributeError):
        raise UserError(f"{side}: no ring geometry (rings.edges_m, rings.h_m); average "
                        "again with 'granavg average'") from None
    reps = path.with_name(path.name + REPLICATES)
    archive = None
    if reps.exists():
        try:
            with np.load(reps) as z:
                archive = {k: z[k] for k in z.files}
        except (OSError, ValueError, KeyError) as exc:
            raise UserError(f"{reps}: damaged replicates ({exc}); average again") from None
    series = path.with_name(path.name + TIMESERIES)
    series = columns_of(pd.read_csv(series)) if series.exists() else None
    if "species" not in table.columns:
        return _from_table(table, path, rings, meta, archive, "", series)
    names = list(dict.fromkeys(table["species"].astype(str)))
    parts = {name: _from_table(table[table["species"].astype(str) == name], path, rings,
                               meta, archive, f"s{k}/", series)
             for k, name in enumerate(names)}
    return Fields.of_species(parts, meta)


def _from_table(table, path, rings, meta, archive, prefix, series) -> Fields:
    """The fields of one table (of one species: its rows), checked; replicates under
    ``prefix`` of the archive."""
    import pandas as pd

    table = table.reset_index(drop=True)
    in_time = "t" in table.columns
    missing = [c for c in (*rings.coordinates(), "n_frames", "flags") if c not in table.columns]
    n_times = len(table) // rings.n if in_time else 1
    if missing or len(table) != rings.n * n_times or (in_time and not n_times):
        what = f"column {missing[0]} is missing" if missing else \
            f"{len(table)} rows for {rings.n} cells" + (" at each time" if in_time else "")
        raise UserError(f"{path}: {what} (the table is cut or not granavg's); average "
                        "again with 'granavg average'")
    names = [c for c in table.columns if f"{c}_sem" in table.columns]
    bad = [n for n in names if not pd.api.types.is_numeric_dtype(table[n])]
    if bad:
        raise UserError(f"{path}: column {bad[0]} holds non-numbers; the table is damaged")
    replicates = None
    if archive is not None:
        try:
            replicates = _time_replicates(archive, prefix) \
                if f"{prefix}time_kinds" in archive else _replicates(archive, prefix)
        except (ValueError, KeyError) as exc:
            raise UserError(f"{path.name}{REPLICATES}: damaged replicates ({exc}); average "
                            "again") from None
    shape = (n_times, rings.n) if in_time else (rings.n,)
    flags = np.array([f if isinstance(f, str) else "" for f in table["flags"]], dtype=object)
    n_frames = table["n_frames"].to_numpy()
    times = edges = None
    if in_time:
        t = table["t"].to_numpy().reshape(shape)
        if not np.all(t == t[:, :1]):
            raise UserError(f"{path}: the rows of one time are not together (column t); "
                            "the table is damaged")
        times, n_frames = t[:, 0], n_frames.reshape(shape)[:, 0]
        if "t_lo" in table.columns and "t_hi" in table.columns:
            edges = np.r_[table["t_lo"].to_numpy()[::rings.n], table["t_hi"].to_numpy()[-1]]
    return Fields(rings, {n: table[n].to_numpy().reshape(shape) for n in names},
                  {n: table[f"{n}_sem"].to_numpy().reshape(shape) for n in names},
                  flags.reshape(shape), n_frames if in_time else int(n_frames[0]), meta,
                  replicates,
                  table["n_runs"].to_numpy().reshape(shape) if "n_runs" in table.columns
                  else None, series, times, edges)


def _replicates(z, prefix: str):
    """The replicates stored under ``prefix`` in an npz archive (a mapping of its
    entries; None where none)."""
    kind = f"{prefix}kind"
    if kind not in z:
        return None
    parts = json.loads(str(z[f"{prefix}parts"])) if f"{prefix}parts" in z else None
    values = {k[len(prefix):]: z[k] for k in z if k.startswith(prefix)
              and k not in (kind, f"{prefix}parts")}
    values = {k: v for k, v in values.items() if "/" not in k}
    return Replicates(str(z[kind]), values, parts)


def _time_replicates(z, prefix: str = "") -> list:
    """Fields in time: one set of replicates per time (``<prefix>t<j>/``)."""
    n = len(json.loads(str(z[f"{prefix}time_kinds"])))
    return [_replicates(z, f"{prefix}t{j}/") for j in range(n)]


def write_profiles(profiles: Fields, path, parquet: bool = False) -> Path:
    """Write the table (CSV, or Parquet), a JSON sidecar ``<path>.json`` (with the unit
    of every column, ``columns``), the replicates ``<path>.replicates.npz`` and the time
    series ``<path>.timeseries.csv``, as one :class:`~granavg.io.output_set.OutputSet`:
    all appear, or none does."""
    with OutputSet(path) as outputs:
        write_profile_files(profiles, outputs, parquet)
        outputs.commit()
    return Path(path)


def write_profile_files(profiles: Fields, outputs: OutputSet, parquet: bool = False):
    """The files of :func:`write_profiles` into the temporary names of ``outputs`` (the
    caller commits them, with its other outputs)."""
    table = profiles.to_columns()
    profiles.meta["columns"] = profiles.units
    if parquet:
        try:
            import pyarrow  # noqa: F401  (pandas' Parquet engine)
        except ImportError:
            raise ParameterError("parquet", "{param} needs pyarrow: pip install "
                                 "'granavg[parquet]'") from None
        profiles.to_pandas().to_parquet(outputs.temp(""), index=False)
    else:
        write_csv(outputs.temp(""), table, "%.10g")
    outputs.temp(".json").write_text(json.dumps(profiles.meta, indent=2) + "\n")
    if profiles.replicates is not None:
        with open(outputs.temp(REPLICATES), "wb") as fh:
            reps = profiles.replicates
            if profiles.species is not None:    # a mixture: one set (or list) per species
                stored = {"species_names": json.dumps(list(profiles.species))}
                for k, r in enumerate(reps):
                    stored.update(_any_stored(r, f"s{k}/"))
                np.savez(fh, **stored)
            else:
                np.savez(fh, **_any_stored(reps, ""))
    if profiles.series is not None:
        write_csv(outputs.temp(TIMESERIES), profiles.series, "%.8g")


def _any_stored(reps, prefix: str) -> dict:
    """One set of replicates, or fields in time' list of one set per time (``t<j>/``),
    as npz entries under ``prefix``."""
    if reps is None:
        return {}
    if not isinstance(reps, list):
        return _stored(reps, prefix)
    stored = {f"{prefix}time_kinds": json.dumps([r.kind if r else None for r in reps])}
    for j, r in enumerate(reps):
        if r is not None:
            stored.update(_stored(r, f"{prefix}t{j}/"))
    return stored


def _stored(reps: Replicates, prefix: str) -> dict:
    """One set of replicates as npz entries under ``prefix``."""
    parts = {f"{prefix}parts": json.dumps(reps.parts)} if reps.parts else {}
    return {f"{prefix}kind": reps.kind, **parts,
            **{f"{prefix}{k}": v for k, v in reps.values.items()}}


def write_csv(path, columns: dict, float_format: str) -> None:
    """Columns (name -> 1-D array, equal lengths) as a CSV table with a header, as pandas
    writes one: floats with ``float_format``, NaN and None as empty fields, integers and
    strings as they are (quoted where the format needs it)."""
    text = []
    for v in columns.values():
        v = np.asarray(v)
        if v.dtype.kind == "f":
            text.append(["" if x != x else float_format % x for x in v.tolist()])
        else:
            text.append(["" if x is None or (isinstance(x, float) and x != x) else str(x)
                         for x in v.tolist()])
    with open(path, "w", newline="") as fh:
        out = csv.writer(fh, lineterminator="\n")
        out.writerow(columns)
        out.writerows(zip(*text))
