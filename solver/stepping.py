"""Adaptive load stepping: step cutting on divergence, growth after easy steps, clean failure.

Robustness features (measurements: see docs/verification.md, "Purely frictional soil"):

* **extrapolated predictor** (``StepControl.predictor = "extrapolate"``; ``StripFooting`` uses
  it by default, ``StepControl`` keeps ``"none"`` for backward compatibility): Newton starts
  from ``u_n + (dt/dt_prev) (u_n - u_{n-1})`` instead of ``u_n``.  On a collapse plateau the
  increments of a perfectly plastic mechanism are nearly identical from step to step, so the
  first iterate is already close to the solution; starting from ``u_n`` instead, the first
  Newton update (made with the tangent of the converged state) overshoots and, for purely
  frictional soil (c = 0), throws hundreds of surface points into the stress-free apex whose
  tangent is zero, i.e. locally singular; Newton then wanders.  This predictor removes most step
  cuts of the c = 0 strip footing.  It is *not* universally better: in the 3D wheel indentation
  with penalty contact (c = 0, phi = 40 deg, psi = 0) it fails earlier than no predictor, and
  on rolling at a held sinkage it costs more Newton iterations (see docs/benchmarks.md, "Rolling cost").
  ``"auto"`` tries the extrapolated start first and, if Newton fails, retries the same step from
  the converged state before cutting.
* **failure memory**: after a cut, the step does not grow beyond ``fail_safety`` times the step
  that failed until ``fail_memory`` steps have converged (no grow/fail/cut cycles).
* **guards**: ``max_wall_time`` (s) and ``max_iterations`` (total Newton iterations) stop a run
  with :class:`SolverDivergedError` (state restored to the last converged step, message says
  which guard), so a run never hangs.
* **signals**: inside :func:`stop_on_signals`, SIGINT / SIGTERM / SIGUSR1 do not kill the process;
  the step being solved finishes and :class:`RunInterrupted` is raised at the next step boundary
  (all ranks together), so the caller can write its history and summary.
"""
from __future__ import annotations

import contextlib
import math
import signal
import time
from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from rollsim.log import get_logger

__all__ = ["StepControl", "StepRecord", "ConvergedState", "SolverDivergedError", "RunInterrupted", "check_interrupt",
           "RelaxationFallback", "solve_load_path", "advance_with_fallback", "straight_path", "stop_on_signals",
           "settle_under_gravity"]

log = get_logger("solver")


@dataclass(frozen=True)
class StepControl:
    """Pseudo-time stepping on ``t in [0, t_end]`` (the load parameter).

    ``dt`` initial step, halved on divergence at most ``max_cuts`` times in a row and never
    below ``dt_min``; multiplied by ``grow`` (capped at ``dt_max``) after a step that needed at
    most ``easy_iterations`` Newton iterations.

    ``predictor``: ``"none"`` (start Newton from the last converged state; default),
    ``"extrapolate"`` (linear extrapolation of the last converged increment as the starting
    point) or ``"auto"`` (extrapolate; on failure retry the same step from the converged state
    before cutting).
    ``fail_memory`` / ``fail_safety``: after a cut the step stays below ``fail_safety * dt_failed``
    for ``fail_memory`` converged steps (0 disables).  ``max_wall_time`` (s) and
    ``max_iterations`` (total Newton iterations of this call) are hard guards.
    """

    t_end: float = 1.0
    dt: float = 0.1
    dt_min: float = 1e-6
    dt_max: float = 0.25
    grow: float = 1.5
    easy_iterations: int = 4
    max_cuts: int = 8
    max_steps: int = 10_000
    predictor: str = "none"
    fail_memory: int = 0
    fail_safety: float = 0.9
    max_wall_time: float = math.inf
    max_iterations: int = 10**9

    def __post_init__(self):
        for name in ("t_end", "dt", "dt_min", "dt_max"):
            val = getattr(self, name)
            if not (np.isfinite(val) and val > 0):
                raise ValueError(f"{name} must be positive and finite, got {val!r}")
        if self.dt_min > self.dt:
            raise ValueError(f"dt_min ({self.dt_min}) must not exceed dt ({self.dt})")
        if self.grow < 1:
            raise ValueError(f"grow must be >= 1, got {self.grow}")
        if self.max_cuts < 0:
            raise ValueError(f"max_cuts must be >= 0, got {self.max_cuts}")
        if self.predictor not in ("extrapolate", "none", "auto"):
            raise ValueError(f"predictor must be 'none', 'extrapolate' or 'auto', got {self.predictor!r}")
        if self.fail_memory < 0 or not 0 < self.fail_safety <= 1:
            raise ValueError(f"fail_memory must be >= 0 and fail_safety in (0, 1], got "
                             f"{self.fail_memory!r}, {self.fail_safety!r}")
        if not self.max_wall_time > 0 or self.max_iterations < 1:
            raise ValueError(f"max_wall_time must be > 0 and max_iterations >= 1, got "
                             f"{self.max_wall_time!r}, {self.max_iterations!r}")


