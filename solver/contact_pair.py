"""Frictional penalty contact between two deformable bodies of one mesh, in plane strain or 3D.

Formulation (integration point to facet, current configuration, consistent linearisation)
-----------------------------------------------------------------------------------------
Both surfaces are their facets, each interpolated through its nodes as in the elements
(``x(xi) = sum N_i(xi) x_i``: a straight or parabolic segment in 2D, a triangle of 3 or 6 nodes
or a quadrilateral of 4 or 9 nodes in 3D).  The master's outward normal is interpolated from nodal normals,
``n(xi) = unit(sum N_i(xi) n_i)``, where ``n_i`` is the average of the normals, at that node, of
all master facets sharing it; so the normal turns continuously from facet to facet (with the
facets' own normals a point at a vertex or edge of a curved master switches between them and
Newton stalls).  The *slave* surface is integrated by Gauss points (3 per segment; as many per
triangle or quadrilateral as it has nodes: more constraints than nodes over-constrain a stiff
penalty); the point of a slave facet now at ``x_s`` is
projected along that normal onto a master facet it lies over (Newton on
``x_s = x(xi) + g n(xi)`` for ``xi`` and the gap ``g``)::

    g = (x_s - x_m(xi)) . n(xi),     p = kappa <-g>_+

and, where it penetrates, adds the nodal forces
``kappa w g (N^s_1 n, ..., N^s_k n, -N^m_1(xi) n, ..., -N^m_k(xi) n)`` (``w``: the point's weight
times the facet's reference length or area element) to the rows of the slave and master
facets' nodes.  Coulomb friction acts as on the rigid wheel: the trial traction
``t_tr = P_T t_n - k_T P_T (x_s - x_m(xi_n))`` (``P_T = I - n n``; ``t_n`` the point's last
converged friction traction, ``x_m(xi_n)`` the master's material point it touched then, where it
is now; ``k_T = kappa``) sticks if ``|t_tr| <= mu p`` and slips as ``mu p t_tr / |t_tr|``
otherwise, adding ``-w t_T`` to the slave's and ``w t_T`` to the master's nodal forces
(shape-weighted).  A point that comes into contact carries no friction until the step that found
it has converged (it has no material point to slip against before).  This is the rigid wheel's
law (:mod:`rollsim.solver.contact`) with the wheel replaced by the master body.  The tangent of
each pair, including the rotation of ``n`` (through every facet around the master facet), the
slide of ``xi`` and the stick/slip switch, is the exact derivative of those forces
(non-symmetric with friction), taken by the complex step: the forces are analytic in the
coordinates once the facet and the active set are chosen, and the projection is iterated in
complex arithmetic.

The couplings between the two bodies are not in the sparsity pattern of the finite-element forms,
so the pair adds its forces and tangent to the assembled PETSc vector and matrix by global index
(:meth:`PlasticityProblem.add_assembled_term`).  The two surfaces (small against the bodies) are
gathered on every rank; the slave facets are dealt out to the ranks in turn; the master facets
near a slave point are found in a k-d tree of their centroids.

Penalty: ``kappa = alpha E / h`` with ``E`` the largest Young modulus of the problem's materials
and ``h`` the smallest cell at the two surfaces, as for the rigid wheel.  Forces are reported on
the slave body.  Triangles, tetrahedra and hexahedra (degree 1 or 2: the facets of a hexahedron
are quadrilaterals of 4 or 9 nodes, integrated by 2 x 2 or 3 x 3 Gauss points).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from mpi4py import MPI
from petsc4py import PETSc
from scipy.spatial import cKDTree

from rollsim import compat

from .contact import DEFAULT_PENALTY, contact_cell_size

__all__ = ["FacetContact", "PairForces", "GAUSS_POINTS"]

#: Gauss points per slave segment (2D); a slave triangle has as many as it has nodes (3 or 6):
#: more constraints than nodes per facet over-constrain a stiff penalty
GAUSS_POINTS = 3
#: a slave point is paired with the nearest master facet it lies over, or with one it lies beside
#: within this fraction of the facet's size past its edge if there is none (a point over the
#: joint of two facets finds one of them)
PROJECTION_TOLERANCE = 0.05
#: points further than this many contact cell sizes from every master facet (behind the surface
#: as well as in front of it) are not paired
SEARCH_DEPTH = 1.0
#: Newton iterations of the projection onto a master facet along its normal, from the projection
#: onto the flat facet through its vertices (round-off in three on elements of fair shape)
PROJECTION_ITERATIONS = 5
_STEP = 1e-30      # complex-step size (coordinates are of order 1 m)
#: the number of edges of the cells handled
_CELL_EDGES = {"triangle": 3, "tetrahedron": 6, "hexahedron": 12}


@dataclass(frozen=True)
class PairForces:
    """Contact state, summed over all ranks: the force on the slave body (N, or N/m in plane
    strain), the largest pressure (Pa) and penetration (m), the number of points in contact and
    moments of the pressure over the slave surface (reference coordinates):
    ``M0 = int p`` (N/m or N) and ``M2 = int p x^2``."""

    force: np.ndarray
    max_pressure: float
    max_penetration: float
    points_in_contact: int
    M0: float
    M2: float


def _quadrilateral(fdim: int, k: int) -> bool:
    """Whether a facet of ``k`` nodes in ``fdim`` dimensions is a quadrilateral (4 or 9 nodes)."""
    return fdim == 2 and k in (4, 9)


def _reference_nodes(fdim: int, k: int) -> np.ndarray:
    """Reference coordinates (k, fdim) of a facet's nodes in the order of :func:`_shape`."""
    if fdim == 1:
        return np.linspace(0.0, 1.0, k)[:, None]
    if _quadrilateral(fdim, k):
        nodes = [[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]
        return np.array(nodes if k == 4 else nodes + [[0.5, 0.0], [1.0, 0.5], [0.5, 1.0], [0.0, 0.5], [0.5, 0.5]])
    corners = [[0.0, 0.0], [1.0, 0.0], [0.0, 1.0]]
    return np.array(corners if k == 3 else corners + [[0.5, 0.0], [0.5, 0.5], [0.0, 0.5]])


def _line_shape(t, k: int):
    """1D shape functions (n, k) and derivatives of ``k`` = 2 or 3 nodes at 0, (1/2,) 1 of ``t``."""
    one = np.ones_like(t)
    if k == 2:
        return np.stack([1 - t, t], axis=1), np.stack([-one, one], axis=1)
    return (np.stack([(1 - t) * (1 - 2 * t), 4 * t * (1 - t), t * (2 * t - 1)], axis=1),
            np.stack([4 * t - 3, 4 - 8 * t, 4 * t - 1], axis=1))


def _shape(xi, fdim: int, k: int):
    """Shape functions (n, k) and their derivatives (n, k, fdim) at ``xi`` (n, fdim) of a facet of
    ``k`` nodes: a segment (2 or 3 nodes: ends and midpoint in order along it), a triangle (3
    vertices, then the midpoints of edges 01, 12, 20) or a quadrilateral (4 corners in turn, then
    the midpoints of edges 01, 12, 23, 30 and the centre)."""
    if fdim == 1:
        N, dN = _line_shape(xi[:, 0], k)
        return N, dN[:, :, None]
    a, b = xi[:, 0], xi[:, 1]
    if _quadrilateral(fdim, k):             # tensor products: node (i, j) at (a_i, b_j)
        nodes = _reference_nodes(fdim, k)
        m = 2 if k == 4 else 3
        index = np.where(nodes == 0.5, 1, np.where(nodes == 1.0, m - 1, 0))     # into _line_shape
        Na, dNa = _line_shape(a, m)
        Nb, dNb = _line_shape(b, m)
        i, j = index[:, 0], index[:, 1]
        N = Na[:, i] * Nb[:, j]
        return N, np.stack([dNa[:, i] * Nb[:, j], Na[:, i] * dNb[:, j]], axis=2)
    L = [1 - a - b, a, b]
    one, zero = np.ones_like(a), np.zeros_like(a)
    dL = [np.stack([-one, -one], axis=1), np.stack([one, zero], axis=1), np.stack([zero, one], axis=1)]
    if k == 3:
        return np.stack(L, axis=1), np.stack(dL, axis=1)
    N = [L[i] * (2 * L[i] - 1) for i in range(3)]
    dN = [(4 * L[i] - 1)[:, None] * dL[i] for i in range(3)]
    for i, j in ((0, 1), (1, 2), (2, 0)):
        N.append(4 * L[i] * L[j])
        dN.append(4 * (L[j][:, None] * dL[i] + L[i][:, None] * dL[j]))
    return np.stack(N, axis=1), np.stack(dN, axis=1)


def _gauss(fdim: int, k: int) -> tuple[np.ndarray, np.ndarray]:
    """Gauss points (p, fdim) and weights of a slave facet (reference length 1, area 1/2 or 1):
    as many as the facet has nodes (3 per segment)."""
    if fdim == 1 or _quadrilateral(fdim, k):
        m = GAUSS_POINTS if fdim == 1 else int(round(math.sqrt(k)))
        eta, w = np.polynomial.legendre.leggauss(m)
        eta, w = (eta + 1) / 2, w / 2
        if fdim == 1:
            return eta[:, None], w
        a, b = np.meshgrid(eta, eta, indexing="ij")
        return np.stack([a.reshape(-1), b.reshape(-1)], axis=1), np.outer(w, w).reshape(-1)
    if k == 3:                                      # degree 2
        return np.array([[1 / 6, 1 / 6], [2 / 3, 1 / 6], [1 / 6, 2 / 3]]), np.full(3, 1 / 6)
    points, weights = [], []                        # degree 4 (Strang and Fix; Dunavant 1985)
    for a, w in ((0.445948490915965, 0.223381589678011), (0.091576213509771, 0.109951743655322)):
        points += [[a, a], [1 - 2 * a, a], [a, 1 - 2 * a]]
        weights += [w / 2] * 3
    return np.array(points), np.array(weights)


def _normal_vector(T):
    """Outward normal (not unit), (n, d), of facets with tangents ``T`` (n, fdim, d): ``(t_y, -t_x)``
    of a segment, ``t_1 x t_2`` of a triangle (the nodes are ordered so that these point out)."""
    if T.shape[1] == 1:
        return np.stack([T[:, 0, 1], -T[:, 0, 0]], axis=1)
    a, b = T[:, 0], T[:, 1]
    return np.stack([a[:, 1] * b[:, 2] - a[:, 2] * b[:, 1], a[:, 2] * b[:, 0] - a[:, 0] * b[:, 2],
                     a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0]], axis=1)


