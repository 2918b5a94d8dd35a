"""Driver of ``protocol = "rolling-continuous"``: the towed wheel pressed to a small sinkage at
the start position, then rolled ``loading.travel`` with its sinkage ramped slowly to
``loading.max_sinkage``; every instant is close to steady rolling, so one run gives a nearly
continuous ``Q_V(s)`` and ``Q_H(s)``."""
from __future__ import annotations

from mpi4py import MPI

from rollsim.log import get_logger

from .base import CHECKPOINT_EVERY, RollingRun

__all__ = ["run_continuous", "ramp_advice", "VERIFIED_RAMP_RATE"]

log = get_logger("run")

#: fastest sinkage ramp of the continuous protocol shown to be slow enough (s per unit travel,
#: = s/d per d): halving it moves Q_V by less than the fast mesh's ripple
#: (``python -m benchmarks rolling report``; measured: see docs/benchmarks.md, "Ramp rate")
VERIFIED_RAMP_RATE = 0.02


def ramp_advice(max_sinkage: float, initial_sinkage: float, ramp_length: float) -> tuple[float, str | None]:
    """Ramp rate of a continuous run (sinkage per unit travel) and, when it is faster than
    :data:`VERIFIED_RAMP_RATE`, a warning with the ramp length (m) that would be slow enough."""
    rate = (max_sinkage - initial_sinkage) / ramp_length
    if rate <= VERIFIED_RAMP_RATE * (1 + 1e-9):
        return rate, None
    needed = (max_sinkage - initial_sinkage) / VERIFIED_RAMP_RATE
    return rate, (f"the sinkage ramp ({rate:.3g} s/d per d of travel) is faster than {VERIFIED_RAMP_RATE:g}, the rate "
                  f"shown slow enough: Q_V(s) reads low while the wheel descends; ramp over >= {needed:.3g} m "
                  f"(loading.travel) for a near-steady curve")


def run_continuous(scene, out_dir, comm: MPI.Comm, *, progress: bool = True, petsc_options: dict | None = None,
                   write_fields: bool = True, penalty: float | None = None, initial_sinkage: float | None = None,
                   ramp: float | None = None, block: dict | None = None, moment_rtol: float = 2e-3,
                   checkpoint_every: int = CHECKPOINT_EVERY, restart: bool = False) -> dict:
    """Continuous rolling of ``scene``: pressed to ``initial_sinkage`` (default 0.005 d), then rolled
    with the sinkage ramped over ``ramp`` m (default: the whole travel).  ``block``: keywords of
    ``rolling_mesh`` (no stiff start zone by default).  A checkpoint every ``checkpoint_every``
    rolled steps; a run directory holding one of the same run is continued unless ``restart``
    (:class:`~rollsim.solver.drivers.base.RollingRun`).  Writes the run directory, returns the summary."""
    d, travel, s_max = scene.wheel.diameter, scene.loading.travel, scene.loading.max_sinkage
    s0 = min(0.005 * d if initial_sinkage is None else float(initial_sinkage), s_max)
    ramp_length = travel if ramp is None else ramp
    rate, advice = ramp_advice(s_max, s0, ramp_length)
    run = RollingRun(scene, out_dir, comm, block={"stiff_length": 0.0, **(block or {})}, moment_rtol=moment_rtol,
                     progress=progress, write_fields=write_fields, petsc_options=petsc_options, penalty=penalty,
                     path={"initial_sinkage": s0, "ramp": ramp_length, "penalty": penalty, "write_fields": write_fields},
                     checkpoint_every=checkpoint_every, restart=restart)
    roll = run.roll

    def rolling():
        run.announce(f"travel {travel:g} m, s -> {s_max:g} m")
        roll.gravity_step()
        if advice and run.root:
            log.warning(advice)
        if run.continue_roll():         # the rest of the roll and of its ramp
            done = roll.position - roll.x_start
            if travel - done > 1e-9 * d:
                roll.roll(travel - done, s_max, ramp=ramp_length - done if ramp_length > done + 1e-9 * d else None,
                          on_step=run.on_step, on_start_over=run.on_start_over)
            return
        roll.press(s0, on_step=run.on_step)
        roll.roll(travel, s_max, ramp=ramp, on_step=run.on_step, on_start_over=run.on_start_over)

    status, reason, diagnostics = run.execute(rolling, run.state)
    run.close_fields()
    summary = run.summary(status, reason)
    summary["model"].update(initial_sinkage_m=s0, ramp_m=ramp_length, ramp_rate=rate, ramp_slow_enough=advice is None)
    run.plot_travel(summary)
    return run.finish(summary, diagnostics)
