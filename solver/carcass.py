"""Hyperelastic carcass inflated by a follower pressure: the first stage of a pneumatic-tire run.

Finite strain, compressible neo-Hookean (linear elastic E, nu at small strain), with the strain
energy per unit reference volume

    psi(F) = mu/2 (tr(F^T F) - 3) - mu ln J + lambda/2 (ln J)^2,   J = det F,

so the first Piola-Kirchhoff stress is ``P = mu (F - F^-T) + lambda ln(J) F^-T``.  The pressure p
pushes on the *current* inner surface: its virtual work ``-int p J F^-T N . v dA`` (Nanson's
formula on the reference surface) is linearised with the rest of the residual, so the Newton
Jacobian carries the load stiffness and converges quadratically under large inflation.
Facets named ``symmetry_x`` / ``symmetry_y`` / ``symmetry_z`` hold that displacement component;
the clamped facets (the tire's bead, ``hub_rim``) hold all three.
"""
from __future__ import annotations

import time
from typing import Callable

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fem_petsc
from mpi4py import MPI
from petsc4py import PETSc

from rollsim import compat
from rollsim.log import get_logger

from .contact import DEFAULT_PENALTY, contact_cell_size
from .materials import NeoHookean
from .problem import NewtonReport
from .stepping import StepControl, StepRecord, solve_load_path

__all__ = ["NeoHookean", "Carcass", "current_area_vector"]

log = get_logger("solver")

#: Newton of the inflation: converged when ``|R| <= NEWTON_RTOL |R_0|`` (``R_0``: the residual of
#: the step's first iterate) or when the update is below ``NEWTON_STOL`` of the displacement (a
#: stiff carcass under a small pressure reaches the round-off floor of its internal forces first)
NEWTON_RTOL = 1e-10
NEWTON_STOL = 1e-9
NEWTON_MAX_IT = 25
#: quadrature degree of the contact-area integral: the points in contact are counted, so their
#: spacing (about h / 7 on a quadratic facet at degree 12) sets the step of the area's jumps
AREA_QUADRATURE_DEGREE = 12


def current_area_vector(F, mesh):
    """Current area vector per unit reference area of a boundary facet (UFL), ``J F^-T N``
    (Nanson's formula): a follower pressure ``p`` pushes on the body with ``-p J F^-T N``."""
    return ufl.det(F) * ufl.dot(ufl.inv(F).T, ufl.FacetNormal(mesh))


