"""Towed rigid wheel rolling over elastoplastic soil: protocol ``rolling-continuous``.

Set-up (``shared/spec/numerical-model.md``, "Rolling, continuous"): half model about the wheel
mid-plane (``rolling_block(cut="half")``), gravity step, wheel placed at ``x0 = ROLLING_START d``
and pressed vertically to a small initial sinkage ``s0``, then translated in +x while its sinkage
is ramped slowly (linearly in travel) to the target; every instant is then close to steady
rolling and one run gives ``Q_V(s)`` and ``Q_H(s)``.

Kinematics of a step (pseudo-time = travel, m): the centre moves by ``dx`` and its height follows
the ramp; the wheel is **towed** (free to rotate, zero axle torque), so its rotation increment
``dtheta`` is an unknown fixed by the torque balance ``M(dtheta) = 0``.  ``M`` is the moment of the
contact tractions about the axle; normal pressures pass through the axle (the wheel surface is a
surface of revolution), so only friction makes a moment, and ``M`` decreases monotonically with
``dtheta`` (more rotation -> the wheel's contact points move backwards -> friction on the wheel
turns forward).  Each step solves ``M = 0`` by secant / Illinois regula falsi on ``dtheta``
around the Newton solve of the soil (each trial warm-started from the previous trial's
displacement; all trials start from the same converged history, so the accepted state does not
depend on the rejected ones), to ``|M| <= moment_rtol * Q_V * d``.  Predictor: the previous
step's ratio ``dtheta R / dx`` (1 = rolling without slip on a rigid surface).  Frictionless: one
solve with the predictor (the rotation does not enter the equations).

The torque iteration is wrapped as the ``solve_increment`` of a proxy problem, so the travel
steps reuse :func:`~rollsim.solver.stepping.solve_load_path` unchanged (step cutting on failure,
growth after easy steps, guards).

Forces are for the whole wheel (twice the half model); ``Q_H`` is the towing force (rolling
resistance), > 0 for a wheel moving in +x.
"""
from __future__ import annotations

import dataclasses
import math
import pathlib
import time
from dataclasses import dataclass
from typing import Callable

import numpy as np
from mpi4py import MPI

from rollsim.log import get_logger

from .indentation import WheelIndentation
from .problem import NewtonReport
from .stepping import SolverDivergedError, StepControl, solve_load_path

__all__ = ["WheelRolling", "RollingStep", "SteadyState", "detect_steady_state", "run_rolling", "rolling_mesh",
           "DEFAULT_ROLL_CONTROL"]

log = get_logger("solver")

#: travel stepping, in units of the contact element size h (scaled in :meth:`WheelRolling.roll`)
DEFAULT_ROLL_CONTROL = dict(dt=0.25, dt_min=1e-3, dt_max=0.5, easy_iterations=8, max_cuts=8, grow=1.5)
#: constant load: travel of the wheel centre on the test soil (past the stiff start zone), in d,
#: before steady state is looked for.  Leaving the stiff zone the wheel overshoots, and one
#: window on the overshoot's plateau can look steady; on the fast preset the plateau ended
#: 0.3-0.6 d past the zone's end and the sinkage had settled by 0.7-0.95 d (README, "Do the two
#: protocols agree?" and the Mn/DOT run)
STEADY_MIN_TRAVEL = 0.75


@dataclass
class RollingStep:
    """One converged rolling step, whole-wheel forces."""

    step: int
    travel: float          # m, centre displacement from the start position
    sinkage: float         # m
    QV: float              # N
    QH: float              # N (towing force, rolling resistance)
    moment: float          # N m about the axle (residual of the torque balance)
    rotation: float        # rad, total wheel rotation since the start
    slip: float            # 1 - R dtheta/dx of the step (0 = rolling without slip)
    contact_area: float    # m^2
    max_penetration: float
    iterations: int        # Newton iterations of the accepted step (all torque trials)
    trials: int            # torque-balance trials
    cuts: int
    plastic: int
    time: float


@dataclass
class SteadyState:
    """Steady rolling at constant load: means over the detection window (whole wheel)."""

    reached: bool
    travel: float           # m, travel at detection
    sinkage: float          # m
    QV: float               # N
    QH: float               # N
    window: float           # m, detection window (one contact length)
    sinkage_change: float   # |trend of s over the window| / s
    QH_change: float        # |trend of Q_H over the window| / |Q_H|


def detect_steady_state(steps, x_start: float, x_soft: float, window: float, s_rtol: float,
                        qh_rtol: float, min_travel: float = 0.0) -> SteadyState | None:
    """Steady state of the last steps, or ``None``.  Only steps whose wheel centre is beyond
    ``x_soft + max(window / 2, min_travel)`` count (the contact patch on the test soil, and the
    transient after the stiff zone rolled out: ``min_travel``, m); the window is the last
    ``window`` metres of travel and needs at least 4 steps.  The change of a quantity over the
    window is its least-squares slope times ``window`` (robust to the element-passing ripple),
    relative to the mean (for ``Q_H``: to at least 1 % of ``Q_V``, so a nearly zero rolling
    resistance, e.g. on elastic soil, does not block the detection)."""
    pts = [st for st in steps if st.travel > 0 and x_start + st.travel >= x_soft + max(0.5 * window, min_travel)]
    if not pts:
        return None
    end = pts[-1].travel
    win = [st for st in pts if st.travel >= end - window]
    if len(win) < 4 or win[-1].travel - win[0].travel < 0.75 * window:
        return None
    x = np.array([st.travel for st in win])
    s = np.array([st.sinkage for st in win])
    qh = np.array([st.QH for st in win])
    qv = float(np.mean([st.QV for st in win]))
    s_change = abs(np.polyfit(x, s, 1)[0]) * window / max(abs(s.mean()), 1e-30)
    qh_change = abs(np.polyfit(x, qh, 1)[0]) * window / max(abs(qh.mean()), 0.01 * abs(qv), 1e-30)
    if s_change <= s_rtol and qh_change <= qh_rtol:
        return SteadyState(True, end, float(s.mean()), qv, float(qh.mean()), window, float(s_change),
                           float(qh_change))
    return None


