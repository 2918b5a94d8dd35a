"""Two bodies in one mesh, for two-body contact: a cylinder on a block (plane strain), a sphere on
a block and a block on a block (3D, quarter models).

The block ``[-half_width, half_width] x [-depth, 0]`` and, a ``gap`` above it, the lower half of
a cylinder of ``radius`` cut at its centre height, where it is loaded; ``symmetric``: only the
half ``x >= 0`` (a quarter of the cylinder).  The two bodies share no node.  Cell tags ``block``
(1) and ``cylinder`` (2); facet tags ``symmetry_x``, ``bottom``, ``side``, ``top`` (the block's
surface), ``rim`` (the cylinder's curved surface) and ``load`` (its cut).  Fine elements within
``zone`` of the point of first contact, growing to coarse over ``opts.transition``.

In 3D (:class:`SphereOnBlock`, :func:`build_block_on_block`) the quarter ``x, y >= 0`` is meshed
with tetrahedra; its cut planes are tagged ``symmetry_x`` and ``symmetry_y``; a block on a block
names the upper block's lower face ``underside``.
"""
from __future__ import annotations

from dataclasses import dataclass

import gmsh
from mpi4py import MPI

from .mesh import (MeshOptions, TaggedMesh, add_physical_groups, box_size_field, distribute, gmsh_model,
                   set_order)

__all__ = ["CylinderOnBlock", "SphereOnBlock", "build_cylinder_on_block", "build_sphere_on_block",
           "build_block_on_block", "PAIR_CELL_TAGS", "PAIR_FACET_TAGS"]

#: the lower body is the ``block``, the upper one (cylinder, sphere or block) tag 2
PAIR_CELL_TAGS = {"block": 1, "cylinder": 2}
PAIR_FACET_TAGS = {"symmetry_x": 1, "bottom": 2, "side": 3, "top": 4, "rim": 5, "load": 6, "symmetry_y": 7,
                   "underside": 8}


@dataclass(frozen=True)
class CylinderOnBlock:
    """Dimensions, m."""

    radius: float = 0.5
    half_width: float = 1.0
    depth: float = 1.0
    gap: float = 1e-4
    zone: float = 0.1
    symmetric: bool = True

    def __post_init__(self):
        for name in ("radius", "half_width", "depth", "gap", "zone"):
            if not getattr(self, name) > 0:
                raise ValueError(f"{name} must be > 0 (m), got {getattr(self, name)}")
        if self.zone >= min(self.radius, self.half_width, self.depth):
            raise ValueError(f"zone must be smaller than the radius, half_width and depth, got {self.zone}")


def build_cylinder_on_block(comm: MPI.Comm, pair: CylinderOnBlock, opts: MeshOptions) -> TaggedMesh:
    """Mesh the cylinder and the block (triangles of ``opts.order``) on rank 0 and distribute."""
    cell_names = facet_names = None
    with gmsh_model(comm, "cylinder_on_block") as model:
        if comm.rank == 0:
            occ = model.occ
            R, W, D, gap = pair.radius, pair.half_width, pair.depth, pair.gap
            left = 0.0 if pair.symmetric else -1.0
            block = occ.addRectangle(left * W, -D, 0.0, (1 - left) * W, D)
            disk = occ.addDisk(0.0, gap + R, 0.0, R, R)
            box = occ.addRectangle(left * R, gap, 0.0, (1 - left) * R, R)
            (cylinder,), _ = occ.intersect([(2, disk)], [(2, box)])
            occ.synchronize()
            facets = {name: [] for name in PAIR_FACET_TAGS}
            for body, name in ((block, "block"), (cylinder[1], "cylinder")):
                for _, curve in model.getBoundary([(2, body)], oriented=False):
                    x0, y0, _, x1, y1, _ = model.getBoundingBox(1, curve)
                    if x1 - x0 < 1e-6 and abs(x0) < 1e-6:
                        facets["symmetry_x"].append(curve)
                    elif name == "block":
                        side = x0 > W / 2 or x1 < -W / 2
                        facets["bottom" if y1 < -D / 2 else "side" if side else "top"].append(curve)
                    else:
                        facets["load" if y1 - y0 < 1e-6 else "rim"].append(curve)
            cell_names = add_physical_groups(model, 2, {"block": [block], "cylinder": [cylinder[1]]},
                                             PAIR_CELL_TAGS)
            facet_names = add_physical_groups(model, 1, facets, PAIR_FACET_TAGS)
            zone = pair.zone
            box_size_field(model, [0.0 if pair.symmetric else -zone, zone, -zone, gap + zone, -1.0, 1.0], opts)
            model.mesh.generate(2)
            set_order(opts.order)
        return distribute(model, comm, 2, 2, cell_names, facet_names)


@dataclass(frozen=True)
class SphereOnBlock(CylinderOnBlock):
    """The lower half of a sphere of ``radius`` a ``gap`` above the block
    ``[0, half_width]^2 x [-depth, 0]``, a quarter (x, y >= 0); dimensions, m."""

    def __post_init__(self):
        super().__post_init__()
        if not self.symmetric:
            raise ValueError("symmetric: the sphere on a block is meshed as a quarter only")


