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
hub lowered), or :meth:`press_to_sinkage`.  Forces are of the whole wheel (the modelled part
times the symmetry factor).  The sinkage is the depth of the tire's lowest point below the
undisturbed surface z = 0; :meth:`tire_state` gives the tire's deflection, contact length,
equivalent diameter, flexibility and the carcass's share of the load.
"""
from __future__ import annotations

import time

import numpy as np
import ufl
from dolfinx import fem
from mpi4py import MPI
from petsc4py import PETSc

from rollsim.geometry.tire import TIRE_CELL_TAGS
from rollsim.log import get_logger

from .carcass import current_area_vector
from .contact_pair import FacetContact
from .indentation import _NORMAL_COMPONENT, IndentationStep, StepCounts, symmetry_factor
from .materials import NeoHookean
from .problem import PlasticityProblem
from .stepping import SolverDivergedError, StepControl, StepRecord, settle_under_gravity, solve_load_path

__all__ = ["PneumaticIndentation", "TIRE_PENALTY"]

#: default penalty factor of the tire-soil contact: in 3D alpha = 3 reads the pressure better than
#: 10 (see docs/verification.md, "Two deformable bodies") and lets the soil's penetration stay small
TIRE_PENALTY = 3.0

#: the largest hub travel of one step of :meth:`PneumaticIndentation.press_to_load`, in aimed sinkage steps
MAX_TRAVEL_RATIO = 4.0

log = get_logger("solver")


def _travel_ratio(travel: float, s0: float, s1: float, ratio: float) -> float:
    """The hub's travel per unit of sinkage of a step that sank the tire from ``s0`` to ``s1``
    (kept within 1-20; ``ratio`` unchanged where the step did not sink it)."""
    return min(max(travel / (s1 - s0), 1.0), 20.0) if s1 > s0 else ratio


class PneumaticIndentation(StepCounts):
    """A pneumatic tire over the soil of ``tagged`` (one mesh, :func:`~rollsim.geometry.build_tire_on_soil`
    of the :class:`~rollsim.geometry.PneumaticTire` ``tire``).

    ``soil``: the soil's material, or ``{cell tag: material}`` per layer; ``carcass``: a
    :class:`NeoHookean`, or ``{section name: NeoHookean}`` for ``tread``, ``transition``,
    ``sidewall``; ``gamma``: the soil's unit weight (N/m^3); ``friction``: Coulomb's mu between
    tire and soil; ``penalty``: alpha in ``kappa = alpha E_max / h``; ``volumetric_strain``,
    ``linear_solver``, ``petsc_options``: as for :class:`~rollsim.solver.problem.PlasticityProblem`.
    """

    def __init__(self, tagged, tire, soil, carcass, *, gamma: float = 0.0, K0: float | None = None,
                 friction: float = 0.0, penalty: float = TIRE_PENALTY, volumetric_strain: str = "pointwise",
                 linear_solver: str = "auto", petsc_options: dict | None = None):
        msh = tagged.mesh
        names = tagged.facet_names
        missing = [n for n in ("inner_surface", "outer_surface", "hub_rim", "top") if n not in names]
        if missing:
            raise ValueError(f"the mesh has no facets named {missing}: build it with build_tire_on_soil")
        self.tagged, self.comm = tagged, msh.comm
        self.gamma, self.K0 = float(gamma), K0
        self.factor = symmetry_factor(names, 3)
        #: a quarter model (x >= the axle only), else a half or full model
        self.quarter = "symmetry_x" in names
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
        #: the hub's displacement (m) and rotation about the axle (rad, positive rolling towards +x):
        #: the bead follows them (:meth:`_place_hub`)
        self.hub = np.zeros(3)
        self.hub_rotation = 0.0
        bcs = []
        for name, comp in _NORMAL_COMPONENT[3].items():
            if name in names:
                dofs = fem.locate_dofs_topological(V.sub(comp), fdim, tagged.facet_tags.find(names[name]))
                bcs.append(fem.dirichletbc(0.0, dofs, V.sub(comp)))
        self._bead = fem.locate_dofs_topological(V, fdim, tagged.facet_tags.find(names["hub_rim"]))
        self._bead_arm = V.tabulate_dof_coordinates()[self._bead] - np.array(tire.centre)   # m, from the axle
        self._bead_u = fem.Function(V)
        bcs.append(fem.dirichletbc(self._bead_u, self._bead))
        pb.bcs = bcs
        #: the inflation pressure (Pa)
        self.pressure = fem.Constant(msh, PETSc.ScalarType(0.0))
        ds = ufl.Measure("ds", domain=msh, subdomain_data=tagged.facet_tags, metadata={"quadrature_degree": 4})
        F = ufl.Identity(3) + ufl.grad(pb.u)
        pb.add_residual_term(self.pressure * ufl.dot(current_area_vector(F, msh), pb.test_function)
                             * ds(names["inner_surface"]))
        master = tuple(names[n] for n in ("top", "contact") if n in names)
        self.contact = FacetContact(pb, tagged.facet_tags, (names["outer_surface"],), master, penalty=penalty,
                                    friction=friction)
        self._outer = self._surface_z_dofs(names["outer_surface"])
        self.n_dofs = pb.n_dofs
        self.diameter = tire.diameter
        self.x_centre = tire.x_centre
        self.tread_half_width = tire.width / 2 - tire.shoulder_radius    # m, the tread's flat half width
        #: the hub's height (m, its z displacement) when the inflated tire touched the soil
        self.hub_at_touch: float | None = None
        #: converged steps of the press (whole-wheel forces)
        self.steps: list[IndentationStep] = []
        #: the rigid wheel's regularisation devices, none here (the soil is rate-independent)
        self.relaxation_length = 0.0
        self.relaxed_spans: list[tuple[float, float]] = []
        self._t_last = time.perf_counter()

    def _surface_z_dofs(self, tag: int) -> tuple[np.ndarray, np.ndarray]:
        """Owned z dofs of the nodes of facets ``tag`` and their reference heights (m)."""
        V = self.problem.V
        Vz, _ = V.sub(2).collapse()
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

    def _patch_length(self, x: np.ndarray) -> float:
        """Length along the travel of the contact patch whose points (this rank's) are ``x``, m
        (0: no contact; collective)."""
        x_axle = self.x_centre + self.hub[0]
        ahead = self.comm.allreduce(float((x[:, 0] - x_axle).max(initial=-np.inf)), op=MPI.MAX)
        behind = self.comm.allreduce(float((x[:, 0] - x_axle).min(initial=np.inf)), op=MPI.MIN)
        if not np.isfinite(ahead):
            return 0.0
        return 2 * ahead if self.quarter else ahead - behind     # the quarter model holds x >= the axle only

    def tire_state(self) -> dict:
        """The tire now (SI, whole wheel; collective): ``sinkage_m``; ``hub_displacement_m``, the
        hub's travel since the inflated tire touched the soil; ``deflection_m``, the loss of loaded
        radius (hub travel minus sinkage); ``contact_length_m`` along the travel direction;
        ``equivalent_diameter_m``, the diameter of the circle fitted (least squares,
        ``z = z_0 + (x - x_c)^2 / d_e``) to the deformed contact arc of the tread (the contact
        points on its flat part), and
        ``equivalent_diameter_from_length_m``, the circle through the patch's ends at the sinkage,
        ``(l/2)^2 / s + s`` (sensitive to the patch's resolution); ``flexibility_m_per_N``,
        ``(d_e - d) / Q`` of the fitted ``d_e`` (None where a value is undefined: no load, or too
        few contact points on the tread for the fit);
        ``carcass_load_share``, ``(Q - p A) / Q`` with A the contact area
        (:meth:`~rollsim.solver.contact_pair.FacetContact.contact_area`); ``contact_area_m2``."""
        s = -self.lowest_point()
        Q = self.wheel_load()
        x = self.contact.contact_points()[0]
        comm = self.comm
        x_axle = self.x_centre + self.hub[0]
        length = self._patch_length(x)
        area = self.factor * self.contact.contact_area()
        hub = 0.0 if self.hub_at_touch is None else self.hub_at_touch - float(self.hub[2])
        tread = np.abs(x[:, 1]) < self.tread_half_width          # the fit of z = z_0 + r2 / d_e
        r2, z = (x[tread, 0] - x_axle) ** 2, x[tread, 2]
        sums = np.array([tread.sum(), r2.sum(), (r2 * r2).sum(), z.sum(), (r2 * z).sum()])
        n, sx, sxx, sz, sxz = comm.allreduce(sums)
        slope = (n * sxz - sx * sz) / (n * sxx - sx * sx) if n > 2 and n * sxx - sx * sx > 0 else 0.0
        d_e = 1.0 / slope if slope > 0 else None
        loaded = Q > 0 and s > 0
        return {"sinkage_m": s, "hub_displacement_m": hub, "deflection_m": hub - s, "contact_length_m": length,
                "equivalent_diameter_m": d_e,
                "equivalent_diameter_from_length_m": (length / 2) ** 2 / s + s if loaded else None,
                "flexibility_m_per_N": (d_e - self.diameter) / Q if loaded and d_e is not None else None,
                "carcass_load_share": (Q - float(self.pressure.value) * area) / Q if loaded else None,
                "contact_area_m2": area, "wheel_load_N": Q, "inflation_Pa": float(self.pressure.value)}

    def _step(self, iterations: int, cuts: int) -> IndentationStep:
        """The record of a converged step of the press."""
        now = time.perf_counter()
        F = self.contact.forces()
        pb = self.problem
        area = self.factor * self.contact.contact_area()
        st = IndentationStep(step=len(self.steps) + 1, sinkage=-self.lowest_point(), QV=self.factor * float(F.force[2]),
                             QH=0.0, moment=0.0, contact_area=area, max_penetration=F.max_penetration,
                             iterations=iterations, cuts=cuts,
                             plastic=int(self.comm.allreduce(int(np.sum(pb.state != 0)))), time=now - self._t_last)
        self._t_last = now
        self.steps.append(st)
        return st

    # ------------------------------------------------------------------ stages
    def gravity_step(self) -> None:
        """Geostatic stress of the soil in equilibrium with its weight (the tire clear of it and
        held at the hub); displacements zeroed.  Nothing without unit weight."""
        if self.gamma:
            settle_under_gravity(self.problem, self.gamma, self.K0)

    def inflate(self, pressure: float, control: StepControl | None = None) -> list[StepRecord]:
        """Ramp the inflation pressure from its current value to ``pressure`` (Pa), the hub held.
        Full Newton steps (no line search): clear of the soil only the hyperelastic carcass is
        loaded, and a backtracking line search damps it to a crawl (measured: see
        docs/theory.md, "Pneumatic tire: carcass and inflation")."""
        start = float(self.pressure.value)
        control = control or StepControl(dt=0.25, dt_max=0.5)
        with self.problem.line_search("basic"):
            records = solve_load_path(self.problem,
                                      lambda t: setattr(self.pressure, "value", start + t * (pressure - start)),
                                      control)
        if self.contact.forces().points_in_contact:
            raise ValueError(f"the tire inflated to {pressure:g} Pa reaches the soil (lowest point at "
                             f"{self.lowest_point():.4g} m): place it higher (gap) to inflate it clear")
        return records

    def touch(self, control: StepControl | None = None) -> list[StepRecord]:
        """Lower the hub until the tire's lowest point reaches the soil's undisturbed surface."""
        records = self.press(self.lowest_point(), control or StepControl(dt=0.5, dt_max=0.5))
        self.hub_at_touch = float(self.hub[2])
        return records

    def press_to_sinkage(self, sinkage: float, step: float, stops=(), on_step=None) -> list[IndentationStep]:
        """Press the hub down in steps until the sinkage reaches ``sinkage`` (m), aiming at it and
        at every sinkage in ``stops``; ``step``: the largest sinkage increment (m) aimed at per
        step.  The hub's travel per step is the aimed sinkage increment times the ratio of travel
        to sinkage of the last step (at first 3: the tire deflects as it sinks), so a step may end
        a little past its aim.  ``on_step(st)`` after each converged step (a step cut by the
        stepper counts its sub-steps as cuts)."""
        if self.hub_at_touch is None:
            raise RuntimeError("touch() before press_to_sinkage()")
        targets = sorted({float(t) for t in stops if 0 < t < sinkage} | {float(sinkage)})
        ratio = 3.0
        for target in targets:
            while True:
                s0 = -self.lowest_point()
                if s0 >= target - 1e-3 * step:
                    break
                travel = ratio * min(step, target - s0)
                records = self.press(travel, StepControl(dt=1.0, dt_max=1.0))
                ratio = _travel_ratio(travel, s0, -self.lowest_point(), ratio)
                st = self._step(sum(r.iterations for r in records), max(len(records) - 1, 0))
                if on_step is not None:
                    on_step(st)
        return self.steps

    def press_to_load(self, load: float, step: float, sinkage_limit: float, rtol: float = 1e-3,
                      max_trials: int = 30, on_step=None) -> str:
        """Press the hub down until the wheel load is ``load`` (N) within ``rtol``.  Steps as in
        :meth:`press_to_sinkage` (at most ``step`` m of sinkage aimed at); a step that would
        pass the load is undone and the hub height that carries it is found by regula falsi from
        the last converged state below it, every accepted step loading further (the soil's path
        stays monotone); a step that does not converge is halved.  Returns ``"ok"`` or
        ``"exceeds_capacity"`` (the sinkage reached ``sinkage_limit`` below the load).  Raises
        :class:`~rollsim.solver.stepping.SolverDivergedError` (last converged state kept) after
        ``max_trials`` trials without a converged step."""
        if self.hub_at_touch is None:
            raise RuntimeError("touch() before press_to_load()")
        if not load > 0:
            raise ValueError(f"load must be > 0, got {load}")
        pb, ratio, above = self.problem, 3.0, None       # above: (hub height, load) of a trial past it
        while True:
            hub0, Q0, s0 = float(self.hub[2]), self.wheel_load(), -self.lowest_point()
            if abs(Q0 - load) <= rtol * load:
                return "ok"
            if s0 >= sinkage_limit:
                return "exceeds_capacity"
            # the hub's travel per step stays below MAX_TRAVEL_RATIO steps: on a stiff soil the tire
            # only deflects, and a long stroke drives the tread through the soil's top facets
            trial = hub0 - min(ratio * min(step, sinkage_limit - s0), MAX_TRAVEL_RATIO * step)
            its = cuts = 0
            for _ in range(max_trials):
                if above is not None:             # the height that carries the load, linearly
                    trial = hub0 + (load - Q0) * (above[0] - hub0) / (above[1] - Q0)
                self._set_hub_height(trial)
                rep = pb.solve_increment()
                its += rep.iterations
                if not rep.converged:             # half the travel, no interpolation until passed again
                    pb.restore()
                    trial, cuts, above = hub0 - 0.5 * (hub0 - trial), cuts + 1, None
                    continue
                Q = self.wheel_load()
                if Q <= load * (1 + rtol):
                    break
                pb.restore()
                above = (trial, Q)
            else:
                self._set_hub_height(hub0)
                raise SolverDivergedError(f"no converged step towards the load {load:g} N in {max_trials} trials",
                                          None, [])
            pb.commit()
            ratio = _travel_ratio(hub0 - trial, s0, -self.lowest_point(), ratio)
            st = self._step(its, cuts)
            if on_step is not None:
                on_step(st)

    def _set_hub_height(self, z: float) -> None:
        hub = self.hub.copy()
        hub[2] = z
        self._place_hub(hub)

    def _place_hub(self, displacement=None, rotation: float | None = None) -> None:
        """Move the hub to ``displacement`` (m) and ``rotation`` (rad about the axle; ``None``:
        unchanged); the bead follows as a rigid body, ``u = c + (R(theta) - I) (X - X_axle)``."""
        if displacement is not None:
            self.hub = np.asarray(displacement, dtype=float).copy()
        if rotation is not None:
            self.hub_rotation = float(rotation)
        c, s = np.cos(self.hub_rotation), np.sin(self.hub_rotation)
        arm = self._bead_arm
        turned = np.column_stack([c * arm[:, 0] + s * arm[:, 2], arm[:, 1], -s * arm[:, 0] + c * arm[:, 2]])
        values = self._bead_u.x.array.reshape(-1, 3)
        values[self._bead] = self.hub + turned - arm

    def press(self, travel: float, control: StepControl | None = None, on_step=None) -> list[StepRecord]:
        """Lower the hub by ``travel`` (m) from where it is; ``on_step(t)`` after each converged
        step (``t``: the fraction of the travel) may return a dict kept in the step's record."""
        start = self.hub.copy()

        def move(t):
            self._place_hub(start - np.array([0.0, 0.0, t * travel]))

        return solve_load_path(self.problem, move, control or StepControl(dt=0.1, dt_max=0.25), on_step=on_step)
