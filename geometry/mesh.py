"""Shared machinery: mesh-density knob, gmsh session, mesh quality, hand-over to DOLFINx."""
from __future__ import annotations

import contextlib
import dataclasses
import math
from collections.abc import Iterator

import gmsh
import numpy as np
from mpi4py import MPI

from rollsim import compat
from rollsim.log import get_logger
from rollsim.presets import PRESETS

log = get_logger("geometry")

#: Accuracy presets -> ``refinement`` (elements per wheel diameter ``d`` in the refined zone of a
#: tetrahedral block), as :data:`rollsim.presets.PRESETS` sets them
ACCURACY_REFINEMENT: dict[str, float] = {name: preset.elements_per_d for name, preset in PRESETS.items()}

#: Coarse / fine element-size ratio used by ``MeshOptions.from_refinement`` (0.08 d / 0.02 d).
COARSE_TO_FINE = 4.0
#: the MeshOptions fields that shorten the refined zone's hexahedra along x, y and z
ANISOTROPIC_REFINEMENTS = ("path_refinement", "cross_refinement", "depth_refinement")


class InvertedElementError(ValueError):
    """The mesh has elements with a non-positive Jacobian determinant."""


@dataclasses.dataclass(frozen=True)
class MeshOptions:
    """Element sizes (m), grading and element type of a mesh.

    fine_size: element size in the refined zone under / along the wheel, m
    coarse_size: element size far from the wheel, m
    transition: distance over which the size grows from fine to coarse, m
    order: geometry (and suggested displacement) order, 1 or 2
    hexahedra: structured (transfinite) hexahedra/quadrilaterals instead of tetrahedra/triangles
    path_refinement: hexahedral 3D blocks: the refined zone's elements are this many times shorter
    along x (the rolling direction) than fine_size
    cross_refinement: the same across the path (y)
    depth_refinement: the same down (z)
    """

    fine_size: float
    coarse_size: float
    transition: float
    order: int = 1
    hexahedra: bool = False
    path_refinement: float = 1.0
    cross_refinement: float = 1.0
    depth_refinement: float = 1.0

    def __post_init__(self):
        if not self.fine_size > 0:
            raise ValueError(f"fine_size must be > 0, got {self.fine_size}")
        if not self.coarse_size >= self.fine_size:
            raise ValueError(f"coarse_size ({self.coarse_size}) must be >= fine_size ({self.fine_size})")
        if not self.transition > 0:
            raise ValueError(f"transition must be > 0, got {self.transition}")
        if self.order not in (1, 2):
            raise ValueError(f"order must be 1 or 2, got {self.order}")
        for name in ANISOTROPIC_REFINEMENTS:
            value = getattr(self, name)
            if not value >= 1:
                raise ValueError(f"{name} must be >= 1, got {value}")
            if value != 1 and not self.hexahedra:
                raise ValueError(f"{name} needs hexahedra (tetrahedral sizes are isotropic)")

    @classmethod
    def from_refinement(cls, d: float, refinement: float, order: int = 1,
                        hexahedra: bool = False, **refinements: float) -> "MeshOptions":
        """The one-knob mesh: ``refinement`` elements per wheel diameter ``d`` (m) in the refined zone.

        fine = d / refinement, coarse = 4 fine, transition = 0.5 d; cell counts grow as refinement**3
        (refinement**2 in 2D). ``refinements``: the anisotropic fields (ANISOTROPIC_REFINEMENTS).
        """
        if not refinement > 0:
            raise ValueError(f"refinement must be > 0, got {refinement}")
        if not d > 0:
            raise ValueError(f"d must be > 0, got {d}")
        fine = d / refinement
        return cls(fine, COARSE_TO_FINE * fine, 0.5 * d, order, hexahedra, **refinements)

    @classmethod
    def from_accuracy(cls, d: float, accuracy: str, order: int = 1,
                      hexahedra: bool = False) -> "MeshOptions":
        """Preset ``accuracy`` ("fast", "standard", "accurate"), see ``ACCURACY_REFINEMENT``."""
        if accuracy not in ACCURACY_REFINEMENT:
            raise ValueError(f"accuracy must be one of {sorted(ACCURACY_REFINEMENT)}, got {accuracy!r}")
        return cls.from_refinement(d, ACCURACY_REFINEMENT[accuracy], order, hexahedra)


@dataclasses.dataclass(frozen=True)
class MeshQuality:
    """Shape measures of the gmsh elements, from their corner nodes.

    min_scaled_jacobian: smallest corner scaled Jacobian (1 for a regular tetrahedron / cube, <= 0 inverted)
    max_edge_ratio: largest longest-edge / shortest-edge ratio of an element (aspect ratio)
    """

    min_scaled_jacobian: float
    max_edge_ratio: float


