"""What each mesh level costs and how wrong it is: the speed-accuracy trade of the presets.

    python -m benchmarks speed_accuracy --ranks 1 2          # run what is missing, then report
    python -m benchmarks speed_accuracy --report             # table and figure from the saved JSON
    mpirun -n 2 python -m benchmarks speed_accuracy --profile indentation-vm --refinement standard

Scenes (Mn/DOT roller, d = 1.524 m, b = 0.4572 m; each with the scene default volumetric strain
of its protocol on the fast preset, for every level, unless ``--volumetric-strain`` is given):

* ``indentation-vm``: report case 2 (von Mises, q_y = 200 kPa, mu = 0.8), quarter block, Q_V at
  s/d = 0.02, 0.05 and 0.08;
* ``indentation-dp``: report case 5 (Drucker-Prager phi_dp = 27.5 deg, c_dp = 194.6 kPa), same;
* ``rolling-case5``: towed at 133.5 kN on the case-5 soil, the sinkage of steady rolling (the
  scene and the measure of ``python -m benchmarks rolling convergence``);
* ``tire-indentation``: the pneumatic tire of ``examples/pneumatic_indentation.toml`` (inflated,
  then pressed into a clay; tire and soil meshed at the level's element size), Q_V at a sinkage
  of 10, 20 and 30 mm.

Each (scene, level, ranks) runs in its own ``mpirun`` process (wall time and peak memory of that
run alone) and is appended to ``--results`` (JSON, one file per scene); runs already there are not
repeated, so an interrupted sweep continues where it stopped.  ``--refinement``: levels as preset
names or elements per d under the wheel (fast = 8, standard = 20, accurate = 50).

The report takes the reference of each scene from Richardson extrapolation of its three finest
levels (the observed order from the three-level formula of Celik et al., J. Fluids Eng. 130 (2008)
078001; the finest level when that order is not between 0.5 and 4), prints a Markdown table (cost
and error per level) and the cheapest level per decision (screening 10 %, design 5 %,
verification 2 %), and draws the error against wall time (``--figure``).

``--profile SCENE``: one run under cProfile with the PETSc log on; prints the split of the wall
time (assembly, strain evaluation, return map, contact, linear solver, the rest) and writes the
PETSc ``-log_view`` report and the cProfile statistics next to ``--results``.
"""
from __future__ import annotations

import argparse
import cProfile
import json
import os
import pathlib
import pstats
import resource
import sys
import time

from _bench import run_in_mpirun

HERE = pathlib.Path(__file__).resolve().parent
RESULTS = HERE / "results"
FIGURE = HERE.parent / "docs" / "img" / "speed-accuracy.png"
SCENES = ("indentation-vm", "indentation-dp", "rolling-case5", "tire-indentation")
PRESETS = {"fast": 8.0, "standard": 20.0, "accurate": 50.0}
DEFAULT_LEVELS = ("fast", "12", "16", "standard")
DECISIONS = (("screening", 0.10), ("design", 0.05), ("verification", 0.02))
ERROR_FLOOR = 0.1                     # %, the figure's floor: smaller errors are ripple, not accuracy
S_READ = (0.02, 0.05, 0.08)            # s/d of the indentation readings; the last one is the scored one
TIRE_SCENE = HERE.parent / "examples" / "pneumatic_indentation.toml"
TIRE_READ = (0.01, 0.02, 0.03)         # m, sinkages of the tire's readings; the last one is the scored one


def level_value(level: str) -> float:
    """Elements per d of a level given as a preset name or a number."""
    if level in PRESETS:
        return PRESETS[level]
    try:
        n = float(level)
    except ValueError:
        raise argparse.ArgumentTypeError(f"--refinement: a preset ({', '.join(PRESETS)}) or elements per d, "
                                         f"got {level!r}") from None
    if not n > 0:
        raise argparse.ArgumentTypeError(f"--refinement: elements per d must be > 0, got {level!r}")
    return n


def level_name(n: float) -> str:
    names = {v: k for k, v in PRESETS.items()}
    return f"{n:g} ({names[n]})" if n in names else f"{n:g}"


def results_path(directory: pathlib.Path, scene: str) -> pathlib.Path:
    return directory / f"speed_accuracy_{scene}.json"


