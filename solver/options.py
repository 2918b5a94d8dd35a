"""Every solver option's choices and default, in one place.

The scene parser (``rollsim.scene``) and the benchmarks import them from here; the solver classes
validate against them.  Names are the scene's spelling (``"plane-strain"``); where the solver's
own functions spell a choice differently, the mapping lives here too (:data:`MATCHING`).
"""
from __future__ import annotations

from rollsim.presets import DEFAULT_PRESET, PRESETS

#: loading protocols of ``rollsim run``
PROTOCOLS = ("indentation", "rolling-continuous", "rolling-constant-load")
#: mesh presets (``[model] accuracy``); what each sets: :data:`rollsim.presets.PRESETS`
ACCURACIES = tuple(PRESETS)
DEFAULT_ACCURACY = DEFAULT_PRESET
#: small strain, or incremental large deformation (``PlasticityProblem(kinematics=...)``)
KINEMATICS = ("small-strain", "updated-lagrangian")
DEFAULT_KINEMATICS = "small-strain"
#: how a rigid wheel rolls (``[model] rolling``): "transient", moved step by step along a block;
#: "steady", the steady state solved directly in the wheel's frame on a window that travels with
#: it (``rollsim.solver.steady``)
ROLLING_METHODS = ("transient", "steady")
DEFAULT_ROLLING_METHOD = "transient"
#: linear solver of the Newton iteration (``PlasticityProblem(linear_solver=...)``): "auto" =
#: direct LU up to ``problem.AUTO_ITERATIVE_DOFS`` dofs, iterative (AMG-preconditioned GMRES) above
LINEAR_SOLVERS = ("auto", "direct", "iterative")
DEFAULT_LINEAR_SOLVER = "auto"
#: volumetric strain of the soil (``PlasticityProblem(volumetric_strain=...)``): "cell-average" =
#: B-bar (the volumetric strain projected per cell - its mean on simplices, a linear function on
#: hexahedra: a few constraints per cell, no locking under isochoric plastic flow),
#: "pointwise" = plain strain at every quadrature point.  The solver classes default to
#: :data:`DEFAULT_VOLUMETRIC_STRAIN`; scenes default per protocol and preset
#: (:meth:`rollsim.presets.Preset.volumetric_strain`).
VOLUMETRIC_STRAINS = ("cell-average", "pointwise")
DEFAULT_VOLUMETRIC_STRAIN = "pointwise"
#: element type of a rigid wheel's rolling block (``[model] cell_type``): 10-node tetrahedra, or
#: structured 27-node hexahedra whose refined strip can be finer across the wheel's path than
#: along it (B-bar: Q2-P1); indentation blocks are tetrahedral, a pneumatic wheel's hexahedral.
#: Scenes default per preset (:attr:`rollsim.presets.Preset.rolling_cell_type`).
CELL_TYPES = ("tetrahedra", "hexahedra")
#: Drucker-Prager to Mohr-Coulomb matching, scene spelling -> ``materials.mc_to_dp`` spelling
MATCHING = {"compression": "compression", "extension": "extension", "plane-strain": "plane_strain",
            "plane-strain-flow": "plane_strain_flow"}
MATCHES = tuple(MATCHING)
DEFAULT_MATCH = "compression"
#: Pa put in place of c = 0 in purely frictional layers (``[model] regularising_cohesion``);
#: 0 keeps c = 0
DEFAULT_REGULARISING_COHESION = 1.0e3
#: Duvaut-Lions relaxation length (m of the wheel's path; ``[model] relaxation_length``); 0: off
DEFAULT_RELAXATION_LENGTH = 0.0
#: relaxation length (m) a push falls back to, over a short stretch of sinkage, when Newton fails
#: on the unregularised soil (``[model] relaxation_fallback``); 0: fail instead
DEFAULT_RELAXATION_FALLBACK = 1e-5
#: relaxation length (m of travel) a roll starts over with, relaxed to its end, when Newton fails
#: on the unregularised soil (``[model] travel_relaxation_fallback``); 0: fail instead
DEFAULT_TRAVEL_RELAXATION_FALLBACK = 5e-4

#: A Newton plateau (see :data:`rollsim.solver.problem.STAGNATION`) whose ``|F|`` is below this
#: fraction of the internal-force norm (``PlasticityProblem.force_rtol``'s scale) is accepted as
#: converged instead of cut (``[model] plateau_tolerance``; 0 switches the acceptance off).
#: Frictional contact on a steep non-associated cone leaves Newton on plateaus that no step cut
#: lowers.  An accepted plateau commits a state out of equilibrium by that residual, and on such
#: soil the path does not recover from it; the tolerance lies an order below the plateaus whose
#: acceptance, decided differently by the rounding of two BLAS kernels, set two runs of one scene
#: on different paths.  The residual left is reported
#: (``PlasticityProblem.plateaus``); see docs/limitations.md, "Non-associated flow: Newton stalls".
PLATEAU_RTOL = 1e-4


def check_choice(name: str, value: str, allowed: tuple[str, ...]) -> str:
    """``value`` if it is one of ``allowed``, else a ``ValueError`` naming the option."""
    if value not in allowed:
        raise ValueError(f"{name} must be one of {', '.join(allowed)}, got {value!r}")
    return value


def check_relaxation_length(value: float) -> float:
    """The Duvaut-Lions relaxation length (m) as a float; ``ValueError`` unless it is >= 0."""
    if not value >= 0:
        raise ValueError(f"relaxation_length must be >= 0 (m), got {value}")
    return float(value)
