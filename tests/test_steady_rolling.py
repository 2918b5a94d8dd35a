"""Steady rolling in the load's frame (rollsim.solver.steady): a Hertz line pressure on von Mises
soil in plane strain, against the static elastic solution, first yield (K. L. Johnson, Contact
Mechanics, ch. 6), the shakedown limit (ch. 9) and mesh convergence."""
from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh as dmesh
from mpi4py import MPI
from petsc4py import PETSc

from rollsim import compat
from rollsim.geometry import CylinderWheel
from rollsim.solver import DruckerPrager, VonMises
from rollsim.solver.contact import Circle, RigidWheelContact
from rollsim.solver.problem import PlasticityProblem, mandel_strain
from rollsim.solver.return_map import elastic_stiffness, invariants
from rollsim.solver.stepping import StepControl, solve_load_path
from rollsim.solver.steady import (NewtonKrylovControl, NoSteadyState, RollingWindow, SteadyRolling,
                                   rolling_window_mesh)
from rollsim.solver.steady_friction import DEFAULT_TANGENTIAL_RATIO, SurfaceFriction, SurfaceRows

K = 1.0                                  # shear yield stress k (Pa)
SOIL = VonMises(E=1000.0, nu=0.3, yield_stress=math.sqrt(3.0) * K)
NEVER_YIELDS = VonMises(E=1000.0, nu=0.3, yield_stress=1e12)
#: a rigid cylinder whose contact is about a = 1 m wide where this soil first yields (p0 = 3.1 k)
WHEEL = Circle(diameter=300.0)
#: the window of the plastic checks: the state 10 a behind the load has settled
WINDOW = RollingWindow(half_width=1.0, ahead=6.0, behind=10.0, depth=10.0, cells_per_half_width=4)


def steady(window: RollingWindow, material, **kwargs) -> SteadyRolling:
    if window.interfaces:
        kwargs.setdefault("interfaces", window.interfaces)
    return SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, window), material, window.half_width, **kwargs)


def half_space_first_yield(nu: float) -> float:
    """p0 / k at first von Mises yield under a Hertz line pressure on an elastic half-space, from
    McEwen's closed-form stresses of the Hertz line pressure, maximised over a grid."""
    x, z = np.meshgrid(np.linspace(-1.5, 1.5, 601), np.linspace(0.01, 2.0, 400))
    A = 1.0 - x ** 2 + z ** 2
    R = np.sqrt(A ** 2 + 4.0 * x ** 2 * z ** 2)
    m, n = np.sqrt(0.5 * (R + A)), np.sign(x) * np.sqrt(0.5 * (R - A))
    r2 = m ** 2 + n ** 2
    sxx = -(m * (1.0 + (z ** 2 + n ** 2) / r2) - 2.0 * z)
    szz = -m * (1.0 - (z ** 2 + n ** 2) / r2)
    sxz = n * (m ** 2 - z ** 2) / r2
    syy = nu * (sxx + szz)
    mean = (sxx + szz + syy) / 3.0
    J2 = 0.5 * ((sxx - mean) ** 2 + (szz - mean) ** 2 + (syy - mean) ** 2) + sxz ** 2
    return 1.0 / math.sqrt(J2.max())


@dataclass(frozen=True)
class BehindTheLoad:
    """The state at ``distance`` (m) behind a rolling load, along the depth below the surface (m):
    sigma_xx (Pa) and the plastic shear strain eps_p_xy (-) on the rows of quadrature points, and
    the surface displacement (m); ``wall_time`` (s) of the solve that gave it."""

    distance: float
    depth: np.ndarray
    sigma_xx: np.ndarray
    plastic_shear: np.ndarray
    surface_displacement: np.ndarray
    wall_time: float

    def __post_init__(self):
        if not (self.depth.shape == self.sigma_xx.shape == self.plastic_shear.shape and self.depth.ndim == 1
                and self.surface_displacement.shape == (2,)):
            raise ValueError("a state behind the load needs profiles of equal length and a 2D surface displacement")


def _at_station(coords: np.ndarray, values: np.ndarray, x: float) -> tuple[np.ndarray, np.ndarray]:
    """``values`` at the quadrature points ``coords`` interpolated linearly in x to ``x`` on every
    row of equal y: (row ordinates from the surface down, (rows, ...) values)."""
    ys = np.unique(np.round(coords[:, 1], 10))[::-1]
    rows = []
    for y in ys:
        on = np.flatnonzero(np.abs(coords[:, 1] - y) < 1e-9)
        on = on[np.argsort(coords[on, 0])]
        rows.append([np.interp(x, coords[on, 0], v) for v in np.atleast_2d(values[on].T)])
    return ys, np.array(rows)


def _surface_at(V, u: np.ndarray, surface: float, x: float) -> np.ndarray:
    X = V.tabulate_dof_coordinates()
    n = V.dofmap.index_map.size_local
    top = np.flatnonzero(np.abs(X[:n, 1] - surface) < 1e-9)
    top = top[np.argsort(X[top, 0])]
    return np.array([np.interp(x, X[top, 0], u.reshape(-1, 2)[top, k]) for k in range(2)])


def steady_behind(st: SteadyRolling, res, distance: float) -> BehindTheLoad:
    """The steady state ``distance`` behind the load (the last solve of ``st``)."""
    ys, rows = _at_station(st.quadrature_coordinates, np.column_stack([st.stress[:, 0], st.plastic_strain[:, 3]]),
                           -distance)
    return BehindTheLoad(distance, st.surface - ys, rows[:, 0], rows[:, 1] / math.sqrt(2.0),
                         _surface_at(st.V, st.u.x.array, st.surface, -distance), res.wall_time)


def residual_part(state: BehindTheLoad, elastic: BehindTheLoad) -> BehindTheLoad:
    """``state`` less that of the elastic soil under the same load on the same block: the residual
    sigma_xx and surface displacement, without the load's elastic far field (which the steady
    window's and the transient block's different far faces shape differently)."""
    return replace(state, sigma_xx=state.sigma_xx - elastic.sigma_xx,
                   surface_displacement=state.surface_displacement - elastic.surface_displacement)


def differences(steady_state: BehindTheLoad, transient: BehindTheLoad) -> dict[str, float]:
    """Relative differences of the transient's state from the steady one's: sigma_xx and eps_p_xy
    (the largest over the depth, over the largest magnitude of the steady profile) and the surface
    settlement u_y (the horizontal displacement is left out: the transient block's held ends
    restrain it)."""
    def rel(a, b):
        return float(np.abs(b - a).max() / np.abs(a).max())
    return {"sigma_xx": rel(steady_state.sigma_xx, transient.sigma_xx),
            "plastic_shear": rel(steady_state.plastic_shear, transient.plastic_shear),
            "settlement": rel(steady_state.surface_displacement[1:], transient.surface_displacement[1:])}


def stretched_block(window: RollingWindow, travel: float, comm: MPI.Comm = MPI.COMM_SELF):
    """A transient reference's block on ``comm``: the cells of ``window`` (plane strain, or a 3D
    half window) with its fine zone stretched by ``travel`` (m, a whole number of fine cells)
    along x."""
    h = window.fine_cell_size
    cells = int(round(travel / h))
    if abs(cells * h - travel) > 1e-9 * window.half_width:
        raise ValueError(f"travel {travel} must be a whole number of cells ({h} m)")
    xs = window.x_nodes()
    nodes = [np.concatenate([xs[xs < -1e-9], np.arange(cells + 1) * h, xs[xs > 1e-9] + travel])]
    nodes += [window.y_nodes()] if window.dimension == 2 else [window.across_nodes(), window.y_nodes()]
    counts = [len(n) - 1 for n in nodes]
    corners = [np.zeros(len(counts)), np.array(counts, dtype=float)]
    msh = (dmesh.create_rectangle(comm, corners, counts, dmesh.CellType.quadrilateral) if window.dimension == 2
           else dmesh.create_box(comm, corners, counts, dmesh.CellType.hexahedron))
    for k, n in enumerate(nodes):
        msh.geometry.x[:, k] = np.interp(msh.geometry.x[:, k], np.arange(len(n)), n)
    return msh


def hold_faces_and_base(pb: PlasticityProblem) -> None:
    """Fix the displacement of ``pb``'s block on its end faces and its base."""
    x = pb.mesh.geometry.x
    (x0, y0), (x1, _) = x[:, :2].min(axis=0), x[:, :2].max(axis=0)
    fdim = pb.mesh.topology.dim - 1
    held = dmesh.locate_entities_boundary(pb.mesh, fdim, lambda p: np.isclose(p[0], x0) | np.isclose(p[0], x1)
                                          | np.isclose(p[1], y0))
    pb.bcs = [fem.dirichletbc(fem.Function(pb.V), fem.locate_dofs_topological(pb.V, fdim, held))]


def transient_behind(window: RollingWindow, material, peak_pressure: float, travel: float, step: float,
                     distance: float) -> BehindTheLoad:
    """The independent reference: the Hertz line pressure of ``window`` (peak ``peak_pressure``)
    set down at x = 0 and moved by ``travel`` (m) in steps of at most ``step`` (m) over a block of
    the same cells (the window with its fine zone stretched by ``travel``; faces and base held),
    solved incrementally with :class:`PlasticityProblem`; the state ``distance`` behind the load's
    last position.  ``material``: one, or one per layer of ``window.interfaces`` (top first)."""
    t0 = time.perf_counter()
    a = window.half_width
    msh = stretched_block(window, travel)
    tags = None
    if isinstance(material, (list, tuple)):             # layers: each cell's by the depth of its centre
        n_cells = msh.topology.index_map(2).size_local
        centres = dmesh.compute_midpoints(msh, 2, np.arange(n_cells, dtype=np.int32))
        layer = np.searchsorted(window.interfaces, -centres[:, 1]).astype(np.int32)
        tags = dmesh.meshtags(msh, 2, np.arange(n_cells, dtype=np.int32), layer)
        material = dict(enumerate(material))
    pb = PlasticityProblem(msh, material, cell_tags=tags)
    fdim = pb.mesh.topology.dim - 1
    hold_faces_and_base(pb)
    top = dmesh.locate_entities_boundary(msh, fdim, lambda p: np.isclose(p[1], 0.0))
    ds = ufl.Measure("ds", domain=msh, subdomain_data=dmesh.meshtags(msh, fdim, np.sort(top),
                                                                     np.ones(len(top), np.int32)))
    peak, centre = fem.Constant(msh, 0.0), fem.Constant(msh, 0.0)
    X = ufl.SpatialCoordinate(msh)
    pressure = peak * ufl.sqrt(ufl.max_value(1.0 - ((X[0] - centre) / a) ** 2, 0.0))
    pb.add_residual_term(pressure * pb.test_function[1] * ds(1, metadata={"quadrature_degree": 12}))

    def set_peak(t):
        peak.value = peak_pressure * t

    def set_centre(t):
        centre.value = t

    solve_load_path(pb, set_peak, StepControl(dt=0.25, dt_max=0.25, dt_min=1e-3))
    # a step cut where Newton fails is taken back to ``step`` at once
    solve_load_path(pb, set_centre, StepControl(t_end=travel, dt=step, dt_max=step, dt_min=step / 64,
                                                easy_iterations=1000))
    coords = compat.evaluate(compat.expression(X, pb.points), msh).reshape(-1, 2)
    values = np.column_stack([pb.sigma.x.array.reshape(-1, 4)[:, 0], pb.eps_p.x.array.reshape(-1, 4)[:, 3]])
    ys, rows = _at_station(coords, values, travel - distance)
    return BehindTheLoad(distance, -ys, rows[:, 0], rows[:, 1] / math.sqrt(2.0),
                         _surface_at(pb.V, pb.u.x.array, 0.0, travel - distance), time.perf_counter() - t0)


