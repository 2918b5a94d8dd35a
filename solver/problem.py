"""Elastoplastic boundary-value problem driven by PETSc SNES (DOLFINx 0.5): small strain, or
incremental large deformation (updated Lagrangian, ``kinematics="updated-lagrangian"``).

Pattern (generalises to 3D, contact and load control):

* unknown: displacement ``u`` (continuous Lagrange, degree 2 by default; P1 locks under
  isochoric plastic flow), optionally with the B-bar (cell-average) volumetric strain, which
  removes the milder locking of P2 tetrahedra;
* history at quadrature points in quadrature-space Functions: converged stress ``sigma_n``,
  plastic strain ``eps_p``; the current stress ``sigma`` and consistent tangent ``tangent``
  (flattened ``ncomp x ncomp``) are refreshed from the numpy return map at every residual
  evaluation; history is committed only after a step has converged;
* residual ``F(u; v) = int sigma(u) : eps(v) - int b . v + sum(extra residual terms)``,
  Jacobian ``J = int (C_t : eps(du)) : eps(v) + sum(extra Jacobian terms)``; Mandel vectors so
  ``:`` is a dot product;
* SNES Newton (line search selectable) with LU (MUMPS) up to 100 000 dofs and GMRES + AMG
  (GAMG, rigid-body near-null space) above (``linear_solver``); any PETSc option can be passed
  (``petsc_options`` dict, applied under ``options_prefix``).

Extension points: :meth:`PlasticityProblem.add_residual_term` adds a UFL residual term and its
Gateaux derivative (rigid-wheel penalty contact is such a term, with the wheel pose in
``fem.Constant`` objects, see ``solver/contact.py``); :meth:`PlasticityProblem.add_assembled_term` adds
forces and tangent entries by global index after the forms are assembled, for couplings outside
the forms' sparsity (contact of two bodies, ``solver/contact_pair.py``).  A cell tag given a
:class:`~rollsim.solver.materials.NeoHookean` material is a hyperelastic body in the same system
(e.g. a tire's carcass beside the soil): total Lagrangian, ``int P(F) : grad v`` over its cells.
"""
from __future__ import annotations

import math
import time
from typing import Sequence

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from rollsim import compat
from rollsim.log import get_logger

from .cell_average import CellProjection
from .linear_solver import (AUTO_ITERATIVE_DOFS, DEFAULT_PETSC_OPTIONS, ITERATIVE_SOLVER_OPTIONS,
                            LinearSolverChoice, _first_line, rigid_body_modes)
from .materials import NeoHookean
from .newton import (REASON_PETSC_ERROR, REASON_RETURN_MAP, STAGNATION, Border, NewtonDriver, NewtonReport,
                     ReturnMapError)
from .options import (DEFAULT_VOLUMETRIC_STRAIN, KINEMATICS, LINEAR_SOLVERS, PLATEAU_RTOL, VOLUMETRIC_STRAINS,
                      check_choice)
from .return_map import (APEX, ELASTIC, PLASTIC, ReturnResult, elastic_stiffness, relax_return, return_map,
                         yield_function)

__all__ = ["NewtonReport", "PlasticityProblem", "mandel_strain", "DEFAULT_PETSC_OPTIONS", "PLATEAU_RTOL",
           "ITERATIVE_SOLVER_OPTIONS", "LINEAR_SOLVERS", "AUTO_ITERATIVE_DOFS", "REASON_PETSC_ERROR",
           "REASON_RETURN_MAP", "STAGNATION", "Border", "ReturnMapError", "rigid_body_modes"]

log = get_logger("solver")

_SQ2 = np.sqrt(2.0)


