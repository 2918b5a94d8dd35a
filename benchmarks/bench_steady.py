"""Steady rolling (rollsim.solver.steady), eleven problems:

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

``reach``: the Mn/DOT cylinder towed (``--friction``, the spin found for zero axle torque) in plane
strain over each ``--soil`` (``case8``: the report's rolling case 8, Drucker-Prager phi_dp =
45.4 deg, c_dp = 89.1 kPa; ``case2``: its clay, von Mises c_dp = 200 kPa; E = 40 MPa, nu = 0.35,
gravity), pointwise, in the steady driver's window (0.4 / 0.6 / 0.4 d ahead / behind / deep) with
cells of 0.1 d / ``--cells-per-half-width`` at the contact, relaxed by each ``--relaxation``: the
sinkage stepped up by ``--step`` (a failed step cut in two on the way) until a steady state is not
found: the deepest one, its Q_V and how far the surface leaves the window moved forward, why the
next failed, and the wall time.

``stabilised``: the same towed cylinder and soils, the soil relaxed by ``--per-spacing`` times
the shortest spacing of the streamlines' stations (a relaxation that shrinks with the cells), at
the service load (133.5 kN over the roller's width): for each ``--cells-per-half-width`` the
sinkage at the load (or where the steps stop), its change from the level before and the observed
order of the last three.

``shove``: the frictionless Mn/DOT cylinder held at ``--sinkage`` mm in plane strain over
``--soil`` (as ``reach``), cells of 0.1 d / ``--cells-per-half-width``: the soil relaxed by
``--relaxation`` mm, then the length halved ``--halvings`` times, then not relaxed, each state
from the last; Newton-Krylov and, where it fails, the elastic fixed point (at most
``--fixed-point`` iterations, Newton tried again from its iterate after ``--newton-retry`` of
them, then after twice as many more each time; 0: never): per length Q_V per metre, how far the
surface leaves the window moved forward, the largest accumulated plastic strain, the Newton and
fixed-point iterations and the wall time.  ``reach`` takes ``--fixed-point`` too, and
``--newton-retry`` with several values, each in turn.

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

``rolled``: the frictionless Mn/DOT roller held at ``--sinkage`` mm over frictionless clay (von
Mises, E = 40 MPa, nu = 0.35, c_dp = 300 kPa) without gravity, 3D, ``--strain``: the steady state
in the steady driver's window (cells of d / ``--refinement`` at the contact) against the roller
rolled at the same axle height over a half block of the same cells (the window with its fine zone
stretched by ``--travel`` d; end faces and base held, rollers on the symmetry plane and the side
face; the same contact penalty and facet rule), in travel steps of ``--step`` cells: Q_V and Q_H
of the whole wheel, the roll's every ``--every`` d of travel against the steady Q_V, its mean
(and range) over the last ``--mean`` d, and the wall times.

``window``: the frictionless Mn/DOT roller (d = 1.524 m, b = 0.4572 m) held at each ``--sinkage``
in turn over the report's case-5 soil (Drucker-Prager, E = 40 MPa, nu = 0.35, phi_dp = 27.5 deg,
c_dp = 194.6 kPa, gamma = 20 kN/m^3), 3D half window of ``rollsim run``'s steady driver on the
``--accuracy`` preset, its side face ``--beside`` d from the wheel's edge (each value its own
run; the other extents the driver's): Q_V, Q_H, the Newton iterations of the last solve, the
steps cut on the way (a failed step halved) and the wall time.  With ``--load`` (kN) the roller
is towed (``--friction``) at that load through the steady driver instead (``rollsim run``'s
``rolling-constant-load``): its steady sinkage, Q_H, rut, Newton iterations and wall time.

``limit``: the same soil and window (``rollsim run``'s steady driver, side face 0.6 d), the roller
towed (``--friction``) at ``--load`` kN on cells of d / ``--refinement`` with ``--strain``: the
route the driver takes (B-bar: the relaxation's limit; pointwise: the sinkage stepped up on the
rate-independent soil) and, pointwise, also the relaxation's limit, taken on purpose, for the
two to be compared: per relaxation length the steady sinkage at the load, Q_H, Newton
iterations, then the extrapolated sinkage, its correction and the wall time.

``convergence``: the Mn/DOT roller towed at ``--load`` kN through ``rollsim run``'s steady driver
over each ``--soil`` (``case5``: the report's case 5, c-phi soil, mu = 0.8; ``case17``: layered
case 17, three layers of clay with c_dp = 300 kPa, mu = 0.8; ``clay``: von Mises c_dp = 300 kPa,
frictionless, at 100 kN; ``case2``: the clay of case 2, c_dp = 200 kPa, mu = 0.8; ``case8``: the
report's rolling case 8, phi_dp = 45.4 deg, c_dp = 89.1 kPa, mu = 0.8; each at the load it was
rolled at unless ``--load`` is given), each ``--strain``,
on fine cells of d / each of ``--levels`` at the contact: the steady sinkage, Q_H, rut, dofs,
Newton and fixed-point iterations and wall time per level; over the last three levels the
observed order and the Richardson value, and the last refinement's change.  B-bar reaches its rate-independent
state through the relaxation's limit (the driver's route; its extrapolated sinkage is the
level's).  With ``--relaxation-per-spacing`` the soil is relaxed by that many of each level's
shortest station spacings (``[model] relaxation_length``: a relaxation that shrinks with the
cells).  ``--fixed-point``: the elastic fixed point's iterations per state where Newton fails
(0: Newton alone, the driver's default).  ``--out``: the rows as JSON, one file per soil and strain,
appended as they finish.

``profile``: one steady state of the same roller towed at ``--sinkage`` mm on cells of d /
``--refinement`` (``--strain``), the spin found for zero axle torque from the undisturbed soil:
where its wall time goes (PETSc's log for the LU factorizations, the LU solves and GMRES's
orthogonalisation; Python's profiler for the Jacobian's actions, the residuals, the sweeps
inside each and the preconditioner's matrices), as fractions of the solve's wall time (the
slowest rank's), and the Newton and Krylov iterations; with several ``--forcing`` the state
solved with each (GMRES's Eisenstat-Walker forcing; 0: the fixed tolerance) in turn, in one run.

    python -m benchmarks steady hertz [--p0 3.6 4.5] [--cells-per-half-width 4]
        [--travel 14] [--step 0.0625] [--distance 5] [--out bench_steady.json]
    mpirun -n 2 python -m benchmarks steady ranks [--cells-per-half-width 2] [--sinkage 2.5 5]
    python -m benchmarks steady reach [--soil case2 case8] [--cells-per-half-width 2 4 8] [--friction 0 0.8]
        [--relaxation 0] [--step 1] [--deepest 40] [--fixed-point 0] [--newton-retry 0 100]
    python -m benchmarks steady shove [--soil case8] [--sinkage 10] [--cells-per-half-width 8]
        [--relaxation 5] [--halvings 6] [--fixed-point 20000] [--newton-retry 100]
    python -m benchmarks steady stabilised [--soil case2 case8] [--per-spacing 0.25 1] [--cells-per-half-width 4 8 16]
    python -m benchmarks steady towed [--soil clay] [--sinkage 2 3 4] [--cells-per-half-width 4]
    python -m benchmarks steady wheel [--soil case5] [--sinkage 4 6] [--travel 4] [--cells-per-half-width 4]
    python -m benchmarks steady rolled [--sinkage 12] [--refinement 10] [--strain pointwise] [--travel 2.5]
    mpirun -n 2 python -m benchmarks steady window [--accuracy standard] [--beside 0.3 0.6]
        [--sinkage 3.05 7.62 10.67] [--load 133.5 --friction 0.8]
    mpirun -n 2 python -m benchmarks steady profile [--refinement 20] [--strain pointwise] [--sinkage 3.048]
        [--forcing 0 0.1]
    mpirun -n 2 python -m benchmarks steady convergence [--soil case5 case17 clay case2]
        [--strain pointwise cell-average] [--levels 10 20 30 40] [--load KN] [--relaxation-per-spacing R]
        [--fixed-point N] [--out DIR]
    mpirun -n 2 python -m benchmarks steady limit [--refinement 20] [--strain cell-average]
        [--load 133.5] [--friction 0.8]
"""
from __future__ import annotations

