"""Pneumatic against rigid wheel on a clay, and the tire's mesh convergence on soil.

    python -m benchmarks tire_soil --out benchmarks/results/tire_soil.json
    python -m benchmarks tire_soil --levels 6:0.15 9:0.1 --rigid 8 12
    python -m benchmarks tire_soil --levels --rigid 9 12 16 --rigid-hexahedra \
        --out benchmarks/results/rigid_hexahedra.json
    python -m benchmarks tire_soil --levels --rigid 9 12 16 --rigid-hexahedra --projection 0

A tire of the Mn/DOT roller's size (d = 1.524 m, b = 0.3 d, hub 0.5 d, shoulder radius 0.08 d,
carcass E = ``--E`` MPa, nu = 0.45, inflated to ``--pressure`` kPa) and a rigid cylinder of the
same diameter and width (fillet b/12) are pressed into the same clay (von Mises, c = ``--cohesion``,
default 60 kPa, E = ``--soil-E``, default 20 MPa, nu = 0.3, gamma = 18 kN/m^3, mu = 0.5, ``--strain``),
quarter models on a block of
1 d each side and 1 d deep.  Each ``--levels`` entry ``n:h`` meshes the tire-on-soil model with
``n`` soil elements per d (hexahedra) and carcass elements of ``h`` m; each ``--rigid`` entry the
rigid wheel's block with that many elements per d (tetrahedra, or ``--rigid-hexahedra``; on
hexahedra B-bar projects per cell onto the linear functions, or onto the constants with
``--projection 0``).  Both are pressed in steps of
about ``--step`` d of sinkage to ``--sinkage`` m.  Prints, per run, the wheel load at that
sinkage and the sinkage at the wheel load ``--load`` kN (both interpolated linearly in the
force-sinkage curve), and for the tire its deflection, equivalent diameter, flexibility and
carcass load share at the last step; then the ratios of the tire's to the rigid wheel's figures
on the finest meshes.
"""
from __future__ import annotations

import argparse
import time

import numpy as np
from mpi4py import MPI

from _bench import dump_json

from rollsim.geometry import (CylinderWheel, MeshOptions, build_soil_block, build_tire_on_soil, indentation_block,
                              pneumatic_tire)
from rollsim.solver import NeoHookean, StepControl, VonMises, WheelIndentation
from rollsim.solver.options import VOLUMETRIC_STRAINS
from rollsim.solver.pneumatic import PneumaticIndentation

D = 1.524
GAMMA, FRICTION = 18e3, 0.5


def clay(cohesion: float = 60e3, young: float = 20e6) -> VonMises:
    """A clay of undrained strength ``cohesion`` (Pa) and Young's modulus ``young`` (Pa), von Mises."""
    return VonMises(E=young, nu=0.3, yield_stress=3 ** 0.5 * cohesion)


def _block():
    return indentation_block(D, half_size=1.0, depth=1.0, cut="quarter")


def _interpolated(curve: list[tuple[float, float]], load: float, sinkage: float) -> tuple:
    """On the force-sinkage ``curve`` [(s, Q)] from (0, 0), linear between steps: the sinkage (m)
    at ``load`` (N) and the load at ``sinkage`` (None where the curve does not reach them)."""
    s, Q = np.array([0.0] + [c[0] for c in curve]), np.array([0.0] + [c[1] for c in curve])
    at_load = float(np.interp(load, Q, s)) if Q.max() >= load and np.all(np.diff(Q) > 0) else None
    at_sinkage = float(np.interp(sinkage, s, Q)) if s.max() >= sinkage * (1 - 1e-3) else None
    return at_load, at_sinkage


def _fmt(value, spec: str, scale: float = 1.0) -> str:
    """``value * scale`` formatted by ``spec``, or "-" for None."""
    return "-" if value is None else format(value * scale, spec)


def tire_run(comm, per_d: float, size: float, pressure: float, young: float, sinkage: float, load: float,
             step: float, strain: str, soil: VonMises) -> dict:
    """The tire pressed to ``sinkage`` (m) in steps of ``step`` (m): its curve and its figures at the end."""
    t0 = time.perf_counter()
    tire = pneumatic_tire(D, cut="quarter", gap=0.05)
    tagged = build_tire_on_soil(comm, tire, _block(), MeshOptions.from_refinement(D, per_d, order=2, hexahedra=True),
                                MeshOptions(size, size, 1.0, order=2))
    pn = PneumaticIndentation(tagged, tire, soil, NeoHookean(young, 0.45), gamma=GAMMA, friction=FRICTION,
                              volumetric_strain=strain)
    pn.gravity_step()
    pn.inflate(pressure)
    pn.touch()
    curve = [(st.sinkage, st.QV) for st in pn.press_to_sinkage(sinkage, step)]
    at_load, at_sinkage = _interpolated(curve, load, sinkage)
    return {"wheel": "pneumatic", "per_d": per_d, "size": size, "dofs": pn.n_dofs, "sinkage_at_load": at_load,
            "load_at_sinkage": at_sinkage, "curve": curve, **pn.tire_state(),
            "newton_iterations": pn.newton_iterations, "time_s": comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)}


