"""Steady rolling (rollsim.solver.steady), five problems:

``hertz``: against transient rolling on the same elements, plane strain, a Hertz line pressure
(half-width a = 1 m) on von Mises soil (E = 1000 Pa, nu = 0.3, k = 1 Pa).  The steady solve in its
window (6 a ahead, 10 a behind, 10 a deep) against the load moved step by step over a block of the
same Q2 cells (the window with its fine zone stretched by the travel), solved incrementally with
PlasticityProblem (tests/test_steady_rolling.py, ``transient_behind``).  Compared ``--distance``
behind the load, where the soil has unloaded, each less the elastic soil's state under the same
load on its own block (the load's elastic far field, which the two blocks' far faces shape
differently): the residual sigma_xx and the plastic shear strain along the depth (largest
magnitude, and the largest difference over the depth relative to it) and the residual settlement
of the surface; wall time of each elastoplastic solve (set-up included) and their ratio, measured
in this run.

``ranks``: the Mn/DOT roller (mu = 0.8 with the full stick stiffness, held at xi = 1) on clay (von Mises, E = 40 MPa, c = 100
kPa, gravity) at the sinkages ``--sinkage``, 3D half window of hexahedra; run under ``mpirun -n
N``: the solve distributed over the N ranks, then the same solve on one rank (every rank at once,
each on its own core), their wall times (set-up included) and the speed-up, the forces of the two.

``towed``: the frictionless Mn/DOT cylinder (d = 1.524 m) towed in plane strain over ``--soil``:
clay (von Mises, E = 40 MPa, nu = 0.35, q_y = 200 kPa) or the report's case 5 (Drucker-Prager,
E = 40 MPa, nu = 0.35, phi_dp = 27.5 deg, c_dp = 194.6 kPa), gravity; pointwise and B-bar, the sinkage stepped
up (halved where Newton fails) to each of ``--sinkage``: Q_V per metre, the highest heave of the
surface ahead of the wheel, the surface's forward displacement at the rear face, the largest
accumulated plastic strain and its depth, the contact's extent along the centre line.

``wheel``: the frictionless Mn/DOT cylinder held at each ``--sinkage`` over ``--soil`` without
gravity, plane strain: the steady state in its window (0.4 d ahead, 0.6 d behind, 0.4 d deep,
cells of 0.1524 m / ``--cells-per-half-width`` at the contact) against the cylinder rolled at the
same axle height over a block of the same cells (the window with its fine zone stretched by
``--travel``; faces and base held), in travel steps of ``--step`` cells: Q_V and Q_H per metre
and the highest heave ahead of the wheel, the transient's every ``--every`` m of travel.

``window``: the frictionless Mn/DOT roller (d = 1.524 m, b = 0.4572 m) held at each ``--sinkage``
in turn over the report's case-5 soil (Drucker-Prager, E = 40 MPa, nu = 0.35, phi_dp = 27.5 deg,
c_dp = 194.6 kPa, gamma = 20 kN/m^3), 3D half window of ``rollsim run``'s steady driver on the
``--accuracy`` preset, its side face ``--beside`` d from the wheel's edge (each value its own
run; the other extents the driver's): Q_V, Q_H, the Newton iterations of the last solve, the
steps cut on the way (a failed step halved) and the wall time.  With ``--load`` (kN) the roller
is towed (``--friction``) at that load through the steady driver instead (``rollsim run``'s
``rolling-constant-load``): its steady sinkage, Q_H, rut, Newton iterations and wall time.

``relaxed``: the same soil and window (``rollsim run``'s, side face 0.6 d), the roller towed (mu =
0.8) at ``--load`` kN with the soil relaxed in the sweep by the first of ``--lengths`` (mm; the
steady driver's sinkage steps), then each next length in turn from the state of the last, at the
same load: the steady sinkage per relaxation length (its limit as the length goes to 0 is the
rate-independent soil's).

    python -m benchmarks steady hertz [--p0 3.6 4.5] [--cells-per-half-width 4]
        [--travel 14] [--step 0.0625] [--distance 5] [--out bench_steady.json]
    mpirun -n 2 python -m benchmarks steady ranks [--cells-per-half-width 2] [--sinkage 2.5 5]
    python -m benchmarks steady towed [--soil clay] [--sinkage 2 3 4] [--cells-per-half-width 4]
    python -m benchmarks steady wheel [--soil case5] [--sinkage 4 6] [--travel 4] [--cells-per-half-width 4]
    mpirun -n 2 python -m benchmarks steady window [--accuracy standard] [--beside 0.3 0.6]
        [--sinkage 3.05 7.62 10.67] [--load 133.5 --friction 0.8]
    mpirun -n 2 python -m benchmarks steady relaxed [--accuracy fast] [--strain cell-average]
        [--lengths 5 3.5 2.5 ...] [--load 133.5]
"""
from __future__ import annotations