import argparse
import itertools
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

from _bench import dump_json, observed_order  # noqa: E402
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
    rolled = sub.add_parser("rolled", help="3D roller on clay: the steady state against the roll on the same cells")
    rolled.add_argument("--sinkage", type=float, default=12.0, help="mm")
    rolled.add_argument("--refinement", type=float, default=10.0, help="elements per d at the contact")
    rolled.add_argument("--strain", choices=("pointwise", "cell-average"), default="pointwise")
    rolled.add_argument("--travel", type=float, default=2.5, help="the roll's travel / d")
    rolled.add_argument("--step", type=float, default=0.25, help="the roll's travel step, in cells")
    rolled.add_argument("--every", type=float, default=0.25, help="travel / d between the roll's rows")
    rolled.add_argument("--mean", type=float, default=0.5, help="travel / d over which the roll's Q_V is averaged")
    extent = sub.add_parser("window", help="3D roller on the case-5 soil: the side face's distance")
    extent.add_argument("--accuracy", default="standard", help="the preset of the cells")
    extent.add_argument("--beside", type=float, nargs="+", default=[0.3, 0.6], help="side face from the wheel's edge, d")
    extent.add_argument("--sinkage", type=float, nargs="+", default=[3.05, 7.62, 10.67], help="mm, in turn")
    extent.add_argument("--load", type=float, help="kN: towed at this load through the steady driver")
    extent.add_argument("--friction", type=float, default=0.8, help="with --load: the Coulomb coefficient")
    limit = sub.add_parser("limit", help="3D roller on the case-5 soil at its load: the relaxation's limit")
    limit.add_argument("--refinement", type=float, default=20.0, help="elements per d at the contact")
    limit.add_argument("--strain", choices=("cell-average", "pointwise"), default="cell-average")
    limit.add_argument("--load", type=float, default=133.5, help="kN")
    limit.add_argument("--friction", type=float, default=0.8)
    conv = sub.add_parser("convergence", help="3D roller towed at its load: mesh convergence per soil and strain")
    conv.add_argument("--soil", nargs="+", choices=sorted(CONVERGENCE_SOILS), default=sorted(CONVERGENCE_SOILS))
    conv.add_argument("--strain", nargs="+", choices=("pointwise", "cell-average"), default=["pointwise", "cell-average"])
    conv.add_argument("--levels", type=float, nargs="+", default=[10.0, 20.0, 30.0, 40.0],
                      help="elements per d at the contact")
    conv.add_argument("--load", type=float, help="kN (default: the soil's, as rolled)")
    conv.add_argument("--relaxation-per-spacing", type=float,
                      help="relax the soil by this many station spacings of each level (default: not)")
    conv.add_argument("--fixed-point", type=int, default=0,
                      help="fixed-point iterations per state where Newton fails (0: Newton alone)")
    conv.add_argument("--out", help="directory of the JSON rows")
    prof = sub.add_parser("profile", help="3D roller, one steady state: where the time goes")
    prof.add_argument("--refinement", type=float, default=20.0, help="elements per d at the contact")
    prof.add_argument("--strain", choices=("cell-average", "pointwise"), default="pointwise")
    prof.add_argument("--sinkage", type=float, default=3.048, help="mm")
    prof.add_argument("--forcing", type=float, nargs="+", default=[0.1],
                      help="GMRES's Eisenstat-Walker forcing (0: the options' fixed tolerance), each in turn")
    reach = sub.add_parser("reach", help="plane strain, towed cylinder: how deep the rate-independent steps reach")
    reach.add_argument("--soil", nargs="+", choices=sorted(REACH_SOILS), default=sorted(REACH_SOILS))
    reach.add_argument("--cells-per-half-width", type=int, nargs="+", default=[2, 4, 8], help="cells per 0.1 d")
    reach.add_argument("--friction", type=float, nargs="+", default=[0.0, 0.8])
    reach.add_argument("--relaxation", type=float, nargs="+", default=[0.0], help="relaxation lengths, mm")
    reach.add_argument("--step", type=float, default=1.0, help="sinkage step, mm")
    reach.add_argument("--deepest", type=float, default=40.0, help="mm")
    reach.add_argument("--fixed-point", type=int, default=0, help="fixed-point iterations where Newton fails")
    reach.add_argument("--newton-retry", type=int, nargs="+", default=[100],
                       help="fixed-point iterations before Newton is tried again (0: never), each in turn")
    shove = sub.add_parser("shove", help="plane strain, held cylinder: the relaxation taken away")
    shove.add_argument("--soil", choices=sorted(REACH_SOILS), default="case8")
    shove.add_argument("--sinkage", type=float, default=10.0, help="mm")
    shove.add_argument("--cells-per-half-width", type=int, default=8, help="cells per 0.1 d")
    shove.add_argument("--relaxation", type=float, default=5.0, help="the first relaxation length, mm")
    shove.add_argument("--halvings", type=int, default=6, help="halvings of the relaxation length before none")
    shove.add_argument("--fixed-point", type=int, default=20000, help="fixed-point iterations where Newton fails")
    shove.add_argument("--newton-retry", type=int, default=100,
                       help="fixed-point iterations before Newton is tried again (0: never)")
    stab = sub.add_parser("stabilised", help="plane strain, towed cylinder at the load: relaxation ~ cells")
    stab.add_argument("--soil", nargs="+", choices=sorted(REACH_SOILS), default=sorted(REACH_SOILS))
    stab.add_argument("--per-spacing", type=float, nargs="+", default=[0.25, 1.0],
                      help="relaxation lengths in station spacings")
    stab.add_argument("--cells-per-half-width", type=int, nargs="+", default=[4, 8, 16], help="cells per 0.1 d")
    args = ap.parse_args()
    run = {"hertz": hertz_against_transient, "ranks": distributed_against_serial, "towed": towed_surface_layer,
           "wheel": steady_against_transient, "window": side_face, "limit": relaxation_limit,
           "convergence": mesh_convergence, "profile": profile_one_state, "rolled": steady_against_rolled,
           "reach": rate_independent_reach, "stabilised": stabilised_at_load, "shove": relaxation_removed}
    return run[args.problem](args)


