"""Vectorised implicit return map (closed form) and consistent tangent for von Mises / Drucker-Prager.

Stress and strain are **Mandel** vectors (tension positive)::

    3D  (6): [xx, yy, zz, sqrt2*xy, sqrt2*yz, sqrt2*xz]
    2D  (4): [xx, yy, zz, sqrt2*xy]        (plane strain: eps_zz = 0 but sigma_zz is kept)

so that ``sigma : eps`` is a plain dot product, the 4th-order tensors are ordinary matrices and the
same code serves plane strain and 3D (the out-of-plane shear components decouple and stay zero).

Algorithm (perfect plasticity, backward Euler; e.g. de Souza Neto, Peric & Owen 2008, ch. 8).
With trial stress ``sigma_tr = sigma_n + D deps``, ``p_tr = -tr(sigma_tr)/3``,
``s_tr = dev(sigma_tr)``, ``q_tr = sqrt(3/2) |s_tr|``, ``n = s_tr/|s_tr|`` and
``f_tr = q_tr - tan(phi) p_tr - c``:

* elastic if ``f_tr <= 0``;
* return to the smooth cone: the flow direction ``dg/dsigma = sqrt(3/2) n + tan(psi)/3 I`` is
  fixed by the trial state, so the consistency condition is linear::

      dlam = f_tr / (3G + K tan(phi) tan(psi)),   q = q_tr - 3G dlam,   p = p_tr + K tan(psi) dlam

* if that gives ``q < 0`` the trial state lies beyond the cone's apex: return to the APEX
  ``sigma = (c / tan(phi)) I`` (``p = -c/tan(phi)``, ``q = 0``); for ``c = 0`` this is the
  stress-free state.  The plastic strain increment absorbs the whole deviatoric trial stress and
  the volumetric excess (for ``psi = 0`` this acts as a tension cut-off at the apex).  The regions
  meet continuously at ``q = 0``.

Consistent (algorithmic) tangent, smooth return (non-symmetric when psi != phi)::

    C = D - (a_g (x) a_f) / H - (2G sqrt(3/2) dlam 2G / |s_tr|) (P_dev - n (x) n)
    a_g = 2G sqrt(3/2) n + K tan(psi) I,  a_f = 2G sqrt(3/2) n + K tan(phi) I,  H = 3G + K tan(phi) tan(psi)

and ``C = 0`` at the apex (the returned stress does not depend on the strain there).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["ELASTIC", "PLASTIC", "APEX", "ReturnResult", "return_map", "duvaut_lions", "relax_return", "elastic_stiffness",
           "identity_vector", "deviatoric_projector", "invariants", "yield_function",
           "tensor_to_mandel", "mandel_to_tensor"]

ELASTIC, PLASTIC, APEX = 0, 1, 2
SQ2 = np.sqrt(2.0)
SQ32 = np.sqrt(1.5)


def point_arrays(sigma_n, deps) -> tuple[np.ndarray, np.ndarray]:
    """``(sigma_n, deps)`` as float arrays of shape (points, components), checked alike."""
    sigma_n = np.atleast_2d(np.asarray(sigma_n, dtype=float))
    deps = np.atleast_2d(np.asarray(deps, dtype=float))
    _check_ncomp(deps.shape[1])
    if sigma_n.shape != deps.shape:
        raise ValueError(f"sigma_n {sigma_n.shape} and deps {deps.shape} differ in shape")
    return sigma_n, deps


def _check_ncomp(ncomp: int) -> None:
    if ncomp not in (4, 6):
        raise ValueError(f"Mandel vectors have 4 (plane strain) or 6 (3D) components, got {ncomp}")


def identity_vector(ncomp: int) -> np.ndarray:
    _check_ncomp(ncomp)
    one = np.zeros(ncomp)
    one[:3] = 1.0
    return one


def deviatoric_projector(ncomp: int) -> np.ndarray:
    one = identity_vector(ncomp)
    return np.eye(ncomp) - np.outer(one, one) / 3.0


def elastic_stiffness(material, ncomp: int) -> np.ndarray:
    """Isotropic elasticity ``D = 2G P_dev + K I (x) I`` as a Mandel matrix."""
    one = identity_vector(ncomp)
    return (2.0 * material.shear_modulus * deviatoric_projector(ncomp)
            + material.bulk_modulus * np.outer(one, one))


def tensor_to_mandel(t: np.ndarray, ncomp: int = 6) -> np.ndarray:
    """Symmetric 3x3 tensor(s) ``(..., 3, 3)`` -> Mandel vector(s)."""
    t = np.asarray(t)
    v = [t[..., 0, 0], t[..., 1, 1], t[..., 2, 2], SQ2 * t[..., 0, 1]]
    if ncomp == 6:
        v += [SQ2 * t[..., 1, 2], SQ2 * t[..., 0, 2]]
    return np.stack(v, axis=-1)


def mandel_to_tensor(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v)
    t = np.zeros(v.shape[:-1] + (3, 3))
    t[..., 0, 0], t[..., 1, 1], t[..., 2, 2] = v[..., 0], v[..., 1], v[..., 2]
    t[..., 0, 1] = t[..., 1, 0] = v[..., 3] / SQ2
    if v.shape[-1] == 6:
        t[..., 1, 2] = t[..., 2, 1] = v[..., 4] / SQ2
        t[..., 0, 2] = t[..., 2, 0] = v[..., 5] / SQ2
    return t


def invariants(sigma: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(p, q) of Mandel stresses ``(n, ncomp)``: ``p = -tr/3`` (compression +), ``q = sqrt(3/2 s:s)``."""
    sigma = np.atleast_2d(sigma)
    tr = sigma[:, :3].sum(axis=1)
    s = sigma.copy()
    s[:, :3] -= tr[:, None] / 3.0
    return -tr / 3.0, SQ32 * np.linalg.norm(s, axis=1)


