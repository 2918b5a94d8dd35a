"""The bearing-capacity wheel model: the wheel's contact patch as a shallow footing.

Implements the bearing-capacity wheel model (docs/theory.md) of the Mn/DOT report "Development of
Improved Test Rolling Methods for Roadway Embankment Construction" (Ch. 3 and App. A) from the
general Meyerhof formula, every wheel case derived from it.
Everything is vectorised: arguments broadcast as numpy arrays. SI units; angles in
radians (``phi``, ``beta``).

Forward:  :func:`wheel_forces` (sinkage -> forces), :func:`sinkage` (load -> sinkage,
with an explicit "exceeds capacity" outcome), :func:`capacity_peak`.
Inverse:  :func:`cohesion_from_sinkage`, :func:`friction_angle_from_sinkage`,
:func:`strength_from_two_measurements`, :func:`strength_profile`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rollsim.units import InputError

MODES = ("indentation", "rolling")
METHODS = ("footing", "load")
DEPTHS = ("modified", "theory")
SHAPES = ("cylinder", "torus")
VALIDITY_RANGE = (0.01, 0.08)  # s/d where the model is meant to be used
SEARCH_LIMIT = 0.5  # largest s/d searched for a root or a capacity peak
PHI_MAX = np.radians(70.0)  # upper end of the friction-angle search
NC0 = 2.0 + np.pi  # Prandtl's N_c for phi = 0


# --------------------------------------------------------------------------- inputs
@dataclass(frozen=True)
class Wheel:
    """A wheel: ``diameter`` d and ``width`` b (m); ``flexibility`` lambda (m/N), 0 = rigid."""

    diameter: float | np.ndarray
    width: float | np.ndarray
    shape: str = "cylinder"
    flexibility: float | np.ndarray = 0.0

    def __post_init__(self):
        _positive("d", self.diameter)
        _positive("b", self.width)
        _non_negative("flex", self.flexibility)
        if self.shape not in SHAPES:
            raise InputError("shape", f"must be one of {', '.join(SHAPES)}, got {self.shape!r}")


@dataclass(frozen=True)
class Soil:
    """Mohr-Coulomb soil: cohesion ``c`` (Pa), friction angle ``phi`` (rad), unit weight ``gamma`` (N/m^3)."""

    c: float | np.ndarray
    phi: float | np.ndarray
    gamma: float | np.ndarray

    def __post_init__(self):
        _non_negative("c", self.c)
        _positive("gamma", self.gamma)
        phi = np.asarray(self.phi, dtype=float)
        if not np.all(np.isfinite(phi)) or np.any(phi < 0) or np.any(phi >= np.pi / 2):
            raise InputError("phi", "friction angle must be in [0, 90) deg")


@dataclass(frozen=True)
class Options:
    """Which case of the model: ``mode``, rolling ``method`` and equivalent-depth choice."""

    mode: str = "rolling"
    method: str = "footing"
    depth: str = "modified"

    def __post_init__(self):
        for name, value, allowed in (("mode", self.mode, MODES), ("method", self.method, METHODS),
                                     ("depth", self.depth, DEPTHS)):
            if value not in allowed:
                raise InputError(name, f"must be one of {', '.join(allowed)}, got {value!r}")


def _positive(field, value):
    v = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(v)) or np.any(v <= 0):
        raise InputError(field, "must be a positive number")


def _non_negative(field, value):
    v = np.asarray(value, dtype=float)
    if not np.all(np.isfinite(v)) or np.any(v < 0):
        raise InputError(field, "must be zero or positive")


# ----------------------------------------------------------------- Meyerhof formula
def bearing_factors(phi):
    """Bearing-capacity factors (N_c, N_q, N_gamma) of friction angle ``phi`` (rad).

    N_c is evaluated as expm1(.)/tan(phi), accurate down to phi -> 0 where it tends
    smoothly to 2 + pi.
    """
    t = np.tan(phi)
    log_nq = 2.0 * np.arcsinh(t) + np.pi * t  # ln N_q: tan(pi/4 + phi/2) = exp(asinh(tan phi))
    nq = np.exp(log_nq)
    with np.errstate(divide="ignore", invalid="ignore"):
        nc = np.where(t > 0, np.expm1(log_nq) / np.where(t > 0, t, 1.0), NC0)
    ngamma = 2.0 * (nq + 1.0) * t
    return nc, nq, ngamma


def depth_eta(phi):
    """eta of the theoretical equivalent depth D = eta s / 6."""
    return np.sin(np.pi / 4 - phi / 2) / np.sin(np.pi / 4 + phi / 2) * np.exp(-np.pi / 2 * np.tan(phi))


def footing_capacity(B, L, D, beta, c, phi, gamma, method="footing"):
    """Ultimate bearing pressure q_u (Pa) of a B x L footing at depth D, inclination beta.

    ``method`` picks the inclination factors: "load" (inclined load on level ground)
    or "footing" (footing on ground sloping at beta, load normal to it). beta = 0 is
    a vertical load for both.
    """
    nc, nq, ngamma = bearing_factors(phi)
    t = np.tan(phi)
    ratio = B / L
    fcs = 1.0 + ratio * nq / nc
    fqs = 1.0 + ratio * t
    fgs = 1.0 - 0.4 * ratio
    d_over_b = D / B
    r = np.where(d_over_b <= 1.0, d_over_b, np.arctan(d_over_b))
    fcd = 1.0 + 0.4 * r
    fqd = 1.0 + 2.0 * t * (1.0 - np.sin(phi)) ** 2 * r
    if method == "load":
        fci = fqi = (1.0 - 2.0 * beta / np.pi) ** 2
        with np.errstate(divide="ignore", invalid="ignore"):
            fgi = np.where(beta < phi, (1.0 - beta / np.where(phi > 0, phi, 1.0)) ** 2, 0.0)
    else:
        log_nq = 2.0 * np.arcsinh(t) + np.pi * t
        with np.errstate(divide="ignore", invalid="ignore"):
            fci = np.where(t > 0, np.expm1(log_nq - 2.0 * beta * t) / np.where(t > 0, np.expm1(log_nq), 1.0),
                           (NC0 - 2.0 * beta) / NC0)
        fqi = fgi = (1.0 - np.tan(beta)) ** 2
    return (c * nc * fcs * fcd * fci
            + gamma * D * nq * fqs * fqd * fqi
            + 0.5 * gamma * B * ngamma * fgs * fgi)


def _formula_force(s, d, b, shape, soil: Soil, opts: Options):
    """(Q, beta): the formula's force (N) and load inclination at sinkage s for wheel diameter d."""
    if opts.mode == "indentation":
        h = 2.0 * np.sqrt(np.maximum(d * s - s * s, 0.0))
        beta = np.zeros_like(h)
        bc = (np.where(s < b / 2, 2.0 * np.sqrt(np.maximum(b * s - s * s, 0.0)), b)
              if shape == "torus" else b + 0.0 * h)
    else:
        h = np.sqrt(np.maximum(d * s - s * s, 0.0)) if opts.method == "load" else np.sqrt(d * s)
        beta = np.sqrt(s / d)
        bc = b + 0.0 * h
    B = np.minimum(h, bc)
    L = np.maximum(h, bc)
    D = s if opts.depth == "modified" else depth_eta(soil.phi) * s / 6.0
    with np.errstate(divide="ignore", invalid="ignore"):
        q = footing_capacity(np.where(B > 0, B, 1.0), np.where(L > 0, L, 1.0), D, beta,
                             soil.c, soil.phi, soil.gamma, opts.method)
    return np.where(B > 0, q * h * bc, 0.0), beta


