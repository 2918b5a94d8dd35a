"""``run_scene``: one finite-element simulation of a scene (``rollsim run SCENE.toml --out DIR``).

The protocol's driver (``rollsim.solver.drivers``) builds the soil mesh, the materials of the
layers, the rigid wheel and its frictional contact from the scene (``rollsim.solver.scene_model``),
runs the loading and writes the run directory (``rollsim.solver.rundir``; format: docs/cli.md).
A rigid wheel with ``[model] rolling = "steady"`` rolls in its own frame instead
(``rollsim.solver.drivers.steady_rolling``).
"""
from __future__ import annotations

from mpi4py import MPI

from .drivers import DRIVERS
from .drivers.steady_rolling import run_steady

__all__ = ["run_scene"]

def run_scene(scene, out_dir, comm: MPI.Comm, **options) -> dict:
    """Run ``scene`` on ``comm`` and write the run directory ``out_dir``; returns the summary dict.

    ``options``: keywords of the protocol's driver (all take ``progress``, ``petsc_options``,
    ``write_fields`` and ``penalty``).  A solver failure after step cutting does not raise: the
    summary has ``status = "failed"`` and ``reason``, and the last converged state is written.
    """
    protocol = scene.loading.protocol
    if protocol not in DRIVERS:
        raise ValueError(f"loading.protocol: {protocol!r} is not supported; supported: {', '.join(DRIVERS)}")
    if scene.model.rolling == "steady":
        return run_steady(scene, out_dir, comm, **options)
    return DRIVERS[protocol](scene, out_dir, comm, **options)
