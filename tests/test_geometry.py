"""rollsim.geometry: tagged measures against closed forms (DOLFINx assembly, any number of ranks),
the refinement knob, quality checks, analytic wheels and the command line."""
from __future__ import annotations

import math

import numpy as np
import pytest
import ufl
from dolfinx import fem
from mpi4py import MPI

from rollsim import compat
from rollsim.geometry.cli import main
from rollsim.geometry.mesh import (ANISOTROPIC_REFINEMENTS, InvertedElementError, MeshOptions, distribute, gmsh_model,
                                   mesh_quality)
from rollsim.geometry.soil import (RefinedZone, PlaneStrainBlock, SoilBlock, build_plane_strain_block,
                                   build_soil_block, indentation_block, rolling_block)
from rollsim.geometry.tire import PneumaticTire, build_tire, pneumatic_tire
from rollsim.geometry.wheels import CylinderWheel, TorusWheel, build_wheel_surface

D = 1.2  # wheel diameter, m (not 1, so that a missing factor d shows)


def measure(tagged, name: str, comm) -> float:
    """Global volume (area) of the cells (facets) tagged ``name``, by DOLFINx assembly."""
    mesh = tagged.mesh
    if name in tagged.cell_names:
        form = fem.Constant(mesh, 1.0) * ufl.dx(domain=mesh, subdomain_data=tagged.cell_tags,
                                                subdomain_id=tagged.cell_names[name])
    else:
        form = fem.Constant(mesh, 1.0) * ufl.ds(domain=mesh, subdomain_data=tagged.facet_tags,
                                                subdomain_id=tagged.facet_names[name])
    return comm.allreduce(fem.assemble_scalar(fem.form(form)), op=MPI.SUM)


def tagged_count(mesh, tags, comm) -> int:
    """Global number of tagged entities (owned ones only)."""
    index_map = mesh.topology.index_map(tags.dim)
    return comm.allreduce(int(np.count_nonzero(tags.indices < index_map.size_local)), op=MPI.SUM)


@pytest.mark.parametrize("hexahedra, order", [(False, 1), (True, 2)])
def test_half_rolling_block_measures(comm, hexahedra, order):
    block = rolling_block(D, layers=(0.3,), cut="half")
    tagged = build_soil_block(comm, block, MeshOptions.from_refinement(D, 8, order, hexahedra))
    length, half_width, depth, stiff = 3.5 * D, 1.5 * D, 1.5 * D, 0.75 * D
    expected_cells = {"stiff_zone": stiff * half_width * depth,
                      "layer_1": (length - stiff) * half_width * 0.3 * D,
                      "layer_2": (length - stiff) * half_width * (depth - 0.3 * D)}
    contact = length * 0.3 * D
    expected_facets = {"top": length * half_width - contact, "contact": contact,
                       "symmetry_y": length * depth, "side": length * depth, "rear": half_width * depth,
                       "front": half_width * depth, "bottom": length * half_width}
    assert set(tagged.cell_names) == set(expected_cells)
    assert set(tagged.facet_names) == set(expected_facets)
    for name, value in {**expected_cells, **expected_facets}.items():
        assert measure(tagged, name, comm) == pytest.approx(value, rel=1e-9), name
    # every cell keeps its tag through distribution
    assert tagged_count(tagged.mesh, tagged.cell_tags, comm) == tagged.stats.cells
    assert tagged.stats.quality.min_scaled_jacobian > 0.05
    assert (tagged.stats.nodes > tagged.stats.vertices) == (order == 2)


def test_quarter_indentation_block_measures(comm):
    tagged = build_soil_block(comm, indentation_block(D, layers=(0.2,)), MeshOptions.from_refinement(D, 8))
    h, r = 1.5 * D, 0.25 * D
    expected = {"layer_1": h * h * 0.2 * D, "layer_2": h * h * (h - 0.2 * D), "contact": r * r,
                "top": h * h - r * r, "symmetry_x": h * h, "symmetry_y": h * h, "side": h * h,
                "front": h * h, "bottom": h * h}
    assert set(tagged.cell_names) | set(tagged.facet_names) == set(expected)
    for name, value in expected.items():
        assert measure(tagged, name, comm) == pytest.approx(value, rel=1e-9), name