# --------------------------------------------------------------------- root finding
def _illinois(f, lo, hi, flo=None, fhi=None, rtol=1e-14, maxiter=200):
    """Vectorised bracketed root of f (Illinois regula falsi): f(lo), f(hi) of opposite sign."""
    lo, hi = np.array(lo, dtype=float), np.array(hi, dtype=float)
    flo = f(lo) if flo is None else np.array(flo, dtype=float)
    fhi = f(hi) if fhi is None else np.array(fhi, dtype=float)
    side = np.zeros(lo.shape, dtype=int)
    x = lo.copy()
    for _ in range(maxiter):
        with np.errstate(divide="ignore", invalid="ignore"):
            x = np.where(fhi != flo, hi - fhi * (hi - lo) / (fhi - flo), 0.5 * (lo + hi))
        x = np.where((x > np.minimum(lo, hi)) & (x < np.maximum(lo, hi)), x, 0.5 * (lo + hi))
        fx = f(x)
        same_as_hi = np.sign(fx) == np.sign(fhi)
        # the endpoint that stays twice in a row gets its value halved (Illinois)
        flo = np.where(same_as_hi & (side == 1), 0.5 * flo, flo)
        fhi = np.where(~same_as_hi & (side == -1), 0.5 * fhi, fhi)
        hi, fhi = np.where(same_as_hi, x, hi), np.where(same_as_hi, fx, fhi)
        lo, flo = np.where(~same_as_hi, x, lo), np.where(~same_as_hi, fx, flo)
        side = np.where(same_as_hi, 1, -1)
        if np.all((np.abs(hi - lo) <= rtol * np.maximum(np.abs(x), 1e-300)) | (fx == 0)):
            break
    return x


