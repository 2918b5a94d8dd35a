"""Pneumatic tire: rigid hub plus a thin solid carcass (tread, shoulder transition, sidewall).

The carcass profile in the meridian plane (y across, r from the axle), for y >= 0::

  tread       r in [R - t, R],                y in [0, b/2 - rho]
  transition  quarter ring around C = (b/2 - rho, R - rho), radii [rho - 0.6 t, rho]
  sidewall    y in [b/2 - 0.2 t, b/2],         r in [d_h/2, R - rho]

with R = d/2, t = tread thickness (reference 0.046 d), rho = shoulder radius. The outer surface is
smooth; the inner (air) surface has small steps where the thickness changes. The hub is rigid and
not meshed: the carcass is clamped to it on the ``hub_rim`` (bead) faces at r = d_h/2.
The profile is revolved about the axle in quarter turns and meshed with structured hexahedra.
"""
from __future__ import annotations

import dataclasses
import math

import numpy as np
from mpi4py import MPI

from rollsim.geometry.mesh import (MeshOptions, TaggedMesh, add_physical_groups, distribute, gmsh_model,
                                   log, set_order)
from rollsim.geometry.soil import FACET_TAGS, SoilBlock, _entities_of, _soil_block_grid, _soil_block_groups
from rollsim.mpi import root_block

TREAD_THICKNESS = 0.046  # x d
TRANSITION_THICKNESS = 0.6  # x tread thickness
SIDEWALL_THICKNESS = 0.2  # x tread thickness

TIRE_CELL_TAGS = {"tread": 21, "transition": 22, "sidewall": 23}
TIRE_FACET_TAGS = {"symmetry_y": 3, "symmetry_x": 4, "inner_surface": 11, "outer_surface": 12, "hub_rim": 13}
TIRE_CUTS = {"full": 4, "half": 4, "quarter": 2}  # quarter turns revolved


@dataclasses.dataclass(frozen=True)
class PneumaticTire:
    """Tire geometry and placement, m.

    diameter: outer diameter d; width: outer width b; hub_diameter: rim (bead) diameter d_h
    shoulder_radius: outer radius rho of the shoulder fillet; tread_thickness: t (default 0.046 d)
    cut: "full", "half" (y >= 0) or "quarter" (y >= 0, x >= x_centre), matching the soil cuts
    gap: clearance between the lowest tire point and the soil surface z = 0
    x_centre: x of the axle
    """

    diameter: float
    width: float
    hub_diameter: float
    shoulder_radius: float
    tread_thickness: float | None = None
    cut: str = "half"
    gap: float = 0.0
    x_centre: float = 0.0

    def __post_init__(self):
        if not self.diameter > 0:
            raise ValueError(f"diameter must be > 0, got {self.diameter}")
        if self.tread_thickness is None:
            object.__setattr__(self, "tread_thickness", TREAD_THICKNESS * self.diameter)
        t, rho = self.tread_thickness, self.shoulder_radius
        if not 0 < t < rho:
            raise ValueError(f"tread_thickness ({t}) must be in (0, shoulder_radius = {rho})")
        if not rho < self.width / 2:
            raise ValueError(f"shoulder_radius ({rho}) must be < width/2 ({self.width / 2})")
        if not 0 < self.hub_diameter / 2 < self.diameter / 2 - rho:
            raise ValueError(f"hub_diameter ({self.hub_diameter}) must be in (0, diameter - 2 shoulder_radius)")
        if self.cut not in TIRE_CUTS:
            raise ValueError(f"cut must be one of {sorted(TIRE_CUTS)}, got {self.cut!r}")
        if not self.gap >= 0:
            raise ValueError(f"gap must be >= 0, got {self.gap}")

    @property
    def centre(self) -> tuple[float, float, float]:
        """Wheel centre (on the axle), m."""
        return self.x_centre, 0.0, self.diameter / 2 + self.gap

    @property
    def thicknesses(self) -> tuple[float, float, float]:
        """Tread, transition and sidewall thickness, m."""
        t = self.tread_thickness
        return t, TRANSITION_THICKNESS * t, SIDEWALL_THICKNESS * t

    def section_volumes(self) -> dict[str, float]:
        """Closed-form volumes of the kept part of each carcass section, m^3 (Pappus for the ring)."""
        R, b, rho = self.diameter / 2, self.width, self.shoulder_radius
        t, t_tr, t_s = self.thicknesses
        tread = math.pi * (R ** 2 - (R - t) ** 2) * (b - 2 * rho)
        inner = rho - t_tr
        area = math.pi / 4 * (rho ** 2 - inner ** 2)
        centroid = 4 / (3 * math.pi) * (rho ** 3 - inner ** 3) / (rho ** 2 - inner ** 2)
        transition = 2 * 2 * math.pi * (R - rho + centroid) * area
        sidewall = 2 * math.pi * ((R - rho) ** 2 - (self.hub_diameter / 2) ** 2) * t_s
        fraction = {"full": 1.0, "half": 0.5, "quarter": 0.25}[self.cut]
        return {"tread": tread * fraction, "transition": transition * fraction, "sidewall": sidewall * fraction}

    def cut_areas(self) -> dict[str, float]:
        """Closed-form areas of the kept hub rim and symmetry cuts, m^2."""
        R, rho, r_h = self.diameter / 2, self.shoulder_radius, self.hub_diameter / 2
        t, t_tr, t_s = self.thicknesses
        fraction = {"full": 1.0, "half": 0.5, "quarter": 0.25}[self.cut]
        areas = {"hub_rim": 2 * 2 * math.pi * r_h * t_s * fraction}
        if self.cut != "full":
            areas["symmetry_y"] = math.pi * (R ** 2 - (R - t) ** 2) * 2 * fraction
        if self.cut == "quarter":  # the profile (y >= 0) at the top and at the bottom of the wheel
            profile = (t * (self.width / 2 - rho) + math.pi / 4 * (rho ** 2 - (rho - t_tr) ** 2)
                       + t_s * (R - rho - r_h))
            areas["symmetry_x"] = 2 * profile
        return areas

    def on_outer_surface(self, r: np.ndarray, y: np.ndarray, tol: float) -> np.ndarray:
        """Whether meridian points (r from the axle, y) lie on the smooth outer carcass surface."""
        R, rho, y_s = self.diameter / 2, self.shoulder_radius, self.width / 2 - self.shoulder_radius
        y = np.abs(y)
        on_tread = (y <= y_s + tol) & (np.abs(r - R) < tol)
        on_shoulder = (y >= y_s - tol) & (r >= R - rho - tol) & (np.abs(np.hypot(y - y_s, r - R + rho) - rho) < tol)
        on_side = (r <= R - rho + tol) & (np.abs(y - self.width / 2) < tol)
        return on_tread | on_shoulder | on_side


