"""Robustness of the solver in the hard cases: purely frictional soil (c = 0) under self weight,
K0 outside the yield surface, run guards, and extremes (phi_dp = 60 deg, nu = 0.49, a 30:1
strength contrast between two layers).  Every case must converge or fail with a clear
SolverDivergedError (state restored), never hang.  Long variants:
`python -m benchmarks solver frictional`.
"""
from __future__ import annotations

import json
import logging
import math
import os
import pathlib
import subprocess
import sys

import numpy as np
import pytest
from conftest import assert_all
from mpi4py import MPI

from rollsim.solver import DruckerPrager, jaky_k0, von_mises_from_tresca

E, NU, C, B = 50e6, 0.3, 100e3, 1.0
DEG = math.pi / 180
GAMMA = 18e3
# Exact N_gamma of a smooth rigid strip on c = 0, q = 0 soil with self weight, associated
# Mohr-Coulomb, phi = 30 deg: method of characteristics, Martin (2005), "Exact bearing
# capacity calculations using the method of characteristics", Proc. 11th IACMAG, Turin, vol. 4,
# pp. 441-450 (smooth footing: 7.65; rough: 14.75).
N_GAMMA_SMOOTH_30 = 7.65


def _c0_footing(comm, n, K0=None, mat=None, diagonal="crossed", **kw):
    """Smooth strip on c = 0 soil with self weight (default: associated, phi = 30 deg)."""
    from rollsim.solver import StripFooting, strip_footing_mesh
    mat = mat or DruckerPrager.from_mohr_coulomb(E, NU, 0.0, 30 * DEG, psi=None, matching="plane_strain")
    return StripFooting(strip_footing_mesh(comm, B, n, diagonal=diagonal), mat, B, unit_weight=GAMMA, K0=K0, **kw)


def _n_gamma(comm, mat, n, phi, settlement, **kw) -> float:
    """N_gamma = p / (gamma B / 2) of a c = 0 footing (K0 = 1 - sin(phi)) pushed to ``settlement`` (m)."""
    from rollsim.solver import StepControl
    fo = _c0_footing(comm, n, K0=jaky_k0(phi), mat=mat, **kw)
    ctl = StepControl(dt=0.02, dt_max=0.1, dt_min=1e-7, max_cuts=12, max_wall_time=120, predictor="auto")
    return fo.run(settlement, ctl).limit_pressure / (0.5 * GAMMA * B)


@pytest.mark.verification
def test_frictional_c0_footing_predictor(comm):
    """c = 0, phi = 30 deg, gamma = 18 kN/m3, K0 = 1 - sin(phi), n = 4.  Before (predictor
    'none', the old stepping): 64 steps, 23 cuts, 886 Newton iterations; with the extrapolated
    predictor: 23 steps, 2 cuts, 169 iterations (n = 8: 709 / 340 / 11 804 -> 38 / 4 / 293).
    N_gamma = 8.13 at n = 4: +6.2 % over Martin's 7.65 (n = 2, 4, 8, 16: +16.8, +6.2, +2.6,
    +1.1 %, converging from above), so 8 % here."""
    from rollsim.solver import StepControl
    ctl = dict(dt=0.05, dt_max=0.1, dt_min=1e-6, max_cuts=12, max_wall_time=300)
    res = {}
    for pred in ("none", "extrapolate"):
        fo = _c0_footing(comm, 4, K0=jaky_k0(30 * DEG))
        r = fo.run(0.03, StepControl(predictor=pred, **ctl))
        res[pred] = (r, fo.problem.timings["iterations"])
    new, its_new = res["extrapolate"]
    old, its_old = res["none"]
    n_gamma = new.limit_pressure / (0.5 * GAMMA * B)
    assert abs(n_gamma / N_GAMMA_SMOOTH_30 - 1) < 0.08, n_gamma
    assert new.limit_pressure == pytest.approx(old.limit_pressure, rel=2e-3)     # same answer
    assert abs(new.pressure[-1] / new.pressure[-3] - 1) < 2e-3                    # on the plateau
    assert max(h.counts.get("apex", 0) for h in new.history) > 0                  # apex returns occur
    assert len(new.iterations) <= 30 and sum(new.cuts) <= 4 and its_new <= 250
    # the no-predictor path is chaotic (its cut sequence depends on round-off, hence on the
    # partition: 886 iterations serially, 315 on 2 ranks in one CI run): only a margin is asserted
    assert its_old > 1.5 * its_new and sum(old.cuts) >= sum(new.cuts)