@dataclasses.dataclass(frozen=True)
class MeshStats:
    """Global sizes of the distributed mesh and the gmsh quality summary."""

    cells: int
    vertices: int
    nodes: int  # geometry nodes (vertices plus the edge/face nodes of order-2 cells)
    quality: MeshQuality


@dataclasses.dataclass
class TaggedMesh:
    """A distributed DOLFINx mesh with its tags; ``cell_names`` / ``facet_names`` map names to tag ints."""

    mesh: object
    cell_tags: object
    facet_tags: object
    cell_names: dict[str, int]
    facet_names: dict[str, int]
    stats: MeshStats


_gmsh_sessions = 0  # gmsh_model contexts open on this rank (gmsh is initialised while > 0)


@contextlib.contextmanager
def gmsh_model(comm: MPI.Comm, name: str) -> Iterator[gmsh.model | None]:
    """A fresh gmsh model on rank 0 of ``comm`` (``None`` elsewhere), removed afterwards.

    rollsim owns the gmsh session: the outermost context initialises gmsh and finalises it again.
    The session state is tracked here and never asked of gmsh, because gmsh 4.8 (Debian bookworm)
    has no ``isInitialized`` and any API call made before ``initialize`` may end the process
    with exit status 1 (seen as a silent rank-0 exit under mpirun).
    """
    global _gmsh_sessions
    if comm.rank == 0:
        if _gmsh_sessions == 0:
            gmsh.initialize()
        _gmsh_sessions += 1
        gmsh.option.setNumber("General.Terminal", 0)
        gmsh.option.setNumber("General.AbortOnError", 0)  # initialize() sets 2: errors would exit
        gmsh.model.add(name)
        gmsh.model.setCurrent(name)
    try:
        yield gmsh.model if comm.rank == 0 else None
    finally:
        if comm.rank == 0:
            gmsh.model.setCurrent(name)
            gmsh.model.remove()
            _gmsh_sessions -= 1
            if _gmsh_sessions == 0:
                gmsh.finalize()


def box_size_field(model: gmsh.model, zone_box: list[float], opts: MeshOptions) -> None:
    """Fine inside ``zone_box`` (xmin, xmax, ymin, ymax, zmin, zmax), linear growth to coarse."""
    field = model.mesh.field.add("Box")
    for key, value in zip(("XMin", "XMax", "YMin", "YMax", "ZMin", "ZMax"), zone_box):
        model.mesh.field.setNumber(field, key, value)
    model.mesh.field.setNumber(field, "VIn", opts.fine_size)
    model.mesh.field.setNumber(field, "VOut", opts.coarse_size)
    model.mesh.field.setNumber(field, "Thickness", opts.transition)
    model.mesh.field.setAsBackgroundMesh(field)
    size_options_off()


def size_options_off() -> None:
    """Let only the background field (or transfinite counts) set element sizes."""
    gmsh.option.setNumber("Mesh.MeshSizeExtendFromBoundary", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 0)
    gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 0)


def set_order(order: int) -> None:
    """Complete (Lagrange) elements of ``order``: 10-node tetrahedra, 27-node hexahedra."""
    if order > 1:
        gmsh.option.setNumber("Mesh.SecondOrderIncomplete", 0)
        gmsh.model.mesh.setOrder(order)


_HEX_CORNER_EDGES = np.array([[1, 3, 4], [2, 0, 5], [3, 1, 6], [0, 2, 7],
                              [7, 5, 0], [4, 6, 1], [5, 7, 2], [6, 4, 3]])
_QUAD_CORNER_EDGES = np.array([[1, 3], [2, 0], [3, 1], [0, 2]])
_TRI_CORNER_EDGES = np.array([[1, 2], [2, 0], [0, 1]])
_TET_CORNER_EDGES = np.array([[1, 2, 3], [2, 0, 3], [0, 1, 3], [0, 2, 1]])


