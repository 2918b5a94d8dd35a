"""PNG pictures of tagged meshes: the boundary faces of a .msh file coloured by physical group.

Uses pyvista off-screen (VTK with EGL or OSMesa) when it is installed, matplotlib otherwise.
Run on one rank.
"""
from __future__ import annotations

import pathlib

import gmsh
import numpy as np
from mpi4py import MPI

from rollsim.geometry.mesh import gmsh_model, log

PALETTE = ["#4c72b0", "#dd8452", "#55a868", "#c44e52", "#8172b3", "#937860", "#da8bc3", "#8c8c8c",
           "#ccb974", "#64b5cd"]


def _faces_by_group(model: gmsh.model) -> tuple[np.ndarray, list[dict[str, list[np.ndarray]]]]:
    """Node coordinates and panels of ``group name -> face corner index arrays``: the facet groups and
    the outer faces of each cell group of a 3D mesh; the cell groups of a 2D or surface mesh."""
    tags, coords, _ = model.mesh.getNodes()
    position = np.empty(int(tags.max()) + 1, dtype=np.int64)
    position[tags.astype(np.int64)] = np.arange(tags.size)

    def faces(surfaces) -> list[np.ndarray]:
        blocks = []
        for surface in surfaces:
            types, _, nodes = model.mesh.getElements(2, surface)
            for etype, enodes in zip(types, nodes):
                _, _, _, nnodes, _, ncorner = model.mesh.getElementProperties(etype)
                blocks.append(position[enodes.reshape(-1, nnodes)[:, :ncorner].astype(np.int64)])
        return blocks

    def name(dim, group):
        return model.getPhysicalName(dim, group) or str(group)

    panels = [{name(2, g): faces(model.getEntitiesForPhysicalGroup(2, g)) for _, g in model.getPhysicalGroups(2)}]
    if model.getDimension() == 3:
        panels.append({name(3, g): faces(abs(s) for _, s in model.getBoundary(
            [(3, v) for v in model.getEntitiesForPhysicalGroup(3, g)], combined=True, oriented=False))
            for _, g in model.getPhysicalGroups(3)})
    return coords.reshape(-1, 3), panels


def _render_pyvista(points, panels, png_path: pathlib.Path, title: str, flat: bool, view) -> None:
    import pyvista

    plotter = pyvista.Plotter(off_screen=True, window_size=(900 * len(panels), 800), shape=(1, len(panels)),
                              border=False)
    plotter.set_background("white")
    for column, groups in enumerate(panels):
        plotter.subplot(0, column)
        for row, (colour, (name, blocks)) in enumerate(zip(PALETTE * 3, groups.items())):
            cells = np.concatenate([np.hstack([np.full((len(b), 1), b.shape[1]), b]).ravel() for b in blocks])
            plotter.add_mesh(pyvista.PolyData(points, faces=cells), color=colour, show_edges=True,
                             edge_color="#333333", line_width=0.5)
            plotter.add_text(name, position=(12, 700 - 26 * row), font_size=11, color=colour)
        plotter.add_text(title if column == 0 else "cell tags (outer faces)", position="upper_edge",
                         font_size=11, color="black")
        if flat:
            plotter.view_xy()
        else:
            plotter.view_vector(view)
        plotter.camera.zoom(0.85)
        plotter.add_axes(color="black")
    if len(panels) > 1:
        plotter.link_views()
    plotter.screenshot(str(png_path))
    plotter.close()


def _render_matplotlib(points, panels, png_path: pathlib.Path, title: str, flat: bool, view) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection
    from matplotlib.patches import Patch
    from mpl_toolkits.mplot3d.art3d import Poly3DCollection

    fig = plt.figure(figsize=(7 * len(panels), 6))
    lo, hi = points.min(axis=0), points.max(axis=0)
    for column, groups in enumerate(panels, start=1):
        ax = fig.add_subplot(1, len(panels), column, **({} if flat else {"projection": "3d"}))
        handles = []
        for colour, (name, blocks) in zip(PALETTE * 3, groups.items()):
            polys = [points[face][:, :2] if flat else points[face] for b in blocks for face in b]
            kind = PolyCollection if flat else Poly3DCollection
            ax.add_collection(kind(polys, facecolor=colour, edgecolor="#333333", linewidth=0.2))
            handles.append(Patch(facecolor=colour, label=name))
        ax.set_xlim(lo[0], hi[0])
        ax.set_ylim(lo[1], hi[1])
        if flat:
            ax.set_aspect("equal")
        else:
            ax.set_zlim(lo[2], hi[2])
            ax.set_box_aspect(hi - lo)
            ax.view_init(elev=np.degrees(np.arctan2(view[2], np.hypot(view[0], view[1]))),
                         azim=np.degrees(np.arctan2(view[1], view[0])))
        ax.legend(handles=handles, loc="upper right")
        ax.set_title(title if column == 1 else "cell tags (outer faces)")
    fig.savefig(png_path, dpi=110)
    plt.close(fig)


def render_msh(msh_path, png_path, title: str = "", view=(1.0, -1.6, 0.9)) -> str:
    """Draw the surface physical groups of a 3D .msh (cells of a 2D one) to ``png_path``.

    ``view``: direction from the model towards the camera (3D meshes).
    Returns the backend used: "pyvista" or "matplotlib".
    """
    png_path = pathlib.Path(png_path)
    with gmsh_model(MPI.COMM_SELF, "render") as model:
        gmsh.merge(str(msh_path))
        points, panels = _faces_by_group(model)
        flat = bool(np.allclose(points[:, 2], 0.0))
    try:
        import pyvista  # noqa: F401
        backend = "pyvista"
    except ImportError:
        backend = "matplotlib"
    (_render_pyvista if backend == "pyvista" else _render_matplotlib)(points, panels, png_path, title, flat, view)
    log.info("picture: %s (%s)", png_path, backend)
    return backend
