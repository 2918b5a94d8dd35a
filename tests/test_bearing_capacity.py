"""The bearing-capacity wheel model against independent values: published factors,
exact limits, a from-the-spec scalar re-derivation, round trips and scaling laws."""
import math

import numpy as np
import pytest

from rollsim.studies import bearing_capacity as bc
from rollsim.studies.bearing_capacity import Options, Soil, Wheel
from rollsim.units import InputError

MNDOT = Wheel(1.524, 0.4572)
CLAY = Soil(100e3, 0.0, 20e3)
SAND = Soil(0.0, math.radians(40.0), 20e3)
C_PHI = Soil(46.1e3, math.radians(13.9), 20e3)
ALL_OPTIONS = [Options(mode, method, depth) for mode in bc.MODES for method in bc.METHODS for depth in bc.DEPTHS
               if not (mode == "indentation" and method == "load")]


# ------------------------------------------------------------------ factors and limits
@pytest.mark.parametrize("phi_deg, nc, nq, ngamma", [
    # Vesic (1973) factors as tabulated in Das, Principles of Foundation Engineering, Table 3.3
    (10, 8.35, 2.47, 1.22), (20, 14.83, 6.40, 5.39), (30, 30.14, 18.40, 22.40), (40, 75.31, 64.20, 109.41)])
def test_bearing_factors_match_published_table(phi_deg, nc, nq, ngamma):
    got = bc.bearing_factors(math.radians(phi_deg))
    np.testing.assert_allclose(got, (nc, nq, ngamma), rtol=0, atol=0.0051)  # printed to 2 decimals


def test_nc_tends_smoothly_to_prandtl():
    phi = np.array([0.0, 1e-12, 1e-8, 1e-5])
    nc, nq, ngamma = bc.bearing_factors(phi)
    assert nc[0] == 2 + math.pi and nq[0] == 1 and ngamma[0] == 0
    np.testing.assert_allclose(nc[:3], 2 + math.pi, rtol=1e-7)
    # slope at 0 is finite: Nc'(0) = (2 + pi)^2 / 2 - 2 ... checked by a one-sided difference
    assert abs((nc[3] - nc[0]) / 1e-5 - (nc[2] - nc[0]) / 1e-8) < 1e-2 * abs((nc[3] - nc[0]) / 1e-5)


def test_prandtl_strip_footing_limit():
    q = bc.footing_capacity(B=1.0, L=1e12, D=0.0, beta=0.0, c=50e3, phi=0.0, gamma=0.0)
    assert q == pytest.approx((2 + math.pi) * 50e3, rel=1e-10)


def test_inclined_footing_factor_limit_phi_to_zero():
    beta = 0.2
    at_zero = bc.footing_capacity(0.3, 0.5, 0.02, beta, 80e3, 0.0, 20e3, method="footing")
    near_zero = bc.footing_capacity(0.3, 0.5, 0.02, beta, 80e3, 1e-9, 20e3, method="footing")
    assert near_zero == pytest.approx(at_zero, rel=1e-7)
    # and the phi = 0 value is the closed form (2 + pi - 2 beta) / (2 + pi) for Fci
    vertical = bc.footing_capacity(0.3, 0.5, 0.02, 0.0, 80e3, 0.0, 0.0, method="footing")
    inclined = bc.footing_capacity(0.3, 0.5, 0.02, beta, 80e3, 0.0, 0.0, method="footing")
    assert inclined / vertical == pytest.approx((2 + math.pi - 2 * beta) / (2 + math.pi), rel=1e-12)


def test_gamma_inclination_factor_vanishes_when_beta_exceeds_phi():
    phi = math.radians(10)
    kw = dict(B=0.3, L=0.5, D=0.0, c=0.0, phi=phi, gamma=20e3, method="load")
    assert bc.footing_capacity(beta=phi * 1.01, **kw) == 0.0
    assert bc.footing_capacity(beta=phi * 0.5, **kw) > 0.0