@pytest.mark.serial
def test_elastic_steady_state_is_the_static_solution():
    """Without plasticity the soil has no history: the steady state is the static elastic
    solution.  Reference: a plain static solve on the same mesh with the last column of cells
    held at the steady displacement; and gravity with its geostatic stress changes nothing."""
    window = RollingWindow(half_width=1.0, ahead=4.0, behind=6.0, depth=6.0, cells_per_half_width=4)
    st = steady(window, NEVER_YIELDS)
    res = st.solve(1.0)
    msh, V = st.mesh, st.V
    x_tie = np.unique(msh.geometry.x[:, 0])[1]
    fdim = msh.topology.dim - 1
    held = fem.locate_dofs_geometrical(V, lambda p: (p[0] <= x_tie + 1e-9) | np.isclose(p[0], st.x_in)
                                       | np.isclose(p[1], st.base))
    u_held = fem.Function(V)
    u_held.x.array[:] = st.u.x.array
    D = ufl.as_matrix(elastic_stiffness(NEVER_YIELDS, 4).tolist())
    u, v = ufl.TrialFunction(V), ufl.TestFunction(V)
    X = ufl.SpatialCoordinate(msh)
    top = dmesh.locate_entities_boundary(msh, fdim, lambda p: np.isclose(p[1], 0.0))
    ds = ufl.Measure("ds", subdomain_data=dmesh.meshtags(msh, fdim, np.sort(top), np.ones(len(top), np.int32)),
                     metadata={"quadrature_degree": 12})
    static = fem.petsc.LinearProblem(
        ufl.inner(ufl.dot(D, mandel_strain(u, 2)), mandel_strain(v, 2)) * ufl.dx(metadata={"quadrature_degree": 4}),
        -ufl.sqrt(ufl.max_value(1.0 - X[0] ** 2, 0.0)) * v[1] * ds(1), bcs=[fem.dirichletbc(u_held, held)],
        petsc_options={"ksp_type": "preonly", "pc_type": "lu"}).solve()
    scale = np.abs(static.x.array).max()
    assert np.abs(st.u.x.array - static.x.array).max() <= 1e-6 * scale
    assert res.newton_iterations <= 3 and res.max_accumulated_plastic_strain == 0.0

    heavy = steady(window, NEVER_YIELDS, unit_weight=20.0, K0=0.5)
    heavy.solve(1.0)
    assert np.abs(heavy.u.x.array - st.u.x.array).max() <= 1e-6 * scale
    assert heavy.stress[:, 1].min() < -100.0          # the geostatic stress is there (20 N/m^3, 6 m deep)


@pytest.mark.serial
def test_elastic_steady_state_with_b_bar_is_the_static_b_bar_solution():
    """B-bar carries over: with the cell-average volumetric strain the elastic steady state is the
    static solution of :class:`PlasticityProblem` with the same volumetric strain on the same mesh
    (last column of cells held at the steady displacement), and differs from the pointwise one; the
    geostatic stress, which B-bar leaves alone (it acts on the change), changes nothing."""
    window = RollingWindow(half_width=1.0, ahead=4.0, behind=6.0, depth=6.0, cells_per_half_width=2)
    soft = VonMises(E=1000.0, nu=0.45, yield_stress=1e12)
    st = steady(window, soft, volumetric_strain="cell-average")
    st.solve(1.0)
    msh = st.mesh
    pb = PlasticityProblem(msh, soft, volumetric_strain="cell-average")
    x_tie = np.unique(msh.geometry.x[:, 0])[1]
    held = fem.locate_dofs_geometrical(pb.V, lambda p: (p[0] <= x_tie + 1e-9) | np.isclose(p[0], st.x_in)
                                       | np.isclose(p[1], st.base))
    u_held = fem.Function(pb.V)
    pb.bcs = [fem.dirichletbc(u_held, held)]
    fdim = msh.topology.dim - 1
    top = dmesh.locate_entities_boundary(msh, fdim, lambda p: np.isclose(p[1], 0.0))
    ds = ufl.Measure("ds", domain=msh, subdomain_data=dmesh.meshtags(msh, fdim, np.sort(top),
                                                                     np.ones(len(top), np.int32)))
    peak = fem.Constant(msh, 0.0)
    X = ufl.SpatialCoordinate(msh)
    pb.add_residual_term(peak * ufl.sqrt(ufl.max_value(1.0 - X[0] ** 2, 0.0)) * pb.test_function[1]
                         * ds(1, metadata={"quadrature_degree": 12}))

    def load(t):
        peak.value = t
        u_held.x.array[:] = t * st.u.x.array

    solve_load_path(pb, load, StepControl(dt=1.0, dt_max=1.0, dt_min=0.25))
    scale = np.abs(st.u.x.array).max()
    assert np.abs(st.u.x.array - pb.u.x.array).max() <= 1e-6 * scale
    pointwise = steady(window, soft)
    pointwise.solve(1.0)
    assert np.abs(pointwise.u.x.array - st.u.x.array).max() > 1e-3 * scale

    heavy = steady(window, soft, unit_weight=20.0, K0=0.5, volumetric_strain="cell-average")
    heavy.solve(1.0)
    assert np.abs(heavy.u.x.array - st.u.x.array).max() <= 1e-6 * scale


@pytest.mark.serial
def test_b_bar_jacobian_action_is_the_derivative_of_the_residual():
    """With B-bar in the plastic range of a Drucker-Prager soil (non-associated: its yield depends
    on the projected pressure) the Jacobian action (the sweep's tangent-linear action through
    yielded stations) equals central differences of the residual."""
    soil = DruckerPrager(E=1000.0, nu=0.3, phi_dp=math.radians(20.0), c_dp=1.0, dilation=math.radians(5.0))
    st = steady(RollingWindow(half_width=1.0, ahead=4.0, behind=6.0, depth=6.0, cells_per_half_width=2), soil,
                volumetric_strain="cell-average")
    assert st.solve(4.0).max_accumulated_plastic_strain > 1e-3
    x = st._b.duplicate()
    x.array[:] = np.random.default_rng(0).normal(size=x.array.shape)
    x.array[np.concatenate([st._fixed[st._fixed < len(x.array)], st._slaves])] = 0.0
    exact = st._b.duplicate()
    st.residual(st.inflow)
    st.jacobian_action(x, exact)
    du = st._full.duplicate()
    st._tie.mult(x, du)
    u0, h = st.u.x.array.copy(), 1e-7 * np.abs(st.u.x.array).max() / np.abs(du.array).max()
    sides = []
    for sign in (1.0, -1.0):
        st.u.x.array[: len(du.array)] = u0[: len(du.array)] + sign * h * du.array
        sides.append(st.residual(st.inflow).array.copy())
    difference = (sides[0] - sides[1]) / (2 * h)
    assert np.abs(difference - exact.array).max() <= 1e-4 * np.abs(exact.array).max()


@pytest.mark.serial
def test_first_yield_of_a_hertz_line_load():
    """Von Mises soil first yields at p0 = 3.1 k below the load's centre (Johnson, ch. 6; 3.107 k
    for nu = 0.3 from McEwen's stresses).  A finite window yields a little earlier (its fixed base
    and faces), the less so the larger it is.  No plastic strain anywhere below first yield, some
    above it."""
    half_space = half_space_first_yield(SOIL.nu)
    assert half_space == pytest.approx(3.107, abs=0.002)
    first_yield = []
    for size in (40.0, 80.0):
        window = RollingWindow(half_width=1.0, ahead=size / 2, behind=size / 2, depth=size, cells_per_half_width=4)
        st = steady(window, NEVER_YIELDS)
        st.solve(1.0)
        q = invariants(st.stress)[1]
        first_yield.append(SOIL.yield_stress / q.max() / K)
        depth = st.surface - st.quadrature_coordinates[q.argmax(), 1]
        assert 0.6 < depth < 0.8                       # Johnson: 0.70 a below the centre
    assert 0.95 * half_space < first_yield[0] < first_yield[1] < half_space

    st = steady(RollingWindow(half_width=1.0, ahead=20.0, behind=20.0, depth=40.0, cells_per_half_width=4), SOIL)
    assert st.solve(0.98 * first_yield[0] * K).max_accumulated_plastic_strain == 0.0
    assert st.solve(1.05 * first_yield[0] * K).max_accumulated_plastic_strain > 1e-6


@pytest.mark.serial
def test_repeated_passes_shake_down_below_4k_and_ratchet_above():
    """Repeated passes, each entering in the state the last one left (Johnson, ch. 9: the
    shakedown limit of a frictionless line contact is p0 = 4 k).  At 3.6 k the second and third
    passes add no plastic strain at all; at 4.5 k each adds about half the first pass's."""
    st = steady(WINDOW, SOIL)

    def added(p0):
        passes = st.passes(p0 * K, 3)
        acc = [np.zeros_like(passes[0].outflow.accumulated_plastic_strain)]
        acc += [r.outflow.accumulated_plastic_strain for r in passes]
        return [float((b - a).max()) for a, b in zip(acc, acc[1:])]

    below, above = added(3.6), added(4.5)
    assert below[0] > 5e-4 and below[2] <= 0.02 * below[0]
    assert above[0] > 5e-3 and 0.3 * above[0] < above[2] <= above[1] * 1.2