class _StopRolling(Exception):
    pass


class _TorqueBalancedProblem:
    """Proxy of a PlasticityProblem whose ``solve_increment`` also finds the wheel rotation
    increment with zero axle moment (for ``solve_load_path``)."""

    def __init__(self, rolling: "WheelRolling"):
        self._r = rolling
        self._pb = rolling.problem

    def __getattr__(self, name):
        return getattr(self._pb, name)

    def solve_increment(self) -> NewtonReport:
        if self._r.target_load is not None:
            return self._r._solve_load_balance()
        return self._r._solve_torque_balance()

    def commit(self) -> None:
        self._pb.commit()

    def restore(self) -> None:
        self._pb.restore()


class WheelRolling:
    """Towed rigid wheel on a half (or full) rolling block.

    ``tagged``: ``TaggedMesh`` from ``build_soil_block(rolling_block(...))``; ``wheel``:
    ``CylinderWheel`` / ``TorusWheel``; ``materials``: one material or ``{cell tag: material}``
    (the stiff start zone, tag ``STIFF_ZONE_TAG``, gets ``stiff_material`` if present in the mesh
    and not in ``materials``: by default elastic with 10x the top layer's modulus);
    ``x_start``: wheel start position (m; default ``ROLLING_START d``); ``moment_rtol``: torque
    balance tolerance relative to ``Q_V d``; ``relaxation_length`` (m, 0: off): Duvaut-Lions
    regularisation of the soil while the wheel moves (press, roll, lift), with the wheel's path
    as pseudo-time: a step that moves the wheel by ``dx`` has ``r = dx / relaxation_length``
    (see :func:`~rollsim.solver.return_map.duvaut_lions`); other keywords as :class:`WheelIndentation`.
    """

    def __init__(self, tagged, wheel, materials, *, gamma: float = 0.0, friction: float = 0.0,
                 x_start: float | None = None, moment_rtol: float = 2e-3, max_trials: int = 12,
                 stiff_material=None, petsc_options: dict | None = None, penalty: float | None = None,
                 relaxation_length: float = 0.0, **kw):
        from rollsim.geometry import ROLLING_START, STIFF_ZONE_TAG
        mats = dict(materials) if isinstance(materials, dict) else {1: materials}
        if STIFF_ZONE_TAG in tagged.cell_names.values() and STIFF_ZONE_TAG not in mats:
            if stiff_material is None:
                from .materials import VonMises
                top = mats[min(mats)]
                stiff_material = VonMises(E=10 * top.E, nu=top.nu, yield_stress=1e12)
            mats[STIFF_ZONE_TAG] = stiff_material
        self.d = wheel.diameter
        self.R = wheel.diameter / 2
        self.width = wheel.width
        self.x_start = ROLLING_START * self.d if x_start is None else float(x_start)
        # WheelIndentation builds the problem, the boundary conditions (rear/front/side/bottom normal
        # displacement, symmetry_y) and the contact; its pose helpers (x = 0) are not used here
        self._ind = WheelIndentation(tagged, wheel, mats if len(mats) > 1 else next(iter(mats.values())),
                                     gamma=gamma, friction=friction, petsc_options=petsc_options,
                                     penalty=penalty, **kw)
        self.tagged = tagged
        self.comm = tagged.mesh.comm
        self.problem = self._ind.problem
        self.contact = self._ind.contact
        self.factor = self._ind.factor
        self.n_dofs = self._ind.n_dofs
        self.friction = float(friction)
        self.moment_rtol = float(moment_rtol)
        self.max_trials = int(max_trials)
        if not relaxation_length >= 0:
            raise ValueError(f"relaxation_length must be >= 0 (m), got {relaxation_length}")
        self.relaxation_length = float(relaxation_length)
        self.steps: list[RollingStep] = []
        self.target_load: float | None = None   # N, whole wheel: set by roll_at_load
        self.load_rtol = 2e-3
        self._jac: np.ndarray | None = None     # Broyden Jacobian d(Q_V, M)/d(s, dtheta), kept between steps
        self._sink_rate = 0.0                    # predictor: ds/dx of the last step
        self.slip_ratio = 0.0           # predictor: slip of the last step
        self._step_dx = 0.0             # translation of the step being solved
        self._trials = 0
        self._its = 0
        self._attempts = 0
        self._t_last = time.perf_counter()
        self.contact.set_pose(centre=self._centre(self.x_start, 0.0), angle=0.0)

    # ------------------------------------------------------------------ pose
    def _centre(self, x: float, s: float) -> np.ndarray:
        return np.array([x, 0.0, self.R - s])

    @property
    def position(self) -> float:
        return float(self.contact.centre_n.value[0])

    @property
    def sinkage(self) -> float:
        return self.R - float(self.contact.centre_n.value[-1])

    @property
    def rotation(self) -> float:
        return float(self.contact.angle_n.value)

    def forces(self) -> dict:
        return self._ind.forces()

    def save_state(self) -> dict:
        return self._ind.save_state() | {"n_roll_steps": len(self.steps), "slip_ratio": self.slip_ratio}

    def load_state(self, st: dict) -> None:
        self._ind.load_state(st)
        del self.steps[st["n_roll_steps"]:]
        self.slip_ratio = st["slip_ratio"]

    @property
    def newton_iterations(self) -> int:
        return self._ind.newton_iterations

    @property
    def cuts(self) -> int:
        return int(sum(st.cuts for st in self.steps))

    # ------------------------------------------------------------------ protocols
    def gravity_step(self) -> None:
        """Geostatic stress + body force, equilibrium solve, displacement zeroed; the wheel is held
        just above the surface at the start position."""
        pb = self.problem
        if self._ind.gamma:
            pb.set_geostatic_stress(self._ind.gamma, surface=0.0, K0=self._ind.K0)
            self.contact.set_pose(centre=self._centre(self.x_start, -1e-3 * self.R), angle=0.0)
            rep = pb.solve_increment()
            if not rep.converged:
                pb.restore()
                raise SolverDivergedError("gravity step did not converge", None, [])
            pb.commit()
            log.info("gravity step: %d Newton iterations", rep.iterations)
            pb.reset_displacement()
        self.contact.set_pose(centre=self._centre(self.x_start, 0.0), angle=0.0)
        self.contact.commit()

    def press(self, s0: float, control: StepControl | None = None,
              on_step: Callable[[RollingStep], None] | None = None) -> list[RollingStep]:
        """Vertical push at the current position to the sinkage ``s0`` (m), displacement control."""
        control = control or StepControl(t_end=1.0, dt=0.25, dt_min=1e-3, dt_max=0.5, easy_iterations=8,
                                         max_cuts=8)
        if s0 <= self.sinkage:
            return self.steps
        return self._move_vertically(s0, control, on_step)

    def _move_vertically(self, s_to: float, control: StepControl, on_step) -> list[RollingStep]:
        """Displacement-controlled vertical move of the wheel from the current sinkage to ``s_to``."""
        x, s_from, th = self.position, self.sinkage, self.rotation

        def set_load(t):
            self._attempts += 1
            s = s_from + (s_to - s_from) * t
            self.problem.relax_over(abs(s - self.sinkage), self.relaxation_length)
            self.contact.set_pose(centre=self._centre(x, s), angle=th)

        def on_t(t):
            st = self._record(dx=0.0, dth=0.0, iterations=int(self.problem.snes.getIterationNumber()), trials=1)
            if on_step is not None:
                on_step(st)
            return {"QV": st.QV}

        self._run(set_load, control, on_t)
        return self.steps

    def roll(self, travel: float, s_target: float, ramp: float | None = None, dx: float | None = None,
             on_step: Callable[[RollingStep], None] | None = None, control: StepControl | None = None
             ) -> list[RollingStep]:
        """Translate the wheel by ``travel`` (m) in +x, its sinkage ramped linearly from the current
        value to ``s_target`` over the first ``ramp`` metres of travel (default: all of it), then
        held.  ``dx``: first travel step (default h/4, h the contact element size; grows to h/2
        after easy steps, cut on divergence).  Returns all steps; ``SolverDivergedError`` (state at
        the last converged step) on failure."""
        if not travel > 0:
            raise ValueError(f"travel must be > 0, got {travel}")
        ramp = travel if ramp is None else float(ramp)
        if not ramp > 0:
            raise ValueError(f"ramp must be > 0, got {ramp}")
        h = self.contact.h
        if control is None:
            c = dict(DEFAULT_ROLL_CONTROL)
            if dx is not None:
                c["dt"] = dx / h
                c["dt_max"] = max(c["dt_max"], c["dt"])
            if self.friction > 0 or self.target_load is not None:   # iterations summed over ~3 trials
                c["easy_iterations"] *= 3
            control = StepControl(t_end=travel, **{k: (v * h if k.startswith("dt") else v) for k, v in c.items()})
        x0, s0, th0 = self.position, self.sinkage, self.rotation

        def sink(t):
            return s0 + (s_target - s0) * min(t / ramp, 1.0)

        def set_load(t):
            self._attempts += 1
            x_prev = self.position
            self._step_dx = (x0 + t) - x_prev
            self.problem.relax_over(abs(self._step_dx), self.relaxation_length)
            s = sink(t) if self.target_load is None else self.sinkage + self._sink_rate * self._step_dx
            self.contact.set_pose(centre=self._centre(x0 + t, s),
                                  angle=self.rotation + (1.0 - self.slip_ratio) * self._step_dx / self.R)

        def on_t(t):
            # pose already committed: the step's increments are centre - (values saved before commit)
            s_prev = self.steps[-1].sinkage if self.steps else self.sinkage
            st = self._record(dx=self._last_dx, dth=self._last_dth, iterations=self._its, trials=self._trials)
            if self._last_dx > 0:
                self.slip_ratio = st.slip
                self._sink_rate = (st.sinkage - s_prev) / self._last_dx
            if on_step is not None:
                on_step(st)
            return {"QV": st.QV, "moment": st.moment}

        self._rolling = True
        try:
            self._run(set_load, control, on_t)
        finally:
            self._rolling = False
        return self.steps

    def lift(self, on_step: Callable[[RollingStep], None] | None = None) -> list[RollingStep]:
        """Lift the wheel vertically off the soil at the current position (displacement control in
        four steps, to 0.1 % of R above the undisturbed surface): the soil rebounds, and the
        surface keeps only the permanent rut."""
        return self._move_vertically(-1e-3 * self.R, StepControl(t_end=1.0, dt=0.25, dt_min=1e-3, dt_max=0.25,
                                                                 max_cuts=8), on_step)

    def press_to_load(self, load: float, sinkage_limit: float,
                      on_step: Callable[[RollingStep], None] | None = None) -> "LoadControlResult":
        """Vertical load control at the current position: sinkage where the whole-wheel ``Q_V``
        equals ``load`` (N), searched up to ``sinkage_limit`` (m); as
        :meth:`WheelIndentation.push_to_load` (outcomes ``ok`` / ``exceeds_capacity`` / ``failed``)."""
        ind = self._ind
        ind.x_centre = self.position
        n0 = len(ind.steps)
        res = ind.push_to_load(load, sinkage_limit, rtol=0.2 * self.load_rtol)
        for ist in ind.steps[n0:]:
            st = RollingStep(step=len(self.steps) + 1, travel=self.position - self.x_start, sinkage=ist.sinkage,
                             QV=ist.QV, QH=ist.QH, moment=ist.moment, rotation=self.rotation, slip=0.0,
                             contact_area=ist.contact_area, max_penetration=ist.max_penetration,
                             iterations=ist.iterations, trials=1, cuts=ist.cuts, plastic=ist.plastic, time=ist.time)
            self.steps.append(st)
            if on_step is not None:
                on_step(st)
        if res.status == "ok" and len(ind.steps) - n0 >= 2:     # initial dQ/ds for the load balance
            a, b = ind.steps[-2], ind.steps[-1]
            if b.sinkage > a.sinkage and b.QV > a.QV:
                self._jac = np.diag([(b.QV - a.QV) / (b.sinkage - a.sinkage), 0.0])
        return res

    def roll_at_load(self, load: float, travel: float, *, x_soft: float | None = None,
                     steady_rtol: float = 0.02, steady_qh_rtol: float = 0.05, run_out: float = 1.0,
                     min_window_elements: float = 3.0, min_travel: float | None = None,
                     on_step: Callable[[RollingStep], None] | None = None,
                     control: StepControl | None = None) -> "SteadyState":
        """Roll at constant whole-wheel ``Q_V = load`` (N), towed, up to ``travel`` (m) in +x.

        Each travel step solves the sinkage and the rotation increment for ``Q_V = load`` (to
        ``load_rtol``) and zero axle moment by Broyden's method on the two unknowns (one soil
        solve per trial, warm-started).  Steady state (see :func:`detect_steady_state`): once the
        whole window lies on the soil beyond ``x_soft`` (m, the end of the stiff start zone;
        default: the start position), sinkage and ``Q_H`` trends over a window of one contact
        length (at least ``min_window_elements`` contact elements: on coarse meshes the force and
        sinkage ripple as the wheel passes elements) change by less than ``steady_rtol`` /
        ``steady_qh_rtol``; the window counts only once the wheel centre has rolled ``min_travel``
        (m; default :data:`STEADY_MIN_TRAVEL` d) past ``x_soft``, so the overshoot after the stiff
        zone is not taken for steady rolling.  The wheel then rolls ``run_out`` windows further
        (the rut behind it is then unloaded) and stops.  Default ``control``: fixed steps of a
        quarter element.
        Returns the :class:`SteadyState` (``reached = False`` when ``travel`` ran out first)."""
        if not load > 0 or not travel > 0:
            raise ValueError(f"load and travel must be > 0, got {load}, {travel}")
        self.target_load = float(load)
        x_soft = self.x_start if x_soft is None else float(x_soft)
        min_travel = STEADY_MIN_TRAVEL * 2 * self.R if min_travel is None else float(min_travel)
        if self.x_start + travel < x_soft + min_travel:
            log.warning("the travel of %g m ends %.3f m before the wheel has rolled the %.3f m on the test soil "
                        "after which steady state is looked for: no steady state will be detected",
                        travel, x_soft + min_travel - self.x_start - travel, min_travel)
        found: list[SteadyState] = []
        stop_at = [math.inf]

        def monitor(st: RollingStep):
            if on_step is not None:
                on_step(st)
            if not found:
                # the element-passing ripple has the period of a contact element: average >= 3 of them
                window = max(self.contact_length(st), min_window_elements * self.contact.h)
                ss = detect_steady_state(self.steps, self.x_start, x_soft, window, steady_rtol, steady_qh_rtol,
                                         min_travel)
                if ss is not None:
                    found.append(ss)
                    stop_at[0] = st.travel + run_out * ss.window
                    log.info("steady state at travel %.3f m: s = %.5f m, Q_H = %.3f kN (changes %.2g / %.2g "
                             "over %.3f m); rolling %.3f m more for the rut", st.travel, ss.sinkage, ss.QH / 1e3,
                             ss.sinkage_change, ss.QH_change, ss.window, run_out * ss.window)
            if st.travel >= stop_at[0] - 1e-12:
                raise _StopRolling

        if control is None:                 # fixed steps of h/4: >= 4 steps per detection window
            h = self.contact.h
            control = StepControl(t_end=travel, dt=0.25 * h, dt_min=1e-3 * h, dt_max=0.25 * h, max_cuts=8,
                                  easy_iterations=10**6)
        try:
            self.roll(travel, self.sinkage, on_step=monitor, control=control)
        except _StopRolling:
            pass
        finally:
            self.target_load = None
        if found:
            return found[0]
        last = self.steps[-1]
        return SteadyState(False, last.travel, last.sinkage, last.QV, last.QH, self.contact_length(last),
                           math.nan, math.nan)

    def contact_length(self, st: RollingStep | None = None) -> float:
        """Contact length along the travel, m: whole-wheel contact area / wheel width."""
        st = st or self.steps[-1]
        return max(st.contact_area / self.width, self.contact.h)

    def surface_profile(self) -> tuple[np.ndarray, np.ndarray]:
        """``(x, settlement)`` of the soil surface on the wheel's mid-plane (y = 0, z = 0), m, sorted
        by x, identical on all ranks (settlement > 0 downwards, relative to the state after gravity)."""
        pb = self.problem
        V = pb.V
        n = V.dofmap.index_map.size_local
        bs = V.dofmap.index_map_bs
        X = V.tabulate_dof_coordinates()[:n]
        tol = 1e-8 * self.d
        on_line = (np.abs(X[:, 1]) < tol) & (np.abs(X[:, 2]) < tol)
        uz = pb.u_n.x.array[: n * bs].reshape(n, bs)[on_line, -1]
        xs = np.concatenate(self.comm.allgather(X[on_line, 0]))
        ws = np.concatenate(self.comm.allgather(-uz))
        xs, keep = np.unique(np.round(xs, 12), return_index=True)
        return xs, ws[keep]

    _rolling = False
    _last_dx = 0.0
    _last_dth = 0.0

    # ------------------------------------------------------------------ internals
    def _run(self, set_load, control, on_t) -> None:
        pb = _TorqueBalancedProblem(self)
        try:
            solve_load_path(pb, set_load, control, on_t)
        except SolverDivergedError:
            c, th = np.array(self.contact.centre_n.value), float(self.contact.angle_n.value)
            self.contact.set_pose(centre=c, angle=th)
            raise
        finally:
            self.problem.relaxation = math.inf

    def _solve_torque_balance(self) -> NewtonReport:
        """Newton solve(s) at the set translation; with friction and while rolling, iterate the
        rotation increment to zero axle moment.  Leaves the accepted iterate in the problem (not
        committed); reports the total Newton iterations."""
        pb = self.problem
        ct = self.contact
        th_n = self.rotation
        dx = self._step_dx if self._rolling else 0.0
        total, t0 = 0, time.perf_counter()
        norms: list[float] = []

        def solve():
            nonlocal total
            rep = pb.solve_increment()
            total += rep.iterations
            norms.extend(rep.residual_norms)
            return rep

        rep = solve()
        trials = 1
        if rep.converged and self.friction > 0 and self._rolling and dx > 0:
            f = self.forces()
            tol = self.moment_rtol * max(abs(f["QV"]), 1e-30) * self.d
            x1, m1 = float(ct.angle.value) - th_n, f["moment"]
            scale = max(abs(dx) / self.R, 1e-12)
            lo = (x1, m1) if m1 > 0 else None        # bracket ends: M > 0 (too little rotation)
            hi = (x1, m1) if m1 < 0 else None        #               M < 0 (too much)
            last_side, m = 0, m1
            nxt = x1 + np.sign(m1) * 0.05 * scale   # probe (M decreases with the rotation)
            prev = (x1, m1)
            while abs(m) > tol:
                if trials >= self.max_trials:
                    log.info("  torque balance not reached in %d trials (|M| = %.3g N m, tol %.3g)",
                             trials, abs(m), tol)
                    rep = NewtonReport(False, total, -200, norms)
                    break
                ct.set_pose(angle=th_n + nxt)
                rep = solve()                       # warm start: the previous trial's displacement
                trials += 1
                if not rep.converged:
                    break
                x, m = nxt, self.forces()["moment"]
                if m > 0:
                    if last_side == 1 and hi is not None:
                        hi = (hi[0], hi[1] / 2)     # Illinois
                    lo, last_side = (x, m), 1
                else:
                    if last_side == -1 and lo is not None:
                        lo = (lo[0], lo[1] / 2)
                    hi, last_side = (x, m), -1
                if lo is not None and hi is not None:
                    nxt = lo[0] - lo[1] * (hi[0] - lo[0]) / (hi[1] - lo[1])
                    w = hi[0] - lo[0]
                    nxt = min(max(nxt, lo[0] + 1e-3 * w), hi[0] - 1e-3 * w) if w > 0 else nxt
                else:                               # secant, kept going the same way, at most x4
                    slope = (m - prev[1]) / (x - prev[0]) if x != prev[0] else -1.0
                    step = -m / slope if slope < 0 else np.sign(m) * 2 * abs(x - prev[0])
                    cap = max(4 * abs(x - prev[0]), 0.05 * scale)
                    step = np.sign(m) * min(max(abs(step), 1e-4 * scale), cap)
                    nxt = x + step
                prev = (x, m)
        self._trials, self._its = trials, total
        if rep.converged:
            self._last_dx = float(ct.centre.value[0]) - self.position
            self._last_dth = float(ct.angle.value) - th_n
            return NewtonReport(True, total, rep.reason, norms, time.perf_counter() - t0, rep.counts)
        return NewtonReport(False, total, rep.reason, norms, time.perf_counter() - t0, {})

    def _solve_load_balance(self) -> NewtonReport:
        """Constant-load step: Broyden's method on (sinkage, rotation increment) for
        ``Q_V = target_load`` and zero axle moment (rotation only with friction while rolling),
        one soil solve per trial warm-started from the previous one.  The Jacobian estimate is kept
        for the next step; trial moves are capped (a quarter contact element in sinkage)."""
        pb, ct = self.problem, self.contact
        load = self.target_load
        th_n = self.rotation
        x = float(ct.centre.value[0])
        with_moment = self.friction > 0 and self._rolling and self._step_dx > 0
        n = 2 if with_moment else 1
        tol = np.array([self.load_rtol * load, self.moment_rtol * load * self.d])[:n]
        J = self._jac if self._jac is not None else np.diag([load / max(self.sinkage, 0.1 * ct.h), 0.0])
        J = J.copy()
        probe = with_moment and J[1, 1] >= 0        # dM/dtheta unknown: measure it with a rotation probe
        J = J[:n, :n]
        z = np.array([self.R - float(ct.centre.value[-1]), float(ct.angle.value) - th_n])[:n]
        cap = np.array([0.25 * ct.h, max(abs(self._step_dx), ct.h) / self.R])[:n]
        total, trials, t0 = 0, 0, time.perf_counter()
        norms: list[float] = []
        prev = None
        rep = None
        while True:
            ct.set_pose(centre=self._centre(x, z[0]), angle=th_n + (z[1] if n == 2 else float(ct.angle.value) - th_n))
            rep = pb.solve_increment()
            total += rep.iterations
            norms.extend(rep.residual_norms)
            trials += 1
            if not rep.converged:
                break
            f = self.forces()
            F = np.array([f["QV"] - load, f["moment"]])[:n]
            if np.all(np.abs(F) <= tol):
                break
            if trials >= self.max_trials:
                log.info("  load balance not reached in %d trials (Q_V - load = %.3g N, M = %.3g N m)",
                         trials, F[0], f["moment"])
                rep = NewtonReport(False, total, -201, norms)
                break
            if prev is not None:                    # Broyden update of the Jacobian estimate
                dz, dF = z - prev[0], F - prev[1]
                if dz @ dz > 0:
                    J = J + np.outer(dF - J @ dz, dz) / (dz @ dz)
            if probe:                               # rotation only (M > 0: too little rotation)
                probe = False
                prev = (z.copy(), F)
                z = z + np.array([0.0, np.sign(F[1]) * 0.05 * abs(self._step_dx) / self.R])
                continue
            if J[0, 0] <= 0:                        # more sinkage must carry more load
                J[0, 0] = abs(J[0, 0]) or load / max(z[0], ct.h)
            if n == 2 and J[1, 1] >= 0:             # more rotation turns the friction moment negative
                J[1, 1] = -abs(J[1, 1]) or -abs(F[1]) / cap[1]
            try:
                step = -np.linalg.solve(J, F)
            except np.linalg.LinAlgError:
                step = -F / np.diag(J)
            scale = np.max(np.abs(step) / cap)
            if scale > 1:
                step = step / scale
            prev = (z.copy(), F)
            z = z + step
        self._trials, self._its = trials, total
        if rep.converged:
            full = np.zeros((2, 2))
            full[:n, :n] = J
            if n == 1 and self._jac is not None:
                full[1, 1] = self._jac[1, 1]
            self._jac = full
            self._last_dx = float(ct.centre.value[0]) - self.position
            self._last_dth = float(ct.angle.value) - th_n
            return NewtonReport(True, total, rep.reason, norms, time.perf_counter() - t0, rep.counts)
        return NewtonReport(False, total, rep.reason, norms, time.perf_counter() - t0, {})

    def _record(self, dx: float, dth: float, iterations: int, trials: int) -> RollingStep:
        now = time.perf_counter()
        f = self.forces()
        pb = self.problem
        slip = 1.0 - self.R * dth / dx if dx > 0 else 0.0
        st = RollingStep(step=len(self.steps) + 1, travel=self.position - self.x_start, sinkage=self.sinkage,
                         QV=f["QV"], QH=f["QH"], moment=f["moment"], rotation=self.rotation, slip=slip,
                         contact_area=f["contact_area"], max_penetration=f["max_penetration"],
                         iterations=iterations, trials=trials, cuts=max(self._attempts - 1, 0),
                         plastic=int(self.comm.allreduce(int(np.sum(pb.state != 0)))), time=now - self._t_last)
        self._t_last = now
        self._attempts = 0
        self.steps.append(st)
        return st


