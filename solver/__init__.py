"""rollsim.solver: elastoplastic soil constitutive core and nonlinear (SNES Newton) solver.

Public API::

    from rollsim.solver import (VonMises, DruckerPrager, mc_to_dp, dp_to_mc, von_mises_from_tresca,
                                return_map, PlasticityProblem, StepControl, solve_load_path,
                                SolverDivergedError, StripFooting, strip_footing_mesh, prandtl_nc,
                                RigidWheelContact, Circle, WheelIndentation, run_scene, FieldWriter)

DOLFINx-dependent parts are imported lazily so that the constitutive code (numpy only) can be
used without DOLFINx.
"""
from .materials import VonMises, DruckerPrager, mc_to_dp, dp_to_mc, von_mises_from_tresca  # noqa: F401
from .return_map import (return_map, ReturnResult, elastic_stiffness, yield_function,  # noqa: F401
                         invariants, ELASTIC, PLASTIC, APEX)
from .materials import jaky_k0, admissible_k0, NeoHookean  # noqa: F401
from .smoothed_mc import SmoothedMohrCoulomb, mohr_coulomb_exact  # noqa: F401

_LAZY = {
    "PlasticityProblem": "problem", "NewtonReport": "problem", "mandel_strain": "problem",
    "StepControl": "stepping", "StepRecord": "stepping", "ConvergedState": "stepping",
    "SolverDivergedError": "stepping", "solve_load_path": "stepping", "RunInterrupted": "stepping",
    "stop_on_signals": "stepping",
    "StripFooting": "footing", "FootingResult": "footing", "strip_footing_mesh": "footing",
    "prandtl_nc": "footing",
    "RigidWheelContact": "contact", "Circle": "contact", "WheelForces": "contact",
    "WheelIndentation": "indentation", "IndentationStep": "indentation", "LoadControlResult": "indentation",
    "WheelRolling": "rolling", "RollingStep": "rolling", "SteadyState": "rolling",
    "run_scene": "run", "FieldWriter": "fields", "DRIVERS": "drivers",
    "Carcass": "carcass", "FacetContact": "contact_pair", "PneumaticIndentation": "pneumatic",
    "PneumaticRolling": "pneumatic_rolling",
    "SteadyRolling": "steady", "RollingWindow": "steady", "rolling_window_mesh": "steady",
    "NoSteadyState": "steady",
}


def __getattr__(name):
    if name in _LAZY:
        import importlib
        return getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["VonMises", "DruckerPrager", "mc_to_dp", "dp_to_mc", "von_mises_from_tresca", "return_map",
           "ReturnResult", "elastic_stiffness", "yield_function", "invariants", "ELASTIC", "PLASTIC",
           "APEX", "jaky_k0", "admissible_k0", "NeoHookean", "SmoothedMohrCoulomb", "mohr_coulomb_exact", *_LAZY]
