"""Frictional contact of the soil with a rigid wheel known as an exact analytic surface.

Formulation (penalty, current configuration, consistent Newton linearisation)
------------------------------------------------------------------------------
Soil surface points ``X`` on the contact facets are at ``x = X + u`` now.  The wheel has a pose
(centre ``c``, rotation ``theta`` about its axle) held in ``fem.Constant``\\ s, so it can translate and
rotate between and during solves without recompiling anything.  With ``R(theta)`` the rotation in
the vertical plane (x, z) (3D; (x, y) in 2D), a point in the wheel frame is ``p = R^T (x - c)`` and
the wheel surface gives the signed distance ``g(p)`` and outward unit normal ``n`` (written in UFL
from the same closed forms as :meth:`rollsim.geometry.CylinderWheel.signed_distance` /
:meth:`~rollsim.geometry.TorusWheel.signed_distance`; ``tests/test_contact.py`` checks that both
agree to round-off).  The traction on the soil is::

    p_N  = kappa <-g>_+                                             normal pressure (>= 0, separation allowed)
    t_tr = P_T t_n - k_T P_T ds,   P_T = I - n (x) n                trial friction traction
    t_T  = t_tr                       if |t_tr| <= mu p_N           stick
         = mu p_N t_tr / |t_tr|       otherwise                     slip (Coulomb return map)
    F_c(u; v) = - int_Gamma (p_N n + t_T) . v  dA

``ds = x_prev - (X + u_n)`` is the slip of the soil point relative to the wheel material point
over the step: the wheel point now at ``x`` was at ``x_prev = c_n + R(theta_n) R(theta)^T (x - c)``
at the last converged pose ``(c_n, theta_n)`` - exact for any translation and rotation of the
wheel.  ``t_n`` (the converged friction traction) is history: a vector P2 field on the soil,
updated only by :meth:`commit` (interpolation of ``t_T`` at the nodes) and untouched by rejected
iterates; the pose is committed with it.  The Jacobian is ``ufl.derivative`` of ``F_c`` (gap,
normal and curvature, active set and stick/slip switch all differentiated: the consistent tangent
of the discrete law; non-symmetric with friction, fine for LU).

Penalty parameters: ``kappa = alpha E / h`` (``h`` the element size at the contact surface, ``E``
the largest Young modulus of the soil), ``k_T = kappa``; the penetration error is ``p_N / kappa``
= ``(p_N / E) (h / alpha)``.  The default ``alpha`` (:data:`DEFAULT_PENALTY`) comes from the
measurement in ``python -m benchmarks contact hertz`` (see docs/verification.md, "Contact").

Forces are reported on the wheel (the negative of the force on the soil), for the modelled part
of the wheel only (the symmetry factor is applied by the callers).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import ufl
from dolfinx import fem
from dolfinx.fem import petsc as fpetsc
from mpi4py import MPI
from petsc4py import PETSc

from rollsim import compat

__all__ = ["Circle", "RigidWheelContact", "WheelForces", "PoseDerivatives", "ufl_signed_distance",
           "contact_cell_size", "DEFAULT_PENALTY"]

#: Default penalty factor alpha in kappa = alpha E / h (measured: see docs/verification.md, "Contact").
DEFAULT_PENALTY = 10.0


@dataclass(frozen=True)
class Circle:
    """Rigid cylinder of infinite length for plane-strain models (axle along the out-of-plane axis)."""

    diameter: float

    def __post_init__(self):
        if not self.diameter > 0:
            raise ValueError(f"diameter must be > 0, got {self.diameter}")

    def signed_distance(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(N,2) wheel-frame points -> signed distance (negative inside) and outward normal (N,2)."""
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        r = np.linalg.norm(p, axis=1)
        n = np.where(r[:, None] > 0, p / np.where(r > 0, r, 1.0)[:, None], np.array([0.0, -1.0]))
        return r - self.diameter / 2, n


    def distance_hessian(self, points: np.ndarray) -> np.ndarray:
        """(N,2,2) second derivative of :meth:`signed_distance` (1/m): ``(I - n n) / r``."""
        p = np.asarray(points, dtype=float).reshape(-1, 2)
        r = np.linalg.norm(p, axis=1)
        _, n = self.signed_distance(p)
        return (np.eye(2) - np.einsum("ni,nj->nij", n, n)) / np.where(r > 0, r, np.inf)[:, None, None]