# ------------------------------------------- the model's cases, re-derived
def _spec_force(s, d, b, c, phi, gamma, case, depth="modified"):
    """A plain scalar transcription of the model's general formula and case table."""
    nq = math.tan(math.pi / 4 + phi / 2) ** 2 * math.exp(math.pi * math.tan(phi))
    nc = (nq - 1) / math.tan(phi) if phi > 0 else 2 + math.pi
    ng = 2 * (nq + 1) * math.tan(phi)
    if case == "indentation":
        h, beta = 2 * math.sqrt(d * s - s * s), 0.0
    elif case == "load":
        h, beta = math.sqrt(d * s - s * s), math.sqrt(s / d)
    else:
        h, beta = math.sqrt(d * s), math.sqrt(s / d)
    B, L = min(h, b), max(h, b)
    eta = math.sin(math.pi / 4 - phi / 2) / math.sin(math.pi / 4 + phi / 2) * math.exp(-math.pi / 2 * math.tan(phi))
    D = s if depth == "modified" else eta * s / 6
    r = D / B if D / B <= 1 else math.atan(D / B)
    fcs, fqs, fgs = 1 + B / L * nq / nc, 1 + B / L * math.tan(phi), 1 - 0.4 * B / L
    fcd, fqd = 1 + 0.4 * r, 1 + 2 * math.tan(phi) * (1 - math.sin(phi)) ** 2 * r
    if case == "load":
        fci = fqi = (1 - 2 * beta / math.pi) ** 2
        fgi = (1 - beta / phi) ** 2 if 0 < phi and beta < phi else 0.0
    elif case == "footing":
        fci = (nq * math.exp(-2 * beta * math.tan(phi)) - 1) / (nq - 1) if phi > 0 else (2 + math.pi - 2 * beta) / (2 + math.pi)
        fqi = fgi = (1 - math.tan(beta)) ** 2
    else:
        fci = fqi = fgi = 1.0
    qu = c * nc * fcs * fcd * fci + gamma * D * nq * fqs * fqd * fqi + 0.5 * gamma * B * ng * fgs * fgi
    Q = qu * h * b
    return Q * math.cos(beta), Q * math.sin(beta)


@pytest.mark.parametrize("soil", [CLAY, SAND, C_PHI], ids=["clay", "sand", "c-phi"])
@pytest.mark.parametrize("case", ["indentation", "load", "footing"])
@pytest.mark.parametrize("depth", ["modified", "theory"])
def test_forces_equal_the_spec_formula(soil, case, depth):
    s = np.array([0.005, 0.03, 0.08, 0.2, 0.5]) * MNDOT.diameter  # both D/B branches, B = h and B = b
    opts = Options("indentation" if case == "indentation" else "rolling", "load" if case == "load" else "footing", depth)
    f = bc.wheel_forces(s, MNDOT, soil, opts)
    expected = np.array([_spec_force(x, MNDOT.diameter, MNDOT.width, soil.c, soil.phi, soil.gamma, case, depth)
                         for x in s])
    np.testing.assert_allclose(f.QV, expected[:, 0], rtol=1e-12)
    np.testing.assert_allclose(f.QH, expected[:, 1], rtol=1e-12, atol=1e-9)


def test_rolling_force_inclination_is_beta():
    s = 0.05
    f = bc.wheel_forces(s, MNDOT, C_PHI)
    assert float(f.QH / f.QV) == pytest.approx(math.tan(math.sqrt(s / MNDOT.diameter)), rel=1e-12)
    assert float(f.Q) == pytest.approx(math.hypot(float(f.QV), float(f.QH)), rel=1e-12)


def test_torus_equals_cylinder_beyond_half_width_and_needs_less_force_before():
    torus, cyl = Wheel(1.524, 0.4572, "torus"), MNDOT
    opts = Options(mode="indentation")
    s_deep = np.array([0.5, 0.6, 0.75]) * torus.width
    np.testing.assert_array_equal(bc.wheel_forces(s_deep, torus, C_PHI, opts).QV,
                                  bc.wheel_forces(s_deep, cyl, C_PHI, opts).QV)
    s_shallow = np.array([0.02, 0.1, 0.3]) * torus.width
    assert np.all(bc.wheel_forces(s_shallow, torus, C_PHI, opts).QV < bc.wheel_forces(s_shallow, cyl, C_PHI, opts).QV)


# ------------------------------------------------------------ load -> sinkage, peaks
@pytest.mark.parametrize("opts", ALL_OPTIONS, ids=lambda o: f"{o.mode}-{o.method}-{o.depth}")
@pytest.mark.parametrize("soil", [CLAY, SAND, C_PHI], ids=["clay", "sand", "c-phi"])
def test_sinkage_round_trip(opts, soil):
    s = np.array([0.01, 0.03, 0.05, 0.08]) * MNDOT.diameter
    r = bc.sinkage(bc.wheel_forces(s, MNDOT, soil, opts).QV, MNDOT, soil, opts)
    before_peak = s <= r.sinkage_at_max
    assert before_peak.sum() >= 3 and not np.any(r.exceeds_capacity)
    np.testing.assert_allclose(r.sinkage[before_peak], s[before_peak], rtol=1e-8)
    # past the peak the same load has an earlier root: that one is returned
    assert np.all(r.sinkage <= r.sinkage_at_max)
    np.testing.assert_allclose(r.forces.QV, bc.wheel_forces(s, MNDOT, soil, opts).QV, rtol=1e-10)


