"""Smoothed Mohr-Coulomb (Abbo & Sloan 1995): yield surface, return map, consistent tangent,
strip-footing limit load; geostatic K0 helpers.

References independent of the code under test: the exact Mohr-Coulomb criterion from principal
stresses (numpy eigvalsh), central finite differences of the return map, the Prandtl-Reissner
N_c.  Full-resolution variants: `python -m benchmarks solver frictional`.
"""
from __future__ import annotations

import math

import numpy as np
import pytest

from rollsim.solver import (APEX, ELASTIC, PLASTIC, DruckerPrager, SmoothedMohrCoulomb, admissible_k0,
                            elastic_stiffness, jaky_k0, mohr_coulomb_exact, return_map, yield_function)

E, NU = 50e6, 0.3
C = 100e3
DEG = math.pi / 180


def _rotation(rng):
    q, _ = np.linalg.qr(rng.normal(size=(3, 3)))
    return q


def _mandel(t, ncomp):
    v = [t[0, 0], t[1, 1], t[2, 2], math.sqrt(2) * t[0, 1]]
    if ncomp == 6:
        v += [math.sqrt(2) * t[1, 2], math.sqrt(2) * t[0, 2]]
    return np.array(v)


def stress_from_lode(mean, radius, theta, ncomp, rng=None):
    """Mandel stress with mean stress ``mean`` (tension +), sqrt(J2) = ``radius`` and Lode angle
    ``theta`` (+30 deg = triaxial compression), optionally randomly rotated (3D only)."""
    # principal deviator for Lode angle theta (sin 3theta = -(3 sqrt3/2) J3/J2^1.5)
    ang = np.array([theta - 2 * math.pi / 3, theta, theta + 2 * math.pi / 3])
    s = 2 / math.sqrt(3) * radius * np.sin(ang)      # one admissible parametrisation
    J2 = 0.5 * np.sum(s * s)
    J3 = np.prod(s)
    if abs(-1.5 * math.sqrt(3) * J3 / J2 ** 1.5 - math.sin(3 * theta)) > 1e-9:
        s = -s
    t = np.diag(mean + s)
    if rng is not None and ncomp == 6:
        R = _rotation(rng)
        t = R @ t @ R.T
    return _mandel(t, ncomp)


def smc(**kw):
    args = dict(E=E, nu=NU, c=C, phi=30 * DEG, dilation=10 * DEG)
    args.update(kw)
    return SmoothedMohrCoulomb(**args)


def random_states(ncomp, n=300, seed=0, strain=5e-3, p0=1e5):
    rng = np.random.default_rng(seed)
    sig = np.zeros((n, ncomp))
    sig[:, :3] = -p0 * rng.uniform(0.2, 1.0, size=(n, 1))
    sig += 2e4 * rng.normal(size=(n, ncomp))
    deps = strain * rng.normal(size=(n, ncomp)) * 10 ** rng.uniform(-2.5, 0.5, size=(n, 1))
    return sig, deps


# ----------------------------------------------------------------------------- surface
def test_validation_names_the_field():
    with pytest.raises(ValueError, match="nu"):
        smc(nu=0.5)
    with pytest.raises(ValueError, match="phi"):
        smc(phi=95 * DEG)
    with pytest.raises(ValueError, match="dilation"):
        smc(dilation=40 * DEG)
    with pytest.raises(ValueError, match="transition_angle"):
        smc(transition_angle=30 * DEG)
    with pytest.raises(ValueError, match="apex_rounding"):
        smc(c=0.0)                          # the default rounding 0.05 c cot(phi) vanishes
    assert smc(c=0.0, apex_rounding=100.0).a == 100.0
    assert smc().a == pytest.approx(0.05 * C / math.tan(30 * DEG))


