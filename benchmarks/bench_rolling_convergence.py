"""Mesh convergence of the constant-load steady sinkage, for both volumetric strains.

    python -m benchmarks rolling_convergence --soil clay --refinement 8 10 12 \\
        --out benchmarks/results/rolling_convergence_clay.json
    python -m benchmarks rolling_convergence --soil case5 --refinement 8 10 12 \\
        --out benchmarks/results/rolling_convergence_case5.json
    python -m benchmarks rolling_convergence --table benchmarks/results/rolling_convergence_*.json

Scenes (Mn/DOT roller, d = 1.524 m, b = 0.4572 m, towed at constant load on a half block of
2.6 x 0.8 x 0.8 d with a 0.5 d stiff start zone, as ``bench_rolling_protocols.py``):

* ``clay``: von Mises q_y = 300 kPa, 100 kN, mu = 0;
* ``case2``: the clay of report case 2, von Mises q_y = 200 kPa, 133.5 kN, mu = 0.8;
* ``case5``: Drucker-Prager phi_dp = 27.5 deg, c_dp = 194.6 kPa (psi = 0), 133.5 kN, mu = 0.8;
* ``sand``: the dense sand of layered case 13, Drucker-Prager phi_dp = 61.6 deg, c_dp = 18.5 kPa
  (psi = 0, a steep non-associated cone), 133.5 kN, mu = 0.8.

Each level is ``--refinement`` elements per diameter under the wheel (the presets are 8 / 20 / 50).
The scored sinkage of a (soil, strain, block) is the steady sinkage at the detected steady state
when every level of it reached one, else the mean over the rolled steps from 1 d of travel on (the
steady-state test's one-contact-length window does not average out the coarse levels'
element-passing ripple; the mean mixes in the approach when the wheel settles late).  For each
strain it is extrapolated from the three finest levels (Richardson, with
the observed order from the generalised three-level formula of Celik et al., J. Fluids Eng. 130
(2008) 078001); a level's error is against that value.  Prints a Markdown table (``--table``
rebuilds it from saved JSON files without solving; with ``--figure`` it also draws the sinkage along
the travel of every level).  ``--relaxation-length`` (mm) runs the levels with a Duvaut-Lions
regularisation along the whole path, ``--fallbacks`` relaxes only the steps that fail, as a plain
``rollsim run`` scene does, ``--length`` / ``--travel`` (d) on a longer block (both kept apart in
the table), ``--path-refinement`` / ``--cross-refinement`` / ``--depth-refinement`` on hexahedra
shorten the refined strip's elements along / across the path or in depth only (at 6-10 per d the
contact arc is one or two elements long and the wheel's half width one or two elements wide),
``--travel-step`` (mm) rolls with fixed steps instead of the solver's (kept apart in the table).
Each level keeps its sinkage along the travel (``travel_sinkage``); ``--progress`` prints a line
per rolled step on stderr.  An existing ``--out`` file is resumed: the levels it holds are not
solved again.
"""
from __future__ import annotations

import argparse
import math
import pathlib
import re

import numpy as np
from mpi4py import MPI

import bench_rolling_protocols as protocols
from _bench import ORDER_RANGE, add_results_arguments, dump_json, observed_order, saved_results, show_table

from rollsim.log import setup_logging
from rollsim.solver.options import VOLUMETRIC_STRAINS

SOILS = {"clay": ["--yield-stress", "300", "--load", "100", "--mu", "0"],
         "case2": ["--yield-stress", "200", "--load", "133.5", "--mu", "0.8"],
         "case5": ["--yield-stress", "194.6", "--phi-dp", "27.5", "--load", "133.5", "--mu", "0.8"],
         "sand": ["--yield-stress", "18.5", "--phi-dp", "61.6", "--load", "133.5", "--mu", "0.8"]}
#: block length and constant-load travel (in d) of the study's levels
LENGTH, TRAVEL = 2.6, 1.5
#: how a plain scene's travel fallback relaxes a roll (``--fallbacks``)
FALLBACK_ROUTE = "started over relaxed"
#: values of the run keys that results saved before the key existed were run with
DEFAULTS = {"relaxation_length_mm": 0.0, "fallbacks": False, "block_length_d": LENGTH, "travel_d": TRAVEL,
            "cell_type": "tetrahedra", "travel_step_mm": 0.0, **dict.fromkeys(protocols.SHORTER, 1.0)}
SHORTER = protocols.SHORTER


def block_args(length: float = LENGTH, travel: float = TRAVEL) -> list[str]:
    """The half block (``length`` x 0.8 x 0.8 d, 0.5 d stiff start zone) and the travel, as
    arguments of ``bench_rolling_protocols.py``."""
    return ["--length", f"{length:g}", "--half-width", "0.8", "--depth", "0.8", "--stiff", "0.5",
            "--cl-travel", f"{travel:g}"]