@pytest.mark.serial
def test_residual_rut_converges_with_the_mesh():
    """The residual rut (surface displacement at the rear face, 10 a behind the load) at
    p0 = 3.6 k on three nested meshes (h = a/2, a/4, a/8 at the load): observed order about 2."""
    ruts = []
    for level in range(3):
        window = RollingWindow(half_width=1.0, ahead=6.0, behind=10.0, depth=10.0, cells_per_half_width=2,
                               refinement=level)
        st = steady(window, SOIL)
        st.solve(3.6 * K)
        x, u = st.surface_displacement()
        ruts.append(u[0])                              # at x = x_out
    ruts = np.array(ruts)
    order = np.log2(np.abs(ruts[0] - ruts[1]) / np.abs(ruts[1] - ruts[2]))
    assert np.all((1.5 < order) & (order < 2.5)), order
    extrapolated = ruts[2] + (ruts[2] - ruts[1]) / (2.0 ** order - 1.0)
    assert np.all(np.abs(extrapolated - ruts[2]) < 0.05 * np.abs(ruts[2]))


@pytest.mark.serial
@pytest.mark.slow
def test_steady_state_is_where_a_transient_rolling_load_settles():
    """The same Hertz pressure (4.5 k) moved 8 a in steps of a/4 over a block of the same cells
    (h = a/2), solved step by step: 3 a behind the load its residual sigma_xx and plastic shear
    strain along the depth and its residual surface displacement (each less the elastic soil's on
    its own block) agree with the steady state's within 8.4, 6.6 and 5.4 % (measured;
    python -m benchmarks steady hertz on the finer mesh)."""
    window = RollingWindow(half_width=1.0, ahead=6.0, behind=10.0, depth=10.0, cells_per_half_width=2)
    behind = {}
    for material in (SOIL, NEVER_YIELDS):
        st = steady(window, material)
        behind[material] = steady_behind(st, st.solve(4.5 * K), 3.0)
    steady_state = residual_part(behind[SOIL], behind[NEVER_YIELDS])
    transient = residual_part(transient_behind(window, SOIL, 4.5 * K, 8.0, 0.25, 3.0),
                              transient_behind(window, NEVER_YIELDS, 4.5 * K, 8.0, 8.0, 3.0))
    diff = differences(steady_state, transient)
    assert diff["sigma_xx"] < 0.10 and diff["plastic_shear"] < 0.08 and diff["settlement"] < 0.07, diff
    assert np.abs(steady_state.plastic_shear).max() > 1e-3          # the comparison is in the plastic range


@pytest.mark.serial
def test_layered_steady_state_marches_each_streamline_in_its_layer():
    """Horizontal layers: a von Mises layer that does not yield at 4.5 k (yield stress doubled)
    over the soil from 0.6 a down (the interface between rows of nodes: the nearest row is moved
    onto it).  No plastic strain on a streamline above the interface and some below; the state
    3 a behind the load agrees with the same pressure moved 10 a over the same layered block (as
    in the uniform comparison) within 7.0, 4.4 and 8.5 % (measured; the uniform soil's steady
    state differs from the layered one's by 104, 85 and 48 %); two equal layers are the uniform
    soil to solver tolerance."""
    window = RollingWindow(half_width=1.0, ahead=6.0, behind=10.0, depth=10.0, cells_per_half_width=2,
                           interfaces=(0.6,))
    assert np.isclose(window.y_nodes(), -0.6).any()
    strong = VonMises(E=SOIL.E, nu=SOIL.nu, yield_stress=2.0 * SOIL.yield_stress)
    st = steady(window, (strong, SOIL))
    res = st.solve(4.5 * K)
    depth = st.surface - st.quadrature_coordinates[:, 1]
    assert st.accumulated_plastic_strain[depth < 0.6].max() == 0.0
    assert st.accumulated_plastic_strain[depth > 0.6].max() > 1e-3
    elastic = steady(window, (NEVER_YIELDS, NEVER_YIELDS))
    steady_state = residual_part(steady_behind(st, res, 3.0), steady_behind(elastic, elastic.solve(4.5 * K), 3.0))
    transient = residual_part(transient_behind(window, (strong, SOIL), 4.5 * K, 10.0, 0.25, 3.0),
                              transient_behind(window, NEVER_YIELDS, 4.5 * K, 10.0, 10.0, 3.0))
    diff = differences(steady_state, transient)
    assert diff["sigma_xx"] < 0.09 and diff["plastic_shear"] < 0.06 and diff["settlement"] < 0.10, diff

    same = steady(window, (SOIL, SOIL))
    same.solve(4.5 * K)
    uniform = steady(window, SOIL, interfaces=())
    uniform.solve(4.5 * K)
    assert np.abs(same.u.x.array - uniform.u.x.array).max() <= 1e-8 * np.abs(uniform.u.x.array).max()
    with pytest.raises(ValueError, match="interface"):
        steady(replace(window, interfaces=()), (strong, SOIL), interfaces=(0.6,))


@pytest.mark.serial
def test_no_steady_state_beyond_the_plastic_limit():
    """At p0 = 6 k the load ploughs: the solver says so instead of returning a state."""
    window = RollingWindow(half_width=1.0, ahead=6.0, behind=10.0, depth=10.0, cells_per_half_width=2)
    with pytest.raises(NoSteadyState, match="no steady state under the peak pressure 6 Pa"):
        steady(window, SOIL).solve(6.0 * K)


@pytest.mark.serial
def test_elastic_steady_rolling_of_a_cylinder_is_static_indentation():
    """Without plasticity the frame does not matter: the steady vertical force of a frictionless
    rigid cylinder at a held sinkage is that of a static indentation on the same mesh by the
    transient solver's contact (RigidWheelContact on PlasticityProblem), the last column of cells
    held at the steady displacement (measured: equal to 3e-10)."""
    window = RollingWindow(half_width=1.0, ahead=4.0, behind=6.0, depth=6.0, cells_per_half_width=4)
    st = SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, window), NEVER_YIELDS, wheel=WHEEL)
    res = st.solve_sinkage(0.004)
    msh = st.mesh
    x_tie = np.unique(msh.geometry.x[:, 0])[1]
    pb = PlasticityProblem(msh, NEVER_YIELDS)
    held = fem.locate_dofs_geometrical(pb.V, lambda p: (p[0] <= x_tie + 1e-9) | np.isclose(p[0], st.x_in)
                                       | np.isclose(p[1], st.base))
    u_held = fem.Function(pb.V)
    u_held.x.array[:] = st.u.x.array
    pb.bcs = [fem.dirichletbc(u_held, held)]
    top = np.sort(dmesh.locate_entities_boundary(msh, 1, lambda p: np.isclose(p[1], 0.0)))
    contact = RigidWheelContact(pb, WHEEL, dmesh.meshtags(msh, 1, top, np.ones(len(top), np.int32)), (1,),
                                E=NEVER_YIELDS.E, h=window.cell_size, quadrature_degree=12,
                                centre=np.array([0.0, WHEEL.diameter / 2 - 0.004]))
    assert pb.solve_increment().converged
    assert res.vertical_force == pytest.approx(contact.forces().vertical, rel=1e-6)
    assert np.abs(pb.u.x.array - st.u.x.array).max() <= 1e-6 * np.abs(st.u.x.array).max()


@pytest.mark.serial
def test_steady_vertical_force_of_a_cylinder_rises_with_the_sinkage():
    """Von Mises soil under the rigid cylinder, the sinkage stepped up from 2 to 12 mm (each solve
    starting from the last): the vertical force rises monotonically, the soil yields from about
    6 mm on, and at 12 mm it carries less than the elastic soil (measured: 5 % less)."""
    window = RollingWindow(half_width=1.0, ahead=4.0, behind=6.0, depth=6.0, cells_per_half_width=2)
    st = SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, window), SOIL, wheel=WHEEL)
    runs = [st.solve_sinkage(s) for s in 0.002 * np.arange(1, 7)]
    forces = np.array([r.vertical_force for r in runs])
    assert np.all(np.diff(forces) > 0), forces
    assert runs[0].max_accumulated_plastic_strain == 0.0 < runs[-1].max_accumulated_plastic_strain
    elastic = SteadyRolling(st.mesh, NEVER_YIELDS, wheel=WHEEL).solve_sinkage(0.012)
    assert 0.9 * elastic.vertical_force < forces[-1] < 0.98 * elastic.vertical_force


def test_streamlines_must_not_cross_ranks(comm):
    """The window's own mesh gives each rank whole rows of cells along x; a mesh partitioned
    otherwise (on 2 ranks: DOLFINx's default, which cuts the rows) is refused on every rank."""
    window = RollingWindow(half_width=1.0, ahead=2.0, behind=2.0, depth=2.0, cells_per_half_width=1)
    depths = SteadyRolling(rolling_window_mesh(comm, window), SOIL, 1.0).streamline_depths
    assert comm.allreduce(len(depths)) == 3 * len(window.y_nodes()) - 3
    if comm.size > 1:
        n = (len(window.x_nodes()) - 1, len(window.y_nodes()) - 1)
        cut = dmesh.create_rectangle(comm, [np.zeros(2), np.array(n, dtype=float)], n, dmesh.CellType.quadrilateral)
        with pytest.raises(ValueError, match="cut between ranks"):
            SteadyRolling(cut, SOIL, 1.0)
        one_layer = RollingWindow(half_width=1.0, ahead=2.0, behind=2.0, depth=1.0, cells_per_half_width=1,
                                  fine_extent=1.0)
        with pytest.raises(ValueError, match="fewer than the"):
            rolling_window_mesh(comm, one_layer)