@pytest.mark.parametrize("phi_deg", [20.0, 30.0])
@pytest.mark.parametrize("ncomp", [4, 6])
def test_surface_equals_mohr_coulomb_away_from_rounding(phi_deg, ncomp):
    """|theta| < theta_T, high mean stress: the smoothed surface is Mohr-Coulomb (hyperbola error
    ~ (a sin phi)^2 / (2 sqrt(J2) K), here < 1e-4 of the radius); in triaxial compression and
    extension (theta = +-30 deg, inside the Lode rounding) it lies inside Mohr-Coulomb by at most
    the rounding tolerance: 0.9 % (compression), 0.3 % (extension) for theta_T = 29 deg and
    4.5 % / 1.5 % for theta_T = 25 deg (phi <= 30 deg; hand-computed in smoothed_mc.py)."""
    rng = np.random.default_rng(3)
    phi = phi_deg * DEG
    for thT_deg, tol_tc, tol_te in ((29.0, 0.0092, 0.0031), (25.0, 0.046, 0.0149)):
        mat = smc(phi=phi, transition_angle=thT_deg * DEG)
        mean = -20 * C / math.tan(phi)                   # far from the apex (hyperbola negligible)
        for theta_deg in np.linspace(-thT_deg + 0.5, thT_deg - 0.5, 9):
            sig = stress_from_lode(mean, 1.0, theta_deg * DEG, ncomp, rng)
            # scale the deviator onto the exact Mohr-Coulomb surface, then compare
            dev = sig.copy()
            dev[:3] -= mean
            lo, hi = 0.0, 1e9
            for _ in range(200):
                mid = 0.5 * (lo + hi)
                trial = np.r_[[mean] * 3, [0.0] * (ncomp - 3)] + mid * dev
                lo, hi = (mid, hi) if mohr_coulomb_exact(trial, C, phi)[0] < 0 else (lo, mid)
            on_mc = np.r_[[mean] * 3, [0.0] * (ncomp - 3)] + lo * dev
            radius = math.sqrt(0.5 * np.sum(lo * dev * lo * dev))
            assert abs(mat.yield_function(on_mc[None])[0]) < 1e-4 * radius
        for theta, tol in ((30 * DEG, tol_tc), (-30 * DEG, tol_te)):
            sig = stress_from_lode(mean, 1.0, theta, ncomp, rng)
            dev = sig.copy()
            dev[:3] -= mean
            # radius where each surface is crossed along this deviatoric ray
            radii = []
            for fun in (lambda x: mohr_coulomb_exact(x, C, phi)[0], lambda x: mat.yield_function(x[None])[0]):
                lo, hi = 0.0, 1e9
                for _ in range(200):
                    mid = 0.5 * (lo + hi)
                    lo, hi = (mid, hi) if fun(np.r_[[mean] * 3, [0.0] * (ncomp - 3)] + mid * dev) < 0 else (lo, mid)
                radii.append(lo)
            rel = radii[1] / radii[0] - 1                    # smoothed / exact
            assert -tol <= rel <= 1e-4, (thT_deg, theta, rel)


# ----------------------------------------------------------------------------- return map
@pytest.mark.parametrize("ncomp", [4, 6])
@pytest.mark.parametrize("psi_deg", [30.0, 10.0, 0.0])
def test_return_map_yield_condition_and_elastic_states(psi_deg, ncomp):
    mat = smc(dilation=psi_deg * DEG, c=2e4)
    sig_n, deps = random_states(ncomp)
    if ncomp == 4:
        deps[:, 2] = 0.0
    res = return_map(mat, sig_n, deps)          # dispatched to the material's own return map
    assert {ELASTIC, PLASTIC} <= set(res.state.tolist())
    f = yield_function(mat, res.sigma)
    scale = mat.c + np.abs(res.sigma).max(axis=1)
    assert np.all(f <= 1e-10 * scale)
    assert np.all(np.abs(f[res.state != ELASTIC]) <= 1e-10 * scale[res.state != ELASTIC])
    D = elastic_stiffness(mat, ncomp)
    trial = sig_n + deps @ D.T
    el = res.state == ELASTIC
    assert np.array_equal(res.sigma[el], trial[el])
    assert np.array_equal(res.tangent[el], np.broadcast_to(D, res.tangent[el].shape))
    assert np.all(res.deps_p[el] == 0)
    assert np.allclose(res.sigma, trial - res.deps_p @ D.T, rtol=0, atol=1e-8 * np.abs(trial).max())
    # plastic strain along the potential gradient: deps_p = dlam n_g(sigma)
    pl = res.state == PLASTIC
    assert np.allclose(res.deps_p[pl], res.dlam[pl, None] * mat.flow_direction(res.sigma[pl]),
                       rtol=1e-8, atol=1e-14)
    if psi_deg == 0.0:      # tension states that no isochoric flow can bring back: tip (cut-off)
        ap = res.state == APEX
        assert np.any(ap) and np.allclose(res.sigma[ap, :3], mat.tip_mean_stress)


