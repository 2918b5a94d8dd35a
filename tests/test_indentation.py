"""Rigid wheel indentation (solver/indentation.py): 3D quarter model, layers, load control, MPI.

Fast variants (coarse "fast" preset); the standard-vs-accurate comparison and the full curves to
s/d = 0.1 are in benchmarks/bench_indentation.py.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from mpi4py import MPI

from rollsim.geometry import (CylinderWheel, MeshOptions, PlaneStrainBlock, build_plane_strain_block,
                              build_soil_block, indentation_block)
from rollsim.solver import DruckerPrager, StepControl, VonMises
from rollsim.solver.contact import Circle
from rollsim.solver.indentation import WheelIndentation

D, B = 1.524, 0.4572          # report wheel
GAMMA = 20e3
DEG = math.pi / 180


def _quarter(comm, accuracy="fast", layers=()):
    return build_soil_block(comm, indentation_block(D, layers=layers), MeshOptions.from_accuracy(D, accuracy))


def _bearing_capacity(s, c, phi):
    from rollsim.studies.bearing_capacity import Options, Soil, Wheel, wheel_forces
    return float(wheel_forces(s, Wheel(D, B), Soil(c, phi, GAMMA), Options(mode="indentation")).QV)


# ------------------------------------------------------------------ 3D elastic stiffness
def test_elastic_wheel_stiffness_matches_flat_punch_estimate(comm):
    """Elastic soil (E = 40 MPa, nu = 0.35), small sinkage.  Independent estimate: the incremental
    stiffness of an indenter equals that of a flat rigid punch of the current contact area A
    (Sneddon; Pharr, Oliver & Brotzen 1992) - for a rectangle, dQ/ds = beta 2 E/(1-nu^2) sqrt(A/pi)
    with beta ~ 1.05-1.1 (King 1987) - taken here with the contact area of the FE solution at
    s = 0.02 d.  Tolerance 25 %: the fast mesh resolves the patch (0.46 m x 0.42 m) with ~3 x 2
    elements and the block is finite (depth 1.5 d, stiffer than a half-space by roughly 10 %)."""
    tm = _quarter(comm)
    mat = VonMises(E=40e6, nu=0.35, yield_stress=1e12)
    ind = WheelIndentation(tm, CylinderWheel(D, B, B / 12), mat, friction=0.0)
    s1, s2 = 0.018 * D, 0.022 * D
    ind.push(s2, stops=[s1])
    q = {round(st.sinkage / D, 6): st for st in ind.steps}
    st1, st2 = q[0.018], q[0.022]
    k_fe = (st2.QV - st1.QV) / (s2 - s1)
    A = 0.5 * (st1.contact_area + st2.contact_area)
    k_punch = 1.07 * 2 * mat.E / (1 - mat.nu ** 2) * math.sqrt(A / math.pi)
    assert abs(k_fe / k_punch - 1) < 0.25, (k_fe, k_punch, A)


# ------------------------------------------------------------------ 3D indentation vs bearing capacity
@pytest.mark.slow
@pytest.mark.parametrize("case", [2, 5])
def test_indentation_report_case_vs_bearing_capacity(comm, case):
    """Report cases (shared/data/cases_indentation.csv) 2 (von Mises c_dp = 200 kPa) and 5 (DP 27.5 deg,
    c_dp = 194.6 kPa), gamma = 20 kN/m^3, mu = 0.8, fast preset, quarter model: Q_V at s/d = 0.05
    within a loose band [0.7, 1.6] of the bearing-capacity model (indentation, D = s) with the
    compression-matched Mohr-Coulomb parameters.  Measured (fast, alpha = 10): FE/BC = 1.15 (case 2)
    and 1.05 (case 5); the band allows for the coarse mesh (h = 0.125 d, converging from above)
    and the model's own approximations; preset comparison in the benchmark."""
    tm = _quarter(comm)
    if case == 2:
        mat, c, phi = VonMises(E=40e6, nu=0.35, yield_stress=200e3), 100e3, 0.0
    else:
        mat, c, phi = DruckerPrager(E=40e6, nu=0.35, phi_dp=27.5 * DEG, c_dp=194.6e3), 92.2e3, 13.9 * DEG
    ind = WheelIndentation(tm, CylinderWheel(D, B, B / 12), mat, gamma=GAMMA, friction=0.8)
    assert ind.factor == 4
    ind.gravity_step()
    ind.push(0.05 * D)
    fe = ind.steps[-1].QV
    bc = _bearing_capacity(0.05 * D, c, phi)
    assert 0.7 < fe / bc < 1.6, (fe, bc)
    # monotone loading: Q_V grows with s
    qv = [st.QV for st in ind.steps]
    assert qv[-1] > qv[0] > 0


@pytest.mark.slow
@pytest.mark.xfail(reason="open: c = 0 wheel indentation stalls (60 s guard) at s/d ~ 0.012 (alpha = 1) / "
                          "0.0004 (alpha = 10); predictor 'auto', penalty continuation, apex stiffening and "
                          "frictionless contact measured without success (README: 'Open: c = 0 under a wheel')", strict=False)
