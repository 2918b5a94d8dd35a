"""Full-resolution Prandtl strip-footing benchmark of rollsim.solver (prints figures, writes JSON).

    .venv/bin/python -m benchmarks solver_prandtl [--out bench_solver_prandtl.json] [--quick]
    mpirun -n 2 .venv/bin/python -m benchmarks solver_prandtl --out bench_np2.json
    .venv/bin/python -m benchmarks solver_prandtl --volumetric-strain cell-average   # B-bar tables

Cases (weightless, smooth rigid strip, half model 2.5B x 2.5B, P2 triangles, crossed, graded):
  * von Mises matched to Tresca c (plane strain): p_lim -> (2 + pi) c, meshes n = 2..16
  * associated Drucker-Prager matched to Mohr-Coulomb (plane strain), phi = 20, 30 deg: c N_c(phi)
  * P1 vs P2 (von Mises, n = 8): volumetric locking of P1 under isochoric flow
  * volumetric locking of P2: von Mises, n = 2, 4, 8, crossed and one-diagonal ("right") meshes, B-bar
    (cell-average volumetric strain) against the pointwise strain (the default); and on Q2
    rectangles, B-bar projected per cell onto the linear functions (its default there) or the
    constants, against the pointwise strain
  * c = 0, phi = 30 deg with self weight (N_gamma-type limit; reported, not verified)
"""
from __future__ import annotations

import argparse
import json
import math
import time

import numpy as np
from mpi4py import MPI

from _bench import add_volumetric_strain

from rollsim.log import setup_logging
from rollsim.solver.options import DEFAULT_VOLUMETRIC_STRAIN, VOLUMETRIC_STRAINS
from rollsim.solver import (DruckerPrager, StepControl, StripFooting, prandtl_nc, strip_footing_mesh,
                            von_mises_from_tresca)

E, NU, C, B = 50e6, 0.3, 100e3, 1.0
DEG = math.pi / 180


def run(comm, material, n, settlement, degree=2, unit_weight=0.0, K0=None, control=None,
        volumetric_strain=DEFAULT_VOLUMETRIC_STRAIN, diagonal="crossed", cell="triangle", projection=None):
    t0 = time.perf_counter()
    fo = StripFooting(strip_footing_mesh(comm, B, n, diagonal=diagonal, cell=cell), material, B, degree=degree,
                      unit_weight=unit_weight, K0=K0, volumetric_strain=volumetric_strain,
                      volumetric_projection=projection)
    res = fo.run(settlement, control, time_elastic=True)
    wall = time.perf_counter() - t0
    return {"n": n, "degree": degree, "dofs": res.n_dofs, "cells": res.n_cells,
            "limit_pressure": res.limit_pressure, "steps": len(res.iterations),
            "newton_iterations_per_step": res.iterations, "cuts": res.cuts,
            "mean_iterations": float(np.mean(res.iterations)),
            "time_per_newton_iteration": res.time_per_iteration, "elastic_solve_time": res.elastic_solve_time,
            "iteration_to_elastic_ratio": res.time_per_iteration / res.elastic_solve_time,
            "wall_time": wall, "settlement": res.displacement, "pressure": res.pressure}


