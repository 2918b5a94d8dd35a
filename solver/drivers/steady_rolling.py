"""Driver of the rolling protocols with ``[model] rolling = "steady"``: the rigid wheel's steady
state solved directly in its frame (:class:`~rollsim.solver.steady.SteadyRolling`) on a half
window sized from the wheel and the preset (:func:`steady_window`), instead of rolling it along a
block.

* ``rolling-constant-load``: the sinkage is stepped up (each state the start of the next) until
  the towed wheel carries ``loading.load``, then found by a secant iteration; the summary gives
  the steady sinkage, Q_H, the wheel's spin and rolling radius, the contact length, the rut left
  behind the window's rear face and the rebound.
  With ``loading.passes`` > 1 the wheel passes again over the soil the last pass left behind
  (its outflow state; the summary's ``passes`` and ``shakedown``).
* ``rolling-continuous``: the towed wheel held at ten sinkages up to ``loading.max_sinkage``,
  each a steady state: the force-sinkage curve Q_V(s), Q_H(s) without a ramp.

``loading.travel`` is not used.  Files: ``summary.json`` (``"rolling": "steady"``, the window,
Newton and Krylov iterations), ``history.csv`` (one row per converged steady state, travel 0),
``force_sinkage.png``, ``rut_profile.csv`` (the surface on the wheel's centre line in the moving
frame: x from the front face to the rear, settlement), ``rut.png`` and ``fields/steady.xdmf``.
"""
from __future__ import annotations

import math
import pathlib
import time
from dataclasses import replace

import numpy as np
from mpi4py import MPI

from rollsim import compat
from rollsim.files import atomic_write_text
from rollsim.log import get_logger

from ..rundir import _pyplot, _save, finish_run, make_run_directory, write_history
from ..scene_model import layer_materials, scene_penalty, wheel_geometry
from ..steady import NoSteadyState, RollingWindow, SteadyRolling, rolling_window_mesh
from .base import run_protected

__all__ = ["run_steady", "steady_problem", "steady_window", "CURVE_POINTS"]

log = get_logger("run")

#: steady states on the force-sinkage curve of ``rolling-continuous``
CURVE_POINTS = 10
#: the first sinkage step of ``rolling-constant-load`` (x d), grown by half per step up to
#: :data:`MAX_STEP` (x d)
FIRST_STEP = 0.002
MAX_STEP = 0.005
#: a step near the load aims this many times as far as the secant of the last two states says
#: the load lies (their Q_V(s) bends over: the secant falls short)
LOAD_OVERSHOOT = 1.25
#: how many times a sinkage step whose steady state is not found is halved
STEP_CUTS = 2
#: the window in wheel diameters: the fine zone's half length (also its depth and, from the wheel's
#: edge, its reach across), the soil ahead of the axle, behind it, below the surface and across
#: from the wheel's edge, and below the deepest layer interface (layered soil)
WINDOW = {"half_width": 0.1, "ahead": 0.4, "behind": 0.6, "depth": 0.4, "beside": 0.6, "below_interface": 0.2}


def layer_interfaces(scene) -> tuple[float, ...]:
    """The depths (m) of the boundaries between the scene's soil layers, top first."""
    return tuple(np.cumsum([layer.thickness for layer in scene.soil.layers[:-1]]).tolist())


def steady_window(scene, extents: dict | None = None) -> RollingWindow:
    """The half window of a steady roll of ``scene`` (m): :data:`WINDOW` (with ``extents`` in its
    place where given) times the diameter, each face at least a cell beyond the fine zone, the base
    at least ``below_interface`` below the deepest layer interface (rows of nodes on each); the
    fine cells d / (the preset's elements per d, or ``[model] refinement``)."""
    d, b = scene.wheel.diameter, scene.wheel.width
    extents = {**WINDOW, **(extents or {})}
    half_width = extents["half_width"] * d
    cells = max(1, round(half_width * scene.model.elements_per_d / d))
    fine = RollingWindow(half_width=half_width, ahead=10 * d, behind=10 * d, depth=10 * d, cells_per_half_width=cells,
                         across=10 * (b + d), load_half_width_across=b / 2)
    reach, h = fine.fine_length + fine.cell_size, fine.cell_size        # the fine zone and one cell more
    interfaces = layer_interfaces(scene)
    depth = max(extents["depth"] * d, reach, (interfaces[-1] + extents["below_interface"] * d) if interfaces else 0.0)
    return replace(fine, ahead=max(extents["ahead"] * d, reach), behind=max(extents["behind"] * d, reach),
                   depth=depth, across=max(b / 2 + extents["beside"] * d, fine.fine_across + h), interfaces=interfaces)