def test_steady_rolling_is_partition_independent(comm):
    """The steady solves on the ranks of ``comm`` equal those on one (mpirun -n 2): the towed
    cylinder on von Mises soil in plane strain (plastic, friction, free spin: the surface on one
    rank) and the roller on clay with gravity and friction in 3D (the surface's rows split between
    the ranks, the row between them swept by both)."""
    if comm.size == 1:
        pytest.skip("needs mpirun -n >= 2 (compares the distributed solve with a COMM_SELF solve)")
    window_3d = RollingWindow(half_width=0.15, ahead=0.3, behind=0.3, depth=0.3, cells_per_half_width=1,
                              across=0.45, load_half_width_across=ROLLER.width / 2)
    found = {}
    for name, cm in (("distributed", comm), ("serial", MPI.COMM_SELF)):
        plane = SteadyRolling(rolling_window_mesh(cm, FRICTION_WINDOW), SOIL, wheel=WHEEL, friction=0.3)
        for sinkage in (0.004, 0.008):
            plane.solve_sinkage(sinkage)
        free = plane.solve_free_rolling(0.012)
        roller = SteadyRolling(rolling_window_mesh(cm, window_3d), CLAY_3D, wheel=ROLLER, friction=0.5,
                               unit_weight=20e3, tangential_ratio=1.0)     # held at xi = 1: the full stick
        held = roller.solve_sinkage(0.0025)
        found[name] = (free, plane.horizontal_balance().towing_force, plane.surface_displacement()[1], held,
                       roller.horizontal_balance().towing_force)
    (free, balance, rut, held, balance_3d), serial = found["distributed"], found["serial"]
    assert free.max_accumulated_plastic_strain > 0 and held.max_accumulated_plastic_strain > 0
    assert abs(held.axle_torque) > 0.01 * ROLLER.diameter / 2 * held.vertical_force        # the friction works
    R = WHEEL.diameter / 2
    assert free.spin == pytest.approx(serial[0].spin, abs=1e-9)
    assert free.axle_torque == pytest.approx(serial[0].axle_torque, abs=1e-7 * R * free.vertical_force)
    for a, b in ((free, serial[0]), (held, serial[3])):
        for key in ("vertical_force", "towing_force", "max_accumulated_plastic_strain"):
            assert getattr(a, key) == pytest.approx(getattr(b, key), rel=1e-7), key
    assert held.axle_torque == pytest.approx(serial[3].axle_torque, rel=1e-7)
    assert balance == pytest.approx(serial[1], rel=1e-7) and balance_3d == pytest.approx(serial[4], rel=1e-7)
    assert np.allclose(rut, serial[2], rtol=0, atol=1e-9 * np.abs(serial[2]).max())


@pytest.mark.serial
def test_towing_force_of_a_cylinder_balances_the_window_and_grows_with_plastic_sinkage():
    """Von Mises soil under the frictionless rigid cylinder, the sinkage stepped up from 2 to 12 mm:
    the towing force from the contact equals the window's horizontal balance (outflow traction,
    inflow and base reactions; measured: within 2e-9 N/m, 1e-9 of the largest resultant), resists
    the travel and grows with the sinkage (measured: Q_H = 2e-5, 1e-4, 3.2e-4, 2.0e-3, 5.9e-3,
    1.35e-2 N/m; 1.5e-3 of Q_V at 12 mm).  Measured: 1.6 s."""
    window = RollingWindow(half_width=1.0, ahead=4.0, behind=6.0, depth=6.0, cells_per_half_width=2)
    st = SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, window), SOIL, wheel=WHEEL)
    towing = []
    for sinkage in 0.002 * np.arange(1, 7):
        res = st.solve_sinkage(sinkage)
        balance = st.horizontal_balance()
        scale = max(abs(balance.outflow_axial), abs(balance.inflow_axial), abs(balance.base_shear))
        assert balance.towing_force == pytest.approx(res.towing_force, abs=1e-7 * scale)
        towing.append(res.towing_force)
    assert res.max_accumulated_plastic_strain > 0
    assert np.all(np.diff(towing) > 0), towing
    assert towing[-1] > 1e-3 * res.vertical_force


@pytest.mark.serial
def test_an_elastic_soil_does_not_resist_the_rolling_cylinder():
    """Without dissipation the steady state is the static indentation: the towing force vanishes up
    to the window's fore-aft asymmetry (measured on a window as long ahead as behind: Q_H =
    3.5e-4 N/m = 4e-5 Q_V at 12 mm, ten times less than 2 m shorter ahead), and the balance holds.
    Measured: 0.3 s."""
    window = RollingWindow(half_width=1.0, ahead=6.0, behind=6.0, depth=6.0, cells_per_half_width=2)
    st = SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, window), NEVER_YIELDS, wheel=WHEEL)
    res = st.solve_sinkage(0.012)
    assert abs(res.towing_force) < 1e-4 * res.vertical_force
    assert st.horizontal_balance().towing_force == pytest.approx(res.towing_force, abs=1e-7 * res.vertical_force)


#: the window of the friction checks: as long ahead as behind (no fore-aft asymmetry in Q_H)
FRICTION_WINDOW = RollingWindow(half_width=1.0, ahead=6.0, behind=6.0, depth=6.0, cells_per_half_width=2)


@pytest.mark.serial
def test_frictionless_free_rolling_is_the_frictionless_solve():
    """With mu = 0 the friction's sweep carries no traction: the free-rolling solve stops at its
    first spin (xi = 1, zero torque) with the frictionless forces.  Measured: 1.9 s."""
    st = SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, FRICTION_WINDOW), SOIL, wheel=WHEEL, friction=0.0)
    frictionless = SteadyRolling(st.mesh, SOIL, wheel=WHEEL)
    for sinkage in (0.006, 0.012):
        res, ref = st.solve_free_rolling(sinkage), frictionless.solve_sinkage(sinkage)
    assert res.spin == 1.0 and res.axle_torque == 0.0
    assert res.vertical_force == pytest.approx(ref.vertical_force, rel=1e-12)
    assert res.towing_force == pytest.approx(ref.towing_force, rel=1e-9)


@pytest.mark.serial
def test_free_rolling_on_elastic_soil_neither_resists_nor_needs_torque():
    """A towed cylinder with Coulomb friction (mu = 0.3) on elastic soil at 12 mm: the spin that
    zeroes the axle torque leaves no towing force (measured: Q_H = 3.3e-4 N/m = 4e-5 Q_V, the
    frictionless 3.5e-4; torque 2e-8 N m/m), the wheel turns a little slower than rolling without
    slip on a rigid surface (measured: xi = 0.99895), and the window balance still holds.  Held at
    xi = 1 instead, the wheel needs a torque and pulls itself forward (measured: 208 N m/m,
    Q_H = -1.4 N/m).  Measured: 2 s."""
    st = SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, FRICTION_WINDOW), NEVER_YIELDS, wheel=WHEEL,
                       friction=0.3)
    for sinkage in (0.004, 0.008):
        st.solve_sinkage(sinkage)
    held = st.solve_sinkage(0.012)
    assert held.axle_torque > 0 and held.towing_force < -0.1
    res = st.solve_free_rolling(0.012)
    R = WHEEL.diameter / 2
    assert abs(res.axle_torque) <= 1e-6 * R * res.vertical_force
    assert abs(res.towing_force) < 1e-4 * res.vertical_force
    assert 0.998 < res.spin < 1.0
    assert st.horizontal_balance().towing_force == pytest.approx(res.towing_force, abs=1e-7 * res.vertical_force)


@pytest.mark.serial
def test_free_rolling_on_plastic_soil_resists_more_than_frictionless():
    """The towed cylinder (mu = 0.3) on von Mises soil at 12 mm: zero torque at xi = 0.99832
    (measured), towing force 1.19e-2 N/m against 1.11e-2 without friction (measured), both
    balanced by the window.  Measured: 8 s."""
    st = SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, FRICTION_WINDOW), SOIL, wheel=WHEEL, friction=0.3)
    frictionless = SteadyRolling(st.mesh, SOIL, wheel=WHEEL)
    for sinkage in (0.004, 0.008):
        st.solve_sinkage(sinkage)
        frictionless.solve_sinkage(sinkage)
    res, ref = st.solve_free_rolling(0.012), frictionless.solve_sinkage(0.012)
    assert abs(res.axle_torque) <= 1e-6 * WHEEL.diameter / 2 * res.vertical_force
    assert res.spin < 1.0
    assert res.towing_force > ref.towing_force > 0
    assert st.horizontal_balance().towing_force == pytest.approx(res.towing_force, abs=1e-7 * res.vertical_force)


@pytest.mark.serial
def test_fixed_point_takes_over_where_newton_fails_and_finds_newtons_state():
    """With one Newton iteration allowed, the solve fails, unless the elastic fixed point takes
    over: the cylinder held with Coulomb friction (mu = 0.3, spin 1) on the von Mises soil at 4 and
    8 mm then reaches the state Newton-Krylov finds (forces within 1e-6)."""
    mesh = rolling_window_mesh(MPI.COMM_SELF, FRICTION_WINDOW)
    newton = SteadyRolling(mesh, SOIL, wheel=WHEEL, friction=0.3)
    one_step = NewtonKrylovControl(max_iterations=1)
    fixed = SteadyRolling(mesh, SOIL, wheel=WHEEL, friction=0.3, control=one_step)
    with pytest.raises(NoSteadyState, match="did not converge in 1 iterations"):
        fixed.solve_sinkage(0.004, max_cuts=0)
    fixed.restart()
    fixed.control = replace(one_step, fixed_point_iterations=5000)
    for sinkage in (0.004, 0.008):
        ref, res = newton.solve_sinkage(sinkage), fixed.solve_sinkage(sinkage)
        assert res.fixed_point_iterations > 0 and res.newton_iterations == 1
        assert res.residual_norms[-1] <= one_step.rtol
        for a, b in ((res.vertical_force, ref.vertical_force), (res.towing_force, ref.towing_force)):
            assert a == pytest.approx(b, rel=1e-6)
    assert ref.max_accumulated_plastic_strain > 0


@pytest.mark.serial
def test_newton_tried_again_from_the_fixed_point_finishes_the_solve():
    """With full Newton steps only (``min_step`` 1) Newton fails from the surface; the fixed point
    carries the iterate on and, tried again after 5 of its iterations (then 10, 20, ... more),
    Newton converges from there to Newton-Krylov's state (forces within 1e-6, mu = 0.3)."""
    mesh = rolling_window_mesh(MPI.COMM_SELF, FRICTION_WINDOW)
    full_steps = NewtonKrylovControl(min_step=1.0)
    for sinkage in (0.004, 0.008):
        ref = SteadyRolling(mesh, SOIL, wheel=WHEEL, friction=0.3).solve_sinkage(sinkage)
        st = SteadyRolling(mesh, SOIL, wheel=WHEEL, friction=0.3, control=full_steps)
        with pytest.raises(NoSteadyState, match="no Newton step lowers the residual"):
            st.solve_sinkage(sinkage, max_cuts=0)
        st.restart()
        st.control = replace(full_steps, fixed_point_iterations=1000, newton_retry=5)
        res = st.solve_sinkage(sinkage, max_cuts=0)
        assert res.fixed_point_iterations in (5, 15, 35, 75) and res.newton_iterations > 1
        assert res.residual_norms[-1] <= full_steps.rtol
        for a, b in ((res.vertical_force, ref.vertical_force), (res.towing_force, ref.towing_force)):
            assert a == pytest.approx(b, rel=1e-6)


