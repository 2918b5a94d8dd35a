"""Soil materials: isotropic linear elasticity + perfect plasticity (SI units, angles in radians).

Sign convention: stresses tension-positive (as in the FE code); the yield functions use the
*compression-positive* mean pressure ``p = -tr(sigma)/3`` and the von Mises equivalent stress
``q = sqrt(3/2 s:s)``.  Drucker-Prager::

    f(sigma) = q - p tan(phi_dp) - c_dp <= 0           (yield surface, a cone; apex p = -c_dp/tan(phi_dp))
    g(sigma) = q - p tan(psi_dp)                          (plastic potential; psi_dp = phi_dp is associated)

von Mises is the same code with ``tan(phi_dp) = tan(psi_dp) = 0`` and ``c_dp = yield_stress``.

Mohr-Coulomb (c, phi) -> Drucker-Prager (c_dp, phi_dp) matchings
-----------------------------------------------------------------
* triaxial compression (outer cone, through the compressive meridian)::

      tan(phi_dp) = 6 sin(phi) / (3 - sin(phi)),   c_dp = 6 c cos(phi) / (3 - sin(phi))

* triaxial extension (inner cone): the same with ``3 + sin(phi)``.
* plane strain, associated flow (Drucker & Prager 1952).  Derivation: let the in-plane principal
  stresses be ``sigma_1, sigma_3`` with centre ``m = (sigma_1 + sigma_3)/2`` (tension positive) and
  radius ``t = (sigma_1 - sigma_3)/2``, and ``sigma_zz = m + d``.  Then ``q^2 = 3 t^2 + d^2`` and
  ``p = -m - d/3``.  Plane strain with associated flow needs ``d eps_zz^p ∝ df/dsigma_zz =
  d/q + T/3 = 0`` (``T = tan(phi_dp)``), i.e. ``d = -q T / 3``.  Hence ``q^2 (1 - T^2/9) = 3 t^2``
  and ``f = 0`` gives ``q (1 - T^2/9) = c_dp - T m``; eliminating ``q``::

      t = (c_dp - T m) / sqrt(3 - T^2/3)

  which is Mohr-Coulomb ``t = c cos(phi) - m sin(phi)`` if and only if::

      tan(phi_dp) = 3 sin(phi) / sqrt(3 + sin(phi)^2),   c_dp = 3 c cos(phi) / sqrt(3 + sin(phi)^2)

  (equivalently ``alpha = tan(phi)/sqrt(9 + 12 tan^2 phi)``, ``k = 3c/sqrt(9 + 12 tan^2 phi)`` in
  ``alpha I1 + sqrt(J2) = k``).  ``phi = 0`` gives ``c_dp = sqrt(3) c``: von Mises with
  ``q = sqrt(3) c``, the plane-strain match of Tresca.
* plane strain with the flow rule (``matching="plane_strain_flow"``, the scene's ``match =
  "plane-strain-flow"``; dilation angle ``psi < phi``).  The same argument with the
  potential ``g = q - p tan(psi_dp)`` gives ``d = -q P / 3`` (``P = tan(psi_dp)``) and::

      t = (c_dp - T m) sqrt(1 - P^2/9) / (sqrt(3) (1 - T P / 9))

  so Mohr-Coulomb (c, phi) needs ``T = sqrt(3) sin(phi) / (sqrt(1 - P^2/9) + sqrt(3) sin(phi) P / 9)``
  and ``c_dp = sqrt(3) c cos(phi) (1 - T P / 9) / sqrt(1 - P^2/9)``; ``psi = 0`` gives
  ``tan(phi_dp) = sqrt(3) sin(phi)``, ``c_dp = sqrt(3) c cos(phi)``.  The dilation angle maps like
  the associated friction angle, ``P = 3 sin(psi) / sqrt(3 + sin(psi)^2)``: that is the in-plane
  dilatancy ``sin(psi) = (deps_1 + deps_3) / (deps_1 - deps_3)`` of the cone's flow.  This cone is
  steeper than the associated one (phi = 40 deg, psi = 0: tan(phi_dp) = 1.113 against 1.044).
  ``"plane_strain"`` keeps the associated formula whatever ``psi`` is (the c = 0 wheel runs were
  tuned and measured with it): with ``psi = 0`` it is, in plane strain, a Mohr-Coulomb soil of
  28.7 / 33.0 / 37.1 / 40.9 deg for phi = 30 / 35 / 40 / 45 deg (see docs/theory.md, "Soil").
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from .options import DEFAULT_REGULARISING_COHESION

__all__ = ["VonMises", "DruckerPrager", "mc_to_dp", "dp_to_mc", "von_mises_from_tresca", "jaky_k0",
           "admissible_k0", "PHI_COMPRESSION_MATCH_LIMIT", "regularised_cohesion"]

# The regularising ("numerical") cohesion put in place of c = 0 by regularised_cohesion (and by
# scene_model.layer_material for scene layers), options.DEFAULT_REGULARISING_COHESION (1 kPa), is
# NOT negligible for a wheel: near the surface the frictional strength gamma z tan(phi) is itself
# of order 1 kPa: on the 3D wheel it raises Q_V markedly against c = 0 exactly.  c = 0 exactly
# runs too ([model] regularising_cohesion = 0), slower, and stalls pointwise at steep angles
# (measured: see docs/benchmarks.md, "c = 0 soil").

#: Above this Mohr-Coulomb angle (asin 0.6 = 36.87 deg) the compression-matched Drucker-Prager cone
#: has tan(phi_dp) >= 1.5: it has no extension-matched Mohr-Coulomb angle, i.e. it is stronger in
#: triaxial extension than any Mohr-Coulomb material.  With psi = 0 such cones stall the 3D wheel
#: indentation near its start (see docs/benchmarks.md, "c = 0 soil"); prefer the plane-strain match
#: there.
PHI_COMPRESSION_MATCH_LIMIT = math.asin(0.6)

MATCHINGS = ("compression", "extension", "plane_strain", "plane_strain_flow")


def _check_elastic(E: float, nu: float) -> None:
    if not (isinstance(E, (int, float)) and math.isfinite(E) and E > 0):
        raise ValueError(f"E must be a positive finite number (Pa), got {E!r}")
    if not (isinstance(nu, (int, float)) and -1.0 < nu < 0.5):
        raise ValueError(f"nu must lie in (-1, 0.5), got {nu!r}")


@dataclass(frozen=True)
class _Elastic:
    E: float
    nu: float

    @property
    def shear_modulus(self) -> float:
        return self.E / (2.0 * (1.0 + self.nu))

    @property
    def bulk_modulus(self) -> float:
        return self.E / (3.0 * (1.0 - 2.0 * self.nu))

    @property
    def lame_lambda(self) -> float:
        return self.E * self.nu / ((1.0 + self.nu) * (1.0 - 2.0 * self.nu))


@dataclass(frozen=True)
class VonMises(_Elastic):
    """Elastic-perfectly plastic von Mises: ``q <= yield_stress`` (Pa).

    For plane-strain Tresca cohesion ``c`` use ``yield_stress = sqrt(3) c``
    (:func:`von_mises_from_tresca`).
    """

    yield_stress: float

    def __post_init__(self):
        _check_elastic(self.E, self.nu)
        if not (isinstance(self.yield_stress, (int, float)) and math.isfinite(self.yield_stress)
                and self.yield_stress > 0):
            raise ValueError(f"yield_stress must be a positive finite number (Pa), got {self.yield_stress!r}")

    # unified Drucker-Prager parameters used by the return map
    @property
    def tan_phi(self) -> float:
        return 0.0

    @property
    def tan_psi(self) -> float:
        return 0.0

    @property
    def cohesion(self) -> float:
        return float(self.yield_stress)


@dataclass(frozen=True)
class DruckerPrager(_Elastic):
    """Elastic-perfectly plastic Drucker-Prager cone ``q - p tan(phi_dp) = c_dp``.

    ``phi_dp`` and ``dilation`` (= ``psi_dp``, angle of the potential ``q - p tan(psi_dp)``) in
    radians, ``c_dp`` in Pa (``c_dp = 0``: purely frictional, cone apex at the origin).
    ``dilation = 0`` (default) is isochoric flow on the smooth part; ``dilation = phi_dp`` is
    associated.  Build from Mohr-Coulomb parameters with :meth:`from_mohr_coulomb`.
    """

    phi_dp: float
    c_dp: float
    dilation: float = 0.0

    def __post_init__(self):
        _check_elastic(self.E, self.nu)
        if not (isinstance(self.phi_dp, (int, float)) and 0.0 <= self.phi_dp < math.pi / 2):
            raise ValueError(f"phi_dp must be an angle in [0, pi/2) radians, got {self.phi_dp!r}")
        if not (isinstance(self.c_dp, (int, float)) and math.isfinite(self.c_dp) and self.c_dp >= 0):
            raise ValueError(f"c_dp must be a finite number >= 0 (Pa), got {self.c_dp!r}")
        if not (isinstance(self.dilation, (int, float)) and 0.0 <= self.dilation <= self.phi_dp + 1e-15):
            raise ValueError(f"dilation must be an angle in [0, phi_dp] radians, got {self.dilation!r}")
        if self.c_dp == 0 and self.phi_dp == 0:
            raise ValueError("c_dp and phi_dp are both zero: no strength (c_dp must be > 0 when phi_dp = 0)")

    @property
    def tan_phi(self) -> float:
        return math.tan(self.phi_dp)

    @property
    def tan_psi(self) -> float:
        return math.tan(self.dilation)

    @property
    def cohesion(self) -> float:
        return float(self.c_dp)

    @classmethod
    def from_mohr_coulomb(cls, E: float, nu: float, c: float, phi: float, psi: float | None = 0.0,
                          matching: str = "compression") -> "DruckerPrager":
        """Drucker-Prager matched to Mohr-Coulomb (c [Pa], phi, psi [rad]); ``psi=None`` -> associated.

        ``matching="plane_strain_flow"``: the cone whose plane-strain strength with the dilation
        ``psi`` is Mohr-Coulomb's (module docstring); ``"plane_strain"`` assumes associated flow."""
        phi_dp, c_dp = mc_to_dp(c, phi, matching, psi=psi)
        if psi is None:
            psi_dp = phi_dp
        else:
            psi_dp, _ = mc_to_dp(0.0, psi, matching)
        return cls(E=E, nu=nu, phi_dp=phi_dp, c_dp=c_dp, dilation=min(psi_dp, phi_dp))