import argparse
from dataclasses import replace
import logging
import math
import pathlib
import sys
import time

import numpy as np
from mpi4py import MPI

sys.path.insert(0, str(pathlib.Path(__file__).parents[1] / "tests"))
from test_steady_rolling import (CLAY_3D, K, NEVER_YIELDS, ROLLER, SOIL, differences,  # noqa: E402
                                 hold_faces_and_base, stretched_block,
                                 residual_part, steady, steady_behind, transient_behind)

from _bench import dump_json  # noqa: E402
from rollsim.solver.materials import DruckerPrager, VonMises  # noqa: E402
from rollsim.solver.steady import NoSteadyState, RollingWindow, SteadyRolling, rolling_window_mesh  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = ap.add_subparsers(dest="problem", required=True)
    hertz = sub.add_parser("hertz", help="plane strain, Hertz line pressure: steady against transient")
    hertz.add_argument("--p0", type=float, nargs="+", default=[3.6, 4.5], help="peak pressures / k")
    hertz.add_argument("--cells-per-half-width", type=int, default=4)
    hertz.add_argument("--travel", type=float, default=14.0, help="the transient load's travel / a")
    hertz.add_argument("--step", type=float, default=0.0625, help="the transient load's step / a")
    hertz.add_argument("--distance", type=float, default=5.0, help="where the states are compared, behind the load / a")
    hertz.add_argument("--out")
    ranks = sub.add_parser("ranks", help="3D roller on clay: the distributed solve against one rank's")
    ranks.add_argument("--cells-per-half-width", type=int, default=2, help="cells per 0.15 m")
    ranks.add_argument("--sinkage", type=float, nargs="+", default=[2.5, 5.0], help="mm, solved in turn")
    towed = sub.add_parser("towed", help="plane strain, towed cylinder on clay or case 5: the surface layer")
    towed.add_argument("--soil", choices=sorted(TOWED_SOILS), default="clay")
    towed.add_argument("--sinkage", type=float, nargs="+", default=[2.0, 3.0, 4.0], help="mm, in turn")
    towed.add_argument("--cells-per-half-width", type=int, default=4, help="cells per 0.06 m")
    wheel = sub.add_parser("wheel", help="plane strain, towed cylinder: the steady state against the transient roll")
    wheel.add_argument("--soil", choices=sorted(TOWED_SOILS), default="case5")
    wheel.add_argument("--sinkage", type=float, nargs="+", default=[4.0, 6.0], help="mm, each its own run")
    wheel.add_argument("--travel", type=float, default=4.0, help="the transient roll's travel, m")
    wheel.add_argument("--step", type=float, default=0.25, help="the transient roll's travel step, in cells")
    wheel.add_argument("--every", type=float, default=0.5, help="m of travel between the transient's rows")
    wheel.add_argument("--cells-per-half-width", type=int, default=4, help="cells per 0.1524 m")
    extent = sub.add_parser("window", help="3D roller on the case-5 soil: the side face's distance")
    extent.add_argument("--accuracy", default="standard", help="the preset of the cells")
    extent.add_argument("--beside", type=float, nargs="+", default=[0.3, 0.6], help="side face from the wheel's edge, d")
    extent.add_argument("--sinkage", type=float, nargs="+", default=[3.05, 7.62, 10.67], help="mm, in turn")
    extent.add_argument("--load", type=float, help="kN: towed at this load through the steady driver")
    extent.add_argument("--friction", type=float, default=0.8, help="with --load: the Coulomb coefficient")
    relax = sub.add_parser("relaxed", help="3D roller on the case-5 soil at its load: the relaxation length lowered")
    relax.add_argument("--accuracy", default="fast", help="the preset of the cells")
    relax.add_argument("--strain", choices=("cell-average", "pointwise"), default="cell-average")
    relax.add_argument("--lengths", type=float, nargs="+",
                       default=[5.0, 3.5, 2.5, 1.75, 1.25, 0.9, 0.625, 0.44, 0.31, 0.22, 0.156, 0.11],
                       help="relaxation lengths (mm), in turn")
    relax.add_argument("--load", type=float, default=133.5, help="kN")
    args = ap.parse_args()
    run = {"hertz": hertz_against_transient, "ranks": distributed_against_serial, "towed": towed_surface_layer,
           "wheel": steady_against_transient, "window": side_face, "relaxed": relaxed_at_load}
    return run[args.problem](args)