def mandel_strain(u, gdim: int, F_inv=None, centroid=None):
    """Small strain of ``u`` as a UFL Mandel vector (4 components in 2D plane strain, 6 in 3D).

    With ``F_inv`` (inverse deformation gradient of a configuration), the gradient is taken with
    respect to that configuration: ``sym(grad(u) F_inv)`` (updated-Lagrangian increments).

    With ``centroid`` (a DG0 vector Function of the cell midpoints), the volumetric part is
    replaced by its cell average (B-bar): ``theta -> theta + grad(theta) . (x_c - x)``, exact for
    the linear ``theta = div u`` of P2 on affine cells (first-order Taylor value otherwise), so
    each cell carries one volumetric constraint instead of one per quadrature point."""
    g = ufl.grad(u) if F_inv is None else ufl.dot(ufl.grad(u), F_inv)
    e = ufl.sym(g)
    vol = 0.0
    if centroid is not None:
        x = ufl.SpatialCoordinate(centroid.function_space.mesh)
        vol = ufl.dot(ufl.grad(ufl.tr(g)), centroid - x) / 3.0
    if gdim == 2:
        return ufl.as_vector([e[0, 0] + vol, e[1, 1] + vol, 0.0 * e[0, 0] + vol, _SQ2 * e[0, 1]])
    if gdim == 3:
        return ufl.as_vector([e[0, 0] + vol, e[1, 1] + vol, e[2, 2] + vol,
                              _SQ2 * e[0, 1], _SQ2 * e[1, 2], _SQ2 * e[0, 2]])
    raise ValueError(f"gdim must be 2 or 3, got {gdim}")


