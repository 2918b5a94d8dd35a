"""Partition-independent state files: every value is stored with the position of its dof node or
quadrature point, so a state written on one partition (number of ranks, or the same number of
ranks partitioned differently: the graph partitioner is not deterministic) is read on another.

Used by :meth:`rollsim.solver.indentation.WheelIndentation.write_checkpoint`.
"""
from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem
from scipy.spatial import cKDTree

from rollsim import compat

#: Largest distance between a stored and a local point that still counts as the same point,
#: relative to the extent of the stored points (coordinates agree to round-off between partitions).
MATCH_RTOL = 1e-8


def _owned(f: fem.Function) -> tuple[np.ndarray, np.ndarray]:
    """(points (n, 3) in m, values (n, bs)) of the owned entries of a Lagrange or quadrature
    Function (owned dofs come first in the local arrays)."""
    V = f.function_space
    n, bs = V.dofmap.index_map.size_local, V.dofmap.index_map_bs
    values = f.x.array[:n * bs].reshape(n, bs)
    qdeg = compat.quadrature_degree_of(V)
    if qdeg is not None:
        mesh = V.mesh
        expr = compat.expression(ufl.SpatialCoordinate(mesh), compat.quadrature_points(mesh, qdeg))
        x = compat.evaluate(expr, mesh).reshape(-1, mesh.geometry.dim)
        if x.shape[0] != n:
            raise RuntimeError(f"quadrature space of {f.name}: {x.shape[0]} points on the owned cells, {n} owned dofs")
        x = np.hstack([x, np.zeros((n, 3 - x.shape[1]))])
    else:
        x = V.tabulate_dof_coordinates()[:n]
    return x, values


def gather(comm, functions: dict[str, fem.Function]) -> dict[str, np.ndarray] | None:
    """The owned points and values of ``functions`` from all ranks, on rank 0 (None elsewhere):
    keys ``<name>.x`` and ``<name>.v``."""
    out = {}
    for name, f in functions.items():
        x, v = _owned(f)
        xs, vs = comm.gather(x, root=0), comm.gather(v, root=0)
        if comm.rank == 0:
            out[f"{name}.x"], out[f"{name}.v"] = np.vstack(xs), np.vstack(vs)
    return out if comm.rank == 0 else None


def local_values(f: fem.Function, points: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, float]:
    """Local array (owned and ghost entries) for the space of ``f`` from stored ``points`` and
    ``values``, and the largest distance (relative to the points' extent) of a local point from its
    stored match.  ``f`` is not changed."""
    x, _ = _owned(f)
    n, bs = x.shape[0], f.function_space.dofmap.index_map_bs
    if values.shape[1] != bs:
        raise ValueError(f"{f.name}: {values.shape[1]} values stored per point, the space has {bs}")
    dist, idx = cKDTree(points).query(x) if n else (np.zeros(0), np.zeros(0, dtype=int))
    extent = max(float(np.ptp(points, axis=0).max()), 1e-300)
    tmp = fem.Function(f.function_space)
    tmp.x.array[:n * bs] = values[idx].reshape(-1)
    tmp.x.scatter_forward()
    return tmp.x.array.copy(), (float(dist.max()) / extent if n else 0.0)
