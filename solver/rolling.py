"""Towed rigid wheel rolling over elastoplastic soil: the mechanics of both rolling protocols
(the drivers are ``rollsim.solver.drivers.rolling_continuous`` and ``rolling_constant_load``).

Set-up: half model about the wheel mid-plane (``rolling_block(cut="half")``), gravity step, wheel placed at ``x0 = ROLLING_START d``
and pressed vertically to a small initial sinkage ``s0``, then translated in +x while its sinkage
is ramped slowly (linearly in travel) to the target; every instant is then close to steady
rolling and one run gives ``Q_V(s)`` and ``Q_H(s)``.

Kinematics of a step (pseudo-time = travel, m): the centre moves by ``dx`` and its height follows
the ramp; the wheel is **towed** (free to rotate, zero axle torque), so its rotation increment
``dtheta`` is an unknown fixed by the torque balance ``M = 0``.  ``M`` is the moment of the
contact tractions about the axle; normal pressures pass through the axle (the wheel surface is a
surface of revolution), so only friction makes a moment.  At constant load the axle height is a
second unknown, fixed by ``Q_V = load``.  These pose unknowns are solved with the soil's
displacement in one Newton system (a bordered system: the exact derivatives of the contact
residual, of ``M`` and of ``Q_V`` with respect to displacement and pose, see
:meth:`~rollsim.solver.contact.RigidWheelContact.pose_derivatives`), to
``|M| <= moment_rtol * Q_V * d`` and ``|Q_V - load| <= load_rtol * load``.  Predictor: the
previous step's ratio ``dtheta R / dx`` (1 = rolling without slip on a rigid surface) and sinkage
rate.  Frictionless: the rotation does not enter the equations and is not solved for.

The pose solve is wrapped as the ``solve_increment`` of a proxy problem, so the travel
steps reuse :func:`~rollsim.solver.stepping.solve_load_path` unchanged (step cutting on failure,
growth after easy steps, guards).

Forces are for the whole wheel (twice the half model); ``Q_H`` is the towing force (rolling
resistance), > 0 for a wheel moving in +x.
"""
from __future__ import annotations

import json
import math
import pathlib
import time
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np
from mpi4py import MPI

from rollsim import compat
from rollsim.files import atomic_write_text
from rollsim.log import get_logger

from .contact import PoseDerivatives, contact_cell_size
from .indentation import LoadControlResult, WheelIndentation
from .options import check_relaxation_length
from .problem import NewtonReport
from .stepping import (RelaxationFallback, SolverDivergedError, StepControl, advance_with_fallback, solve_load_path,
                       straight_path)

__all__ = ["WheelRolling", "RollingStep", "with_stiff_zone", "SteadyState", "detect_steady_state",
           "surface_profile", "DEFAULT_ROLL_CONTROL", "STEADY_MIN_TRAVEL", "constant_load_control"]

log = get_logger("solver")

#: travel stepping, in units of four travel steps (on tetrahedra the contact element's diameter;
#: scaled in :meth:`WheelRolling.roll`)
DEFAULT_ROLL_CONTROL = dict(dt=0.25, dt_min=1e-3, dt_max=0.5, easy_iterations=8, max_cuts=8, grow=1.5)
#: constant load: travel of the wheel centre on the test soil (past the stiff start zone), in d,
#: before steady state is looked for.  Leaving the stiff zone the wheel overshoots, and one
#: window on the overshoot's plateau can look steady; the value is set from fast-preset runs (see
#: docs/limitations.md, "Other limits of the finite-element model")
STEADY_MIN_TRAVEL = 0.75


def constant_load_control(travel: float, dx: float) -> StepControl:
    """Constant-load stepping over ``travel`` (m) in steps of ``dx`` (m), back to the full step
    after a cut (no growth beyond it)."""
    return StepControl(t_end=travel, dt=dx, dt_min=4e-3 * dx, dt_max=dx, max_cuts=8, easy_iterations=10**6)


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
    iterations: int        # Newton iterations of the accepted step
    linear_solves: int     # linear solves of the accepted step (1 + unknowns of the pose per iteration)
    cuts: int
    plastic: int
    time: float


