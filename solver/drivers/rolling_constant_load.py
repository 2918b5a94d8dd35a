"""Driver of ``protocol = "rolling-constant-load"``: the towed wheel pressed to ``loading.load`` on
an elastic stiff start zone, then rolled onto the test soil at that load until its sinkage is
steady; lifted off at the end to measure the rut left behind."""
from __future__ import annotations

import dataclasses

from mpi4py import MPI

from rollsim.log import get_logger

from ..rolling import STEADY_MIN_TRAVEL, SteadyState, WheelRolling
from .base import CHECKPOINT_EVERY, HEAVE_TOLERANCE, RollingRun, heave_warnings, rut_depth
from .pneumatic import run_pneumatic_rolling

__all__ = ["run_constant_load", "measure_rut", "heave_warnings", "STIFF_LENGTH", "HEAVE_TOLERANCE"]

log = get_logger("run")

#: stiff start zone, x / d (the reference set-up: 0.75 d, wheel starting at 0.4 d)
STIFF_LENGTH = 0.75
#: displacement magnification of the rut picture
RUT_PICTURE_SCALE = 5.0
def measure_rut(roll: WheelRolling, steady: SteadyState | None, x_soft: float | None, contact_length: float) -> dict:
    """:func:`~rollsim.solver.drivers.base.rut_depth` of the surface profile once the wheel has been
    lifted off (:meth:`WheelRolling.lift`; collective), with the profile (``"profile"``)."""
    xs, w = roll.surface_profile()
    return {"profile": (xs, w), **rut_depth(xs, w, **_rut_window(roll, steady, x_soft, contact_length))}


def _rut_window(roll: WheelRolling, steady, x_soft, contact_length: float) -> dict:
    """The keywords of :func:`~rollsim.solver.drivers.base.rut_depth` after ``roll``."""
    return {"x_from": x_soft if x_soft is not None else roll.x_start, "x_wheel": roll.position,
            "x_start": roll.x_start, "steady": steady, "sinkage": roll.sinkage, "contact_length": contact_length}


def run_constant_load(scene, out_dir, comm: MPI.Comm, *, progress: bool = True, petsc_options: dict | None = None,
                      write_fields: bool = True, penalty: float | None = None, block: dict | None = None,
                      moment_rtol: float = 2e-3, steady_rtol: float = 0.02, steady_qh_rtol: float = 0.05,
                      min_window_elements: float = 3.0, steady_min_travel: float | None = None,
                      checkpoint_every: int = CHECKPOINT_EVERY, restart: bool = False) -> dict:
    """Constant-load rolling of ``scene``: gravity, ``loading.load`` on the stiff start zone
    (``STIFF_LENGTH`` d, elastic, 10x the top layer's modulus), then rolling at that load until
    steady (:meth:`WheelRolling.roll_at_load`: ``steady_rtol`` / ``steady_qh_rtol``, looked for after
    ``steady_min_travel`` m on the test soil, default ``STEADY_MIN_TRAVEL`` d) or ``loading.travel``.
    The summary reports the steady sinkage and ``Q_H``, the rut depth (mean settlement of the wheel
    path rolled in steady state, after the lift-off) and the rebound (sinkage - rut depth);
    ``rut_profile.csv`` holds the profile.  ``block``: keywords of ``rolling_mesh``.  A checkpoint
    every ``checkpoint_every`` rolled steps; a run directory holding one of the same run is
    continued unless ``restart`` (:class:`~rollsim.solver.drivers.base.RollingRun`).  A pneumatic
    wheel runs :func:`~rollsim.solver.drivers.pneumatic.run_pneumatic_rolling` (no ``block``, no
    checkpoints)."""
    if scene.wheel.type == "pneumatic":
        return run_pneumatic_rolling(scene, out_dir, comm, progress=progress, petsc_options=petsc_options,
                                     write_fields=write_fields, penalty=penalty, steady_rtol=steady_rtol,
                                     steady_qh_rtol=steady_qh_rtol, steady_min_travel=steady_min_travel)
    d, travel, load = scene.wheel.diameter, scene.loading.travel, scene.loading.load
    block = {"stiff_length": STIFF_LENGTH, **(block or {})}
    x_soft = block["stiff_length"] * d if block["stiff_length"] else None
    min_travel = STEADY_MIN_TRAVEL * d if steady_min_travel is None else float(steady_min_travel)
    run = RollingRun(scene, out_dir, comm, block=block, moment_rtol=moment_rtol, progress=progress,
                     write_fields=write_fields, petsc_options=petsc_options, penalty=penalty,
                     path={"steady_rtol": steady_rtol, "steady_qh_rtol": steady_qh_rtol, "penalty": penalty,
                           "min_window_elements": min_window_elements, "steady_min_travel": min_travel,
                           "write_fields": write_fields},
                     checkpoint_every=checkpoint_every, restart=restart)
    roll = run.roll
    outcome = {"steady": None, "contact_length": 0.0, "lifted": False, "lift_failure": None}

    def rolling():
        run.announce(f"travel {travel:g} m, Q_V = {load / 1e3:g} kN")
        roll.gravity_step()
        continued = run.continue_roll()
        if not continued:
            res = roll.press_to_load(load, 0.25 * d, on_step=run.on_step)
            if res.status != "ok":
                return f"pressing the wheel on the stiff start zone: {res.status}: {res.reason}"
        steady = outcome["steady"] = roll.roll_at_load(
            load, travel - (roll.position - roll.x_start), x_soft=x_soft, on_step=run.on_step,
            steady_rtol=steady_rtol, steady_qh_rtol=steady_qh_rtol, min_window_elements=min_window_elements,
            min_travel=min_travel, on_start_over=run.on_start_over, resumed=continued)
        if not steady.reached:
            log.warning("no steady state within the travel of %g m: the values are those of the last "
                        "step (a longer travel or a coarser steady tolerance may help)", travel)
        outcome["contact_length"] = roll.contact_length()
        outcome["lift_failure"] = run.lift_off(lambda: roll.lift(on_step=run.on_step))
        outcome["lifted"] = outcome["lift_failure"] is None
        return None

    status, reason, diagnostics = run.execute(rolling, run.state)
    steady = outcome["steady"]
    rut = (run.measure_rut(roll.surface_profile, **_rut_window(roll, steady, x_soft, outcome["contact_length"]))
           if outcome["lifted"] else None)
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
    run.add_rut(summary, rut, outcome["lift_failure"])
    run.warn_heave(summary, roll.steps, x_soft, roll.x_start)
    if write_fields:
        summary["files"]["rut_picture"] = "rut.png"
    run.plot_travel(summary)
    return run.finish(summary, diagnostics)