def _unit(v):
    """``v / |v|`` along the last axis (analytic: also for complex-step coordinates)."""
    return v / np.sqrt(np.sum(v * v, axis=-1))[..., None]


def _facet_nodes(V, facet_tags, ids) -> list[tuple[np.ndarray, np.ndarray]]:
    """This rank's facets of ``ids``: (global node blocks in the order of :func:`_shape`, oriented
    so that :func:`_normal_vector` points out of the body, and their reference coordinates)."""
    msh = V.mesh
    tdim = msh.topology.dim
    fdim = tdim - 1
    cell_name = msh.topology.cell_type.name
    if cell_name not in _CELL_EDGES:
        raise ValueError(f"FacetContact: triangles, tetrahedra or hexahedra only, got {cell_name}")
    coords = V.tabulate_dof_coordinates()[:, :tdim]
    l2g = V.dofmap.index_map.local_to_global
    layout = V.dofmap.dof_layout
    closure, own = layout.entity_closure_dofs, layout.entity_dofs
    # each edge of the cell: its two vertex dofs and the dof inside it (if any)
    edges = [(frozenset(closure(1, e)) - frozenset(own(1, e)), list(own(1, e)))
             for e in range(_CELL_EDGES[cell_name])]
    all_dofs = compat.cell_dofs(V.dofmap)
    facets = []
    for f in facet_tags.indices[np.isin(facet_tags.values, list(ids))]:
        cell = compat.entity_links(msh, fdim, tdim, f)[0]
        local = int(np.flatnonzero(compat.entity_links(msh, tdim, fdim, cell) == f)[0])
        facet = closure(fdim, local)
        sides = [(ends, inner) for ends, inner in edges if ends <= set(facet)] if fdim == 2 else \
            [(frozenset(facet) - frozenset(own(1, local)), list(own(1, local)))]
        mids = {ends: inner[0] for ends, inner in sides if inner}
        centre = list(own(fdim, local)) if fdim == 2 else []
        corners = [d for d in facet if d not in set(mids.values()) | set(centre)]
        if fdim == 1:
            order = [corners[0]] + list(mids.values()) + [corners[1]]
        else:
            if len(corners) == 4:                    # in turn round the quadrilateral
                c0 = corners[0]
                c1, c3 = [next(iter(ends - {c0})) for ends, _ in sides if c0 in ends]
                corners = [c0, c1, next(c for c in corners if c not in (c0, c1, c3)), c3]
            n = len(corners)
            order = corners + ([mids[frozenset((corners[i], corners[(i + 1) % n]))] for i in range(n)] + centre
                               if mids else [])
        cell_dofs = all_dofs[cell]
        X = coords[cell_dofs[order]]
        k = len(order)
        middle = np.full((1, fdim), 0.5 if fdim == 1 or _quadrilateral(fdim, k) else 1 / 3)
        N, dN = _shape(middle, fdim, k)
        outward = (N[0] @ X) - coords[cell_dofs].mean(axis=0)
        if _normal_vector(np.einsum("kf,kd->fd", dN[0], X)[None])[0] @ outward < 0:
            flip = (list(range(k))[::-1] if fdim == 1 else
                    [0, 3, 2, 1, 7, 6, 5, 4, 8][:k] if _quadrilateral(fdim, k) else [0, 2, 1, 5, 4, 3][:k])
            order = [order[i] for i in flip]
            X = X[flip]
        facets.append((l2g(np.asarray(cell_dofs[order], dtype=np.int32)).astype(np.int64), X))
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