def test_exceeds_capacity_is_reported_not_a_spurious_root():
    soil = Soil(0.0, math.radians(35), 20e3)  # sand: the rolling curve peaks
    peak, s_peak = bc.capacity_peak(MNDOT, soil)
    # the peak really is a maximum of the curve
    grid = np.linspace(0.001, 0.5, 4000) * MNDOT.diameter
    assert float(peak) >= bc.wheel_forces(grid, MNDOT, soil).QV.max() * (1 - 1e-9)
    assert 0 < float(s_peak) < 0.5 * MNDOT.diameter
    r = bc.sinkage([0.999 * peak, 1.001 * peak], MNDOT, soil)
    assert list(r.exceeds_capacity) == [False, True]
    assert np.isfinite(r.sinkage[0]) and np.isnan(r.sinkage[1])
    assert float(r.forces.QV[0]) == pytest.approx(0.999 * float(peak), rel=1e-9)
    assert float(r.max_QV[1]) == pytest.approx(float(peak))


def test_validity_range_flag():
    s = np.array([0.005, 0.05, 0.09]) * MNDOT.diameter
    r = bc.sinkage(bc.wheel_forces(s, MNDOT, CLAY).QV, MNDOT, CLAY)
    assert list(r.in_validity_range) == [False, True, False]


# --------------------------------------------------------------------- flexible wheel
@pytest.mark.parametrize("mode", ["indentation", "rolling"])
def test_flexible_wheel_is_the_fixed_point_of_the_spec_equation(mode):
    lam = 1e-5  # m/N, the report's order for the Mn/DOT tire
    wheel = Wheel(1.524, 0.4572, flexibility=lam)
    opts = Options(mode=mode)
    s = np.array([0.02, 0.05, 0.1])
    f = bc.wheel_forces(s, wheel, CLAY, opts)
    q_formula = bc.wheel_forces(s, Wheel(f.d_e, 0.4572), CLAY, opts).Q  # rigid wheel of diameter d_e
    np.testing.assert_allclose(f.Q, q_formula, rtol=1e-10)
    np.testing.assert_allclose(f.d_e, 1.524 + lam * f.Q, rtol=1e-14)
    assert np.all(f.QV > bc.wheel_forces(s, MNDOT, CLAY, opts).QV)  # a flatter wheel carries more
    r = bc.sinkage(f.QV, wheel, CLAY, opts)
    np.testing.assert_allclose(r.sinkage, s, rtol=1e-8)


def test_zero_flexibility_is_rigid():
    s = np.array([0.02, 0.05])
    np.testing.assert_array_equal(bc.wheel_forces(s, Wheel(1.524, 0.4572, flexibility=0.0), SAND).QV,
                                  bc.wheel_forces(s, MNDOT, SAND).QV)


# --------------------------------------------------------------------- inverse problems
@pytest.mark.parametrize("flex, opts", [
    (0.0, Options()), (0.0, Options(method="load")), (0.0, Options(mode="indentation")), (0.0, Options(depth="theory")),
    (1e-5, Options()), (1e-5, Options(mode="indentation")), (1e-5, Options(depth="theory"))],
    ids=["footing", "load", "indentation", "theory", "flex-footing", "flex-indentation", "flex-theory"])
def test_inverse_round_trips(flex, opts):
    wheel = Wheel(1.524, 0.4572, flexibility=flex)
    s = np.array([0.02, 0.05, 0.08]) * 1.524
    truth = Soil(np.array([30e3, 80e3, 150e3]), np.radians([20.0, 30.0, 38.0]), 19e3)
    load = bc.wheel_forces(s, wheel, truth, opts).QV
    c = bc.cohesion_from_sinkage(s, load, wheel, truth.phi, 19e3, opts)
    np.testing.assert_allclose(c, truth.c, rtol=1e-8)
    phi = bc.friction_angle_from_sinkage(s, load, wheel, truth.c, 19e3, opts)
    np.testing.assert_allclose(phi, truth.phi, rtol=1e-8)


def test_inverse_without_answer_is_nan():
    s, load = 0.05, 10e3  # a light load: even c = 0 with this phi would sink less
    assert np.isnan(bc.cohesion_from_sinkage(s, load, MNDOT, math.radians(40), 20e3))
    assert np.isnan(bc.friction_angle_from_sinkage(s, load, MNDOT, 200e3, 20e3))


