"""Extreme soils on the 3D wheel (quarter block, fast preset): each case either converges or
fails with a clear message and the last converged state kept - never hangs (wall-clock guard).

    python -m benchmarks extremes_3d --out bench_extremes_3d.json
    python -m benchmarks extremes_3d --cases tiny_load above_capacity --max-wall 120

Mn/DOT wheel d = 1.524 m, b = 0.4572 m, fillet b/12, mu = 0.8, gamma = 20 kN/m^3; pushed to
s/d = ``--sinkage`` (displacement control) unless the case is load-controlled.  Base soil: report
case 5 (Drucker-Prager phi_dp = 27.5 deg, c_dp = 194.6 kPa, E = 40 MPa, nu = 0.35, psi = 0).

cases: phi_dp_60 (phi_dp = 60 deg, c_dp = 50 kPa, psi = 0), nu_0.49 (von Mises c_dp = 200 kPa),
E_300 / E_5000 (E/(gamma d) = 300 / 5000 with the base strength), tiny_load (Q_V = 1 kN by load
control: elastic only, no plastic point), above_capacity (load control at 10x the capacity
reached at the sinkage limit: "exceeds capacity"), layers_30_1 / layers_1_30 (top 0.4 d with
c_dp = 20 kPa over 600 kPa and the reverse, von Mises).

Prints one row per case: outcome, sinkage reached, Q_V, steps, Newton iterations, cuts, Newton
plateaus accepted, plastic points, wall time, and the message on failure.
"""
from __future__ import annotations

import argparse
import math
import time

from mpi4py import MPI

from _bench import dump_json

from rollsim.geometry import CylinderWheel, MeshOptions, build_soil_block, indentation_block
from rollsim.solver import DruckerPrager, SolverDivergedError, StepControl, VonMises
from rollsim.solver.indentation import WheelIndentation

D, B, GAMMA = 1.524, 0.4572, 20e3
DEG = math.pi / 180
BASE = dict(E=40e6, nu=0.35, phi_dp=27.5 * DEG, c_dp=194.6e3, dilation=0.0)
CASES = ("phi_dp_60", "nu_0.49", "E_300", "E_5000", "tiny_load", "above_capacity", "layers_30_1", "layers_1_30")


def materials(case):
    if case == "phi_dp_60":
        return DruckerPrager(**{**BASE, "phi_dp": 60 * DEG, "c_dp": 50e3}), ()
    if case == "nu_0.49":
        return VonMises(E=40e6, nu=0.49, yield_stress=200e3), ()
    if case in ("E_300", "E_5000"):
        return DruckerPrager(**{**BASE, "E": float(case[2:]) * GAMMA * D}), ()
    if case.startswith("layers"):
        weak, strong = VonMises(E=40e6, nu=0.35, yield_stress=20e3), VonMises(E=40e6, nu=0.35, yield_stress=600e3)
        top, bottom = (weak, strong) if case == "layers_30_1" else (strong, weak)
        return {1: top, 2: bottom}, (0.4,)
    return DruckerPrager(**BASE), ()


def run_case(comm, case, args):
    t0 = time.perf_counter()
    mats, layers = materials(case)
    tm = build_soil_block(comm, indentation_block(D, layers=layers), MeshOptions.from_accuracy(D, args.accuracy))
    ind = WheelIndentation(tm, CylinderWheel(D, B, B / 12), mats, gamma=GAMMA, friction=0.8)
    ctl = StepControl(dt=0.05, dt_min=1e-4, dt_max=0.2, easy_iterations=8, max_cuts=10, max_wall_time=args.max_wall)
    row = {"case": case, "dofs": ind.n_dofs}
    try:
        ind.gravity_step()
        if case == "tiny_load":
            res = ind.push_to_load(1e3, 0.02 * D, control=ctl)
            row.update(outcome=res.status, message=res.reason)
        elif case == "above_capacity":
            probe = WheelIndentation(tm, CylinderWheel(D, B, B / 12), mats, gamma=GAMMA, friction=0.8)
            probe.gravity_step()
            probe.push(args.sinkage * D, control=ctl)
            target = 10 * max(st.QV for st in probe.steps)
            res = ind.push_to_load(target, args.sinkage * D, control=ctl)
            row.update(outcome=res.status, message=res.reason, target_QV=target)
        else:
            ind.push(args.sinkage * D, control=ctl)
            row.update(outcome="ok", message="")
    except SolverDivergedError as err:
        row.update(outcome="failed", message=str(err))
    last = ind.steps[-1] if ind.steps else None
    row.update(sinkage=ind.sinkage, QV=last.QV if last else 0.0, plastic=last.plastic if last else 0,
               steps=len(ind.steps), newton_iterations=ind.newton_iterations, cuts=ind.cuts,
               plateaus=ind.problem.plateaus["accepted"], time_s=comm.allreduce(time.perf_counter() - t0, op=MPI.MAX))
    return row


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--cases", nargs="+", default=list(CASES), choices=CASES)
    p.add_argument("--sinkage", type=float, default=0.05, help="s/d of the displacement-controlled pushes")
    p.add_argument("--accuracy", default="fast")
    p.add_argument("--max-wall", type=float, default=300.0, help="wall-clock guard per case, s")
    p.add_argument("--out")
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    rows = []
    if comm.rank == 0:
        print(f"{'case':15s} {'outcome':17s} {'s/d':>7s} {'Q_V kN':>9s} {'plastic':>7s} {'steps':>5s} {'its':>5s} "
              f"{'cuts':>4s} {'plat.':>5s} {'wall s':>7s}  message", flush=True)
    for case in args.cases:
        r = run_case(comm, case, args)
        rows.append(r)
        if comm.rank == 0:
            print(f"{case:15s} {r['outcome']:17s} {r['sinkage'] / D:7.4f} {r['QV'] / 1e3:9.1f} {r['plastic']:7d} "
                  f"{r['steps']:5d} {r['newton_iterations']:5d} {r['cuts']:4d} {r['plateaus']:5d} {r['time_s']:7.1f}  "
                  f"{r['message'][:160]}", flush=True)
    dump_json(comm, args.out, {"args": vars(args), "rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