# ---------------------------------------------------------------------- run directory
def rolling_mesh(scene, comm: MPI.Comm, *, length: float | None = None, half_width: float = 1.5,
                 depth: float | None = None, stiff_length: float = 0.0):
    """Half rolling block for the scene (lengths in multiples of d).  Default length: the report's
    3.5 d, or longer when the travel needs it (start + travel + 1 d ahead of the wheel)."""
    from rollsim.geometry import ROLLING_START, MeshOptions, build_soil_block, rolling_block
    d = scene.wheel.diameter
    if length is None:
        length = max(3.5, ROLLING_START + scene.loading.travel / d + 1.0)
    thick = [layer.thickness for layer in scene.soil.layers[:-1]]
    if depth is None:
        depth = max(1.5, sum(thick) / d + 0.5)
    block = rolling_block(d, length=length, half_width=half_width, depth=depth, cut="half",
                          layers=tuple(t / d for t in thick), stiff_length=stiff_length)
    return build_soil_block(comm, block, MeshOptions.from_accuracy(d, scene.model.accuracy))


def run_rolling(scene, out_dir, comm: MPI.Comm, *, progress: bool = True, petsc_options: dict | None = None,
                write_fields: bool = True, penalty: float | None = None, initial_sinkage: float | None = None,
                ramp: float | None = None, block: dict | None = None, moment_rtol: float = 2e-3,
                steady_rtol: float = 0.02, steady_qh_rtol: float = 0.05, min_window_elements: float = 3.0,
                steady_min_travel: float | None = None) -> dict:
    """A rolling protocol of ``scene`` on ``comm``; writes the run directory of
    ``shared/spec/interfaces.md`` (as :func:`~rollsim.solver.run.run_scene`) and returns the summary.

    ``rolling-continuous``: the wheel is pressed to ``initial_sinkage`` (default 0.005 d) at
    ``ROLLING_START d`` and rolls ``loading.travel`` with the sinkage ramped to
    ``loading.max_sinkage`` over ``ramp`` (default: the whole travel).

    ``rolling-constant-load``: gravity, ``loading.load`` applied on the stiff start zone (0.75 d
    long, elastic, 10x the top layer's modulus), then rolling at that load until steady (see
    :meth:`WheelRolling.roll_at_load`; ``steady_rtol`` / ``steady_qh_rtol``, looked for after
    ``steady_min_travel`` m on the test soil, default :data:`STEADY_MIN_TRAVEL` d) or ``loading.travel``;
    the summary reports the steady sinkage, ``Q_H``, the rut depth (mean surface settlement on the
    wheel path over the part rolled in steady state, after the wheel has been lifted off: the
    permanent rut) and the rebound (sinkage - rut depth); ``rut_profile.csv`` has the profile.

    ``block``: keywords of :func:`rolling_mesh` (length/half_width/depth in d).  A signal
    (SIGINT/SIGTERM/SIGUSR1) stops the run after the current step with ``status = "interrupted"``.
    """
    from .run import (_atomic_write, _history_csv, finish_run, history_row, model_summary, relaxation_hint,
                      run_protected, run_setup, scene_penalty)

    protocol = scene.loading.protocol
    if protocol not in ("rolling-continuous", "rolling-constant-load"):
        raise ValueError(f"loading.protocol: {protocol!r} is not a rolling protocol "
                         "(supported: 'rolling-continuous', 'rolling-constant-load')")
    constant_load = protocol == "rolling-constant-load"
    wheel, materials, out = run_setup(scene, out_dir, comm)
    root = comm.rank == 0
    t_start = time.perf_counter()
    d = scene.wheel.diameter
    travel = scene.loading.travel
    s0 = 0.005 * d if initial_sinkage is None else float(initial_sinkage)
    block = dict(block or {})
    block.setdefault("stiff_length", STIFF_LENGTH if constant_load else 0.0)
    stiff_length = block["stiff_length"]
    advice = None
    if not constant_load:
        rate, advice = ramp_advice(scene.loading.max_sinkage, min(s0, scene.loading.max_sinkage),
                                   travel if ramp is None else ramp)
    tagged = rolling_mesh(scene, comm, **block)
    roll = WheelRolling(tagged, wheel, materials, gamma=scene.soil.gamma, friction=scene.wheel.friction,
                        petsc_options=petsc_options, penalty=scene_penalty(scene, penalty), moment_rtol=moment_rtol,
                        kinematics=scene.model.kinematics, linear_solver=scene.model.linear_solver,
                        volumetric_strain=scene.model.volumetric_strain,
                        relaxation_length=scene.model.relaxation_length)
    writer = None
    if write_fields:
        from .fields import FieldWriter
        writer = FieldWriter(roll.problem, out / "fields", cell_tags=tagged.cell_tags)
    rows: list[dict] = []
    bar = TravelProgress(travel, d, enabled=progress and root)

    def on_step(st: RollingStep):
        rows.append(history_row(st, d, st.travel, t_start))
        if writer is not None:
            writer.write(float(len(rows)))
        if root:
            _atomic_write(out / "history.csv", _history_csv(rows))
        bar.update(st)

    steady = None
    lifted = False
    rolling_contact_length = 0.0
    x_soft = stiff_length * d if stiff_length else None
    min_travel = STEADY_MIN_TRAVEL * d if steady_min_travel is None else float(steady_min_travel)

    def rolling():
        nonlocal steady, lifted, rolling_contact_length
        if progress and root:
            what = (f"Q_V = {scene.loading.load / 1e3:g} kN" if constant_load
                    else f"s -> {scene.loading.max_sinkage:g} m")
            log.info("%s: %s wheel d = %g m, mu = %g, %d layer(s), %s mesh: %d cells, %d dofs, %s strain, "
                     "%d rank(s); travel %g m, %s", protocol, scene.wheel.shape, d, scene.wheel.friction,
                     len(materials), scene.model.accuracy, tagged.stats.cells, roll.n_dofs,
                     scene.model.volumetric_strain, comm.size, travel, what)
        roll.gravity_step()
        if not constant_load:
            if advice and root:
                log.warning(advice)
            roll.press(min(s0, scene.loading.max_sinkage), on_step=on_step)
            roll.roll(travel, scene.loading.max_sinkage, ramp=ramp, on_step=on_step)
            return None
        res = roll.press_to_load(scene.loading.load, 0.25 * d, on_step=on_step)
        if res.status != "ok":
            return f"pressing the wheel on the stiff start zone: {res.status}: {res.reason}"
        steady = roll.roll_at_load(scene.loading.load, travel, x_soft=x_soft, on_step=on_step,
                                   steady_rtol=steady_rtol, steady_qh_rtol=steady_qh_rtol,
                                   min_window_elements=min_window_elements, min_travel=min_travel)
        if not steady.reached:
            log.warning("no steady state within the travel of %g m: the values are those of the last "
                        "step (a longer travel or a coarser steady tolerance may help)", travel)
        rolling_contact_length = roll.contact_length()
        roll.lift(on_step=on_step)
        lifted = True
        return None

    status, reason, diagnostics = run_protected(
        rolling, comm, lambda: {"last_converged_travel_m": roll.position - roll.x_start,
                                "last_converged_sinkage_m": roll.sinkage, "step_cuts_total": roll.cuts})
    if status == "failed":
        reason += relaxation_hint(materials, scene)

    rut = None
    if lifted:
        try:
            rut = _rut(roll, steady, x_soft, rolling_contact_length)
            if root:
                _atomic_write(out / "rut_profile.csv", "x_m,settlement_m\n" + "".join(
                    f"{x:.10g},{w:.10g}\n" for x, w in zip(*rut.pop("profile"))))
            else:
                rut.pop("profile")
        except Exception as err:  # noqa: BLE001 - a measurement must not lose the run
            log.warning("rut measurement failed: %s", err)
    if writer is not None:
        try:
            writer.write_deformed()
            if constant_load and rows:
                writer.render_plastic_zone(out / "rut.png", f"rut and plastic zone (displacement x {RUT_PICTURE_SCALE:g})",
                                           displacement_scale=RUT_PICTURE_SCALE)
        except Exception as err:  # noqa: BLE001 - a picture must not lose the run
            log.warning("rut picture failed: %s", err)
        finally:
            writer.close()

    wall = comm.allreduce(time.perf_counter() - t_start, op=MPI.MAX)
    last = rows[-1] if rows else {}
    summary = {
        "status": status,
        "reason": reason,
        "protocol": protocol,
        "scene": scene.to_dict(),
        "wall_time_s": wall,
        "ranks": comm.size,
        "dofs": roll.n_dofs,
        "cells": tagged.stats.cells,
        "steps": len(rows),
        "newton_iterations": roll.newton_iterations,
        "step_cuts": roll.cuts,
        "travel_m": last.get("travel_m", 0.0),
        "sinkage_m": last.get("sinkage_m", 0.0),
        "QV_N": last.get("QV_N", 0.0),
        "QH_N": last.get("QH_N", 0.0),
        "moment_Nm": last.get("moment_Nm", 0.0),
        "rotation_rad": roll.rotation,
        "max_QV_N": max((row["QV_N"] for row in rows), default=0.0),
        "model": {**model_summary(scene, roll), "x_start_m": roll.x_start, "moment_rtol": roll.moment_rtol},
        "files": {"history": "history.csv", "fields": ["fields/fields.xdmf", "fields/deformed.xdmf"]
                  if write_fields else [], "plot": "force_sinkage.png"},
    }
    if constant_load:
        summary["model"].update(stiff_zone_end_m=x_soft, load_rtol=roll.load_rtol, steady_rtol=steady_rtol,
                                steady_qh_rtol=steady_qh_rtol, steady_min_window_elements=min_window_elements,
                                steady_min_travel_m=min_travel)
        if steady is not None:
            summary["steady_state"] = dataclasses.asdict(steady)
            summary.update(sinkage_m=steady.sinkage, QH_N=steady.QH, QV_N=steady.QV)
        if rut is not None:
            summary.update(rut)
            summary["files"]["rut_profile"] = "rut_profile.csv"
        if write_fields:
            summary["files"]["rut_picture"] = "rut.png"
        summary["files"]["travel_plot"] = "rolling.png"
    else:
        summary["model"].update(initial_sinkage_m=s0, ramp_m=travel if ramp is None else ramp, ramp_rate=rate,
                                ramp_slow_enough=advice is None)
    if diagnostics:
        summary["diagnostics"] = diagnostics
    if root and rows:
        try:
            _plot_travel(out / "rolling.png", rows, scene, summary, out / "rut_profile.csv")
        except Exception as err:  # noqa: BLE001
            log.warning("travel plot failed: %s", err)
    return finish_run(out, rows, scene, summary, comm, progress=progress)