@pytest.mark.serial
def test_a_raised_wheel_clear_of_the_last_state_starts_from_undisturbed_soil():
    """Held at 4 mm after 12 mm (mu = 0.3, spin 1), the raised wheel no longer touches the soil's
    last state: the solve starts from the undisturbed soil, stepping down from the surface, and
    finds a fresh solver's state (forces to 1e-9)."""
    mesh = rolling_window_mesh(MPI.COMM_SELF, FRICTION_WINDOW)
    st = SteadyRolling(mesh, SOIL, wheel=WHEEL, friction=0.3)
    st.solve_sinkage(0.012)
    res, ref = st.solve_sinkage(0.004), SteadyRolling(mesh, SOIL, wheel=WHEEL, friction=0.3).solve_sinkage(0.004)
    for a, b in ((res.vertical_force, ref.vertical_force), (res.towing_force, ref.towing_force)):
        assert a == pytest.approx(b, rel=1e-9)
    assert res.spin == 1.0


@pytest.mark.serial
def test_continuing_below_the_last_solve_starts_from_undisturbed_soil_and_spin():
    """Set up for a sinkage shallower than the last solve with no state short of it (the
    relaxation's route after a failed rate-independent one), the solve starts from the
    undisturbed soil turning at xi = 1, not at the spin a failed search left behind: the same
    state as a fresh solver's, to solver tolerance."""
    st = SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, FRICTION_WINDOW), SOIL, wheel=WHEEL, friction=0.3)
    st.solve_free_rolling(0.008)
    st.spin = 0.5                                       # what a failed spin search may leave
    st.continue_from({}, 0.004)
    assert st.spin == 1.0 and not st.u.x.array.any()
    res = st.solve_free_rolling(0.004)
    ref = SteadyRolling(st.mesh, SOIL, wheel=WHEEL, friction=0.3).solve_free_rolling(0.004)
    assert res.spin == pytest.approx(ref.spin, abs=1e-9)
    assert res.vertical_force == pytest.approx(ref.vertical_force, rel=1e-8)


@pytest.mark.serial
def test_constant_load_finds_the_sinkage_that_carries_it():
    """Von Mises soil under the frictionless cylinder carrying 7 N/m, from the 8 mm state: the
    secant on the sinkage finds 9.784 mm (measured: 3 solves after the start, Q_V within 1.5e-9 of
    the load), and a solve at that sinkage stepped up from 4 and 8 mm gives the same forces
    (measured: Q_V to 5e-10, Q_H = 5.36e-3 N/m to 2e-9, relative).  Measured: 3 s."""
    window = RollingWindow(half_width=1.0, ahead=4.0, behind=6.0, depth=6.0, cells_per_half_width=2)
    st = SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, window), SOIL, wheel=WHEEL)
    for sinkage in (0.004, 0.008):
        st.solve_sinkage(sinkage)
    res = st.solve_load(7.0)
    assert res.vertical_force == pytest.approx(7.0, rel=1e-6)
    ref = SteadyRolling(st.mesh, SOIL, wheel=WHEEL)
    for sinkage in (0.004, 0.008, res.sinkage):
        check = ref.solve_sinkage(sinkage)
    assert check.vertical_force == pytest.approx(res.vertical_force, rel=1e-7)
    assert check.towing_force == pytest.approx(res.towing_force, rel=1e-5)


@pytest.mark.serial
def test_relaxation_converges_to_the_rate_independent_steady_state():
    """Duvaut-Lions in the sweep (relaxation length L, m of travel): the cylinder held at 8 mm on
    the von Mises soil dissipates less with the plastic flow lagging, so its towing force Q_H and
    the largest accumulated plastic strain fall short of the rate-independent ones, first order
    in L (measured: slope 1.00 over L = h/80 .. h/10, h the station spacing; Q_H 0.2 % short at
    h/40); a very long L leaves the soil elastic (Q_V within 0.1 % of the elastic soil's, the
    plastic strain under a hundredth of the rate-independent one)."""
    window = RollingWindow(half_width=1.0, ahead=4.0, behind=6.0, depth=6.0, cells_per_half_width=2)
    msh = rolling_window_mesh(MPI.COMM_SELF, window)

    def held(material, length):
        st = SteadyRolling(msh, material, wheel=WHEEL, relaxation_length=length)
        for sinkage in (0.004, 0.008):
            res = st.solve_sinkage(sinkage)
        return res, st.station_spacing
    ref, h = held(SOIL, 0.0)
    lengths = h / np.array([80.0, 40.0, 20.0, 10.0])
    relaxed = [held(SOIL, L)[0] for L in lengths]
    for short in (np.array([ref.towing_force - r.towing_force for r in relaxed]),
                  np.array([ref.max_accumulated_plastic_strain - r.max_accumulated_plastic_strain for r in relaxed])):
        assert np.all(short > 0), short
        order = np.polyfit(np.log(lengths), np.log(short), 1)[0]
        assert 0.9 < order < 1.1, (short, order)
    assert ref.towing_force - relaxed[1].towing_force < 0.005 * ref.towing_force
    elastic, _ = held(NEVER_YIELDS, 0.0)
    slow, _ = held(SOIL, 1e3 * h)
    assert slow.vertical_force == pytest.approx(elastic.vertical_force, rel=1e-3)
    assert slow.max_accumulated_plastic_strain < 1e-2 * ref.max_accumulated_plastic_strain


@pytest.mark.serial
@pytest.mark.slow
def test_towed_wheel_at_constant_load():
    """The towed cylinder (mu = 0.3) on von Mises soil carrying 7 N/m: the sinkage's secant, each
    sinkage solved for zero axle torque, finds 10.00 mm at xi = 0.99876 with Q_H = 5.28e-3 N/m
    (measured: Q_V within 4e-8 of the load, torque 2.6e-4 N m/m).  Measured: 16 s."""
    st = SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, FRICTION_WINDOW), SOIL, wheel=WHEEL, friction=0.3)
    for sinkage in (0.004, 0.008):
        st.solve_sinkage(sinkage)
    res = st.solve_load(7.0, free_rolling=True)
    assert res.vertical_force == pytest.approx(7.0, rel=1e-6)
    assert abs(res.axle_torque) <= 1e-6 * WHEEL.diameter / 2 * res.vertical_force
    assert 0.0098 < res.sinkage < 0.0102 and res.spin < 1.0 and res.towing_force > 0
    assert st.horizontal_balance().towing_force == pytest.approx(res.towing_force, abs=1e-7 * res.vertical_force)


# ------------------------------------------------------------------------------------- 3D
ROLLER = CylinderWheel(1.524, 0.4572, 0.4572 / 12)      # the Mn/DOT roller's size
CLAY_3D = VonMises(E=40e6, nu=0.35, yield_stress=200e3)
ELASTIC_3D = VonMises(E=40e6, nu=0.35, yield_stress=1e12)
#: a coarse half window about the roller at s = 2.5-10 mm (contact half length about 0.06-0.12 m)
WINDOW_3D = RollingWindow(half_width=0.15, ahead=0.45, behind=0.6, depth=0.45, cells_per_half_width=2,
                          across=0.45, load_half_width_across=ROLLER.width / 2)


def test_3d_window_is_a_structured_half_block_of_hexahedra():
    """The 3D window: hexahedra aligned with the axes, y from the symmetry plane to ``across``,
    the fine cells over the roller's half width with a row of nodes on its rim (0.2286 m: four
    cells of 0.0572 m under the roller, two of 0.0732 m beyond, none above the 0.075 m of the
    fine cells); the streamlines are the rows of quadrature points of equal (y, z), all of one
    length; a window too narrow for its fine zone is refused."""
    msh = rolling_window_mesh(MPI.COMM_SELF, WINDOW_3D)
    assert compat.cell_name(msh) == "hexahedron"
    x = msh.geometry.x
    assert x[:, 1].min() == 0.0 and x[:, 1].max() == pytest.approx(0.45) and x[:, 2].max() == pytest.approx(0.0)
    assert WINDOW_3D.fine_across >= ROLLER.width / 2
    ys = WINDOW_3D.across_nodes()
    fine = ys[ys <= WINDOW_3D.fine_across + 1e-12]
    assert np.isclose(fine, ROLLER.width / 2).sum() == 1 and fine[-1] == pytest.approx(WINDOW_3D.fine_across)
    under, beyond = np.diff(fine[fine <= ROLLER.width / 2 + 1e-12]), np.diff(fine[fine >= ROLLER.width / 2 - 1e-12])
    assert np.allclose(under, ROLLER.width / 8) and np.allclose(beyond, (WINDOW_3D.fine_across - ROLLER.width / 2) / 2)
    assert max(under.max(), beyond.max()) <= WINDOW_3D.cell_size
    assert np.all(np.diff(ys) > 0)
    st = SteadyRolling(msh, ELASTIC_3D, wheel=ROLLER)
    n_rows = (3 * (len(ys) - 1)) * (3 * (len(WINDOW_3D.y_nodes()) - 1))
    assert st.streamline_depths.shape == (n_rows,)
    assert np.all(np.diff(st.streamline_depths) >= -1e-12)            # from the surface down
    with pytest.raises(ValueError, match="across"):
        replace(WINDOW_3D, across=0.3)
    with pytest.raises(ValueError, match="both"):
        RollingWindow(half_width=0.15, ahead=0.6, behind=0.9, depth=0.6, across=0.6)


def _static_indentation_3d(st: SteadyRolling, sinkage: float) -> tuple[PlasticityProblem, RigidWheelContact]:
    """The transient solver's static indentation on the steady solve's mesh: the roller pressed to
    ``sinkage`` (m) by RigidWheelContact on a PlasticityProblem with the steady solve's boundary
    conditions, its last column of cells held at the steady displacement."""
    msh = st.mesh
    x_tie = np.unique(msh.geometry.x[:, 0])[1]
    material, tags = st.material, None
    if len(st.materials) > 1:                 # layers: each cell's by the depth of its centre
        n_cells = msh.topology.index_map(3).size_local
        centres = dmesh.compute_midpoints(msh, 3, np.arange(n_cells, dtype=np.int32))
        layer = np.searchsorted(st.interfaces, st.surface - centres[:, 2]).astype(np.int32)
        material, tags = dict(enumerate(st.materials)), dmesh.meshtags(msh, 3, np.arange(n_cells, dtype=np.int32), layer)
    pb = PlasticityProblem(msh, material, volumetric_strain="pointwise", cell_tags=tags)
    held = fem.locate_dofs_geometrical(pb.V, lambda p: (p[0] <= x_tie + 1e-9) | np.isclose(p[0], st.x_in)
                                       | np.isclose(p[2], st.base))
    u_held = fem.Function(pb.V)
    u_held.x.array[:] = st.u.x.array
    side = msh.geometry.x[:, 1].max()
    lateral = fem.locate_dofs_geometrical((pb.V.sub(1), pb.V.sub(1).collapse()[0]),
                                          lambda p: np.isclose(p[1], 0.0) | np.isclose(p[1], side))[0]
    pb.bcs = [fem.dirichletbc(u_held, held), fem.dirichletbc(PETSc.ScalarType(0.0), lateral, pb.V.sub(1))]
    top = np.sort(dmesh.locate_entities_boundary(msh, 2, lambda p: np.isclose(p[2], 0.0)))
    contact = RigidWheelContact(pb, ROLLER, dmesh.meshtags(msh, 2, top, np.ones(len(top), np.int32)), (1,),
                                E=st.material.E, h=WINDOW_3D.cell_size, quadrature_degree=12,
                                centre=np.array([0.0, 0.0, ROLLER.diameter / 2 - sinkage]))
    assert pb.solve_increment().converged
    return pb, contact


