"""FE rolling against the laboratory rolling tests on the very soft clay, and the analytic model.

    mpirun -n 2 python -m benchmarks lab_rolling --series clay_large clay_small --out bench_lab.json

Data: ``studies/data/lab_rolling.csv`` (steady Q_V of a towed aluminium wheel with a sandpaper
surface, the bed translated at a fixed sinkage) and the report's laboratory tests
(docs/validation.md): Duluth clay, phi ~ 0,
gamma = 18.5 kN/m^3, nu = 0.45; small wheel (d = 77.7 mm, b = 25.4 mm) E = 2 MPa,
sigma_0 = 72 kPa; large wheel (d = 115.4 mm, b = 38.3 mm) E = 2.5 MPa, sigma_0 = 70 kPa.
Von Mises with yield stress sigma_0 (c = sigma_0 / 2); the wheel's friction ``--mu``.

FE: protocol rolling-continuous on a half block with the bed's half width (125 mm) and depth
(100 mm, fixed base) and long enough for the travel (start 0.4 d + travel + 1 d); the sinkage is
ramped from 0.005 d to 1.1 x the largest measured sinkage over ``--travel`` d.  Q_V at each
measured sinkage is read by a least-squares line over s +- ``--window`` d (the fast mesh's ripple).

Both kinematics (``--kinematics``): the tests reach s/d = 0.12, where they differ.
``--holds N``: the N smallest measured sinkages are also rolled at a fixed sinkage, as the lab did
(ramped over 0.5 d, held ``--hold-travel`` d, Q_V averaged over the second half of the hold): the
ramped curve's first points are still in the start-up transient.
``--volumetric-strain``: pointwise (default) or cell-average (B-bar).
Model: rolling, footing method, D = s, c = sigma_0 / 2 (as ``rollsim design``).
Prints, per measured point, Q_V measured / FE / model and the two ratios.
"""
from __future__ import annotations

import argparse
import csv
import pathlib
import time

import numpy as np
from mpi4py import MPI

from _bench import add_volumetric_strain, dump_json, read_at

from rollsim.geometry import CylinderWheel, MeshOptions, build_soil_block, rolling_block
from rollsim.solver import SolverDivergedError, VonMises
from rollsim.solver.rolling import WheelRolling
from rollsim.studies.bearing_capacity import Soil, Wheel, wheel_forces
from rollsim.studies.design import LAB_SOILS

DATA = pathlib.Path(__file__).parents[1] / "studies" / "data" / "lab_rolling.csv"
#: E (Pa) of the clay for each wheel's laboratory tests (docs/validation.md); nu as the report's simulations
LAB_E = {"clay_small": 2.0e6, "clay_large": 2.5e6}
NU = 0.45
BED_HALF_WIDTH, BED_DEPTH = 0.125, 0.100   # m


def points(series: str) -> tuple[float, float, np.ndarray, np.ndarray]:
    rows = [r for r in csv.DictReader(DATA.open()) if r["series"] == series]
    if not rows:
        raise SystemExit(f"--series: no rows for {series!r} in {DATA}")
    d, b = float(rows[0]["wheel_d_mm"]) / 1e3, float(rows[0]["wheel_b_mm"]) / 1e3
    return d, b, np.array([float(r["s_mm"]) / 1e3 for r in rows]), np.array([float(r["QV_N"]) for r in rows])


def _lab_wheel(comm, series: str, kinematics: str, travel: float, args):
    """The bed (half block) and towed wheel of ``series`` after the gravity step."""
    d, b, _, _ = points(series)
    c, _, gamma = LAB_SOILS[series]
    mat = VonMises(E=LAB_E[series], nu=NU, yield_stress=2 * c)
    blk = rolling_block(d, length=0.4 + travel + 1.0, half_width=BED_HALF_WIDTH / d, depth=BED_DEPTH / d,
                        stiff_length=0.0)
    tm = build_soil_block(comm, blk, MeshOptions.from_accuracy(d, args.accuracy))
    roll = WheelRolling(tm, CylinderWheel(d, b, b / 12), mat, gamma=gamma, friction=args.mu, kinematics=kinematics,
                        volumetric_strain=args.volumetric_strain)
    roll.gravity_step()
    return roll, tm, mat


def hold(comm, series: str, s_hold: float, args) -> dict:
    """Steady rolling at a fixed sinkage, as in the lab: ramped to ``s_hold`` (m) over 0.5 d, held
    for ``--hold-travel`` d; the mean Q_V over the second half of the hold (small strain)."""
    t0 = time.perf_counter()
    d = points(series)[0]
    roll, _, _ = _lab_wheel(comm, series, "small-strain", 0.5 + args.hold_travel, args)
    status = "ok"
    try:
        roll.press(min(0.002 * d, 0.5 * s_hold))
        roll.roll((0.5 + args.hold_travel) * d, s_hold, ramp=0.5 * d)
    except SolverDivergedError as err:
        status = f"failed: {err}"
    late = [st.QV for st in roll.steps if st.travel >= (0.5 + 0.5 * args.hold_travel) * d]
    return {"s_mm": 1e3 * s_hold, "status": status, "QV_N": float(np.mean(late)) if late else None,
            "QV_std_N": float(np.std(late)) if late else None, "steps": len(late),
            "time_s": comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)}


