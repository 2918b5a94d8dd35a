"""B-bar by exact cell projections, for cells on which the divergence of the displacement is not
linear: quadrilaterals and hexahedra (the divergence of a Q2 field is quadratic in two of its
coordinates), where a Taylor value about the midpoint is not the cell's mean.

Every strain's volumetric part is replaced by its L2 projection per cell onto the constants
(``degree`` 0: the cell mean, Q2-P0, one volumetric constraint per cell) or onto the linear
functions (``degree`` 1: Q2-P1, 1 + dim constraints per cell, the optimal pairing for Q2):
``eps_bar(w) = e(w) + P(tr w) m / 3`` with the pointwise ``e(w) = eps(w) - tr(w) m / 3``, ``m``
the identity as a Mandel vector and ``P(f) = psi . M^-1 int_K psi f`` on each cell ``K``
(basis ``psi`` = 1 or (1, x - x_K), ``M = int_K psi psi^T``; the problem's quadrature, weighted
by the configuration's volume ratio ``J_n``):

* strain increment at the quadrature points: the trace projected per cell (numpy);
* residual: ``int sigma . eps_bar(v) = int sigma_bar . eps(v)`` with
  ``sigma_bar = sigma + (P(tr sigma) - tr sigma) m / 3`` (P is self-adjoint), a quadrature
  Function in the usual form: reactions by :meth:`PlasticityProblem.internal_force` need nothing
  else;
* tangent: ``int eps_bar(v) . C eps_bar(du)`` is the pointwise form on ``e`` plus couplings
  within each cell, ``G^T M^-1 B + B^T (M^-1 H + M^-1 S M^-1 B / 9)`` with the cell-by-dof
  matrices ``B = int_K psi tr(w)``, ``G = int_K psi e(w) . C m / 3`` (``B^T`` and ``G^T``
  assembled as such),
  ``H = int_K psi m . C e(w) / 3`` and the cell blocks ``S = int_K psi psi^T m . C m``, added to
  the assembled Jacobian (and to the residual's lifting).
"""
from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fpetsc
from petsc4py import PETSc

from rollsim import compat


def mandel_trace(e):
    """Trace of a Mandel strain or stress vector (2D plane strain or 3D)."""
    return e[0] + e[1] + e[2]


def mandel_identity(ncomp: int):
    """The identity as a Mandel vector."""
    return ufl.as_vector([1.0, 1.0, 1.0] + [0.0] * (ncomp - 3))