def test_nonassociated_c0_footing_between_davis_and_associated(comm):
    """c = 0, psi = 0 (plane-strain match with the flow rule), gamma = 18 kN/m3, K0 = 1 - sin(phi),
    n = 2: N_gamma lies below the associated cone's on the same mesh (Radenkovic's first theorem:
    non-associated flow cannot raise the limit load) and above the associated cone of the Davis
    angle tan(phi*) = sin(phi) (the reduced-strength estimate of non-associated flow), and the
    non-associated reduction grows with phi.  Measured at settlement 0.005 B (phi 30) / 0.008 B (35):
    8.029 between 5.135 and 8.826 (0.91 of it); 16.00 between 8.65 and 19.86 (0.81).  The
    associated-formula cone ("plane_strain") with psi = 0 is a weaker soil (28.7 / 33.0 deg in plane
    strain): 6.678 / 12.85.  On n = 4 the psi = 0 runs stall (`python -m benchmarks solver frictional`,
    case 4), so there is no mesh convergence here."""
    ratios = []
    for phi_deg, settle in ((30.0, 0.005), (35.0, 0.008)):
        phi = phi_deg * DEG
        n_gamma = {}
        for label, match, angle, psi in (("psi0", "plane_strain_flow", phi, 0.0), ("assoc", "plane_strain", phi, None),
                                         ("davis", "plane_strain", math.atan(math.sin(phi)), None),
                                         ("psi0_assoc_formula", "plane_strain", phi, 0.0)):
            mat = DruckerPrager.from_mohr_coulomb(E, NU, 0.0, angle, psi=psi, matching=match)
            n_gamma[label] = _n_gamma(comm, mat, 2, phi, settle * B)
        assert n_gamma["davis"] < n_gamma["psi0"] < n_gamma["assoc"], n_gamma
        assert n_gamma["psi0_assoc_formula"] < 0.9 * n_gamma["psi0"], n_gamma
        ratios.append(n_gamma["psi0"] / n_gamma["assoc"])
    assert 0.75 < ratios[1] < ratios[0] < 0.97, ratios


def test_bbar_underestimates_nonassociated_c0_footing_on_coarse_meshes(comm):
    """B-bar ("cell-average") on c = 0, psi = 0 soil with self weight (phi = 30 deg, one-diagonal
    triangles): on n = 2 N_gamma falls below the Davis estimate of the same mesh, and it rises with
    refinement (from below), while the pointwise strain stays in the band on both meshes.  Measured
    at settlement 0.005 B: B-bar 4.021 -> 5.411 (n = 2 -> 4; Davis 6.787 / 5.407; 6.28 at n = 8 in
    the benchmark), pointwise 8.007 -> 7.707 (associated 9.895 / 8.774).  Why the documented c = 0
    wheel figures with B-bar (the indentation default) are lower values on a coarse mesh
    (docs, "Plane-strain match and non-associated flow").  A weightless c-phi soil (phi = 20 deg)
    shows no such anomaly (one-off, n = 2 and 4: p/c = 13.7-14.0 with B-bar, 14.4-15.0 pointwise,
    against the Davis estimate 13.0 and the exact associated 14.8)."""
    phi = 30 * DEG
    cones = {"psi0": DruckerPrager.from_mohr_coulomb(E, NU, 0.0, phi, psi=0.0, matching="plane_strain_flow"),
             "davis": DruckerPrager.from_mohr_coulomb(E, NU, 0.0, math.atan(math.sin(phi)), psi=None,
                                                      matching="plane_strain")}
    n_gamma = {}
    for n, strain, cone in ((2, "cell-average", "psi0"), (2, "cell-average", "davis"), (4, "cell-average", "psi0"),
                            (2, "pointwise", "davis"), (2, "pointwise", "psi0"), (4, "pointwise", "psi0")):
        n_gamma[n, strain, cone] = _n_gamma(comm, cones[cone], n, phi, 0.005 * B, diagonal="right",
                                            volumetric_strain=strain)
    bbar = [n_gamma[n, "cell-average", "psi0"] for n in (2, 4)]
    assert bbar[0] < 0.8 * n_gamma[2, "cell-average", "davis"] and bbar[1] > 1.2 * bbar[0], n_gamma
    point = [n_gamma[n, "pointwise", "psi0"] for n in (2, 4)]
    assert point[0] > 1.3 * n_gamma[2, "pointwise", "davis"] and abs(point[1] / point[0] - 1) < 0.06, n_gamma