def rigid_run(comm, per_d: float, sinkage: float, load: float, step: float, strain: str,
              hexahedra: bool, soil: VonMises, projection: int | None = None) -> dict:
    """The rigid cylinder pushed to ``sinkage`` (m) in steps of ``step`` (m): its curve."""
    t0 = time.perf_counter()
    tagged = build_soil_block(comm, _block(), MeshOptions.from_refinement(D, per_d, hexahedra=hexahedra))
    wheel = CylinderWheel(D, 0.3 * D, 0.3 * D / 12)
    ind = WheelIndentation(tagged, wheel, soil, gamma=GAMMA, friction=FRICTION, volumetric_strain=strain,
                           volumetric_projection=projection)
    ind.gravity_step()
    curve = [(st.sinkage, st.QV) for st in ind.push(sinkage, StepControl(dt=step / sinkage, dt_max=step / sinkage))]
    at_load, at_sinkage = _interpolated(curve, load, sinkage)
    return {"wheel": "rigid", "per_d": per_d, "hexahedra": hexahedra, "projection": projection, "dofs": ind.n_dofs,
            "sinkage_at_load": at_load,
            "load_at_sinkage": at_sinkage, "curve": curve, "newton_iterations": ind.newton_iterations,
            "time_s": comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)}


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--levels", nargs="*", default=["6:0.15", "9:0.1", "12:0.075"],
                   help="tire-on-soil meshes: soil elements per d : carcass element size (m)")
    p.add_argument("--rigid", type=float, nargs="*", default=[8.0, 12.0, 16.0], help="rigid wheel: elements per d")
    p.add_argument("--rigid-hexahedra", action="store_true", help="the rigid wheel's block of hexahedra")
    p.add_argument("--strain", choices=VOLUMETRIC_STRAINS, default="cell-average", help="volumetric strain")
    p.add_argument("--projection", type=int, choices=(0, 1),
                   help="B-bar on the rigid wheel's hexahedra: per cell onto constants (0) or linear functions (1)")
    p.add_argument("--pressure", type=float, default=450.0, help="inflation, kPa")
    p.add_argument("--E", type=float, default=50.0, help="carcass Young's modulus, MPa")
    p.add_argument("--load", type=float, default=30.0, help="wheel load of the comparison, kN")
    p.add_argument("--sinkage", type=float, default=0.03, help="pressed to this sinkage, m")
    p.add_argument("--step", type=float, default=0.002, help="sinkage per step, in d")
    p.add_argument("--cohesion", type=float, default=60.0, help="the clay's undrained strength, kPa")
    p.add_argument("--soil-E", type=float, default=20.0, help="the clay's Young's modulus, MPa")
    p.add_argument("--out")
    args = p.parse_args(argv)
    if not (args.cohesion > 0 and args.soil_E > 0):
        p.error("--cohesion and --soil-E must be > 0")
    comm = MPI.COMM_WORLD
    soil = clay(1e3 * args.cohesion, 1e6 * args.soil_E)
    load = 1e3 * args.load
    rows = []

    def show(text):
        if comm.rank == 0:
            print(text, flush=True)

    show(f"| wheel | mesh | dofs | Q at {1e3 * args.sinkage:g} mm (kN) | sinkage at {args.load:g} kN (mm) "
         "| deflection (mm) | d_e / d | lambda (m/N) | carcass share | Newton its | time (s) |\n"
         "|---|---|---|---|---|---|---|---|---|---|---|")
    for level in args.levels:
        per_d, size = (float(v) for v in level.split(":"))
        r = tire_run(comm, per_d, size, 1e3 * args.pressure, 1e6 * args.E, args.sinkage, load, args.step * D,
                     args.strain, soil)
        rows.append(r)
        show(f"| pneumatic | {per_d:g}/d, carcass {1e3 * size:g} mm | {r['dofs']} | "
             f"{_fmt(r['load_at_sinkage'], '.2f', 1e-3)} | {_fmt(r['sinkage_at_load'], '.2f', 1e3)} | {1e3 * r['deflection_m']:.1f} | "
             f"{_fmt(r['equivalent_diameter_m'], '.2f', 1 / D)} | {_fmt(r['flexibility_m_per_N'], '.2e')} | "
             f"{_fmt(r['carcass_load_share'], '.2f')} | {r['newton_iterations']} | {r['time_s']:.0f} |")
    for per_d in args.rigid:
        r = rigid_run(comm, per_d, args.sinkage, load, args.step * D, args.strain, args.rigid_hexahedra, soil,
                      args.projection)
        rows.append(r)
        mesh = f"{per_d:g}/d" + (", hexahedra" if args.rigid_hexahedra else "") + (
            f", projection {args.projection}" if args.projection is not None else "")
        show(f"| rigid | {mesh} | {r['dofs']} | {_fmt(r['load_at_sinkage'], '.2f', 1e-3)} | "
             f"{_fmt(r['sinkage_at_load'], '.2f', 1e3)} | | | | | "
             f"{r['newton_iterations']} | {r['time_s']:.0f} |")
    for key, what in (("sinkage_at_load", f"sinkage at {args.load:g} kN"),
                      ("load_at_sinkage", f"load at {1e3 * args.sinkage:g} mm")):
        finest = [next((r[key] for r in reversed(rows) if r["wheel"] == w), None) for w in ("pneumatic", "rigid")]
        if None not in finest:
            show(f"pneumatic / rigid {what} (finest meshes): {finest[0] / finest[1]:.2f}")
    dump_json(comm, args.out, {"load_N": load, "cohesion_Pa": 1e3 * args.cohesion, "soil_E_Pa": 1e6 * args.soil_E,
                               "results": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
