"""Contact of two deformable bodies (solver/contact_pair.py): consistent tangent, Hertz with the
combined modulus, mesh convergence of the pressure, the contact patch test.

Plane strain: an elastic cylinder (R = 0.5 m, E = 20 MPa) pressed on an elastic block
(E = 10 MPa), both nu = 0.3, quarter model.  3D: a sphere of the same radius and materials on
a block, and a block on a block (quarter models).  The sweep over penalty factors and element
sizes, with either surface as the slave: `python -m benchmarks contact pair`.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import assert_all
from dolfinx import fem
from petsc4py import PETSc

from rollsim import compat
from rollsim.geometry import MeshOptions
from rollsim.geometry.pair import (PAIR_CELL_TAGS, CylinderOnBlock, SphereOnBlock, build_block_on_block,
                                   build_cylinder_on_block, build_sphere_on_block)
from rollsim.solver import NeoHookean, PlasticityProblem, StepControl, VonMises, solve_load_path
from rollsim.solver.contact_pair import FacetContact

E_CYLINDER, E_BLOCK, NU = 20e6, 10e6, 0.3
PUSH = 0.010           # m: the cylinder's cut moves down by this after closing the gap


def _pair(comm, fine: float, penalty: float, slave: str = "top", friction: float = 0.0, symmetric: bool = True,
          cylinder=None):
    """The cylinder-on-block problem, its contact and the Dirichlet values of the cylinder's cut:
    (push down, move along x), m.  ``cylinder``: its material (default: small-strain elastic)."""
    pair = CylinderOnBlock(symmetric=symmetric)
    tm = build_cylinder_on_block(comm, pair, MeshOptions(fine, 20 * fine, 0.3, order=2))
    elastic = {PAIR_CELL_TAGS["block"]: VonMises(E=E_BLOCK, nu=NU, yield_stress=1e12),
               PAIR_CELL_TAGS["cylinder"]: cylinder or VonMises(E=E_CYLINDER, nu=NU, yield_stress=1e12)}
    pb = PlasticityProblem(tm.mesh, elastic, cell_tags=tm.cell_tags)
    V, names = pb.V, tm.facet_names
    push, move = fem.Constant(tm.mesh, 0.0), fem.Constant(tm.mesh, 0.0)

    def held(name, axis, value=0.0):
        Vi = V.sub(axis)
        return fem.dirichletbc(value, fem.locate_dofs_topological(Vi, 1, tm.facet_tags.find(names[name])), Vi)

    pb.bcs = [held("bottom", 0), held("bottom", 1), held("side", 0), held("load", 1, push)]
    pb.bcs += [held("symmetry_x", 0)] if symmetric else [held("load", 0, move)]
    master = "rim" if slave == "top" else "top"
    ct = FacetContact(pb, tm.facet_tags, (names[slave],), (names[master],), penalty=penalty, friction=friction)
    return pair, pb, ct, (push, move)


def hertz_pair_run(comm, fine: float, penalty: float, slave: str = "top", cylinder=None) -> dict:
    """Press the cylinder by PUSH; the contact half-width a (from the pressure's second moment,
    a^2 = 4 int x^2 p / int p for Hertz), the peak pressure p0 and the pressure's L2 distance
    from Hertz's ellipse, against Hertz with 1/E* = (1 - nu1^2)/E1 + (1 - nu2^2)/E2."""
    pair, pb, ct, (push, _) = _pair(comm, fine, penalty, slave, cylinder=cylinder)

    def lower(t):
        push.value = -(pair.gap + PUSH) * t

    records = solve_load_path(pb, lower, StepControl(dt=0.25, dt_max=0.25))
    F = ct.forces()
    P = 2 * abs(F.force[1])                               # N/m, both halves
    E_star = 1 / ((1 - NU ** 2) / E_CYLINDER + (1 - NU ** 2) / E_BLOCK)
    a_h = math.sqrt(4 * pair.radius * P / (math.pi * E_star))
    p0_h = 2 * P / (math.pi * a_h)
    X, w, p = ct.pressures()
    x = X[:, 0]
    hertz = p0_h * np.sqrt(np.maximum(0.0, 1 - (x / a_h) ** 2))
    l2 = math.sqrt(comm.allreduce(float(w @ (p - hertz) ** 2)) / comm.allreduce(float(w @ hertz ** 2)))
    return {"P": P, "a": 2 * math.sqrt(F.M2 / F.M0), "a_hertz": a_h, "p0": F.max_pressure, "p0_hertz": p0_h,
            "l2": l2, "resultant": 2 * F.M0, "penetration": F.max_penetration, "h": ct.h,
            "newton_iterations": sum(r.iterations for r in records), "steps": len(records), "dofs": pb.n_dofs}