def pneumatic_tire(d: float, width: float = 0.3, hub_diameter: float = 0.5, shoulder_radius: float = 0.08,
                   gap: float = 0.01, cut: str = "half", x_centre: float = 0.0) -> PneumaticTire:
    """Tire in multiples of its diameter ``d`` (m); tread 0.046 d, transition 0.6 t, sidewall 0.2 t."""
    return PneumaticTire(d, width * d, hub_diameter * d, shoulder_radius * d, None, cut, gap * d, x_centre * d)


def _profile(occ, tire: PneumaticTire) -> list[tuple[str, int]]:
    """Carcass profile faces (section name, surface tag) in the OCC xy plane: x = y_tire, y = r."""
    R, b, rho = tire.diameter / 2, tire.width, tire.shoulder_radius
    t, t_tr, t_s = tire.thicknesses
    y_s, r_s = b / 2 - rho, R - rho
    y0 = 0.0 if tire.cut != "full" else -y_s
    faces = [("tread", occ.addRectangle(y0, lo, 0, y_s - y0, hi - lo))
             for lo, hi in ((R - t_s, R), (R - t_tr, R - t_s), (R - t, R - t_tr))]
    for inner, outer in ((rho - t_s, rho), (rho - t_tr, rho - t_s)):
        arc_out = occ.addCircle(y_s, r_s, 0, outer, -1, 0, math.pi / 2)
        arc_in = occ.addCircle(y_s, r_s, 0, inner, -1, 0, math.pi / 2)
        top = occ.addLine(occ.addPoint(y_s, r_s + inner, 0), occ.addPoint(y_s, r_s + outer, 0))
        side = occ.addLine(occ.addPoint(y_s + inner, r_s, 0), occ.addPoint(y_s + outer, r_s, 0))
        loop = occ.addCurveLoop([side, arc_out, -top, -arc_in])
        faces.append(("transition", occ.addPlaneSurface([loop])))
    faces.append(("sidewall", occ.addRectangle(b / 2 - t_s, tire.hub_diameter / 2, 0, t_s, r_s - tire.hub_diameter / 2)))
    if tire.cut == "full":
        mirrored = occ.copy([(2, tag) for name, tag in faces[3:]])
        occ.mirror(mirrored, 1, 0, 0, 0)
        faces += [(name, tag) for (name, _), (_, tag) in zip(faces[3:], mirrored)]
    return faces


