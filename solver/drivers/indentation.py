"""Driver of ``protocol = "indentation"``: the wheel pushed vertically into the soil to
``loading.max_sinkage`` (quarter block), the whole ``Q_V(s)`` curve recorded."""
from __future__ import annotations

from mpi4py import MPI

from ..indentation import WheelIndentation
from ..scene_model import indentation_mesh
from .base import REPORT_S_OVER_D, ProtocolRun
from .pneumatic import run_pneumatic_indentation

__all__ = ["run_indentation", "REPORT_S_OVER_D"]


def run_indentation(scene, out_dir, comm: MPI.Comm, *, progress: bool = True, petsc_options: dict | None = None,
                    write_fields: bool = True, penalty: float | None = None) -> dict:
    """Indentation of ``scene`` on ``comm``; writes the run directory ``out_dir`` and returns the
    summary.  A solver failure after step cutting does not raise: the summary has ``status =
    "failed"`` and ``reason``, and the last converged state is written."""
    if scene.wheel.type == "pneumatic":
        return run_pneumatic_indentation(scene, out_dir, comm, progress=progress, write_fields=write_fields,
                                         petsc_options=petsc_options, penalty=penalty)
    run = ProtocolRun(scene, out_dir, comm, progress=progress, write_fields=write_fields,
                      petsc_options=petsc_options, penalty=penalty)
    d, s_max = run.d, scene.loading.max_sinkage
    tagged = indentation_mesh(scene, comm)
    ind = WheelIndentation(tagged, run.wheel, run.soil.single_or_dict, **run.solver_options)
    run.attach(tagged, ind)

    def indentation():
        run.announce(f"s -> {s_max:g} m")
        ind.gravity_step()
        ind.push(s_max, stops=[r * d for r in REPORT_S_OVER_D if r * d < s_max], on_step=run.record_sinkage_step)

    status, reason, diagnostics = run.execute(
        indentation, lambda: {"last_converged_sinkage_m": ind.sinkage, "step_cuts_total": ind.cuts})
    final_s = run.rows[-1]["sinkage_m"] if run.rows else 0.0
    run.close_fields(lambda writer: writer.render_plastic_zone(
        run.out / "plastic_zone.png", f"equivalent plastic strain at s = {final_s:.4f} m"))
    qv_at = {}
    for r in REPORT_S_OVER_D:
        hit = [row["QV_N"] for row in run.rows if abs(row["s_over_d"] - r) < 1e-9]
        if hit:
            qv_at[f"{r:g}"] = hit[0]
    summary = run.summary(status, reason, QV_at_s_over_d=qv_at)
    summary["files"]["plastic_zone"] = "plastic_zone.png" if write_fields else None
    return run.finish(summary, diagnostics)
