"""Rolling against measurements and the analytic model, two problems.

``lab``: FE rolling against the laboratory rolling tests on the very soft clay, and the analytic model.

    mpirun -n 2 python -m benchmarks validation lab --series clay_large clay_small --out bench_lab.json

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

``layered``: Influence depth of a weak lower layer under the rolling wheel: FE (constant load) vs the model.

    mpirun -n 2 python -m benchmarks validation layered --cases 17 18 19 --out bench_layered.json
    mpirun -n 2 python -m benchmarks validation layered --cases 13 14 15 --relaxation-length 1
    mpirun -n 2 python -m benchmarks validation layered --cases 17 18 19 --rolling steady

Cases of ``studies/data/cases_layered.csv`` (three layers of 0.4 d over a fixed base; Mn/DOT roller,
d = 1.524 m, b = 0.4572 m, mu = 0.8, nu = 0.35, gamma = 20 kN/m^3; Drucker-Prager per layer),
protocol rolling-constant-load at Q_V = 133.5 kN through ``run_scene`` (run directories under
``--out-dir``), ``--accuracy`` preset, half block ``--length`` x ``--half-width`` in d and
deep enough for the layers (1.2 d + ``--below`` d); or, with ``--rolling steady``, the steady
state in the wheel's frame (its window reaches 0.2 d below the deepest layer boundary).

Cases 17-19 are strong clay (c_dp = 300 kPa) with a very weak clay (c_dp = 20 kPa, E = 10 MPa)
from 1.2 d (17: none in the block), 0.8 d (18) or 0.4 d (19) down; 13-15 the same with dense
sand on top.  The FE influence depth is bracketed by the weak-layer depths at which the sinkage changes by
more or less than ``--tolerance`` against the homogeneous case, compared at equal travel (the
mean over the last ``--compare`` d of the shortest run).  The model's influence depth
(``rollsim influence``: Meyerhof & Hanna, rolling footing B, L of the top layer at this load)
is printed for the same pair of layers, c and phi from the compression match.
``--relaxation-length`` (mm): the Duvaut-Lions regularisation of the soil along the whole path
(``[model] relaxation_length``); without it the dense sand of cases 13-16 rolls by the travel
fallback of a plain scene (a failed roll starts over relaxed).
"""
from __future__ import annotations

import argparse
import csv
import math
import pathlib
import sys
import time

import numpy as np
from mpi4py import MPI

from _bench import add_volumetric_strain, dump_json, read_at, run_problems

from rollsim.geometry import CylinderWheel, MeshOptions, build_soil_block, rolling_block
from rollsim.scene import parse_scene
from rollsim.solver import SolverDivergedError, VonMises
from rollsim.solver.materials import dp_to_mc
from rollsim.solver.rolling import WheelRolling
from rollsim.solver.run import run_scene
from rollsim.studies.bearing_capacity import Soil, Wheel, wheel_forces
from rollsim.studies.design import LAB_SOILS
from rollsim.studies.layered import influence_depth

LAB_DATA = pathlib.Path(__file__).parents[1] / "studies" / "data" / "lab_rolling.csv"
#: E (Pa) of the clay for each wheel's laboratory tests (docs/validation.md); nu as the report's simulations
LAB_E = {"clay_small": 2.0e6, "clay_large": 2.5e6}
NU = 0.45
BED_HALF_WIDTH, BED_DEPTH = 0.125, 0.100   # m


def points(series: str) -> tuple[float, float, np.ndarray, np.ndarray]:
    rows = [r for r in csv.DictReader(LAB_DATA.open()) if r["series"] == series]
    if not rows:
        raise SystemExit(f"--series: no rows for {series!r} in {LAB_DATA}")
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


