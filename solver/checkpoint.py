"""Partition-independent state files: every value is stored with the position of its dof node or
quadrature point, so a state written on one partition (number of ranks, or the same number of
ranks partitioned differently: the graph partitioner is not deterministic) is read on another.

Used by :meth:`rollsim.solver.indentation.WheelIndentation.write_checkpoint`.  A checkpoint of
several files is written whole by :func:`staged` and then put in place of the previous one.
"""
from __future__ import annotations

import contextlib
import pathlib
from typing import Iterator

import numpy as np
import ufl
from dolfinx import fem
from scipy.spatial import cKDTree

from rollsim import compat
from rollsim.files import remove_directory, replace_directory, staging_directory
from rollsim.mpi import root_block

#: Largest distance between a stored and a local point that still counts as the same point,
#: relative to the extent of the stored points (coordinates agree to round-off between partitions).
MATCH_RTOL = 1e-8


@contextlib.contextmanager
def staged(path, comm) -> Iterator[pathlib.Path]:
    """An empty directory (collective; rank 0 makes it) for the next version of the checkpoint
    directory ``path``, put in its place when the block ends without an exception: a kill at any
    moment leaves the previous version or this one whole (:func:`rollsim.files.complete_directory`).
    A failure on rank 0 is raised on every rank."""
    stage = staging_directory(path)
    with root_block(comm) as on_root:
        if on_root:
            remove_directory(stage)
            stage.mkdir(parents=True)
    yield stage
    with root_block(comm) as on_root:
        if on_root:
            replace_directory(path)


def _points(V) -> np.ndarray:
    """Positions (n, 3) in m of the owned dof nodes or quadrature points of the Lagrange or
    quadrature space ``V`` (owned dofs come first in the local arrays)."""
    n = V.dofmap.index_map.size_local
    qdeg = compat.quadrature_degree_of(V)
    if qdeg is None:
        return V.tabulate_dof_coordinates()[:n]
    mesh = V.mesh
    expr = compat.expression(ufl.SpatialCoordinate(mesh), compat.quadrature_points(mesh, qdeg))
    x = compat.evaluate(expr, mesh).reshape(-1, mesh.geometry.dim)
    if x.shape[0] != n:
        raise RuntimeError(f"quadrature space: {x.shape[0]} points on the owned cells, {n} owned dofs")
    return np.hstack([x, np.zeros((n, 3 - x.shape[1]))])


def _owned_values(f: fem.Function) -> np.ndarray:
    """Values (n, bs) of the owned entries of ``f``."""
    V = f.function_space
    n, bs = V.dofmap.index_map.size_local, V.dofmap.index_map_bs
    return f.x.array[:n * bs].reshape(n, bs)


def _first_on_space(functions: dict[str, fem.Function], name: str) -> str:
    """Name of the first of ``functions`` on the space of ``functions[name]``."""
    V = functions[name].function_space
    return next(k for k, f in functions.items() if f.function_space is V)


def gather(comm, functions: dict[str, fem.Function]) -> dict[str, np.ndarray] | None:
    """The owned points and values of ``functions`` from all ranks, on rank 0 (None elsewhere):
    ``<name>.v`` the values; the points once per function space, as ``<name>.x`` of the first
    function on it and ``<other>.at`` (that name) for the others."""
    out = {}
    for name, f in functions.items():
        first = _first_on_space(functions, name)
        xs = comm.gather(_points(f.function_space), root=0) if first == name else None
        vs = comm.gather(_owned_values(f), root=0)
        if comm.rank == 0:
            out[f"{name}.v"] = np.vstack(vs)
            if first == name:
                out[f"{name}.x"] = np.vstack(xs)
            else:
                out[f"{name}.at"] = np.array(first)
    return out if comm.rank == 0 else None


def scatter(functions: dict[str, fem.Function], stored: dict[str, np.ndarray]) -> tuple[dict[str, np.ndarray], float]:
    """Local arrays (owned and ghost entries) for ``functions`` from what :func:`gather` stored,
    and the largest distance (relative to the stored points' extent) of a local point from its
    stored match; the points of each space are matched once.  The functions are not changed.
    Raises ``KeyError`` (the name) for a function not stored, ``ValueError`` for a wrong size."""
    arrays, worst, matched = {}, 0.0, {}
    for name, f in functions.items():
        V = f.function_space
        key = str(stored[f"{name}.at"]) if f"{name}.at" in stored else name     # where its points are
        if f"{name}.v" not in stored or f"{key}.x" not in stored:
            raise KeyError(name)
        first = _first_on_space(functions, name)
        if first not in matched:
            x, points = _points(V), stored[f"{key}.x"]
            dist, idx = cKDTree(points).query(x) if len(x) else (np.zeros(0), np.zeros(0, dtype=int))
            extent = max(float(np.ptp(points, axis=0).max()), 1e-300)
            worst = max(worst, float(dist.max()) / extent if len(x) else 0.0)
            matched[first] = idx
        idx, values = matched[first], stored[f"{name}.v"]
        n, bs = len(idx), V.dofmap.index_map_bs
        if values.shape[1] != bs:
            raise ValueError(f"{name}: {values.shape[1]} values stored per point, the space has {bs}")
        tmp = fem.Function(V)
        tmp.x.array[:n * bs] = values[idx].reshape(-1)
        tmp.x.scatter_forward()
        arrays[name] = tmp.x.array.copy()
    return arrays, worst
