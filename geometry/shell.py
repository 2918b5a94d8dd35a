"""Thick spherical shell: the closed-form check of an inflated carcass (pressure on its inner surface).

One octant (x, y, z >= 0) of the shell between ``inner_radius`` and ``outer_radius``, meshed with
tetrahedra of about ``size``; the three cut planes are symmetry planes.
"""
from __future__ import annotations

import math

import numpy as np
from mpi4py import MPI

from rollsim.geometry.mesh import MeshOptions, TaggedMesh, add_physical_groups, distribute, gmsh_model, set_order
from rollsim.mpi import root_block

SHELL_CELL_TAGS = {"shell": 1}
SHELL_FACET_TAGS = {"symmetry_x": 1, "symmetry_y": 2, "symmetry_z": 3, "inner_surface": 11, "outer_surface": 12}


def build_spherical_shell(comm: MPI.Comm, inner_radius: float, outer_radius: float, opts: MeshOptions,
                          msh_path=None) -> TaggedMesh:
    """Octant of a thick spherical shell (m), tetrahedra of ``opts.fine_size`` and ``opts.order``;
    facet tags inner_surface, outer_surface and symmetry_x / _y / _z (the planes x, y, z = 0)."""
    if not 0 < inner_radius < outer_radius:
        raise ValueError(f"need 0 < inner_radius < outer_radius, got {inner_radius}, {outer_radius}")
    cell_names = facet_names = None
    with gmsh_model(comm, "shell") as model:
        with root_block(comm) as on_root:
            if on_root:
                occ = model.occ
                shell, _ = occ.cut([(3, occ.addSphere(0, 0, 0, outer_radius))],
                                   [(3, occ.addSphere(0, 0, 0, inner_radius))])
                box = occ.addBox(0, 0, 0, outer_radius, outer_radius, outer_radius)
                octant, _ = occ.intersect(shell, [(3, box)])
                occ.synchronize()
                facets = {name: [] for name in SHELL_FACET_TAGS}
                tol = 1e-6 * outer_radius
                for _, surface in model.getBoundary(octant, oriented=False):
                    box = np.array(model.getBoundingBox(2, surface)).reshape(2, 3)
                    flat = [axis for axis in range(3) if box[1, axis] - box[0, axis] < tol]
                    if flat:
                        facets["symmetry_" + "xyz"[flat[0]]].append(surface)
                    else:                          # a point of the spherical patch gives its radius
                        lo, hi = model.getParametrizationBounds(2, surface)
                        r = float(np.linalg.norm(model.getValue(2, surface, [(lo[0] + hi[0]) / 2,
                                                                            (lo[1] + hi[1]) / 2])))
                        name = "inner_surface" if abs(r - inner_radius) < abs(r - outer_radius) else "outer_surface"
                        facets[name].append(surface)
                cell_names = add_physical_groups(model, 3, {"shell": [tag for _, tag in octant]}, SHELL_CELL_TAGS)
                facet_names = add_physical_groups(model, 2, facets, SHELL_FACET_TAGS)
                model.mesh.setSize(model.getEntities(0), opts.fine_size)
                model.mesh.generate(3)
                set_order(opts.order)
        return distribute(model, comm, 3, 3, cell_names, facet_names, msh_path)


def shell_volume(inner_radius: float, outer_radius: float) -> float:
    """Volume of the octant, m^3."""
    return math.pi / 6 * (outer_radius ** 3 - inner_radius ** 3)