@pytest.mark.parametrize("field, value", [("radius", 0.0), ("gap", -1e-3), ("zone", 0.6)])
def test_cylinder_on_block_names_a_bad_dimension(field, value):
    with pytest.raises(ValueError, match=field):
        CylinderOnBlock(**{field: value})


def test_a_failure_on_one_rank_is_raised_on_every_rank(comm):
    """The pair's local work runs inside the residual's assembly, a collective: an error on one
    rank must reach every rank, or the others would wait in the assembly for ever."""
    _, _, ct, _ = _pair(comm, 0.02, penalty=10.0)

    def local_work(x):
        if comm.rank == comm.size - 1:
            raise ZeroDivisionError("on the last rank")
        return len(x)

    with pytest.raises((ZeroDivisionError, RuntimeError), match="rank"):
        ct._on_every_rank(local_work)


def _tangent_mismatch(comm, pb, ct) -> tuple[float, float]:
    """|J d - (F(u + eps d) - F(u - eps d)) / 2 eps| and |J d| of the pair's assembled tangent J
    and forces F at the current iterate, for a random direction d off the Dirichlet dofs (the pair
    leaves Dirichlet rows and columns out by design)."""
    u = compat.petsc_vector(pb.u)
    rng = np.random.default_rng(7 + comm.rank)
    direction = u.duplicate()
    direction.array[:] = rng.uniform(-1, 1, direction.getLocalSize())
    for bc in pb.bcs:
        held = bc.dof_indices()[0]
        direction.array[held[held < direction.getLocalSize()]] = 0.0
    direction.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)
    base = u.copy()

    def at(eps):
        base.copy(u)
        u.axpy(eps, direction)
        u.ghostUpdate(addv=PETSc.InsertMode.INSERT, mode=PETSc.ScatterMode.FORWARD)

    def forces(eps):
        at(eps)
        b = u.duplicate()
        b.set(0.0)
        ct.add_residual(b)
        return b

    A = pb._A.duplicate()
    A.zeroEntries()
    at(0.0)
    ct.add_jacobian(A)
    A.assemble()
    Jd = u.duplicate()
    A.mult(direction, Jd)
    eps = 1e-9
    fd = forces(eps)
    fd.axpy(-1.0, forces(-eps))
    fd.scale(1 / (2 * eps))
    at(0.0)
    fd.axpy(-1.0, Jd)
    return fd.norm(), Jd.norm()


def _sticking_and_slipping(comm, ct, friction) -> None:
    """Both kinds of points are in contact now (the friction traction at and below mu p)."""
    _, _, _, t_T = ct._evaluate(*ct._pairs())
    t = comm.allgather(np.linalg.norm(t_T, axis=1) / (friction * ct.pressures()[2]))
    assert_all(comm, True)
    t = np.concatenate(t)
    assert (t > 1 - 1e-9).any() and (t < 0.99).any(), "expected both slipping and sticking points"


@pytest.mark.parametrize("friction", [0.0, 0.3], ids=["frictionless", "coulomb"])
def test_pair_tangent_is_the_derivative_of_the_forces(comm, friction):
    """The assembled contact tangent (complex step, per pair) times a direction equals the central
    difference of the assembled contact forces along it, to 1e-6 (in contact, with the normal
    rotating: the block's surface is dented; with friction after a sideways move that leaves
    points sticking and slipping)."""
    pair, pb, ct, (push, move) = _pair(comm, 0.02, penalty=10.0, slave="rim", friction=friction, symmetric=False)
    solve_load_path(pb, lambda t: setattr(push, "value", -(pair.gap + PUSH) * t), StepControl(dt=0.25, dt_max=0.25))
    solve_load_path(pb, lambda t: setattr(move, "value", 0.4e-3 * t), StepControl(dt=0.5, dt_max=0.5))
    move.value = 0.5e-3                 # not committed: slipping points are off the slip limit
    assert pb.solve_increment().converged
    if friction:
        _sticking_and_slipping(comm, ct, friction)
    mismatch, scale = _tangent_mismatch(comm, pb, ct)
    assert scale > 0 and mismatch <= 1e-6 * scale, (mismatch, scale)


