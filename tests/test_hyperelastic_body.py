"""A hyperelastic (neo-Hookean) body in the elastoplastic problem (solver/problem.py): the carcass
of a tire solved in one system with the soil.

Exact: a plane-strain neo-Hookean block stretched or squeezed homogeneously; its lateral stretch
and reaction follow from ``P_22 = 0``.  Together: the elastic cylinder of the two-body Hertz check
(tests/test_contact_pair.py) as a neo-Hookean body reads Hertz's contact as the small-strain one.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from dolfinx import fem
from dolfinx import mesh as dmesh
from scipy.optimize import brentq

from rollsim.solver import NeoHookean, PlasticityProblem, StepControl, VonMises, solve_load_path

E, NU = 10e6, 0.3
LENGTH, HEIGHT = 2.0, 1.0          # m
SOIL, BODY = 1, 2                  # cell tags


def _block(comm):
    """A plane-strain block [0, LENGTH] x [0, HEIGHT] (m) whose cells are all tagged BODY."""
    msh = dmesh.create_rectangle(comm, [np.array([0.0, 0.0]), np.array([LENGTH, HEIGHT])], [4, 2],
                                 dmesh.CellType.triangle)
    n = msh.topology.index_map(2).size_local + msh.topology.index_map(2).num_ghosts
    cells = np.arange(n, dtype=np.int32)
    return msh, dmesh.meshtags(msh, 2, cells, np.full(n, BODY, dtype=np.int32))


def _plane_strain_stretch(mat: NeoHookean, stretch: float) -> tuple[float, float]:
    """Lateral stretch and axial first Piola-Kirchhoff stress (Pa) of plane-strain uniaxial
    tension or compression ``stretch`` along x, free along y: ``F = diag(stretch, l2, 1)``,
    ``P_22 = mu (l2 - 1/l2) + lambda ln(J) / l2 = 0``."""
    def p(l_a, l_b):
        return mat.mu * (l_a - 1 / l_a) + mat.lmbda * math.log(l_a * l_b) / l_a
    lateral = brentq(lambda l2: p(l2, stretch), 0.2, 5.0, xtol=1e-15)
    return lateral, p(stretch, lateral)


def test_a_neo_hookean_body_needs_a_cell_tag_and_a_soil(comm):
    msh, tags = _block(comm)
    with pytest.raises(ValueError, match="needs its cell tag"):
        PlasticityProblem(msh, NeoHookean(E, NU))
    with pytest.raises(ValueError, match="besides the NeoHookean"):
        PlasticityProblem(msh, {BODY: NeoHookean(E, NU)}, cell_tags=tags)


@pytest.mark.parametrize("stretch", [0.7, 1.5])
def test_homogeneous_stretch_of_a_neo_hookean_body_is_exact(comm, stretch):
    """Squeezed to 0.7 or stretched to 1.5 of its length: the lateral stretch and the reaction
    (per unit thickness) match the closed form to round-off (the motion is linear, which P2
    represents exactly); the soil's material has no cell here."""
    msh, tags = _block(comm)
    mat = NeoHookean(E, NU)
    pb = PlasticityProblem(msh, {SOIL: VonMises(E=E, nu=NU, yield_stress=1e3), BODY: mat}, cell_tags=tags)
    V = pb.V
    end = fem.Constant(msh, 0.0)

    def held(where, axis, value=0.0):
        Vi = V.sub(axis)
        return fem.dirichletbc(value, fem.locate_dofs_geometrical((Vi, Vi.collapse()[0]), where)[0], Vi)

    pb.bcs = [held(lambda x: np.isclose(x[0], 0.0), 0), held(lambda x: np.isclose(x[1], 0.0), 1),
              held(lambda x: np.isclose(x[0], LENGTH), 0, end)]

    def pull(t):
        end.value = (stretch - 1) * LENGTH * t

    records = solve_load_path(pb, pull, StepControl(dt=0.25, dt_max=0.25))
    assert records[-1].t == pytest.approx(1.0)
    lateral, P11 = _plane_strain_stretch(mat, stretch)
    w = fem.Function(V)
    w.sub(0).interpolate(lambda x: np.where(np.isclose(x[0], LENGTH), 1.0, 0.0))
    reaction = pb.internal_force(w)
    top = fem.Function(V)
    top.sub(1).interpolate(lambda x: np.where(np.isclose(x[1], HEIGHT), 1.0, 0.0))
    n_top = comm.allreduce(int(np.sum(top.x.array[: V.dofmap.index_map.size_local * 2])))
    uy_top = comm.allreduce(float(pb.u.x.array[: V.dofmap.index_map.size_local * 2]
                                  @ top.x.array[: V.dofmap.index_map.size_local * 2])) / n_top
    assert uy_top == pytest.approx((lateral - 1) * HEIGHT, rel=1e-8)
    assert reaction == pytest.approx(P11 * HEIGHT, rel=1e-8)
    assert abs(P11) > 0.1 * E       # well outside the small-strain range: (stretch - 1) E is off
    assert abs(P11 / ((stretch - 1) * E / (1 - NU ** 2)) - 1) > 0.1
