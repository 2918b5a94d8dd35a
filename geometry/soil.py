"""Soil blocks: 3D (full / half / quarter) for indentation and rolling, 2D plane strain for verification.

Coordinates: x rolling direction, y across (wheel axle), z up, top surface z = 0 (3D);
x horizontal, y up, top surface y = 0 (2D). All lengths in metres; the ``*_block`` helpers take
multiples of the wheel diameter ``d``.
"""
from __future__ import annotations

import dataclasses
import itertools

import gmsh
import numpy as np
from mpi4py import MPI

from rollsim.geometry.mesh import (ANISOTROPIC_REFINEMENTS, MeshOptions, TaggedMesh, add_physical_groups,
                                   box_size_field, distribute, gmsh_model, log, set_order)
from rollsim.mpi import root_block

CUTS = ("full", "half", "quarter")

#: Facet tags. top + contact is the whole top surface; contact is the top face of the refined zone.
FACET_TAGS = {"top": 1, "contact": 2, "symmetry_y": 3, "symmetry_x": 4, "side": 5, "rear": 6,
              "front": 7, "bottom": 8}
#: Cell tags: soil layer k (1 = top) is tag k; the stiff start zone is STIFF_ZONE_TAG.
STIFF_ZONE_TAG = 50

#: Default wheel start position for rolling, x / d (reference: 0.4 d, on the stiff zone of 0.75 d).
ROLLING_START = 0.4
#: Default half width of a rolling block's refined strip each side of the path, in d.
PATH_HALF_WIDTH = 0.3


@dataclasses.dataclass(frozen=True)
class RefinedZone:
    """Box of fine elements under the wheel or along its path, m; its top face is the contact zone.

    x_min, x_max: extent along the rolling direction (3D) or ignored (2D uses half_width only)
    half_width: half extent across (y in 3D, x in 2D) from the wheel mid-plane
    depth: extent below the top surface
    """

    x_min: float
    x_max: float
    half_width: float
    depth: float

    def __post_init__(self):
        _check_box(self.x_min, self.x_max, self.half_width, self.depth)


def _check_box(x_min: float, x_max: float, half_width: float, depth: float) -> None:
    if not x_max > x_min:
        raise ValueError(f"x_max ({x_max}) must be > x_min ({x_min})")
    if not half_width > 0:
        raise ValueError(f"half_width must be > 0, got {half_width}")
    if not depth > 0:
        raise ValueError(f"depth must be > 0, got {depth}")


def _check_layers(layers: tuple[float, ...], depth: float) -> None:
    if any(not t > 0 for t in layers):
        raise ValueError(f"layers: thicknesses must be > 0, got {layers}")
    if sum(layers) >= depth:
        raise ValueError(f"layers: thicknesses {layers} must add up to less than depth {depth} "
                         "(the last layer fills the rest)")


@dataclasses.dataclass(frozen=True)
class SoilBlock:
    """3D soil block, m. The full block spans [x_min, x_max] x [-half_width, half_width] x [-depth, 0].

    cut: "full"; "half" keeps y >= 0 (wheel mid-plane); "quarter" also keeps x >= 0 (indentation)
    layers: thicknesses of the upper layers, top first; the last layer fills the rest of the depth
    x_stiff: if given, the soil at x < x_stiff is the stiff start zone (whole depth)
    """

    x_min: float
    x_max: float
    half_width: float
    depth: float
    refined: RefinedZone
    cut: str = "full"
    layers: tuple[float, ...] = ()
    x_stiff: float | None = None

    def __post_init__(self):
        _check_box(self.x_min, self.x_max, self.half_width, self.depth)
        if self.cut not in CUTS:
            raise ValueError(f"cut must be one of {CUTS}, got {self.cut!r}")
        if self.cut == "quarter" and not self.x_min < 0 < self.x_max:
            raise ValueError(f"cut='quarter' needs x_min < 0 < x_max, got [{self.x_min}, {self.x_max}]")
        object.__setattr__(self, "layers", tuple(float(t) for t in self.layers))
        _check_layers(self.layers, self.depth)
        x_lo, x_hi = self.x_range
        if self.x_stiff is not None and not x_lo < self.x_stiff < x_hi:
            raise ValueError(f"x_stiff ({self.x_stiff}) must lie inside the block ({x_lo}, {x_hi})")
        if self.refined.half_width > self.half_width or self.refined.depth > self.depth:
            raise ValueError("refined: zone must fit inside the block (half_width, depth)")
        if self.refined.x_max <= x_lo or self.refined.x_min >= x_hi:
            raise ValueError(f"refined: x range [{self.refined.x_min}, {self.refined.x_max}] misses the block")

    @property
    def x_range(self) -> tuple[float, float]:
        return (max(self.x_min, 0.0) if self.cut == "quarter" else self.x_min), self.x_max

    @property
    def y_range(self) -> tuple[float, float]:
        return (-self.half_width if self.cut == "full" else 0.0), self.half_width

    @property
    def layer_bottoms(self) -> list[float]:
        """z of the bottom of each layer, m (top layer first)."""
        return [-t for t in np.cumsum(self.layers)] + [-self.depth]