class _Collect(logging.Handler):
    def __init__(self):
        super().__init__(logging.WARNING)
        self.messages = []

    def emit(self, record):
        self.messages.append(record.getMessage())


def test_default_k0_outside_the_cone_is_clipped(comm):
    """nu/(1-nu) = 0.4286 lies outside the plane-strain-matched cone of phi = 30 deg (needs
    K0 >= 0.4648): it is clipped (10 % inside), with a warning; the geostatic state is then
    elastic and in equilibrium (no plastic points, Newton converges at once)."""
    h = _Collect()
    logger = logging.getLogger("rollsim.solver")
    logger.addHandler(h)
    try:
        fo = _c0_footing(comm, 2)
    finally:
        logger.removeHandler(h)
    T = fo.problem.material.tan_phi
    k_min = (3 - T) / (3 + 2 * T)
    assert fo.K0 == pytest.approx(k_min + 0.1 * (1 - k_min), rel=1e-9)
    assert any("violates the yield condition" in m and "Jaky" in m for m in h.messages)
    assert fo.problem.counts()["plastic"] == 0
    rep = fo.problem.solve_increment()
    assert rep.converged and rep.iterations <= 1
    assert _c0_footing(comm, 2, K0=jaky_k0(30 * DEG)).K0 == pytest.approx(0.5)    # Jaky is inside


def test_guards_stop_cleanly(comm):
    """max_wall_time / max_iterations: SolverDivergedError naming the guard (message and kind),
    state restored."""
    from rollsim.solver import SolverDivergedError, StepControl, StripFooting, strip_footing_mesh
    for kw, word, kind in ((dict(max_wall_time=1e-9), "wall-clock", "wall_time_guard"),
                           (dict(max_iterations=3), "max_iterations", "iteration_guard")):
        fo = StripFooting(strip_footing_mesh(comm, B, 2), von_mises_from_tresca(E, NU, C))
        with pytest.raises(SolverDivergedError, match=word) as info:
            fo.run(0.1, StepControl(dt=0.05, **kw))
        assert info.value.kind == kind
        pb = fo.problem
        assert_all(comm, np.array_equal(pb.u.x.array, pb.u_n.x.array), "displacement restored")
        assert_all(comm, np.array_equal(pb.u_n.x.array, info.value.last_converged.u), "state kept")
        assert np.isfinite(fo.pressure())


# ----------------------------------------------------------------------------- extremes
@pytest.mark.parametrize("psi_deg", [60.0, 0.0])
def test_phi_dp_60(comm, psi_deg):
    """phi_dp = 60 deg (tan = sqrt 3: no plane-strain Mohr-Coulomb equivalent, no collapse load
    for associated flow).  Associated: converges, the pressure keeps rising (48.7 c at s = 0.1 B).
    psi = 0: the non-symmetric tangent becomes singular (MUMPS error at apex points, recovered by
    re-creating the linear solver) and Newton stalls near p = 24 c: a SolverDivergedError with
    the state kept (measured 4 s).  Either outcome is accepted if it is clean."""
    from rollsim.solver import SolverDivergedError, StepControl, StripFooting, strip_footing_mesh
    mat = DruckerPrager(E, NU, phi_dp=60 * DEG, c_dp=C, dilation=psi_deg * DEG)
    fo = StripFooting(strip_footing_mesh(comm, B, 4), mat, B)
    ctl = StepControl(dt=0.05, dt_max=0.2, dt_min=1e-5, max_wall_time=90, predictor="extrapolate")
    try:
        res = fo.run(0.1, ctl)
    except SolverDivergedError as err:
        assert psi_deg == 0.0, f"associated phi_dp = 60 deg must converge: {err}"
        assert "last converged state kept" in str(err)
        pb = fo.problem
        assert_all(comm, np.array_equal(pb.u.x.array, pb.u_n.x.array), "displacement restored")
        assert err.last_converged.t > 0.2 and len(err.history) > 3
        assert fo.pressure() > 10 * C
        return
    p = np.array(res.pressure)
    assert np.all(np.diff(p) > 0) and p[-1] > 30 * C