def steady_problem(scene, comm: MPI.Comm, window: RollingWindow, *, penalty: float | None = None,
                   **options) -> SteadyRolling:
    """The steady rolling problem of ``scene`` (its soil's layers, wheel, friction, gravity,
    strain and relaxation) on the half ``window`` meshed on ``comm``; ``penalty``: the contact's
    (:func:`~rollsim.solver.scene_model.scene_penalty`; None: the solver's default); ``options``:
    :class:`SteadyRolling`'s (``petsc_options``, ``control``)."""
    soil = layer_materials(scene)
    return SteadyRolling(rolling_window_mesh(comm, window), [soil.by_layer[k] for k in sorted(soil.by_layer)],
                         wheel=wheel_geometry(scene.wheel), interfaces=window.interfaces,
                         friction=scene.wheel.friction, unit_weight=scene.soil.gamma,
                         volumetric_strain=scene.model.volumetric_strain,
                         relaxation_length=scene.model.relaxation_length,
                         **({} if penalty is None else {"penalty": penalty}), **options)


def run_steady(scene, out_dir, comm: MPI.Comm, *, progress: bool = True, petsc_options: dict | None = None,
               write_fields: bool = True, penalty: float | None = None, window: dict | None = None, **options) -> dict:
    """Steady rolling of ``scene`` (rigid cylinder, uniform or layered soil) on ``comm``; writes the run
    directory ``out_dir`` and returns the summary.  ``window``: extents in d in place of
    :data:`WINDOW`'s (studies of the window's effect, tests); ``options``: :func:`steady_problem`'s
    (``control``).  A steady state not found ends the run as ``"failed"`` (the reason; those found kept)."""
    t_start = time.perf_counter()
    out = make_run_directory(out_dir, comm)
    window = steady_window(scene, window)
    alpha = scene_penalty(scene, penalty)
    steady = steady_problem(scene, comm, window, petsc_options=petsc_options, penalty=alpha, **options)
    dofs = steady.V.dofmap.index_map.size_global * steady.gdim
    if progress and comm.rank == 0:
        log.info("steady rolling (%s) of a rigid cylinder d = %g m, b = %g m: window %.3g m ahead, %.3g m "
                 "behind, %.3g m deep, %.3g m across, fine cells %.3g m; %d dofs on %d rank(s)",
                 scene.loading.protocol, scene.wheel.diameter, scene.wheel.width, window.ahead, window.behind,
                 window.depth, window.across, window.cell_size, dofs, comm.size)
    rows: list[dict] = []
    results: dict = {"inflow": steady.inflow, "pass": 1, "fixed_point": 0}     # the soil the current pass meets
    states: dict = {}               # sinkage -> (displacement, spin, Q_V) of the states solved
    passes: list[dict] = []

    def record(res) -> None:
        rows.append(_row(len(rows) + 1, res, scene.wheel.diameter, t_start))
        write_history(out, rows, comm)
        results.update(last=res, state=(steady.u.x.array.copy(), steady.spin), state_inflow=results["inflow"],
                       fixed_point=results["fixed_point"] + res.fixed_point_iterations)
        if progress and comm.rank == 0:
            _log_state(len(rows), res)

    def solve(sinkage: float):
        res = steady.solve_free_rolling(sinkage, results["inflow"], torque_rtol=TORQUE_RTOL)
        record(res)
        states[res.sinkage] = (*results["state"], res.vertical_force)
        return res

    def recorded(res):
        """``res`` recorded unless it is the last state recorded (a step that hit the load)."""
        if res is not results.get("last"):
            record(res)
        return res

    def body():
        if scene.loading.protocol == "rolling-continuous":
            for s in np.arange(1, CURVE_POINTS + 1) * scene.loading.max_sinkage / CURVE_POINTS:
                solve(float(s))
        else:
            for k in range(1, (scene.loading.passes or 1) + 1):
                if k > 1:                           # the soil the last pass left behind, the wheel lifted
                    steady.restart()
                    states.clear()
                    results.update(inflow=results["last"].outflow, **{"pass": k})
                final, limit = _at_load(steady, scene, solve, states, results["inflow"], recorded, progress)
                recorded(final)
                passes.append(_pass_row(k, steady, final, results["inflow"], passes, progress, limit))
                if limit is not None:
                    results["limit"] = limit
        return None

    status, reason, diagnostics = run_protected(body, comm, lambda: {"steady_states": len(rows)})
    if rows:                       # the last state recorded (a failed solve leaves another behind)
        steady.u.x.array[:], steady.spin = results["state"]
        steady.residual(results["state_inflow"])          # its fields swept again
    line = _centre_line(steady, rows[-1]["sinkage_m"]) if rows else None
    summary = _summary(scene, steady, window, rows, results.get("last"), line, status, reason, diagnostics,
                       t_start, dofs, alpha)
    summary["fixed_point_iterations"] = results["fixed_point"]
    if "limit" in results:
        _add_limit(summary, results["limit"])
    several = (scene.loading.passes or 1) > 1
    if several:
        summary.update(_passes_summary(passes))
    if rows:
        _write_rut(out, line, scene, summary, comm)
        if write_fields:
            _write_fields(out, steady)
            summary["files"]["fields"] = ["fields/steady.xdmf"]
    if several and passes and "rut_depth_m" in summary:
        summary["rut_depth_m"] = passes[-1]["total_rut_m"]        # of all passes (the profile: the last's)
    return finish_run(out, rows, scene, summary, comm, progress=progress)


