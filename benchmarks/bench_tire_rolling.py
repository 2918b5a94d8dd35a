"""The towed pneumatic tire against a towed rigid wheel of its size, at constant load on the same
soil, through ``rollsim run`` of ``examples/pneumatic_rolling.toml``.

    python -m benchmarks tire_rolling --wheel pneumatic rigid --refinement 6 8 \\
        --out benchmarks/results/tire_rolling.json
    python -m benchmarks tire_rolling --table benchmarks/results/tire_rolling.json

For each wheel (``pneumatic``: the example; ``rigid``: a cylinder of the same diameter and width,
fillet b/12, with the example's friction) and each ``--refinement`` (elements per d) the example
is run with ``--load`` kN and ``--travel`` m; the table gives the steady sinkage and ``Q_H`` when
the steady state was detected, and in every case the mean and spread of the sinkage and ``Q_H`` of
the rolled steps whose axle is at least ``--settled`` d past the stiff start zone (the two wheels'
zones end at different x), the tire's rolling radius and deflection, the cost, and each wheel's
sinkage over the rigid wheel's on the same mesh.  An existing ``--out`` file is resumed: the runs
it holds are not repeated.  Run under ``mpirun -n N`` for N ranks (kept in the table).
"""
from __future__ import annotations

import argparse
import csv
import json
import pathlib
import re
import tempfile

import numpy as np
from mpi4py import MPI

from _bench import add_results_arguments, dump_json, saved_results, show_table

from rollsim.scene import load_scene
from rollsim.solver.options import VOLUMETRIC_STRAINS
from rollsim.solver.run import run_scene

EXAMPLE = pathlib.Path(__file__).parents[1] / "examples" / "pneumatic_rolling.toml"


def scene_text(wheel: str, refinement: float, load: float, travel: float, strain: str = "default") -> str:
    """The example scene with ``wheel`` ("pneumatic" or "rigid"), ``refinement`` elements per d,
    ``load`` kN, ``travel`` m and the volumetric ``strain`` ("default": the scene's)."""
    text = EXAMPLE.read_text()
    text = re.sub(r'(?m)^load = .*$', f'load = "{load:g} kN"', text)
    text = re.sub(r'(?m)^travel = .*$', f'travel = "{travel:g} m"', text)
    if wheel == "rigid":          # the tire's keys go; diameter, width and friction stay
        text = re.sub(r'(?m)^(type|hub_diameter|inflation|E_carcass|nu_carcass) = .*\n', "", text)
    text += f"refinement = {refinement:g}\n"
    return text if strain == "default" else text + f'volumetric_strain = "{strain}"\n'


def settled(out: pathlib.Path, summary: dict, settled_d: float) -> dict:
    """Mean and standard deviation of the sinkage and Q_H of the rolled steps whose axle is at
    least ``settled_d`` d past the stiff start zone (from ``history.csv``)."""
    with (out / "history.csv").open() as f:
        rows = list(csv.DictReader(f))
    d = summary["scene"]["wheel"]["diameter"]
    x0, x_soft = summary["model"]["x_start_m"], summary["model"]["stiff_zone_end_m"]
    late = [r for r in rows if float(r["travel_m"]) > 0 and x0 + float(r["travel_m"]) >= x_soft + settled_d * d]
    s = np.array([float(r["sinkage_m"]) for r in late])
    qh = np.array([float(r["QH_N"]) for r in late])
    if len(late) < 3:
        return {"settled_steps": len(late)}
    return {"settled_steps": len(late), "sinkage_mean": float(s.mean()), "sinkage_std": float(s.std()),
            "QH_mean": float(qh.mean()), "QH_std": float(qh.std())}


def run_case(comm, wheel: str, refinement: float, args) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        tmp = pathlib.Path(comm.bcast(tmp if comm.rank == 0 else None))
        path = tmp / "scene.toml"
        if comm.rank == 0:
            path.write_text(scene_text(wheel, refinement, args.load, args.travel, args.strain))
        comm.barrier()
        out = tmp / "run"
        summary = run_scene(load_scene(path), out, comm, progress=False, write_fields=False)
        row = {"wheel": wheel, "refinement": refinement, "load_kN": args.load, "travel_m": args.travel,
               "strain": args.strain, "volumetric_strain": summary["model"]["volumetric_strain"],
               "ranks": comm.size, "status": summary["status"], "reason": summary["reason"],
               "dofs": summary["dofs"], "steps": summary["steps"], "newton_iterations": summary["newton_iterations"],
               "step_cuts": summary["step_cuts"], "time_s": summary["wall_time_s"],
               "steady": summary.get("steady_state", {}).get("reached", False),
               "steady_sinkage": summary.get("steady_state", {}).get("sinkage"),
               "steady_QH": summary.get("steady_state", {}).get("QH"),
               "rolling_radius_m": summary.get("rolling_radius_m"), "tire": summary.get("tire"),
               "settled_d": args.settled, **(settled(out, summary, args.settled) if comm.rank == 0 else {})}
        comm.barrier()
    return comm.bcast(row if comm.rank == 0 else None)


