"""Kinematics of ``PlasticityProblem``: small strain and updated Lagrangian (incremental large
deformation) against exact values of a homogeneous compression."""
from __future__ import annotations

import numpy as np
import pytest
from dolfinx import fem, mesh as dmesh
from petsc4py import PETSc

from rollsim.solver import PlasticityProblem, VonMises

E = 10e6          # Pa


def _compress(comm, kinematics: str, strain: float, steps: int) -> float:
    """Plane-strain unit square, nu = 0, elastic, compressed vertically by ``strain`` of its
    height in ``steps`` equal displacement steps (rollers at the left and bottom).  Returns the
    vertical reaction on the top (N per m out of plane), i.e. -sigma_yy times the top's length."""
    msh = dmesh.create_unit_square(comm, 4, 4)
    pb = PlasticityProblem(msh, VonMises(E=E, nu=0.0, yield_stress=1e15), kinematics=kinematics)
    V, fdim = pb.V, msh.topology.dim - 1

    def side(axis, value):
        facets = dmesh.locate_entities_boundary(msh, fdim, lambda x: np.isclose(x[axis], value))
        return fem.locate_dofs_topological(V.sub(axis), fdim, facets)

    top_dofs = side(1, 1.0)
    push = fem.Constant(msh, PETSc.ScalarType(0.0))
    pb.bcs = [fem.dirichletbc(PETSc.ScalarType(0.0), side(0, 0.0), V.sub(0)),
              fem.dirichletbc(PETSc.ScalarType(0.0), side(1, 0.0), V.sub(1)),
              fem.dirichletbc(push, top_dofs, V.sub(1))]
    w = fem.Function(V)
    w.x.array[top_dofs] = 1.0
    for k in range(1, steps + 1):
        push.value = -strain * k / steps
        rep = pb.solve_increment()
        assert rep.converged, (kinematics, k, rep.reason)
        pb.commit()
    return -pb.internal_force(w)


def test_small_strain_compression_is_linear(comm):
    assert _compress(comm, "small-strain", 0.2, 4) == pytest.approx(E * 0.2, rel=1e-9)


def test_updated_lagrangian_compression_integrates_the_logarithmic_strain(comm):
    """Each step's strain increment is taken on the height at the start of the step, so after n
    steps of dh the stress is E sum dh / h_k (exactly, for this homogeneous field) -> E ln(h0/h):
    25 % above the small-strain value at 40 % compression."""
    strain, steps = 0.4, 40
    dh = strain / steps
    exact_discrete = E * sum(dh / (1.0 - k * dh) for k in range(steps))
    got = _compress(comm, "updated-lagrangian", strain, steps)
    assert got == pytest.approx(exact_discrete, rel=1e-8)
    assert got == pytest.approx(-E * np.log(1 - strain), rel=0.01)      # within the O(dh) scheme error
    assert got / (E * strain) > 1.25


def test_updated_lagrangian_equals_small_strain_at_small_strain(comm):
    ss = _compress(comm, "small-strain", 1e-5, 2)
    ul = _compress(comm, "updated-lagrangian", 1e-5, 2)
    assert ul == pytest.approx(ss, rel=1e-5)


def test_unknown_kinematics_is_refused(comm):
    msh = dmesh.create_unit_square(comm, 1, 1)
    with pytest.raises(ValueError, match="kinematics"):
        PlasticityProblem(msh, VonMises(E=E, nu=0.0, yield_stress=1e6), kinematics="total-lagrangian")


def test_updated_lagrangian_strip_footing_gains_capacity_with_penetration(comm):
    """Smooth rigid strip footing on weightless Tresca soil (n = 2 mesh): at small settlement the two
    kinematics agree (both near (2 + pi) c), and with penetration the updated-Lagrangian pressure
    keeps rising (the footing becomes embedded in its own rut and heave) while small strain stays on
    its plateau.  Measured (n = 2 / n = 4): UL/SS - 1 = +1.8 / +1.6 % at w/B = 0.02, +7.5 / +8.7 % at
    0.05, +19 / +17 % at 0.1."""
    from rollsim.solver import StepControl, StripFooting, strip_footing_mesh
    from rollsim.solver.materials import von_mises_from_tresca
    c = 100e3
    mat = von_mises_from_tresca(3e7, 0.49, c)
    p = {}
    for kin in ("small-strain", "updated-lagrangian"):
        fo = StripFooting(strip_footing_mesh(comm, 1.0, 2), mat, 1.0, kinematics=kin)
        res = fo.run(0.1, StepControl(t_end=1.0, dt=0.02, dt_max=0.05, dt_min=1e-5, predictor="extrapolate"))
        p[kin] = [float(np.interp(w, res.displacement, res.pressure)) / c for w in (0.02, 0.05, 0.1)]
    ss, ul = p["small-strain"], p["updated-lagrangian"]
    assert ss[2] == pytest.approx(2 + np.pi, rel=0.06)            # coarse mesh, from above (docs/verification.md)
    assert abs(ul[0] / ss[0] - 1) < 0.03
    assert ul[2] / ss[2] - 1 > 0.10 and ul[2] > ul[1] > ul[0]
    assert abs(ss[2] / ss[1] - 1) < 0.01                           # small strain: plateau
