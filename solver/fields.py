"""Output fields for ParaView / pyvista: displacement (of the mesh's geometry degree: P1, or Q2 on
the curved hexahedra of a tire on soil), equivalent plastic strain and
generalised shear stress q (cell averages, DG0), written as XDMF time series.

``fields.xdmf``: undeformed mesh + ``displacement`` (use *Warp By Vector* in ParaView or
``mesh.warp_by_vector`` in pyvista), ``equivalent_plastic_strain``, ``q`` (Pa), ``p`` (Pa,
compression positive) and ``layer`` (cell tag), one time value per written step (the sinkage, m).
``deformed.xdmf``: the mesh in its deformed configuration (vertices moved by the displacement)
with the same cell fields, written for the last state.  Quadrature values are projected to
cells as equal-weight averages of the cell's quadrature points (exact L2 projection onto DG0 for
the default degree-2 schemes, whose weights are equal).
"""
from __future__ import annotations

import pathlib
import subprocess
import sys

import numpy as np
from dolfinx import fem

from rollsim import compat
from rollsim.log import get_logger

log = get_logger("fields")

__all__ = ["FieldWriter", "cell_averages"]

_SQ23 = np.sqrt(2.0 / 3.0)


# DOLFINx -> VTK vertex order of linear cells, and the VTK cell types
_VTK_ORDER = {"triangle": [0, 1, 2], "tetrahedron": [0, 1, 2, 3], "quadrilateral": [0, 1, 3, 2],
              "hexahedron": [0, 1, 3, 2, 4, 5, 7, 6]}
_VTK_TYPE = {"triangle": 5, "tetrahedron": 10, "quadrilateral": 9, "hexahedron": 12}


def cell_averages(problem, f: fem.Function, width: int) -> np.ndarray:
    """(n_cells, width) averages over each owned cell's quadrature points of a quadrature Function."""
    nq = problem.points.shape[0]
    return f.x.array[: problem.n_qp * width].reshape(problem.n_cells, nq, width).mean(axis=1)