def test_nearly_incompressible_no_locking(comm):
    """nu = 0.49 with P2: the limit load equals the nu = 0.3 one (measured +1.84 % vs +1.83 % over
    (2 + pi) c on n = 4; nu = 0.499: +1.84 %), i.e. no volumetric locking."""
    from rollsim.solver import StripFooting, strip_footing_mesh
    p = {}
    for nu in (0.3, 0.49):
        res = StripFooting(strip_footing_mesh(comm, B, 4), von_mises_from_tresca(E, nu, C)).run(0.1)
        assert abs(res.pressure[-1] / res.pressure[-2] - 1) < 1e-3
        assert max(res.iterations) <= 12
        p[nu] = res.limit_pressure
    assert p[0.49] == pytest.approx(p[0.3], rel=5e-3)
    assert abs(p[0.49] / ((2 + math.pi) * C) - 1) < 0.03


def test_two_layers_30_to_1(comm):
    """Tresca layers with a 30:1 strength contrast (10 kPa / 300 kPa) under the smooth strip,
    interface at 0.25 B on a mesh line, per-layer materials ``{1: top, 2: bottom}`` of
    PlasticityProblem through ``StripFooting(..., interfaces=[0.25 B])``.  Identical layers
    reproduce the homogeneous run exactly; both orders converge, with the pressure between the
    weak and the strong homogeneous capacities (measured, n = 4: weak over strong 1.077 (2+pi)
    c_weak at a plateau - squeezing of the thin layer; strong over weak 2.637 (2+pi) c_weak at
    s = 0.1 B, punching, still rising; n = 8 / 16: 1.050 / 1.036 and 2.604 / 2.591)."""
    from rollsim.solver import StepControl, StripFooting, strip_footing_mesh

    H = [0.25 * B]

    def run(c_top, c_bot, settle, n=4):
        mat = {1: von_mises_from_tresca(E, NU, c_top), 2: von_mises_from_tresca(E, NU, c_bot)}
        return StripFooting(strip_footing_mesh(comm, B, n, interfaces=H), mat, interfaces=H).run(
            settle, StepControl(dt=0.05, dt_max=0.2, dt_min=1e-5, max_wall_time=90, predictor="extrapolate"))

    same = run(C, C, 0.1, n=2)
    ref = StripFooting(strip_footing_mesh(comm, B, 2, interfaces=H), von_mises_from_tresca(E, NU, C)).run(0.1)
    assert same.limit_pressure == pytest.approx(ref.limit_pressure, rel=1e-10)
    weak, strong = 10e3, 300e3
    nc = 2 + math.pi
    r = run(weak, strong, 0.02)                      # weak over strong: plateau
    assert abs(r.pressure[-1] / r.pressure[-2] - 1) < 1e-3
    assert 1.0 * nc * weak < r.limit_pressure < 1.2 * nc * weak
    r = run(strong, weak, 0.1)                       # strong over weak: punching
    assert np.all(np.diff(r.pressure) > 0)
    assert 2.3 * nc * weak < r.limit_pressure < 3.0 * nc * weak


def test_layer_cell_tags_follow_the_interfaces(comm):
    """The interface is a mesh line and every cell gets the tag of its layer; misuse is refused."""
    from rollsim.solver import StripFooting, strip_footing_mesh
    from rollsim.solver.footing import layer_cell_tags
    msh = strip_footing_mesh(comm, B, 2, interfaces=[0.25 * B, 1.0 * B])
    y = msh.geometry.x[:, 1]
    for h in (0.25, 1.0):
        assert comm.allreduce(int(np.any(np.isclose(y, -h * B))), op=MPI.MAX)
    tags = layer_cell_tags(msh, [0.25 * B, 1.0 * B])
    from dolfinx.mesh import compute_midpoints
    ymid = compute_midpoints(msh, 2, tags.indices)[:, 1]
    expect = np.where(ymid > -0.25 * B, 1, np.where(ymid > -1.0 * B, 2, 3))
    assert np.array_equal(tags.values, expect) and set(np.unique(tags.values)) <= {1, 2, 3}
    mat = von_mises_from_tresca(E, NU, C)
    with pytest.raises(ValueError, match="no material"):
        StripFooting(msh, {1: mat, 2: mat}, interfaces=[0.25 * B, 1.0 * B])
    with pytest.raises(ValueError, match="exactly one"):
        StripFooting(msh, {1: mat})
    with pytest.raises(ValueError, match="need material"):
        StripFooting(msh, mat, interfaces=[0.25 * B])


