"""The long benchmark sweeps keep what they ran: a level or block already in the results file is
not solved again, and their tables compare like with like (no solving here)."""
from __future__ import annotations

import json
import logging
import math
import pathlib

import numpy as np
import pytest
from mpi4py import MPI

from rollsim.solver.rolling import RollingStep

BENCHMARKS = pathlib.Path(__file__).parents[1] / "benchmarks"


@pytest.fixture()
def benchmarks(monkeypatch):
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    import bench_mesh
    import bench_rolling
    return bench_rolling, bench_mesh


def _level(refinement, sinkage, **extra):
    return {"soil": "case5", "strain": "cell-average", "refinement": refinement, "ranks": 1, "dofs": 100,
            "steady": True, "s_cl": sinkage + 1e-3, "steps": 10, "newton_iterations": 50, "cuts": 0, "time_s": 1.0,
            "settled": {"sinkage_mean": sinkage, "sinkage_std": 1e-4}, **extra}


def _solved_level(convergence, monkeypatch, argv: list[str], *fields: str) -> tuple:
    """The ``fields`` of the scene arguments of the one level the case-5 cell-average sweep with
    ``argv`` solves (the solve itself is stopped)."""
    solved = []

    def record(comm, mu, level):
        solved.append(tuple(getattr(level, f) for f in fields))
        raise RuntimeError("stop")

    monkeypatch.setattr(convergence, "constant_load", record)
    with pytest.raises(RuntimeError, match="stop"):
        convergence.levels(["--soil", "case5", "--refinement", "6", "--volumetric-strain", "cell-average"] + argv)
    (level,) = solved
    return level