def _implicit_force(s, wheel: Wheel, soil: Soil, opts: Options):
    """(Q, beta, d_e) of a flexible wheel: Q = F(s, d + lambda Q), solved by bracketing.

    Q is the formula's force: Q_V for indentation, the inclined total force for rolling.
    """
    d, b, lam = wheel.diameter, wheel.width, wheel.flexibility
    q0, _ = _formula_force(s, d, b, wheel.shape, soil, opts)

    def g(q):
        return _formula_force(s, d + lam * q, b, wheel.shape, soil, opts)[0] - q

    hi = 2.0 * q0 + 1.0
    for _ in range(200):  # F grows like sqrt(Q): doubling brackets the fixed point quickly
        ghi = g(hi)
        if np.all(ghi <= 0):
            break
        hi = np.where(ghi > 0, 2.0 * hi, hi)
    q = np.where(q0 > 0, _illinois(g, np.zeros_like(hi), hi, flo=q0, fhi=ghi), 0.0)
    d_e = d + lam * q
    return q, _formula_force(s, d_e, b, wheel.shape, soil, opts)[1], d_e


@dataclass
class Forces:
    """Wheel forces at a sinkage (N); ``beta`` the load inclination (rad); ``d_e`` the wheel diameter used (m)."""

    QV: np.ndarray
    QH: np.ndarray
    Q: np.ndarray
    beta: np.ndarray
    d_e: np.ndarray


def wheel_forces(s, wheel: Wheel, soil: Soil, opts: Options = Options()) -> Forces:
    """Forces on the wheel at sinkage ``s`` (m), any case of the model."""
    s = np.asarray(s, dtype=float)
    d, lam = np.asarray(wheel.diameter, dtype=float), np.asarray(wheel.flexibility, dtype=float)
    if np.all(lam == 0):
        q, beta = _formula_force(s, d, wheel.width, wheel.shape, soil, opts)
        d_e = d + 0 * q
    else:
        if opts.mode == "rolling" and opts.method != "footing":
            raise InputError("method", "a flexible rolling wheel uses the footing method")
        q, beta, d_e = _implicit_force(s, wheel, soil, opts)
    return Forces(QV=q * np.cos(beta), QH=q * np.sin(beta), Q=q, beta=beta, d_e=d_e)


# ------------------------------------------------------------------ load -> sinkage
def _broadcast_shape(wheel: Wheel, soil: Soil, *extra):
    return np.broadcast_shapes(*(np.shape(v) for v in (wheel.diameter, wheel.width, wheel.flexibility,
                                                       soil.c, soil.phi, soil.gamma, *extra)))


def capacity_peak(wheel: Wheel, soil: Soil, opts: Options = Options()):
    """(max Q_V (N), sinkage at the maximum (m)) over 0 < s/d <= SEARCH_LIMIT.

    A coarse logarithmic scan finds the best grid point; golden-section search
    refines the maximum between its neighbours. A curve still rising at the end
    of the range peaks at the end.
    """
    d = np.asarray(wheel.diameter, dtype=float) + np.zeros(_broadcast_shape(wheel, soil))
    grid = np.geomspace(1e-4, SEARCH_LIMIT, 48)
    values = np.stack([wheel_forces(x * d, wheel, soil, opts).QV for x in grid])
    k = np.argmax(values, axis=0)
    a = grid[np.maximum(k - 1, 0)] * d
    b = grid[np.minimum(k + 1, grid.size - 1)] * d
    r = (np.sqrt(5.0) - 1.0) / 2.0

    def qv(x):
        return wheel_forces(x, wheel, soil, opts).QV

    x1, x2 = b - r * (b - a), a + r * (b - a)
    f1, f2 = qv(x1), qv(x2)
    for _ in range(80):
        left = f1 >= f2  # the maximum lies in [a, x2]
        a, b = np.where(left, a, x1), np.where(left, x2, b)
        x_new = np.where(left, b - r * (b - a), a + r * (b - a))
        f_new = qv(x_new)
        x1, f1, x2, f2 = (np.where(left, x_new, x2), np.where(left, f_new, f2),
                          np.where(left, x1, x_new), np.where(left, f1, f_new))
        if np.all(b - a <= 1e-12 * d):
            break
    s_peak = np.where(k == grid.size - 1, grid[-1] * d, 0.5 * (a + b))
    return qv(s_peak), s_peak


