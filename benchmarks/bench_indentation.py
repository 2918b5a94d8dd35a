"""Indentation of the 3D rigid wheel: report cases, c = 0 soil, kinematics, three problems.

``cases``: 3D rigid-wheel indentation (quarter model) for report cases: Q_V(s) to s/d = 0.1, presets compared.

    python -m benchmarks indentation cases --cases 2 5 --accuracy fast standard [accurate] --out bench_indentation.json
    python -m benchmarks indentation cases --c0 --accuracy fast standard     # c = 0, phi = 35/40/45 deg
    mpirun -n 2 python -m benchmarks indentation cases --cases 2 --accuracy standard accurate --s-end 0.05 \\
        --fixed-steps 4                                                       # standard vs accurate within 3 %
    mpirun -n 2 python -m benchmarks indentation cases --cases 2 --accuracy standard --s-end 0.05 \\
        --step 0.000625 --volumetric-strain cell-average                      # equal steps of 0.000625 s/d
    mpirun -n 2 python -m benchmarks indentation cases --solve-cost --accuracy standard accurate \\
        --linear-solver direct iterative                                      # cost of one solve

``--volumetric-strain cell-average``: B-bar (see docs/theory.md, "Volumetric strain: B-bar or pointwise").  ``--checkpoint DIR``:
the state is written whole at every reading stop (beside the previous one, then swapped in), and
the same command started again continues from the last complete one (the accurate preset's
hours-long runs over several sittings), on any number of ranks.

Prints Q_V at s/d = 0.02, 0.05, 0.1, the bearing-capacity model (indentation, D = s) with the
case's compression-matched (c, phi), steps, Newton iterations, cuts and wall time, and the
relative difference of each preset from the finest one run.  ``--linear-solver``: the Newton
iteration's linear solver (default "auto": MUMPS LU up to 100 000 dofs, GMRES + AMG above).

``frictional``: Purely frictional soil (c = 0) under the rigid wheel: 3D indentation to s/d = 0.1 against the
bearing-capacity model, and the sensitivity to the regularising cohesion c_reg or, with c = 0
exactly, to the Duvaut-Lions relaxation length (mm of sinkage).

    python -m benchmarks indentation frictional                       # phi 35 40 45, c_reg = 1 kPa
    python -m benchmarks indentation frictional --phi 40 --creg 2 1 0.5 --out bench_c0.json
    python -m benchmarks indentation frictional --phi 40 --creg 0 --max-wall 1800   # c = 0 exactly
    python -m benchmarks indentation frictional --phi 40 --creg 0 --relaxation-length 0 0.0078125 0.00390625

Setup: wheel d = 1.524 m, b = 0.4572 m (fillet b/12), mu = 0.8, quarter block at the
``fast`` preset, E = 40 MPa, nu = 0.35, gamma = 20 kN/m^3, K0 default (clipped into the cone),
Drucker-Prager matched to Mohr-Coulomb (c_reg, phi) in plane strain (``--match``), psi = 0,
penalty alpha = 1 (``--alpha``), gravity first.  Prints Q_V at s/d = 0.02 / 0.05 / 0.1 (FE and the
bearing-capacity model with c = 0, indentation mode), their ratio, steps, Newton iterations, step
cuts and wall time; with several relaxation lengths, their Q_V against the rate-independent run
and two extrapolations to L -> 0.  Serial; each run is stopped by a wall-clock guard
(``--max-wall``).

``kinematics``: Small strain against updated Lagrangian (incremental large deformation): where they differ.

    python -m benchmarks indentation kinematics --out bench_kinematics.json
    mpirun -n 2 python -m benchmarks indentation kinematics --s-end 0.15 --rolling

Soil: report case 2 (von Mises, q_y = ``--yield-stress`` kPa, E = ``--E`` MPa, nu = 0.35,
gamma = 20 kN/m^3); Mn/DOT roller wheel (d = 1.524 m, b = 0.4572 m, fillet b/12), ``--accuracy``.

1. Indentation (quarter block, mu = ``--mu``) to ``--s-end`` d, both kinematics, landing on the
   same sinkages: Q_V(s) and UL / small strain - 1.
2. With ``--rolling``: the continuous protocol (half block ``--length`` d long, frictionless
   unless ``--rolling-mu``), pressed to 0.005 d and rolled ``--travel`` d while the sinkage is
   ramped to ``--rolling-s-end`` d; mean Q_V and Q_H over bins of s/d = 0.01 compared.

Prints the tables and the smallest sinkage at which the two differ by more than 3 %.
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import pathlib
import sys
import time

import numpy as np
from mpi4py import MPI

from _bench import add_volumetric_strain, dump_json, run_problems

from rollsim.files import complete_directory
from rollsim.geometry import CylinderWheel, MeshOptions, build_soil_block, indentation_block, rolling_block
from rollsim.geometry.mesh import ACCURACY_REFINEMENT
from rollsim.solver import DruckerPrager, SolverDivergedError, StepControl, VonMises
from rollsim.solver.checkpoint import staged
from rollsim.solver.indentation import WheelIndentation
from rollsim.solver.options import DEFAULT_VOLUMETRIC_STRAIN, LINEAR_SOLVERS
from rollsim.solver.rolling import WheelRolling
from rollsim.studies.bearing_capacity import Options, Soil, Wheel, wheel_forces

CASES = pathlib.Path(__file__).parents[1] / "studies" / "data" / "cases_indentation.csv"
STOPS = (0.01, 0.02, 0.03, 0.05, 0.08, 0.1)


def case_row(n):
    return next(r for r in csv.DictReader(CASES.open()) if int(r["case"]) == n)


def case_soil(n):
    """Report case ``n``: (material, d, b, gamma, mu, c, phi) with the compression-matched
    Mohr-Coulomb (c, phi) of the bearing-capacity model (SI units, radians)."""
    r = case_row(n)
    d, b, E, nu = float(r["d_m"]), float(r["b_m"]), float(r["E_MPa"]) * 1e6, float(r["nu"])
    phi_dp, c_dp = math.radians(float(r["phi_dp_deg"])), float(r["c_dp_kPa"]) * 1e3
    mat = VonMises(E=E, nu=nu, yield_stress=c_dp) if phi_dp == 0 else DruckerPrager(E=E, nu=nu, phi_dp=phi_dp, c_dp=c_dp)
    return (mat, d, b, float(r["gamma_kN_m3"]) * 1e3, float(r["mu"]), float(r["c_mc_compression_kPa"]) * 1e3,
            math.radians(float(r["phi_mc_compression_deg"])))


def run(comm, accuracy, mat, d, b, gamma, mu, s_end=0.1, linear_solver="auto", verbose=False, fixed_steps=0,
        volumetric_strain=DEFAULT_VOLUMETRIC_STRAIN, checkpoint=None, petsc_options=None, step=0.0, block=None,
        hexahedra=False):
    """One push on the ``accuracy`` preset (or that many elements per d; with ``hexahedra`` a block of
    Q2 hexahedra of that many elements per d in every direction), on ``block`` (a ``SoilBlock``;
    default the reference quarter block); ``step`` (s/d, > 0): every step that long (a failed step is cut inside it);
    with ``checkpoint`` (a directory) the state is written at every reading stop and a run finding
    one there continues from it (same mesh and path, any number of ranks)."""
    if hexahedra and accuracy in ACCURACY_REFINEMENT:
        raise ValueError(f"hexahedra: give accuracy as elements per d, not the preset {accuracy!r} "
                         "(the presets mesh tetrahedra)")
    t0 = time.perf_counter()
    mesh = (MeshOptions.from_accuracy(d, accuracy) if accuracy in ACCURACY_REFINEMENT
            else MeshOptions.from_refinement(d, float(accuracy), hexahedra=hexahedra))
    tm = build_soil_block(comm, block or indentation_block(d), mesh)
    ind = WheelIndentation(tm, CylinderWheel(d, b, b / 12), mat, gamma=gamma, friction=mu,
                           linear_solver=linear_solver, volumetric_strain=volumetric_strain,
                           petsc_options=petsc_options)
    ind.gravity_step()
    status, steps_before = "ok", 0
    stops = [r * d for r in STOPS if r <= s_end]
    found = None if checkpoint is None else comm.bcast(complete_directory(checkpoint) if comm.rank == 0 else None)
    if found is not None:
        ind.read_checkpoint(found)
        steps_before = len(ind.steps)
        if comm.rank == 0:
            print(f"  {accuracy}: continuing from {checkpoint} at s/d = {ind.sinkage / d:.4f} "
                  f"({len(ind.steps)} steps, {ind.newton_iterations} Newton iterations)", flush=True)

    def on_step(st):
        if verbose and comm.rank == 0:
            print(f"  {accuracy} s/d={st.sinkage / d:.4f} QV={st.QV / 1e3:.2f} kN "
                  f"its={st.iterations} t={time.perf_counter() - t0:.0f} s", flush=True)
        if checkpoint is not None and any(abs(st.sinkage - s) < 1e-9 * d for s in stops):
            with staged(checkpoint, comm) as stage:
                ind.write_checkpoint(stage)

    try:
        control, ends = None, stops
        if fixed_steps:
            control = StepControl(dt=1 / fixed_steps, dt_max=1 / fixed_steps, grow=1.0, dt_min=1e-4, max_cuts=10)
        elif step:
            # each step is a push segment of its own: equal steps whatever the reading stops
            control = StepControl(dt=1.0, dt_max=1.0, grow=1.0, dt_min=1e-4, max_cuts=10)
            grid = [k * step * d for k in range(1, int(s_end / step + 1e-9) + 1)]
            ends = sorted(stops + [s for s in grid if all(abs(s - r) > 1e-9 * d for r in stops)])
        ind.push(s_end * d, stops=[s for s in ends if s > ind.sinkage + 1e-9 * d], control=control,
                 on_step=on_step)
    except SolverDivergedError as err:
        status = f"failed: {err}"
    q = {f"{r:g}": st.QV for r in STOPS for st in ind.steps if abs(st.sinkage - r * d) < 1e-9}
    return {"accuracy": accuracy, "linear_solver": ind.problem.linear_solver,
            "volumetric_strain": volumetric_strain, "cells": tm.stats.cells,
            "dofs": ind.n_dofs, "status": status,
            "steps": len(ind.steps), "newton_iterations": ind.newton_iterations, "cuts": ind.cuts,
            "time_s": comm.allreduce(time.perf_counter() - t0, op=MPI.MAX),   # this sitting
            "steps_from_checkpoint": steps_before, "QV": q,
            "contact_stiffness": (ind.contact.kappa, ind.contact.k_t),
            "curve": [(st.sinkage, st.QV) for st in ind.steps]}


def solve_cost(comm, presets, linear_solvers) -> None:
    """Quarter block per preset: cells, dofs, mesh time and one elastic solve per linear solver
    (assembly, LU factorisation or AMG set-up, solve; report case 2 soil)."""
    for acc in presets:
        t0 = time.perf_counter()
        tm = build_soil_block(comm, indentation_block(1.524), MeshOptions.from_accuracy(1.524, acc))
        t_mesh = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
        for kind in linear_solvers:
            ind = WheelIndentation(tm, CylinderWheel(1.524, 0.4572, 0.4572 / 12),
                                   VonMises(E=40e6, nu=0.35, yield_stress=200e3), linear_solver=kind)
            t_solve = comm.allreduce(ind.problem.elastic_solve_time(repeat=1), op=MPI.MAX)
            if comm.rank == 0:
                print(f"{acc:9s} cells {tm.stats.cells:7d} dofs {ind.n_dofs:8d} mesh {t_mesh:6.1f} s  one elastic "
                      f"solve ({ind.problem.linear_solver}) {t_solve:8.2f} s", flush=True)


def cases(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks indentation cases")
    ap.add_argument("--cases", type=int, nargs="*", default=[2, 5])
    ap.add_argument("--accuracy", nargs="+", default=["fast", "standard"],
                    help="presets (fast, standard, accurate) or elements per d under the wheel")
    ap.add_argument("--c0", action="store_true", help="c = 0 soils (phi 35, 40, 45 deg) instead of the cases")
    ap.add_argument("--solve-cost", action="store_true",
                    help="only build each preset's mesh and time one elastic solve per --linear-solver, the "
                         "unit cost of a Newton iteration")
    ap.add_argument("--linear-solver", nargs="+", default=["auto"], choices=LINEAR_SOLVERS,
                    help="Newton's linear solver (runs: the first one; --solve-cost: each)")
    ap.add_argument("--s-end", type=float, default=0.1, help="push to this s/d")
    ap.add_argument("--verbose", action="store_true", help="print every converged step")
    ap.add_argument("--fixed-steps", type=int, default=0,
                    help="N equal steps between the reading stops (s/d 0.01, 0.02, 0.03, 0.05, ...), the same "
                         "path for every preset (default: automatic step size)")
    ap.add_argument("--step", type=float, default=0.0,
                    help="equal steps of this s/d for every preset (a failed step is cut inside it)")
    add_volumetric_strain(ap)
    ap.add_argument("--hexahedra", action="store_true",
                    help="Q2 hexahedra, --accuracy in elements per d in every direction (B-bar: Q2-P1)")
    ap.add_argument("--checkpoint", default=None,
                    help="directory: write each run's state at every reading stop and continue a run from "
                         "there when it is started again (long accurate runs over several sittings)")
    ap.add_argument("--petsc-option", action="append", default=[], metavar="KEY=VALUE",
                    help="PETSc option for the runs' SNES/KSP, e.g. ksp_rtol=1e-10 (repeatable)")
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    if args.step < 0 or (args.step and args.fixed_steps):
        ap.error("--step: a positive s/d, not together with --fixed-steps")
    if args.hexahedra and any(acc in ACCURACY_REFINEMENT for acc in args.accuracy):
        ap.error("--hexahedra: give --accuracy as elements per d (the presets mesh tetrahedra)")
    petsc = dict(kv.split("=", 1) for kv in args.petsc_option)
    comm = MPI.COMM_WORLD
    if args.solve_cost:
        return solve_cost(comm, args.accuracy, args.linear_solver)
    results = []
    jobs = []
    if args.c0:
        for phi in (35, 40, 45):
            mat = DruckerPrager.from_mohr_coulomb(40e6, 0.35, 0.0, math.radians(phi), psi=0.0)
            jobs.append((f"c=0 phi={phi}", mat, 1.524, 0.4572, 20e3, 0.8, 0.0, math.radians(phi)))
    for n in ([] if args.c0 else args.cases):
        jobs.append((f"case {n}", *case_soil(n)))
    for name, mat, d, b, gamma, mu, c, phi in jobs:
        per = []
        for acc in args.accuracy:
            ckpt = None if args.checkpoint is None else (
                pathlib.Path(args.checkpoint) / f"{name.replace(' ', '').replace('=', '')}-{acc}-{args.volumetric_strain}"
                f"-{f'step{args.step:g}' if args.step else f'fixed{args.fixed_steps}'}-{args.linear_solver[0]}"
                f"{'-hexahedra' if args.hexahedra else ''}")
            res = run(comm, acc, mat, d, b, gamma, mu, args.s_end, args.linear_solver[0], args.verbose,
                      args.fixed_steps, args.volumetric_strain, ckpt, petsc, args.step, hexahedra=args.hexahedra)
            res["hexahedra"] = args.hexahedra
            res["name"] = name
            res["bearing_capacity_QV"] = {f"{r:g}": float(wheel_forces(r * d, Wheel(d, b), Soil(c, phi, gamma),
                                                                       Options(mode="indentation")).QV) for r in STOPS}
            per.append(res)
            if comm.rank == 0:
                qs = "  ".join(f"s/d={k}: {v / 1e3:8.2f} kN (BC {res['bearing_capacity_QV'][k] / 1e3:7.2f})"
                               for k, v in res["QV"].items() if k in ("0.02", "0.05", "0.1"))
                print(f"{name:14s} {acc:9s} {res['linear_solver']:9s} cells {res['cells']:6d} dofs {res['dofs']:7d} steps {res['steps']:3d} "
                      f"its {res['newton_iterations']:4d} cuts {res['cuts']:3d} {res['time_s']:7.1f} s {res['status'][:60]}\n   {qs}",
                      flush=True)
        finest = per[-1]
        for res in per:
            res["rel_to_finest"] = {k: res["QV"][k] / finest["QV"][k] - 1 for k in res["QV"] if k in finest["QV"]}
            if comm.rank == 0 and res is not finest:
                print(f"   {res['accuracy']} vs {finest['accuracy']}: " +
                      "  ".join(f"s/d={k}: {v:+.2%}" for k, v in res["rel_to_finest"].items()))
        results += per
    if args.out and comm.rank == 0:
        pathlib.Path(args.out).write_text(json.dumps(results, indent=2))


D, B, GAMMA, MU = 1.524, 0.4572, 20e3, 0.8
REPORT = (0.02, 0.05, 0.1)


def control(max_wall: float) -> StepControl:
    return StepControl(dt=0.1, dt_min=1e-4, dt_max=0.25, easy_iterations=15, max_cuts=10,
                       max_wall_time=max_wall)


def frictional_run(comm, phi_deg, c_reg, *, match="plane_strain", alpha=1.0, accuracy="fast", s_end=0.1, max_wall=240.0,
        relaxation_length=0.0, volumetric_strain=DEFAULT_VOLUMETRIC_STRAIN):
    phi = math.radians(phi_deg)
    mat = DruckerPrager.from_mohr_coulomb(40e6, 0.35, c_reg, phi, psi=0.0, matching=match)
    t0 = time.perf_counter()
    tm = build_soil_block(comm, indentation_block(D), MeshOptions.from_accuracy(D, accuracy))
    ind = WheelIndentation(tm, CylinderWheel(D, B, B / 12), mat, gamma=GAMMA, friction=MU, penalty=alpha,
                           relaxation_length=relaxation_length, volumetric_strain=volumetric_strain)
    ind.gravity_step()
    status = "ok"
    try:
        ind.push(s_end * D, stops=[r * D for r in STOPS if r < s_end], control=control(max_wall))
    except SolverDivergedError as err:
        status = f"stopped at s/d = {ind.sinkage / D:.4f}: {str(err).split(';')[0]}"
    qv = {f"{r:g}": st.QV for r in REPORT for st in ind.steps if abs(st.sinkage - r * D) < 1e-9}
    bc = {f"{r:g}": float(wheel_forces(r * D, Wheel(D, B), Soil(0.0, phi, GAMMA), Options(mode="indentation")).QV)
          for r in REPORT}
    return {"phi_deg": phi_deg, "c_reg_Pa": c_reg, "relaxation_length_m": relaxation_length, "match": match,
            "alpha": alpha, "accuracy": accuracy, "volumetric_strain": volumetric_strain,
            "dofs": ind.n_dofs, "status": status, "s_over_d_reached": ind.sinkage / D, "steps": len(ind.steps),
            "newton_iterations": ind.newton_iterations, "cuts": ind.cuts,
            "wall_s": comm.allreduce(time.perf_counter() - t0, op=MPI.MAX), "QV_N": qv, "model_QV_N": bc,
            "curve": [(st.sinkage / D, st.QV) for st in ind.steps]}


def _table(results):
    head = ("phi", "c_reg kPa", "L mm", "s/d", "FE Q_V kN", "model kN", "FE/model", "steps", "Newton its", "cuts",
            "wall s", "status")
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in results:
        for i, x in enumerate(REPORT):
            fe = r["QV_N"].get(f"{x:g}")
            bc = r["model_QV_N"][f"{x:g}"]
            first = i == 0
            lines.append("| " + " | ".join([
                f"{r['phi_deg']:g}", f"{r['c_reg_Pa'] / 1e3:g}", f"{r['relaxation_length_m'] * 1e3:g}", f"{x:g}",
                "-" if fe is None else f"{fe / 1e3:.1f}", f"{bc / 1e3:.1f}",
                "-" if fe is None else f"{fe / bc:.2f}",
                f"{r['steps']}" if first else "", f"{r['newton_iterations']}" if first else "",
                f"{r['cuts']}" if first else "", f"{r['wall_s']:.0f}" if first else "",
                r["status"] if first else ""]) + " |")
    return "\n".join(lines)


def _sensitivity(results):
    """Q_V relative to the smallest c_reg run at the same phi (rate-independent runs only)."""
    out = []
    for phi in sorted({r["phi_deg"] for r in results}):
        rs = sorted((r for r in results if r["phi_deg"] == phi and r["relaxation_length_m"] == 0),
                    key=lambda r: r["c_reg_Pa"])
        if len(rs) < 2:
            continue
        ref = rs[0]
        for r in rs[1:]:
            for x in REPORT[1:]:
                a, b = r["QV_N"].get(f"{x:g}"), ref["QV_N"].get(f"{x:g}")
                if a and b:
                    out.append(f"phi {phi:g}: Q_V(c_reg = {r['c_reg_Pa'] / 1e3:g} kPa) / Q_V(c_reg = "
                               f"{ref['c_reg_Pa'] / 1e3:g} kPa) - 1 at s/d = {x:g}: {a / b - 1:+.3f}")
    return "\n".join(out)


def _relaxation_limit(results):
    """Duvaut-Lions runs at the same phi and c_reg: Q_V against the rate-independent run (L = 0), if
    there is one, and, from the three smallest lengths, the first-order Richardson extrapolation
    of the last two and Aitken's of the three (the limit lay between them where it was checked)."""
    out = []
    for phi, c_reg in sorted({(r["phi_deg"], r["c_reg_Pa"]) for r in results}):
        rs = [r for r in results if r["phi_deg"] == phi and r["c_reg_Pa"] == c_reg]
        ref = next((r for r in rs if r["relaxation_length_m"] == 0), None)
        relaxed = sorted((r for r in rs if r["relaxation_length_m"] > 0), key=lambda r: -r["relaxation_length_m"])
        for x in REPORT:
            key = f"{x:g}"
            q = [(r["relaxation_length_m"] * 1e3, r["QV_N"][key]) for r in relaxed if key in r["QV_N"]]
            if not q:
                continue
            q0 = ref["QV_N"].get(key) if ref else None
            line = f"phi {phi:g} c_reg {c_reg / 1e3:g} kPa, s/d = {x:g}: Q_V " + ", ".join(
                f"{v / 1e3:.1f} kN (L {ell:g} mm{'' if q0 is None else f', {v / q0 - 1:+.1%}'})" for ell, v in q)
            if q0 is not None:
                line += f"; rate-independent {q0 / 1e3:.1f} kN"
            if len(q) >= 3:
                (_, q1), (_, q2), (_, q3) = q[-3:]
                line += f"; Richardson {(2 * q3 - q2) / 1e3:.1f} kN"
                if (q1 - q2) != (q2 - q3):
                    line += f", Aitken {(q3 - (q2 - q3) ** 2 / ((q1 - q2) - (q2 - q3))) / 1e3:.1f} kN"
            out.append(line)
    return "\n".join(out)


