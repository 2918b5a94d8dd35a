"""The estimates ``summary.json`` gives for each regularisation a run applied (numpy-free, no DOLFINx)."""
import math

import pytest

from rollsim.solver.regularisation import (COHESION_EXPONENT, FALLBACK_BIAS, RELAXATION_INDENTATION, cohesion_bias,
                                           regularisation_summary, relaxation_bias)

#: Q_V (kN) at s/d = 0.02 / 0.05 / 0.1 on the fast wheel, pointwise, phi = 40 deg (docs/benchmarks.md,
#: "c = 0 soil"): c = 0 exactly and c_reg = 0.5 / 1 / 2 kPa
QV_C0 = (16.6, 35.4, 43.1)
QV_CREG = {500.0: (21.9, 44.9, 57.6), 1000.0: (25.3, 49.2, 69.0), 2000.0: (31.1, 60.4, 82.2)}


def _mean_bias(c_reg):
    return sum(100 * (q / q0 - 1) for q, q0 in zip(QV_CREG[c_reg], QV_C0)) / 3


def test_cohesion_bias_grows_as_the_measured_power_of_c_reg():
    """The exponent is the slope of the measured mean bias between 0.5 and 2 kPa, and the power law
    passes within 5 % of the middle point; outside the measured range the estimate says so."""
    slope = math.log(_mean_bias(2000.0) / _mean_bias(500.0)) / math.log(4.0)
    assert COHESION_EXPONENT == pytest.approx(slope, abs=0.01)
    middle = _mean_bias(500.0) * 2 ** COHESION_EXPONENT
    assert middle == pytest.approx(_mean_bias(1000.0), rel=0.05)
    (lo, hi), inside = cohesion_bias(1e3)
    assert inside and lo == pytest.approx(min(100 * (q / q0 - 1) for q, q0 in zip(QV_CREG[1000.0], QV_C0)), abs=0.1)
    assert hi == 97.0                      # B-bar at s/d = 0.1: 45.4 against 23.0 kN
    assert cohesion_bias(2e3)[0][0] > lo and not cohesion_bias(100.0)[1]


def test_relaxation_bias_follows_the_measured_tables():
    for mm, bias in RELAXATION_INDENTATION:
        (_, hi), inside = relaxation_bias(mm * 1e-3, "indentation")
        assert hi == pytest.approx(bias) and inside
    biases = [relaxation_bias(L, "indentation")[0][1] for L in (2e-6, 1e-5, 1e-4, 1e-3)]
    assert biases == sorted(biases)
    assert not relaxation_bias(1e-7, "indentation")[1]            # shorter than measured: flagged
    (lo, hi), inside = relaxation_bias(1e-3, "rolling-continuous")
    assert (lo, hi) == (0.0, pytest.approx(3.0)) and inside       # about 3 % per mm, first order
    # c = 0 exactly: the rolling table (docs/limitations.md, "Purely frictional soil": Q_V at
    # s/d = 0.01 / 0.02 / 0.03 with 1 mm, against the Richardson and Aitken values at length 0)
    qv_1mm, qv_0 = (17.7, 29.2, 39.2), ((9.4, 7.2), (13.8, 11.7), (16.6, 11.6))
    measured = [100 * (q / q0 - 1) for q, pair in zip(qv_1mm, qv_0) for q0 in pair]
    (lo, hi), inside = relaxation_bias(1e-3, "rolling-continuous", cohesionless=True)
    assert inside and lo == pytest.approx(min(measured), abs=0.5) and hi == pytest.approx(max(measured), abs=0.5)
    (lo, hi), inside = relaxation_bias(5e-4, "rolling-constant-load", cohesionless=True)
    assert inside and (lo, hi) == (50.0, 153.0)
    assert not relaxation_bias(2e-3, "rolling-continuous", cohesionless=True)[1]