class SinkageResult:
    """Sinkage (m) for a load; NaN where the load exceeds the capacity peak.

    ``max_QV`` (N) and ``sinkage_at_max`` (m) describe the peak of the Q_V(s) curve;
    they are computed on first use where the solve did not need them.
    """

    def __init__(self, s, forces: Forces, exceeds, peak=None, curve=None):
        self.sinkage, self.forces, self.exceeds_capacity = s, forces, exceeds
        self._peak, self._curve = peak, curve

    def _peak_values(self):
        if self._peak is None:
            self._peak = capacity_peak(*self._curve)
        return self._peak

    @property
    def max_QV(self):
        return self._peak_values()[0] + np.zeros(np.shape(self.sinkage))

    @property
    def sinkage_at_max(self):
        return self._peak_values()[1] + np.zeros(np.shape(self.sinkage))

    @property
    def in_validity_range(self):
        x = self.sinkage / self.forces.d_e
        return (x >= VALIDITY_RANGE[0]) & (x <= VALIDITY_RANGE[1])


def _first_crossing(carries, d, shape, s_end):
    """Bracket (lo, hi, found) of the first grid sinkage below ``s_end`` where ``carries(s) >= 0``."""
    grid = np.geomspace(1e-6, SEARCH_LIMIT, 64)
    lo, hi = np.zeros(shape), s_end + np.zeros(shape)
    found = np.zeros(shape, dtype=bool)
    for x in grid:
        s_x = x * d
        before_end = s_x < s_end
        above = before_end & ~found & (carries(s_x) >= 0)
        hi = np.where(above, s_x, hi)
        found |= above
        lo = np.where(before_end & ~found, s_x, lo)
    return lo, hi, found


def sinkage(load, wheel: Wheel, soil: Soil, opts: Options = Options()) -> SinkageResult:
    """Sinkage under the vertical wheel load ``load`` = Q_V (N): the first root of Q_V(s) = load.

    Where the load is above the curve's maximum there is no steady sinkage: the
    result is NaN with ``exceeds_capacity`` set (never a spurious root).
    """
    load = np.asarray(load, dtype=float)
    _positive("load", load)
    shape = _broadcast_shape(wheel, soil, load)
    load = load + np.zeros(shape)
    d = np.asarray(wheel.diameter, dtype=float) + np.zeros(shape)
    if np.all(np.asarray(wheel.flexibility) == 0):
        peak, s_peak = (v + np.zeros(shape) for v in capacity_peak(wheel, soil, opts))
        exceeds = load > peak
        target = np.where(exceeds, np.nan, load)

        def residual(s):
            return wheel_forces(s, wheel, soil, opts).QV - target

        lo, hi, _ = _first_crossing(residual, d, shape, s_peak)
        peak_values = (peak, s_peak)
    else:
        # For a known load the flexible wheel's diameter d_e(s, load) does not depend on
        # the soil, and Q_V,flex(s) >= load exactly when the rigid wheel of diameter
        # d_e(s, load) carries the load: one cheap solve instead of a nested one.
        if opts.mode == "rolling" and opts.method != "footing":
            raise InputError("method", "a flexible rolling wheel uses the footing method")

        def residual(s):
            rigid = Wheel(effective_diameter(s, load, wheel, opts), wheel.width, wheel.shape)
            return wheel_forces(s, rigid, soil, opts).QV - load

        lo, hi, found = _first_crossing(residual, d, shape, SEARCH_LIMIT * d)
        exceeds = ~found
        peak_values = None
    s = _illinois(residual, lo, hi)
    s = np.where(exceeds, np.nan, s)
    result = SinkageResult(s, None, exceeds, peak_values, (wheel, soil, opts))
    result.forces = wheel_forces(np.where(exceeds, result.sinkage_at_max if np.any(exceeds) else 0.0, s),
                                 wheel, soil, opts)
    return result


