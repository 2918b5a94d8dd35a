"""Frictional penalty contact between two deformable bodies of one plane-strain mesh.

Formulation (integration point to facet, current configuration, consistent linearisation)
-----------------------------------------------------------------------------------------
Both surfaces are their facets, each interpolated through its nodes as in the elements
(``x(xi) = sum N_i(xi) x_i``, ``xi`` in [0, 1]: a straight segment or a parabola).  The master's
outward normal is interpolated from nodal normals, ``n(xi) = unit(sum N_i(xi) n_i)``, ``n_i`` the
facet's own normal at its midpoint node and, at a vertex, the average of the two facets' normals
there, so it turns continuously from facet to facet (with the facets' own normals a point at a
vertex of a curved master switches between two of them and Newton stalls).  The *slave*
surface is integrated by Gauss points; the point of a slave facet now at ``x_s`` is projected
along that normal onto a master facet it lies over (Newton on ``(x_s - x(xi)) x n(xi) = 0``)::

    g = (x_s - x_m(xi)) . n(xi),     p = kappa <-g>_+

and, where it penetrates, adds the nodal forces
``kappa w g (N^s_1 n, ..., N^s_k n, -N^m_1(xi) n, ..., -N^m_k(xi) n)`` (``w``: the point's weight
times the facet's reference length element) to the rows of the slave and
master facets' nodes.  Coulomb friction acts as on the rigid wheel: the trial traction
``t_tr = P_T t_n - k_T P_T (x_s - x_m(xi_n))`` (``t_n`` the point's last converged friction
traction, ``x_m(xi_n)`` the master's material point it touched then, where it is now;
``k_T = kappa``) sticks if ``|t_tr| <= mu p`` and slips as ``mu p t_tr / |t_tr|`` otherwise,
adding ``-w t_T`` to the slave's and ``w t_T`` to the master's nodal forces (shape-weighted).
A point that comes into contact carries no friction until the step that found it has
converged (it has no material point to slip against before).  This is the rigid wheel's law
(:mod:`rollsim.solver.contact`) with the wheel replaced by the master body.  The tangent of each
pair, including the rotation of ``n``, the slide of ``xi`` and the stick/slip switch, is the exact
derivative of those forces (non-symmetric with friction), taken by the complex step: the forces
are analytic in the coordinates once the facet and the active set are chosen, and the projection
is iterated in complex arithmetic.

The couplings between the two bodies are not in the sparsity pattern of the finite-element forms,
so the pair adds its forces and tangent to the assembled PETSc vector and matrix by global index
(:meth:`PlasticityProblem.add_assembled_term`).  The two surfaces (small against the bodies) are
gathered on every rank; the slave facets are dealt out to the ranks in turn.

Penalty: ``kappa = alpha E / h`` with ``E`` the largest Young modulus of the problem's materials
and ``h`` the smallest cell at the two surfaces, as for the rigid wheel.  Forces are reported on
the slave body.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc

from rollsim import compat

from .contact import DEFAULT_PENALTY, contact_cell_size

__all__ = ["FacetContact", "PairForces", "GAUSS_POINTS"]

#: Gauss points per slave facet (no more than a quadratic facet has nodes: more constraints than
#: nodes per facet over-constrain a stiff penalty)
GAUSS_POINTS = 3
#: a slave point is paired with the nearest master facet it lies over, or with one it lies beside
#: within this fraction of the facet's chord past either end if there is none (a point over the
#: joint of two facets finds one of them)
PROJECTION_TOLERANCE = 0.05
#: points further than this many contact cell sizes from every master facet (behind the surface
#: as well as in front of it) are not paired
SEARCH_DEPTH = 1.0
#: Newton iterations of the projection onto a master facet along its normal, from the chord's
#: projection (round-off in three on facets of elements of fair shape)
PROJECTION_ITERATIONS = 4
_STEP = 1e-30      # complex-step size (coordinates are of order 1 m)


@dataclass(frozen=True)
class PairForces:
    """Contact state, summed over all ranks: the force on the slave body (N, or N/m in plane
    strain), the largest pressure (Pa) and penetration (m), the number of points in contact and
    moments of the pressure over the slave surface (reference coordinates):
    ``M0 = int p`` (N/m) and ``M2 = int p x^2``."""

    force: np.ndarray
    max_pressure: float
    max_penetration: float
    points_in_contact: int
    M0: float
    M2: float


def _shape(xi, k: int):
    """Shape functions of a facet of ``k`` nodes ordered along it, at ``xi`` in [0, 1], with their
    first and second derivatives (lists of ``k`` arrays)."""
    if k == 2:
        one = np.ones_like(xi)
        return [1 - xi, xi], [-one, one], [0 * xi, 0 * xi]
    return ([(1 - xi) * (1 - 2 * xi), 4 * xi * (1 - xi), xi * (2 * xi - 1)],
            [4 * xi - 3, 4 - 8 * xi, 4 * xi - 1], [4 + 0 * xi, -8 + 0 * xi, 4 + 0 * xi])


def _facet_nodes(V, facet_tags, ids) -> list[tuple[np.ndarray, np.ndarray, np.ndarray]]:
    """This rank's facets of ``ids``: (global node blocks ordered along the facet, their reference
    coordinates, the outward normal of the chord)."""
    msh = V.mesh
    fdim = msh.topology.dim - 1
    coords = V.tabulate_dof_coordinates()[:, :2]
    l2g = V.dofmap.index_map.local_to_global
    closure = V.dofmap.dof_layout.entity_closure_dofs
    all_dofs = compat.cell_dofs(V.dofmap)
    facets = []
    for f in facet_tags.indices[np.isin(facet_tags.values, list(ids))]:
        cell = compat.entity_links(msh, fdim, fdim + 1, f)[0]
        local = int(np.flatnonzero(compat.entity_links(msh, fdim + 1, fdim, cell) == f)[0])
        cell_dofs = all_dofs[cell]
        dofs = cell_dofs[closure(fdim, local)]
        X = coords[dofs]
        order = np.argsort((X - X[0]) @ (X[1] - X[0]))
        X = X[order]
        n = np.array([X[-1, 1] - X[0, 1], X[0, 0] - X[-1, 0]])
        n /= np.linalg.norm(n)
        if n @ (X.mean(axis=0) - coords[cell_dofs].mean(axis=0)) < 0:
            n = -n
        facets.append((l2g(np.asarray(dofs[order], dtype=np.int32)).astype(np.int64), X, n))
    return facets


def _gather_facets(comm, V, facet_tags, ids) -> list:
    """All ranks' facets of ``ids``, each once, in a partition-independent order."""
    unique = {}
    for part in comm.allgather(_facet_nodes(V, facet_tags, ids)):
        for facet in part:
            unique.setdefault(tuple(sorted(facet[0].tolist())), facet)
    if not unique:
        raise ValueError(f"no facets tagged {tuple(ids)}")
    return [unique[key] for key in sorted(unique)]


