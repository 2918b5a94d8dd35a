"""The skeleton every protocol driver shares: set-up, one history row per converged step, the
protected run, the fields, the summary and the run directory (``rollsim.solver.rundir``)."""
from __future__ import annotations

import json
import time
import traceback
from typing import Callable

import numpy as np
from mpi4py import MPI

from rollsim import compat
from rollsim.files import atomic_write_text, complete_directory, remove_directory
from rollsim.log import get_logger
from rollsim.mpi import root_block

from ..checkpoint import staged
from ..regularisation import regularisation_summary
from ..rundir import finish_run, history_row, json_default, make_run_directory, write_history
from ..scene_model import layer_materials, relaxation_hint, solver_options, wheel_geometry

__all__ = ["ProtocolRun", "RollingRun", "run_protected", "heave_warnings", "rut_depth", "REPORT_S_OVER_D",
           "HEAVE_TOLERANCE", "CHECKPOINT_EVERY"]

#: s/d values at which an indentation's Q_V is always computed (step boundaries; a pneumatic tire
#: aims at them) and reported in summary.json
REPORT_S_OVER_D = (0.01, 0.02, 0.03, 0.05, 0.08, 0.1)

log = get_logger("run")

#: rolled steps between two checkpoints of a rolling run (``checkpoint/`` in the run directory)
CHECKPOINT_EVERY = 10

#: heave (in d) beyond which a loaded wheel riding above, or a rut rising above, the undisturbed
#: surface is reported by :func:`heave_warnings`
HEAVE_TOLERANCE = 1e-3


def heave_warnings(steps, x_soft: float | None, x_start: float, load: float, d: float,
                   rut_depth: float | None = None, tolerance: float = HEAVE_TOLERANCE) -> list[str]:
    """Plausibility of a constant-load roll on level ground: one line for the highest the wheel
    rode above the undisturbed surface while carrying at least half of ``load`` (N) on the test
    soil (beyond ``x_soft``, m), one for a rut that is a heave (``rut_depth`` < 0, m), each when
    larger than ``tolerance`` d.  Without plastic dilation (psi = 0) neither is physical: the
    rate-independent route is then suspect and a run relaxed along the whole path is the check."""
    lines = []
    x0 = x_soft if x_soft is not None else x_start
    loaded = [st for st in steps if st.QV >= 0.5 * load and x_start + st.travel >= x0]
    if loaded:
        high = min(loaded, key=lambda st: st.sinkage)
        if -high.sinkage > tolerance * d:
            lines.append(f"the loaded wheel rode {-1e3 * high.sinkage:.3g} mm above the undisturbed surface "
                         f"(travel {high.travel:.4g} m, Q_H = {high.QH / 1e3:.3g} kN)")
    if rut_depth is not None and -rut_depth > tolerance * d:
        lines.append(f"the rut is a heave of {-1e3 * rut_depth:.3g} mm")
    if lines:
        lines.append(f"heave under a rolled wheel is not physical without dilation (psi > 0): compare a run "
                     f"relaxed along the whole path ([model] relaxation_length; dense sand: d/1500 = "
                     f"{1e3 * d / 1500:.2g} mm)")
    return lines


def rut_depth(xs, w, *, x_from: float, x_wheel: float, x_start: float, steady, sinkage: float,
              contact_length: float) -> dict:
    """Rut depth (the mean settlement ``w`` of the surface profile ``xs`` once the wheel is lifted
    off) and rebound (sinkage - rut depth), m.  Window: from ``x_from`` (the end of the stiff
    zone, or the start) + half a contact length, or the start of the steady-state window if later,
    to half a contact length behind the wheel centre ``x_wheel`` (soil the wheel has rolled over).
    ``steady``: the :class:`~rollsim.solver.rolling.SteadyState` or None; ``sinkage``: the last
    step's, used without a steady state."""
    lo = x_from + 0.5 * contact_length
    if steady is not None and steady.reached:
        lo = max(lo, x_start + steady.travel - steady.window)
    hi = x_wheel - 0.5 * contact_length
    sel = (xs >= lo) & (xs <= hi)
    result = {"rut_window_m": [float(lo), float(hi)]}
    if sel.sum() >= 2:
        rut = float(np.mean(w[sel]))
        s_ref = steady.sinkage if steady is not None else sinkage
        result.update(rut_depth_m=rut, rebound_m=s_ref - rut)
    else:
        result.update(rut_depth_m=None, rebound_m=None,
                      rut_note="the wheel has not rolled far enough beyond the stiff zone to measure the rut")
    return result