@dataclass(frozen=True)
class NeoHookean:
    """Compressible neo-Hookean solid (finite strain): Young's modulus ``E`` (Pa) and Poisson's
    ratio ``nu`` of its small-strain limit.  Strain energy per unit reference volume
    ``psi(F) = mu/2 (tr(F^T F) - 3) - mu ln J + lambda/2 (ln J)^2``, ``J = det F``."""

    E: float
    nu: float

    def __post_init__(self):
        if not self.E > 0:
            raise ValueError(f"E must be > 0 (Pa), got {self.E}")
        if not -1 < self.nu < 0.5:
            raise ValueError(f"nu must be in (-1, 0.5), got {self.nu}")

    @property
    def mu(self) -> float:
        """Shear modulus, Pa."""
        return self.E / (2 * (1 + self.nu))

    @property
    def lmbda(self) -> float:
        """Lame's first parameter, Pa."""
        return self.E * self.nu / ((1 + self.nu) * (1 - 2 * self.nu))

    def first_piola(self, F):
        """First Piola-Kirchhoff stress (UFL) of the deformation gradient ``F``:
        ``P = mu (F - F^-T) + lambda ln(J) F^-T``."""
        import ufl          # the constitutive code above runs without the finite-element stack
        F_inv_T = ufl.inv(F).T
        return self.mu * (F - F_inv_T) + self.lmbda * ufl.ln(ufl.det(F)) * F_inv_T