def run(comm, series: str, kinematics: str, args) -> dict:
    t0 = time.perf_counter()
    d, b, s_lab, q_lab = points(series)
    c, _, gamma = LAB_SOILS[series]
    roll, tm, mat = _lab_wheel(comm, series, kinematics, args.travel, args)
    s_end = 1.1 * s_lab.max()
    status = "ok"
    try:
        roll.press(0.005 * d)
        roll.roll(args.travel * d, s_end)
    except SolverDivergedError as err:
        status = f"failed: {err}"
    rolled = [st for st in roll.steps if st.travel > 0]
    s = np.array([st.sinkage for st in rolled])
    q = np.array([st.QV for st in rolled])
    table = []
    for si, qi in zip(s_lab, q_lab):
        fe = read_at(s, q, si, args.window * d) if s.size and s[0] <= si <= s[-1] else None
        model = float(wheel_forces(si, Wheel(d, b), Soil(c, 0.0, gamma)).QV)
        table.append({"s_mm": 1e3 * si, "s_over_d": si / d, "QV_lab_N": qi, "QV_fe_N": fe, "QV_model_N": model,
                      "fe_over_lab": fe / qi if fe else None, "model_over_lab": model / qi})
    return {"series": series, "kinematics": kinematics, "d": d, "b": b, "E": mat.E, "yield_stress": mat.yield_stress, "status": status,
            "cells": tm.stats.cells, "dofs": roll.n_dofs, "steps": len(roll.steps), "cuts": roll.cuts,
            "newton_iterations": roll.newton_iterations, "ramp_rate": (s_end / d - 0.005) / args.travel,
            "time_s": comm.allreduce(time.perf_counter() - t0, op=MPI.MAX), "points": table,
            "curve": [(st.travel, st.sinkage, st.QV, st.QH) for st in rolled]}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--series", nargs="+", default=["clay_large", "clay_small"], choices=sorted(LAB_E))
    p.add_argument("--mu", type=float, default=0.0, help="wheel friction (sandpaper; 0 is cheaper)")
    p.add_argument("--accuracy", default="fast")
    p.add_argument("--holds", type=int, default=0,
                   help="also roll at the N smallest measured sinkages held fixed (as the lab did)")
    p.add_argument("--hold-travel", type=float, default=1.5, help="travel at the held sinkage, d")
    p.add_argument("--kinematics", nargs="*", default=["small-strain", "updated-lagrangian"],
                   choices=["small-strain", "updated-lagrangian"])
    p.add_argument("--travel", type=float, default=3.0, help="d")
    add_volumetric_strain(p)
    p.add_argument("--window", type=float, default=0.01, help="half window of the Q_V reading, d")
    p.add_argument("--out")
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    results = []
    for series in args.series if args.holds else ():
        d, b, s_lab, q_lab = points(series)
        c, _, gamma = LAB_SOILS[series]
        for s_hold, q in sorted(zip(s_lab, q_lab))[:args.holds]:
            res = hold(comm, series, s_hold, args)
            res.update(series=series, QV_lab_N=q, QV_model_N=float(wheel_forces(s_hold, Wheel(d, b), Soil(c, 0.0, gamma)).QV))
            results.append(res)
            if comm.rank == 0:
                fe = (f"{res['QV_N']:.1f} +- {res['QV_std_N']:.1f} N (FE/lab {res['QV_N'] / q:.2f})" if res["QV_N"]
                      else "-")
                print(f"{series}, held at s = {res['s_mm']:.1f} mm (s/d {s_hold / d:.3f}): {res['status']}; Q_V lab "
                      f"{q:.1f} N, FE {fe}, model {res['QV_model_N']:.1f} N (model/lab {res['QV_model_N'] / q:.2f}); "
                      f"{res['time_s']:.0f} s", flush=True)
    for series, kinematics in ((s, k) for s in args.series for k in args.kinematics):
        res = run(comm, series, kinematics, args)
        results.append(res)
        if comm.rank == 0:
            print(f"{series}, {kinematics}: d = {1e3 * res['d']:.1f} mm, E = {res['E'] / 1e6:g} MPa, sigma_0 = "
                  f"{res['yield_stress'] / 1e3:g} kPa, mu = {args.mu:g}: {res['status']}, {res['cells']} cells, "
                  f"{res['dofs']} dofs, {res['steps']} steps, {res['cuts']} cuts, ramp ds/dx = "
                  f"{res['ramp_rate']:.3f}, {res['time_s']:.0f} s")
            print("   s (mm)   s/d     Q_V lab (N)  Q_V FE (N)  Q_V model (N)  FE/lab  model/lab")
            for r in res["points"]:
                fe = f"{r['QV_fe_N']:10.1f}  " if r["QV_fe_N"] else "        -   "
                ratio = f"{r['fe_over_lab']:6.2f}" if r["fe_over_lab"] else "     -"
                print(f"   {r['s_mm']:6.1f}  {r['s_over_d']:6.3f}  {r['QV_lab_N']:11.1f}  {fe}{r['QV_model_N']:13.1f}  "
                      f"{ratio}  {r['model_over_lab']:9.2f}", flush=True)
    dump_json(comm, args.out, {"args": vars(args), "results": results})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
