"""The Newton driver of :class:`~rollsim.solver.problem.PlasticityProblem`: PETSc SNES on the
displacement, or a bordered Newton on the displacement and extra unknowns (:class:`Border`),
with the convergence test, its plateaus and cycles, and the failures a stepper cuts on.

:class:`NewtonDriver` is a mixin: the problem brings the forms (``_F_terms``, ``_J_terms``,
``_assembled_terms``), the state (``u``, ``constitutive_update``, ``counts``) and the linear
solver (:class:`~rollsim.solver.linear_solver.LinearSolverChoice`).
"""
from __future__ import annotations

import contextlib
import time
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np
from dolfinx import fem
from dolfinx.fem import petsc as fpetsc
from petsc4py import PETSc

from rollsim import compat
from rollsim.log import get_logger

from .linear_solver import _first_line, rigid_body_modes
from .options import PLATEAU_RTOL

__all__ = ["NewtonDriver", "NewtonReport", "Border", "ReturnMapError", "STAGNATION", "REASON_PETSC_ERROR",
           "REASON_RETURN_MAP"]

log = get_logger("solver")

#: Newton stops (``DIVERGED_LOCAL_MIN``, so the stepper cuts the step; below
#: :data:`~rollsim.solver.options.PLATEAU_RTOL` it accepts the step instead) when ``|F|`` has
#: repeated itself, within the relative ``tolerance`` of the value one or two iterations before (a flat
#: plateau or a two-cycle), in ``iterations`` consecutive iterations: ``(iterations, tolerance)``;
#: ``(0, 0)`` switches it off.  Non-associated Drucker-Prager sand (layered cases 13-15) stalls at
#: flat plateaus, frictional contact cycles between two active sets; without this test both
#: iterate to ``snes_max_it``.  Chosen on recorded residual histories of converged solves, none of
#: which meets it (see docs/theory.md, "Step control and failures").
STAGNATION = (3, 1e-3)

#: ``NewtonReport.reason`` when PETSc raised inside SNES (the linear solver has been re-created)
REASON_PETSC_ERROR = -100
#: ``NewtonReport.reason`` when the return map failed at some quadrature point while evaluating
#: the tangent (in a residual evaluation it makes the residual NaN: ``DIVERGED_FNORM_NAN``)
REASON_RETURN_MAP = -101


class ReturnMapError(RuntimeError):
    """The return map failed at a quadrature point on some rank; raised on every rank, so a
    Newton solve fails on all ranks together (the stepper cuts the step) instead of one rank
    raising while the others wait in a collective operation."""


@dataclass
class NewtonReport:
    converged: bool
    iterations: int
    reason: int
    residual_norms: list[float] = field(default_factory=list)
    time: float = 0.0
    counts: dict = field(default_factory=dict)   # global elastic/plastic/apex quadrature points
    linear_solves: int = 0
    #: ``|F|`` over the internal-force norm of an accepted plateau (see :data:`PLATEAU_RTOL`); 0: none
    plateau: float = 0.0
    plateau_repeats: int = 0       # iterations spent on that plateau before it was accepted


class Border(Protocol):
    """Extra unknowns ``q`` (``size`` of them) and equations ``G(u, q) = 0`` appended to a
    problem's Newton system (:meth:`PlasticityProblem.solve_increment`)."""

    size: int
    #: the unknowns are held at their values (plain Newton on the displacement) until the force
    #: residual is below ``hold_rtol`` times its initial value (0: until it has converged) and
    #: below ``hold_force`` (N; ``inf``: no such bound)
    hold_rtol: float
    hold_force: float

    def evaluate(self):
        """At the current displacement and ``q``: an object with ``values`` G (n), ``d_pose``
        dG/dq (n x n), ``d_displacement`` dG/du and ``residual_d_pose`` dr/dq (n PETSc vectors
        each, Dirichlet rows 0), as :class:`~rollsim.solver.contact.PoseDerivatives`."""

    def satisfied(self, values: np.ndarray) -> bool:
        """Whether ``G`` is within its tolerance."""

    #: weights of ``G`` in the line search's merit function ``|r|^2 + |W G|^2`` (N per unit of G)
    merit_weights: np.ndarray

    def limit(self, dq: np.ndarray) -> np.ndarray:
        """The increment to take for the proposed Newton increment ``dq``."""

    def move(self, dq: np.ndarray) -> None:
        """Add ``dq`` to the unknowns."""


