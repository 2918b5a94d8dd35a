"""Rigid-wheel contact (solver/contact.py): exact surfaces, Hertz, penalty accuracy, Coulomb friction.

Plane-strain checks on a symmetric half block (cheap); the 3D checks are in test_indentation.py.
Full-resolution variants and the penalty sweep: `python -m benchmarks contact hertz`.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import assert_all
import ufl
from dolfinx import fem
from mpi4py import MPI

from rollsim import compat
from rollsim.geometry import CylinderWheel, MeshOptions, PlaneStrainBlock, TorusWheel, build_plane_strain_block
from rollsim.solver import PlasticityProblem, StepControl, VonMises, solve_load_path
from rollsim.solver.contact import Circle, RigidWheelContact, ufl_signed_distance

R, E, NU = 0.5, 10e6, 0.3


# ------------------------------------------------------------------ exact surfaces
@pytest.mark.parametrize("wheel", [CylinderWheel(1.0, 0.4, 0.05), CylinderWheel(1.0, 0.4, 0.0), TorusWheel(1.0, 0.3)],
                         ids=["cylinder-fillet", "cylinder-sharp", "torus"])
def test_ufl_gap_equals_geometry_signed_distance(comm, wheel):
    """The UFL gap/normal used in the residual = rollsim.geometry's numpy signed_distance."""
    from dolfinx import mesh as dmesh
    msh = dmesh.create_box(comm, [np.array([-0.7, -0.4, -0.7]), np.array([0.7, 0.4, 0.7])], [5, 4, 5])
    x = ufl.SpatialCoordinate(msh)
    g, n = ufl_signed_distance(wheel, x)
    pts_ref = np.array([[0.1, 0.2, 0.3], [0.25, 0.25, 0.25], [0.6, 0.1, 0.2], [0.05, 0.7, 0.1]])
    X = compat.evaluate(compat.expression(x, pts_ref), msh).reshape(-1, 3)
    G = compat.evaluate(compat.expression(g, pts_ref), msh).reshape(-1)
    N = compat.evaluate(compat.expression(n, pts_ref), msh).reshape(-1, 3)
    keep = np.hypot(X[:, 0], X[:, 2]) > 1e-9        # the axle itself is a convention
    d_ref, n_ref = wheel.signed_distance(X[keep])
    assert np.abs(G[keep] - d_ref).max() < 1e-12
    assert np.abs(N[keep] - n_ref).max() < 1e-10


def test_circle_signed_distance():
    c = Circle(2.0)
    d, n = c.signed_distance(np.array([[0.0, -2.0], [3.0, 4.0]]))
    assert np.allclose(d, [1.0, 4.0]) and np.allclose(n, [[0, -1], [0.6, 0.8]])


# ------------------------------------------------------------------ plane-strain cylinder
def _block(comm, fine):
    blk = PlaneStrainBlock(half_width=1.0, depth=1.0, contact_half_width=0.1, refined_half_width=0.1,
                           refined_depth=0.1, symmetric=True)
    return build_plane_strain_block(comm, blk, MeshOptions(fine, 20 * fine, 0.3))


def _cylinder_problem(tm, *, penalty, friction=0.0, symmetric=True, material=None):
    msh = tm.mesh
    pb = PlasticityProblem(msh, material or VonMises(E=E, nu=NU, yield_stress=1e12))
    V = pb.V
    bcs = []
    for name, comp in (("symmetry_x", 0), ("side", 0), ("bottom", 1), ("bottom", 0)):
        if name in tm.facet_names and (symmetric or name != "symmetry_x"):
            f = tm.facet_tags.find(tm.facet_names[name])
            bcs.append(fem.dirichletbc(0.0, fem.locate_dofs_topological(V.sub(comp), 1, f), V.sub(comp)))
    pb.bcs = bcs
    ct = RigidWheelContact(pb, Circle(2 * R), tm.facet_tags, (1, 2), friction=friction, penalty=penalty,
                           centre=[0.0, R])
    return pb, ct


def _hertz_run(comm, fine, penalty, delta=0.006):
    tm = _block(comm, fine)
    pb, ct = _cylinder_problem(tm, penalty=penalty)
    solve_load_path(pb, lambda t: ct.set_pose(centre=[0.0, R - delta * t]), StepControl(dt=0.5, dt_max=0.5))
    F = ct.forces()
    P = 2 * F.vertical                                   # force per unit length, both halves
    X = ufl.SpatialCoordinate(tm.mesh)
    M0 = comm.allreduce(fem.assemble_scalar(fem.form(ct.pressure * ct.ds)))
    M2 = comm.allreduce(fem.assemble_scalar(fem.form(X[0] ** 2 * ct.pressure * ct.ds)))
    Es = E / (1 - NU ** 2)
    a_h = math.sqrt(4 * R * P / (math.pi * Es))
    p0_h = 2 * P / (math.pi * a_h)
    return {"P": P, "a": 2 * math.sqrt(M2 / M0), "a_hertz": a_h, "p0": ct.kappa * F.max_penetration,
            "p0_hertz": p0_h, "pen": F.max_penetration, "h": ct.h, "M0": 2 * M0}