def rate(ns, errs):
    return float(-np.polyfit(np.log(ns), np.log(np.abs(errs)), 1)[0])


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default="bench_solver_prandtl.json")
    ap.add_argument("--quick", action="store_true", help="meshes up to n = 8 only")
    add_volumetric_strain(ap, help="of the tables; the locking comparison runs both")
    ap.add_argument("-v", "--verbose", action="store_true")
    args = ap.parse_args()
    comm = MPI.COMM_WORLD
    setup_logging(comm, verbose=args.verbose, quiet=not args.verbose)
    say = print if comm.rank == 0 else (lambda *a, **k: None)
    ns = (2, 4, 8) if args.quick else (2, 4, 8, 16)
    out = {"ranks": comm.size, "E": E, "nu": NU, "c": C, "B": B, "volumetric_strain": args.volumetric_strain,
           "cases": {}}
    vs = args.volumetric_strain

    # von Mises / Tresca
    vm = von_mises_from_tresca(E, NU, C)
    exact = (2 + math.pi) * C
    rows = []
    say(f"von Mises (Tresca c) smooth strip, exact (2+pi)c = {exact / C:.5f} c   [{comm.size} rank(s), "
        f"volumetric strain: {vs}]")
    say(f"{'n':>4} {'dofs':>7} {'p/c':>9} {'error':>8} {'steps':>5} {'its/step':>8} {'max':>4} "
        f"{'cuts':>4} {'t_it/t_el':>9} {'wall s':>7}")
    for n in ns:
        r = run(comm, vm, n, 0.1, volumetric_strain=vs)
        r["error"] = r["limit_pressure"] / exact - 1
        rows.append(r)
        say(f"{n:4d} {r['dofs']:7d} {r['limit_pressure'] / C:9.5f} {100 * r['error']:7.2f}% {r['steps']:5d} "
            f"{r['mean_iterations']:8.2f} {max(r['newton_iterations_per_step']):4d} {sum(r['cuts']):4d} "
            f"{r['iteration_to_elastic_ratio']:9.2f} {r['wall_time']:7.1f}")
    out["cases"]["von_mises"] = {"exact": exact, "runs": rows,
                                 "rate": rate([r["n"] for r in rows], [r["error"] for r in rows])}
    say(f"  observed convergence rate in n (~1/h): {out['cases']['von_mises']['rate']:.2f}")

    # P1 vs P2 (locking)
    r1 = run(comm, vm, 8, 0.1, degree=1, control=StepControl(dt=0.05, dt_max=0.2, dt_min=1e-5))
    r1["error"] = r1["limit_pressure"] / exact - 1
    out["cases"]["von_mises_P1_n8"] = r1
    say(f"  P1 (n=8, {r1['dofs']} dofs): p/c = {r1['limit_pressure'] / C:.4f} ({100 * r1['error']:+.2f}%) "
        f"vs P2 {100 * rows[2]['error']:+.2f}% - P1 locks under isochoric plastic flow")

    # volumetric locking of P2: B-bar against the pointwise strain, two mesh patterns
    say("volumetric locking of P2 (von Mises): error of p_lim, B-bar (cell-average) vs pointwise")
    say(f"{'mesh':>8} {'n':>3} {'cell-average':>13} {'pointwise':>10}")
    locking = []
    table = {("crossed", vs, r["n"]): r["error"] for r in out["cases"]["von_mises"]["runs"]}   # run above
    for diagonal in ("crossed", "right"):
        for n in ns[:3]:
            errs = {v: table[diagonal, v, n] if (diagonal, v, n) in table else
                    run(comm, vm, n, 0.1, volumetric_strain=v, diagonal=diagonal)["limit_pressure"] / exact - 1
                    for v in VOLUMETRIC_STRAINS}
            locking.append({"diagonal": diagonal, "n": n, "error": errs})
            say(f"{diagonal:>8} {n:3d} {100 * errs['cell-average']:12.2f}% {100 * errs['pointwise']:9.2f}%")
    say("Q2 rectangles: B-bar projected per cell onto linear functions (default) or constants, vs pointwise")
    say(f"{'n':>3} {'linear':>8} {'constant':>9} {'pointwise':>10}")
    for n in ns[:3]:
        errs = {name: run(comm, vm, n, 0.1, volumetric_strain=v, cell="quadrilateral",
                          projection=pr)["limit_pressure"] / exact - 1
                for name, v, pr in (("linear", "cell-average", None), ("constant", "cell-average", 0),
                                    ("pointwise", "pointwise", None))}
        locking.append({"cell": "quadrilateral", "n": n, "error": errs})
        say(f"{n:3d} {100 * errs['linear']:7.2f}% {100 * errs['constant']:8.2f}% {100 * errs['pointwise']:9.2f}%")
    out["cases"]["von_mises_locking"] = locking

    # associated Drucker-Prager, plane-strain match
    for phi_deg, settle in ((20.0, 0.2), (30.0, 0.3)):
        phi = phi_deg * DEG
        mat = DruckerPrager.from_mohr_coulomb(E, NU, C, phi, psi=None, matching="plane_strain")
        exact = C * prandtl_nc(phi)
        rows = []
        say(f"associated DP (plane-strain MC match) phi = {phi_deg:g} deg: exact c Nc = {exact / C:.4f} c")
        for n in ns:
            r = run(comm, mat, n, settle, volumetric_strain=vs)
            r["error"] = r["limit_pressure"] / exact - 1
            rows.append(r)
            say(f"{n:4d} {r['dofs']:7d} {r['limit_pressure'] / C:9.4f} {100 * r['error']:7.2f}% {r['steps']:5d} "
                f"{r['mean_iterations']:8.2f} {max(r['newton_iterations_per_step']):4d} {sum(r['cuts']):4d} "
                f"{r['iteration_to_elastic_ratio']:9.2f} {r['wall_time']:7.1f}")
        out["cases"][f"dp_assoc_phi{phi_deg:g}"] = {
            "exact": exact, "runs": rows, "rate": rate([r["n"] for r in rows], [r["error"] for r in rows])}
        say(f"  observed rate: {out['cases'][f'dp_assoc_phi{phi_deg:g}']['rate']:.2f}")

    # purely frictional soil with self weight
    gamma = 18e3
    mat = DruckerPrager.from_mohr_coulomb(E, NU, 0.0, 30 * DEG, psi=None, matching="plane_strain")
    rows = []
    say("c = 0, phi = 30 deg (associated DP, plane-strain match), gamma = 18 kN/m3, K0 = 1 - sin(phi)")
    for n in ns[:2]:      # n = 8 needs ~700 steps / 340 cuts (apex switching on the plateau): open issue
        r = run(comm, mat, n, 0.03, unit_weight=gamma, K0=1 - math.sin(30 * DEG),
                control=StepControl(dt=0.05, dt_max=0.1, dt_min=1e-6, max_cuts=12), volumetric_strain=vs)
        r["N_gamma"] = r["limit_pressure"] / (0.5 * gamma * B)
        rows.append(r)
        say(f"{n:4d} {r['dofs']:7d}  N_gamma = {r['N_gamma']:.3f}  steps {r['steps']}, its/step "
            f"{r['mean_iterations']:.2f} (max {max(r['newton_iterations_per_step'])}), cuts {sum(r['cuts'])}")
    out["cases"]["c0_gravity_phi30"] = {"runs": rows}

    if comm.rank == 0:
        with open(args.out, "w") as fh:
            json.dump(out, fh, indent=1)
        print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