#: the soils of the ``towed`` problem
TOWED_SOILS = {"clay": VonMises(E=40e6, nu=0.35, yield_stress=200e3),
               "case5": DruckerPrager(E=40e6, nu=0.35, phi_dp=math.radians(27.5), c_dp=194.6e3)}


def rate_independent_reach(args) -> int:
    """The ``reach`` problem (module docstring)."""
    print("| soil | cells at the contact (mm) | dofs | mu | relaxation (mm) | Newton retried after | deepest steady "
          "state (mm) | Q_V there (kN/m) | surface moved forward there (mm) | the next step | wall time |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for name, cells, mu, length, retry in itertools.product(args.soil, args.cells_per_half_width, args.friction,
                                                             args.relaxation, args.newton_retry):
        st, window = _reach_problem(name, cells, mu)
        st.relaxation_length = 1e-3 * length
        st.control = replace(st.control, fixed_point_iterations=args.fixed_point, newton_retry=retry)
        t0, reached, force, forward, stop = time.perf_counter(), 0.0, 0.0, 0.0, f"none to {args.deepest:g} mm"
        for s in np.arange(1, round(args.deepest / args.step) + 1) * args.step:
            try:
                res = st.solve_free_rolling(1e-3 * s)
            except NoSteadyState as err:
                stop = f"fails: {_cause(err)}"
                break
            reached, force, forward = s, res.vertical_force / 1e3, 1e3 * st.surface_displacement()[1][0, 0]
        dofs = st.V.dofmap.index_map.size_global * 2
        print(f"| {name} | {1e3 * window.cell_size:.0f} | {dofs} | {mu:g} | {length:g} | {retry or 'never'} | "
              f"{reached:g} | {force:.1f} | {forward:.1f} | {stop} | {time.perf_counter() - t0:.0f} s |", flush=True)
    return 0


