"""Towed pneumatic tire at constant load: the inflated tire pressed to the load on the stiff start
zone, then towed along +x with its hub load held and zero torque on its axle.

The half model (tire and block cut at y = 0) of :class:`~rollsim.solver.pneumatic.PneumaticIndentation`.
Each travel step moves the hub by ``dx`` and finds its height ``z`` and rotation ``theta`` (the
bead turns with the hub as a rigid body) for which the soil carries the load and the hub's
reaction moment about the axle vanishes::

    G(z, theta) = ((Q_V - Q) / Q, M / (Q d)) = 0

``M`` is the moment of the bead's reactions (every residual term, the inflation pressure
included; the air's pressure on the circular rim has no moment about the axle).  ``G`` is solved
by a quasi-Newton loop around the soil-and-tire Newton solve: its 2 x 2 Jacobian is taken by
differences at the first rolled step and updated (Broyden) at every move after, so a step
takes few solves (see docs/verification.md, "Pneumatic tire on soil"), each started from the last one's displacement with the plastic
history of the last converged step.  A step whose solve fails or whose balance is not found is
retried with half the travel.
"""
from __future__ import annotations

import math
import time
from typing import Callable

import numpy as np
from dolfinx import fem

from rollsim.geometry import STIFF_ZONE_TAG
from rollsim.geometry.tire import TIRE_CELL_TAGS
from rollsim.log import get_logger

from .pneumatic import PneumaticIndentation
from .rolling import RollingStep, SteadyState, detect_steady_state, surface_profile, with_stiff_zone
from .stepping import SolverDivergedError, StepControl, check_interrupt

__all__ = ["PneumaticRolling", "ROLLING_PETSC_OPTIONS"]

log = get_logger("solver")

#: the towed tire's PETSc options (a scene's ``petsc_options`` add to them)
ROLLING_PETSC_OPTIONS = {"snes_linesearch_type": "bt"}