#: the soils of the ``towed`` problem
TOWED_SOILS = {"clay": VonMises(E=40e6, nu=0.35, yield_stress=200e3),
               "case5": DruckerPrager(E=40e6, nu=0.35, phi_dp=math.radians(27.5), c_dp=194.6e3)}


def towed_surface_layer(args) -> int:
    """The ``towed`` problem (module docstring)."""
    from rollsim.solver.contact import Circle
    soil, R = TOWED_SOILS[args.soil], 0.762
    window = RollingWindow(half_width=0.06, ahead=0.9, behind=1.2, depth=0.9,
                           cells_per_half_width=args.cells_per_half_width)
    print("strain        s (mm)  Q_V (kN/m)  heave ahead (mm)  u_x at rear (mm)  max eps_p  at depth (mm)  "
          "contact x (mm)  time (s)")
    for strain in ("pointwise", "cell-average"):
        st = SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, window), soil, wheel=Circle(diameter=2 * R),
                           unit_weight=20e3, volumetric_strain=strain)
        t0, s, step = time.perf_counter(), 0.0, 1e-3
        for target in np.array(args.sinkage) * 1e-3:
            while s < target - 1e-12 and step > 1e-6:
                u0, last = st.u.x.array.copy(), st._last_sinkage
                try:
                    res = st.solve_sinkage(min(s + step, target), max_cuts=0)
                    s, step = res.sinkage, min(1.5 * step, 2e-3)
                except NoSteadyState:
                    st.u.x.array[:], st._last_sinkage, step = u0, last, 0.5 * step
            if s < target - 1e-12:
                print(f"{strain:12s}  no steady state found past {1e3 * s:.3f} mm")
                break
            x, u = st.surface_displacement()
            gap = np.hypot(x + u[:, 0], st.surface + u[:, 1] - (st.surface + R - s)) - R
            touching = x[gap < 0]
            acc = st.accumulated_plastic_strain
            depth = st.surface - st.quadrature_coordinates[acc.argmax(), 1]
            print(f"{strain:12s}  {1e3 * s:6.2f}  {res.vertical_force / 1e3:10.1f}  {1e3 * u[x > 0, 1].max():16.2f}  "
                  f"{1e3 * u[0, 0]:16.2f}  {acc.max():9.3f}  {1e3 * depth:13.1f}  "
                  f"{1e3 * touching.min():+.0f} to {1e3 * touching.max():+.0f}  {time.perf_counter() - t0:8.1f}",
                  flush=True)
    return 0