def _log_state(step: int, res) -> None:
    """The progress line of the ``step``-th steady state recorded."""
    log.info("steady state %d: s = %.4g mm, Q_V = %.4g kN, Q_H = %.4g kN, spin %.5f (%d Newton, %d Krylov, "
             "%d fixed-point, %.1f s)", step, 1e3 * res.sinkage, res.vertical_force / 1e3, res.towing_force / 1e3,
             res.spin, res.newton_iterations, res.krylov_iterations, res.fixed_point_iterations, res.wall_time)


class WheelPloughs(NoSteadyState):
    """No steady state carries the load down to the sinkage d/4: the wheel would plough on."""


#: the soil's relaxation length, in the shortest spacing of the streamlines' stations, on the way
#: to a rate-independent steady state the sinkage steps do not reach; halved at the load, each
#: length from the state of the last (the regularisation acts per station: each station's stress
#: moves 1 / (1 + L / spacing) of the way to the return map's)
RELAXATION_START = 0.25
#: the relaxation's limit is reached when the extrapolation of the last three lengths' sinkages
#: moves the last by at most this fraction of it
RELAXATION_RTOL = 0.01
#: the limit counts as reached only where the sinkages' observed order in the length is at least
#: this (1: first order; 0.4: the change per halving falls by at least a quarter)
RELAXATION_MIN_ORDER = 0.4
#: ... and where the orders through the last three lengths and through the three before them
#: differ by at most this (a series in its asymptotic range: one small change does not certify)
RELAXATION_ORDER_SPREAD = 0.5
#: relaxation lengths at most (the first included)
RELAXATION_LEVELS = 12
#: each length over the last: halved, and where that state is not found, the milder reductions
RELAXATION_REDUCTIONS = (0.5, 2 ** -0.5, 2 ** -0.25)
#: relative tolerance on Q_V = load of each relaxation length after the first (finer than
#: :data:`LOAD_RTOL`: the sinkage's change between lengths must stand above the load's tolerance)
LEVEL_LOAD_RTOL = 1e-4


def _at_load(steady: SteadyRolling, scene, solve, states: dict, inflow, record, progress: bool):
    """The towed wheel's steady state at ``loading.load`` and, where it was reached through the
    relaxation's limit, that limit (:func:`_relaxation_limit`; else ``None``).  With ``[model]
    relaxation_length`` the soil stays relaxed by it (:func:`_constant_load`).  Else the sinkage is
    stepped up on the rate-independent soil, except with B-bar, whose steps stall beyond a few mm
    (docs/limitations.md, "Steady rolling: how far it reaches"): then, and where a pointwise step
    is not found, the relaxation's limit is the route."""
    steady.relaxation_length = scene.model.relaxation_length
    if steady.relaxation_length > 0:
        return _constant_load(steady, scene, solve, states, inflow), None
    if steady.volumetric_strain == "pointwise":
        try:
            return _constant_load(steady, scene, solve, states, inflow), None
        except WheelPloughs:
            raise
        except NoSteadyState as err:
            if progress and steady.comm.rank == 0:
                log.info("steady rolling: %s; the load is reached on relaxed soil and the relaxation lowered", err)
    return _relaxation_limit(steady, scene, solve, states, inflow, record, progress)