def run_protected(body, comm: MPI.Comm, state) -> tuple[str, str, dict]:
    """Run a protocol, ``body()``, so that it never hangs or raises: ``(status, reason, diagnostics)``.

    Signals stop it at a step boundary (``"interrupted"``); a solver failure or any exception gives
    ``"failed"`` with the reason; ``body`` may also return a failure reason itself.  ``state()``
    gives the diagnostics of the last converged state.  All ranks agree on the outcome (a
    rank-local exception would otherwise hang the others)."""
    from ..stepping import RunInterrupted, SolverDivergedError, stop_on_signals
    status, reason, diagnostics = "ok", "", {}
    try:
        with stop_on_signals():
            why = body()
        if why:
            status, reason = "failed", why
    except RunInterrupted as err:
        status, reason = "interrupted", str(err)
        diagnostics = {"signal": err.signal_name, **state()}
        log.warning("run interrupted: %s", reason)
    except SolverDivergedError as err:
        status, reason = "failed", str(err)
        hist = getattr(err, "history", None) or []
        diagnostics = {**state(), "last_step_residual_norms": list(hist[-1].residual_norms) if hist else []}
        log.warning("run failed: %s", reason)
    except Exception as err:          # noqa: BLE001 - report, never hang
        status, reason = "failed", f"{type(err).__name__}: {err}"
        diagnostics = {"traceback": traceback.format_exc()}
        log.error("run failed: %s", reason)
    if "failed" in comm.allgather(status) and status != "failed":
        status, reason = "failed", "failed on another rank"
    return status, reason, diagnostics