def steady_against_transient(args) -> int:
    """The ``wheel`` problem (module docstring)."""
    from rollsim.solver.contact import Circle
    soil, R = TOWED_SOILS[args.soil], 0.762
    window = RollingWindow(half_width=0.1524, ahead=0.61, behind=0.914, depth=0.61,
                           cells_per_half_width=args.cells_per_half_width)
    print(f"{'s (mm)':>6} {'run':<22} {'Q_V (kN/m)':>10} {'Q_H (kN/m)':>10} {'heave ahead (mm)':>16} {'time (s)':>8}")
    for sinkage in np.array(args.sinkage) * 1e-3:
        t0 = time.perf_counter()
        st = SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, window), soil, wheel=Circle(diameter=2 * R))
        for s in np.append(np.arange(5e-4, sinkage, 5e-4), sinkage):
            res = st.solve_sinkage(float(s))
        x, u = st.surface_displacement()
        print(f"{1e3 * sinkage:6.2f} {'steady':<22} {res.vertical_force / 1e3:10.2f} {res.towing_force / 1e3:10.3f} "
              f"{1e3 * u[x > 0, 1].max():16.2f} {time.perf_counter() - t0:8.1f}", flush=True)
        t0 = time.perf_counter()
        rows = transient_roll(window, soil, R, sinkage, args.travel, args.step)
        wall = time.perf_counter() - t0
        travel = np.array([row["travel"] for row in rows])
        marks = np.arange(args.every, travel[-1] + 1e-9, args.every)
        shown = sorted(set(np.searchsorted(travel, marks - 1e-9).tolist()) | {len(rows) - 1})
        for i in shown:
            row = rows[i]
            print(f"{1e3 * sinkage:6.2f} {'transient, ' + format(row['travel'], '.2f') + ' m':<22} "
                  f"{row['QV'] / 1e3:10.2f} {row['QH'] / 1e3:10.3f} {1e3 * row['heave']:16.2f} "
                  + (f"{wall:8.1f}" if i == len(rows) - 1 else ""), flush=True)
    return 0


def transient_roll(window: RollingWindow, soil, R: float, sinkage: float, travel: float,
                   step: float) -> list[dict]:
    """The reference of the ``wheel`` problem: a frictionless rigid cylinder (radius ``R``) pressed
    to ``sinkage`` at x = 0 and rolled by ``travel`` (m, a whole number of cells) at that axle
    height, in steps of ``step`` cells, over a block of ``window``'s cells; after each step the
    travel (m), Q_V and Q_H (N/m) and the highest heave ahead of the wheel (m)."""
    from dolfinx import mesh as dmesh
    from rollsim.solver import PlasticityProblem, StepControl, solve_load_path
    from rollsim.solver.contact import Circle, RigidWheelContact
    h = window.cell_size / 2 ** window.refinement
    cells = int(round(travel / h))
    pb = PlasticityProblem(stretched_block(window, cells * h), soil)
    msh = pb.mesh
    hold_faces_and_base(pb)
    top = float(msh.geometry.x[:, 1].max())
    surface = dmesh.locate_entities_boundary(msh, 1, lambda p: np.isclose(p[1], top))
    tags = dmesh.meshtags(msh, 1, np.sort(surface), np.ones(len(surface), np.int32))
    # the steady window's penalty: kappa from the smallest column spacing (the fine cells), the same facet rule
    contact = RigidWheelContact(pb, Circle(2 * R), tags, (1,), quadrature_degree=12, h=h, centre=[0.0, top + R])
    solve_load_path(pb, lambda t: contact.set_pose(centre=[0.0, top + R - sinkage * t]),
                    StepControl(dt=0.1, dt_max=0.1))
    X = pb.V.tabulate_dof_coordinates()
    on_top = np.isclose(X[:, 1], top)
    rows = []

    def record(t):
        u = pb.u.x.array.reshape(-1, 2)[on_top]
        forces = contact.forces()
        rows.append({"travel": t, "QV": forces.vertical, "QH": forces.horizontal,
                     "heave": float(u[X[on_top, 0] > t, 1].max())})

    ds = step * h
    solve_load_path(pb, lambda t: contact.set_pose(centre=[t, top + R - sinkage]),
                    StepControl(t_end=cells * h, dt=ds, dt_max=ds, dt_min=ds / 64, easy_iterations=1000),
                    on_step=record)
    return rows


class _Cuts(logging.Handler):
    """Counts the steady solver's step cuts (its log lines)."""

    def __init__(self):
        super().__init__(logging.INFO)
        self.count = 0

    def emit(self, record):
        self.count += "cutting the step" in record.getMessage()