def _cause(err: NoSteadyState) -> str:
    """Why a steady solve failed: its message without the sinkage and the closing remark."""
    return str(err).split(": ", 1)[1].split("; the load may")[0]


def relaxation_removed(args) -> int:
    """The ``shove`` problem (module docstring)."""
    st, window = _reach_problem(args.soil, args.cells_per_half_width, 0.0)
    st.control = replace(st.control, fixed_point_iterations=args.fixed_point, newton_retry=args.newton_retry)
    sinkage = 1e-3 * args.sinkage
    lengths = [args.relaxation * 0.5 ** k for k in range(args.halvings + 1)] + [0.0]
    print(f"{args.soil}, held at {args.sinkage:g} mm, frictionless, plane strain, cells of "
          f"{1e3 * window.cell_size:.0f} mm at the contact\n"
          "| relaxation (mm) | Q_V (kN/m) | surface moved forward (mm) | max. accumulated plastic strain | Newton its | "
          "fixed-point its | wall time |\n|---|---|---|---|---|---|---|")
    for k, length in enumerate(lengths):
        st.relaxation_length = 1e-3 * length
        t0 = time.perf_counter()
        try:
            if k == 0:
                for s in np.append(np.arange(1e-3, sinkage, 1e-3), sinkage):
                    res = st.solve_sinkage(float(s))
            else:
                res = st.solve_sinkage(sinkage, max_cuts=0)
        except NoSteadyState as err:
            print(f"| {length:.3g} | none: {_cause(err)} | | | | | "
                  f"{time.perf_counter() - t0:.0f} s |", flush=True)
            break
        print(f"| {length:.3g} | {res.vertical_force / 1e3:.1f} | {1e3 * st.surface_displacement()[1][0, 0]:.1f} | "
              f"{res.max_accumulated_plastic_strain:.2f} | {res.newton_iterations} | {res.fixed_point_iterations} | "
              f"{time.perf_counter() - t0:.0f} s |", flush=True)
    return 0


def stabilised_at_load(args) -> int:
    """The ``stabilised`` problem (module docstring)."""
    load = 133.5e3 / ROLLER.width                    # N/m
    print("| soil | relaxation (station spacings) | cells at the contact (mm) | dofs | relaxation (mm) | sinkage at "
          "the load (mm) | change | order | Q_H (kN/m) | wall time |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for name, ratio in itertools.product(args.soil, args.per_spacing):
        found, cells_mm = [], []
        for cells in args.cells_per_half_width:
            st, window = _reach_problem(name, cells, 0.8)
            cells_mm.append(window.cell_size)
            st.relaxation_length = ratio * st.station_spacing
            t0, states, res, s = time.perf_counter(), {}, None, 0.0
            try:
                while res is None or res.vertical_force < load:
                    res = st.solve_free_rolling(s + 1e-3)
                    s += 1e-3                               # the deepest state found
                    states[s] = (st.u.x.array.copy(), st.spin, res.vertical_force)
                res = st.solve_load(load, free_rolling=True, states=states, rtol=1e-5)
                found.append(res.sinkage)
                change = f"{100 * (found[-1] / found[-2] - 1):+.1f} %" if len(found) > 1 and math.isfinite(found[-2]) \
                    else "-"
                last = (cells_mm[-3:][::-1], found[-3:][::-1])                  # fine to coarse
                fit = observed_order(*last) if len(found) >= 3 and np.isfinite(last[1]).all() else None
                cols = (f"{1e3 * res.sinkage:.3f}", change,
                        "-" if fit is None else f"{fit[0]:.2f} (Richardson {1e3 * fit[1]:.2f} mm)",
                        f"{res.towing_force / 1e3:.2f}")
            except NoSteadyState as err:
                found.append(math.nan)
                cols = (f"none beyond {1e3 * s:g} ({str(err).split(': ', 1)[1].split(';')[0]})", "-", "-", "-")
            dofs = st.V.dofmap.index_map.size_global * 2
            print(f"| {name} | {ratio:g} | {1e3 * window.cell_size:.0f} | {dofs} | {1e3 * st.relaxation_length:.2f} | "
                  + " | ".join(cols) + f" | {time.perf_counter() - t0:.0f} s |", flush=True)
    return 0


def _reach_problem(name: str, cells: int, mu: float):
    """The towed cylinder of ``reach`` and ``stabilised`` on ``REACH_SOILS[name]``, and its window."""
    from rollsim.scene import parse_scene
    from rollsim.solver.contact import Circle
    from rollsim.solver.scene_model import layer_materials
    d = ROLLER.diameter
    scene = parse_scene({"wheel": {"diameter": f"{d} m", "width": f"{ROLLER.width} m"},
                         "soil": {"gamma": "20 kN/m^3", "layers": [REACH_SOILS[name]]},
                         "loading": {"protocol": "indentation", "max_sinkage": "0.1 m"}})
    soil = layer_materials(scene)
    window = RollingWindow(half_width=0.1 * d, ahead=0.4 * d, behind=0.6 * d, depth=0.4 * d, cells_per_half_width=cells)
    layers = [soil.by_layer[k] for k in sorted(soil.by_layer)]
    st = SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, window), layers, wheel=Circle(diameter=d), friction=mu,
                       unit_weight=20e3, volumetric_strain="pointwise")
    return st, window


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
    h = window.fine_cell_size
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