# ----------------------------------------------------------------------------- problem.py robustness
def test_set_geostatic_stress_clips_k0_itself(comm):
    """A bare PlasticityProblem moves a K0 outside the cone inside it (as StripFooting did), with a
    one-line warning, per layer when the layers differ; an admissible K0 is kept."""
    from rollsim.solver import PlasticityProblem, strip_footing_mesh
    from rollsim.solver.footing import layer_cell_tags
    import ufl
    cone = DruckerPrager.from_mohr_coulomb(E, NU, 0.0, 30 * DEG, psi=None, matching="plane_strain")
    T = cone.tan_phi
    k_min = (3 - T) / (3 + 2 * T)
    msh = strip_footing_mesh(comm, B, 2, interfaces=[0.5 * B])
    body = ufl.as_vector([0.0, -GAMMA])
    h = _Collect()
    logger = logging.getLogger("rollsim.solver")
    logger.addHandler(h)
    try:
        pb = PlasticityProblem(msh, cone, body_force=body)
        assert pb.set_geostatic_stress(GAMMA, 0.0) == pytest.approx(k_min + 0.1 * (1 - k_min), rel=1e-9)
        assert pb.counts()["plastic"] == 0 and pb.K0 == pytest.approx(k_min + 0.1 * (1 - k_min))
        assert any("violates the yield condition under self weight" in m for m in h.messages)
        assert all("\n" not in m for m in h.messages)
        n_warn = len(h.messages)
        assert PlasticityProblem(msh, cone, body_force=body).set_geostatic_stress(
            GAMMA, 0.0, K0=jaky_k0(30 * DEG)) == pytest.approx(0.5)
        assert len(h.messages) == n_warn                  # Jaky is inside: no warning
        clay = von_mises_from_tresca(E, NU, C)            # nu/(1-nu) is fine for the clay layer
        pb = PlasticityProblem(msh, {1: clay, 2: cone}, body_force=body, cell_tags=layer_cell_tags(msh, [0.5 * B]))
        k = pb.set_geostatic_stress(GAMMA, 0.0)
        assert k[1] == pytest.approx(NU / (1 - NU)) and k[2] == pytest.approx(k_min + 0.1 * (1 - k_min))
        assert any("cell tag 2" in m for m in h.messages)
        from rollsim.solver import StripFooting
        fo = StripFooting(msh, {1: clay, 2: cone}, interfaces=[0.5 * B], unit_weight=GAMMA)
        assert fo.K0 == pytest.approx(k)
        rep = fo.problem.solve_increment()                 # geostatic state in equilibrium
        assert rep.converged and rep.iterations <= 1 and fo.problem.counts()["plastic"] == 0
    finally:
        logger.removeHandler(h)


def _broken_once(pb):
    """Make the next Newton solve fail inside the LU (zero tangent -> MUMPS factorisation error)."""
    orig = pb.constitutive_update

    def broken(tangent=True):
        r = orig(tangent)
        if tangent:
            pb.tangent.x.array[:] = 0.0
        return r
    pb.constitutive_update = broken
    return lambda: setattr(pb, "constitutive_update", orig)


def test_solve_increment_recovers_after_linear_solver_failure(comm):
    """A failed MUMPS factorisation leaves the factor unusable (every later solve failed with
    DIVERGED_LINEAR_SOLVE before): solve_increment re-creates the linear solver itself, so the
    retried step converges without the stepper's help."""
    from rollsim.solver import StripFooting, strip_footing_mesh
    fo = StripFooting(strip_footing_mesh(comm, B, 2), von_mises_from_tresca(E, NU, C))
    pb = fo.problem
    fo.settlement.value = -1e-3
    repair = _broken_once(pb)
    rep = pb.solve_increment()
    assert not rep.converged
    pb.restore()
    repair()
    rep = pb.solve_increment()
    assert rep.converged and rep.iterations <= 2


def test_return_map_failure_on_one_rank_fails_the_solve_on_all(comm):
    """A return map that raises on rank 0 only (the smoothed Mohr-Coulomb's local Newton did, under
    the rolling wheel on 2 ranks, and the other rank waited in a collective for ever): the solve
    fails on every rank with a NaN residual, the state is restored, and the next solve converges."""
    from petsc4py import PETSc

    from rollsim.solver import StripFooting, strip_footing_mesh
    fo = StripFooting(strip_footing_mesh(comm, B, 2), von_mises_from_tresca(E, NU, C))
    pb = fo.problem
    fo.settlement.value = -1e-3
    orig = pb._return_map
    calls = []

    def failing(*args):
        calls.append(1)
        if comm.rank == 0 and len(calls) == 2:         # inside Newton, after the first residual
            raise RuntimeError("local return map did not converge at 1 points")
        return orig(*args)
    pb._return_map = failing
    try:
        rep = pb.solve_increment()
    finally:
        pb._return_map = orig
    assert not rep.converged and len(calls) >= 2
    nan = int(PETSc.SNES.ConvergedReason.DIVERGED_FNORM_NAN)
    assert comm.allgather(rep.reason) == [nan] * comm.size
    pb.restore()
    rep = pb.solve_increment()
    assert rep.converged