@pytest.mark.serial
def test_3d_elastic_steady_rolling_is_static_indentation():
    """Without plasticity the frame does not matter in 3D either: the frictionless roller held at
    10 mm carries the force (whole wheel: twice the half window's) of a static indentation on the
    same hexahedra by the transient solver's contact, with the same displacement."""
    st = SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, WINDOW_3D), ELASTIC_3D, wheel=ROLLER)
    res = st.solve_sinkage(0.01)
    assert res.newton_iterations <= 6 and res.max_accumulated_plastic_strain == 0.0
    pb, contact = _static_indentation_3d(st, 0.01)
    assert res.vertical_force == pytest.approx(2 * contact.forces().vertical, rel=1e-6)
    assert np.abs(pb.u.x.array - st.u.x.array).max() <= 1e-6 * np.abs(st.u.x.array).max()
    # elastic: nothing resists the rolling but the window's asymmetry about the load (measured 1e-4)
    assert abs(res.towing_force) < 1e-3 * res.vertical_force


@pytest.mark.serial
def test_3d_elastic_steady_rolling_on_layers_is_static_indentation():
    """Horizontal layers in 3D (a stiff layer 0.1 m thick over one a quarter as stiff; the row of
    nodes nearest the interface moved onto it): without plasticity the steady roll is the static
    indentation of the same layered hexahedra, and the soft layer below lets the roller sink with
    less force than on the stiff soil alone."""
    window = replace(WINDOW_3D, interfaces=(0.1,))
    soft = VonMises(E=10e6, nu=0.35, yield_stress=1e12)
    st = SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, window), (ELASTIC_3D, soft), wheel=ROLLER,
                       interfaces=window.interfaces)
    res = st.solve_sinkage(0.01)
    pb, contact = _static_indentation_3d(st, 0.01)
    assert res.vertical_force == pytest.approx(2 * contact.forces().vertical, rel=1e-6)
    assert np.abs(pb.u.x.array - st.u.x.array).max() <= 1e-6 * np.abs(st.u.x.array).max()
    stiff = SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, window), ELASTIC_3D, wheel=ROLLER)
    assert res.vertical_force < 0.9 * stiff.solve_sinkage(0.01).vertical_force


@pytest.mark.serial
@pytest.mark.slow
def test_3d_towing_force_of_the_roller_balances_the_window():
    """Clay (von Mises, c = 115 kPa) under the frictionless roller held at 2.5 mm, gravity with its
    geostatic stress: the soil flows plastically, the towing force from
    the contact is positive and equals the window's horizontal balance (outflow traction, inflow
    and base reactions: the outflow condition and the rollers in 3D), and the roller carries less
    than on the elastic soil."""
    msh = rolling_window_mesh(MPI.COMM_SELF, WINDOW_3D)
    st = SteadyRolling(msh, CLAY_3D, wheel=ROLLER, unit_weight=20e3)
    res = st.solve_sinkage(0.0025)
    assert res.max_accumulated_plastic_strain > 0.01 and res.towing_force > 0.01 * res.vertical_force
    assert st.horizontal_balance().towing_force == pytest.approx(res.towing_force, rel=1e-4)
    elastic = SteadyRolling(msh, ELASTIC_3D, wheel=ROLLER, unit_weight=20e3).solve_sinkage(0.0025)
    assert res.vertical_force < 0.9 * elastic.vertical_force


def _friction_strip(gdim: int):
    """The wheel (in 3D the Mn/DOT roller with a fillet) and the surface rows of a strip of 41
    stations over 1.5 m (in 3D 13 rows over 0.3 m across) for the friction's tests."""
    xs = np.linspace(0.6, -0.9, 41)
    if gdim == 3:
        X = np.array([[x, y, 0.0] for y in np.linspace(0.0, 0.3, 13) for x in xs])
        return CylinderWheel(1.524, 0.4572, 0.05), SurfaceRows.of(X, 0.0, 1e-9)
    return Circle(1.524), SurfaceRows.of(np.column_stack([xs, np.zeros_like(xs)]), 0.0, 1e-9)


@pytest.mark.parametrize("gdim", [2, 3])
def test_friction_tangent_is_the_derivative_of_its_sweep(gdim):
    """The friction's tangent (sticking and sliding stations, the wheel's curvature; in 3D the
    fillet's) equals central differences of its sweep, and the nodal weights integrate the
    surface."""
    rng = np.random.default_rng(gdim)
    wheel, rows = _friction_strip(gdim)
    assert rows.weights.sum() == pytest.approx(1.5 * (0.3 if gdim == 3 else 1.0), rel=1e-12)
    friction = SurfaceFriction(rows, wheel, 0.3, 1e8, tangential_ratio=0.3)
    U = np.zeros(rows.nodes.shape + (gdim,))
    U[..., -1] = -0.01 * np.exp(-(rows.x / 0.25) ** 2) + 1e-5 * rng.normal(size=U.shape[:-1])
    U[..., 0] = 1e-4 * np.sin(rows.x * 7.0)
    sweep = lambda V: friction.sweep(V, wheel.diameter / 2 - 0.015, 0.0, 0.99)
    sweep(U)
    stick, contact = friction._state["stick"].copy(), friction._state["contact"]
    assert np.any(stick & contact) and np.any(~stick & contact)
    if gdim == 3:                                                     # some on the fillet
        assert np.any(contact[rows.across > wheel.width / 2 - wheel.fillet])
    dU = rng.normal(size=U.shape)
    exact = friction.tangent(dU)
    h = 1e-9
    forward, backward = sweep(U + h * dU), sweep(U - h * dU)
    assert np.array_equal(friction._state["stick"], stick)          # no station changed its state
    assert np.abs((forward - backward) / (2 * h) - exact).max() <= 1e-5 * np.abs(exact).max()


@pytest.mark.parametrize("gdim", [2, 3])
def test_friction_stiffness_is_each_nodes_own_derivative(gdim):
    """The friction's nodal stiffness (the preconditioner's blocks) is, at sticking and sliding
    stations alike, the derivative of each node's force by its own displacement with the tangent
    frame held (the exact tangent without the wheel's curvature), negated; zero out of contact."""
    wheel, rows = _friction_strip(gdim)
    friction = SurfaceFriction(rows, wheel, 0.3, 1e8, tangential_ratio=0.3)
    U = np.zeros(rows.nodes.shape + (gdim,))
    U[..., -1] = -0.01 * np.exp(-(rows.x / 0.25) ** 2)
    U[..., 0] = 1e-4 * np.sin(rows.x * 7.0)
    friction.sweep(U, wheel.diameter / 2 - 0.015, 0.0, 0.99)
    K = friction.stiffness()
    st = friction._state
    st["hessian"] = np.zeros_like(st["hessian"])                      # the tangent frame held
    stick, contact = st["stick"] & st["contact"], st["contact"]
    nodes = [tuple(np.argwhere(stick)[0]), tuple(np.argwhere(stick)[-1]), tuple(np.argwhere(contact & ~stick)[0]),
             tuple(np.argwhere(contact & ~stick)[-1])]
    for r, j in nodes:
        for c in range(gdim):
            dU = np.zeros_like(U)
            dU[r, j, c] = 1.0
            assert friction.tangent(dU)[r, j] == pytest.approx(-K[r, j, :, c], rel=1e-10, abs=1e-10 * np.abs(K).max())
    assert np.abs(K[~contact]).max() == 0 and np.abs(K[contact]).max() > 0


@pytest.mark.serial
def test_stick_stiffness_regularises_the_friction_only():
    """The friction's stick stiffness (``tangential_ratio`` of the normal penalty) is a
    regularisation: the towed cylinder on the case-5 soil (plane strain, mu = 0.8, 4 mm) carries
    the same Q_V and Q_H with a tenth of the penalty as with all of it (the elastic slip it allows
    moves the free spin by less than 0.2 %, but moves it)."""
    soil = DruckerPrager(E=40e6, nu=0.35, phi_dp=math.radians(27.5), c_dp=194.6e3)
    window = RollingWindow(half_width=0.1524, ahead=0.61, behind=0.914, depth=0.61, cells_per_half_width=2)
    found = {}
    for ratio in (1.0, 0.1):
        st = SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, window), soil, wheel=Circle(diameter=1.524),
                           friction=0.8, unit_weight=20e3, tangential_ratio=ratio)
        st.solve_free_rolling(0.002)
        found[ratio] = st.solve_free_rolling(0.004)
    stiff, soft = found[1.0], found[0.1]
    assert soft.vertical_force == pytest.approx(stiff.vertical_force, rel=2e-3)
    assert soft.towing_force == pytest.approx(stiff.towing_force, rel=1e-2) and stiff.towing_force > 0
    assert 1e-5 < abs(soft.spin - stiff.spin) < 2e-3 * stiff.spin
    with pytest.raises(ValueError, match="tangential_ratio"):
        SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, window), soil, wheel=Circle(diameter=1.524), friction=0.8,
                      tangential_ratio=0.0)


def _slab_mesh(window: RollingWindow, width: float):
    """The plane-strain ``window`` extruded one cell ``width`` (m) across, in y."""
    nodes = [window.x_nodes(), np.array([0.0, width]), window.y_nodes()]
    counts = [len(n) - 1 for n in nodes]
    msh = dmesh.create_box(MPI.COMM_SELF, [np.zeros(3), np.array(counts, dtype=float)], counts,
                           dmesh.CellType.hexahedron)
    x = msh.geometry.x
    for axis, n in enumerate(nodes):
        x[:, axis] = np.interp(x[:, axis], np.arange(counts[axis] + 1), n)
    return msh