def steady_against_rolled(args) -> int:
    """The ``rolled`` problem (module docstring)."""
    from rollsim.scene import parse_scene
    from rollsim.solver.drivers.steady_rolling import steady_window
    from rollsim.solver.scene_model import layer_materials
    comm = MPI.COMM_WORLD
    scene = parse_scene({"wheel": {"diameter": f"{ROLLER.diameter} m", "width": f"{ROLLER.width} m"},
                         "soil": {"gamma": "20 kN/m^3", "layers": CONVERGENCE_SOILS["clay"][1]},
                         "loading": {"protocol": "rolling-constant-load", "load": "100 kN"},
                         "model": {"rolling": "steady", "refinement": args.refinement,
                                   "volumetric_strain": args.strain}})
    # the scene's gravity sizes the window only: both solves run without it
    soil, window, sinkage = layer_materials(scene).by_layer[1], steady_window(scene), 1e-3 * args.sinkage
    t0 = time.perf_counter()
    st = SteadyRolling(rolling_window_mesh(comm, window), soil, wheel=ROLLER, volumetric_strain=args.strain)
    for s in np.append(np.arange(2e-3, sinkage, 2e-3), sinkage):
        res = st.solve_sinkage(float(s))
    steady_wall = comm.allreduce(time.perf_counter() - t0, MPI.MAX)
    dofs = st.V.dofmap.index_map.size_global * st.gdim
    h = window.fine_cell_size
    t0 = time.perf_counter()
    rows = rolled_roller(comm, window, soil, args.strain, sinkage, round(args.travel * ROLLER.diameter / h) * h, args.step)
    rolled_wall = comm.allreduce(time.perf_counter() - t0, MPI.MAX)
    if comm.rank == 0:
        print(f"3D Mn/DOT roller held at {args.sinkage:g} mm on frictionless clay (von Mises c_dp = 300 kPa, no "
              f"gravity), {args.strain}, fine cells d/{args.refinement:g}; steady window {dofs} dofs\n"
              f"| run | travel (d) | Q_V (kN) | Q_H (kN) | against steady | wall (s) |\n|---|---|---|---|---|---|")
        print(f"| steady | | {res.vertical_force / 1e3:.2f} | {res.towing_force / 1e3:.2f} | | {steady_wall:.0f} |")
        travel = np.array([row["travel"] for row in rows]) / ROLLER.diameter
        shown = sorted(set(np.searchsorted(travel, np.arange(args.every, travel[-1] + 1e-9, args.every) - 1e-9)
                           .tolist()) | {len(rows) - 1})
        for i in shown:
            q = rows[i]["QV"]
            print(f"| rolled | {travel[i]:.2f} | {q / 1e3:.2f} | {rows[i]['QH'] / 1e3:.2f} | "
                  f"{100 * (q / res.vertical_force - 1):+.2f} % | " + (f"{rolled_wall:.0f} |" if i == len(rows) - 1 else "|"))
        last = np.array([row["QV"] for row in rows])[travel >= travel[-1] - args.mean - 1e-9]
        print(f"rolled Q_V over the last {args.mean:g} d: mean {last.mean() / 1e3:.2f} kN ({last.min() / 1e3:.2f} to "
              f"{last.max() / 1e3:.2f}), {100 * (last.mean() / res.vertical_force - 1):+.2f} % against steady")
    return 0