def test_full_block_with_stiff_zone_across_origin(comm):
    block = SoilBlock(-1.0, 2.0, 0.5, 0.8, RefinedZone(-1.0, 2.0, 0.2, 0.3), cut="full", x_stiff=0.0)
    tagged = build_soil_block(comm, block, MeshOptions(0.2, 0.4, 0.3))
    assert measure(tagged, "stiff_zone", comm) == pytest.approx(1.0 * 1.0 * 0.8)
    assert measure(tagged, "layer_1", comm) == pytest.approx(2.0 * 1.0 * 0.8)
    assert measure(tagged, "side", comm) == pytest.approx(2 * 3.0 * 0.8)
    assert measure(tagged, "contact", comm) == pytest.approx(3.0 * 0.4)


@pytest.mark.parametrize("symmetric, quads", [(True, False), (False, True)])
def test_plane_strain_block_measures(comm, symmetric, quads):
    block = PlaneStrainBlock(half_width=3.0, depth=2.0, contact_half_width=0.4, refined_half_width=0.8,
                             refined_depth=0.8, layers=(0.5,), symmetric=symmetric)
    tagged = build_plane_strain_block(comm, block, MeshOptions(0.1, 0.4, 0.5, order=2, hexahedra=quads))
    width = 3.0 if symmetric else 6.0
    contact = 0.4 if symmetric else 0.8
    expected = {"layer_1": width * 0.5, "layer_2": width * 1.5, "contact": contact, "top": width - contact,
                "bottom": width, "side": 2.0 if symmetric else 4.0}
    if symmetric:
        expected["symmetry_x"] = 2.0
    assert set(tagged.cell_names) | set(tagged.facet_names) == set(expected)
    for name, value in expected.items():
        assert measure(tagged, name, comm) == pytest.approx(value, rel=1e-9), name


@pytest.mark.parametrize("hexahedra, low, high, band", [(True, 12, 24, (0.8, 1.25)), (False, 16, 32, (0.6, 1.25))])
def test_refinement_knob_scales_cell_count(comm, hexahedra, low, high, band):
    counts = [build_soil_block(comm, indentation_block(D), MeshOptions.from_refinement(D, k, 1, hexahedra)).stats.cells
              for k in (low, high)]
    ratio = counts[1] / counts[0] / (high / low) ** 3
    assert band[0] < ratio < band[1], counts


@pytest.mark.parametrize("knob, axis", [("path_refinement", 0), ("cross_refinement", 1), ("depth_refinement", 2)])
def test_anisotropic_refinement_shortens_hexahedra_along_one_axis_only(comm, knob, axis):
    """With ``knob`` = 2 the cells under the contact strip of a rolling block are half as long along
    ``axis`` (x: along the path, y: across it, z: down) and as long along the other two, the strip
    holds twice the facets (as many when the cells are thinner in depth), and the measures stay."""
    block = rolling_block(D, length=2.0, half_width=0.8, depth=0.8, stiff_length=0.5, refined_depth=0.5)

    def contact_cells(factor):
        opts = MeshOptions.from_refinement(D, 6, 1, True, **{knob: factor})
        tagged = build_soil_block(comm, block, opts)
        assert measure(tagged, "contact", comm) == pytest.approx(2.0 * D * 0.3 * D, rel=1e-9)
        assert measure(tagged, "stiff_zone", comm) == pytest.approx(0.5 * D * 0.8 * D * 0.8 * D, rel=1e-9)
        mesh, tags = tagged.mesh, tagged.facet_tags
        facets = tags.find(tagged.facet_names["contact"])
        owned = np.count_nonzero(facets < mesh.topology.index_map(2).size_local)
        cells = compat.incident_entities(mesh, facets, 2, 3)
        corners = mesh.geometry.x[compat.cell_dofs(mesh.geometry.dofmap)[cells, :8]]    # (cells, 8, 3)
        extent = np.ptp(corners, axis=1).max(axis=0) if cells.size else np.zeros(3)
        return comm.allreduce(owned, op=MPI.SUM), np.array([comm.allreduce(float(e), op=MPI.MAX) for e in extent])

    (n1, size1), (n2, size2) = contact_cells(1.0), contact_cells(2.0)
    assert n2 == (1 if axis == 2 else 2) * n1
    assert size2[axis] == pytest.approx(size1[axis] / 2, rel=1e-6)
    others = [k for k in range(3) if k != axis]
    assert size2[others] == pytest.approx(size1[others], rel=1e-6)
    assert size1[0] == pytest.approx(D / 6, rel=1e-6)


