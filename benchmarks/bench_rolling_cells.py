"""A rolling scene on tetrahedra against hexahedra refined across the wheel, in one run.

    mpirun -n 2 python -m benchmarks rolling_cells --out benchmarks/results/rolling_cells.json
    mpirun -n 2 python -m benchmarks rolling_cells --variant "tetrahedra, fast" standard \
        --work runs --out benchmarks/results/rolling_cells_standard.json
    python -m benchmarks rolling_cells --table benchmarks/results/rolling_cells.json

Runs the scene (default ``examples/rolling_constant_load_mndot.toml``: the Mn/DOT roller at 133.5 kN
towed onto the case-5 soil) through ``rollsim run``'s driver once per mesh variant, one after the
other on the same ranks: the ``fast`` tetrahedra, hexahedra at 6 elements per d along the path with
8 across the wheel's width (``[model] cell_type = "hexahedra"``) with the scene's default strain and
with B-bar, and the ``standard`` preset.  Prints cells, dofs, steps, Newton iterations, cuts, wall
time, the mean sinkage over the rolled steps from 1 d of travel on (and its standard deviation: the
element-passing ripple) and the steady sinkage when detected, with each variant's wall-time ratio to
the first.  An existing ``--out`` file is resumed: the variants it holds are not run again.  With
``--work`` the run directories are kept there, and a variant that was killed continues from its last
checkpoint.
"""
from __future__ import annotations

import argparse
import csv
import math
import pathlib
import tempfile

from mpi4py import MPI

import bench_rolling_protocols as protocols
from _bench import add_results_arguments, dump_json, saved_results, show_table

from rollsim.files import read_toml
from rollsim.log import setup_logging
from rollsim.scene import load_scene, parse_scene
from rollsim.solver.run import run_scene

ROOT = pathlib.Path(__file__).resolve().parents[1]
SCENE = ROOT / "examples" / "rolling_constant_load_mndot.toml"
#: the mesh variants, by name: ``[model]`` keys replacing the scene's mesh keys
VARIANTS = {
    "tetrahedra, fast": {"accuracy": "fast"},
    "hexahedra, 6 per d, 8 across": {"refinement": 6, "cell_type": "hexahedra", "elements_across_wheel": 8,
                                     "elements_along_path": 6},
    "hexahedra, 6 per d, 8 across, B-bar": {"refinement": 6, "cell_type": "hexahedra", "elements_across_wheel": 8,
                                            "elements_along_path": 6, "volumetric_strain": "cell-average"},
    "standard": {"accuracy": "standard"},
}
MESH_KEYS = ("accuracy", "refinement", "cell_type", "elements_across_wheel", "elements_along_path",
             "volumetric_strain")


def variant_scene(path: pathlib.Path, name: str):
    """The scene of ``path`` with its mesh keys replaced by variant ``name``'s."""
    data = read_toml(path, str(path))
    model = {k: v for k, v in data.get("model", {}).items() if k not in MESH_KEYS}
    return parse_scene({**data, "model": model | VARIANTS[name]})


def rolled_sinkage(history: pathlib.Path, d: float, load: float) -> tuple[float, float]:
    """Mean and standard deviation (m) of the sinkage over the steps rolled at the load from 1 d
    of travel on (``history.csv`` of a constant-load run; as the convergence study's mean)."""
    curve = [tuple(r[k] for k in ("travel_m", "sinkage_m", "QV_N", "QH_N")) for r in read_history(history)]
    st = protocols.settled(curve, load, d)
    return (st["sinkage_mean"], st["sinkage_std"]) if st else (math.nan, math.nan)


def run_variant(comm, path: pathlib.Path, name: str, work: pathlib.Path) -> dict:
    """Run variant ``name`` of the scene at ``path`` in ``work``; its result row."""
    scene = variant_scene(path, name)
    out = run_directory(work, name)
    summary = run_scene(scene, out, comm, progress=True, write_fields=False)
    mean, std = rolled_sinkage(out / "history.csv", scene.wheel.diameter, scene.loading.load) \
        if comm.rank == 0 else (None, None)
    mean, std = comm.bcast((mean, std))
    steady = summary.get("steady_state") or {}
    return {"variant": name, "scene": path.name, "status": summary["status"], "cells": summary["cells"],
            "dofs": summary["dofs"], "steps": summary["steps"], "newton_iterations": summary["newton_iterations"],
            "cuts": summary["step_cuts"], "time_s": summary["wall_time_s"], "ranks": comm.size,
            "strain": summary["model"]["volumetric_strain"], "sinkage_mean": mean, "sinkage_std": std,
            "steady_sinkage": summary["sinkage_m"] if steady.get("reached") else None}


def run_directory(work: pathlib.Path, name: str) -> pathlib.Path:
    """The run directory of variant ``name`` under ``work``."""
    return work / name.replace(", ", "_").replace(" ", "-")