def level_args(soil: str, refinement: float, strain: str, relaxation_length: float = 0.0,
               block: list[str] | None = None, fallbacks: bool = False, hexahedra: bool = False,
               refinements: dict[str, float] | None = None, progress: bool = False, travel_step: float = 0.0):
    """The constant-load run of ``soil`` at ``refinement`` elements per d on ``block`` (arguments of
    ``bench_rolling_protocols.py``; default :func:`block_args`; ``refinements``: the anisotropic
    mesh fields by name; ``progress``: a line per rolled step; ``travel_step``: mm, 0 for the
    solver's default), as parsed arguments."""
    return protocols.parser().parse_args(SOILS[soil] + (block or block_args()) + [
        "--refinement", f"{refinement:g}", "--volumetric-strain", strain, "--skip-continuous",
        "--relaxation-length", f"{relaxation_length:g}", "--travel-step", f"{travel_step:g}"]
        + [a for k, v in (refinements or {}).items() for a in (f"--{k.replace('_', '-')}", f"{v:g}")]
        + ["--fallbacks"] * fallbacks + ["--hexahedra"] * hexahedra + ["--progress"] * progress)


def keep_travel_sinkage(cl: dict) -> dict:
    """A constant-load result with its curve replaced by the sinkage along the travel (m, m):
    where a level settles, or whether it drifts."""
    cl["travel_sinkage"] = [[round(x, 5), round(s, 7)] for x, s, _, _ in cl.pop("curve")]
    return cl


def sinkage(r: dict) -> float | None:
    """The mean sinkage of a run over the rolled steps from 1 d of travel on (m; defined whether or
    not the steady-state test passed)."""
    st = r.get("settled")
    return st["sinkage_mean"] if st else None


def scorer(rows: list[dict]):
    """``(name, sinkage of a run)`` scored for the levels ``rows`` of one (soil, strain, block): the
    steady sinkage when every level detected its steady state, else the mean from 1 d."""
    if rows and all(r.get("steady") for r in rows):
        return "steady", lambda r: r["s_cl"]
    return "mean from 1 d", sinkage


def formulation(r: dict) -> str:
    """The strain of a run, with its relaxation length and its block when they are not the
    study's default."""
    ell = r.get("relaxation_length_mm", 0.0)
    text = f"{r['strain']}, {ell:g} mm relaxation" if ell else r["strain"]
    route = r.get("fallbacks")
    if route:       # True: saved when a failed roll was relaxed over 0.1 d stretches only
        text += ", fallbacks over 0.1 d stretches" if route is True else f", fallback {route}"
    if r.get("cell_type", "tetrahedra") == "hexahedra":
        text += ", Q2-P1 hexahedra" if r["strain"] == "cell-average" else ", Q2 hexahedra"
    for name, axis in SHORTER.items():
        if r.get(name, 1.0) != 1.0:
            text += f", {r[name]:g}x finer {axis}"
    length, travel = r.get("block_length_d", LENGTH), r.get("travel_d", TRAVEL)
    if (length, travel) != (LENGTH, TRAVEL):
        text += f", {length:g} d block, {travel:g} d travel"
    if r.get("travel_step_mm", 0.0):
        text += f", {r['travel_step_mm']:g} mm steps"
    return text


def remarks(r: dict) -> list[str]:
    """What the table's row of level ``r`` does not show: a failure (the level is not scored), the
    stretches of travel its fallback relaxed and where a roll started over, a rut that is a heave."""
    out = []
    if r.get("status", "ok") != "ok":
        reached = f" after {r['travel_sinkage'][-1][0]:.2f} m of travel" if r.get("travel_sinkage") else ""
        out.append(f"failed{reached}, not scored ({r['steps']} steps, {r['newton_iterations']} Newton its, "
                   f"{r['time_s']:.0f} s)")
    if r.get("relaxed_travel"):
        length = sum(b - a for a, b in r["relaxed_travel"])
        out.append(f"{len(r['relaxed_travel'])} stretch(es) relaxed, {length:.2f} m of travel")
    for failed in r.get("travel_failures", []):
        out.append(f"the rate-independent roll failed after {failed:.2f} m and started over relaxed")
    if r.get("lift_failure"):
        out.append("the lift-off failed, the rut is not measured")
    if (r.get("rut_depth") or 0.0) < 0:     # None: the travel left no rut to measure
        out.append(f"the rut is a heave of {-1e3 * r['rut_depth']:.1f} mm")
    return out


#: starts (d of travel) of the windows whose mean sinkage the table compares on long travels
WINDOWS = (1.0, 2.0, 2.5)