@dataclass
class StepRecord:
    t: float
    dt: float
    iterations: int
    residual_norms: list[float]
    cuts: int
    counts: dict
    time: float
    data: dict = field(default_factory=dict)   # whatever on_step returned


@dataclass
class ConvergedState:
    """Snapshot of the last converged state (owned + ghost arrays; the problem still holds it)."""

    t: float
    u: np.ndarray
    sigma: np.ndarray
    eps_p: np.ndarray


class SolverDivergedError(RuntimeError):
    """Newton failed even after cutting the step, or a guard stopped the path; ``last_converged`` /
    ``history`` are kept and the problem has been restored to that state.  ``kind`` names the
    failure: ``"newton_diverged"``, ``"wall_time_guard"``, ``"iteration_guard"``, ``"step_limit"``
    or ``"interrupted"``."""

    def __init__(self, message: str, last_converged: ConvergedState, history: list[StepRecord],
                 kind: str = "newton_diverged"):
        super().__init__(message)
        self.last_converged = last_converged
        self.history = history
        self.kind = kind


class RunInterrupted(SolverDivergedError):
    """A signal asked the run to stop (see :func:`stop_on_signals`); the problem holds the last
    converged step.  ``signal_name`` is e.g. ``"SIGINT"``."""

    def __init__(self, message: str, last_converged, history, signal_name: str):
        super().__init__(message, last_converged, history, kind="interrupted")
        self.signal_name = signal_name


_signals_received: list[int] = []
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGUSR1)


@contextlib.contextmanager
def stop_on_signals(signals=STOP_SIGNALS):
    """While active, ``signals`` ask :func:`solve_load_path` to stop at the next step boundary
    (:class:`RunInterrupted`) instead of ending the process.  A second SIGINT ends it at once.
    Outside the main thread (where Python cannot install handlers) this does nothing.

    Under ``mpirun``, Open MPI forwards SIGUSR1 to every rank and turns SIGINT/SIGTERM into a
    SIGTERM followed by SIGKILL a moment later; SLURM sends SIGTERM and SIGKILL after its
    ``KillWait``.  The history is written after every step anyway, so even a hard kill leaves a
    valid ``history.csv``; ``summary.json`` marked ``"interrupted"`` needs the grace period.
    """
    def handler(signum, frame):
        if signum == signal.SIGINT and _signals_received.count(signal.SIGINT) >= 1:
            raise KeyboardInterrupt
        _signals_received.append(signum)
        log.warning("%s received: stopping after the current step (again to abort at once)",
                    signal.Signals(signum).name)

    previous = {}
    try:
        for sig in signals:
            previous[sig] = signal.signal(sig, handler)
    except ValueError:          # not the main thread
        pass
    _signals_received.clear()
    try:
        yield
    finally:
        for sig, old in previous.items():
            signal.signal(sig, old)
        _signals_received.clear()