def _case5_roller(friction: float, load: float, **model):
    """The Mn/DOT roller (``friction``, ``load`` kN) rolled steadily over the report's case-5 soil;
    ``model``: its ``[model]`` keys besides ``rolling``."""
    from rollsim.scene import parse_scene
    return parse_scene({"wheel": {"diameter": "1.524 m", "width": "0.4572 m", "friction": friction},
                        "soil": {"gamma": "20 kN/m^3", "layers": [{"model": "drucker-prager", "E": "40 MPa",
                                                                   "nu": 0.35, "phi_dp": "27.5 deg",
                                                                   "c_dp": "194.6 kPa"}]},
                        "loading": {"protocol": "rolling-constant-load", "load": f"{load} kN"},
                        "model": {"rolling": "steady", **model}})


def side_face(args) -> int:
    """The ``window`` problem (module docstring)."""
    from rollsim.log import get_logger
    from rollsim.solver.drivers.steady_rolling import steady_window
    from rollsim.solver.scene_model import layer_materials, wheel_geometry
    comm = MPI.COMM_WORLD
    scene = _case5_roller(0 if args.load is None else args.friction, args.load or 133.5, accuracy=args.accuracy)
    if args.load is not None:
        return _towed_at_load(scene, args.beside, comm)
    cuts = _Cuts()
    solver_log = get_logger("solver")
    solver_log.addHandler(cuts)
    solver_log.setLevel(logging.INFO)
    for beside in args.beside:
        window = steady_window(scene, {"beside": beside})
        t0 = time.perf_counter()
        st = SteadyRolling(rolling_window_mesh(comm, window), layer_materials(scene).by_layer[1],
                           wheel=wheel_geometry(scene.wheel), unit_weight=scene.soil.gamma,
                           volumetric_strain=scene.model.volumetric_strain)
        if comm.rank == 0:
            print(f"side face {beside:g} d from the wheel's edge ({window.across:.3f} m from the centre), "
                  f"{st.V.dofmap.index_map.size_global * st.gdim} dofs, {args.accuracy}\n"
                  "  s (mm)  Q_V (kN)  Q_H (kN)  Newton  cuts  wall (s)", flush=True)
        for s in args.sinkage:
            before = cuts.count
            try:
                r = st.solve_sinkage(s * 1e-3)
            except NoSteadyState as err:
                if comm.rank == 0:
                    print(f"  {s:6.2f}  no steady state: {err}", flush=True)
                break
            if comm.rank == 0:
                print(f"  {s:6.2f}  {r.vertical_force / 1e3:8.2f}  {r.towing_force / 1e3:8.2f}  {r.newton_iterations:6d}  "
                      f"{cuts.count - before:4d}  {time.perf_counter() - t0:8.1f}", flush=True)
    solver_log.removeHandler(cuts)
    return 0


def relaxed_at_load(args) -> int:
    """The ``relaxed`` problem (module docstring)."""
    from rollsim.solver.drivers.steady_rolling import LOAD_RTOL, TORQUE_RTOL, _constant_load, steady_window
    from rollsim.solver.scene_model import layer_materials, scene_penalty, wheel_geometry
    comm = MPI.COMM_WORLD
    scene = _case5_roller(0.8, args.load, accuracy=args.accuracy, volumetric_strain=args.strain)
    alpha = scene_penalty(scene, None)
    t0 = time.perf_counter()
    st = SteadyRolling(rolling_window_mesh(comm, steady_window(scene)), layer_materials(scene).by_layer[1],
                       wheel=wheel_geometry(scene.wheel), friction=scene.wheel.friction, unit_weight=scene.soil.gamma,
                       volumetric_strain=args.strain, relaxation_length=args.lengths[0] * 1e-3,
                       **({} if alpha is None else {"penalty": alpha}))
    if comm.rank == 0:
        print(f"towed at {args.load:g} kN, mu = 0.8, {args.accuracy}, {args.strain}, "
              f"{st.V.dofmap.index_map.size_global * st.gdim} dofs\n"
              "| relaxation length (mm) | sinkage (mm) | Q_V (kN) | Q_H (kN) | Newton its (last solve) | wall (s) |\n"
              "|---|---|---|---|---|---|", flush=True)
    states: dict = {}

    def solve(sinkage: float):
        res = st.solve_free_rolling(sinkage, None, torque_rtol=TORQUE_RTOL)
        states[res.sinkage] = (st.u.x.array.copy(), st.spin, res.vertical_force)
        return res
    res = None
    for length in args.lengths:
        st.relaxation_length = length * 1e-3
        try:
            res = _constant_load(st, scene, solve, states, st.inflow) if res is None else \
                st.solve_load(scene.loading.load, None, initial_sinkage=res.sinkage, free_rolling=True,
                              rtol=LOAD_RTOL, torque_rtol=TORQUE_RTOL)
        except NoSteadyState as err:
            if comm.rank == 0:
                print(f"| {length:g} | no steady state: {err} | | | | |", flush=True)
            break
        if comm.rank == 0:
            print(f"| {length:g} | {1e3 * res.sinkage:.3f} | {res.vertical_force / 1e3:.2f} | "
                  f"{res.towing_force / 1e3:.2f} | {res.newton_iterations} | {time.perf_counter() - t0:.0f} |",
                  flush=True)
    return 0