def test_petsc_error_in_snes_logs_one_line_and_recovers(comm):
    """A PETSc error raised inside SNES: one WARNING line with the error code (the traceback only
    at DEBUG), reason REASON_PETSC_ERROR, a fresh linear solver, and the next solve converges."""
    from petsc4py import PETSc

    from rollsim.solver import StripFooting, strip_footing_mesh
    from rollsim.solver.problem import REASON_PETSC_ERROR
    fo = StripFooting(strip_footing_mesh(comm, B, 2), von_mises_from_tresca(E, NU, C))
    pb = fo.problem
    pb._compile()
    fo.settlement.value = -1e-3

    class Raising:
        def __init__(self, snes):
            self._snes = snes

        def solve(self, b, x):
            x2 = PETSc.Vec().createSeq(2)
            x2.axpy(1.0, PETSc.Vec().createSeq(3))        # a real PETSc error with a traceback

        def __getattr__(self, name):
            return getattr(self._snes, name)

    real = pb.snes
    ksp_before = real.getKSP().handle
    pb.snes = Raising(real)
    warn, debug = _Collect(), _Collect()
    debug.setLevel(logging.DEBUG)
    logger = logging.getLogger("rollsim.solver")
    level = logger.level
    logger.setLevel(logging.DEBUG)
    logger.addHandler(warn)
    logger.addHandler(debug)
    try:
        rep = pb.solve_increment()
    finally:
        logger.removeHandler(warn)
        logger.removeHandler(debug)
        logger.setLevel(level)
        pb.snes = real
    assert not rep.converged and rep.reason == REASON_PETSC_ERROR
    snes_warn = [m for m in warn.messages if "Newton raised" in m]
    assert len(snes_warn) == 1 and "\n" not in snes_warn[0] and "PETSc error 75" in snes_warn[0]
    assert any("traceback" in m and "VecAXPY" in m for m in debug.messages)
    assert real.getKSP().handle != ksp_before                 # fresh linear solver
    pb.restore()
    rep = pb.solve_increment()
    assert rep.converged


def _steep_sand(friction: float, s_over_d: float, **model) -> dict:
    """Compression-matched c = 0 sand (phi = 40 deg: phi_dp = 58.6 deg, psi = 0; the default
    regularising cohesion), Mn/DOT wheel, fast preset, pushed to ``s_over_d``; ``model``: more
    ``[model]`` keys."""
    return {"wheel": {"diameter": 1.524, "width": 0.4572, "friction": friction},
            "soil": {"gamma": 20e3, "layers": [{"model": "drucker-prager", "E": 40e6, "nu": 0.35,
                                                "phi_dp": 58.6, "c_dp": 0.0}]},
            "loading": {"protocol": "indentation", "max_sinkage": s_over_d * 1.524},
            "model": {"accuracy": "fast", **model}}


#: the OpenBLAS kernel a child process computes with (OPENBLAS_CORETYPE): AVX without FMA rounds
#: differently from the AVX2 and AVX-512 kernels OpenBLAS picks on current CPUs; a CPU that would
#: pick it itself gets the SSE3 one
OTHER_KERNELS = ("Sandybridge", "Prescott")

_STEEP_SAND_RUN = """
import json, pathlib, sys
from mpi4py import MPI
sys.path.insert(0, {tests!r})
from test_solver_robustness import _steep_sand, openblas_kernel
from rollsim.scene import parse_scene
from rollsim.solver.run import run_scene
r = run_scene(parse_scene(_steep_sand({friction!r}, 0.01)), pathlib.Path({out!r}), MPI.COMM_SELF, progress=False,
              write_fields=False)
print(json.dumps({{"summary": r, "kernel": openblas_kernel()}}))
"""


def openblas_kernel() -> str | None:
    """The kernel of the OpenBLAS this process computes with (None: another BLAS), once PETSc
    has loaded its BLAS."""
    import ctypes
    import re
    maps = pathlib.Path("/proc/self/maps").read_text()
    for lib in sorted(set(re.findall(r"(/\S*openblas\S*\.so\S*)", maps))):
        try:
            corename = ctypes.CDLL(lib).openblas_get_corename
        except (OSError, AttributeError):
            continue
        corename.restype = ctypes.c_char_p
        return corename().decode()
    return None


