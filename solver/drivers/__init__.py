"""One driver per loading protocol of ``rollsim run``; :data:`DRIVERS` maps the scene's
``loading.protocol`` to it.  Each takes ``(scene, out_dir, comm, **options)``, writes the run
directory and returns the summary."""
from .indentation import run_indentation
from .rolling_constant_load import run_constant_load
from .rolling_continuous import run_continuous

DRIVERS = {"indentation": run_indentation, "rolling-continuous": run_continuous,
           "rolling-constant-load": run_constant_load}

__all__ = ["DRIVERS", "run_indentation", "run_continuous", "run_constant_load"]