def _relaxation_limit(steady: SteadyRolling, scene, solve, states: dict, inflow, record, progress: bool):
    """The rate-independent steady state at ``loading.load`` as the limit of relaxed ones: the
    sinkage stepped up to the load with the soil relaxed by :data:`RELAXATION_START` station
    spacings (:attr:`SteadyRolling.station_spacing`), then the relaxation length lowered at the
    load, each from the state of the last (halved; where that state is not found, from the last
    state by the milder :data:`RELAXATION_REDUCTIONS`), until the extrapolation of the sinkage is
    certified (:func:`relaxation_certified`: it moves the last level's by at most
    :data:`RELAXATION_RTOL` of it at an order that the levels before agree with), or
    :data:`RELAXATION_LEVELS` lengths, or no reduction's state found.  Returns the
    last level's state and the limit: the levels, the extrapolated sinkage and whether it met the
    tolerance."""
    load = scene.loading.load
    steady.relaxation_length = RELAXATION_START * steady.station_spacing
    states.clear()
    steady.continue_from(states, 0.0)
    res = record(_constant_load(steady, scene, solve, states, inflow, LEVEL_LOAD_RTOL))
    levels = [_level(steady, res)]
    limit = {"levels": levels, "converged": False, "reason": None}
    while True:
        extrapolation, certified = relaxation_certified([(level["relaxation_length_m"], level["sinkage_m"])
                                                         for level in levels])
        limit.update(dict(zip(("sinkage_m", "correction_m", "order"), extrapolation or (None, None, None))))
        if certified:
            limit["converged"] = True
            break
        if len(levels) == RELAXATION_LEVELS:
            limit["reason"] = f"{RELAXATION_LEVELS} relaxation lengths"
            break
        kept = (steady.u.x.array.copy(), steady.spin, res.sinkage, steady.relaxation_length)
        for reduction in RELAXATION_REDUCTIONS:
            steady.relaxation_length = kept[3] * reduction
            try:
                res = steady.solve_load(load, inflow, initial_sinkage=kept[2], free_rolling=True,
                                        rtol=LEVEL_LOAD_RTOL, torque_rtol=TORQUE_RTOL)
                break
            except NoSteadyState as err:
                limit["reason"] = f"relaxation length {1e3 * steady.relaxation_length:.3g} mm: {err}"
                if progress and steady.comm.rank == 0:
                    log.info("steady rolling at relaxation %.3g mm: %s", 1e3 * steady.relaxation_length, err)
                steady.restore(*kept[:3])                   # the last level's state
                steady.relaxation_length = kept[3]
        else:
            steady.residual(inflow)                     # the last level's fields swept again
            break
        limit["reason"] = None
        record(res)
        levels.append(_level(steady, res))
        if progress and steady.comm.rank == 0:
            log.info("relaxation %.3g mm: s = %.4g mm at Q_V = %.4g kN", 1e3 * steady.relaxation_length,
                     1e3 * res.sinkage, res.vertical_force / 1e3)
    if limit["order"] == math.inf:
        limit["order"] = None                   # JSON
    return res, limit


def _level(steady: SteadyRolling, res) -> dict:
    """One relaxation length's steady state at the load."""
    return {"relaxation_length_m": steady.relaxation_length, "sinkage_m": res.sinkage, "QV_N": res.vertical_force,
            "QH_N": res.towing_force, "newton_iterations": res.newton_iterations}


