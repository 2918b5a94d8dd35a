"""Rigid wheel pressed into elastoplastic soil: gravity step, displacement- or load-controlled push.

The soil mesh is a ``TaggedMesh`` from ``rollsim.geometry`` (3D block, full / half / quarter, or a
2D plane-strain block); boundary conditions follow the facet names (normal displacement zero on
``symmetry_x``/``rear``/``front`` (x), ``symmetry_y``/``side`` (y in 3D, x in 2D) and ``bottom``
(vertical)), contact is checked on ``top`` + ``contact``.  Forces are reported for the whole
wheel: the modelled part times the symmetry factor (4 for a quarter block, 2 for a half block;
in 2D per unit length of the cylinder, 2 for a symmetric half block).

Sinkage ``s`` is the depth of the wheel's lowest point below the undisturbed surface (z = 0):
wheel centre at ``z = d/2 - s`` (x = y = 0, the symmetry planes).

Protocols
---------
* :meth:`WheelIndentation.gravity_step` - geostatic stress (K0 = nu/(1-nu) per layer unless given)
  with the body force, one equilibrium solve, then the displacement is zeroed;
* :meth:`WheelIndentation.push` - displacement control to a sinkage, adaptive steps
  (``solve_load_path``: cutting on divergence, growth after easy steps), optional stops;
* :meth:`WheelIndentation.push_to_load` - load control: the wheel force is given and the sinkage is
  the unknown.  Displacement-controlled steps march until ``Q_V`` brackets the load, then the
  sinkage is found by Illinois regula falsi, each trial an elastoplastic solve from the last
  converged state (so the final state is an equilibrium at exactly the given load).  If ``Q_V``
  does not reach the load by the sinkage limit, or peaks below it, the outcome is
  ``"exceeds_capacity"`` with the largest force reached - a bounded search, never a hang.
"""
from __future__ import annotations

import json
import math
import pathlib
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI

from rollsim.files import atomic_path, atomic_write_text
from rollsim.log import get_logger

from . import checkpoint
from .contact import RigidWheelContact
from .options import DEFAULT_VOLUMETRIC_STRAIN, check_relaxation_length
from .problem import PlasticityProblem
from .stepping import (RelaxationFallback, RunInterrupted, SolverDivergedError, StepControl, advance_with_fallback,
                       settle_under_gravity, solve_load_path, straight_path)

__all__ = ["WheelIndentation", "IndentationStep", "LoadControlResult", "symmetry_factor",
           "DEFAULT_STEP_CONTROL", "DEFAULT_PETSC_OPTIONS"]

log = get_logger("solver")

#: sinkage over which a fallback relaxation acts after a failure, in wheel diameters
RELAXATION_STRETCH = 0.005

#: Pseudo-time control of one push leg (t in [0, 1] spans the leg's sinkage range).
DEFAULT_STEP_CONTROL = StepControl(t_end=1.0, dt=0.1, dt_min=1e-4, dt_max=0.25, easy_iterations=8, max_cuts=10)

#: Added to the solver defaults: MUMPS null-pivot detection, so that a tangent made singular by
#: cells whose quadrature points all sit at the Drucker-Prager apex (zero tangent) still factors
#: (without it such steps fail in the LU and are cut until the run fails); backtracking line
#: search (fewer steps, iterations and cuts than full Newton steps; measured: see
#: docs/theory.md, "Step control and failures").
DEFAULT_PETSC_OPTIONS = {"mat_mumps_icntl_24": 1, "snes_linesearch_type": "bt"}

# facet name -> displacement component held (normal to the face); "vertical" = gdim - 1
_NORMAL_COMPONENT = {3: {"symmetry_x": 0, "rear": 0, "front": 0, "symmetry_y": 1, "side": 1, "bottom": 2},
                     2: {"symmetry_x": 0, "side": 0, "bottom": 1}}


def symmetry_factor(facet_names: dict, gdim: int) -> int:
    """Whole wheel / modelled part, from the symmetry planes present in the mesh."""
    planes = [n for n in ("symmetry_x", "symmetry_y") if n in facet_names]
    return 2 ** len(planes)


