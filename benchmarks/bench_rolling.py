"""Towed rigid wheel, protocol rolling-continuous (half model): report case vs the bearing-capacity
model, and the effect of halving the sinkage ramp rate.

    python -m benchmarks rolling --out bench_rolling.json                 # defaults below
    python -m benchmarks rolling --mu 0 0.8 --length 3.5 --half-width 1.5 --depth 1.5   # report block
    mpirun -n 2 python -m benchmarks rolling --mu 0 --s0 0.01 --s-end 0.055 --travel 2.25 --halve \
        --length 5.7 --half-width 0.8 --depth 0.8 --read 0.03 0.04 0.05 --window 0.005      # ramp 0.02 vs 0.01

Report case 2 (von Mises, c_dp = 200 kPa -> c = 100 kPa, phi = 0; E = 40 MPa, nu = 0.35,
gamma = 20 kN/m^3), Mn/DOT roller d = 1.524 m, b = 0.4572 m, fast preset.  The wheel is pressed to
s0 = 0.01 d at x = 0.4 d and rolls while s is ramped linearly to s_end = 0.05 d over ``travel``
(ramp rate (s_end - s0)/travel); ``--halve`` repeats with twice the travel (half the rate).
Prints Q_V, Q_H at s/d = 0.03, 0.04, 0.05 (``--read``; linear interpolation along the run, or a
least-squares line over s/d +- ``--window``), the
bearing-capacity model (rolling, inclined-footing method, D = s) at the same sinkage, steps,
Newton iterations, linear solves, cuts and wall time.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
from mpi4py import MPI

from _bench import dump_json, read_at

from rollsim.geometry import CylinderWheel, MeshOptions, build_soil_block, rolling_block
from rollsim.solver import SolverDivergedError, VonMises
from rollsim.solver.rolling import WheelRolling
from rollsim.studies.bearing_capacity import Options, Soil, Wheel, wheel_forces

D, B, GAMMA = 1.524, 0.4572, 20e3
MAT = VonMises(E=40e6, nu=0.35, yield_stress=200e3)
C, PHI = 100e3, 0.0
READ = (0.03, 0.04, 0.05)


def run(comm, mu, travel_d, args):
    t0 = time.perf_counter()
    blk = rolling_block(D, length=args.length, half_width=args.half_width, depth=args.depth, stiff_length=0)
    tm = build_soil_block(comm, blk, MeshOptions.from_accuracy(D, args.accuracy))
    roll = WheelRolling(tm, CylinderWheel(D, B, B / 12), MAT, gamma=GAMMA, friction=mu)
    roll.gravity_step()
    status = "ok"
    try:
        roll.press(args.s0 * D)
        roll.roll(travel_d * D, args.s_end * D,
                  on_step=(lambda st: print(f"  mu={mu} x={st.travel:.3f} s/d={st.sinkage / D:.4f} "
                                            f"QV={st.QV / 1e3:.2f} kN QH={st.QH / 1e3:.2f} kN M={st.moment:.3g} "
                                            f"slip={st.slip:.3f} its={st.iterations} solves={st.linear_solves}",
                                            flush=True)) if comm.rank == 0 and args.verbose else None)
    except SolverDivergedError as err:
        status = f"failed: {err}"
    rolled = [st for st in roll.steps if st.travel > 0]
    s = np.array([st.sinkage / D for st in rolled])
    out = {"mu": mu, "travel_d": travel_d, "ramp_rate": (args.s_end - args.s0) / travel_d, "status": status,
           "cells": tm.stats.cells, "dofs": roll.n_dofs, "steps": len(roll.steps),
           "newton_iterations": roll.newton_iterations, "cuts": roll.cuts,
           "linear_solves": int(sum(st.linear_solves for st in rolled)),
           "max_rel_moment": max((abs(st.moment) / (st.QV * D) for st in rolled), default=0.0),
           "time_s": comm.allreduce(time.perf_counter() - t0, op=MPI.MAX), "at": {},
           "curve": [(st.travel, st.sinkage, st.QV, st.QH, st.moment, st.slip) for st in roll.steps]}
    for r in args.read:
        if s.size and s[0] <= r <= s[-1]:
            qv = read_at(s, np.array([st.QV for st in rolled]), r, args.window)
            qh = read_at(s, np.array([st.QH for st in rolled]), r, args.window)
            bc = wheel_forces(r * D, Wheel(D, B), Soil(C, PHI, GAMMA), Options(mode="rolling"))
            out["at"][f"{r:g}"] = {"QV_N": qv, "QH_N": qh, "BC_QV_N": float(bc.QV), "BC_QH_N": float(bc.QH),
                                   "QV_over_BC": qv / float(bc.QV)}
    return out


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--mu", type=float, nargs="+", default=[0.8])
    ap.add_argument("--accuracy", default="fast")
    ap.add_argument("--length", type=float, default=2.5, help="block length / d (report: 3.5)")
    ap.add_argument("--half-width", type=float, default=1.0, help="block half width / d (report: 1.5)")
    ap.add_argument("--depth", type=float, default=1.0, help="block depth / d (report: 1.5)")
    ap.add_argument("--travel", type=float, default=1.0, help="travel / d of the base ramp")
    ap.add_argument("--s0", type=float, default=0.01)
    ap.add_argument("--s-end", type=float, default=0.05)
    ap.add_argument("--halve", action="store_true", help="also run with half the ramp rate (2x travel)")
    ap.add_argument("--read", type=float, nargs="+", default=list(READ), help="s/d where Q_V, Q_H are read")
    ap.add_argument("--window", type=float, default=0.0,
                    help="read Q_V, Q_H by a least-squares line over s/d +- window (0: interpolate)")
    ap.add_argument("--verbose", action="store_true")
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    comm = MPI.COMM_WORLD
    results = []
    for mu in args.mu:
        travels = [args.travel] + ([2 * args.travel] if args.halve else [])
        for tr in travels:
            if 0.4 + tr + 0.75 > args.length:
                raise SystemExit(f"block too short: length {args.length} d < 0.4 + travel {tr} + 0.75 d")
            res = run(comm, mu, tr, args)
            results.append(res)
            if comm.rank == 0:
                print(f"mu={mu} travel={tr:g} d (ramp ds/dx = {res['ramp_rate']:.4f}): {res['status']}, "
                      f"{res['cells']} cells, {res['dofs']} dofs, {res['steps']} steps, "
                      f"{res['newton_iterations']} Newton its, {res['linear_solves']} linear solves, "
                      f"{res['cuts']} cuts, max |M|/(Q_V d) = {res['max_rel_moment']:.2e}, {res['time_s']:.0f} s",
                      flush=True)
                for r, v in res["at"].items():
                    print(f"   s/d={r}: Q_V = {v['QV_N'] / 1e3:7.2f} kN (BC {v['BC_QV_N'] / 1e3:7.2f}, "
                          f"FE/BC {v['QV_over_BC']:.3f})  Q_H = {v['QH_N'] / 1e3:6.2f} kN (BC {v['BC_QH_N'] / 1e3:6.2f})",
                          flush=True)
        if args.halve and comm.rank == 0:
            a, b = results[-2], results[-1]
            for r in args.read:
                k = f"{r:g}"
                if k in a["at"] and k in b["at"]:
                    print(f"   ramp halved, s/d={k}: Q_V {a['at'][k]['QV_N'] / 1e3:.2f} -> {b['at'][k]['QV_N'] / 1e3:.2f} kN "
                          f"({b['at'][k]['QV_N'] / a['at'][k]['QV_N'] - 1:+.1%}), Q_H {a['at'][k]['QH_N'] / 1e3:.2f} -> "
                          f"{b['at'][k]['QH_N'] / 1e3:.2f} kN")
    dump_json(comm, args.out, {"args": vars(args), "results": results})


if __name__ == "__main__":
    main()