def load_results(path: pathlib.Path) -> list[dict]:
    return json.loads(path.read_text())["runs"] if path.exists() else []


# ---------------------------------------------------------------------------------------------- runs
def run_scene(comm, scene: str, refinement: float, volumetric_strain: str | None) -> dict:
    """One run of ``scene`` at ``refinement`` elements per d on ``comm``: the cost and the scored
    quantity (``value``: Q_V at s/d = 0.08 in N, or the steady sinkage in m)."""
    from mpi4py import MPI
    t0 = time.perf_counter()
    strain = scene_strain(scene, volumetric_strain)
    if scene.startswith("indentation"):
        import bench_indentation as indentation
        case = {"indentation-vm": 2, "indentation-dp": 5}[scene]
        mat, d, b, gamma, mu = indentation.case_soil(case)[:5]
        res = indentation.run(comm, str(refinement), mat, d, b, gamma, mu, s_end=S_READ[-1], volumetric_strain=strain)
        readings = {f"{r:g}": res["QV"].get(f"{r:g}") for r in S_READ}
        out = {"value": readings[f"{S_READ[-1]:g}"], "readings": readings, "linear_solves": res["newton_iterations"]}
    elif scene == "tire-indentation":
        res, out = tire_run(comm, refinement, strain)
    else:
        import bench_rolling as rolling
        args = rolling.level_args("case5", refinement, strain)
        res = rolling.constant_load(comm, args.mu[0], args)
        res.pop("curve")
        out = {"value": rolling.sinkage(res), "steady": res.get("steady"),
               "linear_solves": res.get("linear_solves", res["newton_iterations"])}
    peak = comm.allreduce(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, op=MPI.SUM) / 1024
    steps = max(res["steps"], 1)
    return {"scene": scene, "refinement": refinement, "ranks": comm.size, "volumetric_strain": strain,
            "status": res["status"], "cells": res.get("cells"), "dofs": res["dofs"], "steps": res["steps"],
            "newton_iterations": res["newton_iterations"], "iterations_per_step": res["newton_iterations"] / steps,
            "cuts": res["cuts"], "peak_memory_mb": peak,
            "time_s": comm.allreduce(time.perf_counter() - t0, op=MPI.MAX), **out}


def tire_run(comm, refinement: float, strain: str) -> tuple[dict, dict]:
    """The tire scene at ``refinement`` elements per d (tire and soil), run in a temporary
    directory: (the run's status and cost, its scored value and readings: Q_V (N) at the
    ``TIRE_READ`` sinkages, interpolated linearly between the steps of the force-sinkage curve)."""
    import csv
    import shutil
    import tempfile

    import numpy as np

    from rollsim.files import read_toml
    from rollsim.scene import parse_scene
    from rollsim.solver.run import run_scene
    data = read_toml(TIRE_SCENE, str(TIRE_SCENE))
    scene = parse_scene({**data, "model": data.get("model", {}) | {"refinement": refinement,
                                                                    "volumetric_strain": strain}})
    work = pathlib.Path(comm.bcast(tempfile.mkdtemp(prefix="rollsim-tire-") if comm.rank == 0 else None))
    summary = run_scene(scene, work, comm, progress=False, write_fields=False)
    readings = None
    if comm.rank == 0:
        with (work / "history.csv").open() as f:
            rows = [(float(r["sinkage_m"]), float(r["QV_N"])) for r in csv.DictReader(f)]
        s, q = np.array([0.0] + [r[0] for r in rows]), np.array([0.0] + [r[1] for r in rows])
        readings = {f"{r:g}": float(np.interp(r, s, q)) if s[-1] >= r else None for r in TIRE_READ}
        shutil.rmtree(work)
    readings = comm.bcast(readings)
    cost = {"status": summary["status"], "steps": summary["steps"], "newton_iterations": summary["newton_iterations"],
            "cuts": summary["step_cuts"], "dofs": summary["dofs"], "cells": summary["cells"]}
    return cost, {"value": readings[f"{TIRE_READ[-1]:g}"], "readings": readings,
                  "linear_solves": summary["linear_solves"]}


