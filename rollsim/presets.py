"""The mesh presets (``[model] accuracy``): what each one sets, in one record.

A preset fixes the element sizes of every model a scene can build (the tetrahedral blocks of
indentation and of ``fast`` rolling, the hexahedral rolling block refined across the wheel and
along its path, the steady window), the rolling block's cell type, the soil's volumetric strain
for rolling a rigid wheel and the linear solver.  ``[model] refinement`` replaces the elements
per diameter everywhere (:func:`resolve_preset`).

Why: on constant-load rolling the sinkage is set by the elements across the wheel and, with
friction, along the path more than by those in depth, so ``standard`` and ``accurate`` roll on
hexahedra refined across and along (the tetrahedral ``standard`` is far too dear for rolling;
see docs/speed-accuracy-details.md, "Constant-load rolling: mesh convergence" and "Along the
path").  B-bar removes the locking of P2 tetrahedra in indentation (docs/verification.md, "Mesh
convergence of indentation") and of the tire's hexahedral soil (docs/verification.md,
"Pneumatic tire on soil"); on ``fast`` rolling neither strain reaches screening accuracy on
both soils and the pointwise one costs less, so it stays there (docs/speed-accuracy-details.md,
"Rolling: the findings behind the presets").  The figures: docs/benchmarks.md, "Presets".

Plain data, imported by the geometry, the solver and the scene parser alike.
"""
from __future__ import annotations

from dataclasses import dataclass, replace

__all__ = ["Preset", "PRESETS", "DEFAULT_PRESET", "DEFAULT_ELEMENTS_ACROSS_WHEEL", "resolve_preset"]

#: elements across the wheel's width in a hexahedral rolling block when ``[model] refinement``
#: replaces the preset (four across the modelled half)
DEFAULT_ELEMENTS_ACROSS_WHEEL = 8.0


@dataclass(frozen=True)
class Preset:
    """What a mesh preset sets.

    ``elements_per_d``: elements per wheel diameter in the refined zone of a tetrahedral block
    (indentation, tetrahedral rolling), 4x larger away from it; ``rolling_cell_type``: a rigid
    wheel's rolling block, ``"tetrahedra"`` or ``"hexahedra"``; ``hexahedra``: that block's
    elements per d, across the wheel's width and per d along the path in the refined strip;
    ``steady_elements_per_d``: a steady window's elements per d at the contact;
    ``rolling_volumetric_strain``: the soil's strain when a rigid wheel rolls (indentation and
    the pneumatic tire take B-bar, ``"cell-average"``, on every preset); ``linear_solver``: of the
    Newton iteration."""

    name: str
    elements_per_d: float
    rolling_cell_type: str
    hexahedra: tuple[float, float, float]
    steady_elements_per_d: float
    rolling_volumetric_strain: str
    linear_solver: str = "auto"

    def volumetric_strain(self, protocol: str, wheel: str = "rigid") -> str:
        """The soil's volumetric strain for a loading ``protocol`` and a ``wheel`` type."""
        if wheel == "pneumatic" or not protocol.startswith("rolling"):
            return "cell-average"
        return self.rolling_volumetric_strain


#: the presets by name; ``accurate`` refines every direction of ``standard`` once more
PRESETS = {
    "fast": Preset("fast", 8.0, "tetrahedra", (6.0, 8.0, 6.0), 20.0, "pointwise"),
    "standard": Preset("standard", 20.0, "hexahedra", (6.0, 8.0, 12.0), 30.0, "cell-average"),
    "accurate": Preset("accurate", 50.0, "hexahedra", (8.0, 16.0, 24.0), 40.0, "cell-average"),
}
DEFAULT_PRESET = "standard"


def resolve_preset(accuracy: str, refinement: float | None = None) -> Preset:
    """The preset ``accuracy``, or with ``refinement`` (elements per d) in place of its element
    sizes: tetrahedral rolling blocks, :data:`DEFAULT_ELEMENTS_ACROSS_WHEEL` across a hexahedral
    one and the refinement along it, and the pointwise strain for rolling up to the ``fast``
    preset's elements per d (B-bar above)."""
    if accuracy not in PRESETS:
        raise ValueError(f"accuracy must be one of {', '.join(PRESETS)}, got {accuracy!r}")
    base = PRESETS[accuracy]
    if refinement is None:
        return base
    coarse = refinement <= PRESETS["fast"].elements_per_d
    return replace(base, elements_per_d=refinement, rolling_cell_type="tetrahedra",
                   hexahedra=(refinement, DEFAULT_ELEMENTS_ACROSS_WHEEL, refinement),
                   steady_elements_per_d=refinement,
                   rolling_volumetric_strain="pointwise" if coarse else "cell-average")
