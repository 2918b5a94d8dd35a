"""The soil meshes: size and build time per preset, and the block's size; two problems.

``presets``: mesh build time and size per accuracy preset:

    python -m benchmarks mesh presets [fast standard accurate]

Run under mpirun to include the distribution cost; rank 0 prints one line per case.

``block``: how large the soil block must be: the answer against the block's size at a fixed element size.

    python -m benchmarks mesh block --scene rolling-case5 --refinement 8 \\
        --block 2.6:0.8:0.8:0.3:0.4 2.6:0.8:0.8:0.2:0.25 2.6:1.5:1.5:0.3:0.4 2.6:2.2:2.2:0.3:0.4
    python -m benchmarks mesh block --scene indentation-vm --refinement 16 \\
        --block 0.75:0.75 1:1 1.5:1.5 2.5:2.5
    python -m benchmarks mesh block --table

Scenes (as ``python -m benchmarks speed_accuracy``):

* ``indentation-vm``: report case 2 (von Mises, mu = 0.8, gravity, B-bar), quarter block, Q_V at
  s/d = 0.02, 0.05 and 0.08; a block is ``HALF_SIZE:DEPTH`` in d (the refined zone stays the
  0.25 d x 0.5 d box under the wheel);
* ``rolling-case5``: towed at 133.5 kN on the case-5 soil (pointwise strain), the mean sinkage from
  1 d of travel on; a block is ``LENGTH:HALF_WIDTH:DEPTH:STRIP_HALF_WIDTH:STRIP_DEPTH`` in d (the
  last two: the refined strip along the wheel's path).

Every run is kept in ``--results`` (one JSON file); a (scene, level, block) found there is not
run again.  The table gives each block's dofs, Newton iterations, wall time and its answer against
the largest block of the same scene and level.
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys
import time

from mpi4py import MPI

from _bench import dump_json, run_problems

from rollsim.geometry import (MeshOptions, build_soil_block, build_tire, indentation_block, pneumatic_tire,
                              rolling_block)

CASES = {
    "indentation quarter, tetrahedra": lambda comm, o: build_soil_block(comm, indentation_block(1.0), o),
    "rolling half, 2 layers, tetrahedra": lambda comm, o: build_soil_block(comm, rolling_block(1.0, layers=(0.3,)), o),
    "rolling half, 2 layers, hexahedra": lambda comm, o: build_soil_block(
        comm, rolling_block(1.0, layers=(0.3,)), MeshOptions(o.fine_size, o.coarse_size, o.transition, o.order, True)),
    "tire half, hexahedra": lambda comm, o: build_tire(
        comm, pneumatic_tire(1.0), MeshOptions(o.fine_size, o.coarse_size, o.transition, o.order, True)),
}


def presets(argv: list[str] | None = None) -> int:
    comm = MPI.COMM_WORLD
    for accuracy in argv or ["fast", "standard"]:
        options = MeshOptions.from_accuracy(1.0, accuracy)
        for name, build in CASES.items():
            comm.barrier()
            start = time.perf_counter()
            stats = build(comm, options).stats
            elapsed = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
            if comm.rank == 0:
                print(f"{accuracy:9s} {name:38s} {stats.cells:8d} cells {stats.nodes:8d} nodes "
                      f"minSJ {stats.quality.min_scaled_jacobian:5.3f} {elapsed:7.2f} s", flush=True)
    return 0


HERE = pathlib.Path(__file__).resolve().parent
RESULTS = HERE / "results" / "block_size.json"
SCENES = ("indentation-vm", "rolling-case5")
BLOCK_FIELDS = {"indentation-vm": 2, "rolling-case5": 5}


def parse_block(scene: str, text: str) -> tuple[float, ...]:
    """The block of ``scene`` from its ``A:B:...`` form (multiples of d)."""
    try:
        values = tuple(float(v) for v in text.split(":"))
    except ValueError:
        values = ()
    if len(values) != BLOCK_FIELDS[scene] or not all(v > 0 for v in values):
        raise ValueError(f"--block: {text!r} is not {BLOCK_FIELDS[scene]} positive numbers separated by ':' "
                         f"for {scene}")
    return values


def run(comm, scene: str, refinement: float, block: tuple[float, ...]) -> dict:
    """One run of ``scene`` on ``block``: its cost and its answer (``value``: Q_V at s/d = 0.08 in N,
    or the mean rolled sinkage in m)."""
    t0 = time.perf_counter()
    if scene == "indentation-vm":
        import bench_indentation as indentation
        from rollsim.geometry import indentation_block
        half_size, depth = block
        mat, d, b, gamma, mu = indentation.case_soil(2)[:5]
        res = indentation.run(comm, f"{refinement:g}", mat, d, b, gamma, mu, s_end=0.08,
                              volumetric_strain="cell-average",
                              block=indentation_block(d, half_size=half_size, depth=depth))
        readings = {r: res["QV"].get(r) for r in ("0.02", "0.05", "0.08")}
        out = {"value": readings["0.08"], "readings": readings, "cells": res["cells"]}
    else:
        import bench_rolling as rolling
        length, half_width, depth, strip, strip_depth = block
        args = rolling.level_args("case5", refinement, "pointwise", block=[
            "--length", f"{length:g}", "--half-width", f"{half_width:g}", "--depth", f"{depth:g}",
            "--stiff", "0.5", "--cl-travel", "1.5", "--path-half-width", f"{strip:g}",
            "--refined-depth", f"{strip_depth:g}"])
        res = rolling.constant_load(comm, args.mu[0], args)
        res.pop("curve")
        out = {"value": rolling.sinkage(res), "std": (res.get("settled") or {}).get("sinkage_std")}
    return {"scene": scene, "refinement": refinement, "block": list(block), "ranks": comm.size,
            "status": res["status"], "dofs": res["dofs"], "steps": res["steps"],
            "newton_iterations": res["newton_iterations"],
            "time_s": comm.allreduce(time.perf_counter() - t0, op=MPI.MAX), **out}


def table(runs: list[dict]) -> str:
    """Markdown table: per (scene, level), each block against the largest one."""
    lines = ["| scene | elements / d | block (d) | dofs | answer | vs largest block | Newton its | wall time (ranks) |",
             "|---|---|---|---|---|---|---|---|"]
    for key in sorted({(r["scene"], r["refinement"]) for r in runs}):
        rows = sorted((r for r in runs if (r["scene"], r["refinement"]) == key), key=lambda r: r["dofs"])
        largest = rows[-1]
        for r in rows:
            if r["scene"] == "indentation-vm" and r.get("readings"):
                answer = " / ".join(f"{v / 1e3:.1f}" for v in r["readings"].values()) + " kN"
                change = " / ".join(f"{100 * (v / w - 1):+.1f}" for v, w in
                                    zip(r["readings"].values(), largest["readings"].values())) + " %"
            elif r.get("value"):
                answer = f"{1e3 * r['value']:.2f} ± {1e3 * r['std']:.2f} mm"
                change = f"{100 * (r['value'] / largest['value'] - 1):+.1f} %"
            else:
                answer, change = r["status"], ""
            lines.append(f"| {r['scene']} | {r['refinement']:g} | {' x '.join(f'{v:g}' for v in r['block'])} "
                         f"| {r['dofs']} | {answer} | {'' if r is largest else change} | {r['newton_iterations']} "
                         f"| {r['time_s']:.0f} s ({r['ranks']}) |")
    return "\n".join(lines)


def block_size(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks mesh block",
                                description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scene", choices=SCENES, default="rolling-case5")
    p.add_argument("--refinement", type=float, default=8.0, help="elements per d under the wheel")
    p.add_argument("--block", nargs="+", default=[], help="blocks to run (see above)")
    p.add_argument("--results", type=pathlib.Path, default=RESULTS)
    p.add_argument("--table", action="store_true", help="print the table of the saved runs and stop")
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    try:
        blocks = [parse_block(args.scene, b) for b in args.block]
    except ValueError as err:
        p.error(str(err))
    runs = json.loads(args.results.read_text())["runs"] if args.results.exists() else []
    for block in [] if args.table else blocks:
        if any(r["scene"] == args.scene and r["refinement"] == args.refinement and tuple(r["block"]) == block
               for r in runs):
            continue
        if comm.rank == 0:
            print(f"{args.scene}, {args.refinement:g} elements / d, block {block} ...", flush=True)
        runs.append(run(comm, args.scene, args.refinement, block))
        dump_json(comm, str(args.results), {"runs": runs})
    if comm.rank == 0:
        print(table(runs))
    return 0



if __name__ == "__main__":
    sys.exit(run_problems({"presets": presets, "block": block_size}, __doc__))