def yield_function(material, sigma: np.ndarray) -> np.ndarray:
    if hasattr(material, "yield_function"):          # e.g. SmoothedMohrCoulomb
        return material.yield_function(np.atleast_2d(sigma))
    p, q = invariants(sigma)
    return q - material.tan_phi * p - material.cohesion


@dataclass
class ReturnResult:
    sigma: np.ndarray        # (n, ncomp) updated stress
    tangent: np.ndarray | None  # (n, ncomp, ncomp) consistent tangent d sigma / d eps
    deps_p: np.ndarray       # (n, ncomp) plastic strain increment (Mandel)
    dlam: np.ndarray         # (n,) plastic multiplier increment (0 elastic; apex: 0, see deps_p)
    state: np.ndarray        # (n,) int8: ELASTIC, PLASTIC or APEX

    def counts(self) -> dict[str, int]:
        return {"elastic": int(np.sum(self.state == ELASTIC)), "plastic": int(np.sum(self.state == PLASTIC)),
                "apex": int(np.sum(self.state == APEX))}


def return_map(material, sigma_n: np.ndarray, deps: np.ndarray, tangent: bool = True,
               rtol: float = 1e-10) -> ReturnResult:
    """Return map of the strain increments ``deps`` from the converged stresses ``sigma_n``.

    ``material`` is a :class:`~rollsim.solver.materials.VonMises` or
    :class:`~rollsim.solver.materials.DruckerPrager`; ``sigma_n`` and ``deps`` are ``(n, ncomp)``
    Mandel arrays (ncomp 4 or 6).  Points with ``f_tr > -rtol * scale`` are returned plastically
    (``dlam = max(f_tr, 0)/H``), so points sitting on the yield surface get the elastoplastic
    tangent at zero increment (the first Newton iteration of a step then starts from the
    continuum tangent instead of the elastic one).

    Materials that carry their own return map (:class:`~rollsim.solver.smoothed_mc.SmoothedMohrCoulomb`)
    are dispatched to it, so :class:`PlasticityProblem` works with them unchanged.
    """
    if hasattr(material, "return_map"):
        return material.return_map(sigma_n, deps, tangent=tangent, rtol=rtol)
    sigma_n, deps = point_arrays(sigma_n, deps)
    n, ncomp = deps.shape
    G, K = material.shear_modulus, material.bulk_modulus
    lam = K - 2.0 * G / 3.0
    tphi, tpsi, c = material.tan_phi, material.tan_psi, material.cohesion

    tr_de = deps[:, :3].sum(axis=1)
    sig_tr = sigma_n + 2.0 * G * deps
    sig_tr[:, :3] += (lam * tr_de)[:, None]
    tr = sig_tr[:, :3].sum(axis=1)
    p_tr = -tr / 3.0
    s_tr = sig_tr.copy()
    s_tr[:, :3] -= (tr / 3.0)[:, None]
    snorm = np.linalg.norm(s_tr, axis=1)
    q_tr = SQ32 * snorm
    f_tr = q_tr - tphi * p_tr - c
    scale = c + tphi * np.abs(p_tr) + q_tr + 1e-300
    plastic = f_tr > -rtol * scale

    H = 3.0 * G + K * tphi * tpsi
    dlam = np.where(plastic, np.maximum(f_tr, 0.0) / H, 0.0)
    q_new = q_tr - 3.0 * G * dlam
    apex = plastic & (q_new <= rtol * scale) & (tphi > 0)
    smooth = plastic & ~apex

    state = np.zeros(n, dtype=np.int8)
    state[smooth] = PLASTIC
    state[apex] = APEX
    sigma = sig_tr.copy()
    deps_p = np.zeros_like(deps)
    one = identity_vector(ncomp)

    # smooth part of the cone
    ns = np.zeros_like(s_tr)
    ok = smooth & (snorm > 0)
    ns[ok] = s_tr[ok] / snorm[ok, None]
    if np.any(smooth):
        dl = dlam[smooth, None]
        nn = ns[smooth]
        sigma[smooth] -= dl * (2.0 * G * SQ32 * nn + K * tpsi * one)
        deps_p[smooth] = dl * (SQ32 * nn + tpsi / 3.0 * one)
    # apex
    if np.any(apex):
        p_apex = -c / tphi
        sigma[apex] = -p_apex * one
        deps_p[apex] = s_tr[apex] / (2.0 * G) + ((p_apex - p_tr[apex]) / (3.0 * K))[:, None] * one
    dlam = np.where(apex, 0.0, dlam)

    Ct = _consistent_tangent(material, smooth, apex, ns, snorm, dlam) if tangent else None
    return ReturnResult(sigma=sigma, tangent=Ct, deps_p=deps_p, dlam=dlam, state=state)


