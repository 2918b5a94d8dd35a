"""Steady rolling in the load's frame (rollsim.solver.steady): a Hertz line pressure on von Mises
soil in plane strain, against the static elastic solution, first yield (K. L. Johnson, Contact
Mechanics, ch. 6), the shakedown limit (ch. 9) and mesh convergence."""
from __future__ import annotations

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem, mesh as dmesh
from mpi4py import MPI

from rollsim.solver import VonMises
from rollsim.solver.problem import mandel_strain
from rollsim.solver.return_map import elastic_stiffness, invariants
from rollsim.solver.steady import (NoSteadyState, RollingWindow, SteadyRolling, rolling_window_mesh)

K = 1.0                                  # shear yield stress k (Pa)
SOIL = VonMises(E=1000.0, nu=0.3, yield_stress=math.sqrt(3.0) * K)
NEVER_YIELDS = VonMises(E=1000.0, nu=0.3, yield_stress=1e12)
#: the window of the plastic checks: the state 10 a behind the load has settled
WINDOW = RollingWindow(half_width=1.0, ahead=6.0, behind=10.0, depth=10.0, cells_per_half_width=4)


def steady(window: RollingWindow, material, **kwargs) -> SteadyRolling:
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
def test_no_steady_state_beyond_the_plastic_limit():
    """At p0 = 6 k the load ploughs: the solver says so instead of returning a state."""
    window = RollingWindow(half_width=1.0, ahead=6.0, behind=10.0, depth=10.0, cells_per_half_width=2)
    with pytest.raises(NoSteadyState, match="no steady state under the peak pressure 6 Pa"):
        steady(window, SOIL).solve(6.0 * K)


def test_steady_rolling_is_serial_for_now(comm):
    """On more than one rank the solver refuses (its streamlines would cross ranks)."""
    window = RollingWindow(half_width=1.0, ahead=2.0, behind=2.0, depth=2.0, cells_per_half_width=1)
    msh = rolling_window_mesh(comm, window)
    if comm.size > 1:
        with pytest.raises(NotImplementedError, match="one rank"):
            SteadyRolling(msh, SOIL, 1.0)
    else:
        assert SteadyRolling(msh, SOIL, 1.0).streamline_depths.shape == (3 * len(window.y_nodes()) - 3,)
