"""Pneumatic tire pressed into the soil: the inflated carcass and the elastoplastic soil in one
Newton system, coupled by frictional contact of the two bodies.

The mesh holds both (:func:`rollsim.geometry.build_tire_on_soil`).  The carcass is neo-Hookean
(:class:`~rollsim.solver.materials.NeoHookean`, per section), its bead (``hub_rim``) tied to the
rigid hub, whose displacement :attr:`PneumaticIndentation.hub` prescribes; the inflation pressure
acts on the current inner surface (a follower load, ``p J F^-T N`` per unit reference area, with
its load stiffness in the Jacobian); the tire's outer surface is the slave of a
:class:`~rollsim.solver.contact_pair.FacetContact` on the soil's top (Coulomb friction, penalty).
Stages: :meth:`gravity_step` (the soil under its weight, the tire clear), :meth:`inflate` (the
pressure ramped, the hub held, the tire clear of the soil), :meth:`touch` and :meth:`press` (the
hub lowered).  Forces are of the whole wheel
(the modelled part times the symmetry factor).
"""
from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from rollsim.geometry.tire import TIRE_CELL_TAGS
from rollsim.log import get_logger

from .contact import DEFAULT_PENALTY
from .contact_pair import FacetContact
from .indentation import _NORMAL_COMPONENT, symmetry_factor
from .materials import NeoHookean
from .problem import PlasticityProblem
from .stepping import SolverDivergedError, StepControl, StepRecord, solve_load_path

__all__ = ["PneumaticIndentation"]

log = get_logger("solver")


