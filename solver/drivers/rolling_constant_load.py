"""Driver of ``protocol = "rolling-constant-load"``: the towed wheel pressed to ``loading.load`` on
an elastic stiff start zone, then rolled onto the test soil at that load until its sinkage is
steady; lifted off at the end to measure the rut left behind."""
from __future__ import annotations

import dataclasses

import numpy as np
from mpi4py import MPI

from rollsim.files import atomic_write_text
from rollsim.log import get_logger

from ..rolling import STEADY_MIN_TRAVEL, SteadyState, WheelRolling
from ..stepping import SolverDivergedError
from .base import HEAVE_TOLERANCE, RollingRun, heave_warnings
from .pneumatic import run_pneumatic_rolling

__all__ = ["run_constant_load", "measure_rut", "heave_warnings", "STIFF_LENGTH", "HEAVE_TOLERANCE"]

log = get_logger("run")

#: stiff start zone, x / d (the reference set-up: 0.75 d, wheel starting at 0.4 d)
STIFF_LENGTH = 0.75
#: displacement magnification of the rut picture
RUT_PICTURE_SCALE = 5.0
def measure_rut(roll: WheelRolling, steady: SteadyState | None, x_soft: float | None, contact_length: float) -> dict:
    """Rut depth and rebound from the surface profile on the wheel path once the wheel has been
    lifted off (:meth:`WheelRolling.lift`; collective).

    Window: from the start of the steady-state window (or the soft soil + half a contact length)
    to half a contact length behind the wheel centre (soil that the wheel has rolled over)."""
    xs, w = roll.surface_profile()
    L = contact_length
    lo = (x_soft if x_soft is not None else roll.x_start) + 0.5 * L
    if steady is not None and steady.reached:
        lo = max(lo, roll.x_start + steady.travel - steady.window)
    hi = roll.position - 0.5 * L
    sel = (xs >= lo) & (xs <= hi)
    result = {"profile": (xs, w), "rut_window_m": [float(lo), float(hi)]}
    if sel.sum() >= 2:
        rut = float(np.mean(w[sel]))
        s_ref = steady.sinkage if steady is not None else roll.sinkage
        result.update(rut_depth_m=rut, rebound_m=s_ref - rut)
    else:
        result.update(rut_depth_m=None, rebound_m=None,
                      rut_note="the wheel has not rolled far enough beyond the stiff zone to measure the rut")
    return result