def _towed_at_load(scene, besides: list[float], comm) -> int:
    """The ``window`` problem with ``--load``: the steady driver's constant-load run per side face."""
    import csv
    import shutil
    import tempfile
    from rollsim.solver.drivers.steady_rolling import run_steady
    if comm.rank == 0:
        print(f"towed at {scene.loading.load / 1e3:g} kN, mu = {scene.wheel.friction:g}, {scene.model.accuracy}\n"
              "| side face from the wheel's edge (d) | dofs | status | sinkage (mm) | Q_H (kN) | rut (mm) | Newton its "
              "| wall (s) |\n|---|---|---|---|---|---|---|---|", flush=True)
    states = []
    for beside in besides:
        out = comm.bcast(tempfile.mkdtemp() if comm.rank == 0 else None)
        try:
            r = run_steady(scene, pathlib.Path(out) / "run", comm, progress=False, write_fields=False,
                           window={"beside": beside})
            if comm.rank == 0:
                with open(pathlib.Path(out) / "run" / "history.csv") as f:
                    states.append((beside, [(float(row["sinkage_m"]), float(row["QV_N"])) for row in csv.DictReader(f)]))
        finally:
            comm.barrier()
            if comm.rank == 0:
                shutil.rmtree(out)
        if comm.rank == 0:
            print(f"| {beside:g} | {r['dofs']} | {r['status']} | {1e3 * r['sinkage_m']:.2f} | {r['QH_N'] / 1e3:.2f} "
                  f"| {1e3 * r.get('rut_depth_m', float('nan')):.2f} | {r['newton_iterations']} "
                  f"| {r['wall_time_s']:.0f} |", flush=True)
    if comm.rank == 0:
        print("\nthe steady states on the way (sinkage mm: Q_V kN):")
        for beside, rows in states:
            print(f"  {beside:g} d: " + ", ".join(f"{1e3 * s:.2f}: {q / 1e3:.2f}" for s, q in rows), flush=True)
    return 0