def _interrupt_signal(comm) -> str | None:
    """Name of the signal that asked for a stop on any rank (collective when ``comm`` is given)."""
    code = _signals_received[0] if _signals_received else 0
    if comm is not None:
        code = comm.allreduce(code, op=_mpi_max())
    return signal.Signals(code).name if code else None


def check_interrupt(comm, where: str) -> None:
    """Raise :class:`RunInterrupted` (at a step boundary, ``where``: e.g. "at travel 0.3 m")
    when a signal asked the run to stop on any rank (collective)."""
    stop = _interrupt_signal(comm)
    if stop is not None:
        raise RunInterrupted(f"interrupted by {stop} {where}; last converged state kept", None, [], stop)


def settle_under_gravity(problem, unit_weight: float, K0=None) -> None:
    """The gravity step of a soil with free surface at height 0: geostatic stress
    (:meth:`~rollsim.solver.problem.PlasticityProblem.set_geostatic_stress`), one equilibrium solve
    with the body force, commit, displacement zeroed (stresses and plastic strains kept).  Raises
    :class:`SolverDivergedError` (state restored) when Newton fails."""
    problem.set_geostatic_stress(unit_weight, surface=0.0, K0=K0)
    rep = problem.solve_increment()
    if not rep.converged:
        problem.restore()
        raise SolverDivergedError("gravity step did not converge", None, [])
    problem.commit()
    umax = problem.comm.allreduce(float(np.abs(problem.u.x.array).max(initial=0.0)), op=_mpi_max())
    log.info("gravity step: %d Newton iterations, max |u| = %.3g m (geostatic stress in equilibrium)",
             rep.iterations, umax)
    problem.reset_displacement()


def _check_limits(problem, set_load, control: StepControl, t: float, history: list, its_total: int,
                  wall: float) -> None:
    """Before a step at ``t``: raise when a signal asked to stop (:class:`RunInterrupted`) or a
    limit of ``control`` is reached (steps, wall time, Newton iterations: :class:`SolverDivergedError`),
    with the last converged state (the load set back to ``t``).  Every rank decides alike."""
    comm = getattr(problem, "comm", None)
    if len(history) >= control.max_steps:
        raise SolverDivergedError(f"max_steps={control.max_steps} reached at t={t:g}",
                                  _snapshot(problem, t), history, kind="step_limit")
    if comm is not None:
        wall = comm.allreduce(wall, op=_mpi_max())     # all ranks take the same decision
    stop = _interrupt_signal(comm)
    if stop is not None:
        set_load(t)
        raise RunInterrupted(f"interrupted by {stop} at t={t:g} after {len(history)} steps; last converged "
                             "state kept", _snapshot(problem, t), history, stop)
    if wall > control.max_wall_time or its_total >= control.max_iterations:
        set_load(t)
        what = (f"wall-clock limit max_wall_time={control.max_wall_time:g} s"
                if wall > control.max_wall_time else f"max_iterations={control.max_iterations}")
        raise SolverDivergedError(
            f"{what} reached at t={t:g} after {len(history)} steps ({its_total} Newton iterations, "
            f"{wall:.1f} s); last converged state kept", _snapshot(problem, t), history,
            kind="wall_time_guard" if wall > control.max_wall_time else "iteration_guard")