class FieldWriter:
    """Writes the fields of a :class:`~rollsim.solver.problem.PlasticityProblem` under ``directory``
    (the time series in the file ``series``)."""

    def __init__(self, problem, directory, cell_tags=None, series: str = "fields.xdmf"):
        self.problem = pb = problem
        self.dir = pathlib.Path(directory)
        msh = pb.mesh
        self.comm = msh.comm
        if self.comm.rank == 0:
            self.dir.mkdir(parents=True, exist_ok=True)
        self.comm.barrier()
        self.V1 = compat.vector_space(msh, compat.geometry_degree(msh))   # a node per geometry node
        self.W0 = compat.scalar_space(msh, 0, "DG")
        self.u1 = fem.Function(self.V1, name="displacement")
        self.epeq = fem.Function(self.W0, name="equivalent_plastic_strain")
        self.q = fem.Function(self.W0, name="q")
        self.p = fem.Function(self.W0, name="p")
        self.layer = fem.Function(self.W0, name="layer")
        n = pb.n_cells
        self._cell_dofs = compat.cell_dofs(self.W0.dofmap).reshape(-1)[:n]
        if cell_tags is not None:
            own = cell_tags.indices < n
            self.layer.x.array[self._cell_dofs[cell_tags.indices[own]]] = cell_tags.values[own]
            self.layer.x.scatter_forward()
        self._file = compat.xdmf_file(self.comm, self.dir / series, "w")
        self._file.write_mesh(msh)
        self._file.write_function(self.layer, 0.0)

    def _update(self) -> None:
        pb = self.problem
        nc = pb.ncomp
        self.u1.interpolate(pb.u)
        ep = cell_averages(pb, pb.eps_p, nc)
        tr = ep[:, :3].sum(axis=1)
        dev = ep.copy()
        dev[:, :3] -= tr[:, None] / 3.0
        self._set(self.epeq, _SQ23 * np.linalg.norm(dev, axis=1))
        sig = pb.sigma_n.x.array[: pb.n_qp * nc].reshape(pb.n_qp, nc)
        trs = sig[:, :3].sum(axis=1)
        s = sig.copy()
        s[:, :3] -= trs[:, None] / 3.0
        nq = pb.points.shape[0]
        q = np.sqrt(1.5) * np.linalg.norm(s, axis=1)
        self._set(self.q, q.reshape(pb.n_cells, nq).mean(axis=1))
        self._set(self.p, (-trs / 3.0).reshape(pb.n_cells, nq).mean(axis=1))

    def _set(self, f, cell_values) -> None:
        f.x.array[self._cell_dofs] = cell_values
        f.x.scatter_forward()

    def write(self, t: float) -> None:
        """Append the converged state at time value ``t`` (e.g. the sinkage)."""
        self._update()
        for f in (self.u1, self.epeq, self.q, self.p):
            self._file.write_function(f, t)

    def write_deformed(self, name: str = "deformed.xdmf") -> None:
        """The mesh moved by the displacement, with the cell fields (last converged state)."""
        self._update()
        msh = self.problem.mesh
        x = msh.geometry.x
        gdim = msh.geometry.dim
        gdofs = compat.cell_dofs(msh.geometry.dofmap)
        vdofs = compat.cell_dofs(self.V1.dofmap).reshape(gdofs.shape)
        nv = gdofs.shape[1]
        disp = np.zeros((x.shape[0], gdim))
        if nv:
            u = self.u1.x.array.reshape(-1, gdim)
            disp[gdofs.reshape(-1)] = u[vdofs.reshape(-1)]
        saved = x.copy()
        x[:, :gdim] += disp
        try:
            with compat.xdmf_file(self.comm, self.dir / name, "w") as f:
                f.write_mesh(msh)
                for fn in (self.epeq, self.q, self.p, self.layer):
                    f.write_function(fn)
        finally:
            x[:] = saved

    def render_plastic_zone(self, png_path, title: str = "", displacement_scale: float = 1.0) -> bool:
        """Picture of the deformed soil coloured by equivalent plastic strain (collective).

        The owned cells of every rank are gathered to rank 0 and drawn off-screen with
        pyvista; ``displacement_scale`` magnifies the displacement (e.g. to show a rut); returns
        False (and draws nothing) where pyvista is not installed.
        """
        self._update()
        msh = self.problem.mesh
        tdim, gdim = msh.topology.dim, msh.geometry.dim
        n = msh.topology.index_map(tdim).size_local
        gdofs = compat.cell_dofs(msh.geometry.dofmap)[:n]
        nv = gdofs.shape[1] if n else 0
        u = self.u1.x.array.reshape(-1, gdim)
        vdofs = compat.cell_dofs(self.V1.dofmap)[:n].reshape(gdofs.shape)
        points = msh.geometry.x[gdofs.reshape(-1), :gdim] + displacement_scale * (u[vdofs.reshape(-1)] if nv else 0.0)
        local = (points, np.full(n, nv), self.epeq.x.array[self._cell_dofs[:n]])
        gathered = self.comm.gather(local, root=0)
        if self.comm.rank != 0:
            return True
        pts = np.concatenate([g[0] for g in gathered]).reshape(-1, gdim)
        if gdim == 2:
            pts = np.column_stack([pts, np.zeros(len(pts))])
        per_cell = int(max(g[1].max(initial=0) for g in gathered))
        conn = np.arange(len(pts)).reshape(-1, per_cell)[:, _VTK_ORDER[compat.cell_name(msh)]]
        npz = pathlib.Path(png_path).with_suffix(".npz")
        np.savez(npz, points=pts, connectivity=conn, cell_type=_VTK_TYPE[compat.cell_name(msh)],
                 values=np.concatenate([g[2] for g in gathered]))
        # a renderer crash must not take the simulation down: draw in a child process
        # (VTK aborts when DOLFINx/PETSc are loaded in the same process, hence the light module)
        code = "import sys; from rollsim.render import render_npz; render_npz(*sys.argv[1:])"
        done = subprocess.run([sys.executable, "-c", code, str(npz), str(png_path), title],
                              capture_output=True, text=True, timeout=300)
        npz.unlink()
        if done.returncode != 0:
            log.warning("plastic-zone picture failed: %s", (done.stderr.strip().splitlines() or ["?"])[-1])
        return done.returncode == 0

    def close(self) -> None:
        self._file.close()

