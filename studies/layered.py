"""Influence depth of a second soil layer under a rolling rigid wheel (docs/theory.md).

The depth H at which a lower layer starts to change the sinkage, from setting the
two-layer capacity (Meyerhof & Hanna 1978, via Das 1995) equal to the top-layer
capacity, with the rolling footing B, L (h = sqrt(d s)) and D of the wheel model.
"""
from __future__ import annotations

import csv
import pathlib
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from rollsim.studies.bearing_capacity import Options, Soil, Wheel, bearing_factors, depth_eta, sinkage
from rollsim.units import InputError

KS_TABLE = pathlib.Path(__file__).with_name("data") / "ks_meyerhof_hanna.csv"
NC_STRIP = 5.14
CASES = ("strong-over-weak-clay", "sand-over-weak-clay", "weak-over-strong")


@lru_cache(maxsize=1)
def _ks_curves():
    rows = [r for r in csv.reader(line for line in KS_TABLE.open() if not line.startswith("#"))][1:]
    curves: dict[float, list[tuple[float, float]]] = {}
    for ratio, phi, ks in rows:
        curves.setdefault(float(ratio), []).append((float(phi), float(ks)))
    return {k: (np.array([p for p, _ in v]), np.array([x for _, x in v])) for k, v in sorted(curves.items())}


def punching_coefficient(phi1, q_ratio):
    """(Ks, extrapolated) of Meyerhof & Hanna for top friction angle ``phi1`` (rad) and q2/q1.

    Linear in phi1 along each digitised curve and linear in q2/q1 between curves
    (source and accuracy in ``data/ks_meyerhof_hanna.csv``). Outside 20-50 deg the
    end values are held and ``extrapolated`` is set.
    """
    phi_deg = np.degrees(np.asarray(phi1, dtype=float))
    ratio = np.clip(np.asarray(q_ratio, dtype=float), 0.0, 1.0)
    curves = _ks_curves()
    ratios = np.array(list(curves))
    values = np.stack([np.interp(phi_deg, *curves[r]) for r in ratios])  # (n_curves, ...)
    k = np.clip(np.searchsorted(ratios, ratio, side="right") - 1, 0, ratios.size - 2)
    w = (ratio - ratios[k]) / (ratios[k + 1] - ratios[k])
    lower = np.take_along_axis(values, k[None, ...], axis=0)[0] if values.ndim > 1 else values[k]
    upper = np.take_along_axis(values, (k + 1)[None, ...], axis=0)[0] if values.ndim > 1 else values[k + 1]
    ks = (1 - w) * lower + w * upper
    extrapolated = (phi_deg < 20.0) | (phi_deg > 50.0) | (np.asarray(q_ratio) > 1.0)
    return ks, extrapolated


def adhesion_ratio(r):
    """c_a / c1 for clay over clay with r = c2/c1 (cubic fit to Das 1995)."""
    return 0.321 * r**3 - 1.023 * r**2 + 1.08 * r + 0.621


@dataclass
class InfluenceDepth:
    """Influence depth ``H_m`` (m) of the lower layer and how it was found.

    NaN where the load exceeds the top layer's rolling capacity (no steady sinkage).
    """

    H_m: np.ndarray
    case: np.ndarray  # one of CASES per point
    exceeds_capacity: np.ndarray
    sinkage_m: np.ndarray
    B_m: np.ndarray
    L_m: np.ndarray
    Ks: np.ndarray  # NaN where not used
    Ks_extrapolated: np.ndarray


