"""Parametric gmsh geometries for test rolling, handed to DOLFINx with named tags.

Builders run gmsh on rank 0 of the communicator they are given and return a ``TaggedMesh``.
"""
from rollsim.geometry.mesh import (ACCURACY_REFINEMENT, InvertedElementError, MeshOptions, MeshQuality,
                                   MeshStats, TaggedMesh, mesh_quality)
from rollsim.geometry.pair import (CylinderOnBlock, SphereOnBlock, build_block_on_block, build_cylinder_on_block,
                                   build_sphere_on_block)
from rollsim.geometry.soil import (FACET_TAGS, PATH_HALF_WIDTH, ROLLING_START, STIFF_ZONE_TAG, PlaneStrainBlock,
                                   RefinedZone, SoilBlock, build_plane_strain_block, build_soil_block, indentation_block,
                                   rolling_block)
from rollsim.geometry.tire import (TIRE_CELL_TAGS, TIRE_FACET_TAGS, PneumaticTire, build_tire,
                                   build_tire_on_soil, pneumatic_tire)
from rollsim.geometry.wheels import CylinderWheel, TorusWheel, build_wheel_surface

__all__ = [
    "ACCURACY_REFINEMENT", "FACET_TAGS", "PATH_HALF_WIDTH", "ROLLING_START", "STIFF_ZONE_TAG", "TIRE_CELL_TAGS",
    "TIRE_FACET_TAGS",
    "CylinderOnBlock", "CylinderWheel", "InvertedElementError", "MeshOptions", "MeshQuality", "MeshStats",
    "PlaneStrainBlock", "PneumaticTire", "RefinedZone", "SoilBlock", "SphereOnBlock", "TaggedMesh", "TorusWheel",
    "build_block_on_block", "build_cylinder_on_block", "build_plane_strain_block", "build_soil_block",
    "build_sphere_on_block", "build_tire", "build_tire_on_soil", "build_wheel_surface",
    "indentation_block", "mesh_quality", "pneumatic_tire", "rolling_block",
]
