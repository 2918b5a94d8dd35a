"""Purely frictional soil (c = 0) under the rigid wheel: 3D indentation to s/d = 0.1 against the
bearing-capacity model, and the sensitivity to the regularising cohesion c_reg or, with c = 0
exactly, to the Duvaut-Lions relaxation length (mm of sinkage).

    python -m benchmarks frictional_wheel                       # phi 35 40 45, c_reg = 1 kPa
    python -m benchmarks frictional_wheel --phi 40 --creg 2 1 0.5 --out bench_c0.json
    python -m benchmarks frictional_wheel --phi 40 --creg 0 --max-wall 1800   # c = 0 exactly
    python -m benchmarks frictional_wheel --phi 40 --creg 0 --relaxation-length 0 0.0078125 0.00390625

Setup: wheel d = 1.524 m, b = 0.4572 m (fillet b/12), mu = 0.8, quarter block at the
``fast`` preset, E = 40 MPa, nu = 0.35, gamma = 20 kN/m^3, K0 default (clipped into the cone),
Drucker-Prager matched to Mohr-Coulomb (c_reg, phi) in plane strain (``--match``), psi = 0,
penalty alpha = 1 (``--alpha``), gravity first.  Prints Q_V at s/d = 0.02 / 0.05 / 0.1 (FE and the
bearing-capacity model with c = 0, indentation mode), their ratio, steps, Newton iterations, step
cuts and wall time; with several relaxation lengths, their Q_V against the rate-independent run
and two extrapolations to L -> 0.  Serial; each run is stopped by a wall-clock guard
(``--max-wall``).
"""
from __future__ import annotations

import argparse
import json
import math
import time

from mpi4py import MPI

from _bench import add_volumetric_strain
from rollsim.geometry import CylinderWheel, MeshOptions, build_soil_block, indentation_block
from rollsim.solver.options import DEFAULT_VOLUMETRIC_STRAIN
from rollsim.solver import DruckerPrager, SolverDivergedError, StepControl
from rollsim.solver.indentation import WheelIndentation
from rollsim.studies.bearing_capacity import Options, Soil, Wheel, wheel_forces

D, B, GAMMA, MU = 1.524, 0.4572, 20e3, 0.8
REPORT = (0.02, 0.05, 0.1)
STOPS = (0.01, 0.02, 0.03, 0.05, 0.08, 0.1)


def control(max_wall: float) -> StepControl:
    return StepControl(dt=0.1, dt_min=1e-4, dt_max=0.25, easy_iterations=15, max_cuts=10,
                       max_wall_time=max_wall)


def run(comm, phi_deg, c_reg, *, match="plane_strain", alpha=1.0, accuracy="fast", s_end=0.1, max_wall=240.0,
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


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
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
    args = ap.parse_args()
    comm = MPI.COMM_WORLD
    results = []
    for phi in args.phi:
        for c in args.creg:
            for ell in args.relaxation_length:
                r = run(comm, phi, c * 1e3, match=args.match, alpha=args.alpha, accuracy=args.accuracy,
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


if __name__ == "__main__":
    main()