def _strain(r: dict) -> str:
    """The ``--strain`` a saved run was made with."""
    return r.get("strain", "default")


def table(results: list[dict]) -> str:
    lines = ["| wheel | strain | elements / d | dofs | steady sinkage | mean sinkage (± std) | mean Q_H (± std) | over rigid "
             "| rolling radius | deflection | steps | Newton its | cuts | wall time (ranks) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    rigid = {(r["refinement"], r["load_kN"], _strain(r)): r for r in results
             if r["wheel"] == "rigid" and "sinkage_mean" in r}
    for r in sorted(results, key=lambda r: (r["load_kN"], _strain(r), r["refinement"], r["wheel"])):
        if "sinkage_mean" not in r:
            lines.append(f"| {r['wheel']} | {r['volumetric_strain']} | {r['refinement']:g} | {r['dofs']} | {r['status']} | too short to read "
                         f"| | | | | {r['steps']} | {r['newton_iterations']} | {r['step_cuts']} | {r['time_s']:.0f} s "
                         f"({r['ranks']}) |")
            continue
        steady = f"{1e3 * r['steady_sinkage']:.2f} mm" if r["steady"] else "not detected"
        ref = rigid.get((r["refinement"], r["load_kN"], _strain(r)))
        ratio = f"{r['sinkage_mean'] / ref['sinkage_mean']:.2f}" if ref else ""
        tire = r.get("tire") or {}
        radius = f"{r['rolling_radius_m']:.3f} m" if r.get("rolling_radius_m") else ""
        deflection = f"{1e3 * tire['deflection_m']:.1f} mm" if tire.get("deflection_m") is not None else ""
        lines.append(f"| {r['wheel']} | {r['volumetric_strain']} | {r['refinement']:g} | {r['dofs']} | {steady} "
                     f"| {1e3 * r['sinkage_mean']:.2f} ± {1e3 * r['sinkage_std']:.2f} mm "
                     f"| {r['QH_mean'] / 1e3:.2f} ± {r['QH_std'] / 1e3:.2f} kN | {ratio} | {radius} | {deflection} "
                     f"| {r['steps']} | {r['newton_iterations']} | {r['step_cuts']} | {r['time_s']:.0f} s ({r['ranks']}) |")
    return "\n".join(lines)


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--wheel", nargs="+", choices=["pneumatic", "rigid"], default=["pneumatic", "rigid"])
    p.add_argument("--refinement", type=float, nargs="+", default=[6.0, 8.0])
    p.add_argument("--load", type=float, default=40.0, help="wheel load, kN")
    p.add_argument("--travel", type=float, default=3.0, help="travel, m")
    p.add_argument("--strain", choices=["default", *VOLUMETRIC_STRAINS], default="default",
                   help="volumetric strain of both wheels (default: the scene's, per protocol and preset)")
    p.add_argument("--settled", type=float, default=0.75,
                   help="the mean is over the steps with the axle this far (d) past the stiff zone")
    add_results_arguments(p)
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    if args.table:
        return show_table(comm, table, saved_results(args.table))
    results = saved_results(args.out)
    for n in args.refinement:
        for wheel in args.wheel:
            key = {"wheel": wheel, "refinement": n, "load_kN": args.load, "travel_m": args.travel,
                   "strain": args.strain}
            if any(all((_strain(r) if k == "strain" else r.get(k)) == v for k, v in key.items()) for r in results):
                continue
            row = run_case(comm, wheel, n, args)
            results.append(row)
            if comm.rank == 0:
                print(json.dumps({k: row[k] for k in ("wheel", "refinement", "status", "time_s")}), flush=True)
            dump_json(comm, args.out, {"args": vars(args), "results": results})
    return show_table(comm, table, results)


if __name__ == "__main__":
    raise SystemExit(main())