def _corner_measures(x: np.ndarray, dim: int) -> tuple[np.ndarray, np.ndarray]:
    """Per-element min corner scaled Jacobian and edge ratio; ``x`` is (cells, corners, 3)."""
    ncorner = x.shape[1]
    table = {(3, 4): _TET_CORNER_EDGES, (3, 8): _HEX_CORNER_EDGES,
             (2, 3): _TRI_CORNER_EDGES, (2, 4): _QUAD_CORNER_EDGES}[(dim, ncorner)]
    edges = x[:, table, :] - x[:, :, None, :]  # (cells, corners, dim, 3)
    lengths = np.linalg.norm(edges, axis=-1)
    if dim == 3:
        det = np.linalg.det(edges)
    else:  # planar 2D meshes (z = 0) or surfaces in 3D: area measure, orientation from z
        cross = np.cross(edges[:, :, 0, :], edges[:, :, 1, :])
        det = cross[..., 2] if np.allclose(x[..., 2], x[0, 0, 2]) else np.linalg.norm(cross, axis=-1)
    sj = det / np.prod(lengths, axis=-1)
    ideal = {(3, 4): 1 / math.sqrt(2), (3, 8): 1.0, (2, 3): math.sqrt(3) / 2, (2, 4): 1.0}[(dim, ncorner)]
    return (sj / ideal).min(axis=1), lengths.max(axis=(1, 2)) / lengths.min(axis=(1, 2))


def mesh_quality(model: gmsh.model, dim: int) -> MeshQuality:
    """Quality of the ``dim``-dimensional elements of a meshed gmsh model.

    Raises ``InvertedElementError`` when an element has a non-positive Jacobian determinant at one
    of its nodes (checked for volume meshes and planar 2D meshes).
    """
    tags, coords, _ = model.mesh.getNodes()
    coords = coords.reshape(-1, 3)
    position = np.empty(int(tags.max()) + 1, dtype=np.int64)
    position[tags] = np.arange(tags.size)
    min_sj, max_ratio, inverted = np.inf, 1.0, 0
    planar = dim == 3 or np.allclose(coords[:, 2], 0.0)
    for etype in model.mesh.getElementTypes(dim):
        _, edim, _, nnodes, local, ncorner = model.mesh.getElementProperties(etype)
        _, nodes = model.mesh.getElementsByType(etype)
        x = coords[position[nodes.reshape(-1, nnodes)[:, :ncorner]]]
        sj, ratio = _corner_measures(x, dim)
        min_sj, max_ratio = min(min_sj, sj.min()), max(max_ratio, ratio.max())
        if planar:
            points = np.zeros((nnodes, 3))
            points[:, :edim] = np.asarray(local).reshape(nnodes, edim)
            _, det, _ = model.mesh.getJacobians(etype, points.reshape(-1))
            det = det.reshape(-1, nnodes)
            inverted += int(np.count_nonzero((det <= 0).any(axis=1) | (sj <= 0)))
    if inverted:
        raise InvertedElementError(f"{inverted} inverted element(s) (non-positive Jacobian determinant) "
                                   f"in the {dim}D mesh; min scaled Jacobian {min_sj:.3g}")
    return MeshQuality(float(min_sj), float(max_ratio))


def distribute(model: gmsh.model | None, comm: MPI.Comm, gdim: int, tdim: int,
               cell_names: dict[str, int] | None, facet_names: dict[str, int] | None,
               msh_path=None) -> TaggedMesh:
    """Check the mesh built on rank 0, hand it to DOLFINx over ``comm`` and count it globally.

    ``cell_names`` / ``facet_names`` are needed on rank 0 only; ``msh_path`` optionally keeps a .msh copy.
    """
    quality = None
    error = None
    if comm.rank == 0:
        try:
            quality = mesh_quality(model, tdim)
        except InvertedElementError as exc:
            error = str(exc)
        if msh_path is not None and error is None:
            gmsh.write(str(msh_path))
    quality, error, cell_names, facet_names = comm.bcast((quality, error, cell_names, facet_names), root=0)
    if error is not None:
        raise InvertedElementError(error)
    mesh, cell_tags, facet_tags = compat.model_to_mesh(model, comm, 0, gdim)
    cells = mesh.topology.index_map(tdim).size_global
    stats = MeshStats(cells=cells, vertices=mesh.topology.index_map(0).size_global,
                      nodes=mesh.geometry.index_map().size_global, quality=quality)
    log.info("mesh: %d cells, %d vertices, %d nodes; min scaled Jacobian %.3f, max edge ratio %.2f",
             stats.cells, stats.vertices, stats.nodes, quality.min_scaled_jacobian, quality.max_edge_ratio)
    return TaggedMesh(mesh, cell_tags, facet_tags, dict(cell_names), dict(facet_names), stats)


def add_physical_groups(model: gmsh.model, dim: int, groups: dict[str, list[int]],
                        numbers: dict[str, int]) -> dict[str, int]:
    """Physical groups ``name -> entity tags`` with fixed ``numbers``; returns the non-empty ones."""
    used = {}
    for name, entities in groups.items():
        if entities:
            model.addPhysicalGroup(dim, sorted(entities), numbers[name])
            model.setPhysicalName(dim, numbers[name], name)
            used[name] = numbers[name]
    return used