@pytest.mark.parametrize("slave", ["top", "rim"])
def test_whole_cylinder_touches_down_on_either_slave(comm, slave):
    """The whole cylinder first touches the block at one point, a vertex of the master surface
    when that is the rim: the master's normal turns continuously there, so Newton presses it
    down without stalling (the steps are cut no more than once); the contact force is vertical
    (|Q_H| < 1e-3 Q_V by symmetry)."""
    pair, pb, ct, (push, _) = _pair(comm, 0.01, penalty=10.0, slave=slave, symmetric=False)
    records = solve_load_path(pb, lambda t: setattr(push, "value", -(pair.gap + PUSH) * t),
                              StepControl(dt=0.25, dt_max=0.25))
    F = ct.forces()
    assert len(records) <= 8 and abs(F.force[0]) < 1e-3 * abs(F.force[1]), (len(records), F.force)


def test_coulomb_sliding_drags_mu_times_the_load(comm):
    """Pressed, then moved sideways: by 1 mm the block's surface follows the cylinder in most of the
    patch (Q_H < mu Q_V); by 10 mm every point slips, so the cylinder is dragged by Q_H = mu Q_V
    (within 2 %: the contact tangents are tilted by the dent)."""
    mu = 0.3
    pair, pb, ct, (push, move) = _pair(comm, 0.01, penalty=10.0, slave="rim", friction=mu, symmetric=False)
    solve_load_path(pb, lambda t: setattr(push, "value", -(pair.gap + PUSH) * t), StepControl(dt=0.5, dt_max=0.5))
    readings = []
    for start, end in ((0.0, 1e-3), (1e-3, 10e-3)):
        solve_load_path(pb, lambda t, a=start, b=end: setattr(move, "value", a + (b - a) * t),
                        StepControl(dt=0.25, dt_max=0.25))
        F = ct.forces()
        readings.append(abs(F.force[0]) / (mu * abs(F.force[1])))
    assert readings[0] < 0.95, readings
    assert abs(readings[1] - 1) < 0.02, readings


@pytest.mark.slow
def test_two_body_hertz(comm):
    """Both bodies deform: the half-width a and the peak pressure p0 match Hertz with the combined
    modulus within 3 % (Hertz for a rigid cylinder, or a rigid block, gives an a 18 % / 42 %
    smaller); the pressure integrates to the contact force; its L2 distance from Hertz's ellipse
    falls with the element size (h = 10 mm -> 5 mm; a ~ 0.054 m)."""
    coarse = hertz_pair_run(comm, 0.01, penalty=10.0)
    fine = hertz_pair_run(comm, 0.005, penalty=10.0)
    for r in (coarse, fine):
        assert abs(r["a"] / r["a_hertz"] - 1) < 0.03, r
        assert abs(r["p0"] / r["p0_hertz"] - 1) < 0.03, r
        assert abs(r["resultant"] / r["P"] - 1) < 2e-3, r
    assert fine["l2"] < 0.06 and fine["l2"] < 0.75 * coarse["l2"], (coarse["l2"], fine["l2"])
    assert_all(comm, True)


def test_neo_hookean_cylinder_reads_hertz_as_the_small_strain_one(comm):
    """The cylinder as a finite-strain (neo-Hookean) body in one system with the block: its
    contact half-width and peak pressure are those of the small-strain cylinder within 1 % (the
    strains are a few per cent) and Hertz's within 3 %; the Newton iterations stay as few."""
    small = hertz_pair_run(comm, 0.01, penalty=10.0)
    finite = hertz_pair_run(comm, 0.01, penalty=10.0, cylinder=NeoHookean(E_CYLINDER, NU))
    for key in ("a", "p0", "P"):
        assert abs(finite[key] / small[key] - 1) < 0.01, (key, small[key], finite[key])
    assert abs(finite["a"] / finite["a_hertz"] - 1) < 0.03, finite
    assert abs(finite["p0"] / finite["p0_hertz"] - 1) < 0.03, finite
    assert finite["newton_iterations"] <= small["newton_iterations"] + 2, (small, finite)


# ---------------------------------------------------------------------------------------- 3D
def _elastic_pair(tm, E_lower: float, E_upper: float) -> PlasticityProblem:
    return PlasticityProblem(tm.mesh, {PAIR_CELL_TAGS["block"]: VonMises(E=E_lower, nu=NU, yield_stress=1e12),
                                       PAIR_CELL_TAGS["cylinder"]: VonMises(E=E_upper, nu=NU, yield_stress=1e12)},
                             cell_tags=tm.cell_tags)


def _held_3d(pb, tm, name, axis, value=0.0):
    Vi = pb.V.sub(axis)
    return fem.dirichletbc(value, fem.locate_dofs_topological(Vi, 2, tm.facet_tags.find(tm.facet_names[name])), Vi)