@dataclass
class IndentationStep:
    """One converged step, whole-wheel forces."""

    step: int
    sinkage: float          # m
    QV: float               # N (per metre in 2D)
    QH: float               # N
    moment: float           # N m, about the axle (whole wheel)
    contact_area: float     # m^2 (whole wheel; m in 2D)
    max_penetration: float  # m, penalty penetration
    iterations: int
    cuts: int
    plastic: int            # plastic + apex quadrature points
    time: float             # wall time of the step, s


class StepCounts:
    """Newton iterations and step cuts so far of a driver with a ``problem`` and its ``steps``,
    the steps before the checkpoint it continues from included."""

    #: Newton iterations of the runs before the checkpoint this one continues from
    newton_iterations_before = 0

    @property
    def newton_iterations(self) -> int:
        return int(self.problem.timings["iterations"]) + self.newton_iterations_before

    @property
    def cuts(self) -> int:
        return int(sum(st.cuts for st in self.steps))


@dataclass
class LoadControlResult:
    status: str                     # "ok" | "exceeds_capacity" | "failed"
    load: float                     # requested whole-wheel Q_V, N
    sinkage: float                  # m (at the load when ok, else at the last converged state)
    QV: float                       # N, at the final state
    max_QV: float                   # largest Q_V reached, N
    sinkage_at_max: float           # m
    iterations: int                 # regula-falsi trials
    reason: str = ""
    steps: list = field(default_factory=list)


class _Bracketed(Exception):
    pass