@pytest.mark.parametrize("knob", ANISOTROPIC_REFINEMENTS)
def test_anisotropic_refinement_is_refused_where_it_has_no_meaning(comm, knob):
    with pytest.raises(ValueError, match=f"{knob} needs hexahedra"):
        MeshOptions.from_refinement(D, 8, **{knob: 2})
    with pytest.raises(ValueError, match=f"{knob} must be >= 1"):
        MeshOptions.from_refinement(D, 8, hexahedra=True, **{knob: 0.5})
    block = PlaneStrainBlock(half_width=3.0, depth=2.0, contact_half_width=0.4, refined_half_width=0.8,
                             refined_depth=0.8)
    with pytest.raises(ValueError, match="plane-strain"):
        build_plane_strain_block(comm, block, MeshOptions(0.1, 0.4, 0.5, hexahedra=True, **{knob: 2}))


def test_accuracy_presets_are_ordered():
    sizes = [MeshOptions.from_accuracy(D, a).fine_size for a in ("fast", "standard", "accurate")]
    assert sizes[0] > sizes[1] > sizes[2] == pytest.approx(0.02 * D)
    assert MeshOptions.from_accuracy(D, "accurate").coarse_size == pytest.approx(0.08 * D)


def _single_tet_model(model, inverted: bool):
    """A discrete volume holding one tetrahedron (nodes listed clockwise if ``inverted``)."""
    volume = model.addDiscreteEntity(3)
    model.mesh.addNodes(3, volume, [1, 2, 3, 4], [0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0, 1])
    model.mesh.addElementsByType(volume, 4, [1], [1, 3, 2, 4] if inverted else [1, 2, 3, 4])
    model.addPhysicalGroup(3, [volume], 1)


def test_inverted_elements_are_refused(comm):
    with gmsh_model(comm, "inverted") as model:
        if model is not None:
            _single_tet_model(model, inverted=False)
            # corner tetrahedron: scaled Jacobian 1/sqrt(2) at the three acute corners
            assert mesh_quality(model, 3).min_scaled_jacobian == pytest.approx(1 / math.sqrt(2))
    with gmsh_model(comm, "inverted") as model:
        if model is not None:
            _single_tet_model(model, inverted=True)
        with pytest.raises(InvertedElementError, match="inverted"):
            distribute(model, comm, 3, 3, {"soil": 1}, {})


@pytest.mark.parametrize("make, message", [
    (lambda: rolling_block(D, layers=(1.0, 0.6)), "layers"),
    (lambda: rolling_block(D, cut="third"), "cut"),
    (lambda: indentation_block(D, cut="quarter", refined_half_size=2.0), "refined"),
    (lambda: MeshOptions(0.1, 0.05, 0.5), "coarse_size"),
    (lambda: MeshOptions.from_refinement(D, 10, order=3), "order"),
    (lambda: PneumaticTire(1.0, 0.3, 0.5, 0.02), "tread_thickness"),
    (lambda: CylinderWheel(1.0, 0.2, fillet=0.2), "fillet"),
    (lambda: TorusWheel(1.0, 0.6), "width"),
])
def test_invalid_parameters_name_the_field(make, message):
    with pytest.raises(ValueError, match=message):
        make()


def test_cylinder_wheel_signed_distance_closed_form():
    r, b, f = 0.6, 0.4, 0.05
    wheel = CylinderWheel(2 * r, b, f)
    s = 1 / math.sqrt(2)
    points = np.array([
        [0.0, 0.0, -r - 0.1],  # below the tread
        [0.3 * s, 0.05, 0.3 * s],  # inside, 0.15 from the flat side face
        [0.0, b / 2 + 0.2, 0.1],  # beside the flat side face
        [r - f + 0.1 * s, b / 2 - f + 0.1 * s, 0.0],  # off the fillet, along its 45 degree normal
        [0.0, 0.0, 0.0],  # centre
    ])
    distance, normal = wheel.signed_distance(points)
    assert distance == pytest.approx([0.1, -0.15, 0.2, 0.1 - f, -b / 2])
    assert normal == pytest.approx(np.array([[0, 0, -1], [0, 1, 0], [0, 1, 0], [s, s, 0], [0, 1, 0]]))