def _transfinite_tire(model, tire: PneumaticTire, opts: MeshOptions, volumes: list[int]) -> None:
    """Structured counts of the tire's ``volumes``: profile edges by length (arcs of the shoulder
    by angle), quarter turns by arc."""
    h = opts.fine_size
    xc, _, zc = tire.centre
    n_arc = max(2, math.ceil(math.pi / 2 * tire.shoulder_radius / h))
    n_turn = max(4, math.ceil(math.pi / 2 * tire.diameter / 2 / h))
    curves, surfaces, volumes = _entities_of(model, 3, volumes)
    for curve in curves:
        ends = [model.getValue(0, abs(p), []) for _, p in model.getBoundary([(1, curve)], oriented=False)]
        (x0, y0, z0), (x1, y1, z1) = ends
        r0, r1 = math.hypot(x0 - xc, z0 - zc), math.hypot(x1 - xc, z1 - zc)
        chord = math.dist(ends[0], ends[1])
        if abs(r0 - r1) < 1e-9 * tire.diameter and abs(y0 - y1) < 1e-9 * tire.diameter:
            n = n_turn  # circumferential arc around the axle
        elif model.occ.getMass(1, curve) > chord * (1 + 1e-6):
            n = n_arc  # shoulder arc
        else:
            n = max(1, math.ceil(round(chord / h, 6)))
        model.mesh.setTransfiniteCurve(curve, n + 1)
    for surface in surfaces:
        model.mesh.setTransfiniteSurface(surface)
        model.mesh.setRecombine(2, surface)
    for volume in volumes:
        model.mesh.setTransfiniteVolume(volume)


def _tire_geometry(model, tire: PneumaticTire):
    """The carcass's volumes, revolved from its profile: (profile faces, volumes per quarter turn)."""
    occ = model.occ
    xc, _, zc = tire.centre
    faces = _profile(occ, tire)
    profile = [(2, tag) for _, tag in faces]
    _, pieces = occ.fragment(profile, [])
    profile = [piece[0] for piece in pieces]
    occ.rotate(profile, 0, 0, 0, 1, 1, 1, 2 * math.pi / 3)  # (x, y, 0) -> (0, x, y)
    occ.translate(profile, xc, 0, zc)
    # quarter turns revolved from the previous turn's end faces, so that neighbours share faces
    turns, source = [], profile
    for _ in range(TIRE_CUTS[tire.cut]):
        out = occ.revolve(source, xc, 0, zc, 0, 1, 0, math.pi / 2)
        body = [i for i, (dim, _) in enumerate(out) if dim == 3]  # each preceded by its end face
        turns.append([out[i] for i in body])
        source = [out[i - 1] for i in body]
    if tire.cut != "quarter":  # close the full turn: glue the last turn to the first
        _, glued = occ.fragment(turns[-1], turns[0])
        turns[-1], turns[0] = [g[0] for g in glued[:len(profile)]], [g[0] for g in glued[len(profile):]]
    occ.synchronize()
    return faces, turns