def _steep_sand_with_another_kernel(friction: float, out, kernel: str) -> subprocess.Popen:
    """:func:`_steep_sand` pushed to s/d = 0.01 in a child process that computes with OpenBLAS's
    ``kernel``; its stdout is one JSON line (``summary``, and ``kernel``: the one it used).  The
    child is a fresh MPI singleton: none of this process's Open MPI variables are passed on."""
    env = {k: v for k, v in os.environ.items()
           if not k.startswith(("OMPI_", "PMIX_", "OPAL_")) or k.startswith("OMPI_ALLOW_RUN_AS_ROOT")}
    env["OPENBLAS_CORETYPE"] = kernel
    code = _STEEP_SAND_RUN.format(tests=str(pathlib.Path(__file__).parent), friction=friction, out=str(out))
    return subprocess.Popen([sys.executable, "-c", code], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)


@pytest.mark.slow
def test_newton_plateaus_let_a_steep_nonassociated_sand_indent(comm, tmp_mpi_path):
    """Pushed to s/d = 0.01.  With mu = 0.8 Newton stalls on plateaus that no step cut lowers:
    cutting alone failed at s/d = 0.007; with the plateaus accepted the wheel reaches s/d = 0.01
    (0.02 in the docs) and the residual left stays below 1 % of Q_V.  Frictionless (pushed to s/d =
    0.005 here), cutting alone converges and no plateau lies below the tolerance: none is accepted, so the run is the cut-only
    run (their Q_V measured equal to the last digit to s/d = 0.02).  With a tolerance of 1e-3 one BLAS kernel accepted an early
    plateau that the others cut, and read Q_V 23 % low at s/d = 0.01 (docs, limitations,
    "Non-associated flow: Newton stalls").  Serially, the rough push is repeated to s/d = 0.01 in a
    child process on another OpenBLAS kernel (AVX without FMA): OpenBLAS's SkylakeX and Haswell
    kernels and the reference BLAS agreed to 1e-13; 1e-6 allowed."""
    from rollsim.scene import parse_scene
    from rollsim.solver import problem
    from rollsim.solver.run import run_scene

    def run(friction, name, s_over_d):
        return run_scene(parse_scene(_steep_sand(friction, s_over_d)), tmp_mpi_path / name, comm, progress=False,
                         write_fields=False)

    kernel = openblas_kernel()
    assert kernel is not None or comm.size > 1, "PETSc does not compute with OpenBLAS (tools/install.sh)"
    other = next(k for k in OTHER_KERNELS if k != kernel)
    other_blas = _steep_sand_with_another_kernel(0.8, tmp_mpi_path / "rough-other-kernel", other) \
        if comm.size == 1 and kernel is not None else None
    try:
        rough, smooth = run(0.8, "rough", 0.01), run(0.0, "smooth", 0.005)
    finally:
        out, err = other_blas.communicate(timeout=900) if other_blas is not None else ("", "")
    assert rough["status"] == "ok", rough["reason"]
    plateaus = rough["newton_plateaus"]
    assert plateaus["accepted"] > 0 and 0 < plateaus["max_residual_ratio"] <= problem.PLATEAU_RTOL
    assert plateaus["max_residual_over_QV"] < 0.01, plateaus
    assert rough["model"]["plateau_tolerance"] == problem.PLATEAU_RTOL
    devices = {e["kind"]: e for e in rough["model"]["regularisation"]}     # c_reg and the plateaus
    assert devices["newton_plateaus"]["effect"]["percent"][1] == round(100 * plateaus["max_residual_over_QV"], 3)
    assert devices["regularising_cohesion"]["value"] == 1e3
    assert smooth["status"] == "ok" and smooth["newton_plateaus"]["accepted"] == 0, smooth["newton_plateaus"]
    if other_blas is not None:
        assert other_blas.returncode == 0, err[-2000:]
        child = json.loads(out.strip().splitlines()[-1])
        assert child["kernel"] == other != kernel, (child["kernel"], kernel)
        assert child["summary"]["status"] == "ok", child["summary"].get("reason")
        ratio = child["summary"]["QV_at_s_over_d"]["0.01"] / rough["QV_at_s_over_d"]["0.01"]
        assert abs(ratio - 1) < 1e-6, ratio