def relaxation_certified(levels: list[tuple[float, float]]) -> tuple[tuple[float, float, float] | None, bool]:
    """The extrapolation of ``levels`` ((length, sinkage), m; :func:`relaxation_extrapolation`)
    and whether it is the limit: its correction at most :data:`RELAXATION_RTOL` of the last
    sinkage, its order at least :data:`RELAXATION_MIN_ORDER` and within
    :data:`RELAXATION_ORDER_SPREAD` of the order through the three levels before the last (or the
    last change negligible)."""
    extrapolation = relaxation_extrapolation(levels)
    if extrapolation is None:
        return None, False
    _, correction, order = extrapolation
    if order == math.inf:
        return extrapolation, True
    before = relaxation_extrapolation(levels[:-1])
    return extrapolation, (order >= RELAXATION_MIN_ORDER and abs(correction) <= RELAXATION_RTOL * abs(levels[-1][1])
                           and before is not None and abs(before[2] - order) <= RELAXATION_ORDER_SPREAD)


def relaxation_extrapolation(levels: list[tuple[float, float]]) -> tuple[float, float, float] | None:
    """The limit as the relaxation length goes to 0 of the sinkages of ``levels`` ((length,
    sinkage), m, lengths falling), as (limit, its distance from the last, observed order): where
    the last change is at most a tenth of :data:`RELAXATION_RTOL` of the sinkage, the last (order
    infinite); else through the last three, s = s0 + a L^p, where their changes have one sign and
    fall (an order p > 0); else ``None``."""
    if len(levels) < 2:
        return None
    (L1, s1), (L2, s2), (L3, s3) = ([(math.nan, math.nan)] + list(levels))[-3:]
    last = s3 - s2
    if abs(last) <= 0.1 * RELAXATION_RTOL * abs(s3):
        return s3, 0.0, math.inf
    if len(levels) < 3 or s2 == s1 or last / (s2 - s1) <= 0:
        return None
    ratio = last / (s2 - s1)

    def excess(p: float) -> float:      # the three lengths' ratio of changes at order p, less the observed
        return (L2 ** p - L3 ** p) / (L1 ** p - L2 ** p) - ratio
    low, high = 1e-3, 10.0
    if excess(low) < 0 or excess(high) > 0:
        return None
    for _ in range(60):                 # excess falls with p: bisection
        mid = 0.5 * (low + high)
        low, high = (mid, high) if excess(mid) > 0 else (low, mid)
    p = 0.5 * (low + high)
    correction = last * L3 ** p / (L2 ** p - L3 ** p)
    return s3 + correction, correction, p


def _add_limit(summary: dict, limit: dict) -> None:
    """``summary.json``'s entries of a state reached through the relaxation's limit:
    ``relaxation_limit``, the last level's sinkage as ``relaxed_sinkage_m`` (the fields, forces
    and rut are that level's) and, where the limit was reached, the extrapolated sinkage as
    ``sinkage_m``; else ``sinkage_m`` stays the last level's, with a warning."""
    summary.update(relaxation_limit={**limit, "rtol": RELAXATION_RTOL, "order_spread": RELAXATION_ORDER_SPREAD,
                                     "start_over_station_spacing": RELAXATION_START},
                   relaxed_sinkage_m=limit["levels"][-1]["sinkage_m"])
    if limit["converged"]:
        summary["sinkage_m"] = limit["sinkage_m"]
    else:
        summary.setdefault("warnings", []).append(
            f"the relaxation's limit was not reached ({limit['reason']}): the sinkage is the last relaxation "
            "length's, short of the rate-independent one" + (
                f"; at the observed order {limit['order']:.2g} the last three lengths extrapolate to "
                f"{1e3 * limit['sinkage_m']:.4g} mm" if limit["sinkage_m"] is not None else ""))


