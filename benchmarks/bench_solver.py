"""Strip footings of rollsim.solver against exact and published limits, two problems.

``prandtl``: the Prandtl strip footing at full resolution (prints figures, writes JSON).

    python -m benchmarks solver prandtl [--out bench_solver_prandtl.json] [--quick]
    mpirun -n 2 python -m benchmarks solver prandtl --out bench_np2.json
    python -m benchmarks solver prandtl --volumetric-strain cell-average   # B-bar tables

Cases (weightless, smooth rigid strip, half model 2.5B x 2.5B, P2 triangles, crossed, graded):
  * von Mises matched to Tresca c (plane strain): p_lim -> (2 + pi) c, meshes n = 2..16
  * associated Drucker-Prager matched to Mohr-Coulomb (plane strain), phi = 20, 30 deg: c N_c(phi)
  * P1 vs P2 (von Mises, n = 8): volumetric locking of P1 under isochoric flow
  * volumetric locking of P2: von Mises, n = 2, 4, 8, crossed and one-diagonal ("right") meshes, B-bar
    (cell-average volumetric strain) against the pointwise strain (the default); and on Q2
    rectangles, B-bar projected per cell onto the linear functions (its default there) or the
    constants, against the pointwise strain
  * c = 0, phi = 30 deg with self weight (N_gamma-type limit; reported, not verified)

``frictional``: robustness: purely frictional soil, smoothed Mohr-Coulomb, extremes.

    python -m benchmarks solver frictional [--out bench_solver_frictional.json]
        [--quick]        meshes n <= 8 (default n <= 16)
        [--before]       also run the old stepping (predictor 'none') at n = 8 (~12 min)
        [--cases 1 2 3 4] which cases to run (default all)

Cases (smooth rigid strip, half model 2.5B x 2.5B, P2 triangles, crossed, graded; B = 1 m):
  1. c = 0, phi = 30 deg (associated DP, plane-strain match), gamma = 18 kN/m3, K0 = 1 - sin(phi):
     N_gamma = p_lim / (gamma B / 2) vs Martin (2005) exact smooth-footing value 7.65; steps, cuts,
     Newton iterations with the extrapolated predictor and without it (the old stepping).
  2. weightless associated smoothed Mohr-Coulomb (Abbo-Sloan, theta_T = 29 and 25 deg),
     phi = 20 deg: p_lim vs the exact c N_c; plane-strain-matched Drucker-Prager alongside.
  3. extremes: nu = 0.3 / 0.49 / 0.499 (von Mises, n = 4); phi_dp = 60 deg with psi = 60 / 0;
     two Tresca layers with a 30:1 strength contrast ({tag: material}, interface on a mesh line).
  4. non-associated flow, c = 0, gamma = 18 kN/m3, K0 = 1 - sin(phi), phi = 30 / 35 deg: N_gamma with
     psi = 0 (plane-strain match with the flow rule) against, on the same mesh, the associated cone
     (an upper bound: Radenkovic's first theorem) and the associated cone of the Davis angle
     tan(phi*) = sin(phi) (the reduced-strength estimate); crossed and one-diagonal ("right")
     triangles, pointwise and B-bar strain; also the associated-formula cone with psi = 0
     ("plane_strain", a weaker Mohr-Coulomb soil in plane strain; crossed, pointwise).  Settlement
     0.005 B (phi 30) / 0.008 B (phi 35); a stalled run reports its last converged settlement.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
import time

import numpy as np
from mpi4py import MPI

from _bench import add_volumetric_strain, run_problems

from rollsim.log import setup_logging
from rollsim.solver import (DruckerPrager, SmoothedMohrCoulomb, SolverDivergedError, StepControl, StripFooting,
                            jaky_k0, prandtl_nc, strip_footing_mesh, von_mises_from_tresca)
from rollsim.solver.options import DEFAULT_VOLUMETRIC_STRAIN, VOLUMETRIC_STRAINS

E, NU, C, B, GAMMA = 50e6, 0.3, 100e3, 1.0, 18e3
DEG = math.pi / 180


def _start(ap: argparse.ArgumentParser, argv: list[str] | None):
    """A problem's options (``-v``: the solver's log), the communicator, a print on rank 0 and the
    mesh levels (``--quick``: up to n = 8)."""
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    setup_logging(comm, verbose=args.verbose, quiet=not args.verbose)
    say = print if comm.rank == 0 else (lambda *a, **k: None)
    return args, comm, say, ((2, 4, 8) if args.quick else (2, 4, 8, 16))


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


def prandtl(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks solver prandtl")
    ap.add_argument("--out", default="bench_solver_prandtl.json")
    ap.add_argument("--quick", action="store_true", help="meshes up to n = 8 only")
    add_volumetric_strain(ap, help="of the tables; the locking comparison runs both")
    ap.add_argument("-v", "--verbose", action="store_true")
    args, comm, say, ns = _start(ap, argv)
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
EXTREME_CTL = StepControl(dt=0.05, dt_max=0.2, dt_min=1e-5, max_wall_time=300, predictor="extrapolate")
N_GAMMA_MARTIN = 7.65      # smooth strip, phi = 30 deg; Martin (2005), Proc. 11th IACMAG, vol. 4, 441-450


def footing(comm, material, n, settlement, control=None, interfaces=None, diagonal="crossed", **kw):
    t0 = time.perf_counter()
    fo = StripFooting(strip_footing_mesh(comm, B, n, interfaces=interfaces or (), diagonal=diagonal), material, B,
                      interfaces=interfaces, **kw)
    out = {"n": n, "dofs": fo.n_dofs}
    try:
        res = fo.run(settlement, control)
        out.update(ok=True, limit_pressure=res.limit_pressure, steps=len(res.iterations), cuts=int(sum(res.cuts)),
                   newton_iterations=int(fo.problem.timings["iterations"]), max_iterations=max(res.iterations),
                   plateau=res.pressure[-1] / res.pressure[-2] - 1, pressure=res.pressure,
                   settlement=res.displacement,
                   apex_max=max(h.counts.get("apex", 0) for h in res.history))
    except SolverDivergedError as err:
        out.update(ok=False, error=str(err), steps=len(err.history), t_failed=err.last_converged.t,
                   limit_pressure=fo.pressure())
    out["wall_time"] = time.perf_counter() - t0
    return out


def frictional(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks solver frictional")
    ap.add_argument("--out", default="bench_solver_frictional.json")
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--before", action="store_true")
    ap.add_argument("--cases", nargs="+", type=int, choices=[1, 2, 3, 4], default=[1, 2, 3, 4])
    ap.add_argument("-v", "--verbose", action="store_true")
    args, comm, say, ns = _start(ap, argv)
    out = {"ranks": comm.size, "cases": {}}

    if 1 in args.cases:
        # 1. purely frictional soil
        mat = DruckerPrager.from_mohr_coulomb(E, NU, 0.0, 30 * DEG, psi=None, matching="plane_strain")
        say(f"1. c = 0, phi = 30 deg, gamma = 18 kN/m3, K0 = 1 - sin(phi): N_gamma vs Martin (2005) smooth "
            f"{N_GAMMA_MARTIN}   [{comm.size} rank(s)]")
        say(f"{'n':>3} {'predictor':>11} {'dofs':>6} {'N_gamma':>8} {'error':>7} {'steps':>5} {'cuts':>4} "
            f"{'Newton':>6} {'max':>3} {'wall s':>7}")
        rows = []
        for n in ns:
            preds = ["extrapolate"] + (["none"] if n <= 4 or (n == 8 and args.before) else [])
            for pred in preds:
                ctl = StepControl(dt=0.05, dt_max=0.1, dt_min=1e-6, max_cuts=12, predictor=pred)
                r = footing(comm, mat, n, 0.03, ctl, unit_weight=GAMMA, K0=jaky_k0(30 * DEG))
                r["predictor"] = pred
                r["N_gamma"] = r["limit_pressure"] / (0.5 * GAMMA * B)
                r["error"] = r["N_gamma"] / N_GAMMA_MARTIN - 1
                rows.append(r)
                say(f"{n:3d} {pred:>11} {r['dofs']:6d} {r['N_gamma']:8.4f} {100 * r['error']:6.2f}% {r['steps']:5d} "
                    f"{r.get('cuts', -1):4d} {r.get('newton_iterations', -1):6d} {r.get('max_iterations', -1):3d} "
                    f"{r['wall_time']:7.1f}" + ("" if r["ok"] else "  FAILED: " + r["error"]))
        ex = [r for r in rows if r["predictor"] == "extrapolate" and r["ok"]]
        if len(ex) >= 3:
            a, b, c = (r["N_gamma"] for r in ex[-3:])
            p = math.log((a - b) / (b - c)) / math.log(2)
            rich = c - (b - c) / (2 ** p - 1)
            out["richardson"] = {"rate": p, "N_gamma": rich}
            say(f"  Richardson from the last three meshes: rate {p:.2f}, N_gamma -> {rich:.3f} "
                f"({100 * (rich / N_GAMMA_MARTIN - 1):+.2f} % vs Martin)")
        out["cases"]["c0_gravity_phi30"] = {"reference": N_GAMMA_MARTIN, "runs": rows}

    if 2 in args.cases:
        # 2. smoothed Mohr-Coulomb
        phi = 20 * DEG
        exact = C * prandtl_nc(phi)
        say(f"2. weightless associated phi = 20 deg: exact c Nc = {exact / C:.4f} c")
        rows = []
        for label, m in (("SMC theta_T=29", SmoothedMohrCoulomb(E, NU, C, phi, dilation=phi)),
                         ("SMC theta_T=25", SmoothedMohrCoulomb(E, NU, C, phi, dilation=phi,
                                                                transition_angle=25 * DEG)),
                         ("DP plane-strain", DruckerPrager.from_mohr_coulomb(E, NU, C, phi, psi=None,
                                                                             matching="plane_strain"))):
            for n in ns[:3]:
                r = footing(comm, m, n, 0.2)
                r["model"], r["error"] = label, r["limit_pressure"] / exact - 1
                rows.append(r)
                say(f"  {label:>16} n={n:2d}: p/c = {r['limit_pressure'] / C:8.4f} ({100 * r['error']:+.2f} %), "
                    f"steps {r['steps']}, cuts {r['cuts']}, Newton {r['newton_iterations']}, "
                    f"wall {r['wall_time']:.1f} s")
        out["cases"]["smoothed_mc_phi20"] = {"exact": exact, "runs": rows}

    if 3 in args.cases:
        # 3. extremes
        say("3. extremes (n = 4)")
        rows = []
        for nu in (0.3, 0.49, 0.499):
            r = footing(comm, von_mises_from_tresca(E, nu, C), 4, 0.1)
            r["case"], r["error"] = f"von Mises nu={nu}", r["limit_pressure"] / ((2 + math.pi) * C) - 1
            rows.append(r)
            say(f"  {r['case']:>24}: p/((2+pi)c) - 1 = {100 * r['error']:+.2f} %, steps {r['steps']}, "
                f"Newton {r['newton_iterations']}, wall {r['wall_time']:.1f} s")
        for psi in (60.0, 0.0):
            m = DruckerPrager(E, NU, phi_dp=60 * DEG, c_dp=C, dilation=psi * DEG)
            r = footing(comm, m, 4, 0.1, EXTREME_CTL)
            r["case"] = f"DP phi_dp=60 psi={psi:g}"
            rows.append(r)
            say(f"  {r['case']:>24}: " + (f"converged, p = {r['limit_pressure'] / C:.2f} c at s = 0.1 B (rising), "
                                          f"steps {r['steps']}, cuts {r['cuts']}" if r["ok"] else
                                          f"SolverDivergedError at t = {r['t_failed']:.4f}, p = "
                                          f"{r['limit_pressure'] / C:.2f} c: {r['error']}")
                + f", wall {r['wall_time']:.1f} s")
        for top, bot, settle in ((10e3, 300e3, 0.02), (300e3, 10e3, 0.1)):
            m = {1: von_mises_from_tresca(E, NU, top), 2: von_mises_from_tresca(E, NU, bot)}
            r = footing(comm, m, 4, settle, EXTREME_CTL, interfaces=[0.25 * B])
            r["case"] = f"Tresca {top / 1e3:g} kPa over {bot / 1e3:g} kPa, H = 0.25 B"
            r["ratio_to_weak"] = r["limit_pressure"] / ((2 + math.pi) * min(top, bot))
            rows.append(r)
            say(f"  {r['case']:>24}: p = {r['ratio_to_weak']:.3f} (2+pi) c_weak at s = {settle} B "
                f"(last increment {100 * r.get('plateau', float('nan')):.2f} %), steps {r['steps']}, "
                f"cuts {r.get('cuts')}, wall {r['wall_time']:.1f} s")
        out["cases"]["extremes"] = rows

    if 4 in args.cases:
        # 4. non-associated flow
        say("4. c = 0, psi = 0: N_gamma between the Davis estimate and the associated cone (same mesh), "
            "both strains, both mesh patterns")
        rows = []
        for phi_deg, settle in ((30.0, 0.005), (35.0, 0.008)):
            phi = phi_deg * DEG
            cones = {"psi=0": DruckerPrager.from_mohr_coulomb(E, NU, 0.0, phi, psi=0.0, matching="plane_strain_flow"),
                     "associated": DruckerPrager.from_mohr_coulomb(E, NU, 0.0, phi, psi=None, matching="plane_strain"),
                     "Davis phi*": DruckerPrager.from_mohr_coulomb(E, NU, 0.0, math.atan(math.sin(phi)), psi=None,
                                                                   matching="plane_strain"),
                     "psi=0, assoc. formula": DruckerPrager.from_mohr_coulomb(E, NU, 0.0, phi, psi=0.0,
                                                                              matching="plane_strain")}
            for diagonal in ("crossed", "right"):
                for strain in ("pointwise", "cell-average"):
                    for n in ns[:2] if args.quick else ns[:3]:
                        by = {}
                        for label, m in cones.items():
                            if label.endswith("formula") and (diagonal, strain) != ("crossed", "pointwise"):
                                continue
                            ctl = StepControl(dt=0.02, dt_max=0.1, dt_min=1e-7, max_cuts=12, max_wall_time=300,
                                              predictor="auto")
                            r = footing(comm, m, n, settle * B, ctl, diagonal=diagonal, volumetric_strain=strain,
                                        unit_weight=GAMMA, K0=jaky_k0(phi))
                            r.update(phi_deg=phi_deg, cone=label, diagonal=diagonal, volumetric_strain=strain,
                                     N_gamma=r["limit_pressure"] / (0.5 * GAMMA * B),
                                     reached=settle if r["ok"] else r["t_failed"] * settle)
                            rows.append(r)
                            by[label] = r
                        say(f"  phi {phi_deg:g} {diagonal:>7} {strain:>12} n={n:2d}: " + ", ".join(
                            f"{k} {v['N_gamma']:.3f}" + ("" if v["ok"] else f" (stalled at {v['reached']:.4f} B)")
                            for k, v in by.items())
                            + f"; psi=0 / associated = {by['psi=0']['N_gamma'] / by['associated']['N_gamma']:.3f}")
        out["cases"]["nonassociated_c0"] = rows

    if comm.rank == 0:
        with open(args.out, "w") as fh:
            json.dump(out, fh, indent=1, default=float)
        print(f"wrote {args.out}")



if __name__ == "__main__":
    sys.exit(run_problems({"prandtl": prandtl, "frictional": frictional}, __doc__))
