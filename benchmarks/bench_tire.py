"""The pneumatic tire on rigid ground, on clay and towed; four problems.

``ground``: the tire on rigid flat ground: load against deflection at several inflation pressures.

    python -m benchmarks tire ground --pressure 400 650 900 --size 0.15
    python -m benchmarks tire ground --pressure 650 --size 0.15 0.1 --out tire_ground.json

Mn/DOT-size tire (d = 1.524 m, b = 0.3 d, hub 0.5 d, shoulder radius 0.08 d; tread 0.046 d,
transition 0.6 t, sidewall 0.2 t), half model, P2 hexahedra of ``--size`` (m), compressible
neo-Hookean carcass ``--E`` (MPa), nu = 0.45.  The tire is inflated clear of the ground, lowered
until it touches, then pressed by its hub to ``--deflection`` (m).  Prints, per pressure and mesh,
the whole-tire load Q at a third, two thirds and all of the deflection (interpolated), the contact area A and
the carcass's share 1 - p A / Q at the end, the inflated growth of the tread, Newton iterations
and wall time.

``calibrate``: the carcass modulus from a load-deflection target on rigid ground.

    python -m benchmarks tire calibrate --E 45 65 100 140 --size 0.15 --check

The same tire as ``ground`` inflated to ``--pressure`` kPa (default 650) and pressed by its hub
``--deflection`` m (default 0.16) for each carcass modulus ``--E`` (MPa): the deflection where it
carries ``--load`` kN (default 133.5, the whole tire's), the contact area and carcass share
1 - p A / Q there, the tread's growth on inflation; then, per element size, the modulus of each
``--targets`` deflection (mm, default 70 90 110), interpolated in log E between the samples that
bracket it, and with ``--check`` the deflection a run at that modulus gives.

``soil``: the tire against the rigid wheel on a clay, and the tire's mesh convergence on soil.

    python -m benchmarks tire soil --out benchmarks/results/tire_soil.json
    python -m benchmarks tire soil --levels 6:0.15 9:0.1 --rigid 8 12
    python -m benchmarks tire soil --levels --rigid 9 12 16 --rigid-hexahedra \\
        --out benchmarks/results/rigid_hexahedra.json
    python -m benchmarks tire soil --levels --rigid 9 12 16 --rigid-hexahedra --projection 0

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

``rolling``: The towed pneumatic tire against a towed rigid wheel of its size, at constant load on the same
soil, through ``rollsim run`` of ``examples/pneumatic_rolling.toml``.

    python -m benchmarks tire rolling --wheel pneumatic rigid --refinement 6 8 \\
        --out benchmarks/results/tire_rolling.json
    python -m benchmarks tire rolling --table benchmarks/results/tire_rolling.json

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
import sys
import tempfile
import time

import numpy as np
from mpi4py import MPI

from _bench import add_results_arguments, dump_json, run_problems, saved_results, show_table

from rollsim.geometry import (CylinderWheel, MeshOptions, build_soil_block, build_tire, build_tire_on_soil,
                              indentation_block, pneumatic_tire)
from rollsim.scene import load_scene
from rollsim.solver import StepControl, VonMises, WheelIndentation
from rollsim.solver.carcass import Carcass, NeoHookean
from rollsim.solver.stepping import SolverDivergedError
from rollsim.solver.options import VOLUMETRIC_STRAINS
from rollsim.solver.pneumatic import PneumaticIndentation
from rollsim.solver.run import run_scene

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


def ground(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks tire ground",
                                description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
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


def at_load(curve: list[dict], load: float) -> dict | None:
    """The deflection (m) and contact area (m^2) where the pressing ``curve`` first carries
    ``load`` (N), interpolated linearly; None if it never does."""
    defl = [0.0] + [c["deflection"] for c in curve]
    force = [0.0] + [c["Q"] for c in curve]
    area = [0.0] + [c["A"] for c in curve]
    for k in range(1, len(force)):
        if force[k] >= load:
            w = (load - force[k - 1]) / (force[k] - force[k - 1])
            return {"deflection": defl[k - 1] + w * (defl[k] - defl[k - 1]),
                    "A": area[k - 1] + w * (area[k] - area[k - 1])}
    return None


def modulus_for(samples: list[tuple[float, float]], target: float) -> float | None:
    """The carcass modulus (Pa) whose deflection is ``target`` (m), from ``samples`` of (modulus,
    deflection at the load): log-linear between the two samples that bracket it; None outside."""
    pts = sorted(samples)
    for (e0, d0), (e1, d1) in zip(pts, pts[1:]):
        if min(d0, d1) <= target <= max(d0, d1) and d0 != d1:
            w = (target - d0) / (d1 - d0)
            return float(np.exp(np.log(e0) + w * (np.log(e1) - np.log(e0))))
    return None


def calibrate(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks tire calibrate",
                                description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--E", type=float, nargs="+", default=[45.0, 65.0, 100.0, 140.0],
                   help="carcass Young's moduli sampled, MPa")
    p.add_argument("--pressure", type=float, default=650.0, help="inflation, kPa")
    p.add_argument("--load", type=float, default=133.5, help="wheel load, kN")
    p.add_argument("--targets", type=float, nargs="+", default=[70.0, 90.0, 110.0],
                   help="deflections at the load, mm")
    p.add_argument("--size", type=float, nargs="+", default=[0.15], help="element size, m")
    p.add_argument("--deflection", type=float, default=0.16, help="hub travel after touching, m")
    p.add_argument("--check", action="store_true",
                   help="run each target's interpolated modulus and print its deflection")
    p.add_argument("--out")
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    load, kpa = args.load * 1e3, args.pressure * 1e3
    rows = []

    def one(size: float, young: float, role: str) -> dict | None:
        try:
            r = run(comm, kpa, size, young, args.deflection)
        except SolverDivergedError as err:
            if comm.rank == 0:
                print(f"| {size:g} | {young / 1e6:.1f} | {role} | failed: {err} |", flush=True)
            return None
        hit = at_load(r["curve"], load)
        r.update(role=role, at_load=hit)
        rows.append(r)
        if comm.rank == 0:
            if hit is None:
                print(f"| {size:g} | {young / 1e6:.1f} | {role} | > {1e3 * args.deflection:.0f} | | | "
                      f"{1e3 * r['growth']:.1f} | {r['newton_iterations']} | {r['time_s']:.0f} |", flush=True)
            else:
                print(f"| {size:g} | {young / 1e6:.1f} | {role} | {1e3 * hit['deflection']:.1f} | {hit['A']:.4f} "
                      f"| {1 - kpa * hit['A'] / load:.2f} | {1e3 * r['growth']:.1f} | {r['newton_iterations']} "
                      f"| {r['time_s']:.0f} |", flush=True)
        dump_json(comm, args.out, {"args": vars(args), "rows": rows})
        return hit

    if comm.rank == 0:
        print(f"Mn/DOT-size tire at {args.pressure:g} kPa on rigid ground, deflection at {args.load:g} kN\n\n"
              "| element (m) | carcass E (MPa) | run | deflection (mm) | contact area (m²) | carcass share 1 - pA/Q "
              "| tread growth (mm) | Newton its | wall (s) |\n|---|---|---|---|---|---|---|---|---|", flush=True)
    for size in args.size:
        samples = []
        for mpa in args.E:
            hit = one(size, mpa * 1e6, "sample")
            if hit is not None:
                samples.append((mpa * 1e6, hit["deflection"]))
        found = {t: modulus_for(samples, t * 1e-3) for t in args.targets}
        if comm.rank == 0:
            print("\n" + "; ".join(f"{t:g} mm: " + ("outside the samples" if e is None else f"E = {e / 1e6:.0f} MPa")
                                    for t, e in found.items()) + f" (element {size:g} m)\n", flush=True)
        if args.check:
            for t, e in found.items():
                if e is not None:
                    one(size, e, f"{t:g} mm")
    return 0


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


def soil(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks tire soil",
                                description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
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


def rolling(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks tire rolling",
                                description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
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
    sys.exit(run_problems({"ground": ground, "calibrate": calibrate, "soil": soil, "rolling": rolling}, __doc__))