def surface_profile(problem, comm: MPI.Comm, length: float) -> tuple[np.ndarray, np.ndarray]:
    """``(x, settlement)`` of the soil surface on the mid-plane (nodes at y = 0, z = 0 of the
    reference mesh) of ``problem``'s last converged state, m, sorted by x, identical on all ranks
    (settlement > 0 downwards, relative to the state after gravity; ``length``: the scale of the
    node search, m)."""
    V = problem.V
    n = V.dofmap.index_map.size_local
    bs = V.dofmap.index_map_bs
    X = V.tabulate_dof_coordinates()[:n]
    tol = 1e-8 * length
    on_line = (np.abs(X[:, 1]) < tol) & (np.abs(X[:, 2]) < tol)
    uz = problem.u_n.x.array[: n * bs].reshape(n, bs)[on_line, -1]
    xs = np.concatenate(comm.allgather(X[on_line, 0]))
    ws = np.concatenate(comm.allgather(-uz))
    xs, keep = np.unique(np.round(xs, 12), return_index=True)
    return xs, ws[keep]


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
        return self._r._solve_pose()

    def commit(self) -> None:
        self._pb.commit()

    def restore(self) -> None:
        self._pb.restore()


class _PoseBorder:
    """Pose unknowns of a rolling step for :meth:`PlasticityProblem.solve_increment`: the axle
    height (equation ``Q_V = target load``) and the rotation (equation ``M = 0``).  Equations are
    divided by the symmetry factor (they are written for the modelled part of the wheel).

    ``M`` is not smooth in the rotation (stiff where the contact sticks, nearly flat where it
    slips), and far from equilibrium the coupled step can overshoot.  The pose is therefore held
    at the predictor until the force residual has dropped to ``HOLD_RTOL`` of its initial value
    (plain Newton iterations on the soil), an iteration turns the wheel by at most a quarter of
    the step's rolling rotation ``dx / R`` and moves the axle by at most 5 % of a contact
    element, and the problem's backtracking line search weighs ``M / R`` and ``Q_V`` with the
    soil's residual.  ``HOLD_RTOL`` is chosen on the test blocks of ``tests/test_rolling.py``,
    against holding the pose never or to convergence and against a nested torque iteration
    (measured: see docs/benchmarks.md, "Rolling cost").

    The relative hold releases the height too early after a translation (whose initial residual
    is large): the soil's pending correction then dominates the coupled step, which moves the
    axle the wrong way and is cut short by the line search.  Without friction (height the only
    unknown) the pose is also held until the force residual is below ``HOLD_LOAD_FRACTION`` of
    the load, which saves Newton iterations and cuts at the same sinkage.  With friction (the
    rotation also unknown) the bound does not pay and is off (measured: see
    docs/benchmarks.md, "Rolling cost")."""

    HOLD_RTOL = 0.1
    HOLD_LOAD_FRACTION = 0.1

    def __init__(self, rolling: "WheelRolling", *, rotation: bool, height: bool, hold_rtol: float = HOLD_RTOL):
        self._r = rolling
        self._ct = rolling.contact
        self.unknowns = (("height",) if height else ()) + (("angle",) if rotation else ())
        self.quantities = ("vertical_force", "moment") if rotation else ("vertical_force",)
        self._rows = ([0] if height else []) + ([1] if rotation else [])
        self.merit_weights = np.array([1.0 if row == 0 else 1.0 / rolling.R for row in self._rows])
        self.size = len(self.unknowns)
        self.hold_rtol = float(hold_rtol)
        self._target = np.array([rolling.target_load or 0.0, 0.0]) / rolling.factor
        h = self._ct.h
        self._cap = np.array([0.05 * h if u == "height" else 0.25 * abs(rolling._step_dx) / rolling.R
                              for u in self.unknowns])
        self._QV = 0.0
        self.hold_force = (self.HOLD_LOAD_FRACTION * (rolling.target_load or 0.0) / rolling.factor
                           if height and not rotation else math.inf)

    def evaluate(self) -> PoseDerivatives:
        der = self._ct.pose_derivatives(self.quantities, self.unknowns)
        self._QV = self._r.factor * der.values[0]
        rows = self._rows
        return PoseDerivatives(values=der.values[rows] - self._target[rows], d_pose=der.d_pose[rows],
                               d_displacement=[der.d_displacement[i] for i in rows],
                               residual_d_pose=der.residual_d_pose)

    def satisfied(self, values: np.ndarray) -> bool:
        r, f = self._r, self._r.factor
        tol = {0: r.load_rtol * (r.target_load or 0.0), 1: r.moment_rtol * abs(self._QV) * r.d}
        return all(abs(f * g) <= tol[row] for g, row in zip(values, self._rows))

    def limit(self, dq: np.ndarray) -> np.ndarray:
        return np.clip(dq, -self._cap, self._cap)

    def move(self, dq: np.ndarray) -> None:
        self._ct.move_pose(self.unknowns, dq)