def _fd_tangent(mat, sig_n, deps, h):
    n, m = deps.shape
    C_fd = np.zeros((n, m, m))
    same = np.ones(n, bool)
    ref = return_map(mat, sig_n, deps, tangent=False).state
    for j in range(m):
        e = np.zeros(m)
        e[j] = h
        rp, rm = return_map(mat, sig_n, deps + e, tangent=False), return_map(mat, sig_n, deps - e, tangent=False)
        C_fd[:, :, j] = (rp.sigma - rm.sigma) / (2 * h)
        same &= (rp.state == ref) & (rm.state == ref)
    return C_fd, same


def targeted_states(mat, ncomp, seed=5):
    """Trial states outside the surface: compression / extension meridians, inside the Lode
    rounding near both corners, mid Lode angle, and near the rounded apex."""
    rng = np.random.default_rng(seed)
    tip = mat.tip_mean_stress
    rows = []
    for theta_deg in (29.9, 28.0, 15.0, 0.0, -15.0, -28.0, -29.9):
        for mean in (tip - 20 * mat.c, tip - 3 * mat.c):
            mc_radius = (mat.c * math.cos(mat.phi) - mean * math.sin(mat.phi)) / 0.7   # >= sqrt(J2) on MC
            rows.append(stress_from_lode(mean, 1.2 * mc_radius, theta_deg * DEG, ncomp, rng))
    for theta_deg in (25.0, -10.0):                    # near the apex: small J2, mean near the tip
        rows.append(stress_from_lode(tip - 0.02 * mat.c, 0.15 * mat.c, theta_deg * DEG, ncomp, rng))
        rows.append(stress_from_lode(tip + 0.01 * mat.c, 0.02 * mat.c, theta_deg * DEG, ncomp, rng))
    sig = np.array(rows)
    return sig, np.zeros_like(sig)


@pytest.mark.parametrize("ncomp", [4, 6])
@pytest.mark.parametrize("psi_deg", [30.0, 10.0])
def test_consistent_tangent_matches_finite_differences(psi_deg, ncomp):
    mat = smc(dilation=psi_deg * DEG)
    sig_r, deps_r = random_states(ncomp, n=200, seed=1, strain=2e-2)
    sig_t, deps_t = targeted_states(mat, ncomp)
    sig_n, deps = np.vstack([sig_r, sig_t]), np.vstack([deps_r, deps_t])
    res = return_map(mat, sig_n, deps)
    assert np.all(res.state[len(sig_r):] != ELASTIC)            # every targeted state is plastic
    C_fd, same = _fd_tangent(mat, sig_n, deps, h=1e-9)
    assert same.mean() > 0.95
    Dn = np.linalg.norm(elastic_stiffness(mat, ncomp))
    err = np.linalg.norm(C_fd - res.tangent, axis=(1, 2)) / np.maximum(np.linalg.norm(res.tangent, axis=(1, 2)), Dn)
    assert same[len(sig_r):].all()
    for s in set(res.state[same].tolist()):
        sel = same & (res.state == s)
        assert err[sel].max() < 1e-6, (s, err[sel].max())
    if psi_deg != 30.0:       # non-associated: non-symmetric tangent
        T = res.tangent[res.state == PLASTIC]
        assert np.abs(T - T.transpose(0, 2, 1)).max() > 1e-3 * Dn


