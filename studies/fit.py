"""Force-sinkage curve summaries (see docs/studies-hpc.md, "Studies and clusters").

    Q_V / (gamma d^3) = k1 sqrt(x) + k2 x + k3 x^2 + k4 x^3,   x = s/d

fitted by linear least squares, with its coefficient of determination R^2.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class ForceSinkageFit:
    """Coefficients k1..k4 (dimensionless) and R^2 of the report's fit form."""

    k: tuple[float, float, float, float]
    r_squared: float
    n_points: int

    def force(self, s, d: float, gamma: float):
        """Q_V (N) of the fitted curve at sinkage ``s`` (m) for wheel diameter d (m), unit weight gamma (N/m^3)."""
        return gamma * d**3 * _basis(np.asarray(s, dtype=float) / d) @ np.asarray(self.k)


def _basis(x):
    return np.stack([np.sqrt(x), x, x**2, x**3], axis=-1)


def fit_force_sinkage(s, QV, d: float, gamma: float) -> ForceSinkageFit:
    """Least-squares fit of a force-sinkage curve (s in m, Q_V in N); needs four points with s > 0."""
    s, QV = np.asarray(s, dtype=float), np.asarray(QV, dtype=float)
    keep = s > 0
    if keep.sum() < 4:
        raise ValueError("the force-sinkage fit needs at least four points with positive sinkage")
    x, y = s[keep] / d, QV[keep] / (gamma * d**3)
    A = _basis(x)
    k, *_ = np.linalg.lstsq(A, y, rcond=None)
    residual = y - A @ k
    total = np.sum((y - y.mean()) ** 2)
    r2 = 1.0 - float(residual @ residual) / float(total) if total > 0 else 1.0
    return ForceSinkageFit(tuple(float(v) for v in k), r2, int(keep.sum()))


def sinkage_at_loads(s, QV, loads):
    """Sinkage (m) where the measured curve first reaches each load (linear between points).

    NaN for a load the curve never reaches.
    """
    s, QV = np.asarray(s, dtype=float), np.asarray(QV, dtype=float)
    out = []
    for load in np.atleast_1d(loads):
        above = np.nonzero(QV >= load)[0]
        if above.size == 0:
            out.append(np.nan)
            continue
        j = above[0]
        if j == 0:
            out.append(s[0] * load / QV[0] if QV[0] > 0 else s[0])
            continue
        t = (load - QV[j - 1]) / (QV[j] - QV[j - 1])
        out.append(s[j - 1] + t * (s[j] - s[j - 1]))
    return np.array(out)