@dataclasses.dataclass(frozen=True)
class PlaneStrainBlock:
    """2D plane-strain soil block, m: [-half_width, half_width] x [-depth, 0] (x >= 0 if symmetric).

    contact_half_width: the contact zone is the top segment ``|x| <= contact_half_width``
    refined_half_width, refined_depth: box of fine elements under the footing / cylinder
    layers: thicknesses of the upper layers, top first; the last layer fills the rest
    symmetric: keep x >= 0 only, with a symmetry line at x = 0
    """

    half_width: float
    depth: float
    contact_half_width: float
    refined_half_width: float
    refined_depth: float
    layers: tuple[float, ...] = ()
    symmetric: bool = False

    def __post_init__(self):
        for name in ("half_width", "depth", "contact_half_width", "refined_half_width", "refined_depth"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0, got {getattr(self, name)}")
        if self.contact_half_width > self.half_width:
            raise ValueError(f"contact_half_width ({self.contact_half_width}) must be <= half_width")
        if self.refined_half_width > self.half_width or self.refined_depth > self.depth:
            raise ValueError("refined_half_width / refined_depth must fit inside the block")
        object.__setattr__(self, "layers", tuple(float(t) for t in self.layers))
        _check_layers(self.layers, self.depth)

    @property
    def layer_bottoms(self) -> list[float]:
        return [-t for t in np.cumsum(self.layers)] + [-self.depth]


def rolling_block(d: float, length: float = 3.5, half_width: float = 1.5, depth: float = 1.5,
                  cut: str = "half", layers: tuple[float, ...] = (), stiff_length: float = 0.75,
                  path_half_width: float = PATH_HALF_WIDTH, refined_depth: float = 0.4) -> SoilBlock:
    """Rolling block in multiples of the wheel diameter ``d`` (m): x in [0, length d].

    The refined strip runs along the whole wheel path (``|y| <= path_half_width d``, down to
    refined_depth d); stiff_length = 0 gives no stiff start zone. The wheel starts at ROLLING_START d.
    """
    return SoilBlock(0.0, length * d, half_width * d, depth * d,
                     RefinedZone(0.0, length * d, path_half_width * d, refined_depth * d), cut,
                     tuple(t * d for t in layers), stiff_length * d if stiff_length else None)


def indentation_block(d: float, half_size: float = 1.5, depth: float = 1.5, cut: str = "quarter",
                      layers: tuple[float, ...] = (), refined_half_size: float = 0.25,
                      refined_depth: float = 0.5) -> SoilBlock:
    """Indentation block in multiples of ``d`` (m), centred under the wheel (x = y = 0).

    The refined zone is the box ``|x|, |y| <= refined_half_size d``, ``z >= -refined_depth d`` (a 0.5 d cube).
    """
    r = refined_half_size * d
    return SoilBlock(-half_size * d, half_size * d, half_size * d, depth * d,
                     RefinedZone(-r, r, r, refined_depth * d), cut, tuple(t * d for t in layers))


def _breakpoints(lo: float, hi: float, physical, grading, min_gap: float) -> np.ndarray:
    """Sorted cut positions in [lo, hi]: physical ones (merged when nearly equal) and grading ones
    (only where they leave ``min_gap`` to the others)."""
    tol = 1e-9 * (hi - lo)
    points = [lo, hi]
    for p in physical:
        if lo + tol < p < hi - tol and all(abs(p - q) > tol for q in points):
            points.append(p)
    for p in grading:
        if lo < p < hi and all(abs(p - q) > min_gap for q in points):
            points.append(p)
    return np.array(sorted(points))


def _size_along(s: np.ndarray, zone: tuple[float, float], opts: MeshOptions, fine: float) -> np.ndarray:
    """Target element size at positions ``s`` on an axis whose refined interval is ``zone`` and
    whose size there is ``fine``."""
    dist = np.maximum(np.maximum(zone[0] - s, s - zone[1]), 0.0)
    return np.minimum(opts.coarse_size, fine + (opts.coarse_size - fine) * dist / opts.transition)


def _entities_of(model: gmsh.model, dim: int, bodies: list[int] | None) -> list[list[int]]:
    """Tags of the ``bodies`` (dimension ``dim``; all of the model if None) and of their boundary
    entities, by dimension: ``[[curves], [surfaces](, [volumes])]`` from dimension 1 up."""
    if bodies is None:
        return [[tag for _, tag in model.getEntities(k)] for k in range(1, dim + 1)]
    out = [list(bodies)]
    for k in range(dim - 1, 0, -1):
        below = model.getBoundary([(k + 1, tag) for tag in out[0]], combined=False, oriented=False)
        out.insert(0, sorted({abs(tag) for _, tag in below}))
    return out


def _set_transfinite(model: gmsh.model, axes: list[np.ndarray], zones: list[tuple[float, float]],
                     opts: MeshOptions, bodies: list[int] | None = None) -> None:
    """Structured mesh of the box grid (its ``bodies``, default all): graded node counts per axis
    interval, quads/hexes; in 3D the refined zone is ``opts.path_refinement``,
    ``opts.cross_refinement`` and ``opts.depth_refinement`` times finer along x, y and z."""
    dim = len(axes)
    factors = (opts.path_refinement, opts.cross_refinement, opts.depth_refinement) if dim == 3 else (1.0, 1.0)
    fine = [opts.fine_size / k for k in factors]
    entities = _entities_of(model, dim, bodies)
    for curve in entities[0]:
        box = np.array(model.getBoundingBox(1, curve)).reshape(2, 3)
        axis = int(np.argmax(box[1] - box[0]))
        a, b = box[0, axis], box[1, axis]
        s = np.linspace(a, b, 201)
        h = _size_along(s, zones[axis], opts, fine[axis])
        n = max(1, int(round(np.trapz(1.0 / h, s))))
        ratio = (h[-1] / h[0]) ** (1.0 / max(n - 1, 1))
        start = model.getValue(1, curve, [model.getParametrizationBounds(1, curve)[0][0]])[axis]
        if abs(start - b) < abs(start - a):  # the curve runs from b to a
            ratio = 1.0 / ratio
        model.mesh.setTransfiniteCurve(curve, n + 1, "Progression", ratio)
    for surface in entities[1]:
        model.mesh.setTransfiniteSurface(surface)
        model.mesh.setRecombine(2, surface)
    if dim == 3:
        for volume in entities[2]:
            model.mesh.setTransfiniteVolume(volume)


def _build_grid(model: gmsh.model, axes: list[np.ndarray]) -> None:
    """Conforming grid of boxes (3D) or rectangles (2D) between the cut positions of ``axes``."""
    occ = model.occ
    pieces = []
    for cell in itertools.product(*[range(len(a) - 1) for a in axes]):
        lo = [a[i] for a, i in zip(axes, cell)]
        size = [a[i + 1] - a[i] for a, i in zip(axes, cell)]
        if len(axes) == 3:
            pieces.append((3, occ.addBox(*lo, *size)))
        else:
            pieces.append((2, occ.addRectangle(*lo, 0.0, *size)))
    if len(pieces) > 1:
        occ.fragment(pieces[:1], pieces[1:])
    occ.synchronize()


def _classify_facets(model: gmsh.model, dim: int, planes: dict[tuple[int, float], str],
                     contact_box: list[tuple[float, float]], bodies: list[int] | None = None) -> dict[str, list[int]]:
    """Boundary facets of the ``bodies`` (default all) by plane: ``planes[(axis, value)] -> name``;
    top facets inside ``contact_box`` (per horizontal axis) are the contact zone."""
    groups: dict[str, list[int]] = {name: [] for name in FACET_TAGS}
    bodies = [tag for _, tag in model.getEntities(dim)] if bodies is None else bodies
    boundary = model.getBoundary([(dim, tag) for tag in bodies], combined=True, oriented=False)
    for _, facet in boundary:
        box = np.array(model.getBoundingBox(dim - 1, facet)).reshape(2, 3)[:, :dim]
        axis = int(np.argmin(box[1] - box[0]))
        centre = box.mean(axis=0)
        name = min(((abs(v - centre[axis]), n) for (a, v), n in planes.items() if a == axis))[1]
        if name == "top":
            if all(lo <= c <= hi for c, (lo, hi) in zip(centre[:dim - 1], contact_box)):
                name = "contact"
        groups[name].append(abs(facet))
    return groups


def _layer_of(z: float, bottoms: list[float]) -> int:
    return next(k for k, bottom in enumerate(bottoms, start=1) if z > bottom)


def _soil_block_grid(model: gmsh.model, block: SoilBlock, opts: MeshOptions):
    """The block's grid of boxes (its volumes, the cut positions per axis and the refined zone)."""
    ref = block.refined
    (x_lo, x_hi), (y_lo, y_hi) = block.x_range, block.y_range
    t = opts.transition if opts.hexahedra else None
    gap = opts.fine_size
    axes = [
        _breakpoints(x_lo, x_hi, [ref.x_min, ref.x_max] + ([] if block.x_stiff is None else [block.x_stiff]),
                     [ref.x_min - t, ref.x_max + t] if t else [], gap),
        _breakpoints(y_lo, y_hi, [-ref.half_width, ref.half_width],
                     [-ref.half_width - t, ref.half_width + t] if t else [], gap),
        _breakpoints(-block.depth, 0.0, block.layer_bottoms[:-1] + [-ref.depth], [-ref.depth - t] if t else [], gap),
    ]
    before = {tag for _, tag in model.getEntities(3)}
    _build_grid(model, axes)
    volumes = sorted({tag for _, tag in model.getEntities(3)} - before)
    zones = [(ref.x_min, ref.x_max), (-ref.half_width, ref.half_width), (-ref.depth, 0.0)]
    return volumes, axes, zones


def _soil_block_groups(model: gmsh.model, block: SoilBlock, opts: MeshOptions, grid) -> tuple[dict, dict, dict]:
    """Mesh sizes of the block's grid (``_soil_block_grid``) and its cell and facet groups:
    (cells, facets, cell tag numbers)."""
    volumes, axes, zones = grid
    ref, bottoms = block.refined, block.layer_bottoms
    if opts.hexahedra:
        _set_transfinite(model, axes, zones, opts, volumes)
    else:
        box_size_field(model, [ref.x_min, ref.x_max, -ref.half_width, ref.half_width, -ref.depth, opts.transition],
                       opts)
    cells: dict[str, list[int]] = {f"layer_{k}": [] for k in range(1, len(bottoms) + 1)}
    cells["stiff_zone"] = []
    for volume in volumes:
        x, _, z = model.occ.getCenterOfMass(3, volume)
        stiff = block.x_stiff is not None and x < block.x_stiff
        cells["stiff_zone" if stiff else f"layer_{_layer_of(z, bottoms)}"].append(volume)
    (x_lo, x_hi), (y_lo, y_hi) = block.x_range, block.y_range
    planes = {(0, x_lo): "symmetry_x" if block.cut == "quarter" else "rear", (0, x_hi): "front",
              (1, y_lo): "side" if block.cut == "full" else "symmetry_y", (1, y_hi): "side",
              (2, 0.0): "top", (2, -block.depth): "bottom"}
    facets = _classify_facets(model, 3, planes, [zones[0], zones[1]], volumes)
    numbers = {**{f"layer_{k}": k for k in range(1, len(bottoms) + 1)}, "stiff_zone": STIFF_ZONE_TAG}
    return cells, facets, numbers


def build_soil_block(comm: MPI.Comm, block: SoilBlock, opts: MeshOptions, msh_path=None) -> TaggedMesh:
    """Mesh a 3D soil block on rank 0 of ``comm`` and distribute it.

    Cell tags: ``layer_k`` (k = 1 top) and ``stiff_zone``; facet tags: see FACET_TAGS (only those
    present: e.g. symmetry_x for quarter blocks, rear/front/side otherwise).
    """
    cell_names = facet_names = None
    with gmsh_model(comm, "soil_block") as model:
        with root_block(comm) as on_root:  # a failure here is raised on every rank
            if on_root:
                cells, facets, numbers = _soil_block_groups(model, block, opts, _soil_block_grid(model, block, opts))
                cell_names = add_physical_groups(model, 3, cells, numbers)
                facet_names = add_physical_groups(model, 2, facets, FACET_TAGS)
                model.mesh.generate(3)
                set_order(opts.order)
                log.info("soil block (%s, %d layer(s)%s): %s", block.cut, len(block.layer_bottoms),
                         ", stiff zone" if block.x_stiff is not None else "",
                         "hexahedra" if opts.hexahedra else "tetrahedra")
        return distribute(model, comm, 3, 3, cell_names, facet_names, msh_path)


def build_plane_strain_block(comm: MPI.Comm, block: PlaneStrainBlock, opts: MeshOptions,
                             msh_path=None) -> TaggedMesh:
    """Mesh a 2D plane-strain block (triangles, or quadrilaterals with ``opts.hexahedra``).

    Cell tags ``layer_k``; facet tags top, contact (``|x| <= contact_half_width``), symmetry_x, side, bottom.
    """
    if any(getattr(opts, name) != 1 for name in ANISOTROPIC_REFINEMENTS):
        raise ValueError(f"{' / '.join(ANISOTROPIC_REFINEMENTS)} apply to 3D blocks "
                         "(a plane-strain block is meshed isotropically)")
    cell_names = facet_names = None
    with gmsh_model(comm, "plane_strain_block") as model:
        with root_block(comm) as on_root:  # a failure here is raised on every rank
            if on_root:
                x_lo = 0.0 if block.symmetric else -block.half_width
                a, w, dr = block.contact_half_width, block.refined_half_width, block.refined_depth
                t = opts.transition if opts.hexahedra else None
                bottoms = block.layer_bottoms
                axes = [_breakpoints(x_lo, block.half_width, [-a, a, -w, w], [-w - t, w + t] if t else [],
                                     opts.fine_size),
                        _breakpoints(-block.depth, 0.0, bottoms[:-1] + [-dr], [-dr - t] if t else [], opts.fine_size)]
                _build_grid(model, axes)
                zones = [(-w, w), (-dr, 0.0)]
                if opts.hexahedra:
                    _set_transfinite(model, axes, zones, opts)
                else:
                    box_size_field(model, [-w, w, -dr, opts.transition, -1.0, 1.0], opts)
                cells = {f"layer_{k}": [] for k in range(1, len(bottoms) + 1)}
                for _, surface in model.getEntities(2):
                    cells[f"layer_{_layer_of(model.occ.getCenterOfMass(2, surface)[1], bottoms)}"].append(surface)
                planes = {(0, x_lo): "symmetry_x" if block.symmetric else "side", (0, block.half_width): "side",
                          (1, 0.0): "top", (1, -block.depth): "bottom"}
                facets = _classify_facets(model, 2, planes, [(-a, a)])
                cell_names = add_physical_groups(model, 2, cells, {name: k for k, name in enumerate(cells, start=1)})
                facet_names = add_physical_groups(model, 1, facets, FACET_TAGS)
                model.mesh.generate(2)
                set_order(opts.order)
        return distribute(model, comm, 2, 2, cell_names, facet_names, msh_path)