def _orientation(X: np.ndarray, n: np.ndarray) -> float:
    """+1 where ``rot(x') = (x'_y, -x'_x)`` along the ordered nodes ``X`` points along ``n``."""
    return 1.0 if n @ np.array([X[-1, 1] - X[0, 1], X[0, 0] - X[-1, 0]]) > 0 else -1.0


def _interpolate(N, x):
    return sum(N[i][:, None] * x[i] for i in range(len(x)))


def _cross(a, b):
    return a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]


def _unit(v):
    return v / np.sqrt(np.sum(v * v, axis=1))[:, None]


def _facet_normal(x, xi, orient):
    """Outward unit normal of facets with nodes ``x`` (list) at ``xi``."""
    t = _interpolate(_shape(xi, len(x))[1], x)
    return orient[:, None] * _unit(np.stack([t[:, 1], -t[:, 0]], axis=1))


def _pair_forces(q: np.ndarray, Ns: np.ndarray, orient: np.ndarray, kw: np.ndarray, km: int,
                 neighbours, friction=None):
    """Gap and nodal forces of pairs.  Rows of ``q`` hold the node coordinates (possibly complex)
    of the slave facet, of the master facet now under the point, of its two neighbours (before its
    first and after its last node) and of the master facet the point touched at the last converged
    step; ``Ns``: the slave shape functions at the point; ``km``: the master facets' node count;
    ``neighbours``: the neighbours' orientations and the ends (0 or 1) they share with the facet
    (pairs x 2 each); ``friction``: ``(mu, k_T, xi_n, t_n, w, carried)`` (``carried``: 1 where the
    point has a converged contact to slip from, else 0) or ``None``.  Returns the gap, the nodal
    forces (in the order of ``q``), ``xi`` and the friction traction."""
    ks = Ns.shape[1]
    nodes = [q[:, 2 * i: 2 * i + 2] for i in range(q.shape[1] // 2)]
    xs = _interpolate(list(Ns.T), nodes[:ks])
    xm, before, after, old = (nodes[ks + j * km: ks + (j + 1) * km] for j in range(4))
    # the master's normal: the facet's, averaged with its neighbour's at each end node, interpolated
    (orient_before, orient_after), (end_before, end_after) = neighbours
    zero, one = np.zeros(len(q)), np.ones(len(q))
    nodal = [_unit(_facet_normal(xm, zero, orient) + _facet_normal(before, end_before, orient_before))]
    if km > 2:
        nodal.append(_facet_normal(xm, 0.5 * one, orient))
    nodal.append(_unit(_facet_normal(xm, one, orient) + _facet_normal(after, end_after, orient_after)))
    chord = xm[-1] - xm[0]
    xi = np.sum((xs - xm[0]) * chord, axis=1) / np.sum(chord * chord, axis=1)
    for _ in range(PROJECTION_ITERATIONS):            # x_s on the normal line through x(xi)
        N, dN, _ = _shape(xi, km)
        r, t = xs - _interpolate(N, xm), _interpolate(dN, xm)
        m, dm = _interpolate(N, nodal), _interpolate(dN, nodal)
        size = np.sqrt(np.sum(m * m, axis=1))[:, None]
        n = m / size
        dn = (dm - n * np.sum(n * dm, axis=1)[:, None]) / size
        xi = xi - _cross(r, n) / (_cross(-t, n) + _cross(r, dn))
    N = _shape(xi, km)[0]
    n = _unit(_interpolate(N, nodal))
    g = np.sum((xs - _interpolate(N, xm)) * n, axis=1)
    kwg = (kw * g)[:, None]
    f_slave = [kwg * Ns[:, i, None] * n for i in range(ks)]
    f_master = [-kwg * N[i][:, None] * n for i in range(km)]
    f_others = [0 * kwg * n for _ in range(3 * km)]      # the neighbours turn n, the old facet slips
    if friction is not None:
        mu, k_T, xi_n, t_n, w, carried = friction
        slip = xs - _interpolate(_shape(xi_n, km)[0], old)
        tau = np.stack([-n[:, 1], n[:, 0]], axis=1)
        trial = (np.sum(t_n * tau, axis=1) - k_T * np.sum(slip * tau, axis=1))[:, None] * tau
        size = np.sqrt(np.sum(trial * trial, axis=1))
        limit = mu * (-(kw / w) * g)                  # mu p: the pairs penetrate
        slips = size.real > limit.real
        t_T = (carried * np.where(slips, limit / np.where(slips, size, 1.0), 1.0))[:, None] * trial
        f_slave = [f - w[:, None] * t_T * Ns[:, i, None] for i, f in enumerate(f_slave)]
        f_master = [f + w[:, None] * t_T * N[i][:, None] for i, f in enumerate(f_master)]
    else:
        t_T = 0 * n
    return g, np.concatenate(f_slave + f_master + f_others, axis=1), xi, t_T


class FacetContact:
    """Penalty contact of the ``slave`` facets (tags) on the ``master`` facets of the problem's
    plane-strain mesh: two parts of one mesh that share no node.

    ``penalty``: alpha in ``kappa = alpha E / h``; ``friction``: Coulomb's mu (0: frictionless).
    Registers itself with the problem (its forces, tangent and the friction history, committed
    with the problem's state); read the state with :meth:`forces` and :meth:`pressures`.
    """

    def __init__(self, problem, facet_tags, slave, master, *, penalty: float = DEFAULT_PENALTY,
                 friction: float = 0.0):
        if problem.gdim != 2:
            raise ValueError("FacetContact is plane strain (2D) only")
        if not friction >= 0:
            raise ValueError(f"friction must be >= 0, got {friction}")
        self.friction = float(friction)
        self.problem = problem
        self.comm = comm = problem.comm
        V = problem.V
        self.bs = V.dofmap.index_map_bs
        self.first, self.last = V.dofmap.index_map.local_range
        slave_facets = _gather_facets(comm, V, facet_tags, slave)
        master_facets = _gather_facets(comm, V, facet_tags, master)
        self.nodes = np.unique(np.concatenate([f[0] for f in slave_facets + master_facets]))
        if np.intersect1d(np.concatenate([f[0] for f in slave_facets]),
                          np.concatenate([f[0] for f in master_facets])).size:
            raise ValueError("the slave and master surfaces share nodes")
        position = {int(i): x for b, X, _ in slave_facets + master_facets for i, x in zip(b, X)}
        self.X = np.array([position[int(i)] for i in self.nodes])
        self._owned = (self.nodes >= self.first) & (self.nodes < self.last)
        # this rank's slave facets and their Gauss points
        mine = slave_facets[comm.rank::comm.size]
        ks = len(slave_facets[0][0])
        eta, gw = np.polynomial.legendre.leggauss(GAUSS_POINTS)
        eta, gw = (eta + 1) / 2, gw / 2
        N, dN, _ = _shape(eta, ks)
        N, dN = np.array(N).T, np.array(dN).T                      # (points, ks)
        self.slave = np.array([np.searchsorted(self.nodes, b) for b, _, _ in mine], dtype=np.int64).reshape(-1, ks)
        X = np.array([X for _, X, _ in mine]).reshape(-1, ks, 2)
        self.point_X = np.einsum("pk,fkd->fpd", N, X).reshape(-1, 2)
        jac = np.linalg.norm(np.einsum("pk,fkd->fpd", dN, X), axis=2)             # (facets, points)
        self.point_w = (jac * gw).reshape(-1)
        self.point_N = np.tile(N, (len(mine), 1))
        self.point_facet = np.repeat(np.arange(len(mine)), GAUSS_POINTS)
        self.master = np.array([np.searchsorted(self.nodes, b) for b, _, _ in master_facets], dtype=np.int64)
        self.orient = np.array([_orientation(X, n) for _, X, n in master_facets])
        # each master facet's neighbours at its first and last node, and the end they meet it
        # with (a facet with none is its own neighbour there)
        meeting: dict[int, list] = {}
        for f, facet in enumerate(self.master):
            meeting.setdefault(int(facet[0]), []).append((f, 0))
            meeting.setdefault(int(facet[-1]), []).append((f, 1))
        self.neighbours = np.zeros((len(self.master), 2), dtype=np.int64)
        self.neighbour_ends = np.zeros((len(self.master), 2))
        for f, facet in enumerate(self.master):
            for side, (node, end) in enumerate(((facet[0], 0), (facet[-1], 1))):
                others = [pair for pair in meeting[int(node)] if pair[0] != f] or [(f, end)]
                self.neighbours[f, side], self.neighbour_ends[f, side] = others[0]
        self.h = contact_cell_size(problem.mesh, facet_tags, tuple(slave) + tuple(master))
        self.E = max(mat.E for mat in problem.materials.values())
        self.kappa = penalty * self.E / self.h
        self._constrained = None
        # friction history per point: the master facet and xi touched at the last converged
        # step (-1: none) and the friction traction then
        self._touched = -np.ones(len(self.point_w), dtype=np.int64)
        self._xi_n = np.zeros(len(self.point_w))
        self._t_n = np.zeros((len(self.point_w), 2))
        problem.add_assembled_term(self)
        problem.add_state_hooks(commit=self.commit)

    # ------------------------------------------------------------------ state
    def _positions(self) -> np.ndarray:
        """Current positions of the surface nodes (gathered from their owners)."""
        local = self.nodes[self._owned] - self.first
        u = self.problem.u.x.array
        values = np.stack([u[self.bs * local + k] for k in range(2)], axis=1)
        x = self.X.copy()
        for where, part in self.comm.allgather((np.flatnonzero(self._owned), values)):
            x[where] += part
        return x

    def _pairs(self, x=None):
        """Penetrating points of this rank's slave facets: (points, master facets, coordinates q);
        ``x``: the surface nodes' positions (gathered now if not given: collective)."""
        x = self._positions() if x is None else x
        km, ks = self.master.shape[1], self.slave.shape[1]
        empty = (np.zeros(0, dtype=np.int64),) * 2 + (np.zeros((0, 2 * (ks + 4 * km))),)
        if self.point_X.size == 0:
            return empty
        xs = np.einsum("pk,pkd->pd", self.point_N, x[self.slave[self.point_facet]])
        x1, x2 = x[self.master[:, 0]], x[self.master[:, -1]]
        d = x2 - x1
        length = np.linalg.norm(d, axis=1)
        n = self.orient[:, None] * np.stack([d[:, 1], -d[:, 0]], axis=1) / length[:, None]
        r = xs[:, None, :] - x1[None, :, :]                                   # (points, facets, 2)
        xi = np.einsum("ijk,jk->ij", r, d) / length ** 2
        g = np.einsum("ijk,jk->ij", r, n)
        # the nearest facet the point lies over; one it lies beside (within the tolerance) only if
        # there is none: at a concave corner the extension of a facet runs inside the body
        outside = np.maximum(np.maximum(-xi, xi - 1), 0.0)
        score = np.abs(g) + np.where(outside > 0, (SEARCH_DEPTH + 1) * self.h + outside, 0.0)
        score[(outside > PROJECTION_TOLERANCE) | (np.abs(g) > SEARCH_DEPTH * self.h)] = np.inf
        best = np.argmin(score, axis=1)
        points = np.flatnonzero(np.isfinite(score[np.arange(len(xs)), best]))
        facets = best[points]
        q = x[self._pair_nodes(points, facets)].reshape(len(points), 2 * (ks + 4 * km))
        gap = _pair_forces(q, self.point_N[points], self.orient[facets], np.zeros(len(points)), km,
                           self._neighbours(facets))[0]
        inside = gap < 0
        return (points[inside], facets[inside], q[inside]) if inside.any() else empty

    def _pair_nodes(self, points, facets) -> np.ndarray:
        """Surface nodes of the pairs: slave facet, master facet, its neighbours, the facet touched."""
        touched = np.where(self._touched[points] >= 0, self._touched[points], facets)
        return np.concatenate([self.slave[self.point_facet[points]], self.master[facets],
                               self.master[self.neighbours[facets, 0]], self.master[self.neighbours[facets, 1]],
                               self.master[touched]], axis=1)

    def _neighbours(self, facets):
        nb = self.neighbours[facets]
        return (self.orient[nb[:, 0]], self.orient[nb[:, 1]]), (self.neighbour_ends[facets, 0],
                                                                self.neighbour_ends[facets, 1])

    def _evaluate(self, points, facets, q):
        """Gap, nodal forces, xi and friction traction of the pairs (see :func:`_pair_forces`)."""
        w = self.point_w[points]
        friction = None
        if self.friction > 0:
            friction = (self.friction, self.kappa, self._xi_n[points], self._t_n[points], w,
                        (self._touched[points] >= 0).astype(float))
        return _pair_forces(q, self.point_N[points], self.orient[facets], self.kappa * w, self.master.shape[1],
                            self._neighbours(facets), friction)

    def _dofs(self, points, facets) -> np.ndarray:
        """Global dofs of the pairs' nodes (:meth:`_pair_nodes`; pairs x 2(ks + 4 km))."""
        blocks = self.nodes[self._pair_nodes(points, facets)]
        return (self.bs * blocks[:, :, None] + np.arange(2)).reshape(len(points), 2 * blocks.shape[1])

    def _gather_constrained(self) -> None:
        """The surface dofs held by the problem's Dirichlet conditions, once (collective)."""
        if self._constrained is None:
            bs, first = self.bs, self.first
            held = [bs * first + local[local < bs * (self.last - first)]
                    for local in (np.asarray(bc.dof_indices()[0], dtype=np.int64) for bc in self.problem.bcs)]
            held = np.concatenate(held) if held else np.zeros(0, dtype=np.int64)
            surface = (bs * self.nodes[:, None] + np.arange(2)).reshape(-1)
            self._constrained = np.unique(np.concatenate(self.comm.allgather(held[np.isin(held, surface)])))

    def _free(self, dofs: np.ndarray) -> np.ndarray:
        """False where a dof is held by one of the problem's Dirichlet conditions (local: the held
        dofs are gathered by :meth:`_on_every_rank` before the local work)."""
        return ~np.isin(dofs, self._constrained)

    # ------------------------------------------------------------------ assembly
    def _on_every_rank(self, compute):
        """``compute(x)`` of the gathered surface here (local work, no collective); if it raised on
        any rank, raise on every rank (a rank left alone in the assembly's collective would wait
        for ever)."""
        x = self._positions()
        self._gather_constrained()
        try:
            result, error = compute(x), None
        except Exception as exc:          # re-raised below, after the ranks have agreed
            result, error = None, exc
        if not self.comm.allreduce(error is None, op=MPI.LAND):
            raise error if error is not None else RuntimeError("contact pair: failed on another rank")
        return result

    def _local_forces(self, x):
        points, facets, q = self._pairs(x)
        dofs = self._dofs(points, facets)
        return self._evaluate(points, facets, q)[1], dofs, self._free(dofs)

    def _local_tangent(self, x):
        points, facets, q = self._pairs(x)
        m = q.shape[1]
        K = np.empty((len(points), m, m))
        for j in range(m):
            qc = q.astype(complex)
            qc[:, j] += 1j * _STEP
            K[:, :, j] = self._evaluate(points, facets, qc)[1].imag / _STEP
        dofs = self._dofs(points, facets)
        return K, dofs, self._free(dofs)

    def add_residual(self, b: PETSc.Vec) -> None:
        """Add the contact forces of the current iterate to the assembled residual ``b``."""
        f, dofs, free = self._on_every_rank(self._local_forces)
        b.setValues(dofs[free].astype(PETSc.IntType), f[free], addv=PETSc.InsertMode.ADD_VALUES)
        b.assemblyBegin()
        b.assemblyEnd()

    def add_jacobian(self, A: PETSc.Mat) -> None:
        """Add the pairs' exact tangent to the assembled Jacobian ``A`` (before its final assembly)."""
        K, dofs, free = self._on_every_rank(self._local_tangent)
        for k in range(len(K)):
            idx = dofs[k, free[k]].astype(PETSc.IntType)
            A.setValues(idx, idx, K[k][np.ix_(free[k], free[k])], addv=PETSc.InsertMode.ADD_VALUES)

    def commit(self) -> None:
        """Keep the converged contact points' master facet, xi and friction traction (collective)."""
        points, facets, q = self._pairs()
        _, _, xi, t_T = self._evaluate(points, facets, q)
        self._touched[:] = -1
        self._touched[points] = facets
        self._xi_n[points] = xi
        self._t_n[:] = 0.0
        self._t_n[points] = t_T

    # ------------------------------------------------------------------ reading
    def pressures(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """This rank's slave points in contact now: reference coordinates (m), weights (m) and
        pressure (Pa); the weights sum the pressure to a force per unit length (collective)."""
        points, facets, q = self._pairs()
        gap = self._evaluate(points, facets, q)[0]
        return self.point_X[points], self.point_w[points], -self.kappa * gap

    def forces(self) -> PairForces:
        """Force on the slave body and the pressure's extremes and moments now (collective)."""
        points, facets, q = self._pairs()
        g, f, _, _ = self._evaluate(points, facets, q)
        ks = self.slave.shape[1]
        force = -f[:, : 2 * ks].reshape(len(points), ks, 2).sum(axis=(0, 1))
        p, w, x = -self.kappa * g, self.point_w[points], self.point_X[points, 0]
        comm = self.comm
        return PairForces(force=comm.allreduce(force),
                          max_pressure=comm.allreduce(float(p.max()) if p.size else 0.0, op=MPI.MAX),
                          max_penetration=comm.allreduce(float(-g.min()) if g.size else 0.0, op=MPI.MAX),
                          points_in_contact=comm.allreduce(int(p.size)), M0=comm.allreduce(float(w @ p)),
                          M2=comm.allreduce(float(w @ (p * x ** 2))))