def test_plane_strain_mohr_coulomb_steady_flow():
    """Associated smoothed MC driven in plane strain to steady plastic flow: the in-plane Mohr
    circle touches the exact Mohr-Coulomb line (up to the rounding; measured 1e-3)."""
    mat = smc(c=40e3, phi=20 * DEG, dilation=20 * DEG)
    k = math.sin(mat.phi)           # plane-strain MC dilatancy: tr(deps_p)/(e1 - e3) = -sin(psi)...
    sig = np.array([[-1e5, -1e5, -1e5, 0.0]])
    d = 2e-5
    deps = np.array([[d * (k + 1) / 2, d * (k - 1) / 2, 0.0, 0.0]])     # e1 - e3 = d, e1 + e3 = k d
    for _ in range(400):
        sig = return_map(mat, sig, deps, tangent=False).sigma
    sxy = sig[0, 3] / math.sqrt(2)
    s1, s3 = np.linalg.eigvalsh(np.array([[sig[0, 0], sxy], [sxy, sig[0, 1]]]))[::-1]
    radius, centre = (s1 - s3) / 2, (s1 + s3) / 2
    assert radius == pytest.approx(mat.c * math.cos(mat.phi) - centre * math.sin(mat.phi), rel=2e-3)


# ----------------------------------------------------------------------------- K0
def test_k0_helpers():
    assert jaky_k0(30 * DEG) == pytest.approx(0.5)
    mat = DruckerPrager.from_mohr_coulomb(E, NU, 0.0, 30 * DEG, psi=None, matching="plane_strain")
    T = mat.tan_phi
    k_min = (3 - T) / (3 + 2 * T)                       # q/p = tan(phi_dp) for sigma_h = K sigma_v
    K, clipped = admissible_k0(mat, None, 45e3)         # nu/(1-nu) = 0.4286 < k_min = 0.4648
    assert clipped and K == pytest.approx(k_min + 0.1 * (1 - k_min), rel=1e-9)
    assert admissible_k0(mat, jaky_k0(30 * DEG), 45e3) == (0.5, False)
    sm = smc(c=0.0, apex_rounding=10.0)
    K, clipped = admissible_k0(sm, 0.2, 45e3)          # Rankine active (1-s)/(1+s) = 1/3 for MC 30 deg
    assert clipped and 1 / 3 < K < 0.45


# ----------------------------------------------------------------------------- FE: Prandtl
@pytest.mark.verification
def test_prandtl_smoothed_mohr_coulomb_phi20(comm):
    """Weightless smooth strip, associated smoothed MC, phi = 20 deg: p_lim = c N_c (exact for
    plane-strain Mohr-Coulomb).  Tolerance 3 % on n = 4: the discretisation error of this mesh
    for the same exact value is +1.46 % with the plane-strain-matched Drucker-Prager; the
    rounding makes the surface at most 0.9 % weaker (corners) and ~0.1 % near the apex; measured
    +1.40 % (n = 4) and +0.49 % (n = 8, benchmark)."""
    from rollsim.solver import StripFooting, prandtl_nc, strip_footing_mesh
    mat = smc(phi=20 * DEG, dilation=20 * DEG)
    res = StripFooting(strip_footing_mesh(comm, 1.0, 4), mat).run(0.2)
    exact = C * prandtl_nc(20 * DEG)
    assert abs(res.pressure[-1] / res.pressure[-2] - 1) < 1e-3
    assert abs(res.limit_pressure / exact - 1) < 0.03, res.limit_pressure / exact - 1
    assert max(res.iterations) <= 15