def frictional(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks indentation frictional",
                                 description=__doc__.split("\n\n")[0])
    ap.add_argument("--phi", type=float, nargs="+", default=[35.0, 40.0, 45.0], help="friction angles, deg")
    ap.add_argument("--creg", type=float, nargs="+", default=[1.0], help="regularising cohesion(s), kPa (0 = none)")
    ap.add_argument("--relaxation-length", type=float, nargs="+", default=[0.0],
                    help="Duvaut-Lions relaxation length(s), mm of sinkage (0 = rate-independent)")
    ap.add_argument("--match", default="plane_strain",
                    choices=["plane_strain", "plane_strain_flow", "compression", "extension"])
    add_volumetric_strain(ap)
    ap.add_argument("--alpha", type=float, default=1.0, help="contact penalty factor alpha (kappa = alpha E/h)")
    ap.add_argument("--accuracy", default="fast")
    ap.add_argument("--s-end", type=float, default=0.1, help="final s/d")
    ap.add_argument("--max-wall", type=float, default=240.0, help="wall-clock guard per run, s")
    ap.add_argument("--out", default=None, help="write the results (with curves) as JSON")
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    results = []
    for phi in args.phi:
        for c in args.creg:
            for ell in args.relaxation_length:
                r = frictional_run(comm, phi, c * 1e3, match=args.match, alpha=args.alpha, accuracy=args.accuracy,
                        s_end=args.s_end, max_wall=args.max_wall, relaxation_length=ell * 1e-3,
                        volumetric_strain=args.volumetric_strain)
                results.append(r)
                if comm.rank == 0:
                    print(f"phi {phi:g} c_reg {c:g} kPa L {ell:g} mm: {r['status']}, {r['steps']} steps, "
                          f"{r['newton_iterations']} its, {r['wall_s']:.0f} s", flush=True)
    if comm.rank == 0:
        print(_table(results))
        for extra in (_sensitivity(results), _relaxation_limit(results)):
            if extra:
                print(extra)
        if args.out:
            with open(args.out, "w") as f:
                json.dump(results, f, indent=1)