@pytest.mark.serial
def test_rolling_convergence_resumes_and_keeps_regularised_runs_apart(benchmarks, tmp_path, monkeypatch, capsys):
    convergence, _ = benchmarks
    out = tmp_path / "levels.json"
    out.write_text(json.dumps({"results": [_level(6.0, 0.018, relaxation_length_mm=0.0),
                                           _level(6.0, 0.0177, relaxation_length_mm=0.5)]}))

    def must_not_solve(*args, **kwargs):
        raise AssertionError("a saved level was solved again")

    monkeypatch.setattr(convergence, "constant_load", must_not_solve)
    assert convergence.levels(["--soil", "case5", "--refinement", "6", "--volumetric-strain", "cell-average",
                             "--relaxation-length", "0.5", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "not solved again" in text
    assert "| case5 | cell-average | 6 |" in text and "| case5 | cell-average, 0.5 mm relaxation | 6 |" in text
    assert len(json.loads(out.read_text())["results"]) == 2
    # a longer block is another run: solved, and labelled apart in the table
    assert _solved_level(convergence, monkeypatch, ["--length", "3.6", "--travel", "2.5", "--out", str(out)],
                         "length", "cl_travel") == (3.6, 2.5)
    longer = _level(6.0, 0.019, relaxation_length_mm=0.0, block_length_d=3.6, travel_d=2.5)
    assert convergence.formulation(longer) == "cell-average, 3.6 d block, 2.5 d travel"


@pytest.mark.serial
def test_rolling_convergence_keeps_hexahedra_apart_from_the_cell_count(benchmarks, tmp_path, monkeypatch, capsys):
    """A run's cell count (``cells``) does not hide its cell type: a saved level of either type
    is found again, and the hexahedra are labelled apart."""
    convergence, _ = benchmarks
    out = tmp_path / "levels.json"
    out.write_text(json.dumps({"results": [_level(6.0, 0.016, cells=1466),
                                           _level(6.0, 0.015, cells=512, cell_type="hexahedra")]}))

    def must_not_solve(*args, **kwargs):
        raise AssertionError("a saved level was solved again")

    monkeypatch.setattr(convergence, "constant_load", must_not_solve)
    for extra in ([], ["--hexahedra"]):
        assert convergence.levels(["--soil", "case5", "--refinement", "6", "--volumetric-strain", "cell-average",
                                 "--out", str(out)] + extra) == 0
    text = capsys.readouterr().out
    assert text.count("not solved again") == 2
    assert "| case5 | cell-average | 6 |" in text and "| case5 | cell-average, Q2-P1 hexahedra | 6 |" in text
    # elements shortened along the path are another run, passed on to the scene and labelled apart
    assert _solved_level(convergence, monkeypatch, ["--hexahedra", "--path-refinement", "2", "--out", str(out)],
                         "hexahedra", "path_refinement") == (True, 2.0)
    finer = _level(6.0, 0.015, cell_type="hexahedra", path_refinement=2.0)
    assert convergence.formulation(finer) == "cell-average, Q2-P1 hexahedra, 2x finer along the path"
    # and so are elements narrowed across the path
    assert _solved_level(convergence, monkeypatch, ["--hexahedra", "--cross-refinement", "3", "--out", str(out)],
                         "path_refinement", "cross_refinement") == (1.0, 3.0)
    narrower = _level(6.0, 0.015, cell_type="hexahedra", cross_refinement=3.0)
    assert convergence.formulation(narrower) == "cell-average, Q2-P1 hexahedra, 3x finer across the path"
    thinner = _level(6.0, 0.015, cell_type="hexahedra", depth_refinement=2.0)
    assert convergence.formulation(thinner) == "cell-average, Q2-P1 hexahedra, 2x finer in depth"
    for knob in ("--path-refinement", "--cross-refinement", "--depth-refinement"):
        with pytest.raises(SystemExit) as exit_info:
            convergence.levels(["--soil", "case5", "--refinement", "6", knob, "2", "--out", str(out)])
        assert exit_info.value.code == 2


@pytest.mark.serial
def test_rolling_convergence_keeps_a_fixed_travel_step_apart(benchmarks, tmp_path, monkeypatch, capsys):
    """A saved level at the solver's travel step is not the level at a fixed step: that one is
    solved, with its step passed on to the roll, and labelled apart."""
    convergence, _ = benchmarks
    out = tmp_path / "levels.json"
    out.write_text(json.dumps({"results": [_level(6.0, 0.018)]}))
    assert _solved_level(convergence, monkeypatch, ["--travel-step", "25", "--out", str(out)],
                         "travel_step") == (25.0,)
    fixed = _level(6.0, 0.017, travel_step_mm=25.0)
    assert convergence.formulation(fixed) == "cell-average, 25 mm steps"
    out.write_text(json.dumps({"results": [_level(6.0, 0.018), fixed]}))
    monkeypatch.setattr(convergence, "constant_load",
                        lambda *a: pytest.fail("a saved level was solved again"))
    assert convergence.levels(["--soil", "case5", "--refinement", "6", "--volumetric-strain", "cell-average",
                             "--travel-step", "25", "--out", str(out)]) == 0
    text = capsys.readouterr().out
    assert "not solved again" in text and "| case5 | cell-average, 25 mm steps | 6 |" in text
    control = convergence.travel_control(2.0, 25.0)
    assert (control.t_end, control.dt, control.dt_max) == (2.0, 0.025, 0.025)
    assert convergence.travel_control(2.0, 0.0) is None


@pytest.mark.serial
def test_rolling_convergence_passes_progress_to_the_level(benchmarks, tmp_path, monkeypatch):
    """``--progress`` asks the level's roll for a line per step; without it the roll is quiet."""
    convergence, _ = benchmarks
    out = str(tmp_path / "levels.json")
    assert _solved_level(convergence, monkeypatch, ["--progress", "--out", out], "progress") == (True,)
    assert _solved_level(convergence, monkeypatch, ["--out", out], "progress") == (False,)


@pytest.mark.serial
def test_rolling_convergence_keeps_the_sinkage_along_the_travel(benchmarks, tmp_path, monkeypatch):
    """A solved level is saved with its (travel, sinkage) curve, not its forces."""
    convergence, _ = benchmarks
    level = _level(6.0, 0.012)

    def solved(comm, mu, args):
        return {**level, "status": "ok", "curve": [(0.1, 0.011, 1e5, 2e3), (0.2, 0.0125, 1e5, 2e3)]}

    monkeypatch.setattr(convergence, "constant_load", solved)
    out = tmp_path / "levels.json"
    assert convergence.levels(["--soil", "case5", "--refinement", "6", "--volumetric-strain", "cell-average",
                             "--out", str(out)]) == 0
    (saved,) = json.loads(out.read_text())["results"]
    assert saved["travel_sinkage"] == [[0.1, 0.011], [0.2, 0.0125]] and "curve" not in saved


@pytest.mark.serial
def test_rolling_convergence_scores_the_steady_sinkage_when_every_level_settled(benchmarks):
    """Levels that all detected a steady state are scored by it (s_cl = mean + 1 mm here); one
    level without one makes the whole group fall back to the mean from 1 d."""
    convergence, _ = benchmarks
    levels = [_level(n, s) for n, s in ((6.0, 0.012), (8.0, 0.016), (10.0, 0.017))]
    rows = [line for line in convergence.table(levels).splitlines() if line.startswith("| case5")]
    assert all("| steady |" in row for row in rows)                     # 18 / 17 mm: +5.9 %, not 17 / 16: +6.2 %
    assert f"{100 * (18 / 17 - 1):+.1f} %" in rows[2] and f"{100 * (17 / 16 - 1):+.1f} %" not in rows[2]
    levels[1]["steady"] = False
    rows = [line for line in convergence.table(levels).splitlines() if line.startswith("| case5")]
    assert all("| mean from 1 d |" in row for row in rows) and "| not detected |" in rows[1]
    assert f"{100 * (17 / 16 - 1):+.1f} %" in rows[2]


@pytest.mark.serial
def test_rolling_convergence_remarks_on_a_heave_and_not_on_an_unmeasured_rut(benchmarks):
    """A negative rut is a heave; a rut left unmeasured by a short travel (None) is no remark."""
    convergence, _ = benchmarks
    levels = [_level(6.0, 0.012, rut_depth=-2e-3), _level(8.0, 0.016, rut_depth=None), _level(10.0, 0.017)]
    notes = [line for line in convergence.table(levels).splitlines() if "rut" in line]
    assert notes == ["- case5, cell-average, 6 elements / d: the rut is a heave of 2.0 mm"]


@pytest.mark.serial
def test_rolling_convergence_runs_the_scene_fallbacks_apart(benchmarks, tmp_path, monkeypatch):
    """``--fallbacks`` gives the levels the relaxation fallbacks of a plain scene and keeps them
    apart from the levels that fail instead."""
    convergence, _ = benchmarks
    passed = []

    def solved(comm, mu, args):
        passed.append(convergence.regularisation(args))
        solution = {k: v for k, v in _level(6.0, 0.012).items() if k not in ("soil", "strain", "refinement")}
        return {**solution, "status": "ok", "curve": [(0.1, 0.011, 1e5, 2e3)]}

    monkeypatch.setattr(convergence, "constant_load", solved)
    out = tmp_path / "levels.json"
    for extra in ([], ["--fallbacks"]):
        assert convergence.levels(["--soil", "sand", "--refinement", "6", "--volumetric-strain", "pointwise",
                                 "--out", str(out)] + extra) == 0
    assert passed[0] == {"relaxation_length": 0.0}
    assert passed[1]["travel_relaxation_fallback"] > 0 and passed[1]["relaxation_fallback"] > 0
    saved = json.loads(out.read_text())["results"]
    assert [convergence.formulation(r) for r in saved] == ["pointwise", "pointwise, fallback started over relaxed"]
    assert convergence.formulation({**saved[1], "fallbacks": True}) == "pointwise, fallbacks over 0.1 d stretches"


@pytest.mark.serial
def test_rolling_convergence_table_names_failed_heaving_and_relaxed_levels(benchmarks, tmp_path, capsys):
    """A failed level is not scored; a heave, the relaxed stretches and a roll that started over
    are named under the table;
    the figure draws the levels that kept their sinkage along the travel."""
    convergence, _ = benchmarks
    failed = _level(6.0, 0.010, status="failed: Newton diverged", travel_sinkage=[[0.0, 0.01], [0.5, 0.011]])
    heaving = _level(8.0, 0.005, rut_depth=-0.012, relaxed_travel=[[0.4, 0.55], [0.9, 1.05]],
                     travel_failures=[0.4], travel_sinkage=[[0.0, 0.01], [0.5, 0.006], [1.0, 0.004]])
    text = convergence.table([failed, heaving])
    rows = [line for line in text.splitlines() if line.startswith("| case5")]
    assert len(rows) == 1 and "| 8 |" in rows[0]
    assert "6 elements / d: failed after 0.50 m of travel, not scored" in text
    assert "8 elements / d: 2 stretch(es) relaxed, 0.30 m of travel" in text
    assert "8 elements / d: the rate-independent roll failed after 0.40 m and started over relaxed" in text
    assert "8 elements / d: the rut is a heave of 12.0 mm" in text
    saved = tmp_path / "levels.json"
    saved.write_text(json.dumps({"results": [failed, heaving]}))
    figure = tmp_path / "travel.png"
    assert convergence.levels(["--table", str(saved), "--figure", str(figure)]) == 0
    assert figure.stat().st_size > 0
    saved.write_text(json.dumps({"results": [_level(6.0, 0.01)]}))
    assert convergence.levels(["--table", str(saved), "--figure", str(tmp_path / "none.png")]) == 0
    assert "not drawn" in capsys.readouterr().out and not (tmp_path / "none.png").exists()


@pytest.mark.serial
def test_block_size_table_and_bad_block(benchmarks, tmp_path, capsys):
    _, block_size = benchmarks
    runs = [{"scene": "rolling-case5", "refinement": 8.0, "block": [2.6, w, w, 0.3, 0.4], "ranks": 1,
             "status": "ok", "dofs": dofs, "steps": 60, "newton_iterations": 800, "time_s": 300.0,
             "value": s, "std": 5e-4} for w, dofs, s in ((0.8, 12822, 0.015), (2.2, 17784, 0.016))]
    results = tmp_path / "block_size.json"
    results.write_text(json.dumps({"runs": runs}))
    assert block_size.block_size(["--table", "--results", str(results)]) == 0
    rows = [line for line in capsys.readouterr().out.splitlines() if line.startswith("| rolling-case5")]
    assert "-6.2 %" in rows[0] and rows[1].count("|") == 9 and "%" not in rows[1]
    with pytest.raises(ValueError, match="--block"):
        block_size.parse_block("rolling-case5", "2.6:0.8:0.8")
    with pytest.raises(SystemExit) as exit_status:
        block_size.block_size(["--block", "2.6:0.8", "--results", str(results)])
    assert exit_status.value.code == 2


@pytest.mark.serial
def test_rolling_convergence_compares_the_levels_over_later_windows(benchmarks):
    """Levels rolled past the last window get the means of their rolled steps from 1 / 2 / 2.5 d of
    travel under the table (the press at x = 0 and the lift-off's repeated x are not rolled steps);
    a group with a level too short for a window gets none."""
    convergence, _ = benchmarks
    d = convergence.D
    x = (0.3 + 0.25 * np.arange(14)) * d                 # rolled steps every 0.25 d from 0.3 d

    def level(n, early, late):                           # 'early' mm up to 2 d of travel, 'late' after
        rolled = [[xi, 1e-3 * (early if xi < 2 * d else late)] for xi in x]
        lift = [[x[-1], 0.005], [x[-1], 0.0]]
        return _level(n, 0.012, travel_sinkage=[[0.0, 0.001]] + rolled + lift)

    text = convergence.table([level(6.0, 10.0, 12.0), level(8.0, 20.0, 12.0)])
    assert convergence.window_means(level(6.0, 10.0, 12.0)) == pytest.approx([(4 * 10 + 7 * 12) / 11 * 1e-3,
                                                                               12e-3, 12e-3])
    (note,) = [line for line in text.splitlines() if "mean sinkage from 1 / 2 / 2.5 d" in line]
    assert "6 / d: 11.27 / 12.00 / 12.00; 8 / d: 14.91 / 12.00 / 12.00" in note
    short = level(8.0, 20.0, 12.0)
    short["travel_sinkage"] = short["travel_sinkage"][:9]        # rolled to 2.05 d only
    assert convergence.window_means(short)[1:] == [None, None]
    assert "mean sinkage from" not in convergence.table([level(6.0, 10.0, 12.0), short])


@pytest.mark.serial
def test_pose_retry_runs_both_variants_once_and_restores_the_default(benchmarks, tmp_path, monkeypatch, capsys):
    """Each variant solves with its own ``POSE_HOLDS``, a resumed file solves nothing again, and the
    default is back afterwards (a failed solve included)."""
    import bench_rolling as bench_pose_retry
    from rollsim.solver.rolling import WheelRolling
    default = WheelRolling.POSE_HOLDS
    seen = []

    def fake(comm, mu, level):
        seen.append(WheelRolling.POSE_HOLDS)
        its = 120 if len(WheelRolling.POSE_HOLDS) > 1 else 80
        return {**_level(6.0, 0.019 + 1e-4 * len(seen)), "newton_iterations": its, "time_s": its / 10,
                "status": "ok", "curve": [(0.0, 0.01, 0.0, 0.0)]}

    monkeypatch.setattr(bench_pose_retry, "constant_load", fake)
    out = tmp_path / "retry.json"
    assert bench_pose_retry.pose_retry(["--soil", "case5", "--out", str(out)]) == 0
    assert seen == [(0.1, 0.0), default] and WheelRolling.POSE_HOLDS == default
    assert bench_pose_retry.pose_retry(["--soil", "case5", "--out", str(out)]) == 0
    assert len(seen) == 2                                                  # resumed: nothing solved again
    text = capsys.readouterr().out
    assert "1.50x fewer Newton iterations, 1.50x less wall time, mean sinkage +0.5 %" in text

    def failing(comm, mu, level):
        raise RuntimeError("solver crashed")

    monkeypatch.setattr(bench_pose_retry, "constant_load", failing)
    with pytest.raises(RuntimeError):
        bench_pose_retry.pose_retry(["--soil", "clay", "--out", str(tmp_path / "other.json")])
    assert WheelRolling.POSE_HOLDS == default


@pytest.mark.serial
def test_rolling_cells_runs_each_mesh_variant_once(monkeypatch, tmp_path, capsys):
    """bench_rolling_cells: a variant's scene carries its mesh keys over the example's, the mean
    sinkage counts only full-load steps from 1 d of travel on, and a saved variant is not run again."""
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    import bench_rolling as cells
    scene = cells.variant_scene(cells.SCENE, "hexahedra, 6 per d, 8 across, B-bar")
    assert (scene.model.cell_type, scene.model.elements_across_wheel, scene.model.refinement) == ("hexahedra", 8, 6)
    assert scene.model.volumetric_strain == "cell-average" and scene.model.accuracy == "standard"
    assert scene.model.elements_along_path == 6
    assert cells.variant_scene(cells.SCENE, "tetrahedra, fast").model.volumetric_strain == "pointwise"
    assert cells.variant_scene(cells.SCENE, "standard").model.accuracy == "standard"
    history = tmp_path / "history.csv"
    history.write_text("travel_m,QV_N,QH_N,sinkage_m\n0,133500,0,0.001\n1.0,133500,9e3,0.5\n1.6,133500,9e3,0.020\n"
                       "2.0,133500,9e3,0.022\n2.4,133500,9e3,0.021\n3.0,52000,0,0.015\n")
    assert cells.rolled_sinkage(history, 1.524, 133.5e3) == pytest.approx((0.021, math.sqrt(2 / 3) * 1e-3))
    ran = []

    def run_variant(comm, path, name, work):
        ran.append(name)
        return {"variant": name, "scene": path.name, "status": "ok", "cells": 10, "dofs": 100, "steps": 5,
                "newton_iterations": 20, "cuts": 0, "time_s": 100.0 * (len(ran) + 1), "ranks": 1,
                "strain": "pointwise", "sinkage_mean": 0.02, "sinkage_std": 0.001, "steady_sinkage": None}

    monkeypatch.setattr(cells, "run_variant", run_variant)
    out = tmp_path / "cells.json"
    first, second = list(cells.CELL_VARIANTS)[:2]
    assert cells.cells(["--variant", first, "--out", str(out)]) == 0
    assert cells.cells(["--variant", first, second, "--out", str(out)]) == 0
    assert ran == [first, second]
    text = capsys.readouterr().out
    assert f"| {second} | pointwise | 10 | 100 | 5 | 20 | 0 | 20.00 ± 1.00 mm | not detected | 300 s (1) | 1.50 |" in text


@pytest.mark.serial
def test_rolling_cells_compares_stopped_runs_over_a_common_travel(monkeypatch, tmp_path, capsys):
    """bench_rolling_cells --progress: each run directory under --work, stopped or finished, is
    read up to the same travel; the sinkage is averaged over the window at the load only."""
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    import bench_rolling as cells
    header = "step,sinkage_m,QV_N,travel_m,newton_iterations,wall_time_s\n"
    runs = {"tetrahedra_fast": "1,0.010,133500,0.5,4,10\n2,0.020,133500,1.0,6,30\n3,0.030,133500,1.5,8,60\n"
                               "4,0.010,50000,2.0,2,70\n",
            "standard": "1,0.010,133500,0.5,10,40\n2,0.024,133500,1.0,12,100\n3,0.040,120000,1.2,30,200\n"}
    for name, rows in runs.items():
        (tmp_path / name).mkdir()
        (tmp_path / name / "history.csv").write_text(header + rows)
    assert cells.cells(["--work", str(tmp_path), "--progress", "1.0", "0.9", "1.3"]) == 0
    text = capsys.readouterr().out
    assert "| tetrahedra, fast | 2.00 m | 2 | 10 | 30 s | 1.00 | 20.00 mm |" in text
    assert "| standard | 1.20 m | 2 | 22 | 100 s | 3.33 | 24.00 mm |" in text
    with pytest.raises(SystemExit):
        cells.cells(["--progress", "1.0", "0.9", "1.3"])


def _held_run(path, strain: str, across: float, s_hold: float, q: float, depth: float = 1.0,
              roll_step: float = 0.0, *, load: float, refined_depth: float = 0.4, mu: float = 0.0, **scene):
    """Write a held run of ``bench_rolling_protocols`` to ``path``: Q_V = ``q`` (N) held at ``s_hold`` (m)
    on the 6-per-d mesh refined ``across`` and in ``depth`` (the strip ``refined_depth`` d deep),
    travel step ``roll_step`` (mm, 0: default), the load ``load`` (kN), friction ``mu`` and the
    other arguments ``scene``."""
    args = {"volumetric_strain": strain, "refinement": 6.0, "accuracy": "fast", "cross_refinement": across,
            "depth_refinement": depth, "roll_step": roll_step, "load": load, "refined_depth": refined_depth,
            "mu": [mu], **scene}
    hold = {"mu": mu, "s_hold": s_hold, "QV_hold": q, "QV_hold_std": 1e3, "QH_hold": 1e4, "steps": 60,
            "newton_iterations": 400, "cuts": 0, "time_s": 10.0}
    path.write_text(json.dumps({"args": args, "results": [{"hold": hold}, {"hold": None}]}))
    return path


@pytest.mark.serial
def test_held_sinkage_table_compares_like_with_like(benchmarks, tmp_path, capsys):
    """The held-sinkage table sorts the runs by strain and mesh and gives each the change of Q_V
    against the mesh of the same strain and elements per d that is twice as coarse along one axis,
    and a run at a set travel step the change against the same mesh at the default step."""
    protocols = benchmarks[0]
    paths = [_held_run(tmp_path / f"run{k}.json", *run, load=105.0) for k, run in enumerate((
        ("pointwise", 4.0, 0.03, 110e3), ("pointwise", 2.0, 0.03, 100e3), ("cell-average", 2.0, 0.03, 90e3),
        ("pointwise", 2.0, 0.03, 99e3, 2.0), ("pointwise", 8.0, 0.03, 121e3), ("pointwise", 2.0, 0.02, 80e3),
        ("pointwise", 4.0, 0.02, 88e3), ("pointwise", 4.0, 0.01, 50e3), ("pointwise", 2.0, 0.03, 104e3, 2.0, 25.4)))]
    assert protocols.roll(["--table"] + [str(p) for p in paths]) == 0
    tables = capsys.readouterr().out.split("\n\n")
    rows = [line for line in tables[0].splitlines() if line.startswith("| ") and "30.00 mm" in line]
    assert [r.split(" | ")[2] for r in rows] == ["2x across the path"] * 2 + [
        "2x across the path, 2x in depth", "2x across the path, 2x in depth, 25.4 mm steps",
        "4x across the path", "8x across the path"]
    assert rows[0].startswith("| cell-average") and "%" not in rows[0]
    assert "|  |  | +11.1 % |" in rows[1]       # no coarser pointwise mesh; B-bar's on its mesh
    assert "| -1.0 % | 2x across the path |" in rows[2] and "dofs" not in rows[2]
    assert "| +5.1 % | 2x across the path, 2x in depth |" in rows[3]
    assert "| +10.0 % | 2x across the path |" in rows[4]
    assert "| +10.0 % | 4x across the path |" in rows[5]
    # the sinkage carrying 105 kN on the power law through the two held points nearest the load
    n = math.log(100 / 80) / math.log(3 / 2)
    coarse, fine = 30 * 1.05 ** (1 / n), 30 * (105 / 110) ** (1 / n)
    at_load = [line for line in tables[1].splitlines() if line.startswith("| pointwise")]
    assert len(at_load) == 2 and f"| {n:.3f} | 105 kN | {coarse:.2f} mm |  |  |" in at_load[0]
    assert f"| {fine:.2f} mm | {100 * (fine / coarse - 1):+.1f} % | 2x across the path |" in at_load[1]
    assert "10.00 / 20.00 / 30.00 mm" in at_load[1]


@pytest.mark.serial
def test_held_table_keeps_scenes_apart_and_compares_the_strains(benchmarks, tmp_path, capsys):
    """Runs of other soils, friction or travel are never compared with each other: each scene gets
    its own changes, and a column names the arguments that tell the scenes apart (not those only
    the constant-load run reads); each pointwise run is compared with B-bar on its scene's mesh."""
    protocols = benchmarks[0]
    runs = (("cell-average", 4.0, 100e3, 0.0, 300.0), ("cell-average", 8.0, 99e3, 0.0, 300.0),
            ("pointwise", 4.0, 110e3, 0.0, 300.0), ("pointwise", 8.0, 99e3, 0.0, 300.0),
            ("cell-average", 4.0, 120e3, 0.8, 300.0), ("pointwise", 4.0, 150e3, 0.8, 300.0),
            ("pointwise", 8.0, 140e3, 0.8, 300.0), ("cell-average", 4.0, 160e3, 0.8, 194.6))
    paths = [_held_run(tmp_path / f"run{k}.json", strain, across, 0.03, q, load=133.5, mu=mu, yield_stress=qy,
                       cl_travel=1.0 + k, ramp=0.5) for k, (strain, across, q, mu, qy) in enumerate(runs)]
    assert protocols.roll(["--table"] + [str(p) for p in paths]) == 0
    held = capsys.readouterr().out.split("\n\n")[0].splitlines()
    assert held[0].startswith("| scene | strain |") and "| against cell-average |" in held[0]
    rows = {tuple(r.split(" | ")[i] for i in (0, 1, 3, 4)): r for r in held[2:]}
    assert len(rows) == 8 and not any("--cl-travel" in r for r in rows)
    clay, friction = "| --yield-stress 300", "0.8"
    assert "| -1.0 % | 4x across the path |  |" in rows[(clay, "cell-average", "8x across the path", "0")]
    assert "|  |  | +10.0 % |" in rows[(clay, "pointwise", "4x across the path", "0")]
    assert "| -10.0 % | 4x across the path | +0.0 % |" in rows[(clay, "pointwise", "8x across the path", "0")]
    assert "|  |  | +25.0 % |" in rows[(clay, "pointwise", "4x across the path", friction)]
    # B-bar of this scene was not run on 8 across: no comparison with the other scene's
    assert "| -6.7 % | 4x across the path |  |" in rows[(clay, "pointwise", "8x across the path", friction)]
    assert "|  |  |  |" in rows[("| --yield-stress 194.6", "cell-average", "4x across the path", friction)]
    with pytest.raises(SystemExit) as stop:          # a file that is not there: one line, status 2
        protocols.roll(["--table", str(paths[0]), str(tmp_path / "none.json")])
    assert stop.value.code == 2 and "--table: no such file:" in capsys.readouterr().err


@pytest.mark.serial
def test_held_table_names_the_cell_mean_apart_from_b_bar(benchmarks, tmp_path, capsys):
    """A B-bar run with the cell mean (``--volumetric-projection 0``) is a strain of its own: its
    changes are against its own coarser run and it is compared with B-bar's default projection on
    its mesh; the option is refused without hexahedra and B-bar (one line, status 2)."""
    protocols = benchmarks[0]
    runs = (("cell-average", 4.0, 100e3, {}), ("cell-average", 8.0, 96e3, {}),
            ("cell-average", 4.0, 90e3, {"volumetric_projection": 0}),
            ("cell-average", 8.0, 93.6e3, {"volumetric_projection": 0}))
    paths = [_held_run(tmp_path / f"run{k}.json", strain, across, 0.03, q, load=100.0, **extra)
             for k, (strain, across, q, extra) in enumerate(runs)]
    assert protocols.roll(["--table"] + [str(p) for p in paths]) == 0
    held = capsys.readouterr().out.split("\n\n")[0].splitlines()
    assert not held[0].startswith("| scene")            # one scene: the projection is the strain's
    rows = {tuple(r.split(" | ")[i] for i in (0, 2)): r for r in held[2:]}
    assert "| -4.0 % | 4x across the path |  |" in rows[("| cell-average", "8x across the path")]
    assert "|  |  | -10.0 % |" in rows[("| cell mean", "4x across the path")]
    assert "| +4.0 % | 4x across the path | -2.5 % |" in rows[("| cell mean", "8x across the path")]
    for refused in (["--volumetric-projection", "0"],
                    ["--hexahedra", "--volumetric-strain", "pointwise", "--volumetric-projection", "1"]):
        with pytest.raises(SystemExit) as stop:
            protocols.roll(refused + ["--out", str(tmp_path / "refused.json")])
        assert stop.value.code == 2 and "--volumetric-projection:" in capsys.readouterr().err
    assert not (tmp_path / "refused.json").exists()


@pytest.mark.serial
def test_held_run_at_a_set_step_falls_back_to_the_default_step(benchmarks, tmp_path, capsys):
    """A run at a set travel step whose mesh was run neither at the default step nor coarser at the
    same step is compared with the coarser mesh at the default step, in both tables."""
    protocols = benchmarks[0]
    paths = [_held_run(tmp_path / f"run{k}.json", "cell-average", 2.0, s_hold, q, *refined, load=100.0)
             for k, (s_hold, q, *refined) in enumerate(((0.02, 90e3), (0.03, 110e3), (0.02, 99e3, 2.0, 25.4),
                                                       (0.03, 121e3, 2.0, 25.4), (0.03, 120e3, 2.0)))]
    assert protocols.roll(["--table"] + [str(p) for p in paths]) == 0
    held, at_load = capsys.readouterr().out.split("\n\n")
    stepped = [line for line in held.splitlines() if "25.4 mm steps" in line]
    assert "| 20.00 mm |" in stepped[0] and "| +10.0 % | 2x across the path |" in stepped[0]
    assert "| 30.00 mm |" in stepped[1] and "| +0.8 % | 2x across the path, 2x in depth |" in stepped[1]
    rows = [line for line in at_load.splitlines() if line.startswith("| cell-average")]
    assert len(rows) == 2 and "25.4 mm steps" in rows[1] and rows[1].endswith("| 2x across the path |")
    assert "%" not in rows[0] and "%" in rows[1].split(" | ")[-2]


@pytest.mark.serial
def test_held_run_on_a_shallower_strip_is_compared_with_the_full_strip(benchmarks, tmp_path, capsys):
    """A strip refined to another depth is named so, kept apart from the full-depth strip of the
    same refinements, and compared with a coarser mesh of its own depth where one was run, else of
    the full depth."""
    protocols = benchmarks[0]
    runs = ((0.03, 100e3, 2.0, 25.4, 0.4), (0.03, 96e3, 4.0, 25.4, 0.2), (0.03, 90e3, 4.0, 25.4, 0.4),
            (0.02, 80e3, 2.0, 25.4, 0.4), (0.02, 85e3, 2.0, 25.4, 0.2), (0.02, 84e3, 4.0, 25.4, 0.2))
    paths = [_held_run(tmp_path / f"run{k}.json", "cell-average", 4.0, s_hold, q, depth, step, load=95.0,
                       refined_depth=strip) for k, (s_hold, q, depth, step, strip) in enumerate(runs)]
    assert protocols.roll(["--table"] + [str(p) for p in paths]) == 0
    held, at_load = capsys.readouterr().out.split("\n\n")
    shallow = "4x across the path, 4x in depth to 0.2 d deep, 25.4 mm steps"
    rows = {(r.split(" | ")[2], r.split(" | ")[4]): r for r in held.splitlines() if r.startswith("| cell-average")}
    assert "| -4.0 % | 4x across the path, 2x in depth, 25.4 mm steps |" in rows[(shallow, "30.00 mm")]
    assert "| -10.0 % | 4x across the path, 2x in depth, 25.4 mm steps |" in rows[
        ("4x across the path, 4x in depth, 25.4 mm steps", "30.00 mm")]
    assert "| -1.2 % | 4x across the path, 2x in depth to 0.2 d deep, 25.4 mm steps |" in rows[(shallow, "20.00 mm")]
    assert len([r for r in at_load.splitlines() if r.startswith("| cell-average")]) == 2


@pytest.mark.serial
def test_sinkage_at_load_skips_repeats_and_flat_curves(benchmarks, tmp_path, capsys):
    """A mesh held twice at one sinkage has a single point (no row); a mesh whose force falls with
    sinkage, or whose power law meets the load far below its held points, gets a row that says so
    instead of a sinkage."""
    protocols = benchmarks[0]
    paths = [_held_run(tmp_path / f"run{k}.json", "cell-average", across, s_hold, q, load=100.0)
             for k, (across, s_hold, q) in enumerate(((2.0, 0.03, 90e3), (2.0, 0.03, 91e3), (4.0, 0.02, 95e3),
                                                      (4.0, 0.03, 94e3), (8.0, 0.02, 108e3), (8.0, 0.04, 125e3)))]
    assert protocols.roll(["--table"] + [str(p) for p in paths]) == 0
    tables = capsys.readouterr().out.split("\n\n")
    assert len(tables) == 2
    at_load = [line for line in tables[1].splitlines() if line.startswith("| cell-average")]
    assert len(at_load) == 2 and "4x across the path" in at_load[0] and "8x across the path" in at_load[1]
    assert "not read: Q_V does not grow with s" in at_load[0] and "20.00 / 30.00 mm" in at_load[0]
    assert "not read: the load lies below the held sinkages" in at_load[1] and "20.00 / 40.00 mm" in at_load[1]


@pytest.mark.serial
def test_held_trend_is_the_slope_over_the_held_steps(benchmarks, tmp_path, capsys):
    """The trend of a held run is the straight-line slope of Q_V over the steps after half a diameter
    of holding, per diameter of travel and relative to their mean, and its Q_V is averaged per
    0.2 d of held travel; the ramp and the first half diameter of holding do not count, and a run
    without its curve gets no row."""
    protocols = benchmarks[0]
    d = protocols.D
    x = np.linspace(0.0, 1.2 * d, 49)
    q = np.where(x < 1.0 * d, 50e3 * x / d, 100e3 * (1.0 + 0.1 * (x / d - 1.1)))   # +10 % per d when held
    paths = [_held_run(tmp_path / f"run{k}.json", "cell-average", across, 0.03, 100e3, load=100.0, ramp=0.5)
             for k, across in enumerate((2.0, 4.0))]
    saved = json.loads(paths[0].read_text())
    saved["results"][0]["hold"]["curve"] = [(xi, 0.03, qi, 0.0) for xi, qi in zip(x, q)]
    paths[0].write_text(json.dumps(saved))
    assert protocols.hold_trend(*protocols.held_curve(saved["args"], saved["results"][0]["hold"])) == pytest.approx(0.1)
    assert protocols.roll(["--table"] + [str(p) for p in paths]) == 0
    trend = capsys.readouterr().out.split("\n\n")[-1]
    rows = [line for line in trend.splitlines() if line.startswith("| cell-average")]
    assert rows == ["| cell-average | 2x across the path | 30.00 mm | +10.0 % | 1.0-1.2 d | 100.0 kN |"]
    x = np.linspace(0.0, 1.6 * d, 65)     # held on to 1.6 d: three stretches, each closed at its end
    q = np.where(x < 1.0 * d, 50e3 * x / d, 100e3 * (1.0 + 0.1 * (x / d - 1.1)))
    longer = {"curve": [(xi, 0.03, qi, 0.0) for xi, qi in zip(x, q)]}
    assert protocols.held_stretches(*protocols.held_curve(saved["args"], longer)) == pytest.approx(
        [100e3, 102.125e3, 104.125e3])


def test_held_run_reads_the_load_only_near_its_ramp(benchmarks):
    """The sinkage carrying the load, read off a held run's ramp slope, is given only where the
    slope grows and the line stays within the width of the ramp's sinkages of the held one."""
    at_load = benchmarks[0]._sinkage_at_load
    ramp = np.array([0.015, 0.02, 0.025, 0.03])
    assert at_load(ramp, 2e6, 0.03, 95e3, 100e3) == pytest.approx(0.0325)
    assert at_load(ramp, 2e6, 0.03, 105e3, 100e3) == pytest.approx(0.0275)
    assert at_load(ramp, 3e4, 0.06, 125e3, 100e3) is None      # a flat ramp read 0.8 m away
    assert at_load(ramp, -1e6, 0.03, 95e3, 100e3) is None


@pytest.mark.serial
@pytest.mark.parametrize("progress", [True, False])
def test_held_run_logs_a_line_per_step_with_progress(benchmarks, monkeypatch, caplog, progress):
    """``--progress`` logs a line per rolled step of the continuous and held runs; without it they are quiet."""
    protocols = benchmarks[0]

    class Rolling:
        steps, newton_iterations, cuts, n_dofs, position, x_start = [], 0, 0, 10, 0.0, 0.0
        comm = protocols.MPI.COMM_WORLD

        def __init__(self, *args, **kwargs):
            pass

        def gravity_step(self):
            pass

        def press(self, sinkage):
            pass

        def roll(self, travel, s_target, ramp=None, dx=None, on_step=None, predictor="none"):
            on_step(RollingStep(1, 0.5 * travel, s_target, 9e4, 1e4, 0.0, 0.0, 0.0, 0.1, 0.0, 3, 3, 0, 0, 1.0))

    monkeypatch.setattr(protocols, "WheelRolling", Rolling)
    monkeypatch.setattr(protocols, "_block", lambda *args, **kwargs: None)
    args = protocols.parser().parse_args(["--mu", "0"] + ["--progress"] * progress)
    monkeypatch.setattr(logging.getLogger("rollsim"), "propagate", True)   # a CLI run before may have cut it
    caplog.set_level("INFO", logger="rollsim")
    protocols.continuous(protocols.MPI.COMM_WORLD, 0.0, args, s_hold=0.03)
    assert ("50%" in caplog.text and "Q_V = 90.00 kN" in caplog.text) == progress


def test_held_run_continues_from_its_checkpoint(benchmarks, tmp_mpi_path, monkeypatch):
    """A held run killed after its third rolled step (checkpoints every second step), started again
    and killed again after its sixth, then started once more with the same arguments gives the
    uninterrupted run's curve and Newton iterations; other arguments are refused (exit 2) before
    anything is solved."""
    protocols = benchmarks[0]
    argv = ["--mu", "0", "--hexahedra", "--refinement", "3", "--skip-constant-load", "--skip-continuous",
            "--hold-sinkage", "20", "--s0", "0.005", "--ramp", "0.08", "--travel", "0.2", "--cont-length", "1.2",
            "--roll-step", "50"]
    whole, resumed = tmp_mpi_path / "whole.json", tmp_mpi_path / "resumed.json"
    assert protocols.roll(argv + ["--out", str(whole)]) == 0
    ckpt = ["--checkpoint", str(tmp_mpi_path / "ckpt"), "--checkpoint-every", "2"]
    update = protocols.TravelProgress.update

    rolled = []

    def killed_after_three_and_six(self, st):
        update(self, st)
        rolled.extend([st.travel] * (st.travel > 0))
        if len(rolled) in (3, 6):
            raise KeyboardInterrupt

    monkeypatch.setattr(protocols.TravelProgress, "update", killed_after_three_and_six)
    for _ in range(2):          # the second run continues from the first's checkpoint and writes its own
        with pytest.raises(KeyboardInterrupt):
            protocols.roll(argv + ckpt + ["--out", str(resumed)])
    monkeypatch.setattr(protocols.TravelProgress, "update", update)
    with pytest.raises(SystemExit) as exit_info:
        protocols.roll(argv[:-1] + ["40"] + ckpt + ["--out", str(resumed)])
    assert exit_info.value.code == 2 and not resumed.exists()
    assert protocols.roll(argv + ckpt + ["--out", str(resumed)]) == 0
    protocols.MPI.COMM_WORLD.barrier()           # rank 0 writes the results
    a, b = ([r["hold"] for r in json.loads(p.read_text())["results"]][0] for p in (whole, resumed))
    assert a["steps"] == b["steps"] and a["newton_iterations"] == b["newton_iterations"]
    np.testing.assert_allclose(np.array(b["curve"]), np.array(a["curve"]), rtol=1e-8, atol=1e-9)


def test_held_run_resumes_a_checkpoint_written_before_an_argument_existed(benchmarks, tmp_path, capsys):
    """A checkpoint whose ``args.json`` lacks an argument added since (here ``--predictor``) is
    continued when that argument is at its default, and refused (exit 2, naming it) otherwise."""
    protocols = benchmarks[0]
    ckpt = tmp_path / "ckpt"
    ckpt.mkdir()
    args = protocols.parser().parse_args(["--hold-sinkage", "20"])
    saved = {k: v for k, v in vars(args).items() if k not in protocols._NOT_THE_PATH and k != "predictor"}
    (ckpt / "args.json").write_text(json.dumps(saved))

    class Roll:
        comm, steps, position, x_start, newton_iterations = MPI.COMM_SELF, [], 0.0, 0.0, 0
        read = []

        def read_checkpoint(self, found):
            self.read.append(found)

    roll = Roll()
    assert protocols.resume(roll, ckpt, args) == 0.0 and roll.read == [ckpt]
    args.predictor = "extrapolate"
    with pytest.raises(SystemExit) as exit_info:
        protocols.resume(roll, ckpt, args)
    assert exit_info.value.code == 2 and "--predictor" in capsys.readouterr().err
    assert roll.read == [ckpt]


@pytest.mark.end_to_end
def test_indentation_push_continues_from_its_last_complete_checkpoint(benchmarks, monkeypatch, tmp_mpi_path, comm):
    """The indentation benchmark writes its checkpoint whole at each reading stop: killed between
    the two renames that put the next version in place, it continues from the previous one and
    reaches the uninterrupted push's force."""
    import bench_indentation
    from rollsim import files
    soil = bench_indentation.case_soil(2)[:5]
    ckpt = tmp_mpi_path / "ckpt"
    first = bench_indentation.run(comm, "4", *soil, s_end=0.02, checkpoint=ckpt)
    if comm.rank == 0:
        files.staging_directory(ckpt).mkdir()
        replace, calls = files.os.replace, []

        def killed_after_one(src, dst):
            if calls:
                raise KeyboardInterrupt
            calls.append(dst)
            replace(src, dst)

        monkeypatch.setattr(files.os, "replace", killed_after_one)
        with pytest.raises(KeyboardInterrupt):
            files.replace_directory(ckpt)
        monkeypatch.setattr(files.os, "replace", replace)
        assert not ckpt.exists()
    resumed = bench_indentation.run(comm, "4", *soil, s_end=0.03, checkpoint=ckpt)
    whole = bench_indentation.run(comm, "4", *soil, s_end=0.03)
    assert resumed["steps_from_checkpoint"] == first["steps"] > 0
    assert resumed["QV"]["0.02"] == pytest.approx(first["QV"]["0.02"], rel=1e-12)
    assert resumed["QV"]["0.03"] == pytest.approx(whole["QV"]["0.03"], rel=1e-6)


@pytest.mark.serial
def test_speed_accuracy_reads_the_tire_off_its_curve_and_scores_it(monkeypatch, tmp_path, capsys):
    """The tire scene reads Q_V at 10, 20 and 30 mm off its run's force-sinkage curve (linear
    between steps, from the origin), leaves no run directory behind, and its levels are scored
    against the Richardson value of the three finest in a table of Q_V at 30 mm."""
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    import bench_speed_accuracy as speed
    import rollsim.solver.run
    work = []

    def run_scene(scene, out, comm, **options):
        assert scene.model.refinement == 12 and scene.wheel.type == "pneumatic" and not options["write_fields"]
        out.mkdir(parents=True, exist_ok=True)
        (out / "history.csv").write_text("step,sinkage_m,QV_N\n1,0.008,16000\n2,0.016,40000\n3,0.032,72000\n")
        work.append(out)
        return {"status": "ok", "steps": 3, "newton_iterations": 30, "linear_solves": 30, "step_cuts": 1,
                "dofs": 100, "cells": 10}

    monkeypatch.setattr(rollsim.solver.run, "run_scene", run_scene)
    cost, run = speed.tire_run(MPI.COMM_WORLD, 12.0, "cell-average")
    assert run["readings"] == pytest.approx({"0.01": 22e3, "0.02": 48e3, "0.03": 68e3})
    assert run["value"] == pytest.approx(68e3) and cost["cuts"] == 1 and not work[0].exists()
    levels = {8: 70e3, 12: 60e3 + 640e3 / 144, 16: 62.5e3, 20: 61.6e3}     # 60 kN + C h^2
    runs = [{"scene": "tire-indentation", "refinement": float(n), "ranks": 1, "volumetric_strain": "cell-average",
             "status": "ok", "cells": 10, "dofs": 100, "steps": 3, "newton_iterations": 30,
             "iterations_per_step": 10.0, "cuts": 0, "peak_memory_mb": 300.0, "time_s": float(n), "value": q,
             "linear_solves": 30} for n, q in levels.items()]
    (tmp_path / "speed_accuracy_tire-indentation.json").write_text(json.dumps({"runs": runs}))
    assert speed.main(["--report", "--scene", "tire-indentation", "--results", str(tmp_path),
                       "--figure", str(tmp_path / "trade.png")]) == 0
    text = capsys.readouterr().out
    assert "Q_V at s = 30 mm; reference 60000 (Richardson from 20, 16, 12 (order 2.00))" in text
    assert "| 8 (fast) | 10 | 100 | 70.00 kN | +16.7 % |" in text
    assert "| 20 (standard) | 10 | 100 | 61.60 kN | +2.7 % |" in text
    assert "| tire-indentation | 12, 12 s | 16, 16 s | finer than run |" in text and (tmp_path / "trade.png").exists()
