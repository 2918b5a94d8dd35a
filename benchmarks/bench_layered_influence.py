"""Influence depth of a weak lower layer under the rolling wheel: FE (constant load) vs the model.

    mpirun -n 2 python -m benchmarks layered_influence --cases 17 18 19 --out bench_layered.json
    mpirun -n 2 python -m benchmarks layered_influence --cases 13 14 15 --relaxation-length 1

Cases of ``studies/data/cases_layered.csv`` (three layers of 0.4 d over a fixed base; Mn/DOT roller,
d = 1.524 m, b = 0.4572 m, mu = 0.8, nu = 0.35, gamma = 20 kN/m^3; Drucker-Prager per layer),
protocol rolling-constant-load at Q_V = 133.5 kN through ``run_scene`` (run directories under
``--out-dir``), ``--accuracy`` preset, half block ``--length`` x ``--half-width`` in d and
deep enough for the layers (1.2 d + ``--below`` d).

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
import time

import numpy as np
from mpi4py import MPI

from _bench import dump_json

from rollsim.scene import parse_scene
from rollsim.solver.materials import dp_to_mc
from rollsim.solver.run import run_scene
from rollsim.studies.bearing_capacity import Soil, Wheel
from rollsim.studies.layered import influence_depth

DATA = pathlib.Path(__file__).parents[1] / "studies" / "data" / "cases_layered.csv"
D, B, GAMMA, LOAD = 1.524, 0.4572, 20e3, 133.5e3


def case_rows() -> dict[int, dict]:
    lines = [ln for ln in DATA.open() if not ln.startswith("#")]
    return {int(r["case"]): r for r in csv.DictReader(lines)}


def scene_of(row: dict, accuracy: str, travel: float, relaxation_length: float = 0.0):
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
                        "model": {"accuracy": accuracy, "relaxation_length": relaxation_length}})


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


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
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
    p.add_argument("--out-dir", default="out/bench_layered")
    p.add_argument("--out")
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    rows = case_rows()
    results = []
    for case in args.cases:
        t0 = time.perf_counter()
        row = rows[case]
        scene = scene_of(row, args.accuracy, args.travel * D, 1e-3 * args.relaxation_length)
        summary = run_scene(scene, pathlib.Path(args.out_dir) / f"case{case}", comm, progress=False,
                              block={"length": args.length, "half_width": args.half_width,
                                     "depth": 1.2 + args.below, "stiff_length": args.stiff})
        ss = summary.get("steady_state", {})
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
        # compare at equal travel: the mean sinkage over the last --compare d of the shortest run
        # (a run that did not reach steady state ran on towards the block's end)
        hist = {r["case"]: rolled_sinkage(pathlib.Path(args.out_dir) / f"case{r['case']}" / "history.csv")
                for r in results if r["status"] == "ok"}
        base = next((r for r in results if r["weak_from_d"] is None and r["case"] in hist), None)
        if base and len(hist) > 1:
            end = min(x[-1] for x, _ in hist.values())
            mean = {c: float(s[(x >= end - args.compare * D) & (x <= end)].mean()) for c, (x, s) in hist.items()}
            print(f"mean sinkage over travel {end - args.compare * D:.2f}-{end:.2f} m: "
                  + ", ".join(f"case {c} {1e3 * v:.2f} mm" for c, v in mean.items()))
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
    raise SystemExit(main())