def _nodal_normals(patch, surface):
    """Unit normals (n, k, d) at the nodes of master facets, each the average of the normals of
    the facets around the node, at that node; ``patch`` (n, P, d): the coordinates (possibly
    complex) of the facets' patches; ``surface``: ``(ring, weight, dN)`` of the facets around each
    node (patch indices of their nodes, 1 or 0 for padding, their shape-function derivatives at
    that node)."""
    ring, weight, ring_dN = surface
    fdim, d = ring_dN.shape[-1], patch.shape[2]
    around = patch[np.arange(len(patch))[:, None, None, None], ring]               # (n, k, K, k, d)
    tangents = np.einsum("nikjf,nikjd->nikfd", ring_dN, around)
    normals = _unit(_normal_vector(tangents.reshape(-1, fdim, d)).reshape(around.shape[:3] + (d,)))
    return _unit(np.einsum("nik,nikd->nid", weight, normals))


def _tiled(a: np.ndarray, m: int) -> np.ndarray:
    """``m`` copies of ``a`` stacked along its first axis."""
    return np.tile(a, (m,) + (1,) * (a.ndim - 1))


def _complex_step(values: np.ndarray, evaluate) -> np.ndarray:
    """Derivatives (rows, outputs, columns) of ``evaluate`` by each column of ``values`` (rows,
    columns), by the complex step, all columns in one call: ``evaluate(stacked, m)`` gets the
    ``m`` perturbed copies stacked along the rows (copy k, row i at k * rows + i) and returns one
    row of outputs for each."""
    rows, m = values.shape
    stacked = np.repeat(values[None].astype(complex), m, axis=0)                  # (m, rows, m)
    stacked[np.arange(m), :, np.arange(m)] += 1j * _STEP
    out = evaluate(stacked.reshape(m * rows, m), m)
    return out.reshape(m, rows, -1).imag.transpose(1, 2, 0) / _STEP