class CellProjection:
    """The volumetric projection of :mod:`rollsim.solver.cell_average` for one problem.

    ``strain``: pointwise Mandel strain of a Function (``w -> vector``, on the problem's
    configuration); ``Ct``: the tangent as a UFL matrix; ``J_n``: volume ratio of the
    configuration (1 in small strain); ``dx``: the elastoplastic cells' measure (the problem's
    quadrature); ``rule``: its reference points and weights; ``degree``: 0 (cell mean) or 1;
    ``fixed_configuration``: the mesh and ``J_n`` never change (small strain), so the matrices that
    depend on them alone (``B`` and ``Bt``) are assembled once per set of Dirichlet conditions."""

    #: the matrices that depend on the configuration only
    GEOMETRIC = ("B", "Bt")

    def __init__(self, mesh, V, strain, Ct, J_n, dx, rule: tuple[np.ndarray, np.ndarray], n_cells: int,
                 degree: int = 0, fixed_configuration: bool = False):
        if degree not in (0, 1):
            raise ValueError(f"degree must be 0 or 1, got {degree}")
        points, weights = rule
        gdim = mesh.geometry.dim
        self.n_cells, self.nq, self.ncomp = n_cells, weights.size, Ct.ufl_shape[0]
        self.comm = mesh.comm
        x, centre = ufl.SpatialCoordinate(mesh), compat.cell_midpoints(mesh)
        psi = ufl.as_vector([1.0] + [x[i] - centre[i] for i in range(gdim)] * degree)
        self.k = psi.ufl_shape[0]
        self._psi = np.ones((n_cells, self.nq, self.k))
        if degree:
            offset = compat.expression(x - centre, points)
            self._psi[..., 1:] = compat.evaluate(offset, mesh).reshape(n_cells, self.nq, gdim)
        self._volume_expr = compat.expression(abs(ufl.JacobianDeterminant(mesh)) * J_n, points)
        self._mesh, self._ref_weights = mesh, weights
        self.weights = self._Minv = None
        m = mandel_identity(self.ncomp)
        R = compat.vector_space(mesh, 0, "DG", dim=self.k)
        r, w = ufl.TestFunction(R), ufl.TrialFunction(V)
        rt, v = ufl.TrialFunction(R), ufl.TestFunction(V)
        e = self.deviatoric(strain)
        # the cell-by-dof matrices B, H and the transposes of B and G assembled as such (MatMatMult
        # of assembled transposes is several times cheaper than MatTransposeMatMult under MPI)
        self._forms = {"B": fem.form(ufl.dot(r, psi) * mandel_trace(strain(w)) * J_n * dx),
                       "H": fem.form(ufl.dot(r, psi) * ufl.dot(m, ufl.dot(Ct, e(w))) / 3.0 * J_n * dx),
                       "Bt": fem.form(ufl.dot(rt, psi) * mandel_trace(strain(v)) * J_n * dx),
                       "Gt": fem.form(ufl.dot(rt, psi) * ufl.dot(e(v), ufl.dot(Ct, m)) / 3.0 * J_n * dx)}
        self._mats = {key: fpetsc.create_matrix(self._forms[key]) for key in ("H", "Gt")}
        self._fixed = fixed_configuration
        self._geometric: dict[tuple, dict[str, PETSc.Mat]] = {}   # Dirichlet conditions -> B, Bt
        imap = R.dofmap.index_map
        self._block_start = imap.local_range[0]
        self._block_of_cell = np.array([R.dofmap.cell_dofs(c)[0] for c in range(n_cells)], dtype=np.int64)
        self._coupling = self._free = None

    def deviatoric(self, strain):
        """``w -> e(w)``: the strain without its pointwise volumetric part."""
        m = mandel_identity(self.ncomp)
        return lambda w: strain(w) - mandel_trace(strain(w)) / 3.0 * m

    # -------------------------------------------------------------- quadrature-point values
    def refresh(self) -> None:
        """Integration weights of the owned quadrature points (reference weight times the cell's
        Jacobian determinant times ``J_n``) and the cells' inverse Gram matrices, for the current
        configuration (computed at first use; call again when ``J_n`` has changed)."""
        self.weights = (compat.evaluate(self._volume_expr, self._mesh).reshape(self.n_cells, self.nq)
                        * self._ref_weights)
        M = np.einsum("cq,cqa,cqb->cab", self.weights, self._psi, self._psi)
        self._Minv = np.linalg.inv(M)

    def projected(self, values: np.ndarray) -> np.ndarray:
        """Mandel vectors at the owned quadrature points, (points, components), with their trace
        replaced by its projection per cell."""
        if self.weights is None:
            self.refresh()
        v = values.reshape(self.n_cells, self.nq, self.ncomp).copy()
        tr = v[..., :3].sum(-1)
        coef = np.einsum("cab,cq,cqb,cq->ca", self._Minv, self.weights, self._psi, tr)
        bar = np.einsum("cqa,ca->cq", self._psi, coef)
        v[..., :3] += ((bar - tr) / 3.0)[..., None]
        return v.reshape(-1, self.ncomp)

    # -------------------------------------------------------------- tangent
    def _block_diagonal(self, blocks: np.ndarray) -> PETSc.Mat:
        """A matrix on the projection's dofs with the cells' ``k x k`` ``blocks`` on its diagonal."""
        n, k = self.n_cells, self.k
        ordered = np.empty_like(blocks)
        ordered[self._block_of_cell] = blocks
        rows = np.arange(0, n * k * k + 1, k, dtype=PETSc.IntType)
        cols = ((self._block_start + np.arange(n))[:, None, None] * k + np.arange(k)[None, None, :])
        cols = np.broadcast_to(cols, (n, k, k)).reshape(-1).astype(PETSc.IntType)
        mat = PETSc.Mat().createAIJ(size=((n * k, None), (n * k, None)), csr=(rows, cols, ordered.reshape(-1)),
                                    comm=self.comm)
        mat.assemble()
        return mat

    def _assembled(self, key: str, bcs, mat: PETSc.Mat) -> PETSc.Mat:
        mat.zeroEntries()
        fpetsc.assemble_matrix(mat, self._forms[key], bcs)
        mat.assemble()
        return mat

    def _geometric_matrices(self, bcs) -> dict[str, PETSc.Mat]:
        """``B`` and ``Bt`` with the rows and columns of ``bcs`` zero: kept while the configuration
        is fixed (for the last two sets of conditions: with and without them), else reassembled."""
        key = tuple(bcs)
        mats = self._geometric.get(key)
        if mats is not None and self._fixed:
            return mats
        if mats is None:
            if len(self._geometric) >= 2:
                for mat in self._geometric.pop(next(iter(self._geometric))).values():
                    mat.destroy()
            mats = self._geometric[key] = {k: fpetsc.create_matrix(self._forms[k]) for k in self.GEOMETRIC}
        for k in self.GEOMETRIC:
            self._assembled(k, bcs, mats[k])
        return mats

    def coupling(self, bcs, tangent: np.ndarray, result: PETSc.Mat | None = None) -> PETSc.Mat:
        """The couplings within the cells at the current tangent (``tangent``: its values at the
        owned quadrature points, (points, components^2)) and configuration, a dof-by-dof matrix
        (into ``result`` when given); the rows and columns of the Dirichlet conditions ``bcs`` are
        zero."""
        mats = {**self._geometric_matrices(bcs),
                **{key: self._assembled(key, bcs, mat) for key, mat in self._mats.items()}}
        if self.weights is None:
            self.refresh()
        nc = self.ncomp
        mCm = tangent.reshape(self.n_cells, self.nq, nc, nc)[..., :3, :3].sum((-1, -2))
        S = np.einsum("cq,cqa,cqb,cq->cab", self.weights, self._psi, self._psi, mCm)
        Minv = self._block_diagonal(self._Minv)
        D = self._block_diagonal(self._Minv @ S @ self._Minv / 9.0)
        same = PETSc.Mat.Structure.SAME_NONZERO_PATTERN
        X = Minv.matMult(mats["B"])
        Y = Minv.matMult(mats["H"])
        DB = D.matMult(mats["B"])
        Y.axpy(1.0, DB, structure=same)
        result = mats["Gt"].matMult(X, result=result)
        extra = mats["Bt"].matMult(Y)
        result.axpy(1.0, extra, structure=same)
        for obj in (Minv, D, X, Y, DB, extra):
            obj.destroy()
        return result

    def add_jacobian(self, A: PETSc.Mat, bcs, tangent: np.ndarray) -> None:
        """Add :meth:`coupling` (without the rows and columns of ``bcs``) to the assembled Jacobian ``A``."""
        self._coupling = self.coupling(bcs, tangent, self._coupling)
        A.axpy(1.0, self._coupling, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)

    def lift_residual(self, b: PETSc.Vec, bcs, x: PETSc.Vec, tangent: np.ndarray) -> None:
        """``b += C (g - x)`` on the owned entries, with ``C`` the couplings and ``g - x`` the
        Dirichlet values missed by ``x`` (zero off the constrained dofs): the part of the
        residual's lifting the assembled forms do not hold.  Without it, the first Newton
        iteration of a step with a prescribed displacement misses the volumetric response to it."""
        self._free = self.coupling([], tangent, self._free)
        gap = x.duplicate()
        gap.set(0.0)
        compat.set_bc(gap, bcs, x, 1.0)
        lift = self._free.createVecLeft()
        self._free.mult(gap, lift)
        b.axpy(1.0, lift)
        gap.destroy()
        lift.destroy()
