"""Two bodies in one plane-strain mesh: an elastic cylinder resting on a block (two-body contact).

The block ``[-half_width, half_width] x [-depth, 0]`` and, a ``gap`` above it, the lower half of
a cylinder of ``radius`` cut at its centre height, where it is loaded; ``symmetric``: only the
half ``x >= 0`` (a quarter of the cylinder).  The two bodies share no node.  Cell tags ``block``
(1) and ``cylinder`` (2); facet tags ``symmetry_x``, ``bottom``, ``side``, ``top`` (the block's
surface), ``rim`` (the cylinder's curved surface) and ``load`` (its cut).  Fine elements within
``zone`` of the point of first contact, growing to coarse over ``opts.transition``.
"""
from __future__ import annotations

from dataclasses import dataclass

from mpi4py import MPI

from .mesh import (MeshOptions, TaggedMesh, add_physical_groups, box_size_field, distribute, gmsh_model,
                   set_order)

__all__ = ["CylinderOnBlock", "build_cylinder_on_block", "PAIR_CELL_TAGS", "PAIR_FACET_TAGS"]

PAIR_CELL_TAGS = {"block": 1, "cylinder": 2}
PAIR_FACET_TAGS = {"symmetry_x": 1, "bottom": 2, "side": 3, "top": 4, "rim": 5, "load": 6}


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
