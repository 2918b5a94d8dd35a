"""Steady rolling in the load's frame (the stationary method): a Hertz line pressure or a rigid
cylinder (penalty contact, optionally Coulomb friction) moving over an elastoplastic soil in plane
strain, or a rigid cylindrical wheel (as well) over a 3D half window, solved directly for the
state that travels with the load.

The load is fixed at x = 0 on the surface (y = 0 in plane strain, z = 0 in 3D, where y runs
across the travel from the symmetry plane y = 0) and the soil flows through a window in -x: it
enters undisturbed at the front face x = x_in (``u = 0`` there, optionally with a geostatic
stress) and leaves at the rear face x = x_out < x_in.  With small strain the streamlines are the
lines of constant transverse coordinates (y; y and z); on a structured mesh of quadrilaterals or
hexahedra aligned with x and a tensor Gauss rule, the quadrature points of equal transverse
coordinates form them.  The stress is not a history variable of a time step but
the result of marching the return map along each streamline from the inflow (a *sweep*)::

    state_0 = inflow state,   state_i = return_map(state_{i-1}, eps_i - eps_{i-1}),   eps_{-1} = 0

(the soil ahead is the strain's reference), vectorised over the streamlines.  Equilibrium
``R(u) = int sigma(u) : eps(v) - int t_out . v - loads = 0`` is solved by Newton-Krylov: GMRES,
right-preconditioned by the LU of the return map's local tangent (plus the contact's stiffness,
factored at each Newton iteration), on the exact Jacobian action computed by the tangent-linear
sweep::

    d sigma_i = C_i (D^-1 d sigma_{i-1} + d eps_i - d eps_{i-1})

(``C_i`` the consistent tangent of the return map at station i, ``D`` the elasticity: the
return map's derivative with respect to its trial stress is ``C_i D^-1``).  The rear face carries
the traction of the swept stress at the last station of each streamline, ``t_out = sigma n``
(the residual stress behind the load needs it; a fixed or free face would be wrong), in the
residual and in the Jacobian action; and the last column of cells is held invariant in x (its
nodes move with those at its front, ``u = P z``), so the axial strain far behind is that of the
soil around it (zero) rather than free: with the traction alone, a uniform axial stress over the
window's rear is a near-null mode of the equations, which deep windows excite.  In 3D the
symmetry plane y = 0 and the far side face are rollers (``u_y = 0``).  Rate-independent
plasticity needs only increments: the rolling speed drops out.

On several ranks every streamline lies on one rank (:func:`rolling_window_mesh` gives each rank
whole rows of cells along x), so the sweeps stay local; a row of surface nodes on the boundary
between two ranks is swept by both, and each adds the forces on the nodes it owns.
Reference: K. Dang Van, M. H. Maitournam, J. Mech. Phys. Solids 41 (1993) 1691-1710.
"""
from __future__ import annotations

import itertools
import math
import time
from dataclasses import dataclass, field

import numpy as np
import ufl
from dolfinx import fem, mesh as dmesh
from dolfinx.fem import petsc as fpetsc
from mpi4py import MPI
from petsc4py import PETSc

from rollsim import compat
from rollsim.log import get_logger

from .cell_average import CellProjection
from .contact import DEFAULT_PENALTY, Circle, ufl_signed_distance
from .materials import admissible_k0
from .options import DEFAULT_VOLUMETRIC_STRAIN, VOLUMETRIC_STRAINS
from .problem import mandel_strain
from .return_map import elastic_stiffness, relax_return, return_map
from .steady_friction import DEFAULT_TANGENTIAL_RATIO, SurfaceFriction, SurfaceRows

__all__ = ["RollingWindow", "rolling_window_mesh", "NewtonKrylovControl", "StreamlineState",
           "SteadyRollingResult", "HorizontalBalance", "SteadyRolling", "NoSteadyState", "DEFAULT_STEADY_OPTIONS"]

log = get_logger("solver")

#: GMRES right-preconditioned by an LU (right: the Krylov test then measures the true residual,
#: which the Newton iteration's own test uses)
DEFAULT_STEADY_OPTIONS = {
    "ksp_type": "gmres",
    "ksp_pc_side": "right",
    "ksp_gmres_restart": 200,
    "ksp_max_it": 1000,
    "ksp_rtol": 1e-4,
    "pc_type": "lu",
    "pc_factor_mat_solver_type": "mumps",
}

#: the elastic fixed point's matrix is made again after this many iterations (the contact changes)
FIXED_POINT_REFACTOR = 50
#: the elastic fixed point stops when its residual has not fallen by a tenth in this many iterations
FIXED_POINT_PATIENCE = 3000

#: how many times a step on a towed wheel's spin whose solve fails is halved before the sinkage
#: counts as having no free-rolling steady state (each failure costs a whole Newton solve)
SPIN_CUTS = 3

#: Mandel components: plane strain [xx, yy, zz, sqrt2 xy]; 3D [xx, yy, zz, sqrt2 xy, sqrt2 yz, sqrt2 xz]
NCOMP = {2: 4, 3: 6}
_SQ2 = math.sqrt(2.0)
_SQ23 = math.sqrt(2.0 / 3.0)


class NoSteadyState(RuntimeError):
    """The steady solve found no steady state (e.g. the load beyond the soil's plastic limit: the
    load keeps ploughing instead of rolling)."""


def _graded_cells(h: float, length: float, grading: float) -> np.ndarray:
    """Cell sizes covering ``length`` (m) from a cell of about ``h``, each ``grading`` times the
    last (all scaled to fit exactly); empty for ``length <= 0``."""
    if length <= 1e-12 * h:
        return np.zeros(0)
    sizes = [h * grading]
    while sum(sizes) < length:
        sizes.append(sizes[-1] * grading)
    if len(sizes) > 1 and sum(sizes) - length > 0.5 * sizes[-1]:
        sizes.pop()
    return np.asarray(sizes) * length / sum(sizes)


@dataclass(frozen=True)
class RollingWindow:
    """The soil window of a steady rolling solve, in the load's frame (m).

    The load's centre is at x = 0 on the surface; the soil enters at x = ``ahead`` and leaves at
    x = -``behind``; the base (fixed) lies ``depth`` below the surface.  Square cells of side
    ``half_width / cells_per_half_width`` fill the zone ``|x| <= fine_extent * half_width``,
    ``depth <= fine_extent * half_width`` (nodes at x = +-half_width); outside it the cells grow by
    ``grading`` per cell.  ``refinement`` halves every cell that many times (nested meshes for
    convergence studies).

    3D (a half window, symmetric about y = 0): ``across`` is the window's extent across the travel
    from the symmetry plane and ``load_half_width_across`` the load's half width (m; half the
    wheel's width); the fine cells span ``y <= fine_extent * load_half_width_across``.  Both None:
    plane strain.

    ``interfaces``: depths below the surface (m) of the boundaries between soil layers, top first;
    the row of nodes nearest each is moved onto it (before refinement), so that no cell straddles
    two layers."""

    half_width: float
    ahead: float
    behind: float
    depth: float
    cells_per_half_width: int = 4
    fine_extent: float = 1.5
    grading: float = 1.3
    refinement: int = 0
    across: float | None = None
    load_half_width_across: float | None = None
    interfaces: tuple[float, ...] = ()

    def __post_init__(self):
        for name in ("half_width", "ahead", "behind", "depth"):
            val = getattr(self, name)
            if not (isinstance(val, (int, float)) and math.isfinite(val) and val > 0):
                raise ValueError(f"{name} must be a positive finite length (m), got {val!r}")
        if not (isinstance(self.cells_per_half_width, int) and self.cells_per_half_width >= 1):
            raise ValueError(f"cells_per_half_width must be an integer >= 1, got {self.cells_per_half_width!r}")
        if not (isinstance(self.refinement, int) and self.refinement >= 0):
            raise ValueError(f"refinement must be an integer >= 0, got {self.refinement!r}")
        if not (math.isfinite(self.grading) and self.grading >= 1.0):
            raise ValueError(f"grading must be a finite number >= 1, got {self.grading!r}")
        if not self.fine_extent >= 1.0:
            raise ValueError(f"fine_extent must be >= 1 (half-widths), got {self.fine_extent!r}")
        fine = self.fine_length
        if fine > min(self.ahead, self.behind) or fine > self.depth:
            raise ValueError(f"the fine zone ({fine:g} m about the load) must fit in the window "
                             f"(ahead {self.ahead:g}, behind {self.behind:g}, depth {self.depth:g} m)")
        if (self.across is None) != (self.load_half_width_across is None):
            raise ValueError("give both across and load_half_width_across (3D) or neither (plane strain)")
        depths = np.asarray(self.interfaces, dtype=float)
        if depths.ndim != 1 or not (np.all(np.isfinite(depths)) and np.all(depths > 0) and np.all(np.diff(depths) > 0)):
            raise ValueError(f"interfaces must be increasing positive depths (m), got {self.interfaces!r}")
        if depths.size and depths[-1] >= self.depth:
            raise ValueError(f"the layer interface at {depths[-1]:g} m must lie above the window's base "
                             f"({self.depth:g} m deep)")
        if self.across is not None:
            for name in ("across", "load_half_width_across"):
                val = getattr(self, name)
                if not (isinstance(val, (int, float)) and math.isfinite(val) and val > 0):
                    raise ValueError(f"{name} must be a positive finite length (m), got {val!r}")
            if self.fine_across > self.across:
                raise ValueError(f"the fine zone across ({self.fine_across:g} m from y = 0) must fit in the "
                                 f"window (across {self.across:g} m)")

    @property
    def dimension(self) -> int:
        """2 (plane strain) or 3 (half window)."""
        return 2 if self.across is None else 3

    @property
    def fine_across(self) -> float:
        """3D: extent of the fine zone across from the symmetry plane, a whole number of cells (m)."""
        return math.ceil(self.fine_extent * self.load_half_width_across / self.cell_size - 1e-9) * self.cell_size

    @property
    def cell_size(self) -> float:
        """Side of the cells in the fine zone before refinement (m)."""
        return self.half_width / self.cells_per_half_width

    @property
    def fine_cell_size(self) -> float:
        """Side of the cells in the fine zone after ``refinement`` (m)."""
        return self.cell_size / 2 ** self.refinement

    @property
    def fine_length(self) -> float:
        """Extent of the fine zone from the load's centre, a whole number of cells (m)."""
        return math.ceil(self.fine_extent * self.cells_per_half_width - 1e-9) * self.cell_size

    def _refined(self, nodes: np.ndarray) -> np.ndarray:
        for _ in range(self.refinement):
            mid = 0.5 * (nodes[1:] + nodes[:-1])
            nodes = np.insert(nodes, np.arange(1, len(nodes)), mid)
        return nodes

    def x_nodes(self) -> np.ndarray:
        """Node abscissae from the rear face to the front face (m)."""
        h, fine = self.cell_size, self.fine_length
        n_fine = int(round(2 * fine / h))
        core = np.linspace(-fine, fine, n_fine + 1)
        front = fine + np.cumsum(_graded_cells(h, self.ahead - fine, self.grading))
        rear = -fine - np.cumsum(_graded_cells(h, self.behind - fine, self.grading))
        return self._refined(np.concatenate([rear[::-1], core, front]))

    def y_nodes(self) -> np.ndarray:
        """Node heights from the base to the surface (m): y in plane strain, z in 3D."""
        h, fine = self.cell_size, self.fine_length
        n_fine = int(round(fine / h))
        core = np.linspace(-fine, 0.0, n_fine + 1)
        below = -fine - np.cumsum(_graded_cells(h, self.depth - fine, self.grading))
        nodes = np.concatenate([below[::-1], core])
        moved = set()
        for depth in self.interfaces:           # the nearest inner row moved onto each interface
            inner = np.arange(1, len(nodes) - 1)
            k = int(inner[np.abs(nodes[inner] + depth).argmin()]) if inner.size else 0
            if k == 0 or k in moved:
                raise ValueError(f"the layer interfaces {list(self.interfaces)} lie too close together (or to the "
                                 f"surface or base) for cells of {h:g} m: refine the window")
            nodes[k] = -depth
            moved.add(k)
        return self._refined(nodes)

    def across_nodes(self) -> np.ndarray:
        """3D: node abscissae across the travel from the symmetry plane to the side face (m): a
        row of nodes at the load's edge (the wheel's rim is a line of the mesh, never inside a
        cell), equal cells of at most ``cell_size`` on either side of it in the fine zone."""
        if self.across is None:
            raise ValueError("a plane-strain window has no nodes across the travel")
        h, fine, edge = self.cell_size, self.fine_across, self.load_half_width_across
        under = np.linspace(0.0, edge, math.ceil(edge / h - 1e-9) + 1)
        beyond = np.linspace(edge, fine, math.ceil((fine - edge) / h - 1e-9) + 1)[1:]     # none when fine = edge
        side = fine + np.cumsum(_graded_cells(h, self.across - fine, self.grading))
        return self._refined(np.concatenate([under, beyond, side]))