def test_two_measurements_recover_both_and_flag_conditioning():
    # a frictional soil and two very different wheels: a well-conditioned pair
    truth = Soil(10e3, math.radians(40), 18e3)
    small = Wheel(0.5, 0.15)
    s1, s2 = 0.05, 0.04
    q1 = float(bc.wheel_forces(s1, MNDOT, truth).QV)
    q2 = float(bc.wheel_forces(s2, small, truth).QV)
    r = bc.strength_from_two_measurements(s1, q1, MNDOT, s2, q2, small, 18e3)
    assert r.c == pytest.approx(10e3, rel=1e-8)
    assert r.phi == pytest.approx(math.radians(40), rel=1e-8)
    assert not r.ill_conditioned
    # sensitivity is the Jacobian's: a finite-difference re-solve with 1 % more sinkage agrees
    r2 = bc.strength_from_two_measurements(s1 * 1.01, q1, MNDOT, s2, q2, small, 18e3)
    assert abs(r2.phi - r.phi) <= r.dphi_per_percent * 1.1
    assert abs(r2.c - r.c) <= r.dc_per_percent * 1.1
    assert abs(r2.c - r.c) >= 0.5 * r.dc_per_percent or abs(r2.phi - r.phi) >= 0.5 * r.dphi_per_percent
    # one wheel at two nearby loads: nearly parallel curves, flagged
    q1b = float(bc.wheel_forces(0.051, MNDOT, truth).QV)
    near = bc.strength_from_two_measurements(s1, q1, MNDOT, 0.051, q1b, MNDOT, 18e3)
    assert near.ill_conditioned


def test_strength_profile_pass_fail():
    position = np.array([0.0, 1.0, 2.0])
    truth_c = np.array([200e3, 120e3, 180e3])
    s = np.array([float(bc.sinkage(133.5e3, MNDOT, Soil(c, 0.0, 20e3)).sinkage) for c in truth_c])
    prof = bc.strength_profile(position, s, 133.5e3, MNDOT, 20e3, phi=0.0, minimum=170e3)
    np.testing.assert_allclose(prof.strength, truth_c, rtol=1e-8)
    assert list(prof.passes) == [True, False, True]


# ------------------------------------------------------------------- scaling laws
def _slope(x, y):
    return np.polyfit(np.log(x), np.log(y), 1)[0]


def test_scaling_laws_of_the_spec():
    loads = np.linspace(60e3, 133.5e3, 8)
    clay = Soil(150e3, 0.0, 20e3)
    sand = Soil(0.0, math.radians(45), 20e3)
    # phi = 0: sinkage roughly ~ Q_V^2; c = 0: roughly linear in Q_V
    assert 1.6 < _slope(loads, bc.sinkage(loads, MNDOT, clay).sinkage) < 2.4
    sand_loads = np.linspace(20e3, 60e3, 8)
    assert 0.8 < _slope(sand_loads, bc.sinkage(sand_loads, MNDOT, sand).sinkage) < 1.3
    # sinkage falls roughly as 1/d
    d = np.linspace(1.0, 2.0, 6)
    s = bc.sinkage(100e3, Wheel(d, 0.4572), clay).sinkage
    assert -1.4 < _slope(d, s) < -0.6


# ------------------------------------------------------------------- input checks
@pytest.mark.parametrize("make, field", [
    (lambda: Wheel(-1.0, 0.4), "d"), (lambda: Wheel(1.0, 0.0), "b"), (lambda: Wheel(1.0, 0.4, "cube"), "shape"),
    (lambda: Soil(-1.0, 0.0, 20e3), "c"), (lambda: Soil(0.0, 2.0, 20e3), "phi"), (lambda: Soil(0, 0, 0), "gamma"),
    (lambda: Options(mode="sliding"), "mode"), (lambda: bc.sinkage(-5.0, MNDOT, CLAY), "load")])
def test_bad_input_names_the_field(make, field):
    with pytest.raises(InputError) as e:
        make()
    assert e.value.field == field


def test_vectorised_broadcasting():
    loads = np.linspace(50e3, 120e3, 5)[:, None]
    c = np.array([100e3, 200e3])[None, :]
    r = bc.sinkage(loads, MNDOT, Soil(c, 0.0, 20e3))
    assert r.sinkage.shape == (5, 2)
    assert np.all(np.diff(r.sinkage, axis=0) > 0) and np.all(r.sinkage[:, 0] > r.sinkage[:, 1])


def test_flexible_wheel_exceeds_capacity_consistently():
    wheel = Wheel(1.524, 0.4572, flexibility=1e-5)
    sand = Soil(0.0, math.radians(35), 20e3)
    peak = float(bc.capacity_peak(wheel, sand)[0])
    r = bc.sinkage([0.98 * peak, 1.02 * peak], wheel, sand)
    assert list(r.exceeds_capacity) == [False, True]
    assert float(r.forces.QV[0]) == pytest.approx(0.98 * peak, rel=1e-9)
    assert float(r.max_QV[1]) == pytest.approx(peak, rel=1e-12)