def read_history(history: pathlib.Path) -> list[dict]:
    """Rows of a rolling run's ``history.csv`` as floats."""
    with history.open() as f:
        return [{k: float(v) for k, v in r.items()} for r in csv.DictReader(f)]


def progress_row(name: str, rows: list[dict], upto: float, window: tuple[float, float], load: float) -> dict:
    """What a run (finished or stopped) did up to ``upto`` m of travel: steps, Newton iterations,
    wall time; and its mean sinkage (m) over the steps at the load with travel in ``window``."""
    done = [r for r in rows if r["travel_m"] <= upto + 1e-9]
    held = [r["sinkage_m"] for r in rows
            if window[0] <= r["travel_m"] <= window[1] and r["QV_N"] >= 0.999 * load]
    return {"variant": name, "travel_m": max(r["travel_m"] for r in rows), "steps": len(done),
            "newton_iterations": int(sum(r["newton_iterations"] for r in done)),
            "time_s": done[-1]["wall_time_s"], "sinkage": sum(held) / len(held) if held else math.nan}


def progress_table(work: pathlib.Path, upto: float, window: tuple[float, float], load: float) -> str:
    """Markdown table of the run directories under ``work`` (one per variant, stopped ones
    included) compared over their first ``upto`` m of travel, with wall-time ratios to the first;
    ``load``: the scene's wheel load (N)."""
    lines = [f"| mesh | travel rolled | steps to {upto:g} m | Newton its | wall time to {upto:g} m | time / first | "
             f"mean sinkage, {window[0]:g}-{window[1]:g} m |", "|---|---|---|---|---|---|---|"]
    base = None
    for name in VARIANTS:
        history = run_directory(work, name) / "history.csv"
        if not history.exists():
            continue
        r = progress_row(name, read_history(history), upto, window, load)
        base = base or r["time_s"]
        lines.append(f"| {name} | {r['travel_m']:.2f} m | {r['steps']} | {r['newton_iterations']} | "
                     f"{r['time_s']:.0f} s | {r['time_s'] / base:.2f} | {1e3 * r['sinkage']:.2f} mm |")
    return "\n".join(lines)


def table(results: list[dict]) -> str:
    """Markdown table of the variants, with wall-time ratios to the first row of each scene."""
    lines = ["| scene | mesh | strain | cells | dofs | steps | Newton its | cuts | mean from 1 d (± std) | "
             "steady | wall time (ranks) | time / first |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    first: dict[str, float] = {}
    for r in results:
        base = first.setdefault(r["scene"], r["time_s"])
        steady = "not detected" if r["steady_sinkage"] is None else f"{1e3 * r['steady_sinkage']:.2f} mm"
        mean = (f"{1e3 * r['sinkage_mean']:.2f} ± {1e3 * r['sinkage_std']:.2f} mm" if r["status"] == "ok"
                else f"failed: {r['status']}")
        lines.append(f"| {r['scene']} | {r['variant']} | {r['strain']} | {r['cells']} | {r['dofs']} | {r['steps']} | "
                     f"{r['newton_iterations']} | {r['cuts']} | {mean} | {steady} | {r['time_s']:.0f} s "
                     f"({r['ranks']}) | {r['time_s'] / base:.2f} |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", type=pathlib.Path, default=SCENE, help="a rolling-constant-load scene (TOML)")
    p.add_argument("--variant", nargs="+", choices=list(VARIANTS), default=list(VARIANTS)[:3],
                   help="the mesh variants to run, in order (default: all but standard)")
    p.add_argument("--work", type=pathlib.Path, default=None,
                   help="keep the run directories here (default: a temporary directory); a killed variant "
                        "continues from its checkpoint")
    p.add_argument("--progress", nargs=3, type=float, metavar=("UPTO", "FROM", "TO"),
                   help="with --work: compare the run directories there (stopped runs too) over their "
                        "first UPTO m of travel, the mean sinkage over FROM-TO m, and stop")
    add_results_arguments(p)
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    setup_logging(comm)
    if args.progress:
        if args.work is None:
            p.error("--progress needs --work")
        if comm.rank == 0:
            upto, a, b = args.progress
            print(progress_table(args.work, upto, (a, b), load_scene(args.scene).loading.load))
        return 0
    if args.table:
        return show_table(comm, table, saved_results(args.table))
    results = saved_results(args.out)
    done = {(r["scene"], r["variant"]) for r in results}
    if load_scene(args.scene).loading.protocol != "rolling-constant-load":
        raise SystemExit(f"{args.scene}: loading.protocol must be rolling-constant-load")
    with tempfile.TemporaryDirectory() as tmp:
        work = args.work or pathlib.Path(comm.bcast(tmp if comm.rank == 0 else None))
        for name in args.variant:
            if (args.scene.name, name) in done:
                continue
            results.append(run_variant(comm, args.scene, name, work))
            dump_json(comm, args.out, {"results": results})
            if comm.rank == 0:
                print(table(results), flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
