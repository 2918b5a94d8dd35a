"""The only module that touches DOLFINx APIs which changed after 0.5.

Porting to a newer DOLFINx means changing this file, not the callers.
Targets DOLFINx 0.5.2 (Debian bookworm).
"""
from __future__ import annotations

import numpy as np
import ufl
from dolfinx import fem, io
from mpi4py import MPI

DOLFINX_VERSION = "0.5"

#: Seconds a process waits for another one that compiles the same form (DOLFINx's default: 10 s).
#: On a fresh cache, study groups (split communicators) and parallel test workers compile the same
#: forms at once, and under load one 3D contact form can take longer than 10 s to compile.  Bounded,
#: so that a lock left by a killed compile still ends in DOLFINx's "clean the cache" error.
JIT_TIMEOUT = 120


def _raise_jit_timeout(seconds: int) -> None:
    from dolfinx import jit
    value, doc = jit.DOLFINX_DEFAULT_JIT_PARAMETERS["timeout"]
    if value < seconds:
        jit.DOLFINX_DEFAULT_JIT_PARAMETERS["timeout"] = (seconds, doc)


_raise_jit_timeout(JIT_TIMEOUT)


def model_to_mesh(model, comm: MPI.Comm, rank: int, gdim: int):
    """gmsh model (built on ``rank``) -> (mesh, cell_tags, facet_tags), distributed over ``comm``."""
    from dolfinx.io import gmshio
    return gmshio.model_to_mesh(model, comm, rank, gdim=gdim)


def vector_space(mesh, degree: int, family: str = "Lagrange"):
    """Vector-valued continuous Lagrange space (one component per geometric dimension)."""
    return fem.VectorFunctionSpace(mesh, (family, degree))


def scalar_space(mesh, degree: int, family: str = "Lagrange"):
    return fem.FunctionSpace(mesh, (family, degree))


def quadrature_space(mesh, degree: int, shape: tuple[int, ...] = ()):
    """Space of values at the quadrature points of ``degree`` (scalar, vector or tensor)."""
    cell = mesh.ufl_cell()
    if shape == ():
        element = ufl.FiniteElement("Quadrature", cell, degree, quad_scheme="default")
    elif len(shape) == 1:
        element = ufl.VectorElement("Quadrature", cell, degree, dim=shape[0], quad_scheme="default")
    else:
        element = ufl.TensorElement("Quadrature", cell, degree, shape=shape, quad_scheme="default")
    return fem.FunctionSpace(mesh, element)


def quadrature_degree_of(V) -> int | None:
    """Degree of a ``quadrature_space``; None for any other space."""
    element = V.ufl_element()
    return element.degree() if element.family() == "Quadrature" else None


def quadrature_points(mesh, degree: int) -> np.ndarray:
    """Reference quadrature points of the default scheme used by ``quadrature_space``."""
    import basix
    cell = {"triangle": basix.CellType.triangle, "tetrahedron": basix.CellType.tetrahedron,
            "quadrilateral": basix.CellType.quadrilateral,
            "hexahedron": basix.CellType.hexahedron}[mesh.topology.cell_name()]
    points, _ = basix.make_quadrature(cell, degree)
    return points


def expression(ufl_expr, points: np.ndarray):
    """Compiled UFL expression evaluated at reference ``points``."""
    return fem.Expression(ufl_expr, points)


def evaluate(expr, mesh) -> np.ndarray:
    """Values of ``expr`` on the owned cells of ``mesh``, shape (cells, points x components)
    (``Expression.eval`` also takes the mesh after 0.5)."""
    n_cells = mesh.topology.index_map(mesh.topology.dim).size_local
    return expr.eval(np.arange(n_cells, dtype=np.int32))


def evaluate_into(expr, target: fem.Function) -> None:
    """Evaluate ``expr`` on the local cells and store it in the quadrature Function ``target``.

    Quadrature-space ``Function.interpolate`` does not work in 0.5.2, hence this.
    """
    values = evaluate(expr, target.function_space.mesh)  # owned cells come first in a quadrature dofmap
    target.x.array[:values.size] = values.reshape(-1)
    target.x.scatter_forward()


def xdmf_file(comm: MPI.Comm, path, mode: str = "w"):
    """XDMF writer (no ADIOS2 in the Debian build)."""
    return io.XDMFFile(comm, str(path), mode)


def write_tagged_mesh(comm: MPI.Comm, path, mesh, cell_tags, facet_tags) -> None:
    """Write ``mesh`` with its cell and facet tags to one XDMF file (tags named as their ``name``)."""
    tdim = mesh.topology.dim
    mesh.topology.create_connectivity(tdim - 1, tdim)
    with io.XDMFFile(comm, str(path), "w") as xdmf:
        xdmf.write_mesh(mesh)
        xdmf.write_meshtags(cell_tags)
        xdmf.write_meshtags(facet_tags)


def cell_midpoints(mesh) -> fem.Function:
    """DG0 vector Function holding each cell's midpoint (the image of the reference centroid)."""
    V = fem.VectorFunctionSpace(mesh, ("DG", 0))
    f = fem.Function(V, name="cell_midpoint")
    f.interpolate(fem.Expression(ufl.SpatialCoordinate(mesh), interpolation_points(V)))
    return f


def interpolation_points(V) -> np.ndarray:
    """Reference interpolation points of the element of ``V`` (a method in 0.5, a property later)."""
    pts = V.element.interpolation_points
    return pts() if callable(pts) else pts


def cell_diameters(mesh, cells: np.ndarray) -> np.ndarray:
    """Largest vertex-to-vertex distance of each of the local ``cells``."""
    x = mesh.geometry.x
    dofmap = mesh.geometry.dofmap
    nv = {"interval": 2, "triangle": 3, "tetrahedron": 4, "quadrilateral": 4,
          "hexahedron": 8}[mesh.topology.cell_name()]
    idx = np.array([dofmap.links(c)[:nv] for c in cells], dtype=np.int64).reshape(len(cells), nv)
    pts = x[idx]                                           # (n, nv, 3)
    diff = pts[:, :, None, :] - pts[:, None, :, :]
    return np.sqrt((diff ** 2).sum(-1)).max(axis=(1, 2))