def _pos(a):
    return ufl.max_value(a, 0.0)


def ufl_signed_distance(wheel, p):
    """Signed distance and outward unit normal (wheel frame) of the wheel-frame point ``p`` (UFL).

    ``wheel``: :class:`Circle` (2D), or ``CylinderWheel`` / ``TorusWheel`` from ``rollsim.geometry``
    (3D, axle along y).  Same closed forms as their ``signed_distance`` methods.
    """
    from rollsim.geometry import CylinderWheel, TorusWheel
    if isinstance(wheel, Circle):
        r = ufl.sqrt(ufl.dot(p, p))
        return r - wheel.diameter / 2, p / r
    rho = ufl.sqrt(p[0] ** 2 + p[2] ** 2)
    e_rho = ufl.as_vector([p[0] / rho, 0.0, p[2] / rho])
    e_y = ufl.as_vector([0.0, 1.0, 0.0])
    sgn_y = ufl.conditional(ufl.ge(p[1], 0.0), 1.0, -1.0)
    if isinstance(wheel, TorusWheel):
        d_rho = rho - wheel.major_radius
        length = ufl.sqrt(d_rho ** 2 + p[1] ** 2)
        return length - wheel.width / 2, (d_rho / length) * e_rho + (p[1] / length) * e_y
    if isinstance(wheel, CylinderWheel):
        f = wheel.fillet
        q_rho = rho - (wheel.diameter / 2 - f)
        q_y = sgn_y * p[1] - (wheel.width / 2 - f)
        out_rho, out_y = _pos(q_rho), _pos(q_y)
        outside = ufl.Or(ufl.gt(q_rho, 0.0), ufl.gt(q_y, 0.0))
        out_len = ufl.conditional(outside, ufl.sqrt(out_rho ** 2 + out_y ** 2), 0.0)
        dist = out_len + ufl.min_value(ufl.max_value(q_rho, q_y), 0.0) - f
        rho_wins = ufl.ge(q_rho, q_y)
        n_rho = ufl.conditional(outside, out_rho / out_len, ufl.conditional(rho_wins, 1.0, 0.0))
        n_y = ufl.conditional(outside, out_y / out_len, ufl.conditional(rho_wins, 0.0, 1.0))
        return dist, n_rho * e_rho + (n_y * sgn_y) * e_y
    raise TypeError(f"unsupported wheel {type(wheel).__name__}: Circle (2D), CylinderWheel or TorusWheel (3D)")


@dataclass
class PoseDerivatives:
    """Border of a Newton system with pose unknowns ``q`` (see
    :meth:`RigidWheelContact.pose_derivatives`): resultant ``values`` G (n), ``d_pose`` dG/dq
    (n x m), ``d_displacement`` dG/du (n PETSc vectors) and ``residual_d_pose`` dr/dq (m PETSc
    vectors, r the soil's residual)."""

    values: np.ndarray
    d_pose: np.ndarray
    d_displacement: list
    residual_d_pose: list


@dataclass
class WheelForces:
    """Resultant contact force on the (modelled part of the) wheel, N, and axle moment, N m.

    ``force``: vector (gdim); ``vertical`` = upward force on the wheel (Q_V > 0 when pressed into the
    soil); ``horizontal`` = x component of the force the wheel exerts on the soil (the towing force
    Q_H for a wheel moving in +x); ``moment``: moment of the contact forces on the wheel about the
    axle (about +y in 3D, +z in 2D)."""

    force: np.ndarray
    moment: float
    area: float
    max_penetration: float

    @property
    def vertical(self) -> float:
        return float(self.force[-1])

    @property
    def horizontal(self) -> float:
        return float(-self.force[0])