# ------------------------------------------------------------------------- inverses
def effective_diameter(s, load, wheel: Wheel, opts: Options = Options()):
    """Wheel diameter d_e (m) of the model for a known load Q_V (N) at sinkage s (m).

    Rigid: d. Flexible indentation: d + lambda Q_V. Flexible rolling: d + lambda Q with
    Q cos(sqrt(s/d_e)) = Q_V, solved by bracketing (independent of the soil).
    """
    s, load = np.asarray(s, dtype=float), np.asarray(load, dtype=float)
    d, lam = np.asarray(wheel.diameter, dtype=float), np.asarray(wheel.flexibility, dtype=float)
    if np.all(lam == 0):
        return d + 0.0 * s * load
    if opts.mode == "indentation":
        return d + lam * load

    def residual(q):
        return q * np.cos(np.sqrt(s / (d + lam * q))) - load

    q = _illinois(residual, load + 0.0 * s, load / np.cos(np.sqrt(s / d)))
    return d + lam * q


def _rigid_equivalent(s, load, wheel: Wheel, opts: Options) -> Wheel:
    return Wheel(effective_diameter(s, load, wheel, opts), wheel.width, wheel.shape)


def cohesion_from_sinkage(s, load, wheel: Wheel, phi, gamma, opts: Options = Options()):
    """Cohesion c (Pa) that gives sinkage ``s`` (m) under ``load`` Q_V (N) with ``phi`` (rad) fixed.

    Q_V is linear in c at a fixed sinkage, so the inversion is exact. NaN where
    friction and weight alone already carry more than the load (no c >= 0 fits).
    """
    _positive("sinkage", s)
    _positive("load", load)
    rigid = _rigid_equivalent(s, load, wheel, opts)
    q0 = wheel_forces(s, rigid, Soil(0.0, phi, gamma), opts).QV
    q1 = wheel_forces(s, rigid, Soil(1.0, phi, gamma), opts).QV
    c = (np.asarray(load, dtype=float) - q0) / (q1 - q0)
    return np.where(c >= 0, c, np.nan)


def friction_angle_from_sinkage(s, load, wheel: Wheel, c, gamma, opts: Options = Options()):
    """Friction angle phi (rad) that gives sinkage ``s`` (m) under ``load`` Q_V (N) with ``c`` (Pa) fixed.

    NaN where the cohesion alone carries more than the load, or where even
    phi = PHI_MAX carries less.
    """
    _positive("sinkage", s)
    _positive("load", load)
    load = np.asarray(load, dtype=float)
    rigid = _rigid_equivalent(s, load, wheel, opts)

    def residual(phi):
        return wheel_forces(s, rigid, Soil(c, phi, gamma), opts).QV - load

    shape = np.broadcast_shapes(np.shape(s), load.shape, np.shape(c), np.shape(gamma),
                                np.shape(rigid.diameter), np.shape(wheel.width))
    lo, hi = np.zeros(shape), np.full(shape, PHI_MAX)
    flo, fhi = residual(lo), residual(hi)
    ok = (flo <= 0) & (fhi >= 0)
    phi = _illinois(residual, lo, hi, flo=np.where(ok, flo, -1.0), fhi=np.where(ok, fhi, 1.0))
    return np.where(ok, phi, np.nan)


@dataclass
class TwoMeasurementResult:
    """c (Pa) and phi (rad) from two measurements, with their sensitivity to a 1 % sinkage error."""

    c: float
    phi: float
    dc_per_percent: float
    dphi_per_percent: float
    ill_conditioned: bool


# a 1 % sinkage error moving phi by more than this, or c by more than the larger of
# the two bounds below, makes a two-measurement pair too ill-conditioned to trust
ILL_CONDITIONED_DPHI = np.radians(2.0)
ILL_CONDITIONED_DC_REL, ILL_CONDITIONED_DC_ABS = 0.25, 2e3


