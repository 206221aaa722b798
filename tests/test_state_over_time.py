"""The state-over-time table (workflows/state_over_time.py): window means per run, then
over runs, with between-run errors; and its one-line refusal of a series without contacts."""

import subprocess
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

WORKFLOWS = Path(__file__).resolve().parents[1] / "workflows"
sys.path.insert(0, str(WORKFLOWS))
import state_over_time  # noqa: E402

COLS = list(state_over_time.COLUMNS)


def series(level_of_run, t=np.arange(0.0, 20.0, 0.5)):
    """Runs whose every column is their level plus 0.01 t (so a window's mean is known)."""
    return pd.concat([pd.DataFrame({"t_s": t, "run": name, **{c: level + 0.01 * t for c in COLS}})
                      for name, level in level_of_run.items()], ignore_index=True)


def test_rows_are_means_over_runs_of_window_means_with_between_run_errors():
    table = state_over_time.over_time(series({"a": 1.0, "b": 2.0, "c": 4.0}), [0, 10], 5.0)
    # window [0, 5): frames 0 ... 4.5, mean t = 2.25
    assert table.loc[0, "P_bulk_Pa"] == pytest.approx(7 / 3 + 0.0225)
    assert table.loc[1, "C_bulk"] == pytest.approx(7 / 3 + 0.1225)
    assert table.loc[0, "P_bulk_Pa_err"] == pytest.approx(np.std([1, 2, 4], ddof=1) / np.sqrt(3))
    assert list(table.runs) == [3, 3]
    two = state_over_time.over_time(series({"a": 1.0, "b": 2.0}), [0], 5.0)
    assert np.isnan(two.loc[0, "P_bulk_Pa_err"])          # no error from 2 runs
    assert "| 0 | " in state_over_time.markdown(table)


def test_a_series_without_contact_columns_is_refused_in_one_line(tmp_path):
    path = tmp_path / "s.csv"
    series({"a": 1.0}).drop(columns=["P_bulk_Pa"]).to_csv(path, index=False)
    proc = subprocess.run([sys.executable, str(WORKFLOWS / "state_over_time.py"), str(path)],
                          capture_output=True, text=True)
    assert proc.returncode == 2 and "no column P_bulk_Pa" in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
