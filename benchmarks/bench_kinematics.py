"""Small strain against updated Lagrangian (incremental large deformation): where they differ.

    python -m benchmarks kinematics --out bench_kinematics.json
    mpirun -n 2 python -m benchmarks kinematics --s-end 0.15 --rolling

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
import time

import numpy as np
from mpi4py import MPI

from _bench import dump_json

from rollsim.geometry import CylinderWheel, MeshOptions, build_soil_block, indentation_block, rolling_block
from rollsim.solver import SolverDivergedError, VonMises
from rollsim.solver.indentation import WheelIndentation
from rollsim.solver.rolling import WheelRolling

D, B, GAMMA = 1.524, 0.4572, 20e3
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


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
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
    raise SystemExit(main())
