"""The linear solver of a problem's Newton iteration: MUMPS LU, or GMRES with smoothed-aggregation
AMG above :data:`AUTO_ITERATIVE_DOFS` (``linear_solver="auto"``), the PETSc options under the
problem's prefix, and a fresh solver after a PETSc failure.

:class:`LinearSolverChoice` is a mixin of :class:`~rollsim.solver.problem.PlasticityProblem`.
"""
from __future__ import annotations

import re
import time

import numpy as np
from dolfinx.fem import petsc as fpetsc
from mpi4py import MPI
from petsc4py import PETSc

from rollsim import compat
from rollsim.log import get_logger

__all__ = ["LinearSolverChoice", "DEFAULT_PETSC_OPTIONS", "AUTO_ITERATIVE_DOFS", "ITERATIVE_SOLVER_OPTIONS",
           "rigid_body_modes"]

log = get_logger("solver")

DEFAULT_PETSC_OPTIONS = {
    "snes_type": "newtonls",
    "snes_linesearch_type": "basic",   # full Newton steps; "bt" for backtracking
    "snes_max_it": 25,
    "snes_rtol": 1e-9,
    "snes_atol": 1e-30,
    "snes_stol": 0.0,
    "ksp_type": "preonly",
    "pc_type": "lu",
    "pc_factor_mat_solver_type": "mumps",
}

#: ``linear_solver="auto"`` (see :data:`rollsim.solver.options.LINEAR_SOLVERS`): direct (MUMPS LU,
#: :data:`DEFAULT_PETSC_OPTIONS`) up to this many global dofs, :data:`ITERATIVE_SOLVER_OPTIONS`
#: above, where the LU factorisation dominates the run time (see docs/benchmarks.md, "Presets")
AUTO_ITERATIVE_DOFS = 100_000

#: GMRES (the tangent is unsymmetric with friction or non-associated flow) preconditioned by
#: smoothed-aggregation AMG (GAMG) with the rigid-body modes as near-null space (attached by
#: :class:`PlasticityProblem`).  Inexact Newton: a relative tolerance of 1e-6 gives the forces of
#: 1e-10 in less time (``python -m benchmarks indentation cases --linear-solver iterative --petsc-option
#: ksp_rtol=...``; measured: see docs/benchmarks.md, "Presets"); the Newton tolerance
#: (``snes_rtol``), not this one, sets the accuracy.
ITERATIVE_SOLVER_OPTIONS = {
    "ksp_type": "gmres",
    "ksp_gmres_restart": 150,
    "ksp_rtol": 1e-6,
    "ksp_max_it": 1500,
    "pc_type": "gamg",
    "pc_gamg_threshold": 0.02,
    "pc_gamg_coarse_eq_limit": 1000,
}


def _first_line(err, limit: int = 200) -> str:
    """One-line summary of an exception (PETSc errors carry a whole traceback): the message lines
    without the ``[rank] Function() at file:line`` frames, joined, at most ``limit`` characters."""
    lines = [re.sub(r"^\[\d+\]\s*", "", ln).strip() for ln in str(err).splitlines()]
    msg = [ln for ln in lines if ln and "() at " not in ln and not ln.startswith("error code")
           and not set(ln) <= set("-")]
    text = "; ".join(msg) or type(err).__name__
    return text if len(text) <= limit else text[: limit - 3] + "..."


def rigid_body_modes(V) -> PETSc.NullSpace:
    """Orthonormal rigid-body modes of the vector space ``V`` (3 in 2D, 6 in 3D) as a PETSc null
    space: the near-null space that AMG needs to coarsen elasticity well."""
    gdim = V.mesh.geometry.dim
    n_own = V.dofmap.index_map.size_local
    x = V.tabulate_dof_coordinates()[:n_own]
    modes = [np.zeros((n_own, gdim)) for _ in range(3 if gdim == 2 else 6)]
    for i in range(gdim):                          # translations
        modes[i][:, i] = 1.0
    rotations = [(0, 1)] if gdim == 2 else [(0, 1), (1, 2), (2, 0)]
    for m, (i, j) in zip(modes[gdim:], rotations):  # rotations in the (i, j) planes
        m[:, i], m[:, j] = -x[:, j], x[:, i]
    vecs = []
    for m in modes:
        vec = PETSc.Vec().createMPI((n_own * gdim, PETSc.DECIDE), bsize=gdim, comm=V.mesh.comm)
        vec.setArray(m.ravel())
        for other in vecs:                         # Gram-Schmidt
            vec.axpy(-vec.dot(other), other)
        vec.normalize()
        vecs.append(vec)
    return PETSc.NullSpace().create(vectors=vecs, comm=V.mesh.comm)