class WheelIndentation(StepCounts):
    """A rigid wheel (``CylinderWheel``/``TorusWheel`` in 3D, ``Circle`` in 2D) on a soil block.

    ``material``: one material or ``{cell tag: material}`` (layers: tag k = layer_k); ``gamma``:
    unit weight (N/m^3; 0 = weightless); ``friction``: Coulomb mu; ``penalty``: alpha in
    kappa = alpha E/h; ``h``: element size at the contact (default measured from the mesh);
    ``petsc_options``: passed to the SNES; ``kinematics``: ``"small-strain"`` or
    ``"updated-lagrangian"``; ``linear_solver``: ``"auto"``, ``"direct"`` or ``"iterative"``;
    ``volumetric_strain``: ``"pointwise"`` or ``"cell-average"`` (B-bar) (all three see
    :class:`~rollsim.solver.problem.PlasticityProblem`); ``relaxation_length`` (m, 0: off):
    Duvaut-Lions regularisation of the soil while the wheel sinks, with the sinkage as
    pseudo-time: a step that changes the sinkage by ``ds`` has ``r = ds / relaxation_length``
    (see :func:`~rollsim.solver.return_map.duvaut_lions`; the gravity step stays rate-independent);
    ``plateau_rtol``: Newton plateaus accepted below this fraction of the internal-force norm
    (default :data:`~rollsim.solver.options.PLATEAU_RTOL`; 0: never); ``relaxation_fallback`` (m,
    0: off): the relaxation length :meth:`push` falls back to over a stretch of sinkage when
    Newton fails on the unregularised soil.  ``volumetric_projection``: as for
    :class:`~rollsim.solver.problem.PlasticityProblem` (hexahedral blocks).
    """

    def __init__(self, tagged, wheel, material, *, gamma: float = 0.0, K0: float | None = None,
                 friction: float = 0.0, penalty: float | None = None, h: float | None = None,
                 petsc_options: dict | None = None, degree: int = 2, contact_ids=None,
                 quadrature_degree: int = 6, smoothing: float = 0.0, kinematics: str = "small-strain",
                 linear_solver: str = "auto", volumetric_strain: str = DEFAULT_VOLUMETRIC_STRAIN,
                 relaxation_length: float = 0.0, plateau_rtol: float | None = None,
                 relaxation_fallback: float = 0.0, volumetric_projection: int | None = None):
        self.relaxation_length = check_relaxation_length(relaxation_length)
        self.relaxation_fallback = check_relaxation_length(relaxation_fallback)
        #: sinkage over which a fallback relaxation acts after a failure, m
        self.relaxation_stretch = RELAXATION_STRETCH * wheel.diameter
        #: ``(from, to)`` sinkage (m) of each stretch the fallback relaxed
        self.relaxed_spans: list[tuple[float, float]] = []
        self.tagged = tagged
        msh = tagged.mesh
        self.comm = msh.comm
        self.gdim = gdim = msh.geometry.dim
        self.wheel = wheel
        self.radius = wheel.diameter / 2
        self.gamma, self.K0 = float(gamma), K0
        self.factor = symmetry_factor(tagged.facet_names, gdim)
        body = ufl.as_vector([0.0] * (gdim - 1) + [-self.gamma]) if self.gamma else None
        self.problem = pb = PlasticityProblem(msh, material, degree=degree, body_force=body,
                                              petsc_options={**DEFAULT_PETSC_OPTIONS, **(petsc_options or {})},
                                              cell_tags=tagged.cell_tags if isinstance(material, dict) else None,
                                              kinematics=kinematics, linear_solver=linear_solver,
                                              volumetric_strain=volumetric_strain, plateau_rtol=plateau_rtol,
                                              volumetric_projection=volumetric_projection)
        V = pb.V
        fdim = msh.topology.dim - 1
        bcs = []
        for name, comp in _NORMAL_COMPONENT[gdim].items():
            if name not in tagged.facet_names:
                continue
            facets = tagged.facet_tags.find(tagged.facet_names[name])
            dofs = fem.locate_dofs_topological(V.sub(comp), fdim, facets)
            bcs.append(fem.dirichletbc(0.0, dofs, V.sub(comp)))
        pb.bcs = bcs
        if contact_ids is None:
            contact_ids = tuple(tagged.facet_names[n] for n in ("top", "contact") if n in tagged.facet_names)
        self.contact = RigidWheelContact(pb, wheel, tagged.facet_tags, contact_ids, friction=friction,
                                         penalty=penalty, h=h, quadrature_degree=quadrature_degree, smoothing=smoothing,
                                         centre=self._centre(0.0))
        self.steps: list[IndentationStep] = []
        self.n_dofs = pb.n_dofs
        self._t_last = time.perf_counter()

    # ------------------------------------------------------------------ state
    #: horizontal position of the wheel centre used by set_sinkage / push / push_to_load (m)
    x_centre = 0.0

    def _centre(self, s: float) -> np.ndarray:
        c = np.zeros(self.gdim)
        c[0] = self.x_centre
        c[-1] = self.radius - s
        return c

    @property
    def sinkage(self) -> float:
        """Sinkage of the last converged pose, m."""
        return self.radius - float(self.contact.centre_n.value[-1])

    def set_sinkage(self, s: float) -> None:
        self.contact.set_pose(centre=self._centre(s))

    def _sink_to(self, s: float) -> None:
        """Pose of the next solve: sinkage ``s`` (m), Duvaut-Lions pseudo-time from the converged one."""
        self.problem.relax_over(abs(s - self.sinkage), self.relaxation_length)
        self.set_sinkage(s)

    def forces(self) -> dict:
        """Whole-wheel forces at the current displacement."""
        f = self.contact.forces()
        return {"QV": self.factor * f.vertical, "QH": self.factor * f.horizontal,
                "moment": self.factor * f.moment, "contact_area": self.factor * f.area,
                "max_penetration": f.max_penetration}

    def save_state(self) -> dict:
        """Copy of the converged state (for load control and restarts)."""
        st = {name: f.x.array.copy() for name, f in self._history_functions().items()}
        st.update(self._pose())
        return st

    def _pose(self) -> dict:
        """Converged wheel pose and the number of steps (the scalar part of a saved state)."""
        ct = self.contact
        return {"centre_n": np.array(ct.centre_n.value), "angle_n": float(ct.angle_n.value),
                "n_steps": len(self.steps)}

    def load_state(self, st: dict) -> None:
        pb, ct = self.problem, self.contact
        pb.u_n.x.array[:] = st["u_n"]
        pb.sigma_n.x.array[:] = st["sigma_n"]
        pb.eps_p.x.array[:] = st["eps_p"]
        ct.centre_n.value = st["centre_n"]
        ct.angle_n.value = st["angle_n"]
        if ct.t_n is not None:
            ct.t_n.x.array[:] = st["t_n"]
            ct._t_n_saved = st["t_n"].copy()
        ct.set_pose(centre=st["centre_n"], angle=st["angle_n"])
        del self.steps[st["n_steps"]:]
        pb.restore()

    def _history_functions(self) -> dict:
        """The Functions a checkpoint carries: displacement, stress, plastic strain, friction."""
        pb, ct = self.problem, self.contact
        fns = {"u_n": pb.u_n, "sigma_n": pb.sigma_n, "eps_p": pb.eps_p}
        if ct.t_n is not None:
            fns["t_n"] = ct.t_n
        return fns

    def write_checkpoint(self, path) -> None:
        """Write the converged state to the directory ``path``: ``state.npz`` (every value with the
        position of its node or quadrature point, see :mod:`rollsim.solver.checkpoint`), then
        ``steps.json`` (the steps so far and the Newton iterations), each replaced atomically by
        rank 0.  :meth:`read_checkpoint` continues from it on the same mesh with any number of
        ranks and any partition (long runs split over job time limits)."""
        path = pathlib.Path(path)
        data = checkpoint.gather(self.comm, self._history_functions())
        if self.comm.rank == 0:
            path.mkdir(parents=True, exist_ok=True)
            data.update(self._pose())
            with atomic_path(path / "state.npz") as tmp:
                np.savez(tmp, **data)
            meta = {"ranks": self.comm.size, "n_dofs": self.n_dofs, "n_steps": len(self.steps),
                    "newton_iterations": self.newton_iterations,
                    "steps": [vars(s) for s in self.steps]}
            atomic_write_text(path / "steps.json", json.dumps(meta, indent=1))
        self.comm.barrier()

    def read_checkpoint(self, path) -> int:
        """Continue from a :meth:`write_checkpoint` directory (call after :meth:`gravity_step`, which
        sets the geostatic stress the state was built on); :attr:`newton_iterations` then counts on
        from the written run's.  Returns the Newton iterations of the run that wrote it.  Raises
        ``ValueError`` naming what does not match (dofs, points, steps)."""
        path = pathlib.Path(path)
        meta = json.loads((path / "steps.json").read_text())
        if meta["n_dofs"] != self.n_dofs:
            raise ValueError(f"checkpoint {path}: written with {meta['n_dofs']} dofs, this run has {self.n_dofs} "
                             "(another mesh or preset)")
        if not (path / "state.npz").exists():
            raise ValueError(f"checkpoint {path}: no state.npz (written by rollsim before partition-independent "
                             "checkpoints, or interrupted while writing)")
        with np.load(path / "state.npz") as data:
            stored = {k: data[k] for k in data.files}
        if int(stored["n_steps"]) != meta["n_steps"]:
            raise ValueError(f"checkpoint {path}: state.npz holds {int(stored['n_steps'])} steps, steps.json "
                             f"{meta['n_steps']} (interrupted while writing)")
        try:
            st, worst = checkpoint.scatter(self._history_functions(), stored)
        except KeyError as err:
            raise ValueError(f"checkpoint {path}: no {err.args[0]} stored (written with another contact model)") from None
        worst = self.comm.allreduce(worst, op=MPI.MAX)
        if worst > checkpoint.MATCH_RTOL:
            raise ValueError(f"checkpoint {path}: a point of this mesh is {worst:.2g} (relative) from the nearest "
                             "stored point (written on another mesh)")
        self.steps[:] = [IndentationStep(**s) for s in meta["steps"]]
        st.update(centre_n=stored["centre_n"], angle_n=float(stored["angle_n"]), n_steps=len(self.steps))
        self.load_state(st)
        # from here on the count goes on from the written run's (its gravity step, not this one's)
        self.newton_iterations_before = int(meta["newton_iterations"]) - int(self.problem.timings["iterations"])
        return int(meta["newton_iterations"])

    # ------------------------------------------------------------------ protocols
    def gravity_step(self) -> None:
        """Geostatic stress + body force, one equilibrium solve with the wheel held clear of the
        soil, displacement zeroed; then the wheel is placed at s = 0 (touching the surface at one
        point, at ``x_centre``) and the pose committed.  Without unit weight only the pose."""
        if self.gamma:
            self.set_sinkage(-1e-3 * self.radius)
            settle_under_gravity(self.problem, self.gamma, self.K0)
        self.set_sinkage(0.0)
        self.contact.commit()

    def push(self, max_sinkage: float, control: StepControl | None = None, stops=(),
             on_step: Callable[[IndentationStep], None] | None = None) -> list[IndentationStep]:
        """Displacement control from the current sinkage to ``max_sinkage`` (m), landing exactly on
        every sinkage in ``stops``; ``on_step(step)`` after each converged step.

        When Newton diverges after step cutting and the soil is not regularised already
        (``relaxation_length = 0``), a ``relaxation_fallback`` > 0 relaxes the soil (Duvaut-Lions,
        that length) over the next ``relaxation_stretch`` of sinkage from the last converged step,
        then the rate-independent push goes on; each such stretch is kept in :attr:`relaxed_spans`.
        Raises ``SolverDivergedError`` (state restored to the last converged step) when that does
        not help, without a fallback, or on a guard (wall time, iterations, signal)."""
        control = control or DEFAULT_STEP_CONTROL
        targets = sorted({float(s) for s in stops if self.sinkage < s < max_sinkage} | {float(max_sinkage)})
        advance_with_fallback(lambda to, c: self._push_to(to, c, on_step), lambda: self.sinkage, targets, control,
                              self.fallback(), self._relax)
        return self.steps

    def fallback(self) -> RelaxationFallback | None:
        """The relaxation fallback of a vertical move: ``relaxation_fallback`` over
        ``relaxation_stretch`` of sinkage; None when the soil is relaxed already or it is off."""
        return RelaxationFallback.unless_relaxed(self.relaxation_length, self.relaxation_fallback,
                                                 self.relaxation_stretch, self.relaxed_spans)

    def _relax(self, length: float) -> None:
        """Set the relaxation length (m; 0: rate-independent) of the next steps."""
        self.relaxation_length = length
        if length == 0:
            self.problem.relaxation = math.inf

    def _push_to(self, target: float, control: StepControl, on_step) -> None:
        """One displacement-controlled path from the current sinkage to ``target`` (m), each
        converged step recorded."""
        def on_t(t):
            st = self._record()
            if on_step is not None:
                on_step(st)
            return {"QV": st.QV, "sinkage": st.sinkage}

        self._sink_segment(target, control, on_t)

    def _sink_segment(self, target: float, control: StepControl, on_t) -> None:
        """:func:`solve_load_path` along a straight sinkage path from the current sinkage to
        ``target`` (m); ``on_t`` after each converged step.  On failure the pose is back at the
        last converged step; the relaxation is off after it."""
        def place(s):
            self._attempts += 1
            self._sink_to(s)

        try:
            solve_load_path(self.problem, straight_path(self.sinkage, target, place), control, on_t)
        except SolverDivergedError:
            self.set_sinkage(self.sinkage)
            raise
        finally:
            self.problem.relaxation = math.inf

    def _record(self) -> IndentationStep:
        """Append the current (just committed) state as a step."""
        now = time.perf_counter()
        f = self.forces()
        pb = self.problem
        st = IndentationStep(step=len(self.steps) + 1, sinkage=self.radius - float(self.contact.centre.value[-1]),
                             QV=f["QV"], QH=f["QH"], moment=f["moment"], contact_area=f["contact_area"],
                             max_penetration=f["max_penetration"],
                             iterations=int(pb.snes.getIterationNumber()), cuts=max(self._attempts - 1, 0),
                             plastic=int(self.comm.allreduce(int(np.sum(pb.state != 0)))),
                             time=now - self._t_last)
        self._t_last = now
        self._attempts = 0
        self.steps.append(st)
        return st

    _t_last = time.perf_counter()
    _attempts = 0


    def push_to_load(self, load: float, sinkage_limit: float, control: StepControl | None = None,
                     rtol: float = 1e-4, max_trials: int = 40) -> LoadControlResult:
        """Load control: find the sinkage where the whole-wheel ``Q_V`` equals ``load`` (N).

        Marches in displacement control (``control``) up to ``sinkage_limit`` until the load is
        bracketed, then solves ``Q_V(s) = load`` to ``rtol * load`` by Illinois regula falsi
        from the last converged state below the load.  Outcomes: ``ok`` (state at the load),
        ``exceeds_capacity`` (not reached by the limit or past a peak; state at the last
        converged step) or ``failed`` (Newton diverged)."""
        if not load > 0:
            raise ValueError(f"load must be > 0, got {load}")
        try:
            return self._push_to_load(load, sinkage_limit, control or DEFAULT_STEP_CONTROL, rtol, max_trials)
        finally:
            self.problem.relaxation = math.inf

    def _push_to_load(self, load, sinkage_limit, control, rtol, max_trials) -> LoadControlResult:
        pb = self.problem
        best = {"QV": self.forces()["QV"] if self.steps else 0.0, "s": self.sinkage}
        saved = {"lo": self.save_state(), "s_lo": self.sinkage, "Q_lo": best["QV"]}
        falling = [0]

        def on_t(t):
            f = self.forces()
            s = self.radius - float(self.contact.centre.value[-1])
            if f["QV"] >= load:
                raise _Bracketed(s, f["QV"])
            if f["QV"] > best["QV"]:
                best.update(QV=f["QV"], s=s)
                falling[0] = 0
            else:
                falling[0] += 1
                if falling[0] >= 3:             # past the peak: the load cannot be carried
                    raise _Bracketed(None, None)
            self._record()
            saved.update(lo=self.save_state(), s_lo=s, Q_lo=f["QV"])
            return {"QV": f["QV"], "sinkage": s}

        bracket = None
        try:
            advance_with_fallback(lambda to, c: self._sink_segment(to, c, on_t), lambda: self.sinkage,
                                  [sinkage_limit], control, self.fallback(), self._relax)
        except _Bracketed as br:
            s_hi, Q_hi = br.args
            if s_hi is not None:
                bracket = (s_hi, Q_hi)
        except RunInterrupted:
            raise
        except SolverDivergedError as err:
            self.set_sinkage(self.sinkage)
            return LoadControlResult("failed", load, self.sinkage, saved["Q_lo"], best["QV"], best["s"], 0,
                                     reason=str(err), steps=self.steps)
        if bracket is None:
            # the bracketing step was committed by solve_load_path before on_step raised
            self.load_state(saved["lo"])
            return LoadControlResult("exceeds_capacity", load, self.sinkage, saved["Q_lo"], best["QV"], best["s"],
                                     0, reason=(f"Q_V = {load:.6g} N exceeds the capacity: largest Q_V "
                                                f"{best['QV']:.6g} N at s = {best['s']:.4g} m "
                                                f"(sinkage limit {sinkage_limit:.4g} m)"), steps=self.steps)
        # back to the last converged state below the load, then Illinois regula falsi
        self.load_state(saved["lo"])
        s_lo, Q_lo = saved["s_lo"], saved["Q_lo"]
        s_hi, Q_hi = bracket
        side = 0
        trials = 0
        for trials in range(1, max_trials + 1):
            s = s_lo + (load - Q_lo) * (s_hi - s_lo) / (Q_hi - Q_lo)
            s = min(max(s, s_lo + 1e-3 * (s_hi - s_lo)), s_hi - 1e-3 * (s_hi - s_lo))
            self._sink_to(s)
            rep = pb.solve_increment()
            if not rep.converged:
                pb.restore()
                s_hi, Q_hi = s, Q_lo + 2.0 * (load - Q_lo)   # unknown force: shrink the bracket
                continue
            Q = self.forces()["QV"]
            if abs(Q - load) <= rtol * load:
                pb.commit()
                self._record()
                return LoadControlResult("ok", load, s, Q, max(best["QV"], Q), s if Q > best["QV"] else best["s"],
                                         trials, steps=self.steps)
            pb.restore()
            if Q < load:
                s_lo, Q_lo = s, Q
                if side == -1:
                    Q_hi = load + (Q_hi - load) / 2
                side = -1
            else:
                s_hi, Q_hi = s, Q
                if side == 1:
                    Q_lo = load - (load - Q_lo) / 2
                side = 1
        self.set_sinkage(self.sinkage)
        return LoadControlResult("failed", load, self.sinkage, saved["Q_lo"], best["QV"], best["s"], trials,
                                 reason=f"load control did not converge in {max_trials} trials", steps=self.steps)