def rolled(r: dict) -> tuple[np.ndarray, np.ndarray]:
    """The travel (m) and sinkage (m) of the rolled steps a level kept (``travel_sinkage``): not
    the press, not the lift-off."""
    x, s = np.array(r.get("travel_sinkage") or [], dtype=float).reshape(-1, 2).T
    _, first = np.unique(x, return_index=True)
    first = np.sort(first[x[first] > 0])
    return x[first], s[first]


def window_means(r: dict, starts=WINDOWS) -> list[float | None]:
    """Mean sinkage (m) of the rolled steps from each of ``starts`` (d of travel) on (None: fewer
    than 3 steps there): does the order of the levels depend on how much of the approach the
    mean takes in?"""
    x, s = rolled(r)
    late = [x >= a * protocols.D for a in starts]
    return [float(s[on].mean()) if on.sum() >= 3 else None for on in late]


def groups(results: list[dict]) -> dict[tuple[str, str], list[dict]]:
    """The levels of ``results`` by (soil, strain with its relaxation, fallback and block), sorted."""
    out: dict[tuple[str, str], list[dict]] = {}
    for r in results:
        out.setdefault((r["soil"], formulation(r)), []).append(r)
    return dict(sorted(out.items(), key=lambda item: (item[0][0], _natural(item[0][1]))))


def _natural(label: str) -> list:
    """Sort key of a label with its numbers by value ("8x" before "16x")."""
    return [(0, float(t), "") if t.replace(".", "", 1).isdigit() else (1, 0.0, t)
            for t in re.split(r"(\d+(?:\.\d+)?)", label)]