@pytest.mark.serial
def test_3d_slab_under_a_wide_roller_is_plane_strain():
    """A slab one cell across between rollers (u_y = 0 on both faces) under a roller wider than it
    is plane strain: the 3D solve (hexahedra, 2D Coulomb friction, the cylinder's distance)
    gives the forces per unit width of the plane-strain solve on the same cells: clay with
    gravity, plastic, a wheel with mu = 0.5 slipping at xi = 0.98."""
    window = RollingWindow(half_width=0.15, ahead=0.45, behind=0.6, depth=0.45, cells_per_half_width=2)
    width = 0.1
    solves = {}
    for name, msh, wheel in (("plane", rolling_window_mesh(MPI.COMM_SELF, window), Circle(ROLLER.diameter)),
                             ("slab", _slab_mesh(window, width), CylinderWheel(ROLLER.diameter, 1.0))):
        st = SteadyRolling(msh, CLAY_3D, wheel=wheel, unit_weight=20e3, friction=0.5)
        st.spin = 0.98
        solves[name] = st.solve_sinkage(0.0025)
    plane, slab = solves["plane"], solves["slab"]
    assert plane.max_accumulated_plastic_strain > 0.01 and plane.axle_torque > 0.05 * plane.vertical_force
    per_width = 1.0 / (2 * width)                 # the slab is half the wheel's width
    for key in ("vertical_force", "towing_force", "axle_torque"):
        assert getattr(slab, key) * per_width == pytest.approx(getattr(plane, key), rel=1e-7), key


@pytest.mark.serial
def test_3d_frictional_roller_rolls_free_on_elastic_soil():
    """The Mn/DOT roller with mu = 0.8 on elastic soil at 2.5 mm: the contact's towing force
    (pressure and friction) equals the window's horizontal balance; towed free (zero axle torque)
    nothing resists it (below 0.1 % of Q_V), while held at xi = 1 the friction does (measured:
    1.9 % of Q_V)."""
    st = SteadyRolling(rolling_window_mesh(MPI.COMM_SELF, WINDOW_3D), ELASTIC_3D, wheel=ROLLER, friction=0.8,
                       unit_weight=20e3)
    held = st.solve_sinkage(0.0025)
    assert st.horizontal_balance().towing_force == pytest.approx(held.towing_force, rel=1e-6)
    assert abs(held.towing_force) > 0.01 * held.vertical_force
    free = st.solve_free_rolling(0.0025)
    assert abs(free.axle_torque) <= 1e-6 * ROLLER.diameter / 2 * free.vertical_force
    assert abs(free.towing_force) < 1e-3 * free.vertical_force and free.spin < 1.0
    assert st.horizontal_balance().towing_force == pytest.approx(free.towing_force, abs=1e-6 * free.vertical_force)


@pytest.mark.end_to_end
def test_steady_scene_runs_end_to_end(comm, tmp_mpi_path):
    """``[model] rolling = "steady"`` through run_scene (constant load, the Mn/DOT roller lightly
    loaded (40 kN) on the case-5 soil, fast cells in a small window): the towed wheel carries the load, the sinkage steps
    up to it, the rut lies between zero and the sinkage, the spin is the free-rolling one (zero axle
    torque), and the run directory holds the profile, the picture, the fields and the report."""
    import csv
    import json

    from rollsim.scene import parse_scene
    from rollsim.solver.run import run_scene
    from rollsim.studies.report import run_report
    scene = parse_scene({"wheel": {"diameter": "1.524 m", "width": "0.4572 m", "friction": 0.8},
                         "soil": {"gamma": "20 kN/m^3", "layers": [{"model": "drucker-prager", "E": "40 MPa",
                                                                    "nu": 0.35, "phi_dp": "27.5 deg",
                                                                    "c_dp": "194.6 kPa"}]},
                         "loading": {"protocol": "rolling-constant-load", "load": "40 kN"},
                         "model": {"rolling": "steady", "accuracy": "fast"}})
    small = {"ahead": 0.25, "behind": 0.35, "depth": 0.25, "beside": 0.15}      # d; the scene's is larger
    summary = run_scene(scene, tmp_mpi_path, comm, progress=False, window=small)
    assert summary["status"] == "ok", summary["reason"]
    assert summary["rolling"] == "steady" and summary["ranks"] == comm.size
    assert summary["model"]["window_m"]["ahead"] == pytest.approx(0.25 * 1.524)
    assert summary["model"]["contact"]["tangential_ratio"] == DEFAULT_TANGENTIAL_RATIO
    assert summary["QV_N"] == pytest.approx(40e3, rel=1e-3)
    rows = list(csv.DictReader((tmp_mpi_path / "history.csv").open()))
    sinkages = [float(r["sinkage_m"]) for r in rows]
    assert len(rows) >= 2 and sinkages[-1] == pytest.approx(summary["sinkage_m"])
    assert all(float(r["travel_m"]) == 0.0 for r in rows)
    assert 0 < summary["rut_depth_m"] < summary["sinkage_m"]
    assert summary["rebound_m"] == pytest.approx(summary["sinkage_m"] - summary["rut_depth_m"])
    # lightly loaded: the surface leaves nearly where it came in, no warning of soil shoved ahead
    assert abs(summary["surface_forward_m"]) < summary["sinkage_m"]
    assert not any("shoves" in w for w in summary.get("warnings", []))
    assert abs(summary["axle_torque_Nm"]) <= 1e-4 * 0.762 * 40e3
    assert summary["QH_N"] > 0 and 0.9 < summary["spin"] < 1.1
    assert summary["rolling_radius_m"] == pytest.approx(0.762 / summary["spin"])
    assert 0 < summary["contact_length_m"] < 2 * summary["model"]["window_m"]["fine_half_length"]
    if comm.rank == 0:
        for name in ("rut_profile.csv", "rut.png", "force_sinkage.png", "fields/steady.xdmf"):
            assert (tmp_mpi_path / name).stat().st_size > 100, name
        assert json.loads((tmp_mpi_path / "summary.json").read_text())["rut_depth_m"] == summary["rut_depth_m"]
        profile = list(csv.DictReader((tmp_mpi_path / "rut_profile.csv").open()))
        assert float(profile[0]["settlement_m"]) == pytest.approx(summary["rut_depth_m"], rel=1e-5)
        assert float(profile[0]["forward_m"]) == pytest.approx(summary["surface_forward_m"], rel=1e-5)
        assert "## Steady rolling" in run_report(tmp_mpi_path).read_text()


@pytest.mark.end_to_end
def test_steady_force_sinkage_curve_end_to_end(comm, tmp_mpi_path):
    """rolling-continuous with ``rolling = "steady"`` (frictionless, coarse cells): ten steady
    states at equal steps to max_sinkage, Q_V rising with the sinkage, the last equal to a direct
    solve on the same window, and the force-sinkage plot."""
    import csv

    from rollsim.scene import parse_scene
    from rollsim.solver.drivers.steady_rolling import CURVE_POINTS, steady_window
    from rollsim.solver.run import run_scene
    scene = parse_scene({"wheel": {"diameter": "1.524 m", "width": "0.4572 m", "friction": 0.0},
                         "soil": {"gamma": "20 kN/m^3", "layers": [{"model": "von-mises", "E": "40 MPa", "nu": 0.35,
                                                                    "c_dp": "200 kPa"}]},
                         "loading": {"protocol": "rolling-continuous", "max_sinkage": "4 mm"},
                         "model": {"rolling": "steady", "refinement": 10}})
    small = {"ahead": 0.25, "behind": 0.35, "depth": 0.25, "beside": 0.15}
    summary = run_scene(scene, tmp_mpi_path, comm, progress=False, window=small)
    assert summary["status"] == "ok", summary["reason"]
    rows = list(csv.DictReader((tmp_mpi_path / "history.csv").open()))
    s = np.array([float(r["sinkage_m"]) for r in rows])
    qv = np.array([float(r["QV_N"]) for r in rows])
    assert len(rows) == CURVE_POINTS and s == pytest.approx(np.arange(1, 11) * 4e-4)
    assert np.all(np.diff(qv) > 0) and summary["spin"] == 1.0
    direct = SteadyRolling(rolling_window_mesh(comm, steady_window(scene, small)), VonMises(E=40e6, nu=0.35,
                                                                                         yield_stress=200e3),
                           wheel=CylinderWheel(1.524, 0.4572, 0.4572 / 12), unit_weight=20e3,
                           volumetric_strain=scene.model.volumetric_strain)
    for sinkage in s[:: 3]:
        last = direct.solve_sinkage(float(sinkage))
    last = direct.solve_sinkage(4e-3)
    assert last.vertical_force == pytest.approx(summary["QV_N"], rel=1e-6)
    assert comm.rank != 0 or (tmp_mpi_path / "force_sinkage.png").stat().st_size > 1000


@pytest.mark.end_to_end
def test_repeated_passes_of_the_towed_wheel(comm, tmp_mpi_path):
    """``loading.passes = 2`` (clay, frictionless, coarse cells, 40 kN): the second pass meets
    the soil the first left (its outflow state) and carries the load at a smaller sinkage, adding
    less rut; the total rut is their sum, and this clay ratchets (the second pass still adds over
    a quarter of the first's rut, measured 0.37).  With B-bar each pass reaches the load through the
    relaxation's limit (module steady_rolling), whose extrapolated sinkage the pass reports."""
    from rollsim.scene import parse_scene
    from rollsim.solver.drivers.steady_rolling import LOAD_RTOL
    from rollsim.solver.run import run_scene
    scene = parse_scene({"wheel": {"diameter": "1.524 m", "width": "0.4572 m", "friction": 0.0},
                         "soil": {"gamma": "20 kN/m^3", "layers": [{"model": "von-mises", "E": "40 MPa", "nu": 0.35,
                                                                    "c_dp": "200 kPa"}]},
                         "loading": {"protocol": "rolling-constant-load", "load": "40 kN", "passes": 2},
                         "model": {"rolling": "steady", "refinement": 10}})
    small = {"ahead": 0.25, "behind": 0.35, "depth": 0.25, "beside": 0.15}
    summary = run_scene(scene, tmp_mpi_path, comm, progress=False, window=small)
    assert summary["status"] == "ok", summary["reason"]
    passes = summary["passes"]
    assert [p["pass"] for p in passes] == [1, 2]
    assert all(abs(p["QV_N"] - 40e3) <= LOAD_RTOL * 40e3 for p in passes)
    sinkage, rut = [p["sinkage_m"] for p in passes], [p["rut_m"] for p in passes]
    assert sinkage[0] > sinkage[1] > 0 and rut[0] > rut[1] > 0.25 * rut[0]
    assert passes[-1]["total_rut_m"] == pytest.approx(sum(rut), rel=1e-12)
    assert summary["sinkage_m"] == pytest.approx(sinkage[-1])
    limit = summary["relaxation_limit"]
    assert limit["converged"] and passes[-1]["relaxed_sinkage_m"] == limit["levels"][-1]["sinkage_m"]
    assert abs(limit["correction_m"]) <= limit["rtol"] * passes[-1]["relaxed_sinkage_m"]
    assert summary["rut_depth_m"] == pytest.approx(passes[-1]["total_rut_m"])
    assert summary["shakedown"]["regime"] == "ratchetting"
    assert summary["shakedown"]["last_over_first_rut"] == pytest.approx(rut[1] / rut[0])