#: stiff start zone of the constant-load protocol, x / d (report: 0.75 d, wheel starting at 0.4 d)
STIFF_LENGTH = 0.75
#: fastest sinkage ramp of the continuous protocol shown to be slow enough (s per unit travel,
#: = s/d per d): halving it from 0.02 to 0.01 changed Q_V at s/d = 0.05 by +1.7 %
#: (``benchmarks/bench_rolling.py``, README "Ramp rate of the continuous protocol")
VERIFIED_RAMP_RATE = 0.02
#: displacement magnification of the rut picture
RUT_PICTURE_SCALE = 5.0


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


def _rut(roll: WheelRolling, steady: SteadyState | None, x_soft: float | None, contact_length: float) -> dict:
    """Rut depth and rebound from the surface profile on the wheel path once the wheel has been
    lifted off (:meth:`WheelRolling.lift`; collective).

    Window: from the start of the steady-state window (or the soft soil + half a contact length)
    to half a contact length behind the wheel centre (soil that the wheel has rolled over)."""
    xs, w = roll.surface_profile()
    L = contact_length
    x_now = roll.position
    lo = (x_soft if x_soft is not None else roll.x_start) + 0.5 * L
    if steady is not None and steady.reached:
        lo = max(lo, roll.x_start + steady.travel - steady.window)
    hi = x_now - 0.5 * L
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


