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

import json
import pathlib
import time
import traceback
from dataclasses import dataclass
from typing import Callable

import numpy as np
from mpi4py import MPI

from rollsim.log import get_logger

from .indentation import WheelIndentation
from .problem import NewtonReport
from .stepping import SolverDivergedError, StepControl, solve_load_path

__all__ = ["WheelRolling", "RollingStep", "run_rolling", "rolling_mesh", "DEFAULT_ROLL_CONTROL"]

log = get_logger("solver")

#: travel stepping, in units of the contact element size h (scaled in :meth:`WheelRolling.roll`)
DEFAULT_ROLL_CONTROL = dict(dt=0.25, dt_min=1e-3, dt_max=0.5, easy_iterations=8, max_cuts=8, grow=1.5)


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


class _TorqueBalancedProblem:
    """Proxy of a PlasticityProblem whose ``solve_increment`` also finds the wheel rotation
    increment with zero axle moment (for ``solve_load_path``)."""

    def __init__(self, rolling: "WheelRolling"):
        self._r = rolling
        self._pb = rolling.problem

    def __getattr__(self, name):
        return getattr(self._pb, name)

    def solve_increment(self) -> NewtonReport:
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
    balance tolerance relative to ``Q_V d``; other keywords as :class:`WheelIndentation`.
    """

    def __init__(self, tagged, wheel, materials, *, gamma: float = 0.0, friction: float = 0.0,
                 x_start: float | None = None, moment_rtol: float = 2e-3, max_trials: int = 12,
                 stiff_material=None, petsc_options: dict | None = None, penalty: float | None = None, **kw):
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
        self.steps: list[RollingStep] = []
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
        x, s_from, th = self.position, self.sinkage, self.rotation
        if s0 <= s_from:
            return self.steps

        def set_load(t):
            self._attempts += 1
            self.contact.set_pose(centre=self._centre(x, s_from + (s0 - s_from) * t), angle=th)

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
            if self.friction > 0:          # iterations are summed over the torque trials (~3 per step)
                c["easy_iterations"] *= 3
            control = StepControl(t_end=travel, **{k: (v * h if k.startswith("dt") else v) for k, v in c.items()})
        x0, s0, th0 = self.position, self.sinkage, self.rotation

        def sink(t):
            return s0 + (s_target - s0) * min(t / ramp, 1.0)

        def set_load(t):
            self._attempts += 1
            x_prev = self.position
            self._step_dx = (x0 + t) - x_prev
            self.contact.set_pose(centre=self._centre(x0 + t, sink(t)),
                                  angle=self.rotation + (1.0 - self.slip_ratio) * self._step_dx / self.R)

        def on_t(t):
            # pose already committed: the step's increments are centre - (values saved before commit)
            st = self._record(dx=self._last_dx, dth=self._last_dth, iterations=self._its, trials=self._trials)
            if self._last_dx > 0:
                self.slip_ratio = st.slip
            if on_step is not None:
                on_step(st)
            return {"QV": st.QV, "moment": st.moment}

        self._rolling = True
        try:
            self._run(set_load, control, on_t)
        finally:
            self._rolling = False
        return self.steps

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
                ramp: float | None = None, block: dict | None = None, moment_rtol: float = 2e-3) -> dict:
    """Protocol ``rolling-continuous`` of ``scene`` on ``comm``; writes the run directory of
    ``shared/spec/interfaces.md`` (as :func:`~rollsim.solver.run.run_scene`) and returns the summary.

    The wheel is pressed to ``initial_sinkage`` (default 0.005 d) at ``ROLLING_START d`` and rolls
    ``loading.travel`` with the sinkage ramped to ``loading.max_sinkage`` over ``ramp`` (default:
    the whole travel).  ``block``: keywords of :func:`rolling_mesh` (length/half_width/depth in d).
    """
    from .run import _atomic_write, _history_csv, _wheel, finish_run, layer_material

    if scene.loading.protocol != "rolling-continuous":
        raise ValueError(f"loading.protocol: {scene.loading.protocol!r} is not supported by run_rolling "
                         "(supported: 'rolling-continuous')")
    wheel = _wheel(scene.wheel)
    materials = {k: layer_material(layer, k - 1) for k, layer in enumerate(scene.soil.layers, start=1)}
    out = pathlib.Path(out_dir)
    root = comm.rank == 0
    if root:
        (out / "fields").mkdir(parents=True, exist_ok=True)
    comm.barrier()
    t_start = time.perf_counter()
    d = scene.wheel.diameter
    s_max = scene.loading.max_sinkage
    travel = scene.loading.travel
    s0 = 0.005 * d if initial_sinkage is None else float(initial_sinkage)

    tagged = rolling_mesh(scene, comm, **(block or {}))
    roll = WheelRolling(tagged, wheel, materials, gamma=scene.soil.gamma, friction=scene.wheel.friction,
                        petsc_options=petsc_options, penalty=penalty, moment_rtol=moment_rtol)
    writer = None
    if write_fields:
        from .fields import FieldWriter
        writer = FieldWriter(roll.problem, out / "fields", cell_tags=tagged.cell_tags)
    rows: list[dict] = []

    def on_step(st: RollingStep):
        row = {"step": st.step, "sinkage_m": st.sinkage, "s_over_d": st.sinkage / d, "QV_N": st.QV, "QH_N": st.QH,
               "travel_m": st.travel, "moment_Nm": st.moment, "contact_area_m2": st.contact_area,
               "max_penetration_m": st.max_penetration, "newton_iterations": st.iterations, "cuts": st.cuts,
               "plastic_points": st.plastic, "wall_time_s": time.perf_counter() - t_start}
        rows.append(row)
        if writer is not None:
            writer.write(float(len(rows)))
        if root:
            _atomic_write(out / "history.csv", _history_csv(rows))
            if progress:
                log.info("step %3d  x = %.4f m  s = %.5f m (s/d = %.4f)  Q_V = %9.2f kN  Q_H = %8.2f kN  "
                         "M = %9.3g N m  slip %.3f  its %d/%d trials", st.step, st.travel, st.sinkage,
                         st.sinkage / d, st.QV / 1e3, st.QH / 1e3, st.moment, st.slip, st.iterations, st.trials)

    status, reason, diagnostics = "ok", "", {}
    try:
        if progress and root:
            log.info("rolling-continuous: %s wheel d = %g m, mu = %g, %d layer(s), %s mesh: %d cells, %d dofs, "
                     "%d rank(s); travel %g m, s -> %g m", scene.wheel.shape, d, scene.wheel.friction,
                     len(materials), scene.model.accuracy, tagged.stats.cells, roll.n_dofs, comm.size, travel, s_max)
        roll.gravity_step()
        roll.press(min(s0, s_max), on_step=on_step)
        roll.roll(travel, s_max, ramp=ramp, on_step=on_step)
    except SolverDivergedError as err:
        status, reason = "failed", str(err)
        diagnostics = {"last_converged_travel_m": roll.position - roll.x_start,
                       "last_converged_sinkage_m": roll.sinkage, "step_cuts_total": roll.cuts}
        log.warning("run failed: %s", reason)
    except Exception as err:          # noqa: BLE001 - report, never hang
        status, reason = "failed", f"{type(err).__name__}: {err}"
        diagnostics = {"traceback": traceback.format_exc()}
        log.error("run failed: %s", reason)
    statuses = comm.allgather(status)
    if "failed" in statuses and status == "ok":
        status, reason = "failed", "failed on another rank"
    if writer is not None:
        try:
            writer.write_deformed()
        finally:
            writer.close()

    wall = comm.allreduce(time.perf_counter() - t_start, op=MPI.MAX)
    ct = roll.contact
    last = rows[-1] if rows else {}
    summary = {
        "status": status,
        "reason": reason,
        "protocol": scene.loading.protocol,
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
        "model": {"symmetry": {4: "quarter", 2: "half", 1: "full"}[roll.factor], "symmetry_factor": roll.factor,
                  "accuracy": scene.model.accuracy, "displacement_degree": roll.problem.degree,
                  "initial_sinkage_m": s0, "ramp_m": travel if ramp is None else ramp,
                  "x_start_m": roll.x_start, "moment_rtol": roll.moment_rtol,
                  "contact": {"method": "penalty", "alpha": ct.alpha, "kappa_Pa_per_m": ct.kappa, "h_m": ct.h,
                              "friction": ct.friction}},
        "files": {"history": "history.csv", "fields": ["fields/fields.xdmf", "fields/deformed.xdmf"]
                  if write_fields else [], "plot": "force_sinkage.png"},
    }
    if diagnostics:
        summary["diagnostics"] = diagnostics
    return finish_run(out, rows, scene, summary, comm, progress=progress)