def test_purely_frictional_soil_with_gravity_converges(comm):
    """c = 0, phi = 40 deg (DP compression match, psi = 0) with gravity: indentation to s/d = 0.03
    converges (the full s/d = 0.1 run is in the benchmark).  Wall-clock guard 60 s.

    Measured (serial, fast mesh, 60 s guard unless noted; s/d reached, steps, cuts, Newton its):
    alpha = 1 'none' 0.0118 / 10 / 2 / 192; alpha = 10 'none' 0.00041 / 3 / 4 / 176; alpha = 1 'auto'
    (40 s) 0.0030 / 5 / 0 / 110; alpha 1 -> 10 after s/d = 0.003 with 'auto' (40 s) 0.0013 / 7 / 1 /
    117; alpha = 10 with 'auto', basic line search, mu = 0 (frictionless) or 1 % elastic stiffness in
    the Newton matrix at apex points: stuck at s/d = 0.0003-0.0004 (25-30 s).  The residual stalls
    at a constant level (line-search failure), also without friction: not a contact-friction or
    linear-solver problem (MUMPS factorisations succeed)."""
    tm = _quarter(comm)
    mat = DruckerPrager.from_mohr_coulomb(40e6, 0.35, 0.0, 40 * DEG, psi=0.0)
    ind = WheelIndentation(tm, CylinderWheel(D, B, B / 12), mat, gamma=GAMMA, friction=0.8, penalty=1.0)
    ind.gravity_step()
    ind.push(0.03 * D, control=StepControl(dt=0.02, dt_min=1e-5, dt_max=0.2, easy_iterations=8, max_cuts=12,
                                           max_wall_time=60))
    assert ind.sinkage == pytest.approx(0.03 * D)
    assert ind.steps[-1].QV > 0


def test_layers_get_their_own_materials(comm):
    """Two layers: a stiff top layer over soft soil gives a stiffer elastic response than the soft
    soil alone, and the per-layer return map sees the right material (the soft layer yields)."""
    tm = _quarter(comm, layers=(0.3,))
    soft = VonMises(E=10e6, nu=0.3, yield_stress=1e12)
    stiff = VonMises(E=200e6, nu=0.3, yield_stress=1e12)
    q = {}
    for name, mats in (("soft", {1: soft, 2: soft}), ("layered", {1: stiff, 2: soft})):
        ind = WheelIndentation(tm, CylinderWheel(D, B, B / 12), mats, friction=0.0)
        ind.push(0.005 * D)
        q[name] = ind.steps[-1].QV
    assert q["layered"] > 2 * q["soft"], q
    with pytest.raises(ValueError, match="no material"):
        WheelIndentation(tm, CylinderWheel(D, B, B / 12), {1: soft}, friction=0.0)


def test_partition_independent_indentation(comm):
    """The distributed run equals a serial run on COMM_SELF (mpirun -n 2)."""
    if comm.size == 1:
        pytest.skip("needs mpirun -n >= 2 (compares the distributed run with a COMM_SELF run)")
    mat = DruckerPrager(E=40e6, nu=0.35, phi_dp=27.5 * DEG, c_dp=194.6e3)
    res = {}
    for name, cm in (("par", comm), ("ser", MPI.COMM_SELF)):
        ind = WheelIndentation(_quarter(cm), CylinderWheel(D, B, B / 12), mat, gamma=GAMMA, friction=0.8)
        ind.gravity_step()
        ind.push(0.01 * D, control=StepControl(dt=0.5, dt_max=0.5, dt_min=1e-3))
        res[name] = ind
    par, ser = res["par"], res["ser"]
    assert par.n_dofs == ser.n_dofs
    assert [s.iterations for s in par.steps] == [s.iterations for s in ser.steps]
    for a, b in zip(par.steps, ser.steps):
        assert a.QV == pytest.approx(b.QV, rel=1e-8)
        assert a.QH == pytest.approx(b.QH, abs=1e-8 * abs(b.QV))


# ------------------------------------------------------------------ load control (plane strain, cheap)
def _strip(comm):
    blk = PlaneStrainBlock(half_width=1.5, depth=1.5, contact_half_width=0.3, refined_half_width=0.3,
                           refined_depth=0.3, symmetric=True)
    tm = build_plane_strain_block(comm, blk, MeshOptions(0.03, 0.2, 0.5))
    mat = VonMises(E=20e6, nu=0.3, yield_stress=100e3)
    return WheelIndentation(tm, Circle(1.0), mat, gamma=GAMMA, friction=0.5)


def test_load_control_reproduces_displacement_control(comm):
    """Plane-strain cylinder (d = 1 m) on von Mises soil with gravity: displacement control to
    s = 0.04 m gives Q_V; load control with that Q_V returns s = 0.04 m (3 %), and a load 5x the
    force reached at the sinkage limit reports "exceeds_capacity" (no hang)."""
    ref = _strip(comm)
    ref.gravity_step()
    ref.push(0.04)
    q_ref = ref.steps[-1].QV
    assert ref.factor == 2 and q_ref > 0
    lc = _strip(comm)
    lc.gravity_step()
    res = lc.push_to_load(q_ref, sinkage_limit=0.1)
    assert res.status == "ok", res.reason
    assert res.QV == pytest.approx(q_ref, rel=2e-4)
    # the frictional elastoplastic path depends on the load steps: the displacement-controlled
    # run (steps of 6 mm) and the load-controlled one (5 mm steps, then one secant trial) differ
    # by about 2 % in force at the same sinkage (measured), hence 3 % here
    assert res.sinkage == pytest.approx(0.04, rel=0.03)
    assert lc.sinkage == pytest.approx(res.sinkage)

    over = _strip(comm)
    over.gravity_step()
    res = over.push_to_load(5 * q_ref, sinkage_limit=0.06)
    assert res.status == "exceeds_capacity"
    assert "exceeds the capacity" in res.reason
    assert res.max_QV < 5 * q_ref and res.sinkage_at_max <= 0.06 + 1e-12
