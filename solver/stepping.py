"""Adaptive load stepping: step cutting on divergence, growth after easy steps, clean failure."""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from rollsim.log import get_logger

__all__ = ["StepControl", "StepRecord", "ConvergedState", "SolverDivergedError", "solve_load_path"]

log = get_logger("solver")


@dataclass(frozen=True)
class StepControl:
    """Pseudo-time stepping on ``t in [0, t_end]`` (the load parameter).

    ``dt`` initial step, halved on divergence at most ``max_cuts`` times in a row and never
    below ``dt_min``; multiplied by ``grow`` (capped at ``dt_max``) after a step that needed at
    most ``easy_iterations`` Newton iterations.
    """

    t_end: float = 1.0
    dt: float = 0.1
    dt_min: float = 1e-6
    dt_max: float = 0.25
    grow: float = 1.5
    easy_iterations: int = 4
    max_cuts: int = 8
    max_steps: int = 10_000

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
    """Newton failed even after cutting the step; ``last_converged`` / ``history`` are kept and the
    problem has been restored to that state."""

    def __init__(self, message: str, last_converged: ConvergedState, history: list[StepRecord]):
        super().__init__(message)
        self.last_converged = last_converged
        self.history = history


def solve_load_path(problem, set_load: Callable[[float], None], control: StepControl = StepControl(),
                    on_step: Callable[[float], dict | None] | None = None, t_start: float = 0.0
                    ) -> list[StepRecord]:
    """Drive ``problem`` (a :class:`PlasticityProblem`) from ``t_start`` to ``control.t_end``.

    ``set_load(t)`` must put the boundary data / loads of pseudo-time ``t`` into the problem
    (e.g. the footing displacement Constant).  After each converged step the history is
    committed and ``on_step(t)`` is called (its dict is stored in the record).
    """
    t = t_start
    dt = min(control.dt, control.t_end - t)
    history: list[StepRecord] = []
    cuts = 0
    while t < control.t_end * (1 - 1e-12):
        if len(history) >= control.max_steps:
            raise SolverDivergedError(f"max_steps={control.max_steps} reached at t={t:g}",
                                      _snapshot(problem, t), history)
        dt = min(dt, control.t_end - t)
        set_load(t + dt)
        rep = problem.solve_increment()
        if not rep.converged:
            problem.restore()
            cuts += 1
            log.info("  step t=%.6g dt=%.3g diverged (reason %d after %d its); cut %d; |F|: %s",
                     t + dt, dt, rep.reason, rep.iterations, cuts,
                     " ".join(f"{r:.1e}" for r in rep.residual_norms))
            dt *= 0.5
            if cuts > control.max_cuts or dt < control.dt_min:
                set_load(t)
                raise SolverDivergedError(
                    f"Newton diverged at t={t:g} (tried dt down to {2 * dt:.3g}, {cuts} cuts); "
                    f"last converged state kept", _snapshot(problem, t), history)
            continue
        problem.commit()
        t += dt
        data = on_step(t) if on_step is not None else None
        history.append(StepRecord(t=t, dt=dt, iterations=rep.iterations, residual_norms=rep.residual_norms,
                                  cuts=cuts, counts=rep.counts, time=rep.time, data=data or {}))
        norms = " ".join(f"{r:.1e}" for r in rep.residual_norms)
        log.info("step %3d t=%.5f dt=%.3g its=%d plastic=%d apex=%d |F|: %s %s", len(history), t, dt,
                 rep.iterations, rep.counts.get("plastic", 0), rep.counts.get("apex", 0), norms,
                 " ".join(f"{k}={v:.6g}" for k, v in (data or {}).items() if isinstance(v, float)))
        if rep.iterations <= control.easy_iterations and cuts == 0:
            dt = min(dt * control.grow, control.dt_max)
        cuts = 0
    return history


def _snapshot(problem, t: float) -> ConvergedState:
    return ConvergedState(t=t, u=problem.u_n.x.array.copy(), sigma=problem.sigma_n.x.array.copy(),
                          eps_p=problem.eps_p.x.array.copy())
