"""Cost of retrying a failed rolling step with the wheel's pose held, against cutting it at once.

    python -m benchmarks pose_retry --soil case5 --refinement 6 --hexahedra --relaxation-length 0.5 \
        --volumetric-strain cell-average --out benchmarks/results/pose_retry.json
    python -m benchmarks pose_retry --soil clay --refinement 6 --hexahedra \
        --volumetric-strain cell-average --out benchmarks/results/pose_retry.json
    python -m benchmarks pose_retry --soil case2 --refinement 6 --hexahedra \
        --volumetric-strain pointwise --out benchmarks/results/pose_retry.json
    python -m benchmarks pose_retry --table benchmarks/results/pose_retry.json

A constant-load level of ``bench_rolling_convergence.py`` runs twice in one process: with the
step's bordered Newton solve retried, when it fails, with the pose held until the soil has
converged (``WheelRolling.POSE_HOLDS = (0.1, 0.0)``), and with the step cut at once (the
default, ``(0.1,)``).  Prints Newton iterations (failed attempts included), steps and cuts,
wall time and the sinkage of each, and their ratios.  An existing ``--out`` file is resumed: the
runs it holds are not solved again.
"""
from __future__ import annotations

import argparse
import math

from mpi4py import MPI

import bench_rolling_convergence as convergence
import bench_rolling_protocols as protocols
from _bench import add_results_arguments, dump_json, saved_results, show_table

from rollsim.log import setup_logging
from rollsim.solver.options import VOLUMETRIC_STRAINS
from rollsim.solver.rolling import WheelRolling

#: the variants compared: name -> ``WheelRolling.POSE_HOLDS``
VARIANTS = {"retried with the pose held": (0.1, 0.0), "cut at once": WheelRolling.POSE_HOLDS}
#: the keys that name one level
LEVEL_KEYS = ("soil", "strain", "refinement", "relaxation_length_mm", "cell_type")


def _mm(value) -> str:
    return "-" if value is None else f"{1e3 * value:.2f} mm"


def table(results: list[dict]) -> str:
    """Markdown table: each level's two variants side by side and the ratio of their costs."""
    lines = ["| level | variant | Newton its | steps / cuts | wall time | mean from 1 d | steady |",
             "|---|---|---|---|---|---|---|"]
    notes = []
    levels: dict[tuple, dict[str, dict]] = {}
    for r in results:
        levels.setdefault(tuple(r[k] for k in LEVEL_KEYS), {})[r["variant"]] = r
    for key, runs in levels.items():
        name = f"{key[0]}, {convergence.formulation(next(iter(runs.values())))}, {key[2]:g} / d"
        for variant, r in ((v, runs[v]) for v in VARIANTS if v in runs):
            lines.append(f"| {name} | {variant} | {r['newton_iterations']} | "
                         f"{r['steps']} / {r['cuts']} | {r['time_s']:.0f} s | {_mm(convergence.sinkage(r))} | "
                         f"{_mm(r['s_cl']) if r.get('steady') else 'not detected'} |")
        old, new = (runs.get(v) for v in VARIANTS)
        if old and new and new["newton_iterations"] and convergence.sinkage(old) and convergence.sinkage(new):
            notes.append(f"- {name}: {old['newton_iterations'] / new['newton_iterations']:.2f}x fewer Newton "
                         f"iterations, {old['time_s'] / new['time_s']:.2f}x less wall time, mean sinkage "
                         f"{100 * (convergence.sinkage(new) / convergence.sinkage(old) - 1):+.1f} %")
    return "\n".join(lines + [""] + notes)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--soil", choices=sorted(convergence.SOILS), default="case5")
    p.add_argument("--refinement", type=float, default=6.0)
    p.add_argument("--volumetric-strain", choices=VOLUMETRIC_STRAINS, default="cell-average")
    p.add_argument("--relaxation-length", type=float, default=0.0,
                   help="Duvaut-Lions relaxation length of the soil, mm of travel (0: off)")
    p.add_argument("--hexahedra", action="store_true", help="structured 27-node hexahedra (B-bar: Q2-P1)")
    p.add_argument("--progress", action="store_true", help="one line per rolled step on stderr")
    add_results_arguments(p)
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    setup_logging(comm, quiet=not args.progress)
    if args.table:
        return show_table(comm, table, saved_results(args.table))
    results = saved_results(args.out)
    level = {"soil": args.soil, "strain": args.volumetric_strain, "refinement": args.refinement,
             "relaxation_length_mm": args.relaxation_length,
             "cell_type": "hexahedra" if args.hexahedra else "tetrahedra"}
    level_args = convergence.level_args(args.soil, args.refinement, args.volumetric_strain, args.relaxation_length,
                                        hexahedra=args.hexahedra, progress=args.progress)
    default_holds = WheelRolling.POSE_HOLDS
    try:
        for variant, holds in VARIANTS.items():
            run = {**level, "variant": variant}
            if any(all(r.get(k) == v for k, v in run.items()) for r in results):
                continue
            WheelRolling.POSE_HOLDS = holds
            cl = convergence.keep_travel_sinkage(protocols.constant_load(comm, level_args.mu[0], level_args))
            results.append({**run, "ranks": comm.size, **cl})
            if comm.rank == 0:
                s = convergence.sinkage(cl)
                print(f"{variant}: {cl['status']}, s = {1e3 * (s if s else math.nan):.2f} mm, "
                      f"{cl['newton_iterations']} Newton its, {cl['time_s']:.0f} s", flush=True)
            dump_json(comm, args.out, {"args": vars(args), "results": results})
    finally:
        WheelRolling.POSE_HOLDS = default_holds
    return show_table(comm, table, results)


if __name__ == "__main__":
    raise SystemExit(main())