def lab(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks validation lab",
                                description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
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


LAYERED_DATA = pathlib.Path(__file__).parents[1] / "studies" / "data" / "cases_layered.csv"
D, B, GAMMA, LOAD = 1.524, 0.4572, 20e3, 133.5e3


def case_rows() -> dict[int, dict]:
    lines = [ln for ln in LAYERED_DATA.open() if not ln.startswith("#")]
    return {int(r["case"]): r for r in csv.DictReader(lines)}


def scene_of(row: dict, accuracy: str, travel: float, relaxation_length: float = 0.0, rolling: str = "transient"):
    layers = []
    for k in (1, 2, 3):
        layer = {"model": "drucker-prager", "E": float(row[f"E{k}_MPa"]) * 1e6, "nu": 0.35,
                 "phi_dp": float(row[f"phi_dp{k}_deg"]), "c_dp": float(row[f"c_dp{k}_kPa"]) * 1e3}
        if k < 3:
            layer["thickness"] = 0.4 * D
        layers.append(layer)
    return parse_scene({"wheel": {"diameter": D, "width": B, "friction": 0.8},
                        "soil": {"gamma": GAMMA, "layers": layers},
                        "loading": {"protocol": "rolling-constant-load", "load": LOAD, "travel": travel},
                        "model": {"accuracy": accuracy, "rolling": rolling,
                                  **({"relaxation_length": relaxation_length} if rolling == "transient" else {})}})


def _weaker(row: dict, k: int) -> bool:
    """Layer k weaker than layer 1: no stronger in either parameter, weaker in one."""
    c1, p1 = float(row["c_dp1_kPa"]), float(row["phi_dp1_deg"])
    ck, pk = float(row[f"c_dp{k}_kPa"]), float(row[f"phi_dp{k}_deg"])
    return ck <= c1 and pk <= p1 and (ck < c1 or pk < p1)


def _first_weak(row: dict) -> int | None:
    return next((k for k in (2, 3) if _weaker(row, k)), None)


def weak_depth(row: dict) -> float | None:
    """Depth (in d) of the top of the first layer weaker than layer 1 (None: none)."""
    k = _first_weak(row)
    return None if k is None else 0.4 * (k - 1)


def model_influence(row: dict) -> float | None:
    """The model's influence depth (m) of the weak layer under the top layer at LOAD."""
    k = _first_weak(row)
    if k is None:
        return None
    c1, phi1 = dp_to_mc(math.radians(float(row["phi_dp1_deg"])), float(row["c_dp1_kPa"]) * 1e3)
    c2, phi2 = dp_to_mc(math.radians(float(row[f"phi_dp{k}_deg"])), float(row[f"c_dp{k}_kPa"]) * 1e3)
    if phi1 > 0:
        c1 = 0.0           # the model's sand-over-clay case is for c = 0 sand (the report's approach)
    res = influence_depth(Wheel(D, B), Soil(c1, phi1, GAMMA), c2, phi2, load=LOAD)
    return float(res.H_m)


def rolled_sinkage(history: pathlib.Path):
    """(travel, sinkage) of the rolled steps at the load (not the press or the lift-off) of a run."""
    rows = list(csv.DictReader(history.open()))
    x = np.array([float(r["travel_m"]) for r in rows])
    s = np.array([float(r["sinkage_m"]) for r in rows])
    on = (x > 0) & (np.array([float(r["QV_N"]) for r in rows]) > 0.99 * LOAD)
    return x[on], s[on]


def layered(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks validation layered",
                                description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--cases", type=int, nargs="+", default=[17, 18, 19])
    p.add_argument("--accuracy", default="fast")
    p.add_argument("--length", type=float, default=2.6, help="block length, d")
    p.add_argument("--half-width", type=float, default=1.0, help="block half width, d")
    p.add_argument("--below", type=float, default=0.5, help="block depth below the layers, d")
    p.add_argument("--stiff", type=float, default=0.5, help="stiff start zone, d")
    p.add_argument("--travel", type=float, default=1.6, help="travel limit, d")
    p.add_argument("--tolerance", type=float, default=0.05, help="relative sinkage change that counts")
    p.add_argument("--compare", type=float, default=0.25, help="travel window of the comparison, d")
    p.add_argument("--relaxation-length", type=float, default=0.0,
                   help="Duvaut-Lions relaxation length, mm of travel ([model] relaxation_length; 0: off)")
    p.add_argument("--rolling", choices=("transient", "steady"), default="transient",
                   help="steady: the steady state in the wheel's frame (no block, travel or relaxation)")
    p.add_argument("--out-dir", default="out/bench_layered")
    p.add_argument("--out")
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    rows = case_rows()
    results = []
    for case in args.cases:
        t0 = time.perf_counter()
        row = rows[case]
        scene = scene_of(row, args.accuracy, args.travel * D, 1e-3 * args.relaxation_length, args.rolling)
        block = {} if args.rolling == "steady" else {
            "block": {"length": args.length, "half_width": args.half_width, "depth": 1.2 + args.below,
                      "stiff_length": args.stiff}}
        summary = run_scene(scene, pathlib.Path(args.out_dir) / f"case{case}", comm, progress=False, **block)
        ss = summary.get("steady_state", {"reached": summary["status"] == "ok"})
        res = {"case": case, "status": summary["status"], "weak_from_d": weak_depth(row),
               "steady": ss.get("reached"), "sinkage_m": summary.get("sinkage_m"), "QH_N": summary.get("QH_N"),
               "rut_depth_m": summary.get("rut_depth_m"), "model_H_m": model_influence(row),
               "steps": summary.get("steps"), "newton_iterations": summary.get("newton_iterations"),
               "time_s": comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)}
        results.append(res)
        if comm.rank == 0:
            H = res["model_H_m"]
            print(f"case {case}: weak layer from {res['weak_from_d']} d: {res['status']}, steady {res['steady']}, "
                  f"s = {1e3 * (res['sinkage_m'] or float('nan')):.2f} mm, Q_H = {(res['QH_N'] or float('nan')) / 1e3:.2f} kN, "
                  f"rut {1e3 * (res['rut_depth_m'] or float('nan')):.2f} mm; model influence depth "
                  + (f"{H:.3f} m = {H / D:.2f} d" if H is not None else "-") + f"; {res['steps']} steps, "
                  f"{res['newton_iterations']} Newton iterations, "
                  f"{res['time_s']:.0f} s", flush=True)
    if comm.rank == 0:
        if args.rolling == "steady":                # one steady sinkage per case
            mean = {r["case"]: r["sinkage_m"] for r in results if r["status"] == "ok"}
        else:
            # compare at equal travel: the mean sinkage over the last --compare d of the shortest run
            # (a run that did not reach steady state ran on towards the block's end)
            hist = {r["case"]: rolled_sinkage(pathlib.Path(args.out_dir) / f"case{r['case']}" / "history.csv")
                    for r in results if r["status"] == "ok"}
            end = min((x[-1] for x, _ in hist.values()), default=0.0)
            mean = {c: float(s[(x >= end - args.compare * D) & (x <= end)].mean()) for c, (x, s) in hist.items()}
            if mean:
                print(f"mean sinkage over travel {end - args.compare * D:.2f}-{end:.2f} m: "
                      + ", ".join(f"case {c} {1e3 * v:.2f} mm" for c, v in mean.items()))
        base = next((r for r in results if r["weak_from_d"] is None and r["case"] in mean), None)
        if base and len(mean) > 1:
            for r in results:
                if r["weak_from_d"] is not None and r["case"] in mean:
                    change = mean[r["case"]] / mean[base["case"]] - 1
                    r["sinkage_change_vs_base"] = change
                    verdict = "inside" if abs(change) > args.tolerance else "outside"
                    print(f"weak layer from {r['weak_from_d']} d (case {r['case']}): sinkage {100 * change:+.1f} % vs "
                          f"case {base['case']} -> the weak layer is {verdict} the FE influence depth "
                          f"(tolerance {100 * args.tolerance:g} %)")

    dump_json(comm, args.out, {"args": vars(args), "results": results})
    return 0



if __name__ == "__main__":
    sys.exit(run_problems({"lab": lab, "layered": layered}, __doc__))
