"""Plane-strain rigid smooth strip footing (Prandtl problem) - the verification case of the solver.

Half model (symmetry at x = 0) of a block ``[0, width] x [-depth, 0]``; the footing occupies
``0 <= x <= B/2`` on the surface y = 0.  Rigid and smooth: the vertical displacement of the
footing facets is imposed, the horizontal one is free.  Rollers on x = 0 and x = width, fixed base.
The footing pressure is the reaction on the footing dofs divided by B/2 (compression positive).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from dolfinx import fem, mesh as dmesh
from mpi4py import MPI
from petsc4py import PETSc

from rollsim.log import get_logger

from .options import DEFAULT_VOLUMETRIC_STRAIN
from .problem import PlasticityProblem
from .stepping import StepControl, solve_load_path

log = get_logger("solver")

__all__ = ["prandtl_nc", "strip_footing_mesh", "layer_cell_tags", "FootingResult", "StripFooting"]


def prandtl_nc(phi: float) -> float:
    """Prandtl-Reissner bearing capacity factor N_c (phi in radians; N_c(0) = 2 + pi)."""
    if phi == 0:
        return 2.0 + math.pi
    nq = math.tan(math.pi / 4 + phi / 2) ** 2 * math.exp(math.pi * math.tan(phi))
    return (nq - 1.0) / math.tan(phi)


def strip_footing_mesh(comm: MPI.Comm, B: float = 1.0, n: int = 8, width: float | None = None,
                       depth: float | None = None, grading: float = 1.5,
                       diagonal: str = "crossed", interfaces=(), cell: str = "triangle"):
    """Structured mesh of the half block, graded towards the footing edge (B/2, 0): triangles
    (``diagonal`` as in ``create_rectangle``) or, with ``cell="quadrilateral"``, rectangles.

    ``n`` cells across the footing half-width; ``width``/``depth`` default to 2.5 B (block 5B x 2.5B).
    Grading: node spacing shrinks like a power ``grading`` towards x = B/2 and y = 0; the footing
    edge is always a mesh node.  ``interfaces``: depths (m below y = 0) put on mesh lines (layer
    boundaries, see :func:`layer_cell_tags`): the nearest row of nodes is moved there and the rows
    between are stretched linearly in depth.
    """
    width = 2.5 * B if width is None else width
    depth = 2.5 * B if depth is None else depth
    if n < 1:
        raise ValueError(f"n must be >= 1, got {n}")
    a = B / 2
    n1 = n                                   # cells on [0, B/2]
    # equal first-cell sizes at the footing edge in all three directions
    n2 = max(1, math.ceil(n * ((width - a) / a) ** (1.0 / grading)))
    ny = max(1, math.ceil(n * (depth / a) ** (1.0 / grading)))
    nx = n1 + n2
    diag = {"crossed": dmesh.DiagonalType.crossed, "right": dmesh.DiagonalType.right,
            "left": dmesh.DiagonalType.left, "right/left": dmesh.DiagonalType.right_left}[diagonal]
    cells = {"triangle": dmesh.CellType.triangle, "quadrilateral": dmesh.CellType.quadrilateral}
    if cell not in cells:
        raise ValueError(f"cell must be one of {sorted(cells)}, got {cell!r}")
    msh = dmesh.create_rectangle(comm, [np.array([0.0, 0.0]), np.array([float(nx), float(ny)])],
                                 [nx, ny], cells[cell], diagonal=diag)
    x = msh.geometry.x
    xi, eta = x[:, 0].copy(), x[:, 1].copy()       # xi in [0, nx], eta in [0, ny]
    left = xi <= n1
    xn = np.empty_like(xi)
    xn[left] = a * (1.0 - (1.0 - xi[left] / n1) ** grading)
    xn[~left] = a + (width - a) * ((xi[~left] - n1) / n2) ** grading
    yn = -depth * ((ny - eta) / ny) ** grading
    if len(interfaces):
        rows = depth * (np.arange(ny + 1) / ny) ** grading            # row depths, increasing
        hs = sorted(float(h) for h in interfaces)
        if not all(0 < h < depth for h in hs):
            raise ValueError(f"interfaces must lie in (0, {depth:g}), got {interfaces!r}")
        ks = [int(np.argmin(np.abs(rows[1:-1] - h))) + 1 for h in hs] if ny > 1 else []
        if len(set(ks)) != len(hs):
            raise ValueError(f"interfaces {hs} are too close for this mesh (n = {n}): refine it")
        yn = -np.interp(-yn, [0.0, *rows[ks], depth], [0.0, *hs, depth])
    x[:, 0], x[:, 1] = xn, yn
    return msh


def layer_cell_tags(msh, interfaces, surface: float = 0.0):
    """Cell tags of horizontal layers: tag ``k`` (1, 2, ...) = layer ``k`` counted from the top
    (the convention of ``WheelIndentation``), with the interfaces at the depths ``interfaces`` (m,
    positive, increasing) below ``surface`` (vertical coordinate = the last one).  A cell belongs to
    the layer holding its midpoint; put the interfaces on mesh lines (``strip_footing_mesh(...,
    interfaces=...)``) for exact layer boundaries."""
    depths = [float(h) for h in interfaces]
    if any(h <= 0 for h in depths) or any(b <= a for a, b in zip(depths, depths[1:])):
        raise ValueError(f"interfaces must be positive, increasing depths, got {interfaces!r}")
    tdim, vert = msh.topology.dim, msh.geometry.dim - 1
    imap = msh.topology.index_map(tdim)
    cells = np.arange(imap.size_local + imap.num_ghosts, dtype=np.int32)
    depth = surface - dmesh.compute_midpoints(msh, tdim, cells)[:, vert]
    values = (1 + np.searchsorted(np.asarray(depths), depth, side="right")).astype(np.int32)
    return dmesh.meshtags(msh, tdim, cells, values)


@dataclass
class FootingResult:
    displacement: list[float]            # footing settlement (m, positive down)
    pressure: list[float]                # mean footing pressure (Pa, compression positive)
    iterations: list[int]
    cuts: list[int]
    limit_pressure: float                # pressure at the final settlement
    n_dofs: int
    n_cells: int
    newton_time: float                   # total SNES wall time
    newton_iterations: int
    elastic_solve_time: float
    history: list = field(default_factory=list, repr=False)

    @property
    def time_per_iteration(self) -> float:
        return self.newton_time / max(self.newton_iterations, 1)


class StripFooting:
    """Displacement-controlled smooth rigid strip footing on an elastoplastic half block.

    ``material``: one material, or ``{cell tag: material}`` for layers with either ``cell_tags``
    or ``interfaces`` (depths in m below the surface y = 0, increasing; tag k = layer k from the top,
    see :func:`layer_cell_tags`), e.g. ``StripFooting(msh, {1: weak, 2: strong}, interfaces=[0.25])``.

    With ``unit_weight`` > 0 a geostatic initial stress with coefficient ``K0`` is set (default
    ``nu/(1-nu)``); a K0 that violates the yield condition is moved inside the yield surface with a
    warning (:meth:`PlasticityProblem.set_geostatic_stress`); the value used is ``self.K0``.
    ``volumetric_strain``, ``volumetric_projection``: as for :class:`PlasticityProblem`.
    """

    def __init__(self, msh, material, B: float = 1.0, *, degree: int = 2, unit_weight: float = 0.0,
                 K0: float | None = None, petsc_options: dict | None = None, interfaces=None, cell_tags=None,
                 kinematics: str = "small-strain", volumetric_strain: str = DEFAULT_VOLUMETRIC_STRAIN,
                 volumetric_projection: int | None = None):
        self.mesh, self.B = msh, B
        comm = msh.comm
        fdim = msh.topology.dim - 1
        xmax = comm.allreduce(msh.geometry.x[:, 0].max(), op=MPI.MAX)
        ymin = comm.allreduce(msh.geometry.x[:, 1].min(), op=MPI.MIN)
        tol = 1e-9 * B
        gamma = unit_weight
        if isinstance(material, dict):
            if (cell_tags is None) == (interfaces is None):
                raise ValueError("material {tag: material} needs exactly one of cell_tags or interfaces")
            if cell_tags is None:
                cell_tags = layer_cell_tags(msh, interfaces)
        elif interfaces is not None or cell_tags is not None:
            raise ValueError("interfaces/cell_tags need material as {cell tag: material}")
        self.cell_tags = cell_tags
        import ufl
        body = ufl.as_vector([0.0, -gamma]) if gamma else None
        self.problem = pb = PlasticityProblem(msh, material, degree=degree, body_force=body,
                                              petsc_options=petsc_options, cell_tags=cell_tags,
                                              kinematics=kinematics, volumetric_strain=volumetric_strain,
                                              volumetric_projection=volumetric_projection)
        V = pb.V
        self.footing_facets = dmesh.locate_entities_boundary(
            msh, fdim, lambda x: (np.abs(x[1]) < tol) & (x[0] <= B / 2 + tol))
        f_sym = dmesh.locate_entities_boundary(msh, fdim, lambda x: np.abs(x[0]) < tol)
        f_right = dmesh.locate_entities_boundary(msh, fdim, lambda x: np.abs(x[0] - xmax) < tol)
        f_base = dmesh.locate_entities_boundary(msh, fdim, lambda x: np.abs(x[1] - ymin) < tol)
        V0, V1 = V.sub(0), V.sub(1)
        self.settlement = fem.Constant(msh, PETSc.ScalarType(0.0))
        zero = PETSc.ScalarType(0.0)
        dofs_foot = fem.locate_dofs_topological(V1, fdim, self.footing_facets)
        bcs = [fem.dirichletbc(zero, fem.locate_dofs_topological(V0, fdim, f_sym), V0),
               fem.dirichletbc(zero, fem.locate_dofs_topological(V0, fdim, f_right), V0),
               fem.dirichletbc(zero, fem.locate_dofs_topological(V0, fdim, f_base), V0),
               fem.dirichletbc(zero, fem.locate_dofs_topological(V1, fdim, f_base), V1),
               fem.dirichletbc(self.settlement, dofs_foot, V1)]
        pb.bcs = bcs
        # test function = 1 (vertical) on the footing dofs -> resultant reaction
        self.w = fem.Function(V)
        self.w.x.array[dofs_foot] = 1.0
        self.w.x.scatter_forward()
        self.K0 = None
        if gamma:
            # K0 = nu/(1-nu) (default) can lie outside a frictional yield surface (nu = 0.3 vs the
            # plane-strain-matched cone of phi = 30 deg): moved inside it, with a warning
            self.K0 = pb.set_geostatic_stress(gamma, surface=0.0, K0=K0)
        n_cells = msh.topology.index_map(msh.topology.dim).size_local
        self.n_cells = comm.allreduce(n_cells)
        self.n_dofs = pb.n_dofs

    def pressure(self) -> float:
        """Mean footing pressure (compression positive) of the current stress state."""
        return -self.problem.internal_force(self.w) / (self.B / 2)

    def run(self, settlement: float, control: StepControl | None = None,
            time_elastic: bool = False) -> FootingResult:
        """Push the footing down by ``settlement`` (m) with adaptive steps; pressure at the end."""
        # the extrapolated predictor: far fewer steps on the c = 0 footing
        # (see docs/verification.md, "Purely frictional soil")
        control = control or StepControl(dt=0.05, dt_max=0.2, dt_min=1e-5, predictor="extrapolate")
        disp, pres = [0.0], [self.pressure()]
        t_el = self.problem.elastic_solve_time() if time_elastic else float("nan")

        def set_load(t):
            self.settlement.value = -settlement * t

        def on_step(t):
            p = self.pressure()
            disp.append(settlement * t)
            pres.append(p)
            return {"pressure": p}

        hist = solve_load_path(self.problem, set_load, control, on_step)
        pb = self.problem
        return FootingResult(displacement=disp, pressure=pres, iterations=[h.iterations for h in hist],
                             cuts=[h.cuts for h in hist], limit_pressure=pres[-1], n_dofs=self.n_dofs,
                             n_cells=self.n_cells, newton_time=pb.timings["snes"],
                             newton_iterations=pb.timings["iterations"], elastic_solve_time=t_el,
                             history=hist)