def test_torus_wheel_signed_distance_closed_form():
    wheel = TorusWheel(1.0, 0.3)  # tube radius 0.15 at 0.35 from the axle
    points = np.array([[0.0, 0.0, -0.6], [0.35, 0.0, 0.0], [0.0, 0.25, 0.35], [0.0, 0.0, 0.0]])
    distance, normal = wheel.signed_distance(points)
    assert distance == pytest.approx([0.1, -0.15, 0.1, 0.2])
    assert normal == pytest.approx(np.array([[0, 0, -1], [1, 0, 0], [0, 1, 0], [0, 0, 1]]))


@pytest.mark.parametrize("wheel", [CylinderWheel(D, 0.4 * D, 0.1 * D), TorusWheel(D, 0.3 * D)])
def test_wheel_distance_is_consistent(wheel):
    """The normal is the distance gradient, and stepping back along it lands on the surface."""
    rng = np.random.default_rng(1)
    points = rng.uniform(-D, D, size=(200, 3))
    distance, normal = wheel.signed_distance(points)
    assert np.linalg.norm(normal, axis=1) == pytest.approx(np.ones(len(points)))
    assert wheel.signed_distance(points - distance[:, None] * normal)[0] == pytest.approx(0, abs=1e-12)
    step = 1e-6
    for axis in range(3):
        shift = np.zeros(3)
        shift[axis] = step
        gradient = (wheel.signed_distance(points + shift)[0] - wheel.signed_distance(points - shift)[0]) / (2 * step)
        assert gradient == pytest.approx(normal[:, axis], abs=1e-5)


@pytest.mark.parametrize("wheel", [CylinderWheel(D, 0.4 * D, 0.1 * D), TorusWheel(D, 0.3 * D)])
def test_wheel_surface_mesh_area(comm, wheel):
    tagged = build_wheel_surface(comm, wheel, 0.08 * D)
    assert measure(tagged, "surface", comm) == pytest.approx(wheel.surface_area(), rel=2e-4)
    distance, _ = wheel.signed_distance(tagged.mesh.geometry.x)
    assert np.abs(distance).max(initial=0.0) < 1e-12  # all nodes on the analytic surface


@pytest.mark.parametrize("cut", ["quarter", "half"])
def test_tire_sections_and_faces(comm, cut):
    tire = pneumatic_tire(D, gap=0.01, cut=cut)
    tagged = build_tire(comm, tire, MeshOptions.from_refinement(D, 8, order=2, hexahedra=True))
    for name, value in tire.section_volumes().items():
        assert measure(tagged, name, comm) == pytest.approx(value, rel=2e-3), name
    for name, value in tire.cut_areas().items():
        assert measure(tagged, name, comm) == pytest.approx(value, rel=2e-3), name
    assert set(tagged.facet_names) == {"inner_surface", "outer_surface"} | set(tire.cut_areas())
    # outer: tread band + shoulder + flat side (Pappus), kept fraction
    R, b, rho, r_h = D / 2, tire.width, tire.shoulder_radius, tire.hub_diameter / 2
    outer = (2 * math.pi * R * (b - 2 * rho) + 2 * (math.pi * rho / 2) * 2 * math.pi * (R - rho + 2 * rho / math.pi)
             + 2 * math.pi * ((R - rho) ** 2 - r_h ** 2))
    assert measure(tagged, "outer_surface", comm) == pytest.approx(outer * {"half": 0.5, "quarter": 0.25}[cut], rel=2e-3)
    lowest = comm.allreduce(tagged.mesh.geometry.x[:, 2].min(initial=np.inf), op=MPI.MIN)
    assert lowest == pytest.approx(0.01 * D, abs=1e-9)  # the gap above the soil


def test_command_line_writes_mesh_xdmf_and_picture(comm, tmp_mpi_path):
    assert main(["example", "plane-strain", "--out", str(tmp_mpi_path), "--refinement", "4", "-q"], comm) == 0
    if comm.rank == 0:
        for suffix in (".msh", ".xdmf", ".h5", ".png"):
            assert (tmp_mpi_path / f"plane-strain{suffix}").stat().st_size > 0
    # layers thicker than the block: refused with exit code 2
    assert main(["block", "--layers", "1,1", "--out", str(tmp_mpi_path), "-q", "--no-png"], comm) == 2