def sweep(args) -> int:
    """Run the missing (scene, level, ranks) combinations, each in its own process."""
    args.results.mkdir(parents=True, exist_ok=True)
    for scene in args.scene:
        path = results_path(args.results, scene)
        for ranks in args.ranks:
            for n in args.refinement:
                runs = load_results(path)
                if any(r["refinement"] == n and r["ranks"] == ranks and r["volumetric_strain"] == scene_strain(scene, args.volumetric_strain)
                       for r in runs):
                    continue
                print(f"{scene}, {level_name(n)} elements / d, {ranks} rank(s) ...", flush=True)
                one = args.results / f".{scene}-{n:g}-{ranks}.json"
                argv = [str(HERE / "bench_speed_accuracy.py"), "--one", scene, "--refinement", f"{n:g}", "--out", str(one)]
                if args.volumetric_strain:
                    argv += ["--volumetric-strain", args.volumetric_strain]
                run = run_in_mpirun(ranks, argv, one)
                if run is None:
                    continue
                path.write_text(json.dumps({"runs": load_results(path) + [run]}, indent=1))
                print(f"  {run['status']}: value {run['value']}, {run['dofs']} dofs, {run['time_s']:.0f} s, "
                      f"{run['peak_memory_mb']:.0f} MB", flush=True)
    return report(args)


def scene_strain(scene: str, volumetric_strain: str | None) -> str:
    """The volumetric strain of a scene's runs: the one given, else its protocol's scene default on
    the fast preset (one strain for every level of a sweep)."""
    from rollsim.presets import PRESETS
    if scene == "tire-indentation":
        return volumetric_strain or PRESETS["fast"].volumetric_strain("indentation", wheel="pneumatic")
    return volumetric_strain or PRESETS["fast"].volumetric_strain(
        "indentation" if scene.startswith("indentation") else "rolling-constant-load")


# ---------------------------------------------------------------------------------------------- report
def reference(runs: list[dict]) -> tuple[float, str, float | None] | None:
    """Reference value of one scene's runs (one rank count), its source, and the level it is taken
    from when it is not extrapolated: Richardson from the three finest levels, else the finest
    level (whose own error is then unknown)."""
    from _bench import ORDER_RANGE, observed_order
    ok = sorted((r for r in runs if r.get("value")), key=lambda r: -r["refinement"])
    if not ok:
        return None
    if len(ok) >= 3:
        fit = observed_order([1 / r["refinement"] for r in ok[:3]], [r["value"] for r in ok[:3]])
        if fit is not None and ORDER_RANGE[0] <= fit[0] <= ORDER_RANGE[1]:
            levels = ", ".join(f"{r['refinement']:g}" for r in ok[:3])
            return fit[1], f"Richardson from {levels} (order {fit[0]:.2f})", None
    return ok[0]["value"], f"finest level, {ok[0]['refinement']:g}: the three finest levels give no order in " \
        f"{ORDER_RANGE[0]:g}-{ORDER_RANGE[1]:g} to extrapolate with", ok[0]["refinement"]


def scored(runs: list[dict]) -> tuple[list[dict], str]:
    """Runs with their error against the scene's reference (from the runs on the fewest ranks:
    the values do not depend on the partition)."""
    ranks = min(r["ranks"] for r in runs)
    ref = reference([r for r in runs if r["ranks"] == ranks])
    if ref is None:
        return [], "no converged run"
    return [{**r, "error": (r["value"] / ref[0] - 1) if r.get("value") and r["refinement"] != ref[2] else None}
            for r in runs], f"reference {ref[0]:.6g} ({ref[1]})"