def _stalled(history: list[float], iterations: int, tolerance: float) -> bool:
    """``|F|`` repeated (see :data:`STAGNATION`) in each of the last ``iterations`` iterations."""
    if iterations <= 0 or len(history) < iterations + 2:
        return False
    h = history
    return all(abs(h[i] - h[i - 1]) <= tolerance * h[i - 1] or abs(h[i] - h[i - 2]) <= tolerance * h[i - 2]
               for i in range(len(h) - iterations, len(h)))


class NewtonDriver:
    """Newton's method for a problem's forms (mixin of ``PlasticityProblem``)."""

    def _init_newton(self, force_rtol: float, plateau_rtol: float | None) -> None:
        """Tolerances, the plateau and cycle test, timings."""
        self.force_rtol = force_rtol
        self.plateau_rtol = PLATEAU_RTOL if plateau_rtol is None else plateau_rtol
        #: accepted Newton plateaus: how many, and the largest ``|F| / |F_internal|`` left in one
        self.plateaus = {"accepted": 0, "max_residual_ratio": 0.0}
        self._plateau = 0.0
        self.plateau_residual = 0.0
        self.divergence_factor = 1e4
        self.stagnation = STAGNATION
        self._compiled = False
        self.timings = {"residual": 0.0, "jacobian": 0.0, "return_map": 0.0, "snes": 0.0, "iterations": 0,
                        "linear_solves": 0}
        self._force_scale = 0.0
        self._gap = None                 # work vector of _dirichlet_gap
        self._history: list[float] = []

    # ------------------------------------------------------------------ SNES plumbing
    def _compile(self) -> None:
        if self._compiled:
            return
        self._F_form = fem.form(sum(self._F_terms[1:], self._F_terms[0]))
        self._J_form = fem.form(sum(self._J_terms[1:], self._J_terms[0]))
        self._b = compat.create_vector(self._F_form)
        self._A = fpetsc.create_matrix(self._J_form)
        if self._assembled_terms:
            self._A.setOption(PETSc.Mat.Option.NEW_NONZERO_ALLOCATION_ERR, False)
        self._x = compat.petsc_vector(self.u).copy()
        self._x_last = compat.petsc_vector(self.u).copy()
        snes = PETSc.SNES().create(self.comm)
        snes.setOptionsPrefix(self.options_prefix)
        self._push_options()
        snes.setFunction(self._snes_F, self._b)
        snes.setJacobian(self._snes_J, self._A)
        snes.setConvergenceTest(self._snes_converged)
        snes.setFromOptions()
        snes.getKSP().setFromOptions()
        if snes.getKSP().getPC().getType() == "gamg":
            self._A.setNearNullSpace(rigid_body_modes(self.V))
        self.snes = snes
        self._compiled = True

    def _load_x(self, x) -> None:
        x.copy(compat.petsc_vector(self.u))
        self.u.x.scatter_forward()

    def _snes_F(self, snes, x, b) -> None:
        t0 = time.perf_counter()
        x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
        self._load_x(x)
        try:
            self.constitutive_update(tangent=True)
        except ReturnMapError as err:       # on all ranks: a NaN residual ends the solve
            log.info("%s; the residual is set to NaN", err)
            b.set(np.nan)
            return
        x.copy(self._x_last)
        with b.localForm() as b_local:
            b_local.set(0.0)
        fpetsc.assemble_vector(b, self._F_form)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        self._force_scale = b.norm()      # includes the reactions: units-consistent floor
        with b.localForm() as b_local:       # ghosts were added to their owners: clear them
            b_local.array[b.getLocalSize():] = 0.0
        for term in self._assembled_terms:
            term.add_residual(b)
        if self._dirichlet_gap(x):
            compat.apply_lifting(b, [self._J_form], self.bcs, x, scale=-1.0)
            b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            if self._projection is not None:
                self._projection.lift_residual(b, self.bcs, x, self._owned(self.tangent, self.ncomp ** 2))
        compat.set_bc(b, self.bcs, x, -1.0)
        self.timings["residual"] += time.perf_counter() - t0

    def _dirichlet_gap(self, x) -> bool:
        """Whether ``x`` misses a Dirichlet value anywhere (collective).  Where it does not, the
        lifting of the residual adds exactly zero and is skipped: it runs the tangent's element
        kernels on every constrained cell (its cost: see
        docs/speed-accuracy-details.md, "Where the time goes: levers")."""
        if not self.bcs:
            return False
        if self._gap is None:
            self._gap = x.duplicate()
        self._gap.set(0.0)
        compat.set_bc(self._gap, self.bcs, x, 1.0)
        return self._gap.norm(PETSc.NormType.NORM_INFINITY) > 0.0

    def _snes_J(self, snes, x, A, P) -> None:
        t0 = time.perf_counter()
        if not x.equal(self._x_last):      # the tangent must belong to this x
            x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            self._load_x(x)
            self.constitutive_update(tangent=True)
            x.copy(self._x_last)
        self._assemble_jacobian(A)
        self.timings["jacobian"] += time.perf_counter() - t0

    def _assemble_jacobian(self, A) -> None:
        A.zeroEntries()
        fpetsc.assemble_matrix(A, self._J_form, self.bcs)
        if self._assembled_terms:
            A.assemble(PETSc.Mat.AssemblyType.FLUSH)
            for term in self._assembled_terms:
                term.add_jacobian(A)
        A.assemble()
        if self._projection is not None:
            self._projection.add_jacobian(A, self.bcs, self._owned(self.tangent, self.ncomp ** 2))

    def _snes_converged(self, snes, it, norms):
        xnorm, gnorm, fnorm = norms
        self._history.append(float(fnorm))
        self._plateau = 0.0
        rtol, atol, stol, max_it = snes.getTolerances()
        if not np.isfinite(fnorm):
            return PETSc.SNES.ConvergedReason.DIVERGED_FNORM_NAN
        if it == 0:
            self._fnorm0 = fnorm
            if fnorm <= atol:
                return PETSc.SNES.ConvergedReason.CONVERGED_FNORM_ABS
            return PETSc.SNES.ConvergedReason.ITERATING
        if fnorm <= atol or fnorm <= self.force_rtol * self._force_scale:
            return PETSc.SNES.ConvergedReason.CONVERGED_FNORM_ABS
        if fnorm <= rtol * self._fnorm0:
            return PETSc.SNES.ConvergedReason.CONVERGED_FNORM_RELATIVE
        if fnorm > self.divergence_factor * self._fnorm0:      # fail fast, the stepper cuts
            return PETSc.SNES.ConvergedReason.DIVERGED_DTOL
        if _stalled(self._history, *self.stagnation):
            if fnorm <= self.plateau_rtol * self._force_scale:       # a plateau at the noise floor
                self._plateau = fnorm / self._force_scale
                return PETSc.SNES.ConvergedReason.CONVERGED_FNORM_ABS
            return PETSc.SNES.ConvergedReason.DIVERGED_LOCAL_MIN     # a plateau or a cycle: cut now
        if it >= max_it:
            return PETSc.SNES.ConvergedReason.DIVERGED_MAX_IT
        return PETSc.SNES.ConvergedReason.ITERATING

    # ------------------------------------------------------------------ public stepping API
    def solve_increment(self, border: "Border | None" = None) -> NewtonReport:
        """Newton solve from the last converged state for the current boundary data.

        ``border``: extra unknowns solved with the displacement in one Newton system (see
        :class:`Border`; e.g. the wheel's rotation and height); ``None``: PETSc SNES.
        Does not commit: call :meth:`commit` (accept) or :meth:`restore` (reject) afterwards.
        """
        self._compile()
        self._history = []
        self._linear_solves = 0
        t0 = time.perf_counter()
        compat.petsc_vector(self.u).copy(self._x)
        # an automatic iterative choice that fails gives way to the direct solver, which then
        # repeats a plain solve from the same start (a bordered one is cut and repeated by its caller)
        start = self._x.copy() if self._auto_iterative and self.linear_solver == "iterative" else None
        retry = False
        its = 0
        try:
            if border is None:
                self.snes.solve(None, self._x)
                reason, its = self.snes.getConvergedReason(), self.snes.getIterationNumber()
                self._linear_solves = its
            else:
                reason, its = self._bordered_newton(border)
        except PETSc.Error as err:        # e.g. a zero pivot in the factorisation
            # one line (a flooded stdout/stderr pipe has killed a rank under mpirun); the full
            # PETSc traceback only at DEBUG
            its = max(len(self._history) - 1, 0)
            code = getattr(err, "ierr", None)
            log.warning("Newton raised PETSc error %s after %d iterations (%s); linear solver re-created",
                        code, its, _first_line(err))
            log.debug("PETSc error traceback:\n%s", err)
            reason = REASON_PETSC_ERROR
            self.reset_linear_solver()
        except ReturnMapError as err:       # raised in the tangent's evaluation, on all ranks
            its = max(len(self._history) - 1, 0)
            log.info("%s (tangent)", err)
            reason = REASON_RETURN_MAP
            self.reset_linear_solver()
        if reason == PETSc.SNES.ConvergedReason.DIVERGED_LINEAR_SOLVE:
            # a failed MUMPS factorisation (e.g. zero pivots from apex points) leaves the factor in
            # its error state and every later factorisation is skipped: without a fresh linear
            # solver all following (cut) steps fail the same way
            log.info("linear solve failed inside Newton (%s); linear solver re-created",
                     self.snes.getKSP().getConvergedReason())
            if start is not None:
                self._use_direct_solver()
                retry = border is None
            self.reset_linear_solver()
        dt = time.perf_counter() - t0
        self.timings["snes"] += dt
        self.timings["iterations"] += its
        self.timings["linear_solves"] += self._linear_solves
        if start is not None:
            if retry:
                self._load_x(start)
            start.destroy()
        if retry:
            return self.solve_increment()
        converged = reason > 0
        plateau = self._plateau if converged else 0.0
        #: ``|F|`` (N) left by the last solve if it ended on an accepted plateau, else 0
        self.plateau_residual = plateau * self._force_scale
        if plateau:
            self.plateaus["accepted"] += 1
            self.plateaus["max_residual_ratio"] = max(self.plateaus["max_residual_ratio"], plateau)
        if converged:
            self._x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            self._load_x(self._x)
            self.constitutive_update(tangent=False)   # stress of the accepted iterate
        return NewtonReport(converged=converged, iterations=its, reason=int(reason),
                            residual_norms=list(self._history), time=dt,
                            counts=self.counts() if converged else {}, linear_solves=self._linear_solves,
                            plateau=plateau, plateau_repeats=self.stagnation[0] if plateau else 0)

    def _bordered_newton(self, border: "Border") -> tuple[int, int]:
        """Newton's method on ``(u, q)`` with the border's equations ``G(u, q) = 0``; returns the
        (SNES-style) converged reason and the number of iterations.

        Each iteration solves ``[K B; C D] [du; dq] = -[r; G]`` by block elimination with the
        problem's linear solver: ``K y0 = r`` and ``K Y = B`` (one factorisation or
        preconditioner set-up, ``1 + m`` solves), ``(D - C Y) dq = C y0 - G`` (m x m),
        ``du = -(y0 + Y dq)`` with ``dq`` as limited by ``border.limit`` (``du`` then solves the
        soil's equations for that ``dq``).  The step is then backtracked on
        ``|r|^2 + |W G|^2`` (``W = border.merit_weights``) when the problem's SNES line search
        is ``bt``.  Converged when the force residual passes the usual test and
        ``border.satisfied(G)``."""
        ITERATING = PETSc.SNES.ConvergedReason.ITERATING
        x, b = self._x, self._b
        max_it = self.snes.getTolerances()[3]
        backtrack = self.petsc_options.get("snes_linesearch_type") == "bt"
        y0, x_old = x.duplicate(), x.duplicate()
        Y = [x.duplicate() for _ in range(border.size)]

        def holds(fnorm, force_ok):
            """The pose is held (plain Newton on the displacement, border forms not assembled) until
            the force residual is below hold_rtol of its initial value and below hold_force, or
            has converged."""
            return not force_ok and (fnorm > border.hold_rtol * self._fnorm0 or fnorm > border.hold_force)

        def merit(fnorm, der):
            return fnorm ** 2 + (0.0 if der is None else float(np.sum((border.merit_weights * der.values) ** 2)))

        it = 0
        self._snes_F(self.snes, x, b)
        fnorm, der = b.norm(), None
        try:
            while True:
                reason = self._snes_converged(self.snes, it, (0.0, 0.0, fnorm))
                force_ok = reason > 0
                held = holds(fnorm, force_ok)
                if der is None and not held:
                    der = border.evaluate()
                if force_ok and not border.satisfied(der.values):
                    reason = ITERATING if it < max_it else PETSc.SNES.ConvergedReason.DIVERGED_MAX_IT
                if reason != ITERATING:
                    return reason, it
                dq = self._bordered_direction(border, None if held else der, y0, Y)
                if dq is None:
                    return PETSc.SNES.ConvergedReason.DIVERGED_LINEAR_SOLVE, it
                phi0 = merit(fnorm, None if held else der)
                x.copy(x_old)
                lam, moved = 1.0, 0.0
                for _ in range(8 if backtrack else 1):
                    x_old.copy(x)
                    x.axpy(-lam, y0)
                    border.move((lam - moved) * dq)
                    moved = lam
                    self._snes_F(self.snes, x, b)
                    fnorm, der = b.norm(), None if held else border.evaluate()
                    phi = merit(fnorm, der)
                    if phi <= (1.0 - 2e-4 * lam) * phi0 or not np.isfinite(phi0):
                        break
                    # minimum of the quadratic through phi0, phi'(0) = -2 phi0 and phi(lam)
                    curv = (phi - phi0 + 2.0 * lam * phi0) / lam ** 2 if np.isfinite(phi) else np.inf
                    lam = float(np.clip(phi0 / curv, 0.1 * lam, 0.5 * lam)) if curv > 0 else 0.5 * lam
                it += 1
                log.debug("  bordered Newton %d: |r| %.3e, step %.2g%s", it, fnorm, lam,
                          "" if held else f", pose move {np.array2string(lam * dq, precision=3)}, "
                          f"G {np.array2string(der.values, precision=3)}")
        finally:
            for vec in (y0, x_old, *Y):
                vec.destroy()

    def _bordered_direction(self, border: "Border", der, y0, Y) -> np.ndarray | None:
        """One bordered Newton direction at the state of the last residual :attr:`_b`: ``y0``
        becomes ``-du`` (in place) and the pose increment ``dq`` is returned (zeros while the pose
        is held, ``der`` None); ``None`` when a linear solve fails."""
        ksp, A, b = self.snes.getKSP(), self._A, self._b
        self._snes_J(self.snes, self._x, A, A)
        ksp.setOperators(A, A)
        for rhs, sol in zip([b] if der is None else [b, *der.residual_d_pose], [y0, *Y]):
            ksp.solve(rhs, sol)
            self._linear_solves += 1
            if ksp.getConvergedReason() < 0:
                return None
        if der is None:
            return np.zeros(border.size)
        C = der.d_displacement
        S = der.d_pose - np.array([[c.dot(y) for y in Y] for c in C]).reshape(der.d_pose.shape)
        rhs = np.array([c.dot(y0) for c in C]) - der.values
        try:
            dq = np.linalg.solve(S, rhs)
        except np.linalg.LinAlgError:
            dq = np.linalg.lstsq(S, rhs, rcond=1e-12)[0]
        dq = border.limit(dq)
        y0.maxpy(list(dq), Y)
        return dq

    @contextlib.contextmanager
    def line_search(self, kind: str):
        """Run the solves inside the ``with`` block with the SNES line search ``kind`` (``"basic"``:
        full Newton steps, ``"bt"``: backtracking), then restore the problem's own."""
        self._compile()
        own = self.petsc_options.get("snes_linesearch_type", "basic")

        def use(line_search: str) -> None:
            self.petsc_options["snes_linesearch_type"] = line_search
            self._push_options()
            self.snes.setFromOptions()

        use(kind)
        try:
            yield
        finally:
            use(own)