def _sphere(comm, fine: float, penalty: float, slave: str = "top", friction: float = 0.0):
    """A quarter of an elastic sphere on a quarter block (symmetry planes held), its contact and
    the Dirichlet value of the sphere's cut (push down, m)."""
    pair = SphereOnBlock(radius=0.5, half_width=1.0, depth=1.0, zone=0.12)
    tm = build_sphere_on_block(comm, pair, MeshOptions(fine, 15 * fine, 0.3, order=2))
    pb = _elastic_pair(tm, E_BLOCK, E_CYLINDER)
    push = fem.Constant(tm.mesh, 0.0)
    pb.bcs = [_held_3d(pb, tm, "bottom", axis) for axis in range(3)]
    pb.bcs += [_held_3d(pb, tm, "symmetry_x", 0), _held_3d(pb, tm, "symmetry_y", 1), _held_3d(pb, tm, "load", 2, push)]
    names = tm.facet_names
    master = "rim" if slave == "top" else "top"
    ct = FacetContact(pb, tm.facet_tags, (names[slave],), (names[master],), penalty=penalty, friction=friction)
    return pair, pb, ct, push


@pytest.mark.parametrize("friction", [0.0, 0.05], ids=["frictionless", "coulomb"])
def test_pair_tangent_in_3d_is_the_derivative_of_the_forces(comm, friction):
    """3D (quadratic triangles, the sphere's curved surface as the master, its normal averaged
    over the facets around each node): the tangent times a direction equals the central
    difference of the forces to 1e-6; with friction the unlike bodies' radial expansion leaves
    points sticking and slipping.  Coarse (60 mm elements; measured with friction: 10 contact points,
    4 slipping, mismatch 5.5e-9 of |J d|; 40 mm took 7x longer)."""
    pair, pb, ct, push = _sphere(comm, 0.06, penalty=10.0, friction=friction)
    solve_load_path(pb, lambda t: setattr(push, "value", -(pair.gap + 0.5 * PUSH) * t),
                    StepControl(dt=0.5, dt_max=0.5))
    push.value = -(pair.gap + 0.6 * PUSH)          # not committed
    assert pb.solve_increment().converged
    if friction:
        _sticking_and_slipping(comm, ct, friction)
    mismatch, scale = _tangent_mismatch(comm, pb, ct)
    assert scale > 0 and mismatch <= 1e-6 * scale, (mismatch, scale)


def _blocks(comm, hexahedra: bool, friction: float = 0.0, sizes=(0.17, 0.125)):
    """A block (E 20 MPa, elements of ``sizes[1]``, 0.125 m) over a block (10 MPa, ``sizes[0]``,
    0.17 m) of the same footprint, sides free; its contact (the upper block's underside as the
    slave) and the Dirichlet value of the upper block's top (push down, m)."""
    tm = build_block_on_block(comm, W_BLOCKS, D_BLOCKS, H_BLOCKS, 1e-4, sizes, hexahedra=hexahedra)
    pb = _elastic_pair(tm, E_BLOCK, E_CYLINDER)
    push = fem.Constant(tm.mesh, 0.0)
    pb.bcs = [_held_3d(pb, tm, "bottom", 2), _held_3d(pb, tm, "symmetry_x", 0), _held_3d(pb, tm, "symmetry_y", 1),
              _held_3d(pb, tm, "load", 2, push)]
    names = tm.facet_names
    ct = FacetContact(pb, tm.facet_tags, (names["underside"],), (names["top"],), penalty=10.0, friction=friction)
    return pb, ct, push


W_BLOCKS, D_BLOCKS, H_BLOCKS = 0.5, 0.5, 0.3     # m


@pytest.mark.parametrize("hexahedra", [False, True], ids=["tetrahedra", "hexahedra"])
def test_patch_test_of_blocks_with_unlike_facets(comm, hexahedra):
    """Blocks pressed frictionless, sides free: the stress is uniform, so the contact force is
    ``delta / (H_1 / E_1 + H_2 / E_2 + 1 / kappa)`` times the area; within 1e-3 although the
    facets of the two faces (triangles, or quadrilaterals of 9 nodes) do not match (the
    pointwise pressure then scatters, docs).  Measured (elements of 0.17 / 0.125 m, one step:
    elastic and frictionless, so the steps do not matter): -5.6e-5 (tetrahedra) and -2.1e-4
    (hexahedra; -3.0e-4 with the former 0.12 / 0.09 m)."""
    delta = 1e-3
    pb, ct, push = _blocks(comm, hexahedra)
    solve_load_path(pb, lambda t: setattr(push, "value", -(1e-4 + delta) * t), StepControl(dt=1.0, dt_max=1.0))
    F = ct.forces()
    exact = delta / (H_BLOCKS / E_CYLINDER + D_BLOCKS / E_BLOCK + 1 / ct.kappa) * W_BLOCKS ** 2
    assert abs(F.force[2] / exact - 1) < 1e-3, (F.force, exact)
    assert abs(F.M0 / exact - 1) < 1e-3 and np.all(np.abs(F.force[:2]) < 1e-5 * exact), F
    assert ct.contact_area() == pytest.approx(W_BLOCKS ** 2, rel=1e-12)      # the whole face, sampled


