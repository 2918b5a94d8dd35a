"""Influence depth (layered soil), DCP correlations and unit handling against closed forms."""
import math

import numpy as np
import pytest

from rollsim.studies import dcp, layered
from rollsim.studies.bearing_capacity import Soil, Wheel, bearing_factors
from rollsim.units import ANGLE, FLEXIBILITY, FORCE, LENGTH, PRESSURE, UNIT_WEIGHT, InputError, to_si

MNDOT = Wheel(1.524, 0.4572)


def test_strong_over_weak_clay_closed_form():
    c1, c2, s = 200e3, 50e3, 0.04
    r = layered.influence_depth(MNDOT, Soil(c1, 0.0, 20e3), c2, 0.0, s=s)
    h = math.sqrt(1.524 * s)
    B, L = min(h, 0.4572), max(h, 0.4572)
    x = c2 / c1
    ca = c1 * (0.321 * x**3 - 1.023 * x**2 + 1.08 * x + 0.621)
    # 5.14 (1 + 0.2 B/L) c2 + (1 + B/L) 2 ca H / B = 5.14 (1 + 0.2 B/L) c1
    H = 5.14 * (1 + 0.2 * B / L) * (c1 - c2) * B / ((1 + B / L) * 2 * ca)
    assert str(r.case) == "strong-over-weak-clay"
    assert float(r.H_m) == pytest.approx(H, rel=1e-12)


def test_sand_over_weak_clay_satisfies_the_punching_equation():
    phi1, c2, g = math.radians(40), 15e3, 20e3
    r = layered.influence_depth(MNDOT, Soil(0.0, phi1, g), c2, 0.0, load=60e3)
    assert str(r.case) == "sand-over-weak-clay" and not r.Ks_extrapolated
    s, B, L, H, ks = float(r.sinkage_m), float(r.B_m), float(r.L_m), float(r.H_m), float(r.Ks)
    D = s
    _, nq, ng = bearing_factors(phi1)
    lhs = 5.14 * (1 + 0.2 * B / L) * c2 + (1 + B / L) * g * H**2 * (1 + 2 * D / H) * ks * math.tan(phi1) / B + g * D
    rhs = g * D * nq + 0.5 * (1 - 0.4 * B / L) * g * B * ng
    assert lhs == pytest.approx(rhs, rel=1e-10)
    # Ks read at delta = 10.28 c2 / (gamma B Ngamma)
    delta = 10.28 * c2 / (g * B * ng)
    assert ks == pytest.approx(float(layered.punching_coefficient(phi1, delta)[0]), rel=1e-12)


def test_weak_over_strong_is_B():
    r = layered.influence_depth(MNDOT, Soil(50e3, 0.0, 20e3), 150e3, 0.0, load=60e3)
    assert str(r.case) == "weak-over-strong" and float(r.H_m) == float(r.B_m)


def test_influence_depth_over_capacity_is_nan():
    r = layered.influence_depth(MNDOT, Soil(0.0, math.radians(35), 20e3), 10e3, 0.0, load=np.array([20e3, 500e3]))
    assert np.isfinite(r.H_m[0]) and np.isnan(r.H_m[1]) and list(r.exceeds_capacity) == [False, True]


def test_uncovered_layer_pair_is_refused():
    with pytest.raises(InputError):  # a c-phi top layer over weaker clay is outside the model
        layered.influence_depth(MNDOT, Soil(80e3, math.radians(30), 20e3), 5e3, 0.0, load=60e3)


@pytest.mark.parametrize("ratio, phi_deg, ks", [(0.0, 40.00, 2.26), (0.2, 35.00, 3.11), (0.4, 45.07, 11.11),
                                                (1.0, 30.00, 6.07)])
def test_punching_coefficient_reproduces_digitised_points(ratio, phi_deg, ks):
    got, extrapolated = layered.punching_coefficient(math.radians(phi_deg), ratio)
    assert float(got) == pytest.approx(ks, rel=1e-9) and not extrapolated


def test_punching_coefficient_interpolates_and_flags_extrapolation():
    mid, _ = layered.punching_coefficient(math.radians(40.0), 0.1)
    assert float(mid) == pytest.approx(0.5 * (2.26 + float(layered.punching_coefficient(math.radians(40.0), 0.2)[0])))
    _, extra = layered.punching_coefficient(np.radians([15.0, 55.0, 35.0]), [0.1, 0.1, 0.1])
    assert list(extra) == [True, True, False]


def test_dcp_correlations():
    pr = np.array([10.0, 15.0, 30.0])
    np.testing.assert_allclose(dcp.cohesion_from_penetration_rate(pr) / 1e3, 3650 * pr ** -1.14, rtol=1e-3)
    assert float(dcp.cbr_from_penetration_rate(1.0)) == pytest.approx(338.8)
    phi, ok = dcp.friction_angle_from_penetration_rate(20.0, 103e3)
    qf = 692 - 6.35 * 20
    assert float(phi) == pytest.approx(math.asin(qf / (qf + 2 * 103)), rel=1e-12) and bool(ok)
    _, ok = dcp.friction_angle_from_penetration_rate(40.0, 34.4e3)
    assert not ok


@pytest.mark.parametrize("value, kind, si", [
    ("1.52 m", LENGTH, 1.52), ("60 in", LENGTH, 1.524), (1.5, LENGTH, 1.5), ("2.5", LENGTH, 2.5),
    ("170 kPa", PRESSURE, 170e3), ("25 psi", PRESSURE, 172368.932),
    ("133.5 kN", FORCE, 133.5e3), ("15 ton", FORCE, 15 * 2000 * 0.45359237 * 9.80665),
    ("20 kN/m^3", UNIT_WEIGHT, 20e3), ("127 pcf", UNIT_WEIGHT, 127 * 4.4482216152605 / 0.3048**3),
    ("0.01 m/kN", FLEXIBILITY, 1e-5), ("27.5 deg", ANGLE, 27.5), (30, ANGLE, 30.0),
    ("0.5 rad", ANGLE, math.degrees(0.5))])
def test_units(value, kind, si):
    assert to_si(value, kind, "x") == pytest.approx(si, rel=1e-6)


@pytest.mark.parametrize("value, kind", [("3 kg", LENGTH), ("fast", FORCE), ("5 m", ANGLE), (True, LENGTH),
                                         ([1], PRESSURE), ("nan", LENGTH)])
def test_bad_units_name_the_field(value, kind):
    with pytest.raises(InputError) as e:
        to_si(value, kind, "wheel.diameter")
    assert e.value.field == "wheel.diameter" and str(e.value).startswith("wheel.diameter: ")