# ----------------------------------------------------------------------------- purely frictional soil (c = 0)
def test_smoothed_mc_psi0_point_at_the_rounded_tip_does_not_crash():
    """psi = 0 with the rounded tip at the stress-free state (a = c cot(phi), allowed now): a point
    exactly on the surface at the tip (J2 = 0) has no flow direction (dg/dsigma = 0), so its local
    Jacobian is singular.  That used to raise numpy's LinAlgError out of the global Newton
    (measured in the 3D wheel run); it now keeps the trial stress with the elastic tangent, and a
    tensile trial state still returns to the tip."""
    c, phi = 1e3, 40 * DEG
    mat = SmoothedMohrCoulomb(E=E, nu=NU, c=c, phi=phi, dilation=0.0, apex_rounding=c / math.tan(phi))
    assert mat.tip_mean_stress == pytest.approx(0.0, abs=1e-9)
    assert yield_function(mat, np.zeros((1, 6)))[0] == pytest.approx(0.0, abs=1e-9)
    with pytest.raises(ValueError, match="apex_rounding"):
        SmoothedMohrCoulomb(E=E, nu=NU, c=c, phi=phi, apex_rounding=1.01 * c / math.tan(phi))
    sig_n = np.zeros((3, 6))
    deps = np.zeros((3, 6))
    deps[1, :3] = 1e-4                      # hydrostatic tension: beyond the tip
    sig_n[2, :3] = -1e4                     # pure shear from 10 kPa confinement: a smooth return
    deps[2, 3] = 1e-3
    res = return_map(mat, sig_n, deps)
    D = elastic_stiffness(mat, 6)
    assert np.allclose(res.sigma[0], 0.0) and np.allclose(res.tangent[0], D)
    assert res.state[1] == APEX and np.allclose(res.sigma[1], 0.0, atol=1e-9)
    assert res.state[2] == PLASTIC
    assert abs(yield_function(mat, res.sigma[2:3])[0]) < 1e-9 * E * 1e-3