def _constant_load(steady: SteadyRolling, scene, solve, states: dict, inflow, rtol: float | None = None):
    """The towed wheel at ``loading.load`` on the soil entering in the state ``inflow``: sinkage
    steps of :data:`FIRST_STEP` d (growing by half per step up to :data:`MAX_STEP` d) until Q_V
    passes the load, then :meth:`SteadyRolling.solve_load` inside that bracket from the ``states``
    solved (to ``rtol``, default :data:`LOAD_RTOL`).  Near the load a step aims :data:`LOAD_OVERSHOOT` times as far
    as the sinkage where the secant of the last two states carries it (the undisturbed surface,
    Q_V = 0, counts as one; not less than a tenth of the first step); a step whose steady state is
    not found is halved from the last state, :data:`STEP_CUTS` times at most in all."""
    d, load = scene.wheel.diameter, scene.loading.load
    step, sinkage, cuts = FIRST_STEP * d, 0.0, 0
    last = [(0.0, 0.0)]                     # (sinkage, Q_V) of the last two states
    while True:
        if sinkage + step > 0.25 * d:
            raise WheelPloughs(f"no steady state carries Q_V = {load / 1e3:g} kN down to the sinkage d/4 = "
                                f"{0.25 * d:g} m: the wheel would plough on")
        if len(last) == 2 and last[1][1] > last[0][1]:
            (s0, q0), (s1, q1) = last
            aim = LOAD_OVERSHOOT * (load - q1) * (s1 - s0) / (q1 - q0)
            step = min(step, max(aim, 0.1 * FIRST_STEP * d))
        try:
            res = solve(sinkage + step)
        except NoSteadyState as err:
            if cuts == STEP_CUTS or not states:
                raise
            cuts += 1
            steady.continue_from(states, sinkage + step)
            step *= 0.5
            log.info("steady rolling: %s; the sinkage step halved to %.4g mm", err, 1e3 * step)
            continue
        sinkage = res.sinkage
        last = [*last, (sinkage, res.vertical_force)][-2:]
        if res.vertical_force >= load:
            break
        step = min(1.5 * step, MAX_STEP * d)
    rtol = LOAD_RTOL if rtol is None else rtol
    if abs(res.vertical_force - load) <= rtol * load:
        return res
    return steady.solve_load(load, inflow, free_rolling=True, rtol=rtol, states=states, torque_rtol=TORQUE_RTOL)


#: the last of several passes counts as adding no rut (or no plastic strain) when it adds at most
#: this fraction of the first pass's
SHAKEDOWN_RATIO = 0.02


def _pass_row(k: int, steady: SteadyRolling, res, inflow, passes: list[dict], progress: bool,
              limit: dict | None = None) -> dict:
    """One pass of ``loading.passes``: its steady sinkage (below the surface it meets), forces, the
    rut it adds (the centre line's settlement at the rear face), the rut of all passes so far, the
    largest accumulated plastic strain it adds on a streamline leaving the window.  Reached
    through the relaxation's ``limit``: the last level's sinkage as ``relaxed_sinkage_m`` and, where
    the limit was reached, the extrapolated one as ``sinkage_m`` (as the summary's)."""
    rut = float(_centre_line(steady, res.sinkage)["settlement"][0])
    added = res.outflow.accumulated_plastic_strain - inflow.accumulated_plastic_strain
    row = {"pass": k, "sinkage_m": res.sinkage, "QV_N": res.vertical_force, "QH_N": res.towing_force,
           "spin": res.spin, "rut_m": rut, "total_rut_m": rut + sum(p["rut_m"] for p in passes),
           "added_plastic_strain": steady.comm.allreduce(float(added.max(initial=0.0)), MPI.MAX)}
    if limit is not None:
        row["relaxed_sinkage_m"] = res.sinkage
        if limit["converged"]:
            row["sinkage_m"] = limit["sinkage_m"]
    if progress and steady.comm.rank == 0:
        log.info("pass %d: s = %.4g mm below the surface it meets, Q_H = %.4g kN, rut %.4g mm (total %.4g mm), "
                 "accumulated plastic strain added %.3g", k, 1e3 * row["sinkage_m"], res.towing_force / 1e3,
                 1e3 * rut, 1e3 * row["total_rut_m"], row["added_plastic_strain"])
    return row


def _passes_summary(passes: list[dict]) -> dict:
    """``summary.json``'s ``passes`` (one row per pass) and ``shakedown``: what the last pass adds
    against the first (ratios of the rut and of the largest accumulated plastic strain added) and
    the regime (K. L. Johnson, Contact Mechanics, ch. 9): ``elastic shakedown`` (no more plastic
    strain), ``cyclic plasticity`` (the rut stops growing, the plastic strain does not) or
    ``ratchetting`` (the rut grows on); "no more" is at most :data:`SHAKEDOWN_RATIO` of the first
    pass's."""
    out = {"passes": passes}
    if len(passes) < 2:
        return out
    first, last = passes[0], passes[-1]
    if first["rut_m"] > 0 and first["added_plastic_strain"] > 0:
        rut = last["rut_m"] / first["rut_m"]
        plastic = last["added_plastic_strain"] / first["added_plastic_strain"]
        regime = ("elastic shakedown" if plastic <= SHAKEDOWN_RATIO
                  else "cyclic plasticity" if abs(rut) <= SHAKEDOWN_RATIO else "ratchetting")
        out["shakedown"] = {"last_over_first_rut": rut, "last_over_first_plastic_strain": plastic,
                            "regime": regime, "criterion": SHAKEDOWN_RATIO}
    return out


