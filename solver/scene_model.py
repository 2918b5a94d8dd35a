"""From a scene to the finite-element model: layer materials, contact penalty, wheel and mesh.

The scene (``rollsim.scene.Scene``) is read by attribute only: this module does not import the
input layer.  The drivers (``rollsim.solver.drivers``) build their runs from these pieces.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

from mpi4py import MPI

from rollsim.geometry import (PATH_HALF_WIDTH, ROLLING_START, CylinderWheel, MeshOptions, PneumaticTire, TorusWheel,
                              build_soil_block, build_tire_on_soil, indentation_block, rolling_block)
from rollsim.log import get_logger

from .materials import PHI_COMPRESSION_MATCH_LIMIT, DruckerPrager, VonMises, mc_to_dp, regularised_cohesion
from .options import DEFAULT_REGULARISING_COHESION, MATCHING

__all__ = ["layer_material", "layer_materials", "frictional_layers", "regularised_layers", "scene_penalty",
           "solver_options", "FRICTIONAL_PENALTY", "relaxation_hint", "non_associated", "wheel_geometry",
           "block_depth", "indentation_mesh", "rolling_mesh", "rolling_mesh_options", "path_half_width",
           "SoilMaterials"]

log = get_logger("run")


def layer_material(layer, index: int = 0, *, c_reg: float = DEFAULT_REGULARISING_COHESION):
    """``LayerSpec`` -> ``VonMises`` / ``DruckerPrager`` (SI, radians).

    von Mises: yield stress ``q_y = c_dp`` if given, else from the cohesion ``c`` by the layer's
    ``match`` (compression / extension: ``q_y = 2 c``; plane strain: ``sqrt(3) c``).
    Drucker-Prager: ``phi_dp``/``c_dp``/``dilation`` as given, or matched to ``c``/``phi`` (dilation
    angle mapped with the same matching).  ``mohr-coulomb``: the smoothed (Abbo-Sloan) surface of
    ``solver/smoothed_mc.py`` when available, else a ``ValueError`` naming the layer.

    Purely frictional layers (``c = 0`` or ``c_dp = 0`` with a friction angle > 0) get the
    regularising cohesion ``c_reg`` (Pa: the scene's ``[model] regularising_cohesion``) in its
    place, with a warning in the log stating its measured effect on Q_V (see
    docs/limitations.md, "Purely frictional soil (c = 0)");
    ``c_reg = 0`` keeps c = 0 (not for mohr-coulomb, whose rounded tip needs c > 0: ``ValueError``
    naming the layer).
    """
    return _layer_material(layer, index, float(c_reg))[0]


def _layer_material(layer, index: int, c_reg: float) -> tuple[object, bool]:
    """``(material, regularised)``: :func:`layer_material` and whether ``c_reg`` replaced c = 0."""
    key = f"soil.layers[{index}]"
    c, c_dp, reg = layer.c, layer.c_dp, False
    if layer.model in ("drucker-prager", "mohr-coulomb"):
        angle = layer.phi_dp if (layer.model == "drucker-prager" and layer.phi_dp is not None) else layer.phi
        if c_reg == 0:
            if layer.model == "mohr-coulomb" and c == 0:
                raise ValueError(f"{key}.c: the smoothed Mohr-Coulomb needs c > 0 (its rounded tip); with "
                                 "model.regularising_cohesion = 0 use drucker-prager for c = 0")
        elif angle is not None and layer.model == "drucker-prager" and layer.phi_dp is not None and c_dp is not None:
            c_dp, reg = regularised_cohesion(c_dp, angle, c_reg)
        elif angle is not None and c is not None:
            c, reg = regularised_cohesion(c, angle, c_reg)
        if reg:
            log.warning("%s: c = 0 (purely frictional) -> regularising cohesion %g Pa used (numerical device; it "
                        "raises Q_V markedly: at s/d = 0.1, +60 %% pointwise and +97 %% B-bar for 1 kPa, phi = 40 deg; "
                        "model.regularising_cohesion = 0 keeps c = 0; docs/limitations.md)", key, c_reg)
        if (layer.model == "drucker-prager" and layer.phi_dp is None and layer.phi is not None
                and MATCHING.get(layer.match) == "compression" and layer.phi > PHI_COMPRESSION_MATCH_LIMIT):
            log.warning("%s: compression-matched Drucker-Prager with phi = %.1f deg > 36.87 deg is stronger in "
                        "triaxial extension than any Mohr-Coulomb soil and converges poorly with psi = 0; "
                        "match = 'plane-strain' is recommended", key, math.degrees(layer.phi))
    return _material(layer, key, c, c_dp), reg


def _material(layer, key: str, c: float | None, c_dp: float | None):
    """The solver material of ``layer`` with the cohesion ``c`` / ``c_dp`` (Pa) it is to have."""
    if layer.model == "von-mises":
        q_y = layer.c_dp if layer.c_dp is not None else mc_to_dp(layer.c, 0.0, MATCHING[layer.match])[1]
        return VonMises(E=layer.E, nu=layer.nu, yield_stress=q_y)
    if layer.model == "drucker-prager":
        if layer.phi_dp is not None:
            return DruckerPrager(E=layer.E, nu=layer.nu, phi_dp=layer.phi_dp, c_dp=c_dp,
                                 dilation=layer.dilation)
        return DruckerPrager.from_mohr_coulomb(layer.E, layer.nu, c, layer.phi, psi=layer.dilation,
                                               matching=MATCHING[layer.match])
    if layer.model == "mohr-coulomb":
        try:
            from .smoothed_mc import SmoothedMohrCoulomb
            return SmoothedMohrCoulomb(E=layer.E, nu=layer.nu, c=c, phi=layer.phi, dilation=layer.dilation)
        except (ImportError, TypeError) as err:
            raise ValueError(f"{key}.model: 'mohr-coulomb' is not available in the finite-element solver "
                             f"({err}); use von-mises or drucker-prager") from None
    raise ValueError(f"{key}.model: {layer.model!r} is not available in the finite-element solver "
                     "(use von-mises, drucker-prager or mohr-coulomb)")


def frictional_layers(scene) -> dict:
    """``{"soil.layers[i]": layer}``: the purely frictional layers (c = 0, friction angle > 0)."""
    out = {}
    for i, layer in enumerate(scene.soil.layers):
        if layer.model == "drucker-prager" and layer.phi_dp is not None:
            c, angle = layer.c_dp, layer.phi_dp
        else:
            c, angle = layer.c, layer.phi
        if layer.model != "von-mises" and c == 0 and angle is not None and angle > 0:
            out[f"soil.layers[{i}]"] = layer
    return out


def regularised_layers(scene) -> dict:
    """``{"soil.layers[i]": c_reg (Pa)}`` for the purely frictional layers that ``layer_material``
    gives the scene's regularising cohesion (reported in summary.json: it raises Q_V markedly);
    none when ``[model] regularising_cohesion`` is 0."""
    return layer_materials(scene).regularised


#: penalty alpha for scenes with a purely frictional layer (c = 0, regularised): much faster than
#: the default alpha = 10 there (measured: see docs/benchmarks.md, "c = 0 soil")
FRICTIONAL_PENALTY = 1.0


def scene_penalty(scene, penalty: float | None) -> float | None:
    """The contact penalty alpha for ``scene``: ``penalty`` if given, :data:`FRICTIONAL_PENALTY`
    when a layer is purely frictional (see :func:`frictional_layers`), else None (the default)."""
    frictional = frictional_layers(scene)
    if penalty is not None or not frictional:
        return penalty
    log.info("purely frictional layer(s) %s: contact penalty alpha = %g (pass penalty to override)",
             ", ".join(frictional), FRICTIONAL_PENALTY)
    return FRICTIONAL_PENALTY


def solver_options(scene, *, penalty: float | None = None, petsc_options: dict | None = None) -> dict:
    """Keywords of the wheel classes (``WheelIndentation``, ``WheelRolling``) for ``scene``: its unit
    weight and wheel friction, the penalty of :func:`scene_penalty` and the ``[model]`` options
    (``travel_relaxation_fallback`` for the rolling protocols only)."""
    model = scene.model
    rolling = {} if scene.loading.protocol == "indentation" else {
        "travel_relaxation_fallback": model.travel_relaxation_fallback}
    return rolling | dict(gamma=scene.soil.gamma, friction=scene.wheel.friction, petsc_options=petsc_options,
                penalty=scene_penalty(scene, penalty), kinematics=model.kinematics,
                linear_solver=model.linear_solver, volumetric_strain=model.volumetric_strain,
                relaxation_length=model.relaxation_length, relaxation_fallback=model.relaxation_fallback,
                plateau_rtol=model.plateau_tolerance)


#: Duvaut-Lions relaxation length the failure hint suggests, by protocol (m of the wheel's path):
#: rolling 1 mm (dense sand of the layered cases 13-15), indentation 0.01 mm (c = 0, phi = 40 deg;
#: docs/benchmarks.md)
SUGGESTED_RELAXATION_LENGTH = {"indentation": "0.01 mm", "rolling": "1 mm"}


def non_associated(materials) -> bool:
    """Any frictional material (``{tag: material}`` or one) whose dilation is below its friction angle."""
    mats = materials.values() if isinstance(materials, dict) else [materials]
    return any(getattr(m, "tan_phi", 0.0) > getattr(m, "tan_psi", 0.0) * (1 + 1e-12) for m in mats)


def relaxation_hint(materials, scene) -> str:
    """What to append to a failed run's reason: the Duvaut-Lions remedy when the soil's flow is
    non-associated and the scene does not regularise it yet, and the regularising cohesion when
    the scene keeps c = 0; else ""."""
    hint = ""
    if scene.model.relaxation_length == 0 and non_associated(materials):
        length = SUGGESTED_RELAXATION_LENGTH["indentation" if scene.loading.protocol == "indentation" else "rolling"]
        hint += ("; the soil's flow is non-associated (dilation below the friction angle), whose Newton tangent can "
                 f"be near-singular: [model] relaxation_length = \"{length}\" (Duvaut-Lions regularisation; its bias "
                 "is first order in the length, so compare with half of it) may let the run converge")
    if scene.model.regularising_cohesion == 0 and frictional_layers(scene):
        hint += ("; c = 0 is kept exactly (model.regularising_cohesion = 0): the default \"1 kPa\" runs more often "
                 "but raises Q_V markedly (docs/limitations.md)")
    return hint


def block_depth(scene) -> float:
    """Depth of the soil block, in d: the reference 1.5 d, or the layers above the last one + 0.5 d."""
    d = scene.wheel.diameter
    return max(1.5, sum(layer.thickness for layer in scene.soil.layers[:-1]) / d + 0.5)


def _layer_thicknesses(scene) -> tuple[float, ...]:
    """Thicknesses of the layers above the last one, in d."""
    return tuple(layer.thickness / scene.wheel.diameter for layer in scene.soil.layers[:-1])


def indentation_mesh(scene, comm: MPI.Comm):
    """Quarter indentation block for the scene (layers from the scene, the elements per d of its
    ``[model]``)."""
    d = scene.wheel.diameter
    block = indentation_block(d, depth=block_depth(scene), cut="quarter", layers=_layer_thicknesses(scene))
    return build_soil_block(comm, block, MeshOptions.from_refinement(d, scene.model.elements_per_d))


#: gap (in d) between the pneumatic tire and the soil before inflation, and the tire's shoulder radius (in d)
TIRE_GAP, TIRE_SHOULDER = 0.05, 0.08


#: a towed tire's start (axle) and the end of its stiff start zone, x / d: the tire lies over the
#: block, 0.35 d of the zone ahead of the axle (as the rigid wheel's 0.4 / 0.75 d)
TIRE_ROLLING_START, TIRE_STIFF_LENGTH = 0.6, 0.95


def pneumatic_mesh(scene, comm: MPI.Comm, rolling: bool = False):
    """The scene's pneumatic tire over its soil block, one mesh of P2 hexahedra
    (``build_tire_on_soil``; the carcass meshed at the soil's fine size): (mesh, tire).  Pressed:
    a quarter tire over the quarter indentation block; ``rolling``: a half tire at
    ``TIRE_ROLLING_START`` d over a half rolling block with a stiff start zone to
    ``TIRE_STIFF_LENGTH`` d, long enough for the travel and 1 d ahead."""
    d, w = scene.wheel.diameter, scene.wheel
    rho = min(TIRE_SHOULDER * d, 0.45 * w.width)
    if not w.t_tread < rho:
        raise ValueError(f"wheel.width: {w.width:g} m leaves no room for the tire's shoulder (radius {rho:g} m) "
                         f"beyond the tread thickness {w.t_tread:g} m")
    cut = "half" if rolling else "quarter"
    tire = PneumaticTire(d, w.width, w.hub_diameter, rho, w.t_tread, cut=cut, gap=TIRE_GAP * d,
                         x_centre=TIRE_ROLLING_START * d if rolling else 0.0)
    if rolling:
        block = rolling_block(d, length=TIRE_ROLLING_START + scene.loading.travel / d + 1.0, half_width=1.5,
                              depth=block_depth(scene), cut="half", layers=_layer_thicknesses(scene),
                              stiff_length=TIRE_STIFF_LENGTH)
    else:
        block = indentation_block(d, depth=block_depth(scene), cut="quarter", layers=_layer_thicknesses(scene))
    soil = MeshOptions.from_refinement(d, scene.model.elements_per_d, order=2, hexahedra=True)
    carcass = MeshOptions(soil.fine_size, soil.fine_size, 1.0, order=2)
    return build_tire_on_soil(comm, tire, block, soil, carcass), tire


#: margin (in d) of a rolling block's refined strip beside the wheel: the strip covers the wheel's
#: half width plus this margin where that is wider than ``PATH_HALF_WIDTH``
PATH_MARGIN = 0.15


def path_half_width(scene) -> float:
    """Half width (in d) of the scene's refined strip along the wheel's path: ``PATH_HALF_WIDTH``,
    or the wheel's half width plus ``PATH_MARGIN`` where that is wider (a wheel wider than 0.3 d)."""
    return max(PATH_HALF_WIDTH, 0.5 * scene.wheel.width / scene.wheel.diameter + PATH_MARGIN)


def rolling_mesh_options(scene) -> MeshOptions:
    """Element sizes of the scene's rolling block: the elements per d of its ``[model]``, on
    hexahedra (``cell_type``) with the refined strip's elements shortened across the path so that
    ``elements_across_wheel`` of them span the wheel's width (never coarser than along it) and
    along the path to ``elements_along_path`` per d."""
    d, per_d = scene.wheel.diameter, scene.model.elements_per_d
    if scene.model.cell_type != "hexahedra":
        return MeshOptions.from_refinement(d, per_d)
    across = scene.model.elements_across_wheel * (d / per_d) / scene.wheel.width
    along = (scene.model.elements_along_path or per_d) / per_d
    return MeshOptions.from_refinement(d, per_d, hexahedra=True, cross_refinement=max(1.0, across),
                                       path_refinement=max(1.0, along))


def rolling_mesh(scene, comm: MPI.Comm, *, length: float | None = None, half_width: float = 1.5,
                 depth: float | None = None, stiff_length: float = 0.0):
    """Half rolling block for the scene (lengths in multiples of d).  Default length: the reference
    3.5 d, or longer when the travel needs it (start + travel + 1 d ahead of the wheel).  Its
    refined strip spans ``path_half_width`` each side of the path, the whole wheel and a margin."""
    d = scene.wheel.diameter
    if length is None:
        length = max(3.5, ROLLING_START + scene.loading.travel / d + 1.0)
    path = path_half_width(scene)
    block = rolling_block(d, length=length, half_width=half_width,
                          depth=block_depth(scene) if depth is None else depth, cut="half",
                          layers=_layer_thicknesses(scene), stiff_length=stiff_length,
                          path_half_width=min(path, 0.9 * half_width))
    return build_soil_block(comm, block, rolling_mesh_options(scene))


def wheel_geometry(spec):
    """The rigid wheel of a scene's ``[wheel]``: ``CylinderWheel`` or ``TorusWheel``."""
    if spec.type != "rigid":
        raise ValueError(f"wheel.type: a {spec.type} wheel runs with protocol = \"indentation\" only so far")
    if spec.shape == "torus":
        return TorusWheel(spec.diameter, spec.width)
    return CylinderWheel(spec.diameter, spec.width, spec.fillet)


@dataclass(frozen=True)
class SoilMaterials:
    """The materials built for a scene's layers, and what was put in place of c = 0."""

    by_layer: dict          # {layer id (1 = top): material}
    regularised: dict       # {"soil.layers[i]": regularising cohesion applied (Pa)}
    cohesionless: bool = False      # a purely frictional layer is solved with c = 0 exactly

    @property
    def single_or_dict(self):
        """One material for a one-layer soil, else ``by_layer`` (as the wheel classes take it)."""
        return self.by_layer[1] if len(self.by_layer) == 1 else self.by_layer


def layer_materials(scene) -> SoilMaterials:
    """The solver materials of the scene's layers with its regularising cohesion."""
    c_reg = float(scene.model.regularising_cohesion)
    by_layer, regularised = {}, {}
    for k, layer in enumerate(scene.soil.layers, start=1):
        by_layer[k], reg = _layer_material(layer, k - 1, c_reg)
        if reg:
            regularised[f"soil.layers[{k - 1}]"] = c_reg
    return SoilMaterials(by_layer, regularised, cohesionless=bool(set(frictional_layers(scene)) - set(regularised)))