def table(scene: str, runs: list[dict], note: str) -> str:
    unit = {"tire-indentation": ("Q_V at s = 30 mm", 1e-3, "kN"),
            "rolling-case5": ("steady sinkage", 1e3, "mm")}.get(scene, ("Q_V at s/d = 0.08", 1e-3, "kN"))
    by_level = {}
    for r in runs:
        by_level.setdefault(r["refinement"], {})[r["ranks"]] = r
    ranks = sorted({r["ranks"] for r in runs})
    lines = [f"**{scene}** ({runs[0]['volumetric_strain']}; {unit[0]}; {note})", "",
             f"| elements / d | cells | dofs | {unit[0]} | error | steps | Newton its / step | linear solves "
             "| peak memory | " + " | ".join(f"wall time, {k} rank{'s' * (k > 1)}" for k in ranks) + " |",
             "|---" * (9 + len(ranks)) + "|"]
    for n in sorted(by_level):
        rr = by_level[n]
        r = rr.get(min(rr))
        val = f"{r['value'] * unit[1]:.2f} {unit[2]}" if r.get("value") else r["status"][:40]
        err = f"{100 * r['error']:+.1f} %" if r.get("error") is not None else ""
        times = " | ".join(f"{rr[k]['time_s']:.0f} s" if k in rr else "" for k in ranks)
        lines.append(f"| {level_name(n)} | {r.get('cells') or ''} | {r['dofs']} | {val} | {err} | {r['steps']} "
                     f"| {r['iterations_per_step']:.1f} | {r['linear_solves']} | {r['peak_memory_mb']:.0f} MB "
                     f"| {times} |")
    return "\n".join(lines)


def decisions(scene: str, runs: list[dict]) -> str:
    """Cheapest level (wall time on the most ranks run) whose error is within each decision's tolerance."""
    ranks = max(r["ranks"] for r in runs)
    cells = []
    for name, tol in DECISIONS:
        ok = [r for r in runs if r["ranks"] == ranks and r.get("error") is not None and abs(r["error"]) <= tol]
        best = min(ok, key=lambda r: r["time_s"], default=None)
        cells.append(f"{level_name(best['refinement'])}, {best['time_s']:.0f} s" if best else "finer than run")
    return f"| {scene} | " + " | ".join(cells) + " |"


def figure(path: pathlib.Path, scored_runs: dict[str, list[dict]]) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    fig, ax = plt.subplots(figsize=(6.4, 4.2))
    for scene, runs in scored_runs.items():
        for ranks, marker in ((1, "o"), (2, "s")):
            rr = sorted((r for r in runs if r["ranks"] == ranks and r.get("error")), key=lambda r: r["refinement"])
            if rr:
                err = [max(100 * abs(r["error"]), ERROR_FLOOR) for r in rr]
                ax.loglog([r["time_s"] for r in rr], err, marker=marker,
                          ls="-" if ranks == 1 else "--", label=f"{scene}, {ranks} rank{'s' * (ranks > 1)}")
                for r, e in zip(rr, err):
                    ax.annotate(f"{r['refinement']:g}", (r["time_s"], e), fontsize=7,
                                textcoords="offset points", xytext=(3, 3))
    for name, tol in DECISIONS:
        ax.axhline(100 * tol, color="grey", lw=0.6, ls=":")
        ax.text(ax.get_xlim()[0] if ax.lines else 1, 100 * tol, f" {name}", fontsize=7, va="bottom", color="grey")
    ax.set_xlabel("wall time (s)")
    ax.set_ylabel(f"|error| against the reference, % (at least {ERROR_FLOOR:g})")
    ax.set_title("Speed-accuracy trade (labels: elements per wheel diameter)", fontsize=9)
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def report(args) -> int:
    all_scored, parts = {}, []
    rows = ["| scene | screening (10 %) | design (5 %) | verification (2 %) |", "|---|---|---|---|"]
    for scene in args.scene:
        runs = load_results(results_path(args.results, scene))
        if not runs:
            continue
        sr, note = scored(runs)
        if not sr:
            parts.append(f"**{scene}**: {note}")
            continue
        all_scored[scene] = sr
        parts.append(table(scene, sr, note))
        rows.append(decisions(scene, sr))
    if not all_scored:
        print(f"no results under {args.results}")
        return 1
    print("\n\n".join(parts + ["\n".join(rows)]))
    if args.figure:
        figure(args.figure, all_scored)
        print(f"\nfigure: {args.figure}")
    return 0


# ---------------------------------------------------------------------------------------------- profile
#: (category, predicate on a cProfile function key (file, line, name))
CATEGORIES = (
    ("assembly", lambda f: f[0] == "~" and "dolfinx.cpp.fem" in f[2] and ("assemble" in f[2] or "lifting" in f[2])),
    ("strain evaluation", lambda f: f[2] == "evaluate_into"),
    ("return map", lambda f: f[2] == "_return_map"),
    ("contact (pose, forces)", lambda f: f[0].endswith(os.path.join("solver", "contact.py"))),
)