class RigidWheelContact:
    """Penalty frictional contact between ``problem``'s soil and a rigid ``wheel``.

    Parameters
    ----------
    problem : :class:`~rollsim.solver.problem.PlasticityProblem` (before its first solve)
    wheel : ``Circle`` (2D) or ``CylinderWheel`` / ``TorusWheel`` (3D)
    facet_tags, contact_ids : facets where contact is checked (e.g. top 1 and contact 2)
    friction : Coulomb coefficient mu (0: frictionless, no tangential terms compiled)
    penalty : alpha in kappa = alpha E / h (default :data:`DEFAULT_PENALTY`)
    E : modulus for the scaling (default: the largest of the problem's materials)
    h : element size at the contact (default: the smallest cell size next to the contact facets)
    tangential_ratio : k_T / kappa
    quadrature_degree : of the facet integrals (the integrand has a kink at the contact edge)
    centre, angle : initial pose
    """

    def __init__(self, problem, wheel, facet_tags, contact_ids=(1, 2), *, friction: float = 0.0,
                 penalty: float | None = None, E: float | None = None, h: float | None = None,
                 tangential_ratio: float = 1.0, quadrature_degree: int = 6,
                 centre=None, angle: float = 0.0, smoothing: float = 0.0):
        self.problem = pb = problem
        self.wheel = wheel
        msh = pb.mesh
        gdim = self.gdim = pb.gdim
        if (gdim == 2) != isinstance(wheel, Circle):
            raise ValueError("use Circle in 2D and CylinderWheel / TorusWheel in 3D")
        if friction < 0:
            raise ValueError(f"friction must be >= 0, got {friction}")
        self.friction = float(friction)
        self.alpha = DEFAULT_PENALTY if penalty is None else float(penalty)
        if not self.alpha > 0:
            raise ValueError(f"penalty must be > 0, got {penalty}")
        self.E = float(E) if E is not None else max(m.E for m in pb.materials.values())
        ids = self.contact_ids = tuple(int(i) for i in np.atleast_1d(contact_ids))
        self.h = float(h) if h is not None else contact_cell_size(msh, facet_tags, ids)
        self.kappa = self.alpha * self.E / self.h
        self.k_t = tangential_ratio * self.kappa

        sc = PETSc.ScalarType
        c0 = np.zeros(gdim) if centre is None else np.asarray(centre, dtype=float)
        self.centre = fem.Constant(msh, sc(c0))
        self.angle = fem.Constant(msh, sc(angle))
        self.centre_n = fem.Constant(msh, sc(c0))
        self.angle_n = fem.Constant(msh, sc(angle))
        self._kappa_c = fem.Constant(msh, sc(self.kappa))
        self._kt_c = fem.Constant(msh, sc(self.k_t))
        self._mu_c = fem.Constant(msh, sc(self.friction))

        self.ds = ufl.Measure("ds", domain=msh, subdomain_data=facet_tags,
                              metadata={"quadrature_degree": quadrature_degree})(ids)
        u, u_n, v = pb.u, pb.u_n, pb.test_function
        X = ufl.SpatialCoordinate(msh)
        x = X + u
        iv = gdim - 1                      # vertical axis; rotation in the plane (0, iv)
        rot = self._rotate

        # the pose's unknowns of a bordered Newton step (axle height, rotation) as UFL variables,
        # so forms can be differentiated with respect to them (see :meth:`pose_derivatives`)
        self._pose_vars = {"height": ufl.variable(self.centre[iv]), "angle": ufl.variable(self.angle)}
        centre = ufl.as_vector([self._pose_vars["height"] if i == iv else self.centre[i] for i in range(gdim)])
        angle = self._pose_vars["angle"]
        p = rot(angle, x - centre, transpose=True)
        g, n_w = ufl_signed_distance(wheel, p)
        n = rot(angle, n_w)
        self.gap, self.normal = g, n
        # normal pressure kappa <-g>_+, optionally with the kink rounded over a band |g| < eps
        # (C1 quadratic blend; eps = smoothing * h) - helps Newton when many points change status
        self.smoothing = float(smoothing)
        if self.smoothing > 0:
            eps = self.smoothing * self.h
            pen = -g
            pN = self._kappa_c * ufl.conditional(ufl.ge(pen, eps), pen,
                                                 ufl.conditional(ufl.le(pen, -eps), 0.0, (pen + eps) ** 2 / (4 * eps)))
        else:
            pN = self._kappa_c * _pos(-g)
        traction = pN * n
        if self.friction > 0:
            # where the surface point was at the last converged pose, carried with the wheel
            x_prev = self.centre_n + rot(self.angle_n, rot(angle, x - centre, transpose=True))
            traction = traction + self._init_friction(x_prev - (X + u_n), n, pN, facet_tags, ids)
        else:
            self.t_n = None
        self.pressure = pN
        self.traction = traction                  # on the soil
        F = -ufl.inner(traction, v) * self.ds
        pb.add_residual_term(F)
        pb.add_state_hooks(commit=self.commit, restore=self.restore)

        self._init_resultants(x - centre, traction, g)
        self._border_forms: dict = {}
        self._committed = None

    def _init_resultants(self, r, traction, g) -> None:
        """The forms of the force and the moment on the wheel (minus those on the soil; ``r``: the
        surface point from the axle) and of the contact area (``g < 0``)."""
        gdim, iv = self.gdim, self.gdim - 1
        self._force_forms = [fem.form(-traction[i] * self.ds) for i in range(gdim)]
        # moment about the axle (+y in 3D, +z in 2D) of the force -traction applied at x
        mom = -(r[iv] * traction[0] - r[0] * traction[iv]) if gdim == 3 else -(r[0] * traction[1] - r[1] * traction[0])
        self._moment_form = fem.form(mom * self.ds)
        self._resultants = {"vertical_force": -traction[iv], "moment": mom}
        self._area_form = fem.form(ufl.conditional(ufl.lt(g, 0.0), 1.0, 0.0) * self.ds)

    def _rotate(self, theta, a, transpose: bool = False):
        """``a`` turned by ``theta`` in the plane of the first and the vertical axis (UFL)."""
        iv = self.gdim - 1
        cth, sth = ufl.cos(theta), ufl.sin(theta)
        s = -sth if transpose else sth
        comps = [a[i] for i in range(self.gdim)]
        comps[0] = cth * a[0] + s * a[iv]
        comps[iv] = -s * a[0] + cth * a[iv]
        return ufl.as_vector(comps)

    def _init_friction(self, slip, n, pN, facet_tags, ids):
        """The Coulomb traction (UFL) for the surface's ``slip`` since the last converged state,
        the normal ``n`` and the pressure ``pN``: trial ``t_n - k_T slip`` in the tangent plane,
        returned to ``|t| <= mu pN``; its history :attr:`t_n` at the surface cells' nodes."""
        pb, msh, gdim = self.problem, self.problem.mesh, self.gdim
        V = pb.V
        self.t_n = fem.Function(V, name="friction_traction_converged")
        PT = ufl.Identity(gdim) - ufl.outer(n, n)
        t_tr = ufl.dot(PT, self.t_n) - self._kt_c * ufl.dot(PT, slip)
        norm = ufl.sqrt(ufl.dot(t_tr, t_tr))
        limit = self._mu_c * pN
        t_T = ufl.conditional(ufl.le(norm, limit), t_tr, limit * t_tr / ufl.max_value(norm, 1e-300))
        self._t_T, self._t_tr = t_T, t_tr
        self._t_T_expr = compat.expression(t_T, compat.interpolation_points(V))
        # history lives at the nodes of the surface cells only
        fdim = msh.topology.dim - 1
        msh.topology.create_connectivity(fdim, msh.topology.dim)
        facets = np.concatenate([facet_tags.find(i) for i in ids])
        self._hist_cells = np.unique(compat.incident_entities(msh, facets, fdim, msh.topology.dim))
        self._t_n_saved = self.t_n.x.array.copy()
        return t_T

    # ------------------------------------------------------------------ pose and history
    def set_pose(self, centre=None, angle: float | None = None) -> None:
        """Move the wheel (takes effect at the next residual evaluation)."""
        if centre is not None:
            self.centre.value = np.asarray(centre, dtype=float)
        if angle is not None:
            self.angle.value = float(angle)

    @property
    def pose(self) -> tuple[np.ndarray, float]:
        return np.array(self.centre.value, dtype=float), float(self.angle.value)

    def commit(self) -> None:
        """Accept the current (converged) state: friction history and pose (a PlasticityProblem hook,
        run before the problem updates ``u_n``).  The resultants of the converged state are kept:
        after the commit the slip of the step is gone, so :meth:`forces` returns these values until
        the displacement or the pose changes."""
        self._committed = (self._assemble(), self.problem.u.x.array.copy(), self.pose)
        if self.t_n is not None:
            tmp = fem.Function(self.t_n.function_space)
            tmp.interpolate(self._t_T_expr, self._hist_cells)
            self.t_n.x.array[:] = tmp.x.array
            self.t_n.x.scatter_forward()
            self._t_n_saved = self.t_n.x.array.copy()
        self.centre_n.value = np.array(self.centre.value)
        self.angle_n.value = float(self.angle.value)

    def restore(self) -> None:
        """Reject: the friction history is untouched by iterates, nothing to undo but the pose is
        left as set (the caller resets it with :meth:`set_pose` when needed)."""
        if self.t_n is not None:
            self.t_n.x.array[:] = self._t_n_saved

    # ------------------------------------------------------------------ bordered Newton
    def pose_derivatives(self, quantities: tuple[str, ...], unknowns: tuple[str, ...]) -> "PoseDerivatives":
        """Values and derivatives, at the current displacement and pose, of the resultants
        ``quantities`` (``"vertical_force"``, N; ``"moment"``, N m; modelled part of the wheel)
        with respect to the displacement and to the pose ``unknowns`` (``"height"`` of the axle,
        m; ``"angle"``, rad), and of the contact residual with respect to the unknowns: the border
        rows and columns of a Newton system in which the pose is solved with the soil (exact
        derivatives of the discrete contact law; Dirichlet rows are zero)."""
        for name in quantities:
            if name not in self._resultants:
                raise ValueError(f"quantity must be one of {sorted(self._resultants)}, got {name!r}")
        for name in unknowns:
            if name not in self._pose_vars:
                raise ValueError(f"unknown must be one of {sorted(self._pose_vars)}, got {name!r}")
        key = (quantities, unknowns)
        if key not in self._border_forms:
            self._border_forms[key] = self._compile_border(quantities, unknowns)
        value_f, dq_f, du_f, dres_f, vecs = self._border_forms[key]
        comm, bcs = self.problem.comm, self.problem.bcs
        x0 = compat.petsc_vector(self.problem.u)
        for form, vec in zip(du_f + dres_f, vecs):
            with vec.localForm() as loc:
                loc.set(0.0)
            fpetsc.assemble_vector(vec, form)
            vec.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
            compat.set_bc(vec, bcs, x0, 0.0)            # Dirichlet rows: 0
        n = len(value_f)
        return PoseDerivatives(values=np.array([_assemble_global(f, comm) for f in value_f]),
                               d_pose=np.array([[_assemble_global(f, comm) for f in row]
                                                for row in dq_f]).reshape(n, -1),
                               d_displacement=vecs[:n], residual_d_pose=vecs[n:])

    def _compile_border(self, quantities, unknowns):
        u, v = self.problem.u, self.problem.test_function
        q = [self._pose_vars[k] for k in unknowns]
        res = [self._resultants[k] for k in quantities]
        value_f = [fem.form(r * self.ds) for r in res]
        dq_f = [[fem.form(ufl.diff(r, qk) * self.ds) for qk in q] for r in res]
        du_f = [fem.form(ufl.derivative(r * self.ds, u, v)) for r in res]
        dres_f = [fem.form(-ufl.inner(ufl.diff(self.traction, qk), v) * self.ds) for qk in q]
        return value_f, dq_f, du_f, dres_f, [compat.create_vector(f) for f in du_f + dres_f]

    def move_pose(self, unknowns: tuple[str, ...], increments) -> None:
        """Add ``increments`` to the pose ``unknowns`` (see :meth:`pose_derivatives`)."""
        iv = self.gdim - 1
        for name, dq in zip(unknowns, increments):
            if name == "height":
                c = np.array(self.centre.value, dtype=float)
                c[iv] += dq
                self.centre.value = c
            else:
                self.angle.value = float(self.angle.value) + dq

    # ------------------------------------------------------------------ results
    def forces(self) -> WheelForces:
        """Resultant force and moment on the wheel at the current displacement and pose (global, all
        ranks); at a just committed state, those of the converged step (see :meth:`commit`)."""
        if self._committed is not None:
            vals, u_c, (c_c, th_c) = self._committed
            c, th = self.pose
            same = (np.array_equal(u_c, self.problem.u.x.array) and np.array_equal(c, c_c) and th == th_c)
            if self.problem.comm.allreduce(int(not same)) == 0:
                return vals
        return self._assemble()

    def _assemble(self) -> WheelForces:
        comm = self.problem.comm
        f = np.array([_assemble_global(F, comm) for F in self._force_forms])
        m = _assemble_global(self._moment_form, comm)
        a = _assemble_global(self._area_form, comm)
        return WheelForces(force=f, moment=float(m), area=float(a), max_penetration=self.max_penetration())

    def max_penetration(self) -> float:
        """Largest penetration ``-g`` of the soil's surface nodes into the wheel, m (0 if none)."""
        pts = self._surface_points()
        if pts.shape[0]:
            c, th = self.pose
            iv = self.gdim - 1
            rel = pts - c
            cth, sth = np.cos(th), np.sin(th)
            p = rel.copy()
            p[:, 0] = cth * rel[:, 0] - sth * rel[:, iv]
            p[:, iv] = sth * rel[:, 0] + cth * rel[:, iv]
            g, _ = self.wheel.signed_distance(p)
            loc = float(max(-g.min(), 0.0))
        else:
            loc = 0.0
        return self.problem.comm.allreduce(loc, op=MPI.MAX)

    def _surface_points(self) -> np.ndarray:
        """Current positions of the dofs on the contact facets (owned + ghost), (N, gdim)."""
        if not hasattr(self, "_surf_dofs"):
            V = self.problem.V
            msh = self.problem.mesh
            fdim = msh.topology.dim - 1
            facets = np.concatenate([self.ds.subdomain_data().find(i) for i in self.ds.subdomain_id()])
            blocks = fem.locate_dofs_topological(V, fdim, facets)   # blocked dofs (node indices)
            self._surf_dofs = blocks
            self._surf_X = V.tabulate_dof_coordinates()[blocks, :self.gdim]
        bs = self.gdim
        u = self.problem.u.x.array.reshape(-1, bs)[self._surf_dofs]
        return self._surf_X + u


def _assemble_global(form, comm) -> float:
    """A scalar form summed over the ranks of ``comm``."""
    return float(comm.allreduce(fem.assemble_scalar(form), op=MPI.SUM))


def contact_cell_size(msh, facet_tags, ids, axis: int | None = None) -> float:
    """Smallest diameter of the cells touching the contact facets (global, m); with ``axis``
    their smallest extent along that coordinate instead."""
    tdim = msh.topology.dim
    msh.topology.create_connectivity(tdim - 1, tdim)
    facets = np.concatenate([facet_tags.find(i) for i in ids]).astype(np.int32)
    cells = compat.incident_entities(msh, facets, tdim - 1, tdim)
    sizes = compat.cell_diameters(msh, cells) if axis is None else compat.cell_extents(msh, cells, axis)
    loc = float(sizes.min()) if cells.size else np.inf
    h = msh.comm.allreduce(loc, op=MPI.MIN)
    if not np.isfinite(h):
        raise ValueError(f"no facets with tags {ids}: cannot place the contact surface")
    return h