class PlasticityProblem(NewtonDriver, LinearSolverChoice):
    """Elastoplastic solid on ``mesh`` (2D plane strain or 3D) with a numpy return map.

    Parameters
    ----------
    mesh : dolfinx mesh (its communicator is used throughout)
    material : ``VonMises``, ``DruckerPrager`` or ``SmoothedMohrCoulomb``, or
        ``{cell tag: material}`` with ``cell_tags``; a tag given a ``NeoHookean`` is a hyperelastic
        body (finite strain, total Lagrangian, no body force, no return map) solved with the others
    bcs : Dirichlet conditions on ``self.V`` (may be set later via :attr:`bcs`; build them with
        ``problem.V``)
    degree : displacement degree (2 recommended)
    quadrature_degree : default ``2 * (degree - 1)`` on triangles and tetrahedra (exact for the
        stiffness on affine cells) and ``2 * degree`` on quadrilaterals and hexahedra (full
        integration: fewer points leave hourglass modes)
    body_force : UFL vector (N/m^3), multiplied by :attr:`gravity_factor` (a ``fem.Constant``)
    petsc_options : dict overriding :data:`DEFAULT_PETSC_OPTIONS` (and the linear solver's options)
    linear_solver : one of :data:`LINEAR_SOLVERS`; the resolved choice is :attr:`linear_solver`
    force_rtol : Newton also converges when ``|F| <= force_rtol * |F_internal|`` (the norm of the
        unconstrained internal-force vector, i.e. of the reactions at equilibrium) - a
        units-consistent absolute floor.
    plateau_rtol : a Newton plateau below ``plateau_rtol * |F_internal|`` is accepted (default
        :data:`~rollsim.solver.options.PLATEAU_RTOL`; 0: never); :attr:`plateaus` counts them and
        keeps the largest ratio.
    kinematics : ``"small-strain"`` (default: strains and equilibrium on the initial configuration)
        or ``"updated-lagrangian"``: incremental large deformation.  Each step's strain increment
        and equilibrium are taken on the configuration of the last converged step
        (``x_n = X + u_n``, through ``F_n = I + grad u_n`` and ``J_n = det F_n``), the Cauchy stress
        is carried over without a rotation correction (no Jaumann term: rotations under a wheel are
        a few degrees), and the body force is per unit of initial volume (mass is conserved).
        The configuration is frozen within a step, so the Newton tangent stays consistent.
    volumetric_strain : ``"cell-average"`` (B-bar): the volumetric part of every strain
        (trial, test and increment) is replaced by its projection per cell, so each cell carries
        a few incompressibility constraints instead of one per quadrature point - P2 tetrahedra
        lock under isochoric plastic flow otherwise (see
        docs/theory.md, "Volumetric strain: B-bar or pointwise").  On triangles
        and tetrahedra the cell mean, by a Taylor value about the midpoint: exact for P2 on
        affine cells (div u is linear there), first-order on curved cells and in
        updated-Lagrangian steps.  On quadrilaterals and hexahedra the exact projection onto the
        linear functions of the cell (Q2-P1, the optimal pairing), or onto the constants with
        ``volumetric_projection=0`` (Q2-P0, the cell mean: converges from below and more slowly)
        - solver/cell_average.py.  ``"pointwise"`` (the default of the solver classes,
        :data:`DEFAULT_VOLUMETRIC_STRAIN`; scenes choose per protocol and preset): the plain strain.
    """

    def __init__(self, mesh, material, bcs: Sequence = (), *, degree: int = 2,
                 quadrature_degree: int | None = None, body_force=None,
                 petsc_options: dict | None = None, options_prefix: str = "rollsim_plasticity_",
                 force_rtol: float = 1e-10, plateau_rtol: float | None = None, cell_tags=None,
                 kinematics: str = "small-strain", linear_solver: str = "auto",
                 volumetric_strain: str = DEFAULT_VOLUMETRIC_STRAIN, volumetric_projection: int | None = None):
        check_choice("kinematics", kinematics, KINEMATICS)
        check_choice("linear_solver", linear_solver, LINEAR_SOLVERS)
        check_choice("volumetric_strain", volumetric_strain, VOLUMETRIC_STRAINS)
        self.kinematics, self.volumetric_strain = kinematics, volumetric_strain
        self.mesh = mesh
        self.comm = mesh.comm
        self._init_materials(material, cell_tags)
        self.gdim = mesh.geometry.dim
        self.ncomp = 4 if self.gdim == 2 else 6
        self.degree = degree
        simplex = compat.cell_name(mesh) in ("triangle", "tetrahedron")
        if volumetric_projection is not None and (simplex or volumetric_strain != "cell-average"):
            raise ValueError("volumetric_projection applies to volumetric_strain='cell-average' on quadrilaterals "
                             "and hexahedra only")
        self.qdeg = (quadrature_degree if quadrature_degree is not None
                     else max(2 * (degree - 1), 1) if simplex else 2 * degree)
        self.V = compat.vector_space(mesh, degree)
        self.n_dofs = self.V.dofmap.index_map.size_global * self.V.dofmap.index_map_bs   # global
        self.bcs = list(bcs)
        self._init_newton(force_rtol, plateau_rtol)
        #: Duvaut-Lions regularisation of the next steps (:func:`~rollsim.solver.return_map.duvaut_lions`):
        #: the step's pseudo-time over the relaxation time; ``inf`` (default): rate-independent
        self.relaxation = math.inf
        self._init_state()
        F_inv, centroid = self._init_kinematics(simplex)
        self._groups = self._material_groups(cell_tags)      # [(material, owned qp indices)]
        self.K0 = None                                       # set by set_geostatic_stress
        self._set_owned(self.tangent, self._elastic_tangent())
        self._commit_hooks: list = []
        self._restore_hooks: list = []
        self._init_forms(cell_tags, body_force, F_inv, centroid, simplex, volumetric_projection)
        self._init_linear_solver(linear_solver, petsc_options, options_prefix)

    def _init_materials(self, material, cell_tags) -> None:
        """:attr:`materials` ({cell tag: material}, or {None: material}), the hyperelastic bodies
        among them and :attr:`material`, the first elastoplastic one."""
        # one material, or {cell tag: material} with ``cell_tags`` (e.g. soil layers): the return
        # map then runs per group of quadrature points; ``self.material`` is the first one
        if isinstance(material, dict):
            if cell_tags is None:
                raise ValueError("cell_tags is required when material is a dict {cell tag: material}")
            if not material:
                raise ValueError("material: give at least one {cell tag: material}")
            self.materials = dict(material)
        else:
            self.materials = {None: material}
        if isinstance(self.materials.get(None), NeoHookean):
            raise ValueError("material: a NeoHookean body needs its cell tag ({cell tag: material})")
        #: the hyperelastic bodies {cell tag: NeoHookean}; the other tags are elastoplastic
        self.hyperelastic = {tag: mat for tag, mat in self.materials.items() if isinstance(mat, NeoHookean)}
        plastic = [mat for mat in self.materials.values() if not isinstance(mat, NeoHookean)]
        if not plastic:
            raise ValueError("material: give at least one elastoplastic material besides the NeoHookean bodies")
        self.material = plastic[0]

    def _init_state(self) -> None:
        """The displacement and the quadrature-point state: stress, plastic strain, tangent."""
        mesh = self.mesh
        nc = self.ncomp
        self.Qs = compat.quadrature_space(mesh, self.qdeg, (nc,))
        self.Qt = compat.quadrature_space(mesh, self.qdeg, (nc * nc,))
        self.u = fem.Function(self.V, name="displacement")
        self.u_n = fem.Function(self.V, name="displacement_converged")
        self.sigma = fem.Function(self.Qs, name="stress")
        self.sigma_n = fem.Function(self.Qs, name="stress_converged")
        self.eps_p = fem.Function(self.Qs, name="plastic_strain")
        self.tangent = fem.Function(self.Qt, name="tangent")
        self._deps_q = fem.Function(self.Qs)
        self._deps_p = np.zeros((0, nc))
        self.state = np.zeros(0, dtype=np.int8)
        tdim = mesh.topology.dim
        self.n_cells = mesh.topology.index_map(tdim).size_local
        self.points = compat.quadrature_points(mesh, self.qdeg)
        self.n_qp = self.n_cells * self.points.shape[0]      # owned quadrature points

    def _init_kinematics(self, simplex: bool):
        """The strain of a displacement (small strain, or on the last converged configuration;
        B-bar on simplices by a Taylor value); returns ``F_inv`` and the cells' midpoints (B-bar
        on simplices, else ``None``)."""
        kinematics, mesh = self.kinematics, self.mesh
        if kinematics == "updated-lagrangian":
            F_n = ufl.Identity(self.gdim) + ufl.grad(self.u_n)
            F_inv, self._J_n = ufl.inv(F_n), ufl.det(F_n)
        else:
            F_inv, self._J_n = None, 1.0
        # B-bar: a Taylor value about the midpoint on simplices (the exact mean for P2 on affine
        # cells), an exact projection per cell on quadrilaterals and hexahedra (solver/cell_average.py)
        bbar = self.volumetric_strain == "cell-average"
        centroid = compat.cell_midpoints(mesh) if bbar and simplex else None
        self._strain = lambda w: mandel_strain(w, self.gdim, F_inv, centroid)
        self._deps_expr = compat.expression(self._strain(self.u - self.u_n), self.points)
        return F_inv, centroid

    def _init_forms(self, cell_tags, body_force, F_inv, centroid, simplex: bool, volumetric_projection) -> None:
        """The bodies' residual and Jacobian forms: the elastoplastic soil (B-bar by the cell
        projection on quadrilaterals and hexahedra) and the hyperelastic bodies."""
        mesh, degree, nc = self.mesh, self.degree, self.ncomp
        bbar = self.volumetric_strain == "cell-average"
        self.dx = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": self.qdeg,
                                                            "quadrature_scheme": "default"})
        # the elastoplastic terms run over the elastoplastic cells only when there is another body
        dx_soil, dx_body = self.dx, {}
        if self.hyperelastic:
            dx_tags = self.dx(subdomain_data=cell_tags)
            dx_soil = dx_tags(tuple(tag for tag in self.materials if tag not in self.hyperelastic))
            dx_body = {tag: ufl.Measure("dx", domain=mesh, subdomain_data=cell_tags,
                                        metadata={"quadrature_degree": 2 * degree})(tag)
                       for tag in self.hyperelastic}
        v = ufl.TestFunction(self.V)
        du = ufl.TrialFunction(self.V)
        self._v, self._du = v, du
        self.gravity_factor = fem.Constant(mesh, PETSc.ScalarType(1.0))
        zero = ufl.as_vector([0.0] * self.gdim)
        self.body_force = body_force if body_force is not None else zero
        Ct = ufl.as_matrix([[self.tangent[i * nc + j] for j in range(nc)] for i in range(nc)])
        eps = self._strain
        # the initial (geostatic) stress varies inside a cell, so it is in equilibrium with the
        # body force for the pointwise strain only: B-bar acts on the stress change
        self._sigma0 = fem.Function(self.Qs, name="initial_stress") if bbar else None
        self._projection = None
        stress = self.sigma
        if bbar and not simplex:
            self._projection = CellProjection(mesh, self.V, eps, Ct, self._J_n, dx_soil,
                                              compat.quadrature_rule(mesh, self.qdeg), self.n_cells,
                                              degree=1 if volumetric_projection is None else volumetric_projection,
                                              fixed_configuration=F_inv is None)
            self._sigma_bar = stress = fem.Function(self.Qs, name="stress_projected_trace")
        soil = (ufl.inner(stress, eps(v)) * self._J_n * dx_soil
                - self.gravity_factor * ufl.inner(self.body_force, v) * dx_soil)
        if centroid is not None:     # residual + int sigma_0 : (eps(v) - eps_bar(v)), a constant vector
            soil += ufl.inner(self._sigma0, mandel_strain(v, self.gdim, F_inv) - eps(v)) * self._J_n * dx_soil
        bodies = soil
        if self._projection is not None:   # pointwise part; the cell couplings are added assembled
            e = self._projection.deviatoric(eps)
            jacobian = ufl.inner(ufl.dot(Ct, e(du)), e(v)) * self._J_n * dx_soil
        else:
            jacobian = ufl.inner(ufl.dot(Ct, eps(du)), eps(v)) * self._J_n * dx_soil
        if self.hyperelastic:
            F = ufl.Identity(self.gdim) + ufl.grad(self.u)
            hyper = sum(ufl.inner(mat.first_piola(F), ufl.grad(v)) * dx_body[tag]
                        for tag, mat in self.hyperelastic.items())
            bodies += hyper
            jacobian += ufl.derivative(hyper, self.u, du)
        self._F_terms = [bodies]     # the bodies' internal minus external force (internal_force)
        self._J_terms = [jacobian]
        self._assembled_terms: list = []
        self._internal_force_forms: dict = {}


    # ------------------------------------------------------------------ helpers
    def _material_groups(self, cell_tags):
        nq = self.points.shape[0]
        if None in self.materials:
            return [(self.materials[None], slice(None))]
        tag_of = np.full(self.n_cells, -1, dtype=np.int64)
        idx = cell_tags.indices
        own = idx < self.n_cells
        tag_of[idx[own]] = cell_tags.values[own]
        missing = np.setdiff1d(np.unique(tag_of), list(self.materials))
        if missing.size:
            raise ValueError(f"cells with tag(s) {missing.tolist()} have no material "
                             f"(materials given for tags {sorted(self.materials)})")
        groups = []
        self._body_qp = np.zeros(0, dtype=np.int64)
        for tag, mat in self.materials.items():
            cells = np.flatnonzero(tag_of == tag)
            qp = (cells[:, None] * nq + np.arange(nq)[None, :]).reshape(-1)
            if tag in self.hyperelastic:       # no return map there: zero stress, zero tangent
                self._body_qp = np.concatenate([self._body_qp, qp])
            else:
                groups.append((mat, qp))
        return groups

    def _elastic_tangent(self) -> np.ndarray:
        nc = self.ncomp
        out = np.zeros((self.n_qp, nc * nc))
        for mat, qp in self._groups:
            out[qp] = elastic_stiffness(mat, nc).reshape(-1)
        return out

    def material_function(self, attribute: str, name: str | None = None) -> fem.Function:
        """Cell-wise (DG0) Function of a material attribute (e.g. ``"nu"``, ``"E"``) - for output
        and per-layer expressions."""
        return self._cellwise([getattr(mat, attribute) for mat, _ in self._groups], name or attribute)

    def _cellwise(self, values, name: str) -> fem.Function:
        """DG0 Function with ``values[i]`` on the cells of material group ``i``."""
        W = compat.scalar_space(self.mesh, 0, "DG")
        f = fem.Function(W, name=name)
        nq = self.points.shape[0]
        vals = np.zeros(self.n_cells)
        for (mat, qp), val in zip(self._groups, values):
            cells = np.arange(self.n_cells) if isinstance(qp, slice) else qp[::nq] // nq
            vals[cells] = val
        # DG0: one dof per cell, owned cells first in cell order
        dofs = np.array([W.dofmap.cell_dofs(c)[0] for c in range(self.n_cells)], dtype=np.int32)
        f.x.array[dofs] = vals
        f.x.scatter_forward()
        return f

    def add_state_hooks(self, commit=None, restore=None) -> None:
        """Callables run by :meth:`commit` / :meth:`restore` (e.g. contact history, wheel pose)."""
        if commit is not None:
            self._commit_hooks.append(commit)
        if restore is not None:
            self._restore_hooks.append(restore)

    def _set_owned(self, f: fem.Function, values: np.ndarray) -> None:
        n = values.size
        f.x.array[:n] = values.reshape(-1)
        f.x.scatter_forward()

    def _owned(self, f: fem.Function, width: int) -> np.ndarray:
        return f.x.array[: self.n_qp * width].reshape(self.n_qp, width)

    def add_residual_term(self, F_term, J_term=None) -> None:
        """Add a UFL residual term (test function :attr:`test_function`) and its derivative.

        ``J_term`` defaults to ``ufl.derivative(F_term, u, trial_function)``.  Call before the
        first solve (forms are compiled once).  Intended for contact (penalty/Nitsche) terms.
        """
        if self._compiled:
            raise RuntimeError("add_residual_term must be called before the first solve")
        self._F_terms.append(F_term)
        self._J_terms.append(J_term if J_term is not None else ufl.derivative(F_term, self.u, self._du))

    def add_assembled_term(self, term) -> None:
        """Add a term assembled by index: ``term.add_residual(b)`` adds its forces to the
        assembled residual (owned entries complete, before the Dirichlet rows are set) and
        ``term.add_jacobian(A)`` its tangent to the assembled Jacobian (before its final
        assembly), both by global index and for the current iterate :attr:`u`; new nonzeros are
        allowed in the Jacobian.  Call before the first solve."""
        if self._compiled:
            raise RuntimeError("add_assembled_term must be called before the first solve")
        self._assembled_terms.append(term)

    @property
    def test_function(self):
        return self._v

    @property
    def trial_function(self):
        return self._du

    def set_initial_stress(self, stress_ufl) -> None:
        """Set the converged (and current) stress from a UFL Mandel vector, e.g. geostatic."""
        expr = compat.expression(stress_ufl, self.points)
        compat.evaluate_into(expr, self.sigma_n)
        if self.hyperelastic:           # the hyperelastic bodies carry no such stress
            self._owned(self.sigma_n, self.ncomp)[self._body_qp] = 0.0
            self.sigma_n.x.scatter_forward()
        self.sigma.x.array[:] = self.sigma_n.x.array
        if self._sigma0 is not None:
            self._sigma0.x.array[:] = self.sigma_n.x.array
        self._refresh_stress_bar()

    def set_geostatic_stress(self, unit_weight: float, surface: float, K0=None):
        """Geostatic initial stress for a soil with unit weight ``gamma`` (N/m^3) and free surface at
        ``x[gdim-1] = surface``: sigma_v = -gamma (surface - z), sigma_h = K0 sigma_v,
        K0 = nu/(1-nu) by default (per layer with several materials).  Use with
        ``body_force = (0, .., -gamma)``.

        A K0 that puts the deepest point of a layer outside its yield surface (e.g. the default
        nu/(1-nu) = 0.43 of nu = 0.3 against the plane-strain-matched cone of phi = 30 deg) is moved
        inside it with a warning (:func:`~rollsim.solver.materials.admissible_k0`: 10 % inside the
        yield surface towards K0 = 1).  Returns the K0 used: a float, or ``{cell tag: K0}`` when the
        layers got different values."""
        from .materials import admissible_k0
        zmin = self.comm.allreduce(float(self.mesh.geometry.x[:, self.gdim - 1].min(initial=np.inf)), op=MPI.MIN)
        sv_max = unit_weight * (surface - zmin)
        used = []
        tags = [tag for tag in self.materials if tag not in self.hyperelastic]    # self._groups' order
        for tag, (mat, _) in zip(tags, self._groups):
            k_given = K0.get(tag) if isinstance(K0, dict) else K0
            k_used, clipped = admissible_k0(mat, k_given, sv_max, self.ncomp)
            if clipped:
                given = (f"K0 = {k_given:g}" if k_given is not None
                         else f"default K0 = nu/(1-nu) = {mat.nu / (1 - mat.nu):.4g}")
                where = "" if tag is None else f" (cell tag {tag})"
                log.warning("%s%s violates the yield condition under self weight; using K0 = %.4g "
                            "(10 %% inside the yield surface towards K0 = 1); pass K0 = 1 - sin(phi) (Jaky, "
                            "rollsim.solver.jaky_k0) for a frictional soil", given, where, k_used)
            used.append(k_used)
        if len(set(used)) == 1:
            K0_used = K0_field = used[0]
        else:                                       # per layer: a cell-wise (DG0) coefficient
            K0_used = dict(zip(tags, used))
            K0_field = self._cellwise(used, "K0")
        x = ufl.SpatialCoordinate(self.mesh)
        sv = -unit_weight * (surface - x[self.gdim - 1])
        comps = [K0_field * sv] * 3
        comps[self.gdim - 1] = sv
        comps += [0.0 * sv] * (self.ncomp - 3)
        self.set_initial_stress(ufl.as_vector(comps))
        sig = self._owned(self.sigma_n, self.ncomp)
        nviol = 0
        for mat, qp in self._groups:
            f = yield_function(mat, sig[qp])
            nviol += int(np.sum(f > 1e-8 * (abs(mat.cohesion) + np.abs(sig).max(initial=1.0))))
        nviol = self.comm.allreduce(nviol)
        if nviol:
            log.warning("geostatic stress violates the yield condition at %d quadrature points", nviol)
        self.K0 = K0_used
        return K0_used

    # ------------------------------------------------------------------ constitutive update
    def constitutive_update(self, tangent: bool = True):
        """Strain increment at the quadrature points of ``u - u_n`` -> stress (and tangent).
        Collective: a return map failing on any rank raises :class:`ReturnMapError` on all."""
        t0 = time.perf_counter()
        compat.evaluate_into(self._deps_expr, self._deps_q)
        nc = self.ncomp
        sig_n, deps = self._owned(self.sigma_n, nc), self._owned(self._deps_q, nc)
        if self._projection is not None:
            if self.kinematics == "updated-lagrangian":   # the weights follow the configuration
                self._projection.refresh()
            deps[:] = self._projection.projected(deps)
        error = None
        try:
            res = self._return_map(sig_n, deps, tangent)
        except (RuntimeError, ArithmeticError, np.linalg.LinAlgError) as err:
            error, res = err, None
        if self.comm.allreduce(error is not None, op=MPI.LOR):
            raise ReturnMapError(f"return map failed: {_first_line(error) if error else 'on another rank'}")
        self._set_owned(self.sigma, res.sigma)
        self._refresh_stress_bar()
        if tangent:
            self._set_owned(self.tangent, res.tangent.reshape(self.n_qp, nc * nc))
        self._deps_p = res.deps_p
        self.state = res.state
        self.timings["return_map"] += time.perf_counter() - t0
        return res

    def _refresh_stress_bar(self) -> None:
        """With the exact cell projection: the residual's stress, the current stress with the trace
        of its change projected, ``sigma_0 + projected(sigma - sigma_0)`` (solver/cell_average.py)."""
        if self._projection is None:
            return
        nc = self.ncomp
        sig0 = self._owned(self._sigma0, nc)
        self._set_owned(self._sigma_bar, sig0 + self._projection.projected(self._owned(self.sigma, nc) - sig0))

    def _return_map(self, sig_n: np.ndarray, deps: np.ndarray, tangent: bool) -> ReturnResult:
        """The return map of every material group (and the Duvaut-Lions step when it is on)."""
        nc = self.ncomp
        if len(self._groups) == 1 and isinstance(self._groups[0][1], slice):
            res = return_map(self.material, sig_n, deps, tangent=tangent)
        else:      # the points of no group (hyperelastic bodies) keep zero stress and tangent
            parts = [(qp, return_map(mat, sig_n[qp], deps[qp], tangent=tangent)) for mat, qp in self._groups]
            res = ReturnResult(sigma=np.zeros_like(sig_n), tangent=np.zeros((self.n_qp, nc, nc)) if tangent else None,
                               deps_p=np.zeros_like(sig_n), dlam=np.zeros(self.n_qp),
                               state=np.zeros(self.n_qp, dtype=np.int8))
            for qp, r in parts:
                res.sigma[qp], res.deps_p[qp], res.dlam[qp], res.state[qp] = r.sigma, r.deps_p, r.dlam, r.state
                if tangent:
                    res.tangent[qp] = r.tangent
        if math.isfinite(self.relaxation):
            self._relax(res, sig_n, deps)
        return res

    def relax_over(self, path: float, relaxation_length: float) -> None:
        """Set :attr:`relaxation` for a step that moves the load along ``path`` (m) with the
        Duvaut-Lions ``relaxation_length`` (m) as relaxation time: ``r = path / relaxation_length``;
        ``relaxation_length`` 0 leaves the problem as it is (rate-independent unless set)."""
        if relaxation_length > 0:
            self.relaxation = path / relaxation_length

    def _relax(self, res: ReturnResult, sig_n: np.ndarray, deps: np.ndarray) -> None:
        """Duvaut-Lions step (:func:`~rollsim.solver.return_map.duvaut_lions`) with :attr:`relaxation`."""
        for mat, qp in self._groups:        # qp: the group's owned quadrature points
            relax_return(mat, res, sig_n[qp], deps[qp], self.relaxation, qp)

    def counts(self) -> dict[str, int]:
        """Global numbers of elastic / plastic / apex quadrature points of the current state."""
        loc = np.array([np.sum(self.state == s) for s in (ELASTIC, PLASTIC, APEX)], dtype=np.int64)
        glob = np.zeros_like(loc)
        self.comm.Allreduce(loc, glob)
        return dict(zip(("elastic", "plastic", "apex"), map(int, glob)))


    def commit(self) -> None:
        """Accept the current state as converged (update history variables)."""
        for hook in self._commit_hooks:     # hooks see the state before the history update
            hook()
        nc = self.ncomp
        self.sigma_n.x.array[:] = self.sigma.x.array
        ep = self._owned(self.eps_p, nc) + self._deps_p
        self._set_owned(self.eps_p, ep)
        self.u_n.x.array[:] = self.u.x.array

    def restore(self) -> None:
        """Reject the current iterate: back to the last converged state."""
        self.u.x.array[:] = self.u_n.x.array
        self.sigma.x.array[:] = self.sigma_n.x.array
        self._refresh_stress_bar()
        self.state = np.zeros(self.n_qp, dtype=np.int8)
        for hook in self._restore_hooks:
            hook()

    def reset_displacement(self) -> None:
        """Zero the displacement (e.g. after a gravity step) keeping stresses and plastic strains."""
        self.u.x.array[:] = 0.0
        self.u_n.x.array[:] = 0.0

    def internal_force(self, w: fem.Function, every_term: bool = False) -> float:
        """Global ``int sigma : eps(w) - b . w`` at the current stress: for ``w`` = 1 on a set of
        dofs (one direction) and 0 elsewhere this is the resultant reaction there (partition
        independent: an assembled global scalar).  ``every_term``: the whole residual of the forms
        (with the terms of :meth:`add_residual_term`, e.g. a pressure), not the terms assembled by
        index."""
        key = (id(w), every_term)
        if key not in self._internal_force_forms:
            terms = self._F_terms if every_term else self._F_terms[:1]
            wf = ufl.replace(sum(terms[1:], terms[0]), {self._v: w})
            self._internal_force_forms[key] = (w, fem.form(wf))
        val = fem.assemble_scalar(self._internal_force_forms[key][1])
        return float(self.comm.allreduce(val))