#: relative tolerance on Q_V = load of ``rolling-constant-load``
LOAD_RTOL = 1e-3
#: the towed wheel's axle torque, at most this times R Q_V
TORQUE_RTOL = 1e-4


def _row(step: int, res, d: float, t_start: float) -> dict:
    """The ``history.csv`` row of a steady state (travel 0; the moment is the axle torque)."""
    return {"step": step, "sinkage_m": res.sinkage, "s_over_d": res.sinkage / d, "QV_N": res.vertical_force,
            "QH_N": res.towing_force, "travel_m": 0.0, "moment_Nm": res.axle_torque, "contact_area_m2": None,
            "max_penetration_m": None, "newton_iterations": res.newton_iterations, "cuts": 0,
            "plastic_points": None, "wall_time_s": time.perf_counter() - t_start}


def _centre_line(steady: SteadyRolling, sinkage: float) -> dict:
    """On the wheel's centre line (y = 0): the surface's x (m, rear to front), settlement (m, down
    positive), displacement in the direction of travel (m) and the contact length (m: the extent of
    the surface nodes the wheel penetrates)."""
    x, u = steady.surface_displacement()
    R = steady.wheel.diameter / 2
    axle = steady.surface + R - sinkage
    gap = np.hypot(x + u[:, 0], steady.surface + u[:, -1] - axle) - R
    touching = x[gap < 0]
    return {"x": x, "settlement": -u[:, -1], "forward": u[:, 0],
            "contact_length": float(touching.max() - touching.min()) if touching.size > 1 else 0.0}


def _summary(scene, steady: SteadyRolling, window: RollingWindow, rows, last, line: dict | None, status, reason,
             diagnostics, t_start: float, dofs: int, alpha) -> dict:
    """``summary.json`` of a steady roll; ``line``: :func:`_centre_line` of the ``last`` state."""
    wall = steady.comm.allreduce(time.perf_counter() - t_start, op=MPI.MAX)
    summary = {"status": status, "reason": reason, "protocol": scene.loading.protocol, "rolling": "steady",
               "scene": scene.to_dict(), "wall_time_s": wall, "ranks": steady.comm.size, "dofs": dofs,
               "cells": steady.comm.allreduce(steady.n_cells, op=MPI.SUM), "steps": len(rows),
               "newton_iterations": int(sum(r["newton_iterations"] for r in rows)),
               "sinkage_m": rows[-1]["sinkage_m"] if rows else 0.0, "QV_N": rows[-1]["QV_N"] if rows else 0.0,
               "QH_N": rows[-1]["QH_N"] if rows else 0.0, "max_QV_N": max((r["QV_N"] for r in rows), default=0.0),
               "model": {"rolling": "steady", "symmetry": "half", "symmetry_factor": 2,
                         "accuracy": scene.model.accuracy, "elements_per_d": scene.model.elements_per_d,
                         "cell_type": "hexahedron", "displacement_degree": 2, "kinematics": "small-strain",
                         "volumetric_strain": steady.volumetric_strain,
                         "relaxation_length_m": scene.model.relaxation_length,
                         "contact": {"method": "penalty", "kappa_Pa_per_m": steady.kappa, "alpha": alpha,
                                     "friction": steady.friction, "tangential_ratio": steady.tangential_ratio},
                         "window_m": {"ahead": window.ahead, "behind": window.behind, "depth": window.depth,
                                      "across": window.across, "fine_cell": window.cell_size,
                                      "fine_half_length": window.fine_length,
                                      "layer_interfaces": list(window.interfaces)}},
               "files": {"history": "history.csv", "plot": "force_sinkage.png", "rut_profile": "rut_profile.csv",
                         "rut_picture": "rut.png", "fields": []}}
    if last is not None:
        rut = float(line["settlement"][0])                  # at the rear face, where the state has settled
        forward = float(line["forward"][0])
        summary.update(spin=last.spin, rolling_radius_m=steady.wheel.diameter / 2 / last.spin,
                       axle_torque_Nm=last.axle_torque, contact_length_m=line["contact_length"],
                       rut_depth_m=rut, rebound_m=last.sinkage - rut, surface_forward_m=forward,
                       max_accumulated_plastic_strain=last.max_accumulated_plastic_strain,
                       krylov_iterations_last=last.krylov_iterations)
        if line["contact_length"] > 2 * window.fine_length:
            summary.setdefault("warnings", []).append(
                f"the contact ({line['contact_length']:.3g} m) reaches beyond the window's fine zone "
                f"(+-{window.fine_length:.3g} m): refine with a larger [model] refinement")
        if forward > last.sinkage:
            summary.setdefault("warnings", []).append(
                f"the surface leaves the window moved forward by {1e3 * forward:.3g} mm, "
                f"{forward / last.sinkage:.2g} times the sinkage: the wheel shoves the soil ahead of it; in plane "
                "strain a rolled wheel does not settle past this point (docs/limitations.md, \"Steady rolling: how "
                'far it reaches")')
    if diagnostics:
        summary["diagnostics"] = diagnostics
    return summary