def test_regularised_cohesion_and_scene_layers():
    """c = 0 layers get the default regularising cohesion, and the log says so; c > 0 is untouched."""
    import logging

    from rollsim.scene import parse_scene
    from rollsim.solver.materials import regularised_cohesion
    from rollsim.solver.options import DEFAULT_REGULARISING_COHESION as C_REG_DEFAULT
    from rollsim.units import InputError
    from rollsim.solver.scene_model import layer_material
    assert regularised_cohesion(0.0, 40 * DEG) == (C_REG_DEFAULT, True)
    assert regularised_cohesion(5e3, 40 * DEG) == (5e3, False)
    assert regularised_cohesion(0.0, 40 * DEG, c_reg=500.0) == (500.0, True)
    with pytest.raises(ValueError, match="c_reg"):
        regularised_cohesion(0.0, 40 * DEG, c_reg=0.0)
    layers = [{"model": "drucker-prager", "E": 4e7, "nu": 0.35, "c": 0, "phi": 40, "match": "plane-strain",
               "thickness": 0.3},
              {"model": "drucker-prager", "E": 4e7, "nu": 0.35, "c": 0, "phi": 40, "thickness": 0.3},
              {"model": "mohr-coulomb", "E": 4e7, "nu": 0.35, "c": 0, "phi": 40, "thickness": 0.3},
              {"model": "drucker-prager", "E": 4e7, "nu": 0.35, "c": 10e3, "phi": 30}]
    sc = parse_scene({"wheel": {"diameter": 1.0, "width": 0.3}, "soil": {"gamma": 20e3, "layers": layers},
                      "loading": {"protocol": "indentation", "max_sinkage": 0.1}})
    records = []
    handler = logging.Handler(logging.WARNING)
    handler.emit = records.append            # the rollsim logger may not propagate (CLI setup)
    logger = logging.getLogger("rollsim.run")
    logger.addHandler(handler)
    try:
        mats = [layer_material(layer, i) for i, layer in enumerate(sc.soil.layers)]
    finally:
        logger.removeHandler(handler)
    s = math.sin(40 * DEG)
    assert mats[0].c_dp == pytest.approx(3 * C_REG_DEFAULT * math.cos(40 * DEG) / math.sqrt(3 + s * s))
    assert mats[1].c_dp == pytest.approx(6 * C_REG_DEFAULT * math.cos(40 * DEG) / (3 - s))
    assert mats[2].c == C_REG_DEFAULT
    assert mats[3].c_dp == pytest.approx(6 * 10e3 * math.cos(30 * DEG) / (3 - math.sin(30 * DEG)))
    text = "\n".join(r.getMessage() for r in records)
    assert text.count("regularising cohesion") == 3 and "soil.layers[3]" not in text
    assert "plane-strain" in text and "soil.layers[1]: compression-matched" in text
    from rollsim.solver.scene_model import regularised_layers     # what summary.json reports
    assert regularised_layers(sc) == {f"soil.layers[{i}]": C_REG_DEFAULT for i in range(3)}
    from rollsim.solver.scene_model import FRICTIONAL_PENALTY, scene_penalty
    assert scene_penalty(sc, None) == FRICTIONAL_PENALTY and scene_penalty(sc, 10.0) == 10.0
    cohesive = parse_scene({"wheel": {"diameter": 1.0, "width": 0.3}, "soil": {"gamma": 20e3, "layers": layers[3:]},
                            "loading": {"protocol": "indentation", "max_sinkage": 0.1}})
    assert scene_penalty(cohesive, None) is None
    # [model] regularising_cohesion: another value, or 0 (c stays 0; still alpha = 1); the smoothed
    # Mohr-Coulomb's rounded tip needs c > 0, so 0 is refused for its c = 0 layer, naming the key
    scene = {"wheel": {"diameter": 1.0, "width": 0.3}, "soil": {"gamma": 20e3, "layers": layers[:2] + layers[3:]},
             "loading": {"protocol": "indentation", "max_sinkage": 0.1}, "model": {"regularising_cohesion": "0.5 kPa"}}
    assert regularised_layers(parse_scene(scene)) == {f"soil.layers[{i}]": 500.0 for i in range(2)}
    scene["model"]["regularising_cohesion"] = 0
    exact = parse_scene(scene)
    assert regularised_layers(exact) == {} and scene_penalty(exact, None) == FRICTIONAL_PENALTY
    assert layer_material(exact.soil.layers[0], 0, c_reg=0.0).c_dp == 0.0
    with pytest.raises(ValueError, match=r"soil.layers\[2\].c"):
        layer_material(sc.soil.layers[2], 2, c_reg=0.0)
    scene["soil"]["layers"] = layers
    with pytest.raises(InputError, match="model.regularising_cohesion"):
        parse_scene(scene)


def test_scene_match_plane_strain_flow():
    """match = "plane-strain-flow": the cone of the layer's dilation angle (psi = 0 by default:
    tan(phi_dp) = sqrt(3) sin(phi), c_dp = sqrt(3) c cos(phi)); "plane-strain" keeps the associated
    formula; with an associated layer (dilation = phi) the two agree."""
    from rollsim.scene import parse_scene
    from rollsim.solver.scene_model import layer_material
    layer = {"model": "drucker-prager", "E": 4e7, "nu": 0.35, "c": 10e3, "phi": 40}

    def material(**kw):
        sc = parse_scene({"wheel": {"diameter": 1.0, "width": 0.3},
                          "soil": {"gamma": 20e3, "layers": [dict(layer, **kw)]},
                          "loading": {"protocol": "indentation", "max_sinkage": 0.1}})
        return layer_material(sc.soil.layers[0])
    s, co = math.sin(40 * DEG), math.cos(40 * DEG)
    flow = material(match="plane-strain-flow")
    assert math.tan(flow.phi_dp) == pytest.approx(math.sqrt(3) * s, rel=1e-12) and flow.dilation == 0
    assert flow.c_dp == pytest.approx(math.sqrt(3) * 10e3 * co, rel=1e-12)
    assert math.tan(material(match="plane-strain").phi_dp) == pytest.approx(3 * s / math.sqrt(3 + s * s), rel=1e-12)
    assoc = material(match="plane-strain-flow", dilation=40)
    assert assoc == material(match="plane-strain", dilation=40)
