"""Off-screen pictures of finite-element results, drawn with pyvista in a process of their own.

This module imports neither DOLFINx nor PETSc: VTK's renderer aborts in a process that has
them loaded, so the solver saves the data (``.npz``) and calls ``render_npz`` in a child.
"""
from __future__ import annotations

import numpy as np


def render_npz(npz_path, png_path, title: str = "") -> None:
    """Draw a cell field saved by ``FieldWriter.render_plastic_zone`` off-screen with pyvista."""
    import pyvista
    data = np.load(npz_path)
    pts, conn, values = data["points"], data["connectivity"], data["values"]
    cells = np.column_stack([np.full(len(conn), conn.shape[1]), conn]).ravel()
    grid = pyvista.UnstructuredGrid(cells, np.full(len(conn), int(data["cell_type"]), dtype=np.uint8), pts)
    grid.cell_data["equivalent plastic strain"] = values
    plotter = pyvista.Plotter(off_screen=True, window_size=(1100, 800))
    plotter.set_background("white")
    plotter.add_mesh(grid, scalars="equivalent plastic strain", cmap="YlOrRd", show_edges=True,
                     edge_color="#b0b0b0", line_width=0.5,
                     clim=(0.0, max(float(values.max(initial=0.0)), 1e-12)),
                     scalar_bar_args={"color": "black", "title": "equivalent plastic strain"})
    if np.ptp(pts[:, 2]) > 0:
        # look at the symmetry planes (x = 0, y = 0): the section under the wheel centre
        lo, hi = pts.min(axis=0), pts.max(axis=0)
        span = float(np.max(hi - lo))
        plotter.camera_position = [(lo[0] - 1.2 * span, lo[1] - 1.6 * span, hi[2] + 0.9 * span),
                                   tuple(0.5 * (lo + hi)), (0.0, 0.0, 1.0)]
    else:
        plotter.view_xy()
    if title:
        plotter.add_title(title, font_size=10, color="black")
    plotter.screenshot(str(png_path))
    plotter.close()