def test_regularisation_summary_lists_what_was_applied():
    assert regularisation_summary("indentation", regularised={}, relaxation_length=0.0,
                                  plateau_tolerance=1e-3, plateau_share=0.0) == []
    entries = regularisation_summary("rolling-constant-load", regularised={"soil.layers[1]": 1e3},
                                     relaxation_length=5e-4, plateau_tolerance=1e-3, plateau_share=2e-4)
    kinds = {e["kind"]: e for e in entries}
    assert kinds["regularising_cohesion"]["applies_to"] == "soil.layers[1]"
    assert kinds["regularising_cohesion"]["effect"]["percent"] == [39.0, 97.0]
    relax = kinds["duvaut_lions"]["effect"]
    assert relax["quantity"] == "sinkage" and relax["percent"] == [-1.5, 0.0]    # less sinkage
    assert kinds["newton_plateaus"]["effect"]["percent"] == [-0.02, 0.02]
    assert all(e["tighten"].startswith(("lower", "halve")) and e["key"].startswith("model.") for e in entries)


def test_fallback_relaxation_is_listed_with_its_stretches():
    """A run the fallback relaxed lists each stretch; a run it did not relax lists nothing."""
    assert regularisation_summary("indentation", regularised={}, relaxation_length=0.0, plateau_tolerance=1e-3,
                                  plateau_share=0.0, relaxation_fallback=1e-5, relaxed_spans=[]) == []
    (entry,) = regularisation_summary("indentation", regularised={}, relaxation_length=0.0, plateau_tolerance=1e-3,
                                      plateau_share=0.0, relaxation_fallback=1e-5,
                                      relaxed_spans=[(0.01, 0.0176), (0.03, 0.0376)])
    assert entry["kind"] == "duvaut_lions_fallback" and entry["key"] == "model.relaxation_fallback"
    assert entry["value"] == 1e-5 and entry["effect"]["measured_range"]
    assert entry["applies_to"] == "soil, over s = 0.01-0.0176 m, s = 0.03-0.0376 m"
    assert entry["effect"]["percent"] == list(FALLBACK_BIAS) and entry["tighten"].startswith("halve")
    assert not regularisation_summary("indentation", regularised={}, relaxation_length=0.0, plateau_tolerance=1e-3,
                                      plateau_share=0.0, relaxation_fallback=1e-3,
                                      relaxed_spans=[(0.01, 0.02)])[0]["effect"]["measured_range"]


def test_travel_fallback_is_listed_with_its_stretches():
    """A roll the travel fallback relaxed lists each stretch of travel; the effect is that of the
    whole path relaxed by the same length, with the sign of the protocol's quantity."""
    kw = dict(regularised={}, relaxation_length=0.0, plateau_tolerance=1e-3, plateau_share=0.0)
    assert regularisation_summary("rolling-constant-load", travel_relaxation_fallback=5e-4, relaxed_travel=[], **kw) == []
    (entry,) = regularisation_summary("rolling-constant-load", travel_relaxation_fallback=5e-4,
                                      relaxed_travel=[(0.5, 0.65)], **kw)
    assert entry["kind"] == "duvaut_lions_travel_fallback" and entry["key"] == "model.travel_relaxation_fallback"
    assert entry["applies_to"] == "soil, over travel = 0.5-0.65 m" and entry["effect"]["measured_range"]
    assert entry["effect"] == entry["effect"] | {"quantity": "sinkage", "percent": [-1.5, 0.0]}
    (entry,) = regularisation_summary("rolling-continuous", travel_relaxation_fallback=2e-3,
                                      relaxed_travel=[(0.5, 0.65)], **kw)
    assert entry["effect"]["percent"] == [0.0, 6.0] and not entry["effect"]["measured_range"]
    (entry,) = regularisation_summary("rolling-constant-load", travel_relaxation_fallback=5e-4,
                                      relaxed_travel=[(0.5, 2.2)], cohesionless=True, **kw)
    # Q_V +50 to +153 % at 0.5 mm, Q_V ~ s**0.5: the sinkage 1.5**-2 to 2.53**-2 of the unrelaxed one
    assert entry["effect"]["percent"] == [-84.4, -55.6] and entry["effect"]["measured_range"]
    assert "c = 0 sand" in entry["effect"]["basis"]