class ProtocolRun:
    """One ``rollsim run`` of a scene, around the protocol's own loading.

    A driver builds its mesh and wheel object (:class:`~rollsim.solver.indentation.WheelIndentation`
    or :class:`~rollsim.solver.rolling.WheelRolling`) with :attr:`solver_options`, hands them to
    :meth:`attach`, calls :meth:`record` for every converged step from inside the body it gives
    :meth:`execute`, then :meth:`close_fields`, :meth:`summary` and :meth:`finish`.
    """

    def __init__(self, scene, out_dir, comm: MPI.Comm, *, progress: bool = True, write_fields: bool = True,
                 petsc_options: dict | None = None, penalty: float | None = None):
        self.scene, self.comm, self.progress, self.write_fields = scene, comm, progress, write_fields
        self.root = comm.rank == 0
        self.t_start = time.perf_counter()
        self.d = scene.wheel.diameter
        #: the rigid wheel's geometry (None for a pneumatic tire, which its driver builds)
        self.wheel = wheel_geometry(scene.wheel) if scene.wheel.type == "rigid" else None
        self.soil = layer_materials(scene)
        self.out = make_run_directory(out_dir, comm)
        #: keywords shared by the wheel classes: what this run applies
        self.solver_options = solver_options(scene, penalty=penalty, petsc_options=petsc_options)
        self.rows: list[dict] = []
        #: the field time series under ``fields/`` (a continued run adds one)
        self.field_series = ["fields.xdmf"]
        #: linear solves of the runs this one continues (the roll counts their Newton iterations)
        self.solves_before = 0
        #: largest out-of-balance force left by an accepted Newton plateau, over that step's Q_V
        self.plateau_share = 0.0
        self.tagged = self.wheel_run = self.writer = None

    def attach(self, tagged, wheel_run) -> None:
        """The mesh and the wheel object of the run; opens the field writer."""
        self.tagged, self.wheel_run = tagged, wheel_run
        if self.write_fields:
            from ..fields import FieldWriter
            self.writer = FieldWriter(wheel_run.problem, self.out / "fields", cell_tags=tagged.cell_tags,
                                      series=self.field_series[-1])

    def announce(self, loading: str = "") -> None:
        """The run's first log line: protocol, wheel, soil, mesh, then the protocol's ``loading``."""
        if self.progress and self.root:
            sc = self.scene
            log.info("%s: %s wheel d = %g m, mu = %g, %d layer(s), %s mesh: %d cells, %d dofs, %s strain, "
                     "%d rank(s)%s", sc.loading.protocol,
                     sc.wheel.shape if sc.wheel.type == "rigid" else sc.wheel.type, self.d, sc.wheel.friction,
                     len(self.soil.by_layer), sc.model.mesh_name, self.tagged.stats.cells, self.wheel_run.n_dofs,
                     self.wheel_run.problem.volumetric_strain, self.comm.size, f"; {loading}" if loading else "")

    def record(self, st, travel: float, field_time: float) -> None:
        """A converged step ``st``: its history row, its fields at ``field_time``, history.csv."""
        self.rows.append(history_row(st, self.d, travel, self.t_start))
        residual = self.wheel_run.problem.plateau_residual       # N, modelled part; 0: converged fully
        if residual and st.QV:
            self.plateau_share = max(self.plateau_share, self.wheel_run.factor * residual / abs(st.QV))
        if self.writer is not None:
            self.writer.write(field_time)
        write_history(self.out, self.rows, self.comm)

    def record_sinkage_step(self, st) -> None:
        """An indentation step ``st``: :meth:`record` (fields at time = the sinkage) and a progress line."""
        self.record(st, 0.0, st.sinkage)
        if self.progress and self.root:
            log.info("step %3d  s = %.5f m (s/d = %.4f)  Q_V = %10.2f kN  Newton its %d", st.step, st.sinkage,
                     st.sinkage / self.d, st.QV / 1e3, st.iterations)

    def execute(self, body: Callable[[], str | None], state: Callable[[], dict]) -> tuple[str, str, dict]:
        """:func:`run_protected` of ``body``; a failure's reason names the remedies that apply."""
        status, reason, diagnostics = run_protected(body, self.comm, state)
        if status == "failed":
            reason += relaxation_hint(self.soil.by_layer, self.scene)
        return status, reason, diagnostics

    def close_fields(self, picture: Callable | None = None) -> None:
        """Write the deformed mesh, then ``picture(writer)`` if given (a failing picture is logged,
        never fatal), and close the field files."""
        if self.writer is None:
            return
        try:
            self.writer.write_deformed()
            if picture is not None:
                picture(self.writer)
        except Exception as err:  # noqa: BLE001 - a picture must not lose the run
            log.warning("field picture failed: %s", err)
        finally:
            self.writer.close()

    def model_summary(self) -> dict:
        """The ``model`` entry of ``summary.json``: what the run applied (symmetry, mesh preset,
        element degree, kinematics, linear solver, strain, contact, relaxation length, Newton
        plateau tolerance and the regularising cohesion put in place of c = 0), read from the
        objects that were built, and ``regularisation``: each device applied with its estimated
        effect (:func:`~rollsim.solver.regularisation.regularisation_summary`)."""
        run = self.wheel_run
        ct = run.contact
        model = {"symmetry": {4: "quarter", 2: "half", 1: "full"}[run.factor], "symmetry_factor": run.factor,
                 "accuracy": self.scene.model.accuracy, "elements_per_d": self.scene.model.elements_per_d,
                 "cell_type": compat.cell_name(self.tagged.mesh),
                 "displacement_degree": run.problem.degree,
                 "kinematics": run.problem.kinematics, "linear_solver": run.problem.linear_solver,
                 "volumetric_strain": run.problem.volumetric_strain,
                 "contact": {"method": "penalty", "alpha": ct.alpha, "kappa_Pa_per_m": ct.kappa, "h_m": ct.h,
                             "friction": ct.friction},
                 "relaxation_length_m": run.relaxation_length,
                 "relaxation_fallback_m": self.scene.model.relaxation_fallback,
                 "relaxed_spans_m": [list(span) for span in run.relaxed_spans],
                 "plateau_tolerance": run.problem.plateau_rtol}
        if self.scene.model.elements_across_wheel is not None:
            model["elements_across_wheel"] = self.scene.model.elements_across_wheel
            model["elements_along_path"] = self.scene.model.elements_along_path
        travel_fallback, relaxed_travel = self.travel_relaxation()
        if relaxed_travel is not None:
            model["travel_relaxation_fallback_m"] = travel_fallback
            model["relaxed_travel_m"] = [list(span) for span in relaxed_travel]
        if self.soil.regularised:
            model["regularising_cohesion_Pa"] = dict(self.soil.regularised)
        model["regularisation"] = regularisation_summary(
            self.scene.loading.protocol, regularised=self.soil.regularised,
            relaxation_length=run.relaxation_length, plateau_tolerance=run.problem.plateau_rtol,
            plateau_share=self.plateau_share, relaxation_fallback=self.scene.model.relaxation_fallback,
            relaxed_spans=run.relaxed_spans,
            travel_relaxation_fallback=travel_fallback, relaxed_travel=relaxed_travel or (),
            cohesionless=self.soil.cohesionless)
        return model

    def travel_relaxation(self) -> tuple[float, list[tuple[float, float]] | None]:
        """The travel relaxation fallback (m) and the relaxed travel stretches (m) of a rolling run;
        ``(0.0, None)`` for a run without travel."""
        return 0.0, None

    def summary(self, status: str, reason: str, **results) -> dict:
        """The keys of ``summary.json`` every protocol writes, then the protocol's ``results``
        (``sinkage_m``, ``QV_N``, ``QH_N`` default to the last converged step)."""
        wall = self.comm.allreduce(time.perf_counter() - self.t_start, op=MPI.MAX)
        last = self.rows[-1] if self.rows else {}
        run = self.wheel_run
        return {"status": status, "reason": reason, "protocol": self.scene.loading.protocol,
                "scene": self.scene.to_dict(), "wall_time_s": wall, "ranks": self.comm.size, "dofs": run.n_dofs,
                "cells": self.tagged.stats.cells, "steps": len(self.rows),
                "newton_iterations": run.newton_iterations,
                "linear_solves": int(run.problem.timings["linear_solves"]) + self.solves_before,
                "step_cuts": run.cuts,
                "newton_plateaus": {**run.problem.plateaus, "max_residual_over_QV": self.plateau_share},
                "sinkage_m": last.get("sinkage_m", 0.0), "QV_N": last.get("QV_N", 0.0),
                "QH_N": last.get("QH_N", 0.0), "max_QV_N": max((r["QV_N"] for r in self.rows), default=0.0),
                **results, "model": self.model_summary(),
                "files": {"history": "history.csv", "plot": "force_sinkage.png",
                          "fields": ([f"fields/{name}" for name in self.field_series] + ["fields/deformed.xdmf"]
                                     if self.write_fields else [])}}

    def measure_rut(self, profile: Callable[[], tuple], **window) -> dict | None:
        """:func:`rut_depth` of the surface ``profile()`` (after the lift-off), the profile written
        to ``rut_profile.csv`` and listed in the summary's files by :meth:`add_rut`; None when
        it fails (logged: a measurement must not lose the run)."""
        try:
            xs, w = profile()
            rut = rut_depth(xs, w, **window)
            if self.root:
                atomic_write_text(self.out / "rut_profile.csv", "x_m,settlement_m\n" + "".join(
                    f"{x:.10g},{s:.10g}\n" for x, s in zip(xs, w)))
            return rut
        except Exception as err:  # noqa: BLE001 - a measurement must not lose the run
            log.warning("rut measurement failed: %s", err)
            return None

    @staticmethod
    def lift_off(lift: Callable[[], object]) -> str | None:
        """Run ``lift()``, the wheel lifted off to measure the rut.  A failure loses only the rut:
        its reason is logged and returned (None: lifted); an interrupt propagates."""
        from ..stepping import SolverDivergedError
        try:
            lift()
        except SolverDivergedError as err:      # the rolling result stands
            if err.kind == "interrupted":
                raise
            log.warning("lift-off failed, the rut is not measured: %s", err)
            return str(err)
        return None

    @staticmethod
    def add_rut(summary: dict, rut: dict | None, lift_failure: str | None) -> None:
        """The rut of :meth:`measure_rut` into ``summary`` (or why it is missing)."""
        if rut is not None:
            summary.update(rut)
            summary["files"]["rut_profile"] = "rut_profile.csv"
        elif lift_failure:
            summary.update(rut_depth_m=None, rebound_m=None, rut_note=f"lift-off failed: {lift_failure}")

    def warn_heave(self, summary: dict, steps, x_soft: float | None, x_start: float) -> None:
        """Put :func:`heave_warnings` of a constant-load roll (``steps``, and the rut depth in
        ``summary`` if measured) into ``summary`` and log them."""
        summary["warnings"] = heave_warnings(steps, x_soft, x_start, self.scene.loading.load, self.d,
                                             summary.get("rut_depth_m"))
        for line in summary["warnings"]:
            log.warning("%s", line)

    def plot_travel(self, summary: dict) -> None:
        """``rolling.png`` (sinkage, rut and forces against travel) from rank 0, listed in
        ``summary["files"]``; never fatal."""
        summary["files"]["travel_plot"] = "rolling.png"
        if self.root and self.rows:
            from ..rundir import plot_travel
            try:
                plot_travel(self.out / "rolling.png", self.rows, self.scene, summary, self.out / "rut_profile.csv")
            except Exception as err:  # noqa: BLE001 - a plot must not lose the run
                log.warning("travel plot failed: %s", err)

    def finish(self, summary: dict, diagnostics: dict) -> dict:
        """Write history.csv, the force-sinkage plot and summary.json (last); returns ``summary``."""
        if diagnostics:
            summary["diagnostics"] = diagnostics
        return finish_run(self.out, self.rows, self.scene, summary, self.comm, progress=self.progress)