def rolled_roller(comm, window: RollingWindow, soil, strain: str, sinkage: float, travel: float,
                  step: float) -> list[dict]:
    """The reference of the ``rolled`` problem: the frictionless :data:`ROLLER` pressed to ``sinkage``
    (m) at x = 0 and rolled by ``travel`` (m, a whole number of fine cells) at that axle height, in
    steps of ``step`` cells, over a half block of ``window``'s cells with its fine zone stretched by
    the travel (end faces and base held, rollers on the symmetry plane and the side face); after
    each step the travel (m), Q_V and Q_H of the whole wheel (N)."""
    from dolfinx import fem, mesh as dmesh
    from petsc4py import PETSc
    from rollsim.solver import PlasticityProblem, StepControl, solve_load_path
    from rollsim.solver.contact import RigidWheelContact
    h = window.fine_cell_size
    msh = stretched_block(window, travel, comm)
    pb = PlasticityProblem(msh, soil, volumetric_strain=strain)
    fdim = msh.topology.dim - 1
    lo = np.min(comm.allgather(msh.geometry.x.min(axis=0)), axis=0)        # the block's corners
    hi = np.max(comm.allgather(msh.geometry.x.max(axis=0)), axis=0)
    held = dmesh.locate_entities_boundary(msh, fdim, lambda p: np.isclose(p[0], lo[0]) | np.isclose(p[0], hi[0])
                                          | np.isclose(p[2], lo[2]))
    sides = dmesh.locate_entities_boundary(msh, fdim, lambda p: np.isclose(p[1], 0.0) | np.isclose(p[1], hi[1]))
    pb.bcs = [fem.dirichletbc(fem.Function(pb.V), fem.locate_dofs_topological(pb.V, fdim, held)),
              fem.dirichletbc(PETSc.ScalarType(0.0), fem.locate_dofs_topological(pb.V.sub(1), fdim, sides),
                              pb.V.sub(1))]
    surface = dmesh.locate_entities_boundary(msh, fdim, lambda p: np.isclose(p[2], 0.0))
    tags = dmesh.meshtags(msh, fdim, np.sort(surface), np.ones(len(surface), np.int32))
    # the steady window's penalty (kappa from the finest column spacing) and facet rule
    top = ROLLER.diameter / 2                   # the axle's height over the surface at no sinkage
    contact = RigidWheelContact(pb, ROLLER, tags, (1,), quadrature_degree=12, h=h, centre=[0.0, 0.0, top])
    solve_load_path(pb, lambda t: contact.set_pose(centre=[0.0, 0.0, top - sinkage * t]),
                    StepControl(dt=0.1, dt_max=0.1))
    rows = []

    def record(t):
        forces = contact.forces()
        rows.append({"travel": t, "QV": 2 * forces.vertical, "QH": 2 * forces.horizontal})

    ds = step * h
    solve_load_path(pb, lambda t: contact.set_pose(centre=[t, 0.0, top - sinkage]),
                    StepControl(t_end=travel, dt=ds, dt_max=ds, dt_min=ds / 64, easy_iterations=1000),
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
    from rollsim.solver.drivers.steady_rolling import steady_problem, steady_window
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
        st = steady_problem(scene, comm, window)
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


def relaxation_limit(args) -> int:
    """The ``limit`` problem (module docstring)."""
    from rollsim.solver.drivers import steady_rolling as drv
    comm = MPI.COMM_WORLD
    scene = _case5_roller(args.friction, args.load, refinement=args.refinement, volumetric_strain=args.strain)
    routes = ("as the driver", "relaxation's limit") if args.strain == "pointwise" else ("as the driver",)
    for route in routes:
        at_load = drv._at_load
        if route == "relaxation's limit":
            drv._at_load = lambda steady, *rest: drv._relaxation_limit(steady, *rest)
        try:
            r, _ = _steady_run(scene, comm)
        finally:
            drv._at_load = at_load
        if comm.rank != 0:
            continue
        print(f"towed at {args.load:g} kN, mu = {args.friction:g}, d/{args.refinement:g} cells, {args.strain}, "
              f"{r['dofs']} dofs, {route}: {r['status']}, {1e3 * r['sinkage_m']:.3f} mm, Q_H {r['QH_N'] / 1e3:.2f} kN, "
              f"{r['newton_iterations']} Newton its, {r['wall_time_s']:.0f} s", flush=True)
        limit = r.get("relaxation_limit")
        if limit:
            print("| relaxation length (mm) | sinkage (mm) | Q_H (kN) | Newton its |\n|---|---|---|---|")
            for level in limit["levels"]:
                print(f"| {1e3 * level['relaxation_length_m']:.3g} | {1e3 * level['sinkage_m']:.3f} "
                      f"| {level['QH_N'] / 1e3:.2f} | {level['newton_iterations']} |")
            if limit["sinkage_m"] is not None:
                print(f"extrapolated {1e3 * limit['sinkage_m']:.3f} mm (correction {1e3 * limit['correction_m']:.3f} mm), "
                      f"converged: {limit['converged']}", flush=True)
    return 0


def _layer(model: str, c_dp: str, phi_dp: str | None = None, **extra) -> dict:
    return {"model": model, "E": "40 MPa", "nu": 0.35, "c_dp": c_dp, **({"phi_dp": phi_dp} if phi_dp else {}), **extra}


#: the soils of the ``reach`` problem: ``[[soil.layers]]`` tables of the report's rolling cases
REACH_SOILS = {"case8": _layer("drucker-prager", "89.1 kPa", "45.4 deg"), "case2": _layer("von-mises", "200 kPa")}


#: the soils of the ``convergence`` problem: (friction, layers, load in kN), those of the rolled
#: references (docs/speed-accuracy-details.md, "Constant-load rolling: mesh convergence")
CONVERGENCE_SOILS = {
    "case5": (0.8, [_layer("drucker-prager", "194.6 kPa", "27.5 deg")], 133.5),
    "case17": (0.8, [_layer("von-mises", "300 kPa", thickness="0.6096 m"),
                     _layer("von-mises", "300 kPa", thickness="0.6096 m"), _layer("von-mises", "300 kPa")], 133.5),
    "clay": (0.0, [_layer("von-mises", "300 kPa")], 100.0),
    "case2": (0.8, [_layer("von-mises", "200 kPa")], 133.5),
    "case8": (0.8, [_layer("drucker-prager", "89.1 kPa", "45.4 deg")], 133.5),
}

#: the shortest spacing of a streamline's stations in cells of length h, over h: two Gauss
#: points of the 3-point rule either side of a face between equal cells
GAUSS_FACE_SPACING = 1.0 - math.sqrt(3.0 / 5.0)


def mesh_convergence(args) -> int:
    """The ``convergence`` problem (module docstring)."""
    import json
    from rollsim.scene import parse_scene
    from rollsim.solver.steady import NewtonKrylovControl
    comm = MPI.COMM_WORLD
    control = NewtonKrylovControl(fixed_point_iterations=args.fixed_point)
    for soil in args.soil:
        friction, layers, load = CONVERGENCE_SOILS[soil]
        load = args.load or load
        for strain in args.strain:
            rows = []
            ratio = args.relaxation_per_spacing
            if comm.rank == 0:
                print(f"\n{soil}, {strain}, towed at {load:g} kN" + (f", relaxed by {ratio:g} station spacing(s)"
                                                                     if ratio else "") +
                      "\n| cells at the contact | dofs | status | sinkage (mm) | Q_H (kN) | rut (mm) | surface moved "
                      "forward (mm) | Newton its | fixed-point its | wall (s) |\n|---|---|---|---|---|---|---|---|---|---|",
                      flush=True)
            for level in args.levels:
                model = {"rolling": "steady", "refinement": level, "volumetric_strain": strain}
                if ratio:
                    model["relaxation_length"] = ratio * GAUSS_FACE_SPACING * ROLLER.diameter / level
                scene = parse_scene({"wheel": {"diameter": "1.524 m", "width": "0.4572 m", "friction": friction},
                                     "soil": {"gamma": "20 kN/m^3", "layers": layers},
                                     "loading": {"protocol": "rolling-constant-load", "load": f"{load} kN"},
                                     "model": model})
                r, _ = _steady_run(scene, comm, control=control)
                rows.append({"level": level, "dofs": r["dofs"], "status": r["status"], "reason": r.get("reason"),
                             "sinkage_m": r["sinkage_m"], "QH_N": r["QH_N"], "rut_m": r.get("rut_depth_m"),
                             "newton_iterations": r["newton_iterations"], "wall_time_s": r["wall_time_s"],
                             "fixed_point_iterations": r.get("fixed_point_iterations"),
                             "relaxation_limit": r.get("relaxation_limit"),
                             "relaxation_length_m": model.get("relaxation_length", 0.0),
                             "surface_forward_m": r.get("surface_forward_m")})
                if comm.rank == 0:
                    print(f"| d/{level:g} | {r['dofs']} | {r['status']} | {1e3 * r['sinkage_m']:.2f} | "
                          f"{r['QH_N'] / 1e3:.2f} | {1e3 * (r.get('rut_depth_m') or float('nan')):.2f} | "
                          f"{1e3 * (r.get('surface_forward_m') or float('nan')):.1f} | "
                          f"{r['newton_iterations']} | {r.get('fixed_point_iterations')} | {r['wall_time_s']:.0f} |",
                          flush=True)
                    if r["status"] != "ok":
                        print(f"  ({r['status']}: {r.get('reason')})", flush=True)
                    if args.out:
                        path = pathlib.Path(args.out) / f"steady_convergence_{soil}_{strain}.json"
                        path.parent.mkdir(parents=True, exist_ok=True)
                        path.write_text(json.dumps(rows, indent=1))
            ok = [row for row in rows if row["status"] == "ok"]
            if comm.rank == 0 and len(ok) >= 3:
                fine = ok[::-1][:3]
                h, s = [1 / row["level"] for row in fine], [row["sinkage_m"] for row in fine]
                fit = observed_order(h, s)
                print(f"last refinement {100 * (s[0] - s[1]) / s[0]:+.2f} %; " +
                      (f"observed order {fit[0]:.2f}, Richardson {1e3 * fit[1]:.2f} mm" if fit is not None
                       else "changes not monotone: no order"), flush=True)
    return 0


#: the ``profile`` problem's parts: PETSc log events, and the Python functions (by name) whose
#: time is counted where they are outermost
PROFILE_EVENTS = {"LU factorizations": ("MatLUFactorSym", "MatLUFactorNum"), "LU solves": ("MatSolve",),
                  "GMRES orthogonalisation": ("KSPGMRESOrthog",)}
PROFILE_FUNCTIONS = {"Jacobian actions (sweep, assembly, friction)": "jacobian_action",
                     "  of which tangent-linear sweeps": "_tangent_sweep",
                     "residuals (sweep, assembly, friction)": "residual", "  of which sweeps": "_sweep",
                     "preconditioner matrices (assembly)": "_update_preconditioner"}


def profile_one_state(args) -> int:
    """The ``profile`` problem (module docstring)."""
    from rollsim.solver.steady import NewtonKrylovControl
    from rollsim.solver.drivers.steady_rolling import steady_problem, steady_window
    comm = MPI.COMM_WORLD
    scene = _case5_roller(0.8, 133.5, refinement=args.refinement, volumetric_strain=args.strain)
    walls = []
    for forcing in args.forcing:
        steady = steady_problem(scene, comm, steady_window(scene), control=NewtonKrylovControl(forcing=forcing))
        wall, parts, res, dofs = _profiled_state(steady, args)
        walls.append(wall)
        if comm.rank == 0:
            print(f"\nGMRES forcing {forcing:g}: one steady state at {args.sinkage:g} mm, d/{args.refinement:g} cells, "
                  f"{args.strain}, {dofs} dofs, {comm.size} rank(s): {wall:.1f} s, {res.newton_iterations} Newton, "
                  f"{res.krylov_iterations} Krylov iterations, Q_V {res.vertical_force / 1e3:.4f} kN, spin "
                  f"{res.spin:.6f}\n| part | share of the wall time |\n|---|---|")
            for name, value in parts.items():
                print(f"| {name} | {100 * value / wall:.0f} % |")
            rest = wall - sum(value for name, value in parts.items() if not name.startswith(" "))
            print(f"| the rest (Python, PETSc's other work) | {100 * rest / wall:.0f} % |", flush=True)
    if comm.rank == 0 and len(walls) > 1:
        print("\nwall time against the first forcing's: " + ", ".join(f"{w / walls[0]:.2f}" for w in walls))
    return 0


def _profiled_state(st: SteadyRolling, args):
    """One free-rolling steady state of ``st`` at ``args.sinkage`` under the profilers: the
    wall time (s, the slowest rank's), its parts (s), the result and the dofs."""
    import cProfile
    import pstats
    from petsc4py import PETSc
    from rollsim.solver.drivers.steady_rolling import TORQUE_RTOL
    comm = st.comm
    PETSc.Log.begin()
    before = {name: sum(PETSc.Log.Event(e).getPerfInfo()["time"] for e in events)
              for name, events in PROFILE_EVENTS.items()}
    profiler = cProfile.Profile()
    comm.barrier()
    t0 = time.perf_counter()
    profiler.enable()
    res = st.solve_free_rolling(args.sinkage * 1e-3, None, torque_rtol=TORQUE_RTOL)
    profiler.disable()
    wall = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
    parts = {name: sum(PETSc.Log.Event(e).getPerfInfo()["time"] for e in events) - before[name]
             for name, events in PROFILE_EVENTS.items()}
    stats = pstats.Stats(profiler).stats
    for name, function in PROFILE_FUNCTIONS.items():
        parts[name] = sum(cumulative for (path, _, fn), (_, _, _, cumulative, _) in stats.items()
                          if fn == function and path.endswith("steady.py"))
    parts = {name: comm.allreduce(value, op=MPI.MAX) for name, value in parts.items()}
    return wall, parts, res, st.V.dofmap.index_map.size_global * st.gdim


def _steady_run(scene, comm, **kwargs) -> tuple[dict, list[tuple[float, float]]]:
    """``rollsim run``'s steady driver on ``scene`` in a scratch directory: the summary and, on
    rank 0, the (sinkage, Q_V) of the states on the way."""
    import csv
    import shutil
    import tempfile
    from rollsim.solver.drivers.steady_rolling import run_steady
    out = comm.bcast(tempfile.mkdtemp() if comm.rank == 0 else None)
    states = []
    try:
        r = run_steady(scene, pathlib.Path(out) / "run", comm, progress=False, write_fields=False, **kwargs)
        if comm.rank == 0:
            with open(pathlib.Path(out) / "run" / "history.csv") as f:
                states = [(float(row["sinkage_m"]), float(row["QV_N"])) for row in csv.DictReader(f)]
    finally:
        comm.barrier()
        if comm.rank == 0:
            shutil.rmtree(out)
    return r, states


def _towed_at_load(scene, besides: list[float], comm) -> int:
    """The ``window`` problem with ``--load``: the steady driver's constant-load run per side face."""
    if comm.rank == 0:
        print(f"towed at {scene.loading.load / 1e3:g} kN, mu = {scene.wheel.friction:g}, {scene.model.accuracy}\n"
              "| side face from the wheel's edge (d) | dofs | status | sinkage (mm) | Q_H (kN) | rut (mm) | Newton its "
              "| wall (s) |\n|---|---|---|---|---|---|---|---|", flush=True)
    states = []
    for beside in besides:
        r, rows = _steady_run(scene, comm, window={"beside": beside})
        states.append((beside, rows))
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