class PneumaticRolling(PneumaticIndentation):
    """A pneumatic tire towed over the soil of ``tagged`` (half model: :func:`~rollsim.geometry.build_tire_on_soil`
    of a half :class:`~rollsim.geometry.PneumaticTire` over a half rolling block).

    Arguments as :class:`PneumaticIndentation` (``petsc_options`` added to
    :data:`ROLLING_PETSC_OPTIONS`); the stiff start zone (tag ``STIFF_ZONE_TAG``) is
    elastic with 10x the top layer's modulus unless ``soil`` names it.  ``load_rtol`` /
    ``moment_rtol``: tolerances of the load and of the axle moment (relative to ``Q`` and ``Q d``).
    """

    def __init__(self, tagged, tire, soil, carcass, *, load_rtol: float = 2e-3, moment_rtol: float = 2e-3,
                 petsc_options: dict | None = None, **kw):
        if tire.cut != "half":
            raise ValueError(f"a rolling tire is a half model (cut 'half'), got {tire.cut!r}")
        soil_tags = [t for n, t in tagged.cell_names.items() if n not in TIRE_CELL_TAGS and t != STIFF_ZONE_TAG]
        layers = soil if isinstance(soil, dict) else {tag: soil for tag in soil_tags}
        # backtracking: with the tread sticking to a stiff soil, full Newton steps cycle between
        # stick and slip (a towed tire on an elastic soil failed steps of 1/8 element without it)
        options = {**ROLLING_PETSC_OPTIONS, **(petsc_options or {})}
        super().__init__(tagged, tire, with_stiff_zone(tagged, layers), carcass, petsc_options=options, **kw)
        self.load_rtol, self.moment_rtol = float(load_rtol), float(moment_rtol)
        self.x_start = tire.x_centre
        # the virtual rotation of the bead about the axle: e_y x (x - x_axle), on the bead only
        self._spin = fem.Function(self.problem.V)
        self._jacobian: np.ndarray | None = None        # dG/d(z, theta) of the last rolled step
        self._rate = np.array([0.0, 2.0 / tire.diameter])   # (dz/dx, dtheta/dx) of the last step
        #: converged rolled steps (whole-wheel forces)
        self.roll_steps: list[RollingStep] = []
        self._rotation_start = 0.0

    # ------------------------------------------------------------------ readings
    @property
    def travel(self) -> float:
        """The hub's travel from its start, m."""
        return float(self.hub[0])

    @property
    def cuts(self) -> int:
        """Step cuts so far, of the press and of the rolled steps."""
        return int(sum(st.cuts for st in self.steps) + sum(st.cuts for st in self.roll_steps))

    def axle_moment(self) -> float:
        """Moment about the axle of the bead's reactions (whole wheel, N m; positive about +y)."""
        arm = self._bead_arm
        c, s = math.cos(self.hub_rotation), math.sin(self.hub_rotation)
        dx, dz = c * arm[:, 0] + s * arm[:, 2], -s * arm[:, 0] + c * arm[:, 2]   # the arm turned
        w = self._spin.x.array.reshape(-1, 3)
        w[:] = 0.0
        w[self._bead, 0], w[self._bead, 2] = dz, -dx
        return self.factor * self.problem.internal_force(self._spin, every_term=True)

    def _balance(self, load: float) -> np.ndarray:
        return np.array([(self.wheel_load() - load) / load, self.axle_moment() / (load * self.diameter)])

    def _balanced(self, g: np.ndarray) -> bool:
        return abs(g[0]) <= self.load_rtol and abs(g[1]) <= self.moment_rtol

    # ------------------------------------------------------------------ rolling
    def _pose(self) -> np.ndarray:
        return np.array([self.hub[2], self.hub_rotation])

    def _set_pose(self, x: float, q: np.ndarray) -> None:
        self._place_hub(np.array([x, 0.0, q[0]]), float(q[1]))

    def _solve_at(self, x: float, q: np.ndarray, load: float):
        """Solve with the hub at travel ``x`` and pose ``q``: (converged, G, iterations)."""
        self._set_pose(x, q)
        rep = self.problem.solve_increment()
        g = self._balance(load) if rep.converged else None
        log.debug("  tire at travel %.5g m, hub z %.6g m, rotation %.6g: %s, %d its, G = %s, |F| %s", x, q[0], q[1],
                  "converged" if rep.converged else "not converged", rep.iterations, g,
                  " ".join(f"{r:.1e}" for r in rep.residual_norms))
        return rep.converged, g, rep.iterations

    def _rolled_step(self, x: float, load: float, max_solves: int = 16) -> tuple[str, int]:
        """Balance the tire at travel ``x`` from the last converged state: (outcome, Newton
        iterations), outcome ``"ok"``, ``"newton"`` (a solve failed) or ``"balance"`` (not found in
        ``max_solves`` solves).  Leaves the balanced iterate in the problem (not committed)."""
        x0, q0 = self.travel, self._pose()
        q = q0 + self._rate * (x - x0)
        its = solves = 0
        ok, g, n = self._solve_at(x, q, load)
        its, solves = its + n, solves + 1
        if not ok:
            return "newton", its
        if self._jacobian is None:           # by differences, once: a lower hub, a forward turn
            J = np.zeros((2, 2))
            for k, delta in enumerate((-1e-3 * self.diameter, 1e-3)):
                dq = np.zeros(2)
                dq[k] = delta
                ok, gk, n = self._solve_at(x, q + dq, load)
                its, solves = its + n, solves + 1
                if not ok:
                    return "newton", its
                J[:, k] = (gk - g) / delta
            self._jacobian = J
            self._set_pose(x, q)
        J = self._jacobian
        while not self._balanced(g):
            if solves >= max_solves:
                log.debug("  tire balance not found in %d solves: G = %s", solves, g)
                return "balance", its
            try:
                dq = -np.linalg.solve(J, g)
            except np.linalg.LinAlgError:
                return "balance", its
            dq[0] = float(np.clip(dq[0], -0.01 * self.diameter, 0.01 * self.diameter))
            dq[1] = float(np.clip(dq[1], -0.02, 0.02))
            ok, g_new, n = self._solve_at(x, q + dq, load)
            its, solves = its + n, solves + 1
            if not ok:
                return "newton", its
            J += np.outer(g_new - g - J @ dq, dq) / float(dq @ dq)     # Broyden
            q, g = q + dq, g_new
        return "ok", its

    def roll_at_load(self, load: float, travel: float, step: float, *, x_soft: float | None = None,
                     steady_rtol: float = 0.02, steady_qh_rtol: float = 0.05, min_travel: float = 0.0,
                     run_out: float = 1.0, max_cuts: int = 8,
                     on_step: Callable[[RollingStep], None] | None = None) -> SteadyState:
        """Tow the tire up to ``travel`` (m) in steps of ``step`` (m) at the wheel load ``load`` (N)
        with zero axle torque (after :meth:`press_to_load`).  Steady state as for the rigid wheel
        (:func:`~rollsim.solver.rolling.detect_steady_state`: sinkage and ``Q_H`` trends over one
        contact length beyond ``x_soft`` + ``min_travel``); the tire then rolls ``run_out``
        windows further and stops.  A failed step is retried with half the travel, at most
        ``max_cuts`` times in a row (then :class:`SolverDivergedError`, last converged state kept);
        after a cut the steps grow back by 1.5x per converged step up to 3/4 of the travel that
        failed, and to ``step`` after 5 converged steps in a row."""
        if not load > 0 or not travel > 0 or not step > 0:
            raise ValueError(f"load, travel and step must be > 0, got {load}, {travel}, {step}")
        x_soft = self.x_start if x_soft is None else float(x_soft)
        pb, found, stop_at = self.problem, None, math.inf
        self._rotation_start = self.hub_rotation
        dx, cuts, cap, streak = step, 0, math.inf, 0
        while self.travel < min(travel, stop_at) - 1e-9 * step:
            check_interrupt(self.comm, f"at travel {self.travel:.4g} m")
            x0, q0 = self.travel, self._pose()
            x = min(x0 + dx, travel)
            t0, solves0 = time.perf_counter(), pb.timings["linear_solves"]
            outcome, its = self._rolled_step(x, load)
            if outcome != "ok":
                pb.restore()
                self._set_pose(x0, q0)
                if outcome == "balance":           # differences again at the shorter step
                    self._jacobian = None
                cuts, cap, streak = cuts + 1, 0.75 * (x - x0), 0
                if cuts > max_cuts:
                    raise SolverDivergedError(f"towed tire: no balanced step after {max_cuts} cuts at travel "
                                              f"{x0:.4g} m", None, [])
                dx *= 0.5
                log.info("tire step to travel %.4g m failed: travel step cut to %.3g m", x, dx)
                continue
            pb.commit()
            self._rate = (self._pose() - q0) / (x - x0)       # the next step's predictor
            st = self._record(x - x0, self.hub_rotation - q0[1], its, int(pb.timings["linear_solves"] - solves0),
                              cuts, time.perf_counter() - t0)
            streak += 1
            cap = math.inf if streak >= 5 else cap
            cuts, dx = 0, min(step, 1.5 * dx, cap)
            if on_step is not None:
                on_step(st)
            if found is None:
                window = max(self.contact_length(), 3 * self.contact.h)
                found = detect_steady_state(self.roll_steps, 0.0, x_soft - self.x_start, window, steady_rtol,
                                            steady_qh_rtol, min_travel)
                if found is not None:
                    stop_at = st.travel + run_out * found.window
                    log.info("steady state at travel %.3f m: s = %.5f m, Q_H = %.3f kN; rolling %.3f m more",
                             st.travel, found.sinkage, found.QH / 1e3, run_out * found.window)
        if found is not None:
            return found
        last = self.roll_steps[-1]
        return SteadyState(False, last.travel, last.sinkage, last.QV, last.QH, self.contact_length(),
                           math.nan, math.nan)

    def rolling_radius(self, x_from: float) -> float | None:
        """The tire's rolling radius, m: its travel per unit of rotation over the rolled steps with
        the axle at or beyond ``x_from`` (m; None: fewer than two such steps)."""
        steps = [st for st in self.roll_steps if self.x_start + st.travel >= x_from]
        if len(steps) < 2 or not steps[-1].rotation > steps[0].rotation:
            return None
        return (steps[-1].travel - steps[0].travel) / (steps[-1].rotation - steps[0].rotation)

    @property
    def position(self) -> float:
        """x of the axle now, m."""
        return self.x_centre + float(self.hub[0])

    def surface_profile(self) -> tuple[np.ndarray, np.ndarray]:
        """The soil surface on the mid-plane: :func:`~rollsim.solver.rolling.surface_profile` (the
        tire's nodes lie above the undisturbed surface in the reference mesh)."""
        return surface_profile(self.problem, self.comm, self.diameter)

    def lift(self) -> list:
        """Lift the hub vertically until the tire is clear of the soil (displacement control in
        four steps, by the sinkage plus the deflection plus 0.1 % of the radius): the carcass
        recovers its shape, the soil rebounds and keeps only the permanent rut."""
        state = self.tire_state()
        rise = max(state["sinkage_m"], 0.0) + max(state["deflection_m"], 0.0) + 5e-4 * self.diameter
        return self.press(-rise, StepControl(t_end=1.0, dt=0.25, dt_min=1e-3, dt_max=0.25, max_cuts=8))

    def contact_length(self) -> float:
        """Contact length along the travel now, m (at least one contact element)."""
        return max(self._patch_length(self.contact.contact_points()[0]), self.contact.h)

    def _record(self, dx: float, dth: float, its: int, solves: int, cuts: int, wall: float) -> RollingStep:
        F = self.contact.forces()
        st = RollingStep(step=len(self.steps) + len(self.roll_steps) + 1, travel=self.travel,
                         sinkage=-self.lowest_point(), QV=self.factor * float(F.force[2]),
                         QH=-self.factor * float(F.force[0]), moment=self.axle_moment(),
                         rotation=self.hub_rotation - self._rotation_start, slip=1.0 - 0.5 * self.diameter * dth / dx,
                         contact_area=self.factor * self.contact.contact_area(),
                         max_penetration=F.max_penetration, iterations=its, linear_solves=solves, cuts=cuts,
                         plastic=int(self.comm.allreduce(int(np.sum(self.problem.state != 0)))), time=wall)
        self.roll_steps.append(st)
        return st
