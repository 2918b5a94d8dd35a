"""The CalculiX deck of the peer benchmark (``python -m benchmarks peer_calculix``) holds the mesh
rollsim solves: every quadratic tetrahedron positive and the block's volume exact, the contact
faces on the soil surface, the wheel facets on the wheel surface facing the soil.  CalculiX
itself is not needed (the benchmark runs it)."""
from __future__ import annotations

import importlib.util
import pathlib
import re

import numpy as np
import pytest

from rollsim.geometry import CylinderWheel

BENCH = pathlib.Path(__file__).parents[1] / "benchmarks" / "bench_peer_calculix.py"


@pytest.fixture(scope="module")
def peer():
    spec = importlib.util.spec_from_file_location("bench_peer_calculix", BENCH)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def _tet_volumes(x, conn):
    a, b, c = (x[conn[:, k]] - x[conn[:, 0]] for k in (1, 2, 3))
    return np.einsum("ij,ij->i", np.cross(a, b), c) / 6


@pytest.mark.serial
def test_deck_mesh_is_the_block_with_straight_quadratic_tetrahedra(peer, tmp_path):
    x, tets, boundaries = peer.soil_mesh(6.0, tmp_path / "soil.msh")
    nodes, conn, _ = peer.quadratic_tets(x, tets)
    vol = _tet_volumes(nodes, conn)
    assert vol.min() > 0
    extent = nodes.max(axis=0) - nodes.min(axis=0)
    assert vol.sum() == pytest.approx(np.prod(extent), rel=1e-12)
    for k, (i, j) in enumerate(peer.C3D10_EDGES):      # mid-side nodes halfway along their edges
        assert np.allclose(nodes[conn[:, 4 + k]], 0.5 * (nodes[conn[:, i]] + nodes[conn[:, j]]))
    assert np.allclose(nodes[boundaries["bottom"], 2], nodes[:, 2].min())
    assert np.allclose(nodes[boundaries["symmetry_x"], 0], 0.0)


@pytest.mark.serial
def test_deck_contact_faces_and_wheel_facets(peer, tmp_path):
    sizes = peer.calculix_deck(6.0, (1e9, 1e9), tmp_path)
    deck = (tmp_path / "indent.inp").read_text()
    assert sizes["slave_faces"] > 0 and sizes["wheel_facets"] > 0
    x, tets, _ = peer.soil_mesh(6.0, tmp_path / "again.msh")
    faces = re.findall(r"^(\d+), S(\d)$", deck.split("*SURFACE, NAME=SOILTOP")[1].split("*SURFACE")[0], re.M)
    assert len(faces) == sizes["slave_faces"]
    for e, f in faces:                                  # each named face lies on the soil surface z = 0
        corners = tets[int(e) - 1][list(peer.TET_FACES[int(f) - 1])]
        assert np.allclose(x[corners, 2], 0.0)
    wheel_xyz, bricks = peer.wheel_shell(0, thickness=0.05 * peer.D)
    a, b, c = (wheel_xyz[bricks[:, k]] - wheel_xyz[bricks[:, 0]] for k in (1, 3, 4))
    assert (np.einsum("ij,ij->i", np.cross(a, b), c) > 0).all()     # positive bricks: S1 faces out of each
    wheel = CylinderWheel(peer.D, peer.B, peer.FILLET)
    centre = np.array([0.0, 0.0, peer.D / 2])
    on_rim, _ = wheel.signed_distance(wheel_xyz[bricks[:, :4]].reshape(-1, 3) - centre)
    inside, _ = wheel.signed_distance(wheel_xyz[bricks[:, 4:]].reshape(-1, 3) - centre)
    assert np.abs(on_rim).max() < 1e-12 * peer.D                      # S1 nodes on the wheel surface
    assert inside.max() < 0                                           # the rest inside the wheel
