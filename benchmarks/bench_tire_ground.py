"""Pneumatic tire on rigid flat ground: load against deflection at several inflation pressures.

    python -m benchmarks tire_ground --pressure 400 650 900 --size 0.15
    python -m benchmarks tire_ground --pressure 650 --size 0.15 0.1 --out tire_ground.json

Mn/DOT-size tire (d = 1.524 m, b = 0.3 d, hub 0.5 d, shoulder radius 0.08 d; tread 0.046 d,
transition 0.6 t, sidewall 0.2 t), half model, P2 hexahedra of ``--size`` (m), compressible
neo-Hookean carcass ``--E`` (MPa), nu = 0.45.  The tire is inflated clear of the ground, lowered
until it touches, then pressed by its hub to ``--deflection`` (m).  Prints, per pressure and mesh,
the whole-tire load Q at a third, two thirds and all of the deflection (interpolated), the contact area A and
the carcass's share 1 - p A / Q at the end, the inflated growth of the tread, Newton iterations
and wall time.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
from mpi4py import MPI

from _bench import dump_json

from rollsim.geometry import MeshOptions, build_tire, pneumatic_tire
from rollsim.solver.carcass import Carcass, NeoHookean

D = 1.524
GROUND = -0.2   # m: well below the tire, which inflates before it is lowered


def run(comm, pressure: float, size: float, young: float, deflection: float) -> dict:
    """One tire: inflate to ``pressure`` (Pa), touch the ground, press by ``deflection`` (m)."""
    t0 = time.perf_counter()
    tire = pneumatic_tire(D, width=0.3, hub_diameter=0.5, shoulder_radius=0.08, gap=0.01, cut="half")
    mesh = build_tire(comm, tire, MeshOptions(size, size, 1.0, order=2))
    carcass = Carcass(mesh, NeoHookean(young, 0.45), ground=GROUND)
    low = carcass.lowest_point()
    carcass.inflate(pressure)
    growth = low - carcass.lowest_point()
    carcass.press(carcass.lowest_point() - GROUND)
    records = carcass.press(deflection, on_step=lambda: {"Q": 2 * carcass.ground_force(),
                                                         "A": 2 * carcass.contact_area()})
    curve = [{"deflection": r.t * deflection, **r.data} for r in records]
    return {"pressure": pressure, "size": size, "E": young, "dofs": carcass.n_dofs, "growth": growth,
            "curve": curve, "newton_iterations": carcass.newton_iterations,
            "time_s": comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--pressure", type=float, nargs="+", default=[400.0, 650.0, 900.0], help="kPa")
    p.add_argument("--size", type=float, nargs="+", default=[0.15], help="element size, m")
    p.add_argument("--E", type=float, default=50.0, help="carcass Young's modulus, MPa")
    p.add_argument("--deflection", type=float, default=0.06, help="hub travel after touching, m")
    p.add_argument("--out")
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    rows = []
    if comm.rank == 0:
        print("| p (kPa) | element (m) | dofs | tread growth | Q at 1/3, 2/3, 3/3 of the deflection (kN) "
              "| contact area at the end | carcass share at the end | Newton its | wall (s) |\n"
              "|---|---|---|---|---|---|---|---|---|", flush=True)
    for size in args.size:
        for kpa in args.pressure:
            r = run(comm, kpa * 1e3, size, args.E * 1e6, args.deflection)
            rows.append(r)
            if comm.rank == 0:
                curve = r["curve"]
                defl = [0.0] + [c["deflection"] for c in curve]
                force = [0.0] + [c["Q"] for c in curve]
                end = curve[-1]
                loads = " / ".join(f"{np.interp(f * args.deflection, defl, force) / 1e3:.1f}"
                                   for f in (1 / 3, 2 / 3, 1))
                print(f"| {kpa:g} | {size:g} | {r['dofs']} | {1e3 * r['growth']:.1f} mm | {loads} | {end['A']:.4f} m² "
                      f"| {1 - r['pressure'] * end['A'] / end['Q']:.2f} | {r['newton_iterations']} "
                      f"| {r['time_s']:.0f} |", flush=True)
    dump_json(comm, args.out, {"args": vars(args), "rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