class RollingRun(ProtocolRun):
    """A :class:`ProtocolRun` of a towed wheel on the half rolling block (``block``: keywords of
    :func:`~rollsim.solver.scene_model.rolling_mesh`, lengths in d): :attr:`roll` is the
    :class:`~rollsim.solver.rolling.WheelRolling`, :meth:`on_step` records a step and prints the
    travel progress.

    Every ``checkpoint_every`` rolled steps (0: never) the run's state goes to ``checkpoint/`` in
    the run directory (the roll's :meth:`~rollsim.solver.rolling.WheelRolling.write_checkpoint`
    and ``run.json``: the history rows, the field frames, the wall time and counts so far, and
    what set the path: the scene echo, ``block``, ``moment_rtol`` and the driver's ``path``
    keywords).  A run started on a directory with a checkpoint of the same path continues from it
    (:meth:`continue_roll`) unless ``restart``; one of another path is removed and the run starts
    over.  The checkpoint is removed when the run ends ``ok``, and no longer written once a roll
    has started over relaxed (its resumption would relax from the checkpoint on, not from the
    start of the roll)."""

    def __init__(self, scene, out_dir, comm: MPI.Comm, *, block: dict, moment_rtol: float, path: dict | None = None,
                 checkpoint_every: int = CHECKPOINT_EVERY, restart: bool = False, **kw):
        from ..rolling import WheelRolling
        from ..rundir import TravelProgress
        from ..scene_model import rolling_mesh
        super().__init__(scene, out_dir, comm, **kw)
        if checkpoint_every < 0:
            raise ValueError(f"checkpoint_every must be >= 0, got {checkpoint_every}")
        self.checkpoint, self.checkpoint_every = self.out / "checkpoint", int(checkpoint_every)
        self.identity = json.loads(json.dumps({"scene": scene.to_dict(), "block": block, "moment_rtol": moment_rtol,
                                               **(path or {})}, default=json_default))
        #: run.json of the checkpoint this run continues (None: from the start)
        self.saved = self._saved_run(restart)
        self.continued: list[dict] = self.saved["continued"] if self.saved else []
        if self.saved:
            self.field_series = self.saved["field_series"] + [f"fields_from_frame_{self.saved['frames'] + 1}.xdmf"]
        tagged = rolling_mesh(scene, comm, **block)
        self.roll = WheelRolling(tagged, self.wheel, self.soil.by_layer, moment_rtol=moment_rtol,
                                 **self.solver_options)
        self.attach(tagged, self.roll)
        self.bar = TravelProgress(scene.loading.travel, self.d, enabled=self.progress and self.root,
                                  start=self.saved["travel"] if self.saved else 0.0)
        self.frames = 0     # field frames written: their time counts on when a roll starts over
        self._rolled_last = False       # the last converged step was a rolled one

    def _saved_run(self, restart: bool) -> dict | None:
        """``run.json`` of the last complete checkpoint if this run continues it (read on rank 0);
        a checkpoint of another path, unreadable, or set aside by ``restart`` is removed."""
        meta = None
        if self.root:
            found = complete_directory(self.checkpoint)
            why = "a restart was asked for" if restart else None
            if found is not None and why is None:
                try:
                    meta = json.loads((found / "run.json").read_text())
                    if meta["identity"] != self.identity:
                        why = "written for another scene or other run options"
                    meta["directory"] = str(found)
                except (OSError, ValueError, KeyError, TypeError) as err:
                    why = f"unreadable: {err}"
            if found is not None and why:
                meta = None
                log.warning("%s not continued (%s): the run starts from the beginning", self.checkpoint, why)
            if meta is None:
                remove_directory(self.checkpoint)
        return self.comm.bcast(meta, root=0)

    def continue_roll(self) -> bool:
        """After the gravity step: continue from the checkpoint found at the start, if any (the
        roll's state, the history rows and field frames up to it, the wall time and counts before
        it); True when continued.  The rows and frames a run wrote after its last checkpoint are
        dropped from history.csv and stay in the earlier field series."""
        meta = self.saved
        if meta is None:
            return False
        roll = self.roll
        roll.read_checkpoint(meta["directory"])
        # this run's gravity step takes the place of the written run's in the totals
        self.solves_before = meta["linear_solves"] - int(roll.problem.timings["linear_solves"])
        self.rows[:] = meta["rows"]
        self.frames, self.t_start = meta["frames"], self.t_start - meta["wall_time_s"]
        self.plateau_share = max(self.plateau_share, meta["plateau_share"])
        self.continued.append({"from_step": len(self.rows), "from_travel_m": roll.position - roll.x_start})
        write_history(self.out, self.rows, self.comm)
        if self.progress and self.root:
            log.info("continuing from %s at travel %.4g m (step %d, %.1f min of wall time before)", self.checkpoint,
                     roll.position - roll.x_start, len(self.rows), meta["wall_time_s"] / 60)
        return True

    def write_checkpoint(self) -> None:
        """The state after the last converged step in ``checkpoint/`` (collective), written whole
        beside it and then put in its place (:func:`~rollsim.solver.checkpoint.staged`)."""
        roll = self.roll
        with staged(self.checkpoint, self.comm) as stage:
            roll.write_checkpoint(stage)
            with root_block(self.comm) as on_root:
                if on_root:
                    meta = {"identity": self.identity, "travel": roll.position - roll.x_start, "rows": self.rows,
                            "frames": self.frames, "field_series": self.field_series, "continued": self.continued,
                            "wall_time_s": time.perf_counter() - self.t_start, "plateau_share": self.plateau_share,
                            "newton_iterations": roll.newton_iterations,
                            "linear_solves": int(roll.problem.timings["linear_solves"]) + self.solves_before}
                    atomic_write_text(stage / "run.json", json.dumps(meta, default=json_default))

    def travel_relaxation(self) -> tuple[float, list[tuple[float, float]]]:
        return self.roll.travel_relaxation_fallback, self.roll.relaxed_travel

    def on_step(self, st) -> None:
        """A converged ``RollingStep``: history row, fields (time = frame number), progress, and
        every :attr:`checkpoint_every` rolled steps the checkpoint."""
        self.frames += 1
        self.record(st, st.travel, float(self.frames))
        self.bar.update(st)
        self._rolled_last = self.roll.rolling
        every = self.checkpoint_every
        if every and self._rolled_last and sum(r["travel_m"] > 0 for r in self.rows) % every == 0:
            self.write_checkpoint()

    def on_start_over(self, dropped: int) -> None:
        """A roll that starts over relaxed: its ``dropped`` steps leave history.csv (the field
        frames written for them stay, earlier in time); checkpoints stop."""
        if dropped:
            del self.rows[-dropped:]
        write_history(self.out, self.rows, self.comm)
        if self.checkpoint_every and self.root:
            log.info("no checkpoints after the roll started over relaxed: a killed run starts from the beginning")
        self.checkpoint_every = 0
        if self.root:
            remove_directory(self.checkpoint)
        self.comm.barrier()

    def finish(self, summary: dict, diagnostics: dict) -> dict:
        """:meth:`ProtocolRun.finish`; a run interrupted while rolling writes its last converged
        state to the checkpoint, a finished run removes it (a failed run keeps it: started again
        it fails again within minutes, or continues with other PETSc options)."""
        if self.continued:
            summary["continued"] = self.continued
        if summary["status"] == "interrupted" and self._rolled_last and self.checkpoint_every:
            self.write_checkpoint()
            summary["files"]["checkpoint"] = "checkpoint"
            summary["reason"] += (f"; run it again to continue from the checkpoint at travel "
                                  f"{self.roll.position - self.roll.x_start:.4g} m")
        elif summary["status"] == "ok" and self.root:
            remove_directory(self.checkpoint)
        return super().finish(summary, diagnostics)

    def state(self) -> dict:
        """Diagnostics of the last converged state."""
        roll = self.roll
        return {"last_converged_travel_m": roll.position - roll.x_start, "last_converged_sinkage_m": roll.sinkage,
                "step_cuts_total": roll.cuts}

    def summary(self, status: str, reason: str, **results) -> dict:
        last = self.rows[-1] if self.rows else {}
        summary = super().summary(status, reason, travel_m=last.get("travel_m", 0.0),
                                  moment_Nm=last.get("moment_Nm", 0.0), rotation_rad=self.roll.rotation, **results)
        summary["model"].update(x_start_m=self.roll.x_start, moment_rtol=self.roll.moment_rtol,
                                travel_step_m=self.roll.travel_step)
        if self.roll.travel_failures:
            summary["model"]["rate_independent_travel_failed_at_m"] = list(self.roll.travel_failures)
        return summary