def test_hertz_cylinder_plane_strain(comm):
    """Rigid cylinder (R = 0.5 m) on an elastic block 1 m deep, contact half-width a ~ 0.04 m:
    a (from the second moment of the pressure: a^2 = 4 int x^2 p / int p for Hertz) and the peak
    pressure p0 match Hertz, a = sqrt(4 R P'/(pi E*)), p0 = 2P'/(pi a), within 2 %.  The measured
    deviation (+0.8 % / -0.8 %) is the finite block (depth 25 a: the same with half the element
    size), not the mesh (h = a/8) or the penalty (alpha = 100: 0.1 % from alpha = 1e4)."""
    r = _hertz_run(comm, 0.005, penalty=100)
    assert abs(r["a"] / r["a_hertz"] - 1) < 0.02, r
    assert abs(r["p0"] / r["p0_hertz"] - 1) < 0.02, r
    assert abs(r["M0"] / r["P"] - 1) < 1e-3          # pressure integral = resultant (no friction)
    # a soft penalty is measurably wrong: alpha = 1 overestimates a by > 4 %
    soft = _hertz_run(comm, 0.005, penalty=1)
    assert soft["a"] / soft["a_hertz"] - 1 > 0.04, soft
    # penetration ~ p0 h / (alpha E)
    assert 0.3 < r["pen"] / (r["p0"] * r["h"] / (100 * E)) < 3


def _press(comm, mu, delta=0.004):
    pb, ct = _cylinder_problem(build_full_block(comm), penalty=100, friction=mu, symmetric=False)
    solve_load_path(pb, lambda t: ct.set_pose(centre=[0.0, R - delta * t]), StepControl(dt=0.5, dt_max=0.5))
    return pb, ct


@pytest.fixture(scope="session")
def pressed(comm):
    """The cylinder pressed as :func:`_press` (mu = 0.3, 4 mm) once per session (not per module:
    conftest deals the long tests out of file order, which would tear a module fixture down in
    between): a callable that puts the problem back into the pressed state (the converged
    displacement, stresses, friction history and pose) and returns it."""
    pb, ct = _press(comm, 0.3, 0.004)
    fields = (pb.u_n, pb.sigma_n, pb.eps_p)
    saved = ([f.x.array.copy() for f in fields], ct._t_n_saved.copy(), ct.pose)

    def fresh():
        arrays, t_n, (centre, angle) = saved
        for f, a in zip(fields, arrays):
            f.x.array[:] = a
        ct._t_n_saved = t_n.copy()
        ct.centre_n.value, ct.angle_n.value = centre.copy(), angle
        ct.set_pose(centre=centre, angle=angle)
        ct._committed = None
        pb.restore()                     # u, stresses and friction history from the converged state
        return pb, ct
    return fresh


@pytest.mark.parametrize("motion", ["slide", pytest.param("roll", marks=pytest.mark.slow), "roll-backwards"])
def test_coulomb_friction_sliding_and_rolling(pressed, motion):
    """Press the cylinder (elastic soil), then move it sideways by dx = 10 mm, 25 elastic-slip
    lengths: sliding (no rotation) makes every contact point slip, so the drag is Q_H = mu Q_V
    (the normal pressure's horizontal resultant is ~1 % here); rolling without slip (rotation
    dx/R) mobilises little friction; rotating the wrong way slides at twice the speed: mu Q_V again.
    The pose's rotation therefore enters the slip with the right sign.

    The press is solved once per module (fixture ``pressed``; a motion started from its restored
    state repeats the fresh run's iterations and forces exactly).  The roll goes dx = 1 mm only (2.5 elastic-slip lengths; a missing or wrong-signed rotation
    would slip 1-2 mm there): rolling, Newton converges in steps of about 15 um only (stick and
    slip meet all over the contact), and 10 mm took 5 min.  Measured |Q_H| / (mu Q_V): 0.0073
    after 1 mm, 0.016 after 2 mm (growing about linearly with the travel; bound 0.2)."""
    mu, delta = 0.3, 0.004
    dx = 0.001 if motion == "roll" else 0.01
    pb, ct = pressed()
    rate = {"slide": 0.0, "roll": 1.0, "roll-backwards": -1.0}[motion] / R
    solve_load_path(pb, lambda t: ct.set_pose(centre=[dx * t, R - delta], angle=rate * dx * t),
                    StepControl(dt=0.25, dt_max=0.25))
    F = ct.forces()
    assert F.vertical > 0
    ratio = F.horizontal / (mu * F.vertical)
    if motion == "roll":
        assert abs(ratio) < 0.2, ratio
    else:
        assert abs(ratio - 1) < 0.03, ratio       # friction opposes the motion (+x): force on wheel -x


def build_full_block(comm):
    blk = PlaneStrainBlock(half_width=1.0, depth=1.0, contact_half_width=0.1, refined_half_width=0.12,
                           refined_depth=0.1, symmetric=False)
    return build_plane_strain_block(comm, blk, MeshOptions(0.01, 0.2, 0.3))


def test_contact_history_committed_only_on_convergence(comm):
    """A rejected iterate leaves the friction history and the committed pose unchanged."""
    full = build_full_block(comm)
    pb, ct = _cylinder_problem(full, penalty=100, friction=0.5, symmetric=False)
    solve_load_path(pb, lambda t: ct.set_pose(centre=[0.0, R - 0.003 * t]), StepControl(dt=1.0, dt_max=1.0))
    solve_load_path(pb, lambda t: ct.set_pose(centre=[0.002 * t, R - 0.003]), StepControl(dt=1.0, dt_max=1.0))
    t_saved = ct.t_n.x.array.copy()
    c_saved = np.array(ct.centre_n.value)
    # global: a rank may own none of the contact facets (the partition varies between runs); a
    # rank-local assert failed on rank 0 alone and left rank 1 waiting in solve_increment
    assert comm.allreduce(np.abs(t_saved).max(initial=0.0), op=MPI.MAX) > 0
    ct.set_pose(centre=[0.05, R - 0.003])
    pb.solve_increment()
    pb.restore()
    assert_all(comm, np.array_equal(ct.t_n.x.array, t_saved), "friction history restored")
    assert np.array_equal(np.array(ct.centre_n.value), c_saved)