def mc_to_dp(c: float, phi: float, matching: str = "compression", psi: float | None = None) -> tuple[float, float]:
    """Mohr-Coulomb (c [Pa], phi [rad]) -> Drucker-Prager (phi_dp [rad], c_dp [Pa]).

    ``psi`` (rad, dilation angle; None = associated) is used by ``"plane_strain_flow"`` only."""
    if matching not in MATCHINGS:
        raise ValueError(f"matching must be one of {MATCHINGS}, got {matching!r}")
    if not 0.0 <= phi < math.pi / 2:
        raise ValueError(f"phi must be in [0, pi/2) radians, got {phi!r}")
    if c < 0:
        raise ValueError(f"c must be >= 0, got {c!r}")
    s, co = math.sin(phi), math.cos(phi)
    if matching == "compression":
        return math.atan(6 * s / (3 - s)), 6 * c * co / (3 - s)
    if matching == "extension":
        return math.atan(6 * s / (3 + s)), 6 * c * co / (3 + s)
    if matching == "plane_strain" or psi is None or psi >= phi:
        r = math.sqrt(3 + s * s)
        return math.atan(3 * s / r), 3 * c * co / r
    if psi < 0:
        raise ValueError(f"psi must be in [0, phi] radians, got {psi!r}")
    P = math.tan(mc_to_dp(0.0, psi, "plane_strain")[0])     # the dilation maps like an associated angle
    R, root3 = math.sqrt(1 - P * P / 9), math.sqrt(3.0)
    T = root3 * s / (R + root3 * s * P / 9)
    return math.atan(T), root3 * c * co * (1 - T * P / 9) / R


