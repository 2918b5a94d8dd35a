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


def create_partitioned_mesh(comm: MPI.Comm, cells: np.ndarray, x: np.ndarray, cell_name: str, destination):
    """Mesh of first-order ``cell_name`` cells (vertex indices into ``x``, both given on rank 0,
    empty elsewhere) where ``destination(cell_vertices, parts)`` (an array of the vertices of the
    cells to place, one row per cell) gives each cell's ranks: ``(owner, ghosts)``, an array of
    owners and a list of arrays of the ranks that hold the cell as a ghost (the owners of the cells
    that share a vertex with it).  The partitioner's signature and the element's construction
    changed after 0.5."""
    from dolfinx import cpp, mesh as dmesh
    vertices = cells.shape[1]

    def partitioner(_comm, parts, _tdim, cell_vertices, _ghost_mode):
        owner, ghosts = destination(cell_vertices.array.reshape(-1, vertices), parts)
        lists = [np.concatenate([[o], g]) for o, g in zip(owner, ghosts)]
        offsets = np.cumsum([0] + [len(d) for d in lists]).astype(np.int32)
        data = np.concatenate(lists).astype(np.int32) if lists else np.zeros(0, np.int32)
        return cpp.graph.AdjacencyList_int32(data, offsets)

    domain = ufl.Mesh(ufl.VectorElement("Lagrange", cell_name, 1))
    return dmesh.create_mesh(comm, cells, x, domain, dmesh.GhostMode.shared_facet, partitioner)


def vector_space(mesh, degree: int, family: str = "Lagrange", dim: int | None = None):
    """Vector-valued space of ``family`` (continuous Lagrange by default), with one component per
    geometric dimension or ``dim``."""
    return fem.VectorFunctionSpace(mesh, (family, degree), dim=dim)


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


def quadrature_rule(mesh, degree: int) -> tuple[np.ndarray, np.ndarray]:
    """Reference points and weights of the default scheme used by ``quadrature_space``."""
    import basix
    cell = {"triangle": basix.CellType.triangle, "tetrahedron": basix.CellType.tetrahedron,
            "quadrilateral": basix.CellType.quadrilateral,
            "hexahedron": basix.CellType.hexahedron}[mesh.topology.cell_name()]
    return basix.make_quadrature(cell, degree)


def quadrature_points(mesh, degree: int) -> np.ndarray:
    """Reference quadrature points of the default scheme used by ``quadrature_space``."""
    return quadrature_rule(mesh, degree)[0]


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


def geometry_degree(mesh) -> int:
    """Degree of the mesh's coordinate element (``geometry.cmap.degree`` in 0.5, ``cmaps`` later)."""
    return mesh.geometry.cmap.degree


def cell_name(mesh) -> str:
    """The cell type's name ("tetrahedron", ...; ``topology.cell_name()`` in 0.5, ``cell_type.name`` later)."""
    return mesh.topology.cell_name()


def cell_dofs(dofmap) -> np.ndarray:
    """A dofmap as a 2D array ``(cells, dofs per cell)`` (an adjacency list in 0.5, an array later);
    works for function-space dofmaps and ``mesh.geometry.dofmap``."""
    adjacency = getattr(dofmap, "list", dofmap)
    if adjacency.num_nodes == 0:
        return np.zeros((0, 0), dtype=np.int32)
    return adjacency.array.reshape(adjacency.num_nodes, -1)


def entity_links(mesh, dim: int, other_dim: int, entity: int) -> np.ndarray:
    """The entities of dimension ``other_dim`` connected to one entity of dimension ``dim``, in
    the topology's local order (an adjacency list's ``links`` in 0.5)."""
    mesh.topology.create_connectivity(dim, other_dim)
    return mesh.topology.connectivity(dim, other_dim).links(entity)


def incident_entities(mesh, entities: np.ndarray, dim: int, other_dim: int) -> np.ndarray:
    """Entities of dimension ``other_dim`` incident to ``entities`` of dimension ``dim`` (takes
    the mesh in 0.5, the topology later)."""
    from dolfinx.mesh import compute_incident_entities
    return compute_incident_entities(mesh, entities, dim, other_dim)


def petsc_vector(u: fem.Function):
    """The PETSc vector of a Function (``u.vector`` in 0.5, ``u.x.petsc_vec`` later)."""
    return u.vector


def create_vector(form):
    """A PETSc vector for assembling the linear ``form`` (takes the function space from 0.10)."""
    from dolfinx.fem import petsc
    return petsc.create_vector(form)


def apply_lifting(b, forms, bcs, x0, scale: float) -> None:
    """``b -= scale A (g - x0)`` for the Dirichlet rows (``scale`` is named ``alpha`` later)."""
    from dolfinx.fem import petsc
    petsc.apply_lifting(b, forms, [bcs], x0=[x0], scale=scale)


def set_bc(b, bcs, x0=None, scale: float = 1.0) -> None:
    """Set the Dirichlet rows of ``b`` to ``scale (g - x0)`` (``scale`` is named ``alpha`` later)."""
    from dolfinx.fem import petsc
    if x0 is None:
        petsc.set_bc(b, bcs)
    else:
        petsc.set_bc(b, bcs, x0, scale)


def _cell_vertices(mesh, cells: np.ndarray) -> np.ndarray:
    """Vertex coordinates of the local ``cells``, shape (cells, vertices per cell, 3)."""
    nv = {"interval": 2, "triangle": 3, "tetrahedron": 4, "quadrilateral": 4,
          "hexahedron": 8}[cell_name(mesh)]
    idx = cell_dofs(mesh.geometry.dofmap)[np.asarray(cells, dtype=np.int64), :nv].reshape(len(cells), nv)
    return mesh.geometry.x[idx]


def cell_diameters(mesh, cells: np.ndarray) -> np.ndarray:
    """Largest vertex-to-vertex distance of each of the local ``cells``."""
    pts = _cell_vertices(mesh, cells)
    diff = pts[:, :, None, :] - pts[:, None, :, :]
    return np.sqrt((diff ** 2).sum(-1)).max(axis=(1, 2))


def cell_extents(mesh, cells: np.ndarray, axis: int) -> np.ndarray:
    """Extent of each of the local ``cells`` along coordinate ``axis`` (largest minus smallest
    vertex coordinate)."""
    pts = _cell_vertices(mesh, cells)[:, :, axis]
    return pts.max(axis=1) - pts.min(axis=1)
