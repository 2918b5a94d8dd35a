"""Smoothed Mohr-Coulomb plasticity (Abbo & Sloan 1995), non-associated, with a vectorised
closest-point (backward-Euler) return map and its consistent tangent.

Reference: A.J. Abbo and S.W. Sloan (1995), "A smooth hyperbolic approximation to the
Mohr-Coulomb yield criterion", Computers & Structures 54(3), 427-441.  (A C2-continuous variant:
Abbo, Lyamin, Sloan & Hambleton (2011), Computers & Structures 89, 1749-1761; not used here.)

Yield function (stresses tension positive, as everywhere in rollsim)::

    F = sm sin(phi) + sqrt(J2 K(theta)^2 + a^2 sin(phi)^2) - c cos(phi)

with ``sm = tr(sigma)/3``, ``J2 = s:s/2``, ``J3 = det(s)`` and the Lode angle
``sin(3 theta) = -(3 sqrt(3)/2) J3 / J2^(3/2)``, ``|theta| <= 30 deg``:

* ``K(theta) = cos(theta) - sin(theta) sin(phi)/sqrt(3)`` for ``|theta| <= theta_T`` (exact
  Mohr-Coulomb; ``theta = +30 deg`` is triaxial compression, ``-30 deg`` triaxial extension),
* ``K(theta) = A - B sin(3 theta)`` for ``|theta| > theta_T``, with A, B fixed (for each sign of
  theta) so that K and dK/dtheta are continuous at ``theta_T`` - this rounds the corners of the
  hexagon (the surface becomes C1).  Abbo & Sloan recommend theta_T = 25-29 deg; the default
  is 29 deg because the rounded surface lies *inside* Mohr-Coulomb at the corners, by
  ``K(30)/K_MC(30) - 1`` = 4.5 % (compression) / 1.1 % (extension) for theta_T = 25 deg and
  0.9 % / 0.2 % for 29 deg (phi = 30 deg; hand check for 25 deg: K_MC(25) = 0.7843,
  B = 0.881, K(30) = 0.7843 - 0.881 (1 - sin 75) = 0.7543 vs K_MC(30) = 0.7217);
* the hyperbola ``sqrt(J2 K^2 + a^2 sin^2 phi)`` rounds the apex; far from the apex it tends to
  the exact cone.  Default ``a = 0.05 c cot(phi)`` (Abbo & Sloan); the rounded tip is at
  ``sm = c cot(phi) - a``.

Plastic potential: the same function with the dilation angle ``psi`` in place of ``phi`` in the
linear and the Lode terms, keeping the hyperbolic term ``a sin(phi)`` (so that the potential is
smooth at the tip also for psi = 0).  ``dilation = phi`` is associated.

Return map (per quadrature point, vectorised over points): Newton on the backward-Euler
equations ``sigma - sigma_tr + dlam D dg/dsigma(sigma) = 0``, ``F(sigma) = 0`` in the Mandel
components (4 in plane strain, 6 in 3D) with a backtracking line search on the residual norm;
the Hessian of g is computed with the complex-step derivative of the analytic gradient (exact to
rounding).  Points where Newton fails from the trial state are restarted from the rounded tip;
if that fails too (e.g. psi = 0 and a trial state far in tension, which no deviatoric flow can
bring back) the point returns to the tip (``APEX``, zero tangent), as the Drucker-Prager apex.
Consistent tangent: ``C = [J^-1]_(sigma sigma) D`` with the Jacobian J of the converged local
system (non-symmetric for psi != phi).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .materials import _check_elastic, _Elastic

__all__ = ["SmoothedMohrCoulomb", "mohr_coulomb_exact"]

_SQ3 = math.sqrt(3.0)
_SQ2 = math.sqrt(2.0)


@dataclass(frozen=True)
class SmoothedMohrCoulomb(_Elastic):
    """Abbo-Sloan smoothed Mohr-Coulomb: ``c`` (Pa), ``phi``, ``dilation`` (rad).

    ``transition_angle`` theta_T (rad, in (0, 30 deg)); ``apex_rounding`` a (Pa, the hyperbola
    parameter; default ``0.05 c cot(phi)``; required > 0 when c = 0 and phi > 0; at most
    ``c cot(phi)``: ``a = c cot(phi)`` puts the rounded tip at the stress-free state, a surface with
    no tensile strength that approaches the cone of cohesion c at large stresses).
    """

    c: float
    phi: float
    dilation: float = 0.0
    transition_angle: float = 29.0 * math.pi / 180.0
    apex_rounding: float | None = None

    def __post_init__(self):
        _check_elastic(self.E, self.nu)
        if not (isinstance(self.c, (int, float)) and math.isfinite(self.c) and self.c >= 0):
            raise ValueError(f"c must be a finite number >= 0 (Pa), got {self.c!r}")
        if not (isinstance(self.phi, (int, float)) and 0.0 <= self.phi < math.pi / 2):
            raise ValueError(f"phi must be an angle in [0, pi/2) radians, got {self.phi!r}")
        if not (isinstance(self.dilation, (int, float)) and 0.0 <= self.dilation <= self.phi + 1e-15):
            raise ValueError(f"dilation must be an angle in [0, phi] radians, got {self.dilation!r}")
        if not (isinstance(self.transition_angle, (int, float))
                and 0.0 < self.transition_angle < math.pi / 6 - 1e-3):
            raise ValueError(f"transition_angle must be in (0, 30 deg) radians, got {self.transition_angle!r}")
        if self.c == 0 and self.phi == 0:
            raise ValueError("c and phi are both zero: no strength")
        a = self.apex_rounding
        if a is not None and not (isinstance(a, (int, float)) and math.isfinite(a) and a >= 0):
            raise ValueError(f"apex_rounding must be a finite number >= 0 (Pa), got {a!r}")
        if self.c == 0 and (a is None or a <= 0):
            raise ValueError("apex_rounding must be given (> 0, Pa) when c = 0: the default 0.05 c cot(phi) "
                             "vanishes")
        if a is not None and self.phi > 0 and self.c > 0 and a > self.c / math.tan(self.phi) * (1 + 1e-12):
            raise ValueError(f"apex_rounding must not exceed c cot(phi) = {self.c / math.tan(self.phi)!r} (the "
                             f"rounded tip would lie in compression), got {a!r}")

    # ------------------------------------------------------------ parameters
    @property
    def a(self) -> float:
        if self.apex_rounding is not None:
            return float(self.apex_rounding)
        return 0.05 * self.c / math.tan(self.phi) if self.phi > 0 else 0.0

    @property
    def cohesion(self) -> float:       # used for scales / diagnostics (PlasticityProblem)
        return float(self.c)

    @property
    def tan_phi(self) -> float:
        return math.tan(self.phi)

    @property
    def tan_psi(self) -> float:
        return math.tan(self.dilation)

    @property
    def tip_mean_stress(self) -> float:
        """Mean stress (tension positive) of the rounded apex, ``c cot(phi) - a`` (inf for phi = 0)."""
        if self.phi == 0:
            return math.inf
        return self.c / math.tan(self.phi) - self.a

    # ------------------------------------------------------------ functions of the stress
    def yield_function(self, sigma: np.ndarray) -> np.ndarray:
        sigma = np.atleast_2d(np.asarray(sigma, dtype=float))
        return _surface(sigma, math.sin(self.phi), self._a2(), self.c * math.cos(self.phi),
                        self.transition_angle, grad=False)[0]

    def flow_direction(self, sigma: np.ndarray) -> np.ndarray:
        sigma = np.atleast_2d(np.asarray(sigma, dtype=float))
        return _surface(sigma, math.sin(self.dilation), self._a2(), 0.0, self.transition_angle)[1]

    def yield_gradient(self, sigma: np.ndarray) -> np.ndarray:
        sigma = np.atleast_2d(np.asarray(sigma, dtype=float))
        return _surface(sigma, math.sin(self.phi), self._a2(), self.c * math.cos(self.phi),
                        self.transition_angle)[1]

    def _a2(self) -> float:
        return (self.a * math.sin(self.phi)) ** 2

    def return_map(self, sigma_n: np.ndarray, deps: np.ndarray, tangent: bool = True, rtol: float = 1e-10):
        return smoothed_mc_return_map(self, sigma_n, deps, tangent=tangent, rtol=rtol)


# ---------------------------------------------------------------------------- invariants
def _dev(sig):
    s = sig.copy()
    sm = sig[:, :3].sum(axis=1) / 3.0
    s[:, :3] -= sm[:, None]
    return sm, s


def _det_and_square(s):
    """det and the Mandel vector of s.s for Mandel vectors s (n, 4|6) of any dtype."""
    nc = s.shape[1]
    xx, yy, zz, xy = s[:, 0], s[:, 1], s[:, 2], s[:, 3] / _SQ2
    if nc == 6:
        yz, xz = s[:, 4] / _SQ2, s[:, 5] / _SQ2
    else:
        yz = xz = np.zeros_like(xx)
    det = xx * (yy * zz - yz * yz) - xy * (xy * zz - yz * xz) + xz * (xy * yz - yy * xz)
    sq = np.empty_like(s)
    sq[:, 0] = xx * xx + xy * xy + xz * xz
    sq[:, 1] = xy * xy + yy * yy + yz * yz
    sq[:, 2] = xz * xz + yz * yz + zz * zz
    sq[:, 3] = _SQ2 * (xx * xy + xy * yy + xz * yz)
    if nc == 6:
        sq[:, 4] = _SQ2 * (xy * xz + yy * yz + yz * zz)
        sq[:, 5] = _SQ2 * (xx * xz + xy * yz + xz * zz)
    return det, sq


def _lode_K(sin3t, sphi, theta_T):
    """K(theta) and dK/d(sin 3 theta) (outer branch) or dK/dtheta / (3 cos 3 theta) (inner), i.e.
    always dK/d(sin 3theta).  Branch decisions use real parts (complex-step safe)."""
    sT, cT = math.sin(theta_T), math.cos(theta_T)
    s3T, c3T = math.sin(3 * theta_T), math.cos(3 * theta_T)
    r = np.real(sin3t)
    inner = np.abs(r) <= s3T
    K = np.empty_like(sin3t)
    dK = np.empty_like(sin3t)
    if np.any(inner):
        x = sin3t[inner]
        th = np.arcsin(x) / 3.0
        K[inner] = np.cos(th) - np.sin(th) * sphi / _SQ3
        dKdth = -np.sin(th) - np.cos(th) * sphi / _SQ3
        dK[inner] = dKdth / (3.0 * np.cos(3.0 * th))
    outer = ~inner
    if np.any(outer):
        sg = np.where(r[outer] > 0, 1.0, -1.0)
        # continuity of K and dK/dtheta at theta = sg theta_T
        Kt = cT - sg * sT * sphi / _SQ3
        dKt = -sg * sT - cT * sphi / _SQ3
        B = -dKt / (3.0 * c3T)
        A = Kt + B * sg * s3T
        K[outer] = A - B * sin3t[outer]
        dK[outer] = -B
    return K, dK


def _surface(sig, sphi, a2, ccos, theta_T, grad=True):
    """F = sm sphi + sqrt(J2 K^2 + a2) - ccos and dF/dsigma (Mandel) for (n, nc) stresses."""
    sm, s = _dev(sig)
    J2 = 0.5 * np.sum(s * s, axis=1)
    J3, ss = _det_and_square(s)
    scale2 = np.real(J2) + np.real(sm) ** 2 + 1e-300
    small = np.real(J2) <= 1e-28 * scale2
    J2s = np.where(small, 1.0, J2)
    sin3t = np.where(small, 0.0, -1.5 * _SQ3 * J3 / J2s ** 1.5)
    # keep the real part inside [-1, 1] (rounding) without breaking the complex step
    r = np.real(sin3t)
    sin3t = sin3t - (r - np.clip(r, -1.0, 1.0))
    K, dK = _lode_K(sin3t, sphi, theta_T)
    R = np.sqrt(J2 * K * K + a2)
    F = sm * sphi + R - ccos
    if not grad:
        return F, None
    nc = sig.shape[1]
    one = np.zeros(nc)
    one[:3] = 1.0
    dJ3 = ss.copy()
    dJ3[:, :3] -= (2.0 / 3.0 * J2)[:, None]
    # d(sin3t)/dsigma = -(3 sqrt3 / 2) (dJ3 J2^-3/2 - 3/2 J3 J2^-5/2 s)
    ds3 = -1.5 * _SQ3 * (dJ3 / J2s[:, None] ** 1.5 - 1.5 * (J3 / J2s ** 2.5)[:, None] * s)
    ds3 = np.where(small[:, None], 0.0, ds3)
    Rs = np.where(np.real(R) > 0, R, 1.0)
    n = sphi / 3.0 * one + (K * K / (2.0 * Rs))[:, None] * s + (J2 * K * dK / Rs)[:, None] * ds3
    return F, n


def _hessian(sig, sphi, a2, theta_T, h=1e-20):
    """Complex-step Hessian d2g/dsigma2 (n, nc, nc) of the potential at Mandel stresses ``sig``."""
    n, nc = sig.shape
    H = np.empty((n, nc, nc))
    scale = np.abs(sig).max(axis=1) + 1.0
    for j in range(nc):
        sp = sig.astype(complex)
        hj = h * scale
        sp[:, j] += 1j * hj
        H[:, :, j] = np.imag(_surface(sp, sphi, a2, 0.0, theta_T)[1]) / hj[:, None]
    return 0.5 * (H + H.transpose(0, 2, 1))


# ---------------------------------------------------------------------------- return map
def smoothed_mc_return_map(mat: SmoothedMohrCoulomb, sigma_n, deps, tangent=True, rtol=1e-10,
                           max_iterations=40):
    from .return_map import ELASTIC, PLASTIC, APEX, ReturnResult, elastic_stiffness, point_arrays

    sigma_n, deps = point_arrays(sigma_n, deps)
    npts, nc = deps.shape
    D = elastic_stiffness(mat, nc)
    sig_tr = sigma_n + deps @ D.T
    sphi, spsi = math.sin(mat.phi), math.sin(mat.dilation)
    a2 = mat._a2()
    ccos = mat.c * math.cos(mat.phi)
    thT = mat.transition_angle
    F_tr = _surface(sig_tr, sphi, a2, ccos, thT, grad=False)[0]
    sm_tr, s_tr = _dev(sig_tr)
    scale = mat.c + np.abs(sm_tr) + np.linalg.norm(s_tr, axis=1) + mat.a + 1e-300
    plastic = F_tr > -rtol * scale

    sigma = sig_tr.copy()
    dlam = np.zeros(npts)
    state = np.zeros(npts, dtype=np.int8)
    Ct = np.broadcast_to(D, (npts, nc, nc)).copy() if tangent else None
    idx = np.nonzero(plastic)[0]
    if idx.size:
        on_surface = F_tr[idx] <= 0          # within tolerance of the surface: dlam = 0
        sig_p, dl_p, ok, Jinv = _newton(sig_tr[idx], scale[idx], D, sphi, spsi, a2, ccos, thT,
                                        sig_tr[idx].copy(), np.zeros(idx.size), max_iterations,
                                        freeze=on_surface)
        bad = ~ok
        if np.any(bad) and sphi > 0:       # restart from the rounded tip
            tip = np.zeros(nc)
            tip[:3] = mat.tip_mean_stress
            b = np.nonzero(bad)[0]
            s0 = tip[None, :] + 1e-3 * _dev(sig_tr[idx[b]])[1]
            dl0 = np.zeros(b.size)
            if spsi > 0:
                dl0 = np.maximum(sm_tr[idx[b]] - mat.tip_mean_stress, 0.0) / (mat.bulk_modulus * spsi)
            s2, d2, ok2, J2inv = _newton(sig_tr[idx[b]], scale[idx[b]], D, sphi, spsi, a2, ccos, thT, s0, dl0,
                                         max_iterations, freeze=np.zeros(b.size, bool))
            sig_p[b[ok2]], dl_p[b[ok2]], Jinv[b[ok2]] = s2[ok2], d2[ok2], J2inv[ok2]
            ok[b[ok2]] = True
        good = ok & (dl_p >= -rtol)
        gi = idx[good]
        sigma[gi] = sig_p[good]
        dlam[gi] = np.maximum(dl_p[good], 0.0)
        state[gi] = PLASTIC
        if tangent:
            Ct[gi] = Jinv[good][:, :nc, :nc] @ D
        ai = idx[~good]
        if ai.size:
            if sphi > 0:
                sigma[ai] = 0.0
                sigma[ai, :3] = mat.tip_mean_stress
                state[ai] = APEX
                if tangent:
                    Ct[ai] = 0.0
            else:
                raise RuntimeError(f"smoothed Mohr-Coulomb return map did not converge at {ai.size} points")
    Dinv = np.linalg.inv(D)
    deps_p = (sig_tr - sigma) @ Dinv.T
    deps_p[state == ELASTIC] = 0.0
    return ReturnResult(sigma=sigma, tangent=Ct, deps_p=deps_p, dlam=dlam, state=state)


def _newton(sig_tr, scale, D, sphi, spsi, a2, ccos, thT, sig0, dl0, max_it, freeze, tol=1e-12):
    """Batched Newton on r = [sigma - sig_tr + dlam D n_g ; F] with a backtracking line search on
    |r|.  Returns (sigma, dlam, converged mask, inverse local Jacobian at the solution)."""
    m, nc = sig_tr.shape
    out_sig = sig0.copy()
    out_dl = dl0.copy()
    ok = np.zeros(m, bool)
    Jinv = np.zeros((m, nc + 1, nc + 1))
    eye = np.eye(nc)

    def residual(sig, dl, st):
        F, nf = _surface(sig, sphi, a2, ccos, thT)
        _, ng = _surface(sig, spsi, a2, 0.0, thT)
        r = np.concatenate([sig - st + dl[:, None] * (ng @ D.T), F[:, None]], axis=1)
        return r, nf, ng

    def jac(sig, dl, nf, ng):
        Hg = _hessian(sig, spsi, a2, thT)
        J = np.zeros((sig.shape[0], nc + 1, nc + 1))
        J[:, :nc, :nc] = eye + dl[:, None, None] * np.einsum("ij,pjk->pik", D, Hg)
        J[:, :nc, nc] = ng @ D.T
        J[:, nc, :nc] = nf
        return J

    act = np.arange(m)
    sig, dl = sig0.copy(), dl0.copy()
    fr = freeze.copy()
    sig[fr], dl[fr] = sig_tr[fr], 0.0
    st = sig_tr.copy()
    r, nf, ng = residual(sig, dl, st)
    for it in range(max_it + 1):
        nr = np.linalg.norm(r, axis=1) / scale[act]
        conv = (nr <= tol) | fr
        if np.any(conv):
            c = act[conv]
            out_sig[c], out_dl[c] = sig[conv], dl[conv]
            Jinv[c] = _inverse(jac(sig[conv], dl[conv], nf[conv], ng[conv]), nc)
            ok[c] = True
            keep = ~conv
            act, sig, dl, r, nf, ng, fr, st = (act[keep], sig[keep], dl[keep], r[keep], nf[keep], ng[keep],
                                               fr[keep], st[keep])
        if act.size == 0 or it == max_it:
            break
        J = jac(sig, dl, nf, ng)
        step = -_solve(J, r)
        alpha = np.ones(act.size)
        r0 = np.linalg.norm(r, axis=1)
        todo = np.ones(act.size, bool)
        for ls in range(12):
            ti = np.nonzero(todo)[0]
            if ti.size == 0:
                break
            s_try = sig[ti] + alpha[ti, None] * step[ti, :nc]
            d_try = dl[ti] + alpha[ti] * step[ti, nc]
            r_try, nf_try, ng_try = residual(s_try, d_try, st[ti])
            better = (np.linalg.norm(r_try, axis=1) < (1 - 1e-4 * alpha[ti]) * r0[ti]) | (ls == 11)
            bi = ti[better]
            sig[bi], dl[bi] = s_try[better], d_try[better]
            r[bi], nf[bi], ng[bi] = r_try[better], nf_try[better], ng_try[better]
            todo[bi] = False
            alpha[ti] *= 0.5
    out_sig[~ok] = np.nan
    return out_sig, out_dl, ok, Jinv


def _inverse(J, nc):
    """Inverses of the local Jacobians.  A singular one (a point frozen on the surface where the
    potential has no gradient: psi = 0 at the rounded tip, J2 = 0) gets ``[[I, 0], [0, 0]]``, i.e.
    the elastic tangent: its stress is the trial stress (dlam = 0)."""
    try:
        return np.linalg.inv(J)
    except np.linalg.LinAlgError:
        out = np.zeros_like(J)
        for i in range(J.shape[0]):
            try:
                out[i] = np.linalg.inv(J[i])
            except np.linalg.LinAlgError:
                out[i, :nc, :nc] = np.eye(nc)
        return out


def _solve(J, r):
    """Newton steps ``J^-1 r`` per point; zero for a singular Jacobian (the point then does not
    converge and takes the restart / tip fallback)."""
    try:
        return np.linalg.solve(J, r[:, :, None])[:, :, 0]
    except np.linalg.LinAlgError:
        out = np.zeros_like(r)
        for i in range(J.shape[0]):
            try:
                out[i] = np.linalg.solve(J[i], r[i])
            except np.linalg.LinAlgError:
                pass
        return out


def mohr_coulomb_exact(sigma: np.ndarray, c: float, phi: float) -> np.ndarray:
    """Exact Mohr-Coulomb ``(s1 - s3)/2 + (s1 + s3)/2 sin(phi) - c cos(phi)`` (tension positive,
    s1 >= s2 >= s3 principal stresses) of Mandel stresses (n, 4|6)."""
    from .return_map import mandel_to_tensor
    ev = np.linalg.eigvalsh(mandel_to_tensor(np.atleast_2d(sigma)))
    s1, s3 = ev[:, 2], ev[:, 0]
    return 0.5 * (s1 - s3) + 0.5 * (s1 + s3) * math.sin(phi) - c * math.cos(phi)
