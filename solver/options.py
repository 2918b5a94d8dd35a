"""Every solver option's choices and default, in one place.

The scene parser (``rollsim.scene``) and the benchmarks import them from here; the solver classes
validate against them.  Names are the scene's spelling (``"plane-strain"``); where the solver's
own functions spell a choice differently, the mapping lives here too (:data:`MATCHING`).
"""
from __future__ import annotations

from rollsim.geometry.mesh import ACCURACY_REFINEMENT

#: loading protocols of ``rollsim run``
PROTOCOLS = ("indentation", "rolling-continuous", "rolling-constant-load")
#: mesh presets (``[model] accuracy``); their element sizes are ``ACCURACY_REFINEMENT`` in
#: ``rollsim.geometry.mesh``
ACCURACIES = tuple(ACCURACY_REFINEMENT)
DEFAULT_ACCURACY = "standard"
#: small strain, or incremental large deformation (``PlasticityProblem(kinematics=...)``)
KINEMATICS = ("small-strain", "updated-lagrangian")
DEFAULT_KINEMATICS = "small-strain"
#: how a rigid wheel rolls (``[model] rolling``): "transient", moved step by step along a block;
#: "steady", the steady state solved directly in the wheel's frame on a window that travels with
#: it (``rollsim.solver.steady``)
ROLLING_METHODS = ("transient", "steady")
DEFAULT_ROLLING_METHOD = "transient"
#: steady rolling: elements per wheel diameter at the contact, per mesh preset (the window's fine
#: cells, d / this; ``[model] refinement`` replaces it)
STEADY_ELEMENTS_PER_D = {"fast": 20.0, "standard": 30.0, "accurate": 40.0}
#: linear solver of the Newton iteration (``PlasticityProblem(linear_solver=...)``): "auto" =
#: direct LU up to ``problem.AUTO_ITERATIVE_DOFS`` dofs, iterative (AMG-preconditioned GMRES) above
LINEAR_SOLVERS = ("auto", "direct", "iterative")
DEFAULT_LINEAR_SOLVER = "auto"
#: volumetric strain of the soil (``PlasticityProblem(volumetric_strain=...)``): "cell-average" =
#: B-bar (the volumetric strain projected per cell - its mean on simplices, a linear function on
#: hexahedra: a few constraints per cell, no locking under isochoric plastic flow),
#: "pointwise" = plain strain at every quadrature point.  The solver classes default to
#: :data:`DEFAULT_VOLUMETRIC_STRAIN`; scenes default per protocol and preset
#: (:func:`default_volumetric_strain`).
VOLUMETRIC_STRAINS = ("cell-average", "pointwise")
DEFAULT_VOLUMETRIC_STRAIN = "pointwise"
#: element type of a rigid wheel's rolling block (``[model] cell_type``): 10-node tetrahedra, or
#: structured 27-node hexahedra whose refined strip can be finer across the wheel's path than
#: along it (B-bar: Q2-P1); indentation blocks are tetrahedral, a pneumatic wheel's hexahedral.
#: Scenes default per preset (:func:`default_cell_type`).
CELL_TYPES = ("tetrahedra", "hexahedra")
#: elements across the wheel's width in a hexahedral rolling block (``[model]
#: elements_across_wheel``): 8, four across the modelled half.  On constant-load rolling the
#: sinkage is set by the elements across the wheel more than by those along it, and on the c-phi
#: soil of case 5 it settles across from this count on (measured: see
#: docs/speed-accuracy-details.md, "Constant-load rolling: mesh convergence").
DEFAULT_ELEMENTS_ACROSS_WHEEL = 8.0
#: a rigid wheel's hexahedral rolling block per mesh preset: (elements per d, elements across the
#: wheel's width, elements per d along the path in the refined strip).  ``standard`` and
#: ``accurate`` roll on it by default (:func:`default_cell_type`); ``accurate`` refines every
#: direction of ``standard`` once more.  With friction the held force and the sinkage at the load
#: still move from 6 to 12 to 24 elements per d along the path, each level at a few times the
#: cost of the one before (measured: see docs/speed-accuracy-details.md, "Along the path").
ROLLING_HEXAHEDRA = {"fast": (6.0, 8.0, 6.0), "standard": (6.0, 8.0, 12.0), "accurate": (8.0, 16.0, 24.0)}
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


def default_volumetric_strain(protocol: str, accuracy: str = DEFAULT_ACCURACY,
                              refinement: float | None = None, wheel: str = "rigid") -> str:
    """The scene default of ``[model] volumetric_strain`` for a loading protocol and mesh preset
    (or ``refinement``, elements per d, when the scene sets it: up to the fast preset's 8 it counts
    as ``fast``).

    Indentation: B-bar ("cell-average"), which removes the locking of the P2 tetrahedra (see
    docs/verification.md, "Mesh convergence of indentation").  Rolling: B-bar on the standard and
    accurate presets, "pointwise" on ``fast``.  On constant-load rolling B-bar's levels converge on
    the case-5 soil, while the pointwise sinkage levels off below them (it locks under the
    isochoric plastic flow); on the fast mesh neither strain reaches screening accuracy on both
    soils, and pointwise costs less and needs no regularisation with friction: it stays the
    screening default there (measured: see
    docs/speed-accuracy-details.md, "Rolling: the findings behind the presets").

    A pneumatic ``wheel``: B-bar always.  Its soil is of hexahedra, where B-bar is the exact
    projection onto linear functions per cell (Q2-P1), while the pointwise strain locks and the
    towed tire on clay sinks markedly less with it (measured: see
    docs/verification.md, "Pneumatic tire on soil")."""
    if wheel == "pneumatic":
        return "cell-average"
    coarse = accuracy == "fast" if refinement is None else refinement <= ACCURACY_REFINEMENT["fast"]
    if protocol == "indentation" or not coarse:
        return "cell-average"
    return "pointwise"


def default_cell_type(accuracy: str = DEFAULT_ACCURACY, refinement: float | None = None) -> str:
    """The scene default of ``[model] cell_type`` for rolling a rigid wheel: hexahedra refined
    across the wheel and along its path (:data:`ROLLING_HEXAHEDRA`) on the ``standard`` and
    ``accurate`` presets, tetrahedra on ``fast`` and wherever the scene sets ``refinement``.

    On constant-load rolling the sinkage is set by the elements across the wheel and, with
    friction, along the path more than by those in depth.  On the case-5 soil B-bar on these
    hexahedra settles across the wheel at a fraction of the cost of the tetrahedral levels that
    come as close, and the tetrahedral ``standard`` (20 per d) is far too dear for rolling
    (measured: see docs/speed-accuracy-details.md, "Constant-load rolling: mesh convergence").
    ``fast`` keeps the tetrahedra, the cheapest run (pointwise, for screening)."""
    if refinement is None and accuracy != "fast":
        return "hexahedra"
    return "tetrahedra"


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
