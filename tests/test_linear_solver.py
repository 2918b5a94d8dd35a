"""Linear solver of the Newton iteration: direct LU (MUMPS) or GMRES + smoothed-aggregation AMG
with the rigid-body modes as near-null space (large meshes, ``linear_solver="auto"``)."""
from __future__ import annotations

import math

import numpy as np
import pytest
from dolfinx import mesh as dmesh
from dolfinx.fem import petsc as fpetsc

from rollsim.geometry import MeshOptions, PlaneStrainBlock, build_plane_strain_block
from rollsim.solver import DruckerPrager, PlasticityProblem, VonMises
from rollsim.solver import linear_solver as linear_solver_module
from rollsim.solver.contact import Circle
from rollsim.solver.indentation import WheelIndentation
from rollsim.solver.problem import rigid_body_modes

DEG = math.pi / 180


@pytest.mark.parametrize("gdim", [2, 3])
def test_rigid_body_modes_are_null_modes_of_the_free_stiffness(comm, gdim):
    """Without supports the elastic stiffness maps each translation and rotation to zero force."""
    msh = (dmesh.create_unit_square(comm, 3, 3) if gdim == 2 else dmesh.create_unit_cube(comm, 2, 2, 2))
    pb = PlasticityProblem(msh, VonMises(E=1e7, nu=0.3, yield_stress=1e12))
    pb._compile()
    A = fpetsc.assemble_matrix(pb._J_form, [])
    A.assemble()
    modes = rigid_body_modes(pb.V).getVecs()
    assert len(modes) == (3 if gdim == 2 else 6)
    y = modes[0].duplicate()
    for i, m in enumerate(modes):
        A.mult(m, y)
        assert y.norm() <= 1e-10 * A.norm(), i
        for j, other in enumerate(modes):
            assert m.dot(other) == pytest.approx(float(i == j), abs=1e-12)


def _plane_strain_wheel(comm, linear_solver: str) -> WheelIndentation:
    """Plane-strain cylinder (d = 1 m) with friction on non-associated Drucker-Prager soil with
    gravity: an unsymmetric tangent (friction, psi != phi), the hard case for the iterative solver."""
    blk = PlaneStrainBlock(half_width=1.5, depth=1.5, contact_half_width=0.3, refined_half_width=0.3,
                           refined_depth=0.3, symmetric=True)
    tm = build_plane_strain_block(comm, blk, MeshOptions(0.04, 0.25, 0.5))
    mat = DruckerPrager(E=20e6, nu=0.3, phi_dp=25 * DEG, c_dp=60e3, dilation=5 * DEG)
    return WheelIndentation(tm, Circle(1.0), mat, gamma=20e3, friction=0.5, linear_solver=linear_solver)


def test_iterative_solver_reproduces_the_direct_one(comm):
    """Same Newton iterations and the same force-sinkage curve (to 1e-7) into the plastic range."""
    runs = {}
    for kind in ("direct", "iterative"):
        ind = _plane_strain_wheel(comm, kind)
        ind.gravity_step()
        ind.push(0.03)
        runs[kind] = ind
    direct, iterative = runs["direct"], runs["iterative"]
    assert iterative.problem.linear_solver == "iterative"
    ksp = iterative.problem.snes.getKSP()
    assert ksp.getType() == "gmres" and ksp.getPC().getType() == "gamg"
    assert iterative.problem._A.getNearNullSpace().getVecs()       # rigid-body modes attached
    assert direct.problem.snes.getKSP().getPC().getType() == "lu"
    assert iterative.problem.counts()["plastic"] > 0
    assert [s.iterations for s in iterative.steps] == [s.iterations for s in direct.steps]
    for a, b in zip(iterative.steps, direct.steps):
        assert a.QV == pytest.approx(b.QV, rel=1e-7)


def test_auto_chooses_by_problem_size(comm, monkeypatch):
    msh = dmesh.create_unit_square(comm, 2, 2)
    mat = VonMises(E=1e7, nu=0.3, yield_stress=1e6)
    assert PlasticityProblem(msh, mat).linear_solver == "direct"
    monkeypatch.setattr(linear_solver_module, "AUTO_ITERATIVE_DOFS", 10)
    pb = PlasticityProblem(msh, mat)
    assert pb.linear_solver == "iterative" and pb.petsc_options["pc_type"] == "gamg"
    assert PlasticityProblem(msh, mat, linear_solver="direct").linear_solver == "direct"
    # explicit PETSc options still win over the chosen solver's
    assert PlasticityProblem(msh, mat, petsc_options={"ksp_rtol": 1e-6}).petsc_options["ksp_rtol"] == 1e-6


def test_unknown_linear_solver_is_refused(comm):
    msh = dmesh.create_unit_square(comm, 1, 1)
    with pytest.raises(ValueError, match="linear_solver"):
        PlasticityProblem(msh, VonMises(E=1e7, nu=0.3, yield_stress=1e6), linear_solver="cholesky")


def test_elastic_solve_time_uses_the_configured_solver(comm):
    """The cost reference is measured with the Newton iteration's own linear solver."""
    msh = dmesh.create_unit_square(comm, 4, 4)
    pb = PlasticityProblem(msh, VonMises(E=1e7, nu=0.3, yield_stress=1e6), linear_solver="iterative")
    facets = dmesh.locate_entities_boundary(msh, 1, lambda x: np.isclose(x[1], 0.0))
    from dolfinx import fem
    from petsc4py import PETSc
    pb.bcs = [fem.dirichletbc(np.zeros(2, dtype=PETSc.ScalarType),
                              fem.locate_dofs_topological(pb.V, 1, facets), pb.V)]
    assert pb.elastic_solve_time(repeat=1) > 0
    assert pb.snes.getKSP().getPC().getType() == "gamg"


def test_auto_iterative_solver_gives_way_to_the_direct_one_where_it_fails(comm, monkeypatch):
    """Where the automatically chosen iterative solver fails, the direct one takes over for the rest
    of the run: the push goes on and ends where the direct solver's does (same sinkage and force)."""
    direct = _plane_strain_wheel(comm, "direct")
    direct.gravity_step()
    direct.push(0.01)
    monkeypatch.setattr(linear_solver_module, "AUTO_ITERATIVE_DOFS", 10)
    monkeypatch.setattr(linear_solver_module, "ITERATIVE_SOLVER_OPTIONS",        # an iterative solver that fails
                        {"ksp_type": "gmres", "ksp_max_it": 2, "ksp_rtol": 1e-12, "pc_type": "jacobi"})
    auto = _plane_strain_wheel(comm, "auto")
    assert auto.problem.linear_solver == "iterative"
    auto.gravity_step()
    auto.push(0.01)
    assert auto.problem.linear_solver == "direct" and auto.problem.snes.getKSP().getPC().getType() == "lu"
    assert auto.steps[-1].sinkage == pytest.approx(direct.steps[-1].sinkage, rel=1e-9)
    assert auto.steps[-1].QV == pytest.approx(direct.steps[-1].QV, rel=1e-3)
