"""Coulomb friction of a rolling rigid wheel in the load's frame (the stationary method): the
tangential traction on the soil's surface nodes is marched along the surface streamlines (the
rows of surface nodes of equal transverse coordinate, from the inflow), as the stress is along
the quadrature rows (:mod:`rollsim.solver.steady`).

Between consecutive stations of a row (``dx < 0`` apart) the soil slips against the wheel's
surface by the difference of the two relative motions::

    dg = du + dx (e_x - xi / R  w(P))          w(P) = e_axle x P  turned into the rolling sense

(``du`` the difference of the nodes' displacements, ``P`` the point from the axle, ``xi = omega R
/ V`` the wheel's spin: 1 rolls without slip on a rigid surface).  The traction, kept as
components in the wheel's tangent frame, takes the trial ``t_prev - k_T (dg . tau)`` and returns
to ``|t| <= mu p_N`` (``p_N = kappa <-g>_+`` the penalty pressure at the node, ``k_T =
tangential_ratio kappa``: the stick stiffness, :data:`DEFAULT_TANGENTIAL_RATIO`).
Nodal forces use the nodal (Simpson) weights of quadratic Lagrange faces.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

__all__ = ["SurfaceRows", "SurfaceFriction", "DEFAULT_TANGENTIAL_RATIO"]

#: the stick stiffness over the normal penalty, ``k_T / kappa``.  Towed at its service load the
#: Mn/DOT roller's stick-slip pattern defeats Newton with ``k_T = kappa``; a tenth of it rolls
#: there and moves the forces little (see docs/limitations.md, "Steady rolling: how far it reaches").
DEFAULT_TANGENTIAL_RATIO = 0.1


def _simpson(x: np.ndarray) -> np.ndarray:
    """Nodal weights (m) of the vertex/mid-side nodes ``x`` of a row of quadratic elements."""
    if len(x) % 2 != 1:
        raise ValueError("friction needs quadratic Lagrange elements (vertex and mid-side surface nodes)")
    h = np.abs(x[:-2:2] - x[2::2])
    w = np.zeros(len(x))
    w[:-2:2] += h / 6.0
    w[1::2] += 4.0 * h / 6.0
    w[2::2] += h / 6.0
    return w


@dataclass(frozen=True)
class SurfaceRows:
    """The surface nodes as (rows, stations): ``nodes`` (node indices), ``x`` (stations'
    abscissae, m, from the inflow: decreasing), ``across`` (the rows' transverse coordinates, m;
    one row of 0 in plane strain), ``weights`` (nodal area or length, m^2 or m) and the
    dimension ``gdim``."""

    nodes: np.ndarray
    x: np.ndarray
    across: np.ndarray
    weights: np.ndarray
    gdim: int

    @classmethod
    def of(cls, coordinates: np.ndarray, surface: float, tol: float, across: np.ndarray | None = None) -> "SurfaceRows":
        """The nodes at the height ``surface`` (m, tolerance ``tol``) of the node ``coordinates``
        (n, gdim: the last the height), on a structured grid.  3D: ``across`` are the transverse
        coordinates of all the surface's rows (m; default: those of ``coordinates``), which the
        rows' weights need when ``coordinates`` hold only some rows (one rank's)."""
        gdim = coordinates.shape[1]
        top = np.flatnonzero(np.abs(coordinates[:, -1] - surface) < tol)
        if len(top) == 0:
            return cls(np.zeros((0, 0), dtype=np.int64), np.zeros(0), np.zeros(0), np.zeros((0, 0)), gdim)
        y = np.round(coordinates[top, 1], 12) if gdim == 3 else np.zeros(len(top))
        top = top[np.lexsort((-coordinates[top, 0], y))]
        levels = np.unique(y)
        if len(top) % len(levels):
            raise ValueError("the surface nodes are not a structured grid: rows of unequal length")
        nodes = top.reshape(len(levels), -1)
        x = coordinates[nodes[0], 0]
        if not np.allclose(coordinates[nodes, 0], x[None, :], atol=tol):
            raise ValueError("the surface nodes are not a structured grid: rows at different abscissae")
        w = _simpson(x)[None, :]
        if gdim == 3:
            every = np.unique(np.round(levels if across is None else across, 12))
            at = np.searchsorted(every, levels)
            if np.any(at >= len(every)) or not np.array_equal(every[np.minimum(at, len(every) - 1)], levels):
                raise ValueError("the surface rows are not among the transverse coordinates given (across)")
            w = w * _simpson(every)[at][:, None]
        return cls(nodes, x, levels, w, gdim)


class SurfaceFriction:
    """Penalty-regularised Coulomb friction (coefficient ``mu``, normal stiffness ``kappa``, Pa/m,
    stick stiffness ``tangential_ratio kappa``) between the surface ``rows`` and the rigid
    ``wheel`` (``Circle`` in plane strain, ``CylinderWheel`` in 3D with the axle along y).
    :meth:`sweep` returns the nodal forces on the soil; :meth:`tangent` their derivative at the
    state of the last sweep."""

    def __init__(self, rows: SurfaceRows, wheel, mu: float, kappa: float,
                 tangential_ratio: float = DEFAULT_TANGENTIAL_RATIO):
        if not tangential_ratio > 0:
            raise ValueError(f"tangential_ratio must be > 0, got {tangential_ratio!r}")
        self.rows, self.wheel, self.mu, self.kappa = rows, wheel, float(mu), float(kappa)
        self.k_t = float(tangential_ratio) * self.kappa
        self.gdim = rows.gdim
        self.radius = wheel.diameter / 2
        self._dx = np.diff(rows.x, prepend=rows.x[:1])                  # (stations,), <= 0
        self._state = None

    def torque(self, forces: np.ndarray, dU: np.ndarray | None = None, dforces: np.ndarray | None = None) -> float:
        """The moment about the axle (N m, in the rolling sense) on the wheel of the nodal
        ``forces`` on the soil at the last sweep; with ``dU`` and ``dforces`` (their derivative),
        its derivative."""
        P = self.point
        if dU is None:
            return -float(np.sum(P[..., 0] * forces[..., -1] - P[..., -1] * forces[..., 0]))
        return -float(np.sum(dU[..., 0] * forces[..., -1] + P[..., 0] * dforces[..., -1]
                             - dU[..., -1] * forces[..., 0] - P[..., -1] * dforces[..., 0]))

    @property
    def point(self) -> np.ndarray:
        """The surface nodes' positions from the axle (m, (rows, stations, gdim)) at the last sweep."""
        return self._state["P"]

    # the turning direction of a point about the axle, in the rolling sense (linear in P)
    def _turn(self, P: np.ndarray) -> np.ndarray:
        w = np.zeros_like(P)
        w[..., 0], w[..., -1] = -P[..., -1], P[..., 0]
        return w

    def _frame(self, n: np.ndarray) -> np.ndarray:
        """(rows, stations, m, gdim) orthonormal tangent vectors at the normals ``n``."""
        t1 = self._turn(n)                                  # rolling direction on the wheel
        size = np.linalg.norm(t1, axis=-1, keepdims=True)
        # on a side face (n along the axle) any tangent will do: e_x
        t1 = np.where(size > 1e-12, t1 / np.where(size > 1e-12, size, 1.0), np.eye(self.gdim)[0])
        if self.gdim == 2:
            return t1[..., None, :]
        return np.stack([t1, np.cross(n, t1)], axis=-2)

    def _frame_derivative(self, n: np.ndarray, T: np.ndarray, dn: np.ndarray) -> np.ndarray:
        t1 = T[..., 0, :]
        raw = self._turn(n)
        norm = np.linalg.norm(raw, axis=-1, keepdims=True)
        dt1 = self._turn(dn) / np.where(norm > 1e-12, norm, np.inf)
        dt1 -= t1 * np.sum(t1 * dt1, axis=-1, keepdims=True)
        if self.gdim == 2:
            return dt1[..., None, :]
        return np.stack([dt1, np.cross(dn, t1) + np.cross(n, dt1)], axis=-2)

    def sweep(self, U: np.ndarray, axle_height: float, surface: float, spin: float) -> np.ndarray:
        """Nodal forces on the soil (N, (rows, stations, gdim)) at the surface nodes' displacement
        ``U`` (m, (rows, stations, gdim)), the axle at ``axle_height`` above x = 0 (m), the
        undisturbed surface at ``surface`` (m), the wheel turning at ``spin``."""
        rows = self.rows
        if rows.nodes.size == 0:                # none of the surface's rows (on this rank)
            self._state = dict(P=np.zeros_like(U))
            return np.zeros_like(U)
        P = U.copy()
        P[..., 0] += rows.x[None, :]
        if self.gdim == 3:
            P[..., 1] += rows.across[:, None]
        P[..., -1] += surface - axle_height
        flat = P.reshape(-1, self.gdim)
        dist, n = self.wheel.signed_distance(flat)
        n = n.reshape(P.shape)
        pN = self.kappa * np.maximum(-dist, 0.0).reshape(P.shape[:-1])
        T = self._frame(n)
        slip = np.diff(U, axis=1, prepend=U[:, :1]) + self._dx[None, :, None] * (
            np.eye(self.gdim)[0] - spin / self.radius * self._turn(P))
        s = np.einsum("rsmi,rsi->rsm", T, slip)
        t, direction = np.zeros_like(s), np.zeros_like(s)
        scale = np.ones(s.shape[:-1])
        stick = np.zeros(s.shape[:-1], dtype=bool)
        prev = np.zeros_like(s[:, 0])
        for j in range(s.shape[1]):
            trial = prev - self.k_t * s[:, j]
            size = np.linalg.norm(trial, axis=-1)
            limit = self.mu * pN[:, j]
            stick[:, j] = size <= limit
            direction[:, j] = trial / np.where(size > 0, size, 1.0)[:, None]
            scale[:, j] = np.where(stick[:, j], 1.0, limit / np.where(size > 0, size, 1.0))
            prev = t[:, j] = trial * scale[:, j, None]
        hessian = self.wheel.distance_hessian(flat).reshape(P.shape + (self.gdim,))
        self._state = dict(P=P, n=n, T=T, slip=slip, t=t, stick=stick, direction=direction, scale=scale,
                           contact=dist.reshape(pN.shape) < 0, hessian=hessian, spin=spin)
        return self.rows.weights[..., None] * np.einsum("rsm,rsmi->rsi", t, T)

    def stiffness(self) -> np.ndarray:
        """Each surface node's own block of the derivative of the last :meth:`sweep`'s nodal
        forces by that node's displacement, negated (N/m, (rows, stations, gdim, gdim)): the stick
        stiffness along the tangent plane, in slip its part across the sliding direction and the
        pressure's pull along it.  The coupling with the upstream stations and the turn of the
        tangent frame with the normal are left out: a preconditioner's block (:meth:`tangent` is
        the exact derivative)."""
        st = self._state
        if self.rows.nodes.size == 0:
            return np.zeros(st["P"].shape + (self.gdim,))
        T, q, n = st["T"], st["direction"], st["n"]
        m, g = T.shape[-2], self.gdim
        turn = self._turn(np.eye(g)).T                      # _turn as a matrix
        # the slip's derivative by the node's own displacement: its difference less the wheel's turn
        own = np.eye(g) - (st["spin"] * self._dx / self.radius)[:, None, None] * turn
        own[0] = 0.0                                        # the first station has no upstream difference
        slide = np.eye(m) - q[..., :, None] * q[..., None, :]
        across = np.where(st["stick"][..., None, None], np.eye(m), st["scale"][..., None, None] * slide)
        K = self.k_t * np.einsum("rsmi,rsmn,rsnk,skj->rsij", T, across, T, own)
        K += np.where(st["stick"][..., None, None], 0.0,
                      self.mu * self.kappa * np.einsum("rsmi,rsm,rsj->rsij", T, q, n))
        return self.rows.weights[..., None, None] * np.where(st["contact"][..., None, None], K, 0.0)

    def tangent(self, dU: np.ndarray, dspin: float = 0.0) -> np.ndarray:
        """The derivative of the last :meth:`sweep`'s nodal forces (N) for the surface nodes'
        displacement increment ``dU`` (m, (rows, stations, gdim)) and the spin's ``dspin``."""
        st = self._state
        if self.rows.nodes.size == 0:
            return np.zeros_like(dU)
        n, T, t, slip = st["n"], st["T"], st["t"], st["slip"]
        dn = np.einsum("rsij,rsj->rsi", st["hessian"], dU)
        dT = self._frame_derivative(n, T, dn)
        dpN = np.where(st["contact"], -self.kappa * np.einsum("rsi,rsi->rs", n, dU), 0.0)
        dslip = np.diff(dU, axis=1, prepend=dU[:, :1]) - (self._dx / self.radius)[None, :, None] * (
            st["spin"] * self._turn(dU) + dspin * self._turn(st["P"]))
        ds = np.einsum("rsmi,rsi->rsm", T, dslip) + np.einsum("rsmi,rsi->rsm", dT, slip)
        dt = np.zeros_like(ds)
        prev = np.zeros_like(ds[:, 0])
        for j in range(ds.shape[1]):
            dtrial = prev - self.k_t * ds[:, j]
            q, scale = st["direction"][:, j], st["scale"][:, j, None]
            # sliding: t = mu p_N q, q = trial / |trial|
            slide = self.mu * dpN[:, j, None] * q + scale * (dtrial - q * np.sum(q * dtrial, axis=-1, keepdims=True))
            prev = dt[:, j] = np.where(st["stick"][:, j, None], dtrial, slide)
        return self.rows.weights[..., None] * (np.einsum("rsm,rsmi->rsi", dt, T) + np.einsum("rsm,rsmi->rsi", t, dT))