def dp_to_mc(phi_dp: float, c_dp: float, matching: str = "compression",
             psi_dp: float | None = None) -> tuple[float, float]:
    """Inverse of :func:`mc_to_dp`: (phi_dp [rad], c_dp [Pa]) -> (c [Pa], phi [rad]).

    ``psi_dp`` (rad, the cone's dilation; None = associated) is used by ``"plane_strain_flow"`` only."""
    if matching not in MATCHINGS:
        raise ValueError(f"matching must be one of {MATCHINGS}, got {matching!r}")
    T = math.tan(phi_dp)
    if matching == "compression":
        s = 3 * T / (6 + T)           # T (3 - s) = 6 s
        if s >= 1:
            raise ValueError(f"phi_dp = {phi_dp} has no compression-matched Mohr-Coulomb angle")
        phi = math.asin(s)
        c = c_dp * (3 - s) / (6 * math.cos(phi))
    elif matching == "extension":
        s = 3 * T / (6 - T)
        if not 0 <= s < 1:
            raise ValueError(f"phi_dp = {phi_dp} has no extension-matched Mohr-Coulomb angle")
        phi = math.asin(s)
        c = c_dp * (3 + s) / (6 * math.cos(phi))
    else:
        P = T if matching == "plane_strain" or psi_dp is None else min(math.tan(psi_dp), T)
        R, den = math.sqrt(max(1 - P * P / 9, 0.0)), math.sqrt(3) * (1 - T * P / 9)
        s = T * R / den if den > 0 else math.inf            # sin(phi), module docstring
        if not 0 <= s < 1:
            raise ValueError(f"phi_dp = {phi_dp} has no plane-strain-matched Mohr-Coulomb angle")
        phi = math.asin(s)
        c = c_dp * R / (den * math.cos(phi))
    return c, phi


def regularised_cohesion(c: float, phi: float, c_reg: float = DEFAULT_REGULARISING_COHESION) -> tuple[float, bool]:
    """Cohesion to use for a soil with (c [Pa], phi [rad]): ``(c_reg, True)`` for a purely frictional
    soil (``c == 0``, ``phi > 0``), else ``(c, False)``.

    A small cohesion keeps the stress-free surface inside the yield surface (the cone's apex moves
    to the tensile mean stress ``c_reg cot(phi)``), so near-surface points are elastic rather than
    on the apex, whose tangent is zero.  It is a numerical device, not soil data, and it raises
    the wheel force measurably (``options.DEFAULT_REGULARISING_COHESION``): callers must report it, and results should
    be checked against smaller values (``python -m benchmarks indentation frictional` --creg 1 0.5 0``)."""
    if not (math.isfinite(c_reg) and c_reg > 0):
        raise ValueError(f"c_reg must be a positive finite number (Pa), got {c_reg!r}")
    if c == 0 and phi > 0:
        return float(c_reg), True
    return c, False


def von_mises_from_tresca(E: float, nu: float, c: float) -> VonMises:
    """Plane-strain match of a Tresca material with cohesion (undrained strength) ``c``."""
    return VonMises(E=E, nu=nu, yield_stress=math.sqrt(3.0) * c)


def jaky_k0(phi: float) -> float:
    """Jaky's at-rest coefficient ``K0 = 1 - sin(phi)`` (phi in radians, Mohr-Coulomb angle)."""
    if not 0.0 <= phi < math.pi / 2:
        raise ValueError(f"phi must be in [0, pi/2) radians, got {phi!r}")
    return 1.0 - math.sin(phi)


def admissible_k0(material, K0: float | None, max_vertical_stress: float, ncomp: int = 4,
                  margin: float = 0.1) -> tuple[float, bool]:
    """Geostatic coefficient actually usable with ``material``: ``(K0_used, clipped)``.

    The geostatic state ``sigma_v = -s``, ``sigma_h = -K0 s`` (all non-vertical normal stresses) is
    checked at the deepest point ``s = max_vertical_stress`` (Pa, > 0): for the cone and for
    Mohr-Coulomb the stress ratio violates yield worst at depth (cohesion helps relatively less
    there), for von Mises too.  ``K0=None`` means the elastic value ``nu/(1-nu)``.  If the state is
    inadmissible, K0 is moved towards 1 (hydrostatic, always admissible in compression): to the
    yield boundary ``K_b`` found by bisection plus ``margin (1 - K_b)``; ``clipped`` is True then
    (the caller should warn).  Example: nu = 0.3 gives 0.4286, outside the plane-strain-matched
    cone of phi = 30 deg (which needs K0 >= 0.465) - Jaky's 1 - sin(phi) = 0.5 is inside.
    """
    from .return_map import yield_function
    K = material.nu / (1.0 - material.nu) if K0 is None else float(K0)
    if not (math.isfinite(K) and K >= 0):
        raise ValueError(f"K0 must be a finite number >= 0, got {K0!r}")
    if not max_vertical_stress > 0:
        return K, False

    def f(k):
        sig = [-k * max_vertical_stress] * 3 + [0.0] * (ncomp - 3)
        sig[1 if ncomp == 4 else 2] = -max_vertical_stress
        return float(yield_function(material, [sig])[0])

    scale = max_vertical_stress + getattr(material, "cohesion", 0.0)
    if f(K) <= -1e-12 * scale:
        return K, False
    lo, hi = K, 1.0                       # f(lo) > 0, f(1) < 0
    for _ in range(80):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if f(mid) > 0 else (lo, mid)
    return hi + margin * (1.0 - hi), True