class PneumaticIndentation:
    """A pneumatic tire over the soil of ``tagged`` (one mesh, :func:`~rollsim.geometry.build_tire_on_soil`).

    ``soil``: the soil's material, or ``{cell tag: material}`` per layer; ``carcass``: a
    :class:`NeoHookean`, or ``{section name: NeoHookean}`` for ``tread``, ``transition``,
    ``sidewall``; ``gamma``: the soil's unit weight (N/m^3); ``friction``: Coulomb's mu between
    tire and soil; ``penalty``: alpha in ``kappa = alpha E_max / h``; ``volumetric_strain``,
    ``linear_solver``, ``petsc_options``: as for :class:`~rollsim.solver.problem.PlasticityProblem`.
    """

    def __init__(self, tagged, soil, carcass, *, gamma: float = 0.0, K0: float | None = None,
                 friction: float = 0.0, penalty: float = DEFAULT_PENALTY, volumetric_strain: str = "pointwise",
                 linear_solver: str = "auto", petsc_options: dict | None = None):
        msh = tagged.mesh
        names = tagged.facet_names
        missing = [n for n in ("inner_surface", "outer_surface", "hub_rim", "top") if n not in names]
        if missing:
            raise ValueError(f"the mesh has no facets named {missing}: build it with build_tire_on_soil")
        self.tagged, self.comm = tagged, msh.comm
        self.gamma, self.K0 = float(gamma), K0
        self.factor = symmetry_factor(names, 3)
        sections = {n: t for n, t in TIRE_CELL_TAGS.items() if n in tagged.cell_names}
        carcass = carcass if isinstance(carcass, dict) else {name: carcass for name in sections}
        unknown = sorted(set(carcass) - set(sections))
        if unknown or not all(isinstance(m, NeoHookean) for m in carcass.values()):
            raise ValueError(f"carcass: give a NeoHookean per section of {sorted(sections)}"
                             + (f" (no section {unknown} in the mesh)" if unknown else ""))
        soil_tags = [t for n, t in tagged.cell_names.items() if n not in sections]
        soil = soil if isinstance(soil, dict) else {tag: soil for tag in soil_tags}
        materials = {**soil, **{sections[name]: mat for name, mat in carcass.items()}}
        body = ufl.as_vector([0.0, 0.0, -self.gamma]) if self.gamma else None
        self.problem = pb = PlasticityProblem(msh, materials, body_force=body, cell_tags=tagged.cell_tags,
                                              volumetric_strain=volumetric_strain, linear_solver=linear_solver,
                                              petsc_options=petsc_options)
        V = pb.V
        fdim = msh.topology.dim - 1
        #: the hub's displacement (m): the bead follows it
        self.hub = fem.Constant(msh, np.zeros(3, dtype=PETSc.ScalarType))
        bcs = []
        for name, comp in _NORMAL_COMPONENT[3].items():
            if name in names:
                dofs = fem.locate_dofs_topological(V.sub(comp), fdim, tagged.facet_tags.find(names[name]))
                bcs.append(fem.dirichletbc(0.0, dofs, V.sub(comp)))
        bead = fem.locate_dofs_topological(V, fdim, tagged.facet_tags.find(names["hub_rim"]))
        bcs.append(fem.dirichletbc(self.hub, bead, V))
        pb.bcs = bcs
        #: the inflation pressure (Pa)
        self.pressure = fem.Constant(msh, PETSc.ScalarType(0.0))
        ds = ufl.Measure("ds", domain=msh, subdomain_data=tagged.facet_tags, metadata={"quadrature_degree": 4})
        F = ufl.Identity(3) + ufl.grad(pb.u)
        area_vector = ufl.det(F) * ufl.dot(ufl.inv(F).T, ufl.FacetNormal(msh))     # J F^-T N (Nanson)
        pb.add_residual_term(self.pressure * ufl.dot(area_vector, pb.test_function) * ds(names["inner_surface"]))
        master = tuple(names[n] for n in ("top", "contact") if n in names)
        self.contact = FacetContact(pb, tagged.facet_tags, (names["outer_surface"],), master, penalty=penalty,
                                    friction=friction)
        self._outer = self._surface_z_dofs(names["outer_surface"])
        self.n_dofs = pb.n_dofs

    def _surface_z_dofs(self, tag: int) -> tuple[np.ndarray, np.ndarray]:
        """Owned z dofs of the nodes of facets ``tag`` and their reference heights (m)."""
        V = self.problem.V
        Vz, to_parent = V.sub(2).collapse()
        local = fem.locate_dofs_topological((V.sub(2), Vz), 2, self.tagged.facet_tags.find(tag))[0]
        owned = local[local < V.dofmap.index_map.size_local * V.dofmap.index_map_bs]
        heights = V.tabulate_dof_coordinates()[owned // V.dofmap.index_map_bs, 2]
        return owned, heights

    # ------------------------------------------------------------------ readings
    def lowest_point(self) -> float:
        """Current height (m) of the tire's lowest point (the soil's undisturbed surface is z = 0)."""
        dofs, heights = self._outer
        z = heights + self.problem.u.x.array[dofs]
        return self.comm.allreduce(float(z.min(initial=np.inf)), op=MPI.MIN)

    def wheel_load(self) -> float:
        """Vertical force of the soil on the whole tire, N."""
        return self.factor * float(self.contact.forces().force[2])

    # ------------------------------------------------------------------ stages
    def gravity_step(self) -> None:
        """Geostatic stress of the soil in equilibrium with its weight (the tire clear of it and
        held at the hub); displacements zeroed.  Nothing without unit weight."""
        pb = self.problem
        if not self.gamma:
            return
        pb.set_geostatic_stress(self.gamma, surface=0.0, K0=self.K0)
        rep = pb.solve_increment()
        if not rep.converged:
            pb.restore()
            raise SolverDivergedError("gravity step did not converge", None, [])
        pb.commit()
        pb.reset_displacement()

    def inflate(self, pressure: float, control: StepControl | None = None) -> list[StepRecord]:
        """Ramp the inflation pressure from its current value to ``pressure`` (Pa), the hub held."""
        start = float(self.pressure.value)
        control = control or StepControl(dt=0.25, dt_max=0.5)
        records = solve_load_path(self.problem,
                                  lambda t: setattr(self.pressure, "value", start + t * (pressure - start)), control)
        if self.contact.forces().points_in_contact:
            raise ValueError(f"the tire inflated to {pressure:g} Pa reaches the soil (lowest point at "
                             f"{self.lowest_point():.4g} m): place it higher (gap) to inflate it clear")
        return records

    def touch(self, control: StepControl | None = None) -> list[StepRecord]:
        """Lower the hub until the tire's lowest point reaches the soil's undisturbed surface."""
        return self.press(self.lowest_point(), control or StepControl(dt=0.5, dt_max=0.5))

    def press(self, travel: float, control: StepControl | None = None, on_step=None) -> list[StepRecord]:
        """Lower the hub by ``travel`` (m) from where it is; ``on_step(t)`` after each converged
        step (``t``: the fraction of the travel) may return a dict kept in the step's record."""
        start = np.array(self.hub.value, dtype=float)

        def move(t):
            self.hub.value = start - np.array([0.0, 0.0, t * travel])

        return solve_load_path(self.problem, move, control or StepControl(dt=0.1, dt_max=0.25), on_step=on_step)