def rolling_window_mesh(comm: MPI.Comm, window: RollingWindow):
    """Structured mesh of ``window``, cells aligned with the axes: quadrilaterals in plane strain,
    hexahedra in 3D.  On several ranks each rank owns whole rows of cells along x, so that every
    streamline lies on one rank: in plane strain a block of layers, in 3D a block of columns across
    the travel (each from the surface to the base); the rows next to them are its ghosts."""
    nodes = [window.x_nodes(), window.y_nodes()] if window.dimension == 2 else \
        [window.x_nodes(), window.across_nodes(), window.y_nodes()]
    counts = [len(n) - 1 for n in nodes]
    rows = int(np.prod(counts[1:]))
    if comm.size > rows:
        raise ValueError(f"the window has {rows} rows of cells along the travel, fewer than the {comm.size} ranks: "
                         "each rank needs whole rows")
    gdim = len(counts)
    if comm.rank == 0:
        grids = np.meshgrid(*nodes, indexing="ij")
        x = np.stack([g.ravel(order="F") for g in grids], axis=1)          # x fastest
        index = np.arange(len(x)).reshape([c + 1 for c in counts], order="F")
        corners = []
        for offset in itertools.product((0, 1), repeat=gdim):       # DOLFINx's tensor-product order
            shift = offset[::-1]                                    # x varies fastest
            corners.append(index[tuple(slice(shift[k], shift[k] + counts[k]) for k in range(gdim))].ravel(order="F"))
        cells = np.stack(corners, axis=1).astype(np.int64)
    else:
        x, cells = np.zeros((0, gdim)), np.zeros((0, 2 ** gdim), dtype=np.int64)
    stride = counts[0] + 1

    across, layers = (counts[1], counts[2]) if gdim == 3 else (1, counts[1])

    def owner(j: np.ndarray, k: np.ndarray) -> np.ndarray:
        """The rank of the row of cells ``j`` across (from y = 0) and ``k`` up (from the base)."""
        return (k + layers * j) * comm.size // rows

    def by_rows(cell_vertices: np.ndarray, parts: int):
        first = cell_vertices.min(axis=1) // stride                 # the cell's row of vertices
        j, k = (first % (counts[1] + 1), first // (counts[1] + 1)) if gdim == 3 else (np.zeros_like(first), first)
        own = owner(j, k)
        near = [owner(np.clip(j + dj, 0, across - 1), np.clip(k + dk, 0, layers - 1))
                for dj in (-1, 0, 1) for dk in (-1, 0, 1)]
        ghosts = [np.setdiff1d(ranks, [o]) for o, ranks in zip(own, np.stack(near, axis=1))]
        return own, ghosts

    return compat.create_partitioned_mesh(comm, cells, x, "quadrilateral" if gdim == 2 else "hexahedron", by_rows)


@dataclass(frozen=True)
class NewtonKrylovControl:
    """Global iteration of a steady solve: Newton converged when the residual's norm is below
    ``rtol`` times the load vector's; at most ``max_iterations`` Newton steps; each step
    backtracked (halved) down to ``min_step`` until the residual's norm decreases.  The
    preconditioner is factored at the first Newton step of a solve and again after a step whose
    GMRES needed more than ``refactor_iterations`` iterations (0: at every step).  GMRES stops
    at the relative tolerance of the options (``ksp_rtol``) or, with ``forcing`` > 0, at the
    Eisenstat-Walker forcing term (choice 2: 0.9 times the square of the residual's last
    reduction, kept between ``ksp_rtol`` and ``forcing``; the first step ``forcing``).  Where
    Newton fails, ``fixed_point_iterations`` > 0 continues from its last iterate by the elastic
    fixed point (:meth:`SteadyRolling._fixed_point`) for at most that many iterations, trying
    Newton again from its iterate after ``newton_retry`` of them (then after twice as many more
    each time Newton fails; 0: never)."""

    rtol: float = 1e-8
    max_iterations: int = 30
    min_step: float = 1.0 / 64
    refactor_iterations: int = 30
    forcing: float = 0.1
    fixed_point_iterations: int = 0
    newton_retry: int = 100

    def __post_init__(self):
        if not 0 < self.rtol < 1:
            raise ValueError(f"rtol must lie in (0, 1), got {self.rtol!r}")
        if not (isinstance(self.max_iterations, int) and self.max_iterations >= 1):
            raise ValueError(f"max_iterations must be an integer >= 1, got {self.max_iterations!r}")
        if not 0 < self.min_step <= 1:
            raise ValueError(f"min_step must lie in (0, 1], got {self.min_step!r}")
        if not (isinstance(self.refactor_iterations, int) and self.refactor_iterations >= 0):
            raise ValueError(f"refactor_iterations must be an integer >= 0, got {self.refactor_iterations!r}")
        if not 0 <= self.forcing < 1:
            raise ValueError(f"forcing must lie in [0, 1), got {self.forcing!r}")
        if not (isinstance(self.fixed_point_iterations, int) and self.fixed_point_iterations >= 0):
            raise ValueError(f"fixed_point_iterations must be an integer >= 0, got {self.fixed_point_iterations!r}")
        if not (isinstance(self.newton_retry, int) and self.newton_retry >= 0):
            raise ValueError(f"newton_retry must be an integer >= 0, got {self.newton_retry!r}")


@dataclass(frozen=True)
class StreamlineState:
    """The material state at one station of every streamline (rows ordered as
    :attr:`SteadyRolling.streamline_depths`): stress and plastic strain (Mandel vectors, Pa and
    -), accumulated plastic strain ``sum sqrt(2/3) |d eps_p|`` (-)."""

    stress: np.ndarray
    plastic_strain: np.ndarray
    accumulated_plastic_strain: np.ndarray

    def __post_init__(self):
        rows = self.accumulated_plastic_strain.shape
        if (len(rows) != 1 or self.stress.shape[:1] != rows or self.stress.ndim != 2
                or self.stress.shape[1] not in NCOMP.values() or self.plastic_strain.shape != self.stress.shape):
            raise ValueError("a streamline state needs (rows, 4 or 6) stresses and plastic strains and (rows,) "
                             f"accumulated plastic strains, got {self.stress.shape}, {self.plastic_strain.shape}, "
                             f"{self.accumulated_plastic_strain.shape}")


@dataclass
class SteadyRollingResult:
    """A converged steady state under the Hertz pressure of peak ``peak_pressure`` (Pa), or under
    the rigid cylinder at ``sinkage`` (m) carrying ``vertical_force`` (N/m, upward on the wheel)
    and towed by ``towing_force`` (N/m, positive against the travel)."""

    peak_pressure: float | None
    newton_iterations: int
    krylov_iterations: int
    sweeps: int                           # residual and tangent-linear sweeps
    wall_time: float                      # s
    outflow: StreamlineState              # the state leaving the window (the next pass's inflow)
    max_accumulated_plastic_strain: float  # over the window
    residual_norms: list[float] = field(default_factory=list)   # relative to the load vector's norm
    sinkage: float | None = None
    vertical_force: float | None = None
    towing_force: float | None = None     # N/m, Q_H: the horizontal force on the axle that keeps the wheel rolling
    spin: float | None = None             # the wheel's xi = omega R / V (-)
    axle_torque: float | None = None      # N m/m, the contact's moment on the wheel about the axle (counter-clockwise)
    fixed_point_iterations: int = 0       # after Newton failed (NewtonKrylovControl.fixed_point_iterations)


@dataclass(frozen=True)
class HorizontalBalance:
    """The horizontal forces on the soil window's faces (N/m): the axial resultants
    ``int sigma_xx dy`` over the outflow and the inflow faces and the base's shear
    ``int sigma_xy dx``.  Their balance gives the towing force :attr:`towing_force`."""

    outflow_axial: float
    inflow_axial: float
    base_shear: float

    def __post_init__(self):
        for name in ("outflow_axial", "inflow_axial", "base_shear"):
            if not math.isfinite(getattr(self, name)):
                raise ValueError(f"{name} must be a finite force (N/m), got {getattr(self, name)!r}")

    @property
    def towing_force(self) -> float:
        """``Q_H = int_out sigma_xx - int_in sigma_xx + int_base sigma_xy`` (N/m): the window's
        horizontal equilibrium (outward normals -e_x, +e_x and -e_y; no horizontal body force)."""
        return self.outflow_axial - self.inflow_axial + self.base_shear


def _check_arguments(mesh, half_width, wheel, penalty, friction, tangential_ratio, preconditioner, unit_weight,
                     volumetric_strain, layers: int, interfaces: np.ndarray) -> None:
    """The arguments of :class:`SteadyRolling` that it refuses, with the reason."""
    gdim = mesh.geometry.dim
    cells = {2: "quadrilateral", 3: "hexahedron"}.get(gdim)
    if compat.cell_name(mesh) != cells:
        raise ValueError(f"steady rolling needs a structured mesh of {cells or 'quadrilateral or hexahedron'} "
                         f"cells, got {compat.cell_name(mesh)} cells")
    if (half_width is None) == (wheel is None):
        raise ValueError("give exactly one load: the Hertz pressure's half_width or a rigid wheel")
    if half_width is not None and gdim == 3:
        raise ValueError("the Hertz line pressure is plane strain: roll a wheel over a 3D window")
    if half_width is not None and not (math.isfinite(half_width) and half_width > 0):
        raise ValueError(f"half_width must be a positive length (m), got {half_width!r}")
    from rollsim.geometry import CylinderWheel
    wheel_type = Circle if gdim == 2 else CylinderWheel
    if wheel is not None and not isinstance(wheel, wheel_type):
        raise TypeError(f"wheel must be a {wheel_type.__name__} in {gdim}D, got {type(wheel).__name__}")
    if not (math.isfinite(penalty) and penalty > 0):
        raise ValueError(f"penalty must be a positive factor, got {penalty!r}")
    if not (math.isfinite(friction) and friction >= 0):
        raise ValueError(f"friction must be a Coulomb coefficient >= 0, got {friction!r}")
    if friction and wheel is None:
        raise ValueError("friction needs a rigid wheel (the Hertz pressure is frictionless)")
    if not (math.isfinite(tangential_ratio) and tangential_ratio > 0):
        raise ValueError(f"tangential_ratio must be > 0, got {tangential_ratio!r}")
    if preconditioner not in ("tangent", "elastic"):
        raise ValueError(f"preconditioner must be 'tangent' or 'elastic', got {preconditioner!r}")
    if not (math.isfinite(unit_weight) and unit_weight >= 0):
        raise ValueError(f"unit_weight must be >= 0 (N/m^3), got {unit_weight!r}")
    if volumetric_strain not in VOLUMETRIC_STRAINS:
        raise ValueError(f"volumetric_strain must be one of {', '.join(VOLUMETRIC_STRAINS)}, got {volumetric_strain!r}")
    if len(interfaces) != layers - 1 or np.any(np.diff(interfaces) <= 0) or np.any(interfaces <= 0):
        raise ValueError(f"{layers} layer(s) need {layers - 1} increasing positive interface depth(s) (m), "
                         f"got {list(interfaces)}")


class SteadyRolling:
    """Steady rolling of a Hertz line pressure ``p(x) = p0 sqrt(1 - (x/half_width)^2)`` (Pa, m), or
    of a rigid cylinder ``wheel`` whose axle is held above x = 0 (:meth:`solve_sinkage`,
    :meth:`solve_free_rolling`, :meth:`solve_load`), over the soil of ``mesh`` (from
    :func:`rolling_window_mesh`: structured, aligned with x), in the load's frame (module
    docstring).  Give exactly one of ``half_width`` and ``wheel``.

    Plane strain (a quadrilateral mesh): ``wheel`` is a :class:`~rollsim.solver.contact.Circle`,
    forces are per unit length (N/m).  3D (a hexahedral half window, y >= 0): ``wheel`` is a
    ``CylinderWheel`` (axle along y, centred on y = 0), no Hertz pressure; forces are the whole
    wheel's (N: twice the half window's).  ``friction``: the Coulomb coefficient, with the stick
    stiffness ``tangential_ratio`` times the normal penalty (:mod:`rollsim.solver.steady_friction`).

    The cylinder presses on the surface through the penalty law of
    :class:`~rollsim.solver.contact.RigidWheelContact`: ``p_N = kappa <-g>_+`` on the gap ``g``
    of the surface point at ``x + u``, ``kappa = penalty E / h`` (``h`` the smallest cell size at
    the surface); the law has no history, so its term and its derivative are local.

    ``material``: ``VonMises`` or ``DruckerPrager`` (or a material with its own return map); for
    horizontally layered soil, a sequence of them from the surface down, with ``interfaces`` the
    depths (m) of the boundaries between them (the mesh's rows of nodes must lie on them:
    :class:`RollingWindow`'s ``interfaces``): a streamline lies in one layer, whose return map it
    marches.  The penalty's ``E`` is the top layer's.  ``unit_weight`` (N/m^3) > 0 adds gravity and
    the geostatic stress ``sigma_v = -gamma depth``, ``sigma_h = K0 sigma_v`` (K0 as
    :meth:`PlasticityProblem.set_geostatic_stress`) as the inflow state.  ``degree``: displacement
    (Lagrange); ``quadrature_degree``: of the tensor Gauss rule (default ``2 * degree``: full
    integration).  ``petsc_options`` override :data:`DEFAULT_STEADY_OPTIONS` under
    ``options_prefix``; ``preconditioner``: ``"tangent"`` (the LU of the local consistent tangent,
    refactored at each Newton iteration) or ``"elastic"`` (of the elastic stiffness).
    ``volumetric_strain``: ``"cell-average"`` (B-bar, as :class:`PlasticityProblem`'s: the trace
    of every strain and of the stress's change from the inflow state projected per cell onto the
    linear functions, Q2-P1, :mod:`rollsim.solver.cell_average`) or ``"pointwise"``.
    """

    def __init__(self, mesh, material, half_width: float | None = None, *, wheel: Circle | None = None,
                 penalty: float = DEFAULT_PENALTY, friction: float = 0.0,
                 tangential_ratio: float = DEFAULT_TANGENTIAL_RATIO, degree: int = 2,
                 quadrature_degree: int | None = None, unit_weight: float = 0.0, K0: float | None = None,
                 control: NewtonKrylovControl | None = None, petsc_options: dict | None = None,
                 options_prefix: str = "rollsim_steady_", preconditioner: str = "tangent",
                 volumetric_strain: str = DEFAULT_VOLUMETRIC_STRAIN, interfaces=(),
                 relaxation_length: float = 0.0):
        #: the soil's layers from the surface down and the depths of their boundaries (m)
        self.materials = tuple(material) if isinstance(material, (list, tuple)) else (material,)
        self.interfaces = np.asarray(interfaces, dtype=float).reshape(-1)
        _check_arguments(mesh, half_width, wheel, penalty, friction, tangential_ratio, preconditioner, unit_weight,
                         volumetric_strain, len(self.materials), self.interfaces)
        self.volumetric_strain = volumetric_strain
        self.comm = mesh.comm
        self.mesh, self.material, self.wheel = mesh, self.materials[0], wheel
        gdim = mesh.geometry.dim
        self.gdim, self.ncomp = gdim, NCOMP[gdim]
        self._up = gdim - 1                        # the vertical axis
        #: the whole wheel's share of the modelled soil's forces (3D: a half window)
        self.symmetry = 1.0 if gdim == 2 else 2.0
        self.friction = float(friction)
        #: the friction's stick stiffness over the normal penalty (:mod:`rollsim.solver.steady_friction`)
        self.tangential_ratio = float(tangential_ratio)
        self._predict_spin = False          # the predictor moves the spin too (a free-rolling solve's first)
        self.half_width = None if half_width is None else float(half_width)
        self.control = control or NewtonKrylovControl()
        self.qdeg = 2 * degree if quadrature_degree is None else quadrature_degree
        #: the layers' elasticity
        self._D_layers = np.array([elastic_stiffness(m, self.ncomp) for m in self.materials])
        x, comm = mesh.geometry.x, self.comm
        #: the abscissae of the window's columns of vertices (m, all ranks'), from the rear face
        self._columns = np.unique(np.concatenate(comm.allgather(np.unique(np.round(x[:, 0], 12)))))
        self.x_in, self.x_out = float(self._columns[-1]), float(self._columns[0])
        self.surface = comm.allreduce(float(x[:, self._up].max()), MPI.MAX)
        self.base = comm.allreduce(float(x[:, self._up].min()), MPI.MIN)
        self._init_spaces(degree)
        #: Duvaut-Lions relaxation length (m of travel; 0: rate-independent)
        self.relaxation_length = float(relaxation_length)
        self.restart()
        ds = self._init_boundary()
        K = self._init_forms(ds, degree, penalty, unit_weight)
        self._init_preconditioner(K, preconditioner)
        #: the friction along the surface nodes' rows (a wheel with a friction coefficient)
        self._friction = self._surface_friction() if wheel is not None and self.friction > 0 else None
        self.inflow = self._geostatic_state(unit_weight, K0)
        self.petsc_options = {**DEFAULT_STEADY_OPTIONS, **(petsc_options or {})}
        self.options_prefix = options_prefix
        self._ksp = self._krylov_solver()
        self._krylov_rtol = self._ksp.getTolerances()[0]
        self._fields: tuple | None = None
        self._counts = {"sweeps": 0, "krylov": 0}

    # ------------------------------------------------------------------ set-up
    def _init_spaces(self, degree: int) -> None:
        """The displacement, the quadrature points and their streamlines, the stress and the rear
        face's traction."""
        mesh = self.mesh
        self.V = compat.vector_space(mesh, degree)
        self.u = fem.Function(self.V, name="displacement")
        self._du = fem.Function(self.V)
        #: the rank's owned nodes of the displacement (the first of its local nodes; ghosts follow)
        self._owned_nodes = self.V.dofmap.index_map.size_local
        #: the global number of this rank's first dof (PETSc's numbering)
        self._dof_offset = self.V.dofmap.index_map.local_range[0] * self.V.dofmap.index_map_bs
        self.n_cells = mesh.topology.index_map(mesh.topology.dim).size_local
        points = compat.quadrature_points(mesh, self.qdeg)
        self._n_points = points.shape[0]
        self.n_qp = self.n_cells * self._n_points
        coords = compat.evaluate(compat.expression(ufl.SpatialCoordinate(mesh), points), mesh)
        #: coordinates of the quadrature points (m), in the quadrature spaces' order
        self.quadrature_coordinates = coords.reshape(self.n_qp, self.gdim)
        self._order, self.streamline_depths = self._streamlines()
        x_stations = self.quadrature_coordinates[self._order[0], 0] if self._order.size else np.empty(0)
        #: the travel (m) from the station before (the inflow face for the first) to each station
        self._station_travel = -np.diff(x_stations, prepend=self.x_in)
        #: the shortest travel between two stations of a streamline (m, all ranks')
        self.station_spacing = self.comm.allreduce(float(self._station_travel.min(initial=np.inf)), MPI.MIN)
        self._init_layers()
        self._strain_expr = compat.expression(mandel_strain(self.u, self.gdim), points)
        self._dstrain_expr = compat.expression(mandel_strain(self._du, self.gdim), points)
        Qs = compat.quadrature_space(mesh, self.qdeg, (self.ncomp,))
        self._sigma, self._dsigma = fem.Function(Qs, name="stress"), fem.Function(Qs)
        self._traction_space = compat.vector_space(mesh, degree, "DQ")
        self._traction, self._dtraction = fem.Function(self._traction_space), fem.Function(self._traction_space)
        self._outflow_map()

    def _init_layers(self) -> None:
        """Each streamline's layer (:attr:`_row_layer`), the material, rows and elasticity of each
        layer's return map (:attr:`_groups`), the inverse elasticity per row; refuses interfaces
        that cells straddle."""
        heights = np.unique(np.concatenate(self.comm.allgather(np.unique(np.round(self.mesh.geometry.x[:, self._up],
                                                                                  12)))))
        for depth in self.interfaces:
            if np.abs(heights - (self.surface - depth)).min() > 1e-9 * (self.surface - self.base):
                raise ValueError(f"no row of nodes lies on the layer interface {depth:g} m deep: the cells would "
                                 "straddle two layers (RollingWindow's interfaces)")
        #: the layer (index into :attr:`materials`) of each streamline
        self._row_layer = np.searchsorted(self.interfaces, self.streamline_depths)
        self._groups = [(m, np.flatnonzero(self._row_layer == k), self._D_layers[k])
                        for k, m in enumerate(self.materials)]
        self._groups = [group for group in self._groups if group[1].size]
        if len(self._groups) == 1:              # one material on every streamline: no gathering
            self._groups = [(self._groups[0][0], slice(None), self._groups[0][2])]
        self._D_inv = np.linalg.inv(self._D_layers)[self._row_layer]          # (rows, ncomp, ncomp)
        #: the elasticity in UFL (the elastic stiffness and the elastic preconditioner)
        self._elastic_ufl = self._elasticity()

    def _elasticity(self):
        """The elasticity as a UFL matrix: constant, or per cell from its layer's (layered soil)."""
        if len(self.materials) == 1:
            return ufl.as_matrix(self._D_layers[0].tolist())
        DG0 = compat.scalar_space(self.mesh, 0, "DG")
        depth = self.surface - DG0.tabulate_dof_coordinates()[:, self._up]
        layer = np.searchsorted(self.interfaces, depth)
        D = 0
        for k, Dk in enumerate(self._D_layers):
            chi = fem.Function(DG0)
            chi.x.array[:] = layer == k
            D = D + chi * ufl.as_matrix(Dk.tolist())
        return D

    def _init_boundary(self) -> ufl.Measure:
        """The fixed inflow face and base, the rollers in 3D (:attr:`bcs`, :attr:`_fixed`); the
        surface (tag 1) and rear face (tag 2) measure."""
        mesh, gdim, up = self.mesh, self.gdim, self._up
        fdim = mesh.topology.dim - 1
        tol = 1e-9 * (self.x_in - self.x_out)
        front = dmesh.locate_entities_boundary(mesh, fdim, lambda p: np.abs(p[0] - self.x_in) < tol)
        base = dmesh.locate_entities_boundary(mesh, fdim, lambda p: np.abs(p[up] - self.base) < tol)
        top = dmesh.locate_entities_boundary(mesh, fdim, lambda p: np.abs(p[up] - self.surface) < tol)
        rear = dmesh.locate_entities_boundary(mesh, fdim, lambda p: np.abs(p[0] - self.x_out) < tol)
        fixed = fem.locate_dofs_topological(self.V, fdim, np.unique(np.concatenate([front, base])))
        #: nodes of the inflow face, and of the base but not the inflow face (their reactions)
        self._inflow_nodes = fem.locate_dofs_topological(self.V, fdim, front)
        self._base_nodes = np.setdiff1d(fem.locate_dofs_topological(self.V, fdim, base), self._inflow_nodes)
        self._fixed_nodes = fixed
        self.bcs = [fem.dirichletbc(np.zeros(gdim, dtype=PETSc.ScalarType), fixed, self.V)]
        bs = self.V.dofmap.index_map_bs
        self._fixed = (fixed[:, None] * bs + np.arange(bs)).reshape(-1)     # unrolled dof indices
        if gdim == 3:                # rollers: the symmetry plane y = 0 and the side face
            y_side = self.comm.allreduce(float(mesh.geometry.x[:, 1].max()), MPI.MAX)
            sides = dmesh.locate_entities_boundary(
                mesh, fdim, lambda p: (np.abs(p[1]) < tol) | (np.abs(p[1] - y_side) < tol))
            lateral = fem.locate_dofs_topological(self.V.sub(1), fdim, sides)
            if not np.all(lateral % bs == 1):
                raise RuntimeError("the lateral faces' dofs of u_y are not in the unrolled numbering expected")
            self.bcs.append(fem.dirichletbc(PETSc.ScalarType(0.0), lateral, self.V.sub(1)))
            self._fixed = np.union1d(self._fixed, lateral)
        owned = self._fixed[self._fixed < self._owned_nodes * bs]
        #: the fixed dofs owned here, numbered globally (PETSc's rows)
        self._fixed_global = (owned + self._dof_offset).astype(PETSc.IntType)
        facets = np.concatenate([top, rear])
        tags = np.concatenate([np.full(len(top), 1, np.int32), np.full(len(rear), 2, np.int32)])
        order = np.argsort(facets)
        return ufl.Measure("ds", domain=mesh, subdomain_data=dmesh.meshtags(mesh, fdim, facets[order], tags[order]))

    def _init_forms(self, ds: ufl.Measure, degree: int, penalty: float, unit_weight: float) -> PETSc.Mat:
        """The residual, its Jacobian action and the load (a Hertz pressure or the wheel's contact,
        gravity); returns the elastic stiffness matrix."""
        mesh, gdim, up, wheel = self.mesh, self.gdim, self._up, self.wheel
        dx = ufl.Measure("dx", domain=mesh, metadata={"quadrature_degree": self.qdeg, "quadrature_scheme": "default"})
        v, w = ufl.TestFunction(self.V), ufl.TrialFunction(self.V)
        X = ufl.SpatialCoordinate(mesh)
        self._eps_v, self._eps_w, self._dx = mandel_strain(v, gdim), mandel_strain(w, gdim), dx
        # the pressure's square-root ends and the contact's edge need more points than the displacement's degree
        ds_top = ds(1, metadata={"quadrature_degree": 4 * degree + 4})
        self._contact_stiffness = None
        if wheel is None:
            self.peak = fem.Constant(mesh, PETSc.ScalarType(0.0))
            pressure = self.peak * ufl.sqrt(ufl.max_value(1.0 - (X[0] / self.half_width) ** 2, 0.0))
            load = pressure * v[up] * ds_top
        else:
            self.axle_height = fem.Constant(mesh, PETSc.ScalarType(self.surface + wheel.diameter / 2))
            h = float(np.diff(self._columns).min())
            self.kappa = penalty * self.material.E / h
            axle = ufl.as_vector([0.0] * up + [self.axle_height])
            gap, normal = ufl_signed_distance(wheel, X + self.u - axle)
            traction = self.kappa * ufl.max_value(-gap, 0.0) * normal          # on the soil
            load = -ufl.inner(traction, v) * ds_top
            self._vertical_force = fem.form(-traction[up] * ds_top)
            self._towing_force = fem.form(traction[0] * ds_top)
            self._contact_stiffness = fem.form(ufl.derivative(load, self.u, w))
        if unit_weight:
            load += unit_weight * v[up] * dx
        # the rear face's Gauss points lie on the streamlines: the traction's trace there is exact
        ds_rear = ds(2, metadata={"quadrature_degree": self.qdeg})
        self._outflow_force = fem.form(self._traction[0] * ds_rear)
        eps_v = self._eps_v
        self._F = fem.form(ufl.inner(self._sigma, eps_v) * dx - ufl.inner(self._traction, v) * ds_rear + load)
        self._Jv = fem.form(ufl.inner(self._dsigma, eps_v) * dx - ufl.inner(self._dtraction, v) * ds_rear)
        self._load = fem.form(load)
        Dm = self._elastic_ufl
        self._elastic_form = fem.form(ufl.inner(ufl.dot(Dm, self._eps_w), eps_v) * dx)
        K = fpetsc.assemble_matrix(self._elastic_form, bcs=self.bcs)
        K.assemble()
        self._b = compat.create_vector(self._F)
        self._full = self._b.duplicate()
        return K

    def _init_preconditioner(self, K: PETSc.Mat, preconditioner: str) -> None:
        """The rear tie, the elastic stiffness ``K`` reduced by it, and the matrices that the
        preconditioner is refilled into (:meth:`_update_preconditioner`)."""
        self._tie = self._rear_tie()
        self.preconditioner = preconditioner
        self._tangent_form = None
        nc = self.ncomp
        Ct = self._elastic_ufl
        if preconditioner == "tangent":
            self._tangent_fn = fem.Function(compat.quadrature_space(self.mesh, self.qdeg, (nc * nc,)))
            Ct = ufl.as_matrix([[self._tangent_fn[i * nc + j] for j in range(nc)] for i in range(nc)])
        #: B-bar's projection of the volumetric strain per cell (None: pointwise)
        self._projection = None
        eps_w, eps_v = self._eps_w, self._eps_v
        if self.volumetric_strain == "cell-average":
            strain = lambda w: mandel_strain(w, self.gdim)                    # noqa: E731
            self._projection = CellProjection(self.mesh, self.V, strain, Ct, 1.0, self._dx,
                                              compat.quadrature_rule(self.mesh, self.qdeg), self.n_cells,
                                              degree=1, fixed_configuration=True)
            e = self._projection.deviatoric(strain)
            eps_w, eps_v = e(ufl.TrialFunction(self.V)), e(ufl.TestFunction(self.V))
        if preconditioner == "tangent":      # pointwise part; B-bar's couplings within the cells are added
            self._tangent_form = fem.form(ufl.inner(ufl.dot(Ct, eps_w), eps_v) * self._dx)
        #: the preconditioner factored once (the elastic stiffness under a Hertz pressure), else
        #: refilled at each Newton iteration into :attr:`_preconditioner_full`'s pattern
        self._elastic_matrix = self._elastic_full = self._preconditioner_full = None
        if self.wheel is None and self._tangent_form is None:
            self._elastic_matrix = self._reduced_matrix(K)[0]
            K.destroy()
        elif self._tangent_form is None:        # under a wheel, the contact's stiffness is added to it
            self._elastic_full, self._preconditioner_full = K, K.duplicate(copy=True)
        else:
            self._preconditioner_full = K
        self._contact_matrix: PETSc.Mat | None = None
        self._preconditioner_matrix: tuple[PETSc.Mat, PETSc.Mat] | None = None   # (reduced, product)

    def _streamlines(self) -> tuple[np.ndarray, np.ndarray]:
        """Quadrature points as (rows, stations): rows of equal transverse coordinates from the
        surface down (then across from y = 0 in 3D), each from the inflow (largest x) to the
        outflow; and the rows' depths below the surface (m)."""
        coords = self.quadrature_coordinates
        xq, height = coords[:, 0], coords[:, self._up]
        tol = 1e-9 * (self.surface - self.base)
        levels = [_levels(-height, tol)] + [_levels(coords[:, k], tol) for k in range(1, self._up)]
        key = np.ravel_multi_index(levels, [lv.max() + 1 for lv in levels])
        order = np.argsort(key, kind="stable")
        rows = np.split(order, np.flatnonzero(np.diff(key[order])) + 1)
        if self.comm.allreduce(len({len(r) for r in rows}) != 1, MPI.LOR):
            raise ValueError("the quadrature points do not form streamlines of equal length: the mesh must be "
                             "a structured grid of cells aligned with x (rolling_window_mesh)")
        table = np.array([r[np.argsort(-xq[r], kind="stable")] for r in rows]).reshape(len(rows), -1)
        stations = (len(self._columns) - 1) * round(self._n_points ** (1.0 / self.gdim))
        if self.comm.allreduce(table.shape[1] != stations, MPI.LOR):
            raise ValueError(f"the streamlines are cut between ranks (the window has {stations} stations along "
                             "each): each rank must own whole rows of cells along x (rolling_window_mesh's "
                             "partition)")
        return table, self.surface - height[table[:, 0]]

    def _outflow_map(self) -> None:
        """Where the rear face's traction goes: for each cell on the rear face, its traction dofs
        on the face and the streamlines whose last station lies in it (three Gauss rows in plane
        strain, three by three in 3D), with the quadratic Lagrange weights (tensor products in 3D)
        from those stations' transverse coordinates to the dofs'."""
        last = self._order[:, -1]
        cell_of_row = last // self._n_points
        dof_x = self._traction_space.tabulate_dof_coordinates()
        dofs = compat.cell_dofs(self._traction_space.dofmap)
        tol = 1e-9 * (self.x_in - self.x_out)
        cells = np.unique(cell_of_row)
        face_dofs, face_rows, weights = [], [], []
        transverse = range(1, self.gdim)
        n_face = 3 ** (self.gdim - 1)
        for c in cells:
            rows = np.flatnonzero(cell_of_row == c)
            on_face = dofs[c][np.abs(dof_x[dofs[c], 0] - self.x_out) < tol]
            if len(rows) != n_face or len(on_face) != n_face:
                raise ValueError(f"the rear face's traction needs quadratic Lagrange cells with {n_face} Gauss rows "
                                 f"(cell {c}: {len(rows)} rows, {len(on_face)} face dofs)")
            L = np.ones((n_face, n_face))
            for k in transverse:
                at = self.quadrature_coordinates[last[rows], k]
                points = np.unique(np.round(at, 12))
                if len(points) != 3:
                    raise ValueError(f"the rear face's cell {c} has {len(points)} Gauss abscissae along axis {k}, not 3")
                which = np.abs(at[:, None] - points[None, :]).argmin(axis=1)
                yn = dof_x[on_face, k]
                for g in range(n_face):
                    for m in range(3):
                        if m != which[g]:
                            L[:, g] *= (yn - points[m]) / (points[which[g]] - points[m])
            face_dofs.append(on_face)
            face_rows.append(rows)
            weights.append(L)
        self._face_dofs, self._face_rows, self._face_weights = map(np.array, (face_dofs, face_rows, weights))

    def _rear_tie(self) -> PETSc.Mat:
        """``P`` with ``u = P z``: the displacement of the last column of cells is that of its front
        nodes, the same at every x (the state no longer changes there); identity elsewhere.
        :attr:`_slaves`: the (owned) dofs so tied."""
        X = self.V.tabulate_dof_coordinates()
        index_map, bs = self.V.dofmap.index_map, self.V.dofmap.index_map_bs
        n_nodes = self._owned_nodes
        x_tie = self._columns[1]
        tol = 1e-9 * (self.x_in - self.x_out)
        rear = np.setdiff1d(np.flatnonzero(X[:n_nodes, 0] < x_tie - tol), self._fixed_nodes)
        front = np.flatnonzero(np.abs(X[:, 0] - x_tie) < tol)      # owned or ghost: the rows are whole
        # the front node at the same transverse coordinates as each rear node
        levels = [_levels(X[np.concatenate([front, rear]), k], tol) for k in range(1, self.gdim)]
        key = np.ravel_multi_index(levels, [lv.max() + 1 for lv in levels]) if len(front) else np.zeros(0, int)
        front_key, rear_key = key[:len(front)], key[len(front):]
        by_key = np.argsort(front_key)
        at = np.minimum(np.searchsorted(front_key[by_key], rear_key), len(front) - 1)
        master = front[by_key[at]]
        if not np.array_equal(front_key[by_key[at]], rear_key):
            raise ValueError("the last column of cells has no front node at the transverse coordinates of "
                             "every rear node")
        n = n_nodes * bs
        size = ((n, PETSc.DECIDE), (n, PETSc.DECIDE))
        global_nodes = index_map.local_to_global(np.arange(len(X), dtype=np.int32))
        own = (np.arange(n) + self._dof_offset).astype(PETSc.IntType)
        cols = own.copy()
        slaves = (rear[:, None] * bs + np.arange(bs)).reshape(-1)
        cols[slaves] = (global_nodes[master][:, None] * bs + np.arange(bs)).reshape(-1)
        rows = np.arange(n + 1, dtype=PETSc.IntType)
        P = PETSc.Mat().createAIJWithArrays(size, (rows, cols, np.ones(n)), comm=self.comm)
        self._slaves = slaves
        diagonal = np.zeros(n)
        diagonal[slaves] = 1.0
        self._tied_ones = PETSc.Mat().createAIJWithArrays(size, (rows, own, diagonal), comm=self.comm)
        return P

    def _reduced_matrix(self, K: PETSc.Mat, out: tuple[PETSc.Mat, PETSc.Mat] | None = None
                        ) -> tuple[PETSc.Mat, PETSc.Mat]:
        """``P^T K P`` with ones on the tied dofs' diagonal, and the product ``P^T K P`` it came
        from; ``out`` (an earlier result for a matrix of ``K``'s pattern) is refilled in place."""
        if out is not None:
            reduced, product = out
            K.PtAP(self._tie, result=product)
            reduced.zeroEntries()
            reduced.axpy(1.0, product, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
            reduced.axpy(1.0, self._tied_ones, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
            return reduced, product
        product = K.PtAP(self._tie)
        reduced = product.duplicate(copy=True)
        reduced.axpy(1.0, self._tied_ones, structure=PETSc.Mat.Structure.DIFFERENT_NONZERO_PATTERN)
        return reduced, product

    def _surface_friction(self) -> SurfaceFriction:
        """The friction on the surface nodes' rows that this rank holds (whole rows: its own
        nodes' and its ghosts'); :attr:`_surface_free`: which of their dofs ((rows, stations, gdim))
        are not fixed and are owned here (each rank adds the forces on its own nodes)."""
        X = self.V.tabulate_dof_coordinates()[:, : self.gdim]
        tol = 1e-9 * (self.x_in - self.x_out)
        on_top = np.abs(X[:, -1] - self.surface) < tol
        across = np.unique(np.concatenate(self.comm.allgather(np.unique(np.round(X[on_top, 1], 12))))) \
            if self.gdim == 3 else None
        rows = SurfaceRows.of(X, self.surface, tol, across)
        dofs = rows.nodes[..., None] * self.V.dofmap.index_map_bs + np.arange(self.gdim)
        #: which of the rows' nodes this rank owns
        self._surface_owned = rows.nodes < self._owned_nodes
        self._surface_free = ~np.isin(dofs, self._fixed) & self._surface_owned[..., None]
        return SurfaceFriction(rows, self.wheel, self.friction, self.kappa, self.tangential_ratio)

    def _owned(self, forces: np.ndarray) -> np.ndarray:
        """The friction's nodal ``forces`` ((rows, stations, gdim)) on this rank's own nodes (zero on
        its ghosts: their owners count them)."""
        return np.where(self._surface_owned[..., None], forces, 0.0)

    def _friction_torque(self, forces: np.ndarray, dU: np.ndarray | None = None,
                         dforces: np.ndarray | None = None) -> float:
        """:meth:`SurfaceFriction.torque` summed over the ranks (the half window's, N m)."""
        dforces = None if dforces is None else self._owned(dforces)
        return self.comm.allreduce(self._friction.torque(self._owned(forces), dU, dforces), MPI.SUM)

    def _surface_displacement(self, u: np.ndarray) -> np.ndarray:
        return u.reshape(-1, self.gdim)[self._friction.rows.nodes]

    def _friction_forces(self) -> np.ndarray:
        """The friction's nodal forces on the soil (N or N/m, (rows, stations, gdim)) at the current displacement."""
        return self._friction.sweep(self._surface_displacement(self.u.x.array), float(self.axle_height.value),
                                    self.surface, self.spin)

    def _add_friction_stiffness(self, M: PETSc.Mat) -> None:
        """Add the friction's nodal stiffness (:meth:`SurfaceFriction.stiffness`, the free dofs of
        this rank's own surface nodes) to the preconditioner's matrix ``M``."""
        free = self._surface_free
        blocks = self._friction.stiffness() * (free[..., :, None] & free[..., None, :])
        first = self.V.dofmap.index_map.local_range[0]
        bs, g = self.V.dofmap.index_map_bs, self.gdim
        for node, block in zip(self._friction.rows.nodes.ravel(), blocks.reshape(-1, g, g)):
            if block.any():
                dofs = ((first + node) * bs + np.arange(g)).astype(PETSc.IntType)
                M.setValues(dofs, dofs, block, addv=PETSc.InsertMode.ADD_VALUES)
        M.assemble()

    def _add_friction(self, b: PETSc.Vec, forces: np.ndarray) -> None:
        """Subtract the friction's nodal forces on the soil from the residual ``b`` (free dofs)."""
        with b.localForm() as local:
            local.array.reshape(-1, self.gdim)[self._friction.rows.nodes] -= np.where(self._surface_free, forces, 0.0)

    def _geostatic_state(self, unit_weight: float, K0: float | None) -> StreamlineState:
        rows, nc = len(self.streamline_depths), self.ncomp
        stress = np.zeros((rows, nc))
        self.K0 = None
        if unit_weight:
            used = []
            for k, material in enumerate(self.materials):
                k0, clipped = admissible_k0(material, K0, unit_weight * (self.surface - self.base), nc)
                if clipped:
                    log.warning("K0 violates the yield condition of layer %d under self weight; using K0 = %.4g",
                                k + 1, k0)
                used.append(k0)
            sv = -unit_weight * self.streamline_depths
            stress[:, [k for k in range(3) if k != self._up]] = (np.array(used)[self._row_layer] * sv)[:, None]
            stress[:, self._up] = sv
            #: the geostatic coefficient used: one, or per layer
            self.K0 = used[0] if len(set(used)) == 1 else tuple(used)
        return StreamlineState(stress, np.zeros((rows, nc)), np.zeros(rows))

    def _krylov_solver(self) -> PETSc.KSP:
        n = self._owned_nodes * self.V.dofmap.index_map_bs
        jac = PETSc.Mat().createPython(((n, PETSc.DECIDE), (n, PETSc.DECIDE)), _JacobianAction(self), comm=self.comm)
        jac.setUp()
        opts = PETSc.Options()
        for key, val in self.petsc_options.items():
            opts[self.options_prefix + key] = val
        ksp = PETSc.KSP().create(self.comm)
        ksp.setOptionsPrefix(self.options_prefix)
        if self._elastic_matrix is not None:
            ksp.setOperators(jac, self._elastic_matrix)     # the preconditioner is factored once
        else:                                           # set at each Newton iteration
            ksp.setOperators(jac)
        ksp.setFromOptions()
        self._jacobian = jac
        return ksp

    # ------------------------------------------------------------------ sweeps
    def _point_values(self, expr) -> np.ndarray:
        return compat.evaluate(expr, self.mesh).reshape(self.n_qp, self.ncomp)

    def _at_points(self, rows_values: np.ndarray) -> np.ndarray:
        """(rows, stations, ...) values in the quadrature points' order, (points, ...)."""
        flat = np.empty((self.n_qp,) + rows_values.shape[2:])
        flat[self._order] = rows_values
        return flat

    def _store(self, f: fem.Function, rows_values: np.ndarray) -> None:
        """Put (rows, stations, components) values at their quadrature points of ``f``."""
        flat = self._at_points(rows_values)
        f.x.array[: flat.size] = flat.reshape(-1)

    def _store_traction(self, f: fem.Function, stress: np.ndarray) -> None:
        """The rear face's traction ``sigma n`` (n = -e_x) of the last stations' ``stress``."""
        shear = [3] if self.gdim == 2 else [3, 5]                          # sqrt2 xy (and sqrt2 xz)
        t = -np.concatenate([stress[:, :1], stress[:, shear] / _SQ2], axis=1)   # (rows, gdim)
        nodal = np.einsum("cng,cgk->cnk", self._face_weights, t[self._face_rows])
        f.x.array.reshape(-1, self.gdim)[self._face_dofs] = nodal

    def _sweep(self, inflow: StreamlineState) -> None:
        """March the return map along the streamlines at the current displacement."""
        strain = self._projected(self._point_values(self._strain_expr))[self._order]   # (rows, stations, 4)
        rows, stations, _ = strain.shape
        sigma, eps_p = inflow.stress.copy(), inflow.plastic_strain.copy()
        acc = inflow.accumulated_plastic_strain.copy()
        S, EP = np.empty_like(strain), np.empty_like(strain)
        C, ACC = np.empty((rows, stations, self.ncomp, self.ncomp)), np.empty((rows, stations))
        previous = np.zeros((rows, self.ncomp))
        relaxed = self.relaxation_length > 0
        for i in range(stations):
            deps = strain[:, i] - previous
            for material, rows, D in self._groups:
                res = return_map(material, sigma[rows], deps[rows])
                if relaxed:
                    relax_return(material, res, sigma[rows], deps[rows], self._station_travel[i] / self.relaxation_length,
                                 D=D)
                sigma[rows] = res.sigma
                eps_p[rows] += res.deps_p
                acc[rows] += _SQ23 * np.linalg.norm(res.deps_p, axis=1)
                C[rows, i] = res.tangent
            S[:, i], EP[:, i], ACC[:, i] = sigma, eps_p, acc
            previous = strain[:, i]
        self._counts["sweeps"] += 1
        self._fields = (S, EP, ACC)
        self._tangent = C
        self._upstream = C @ self._D_inv[:, None]  # d sigma_i / d sigma_{i-1}
        if self._projection is not None:           # the residual's stress: B-bar acts on the change
            S = self._stress_bar(S, inflow.stress[:, None, :])
        self._store(self._sigma, S)
        self._store_traction(self._traction, S[:, -1])

    def _projected(self, values: np.ndarray) -> np.ndarray:
        """Mandel strains at the quadrature points (flat order) with B-bar's projected trace (as
        they are when pointwise)."""
        return values if self._projection is None else self._projection.projected(values)

    def _stress_bar(self, stress: np.ndarray, reference) -> np.ndarray:
        """The residual's stress of the (rows, stations, components) ``stress``: ``reference +
        projected(stress - reference)``, in the same layout."""
        change = self._at_points(stress - reference)
        return self._projection.projected(change)[self._order] + reference

    def _tangent_sweep(self) -> None:
        """The sweep's directional derivative for the displacement increment in ``self._du``."""
        dstrain = self._projected(self._point_values(self._dstrain_expr))[self._order]
        local = np.einsum("rsij,rsj->rsi", self._tangent, np.diff(dstrain, axis=1, prepend=0.0))
        dsigma = np.empty_like(dstrain)
        ds = np.zeros(dstrain[:, 0].shape)
        for i in range(dstrain.shape[1]):
            ds = np.einsum("rij,rj->ri", self._upstream[:, i], ds) + local[:, i]
            dsigma[:, i] = ds
        self._counts["sweeps"] += 1
        if self._projection is not None:
            dsigma = self._stress_bar(dsigma, 0.0)
        self._store(self._dsigma, dsigma)
        self._store_traction(self._dtraction, dsigma[:, -1])

    def _assemble(self, form, b: PETSc.Vec) -> PETSc.Vec:
        with b.localForm() as local:
            local.set(0.0)
        fpetsc.assemble_vector(b, form)
        b.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        compat.set_bc(b, self.bcs)
        return b

    def residual(self, inflow: StreamlineState) -> PETSc.Vec:
        """The residual (N/m) of the current displacement, ``P^T R``: sweep, then assemble."""
        self._sweep(inflow)
        self._assemble(self._F, self._full)
        if self._friction is not None:
            self._friction_force = self._friction_forces()
            self._add_friction(self._full, self._friction_force)
        self._tie.multTranspose(self._full, self._b)
        return self._b

    def _update_preconditioner(self, refactor: bool = True) -> None:
        """The contact's stiffness at the current displacement, in the Jacobian action and (with
        ``refactor``) the preconditioner; the preconditioner (the elastic stiffness, or the return
        map's local tangent, plus the contact's and the friction's nodal stiffness) then factored
        again."""
        self._update_contact_matrix()
        if not refactor and self._preconditioner_matrix is not None:
            return
        M = self._preconditioner_full
        if self._tangent_form is not None:
            tangent = self._tangent.reshape(*self._tangent.shape[:2], -1)
            self._store(self._tangent_fn, tangent)
            M.zeroEntries()
            fpetsc.assemble_matrix(M, self._tangent_form, bcs=self.bcs)
            M.assemble()
            if self._projection is not None:
                self._projection.add_jacobian(M, self.bcs, self._at_points(tangent))
        else:
            self._elastic_full.copy(M, structure=PETSc.Mat.Structure.SAME_NONZERO_PATTERN)
        self._add_contact_and_friction(M)
        first = self._preconditioner_matrix is None
        self._preconditioner_matrix = self._reduced_matrix(M, self._preconditioner_matrix)
        if first:
            self._ksp.setOperators(self._jacobian, self._preconditioner_matrix[0])

    def _update_contact_matrix(self) -> None:
        """:attr:`_contact_matrix`: the contact's stiffness at the current displacement, zero on the
        fixed dofs' rows, columns and diagonal (the elastic stiffness has its ones there)."""
        if self._contact_stiffness is None:
            return
        if self._contact_matrix is not None:
            self._contact_matrix.destroy()
        self._contact_matrix = fpetsc.assemble_matrix(self._contact_stiffness)
        self._contact_matrix.assemble()
        self._contact_matrix.zeroRowsColumns(self._fixed_global, diag=0.0)

    def _add_contact_and_friction(self, M: PETSc.Mat) -> None:
        """Add the contact's stiffness (:attr:`_contact_matrix`) and the friction's nodal blocks to ``M``."""
        if self._contact_matrix is not None:
            M.axpy(1.0, self._contact_matrix, structure=PETSc.Mat.Structure.SUBSET_NONZERO_PATTERN)
        if self._friction is not None:
            self._add_friction_stiffness(M)

    def jacobian_action(self, x: PETSc.Vec, y: PETSc.Vec) -> None:
        """``y = P^T J P x`` at the state of the last residual (identity on the fixed and tied dofs)."""
        du = compat.petsc_vector(self._du)
        self._tie.mult(x, du)
        self._du.x.scatter_forward()
        self._du.x.array[self._fixed] = 0.0
        self._tangent_sweep()
        self._assemble(self._Jv, self._full)
        if self._contact_matrix is not None:
            self._contact_matrix.multAdd(du, self._full, self._full)
        if self._friction is not None:
            self._add_friction(self._full, self._friction.tangent(self._surface_displacement(self._du.x.array)))
        self._tie.multTranspose(self._full, y)
        keep = np.concatenate([self._fixed[self._fixed < len(y.array)], self._slaves])
        y.array[keep] = x.array_r[keep]

    # ------------------------------------------------------------------ solves
    def solve(self, peak_pressure: float, inflow: StreamlineState | None = None) -> SteadyRollingResult:
        """The steady state under the peak pressure ``peak_pressure`` (Pa) with the soil entering
        in the state ``inflow`` (default: undisturbed, :attr:`inflow`), from zero displacement.
        Raises :class:`NoSteadyState` when Newton-Krylov does not converge."""
        if self.wheel is not None:
            raise RuntimeError("this steady solve rolls a rigid wheel: call solve_sinkage()")
        if not (math.isfinite(peak_pressure) and peak_pressure > 0):
            raise ValueError(f"peak_pressure must be a positive pressure (Pa), got {peak_pressure!r}")
        self.peak.value = peak_pressure
        self.u.x.array[:] = 0.0
        result = self._newton(inflow, f"under the peak pressure {peak_pressure:.6g} Pa")
        result.peak_pressure = float(peak_pressure)
        return result

    def solve_sinkage(self, sinkage: float, inflow: StreamlineState | None = None, *,
                      max_cuts: int = 4) -> SteadyRollingResult:
        """The steady state under the rigid wheel with its lowest point ``sinkage`` (m) below the
        undisturbed surface, turning at :attr:`spin`, with the contact's forces and torque on it;
        Newton starts from the last solve's displacement (continuation: step the sinkage up),
        extrapolated along the secant of the last two sinkages solved when it is the last of them
        (by at most their distance), or from the undisturbed soil when the wheel, raised, no
        longer touches it.  When Newton fails on the way down from the last solve's sinkage (or
        from the surface), the step is halved, from the last converged state, up to ``max_cuts``
        times.  ``inflow`` as in :meth:`solve`."""
        if self.wheel is None:
            raise RuntimeError("this steady solve rolls a Hertz pressure: call solve()")
        if not (math.isfinite(sinkage) and sinkage > 0):
            raise ValueError(f"sinkage must be a positive depth (m), got {sinkage!r}")
        if not (isinstance(max_cuts, int) and max_cuts >= 0):
            raise ValueError(f"max_cuts must be an integer >= 0, got {max_cuts!r}")
        self.axle_height.value = self.surface + self.wheel.diameter / 2 - sinkage
        if self._load_norm() == 0.0:        # raised clear of the last state: from the undisturbed soil
            spin = self.spin
            self.restart()
            self.spin = spin
        start = 0.0 if self._last_sinkage is None else self._last_sinkage
        u0 = self.u.x.array.copy()
        self._predict(sinkage)
        try:
            return self._solve_sinkage(sinkage, inflow)
        except NoSteadyState as err:
            if max_cuts == 0 or not start < sinkage:
                raise
            self.u.x.array[:] = u0
            middle = 0.5 * (start + sinkage)
            log.info("steady rolling: %s; cutting the step: first at the sinkage %.6g m", err, middle)
            self.solve_sinkage(middle, inflow, max_cuts=max_cuts - 1)
            return self.solve_sinkage(sinkage, inflow, max_cuts=max_cuts - 1)

    def restart(self) -> None:
        """Back to the undisturbed soil under the wheel touching it (spin 1): the next
        :meth:`solve_sinkage` continues from there (e.g. the next pass, on another inflow)."""
        self.u.x.array[:] = 0.0
        #: the wheel's dimensionless spin ``xi = omega R / V`` (-; ``omega`` in the rolling sense, 1:
        #: rolling without slip on a rigid surface)
        self.spin = 1.0
        self._last_sinkage: float | None = None
        #: the sinkage, displacement and spin of the last two sinkages solved (the predictor's secant)
        self._converged: list[tuple[float, np.ndarray, float]] = \
            [(0.0, self.u.x.array.copy(), self.spin)] if self.wheel is not None else []

    def _predict(self, sinkage: float) -> None:
        """Secant predictor: when the displacement is that of the last sinkage solved and the two
        last sinkages lie below ``sinkage``, move it along their secant (at most one of their
        steps), and the spin as well at the start of a free-rolling solve."""
        ratio = self._secant_ratio(sinkage)
        if ratio:
            (_, u0, spin0), (_, u1, spin1) = self._converged
            self.u.x.array[:] = u1 + ratio * (u1 - u0)
            if self._predict_spin:
                self.spin = spin1 + ratio * (spin1 - spin0)

    def _secant_ratio(self, sinkage: float) -> float:
        """How far along the secant of the last two sinkages solved ``sinkage`` lies beyond the
        last (in their steps, at most 1), when the displacement is still the last's; else 0."""
        if len(self._converged) < 2:
            return 0.0
        (s0, _, _), (s1, u1, _) = self._converged
        current = self.comm.allreduce(bool(np.array_equal(self.u.x.array, u1)), MPI.LAND)
        return min((sinkage - s1) / (s1 - s0), 1.0) if current and s0 < s1 < sinkage else 0.0

    def _solve_sinkage(self, sinkage: float, inflow: StreamlineState | None) -> SteadyRollingResult:
        """The steady state at ``sinkage``, the axle already set there by :meth:`solve_sinkage`."""
        result = self._newton(inflow, f"at the sinkage {sinkage:.6g} m")
        if self._converged and self._converged[-1][0] == sinkage:
            self._converged.pop()
        self._converged = (self._converged + [(float(sinkage), self.u.x.array.copy(), self.spin)])[-2:]
        result.sinkage = self._last_sinkage = float(sinkage)
        result.vertical_force = self.symmetry * self._scalar(self._vertical_force)
        result.towing_force = self.symmetry * self._scalar(self._towing_force)
        result.spin = self.spin
        result.axle_torque = 0.0          # frictionless: the normal pressure passes through the axle
        if self._friction is not None:
            forces = self._friction_force                        # on the soil, at the converged state
            total = self.comm.allreduce(self._owned(forces).sum(axis=(0, 1)), MPI.SUM)
            result.vertical_force -= self.symmetry * float(total[-1])
            result.towing_force += self.symmetry * float(total[0])
            result.axle_torque = self.symmetry * self._friction_torque(forces)
        return result

    def _scalar(self, form) -> float:
        """A functional assembled over all ranks."""
        return self.comm.allreduce(float(fem.assemble_scalar(form)), MPI.SUM)

    def solve_free_rolling(self, sinkage: float, inflow: StreamlineState | None = None, *,
                           torque_rtol: float = 1e-6, spin_tol: float = 1e-8,
                           max_iterations: int = 20) -> SteadyRollingResult:
        """The steady state of the towed (free-rolling) wheel at ``sinkage`` (m): the spin
        :attr:`spin` that zeroes the axle torque, to ``|torque| <= torque_rtol R Q_V``, each solve
        from the last.  Newton steps on the spin with the torque's exact derivative and the
        displacement's sensitivity as predictor (:meth:`_spin_sensitivity`) until the root is
        bracketed, then regula falsi (Illinois).  Where the torque jumps across zero (a bracket
        narrower than ``spin_tol``), the side of the smaller torque is taken, with a warning.  The
        result's iterations, sweeps and wall time are those of all the solves."""
        if not (isinstance(max_iterations, int) and max_iterations >= 1):
            raise ValueError(f"max_iterations must be an integer >= 1, got {max_iterations!r}")
        if not 0 < torque_rtol < 1:
            raise ValueError(f"torque_rtol must lie in (0, 1), got {torque_rtol!r}")
        R = self.wheel.diameter / 2
        self._predict_spin = self._friction is not None     # the first solve's spin along the secant too
        started, work = time.perf_counter(), np.zeros(4, dtype=int)      # Newton, Krylov, sweeps, fixed point
        try:
            result = self._counted(self.solve_sinkage(sinkage, inflow), work, started)
        finally:
            self._predict_spin = False
        bracket: dict[bool, tuple[float, float]] = {}      # (spin, torque) on each side of zero torque
        ends = {}                                           # the same, torques unweighted
        kept = None                                         # the end the last regula falsi step kept
        for _ in range(max_iterations):
            torque = result.axle_torque
            if self._friction is None or abs(torque) <= torque_rtol * R * abs(result.vertical_force):
                return result
            side = torque > 0
            bracket[side] = ends[side] = (result.spin, torque)
            if len(bracket) == 2:
                (s1, t1), (s0, t0) = bracket[True], bracket[False]
                if abs(s1 - s0) <= spin_tol:
                    return self._torque_jump(sinkage, inflow, result, ends)
                other = not side
                if kept == other:                           # Illinois: an end kept twice weighs half
                    bracket[other] = (bracket[other][0], 0.5 * bracket[other][1])
                    (s1, t1), (s0, t0) = bracket[True], bracket[False]
                kept = other
                step = (s0 * t1 - s1 * t0) / (t1 - t0) - result.spin
                sensitivity = self._spin_sensitivity()[0]
            else:
                sensitivity, slope = self._spin_sensitivity()
                step = -torque / slope if slope != 0 else math.nan
            if not math.isfinite(step):
                break
            u = self.u.x.array.copy()
            for cut in range(SPIN_CUTS + 1):
                self.spin = result.spin + step
                self.u.x.array[:] = u + step * sensitivity
                try:
                    trial = self._counted(self.solve_sinkage(sinkage, inflow), work, started)
                    break
                except NoSteadyState:
                    # the stick-slip pattern jumped too far: back to the last state, half the step
                    step *= 0.5
                    if cut == SPIN_CUTS:
                        self.u.x.array[:], self.spin = u, result.spin
                        raise
            result = trial
        raise NoSteadyState(f"no free-rolling spin at the sinkage {sinkage:.6g} m: the axle torque stayed at "
                            f"{result.axle_torque:.3e} {'N m/m' if self.gdim == 2 else 'N m'} after {max_iterations} solves")

    @staticmethod
    def _counted(result: SteadyRollingResult, work: np.ndarray, started: float) -> SteadyRollingResult:
        """``result`` with the Newton, Krylov and fixed-point iterations and sweeps of all the
        solves so far (``work``, added to in place) and the wall time since ``started``."""
        work += (result.newton_iterations, result.krylov_iterations, result.sweeps, result.fixed_point_iterations)
        (result.newton_iterations, result.krylov_iterations, result.sweeps,
         result.fixed_point_iterations) = (int(w) for w in work)
        result.wall_time = time.perf_counter() - started
        return result

    def _torque_jump(self, sinkage: float, inflow, result: SteadyRollingResult,
                     ends: dict[bool, tuple[float, float]]) -> SteadyRollingResult:
        """The free-rolling state where the torque jumps across zero between the ``ends``
        ((spin, torque) of either sign)."""
        spin, torque = min(ends.values(), key=lambda end: abs(end[1]))
        log.warning("steady rolling at the sinkage %.6g m: the axle torque jumps from %.4g to %.4g N m "
                    "between the spins %.9f and %.9f; taking %.9f", sinkage, ends[False][1],
                    ends[True][1], ends[False][0], ends[True][0], spin)
        if spin == result.spin:
            return result
        self.spin = spin
        return self.solve_sinkage(sinkage, inflow)

    def solve_load(self, load: float, inflow: StreamlineState | None = None, *, initial_sinkage: float | None = None,
                   free_rolling: bool = False, rtol: float = 1e-6, max_iterations: int = 20,
                   states: dict | None = None, torque_rtol: float = 1e-6) -> SteadyRollingResult:
        """The steady state of the wheel carrying the vertical force ``load`` (N/m): the sinkage
        with ``|Q_V - load| <= rtol load``.  Each new sinkage is the secant through the two states
        whose Q_V lie closest to the load, kept inside the bracket of the load once there is one
        (else the bracket is halved); before that, as if Q_V were proportional to the sinkage.
        The first state is the solve at ``initial_sinkage`` (m; default: the last solve's) or,
        given ``states`` (sinkage -> (displacement array, spin, Q_V) of converged states, e.g. from
        stepping the sinkage up), those.  Each solve starts from the converged state at the
        deepest sinkage short of it (stepping up keeps the contact), with its spin.  With
        ``free_rolling`` every sinkage is solved by :meth:`solve_free_rolling` (to ``torque_rtol``),
        else at the current :attr:`spin`; the displacement (and the spin) start on the secant of the
        two deepest states short of the sinkage (:meth:`solve_sinkage`'s predictor)."""
        if not (math.isfinite(load) and load > 0):
            raise ValueError(f"load must be a positive force (N/m), got {load!r}")
        if not 0 < rtol < 1:
            raise ValueError(f"rtol must lie in (0, 1), got {rtol!r}")
        if not (isinstance(max_iterations, int) and max_iterations >= 1):
            raise ValueError(f"max_iterations must be an integer >= 1, got {max_iterations!r}")
        known = dict(states or {})

        def solve(sinkage: float, inflow) -> SteadyRollingResult:
            if free_rolling:
                return self.solve_free_rolling(sinkage, inflow, torque_rtol=torque_rtol)
            return self.solve_sinkage(sinkage, inflow)

        def solve_at(sinkage: float) -> SteadyRollingResult:
            self.continue_from(known, sinkage)
            result = solve(sinkage, inflow)
            known[result.sinkage] = (self.u.x.array.copy(), self.spin, result.vertical_force)
            return result

        result = None
        if not known:
            sinkage = self._last_sinkage if initial_sinkage is None else initial_sinkage
            if sinkage is None:
                raise ValueError("give an initial_sinkage (m) or states: no sinkage has been solved yet")
            result = solve_at(sinkage)
        for _ in range(max_iterations):
            if result is not None and abs(result.vertical_force - load) <= rtol * load:
                return result
            result = solve_at(_next_sinkage({s: q for s, (_, _, q) in known.items()}, load))
        raise NoSteadyState(f"no sinkage carries the load {load:.6g} N/m: Q_V = {result.vertical_force:.6g} N/m "
                            f"after {max_iterations} solves")

    def restore(self, displacement: np.ndarray, spin: float, sinkage: float) -> None:
        """Make the converged state (``displacement`` array, ``spin``) at ``sinkage`` (m) the
        current one, and the next solve's start (a state found before a failed solve)."""
        self.u.x.array[:] = displacement
        self.spin = spin
        self._last_sinkage = sinkage
        self._converged = [(sinkage, displacement.copy(), spin)]

    def continue_from(self, states: dict, sinkage: float) -> None:
        """Set up the next solve at ``sinkage`` (m) from ``states`` (sinkage -> (displacement
        array, spin, Q_V) of converged states): from the deepest state short of it, with its spin
        and the secant predictor of the two deepest (a failed step is cut from there); with none
        short of it and the last solve deeper, from the undisturbed soil and spin 1 (:meth:`restart`:
        a failed spin search leaves its last trial spin behind)."""
        shallower = [s for s in states if s < sinkage]
        if shallower:
            self._last_sinkage = max(shallower)
            u, self.spin, _ = states[self._last_sinkage]
            self.u.x.array[:] = u
            self._converged = [(s, states[s][0], states[s][1]) for s in sorted(shallower)[-2:]]
        elif self._last_sinkage is not None and self._last_sinkage > sinkage:
            self.restart()

    def _load_norm(self) -> float:
        """Norm of the load vector (N/m) at the current displacement (the contact's depends on it)."""
        load = self._b.duplicate()
        self._tie.multTranspose(self._assemble(self._load, self._full), load)
        norm = load.norm()
        load.destroy()
        return norm

    def _newton(self, inflow: StreamlineState | None, load_text: str) -> SteadyRollingResult:
        """Newton-Krylov from the current displacement to the steady state under the load set; where
        it fails, the fixed point (:meth:`_fixed_point`) if ``control.fixed_point_iterations``."""
        inflow = self.inflow if inflow is None else inflow
        if inflow.stress.shape[0] != len(self.streamline_depths):
            raise ValueError(f"inflow state has {inflow.stress.shape[0]} streamlines, the mesh "
                             f"{len(self.streamline_depths)}")
        t0 = time.perf_counter()
        self._counts = {"sweeps": 0, "krylov": 0, "newton": 0}
        history: list[float] = []
        failure = self._newton_iterations(inflow, load_text, history)
        fixed_point = 0
        if failure is not None:
            if not self.control.fixed_point_iterations:
                self._fail(load_text, failure)
            fixed_point = self._fixed_point(inflow, load_text, failure, history)
        S, EP, ACC = self._fields
        outflow = StreamlineState(S[:, -1].copy(), EP[:, -1].copy(), ACC[:, -1].copy())
        return SteadyRollingResult(peak_pressure=None, newton_iterations=self._counts["newton"],
                                   fixed_point_iterations=fixed_point, krylov_iterations=self._counts["krylov"],
                                   sweeps=self._counts["sweeps"], wall_time=time.perf_counter() - t0,
                                   outflow=outflow,
                                   max_accumulated_plastic_strain=self.comm.allreduce(float(ACC.max(initial=0.0)),
                                                                                      MPI.MAX),
                                   residual_norms=history)

    def _newton_iterations(self, inflow: StreamlineState, load_text: str, history: list[float]) -> str | None:
        """Newton-Krylov steps from the current displacement until the residual passes
        ``control.rtol`` (``None``) or they fail (the cause; the displacement is then that of the
        last step taken).  Appends the relative residuals to ``history``."""
        ctl = self.control
        scale = self._load_norm()
        b = self.residual(inflow)
        norm = b.norm()
        history.append(norm / scale)
        it = 0
        while not history[-1] <= ctl.rtol:
            if not math.isfinite(norm):
                self._fail(load_text, "the residual is not finite")
            if it == ctl.max_iterations:
                return (f"Newton-Krylov did not converge in {it} iterations (residual {history[-1]:.2e} of the "
                        f"load's, wanted {ctl.rtol:.0e})")
            if self.wheel is not None or self._tangent_form is not None:
                # the factorization is kept while GMRES converges quickly on it (the action is exact)
                self._update_preconditioner(it == 0 or self._ksp.getIterationNumber() > self.control.refactor_iterations)
            eta = self._krylov_rtol
            if ctl.forcing:                         # Eisenstat-Walker (choice 2, gamma 0.9, alpha 2)
                eta = ctl.forcing if it == 0 else \
                    min(ctl.forcing, max(0.9 * (history[-1] / history[-2]) ** 2, self._krylov_rtol))
            u0 = self.u.x.array.copy()
            trial, alpha = self._line_search(inflow, b, norm, scale, eta, u0)
            if trial is None and eta != self._krylov_rtol:
                # a loose direction that no step along lowers the residual is solved again tightly
                self.u.x.array[:] = u0
                b = self.residual(inflow)
                trial, alpha = self._line_search(inflow, b, norm, scale, self._krylov_rtol, u0)
            if trial is None:
                self.u.x.array[:] = u0
                return f"no Newton step lowers the residual ({norm / scale:.2e} of the load's after {it} iterations)"
            b, norm = trial
            if self.wheel is not None:
                scale = self._load_norm()
            it += 1
            self._counts["newton"] += 1
            history.append(norm / scale)
            log.debug("steady rolling %s: Newton %d, residual %.3e, step %.3g, GMRES %d", load_text,
                      it, history[-1], alpha, self._ksp.getIterationNumber())
        return None

    def _fixed_point(self, inflow: StreamlineState, load_text: str, failure: str, history: list[float]) -> int:
        """Where Newton failed (``failure``): the elastic fixed point (the initial-stiffness method)
        ``u <- u - P M^-1 P^T R(u)`` from the current displacement, ``M`` the elastic stiffness plus
        the contact's and the friction's (:meth:`_fixed_point_matrix`, made again every
        :data:`FIXED_POINT_REFACTOR` iterations as the contact changes).  It needs no derivative of
        the sweep and carries the iterate past where Newton's line search finds no descent; after
        ``control.newton_retry`` iterations Newton is tried again from there
        (:meth:`_newton_from_fixed_point`), and again after twice as many more each time it fails.
        Appends the residuals to ``history``; returns the fixed-point iterations; raises
        :class:`NoSteadyState` when the residual has not fallen by a tenth in
        :data:`FIXED_POINT_PATIENCE` iterations, or after ``control.fixed_point_iterations``."""
        ctl = self.control
        ksp = PETSc.KSP().create(self.comm)
        ksp.setType("preonly")
        ksp.getPC().setType("lu")
        ksp.getPC().setFactorSolverType("mumps")
        x, rhs = self._b.duplicate(), self._b.duplicate()
        b = self.residual(inflow)
        best, since, M = history[-1], 0, None
        newton_at, wait = ctl.newton_retry, ctl.newton_retry
        try:
            for it in range(1, ctl.fixed_point_iterations + 1):
                if (it - 1) % FIXED_POINT_REFACTOR == 0:
                    if M is not None:
                        M.destroy()
                    M = self._fixed_point_matrix()
                    ksp.setOperators(M)
                b.copy(rhs)
                rhs.scale(-1.0)
                ksp.solve(rhs, x)
                self._tie.mult(x, compat.petsc_vector(self._du))
                self._du.x.scatter_forward()
                self.u.x.array[:] += self._du.x.array
                b = self.residual(inflow)
                history.append(b.norm() / self._load_norm())
                if history[-1] <= ctl.rtol:
                    return it
                if it == newton_at:
                    if self._newton_from_fixed_point(inflow, load_text, history):
                        return it
                    b = self.residual(inflow)
                    wait *= 2
                    newton_at += wait
                best, since = (history[-1], 0) if history[-1] < 0.9 * best else (best, since + 1)
                if since == FIXED_POINT_PATIENCE or not math.isfinite(history[-1]):
                    break
            self._fail(load_text, f"{failure}; the fixed point then stalled at {history[-1]:.2e} of the load's "
                                  f"after {it} iterations")
        finally:
            for obj in (ksp, x, rhs, M):
                if obj is not None:
                    obj.destroy()

    def _newton_from_fixed_point(self, inflow: StreamlineState, load_text: str, history: list[float]) -> bool:
        """Newton-Krylov from the fixed point's iterate: whether it converged (its residuals then
        appended to ``history``); if not, the displacement is the fixed point's again."""
        u0 = self.u.x.array.copy()
        tried: list[float] = []
        if self._newton_iterations(inflow, load_text, tried) is None:
            history.extend(tried[1:])
            return True
        self.u.x.array[:] = u0
        return False

    def _fixed_point_matrix(self) -> PETSc.Mat:
        """The fixed point's matrix, reduced by the rear tie: the elastic stiffness plus the
        contact's stiffness at the current displacement and the friction's nodal blocks."""
        M = fpetsc.assemble_matrix(self._elastic_form, bcs=self.bcs)
        M.assemble()
        self._update_contact_matrix()
        self._add_contact_and_friction(M)
        reduced, product = self._reduced_matrix(M)
        for obj in (M, product):
            obj.destroy()
        return reduced

    def _line_search(self, inflow, b: PETSc.Vec, norm: float, scale: float, eta: float, u0: np.ndarray):
        """The Newton step from ``u0`` (residual ``b``, its norm ``norm``) with GMRES to the
        relative tolerance ``eta``, backtracked (halved) until the residual's norm decreases:
        ((residual, norm), step length), or (None, None) below ``control.min_step``."""
        rhs = b.copy()
        rhs.scale(-1.0)
        self._ksp.setTolerances(rtol=eta)
        du = self._krylov(rhs, scale)
        rhs.destroy()
        alpha = 1.0
        while alpha >= self.control.min_step:
            self.u.x.array[:] = u0 + alpha * du
            b = self.residual(inflow)
            trial = b.norm()
            if trial <= (1.0 - 1e-4 * alpha) * norm:       # False for a NaN residual
                return (b, trial), alpha
            alpha *= 0.5
        return None, None

    def _krylov(self, rhs: PETSc.Vec, scale: float) -> np.ndarray:
        """The full displacement increment ``P x`` of ``P^T J P x = rhs`` (GMRES, to the absolute
        tolerance of a tenth of the Newton test on ``scale``)."""
        x = self._b.duplicate()
        self._ksp.setTolerances(atol=0.1 * self.control.rtol * scale)
        self._ksp.solve(rhs, x)
        self._counts["krylov"] += self._ksp.getIterationNumber()
        reason = self._ksp.getConvergedReason()
        if reason < 0:
            log.info("steady rolling: GMRES stopped (reason %d) after %d iterations; step taken as is",
                     reason, self._ksp.getIterationNumber())
        self._tie.mult(x, compat.petsc_vector(self._du))
        self._du.x.scatter_forward()
        x.destroy()
        return self._du.x.array.copy()

    def _spin_sensitivity(self) -> tuple[np.ndarray, float]:
        """At a converged state (that of the last residual): the displacement's derivative with the
        spin ``c`` (``J c = -dR/dxi``) and the axle torque's total derivative ``T_xi + T_u c`` (N m
        per unit spin, the half window's)."""
        self._update_preconditioner(refactor=False)
        friction, force = self._friction, self._friction_force
        zero = np.zeros(friction.rows.nodes.shape + (self.gdim,))
        d_spin = friction.tangent(zero, dspin=1.0)
        with self._full.localForm() as local:
            local.set(0.0)
        self._add_friction(self._full, d_spin)              # dR/dxi
        rhs = self._b.duplicate()
        self._tie.multTranspose(self._full, rhs)
        rhs.scale(-1.0)
        c = self._krylov(rhs, self._load_norm())
        rhs.destroy()
        dU = self._surface_displacement(c)
        slope = self._friction_torque(force, zero, d_spin) + self._friction_torque(force, dU, friction.tangent(dU))
        return c, slope

    def passes(self, peak_pressure: float, count: int) -> list[SteadyRollingResult]:
        """``count`` passes of the same load: each pass's soil enters in the state the last one
        left behind (the window must reach far enough behind the load for that state to be
        settled).  The first pass starts from :attr:`inflow`."""
        if not (isinstance(count, int) and count >= 1):
            raise ValueError(f"count must be an integer >= 1, got {count!r}")
        results, state = [], self.inflow
        for _ in range(count):
            results.append(self.solve(peak_pressure, state))
            state = results[-1].outflow
        return results

    @staticmethod
    def _fail(load_text: str, cause: str) -> None:
        raise NoSteadyState(f"no steady state {load_text}: {cause}; the load may exceed the soil's plastic limit "
                            "(it would keep ploughing)")

    # ------------------------------------------------------------------ fields of the last solve
    @property
    def stress(self) -> np.ndarray:
        """Swept stress at the quadrature points (Pa, Mandel, :attr:`quadrature_coordinates` order)."""
        return self._flat(0)

    @property
    def plastic_strain(self) -> np.ndarray:
        """Plastic strain at the quadrature points (Mandel)."""
        return self._flat(1)

    @property
    def accumulated_plastic_strain(self) -> np.ndarray:
        """``sum sqrt(2/3) |d eps_p|`` at the quadrature points."""
        return self._flat(2)

    def _flat(self, k: int) -> np.ndarray:
        if self._fields is None:
            raise RuntimeError("no steady state computed yet: call solve() first")
        return self._at_points(self._fields[k])

    def horizontal_balance(self) -> HorizontalBalance:
        """The window's horizontal resultants (N/m) of the last solve: the outflow face's from its
        traction (the swept stress at the last stations), the inflow face's and the base's as the
        consistent reactions of their fixed nodes (the residual there, the discrete ``int sigma n``)."""
        if self._fields is None:
            raise RuntimeError("no steady state computed yet: call solve() first")
        reaction = self._full.duplicate()
        with reaction.localForm() as local:
            local.set(0.0)
        fpetsc.assemble_vector(reaction, self._F)
        reaction.ghostUpdate(addv=PETSc.InsertMode.ADD, mode=PETSc.ScatterMode.REVERSE)
        r = reaction.array_r.reshape(-1, self.gdim)[:, 0]
        owned = self._owned_nodes
        inflow, base = (self.comm.allreduce(float(r[nodes[nodes < owned]].sum()), MPI.SUM)
                        for nodes in (self._inflow_nodes, self._base_nodes))
        reaction.destroy()
        outflow = -self._scalar(self._outflow_force)
        k = self.symmetry
        return HorizontalBalance(outflow_axial=k * outflow, inflow_axial=k * inflow, base_shear=-k * base)

    def surface_displacement(self) -> tuple[np.ndarray, np.ndarray]:
        """``(x, u)`` of the displacement's nodes on the surface (in 3D on the centre line y = 0),
        ordered by x (m, m)."""
        X = self.V.tabulate_dof_coordinates()
        n = self._owned_nodes
        tol = 1e-9 * (self.x_in - self.x_out)
        on = np.abs(X[:n, self._up] - self.surface) < tol
        if self.gdim == 3:
            on &= np.abs(X[:n, 1]) < tol
        top = np.flatnonzero(on)
        x = np.concatenate(self.comm.allgather(X[top, 0]))
        u = np.concatenate(self.comm.allgather(self.u.x.array.reshape(-1, self.gdim)[top]))
        order = np.argsort(x)
        return x[order], u[order]


def _next_sinkage(forces: dict[float, float], load: float) -> float:
    """The next sinkage of :meth:`SteadyRolling.solve_load` from the vertical forces found so far
    (sinkage -> Q_V, m -> N/m)."""
    points = sorted(forces.items())
    below = [p for p in points if p[1] < load]
    above = [p for p in points if p[1] >= load]
    if len(points) == 1:
        s, q = points[0]
        return s * load / q if q > 0 else 2.0 * s
    (s0, q0), (s1, q1) = sorted(points, key=lambda p: abs(p[1] - load))[:2]
    guess = s1 + (load - q1) * (s1 - s0) / (q1 - q0) if q1 != q0 else math.nan
    if below and above:
        lo, hi = below[-1][0], above[0][0]
        return guess if lo < guess < hi else 0.5 * (lo + hi)
    if above:                               # every state carries more: shallower, not past half of it
        return guess if 0.5 * above[0][0] <= guess < above[0][0] else max(above[0][0] * load / above[0][1],
                                                                            0.5 * above[0][0])
    (deepest, q), double = below[-1], 2.0 * below[-1][0]   # every state carries less: deeper, at most twice
    return guess if deepest < guess <= double else (min(deepest * load / q, double) if q > 0 else double)


def _levels(values: np.ndarray, tol: float) -> np.ndarray:
    """The rank of each value among the distinct values (those closer than ``tol`` count as one)."""
    order = np.argsort(values, kind="stable")
    rank = np.empty(len(values), dtype=np.int64)
    rank[order] = np.concatenate([[0], np.cumsum(np.diff(values[order]) > tol)])
    return rank


class _JacobianAction:
    """PETSc Python matrix: the exact Jacobian action of a :class:`SteadyRolling`."""

    def __init__(self, steady: SteadyRolling):
        self.steady = steady

    def mult(self, mat, x, y):
        self.steady.jacobian_action(x, y)
