"""Rigid wheels as exact analytic surfaces (for contact) and as gmsh surface meshes (for pictures).

Wheel frame: origin at the wheel centre, x rolling direction, y along the axle, z up. Both wheels
are solids of revolution about the y axis, so the signed distance of a point is the 2D signed
distance of its meridian-plane coordinates (rho = sqrt(x^2 + z^2), y) to the wheel profile.
"""
from __future__ import annotations

import dataclasses
import math

import gmsh
import numpy as np
from mpi4py import MPI

from rollsim.geometry.mesh import TaggedMesh, add_physical_groups, distribute, gmsh_model, size_options_off
from rollsim.mpi import root_block


def _meridian(points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(N,3) points -> radial distance rho from the axle, y, and the radial unit vector e_rho.

    On the axle (rho = 0) e_rho is taken as -z (towards the soil)."""
    p = np.asarray(points, dtype=float).reshape(-1, 3)
    rho = np.hypot(p[:, 0], p[:, 2])
    e_rho = np.zeros_like(p)
    on_axle = rho == 0.0
    e_rho[~on_axle, 0] = p[~on_axle, 0] / rho[~on_axle]
    e_rho[~on_axle, 2] = p[~on_axle, 2] / rho[~on_axle]
    e_rho[on_axle, 2] = -1.0
    return rho, p[:, 1], e_rho


def _to_3d(n_rho: np.ndarray, n_y: np.ndarray, e_rho: np.ndarray) -> np.ndarray:
    normal = n_rho[:, None] * e_rho
    normal[:, 1] = n_y
    return normal


@dataclasses.dataclass(frozen=True)
class CylinderWheel:
    """Rigid cylindrical wheel (roller), m: outer diameter, width along the axle, edge fillet radius."""

    diameter: float
    width: float
    fillet: float = 0.0

    def __post_init__(self):
        if not self.diameter > 0:
            raise ValueError(f"diameter must be > 0, got {self.diameter}")
        if not self.width > 0:
            raise ValueError(f"width must be > 0, got {self.width}")
        if not 0 <= self.fillet <= min(self.diameter, self.width) / 2:
            raise ValueError(f"fillet must be in [0, min(diameter, width)/2], got {self.fillet}")

    def _meridian_distance(self, points: np.ndarray):
        """In the meridian plane (rho, |y|), the rounded rectangle |rho| <= R, |y| <= b/2 with
        corners rounded by the fillet: rho, y, e_rho, the offsets (q_rho, q_y) from the fillets'
        centres, the length beyond them and the meridian normal (n_rho, n_y >= 0)."""
        rho, y, e_rho = _meridian(points)
        f = self.fillet
        q_rho = rho - (self.diameter / 2 - f)
        q_y = np.abs(y) - (self.width / 2 - f)
        out_rho, out_y = np.maximum(q_rho, 0.0), np.maximum(q_y, 0.0)
        out_len = np.hypot(out_rho, out_y)
        outside = out_len > 0
        safe = np.where(outside, out_len, 1.0)
        n_rho = np.where(outside, out_rho / safe, (q_rho >= q_y).astype(float))
        n_y = np.where(outside, out_y / safe, (q_rho < q_y).astype(float))
        return rho, y, e_rho, q_rho, q_y, out_len, n_rho, n_y

    def signed_distance(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distance (m, negative inside) of (N,3) wheel-frame points to the surface, and the
        outward unit normal (N,3) of the nearest surface point (the distance gradient)."""
        rho, y, e_rho, q_rho, q_y, out_len, n_rho, n_y = self._meridian_distance(points)
        dist = out_len + np.minimum(np.maximum(q_rho, q_y), 0.0) - self.fillet
        return dist, _to_3d(n_rho, n_y * np.sign(y + (y == 0)), e_rho)

    def distance_hessian(self, points: np.ndarray) -> np.ndarray:
        """(N,3,3) second derivative of :meth:`signed_distance` (1/m): the derivative of the
        normal with respect to the point (the wheel surface's curvature, extended off it)."""
        rho, y, e_rho, q_rho, q_y, out_len, n_rho, n_y = self._meridian_distance(points)
        e_y = np.broadcast_to([0.0, 1.0, 0.0], e_rho.shape)
        e_theta = np.stack([e_rho[:, 2], np.zeros_like(rho), -e_rho[:, 0]], axis=1)
        # around the axle: the radial normal turns with the point (curvature n_rho / rho)
        H = (n_rho / np.where(rho > 0, rho, np.inf))[:, None, None] * np.einsum("ni,nj->nij", e_theta, e_theta)
        # in the meridian plane: beyond a fillet's centre in both directions, its circle
        corner = (q_rho > 0) & (q_y > 0)
        n_m = n_rho[:, None] * e_rho + (n_y * np.sign(y + (y == 0)))[:, None] * e_y
        m = np.einsum("ni,nj->nij", e_rho, e_rho) + np.einsum("ni,nj->nij", e_y, e_y)
        fillet = m - np.einsum("ni,nj->nij", n_m, n_m)
        return H + np.where(corner, 1.0 / np.where(corner, out_len, 1.0), 0.0)[:, None, None] * fillet

    def surface_area(self) -> float:
        """Closed-form area of the wheel surface, m^2 (Pappus: profile length x centroid path)."""
        r, f, b = self.diameter / 2, self.fillet, self.width
        faces = 2 * math.pi * (r - f) ** 2
        tread = 2 * math.pi * r * (b - 2 * f)
        fillets = 2 * (math.pi * f / 2) * 2 * math.pi * (r - f + 2 * f / math.pi)
        return faces + tread + fillets

    def _add_to(self, occ) -> list[tuple[int, int]]:
        r, b = self.diameter / 2, self.width
        volume = occ.addCylinder(0, -b / 2, 0, 0, b, 0, r)
        if self.fillet > 0:
            occ.synchronize()
            rims = [abs(c) for _, c in occ.getEntities(1)]
            return occ.fillet([volume], rims, [self.fillet])
        return [(3, volume)]


@dataclasses.dataclass(frozen=True)
class TorusWheel:
    """Rigid torus wheel, m: outer diameter and width; the tube diameter equals the width."""

    diameter: float
    width: float

    def __post_init__(self):
        if not self.diameter > 0:
            raise ValueError(f"diameter must be > 0, got {self.diameter}")
        if not 0 < self.width <= self.diameter / 2:
            raise ValueError(f"width must be in (0, diameter/2] (ring torus), got {self.width}")

    @property
    def major_radius(self) -> float:
        """Distance from the axle to the centre of the tube, m."""
        return (self.diameter - self.width) / 2

    def signed_distance(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Signed distance (m, negative inside) and outward unit normal (N,3), see CylinderWheel."""
        rho, y, e_rho = _meridian(points)
        d_rho = rho - self.major_radius
        length = np.hypot(d_rho, y)
        safe = np.where(length > 0, length, 1.0)
        n_rho = np.where(length > 0, d_rho / safe, 1.0)  # tube centre line: take the outward radial
        return length - self.width / 2, _to_3d(n_rho, np.where(length > 0, y / safe, 0.0), e_rho)

    def surface_area(self) -> float:
        """4 pi^2 R r, m^2."""
        return 4 * math.pi ** 2 * self.major_radius * self.width / 2

    def _add_to(self, occ) -> list[tuple[int, int]]:
        torus = occ.addTorus(0, 0, 0, self.major_radius, self.width / 2)
        occ.rotate([(3, torus)], 0, 0, 0, 1, 0, 0, math.pi / 2)  # axis z -> y
        return [(3, torus)]


def build_wheel_surface(comm: MPI.Comm, wheel: CylinderWheel | TorusWheel, size: float,
                        msh_path=None) -> TaggedMesh:
    """Triangulated wheel surface (3D manifold mesh, one cell tag ``surface`` = 1), for pictures and
    checks; ``size`` is the element size, m."""
    names = None
    with gmsh_model(comm, "wheel_surface") as model:
        with root_block(comm) as on_root:  # a failure here is raised on every rank
            if on_root:
                volumes = wheel._add_to(model.occ)
                model.occ.synchronize()
                surfaces = [s for _, s in model.getBoundary(volumes, oriented=False)]
                names = add_physical_groups(model, 2, {"surface": surfaces}, {"surface": 1})
                size_options_off()
                model.mesh.setSize(model.getEntities(0), size)
                gmsh.option.setNumber("Mesh.MeshSizeMax", size)
                gmsh.option.setNumber("Mesh.MeshSizeFromCurvature", 12)
                model.mesh.generate(2)
                model.mesh.setOrder(2)
        return distribute(model, comm, 3, 2, names, {}, msh_path)