def _tag_faces(model, bodies: dict[str, int], classify) -> dict[str, list[int]]:
    """Facet groups of the 3D ``bodies`` (name -> volume): the cut planes x = 0 and y = 0 are
    symmetry planes, every other face is named by ``classify(body name, bounding box)``."""
    facets = {name: [] for name in PAIR_FACET_TAGS}
    for name, body in bodies.items():
        for _, face in model.getBoundary([(3, body)], oriented=False):
            box = model.getBoundingBox(2, face)
            lo, hi = box[:3], box[3:]
            if hi[0] - lo[0] < 1e-6 and abs(lo[0]) < 1e-6:
                facets["symmetry_x"].append(face)
            elif hi[1] - lo[1] < 1e-6 and abs(lo[1]) < 1e-6:
                facets["symmetry_y"].append(face)
            else:
                facets[classify(name, lo, hi)].append(face)
    return facets


def build_sphere_on_block(comm: MPI.Comm, pair: SphereOnBlock, opts: MeshOptions) -> TaggedMesh:
    """Mesh a quarter of the sphere and of the block (tetrahedra of ``opts.order``) on rank 0 and
    distribute; fine within ``pair.zone`` of the point of first contact."""
    cell_names = facet_names = None
    with gmsh_model(comm, "sphere_on_block") as model:
        if comm.rank == 0:
            occ = model.occ
            R, W, D, gap = pair.radius, pair.half_width, pair.depth, pair.gap
            block = occ.addBox(0.0, 0.0, -D, W, W, D)
            ball = occ.addSphere(0.0, 0.0, gap + R, R)
            (sphere,), _ = occ.intersect([(3, ball)], [(3, occ.addBox(0.0, 0.0, gap, R, R, R))])
            occ.synchronize()

            def classify(name, lo, hi):
                if name == "block":
                    return "bottom" if hi[2] < -D / 2 else "top" if lo[2] > -1e-6 else "side"
                return "load" if hi[2] - lo[2] < 1e-6 else "rim"

            facets = _tag_faces(model, {"block": block, "cylinder": sphere[1]}, classify)
            cell_names = add_physical_groups(model, 3, {"block": [block], "cylinder": [sphere[1]]}, PAIR_CELL_TAGS)
            facet_names = add_physical_groups(model, 2, facets, PAIR_FACET_TAGS)
            zone = pair.zone
            box_size_field(model, [0.0, zone, 0.0, zone, -zone, gap + zone], opts)
            model.mesh.generate(3)
            set_order(opts.order)
        return distribute(model, comm, 3, 3, cell_names, facet_names)


def build_block_on_block(comm: MPI.Comm, half_width: float, depth: float, height: float, gap: float,
                         sizes: tuple[float, float], order: int = 2, hexahedra: bool = False) -> TaggedMesh:
    """A block ``[0, half_width]^2 x [gap, gap + height]`` over the block
    ``[0, half_width]^2 x [-depth, 0]`` (m; a quarter), tetrahedra (or structured ``hexahedra``)
    of ``sizes`` (lower, upper; m: unlike sizes give the two faces that meet unlike facets) and
    ``order``; facets ``top`` (the lower block's upper face), ``underside``, ``load`` (the upper
    block's top), ``bottom``, ``side``."""
    for name, value in (("half_width", half_width), ("depth", depth), ("height", height), ("gap", gap),
                        ("sizes[0]", sizes[0]), ("sizes[1]", sizes[1])):
        if not value > 0:
            raise ValueError(f"{name} must be > 0 (m), got {value}")
    cell_names = facet_names = None
    with gmsh_model(comm, "block_on_block") as model:
        if comm.rank == 0:
            occ = model.occ
            lower = occ.addBox(0.0, 0.0, -depth, half_width, half_width, depth)
            upper = occ.addBox(0.0, 0.0, gap, half_width, half_width, height)
            occ.synchronize()

            def classify(name, lo, hi):
                if hi[2] - lo[2] > 1e-6:
                    return "side"
                if name == "block":
                    return "top" if lo[2] > -1e-6 else "bottom"
                return "underside" if lo[2] < gap + 1e-6 else "load"

            facets = _tag_faces(model, {"block": lower, "cylinder": upper}, classify)
            cell_names = add_physical_groups(model, 3, {"block": [lower], "cylinder": [upper]}, PAIR_CELL_TAGS)
            facet_names = add_physical_groups(model, 2, facets, PAIR_FACET_TAGS)
            gmsh.option.setNumber("Mesh.MeshSizeFromPoints", 1)
            for body, size in ((lower, sizes[0]), (upper, sizes[1])):
                model.mesh.setSize(model.getBoundary([(3, body)], recursive=True), size)
                if hexahedra:
                    faces = model.getBoundary([(3, body)], oriented=False)
                    for _, curve in model.getBoundary(faces, combined=False, oriented=False):
                        length = model.occ.getMass(1, abs(curve))
                        model.mesh.setTransfiniteCurve(abs(curve), max(1, round(length / size)) + 1)
                    for _, face in faces:
                        model.mesh.setTransfiniteSurface(face)
                        model.mesh.setRecombine(2, face)
                    model.mesh.setTransfiniteVolume(body)
            model.mesh.generate(3)
            set_order(order)
        return distribute(model, comm, 3, 3, cell_names, facet_names)
