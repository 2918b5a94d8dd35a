"""The force-sinkage fit recovers known coefficients and reads sinkage off a curve."""
import numpy as np
import pytest

from rollsim.studies.fit import fit_force_sinkage, sinkage_at_loads

D, GAMMA = 1.524, 20e3


@pytest.mark.parametrize("k", [(12.0, 150.0, -400.0, 900.0), (3.5, 0.0, 0.0, 0.0), (0.0, 80.0, 25.0, -3.0)])
def test_exact_recovery_without_noise(k):
    s = np.linspace(0.0, 0.1, 41) * D
    x = s / D
    qv = GAMMA * D**3 * (k[0] * np.sqrt(x) + k[1] * x + k[2] * x**2 + k[3] * x**3)
    fit = fit_force_sinkage(s, qv, D, GAMMA)
    np.testing.assert_allclose(fit.k, k, rtol=0, atol=1e-10 * max(abs(v) for v in k))
    assert fit.r_squared == pytest.approx(1.0, abs=1e-12) and fit.n_points == 40
    np.testing.assert_allclose(fit.force(s, D, GAMMA), qv, rtol=1e-10, atol=1e-6)


def test_noise_lowers_r_squared_and_stays_close():
    rng = np.random.default_rng(0)
    s = np.linspace(0.002, 0.1, 60) * D
    x = s / D
    clean = GAMMA * D**3 * (10 * np.sqrt(x) + 100 * x)
    fit = fit_force_sinkage(s, clean * (1 + 0.02 * rng.standard_normal(x.size)), D, GAMMA)
    assert 0.98 < fit.r_squared < 1.0
    in_range = x >= 0.01  # near s = 0 the sqrt(x) term has the most leverage on noise
    np.testing.assert_allclose(fit.force(s, D, GAMMA)[in_range], clean[in_range], rtol=0.05)


def test_too_few_points():
    with pytest.raises(ValueError):
        fit_force_sinkage([0.0, 0.01, 0.02, 0.03], [0, 1, 2, 3], D, GAMMA)


def test_sinkage_at_loads_interpolates_first_crossing():
    s = np.array([0.0, 0.01, 0.02, 0.03, 0.04])
    qv = np.array([0.0, 10e3, 30e3, 25e3, 60e3])  # a dip: the first crossing counts
    np.testing.assert_allclose(sinkage_at_loads(s, qv, [5e3, 20e3, 27e3, 100e3])[:3], [0.005, 0.015, 0.0185])
    assert np.isnan(sinkage_at_loads(s, qv, [100e3])[0])
