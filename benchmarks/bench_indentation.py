"""3D rigid-wheel indentation (quarter model) for report cases: Q_V(s) to s/d = 0.1, presets compared.

    python -m benchmarks indentation --cases 2 5 --accuracy fast standard [accurate] --out bench_indentation.json
    python -m benchmarks indentation --c0 --accuracy fast standard     # c = 0, phi = 35/40/45 deg
    mpirun -n 2 python -m benchmarks indentation --cases 2 --accuracy standard accurate --s-end 0.05 \
        --fixed-steps 4                                                       # standard vs accurate within 3 %
    mpirun -n 2 python -m benchmarks indentation --cases 2 --accuracy standard --s-end 0.05 \
        --step 0.000625 --volumetric-strain cell-average                      # equal steps of 0.000625 s/d
    mpirun -n 2 python -m benchmarks indentation --solve-cost --accuracy standard accurate \
        --linear-solver direct iterative                                      # cost of one solve

``--volumetric-strain cell-average``: B-bar (see docs/theory.md, "Volumetric strain: B-bar or pointwise").  ``--checkpoint DIR``:
the state is written whole at every reading stop (beside the previous one, then swapped in), and
the same command started again continues from the last complete one (the accurate preset's
hours-long runs over several sittings), on any number of ranks.

Prints Q_V at s/d = 0.02, 0.05, 0.1, the bearing-capacity model (indentation, D = s) with the
case's compression-matched (c, phi), steps, Newton iterations, cuts and wall time, and the
relative difference of each preset from the finest one run.  ``--linear-solver``: the Newton
iteration's linear solver (default "auto": MUMPS LU up to 100 000 dofs, GMRES + AMG above).
"""
from __future__ import annotations

import argparse
import csv
import json
import math
import pathlib
import time

from mpi4py import MPI

from _bench import add_volumetric_strain

from rollsim.files import complete_directory
from rollsim.geometry import CylinderWheel, MeshOptions, build_soil_block, indentation_block
from rollsim.geometry.mesh import ACCURACY_REFINEMENT
from rollsim.solver.options import DEFAULT_VOLUMETRIC_STRAIN, LINEAR_SOLVERS
from rollsim.solver import DruckerPrager, SolverDivergedError, StepControl, VonMises
from rollsim.solver.checkpoint import staged
from rollsim.solver.indentation import WheelIndentation
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


def main():
    ap = argparse.ArgumentParser()
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
    args = ap.parse_args()
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


if __name__ == "__main__":
    main()