@pytest.mark.slow
def test_pair_tangent_on_quadrilateral_facets(comm):
    """Hexahedra (facets of 9 nodes), Coulomb friction: the unlike blocks' lateral expansion
    slides the faces on each other, part of the interface sticking; the tangent times a direction
    equals the central difference of the forces to 1e-6.  Coarse blocks (2 x 2 under 3 x 3 facets:
    81 slave points, measured 48 % slipping, mismatch 1.5e-8 of |J d|)."""
    friction = 0.05
    pb, ct, push = _blocks(comm, hexahedra=True, friction=friction, sizes=(0.25, 0.17))
    solve_load_path(pb, lambda t: setattr(push, "value", -(1e-4 + 2e-3) * t), StepControl(dt=0.5, dt_max=0.5))
    push.value = -(1e-4 + 2.5e-3)                   # not committed
    assert pb.solve_increment().converged
    _sticking_and_slipping(comm, ct, friction)
    mismatch, scale = _tangent_mismatch(comm, pb, ct)
    assert scale > 0 and mismatch <= 1e-6 * scale, (mismatch, scale)


def hertz_sphere_run(comm, fine: float, penalty: float, slave: str = "top") -> dict:
    """Press the sphere by PUSH: the contact radius a (from the pressure's second moment,
    a^2 = 5 int x^2 p / int p for Hertz), the peak pressure p0 and the pressure's L2 distance
    from Hertz's, against Hertz with the combined modulus (as :func:`hertz_pair_run`)."""
    pair, pb, ct, push = _sphere(comm, fine, penalty, slave)
    records = solve_load_path(pb, lambda t: setattr(push, "value", -(pair.gap + PUSH) * t),
                              StepControl(dt=0.25, dt_max=0.25))
    F = ct.forces()
    P = 4 * abs(F.force[2])                               # N, the whole sphere
    E_star = 1 / ((1 - NU ** 2) / E_CYLINDER + (1 - NU ** 2) / E_BLOCK)
    a_h = (3 * P * pair.radius / (4 * E_star)) ** (1 / 3)
    p0_h = 3 * P / (2 * math.pi * a_h ** 2)
    X, w, p = ct.pressures()
    hertz = p0_h * np.sqrt(np.maximum(0.0, 1 - np.sum(X[:, :2] ** 2, axis=1) / a_h ** 2))
    l2 = math.sqrt(comm.allreduce(float(w @ (p - hertz) ** 2)) / comm.allreduce(float(w @ hertz ** 2)))
    return {"P": P, "a": math.sqrt(5 * F.M2 / F.M0), "a_hertz": a_h, "p0": F.max_pressure, "p0_hertz": p0_h,
            "l2": l2, "resultant": 4 * F.M0, "area": 4 * ct.contact_area(), "penetration": F.max_penetration, "h": ct.h,
            "newton_iterations": sum(r.iterations for r in records), "steps": len(records), "dofs": pb.n_dofs}


@pytest.mark.slow
def test_two_body_hertz_sphere(comm):
    """A sphere pressed on a block, both deformable: the contact radius and the peak pressure match
    Hertz with the combined modulus within 3 % with 20 mm elements (a = 72 mm); the pressure
    integrates to the contact force; the sampled contact area is Hertz's pi a^2 within 5 %
    (measured -3.5 %: the last ring of points before the edge carries almost no pressure)."""
    r = hertz_sphere_run(comm, 0.02, penalty=10.0)
    assert abs(r["area"] / (math.pi * r["a_hertz"] ** 2) - 1) < 0.05, r
    assert abs(r["a"] / r["a_hertz"] - 1) < 0.03, r
    assert abs(r["p0"] / r["p0_hertz"] - 1) < 0.03, r
    assert abs(r["resultant"] / r["P"] - 1) < 5e-3, r