class Carcass:
    """A hyperelastic body (``tagged``: a TaggedMesh) inflated by a pressure on ``pressure_facets``.

    ``material``: one :class:`NeoHookean` or ``{cell tag: NeoHookean}``; ``clamped_facets``: names of
    facets tied to the rigid hub (missing names are skipped), which :meth:`set_hub` moves;
    ``degree``: displacement degree.  ``ground``: height (m) of a rigid flat ground ``z = ground``
    that the ``contact_facets`` may touch (frictionless penalty, ``p_N = kappa <-g>_+`` with the
    gap ``g = z + u_z - ground`` and ``kappa = penalty E_max / h``, ``h`` the smallest cell at the
    contact facets); ``None``: no ground.
    Call :meth:`inflate`, then :meth:`press` against the ground; :meth:`gas_force`,
    :meth:`ground_force`, :meth:`contact_area` and :meth:`mean_normal_displacement` read the state.
    """

    def __init__(self, tagged, material, *, pressure_facets=("inner_surface",),
                 clamped_facets=("hub_rim",), degree: int = 2, ground: float | None = None,
                 contact_facets=("outer_surface",), penalty: float = DEFAULT_PENALTY):
        msh = tagged.mesh
        self.tagged, self.comm = tagged, msh.comm
        self.V = V = compat.vector_space(msh, degree)
        self.n_dofs = V.dofmap.index_map.size_global * V.dofmap.index_map_bs
        self.u, self.u_n, self.du = fem.Function(V), fem.Function(V), fem.Function(V)
        self.pressure = fem.Constant(msh, PETSc.ScalarType(0.0))       # Pa, set by inflate()
        names = tagged.facet_names
        missing = [name for name in pressure_facets if name not in names]
        if missing:
            raise ValueError(f"pressure_facets: the mesh has no facets named {missing}")
        qdeg = {"quadrature_degree": 2 * degree}
        dx = ufl.Measure("dx", domain=msh, subdomain_data=tagged.cell_tags, metadata=qdeg)
        self._ds = ds = ufl.Measure("ds", domain=msh, subdomain_data=tagged.facet_tags, metadata=qdeg)
        materials = material if isinstance(material, dict) else {None: material}
        F = ufl.Identity(3) + ufl.grad(self.u)
        v = ufl.TestFunction(V)
        internal = sum(ufl.inner(mat.first_piola(F), ufl.grad(v)) * (dx if tag is None else dx(tag))
                       for tag, mat in materials.items())
        self._surface = ds(tuple(names[name] for name in pressure_facets))
        # Nanson: the current area vector of a reference facet, da n = J F^-T N dA
        area_vector = current_area_vector(F, msh)
        #: force of the gas on the body per unit reference area: -p J F^-T N
        self._traction = -self.pressure * area_vector
        residual = internal - ufl.dot(self._traction, v) * self._surface
        self.hub = fem.Constant(msh, np.zeros(3, dtype=PETSc.ScalarType))     # m, set_hub()
        self.ground, self.kappa = ground, 0.0
        if ground is not None:
            ids = [names[name] for name in contact_facets if name in names]
            h = contact_cell_size(msh, tagged.facet_tags, ids)
            self.kappa = penalty * max(mat.E for mat in materials.values()) / h        # Pa/m
            x = ufl.SpatialCoordinate(msh)
            #: contact pressure of the ground on the body, Pa (per unit reference area)
            self._ground_pressure = self.kappa * ufl.max_value(ground - x[2] - self.u[2], 0.0)
            self._contact = ds(tuple(ids))
            residual = residual - self._ground_pressure * v[2] * self._contact
            self._ground_force_form = fem.form(self._ground_pressure * self._contact)
            # the patch in the current configuration (da = |J F^-T N| dA), sampled finely so that
            # its edge moves smoothly as the points cross it
            touching = ufl.conditional(ufl.gt(self._ground_pressure, 0.0), 1.0, 0.0)
            stretch = ufl.sqrt(ufl.dot(area_vector, area_vector))
            fine = ufl.Measure("ds", domain=msh, subdomain_data=tagged.facet_tags,
                               metadata={"quadrature_degree": AREA_QUADRATURE_DEGREE})(tuple(ids))
            self._contact_area_form = fem.form(touching * stretch * fine)
        self._R = fem.form(residual)
        self._J = fem.form(ufl.derivative(residual, self.u, ufl.TrialFunction(V)))
        self.bcs = self._boundary_conditions(clamped_facets)
        self._A = fem_petsc.create_matrix(self._J)
        self._b = compat.create_vector(self._R)
        self._ksp = PETSc.KSP().create(self.comm)
        self._ksp.setType("preonly")
        self._ksp.getPC().setType("lu")
        self._ksp.getPC().setFactorSolverType("mumps")
        self.newton_iterations = 0
        self.history: list[StepRecord] = []
        self._surface_nodes: dict[str, tuple] = {}     # facet name -> node heights, u_z entries

    def _boundary_conditions(self, clamped_facets) -> list:
        tagged, V = self.tagged, self.V
        fdim = tagged.mesh.topology.dim - 1
        bcs = []
        for axis, name in enumerate(("symmetry_x", "symmetry_y", "symmetry_z")):
            if name in tagged.facet_names:
                Vi = V.sub(axis)
                dofs = fem.locate_dofs_topological(Vi, fdim, tagged.facet_tags.find(tagged.facet_names[name]))
                bcs.append(fem.dirichletbc(PETSc.ScalarType(0.0), dofs, Vi))
        for name in clamped_facets:
            if name in tagged.facet_names:
                dofs = fem.locate_dofs_topological(V, fdim, tagged.facet_tags.find(tagged.facet_names[name]))
                bcs.append(fem.dirichletbc(self.hub, dofs, V))
        return bcs

    # ------------------------------------------------------------------ the stepping protocol
    def solve_increment(self) -> NewtonReport:
        """Newton from the current iterate for the current pressure (not committed)."""
        t0 = time.perf_counter()
        norms: list[float] = []
        x = compat.petsc_vector(self.u)
        dx = compat.petsc_vector(self.du)
        for it in range(NEWTON_MAX_IT + 1):
            b = self._b
            with b.localForm() as local:
                local.set(0.0)
            fem_petsc.assemble_vector(b, self._R)
            compat.apply_lifting(b, [self._J], self.bcs, x0=x, scale=-1.0)
            b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            compat.set_bc(b, self.bcs, x, -1.0)
            norm = b.norm()
            norms.append(norm)
            if not np.isfinite(norm) or (it > 0 and norm > 1e4 * norms[0]):
                return NewtonReport(False, it, -4, norms, time.perf_counter() - t0)
            if it > 0 and (norm <= NEWTON_RTOL * norms[0] or dx.norm() <= NEWTON_STOL * max(x.norm(), 1e-300)):
                return NewtonReport(True, it, 2, norms, time.perf_counter() - t0, linear_solves=it)
            if it == NEWTON_MAX_IT:
                break
            self._A.zeroEntries()
            fem_petsc.assemble_matrix(self._A, self._J, bcs=self.bcs)
            self._A.assemble()
            self._ksp.setOperators(self._A)
            self._ksp.solve(b, dx)
            if self._ksp.getConvergedReason() < 0:
                return NewtonReport(False, it + 1, -3, norms, time.perf_counter() - t0)
            dx.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            x.axpy(-1.0, dx)
            x.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
            self.newton_iterations += 1
        return NewtonReport(False, NEWTON_MAX_IT, -5, norms, time.perf_counter() - t0)

    def commit(self) -> None:
        self.u_n.x.array[:] = self.u.x.array

    def restore(self) -> None:
        self.u.x.array[:] = self.u_n.x.array

    # ------------------------------------------------------------------ public API
    def inflate(self, pressure: float, control: StepControl | None = None) -> list[StepRecord]:
        """Ramp the pressure from its current value to ``pressure`` (Pa) with step cutting; raises
        :class:`~rollsim.solver.stepping.SolverDivergedError` (last converged state kept) on failure."""
        p0 = float(self.pressure.value)
        control = control or StepControl(dt=0.25, dt_min=1e-3, dt_max=0.5, easy_iterations=6, max_cuts=6)

        def set_load(t):
            self.pressure.value = p0 + t * (pressure - p0)

        records = solve_load_path(self, set_load, control)
        self.history += records
        log.info("inflated to %.4g Pa: %d steps, %d Newton iterations", pressure, len(records),
                 sum(r.iterations for r in records))
        return records

    def set_hub(self, displacement) -> None:
        """Move the rigid hub (and the bead tied to it) to ``displacement`` (m, x / y / z) from
        its initial place; applied at the next solve."""
        self.hub.value = np.asarray(displacement, dtype=float)

    def press(self, hub_travel: float, control: StepControl | None = None,
              on_step: Callable[[], dict] | None = None) -> list[StepRecord]:
        """Lower the hub by ``hub_travel`` (m) from where it is, the pressure held, against the
        ground; ``on_step()`` is called after each converged step and its dict kept in the record.
        Raises :class:`~rollsim.solver.stepping.SolverDivergedError` on failure."""
        if self.ground is None:
            raise ValueError("press: this carcass has no ground (give ground=...)")
        start = np.array(self.hub.value, dtype=float)
        control = control or StepControl(dt=0.05, dt_min=1e-4, dt_max=0.1, easy_iterations=6, max_cuts=8)

        def set_load(t):
            self.set_hub(start - np.array([0.0, 0.0, t * hub_travel]))

        records = solve_load_path(self, set_load, control, on_step=(lambda t: on_step()) if on_step else None)
        self.history += records
        return records

    def ground_force(self) -> float:
        """Upward force of the ground on the modelled part of the body, N."""
        if self.ground is None:
            return 0.0
        return self._assemble(self._ground_force_form)

    def contact_area(self) -> float:
        """Current area of the contact facets pressed into the ground, m^2."""
        if self.ground is None:
            return 0.0
        return self._assemble(self._contact_area_form)

    def lowest_point(self, facet_name: str = "outer_surface") -> float:
        """Lowest current height (m) of the nodes of the named facets (a tire's sinkage is
        measured to its lowest point)."""
        if facet_name not in self._surface_nodes:
            tagged = self.tagged
            Vz, to_u = self.V.sub(2).collapse()
            facets = tagged.facet_tags.find(tagged.facet_names[facet_name])
            dofs = fem.locate_dofs_topological(Vz, tagged.mesh.topology.dim - 1, facets)
            dofs = dofs[dofs < Vz.dofmap.index_map.size_local]                  # owned: each node once
            self._surface_nodes[facet_name] = (Vz.tabulate_dof_coordinates()[dofs, 2], np.asarray(to_u)[dofs])
        z0, u_z = self._surface_nodes[facet_name]
        z = z0 + self.u.x.array[u_z]
        return self.comm.allreduce(float(z.min()) if z.size else np.inf, op=MPI.MIN)

    def _assemble(self, form) -> float:
        """A compiled scalar form summed over the ranks."""
        return self.comm.allreduce(fem.assemble_scalar(form), op=MPI.SUM)

    def _integral(self, integrand) -> float:
        return self._assemble(fem.form(integrand))

    def gas_force(self) -> np.ndarray:
        """Resultant force of the pressure on the body's current pressure surface (N, x / y / z)."""
        return np.array([self._integral(self._traction[i] * self._surface) for i in range(3)])

    def mean_normal_displacement(self, facet_name: str) -> float:
        """Mean of ``u . N`` over the named facets (m; N the outward reference normal of the body)."""
        tagged = self.tagged
        surface = self._ds(tagged.facet_names[facet_name])
        n = ufl.FacetNormal(tagged.mesh)
        return self._integral(ufl.dot(self.u, n) * surface) / self._integral(1.0 * surface)