def profile_split(stats: pstats.Stats, petsc_linear: float, total: float) -> list[tuple[str, float]]:
    """Wall time per category: the time spent in calls entering a category from outside it (no
    double counting of nested calls); the linear solver from the PETSc log; the rest is Python
    and other overhead."""
    split = []
    for name, inside in CATEGORIES:
        t = 0.0
        for func, (_, _, _, _, callers) in stats.stats.items():
            if inside(func):
                t += sum(c[3] for caller, c in callers.items() if not inside(caller))
        split.append((name, t))
    split.append(("linear solver (set-up and solves)", petsc_linear))
    split.append(("other (Python, meshing, I/O)", total - sum(t for _, t in split)))
    return split


def profile(args) -> int:
    from mpi4py import MPI
    from petsc4py import PETSc
    comm = MPI.COMM_WORLD
    scene, n = args.profile, args.refinement[0]
    args.results.mkdir(parents=True, exist_ok=True)
    stem = args.results / f"profile_{scene}_{n:g}_{comm.size}"
    PETSc.Log.begin()
    prof = cProfile.Profile()
    t0 = time.perf_counter()
    prof.enable()
    run = run_scene(comm, scene, n, args.volumetric_strain)
    prof.disable()
    total = time.perf_counter() - t0
    linear = sum(PETSc.Log.Event(e).getPerfInfo()["time"] for e in ("PCSetUp", "KSPSolve"))  # disjoint events
    PETSc.Log.view(PETSc.Viewer.ASCII(f"{stem}.log_view.txt", comm=comm))
    stats = pstats.Stats(prof)
    if comm.rank == 0:
        stats.dump_stats(f"{stem}.pstats")
        split = profile_split(stats, linear, total)
        print(f"{scene}, {level_name(n)} elements / d, {comm.size} rank(s): {run['dofs']} dofs, {run['steps']} steps, "
              f"{run['newton_iterations']} Newton iterations, value {run['value']}, {total:.0f} s (rank 0)")
        print("| part | time | share |\n|---|---|---|")
        for name, t in split:
            print(f"| {name} | {t:.1f} s | {100 * t / total:.0f} % |")
        print(f"\nPETSc log: {stem}.log_view.txt; cProfile: {stem}.pstats")
    return 0


# ---------------------------------------------------------------------------------------------- CLI
def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scene", nargs="+", choices=SCENES, default=list(SCENES))
    p.add_argument("--refinement", nargs="+", type=level_value, default=[level_value(v) for v in DEFAULT_LEVELS],
                   help="levels: preset names or elements per d")
    p.add_argument("--ranks", nargs="+", type=int, default=[1, 2], help="MPI ranks of the runs")
    p.add_argument("--volumetric-strain", choices=("cell-average", "pointwise"),
                   help="default: the scene default of each protocol on the fast preset")
    p.add_argument("--results", type=pathlib.Path, default=RESULTS, help="directory of the JSON results")
    p.add_argument("--figure", type=pathlib.Path, default=FIGURE)
    p.add_argument("--report", action="store_true", help="only print the table and draw the figure")
    p.add_argument("--profile", choices=SCENES, help="profile one run of this scene at the first --refinement")
    p.add_argument("--one", choices=SCENES, help=argparse.SUPPRESS)      # one run, in the sweep's subprocess
    p.add_argument("--out", type=pathlib.Path, help=argparse.SUPPRESS)
    return p


def main(argv=None) -> int:
    args = parser().parse_args(argv)
    if args.one:
        from mpi4py import MPI
        comm = MPI.COMM_WORLD
        run = run_scene(comm, args.one, args.refinement[0], args.volumetric_strain)
        if comm.rank == 0:
            args.out.write_text(json.dumps(run, default=float))
        return 0
    if args.profile:
        return profile(args)
    if args.report:
        return report(args)
    if any(r < 1 for r in args.ranks):
        print("--ranks: at least 1", file=sys.stderr)
        return 2
    return sweep(args)


if __name__ == "__main__":
    raise SystemExit(main())