def with_stiff_zone(tagged, materials, stiff_material=None) -> dict:
    """``{cell tag: material}`` of ``materials`` (one material: the layer tag 1), with the stiff
    start zone (tag ``STIFF_ZONE_TAG``) when the mesh has one and ``materials`` does not name it:
    ``stiff_material``, by default elastic with 10x the top layer's modulus."""
    from rollsim.geometry import STIFF_ZONE_TAG
    mats = dict(materials) if isinstance(materials, dict) else {1: materials}
    if STIFF_ZONE_TAG in tagged.cell_names.values() and STIFF_ZONE_TAG not in mats:
        if stiff_material is None:
            from .materials import VonMises
            top = mats[min(mats)]
            stiff_material = VonMises(E=10 * top.E, nu=top.nu, yield_stress=1e12)
        mats[STIFF_ZONE_TAG] = stiff_material
    return mats


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
    (see :func:`~rollsim.solver.return_map.duvaut_lions`); ``travel_relaxation_fallback`` (m, 0: off):
    the relaxation length a roll falls back to when Newton fails after step cutting on the
    unregularised soil: the roll starts over from where it began, relaxed to its end (the vertical
    moves fall back to ``relaxation_fallback`` as :meth:`WheelIndentation.push`); other keywords as
    :class:`WheelIndentation`.
    """

    #: the pose solve's attempts before a step is cut, by the ``hold_rtol`` of each (see
    #: :meth:`_solve_pose`).  A second attempt with the pose held until the soil has converged
    #: (``(0.1, 0.0)``) rarely rescues a failed solve and costs Newton iterations
    #: (``python -m benchmarks rolling retry``; measured: see docs/benchmarks.md, "Rolling cost"):
    #: cutting at once is cheaper.
    POSE_HOLDS: tuple[float, ...] = (_PoseBorder.HOLD_RTOL,)

    def __init__(self, tagged, wheel, materials, *, gamma: float = 0.0, friction: float = 0.0,
                 x_start: float | None = None, moment_rtol: float = 2e-3,
                 stiff_material=None, petsc_options: dict | None = None, penalty: float | None = None,
                 relaxation_length: float = 0.0, travel_relaxation_fallback: float = 0.0, **kw):
        from rollsim.geometry import ROLLING_START
        mats = with_stiff_zone(tagged, materials, stiff_material)
        self.d = wheel.diameter
        self.R = wheel.diameter / 2
        self.width = wheel.width
        self.x_start = ROLLING_START * self.d if x_start is None else float(x_start)
        # WheelIndentation builds the problem, the boundary conditions (rear/front/side/bottom normal
        # displacement, symmetry_y) and the contact; its pose helpers (x = 0) are not used here
        self._ind = WheelIndentation(tagged, wheel, mats if len(mats) > 1 else next(iter(mats.values())),
                                     gamma=gamma, friction=friction, petsc_options=petsc_options,
                                     penalty=penalty, relaxation_length=relaxation_length, **kw)
        self.tagged = tagged
        self.comm = tagged.mesh.comm
        self.problem = self._ind.problem
        self.contact = self._ind.contact
        self.factor = self._ind.factor
        self.n_dofs = self._ind.n_dofs
        self.friction = float(friction)
        self.travel_relaxation_fallback = check_relaxation_length(travel_relaxation_fallback)
        #: ``(from, to)`` travel (m) of each stretch a roll relaxed after a failure
        self.relaxed_travel: list[tuple[float, float]] = []
        #: travel (m) at which each roll that started over relaxed had failed rate-independent
        self.travel_failures: list[float] = []
        self._roll_relaxation = 0.0              # m: the fallback relaxation the last roll ended with
        self.moment_rtol = float(moment_rtol)
        self.steps: list[RollingStep] = []
        self.target_load: float | None = None   # N, whole wheel: set by roll_at_load
        self.load_rtol = 2e-3
        self._sink_rate = 0.0                    # predictor: ds/dx of the last step
        self.slip_ratio = 0.0           # predictor: slip of the last step
        self._step_dx = 0.0             # translation of the step being solved
        self._its = 0
        self._solves = 0
        self._attempts = 0
        self._t_last = time.perf_counter()
        self.hexahedral = compat.cell_name(tagged.mesh) == "hexahedron"
        self.travel_step = self._travel_step(tagged)
        self.contact.set_pose(centre=self._centre(self.x_start, 0.0), angle=0.0)

    def _travel_step(self, tagged) -> float:
        """The constant-load travel step, m: a quarter of the contact element's diameter on
        tetrahedra, a fifth of its length along the travel on hexahedra; about five steps per
        element along the travel on either (a quarter of a hexahedron's diameter, its space
        diagonal, gives about 2.5 and samples the element-passing ripple unevenly)."""
        if not self.hexahedral:
            return 0.25 * self.contact.h
        return 0.2 * contact_cell_size(tagged.mesh, tagged.facet_tags, self.contact.contact_ids, axis=0)

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

    def write_checkpoint(self, path) -> None:
        """Write the converged state to the directory ``path``: the soil's state and the wheel's
        pose as :meth:`WheelIndentation.write_checkpoint`, then ``rolling.json`` (the rolling steps
        and the predictors of the next step), replaced atomically by rank 0.  Call it between
        steps (from ``on_step``) or between protocols; :meth:`read_checkpoint` continues from it."""
        path = pathlib.Path(path)
        self._ind.write_checkpoint(path)
        if self.comm.rank == 0:
            meta = {"position": self.position, "newton_iterations": self.newton_iterations,
                    "slip_ratio": self.slip_ratio, "sink_rate": self._sink_rate,
                    "steps": [vars(s) for s in self.steps]}
            atomic_write_text(path / "rolling.json", json.dumps(meta, indent=1))
        self.comm.barrier()

    def read_checkpoint(self, path) -> int:
        """Continue from a :meth:`write_checkpoint` directory on the same mesh, with any number of
        ranks (call after :meth:`gravity_step`); a roll then goes on from the stored position and
        sinkage.  Returns the Newton iterations of the run that wrote it.  Raises ``ValueError``
        naming what does not match."""
        path = pathlib.Path(path)
        if not (path / "rolling.json").exists():
            raise ValueError(f"checkpoint {path}: no rolling.json (not written by a rolling wheel)")
        self._ind.read_checkpoint(path)
        meta = json.loads((path / "rolling.json").read_text())
        if abs(meta["position"] - self.position) > 1e-9 * self.d:
            raise ValueError(f"checkpoint {path}: rolling.json is at x = {meta['position']:.6f} m, state.npz at "
                             f"{self.position:.6f} m (interrupted while writing)")
        self.steps[:] = [RollingStep(**s) for s in meta["steps"]]
        self.slip_ratio, self._sink_rate = meta["slip_ratio"], meta["sink_rate"]
        return int(meta["newton_iterations"])

    @property
    def newton_iterations(self) -> int:
        return self._ind.newton_iterations

    @property
    def rolling(self) -> bool:
        """True while :meth:`roll` moves the wheel (not in a press or the lift-off)."""
        return self._rolling

    @property
    def relaxation_length(self) -> float:
        """Duvaut-Lions relaxation length, m (0: off); the press at constant load uses it too."""
        return self._ind.relaxation_length

    @property
    def relaxed_spans(self) -> list[tuple[float, float]]:
        """Sinkage stretches (m) the vertical moves (press, press to load) relaxed after a failure."""
        return self._ind.relaxed_spans

    @property
    def cuts(self) -> int:
        return int(sum(st.cuts for st in self.steps))

    # ------------------------------------------------------------------ protocols
    def gravity_step(self) -> None:
        """:meth:`WheelIndentation.gravity_step` at the start position (wheel held clear of the
        soil during the solve, then placed on the surface)."""
        self._ind.x_centre = self.x_start
        self._ind.gravity_step()

    def press(self, s0: float, control: StepControl | None = None,
              on_step: Callable[[RollingStep], None] | None = None) -> list[RollingStep]:
        """Vertical push at the current position to the sinkage ``s0`` (m), displacement control."""
        control = control or StepControl(t_end=1.0, dt=0.25, dt_min=1e-3, dt_max=0.5, easy_iterations=8,
                                         max_cuts=8)
        if s0 <= self.sinkage:
            return self.steps
        return self._move_vertically(s0, control, on_step)

    def _move_vertically(self, s_to: float, control: StepControl, on_step) -> list[RollingStep]:
        """Displacement-controlled vertical move of the wheel from the current sinkage to ``s_to``;
        downwards with the relaxation fallback of :meth:`WheelIndentation.push`."""
        x, th = self.position, self.rotation

        def on_t(t):
            st = self._record(dx=0.0, dth=0.0)
            if on_step is not None:
                on_step(st)
            return {"QV": st.QV}

        def place(s):
            self._attempts += 1
            self.problem.relax_over(abs(s - self.sinkage), self.relaxation_length)
            self.contact.set_pose(centre=self._centre(x, s), angle=th)

        def advance(to: float, c: StepControl) -> None:
            self._run(straight_path(self.sinkage, to, place), c, on_t)

        if s_to > self.sinkage:
            advance_with_fallback(advance, lambda: self.sinkage, [s_to], control, self._ind.fallback(),
                                  self._ind._relax)
        else:
            advance(s_to, control)
        return self.steps

    def roll(self, travel: float, s_target: float, ramp: float | None = None, dx: float | None = None,
             on_step: Callable[[RollingStep], None] | None = None, control: StepControl | None = None,
             on_start_over: Callable[[int], None] | None = None, predictor: str = "none") -> list[RollingStep]:
        """Translate the wheel by ``travel`` (m) in +x, its sinkage ramped linearly from the current
        value to ``s_target`` over the first ``ramp`` metres of travel (default: all of it), then
        held.  ``dx``: travel step, m (default :attr:`travel_step`, which samples the
        element-passing ripple about five times per element; on tetrahedra it grows to twice
        ``dx`` after easy steps, on hexahedra it stays; cut on divergence and grown back).  After a failure the roll
        starts over relaxed (see ``travel_relaxation_fallback``): the steps it rolled are dropped,
        and ``on_start_over(n)`` is told how many.  ``predictor``: Newton's start in each step with the
        default ``control`` (:class:`StepControl`; ``"extrapolate"`` costs more Newton iterations
        than ``"none"`` on held rolling: see docs/benchmarks.md, "Rolling cost").  Returns all
        steps; ``SolverDivergedError`` (state at the last converged step) on failure."""
        if not travel > 0:
            raise ValueError(f"travel must be > 0, got {travel}")
        ramp = travel if ramp is None else float(ramp)
        if not ramp > 0:
            raise ValueError(f"ramp must be > 0, got {ramp}")
        if control is None:
            c = dict(DEFAULT_ROLL_CONTROL, predictor=predictor)
            h = (self.travel_step if dx is None else dx) / c["dt"]   # the contact element's diameter on tetrahedra
            if not h > 0:
                raise ValueError(f"dx must be > 0, got {dx}")
            if self.hexahedral:
                c["dt_max"] = c["dt"]
            control = StepControl(t_end=travel, **{k: (v * h if k.startswith("dt") else v) for k, v in c.items()})
        x0, s0 = self.position, self.sinkage

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
            st = self._record(dx=self._last_dx, dth=self._last_dth)
            if self._last_dx > 0:
                self.slip_ratio = st.slip
                self._sink_rate = (st.sinkage - s_prev) / self._last_dx
            if on_step is not None:
                on_step(st)
            return {"QV": st.QV, "moment": st.moment}

        def advance(to: float, c: StepControl) -> None:
            self._run(set_load, replace(c, t_end=to), on_t, t_start=self.position - x0)

        begun = self.save_state() | {"sink_rate": self._sink_rate}

        def start_over(failed_at: float) -> None:
            dropped = len(self.steps) - begun["n_roll_steps"]
            self.load_state(begun)
            self._sink_rate = begun["sink_rate"]
            self.travel_failures.append(failed_at)
            if on_start_over is not None:
                on_start_over(dropped)

        relaxed_before = len(self.relaxed_travel)
        self._rolling = True
        try:
            # started over and relaxed to the end of the roll: on dense non-associated sand the
            # rate-independent travel up to the failure localises and leaves a heave where the rut
            # belongs, and relaxed stretches between rate-independent ones heave more at several
            # times the Newton iterations (see docs/limitations.md, "Non-associated flow: Newton stalls")
            fallback = RelaxationFallback.unless_relaxed(self.relaxation_length, self.travel_relaxation_fallback,
                                                         math.inf, self.relaxed_travel)
            advance_with_fallback(advance, lambda: self.position - x0, [travel], control, fallback,
                                  self._ind._relax, what="travel", start_over=start_over)
        finally:
            self._rolling = False
            relaxed = len(self.relaxed_travel) > relaxed_before
            self._roll_relaxation = self.travel_relaxation_fallback if relaxed else 0.0
        return self.steps

    def lift(self, on_step: Callable[[RollingStep], None] | None = None) -> list[RollingStep]:
        """Lift the wheel vertically off the soil at the current position (displacement control in
        four steps, to 0.1 % of R above the undisturbed surface): the soil rebounds, and the
        surface keeps only the permanent rut.  After a roll that ended relaxed by its travel
        fallback the soil stays relaxed by the same length through the lift-off (rate-independent,
        the unloading of such a rut diverged on dense sand)."""
        length = self._roll_relaxation
        if length > 0:
            log.info("lift-off relaxed as the roll before it (Duvaut-Lions, %.3g mm)", 1e3 * length)
            self._ind._relax(length)
        try:
            return self._move_vertically(-1e-3 * self.R, StepControl(t_end=1.0, dt=0.25, dt_min=1e-3, dt_max=0.25,
                                                                     max_cuts=8), on_step)
        finally:
            if length > 0:
                self._ind._relax(0.0)

    def press_to_load(self, load: float, sinkage_limit: float,
                      on_step: Callable[[RollingStep], None] | None = None) -> LoadControlResult:
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
                             iterations=ist.iterations, linear_solves=ist.iterations, cuts=ist.cuts, plastic=ist.plastic, time=ist.time)
            self.steps.append(st)
            if on_step is not None:
                on_step(st)
        return res

    def roll_at_load(self, load: float, travel: float, *, x_soft: float | None = None,
                     steady_rtol: float = 0.02, steady_qh_rtol: float = 0.05, run_out: float = 1.0,
                     min_window_elements: float = 3.0, min_travel: float | None = None,
                     on_step: Callable[[RollingStep], None] | None = None,
                     control: StepControl | None = None,
                     on_start_over: Callable[[int], None] | None = None, resumed: bool = False) -> "SteadyState":
        """Roll at constant whole-wheel ``Q_V = load`` (N), towed, up to ``travel`` (m) in +x.

        Each travel step solves the sinkage and the rotation increment for ``Q_V = load`` (to
        ``load_rtol``) and zero axle moment with the soil, in one Newton system.  Steady state (see :func:`detect_steady_state`): once the
        whole window lies on the soil beyond ``x_soft`` (m, the end of the stiff start zone;
        default: the start position), sinkage and ``Q_H`` trends over a window of one contact
        length (at least ``min_window_elements`` contact elements: on coarse meshes the force and
        sinkage ripple as the wheel passes elements) change by less than ``steady_rtol`` /
        ``steady_qh_rtol``; the window counts only once the wheel centre has rolled ``min_travel``
        (m; default :data:`STEADY_MIN_TRAVEL` d) past ``x_soft``, so the overshoot after the stiff
        zone is not taken for steady rolling.  The wheel then rolls ``run_out`` windows further
        (the rut behind it is then unloaded) and stops.  Default ``control``: steps of
        :attr:`travel_step` (after a cut, they grow back by 1.5x per step).  ``on_start_over``: as :meth:`roll`
        (a steady state found before the roll started over is forgotten).  ``resumed``: the rolled
        steps so far (from :meth:`read_checkpoint`) are this roll's: the steady-state search goes
        over them again as it did while they were rolled, and ``travel`` is what is left of it (<= 0:
        none; the search only).  Returns the :class:`SteadyState` (``reached = False`` when ``travel``
        ran out first)."""
        if not load > 0 or not (travel > 0 or resumed):
            raise ValueError(f"load and travel must be > 0, got {load}, {travel}")
        self.target_load = float(load)
        x_soft = self.x_start if x_soft is None else float(x_soft)
        min_travel = STEADY_MIN_TRAVEL * 2 * self.R if min_travel is None else float(min_travel)
        if self.position + travel < x_soft + min_travel:
            log.warning("the travel of %g m ends %.3f m before the wheel has rolled the %.3f m on the test soil "
                        "after which steady state is looked for: no steady state will be detected",
                        travel, x_soft + min_travel - self.position - travel, min_travel)
        found: list[SteadyState] = []
        stop_at = [math.inf]

        def search(st: RollingStep, steps: list[RollingStep]):
            if not found:
                # the element-passing ripple has the period of a contact element: average >= 3 of them
                window = max(self.contact_length(st), min_window_elements * self.contact.h)
                ss = detect_steady_state(steps, self.x_start, x_soft, window, steady_rtol, steady_qh_rtol,
                                         min_travel)
                if ss is not None:
                    found.append(ss)
                    stop_at[0] = st.travel + run_out * ss.window
                    log.info("steady state at travel %.3f m: s = %.5f m, Q_H = %.3f kN (changes %.2g / %.2g "
                             "over %.3f m); rolling %.3f m more for the rut", st.travel, ss.sinkage, ss.QH / 1e3,
                             ss.sinkage_change, ss.QH_change, ss.window, run_out * ss.window)

        def monitor(st: RollingStep):
            if on_step is not None:
                on_step(st)
            search(st, self.steps)
            if st.travel >= stop_at[0] - 1e-12:
                raise _StopRolling

        def started_over(dropped: int):
            found.clear()
            stop_at[0] = math.inf
            if on_start_over is not None:
                on_start_over(dropped)

        if resumed:
            for k, st in enumerate(self.steps):
                if st.travel > 0:
                    search(st, self.steps[:k + 1])
        try:
            if found and self.steps[-1].travel >= stop_at[0] - 1e-12 or travel <= 1e-9 * self.d:
                raise _StopRolling
            self.roll(travel, self.sinkage, on_step=monitor, control=control or constant_load_control(
                travel, self.travel_step), on_start_over=started_over)
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
        """The soil surface on the wheel's mid-plane: :func:`surface_profile`."""
        return surface_profile(self.problem, self.comm, self.d)

    _rolling = False
    _last_dx = 0.0
    _last_dth = 0.0

    # ------------------------------------------------------------------ internals
    def _run(self, set_load, control, on_t, t_start: float = 0.0) -> None:
        pb = _TorqueBalancedProblem(self)
        try:
            solve_load_path(pb, set_load, control, on_t, t_start=t_start)
        except SolverDivergedError:
            c, th = np.array(self.contact.centre_n.value), float(self.contact.angle_n.value)
            self.contact.set_pose(centre=c, angle=th)
            raise
        finally:
            self.problem.relaxation = math.inf

    def _solve_pose(self) -> NewtonReport:
        """Newton solve at the set translation; with friction while rolling the rotation, and at
        constant load the axle height, are unknowns of the same Newton system (zero axle moment,
        ``Q_V`` = target load; see :class:`_PoseBorder`), once per entry of :attr:`POSE_HOLDS`
        from the last converged state until one converges.  Leaves the accepted iterate in the
        problem (not committed)."""
        rotation = self.friction > 0 and self._rolling and self._step_dx > 0
        height = self.target_load is not None
        if not (rotation or height):
            rep = self.problem.solve_increment()
            self._its, self._solves = rep.iterations, rep.linear_solves
            return rep
        th_n = self.rotation
        predictor = self.contact.pose
        its = solves = 0
        for hold in self.POSE_HOLDS:
            border = _PoseBorder(self, rotation=rotation, height=height, hold_rtol=hold)
            rep = self.problem.solve_increment(border)
            its, solves = its + rep.iterations, solves + rep.linear_solves
            if rep.converged:
                break
            log.debug("  pose solve failed (hold_rtol %g, reason %d)", hold, rep.reason)
            self.problem.restore()
            self.contact.set_pose(centre=predictor[0], angle=predictor[1])
        self._its, self._solves = its, solves
        if rep.converged:
            self._last_dx = float(self.contact.centre.value[0]) - self.position
            self._last_dth = float(self.contact.angle.value) - th_n
        return NewtonReport(rep.converged, its, rep.reason, rep.residual_norms, rep.time, rep.counts, solves)

    def _record(self, dx: float, dth: float) -> RollingStep:
        now = time.perf_counter()
        f = self.forces()
        pb = self.problem
        slip = 1.0 - self.R * dth / dx if dx > 0 else 0.0
        st = RollingStep(step=len(self.steps) + 1, travel=self.position - self.x_start, sinkage=self.sinkage,
                         QV=f["QV"], QH=f["QH"], moment=f["moment"], rotation=self.rotation, slip=slip,
                         contact_area=f["contact_area"], max_penetration=f["max_penetration"],
                         iterations=self._its, linear_solves=self._solves, cuts=max(self._attempts - 1, 0),
                         plastic=int(self.comm.allreduce(int(np.sum(pb.state != 0)))), time=now - self._t_last)
        self._t_last = now
        self._attempts = 0
        self.steps.append(st)
        return st