def _plot_travel(path: pathlib.Path, rows, scene, summary: dict, rut_csv: pathlib.Path) -> None:
    """Sinkage and Q_H against travel (and the rut profile for the constant-load protocol)."""
    import io

    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from .run import _atomic_write
    x = np.array([r["travel_m"] for r in rows])
    s = np.array([r["sinkage_m"] for r in rows])
    qh = np.array([r["QH_N"] for r in rows]) / 1e3
    qv = np.array([r["QV_N"] for r in rows]) / 1e3
    x0 = summary["model"]["x_start_m"]
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    ax1.plot(x0 + x, 1e3 * s, "o-", ms=2.5, label="sinkage under the wheel")
    if rut_csv.exists():
        prof = np.loadtxt(rut_csv, delimiter=",", skiprows=1, ndmin=2)
        if prof.size:
            ax1.plot(prof[:, 0], 1e3 * prof[:, 1], "-", color="0.4", label="surface settlement (rut) on the path")
    st = summary.get("steady_state")
    if st and st.get("reached"):
        ax1.axhline(1e3 * st["sinkage"], color="C3", lw=0.8, ls="--", label=f"steady s = {1e3 * st['sinkage']:.1f} mm")
    if summary.get("rut_depth_m") is not None:
        ax1.axhline(1e3 * summary["rut_depth_m"], color="0.4", lw=0.8, ls=":",
                    label=f"rut depth {1e3 * summary['rut_depth_m']:.1f} mm")
    zone = summary["model"].get("stiff_zone_end_m")
    for ax in (ax1, ax2):
        if zone:
            ax.axvspan(0, zone, color="0.9", zorder=0)
        ax.grid(alpha=0.3)
    ax1.set_ylabel("sinkage / settlement (mm)")
    ax1.invert_yaxis()
    ax1.legend(fontsize=8, loc="lower right")
    ax2.plot(x0 + x, qh, "o-", ms=2.5, color="C1", label="Q_H (towing force)")
    ax2.plot(x0 + x, qv, "-", color="C0", lw=0.8, label="Q_V")
    ax2.set_xlabel("wheel centre x (m)" + ("  (grey: stiff start zone)" if zone else ""))
    ax2.set_ylabel("force (kN)")
    ax2.legend(fontsize=8)
    d = scene.wheel.diameter
    fig.suptitle(f"{summary['protocol']}: rigid {scene.wheel.shape} d = {d:g} m, b = {scene.wheel.width:g} m, "
                 f"mu = {scene.wheel.friction:g}" + ("" if summary["status"] == "ok" else f" [{summary['status']}]"),
                 fontsize=10)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=120)
    plt.close(fig)
    _atomic_write(path, buf.getvalue(), binary=True)


class TravelProgress:
    """Progress of a rolling run on rank 0: a bar with travel, sinkage and forces, one log line
    per step (readable in files and under mpirun), with the mean step time and an estimate of
    the time left for the travel."""

    def __init__(self, travel: float, d: float, enabled: bool = True, width: int = 24):
        self.travel, self.d, self.enabled, self.width = travel, d, enabled, width
        self.t0 = time.perf_counter()

    def update(self, st: RollingStep) -> None:
        if not self.enabled:
            return
        frac = min(max(st.travel / self.travel, 0.0), 1.0)
        filled = int(round(frac * self.width))
        elapsed = time.perf_counter() - self.t0
        eta = (f", <= {elapsed * (1 - frac) / frac / 60:.1f} min left" if frac > 0.02 else "")
        log.info("[%s%s] %3.0f%%  x = %.3f m  s = %.2f mm (s/d %.4f)  Q_V = %.2f kN  Q_H = %.2f kN  M = %.2g N m  "
                 "%d its/%d trials%s", "#" * filled, "." * (self.width - filled), 100 * frac, st.travel,
                 1e3 * st.sinkage, st.sinkage / self.d, st.QV / 1e3, st.QH / 1e3, st.moment, st.iterations,
                 st.trials, eta)