def influence_depth(wheel: Wheel, top: Soil, c2, phi2, *, load=None, s=None, depth="modified") -> InfluenceDepth:
    """Influence depth of a lower layer (c2 Pa, phi2 rad) under a rigid rolling wheel.

    Give the wheel ``load`` Q_V (N) or the sinkage ``s`` (m) on the top layer.
    Cases: strong clay over weak clay, sand (c = 0) over weak clay (punching
    shear), and weak over strong (H = B). Other pairs raise ``InputError``.
    """
    if (load is None) == (s is None):
        raise InputError("load/sinkage", "give exactly one of the load or the sinkage")
    if np.any(np.asarray(wheel.flexibility) != 0):
        raise InputError("flex", "the influence-depth model is for a rigid wheel")
    opts = Options(mode="rolling", method="footing", depth=depth)
    exceeds = np.asarray(False)
    if s is None:
        result = sinkage(load, wheel, top, opts)
        exceeds = result.exceeds_capacity
        s = np.where(exceeds, result.sinkage_at_max, result.sinkage)
    s = np.asarray(s, dtype=float)
    d, b = wheel.diameter, wheel.width
    h = np.sqrt(d * s)
    B, L = np.minimum(h, b), np.maximum(h, b)
    D = s if depth == "modified" else depth_eta(top.phi) * s / 6.0
    c1, phi1, g1 = (np.asarray(v, dtype=float) for v in (top.c, top.phi, top.gamma))
    c2, phi2 = np.asarray(c2, dtype=float), np.asarray(phi2, dtype=float)
    ratio = B / L
    shape = np.broadcast_shapes(s.shape, c1.shape, phi1.shape, c2.shape, phi2.shape, np.shape(d))

    # strong clay over weak clay
    r = np.divide(c2, c1, out=np.ones(np.broadcast_shapes(c1.shape, c2.shape)), where=c1 > 0)
    ca = adhesion_ratio(r) * c1
    with np.errstate(divide="ignore", invalid="ignore"):
        h_clay = NC_STRIP * (1 + 0.2 * ratio) * (c1 - c2) * B / (2.0 * ca * (1 + ratio))
    clay_clay = (phi1 == 0) & (phi2 == 0)

    # dense sand over weak clay: a quadratic in H
    _, nq1, ng1 = bearing_factors(phi1)
    q_top = g1 * D * nq1 + 0.5 * (1 - 0.4 * ratio) * g1 * B * ng1
    with np.errstate(divide="ignore", invalid="ignore"):
        q_ratio = 2.0 * NC_STRIP * c2 / (g1 * B * ng1)  # = 10.28 c2 / (gamma1 B Ngamma1) = q2/q1
    ks, ks_extra = punching_coefficient(phi1, np.nan_to_num(q_ratio, nan=1.0, posinf=1.0))
    surplus = q_top - NC_STRIP * (1 + 0.2 * ratio) * c2 - g1 * D
    with np.errstate(divide="ignore", invalid="ignore"):
        k = surplus * B / ((1 + ratio) * g1 * ks * np.tan(phi1))
        h_sand = -D + np.sqrt(D * D + np.maximum(k, 0.0))
    sand_clay = (c1 == 0) & (phi1 > 0) & (phi2 == 0)

    strong_over_weak = np.where(clay_clay, c2 < c1, np.where(sand_clay, (q_ratio < 1) & (surplus > 0), False))
    # any other pair is covered only when the lower layer is the stronger one
    other = ~clay_clay & ~sand_clay
    if np.any(other):
        from rollsim.studies.bearing_capacity import footing_capacity
        lower_stronger = (footing_capacity(B, L, D, 0.0, c2, phi2, g1)
                          >= footing_capacity(B, L, D, 0.0, c1, phi1, g1))
        if np.any(other & ~lower_stronger):
            raise InputError("c2/phi2", "a stronger top layer is covered for clay over clay and for "
                             "sand (c = 0) over clay (phi2 = 0) only")
    case_index = np.where(strong_over_weak, np.where(clay_clay, 0, 1), 2) + np.zeros(shape, dtype=int)
    H = np.choose(case_index, [h_clay + np.zeros(shape), h_sand + np.zeros(shape), B + np.zeros(shape)])
    H = np.where(exceeds, np.nan, H)
    uses_ks = case_index == 1
    return InfluenceDepth(H_m=H, case=np.array(CASES)[case_index], exceeds_capacity=exceeds + np.zeros(shape, bool),
                          sinkage_m=np.where(exceeds, np.nan, s) + np.zeros(shape),
                          B_m=B + np.zeros(shape), L_m=L + np.zeros(shape),
                          Ks=np.where(uses_ks, ks, np.nan), Ks_extrapolated=uses_ks & ks_extra)