def _tire_groups(model, tire: PneumaticTire, opts: MeshOptions, geometry) -> tuple[dict, dict]:
    """Structured mesh counts of the carcass (``_tire_geometry``) and its cell and facet groups."""
    faces, turns = geometry
    xc, _, zc = tire.centre
    cells = {name: [] for name in TIRE_CELL_TAGS}
    for turn in turns:
        for (name, _), (_, volume) in zip(faces, turn):
            cells[name].append(volume)
    volumes = [volume for turn in turns for _, volume in turn]
    facets = {name: [] for name in TIRE_FACET_TAGS}
    tol = 1e-6 * tire.diameter
    for _, surface in model.getBoundary([(3, v) for v in volumes], combined=True, oriented=False):
        lo, hi = model.getParametrizationBounds(2, abs(surface))
        x, y, z = model.getValue(2, abs(surface), [(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2])
        box = np.array(model.getBoundingBox(2, abs(surface))).reshape(2, 3)
        r = math.hypot(x - xc, z - zc)
        if box[1, 1] - box[0, 1] < tol and abs(y) < tol and tire.cut != "full":
            name = "symmetry_y"
        elif box[1, 0] - box[0, 0] < tol and abs(x - xc) < tol and tire.cut == "quarter":
            name = "symmetry_x"
        elif abs(r - tire.hub_diameter / 2) < tol:
            name = "hub_rim"
        elif tire.on_outer_surface(np.array([r]), np.array([y]), tol)[0]:
            name = "outer_surface"
        else:
            name = "inner_surface"
        facets[name].append(abs(surface))
    _transfinite_tire(model, tire, opts, volumes)
    return cells, facets


def build_tire(comm: MPI.Comm, tire: PneumaticTire, opts: MeshOptions, msh_path=None) -> TaggedMesh:
    """Mesh the carcass (hexahedra, ``opts.fine_size`` along the profile and around) and distribute it.

    Cell tags tread / transition / sidewall; facet tags inner_surface (inflation pressure),
    outer_surface (contact), hub_rim (bead, clamped to the rigid hub) and the symmetry planes of the cut.
    """
    cell_names = facet_names = None
    with gmsh_model(comm, "tire") as model:
        with root_block(comm) as on_root:  # a failure here is raised on every rank
            if on_root:
                cells, facets = _tire_groups(model, tire, opts, _tire_geometry(model, tire))
                cell_names = add_physical_groups(model, 3, cells, TIRE_CELL_TAGS)
                facet_names = add_physical_groups(model, 2, facets, TIRE_FACET_TAGS)
                model.mesh.generate(3)
                set_order(opts.order)
                log.info("tire (%s): d = %g m, b = %g m, hub %g m", tire.cut, tire.diameter, tire.width,
                         tire.hub_diameter)
        return distribute(model, comm, 3, 3, cell_names, facet_names, msh_path)


def build_tire_on_soil(comm: MPI.Comm, tire: PneumaticTire, block: SoilBlock, soil_opts: MeshOptions,
                       tire_opts: MeshOptions, msh_path=None) -> TaggedMesh:
    """The tire above the soil block in one mesh of hexahedra (two bodies that share no node; one
    mesh holds one cell type, and the thin carcass needs structured hexahedra), distributed.

    The block is meshed by ``soil_opts`` (``hexahedra`` required), the carcass by
    ``tire_opts.fine_size``; both of ``soil_opts.order``.  The tire's cut must be the block's.
    Cell tags: the block's and the carcass's (:data:`TIRE_CELL_TAGS`); facet tags: the block's
    (``FACET_TAGS``) and the carcass's (:data:`TIRE_FACET_TAGS`; the symmetry planes share theirs).
    """
    if not soil_opts.hexahedra:
        raise ValueError("soil_opts.hexahedra must be True: the carcass is meshed with hexahedra and one mesh "
                         "holds one cell type")
    if tire.cut != block.cut:
        raise ValueError(f"the tire's cut ({tire.cut!r}) must be the block's ({block.cut!r})")
    (x_lo, x_hi), _ = block.x_range, block.y_range
    R = tire.diameter / 2
    if not (x_lo <= tire.x_centre - (0 if tire.cut == "quarter" else R) and tire.x_centre + R <= x_hi):
        raise ValueError(f"the tire (x_centre {tire.x_centre} m, diameter {tire.diameter} m) must lie over the "
                         f"block (x from {x_lo} to {x_hi} m)")
    cell_names = facet_names = None
    with gmsh_model(comm, "tire_on_soil") as model:
        with root_block(comm) as on_root:  # a failure here is raised on every rank
            if on_root:
                grid = _soil_block_grid(model, block, soil_opts)
                carcass = _tire_geometry(model, tire)
                cells, facets, numbers = _soil_block_groups(model, block, soil_opts, grid)
                tire_cells, tire_facets = _tire_groups(model, tire, tire_opts, carcass)
                for name, tags in tire_facets.items():
                    facets.setdefault(name, []).extend(tags)
                cell_names = add_physical_groups(model, 3, {**cells, **tire_cells}, {**numbers, **TIRE_CELL_TAGS})
                facet_names = add_physical_groups(model, 2, facets, {**FACET_TAGS, **TIRE_FACET_TAGS})
                model.mesh.generate(3)
                set_order(soil_opts.order)
                log.info("tire (%s, d = %g m) on a soil block (%d layer(s)): hexahedra", tire.cut, tire.diameter,
                         len(block.layer_bottoms))
        return distribute(model, comm, 3, 3, cell_names, facet_names, msh_path)