def _pair_forces(q: np.ndarray, Ns: np.ndarray, kw: np.ndarray, nodal: np.ndarray, xi0: np.ndarray, friction=None):
    """Gap and nodal forces of pairs.  Rows of ``q`` hold the node coordinates (possibly complex)
    of the slave facet, of the master facet now under the point and of the master facet the point
    touched at the last converged step; ``Ns``: the slave shape functions at the point;
    ``nodal``: the master facet's nodal normals (:func:`_nodal_normals`); ``xi0``: the start of
    the projection; ``friction``: ``(mu, k_T, xi_n, t_n, w, carried)`` (``carried``: 1 where the
    point has a converged contact to slip from, else 0) or ``None``.  Returns the gap, the nodal
    forces on the slave and master facets' nodes (in the order of ``q``), ``xi`` and the friction
    traction."""
    n_pairs, ks = Ns.shape
    km, d = nodal.shape[1], nodal.shape[2]
    fdim = d - 1
    nodes = q.reshape(n_pairs, q.shape[1] // d, d)
    xs = np.einsum("nk,nkd->nd", Ns, nodes[:, :ks])
    xm, old = nodes[:, ks:ks + km], nodes[:, ks + km:]
    xi, g = xi0.astype(q.dtype), np.zeros(n_pairs, dtype=q.dtype)
    for it in range(PROJECTION_ITERATIONS + 1):          # x_s = x(xi) + g n(xi)
        N, dN = _shape(xi, fdim, km)
        x, t = np.einsum("nk,nkd->nd", N, xm), np.einsum("nkf,nkd->nfd", dN, xm)
        m, dm = np.einsum("nk,nkd->nd", N, nodal), np.einsum("nkf,nkd->nfd", dN, nodal)
        size = np.sqrt(np.sum(m * m, axis=1))
        n = m / size[:, None]
        if it == 0:
            g = np.sum((xs - x) * n, axis=1)
        if it == PROJECTION_ITERATIONS:
            break
        dn = (dm - n[:, None, :] * np.sum(n[:, None, :] * dm, axis=2)[:, :, None]) / size[:, None, None]
        J = np.concatenate([-(t + g[:, None, None] * dn), -n[:, None, :]], axis=1).transpose(0, 2, 1)
        step = np.linalg.solve(J, -(xs - x - g[:, None] * n)[:, :, None])[:, :, 0]
        xi, g = xi + step[:, :fdim], g + step[:, fdim]
    g = np.sum((xs - x) * n, axis=1)
    kwg = (kw * g)[:, None, None]
    f_slave = kwg * Ns[:, :, None] * n[:, None, :]
    f_master = -kwg * N[:, :, None] * n[:, None, :]
    t_T = 0 * n
    if friction is not None:
        mu, k_T, xi_n, t_n, w, carried = friction
        slip = xs - np.einsum("nk,nkd->nd", _shape(xi_n, fdim, km)[0], old)

        def tangential(v):
            return v - n * np.sum(n * v, axis=1)[:, None]

        trial = tangential(t_n) - k_T * tangential(slip)
        size = np.sqrt(np.sum(trial * trial, axis=1))
        limit = mu * (-(kw / w) * g)                  # mu p: the pairs penetrate
        slips = size.real > limit.real
        t_T = (carried * np.where(slips, limit / np.where(slips, size, 1.0), 1.0))[:, None] * trial
        f_slave = f_slave - (w[:, None] * t_T)[:, None, :] * Ns[:, :, None]
        f_master = f_master + (w[:, None] * t_T)[:, None, :] * N[:, :, None]
    forces = np.concatenate([f_slave, f_master], axis=1).reshape(n_pairs, d * (ks + km))
    return g, forces, xi, t_T


class FacetContact:
    """Penalty contact of the ``slave`` facets (tags) on the ``master`` facets of the problem's
    mesh (plane strain or 3D): two parts of one mesh that share no node.

    ``penalty``: alpha in ``kappa = alpha E / h``; ``friction``: Coulomb's mu (0: frictionless).
    Registers itself with the problem (its forces, tangent and the friction history, committed
    with the problem's state); read the state with :meth:`forces` and :meth:`pressures`.
    """

    def __init__(self, problem, facet_tags, slave, master, *, penalty: float = DEFAULT_PENALTY,
                 friction: float = 0.0):
        if not friction >= 0:
            raise ValueError(f"friction must be >= 0, got {friction}")
        self.friction = float(friction)
        self.problem = problem
        self.comm = comm = problem.comm
        V = problem.V
        self.d = d = problem.gdim
        self.fdim = fdim = d - 1
        self.bs = V.dofmap.index_map_bs
        self.first, self.last = V.dofmap.index_map.local_range
        slave_facets = _gather_facets(comm, V, facet_tags, slave)
        master_facets = _gather_facets(comm, V, facet_tags, master)
        self.nodes = np.unique(np.concatenate([f[0] for f in slave_facets + master_facets]))
        if np.intersect1d(np.concatenate([f[0] for f in slave_facets]),
                          np.concatenate([f[0] for f in master_facets])).size:
            raise ValueError("the slave and master surfaces share nodes")
        position = {int(i): x for b, X in slave_facets + master_facets for i, x in zip(b, X)}
        self.X = np.array([position[int(i)] for i in self.nodes])
        self._owned = (self.nodes >= self.first) & (self.nodes < self.last)
        # this rank's slave facets and their Gauss points
        mine = slave_facets[comm.rank::comm.size]
        ks = len(slave_facets[0][0])
        eta, gw = _gauss(fdim, ks)
        N, dN = _shape(eta, fdim, ks)                                   # (points, ks), (points, ks, fdim)
        self.slave = np.array([np.searchsorted(self.nodes, b) for b, _ in mine], dtype=np.int64).reshape(-1, ks)
        X = np.array([X for _, X in mine]).reshape(-1, ks, d)
        self.point_X = np.einsum("pk,fkd->fpd", N, X).reshape(-1, d)
        T = np.einsum("pkf,ckd->cpfd", dN, X).reshape(-1, fdim, d)
        jac = np.linalg.norm(_normal_vector(T), axis=1).reshape(len(mine), len(gw))
        self.point_w = (jac * gw).reshape(-1)
        self.point_N = np.tile(N, (len(mine), 1))
        self.point_facet = np.repeat(np.arange(len(mine)), len(gw))
        self.master = np.array([np.searchsorted(self.nodes, b) for b, _ in master_facets], dtype=np.int64)
        km = self.master.shape[1]
        self._quadrilateral = _quadrilateral(fdim, km)
        #: the master facets' corner nodes (columns of :attr:`master`), for the search
        self._corners = [0, km - 1] if fdim == 1 else [0, 1, 2, 3] if self._quadrilateral else [0, 1, 2]
        self._patches()
        self.h = contact_cell_size(problem.mesh, facet_tags, tuple(slave) + tuple(master))
        self.E = max(mat.E for mat in problem.materials.values())
        self.alpha = float(penalty)
        self.kappa = penalty * self.E / self.h
        self._constrained = None
        # friction history per point: the master facet and xi touched at the last converged
        # step (-1: none) and the friction traction then
        self._touched = -np.ones(len(self.point_w), dtype=np.int64)
        self._xi_n = np.zeros((len(self.point_w), fdim))
        self._t_n = np.zeros((len(self.point_w), d))
        problem.add_assembled_term(self)
        problem.add_state_hooks(commit=self.commit)

    def _patches(self) -> None:
        """For each master facet, the facets around each of its nodes (those sharing the node) and
        their nodes: ``patch`` (facets, P) surface nodes, the facet's own first (padded with its
        first node); ``ring`` (facets, k, K, k) their patch indices, ``ring_weight`` (1, or 0 for
        padding) and ``ring_dN`` the facets' shape-function derivatives at the shared node."""
        master, fdim = self.master, self.fdim
        km = master.shape[1]
        at_node: dict[int, list] = {}
        for f, facet in enumerate(master):
            for i, node in enumerate(facet):
                at_node.setdefault(int(node), []).append((f, i))
        K = max(len(v) for v in at_node.values())
        patches = []
        for facet in master:
            nodes = list(facet) + sorted({int(n) for node in facet for g, _ in at_node[int(node)]
                                          for n in master[g]} - set(facet.tolist()))
            patches.append(nodes)
        P = max(len(nodes) for nodes in patches)
        self.patch = np.array([nodes + [nodes[0]] * (P - len(nodes)) for nodes in patches], dtype=np.int64)
        reference = _reference_nodes(fdim, km)
        dN_at = _shape(reference, fdim, km)[1]                        # (km: at node j, km, fdim)
        nf = len(master)
        self.ring = np.zeros((nf, km, K, km), dtype=np.int64)
        self.ring_weight = np.zeros((nf, km, K))
        self.ring_dN = np.zeros((nf, km, K, km, fdim))
        for f, facet in enumerate(master):
            index = {int(n): j for j, n in enumerate(self.patch[f][:len(patches[f])])}
            for i, node in enumerate(facet):
                around = at_node[int(node)]
                for slot in range(K):
                    g, j = around[slot] if slot < len(around) else (f, i)
                    self.ring[f, i, slot] = [index[int(n)] for n in master[g]]
                    self.ring_weight[f, i, slot] = 1.0 if slot < len(around) else 0.0
                    self.ring_dN[f, i, slot] = dN_at[j]

    # ------------------------------------------------------------------ state
    def _positions(self) -> np.ndarray:
        """Current positions of the surface nodes (gathered from their owners)."""
        local = self.nodes[self._owned] - self.first
        u = self.problem.u.x.array
        values = np.stack([u[self.bs * local + k] for k in range(self.d)], axis=1)
        x = self.X.copy()
        for where, part in self.comm.allgather((np.flatnonzero(self._owned), values)):
            x[where] += part
        return x

    def _candidates(self, xs, x):
        """Pairs (point, master facet) of the points ``xs`` with the facets whose flat version
        (through their vertices) they lie over or beside within reach, and the flat projection:
        ``xi`` (pairs, fdim), the gap and how far the point lies outside the facet."""
        corners = x[self.master[:, self._corners]]                       # (facets, corners, d)
        centroid = corners.mean(axis=1)
        reach = np.sqrt(np.max(np.sum((corners - centroid[:, None]) ** 2, axis=2)))
        near = cKDTree(centroid).query_ball_point(xs, reach + SEARCH_DEPTH * self.h)
        counts = np.array([len(c) for c in near], dtype=np.int64)
        points = np.repeat(np.arange(len(xs)), counts)
        facets = np.concatenate([np.asarray(c, dtype=np.int64) for c in near]) if points.size \
            else np.zeros(0, dtype=np.int64)
        v = corners[facets]
        edges = v[:, 1:2] - v[:, :1] if self.fdim == 1 else v[:, [1, -1]] - v[:, :1]    # (pairs, fdim, d)
        n = _unit(_normal_vector(edges))
        r = xs[points] - v[:, 0]
        gram = np.einsum("pad,pbd->pab", edges, edges)
        xi = np.linalg.solve(gram, np.einsum("pad,pd->pa", edges, r)[:, :, None])[:, :, 0]
        g = np.sum(r * n, axis=1)
        beyond = xi.max(axis=1) if self._quadrilateral or self.fdim == 1 else xi.sum(axis=1)
        outside = np.maximum(np.maximum(-xi.min(axis=1), beyond - 1), 0.0)
        return points, facets, xi, g, outside

    def _nearest(self, xs, x):
        """The master facet of each point ``xs`` (current coordinates) near enough to pair:
        (points, facets, the start of the projection ``xi``).  The nearest facet the point lies
        over; one it lies beside (within the tolerance) only if there is none: at a concave corner
        the extension of a facet runs inside the body."""
        points, facets, xi, g, outside = self._candidates(xs, x)
        score = np.abs(g) + np.where(outside > 0, (SEARCH_DEPTH + 1) * self.h + outside, 0.0)
        keep = (outside <= PROJECTION_TOLERANCE) & (np.abs(g) <= SEARCH_DEPTH * self.h)
        points, facets, xi, score = points[keep], facets[keep], xi[keep], score[keep]
        best = np.lexsort((score, points))
        first = np.ones(len(best), dtype=bool)
        first[1:] = points[best][1:] != points[best][:-1]
        best = best[first]
        return points[best], facets[best], xi[best]

    def _pairs(self, x=None):
        """Penetrating points of this rank's slave facets: (points, master facets, coordinates q,
        the start of their projection); ``x``: the surface nodes' positions (gathered now if not
        given: collective)."""
        x = self._positions() if x is None else x
        width = self.d * (self.slave.shape[1] + self.patch.shape[1] + self.master.shape[1])
        empty = (np.zeros(0, dtype=np.int64),) * 2 + (np.zeros((0, width)), np.zeros((0, self.fdim)))
        if self.point_X.size == 0:
            return empty
        xs = np.einsum("pk,pkd->pd", self.point_N, x[self.slave[self.point_facet]])
        points, facets, xi = self._nearest(xs, x)
        if not points.size:
            return empty
        q = x[self._pair_nodes(points, facets)].reshape(len(points), width)
        gap = self._evaluate(points, facets, q, xi, kw=np.zeros(len(points)))[0]
        inside = gap < 0
        return (points[inside], facets[inside], q[inside], xi[inside]) if inside.any() else empty

    def contact_area(self, samples: int = 8) -> float:
        """Area (m^2, or m in plane strain; reference measure) of the slave surface in contact now,
        summed over all ranks: each slave facet sampled by ``samples`` points per direction
        (midpoints of a regular subdivision), finer than its Gauss points, so that the area grows
        smoothly as the patch spreads (collective)."""
        x = self._positions()
        fdim, ks, d = self.fdim, self.slave.shape[1], self.d
        if fdim == 1 or _quadrilateral(fdim, ks):
            t = (np.arange(samples) + 0.5) / samples
            eta = t[:, None] if fdim == 1 else np.stack(np.meshgrid(t, t, indexing="ij"), axis=2).reshape(-1, 2)
            weight = np.full(len(eta), 1.0 / len(eta))
        else:                     # centroids of the samples^2 sub-triangles of the reference triangle
            i, j = np.meshgrid(np.arange(samples), np.arange(samples), indexing="ij")
            up = (i + j < samples)
            down = (i + j < samples - 1)
            eta = np.concatenate([np.stack([i[up] + 1 / 3, j[up] + 1 / 3], axis=1),
                                  np.stack([i[down] + 2 / 3, j[down] + 2 / 3], axis=1)]) / samples
            weight = np.full(len(eta), 0.5 / len(eta))
        N, dN = _shape(eta, fdim, ks)
        X = self.X[self.slave]                                            # (facets, ks, d) reference
        T = np.einsum("pkf,ckd->cpfd", dN, X).reshape(-1, fdim, d)
        w = (np.linalg.norm(_normal_vector(T), axis=1).reshape(len(X), len(eta)) * weight).reshape(-1)
        xs = np.einsum("pk,ckd->cpd", N, x[self.slave]).reshape(-1, d)
        points, facets, xi = self._nearest(xs, x) if len(xs) else (np.zeros(0, dtype=np.int64),) * 3
        area = 0.0
        if points.size:
            core = np.concatenate([xs[points][:, None, :], x[self.master[facets]], x[self.master[facets]]], axis=1)
            nodal = _nodal_normals(x[self.patch[facets]], self._surface(facets))
            gap = _pair_forces(core.reshape(len(points), -1), np.ones((len(points), 1)), np.zeros(len(points)),
                               nodal, xi)[0]
            area = float(w[points[gap < 0]].sum())
        return self.comm.allreduce(area)

    def _pair_nodes(self, points, facets) -> np.ndarray:
        """Surface nodes of the pairs: slave facet, master facet with its patch, the facet touched."""
        touched = np.where(self._touched[points] >= 0, self._touched[points], facets)
        return np.concatenate([self.slave[self.point_facet[points]], self.patch[facets], self.master[touched]],
                              axis=1)

    def _surface(self, facets):
        return self.ring[facets], self.ring_weight[facets], self.ring_dN[facets]

    def _split(self, q):
        """The slave facet, master facet and touched facet's coordinates (the core of the pairs)
        and the master facets' patches, of the pairs' coordinates ``q``."""
        ks, km, P, d = self.slave.shape[1], self.master.shape[1], self.patch.shape[1], self.d
        nodes = q.reshape(len(q), ks + P + km, d)
        core = np.concatenate([nodes[:, :ks + km], nodes[:, ks + P:]], axis=1).reshape(len(q), d * (ks + 2 * km))
        return core, nodes[:, ks:ks + P]

    def _core(self, points, core, nodal, xi0, kw=None):
        """:func:`_pair_forces` of the pairs' core coordinates and nodal normals."""
        w = self.point_w[points]
        friction = None
        if self.friction > 0:
            friction = (self.friction, self.kappa, self._xi_n[points], self._t_n[points], w,
                        (self._touched[points] >= 0).astype(float))
        return _pair_forces(core, self.point_N[points], self.kappa * w if kw is None else kw, nodal, xi0, friction)

    def _evaluate(self, points, facets, q, xi0, kw=None):
        """Gap, nodal forces (in the order of the pairs' nodes, :meth:`_pair_nodes`), xi and
        friction traction of the pairs (see :func:`_pair_forces`)."""
        core, patch = self._split(q)
        g, f, xi, t_T = self._core(points, core, _nodal_normals(patch, self._surface(facets)), xi0, kw)
        forces = np.zeros(q.shape, dtype=f.dtype)
        forces[:, :f.shape[1]] = f
        return g, forces, xi, t_T

    def _dofs(self, points, facets) -> np.ndarray:
        """Global dofs of the pairs' nodes (:meth:`_pair_nodes`; pairs x d nodes)."""
        blocks = self.nodes[self._pair_nodes(points, facets)]
        return (self.bs * blocks[:, :, None] + np.arange(self.d)).reshape(len(points), self.d * blocks.shape[1])

    def _gather_constrained(self) -> None:
        """The surface dofs held by the problem's Dirichlet conditions, once (collective)."""
        if self._constrained is None:
            bs, first = self.bs, self.first
            held = [bs * first + local[local < bs * (self.last - first)]
                    for local in (np.asarray(bc.dof_indices()[0], dtype=np.int64) for bc in self.problem.bcs)]
            held = np.concatenate(held) if held else np.zeros(0, dtype=np.int64)
            surface = (bs * self.nodes[:, None] + np.arange(self.d)).reshape(-1)
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
        points, facets, q, xi0 = self._pairs(x)
        dofs = self._dofs(points, facets)
        return self._evaluate(points, facets, q, xi0)[1], dofs, self._free(dofs)

    def _local_tangent(self, x):
        """The pairs' tangent: rows, columns (global dofs) and values of its nonzero entries outside
        the Dirichlet rows and columns (repeated entries to be summed).  By the chain rule: the
        complex step of the forces by the core coordinates and by the nodal normals, and of the
        nodal normals by the patch's coordinates, once per master facet."""
        points, facets, q, xi0 = self._pairs(x)
        if not len(points):
            return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64), np.zeros(0)
        ks, km, P, d = self.slave.shape[1], self.master.shape[1], self.patch.shape[1], self.d
        n, loaded = len(points), d * (ks + km)          # the slave and master facets' rows
        core, patch = self._split(q)
        unique, first, inverse = np.unique(facets, return_index=True, return_inverse=True)
        surface = self._surface(unique)
        patch = patch[first]                                                   # (facets, P, d)
        D_nodal = _complex_step(patch.reshape(len(unique), P * d), lambda pc, m: _nodal_normals(
            pc.reshape((-1,) + patch.shape[1:]), tuple(_tiled(a, m) for a in surface)).reshape(len(pc), km * d))
        nodal = _nodal_normals(patch, surface)[inverse]
        K_core = _complex_step(core, lambda cc, m: self._core(_tiled(points, m), cc, _tiled(nodal, m),
                                                              _tiled(xi0, m))[1])
        K_nodal = _complex_step(nodal.reshape(n, km * d), lambda nc, m: self._core(
            _tiled(points, m), _tiled(core, m), nc.reshape((-1,) + nodal.shape[1:]), _tiled(xi0, m))[1])
        K = np.zeros((n, loaded, q.shape[1]))
        K[:, :, :loaded] = K_core[:, :, :loaded]
        K[:, :, d * (ks + P):] = K_core[:, :, loaded:]
        K[:, :, d * ks:d * (ks + P)] += K_nodal @ D_nodal[inverse]
        dofs = self._dofs(points, facets)
        free = self._free(dofs)
        keep = free[:, :loaded, None] & free[:, None, :] & (K != 0)
        rows = np.broadcast_to(dofs[:, :loaded, None], K.shape)[keep]
        cols = np.broadcast_to(dofs[:, None, :], K.shape)[keep]
        return rows, cols, K[keep]

    def add_residual(self, b: PETSc.Vec) -> None:
        """Add the contact forces of the current iterate to the assembled residual ``b``."""
        f, dofs, free = self._on_every_rank(self._local_forces)
        b.setValues(dofs[free].astype(PETSc.IntType), f[free], addv=PETSc.InsertMode.ADD_VALUES)
        b.assemblyBegin()
        b.assemblyEnd()

    def add_jacobian(self, A: PETSc.Mat) -> None:
        """Add the pairs' exact tangent to the Jacobian ``A`` (assembled here).  The entries go to
        their owners and into a matrix of their own, added to ``A`` at once: inserting the pairs'
        couplings, new to ``A``'s sparsity, one by one would reallocate ``A`` for every row."""
        rows, cols, values = self._on_every_rank(self._local_tangent)
        comm = self.comm
        ranges = A.getOwnershipRanges()
        owner = np.searchsorted(ranges, rows, side="right") - 1
        parts = comm.alltoall([(rows[owner == r], cols[owner == r], values[owner == r]) for r in range(comm.size)])
        rows, cols, values = (np.concatenate([part[i] for part in parts]) for i in range(3))
        size = A.getSize()[1]
        key, where = np.unique(rows * size + cols, return_inverse=True)
        values = np.bincount(where, weights=values, minlength=len(key))
        local = key // size - ranges[comm.rank]
        indptr = np.r_[0, np.cumsum(np.bincount(local, minlength=ranges[comm.rank + 1] - ranges[comm.rank]))]
        C = PETSc.Mat().createAIJ(A.getSizes(), csr=(indptr.astype(PETSc.IntType), (key % size).astype(PETSc.IntType),
                                                     values), comm=comm)
        C.assemble()
        A.assemble()
        A.axpy(1.0, C, structure=PETSc.Mat.Structure.UNKNOWN_NONZERO_PATTERN)
        C.destroy()

    def commit(self) -> None:
        """Keep the converged contact points' master facet, xi and friction traction (collective)."""
        points, facets, q, xi0 = self._pairs()
        _, _, xi, t_T = self._evaluate(points, facets, q, xi0)
        self._touched[:] = -1
        self._touched[points] = facets
        self._xi_n[points] = xi
        self._t_n[:] = 0.0
        self._t_n[points] = t_T

    # ------------------------------------------------------------------ reading
    def pressures(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """This rank's slave points in contact now: reference coordinates (m), weights (m^2, or m)
        and pressure (Pa); the weights sum the pressure to a force (per unit length in plane
        strain; collective)."""
        return self._in_contact(current=False)

    def contact_points(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """:meth:`pressures` with the points' current coordinates (m) (collective)."""
        return self._in_contact(current=True)

    def _in_contact(self, current: bool):
        x = self._positions()
        points, facets, q, xi0 = self._pairs(x)
        gap = self._evaluate(points, facets, q, xi0)[0]
        where = (np.einsum("pk,pkd->pd", self.point_N[points], x[self.slave[self.point_facet[points]]]) if current
                 else self.point_X[points])
        return where, self.point_w[points], -self.kappa * gap

    def forces(self) -> PairForces:
        """Force on the slave body and the pressure's extremes and moments now (collective)."""
        points, facets, q, xi0 = self._pairs()
        g, f, _, _ = self._evaluate(points, facets, q, xi0)
        ks, d = self.slave.shape[1], self.d
        force = -f[:, : d * ks].reshape(len(points), ks, d).sum(axis=(0, 1))
        p, w, x = -self.kappa * g, self.point_w[points], self.point_X[points, 0]
        comm = self.comm
        return PairForces(force=comm.allreduce(force),
                          max_pressure=comm.allreduce(float(p.max()) if p.size else 0.0, op=MPI.MAX),
                          max_penetration=comm.allreduce(float(-g.min()) if g.size else 0.0, op=MPI.MAX),
                          points_in_contact=comm.allreduce(int(p.size)), M0=comm.allreduce(float(w @ p)),
                          M2=comm.allreduce(float(w @ (p * x ** 2))))
