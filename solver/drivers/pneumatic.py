"""Driver of ``protocol = "indentation"`` with ``[wheel] type = "pneumatic"``: the tire inflated
clear of the soil, lowered until it touches, then pressed by its hub until the sinkage (its lowest
point below the undisturbed surface) reaches ``loading.max_sinkage``; quarter model, one mesh of
hexahedra for tire and soil (``rollsim.solver.pneumatic``)."""
from __future__ import annotations

from mpi4py import MPI

from rollsim.log import get_logger

from ..materials import NeoHookean
from ..pneumatic import TIRE_PENALTY, PneumaticIndentation
from ..scene_model import pneumatic_mesh
from .base import REPORT_S_OVER_D, ProtocolRun

__all__ = ["run_pneumatic_indentation", "SINKAGE_STEP"]

log = get_logger("run")

#: the largest sinkage increment aimed at per step, in d
SINKAGE_STEP = 0.004


def run_pneumatic_indentation(scene, out_dir, comm: MPI.Comm, *, progress: bool = True,
                              petsc_options: dict | None = None, write_fields: bool = True,
                              penalty: float | None = None) -> dict:
    """Pneumatic indentation of ``scene`` on ``comm``; writes the run directory ``out_dir`` and
    returns the summary (with a ``tire`` object: :meth:`PneumaticIndentation.tire_state`).  Fields
    are not written for the tire yet (``write_fields`` is ignored, with a note in the log)."""
    run = ProtocolRun(scene, out_dir, comm, progress=progress, write_fields=False, petsc_options=petsc_options,
                      penalty=penalty)
    if write_fields and progress and run.root:
        log.info("pneumatic tire: the field files are not written for the tire yet")
    d, s_max, w = run.d, scene.loading.max_sinkage, scene.wheel
    tagged, tire = pneumatic_mesh(scene, comm)
    options = run.solver_options
    pn = PneumaticIndentation(tagged, tire, run.soil.by_layer, NeoHookean(w.E_carcass, w.nu_carcass),
                              gamma=options["gamma"], friction=options["friction"],
                              penalty=TIRE_PENALTY if options["penalty"] is None else options["penalty"],
                              volumetric_strain=options["volumetric_strain"], linear_solver=options["linear_solver"],
                              petsc_options=petsc_options)
    run.attach(tagged, pn)

    def indentation():
        run.announce(f"inflation {w.inflation / 1e3:g} kPa, then s -> {s_max:g} m")
        pn.gravity_step()
        pn.inflate(w.inflation)
        pn.touch()
        pn.press_to_sinkage(s_max, SINKAGE_STEP * d, stops=[r * d for r in REPORT_S_OVER_D if r * d < s_max],
                            on_step=run.record_sinkage_step)

    status, reason, diagnostics = run.execute(
        indentation, lambda: {"last_converged_sinkage_m": -pn.lowest_point(), "step_cuts_total": pn.cuts})
    summary = run.summary(status, reason, tire=pn.tire_state())
    return run.finish(summary, diagnostics)