def _write_rut(out: pathlib.Path, line: dict, scene, summary: dict, comm: MPI.Comm) -> None:
    """``rut_profile.csv`` and ``rut.png``: the surface on the centre line (:func:`_centre_line`)
    in the moving frame."""
    if comm.rank != 0:
        return
    text = "x_m,settlement_m,forward_m\n" + "".join(
        f"{x:.6g},{w:.6g},{f:.6g}\n" for x, w, f in zip(line["x"], line["settlement"], line["forward"]))
    atomic_write_text(out / "rut_profile.csv", text)
    try:
        plt = _pyplot()
        fig, ax = plt.subplots(figsize=(7, 3.4))
        ax.plot(line["x"], 1e3 * line["settlement"], "-", color="0.3", label="surface on the centre line")
        R, s = scene.wheel.diameter / 2, summary["sinkage_m"]
        xs = np.linspace(-0.3 * R, 0.3 * R, 101)
        ax.plot(xs, 1e3 * (s - (R - np.sqrt(R ** 2 - xs ** 2))), color="C3", lw=1.0, label="wheel")
        if summary.get("rut_depth_m") is not None:
            ax.axhline(1e3 * summary["rut_depth_m"], color="0.4", lw=0.8, ls=":",
                       label=f"rut depth {1e3 * summary['rut_depth_m']:.2f} mm")
        ax.invert_yaxis()
        ax.set_xlabel("x from the axle (m; the soil flows towards -x)")
        ax.set_ylabel("settlement (mm)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        ax.set_title(f"steady rolling: s = {1e3 * s:.2f} mm, Q_V = {summary['QV_N'] / 1e3:.4g} kN"
                     + ("" if summary["status"] == "ok" else f" [{summary['status']}]"), fontsize=10)
        fig.tight_layout()
        _save(fig, out / "rut.png")
    except Exception as err:   # noqa: BLE001 - a plot must not lose the run
        log.warning("rut plot failed: %s", err)


def _write_fields(out: pathlib.Path, steady: SteadyRolling) -> None:
    """``fields/steady.xdmf``: the window with the displacement and the cell averages of the
    accumulated plastic strain (collective)."""
    from dolfinx import fem
    mesh = steady.mesh
    V1 = compat.vector_space(mesh, 1)
    u1 = fem.Function(V1, name="displacement")
    u1.interpolate(steady.u)
    W0 = compat.scalar_space(mesh, 0, "DG")
    acc = fem.Function(W0, name="accumulated_plastic_strain")
    nq = steady.n_qp // max(steady.n_cells, 1)
    acc.x.array[: steady.n_cells] = steady.accumulated_plastic_strain.reshape(steady.n_cells, nq).mean(axis=1)
    acc.x.scatter_forward()
    with compat.xdmf_file(steady.comm, out / "fields" / "steady.xdmf", "w") as f:
        f.write_mesh(mesh)
        f.write_function(u1)
        f.write_function(acc)