class LinearSolverChoice:
    """The Newton iteration's linear solver (mixin of ``PlasticityProblem``)."""

    def _init_linear_solver(self, linear_solver: str, petsc_options: dict | None, options_prefix: str) -> None:
        """Resolve ``"auto"`` by the problem's size (:attr:`n_dofs`) and set the PETSc options."""
        self.options_prefix = options_prefix
        #: "auto" chose the iterative solver: it gives way to the direct one where it fails
        self._auto_iterative = linear_solver == "auto" and self.n_dofs > AUTO_ITERATIVE_DOFS
        if linear_solver == "auto":
            linear_solver = "iterative" if self._auto_iterative else "direct"
        self.linear_solver = linear_solver
        self._user_petsc_options = dict(petsc_options or {})
        self.petsc_options = self._solver_options(linear_solver)

    def _push_options(self) -> None:
        """Write this problem's options to the (process-global) PETSc options database under its
        prefix; another problem with the same prefix may have overwritten them since."""
        opts = PETSc.Options()
        for k, val in self.petsc_options.items():
            opts[self.options_prefix + k] = val

    def _use_direct_solver(self) -> None:
        """Switch an automatic choice of the iterative linear solver to the direct one (MUMPS LU)
        for the rest of the run, after the iterative solve failed (e.g. GAMG on a tire's carcass
        in contact with the soil); :attr:`linear_solver` then reads "direct"."""
        log.warning("the iterative linear solver failed (%d dofs): the direct solver (MUMPS LU) takes "
                    "over for the rest of the run", self.n_dofs)
        opts = PETSc.Options()
        for k in ITERATIVE_SOLVER_OPTIONS:
            if k not in self._user_petsc_options:
                opts.delValue(self.options_prefix + k)
        self.linear_solver = "direct"
        self.petsc_options = self._solver_options("direct")

    def _solver_options(self, linear_solver: str) -> dict:
        """The PETSc options of ``linear_solver`` ("direct" or "iterative"): the defaults, the
        iterative solver's own, then the caller's ``petsc_options`` over them."""
        iterative = ITERATIVE_SOLVER_OPTIONS if linear_solver == "iterative" else {}
        return {**DEFAULT_PETSC_OPTIONS, **iterative, **self._user_petsc_options}

    def reset_linear_solver(self) -> None:
        """Give SNES a fresh KSP with the same options.  After a PETSc error inside SNES (e.g.
        MUMPS failing on a singular tangent) the old KSP is unusable (PETSc 3.18: "Cannot embed
        PCPreSolve() more than twice" on every later solve), so a cut step could never succeed.
        :meth:`solve_increment` calls this itself after such an error."""
        if not self._compiled:
            return
        try:
            old = self.snes.getKSP()
            ksp = PETSc.KSP().create(old.getComm())
            ksp.setOptionsPrefix(old.getOptionsPrefix())
            self._push_options()
            ksp.setFromOptions()
            self.snes.setKSP(ksp)
            old.destroy()
            log.debug("linear solver re-created after a PETSc error")
        except Exception as err:          # pragma: no cover - best effort
            log.warning("could not re-create the linear solver: %s", _first_line(err))

    def elastic_solve_time(self, repeat: int = 3) -> float:
        """Wall time of one linear elastic solve with this problem's linear solver (assemble the
        elastic stiffness, set up the preconditioner - numeric LU factorisation or AMG hierarchy -,
        solve; the symbolic factorisation is reused, as in Newton), the reference for the cost of a
        plastic Newton iteration (best of ``repeat``)."""
        self._compile()
        saved = self.tangent.x.array.copy()
        self._set_owned(self.tangent, self._elastic_tangent())
        b = compat.create_vector(self._F_form)
        b.set(1.0)
        compat.set_bc(b, self.bcs)
        y = b.duplicate()
        ksp = PETSc.KSP().create(self.comm)
        ksp.setOptionsPrefix(self.options_prefix)    # the Newton iteration's linear solver
        self._push_options()
        ksp.setFromOptions()
        best = np.inf
        for _ in range(repeat + 1):              # the first pass (symbolic factorisation) is warm-up
            t0 = time.perf_counter()
            self._A.zeroEntries()
            fpetsc.assemble_matrix(self._A, self._J_form, self.bcs)
            self._A.assemble()
            if self._projection is not None:
                self._projection.add_jacobian(self._A, self.bcs, self._owned(self.tangent, self.ncomp ** 2))
            ksp.setOperators(self._A)
            ksp.solve(b, y)
            if _:
                best = min(best, time.perf_counter() - t0)
        dt = self.comm.allreduce(best, op=MPI.MAX)
        ksp.destroy(); b.destroy(); y.destroy()
        self.tangent.x.array[:] = saved
        return dt