KINDS = ("small-strain", "updated-lagrangian")


def _material(args):
    return VonMises(E=args.E * 1e6, nu=0.35, yield_stress=args.yield_stress * 1e3)


def indentation(comm, kinematics, args):
    t0 = time.perf_counter()
    tm = build_soil_block(comm, indentation_block(D), MeshOptions.from_accuracy(D, args.accuracy))
    ind = WheelIndentation(tm, CylinderWheel(D, B, B / 12), _material(args), gamma=GAMMA, friction=args.mu,
                           kinematics=kinematics)
    ind.gravity_step()
    stops = np.round(np.arange(0.01, args.s_end + 1e-9, 0.01), 4)
    status = "ok"
    try:
        ind.push(args.s_end * D, stops=[r * D for r in stops])
    except SolverDivergedError as err:
        status = f"failed: {err}"
    qv = {float(r): st.QV for r in stops for st in ind.steps if abs(st.sinkage - r * D) < 1e-9}
    return {"kinematics": kinematics, "status": status, "dofs": ind.n_dofs, "steps": len(ind.steps),
            "newton_iterations": ind.newton_iterations, "cuts": ind.cuts, "QV": qv,
            "time_s": comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)}


def rolling(comm, kinematics, args):
    t0 = time.perf_counter()
    blk = rolling_block(D, length=args.length, half_width=args.half_width, depth=args.depth, stiff_length=0.0)
    tm = build_soil_block(comm, blk, MeshOptions.from_accuracy(D, args.accuracy))
    roll = WheelRolling(tm, CylinderWheel(D, B, B / 12), _material(args), gamma=GAMMA, friction=args.rolling_mu,
                        kinematics=kinematics)
    roll.gravity_step()
    status = "ok"
    try:
        roll.press(0.005 * D)
        roll.roll(args.travel * D, args.rolling_s_end * D)
    except SolverDivergedError as err:
        status = f"failed: {err}"
    rolled = [(st.travel, st.sinkage, st.QV, st.QH) for st in roll.steps if st.travel > 0]
    return {"kinematics": kinematics, "status": status, "dofs": roll.n_dofs, "steps": len(roll.steps),
            "newton_iterations": roll.newton_iterations, "cuts": roll.cuts, "curve": rolled,
            "time_s": comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)}