def distributed_against_serial(args) -> int:
    """The ``ranks`` problem (module docstring)."""
    comm = MPI.COMM_WORLD
    window = RollingWindow(half_width=0.15, ahead=0.45, behind=0.6, depth=0.45,
                           cells_per_half_width=args.cells_per_half_width, across=0.45,
                           load_half_width_across=ROLLER.width / 2)
    found = {}
    for name, cm in (("distributed", comm), ("one rank", MPI.COMM_SELF)):
        comm.barrier()
        t0 = time.perf_counter()
        st = SteadyRolling(rolling_window_mesh(cm, window), CLAY_3D, wheel=ROLLER, friction=0.8, unit_weight=20e3,
                           tangential_ratio=1.0)
        runs = [st.solve_sinkage(s * 1e-3) for s in args.sinkage]
        wall = comm.allreduce(time.perf_counter() - t0, MPI.MAX)
        found[name] = (wall, runs, st.V.dofmap.index_map.size_global * st.gdim)
    if comm.rank == 0:
        (wall_n, runs_n, dofs), (wall_1, runs_1, _) = found["distributed"], found["one rank"]
        print(f"3D roller on clay, {dofs} dofs, sinkages {args.sinkage} mm")
        print(f"{'':<12} {'ranks':>5} {'wall (s)':>9} {'Newton':>7} {'GMRES':>6}   Q_V (kN) at each sinkage")
        for label, wall, runs, n in (("distributed", wall_n, runs_n, comm.size), ("one rank", wall_1, runs_1, 1)):
            print(f"{label:<12} {n:5d} {wall:9.1f} {sum(r.newton_iterations for r in runs):7d} "
                  f"{sum(r.krylov_iterations for r in runs):6d}   "
                  + " ".join(f"{r.vertical_force / 1e3:.6f}" for r in runs))
        print(f"speed-up {wall_1 / wall_n:.2f}x on {comm.size} ranks")
    return 0


def hertz_against_transient(args) -> int:
    """The ``hertz`` problem (module docstring)."""
    window = RollingWindow(half_width=1.0, ahead=6.0, behind=10.0, depth=10.0,
                           cells_per_half_width=args.cells_per_half_width)
    print(f"h = a/{args.cells_per_half_width}, transient travel {args.travel:g} a in steps of {args.step:g} a, "
          f"compared {args.distance:g} a behind the load", flush=True)
    print(f"{'p0/k':>5} {'quantity':<30} {'steady':>11} {'transient':>11} {'difference':>11}")
    results = []
    for p0 in args.p0:
        behind = {}
        for material in (SOIL, NEVER_YIELDS):
            t0 = time.perf_counter()                 # set-up and solve, as the transient's
            st = steady(window, material)
            behind[material] = replace(steady_behind(st, st.solve(p0 * K), args.distance),
                                       wall_time=time.perf_counter() - t0)
        s = residual_part(behind[SOIL], behind[NEVER_YIELDS])
        elastic = transient_behind(window, NEVER_YIELDS, p0 * K, args.travel, args.travel, args.distance)
        t = residual_part(transient_behind(window, SOIL, p0 * K, args.travel, args.step, args.distance), elastic)
        diff = differences(s, t)
        peak_sxx = int(np.argmax(np.abs(s.sigma_xx)))
        peak_gp = int(np.argmax(np.abs(s.plastic_shear)))
        rows = [("residual sigma_xx / k, largest", s.sigma_xx[peak_sxx] / K, t.sigma_xx[peak_sxx] / K, None),
                ("  over the depth", None, None, diff["sigma_xx"]),
                ("eps_p_xy, largest", s.plastic_shear[peak_gp], t.plastic_shear[peak_gp], None),
                ("  over the depth", None, None, diff["plastic_shear"]),
                ("residual settlement u_y / a", s.surface_displacement[1], t.surface_displacement[1], None),
                ("wall time (s)", s.wall_time, t.wall_time, None),
                ("  transient / steady", None, None, t.wall_time / s.wall_time)]
        for name, a, b, d in rows:
            if d is None:
                d = (b - a) / abs(a) if a else float("nan")
                text = f"{d:+10.1%}" if "wall" not in name else ""
            else:
                text = f"{d:10.1%}" if "/" not in name else f"{d:9.1f}x"
            cells = [f"{v:11.4g}" if v is not None else " " * 11 for v in (a, b)]
            print(f"{p0:5.2f} {name:<30} {cells[0]} {cells[1]} {text:>11}", flush=True)
        results.append({"p0_over_k": p0, "depth": s.depth.tolist(), "differences": diff,
                        **{name: {"sigma_xx": r.sigma_xx.tolist(), "plastic_shear": r.plastic_shear.tolist(),
                                  "surface_displacement": r.surface_displacement.tolist(), "wall_time": r.wall_time}
                           for name, r in (("steady", s), ("transient", t))}})
    dump_json(MPI.COMM_WORLD, args.out, {"arguments": vars(args), "results": results})
    return 0


if __name__ == "__main__":
    sys.exit(main())