def solve_load_path(problem, set_load: Callable[[float], None], control: StepControl = StepControl(),
                    on_step: Callable[[float], dict | None] | None = None, t_start: float = 0.0
                    ) -> list[StepRecord]:
    """Drive ``problem`` (a :class:`PlasticityProblem`, or any object with ``comm``, ``u``, ``u_n``,
    ``solve_increment``, ``commit`` and ``restore``) from ``t_start`` to ``control.t_end``.

    ``set_load(t)`` must put the boundary data / loads of pseudo-time ``t`` into the problem
    (e.g. the footing displacement Constant).  After each converged step the history is
    committed and ``on_step(t)`` is called (its dict is stored in the record).
    """
    t = t_start
    dt = min(control.dt, control.t_end - t)
    history: list[StepRecord] = []
    cuts = 0
    t_wall0 = time.perf_counter()
    its_total = 0
    u_prev, dt_prev = None, None        # previous converged displacement and its step (predictor)
    dt_cap, cap_left = math.inf, 0      # failure memory
    while t < control.t_end * (1 - 1e-12):
        _check_limits(problem, set_load, control, t, history, its_total, time.perf_counter() - t_wall0)
        dt = min(dt, dt_cap if cap_left > 0 else math.inf, control.t_end - t)
        set_load(t + dt)
        predicted = control.predictor in ("extrapolate", "auto") and u_prev is not None
        if predicted:
            _extrapolate(problem, u_prev, dt / dt_prev)
        rep = problem.solve_increment()
        its_total += rep.iterations
        if not rep.converged and predicted and control.predictor == "auto":
            problem.restore()
            log.info("  step t=%.6g dt=%.3g: extrapolated start failed (reason %d after %d its); "
                     "retrying from the converged state", t + dt, dt, rep.reason, rep.iterations)
            rep = problem.solve_increment()
            its_total += rep.iterations
        if not rep.converged:
            problem.restore()
            cuts += 1
            log.info("  step t=%.6g dt=%.3g diverged (reason %d after %d its); cut %d; |F|: %s",
                     t + dt, dt, rep.reason, rep.iterations, cuts,
                     " ".join(f"{r:.1e}" for r in rep.residual_norms))
            if control.fail_memory > 0:
                dt_cap, cap_left = control.fail_safety * dt, control.fail_memory
            dt *= 0.5
            if cuts > control.max_cuts or dt < control.dt_min:
                set_load(t)
                why = (f"{cuts} consecutive cuts > max_cuts={control.max_cuts}" if cuts > control.max_cuts
                       else f"the next step {dt:.3g} would be below dt_min={control.dt_min:g}")
                raise SolverDivergedError(
                    f"Newton diverged at t={t:g} (tried dt down to {2 * dt:.3g}, {cuts} cuts; {why}; "
                    f"last failure: reason {rep.reason} after {rep.iterations} iterations); "
                    f"last converged state kept", _snapshot(problem, t), history)
            continue
        if control.predictor != "none":
            u_prev = problem.u_n.x.array.copy()
        problem.commit()
        t += dt
        dt_prev = dt
        cap_left = max(cap_left - 1, 0)
        data = on_step(t) if on_step is not None else None
        history.append(StepRecord(t=t, dt=dt, iterations=rep.iterations, residual_norms=rep.residual_norms,
                                  cuts=cuts, counts=rep.counts, time=rep.time, data=data or {}))
        norms = " ".join(f"{r:.1e}" for r in rep.residual_norms)
        log.debug("step %3d t=%.5f dt=%.3g its=%d plastic=%d apex=%d |F|: %s %s", len(history), t, dt,
                 rep.iterations, rep.counts.get("plastic", 0), rep.counts.get("apex", 0), norms,
                 " ".join(f"{k}={v:.6g}" for k, v in (data or {}).items() if isinstance(v, float)))
        # an accepted Newton plateau had converged when it began: its repeats do not count
        its = rep.iterations - getattr(rep, "plateau_repeats", 0)
        if its <= control.easy_iterations and cuts == 0:
            dt = min(dt * control.grow, control.dt_max)
        cuts = 0
    return history