def run_constant_load(scene, out_dir, comm: MPI.Comm, *, progress: bool = True, petsc_options: dict | None = None,
                      write_fields: bool = True, penalty: float | None = None, block: dict | None = None,
                      moment_rtol: float = 2e-3, steady_rtol: float = 0.02, steady_qh_rtol: float = 0.05,
                      min_window_elements: float = 3.0, steady_min_travel: float | None = None) -> dict:
    """Constant-load rolling of ``scene``: gravity, ``loading.load`` on the stiff start zone
    (``STIFF_LENGTH`` d, elastic, 10x the top layer's modulus), then rolling at that load until
    steady (:meth:`WheelRolling.roll_at_load`: ``steady_rtol`` / ``steady_qh_rtol``, looked for after
    ``steady_min_travel`` m on the test soil, default ``STEADY_MIN_TRAVEL`` d) or ``loading.travel``.
    The summary reports the steady sinkage and ``Q_H``, the rut depth (mean settlement of the wheel
    path rolled in steady state, after the lift-off) and the rebound (sinkage - rut depth);
    ``rut_profile.csv`` holds the profile.  ``block``: keywords of ``rolling_mesh``.  A pneumatic
    wheel runs :func:`~rollsim.solver.drivers.pneumatic.run_pneumatic_rolling` (no ``block``)."""
    if scene.wheel.type == "pneumatic":
        return run_pneumatic_rolling(scene, out_dir, comm, progress=progress, petsc_options=petsc_options,
                                     write_fields=write_fields, penalty=penalty, steady_rtol=steady_rtol,
                                     steady_qh_rtol=steady_qh_rtol, steady_min_travel=steady_min_travel)
    d, travel, load = scene.wheel.diameter, scene.loading.travel, scene.loading.load
    block = {"stiff_length": STIFF_LENGTH, **(block or {})}
    x_soft = block["stiff_length"] * d if block["stiff_length"] else None
    min_travel = STEADY_MIN_TRAVEL * d if steady_min_travel is None else float(steady_min_travel)
    run = RollingRun(scene, out_dir, comm, block=block, moment_rtol=moment_rtol, progress=progress,
                     write_fields=write_fields, petsc_options=petsc_options, penalty=penalty)
    roll = run.roll
    outcome = {"steady": None, "contact_length": 0.0, "lifted": False, "lift_failure": None}

    def rolling():
        run.announce(f"travel {travel:g} m, Q_V = {load / 1e3:g} kN")
        roll.gravity_step()
        res = roll.press_to_load(load, 0.25 * d, on_step=run.on_step)
        if res.status != "ok":
            return f"pressing the wheel on the stiff start zone: {res.status}: {res.reason}"
        steady = outcome["steady"] = roll.roll_at_load(
            load, travel, x_soft=x_soft, on_step=run.on_step, steady_rtol=steady_rtol,
            steady_qh_rtol=steady_qh_rtol, min_window_elements=min_window_elements, min_travel=min_travel,
            on_start_over=run.on_start_over)
        if not steady.reached:
            log.warning("no steady state within the travel of %g m: the values are those of the last "
                        "step (a longer travel or a coarser steady tolerance may help)", travel)
        outcome["contact_length"] = roll.contact_length()
        try:
            roll.lift(on_step=run.on_step)
        except SolverDivergedError as err:      # the rolling result stands; only the rut is lost
            if err.kind == "interrupted":
                raise
            log.warning("lift-off failed, the rut is not measured: %s", err)
            outcome["lift_failure"] = str(err)
            return None
        outcome["lifted"] = True
        return None

    status, reason, diagnostics = run.execute(rolling, run.state)
    steady = outcome["steady"]
    rut = _rut(run, steady, x_soft, outcome["contact_length"]) if outcome["lifted"] else None
    run.close_fields(lambda writer: writer.render_plastic_zone(
        run.out / "rut.png", f"rut and plastic zone (displacement x {RUT_PICTURE_SCALE:g})",
        displacement_scale=RUT_PICTURE_SCALE) if run.rows else None)
    summary = run.summary(status, reason)
    summary["model"].update(stiff_zone_end_m=x_soft, load_rtol=roll.load_rtol, steady_rtol=steady_rtol,
                            steady_qh_rtol=steady_qh_rtol, steady_min_window_elements=min_window_elements,
                            steady_min_travel_m=min_travel)
    if steady is not None:
        summary["steady_state"] = dataclasses.asdict(steady)
        summary.update(sinkage_m=steady.sinkage, QH_N=steady.QH, QV_N=steady.QV)
    if rut is not None:
        summary.update(rut)
        summary["files"]["rut_profile"] = "rut_profile.csv"
    elif outcome["lift_failure"]:
        summary.update(rut_depth_m=None, rebound_m=None, rut_note=f"lift-off failed: {outcome['lift_failure']}")
    run.warn_heave(summary, roll.steps, x_soft, roll.x_start, summary.get("rut_depth_m"))
    if write_fields:
        summary["files"]["rut_picture"] = "rut.png"
    run.plot_travel(summary)
    return run.finish(summary, diagnostics)


def _rut(run: RollingRun, steady, x_soft, contact_length: float) -> dict | None:
    """:func:`measure_rut` after the lift-off, with the profile written to ``rut_profile.csv``;
    None when it fails (logged)."""
    try:
        rut = measure_rut(run.roll, steady, x_soft, contact_length)
        xs, w = rut.pop("profile")
        if run.root:
            atomic_write_text(run.out / "rut_profile.csv", "x_m,settlement_m\n" + "".join(
                f"{x:.10g},{s:.10g}\n" for x, s in zip(xs, w)))
        return rut
    except Exception as err:  # noqa: BLE001 - a measurement must not lose the run
        log.warning("rut measurement failed: %s", err)
        return None