def _consistent_tangent(material, smooth: np.ndarray, apex: np.ndarray, ns: np.ndarray, snorm: np.ndarray,
                        dlam: np.ndarray) -> np.ndarray:
    """The consistent tangent (n, ncomp, ncomp) of :func:`return_map` for the Drucker-Prager
    cone: elastic at the elastic points, zero at the apex, and on the smooth part of the cone
    the elastic stiffness less the (non-associated) plastic part and the flow direction's
    rotation (``ns``: unit deviatoric trial stresses, ``snorm`` their norms, ``dlam`` the
    plastic multipliers)."""
    n, ncomp = ns.shape
    G, K = material.shear_modulus, material.bulk_modulus
    tphi, tpsi = material.tan_phi, material.tan_psi
    one = identity_vector(ncomp)
    Ct = np.broadcast_to(elastic_stiffness(material, ncomp), (n, ncomp, ncomp)).copy()
    if np.any(smooth):
        nn = ns[smooth]
        a_g = 2.0 * G * SQ32 * nn + K * tpsi * one
        a_f = 2.0 * G * SQ32 * nn + K * tphi * one
        beta = np.zeros(nn.shape[0])
        pos = snorm[smooth] > 0
        beta[pos] = 2.0 * G * SQ32 * dlam[smooth][pos] * 2.0 * G / snorm[smooth][pos]
        Pdev = deviatoric_projector(ncomp)
        H = 3.0 * G + K * tphi * tpsi
        Ct[smooth] -= (np.einsum("pi,pj->pij", a_g, a_f) / H
                       + beta[:, None, None] * (Pdev[None] - np.einsum("pi,pj->pij", nn, nn)))
    if np.any(apex):
        Ct[apex] = 0.0
    return Ct


def duvaut_lions(res: ReturnResult, sigma_trial: np.ndarray, D: np.ndarray, relaxation: float,
                 sel=slice(None)) -> None:
    """Duvaut-Lions viscoplastic step (backward Euler, e.g. Simo & Hughes 1998, sec. 2.7) from the
    rate-independent return ``res``, in place for the points ``sel`` (``sigma_trial``: their trial
    stresses, ``D``: their elasticity): with ``r = relaxation`` (the step's pseudo-time over the
    relaxation time) and ``w = r / (1 + r)``::

        sigma = sigma_tr + w (sigma_inv - sigma_tr),   C = (1 - w) D + w C_inv

    and the plastic strain and multiplier increments scaled by ``w``.  ``r = inf`` leaves the
    rate-independent return; as ``r -> 0`` the step becomes elastic, so a cut step is better
    conditioned than the rate-independent one (whose tangent can be near-singular under
    non-associated flow).  Over many steps the stress relaxes to the yield surface with the
    relaxation time: the overstress in steady flow is ``D`` times the plastic strain over one
    relaxation time."""
    if not relaxation >= 0:
        raise ValueError(f"relaxation must be >= 0, got {relaxation}")
    if math.isinf(relaxation):
        return
    w = relaxation / (1.0 + relaxation)
    res.sigma[sel] = sigma_trial + w * (res.sigma[sel] - sigma_trial)
    if res.tangent is not None:
        res.tangent[sel] = (1.0 - w) * D + w * res.tangent[sel]
    res.deps_p[sel] *= w
    res.dlam[sel] *= w


def relax_return(material, res: ReturnResult, sigma_n: np.ndarray, deps: np.ndarray, relaxation: float,
                 sel=slice(None), D: np.ndarray | None = None) -> None:
    """:func:`duvaut_lions` after :func:`return_map` of ``material`` from ``sigma_n`` by ``deps``
    (the points ``sel`` of ``res``): the trial stress and elasticity from the material (``D``: its
    :func:`elastic_stiffness`, where the caller holds it)."""
    if D is None:
        D = elastic_stiffness(material, sigma_n.shape[1])
    duvaut_lions(res, sigma_n + deps @ D.T, D, relaxation, sel)