def test_fallback_relaxes_the_stretch_after_a_failure_then_goes_on():
    """``advance_with_fallback`` on a path that fails at 0.3 and 0.55 unless relaxed: each failure
    is retried relaxed over the next stretch (and no further), the relaxation is switched off
    after it, both stretches are listed; a guard, or a failure inside the stretch, is raised; with
    ``start_over`` the move restarts relaxed from its start."""
    from rollsim.solver.stepping import RelaxationFallback, SolverDivergedError, StepControl, advance_with_fallback
    hard = [0.3, 0.55]
    state = {"x": 0.0, "relax": 0.0}
    switched = []

    def advance(to, control):
        assert control.max_wall_time > 0
        block = next((h for h in hard if state["x"] < h <= to), None)
        if block is not None and state["relax"] == 0:
            state["x"] = block - 0.01
            raise SolverDivergedError("Newton diverged at t=...", None, [])
        state["x"] = to

    def relax(length):
        state["relax"] = length
        switched.append(length)

    fb = RelaxationFallback(length=1e-3, stretch=0.1)
    advance_with_fallback(advance, lambda: state["x"], [0.5, 1.0], StepControl(), fb, relax)
    assert state["x"] == 1.0 and state["relax"] == 0.0 and switched == [1e-3, 0.0, 1e-3, 0.0]
    assert fb.spans == [(0.29, pytest.approx(0.39)), (0.54, pytest.approx(0.64))]
    state.update(x=0.0)
    with pytest.raises(SolverDivergedError):                  # no fallback: the failure stands
        advance_with_fallback(advance, lambda: state["x"], [1.0], StepControl(), None, relax)
    assert state["x"] == pytest.approx(0.29)
    guard = SolverDivergedError("wall-clock limit max_wall_time=1 s reached", None, [], kind="wall_time_guard")
    assert not fb.applies(guard) and fb.applies(SolverDivergedError("Newton diverged at t=0", None, []))
    assert not RelaxationFallback(length=0.0, stretch=0.1).applies(SolverDivergedError("Newton diverged", None, []))
    hard[:] = [0.3, 0.35]                                     # fails again inside the relaxed stretch
    state.update(x=0.0)

    def stubborn(to, control):
        if state["x"] < 0.35 <= to:
            state["x"] = min(max(state["x"], 0.34), to)
            raise SolverDivergedError("Newton diverged at t=...", None, [])
        advance(to, control)

    with pytest.raises(SolverDivergedError):
        advance_with_fallback(stubborn, lambda: state["x"], [1.0], StepControl(), RelaxationFallback(1e-3, 0.1), relax)
    assert state["relax"] == 0.0
    hard[:] = [0.3, 0.55]                                     # relaxed from a failure to the end of its target
    state.update(x=0.0)
    switched.clear()
    fb = RelaxationFallback(length=1e-3, stretch=math.inf)
    advance_with_fallback(advance, lambda: state["x"], [0.5, 1.0], StepControl(), fb, relax)
    assert state["x"] == 1.0 and switched == [1e-3, 0.0, 1e-3, 0.0] and fb.spans == [(0.29, 0.5), (0.54, 1.0)]
    state.update(x=0.0)                                       # started over: relaxed from the move's start
    switched.clear()
    failures = []

    def start_over(where):
        failures.append(where)
        state["x"] = 0.0

    fb = RelaxationFallback(length=1e-3, stretch=math.inf)
    advance_with_fallback(advance, lambda: state["x"], [1.0], StepControl(), fb, relax, start_over=start_over)
    assert state["x"] == 1.0 and switched == [1e-3, 0.0] and fb.spans == [(0.0, 1.0)] and failures == [0.29]
    spans = []
    assert RelaxationFallback.unless_relaxed(2e-3, 1e-3, 0.1, spans) is None       # relaxed along the path
    assert RelaxationFallback.unless_relaxed(0.0, 0.0, 0.1, spans) is None         # fallback off
    fb = RelaxationFallback.unless_relaxed(0.0, 1e-3, 0.1, spans)
    assert (fb.length, fb.stretch) == (1e-3, 0.1) and fb.spans is spans


def test_straight_path_places_the_coordinate_linearly_in_pseudo_time():
    from rollsim.solver.stepping import straight_path
    placed = []
    set_load = straight_path(0.02, 0.05, placed.append)
    for t in (0.0, 0.5, 1.0):
        set_load(t)
    assert placed == pytest.approx([0.02, 0.035, 0.05])
