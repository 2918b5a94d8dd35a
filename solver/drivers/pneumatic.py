"""Driver of ``protocol = "indentation"`` with ``[wheel] type = "pneumatic"``: the tire inflated
clear of the soil, lowered until it touches, then pressed by its hub until the sinkage (its lowest
point below the undisturbed surface) reaches ``loading.max_sinkage``, or until the wheel load is
``loading.load`` (``max_sinkage`` then the limit); quarter model, one mesh of
hexahedra for tire and soil (``rollsim.solver.pneumatic``).  Besides the common run files:
the fields of tire and soil, ``plastic_zone.png`` (the deformed tire on the soil) and the contact
pressure under the tire at the end (``contact_pressure.csv`` and ``.png``)."""
from __future__ import annotations

from mpi4py import MPI

from ..materials import NeoHookean
from ..pneumatic import TIRE_PENALTY, PneumaticIndentation
from ..rundir import write_contact_pressure
from ..scene_model import pneumatic_mesh
from .base import REPORT_S_OVER_D, ProtocolRun

__all__ = ["run_pneumatic_indentation", "SINKAGE_STEP"]

#: the largest sinkage increment aimed at per step, in d
SINKAGE_STEP = 0.004


def run_pneumatic_indentation(scene, out_dir, comm: MPI.Comm, *, progress: bool = True,
                              petsc_options: dict | None = None, write_fields: bool = True,
                              penalty: float | None = None) -> dict:
    """Pneumatic indentation of ``scene`` on ``comm``; writes the run directory ``out_dir`` and
    returns the summary (with a ``tire`` object: :meth:`PneumaticIndentation.tire_state`)."""
    run = ProtocolRun(scene, out_dir, comm, progress=progress, write_fields=write_fields,
                      petsc_options=petsc_options, penalty=penalty)
    d, s_max, w = run.d, scene.loading.max_sinkage, scene.wheel
    tagged, tire = pneumatic_mesh(scene, comm)
    options = run.solver_options
    pn = PneumaticIndentation(tagged, tire, run.soil.by_layer, NeoHookean(w.E_carcass, w.nu_carcass),
                              gamma=options["gamma"], friction=options["friction"],
                              penalty=TIRE_PENALTY if options["penalty"] is None else options["penalty"],
                              volumetric_strain=options["volumetric_strain"], linear_solver=options["linear_solver"],
                              petsc_options=petsc_options)
    run.attach(tagged, pn)

    load = scene.loading.load

    def indentation():
        run.announce(f"inflation {w.inflation / 1e3:g} kPa, then "
                     + (f"Q -> {load / 1e3:g} kN (s <= {s_max:g} m)" if load else f"s -> {s_max:g} m"))
        pn.gravity_step()
        pn.inflate(w.inflation)
        pn.touch()
        if not load:
            pn.press_to_sinkage(s_max, SINKAGE_STEP * d, stops=[r * d for r in REPORT_S_OVER_D if r * d < s_max],
                                on_step=run.record_sinkage_step)
            return None
        if pn.press_to_load(load, SINKAGE_STEP * d, s_max, on_step=run.record_sinkage_step) != "ok":
            return (f"the wheel load {load:g} N is not carried by max_sinkage = {s_max:g} m (Q = "
                    f"{pn.wheel_load():.4g} N there): raise loading.max_sinkage or lower loading.load")
        return None

    status, reason, diagnostics = run.execute(
        indentation, lambda: {"last_converged_sinkage_m": -pn.lowest_point(), "step_cuts_total": pn.cuts})
    tire_state = pn.tire_state()
    run.close_fields(lambda writer: writer.render_plastic_zone(
        run.out / "plastic_zone.png", f"tire on soil: equivalent plastic strain at s = {tire_state['sinkage_m']:.4f} m"))
    gathered = comm.gather(pn.contact.contact_points(), root=0)       # (points, areas, pressures) per rank
    if run.root:
        write_contact_pressure(run.out, *zip(*gathered), w.inflation, tire_state["sinkage_m"])
    summary = run.summary(status, reason, tire=tire_state)
    summary["files"].update({"plastic_zone": "plastic_zone.png" if write_fields else None,
                             "contact_pressure": ["contact_pressure.csv", "contact_pressure.png"]})
    return run.finish(summary, diagnostics)