def strength_from_two_measurements(s1, load1, wheel1: Wheel, s2, load2, wheel2: Wheel, gamma,
                                   opts: Options = Options()) -> TwoMeasurementResult:
    """Both c and phi from two (sinkage, load, wheel) measurements on the same soil.

    c is eliminated with the first measurement (Q_V is linear in c); the second
    gives a scalar equation in phi, whose first root with c >= 0 is bracketed on a
    scan and refined. Raises ``InputError`` when no (c >= 0, phi) fits both.
    """
    r1, r2 = _rigid_equivalent(s1, load1, wheel1, opts), _rigid_equivalent(s2, load2, wheel2, opts)

    def qv(s, rigid, c, phi):
        """Q_V, using that it is linear in c (so c < 0 can be probed during the scan)."""
        q0 = wheel_forces(s, rigid, Soil(0.0, phi, gamma), opts).QV
        return q0 + c * (wheel_forces(s, rigid, Soil(1.0, phi, gamma), opts).QV - q0)

    def c_from_first(phi):
        q0 = qv(s1, r1, 0.0, phi)
        return (load1 - q0) / (qv(s1, r1, 1.0, phi) - q0)

    def residual(phi):
        return qv(s2, r2, c_from_first(phi), phi) - load2

    grid = np.linspace(0.0, PHI_MAX, 141)
    c_grid = np.array([float(c_from_first(p)) for p in grid])
    r_grid = np.array([float(residual(p)) for p in grid])
    roots = [i for i in range(grid.size - 1)
             if np.sign(r_grid[i]) != np.sign(r_grid[i + 1]) and max(c_grid[i], c_grid[i + 1]) >= 0]
    if r_grid[0] == 0:
        roots.insert(0, 0)
    if not roots:
        raise InputError("sinkage2", "no soil (c >= 0, phi) reproduces both measurements")
    i = roots[0]
    phi = float(_illinois(residual, grid[i], grid[i + 1], flo=r_grid[i], fhi=r_grid[i + 1]))
    c = float(c_from_first(phi))
    if c < 0:
        raise InputError("sinkage2", "the measurements need a negative cohesion")
    # sensitivity: J d(c, phi) = (dQ1/ds1 ds1, dQ2/ds2 ds2) for a 1 % error in each sinkage
    hc, hp = max(1.0, 1e-4 * c), 1e-6

    def jac_row(s, rigid):
        return [(qv(s, rigid, c + hc, phi) - qv(s, rigid, c - hc, phi)) / (2 * hc),
                (qv(s, rigid, c, phi + hp) - qv(s, rigid, c, phi - hp)) / (2 * hp)]

    def dq_ds(s, rigid):
        return (qv(s * 1.001, rigid, c, phi) - qv(s * 0.999, rigid, c, phi)) / (0.002 * s)

    jac = np.array([jac_row(s1, r1), jac_row(s2, r2)], dtype=float).reshape(2, 2)
    rhs = np.diag([float(dq_ds(s1, r1)) * 0.01 * s1, float(dq_ds(s2, r2)) * 0.01 * s2])
    try:
        delta = np.abs(np.linalg.solve(jac, rhs))
        dc, dphi = float(delta[0].max()), float(delta[1].max())
    except np.linalg.LinAlgError:
        dc = dphi = float("inf")
    ill = dphi > ILL_CONDITIONED_DPHI or dc > max(ILL_CONDITIONED_DC_REL * c, ILL_CONDITIONED_DC_ABS)
    return TwoMeasurementResult(c=c, phi=phi, dc_per_percent=dc, dphi_per_percent=dphi, ill_conditioned=ill)


@dataclass
class StrengthProfile:
    """Strength along a station: ``strength`` is c (Pa) or phi (rad) per record point."""

    position: np.ndarray
    sinkage: np.ndarray
    strength: np.ndarray
    passes: np.ndarray
    quantity: str  # "c" or "phi"


def strength_profile(position, s, load, wheel: Wheel, gamma, *, c=None, phi=None, minimum,
                     opts: Options = Options()) -> StrengthProfile:
    """A continuous sinkage record -> strength per point and pass/fail against ``minimum``.

    Give exactly one of ``c`` (Pa, held fixed: phi is found, minimum in rad) or
    ``phi`` (rad, held fixed: c is found, minimum in Pa). A point whose strength
    cannot be found (NaN) fails.
    """
    if (c is None) == (phi is None):
        raise InputError("c/phi", "hold exactly one of c or phi fixed")
    s = np.asarray(s, dtype=float)
    if phi is None:
        strength, quantity = friction_angle_from_sinkage(s, load, wheel, c, gamma, opts), "phi"
    else:
        strength, quantity = cohesion_from_sinkage(s, load, wheel, phi, gamma, opts), "c"
    passes = np.nan_to_num(strength, nan=-np.inf) >= minimum
    return StrengthProfile(np.asarray(position, dtype=float), s, strength, passes, quantity)
