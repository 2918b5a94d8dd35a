"""The extremes matrix's fast subset (``python -m benchmarks extremes matrix``): plain indentation scenes on
the plane-strain wheel end as documented with default settings - at s/d = 0.1, or
``exceeds_capacity`` for a load above the capacity - within a wall-time guard."""
from __future__ import annotations

import json
import pathlib
import sys

import pytest

from rollsim.solver.regularisation import FALLBACK_BIAS

sys.path.insert(0, str(pathlib.Path(__file__).parents[1] / "benchmarks"))
import bench_extremes  # noqa: E402

GUARD = 120.0    # s per cell; the slowest fast cell takes about 16 s on 1 rank


@pytest.mark.slow
@pytest.mark.parametrize("name", bench_extremes.FAST)
def test_fast_subset_ends_as_documented(comm, name):
    (cell,) = bench_extremes.select([name])
    row = bench_extremes.run_cell(comm, cell, "fast", guard=GUARD)
    assert row["outcome"] == cell.expected, row["message"]
    if cell.expected == "ok" and not cell.special.endswith("load"):
        assert row["s_over_d"] == pytest.approx(bench_extremes.S_OVER_D, rel=1e-9)
    if name == "tiny_load":
        assert row["plastic"] == 0 and row["QV_N_per_m"] == pytest.approx(bench_extremes.TINY_LOAD, rel=1e-3)
    if name == "above_capacity":
        assert row["s_over_d"] == pytest.approx(bench_extremes.S_OVER_D, rel=1e-9) and row["plastic"] > 0


def test_steep_nonassociated_sand_needs_the_relaxation_fallback(comm):
    """phi_dp = 65 deg, psi = 0, c = 0 (1 kPa regularising cohesion): without the fallback Newton
    fails early (measured s/d = 0.003 after step cutting); with the default 0.01 mm over 0.005 d
    the push relaxes a few stretches and reaches s/d = 0.1."""
    (cell,) = bench_extremes.select(["phi65_psi0_c0_nu0.35_E1300"])
    plain = bench_extremes.run_cell(comm, cell, "fast", guard=GUARD, model={"relaxation_fallback": 0.0})
    assert plain["outcome"] == "newton_diverged" and plain["s_over_d"] < 0.05
    assert plain["relaxed_stretches"] == 0
    default = bench_extremes.run_cell(comm, cell, "fast", guard=GUARD)
    assert default["outcome"] == "ok" and default["relaxed_stretches"] >= 1
    assert default["relaxed_s_over_d"] <= default["relaxed_stretches"] * 0.005 + 1e-12


def test_matrix_names():
    """Every fast cell is in the matrix and the matrix has no duplicates."""
    names = [c.name for c in bench_extremes.matrix()]
    assert len(names) == len(set(names)) == 355 and set(bench_extremes.FAST) <= set(names)


def test_fallback_estimate_matches_the_saved_matrix():
    """The effect summary.json gives for the relaxation fallback (regularisation.FALLBACK_BIAS) is
    what the saved matrix shows: Q_V at s/d = 0.1 of the cells the default relaxed, against the
    same cells with the length halved (no solving here)."""
    saved = pathlib.Path(__file__).parents[1] / "benchmarks" / "results" / "extremes_fast.json"
    rows = json.loads(saved.read_text())["results"]
    default = {r["cell"]: r for r in rows if bench_extremes.settings(r) == "fast"}
    halved = [r for r in rows if bench_extremes.settings(r) == "fast, relaxation_fallback = 0.005 mm"]
    changes = sorted(100 * abs(r["QV_N_per_m"] / default[r["cell"]]["QV_N_per_m"] - 1) for r in halved
                     if r["outcome"] == default[r["cell"]]["outcome"] == "ok")
    assert len(changes) == 30 and all(default[r["cell"]]["relaxed_stretches"] > 0 for r in halved)
    assert changes[23] <= 1.6 < changes[24] and changes[28] <= FALLBACK_BIAS[1] < changes[29]
    ok = [r for r in default.values() if r["outcome"] == r["expected"]]
    assert len(default) == 355 and len(ok) == 352