@dataclass
class RelaxationFallback:
    """Duvaut-Lions fallback of a path on the unregularised soil (see :func:`advance_with_fallback`):
    when Newton fails after step cutting, the path goes on relaxed with ``length`` (m of the path's
    coordinate; 0: off) over the next ``stretch`` (m of that coordinate; ``math.inf``: up to the
    target being moved to), then rate-independent again.  ``spans`` collects the ``(from, to)``
    coordinate of every relaxed stretch."""

    length: float
    stretch: float
    spans: list[tuple[float, float]] = field(default_factory=list)

    def __post_init__(self):
        if not (self.length >= 0 and self.stretch > 0 and math.isfinite(self.length)):
            raise ValueError(f"length must be >= 0 and stretch > 0, got {self.length!r}, {self.stretch!r}")

    @classmethod
    def unless_relaxed(cls, relaxation_length: float, length: float, stretch: float,
                       spans: list[tuple[float, float]]) -> RelaxationFallback | None:
        """The fallback of a path whose soil has ``relaxation_length`` (m) along the whole of it:
        None when that is > 0 already (nothing to fall back to) or when ``length`` is 0 (off)."""
        if relaxation_length > 0 or length == 0:
            return None
        return cls(length, stretch, spans)

    def applies(self, err: SolverDivergedError) -> bool:
        """Whether ``err`` may be retried relaxed: Newton diverged (not a guard or a signal)."""
        return self.length > 0 and err.kind == "newton_diverged"


def advance_with_fallback(advance: Callable[[float, StepControl], None], position: Callable[[], float],
                          targets, control: StepControl, fallback: RelaxationFallback | None,
                          relax: Callable[[float], None], what: str = "s",
                          start_over: Callable[[float], None] | None = None) -> None:
    """Move a path coordinate (sinkage or travel, m) from ``position()`` through each of ``targets``
    (ascending) by ``advance(to, control)`` (one :func:`solve_load_path` from the current state to
    ``to``).  When ``advance`` fails as ``fallback`` allows, ``relax(fallback.length)`` switches the
    soil's relaxation on for the next ``fallback.stretch`` and ``relax(0)`` off again; a failure
    inside that stretch is raised.  With ``start_over``, the first such failure calls
    ``start_over(where)`` (``where``: the coordinate it failed at), which restores the state the
    move started from, and the relaxed stretch begins there.  ``control.max_wall_time`` holds for
    the whole move; ``what`` names the coordinate in the log."""
    deadline = time.perf_counter() + control.max_wall_time

    def remaining() -> StepControl:
        return replace(control, max_wall_time=max(deadline - time.perf_counter(), 1e-3))

    for target in targets:
        while target - position() > 1e-12 * max(abs(target), 1e-3):
            try:
                advance(target, remaining())
            except SolverDivergedError as err:
                if fallback is None or not fallback.applies(err):
                    raise
                failed = position()
                if start_over is not None:
                    start_over(failed)
                    start_over = None
                start = position()
                end = min(target, start + fallback.stretch)
                log.warning("Newton failed at %s = %.5g m: the soil is relaxed (Duvaut-Lions, %.3g mm) from "
                            "%s = %.5g m%s up to %s = %.5g m%s", what, failed, 1e3 * fallback.length, what, start,
                            " (the move starts over)" if start < failed else "", what, end,
                            ", the end of the move" if end == target else ", then the rate-independent path goes on")
                relax(fallback.length)
                try:
                    advance(end, remaining())
                finally:
                    relax(0.0)
                    if position() > start:
                        fallback.spans.append((start, position()))


def straight_path(start: float, end: float, place: Callable[[float], None]) -> Callable[[float], None]:
    """``set_load`` of :func:`solve_load_path` for one straight segment of a path coordinate (m):
    pseudo-time ``t`` in [0, 1] calls ``place(start + (end - start) t)``."""
    def set_load(t: float) -> None:
        place(start + (end - start) * t)
    return set_load


def _mpi_max():
    from mpi4py import MPI
    return MPI.MAX


def _extrapolate(problem, u_prev: np.ndarray, ratio: float) -> None:
    """Newton starting point ``u_n + ratio (u_n - u_prev)`` (owned and ghost values alike)."""
    un = problem.u_n.x.array
    problem.u.x.array[:] = un + ratio * (un - u_prev)


def _snapshot(problem, t: float) -> ConvergedState:
    """The converged state; a problem without history variables (elastic) gives empty ones."""
    def saved(name):
        f = getattr(problem, name, None)
        return f.x.array.copy() if f is not None else np.empty(0)
    return ConvergedState(t=t, u=problem.u_n.x.array.copy(), sigma=saved("sigma_n"), eps_p=saved("eps_p"))
