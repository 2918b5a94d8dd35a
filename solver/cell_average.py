"""B-bar by exact cell averages, for cells on which the divergence of the displacement is not
linear: quadrilaterals and hexahedra (the divergence of a Q2 field is quadratic in two of its
coordinates), where a Taylor value about the midpoint is not the cell's mean.

Every strain's volumetric part is replaced by its mean over the cell,
``eps_bar(w) = e(w) + a_K(w) m / 3`` with the pointwise ``e(w) = eps(w) - tr(w) m / 3``,
``m`` the identity as a Mandel vector and ``a_K(w) = int_K tr(w) / |K|`` (the problem's
quadrature, weighted by the configuration's volume ratio ``J_n``), so each cell carries one
volumetric constraint:

* strain increment at the quadrature points: the trace's weighted mean per cell (numpy);
* residual: ``int sigma . eps_bar(v) = int sigma_bar . eps(v)`` with the stress of averaged
  trace ``sigma_bar = sigma + (mean_K tr sigma - tr sigma) m / 3``, a quadrature Function in the
  usual form (reactions by :meth:`PlasticityProblem.internal_force` need nothing else);
* tangent: ``int eps_bar(v) . C eps_bar(du)`` is the pointwise form on ``e`` plus couplings of
  rank one per cell, ``G^T diag(1/|K|) B + B^T (diag(1/|K|) H + diag(c / 9|K|^2) B)`` with the
  cell-by-dof matrices ``B = int_K tr(w)``, ``G = int_K e(w) . C m / 3``,
  ``H = int_K m . C e(w) / 3`` and ``c = int_K m . C m``, added to the assembled Jacobian.
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


class CellAverage:
    """The cell means of :mod:`rollsim.solver.cell_average` for one problem.

    ``strain``: pointwise Mandel strain of a Function (``w -> vector``, on the problem's
    configuration); ``Ct``: the tangent as a UFL matrix; ``J_n``: volume ratio of the
    configuration (1 in small strain); ``dx``: the elastoplastic cells' measure (the problem's
    quadrature); ``rule``: its reference points and weights."""

    def __init__(self, mesh, V, strain, Ct, J_n, dx, rule: tuple[np.ndarray, np.ndarray], n_cells: int):
        points, weights = rule
        self.n_cells, self.nq = n_cells, weights.size
        self.ncomp = Ct.ufl_shape[0]
        self._mesh = mesh
        self._volume_expr = compat.expression(abs(ufl.JacobianDeterminant(mesh)) * J_n, points)
        self._weights = weights
        m = mandel_identity(self.ncomp)
        Q0 = compat.scalar_space(mesh, 0, "DG")
        q, w = ufl.TestFunction(Q0), ufl.TrialFunction(V)
        e = self.deviatoric(strain)
        self._forms = {"B": fem.form(q * mandel_trace(strain(w)) * J_n * dx),
                       "G": fem.form(q * ufl.dot(e(w), ufl.dot(Ct, m)) / 3.0 * J_n * dx),
                       "H": fem.form(q * ufl.dot(m, ufl.dot(Ct, e(w))) / 3.0 * J_n * dx)}
        self._volume = fem.form(q * J_n * dx)
        self._mCm = fem.form(q * ufl.dot(m, ufl.dot(Ct, m)) * J_n * dx)
        self._mats = {k: fpetsc.create_matrix(f) for k, f in self._forms.items()}
        self._coupling = self._free = None

    def deviatoric(self, strain):
        """``w -> e(w)``: the strain without its pointwise volumetric part."""
        m = mandel_identity(self.ncomp)
        return lambda w: strain(w) - mandel_trace(strain(w)) / 3.0 * m

    # -------------------------------------------------------------- quadrature-point values
    def point_weights(self) -> np.ndarray:
        """Integration weights of the owned quadrature points, (cells, points): reference weight
        times the cell's Jacobian determinant times ``J_n``."""
        return compat.evaluate(self._volume_expr, self._mesh).reshape(self.n_cells, self.nq) * self._weights

    def averaged(self, values: np.ndarray, weights: np.ndarray) -> np.ndarray:
        """Mandel vectors at the owned quadrature points, (points, components), with their trace
        replaced by its weighted cell mean (``weights`` from :meth:`point_weights`)."""
        v = values.reshape(self.n_cells, self.nq, self.ncomp).copy()
        tr = v[..., :3].sum(-1)
        mean = (weights * tr).sum(1) / weights.sum(1)
        v[..., :3] += ((mean[:, None] - tr) / 3.0)[..., None]
        return v.reshape(-1, self.ncomp)

    # -------------------------------------------------------------- tangent
    def _cell_vector(self, form) -> PETSc.Vec:
        vec = compat.create_vector(form)
        with vec.localForm() as loc:
            loc.set(0.0)
        fpetsc.assemble_vector(vec, form)
        vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        return vec

    def coupling(self, bcs, result: PETSc.Mat | None = None) -> PETSc.Mat:
        """The cell couplings of the averaged volumetric strain at the current tangent and
        configuration, a dof-by-dof matrix (into ``result`` when given); the rows and columns of
        the Dirichlet conditions ``bcs`` are zero."""
        mats = self._mats
        for key, form in self._forms.items():
            mats[key].zeroEntries()
            fpetsc.assemble_matrix(mats[key], form, bcs)
            mats[key].assemble()
        volume, mCm = self._cell_vector(self._volume), self._cell_vector(self._mCm)
        inv = volume.copy()
        with inv.localForm() as loc:       # cells outside the measure (another body) have no volume
            v = loc.array
            v[:] = np.divide(1.0, v, out=np.zeros_like(v), where=v > 0)
        scaled_c = mCm.copy()
        scaled_c.pointwiseMult(mCm, inv)
        scaled_c.pointwiseMult(scaled_c, inv)
        scaled_c.scale(1.0 / 9.0)
        same = PETSc.Mat.Structure.SAME_NONZERO_PATTERN
        X = mats["B"].copy()
        X.diagonalScale(L=inv)
        Y = mats["H"].copy()
        Y.diagonalScale(L=inv)
        cB = mats["B"].copy()
        cB.diagonalScale(L=scaled_c)
        Y.axpy(1.0, cB, structure=same)
        result = mats["G"].transposeMatMult(X, result=result)
        extra = mats["B"].transposeMatMult(Y)
        result.axpy(1.0, extra, structure=same)
        for obj in (volume, mCm, inv, scaled_c, X, Y, cB, extra):
            obj.destroy()
        return result

    def add_jacobian(self, A: PETSc.Mat, bcs) -> None:
        """Add :meth:`coupling` (without the rows and columns of ``bcs``) to the assembled Jacobian ``A``."""
        self._coupling = self.coupling(bcs, self._coupling)
        A.axpy(1.0, self._coupling, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)

    def apply_lifting(self, b: PETSc.Vec, bcs, x: PETSc.Vec) -> None:
        """``b += C (g - x)`` on the owned entries, with ``C`` the couplings and ``g - x`` the
        Dirichlet values missed by ``x`` (zero off the constrained dofs): the part of the
        residual's lifting the assembled forms do not hold.  Without it, the first Newton
        iteration of a step with a prescribed displacement misses the volumetric response to it."""
        self._free = self.coupling([], self._free)
        gap = x.duplicate()
        gap.set(0.0)
        compat.set_bc(gap, bcs, x, 1.0)
        lift = self._free.createVecLeft()
        self._free.mult(gap, lift)
        b.axpy(1.0, lift)
        gap.destroy()
        lift.destroy()