def test_constant_load_steps_aim_at_the_load_and_halve_a_failed_step():
    """The constant-load driver's sinkage steps on a Q_V(s) that bends over (Q_V ~ sqrt(s)): near
    the load each step aims LOAD_OVERSHOOT times past the secant's sinkage, so the state that
    passes the load lies within 10 % of its sinkage (growing steps alone: 30 % past it); a step
    whose steady state is not found is tried again from the last state at half its length, and
    a failure after STEP_CUTS halvings ends the run."""
    from types import SimpleNamespace

    from rollsim.solver.drivers import steady_rolling as drv
    from rollsim.solver.steady import NoSteadyState
    d, load = 1.0, 1.0e3
    target = (load / 1.0e4) ** 2                     # Q_V = 1e4 sqrt(s): 0.01 m carries the load

    def driver(fails_beyond=None, cuts=0):
        tried, states, restarts = [], {}, []

        def solve(s):
            tried.append(s)
            last = max(states, default=0.0)
            if fails_beyond is not None and s > fails_beyond and s - last > 0.6e-3 and len(restarts) < cuts + 1:
                raise NoSteadyState("stalled")
            states[s] = (None, 1.0, 1.0e4 * s ** 0.5)
            return SimpleNamespace(sinkage=s, vertical_force=states[s][2])
        steady = SimpleNamespace(continue_from=lambda known, s: restarts.append((dict(known), s)),
                                 solve_load=lambda *a, **k: SimpleNamespace(sinkage=target, vertical_force=load))
        scene = SimpleNamespace(wheel=SimpleNamespace(diameter=d), loading=SimpleNamespace(load=load))
        drv._constant_load(steady, scene, solve, states, None)
        return tried, restarts

    tried, restarts = driver()
    assert not restarts and tried[-1] >= target and tried[-2] < target
    assert tried[-1] < 1.1 * target
    growing = np.cumsum(drv.FIRST_STEP * d * np.minimum(1.5 ** np.arange(20), drv.MAX_STEP / drv.FIRST_STEP))
    assert growing[np.argmax(growing >= target)] > 1.3 * target
    tried, restarts = driver(fails_beyond=0.005)
    (known, failed), = restarts
    k = tried.index(failed)
    assert max(known) == tried[k - 1] and tried[k + 1] - tried[k - 1] == pytest.approx(0.5 * (failed - tried[k - 1]))
    assert tried[-1] >= target
    with pytest.raises(NoSteadyState, match="stalled"):
        driver(fails_beyond=0.005, cuts=drv.STEP_CUTS)


def test_regimes_of_repeated_passes():
    """The regime of several passes from what the last adds against the first."""
    from rollsim.solver.drivers.steady_rolling import _passes_summary

    def regime(rut, plastic):
        rows = [{"rut_m": 1e-3, "added_plastic_strain": 0.1}, {"rut_m": rut, "added_plastic_strain": plastic}]
        return _passes_summary(rows)["shakedown"]["regime"]
    assert regime(1e-6, 1e-4) == "elastic shakedown"
    assert regime(1e-5, 0.05) == "cyclic plasticity"
    assert regime(3e-4, 0.05) == "ratchetting"
    assert "shakedown" not in _passes_summary([{"rut_m": 1e-3, "added_plastic_strain": 0.1}])


def test_relaxation_limit_extrapolates_the_halved_lengths():
    """The route to a rate-independent steady state through relaxed ones: the load reached with
    the soil relaxed by RELAXATION_START station spacings, then the length halved at the load
    until the extrapolation through the last three levels moves the last by at most
    RELAXATION_RTOL at an order the three before agree with.  On a sinkage first order in the
    length, s(L) = s0 - a L, the extrapolation is exact and stops at the first level whose
    correction is within the tolerance; it is exact
    at second order on uneven lengths too; a series whose changes grow or change sign is not
    extrapolated, one that falls slowly gives its order; where a halved length's state is not found, a milder reduction
    from the last state, and where none is found the series ends with the levels so far."""
    from types import SimpleNamespace

    from rollsim.solver.drivers import steady_rolling as drv
    from rollsim.solver.steady import NoSteadyState
    s0, a, spacing, load = 0.02, 0.5, 0.04, 1.0e5

    def limit(fails=lambda length: False):
        def solve_load(load_, inflow, **kwargs):
            if fails(steady.relaxation_length):
                raise NoSteadyState("stalled")
            return SimpleNamespace(sinkage=s0 - a * steady.relaxation_length, vertical_force=load_,
                                   towing_force=0.0, newton_iterations=1)
        steady = SimpleNamespace(station_spacing=spacing, relaxation_length=0.0, solve_load=solve_load,
                                 continue_from=lambda states, s: None, comm=MPI.COMM_SELF, spin=1.0,
                                 u=SimpleNamespace(x=SimpleNamespace(array=np.zeros(2))), residual=lambda inflow: None,
                                 restore=lambda u, spin, sinkage: None)
        scene = SimpleNamespace(wheel=SimpleNamespace(diameter=1.0), loading=SimpleNamespace(load=load))
        constant = drv._constant_load
        drv._constant_load = lambda st, sc, solve, states, inflow, rtol=None: solve_load(load, inflow)
        try:
            return drv._relaxation_limit(steady, scene, None, {}, None, lambda res: res, False)
        finally:
            drv._constant_load = constant

    res, lim = limit()
    lengths = [level["relaxation_length_m"] for level in lim["levels"]]
    assert lengths[0] == drv.RELAXATION_START * spacing
    assert lengths == pytest.approx(lengths[0] * 0.5 ** np.arange(len(lengths)))
    assert lim["converged"] and lim["sinkage_m"] == pytest.approx(s0, rel=1e-12) and lim["order"] == pytest.approx(1.0)
    # stops at the first level whose correction (= its change, first order) is within the tolerance
    sinkages = [level["sinkage_m"] for level in lim["levels"]]
    assert len(lengths) > 3 and lim["correction_m"] == pytest.approx(a * lengths[-1])
    assert a * lengths[-1] <= drv.RELAXATION_RTOL * sinkages[-1] and a * lengths[-2] > drv.RELAXATION_RTOL * sinkages[-2]
    L = [4.0, 2.0, 1.0]
    assert drv.relaxation_extrapolation(list(zip(L, [1.0, 1.1, 1.3]))) is None        # changes grow
    assert drv.relaxation_extrapolation(list(zip(L, [1.0, 1.1, 1.05]))) is None       # change of sign
    assert drv.relaxation_extrapolation(list(zip(L, [1.0, 1.1, 1.19])))[2] == pytest.approx(np.log2(1 / 0.9))
    assert drv.relaxation_extrapolation([(2.0, 1.0), (1.0, 1.0 + 1e-5)]) == (1.0 + 1e-5, 0.0, np.inf)
    second = [1.0 - 0.01 * x ** 2 for x in (3.0, 2.0, 1.4)]                         # uneven, second order
    assert drv.relaxation_extrapolation(list(zip([3.0, 2.0, 1.4], second)))[0] == pytest.approx(1.0, rel=1e-9)
    # the towed roller's series (d/10, pointwise, mm): after two equal changes a small one meets the
    # tolerance but does not certify; two changes falling at one order do, within 0.1 % of the
    # rate-independent 15.436 mm
    measured = [(8.59, 13.662), (4.29, 14.198), (2.15, 14.752), (1.07, 14.909), (0.537, 15.142), (0.268, 15.280),
                (0.134, 15.352)]
    assert abs(drv.relaxation_extrapolation(measured[:4])[1]) <= drv.RELAXATION_RTOL * measured[3][1]
    assert not any(drv.relaxation_certified(measured[:n])[1] for n in range(2, len(measured)))
    (value, _, _), certified = drv.relaxation_certified(measured)
    assert certified and value == pytest.approx(15.436, rel=1e-3)
    # a halving whose state is not found: the milder reductions from the last state
    res, lim = limit(fails=lambda length: length == lengths[2] / 2)
    got = [level["relaxation_length_m"] for level in lim["levels"]]
    assert got[:3] == lengths[:3] and got[3] == pytest.approx(lengths[2] * 2 ** -0.5)
    assert lim["converged"] and lim["sinkage_m"] == pytest.approx(s0, rel=1e-9)
    # none found: the levels so far
    res, lim = limit(fails=lambda length: length < lengths[2] * 0.9)
    assert not lim["converged"] and len(lim["levels"]) == 3 and "stalled" in lim["reason"]
    assert res.sinkage == lim["levels"][-1]["sinkage_m"]


def test_constant_load_route_to_the_rate_independent_state():
    """Which way the constant-load driver reaches the load: a relaxed scene stays relaxed; a
    pointwise soil steps up rate-independent and takes the relaxation's limit only where a step
    is not found (not where the wheel ploughs on); B-bar takes the limit at once."""
    from types import SimpleNamespace

    from rollsim.solver.drivers import steady_rolling as drv
    from rollsim.solver.steady import NoSteadyState

    def route(strain, relaxation=0.0, fails=None):
        taken = []

        def constant_load(steady, scene, solve, states, inflow, rtol=None):
            taken.append(("steps", steady.relaxation_length))
            if fails is not None:
                raise fails
            return "state"
        steady = SimpleNamespace(volumetric_strain=strain, relaxation_length=123.0, comm=MPI.COMM_SELF)
        scene = SimpleNamespace(model=SimpleNamespace(relaxation_length=relaxation))
        saved = drv._constant_load, drv._relaxation_limit
        drv._constant_load = constant_load
        drv._relaxation_limit = lambda *args: (taken.append(("limit",)), ("limit state", {}))[1]
        try:
            return drv._at_load(steady, scene, None, {}, None, None, False), taken
        finally:
            drv._constant_load, drv._relaxation_limit = saved

    assert route("pointwise") == (("state", None), [("steps", 0.0)])
    assert route("cell-average", relaxation=0.002) == (("state", None), [("steps", 0.002)])
    assert route("cell-average") == (("limit state", {}), [("limit",)])
    assert route("pointwise", fails=NoSteadyState("stalled"))[1] == [("steps", 0.0), ("limit",)]
    with pytest.raises(drv.WheelPloughs):
        route("pointwise", fails=drv.WheelPloughs("ploughs"))