def table(results: list[dict]) -> str:
    """Markdown table of the levels of each (soil, strain): sinkage, change against the next
    coarser level, error against the extrapolated value, cost."""
    lines = ["| soil | strain | elements / d | dofs | mean from 1 d (± std) | steady sinkage | scored "
             "| change vs coarser | error vs extrapolated | steps | Newton its | cuts | wall time (ranks) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    notes = []
    for key, group in groups(results).items():
        rows = sorted((r for r in group if r.get("status", "ok") == "ok" and sinkage(r)),
                      key=lambda r: -r["refinement"])
        notes += [f"{key[0]}, {key[1]}, {r['refinement']:g} elements / d: {remark}"
                  for r in sorted(group, key=lambda r: r["refinement"]) for remark in remarks(r)]
        scored, score = scorer(rows)
        fit = None
        if len(rows) >= 3:
            fit = observed_order([1 / r["refinement"] for r in rows[:3]], [score(r) for r in rows[:3]])
        if fit and not ORDER_RANGE[0] <= fit[0] <= ORDER_RANGE[1]:
            notes.append(f"{key[0]}, {key[1]}: observed order {fit[0]:.2f}, outside {ORDER_RANGE[0]:g}-"
                         f"{ORDER_RANGE[1]:g}: the levels are not in the asymptotic range, no extrapolation")
            fit = None
        elif fit:
            notes.append(f"{key[0]}, {key[1]}: observed order {fit[0]:.2f}, extrapolated sinkage {1e3 * fit[1]:.2f} mm")
        elif len(rows) >= 3:
            notes.append(f"{key[0]}, {key[1]}: the three finest levels do not converge monotonically")
        windows = {r["refinement"]: window_means(r) for r in rows}
        if len(rows) >= 2 and all(None not in w for w in windows.values()):
            means = "; ".join(f"{n:g} / d: " + " / ".join(f"{1e3 * m:.2f}" for m in w)
                              for n, w in sorted(windows.items()))
            notes.append(f"{key[0]}, {key[1]}: mean sinkage from {' / '.join(f'{a:g}' for a in WINDOWS)} d "
                         f"of travel (mm): {means}")
        for r in sorted(rows, key=lambda r: r["refinement"]):
            coarser = [c for c in rows if c["refinement"] < r["refinement"]]
            change = f"{100 * (score(r) / score(coarser[0]) - 1):+.1f} %" if coarser else ""
            err = f"{100 * (score(r) / fit[1] - 1):+.1f} %" if fit else ""
            steady = f"{1e3 * r['s_cl']:.2f} mm" if r.get("steady") else "not detected"
            lines.append(f"| {key[0]} | {key[1]} | {r['refinement']:g} | {r['dofs']} "
                         f"| {1e3 * sinkage(r):.2f} ± {1e3 * r['settled']['sinkage_std']:.2f} mm "
                         f"| {steady} | {scored} "
                         f"| {change} | {err} | {r['steps']} "
                         f"| {r['newton_iterations']} | {r['cuts']} | {r['time_s']:.0f} s ({r['ranks']}) |")
    return "\n".join(lines + [""] + [f"- {n}" for n in notes])


def travel_figure(path: pathlib.Path, results: list[dict]) -> bool:
    """Sinkage along the travel of every level that kept it (``travel_sinkage``), one panel per
    (soil, strain): where each level settles, or whether it drifts.  False: no level kept it."""
    kept = {key: [r for r in group if r.get("travel_sinkage")] for key, group in groups(results).items()}
    kept = {key: group for key, group in kept.items() if group}
    if not kept:
        return False
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    cols = min(3, len(kept))
    rows = -(-len(kept) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.0 * rows), squeeze=False)
    for ax, (key, group) in zip(axes.flat, kept.items()):
        for r in sorted(group, key=lambda r: r["refinement"]):
            x, s = rolled(r)
            ax.plot(x / protocols.D, 1e3 * s, lw=1, label=f"{r['refinement']:g} / d")
        ax.set_title(f"{key[0]}, {key[1]}", fontsize=8)
        ax.set_xlabel("travel / d", fontsize=8)
        ax.set_ylabel("sinkage (mm)", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=7)
    for ax in axes.flat[len(kept):]:
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--soil", choices=sorted(SOILS), default="clay")
    p.add_argument("--refinement", type=float, nargs="+", default=[8.0, 10.0, 12.0])
    p.add_argument("--volumetric-strain", choices=VOLUMETRIC_STRAINS, nargs="+", default=list(VOLUMETRIC_STRAINS))
    p.add_argument("--relaxation-length", type=float, default=0.0,
                   help="Duvaut-Lions relaxation length of the soil, mm of travel (0: off)")
    p.add_argument("--fallbacks", action="store_true",
                   help="relax a failed step as a plain rollsim run scene does (kept apart in the table)")
    p.add_argument("--length", type=float, default=LENGTH, help="block length, d (kept apart in the table)")
    p.add_argument("--travel", type=float, default=TRAVEL, help="constant-load travel limit, d")
    p.add_argument("--hexahedra", action="store_true",
                   help="structured 27-node hexahedra (B-bar: Q2-P1; kept apart in the table)")
    p.add_argument("--travel-step", type=float, default=0.0,
                   help="travel step, mm (0: the solver's default; kept apart in the table)")
    for name, axis in SHORTER.items():
        p.add_argument(f"--{name.replace('_', '-')}", type=float, default=1.0,
                       help=f"with --hexahedra: the refined strip's elements this many times shorter {axis} "
                            "(kept apart in the table)")
    add_results_arguments(p)
    p.add_argument("--progress", action="store_true",
                   help="one line per rolled step on stderr (travel, sinkage, forces, time left)")
    p.add_argument("--figure", type=pathlib.Path,
                   help="with --table: draw the sinkage along the travel of every level to this file")
    args = p.parse_args(argv)
    for name in SHORTER:
        if getattr(args, name) != 1.0 and not args.hexahedra:
            p.error(f"--{name.replace('_', '-')} needs --hexahedra")
    refinements = {name: getattr(args, name) for name in SHORTER}
    comm = MPI.COMM_WORLD
    setup_logging(comm, quiet=not args.progress)
    if args.table:
        if comm.rank == 0:
            results = saved_results(args.table)
            print(table(results))
            if args.figure and not travel_figure(args.figure, results):
                print(f"{args.figure}: not drawn, no level kept its sinkage along the travel")
        return 0
    results = saved_results(args.out)
    for strain in args.volumetric_strain:
        for n in args.refinement:
            run = {"soil": args.soil, "strain": strain, "refinement": n,
                   "relaxation_length_mm": args.relaxation_length, "fallbacks": args.fallbacks and FALLBACK_ROUTE,
                   "block_length_d": args.length, "travel_d": args.travel,
                   "cell_type": "hexahedra" if args.hexahedra else "tetrahedra",
                   "travel_step_mm": args.travel_step, **refinements}
            if any(all(r.get(k, DEFAULTS.get(k, 0.0)) == v for k, v in run.items()) for r in results):
                if comm.rank == 0:
                    print(f"{formulation(run)}, {n:g} elements / d: in {args.out}, not solved again", flush=True)
                continue
            level = level_args(args.soil, n, strain, args.relaxation_length, block_args(args.length, args.travel),
                               args.fallbacks, args.hexahedra, refinements, args.progress, args.travel_step)
            cl = keep_travel_sinkage(protocols.constant_load(comm, level.mu[0], level))
            results.append({**run, "ranks": comm.size, **cl})
            if comm.rank == 0:
                s = sinkage(cl)
                print(f"{args.soil}, {formulation(run)}, {n:g} elements / d: {cl['status']}, "
                      f"steady {cl.get('steady')}, "
                      f"s = {1e3 * (s if s else math.nan):.2f} mm, {cl['dofs']} dofs, "
                      f"{cl['newton_iterations']} Newton its, {cl['time_s']:.0f} s", flush=True)
            dump_json(comm, args.out, {"args": vars(args), "results": results})
    return show_table(comm, table, results)


if __name__ == "__main__":
    raise SystemExit(main())