def first_above(s, diff, limit=0.03):
    """Smallest s where |diff| > limit (None if never)."""
    over = [si for si, di in zip(s, diff) if abs(di) > limit]
    return min(over) if over else None


def kinematics(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks indentation kinematics",
                                description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--accuracy", default="fast")
    p.add_argument("--E", type=float, default=40.0, help="Young's modulus, MPa")
    p.add_argument("--yield-stress", type=float, default=200.0, help="von Mises yield stress, kPa")
    p.add_argument("--mu", type=float, default=0.8, help="indentation friction")
    p.add_argument("--s-end", type=float, default=0.15, help="indentation sinkage, d")
    p.add_argument("--rolling", action="store_true")
    p.add_argument("--rolling-mu", type=float, default=0.0)
    p.add_argument("--rolling-s-end", type=float, default=0.08, help="continuous ramp end, d")
    p.add_argument("--travel", type=float, default=1.2, help="d")
    p.add_argument("--length", type=float, default=2.2, help="rolling block length, d")
    p.add_argument("--half-width", type=float, default=0.8)
    p.add_argument("--depth", type=float, default=0.8)
    p.add_argument("--skip-indentation", action="store_true")
    p.add_argument("--out")
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    root = comm.rank == 0
    out = {"args": vars(args)}
    if not args.skip_indentation:
        runs = [indentation(comm, k, args) for k in KINDS]
        out["indentation"] = runs
        ss, ul = (r["QV"] for r in runs)
        s = sorted(set(ss) & set(ul))
        diff = [ul[r] / ss[r] - 1 for r in s]
        if root:
            print("indentation (quarter block, mu = %g):" % args.mu)
            for r in runs:
                print(f"  {r['kinematics']:>19}: {r['status']}, {r['dofs']} dofs, {r['steps']} steps, "
                      f"{r['newton_iterations']} Newton its, {r['cuts']} cuts, {r['time_s']:.0f} s")
            print("  s/d    Q_V small strain (kN)   Q_V updated Lagrangian (kN)   UL/SS - 1")
            for r, dr in zip(s, diff):
                print(f"  {r:5.3f}  {ss[r] / 1e3:21.1f}   {ul[r] / 1e3:27.1f}   {100 * dr:+8.2f} %")
            print(f"  first s/d with |UL/SS - 1| > 3 %: {first_above(s, diff)}")
    if args.rolling:
        runs = [rolling(comm, k, args) for k in KINDS]
        out["rolling"] = runs
        a, b = (np.array(r["curve"]) for r in runs)
        if root:
            print("continuous rolling (half block, mu = %g):" % args.rolling_mu)
            for r in runs:
                print(f"  {r['kinematics']:>19}: {r['status']}, {r['dofs']} dofs, {r['steps']} steps, "
                      f"{r['newton_iterations']} Newton its, {r['cuts']} cuts, {r['time_s']:.0f} s")
            if len(a) and len(b):
                # both ramps are the same function of travel: compare the mean Q_V over bins of
                # s/d (several steps each, which averages out the element ripple)
                edges = np.round(np.arange(0.0, args.rolling_s_end + 1e-9, 0.01), 4)
                print("  s/d bin        Q_V SS (kN)  Q_V UL (kN)  UL/SS - 1   Q_H SS (kN)  Q_H UL (kN)")
                first = None
                for lo, hi in zip(edges[:-1], edges[1:]):
                    ma = (a[:, 1] / D >= lo) & (a[:, 1] / D < hi)
                    mb = (b[:, 1] / D >= lo) & (b[:, 1] / D < hi)
                    if ma.sum() < 2 or mb.sum() < 2:
                        continue
                    qa, qb = a[ma, 2].mean(), b[mb, 2].mean()
                    if first is None and abs(qb / qa - 1) > 0.03:
                        first = lo
                    print(f"  {lo:.2f}-{hi:.2f}  {qa / 1e3:11.1f}  {qb / 1e3:11.1f}  {100 * (qb / qa - 1):+8.1f} %  "
                          f"{a[ma, 3].mean() / 1e3:11.2f}  {b[mb, 3].mean() / 1e3:11.2f}")
                print(f"  first s/d bin with |UL/SS - 1| > 3 %: {first}")
    dump_json(comm, args.out, out)
    return 0



if __name__ == "__main__":
    sys.exit(run_problems({"cases": cases, "frictional": frictional, "kinematics": kinematics}, __doc__))
