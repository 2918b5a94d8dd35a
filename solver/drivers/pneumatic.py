"""Drivers of a ``[wheel] type = "pneumatic"`` scene; one mesh of hexahedra for tire and soil.

``protocol = "indentation"`` (quarter model, ``rollsim.solver.pneumatic``): the tire inflated
clear of the soil, lowered until it touches, then pressed by its hub until the sinkage (its lowest
point below the undisturbed surface) reaches ``loading.max_sinkage``, or until the wheel load is
``loading.load`` (``max_sinkage`` then the limit).

``protocol = "rolling-constant-load"`` (half model, ``rollsim.solver.pneumatic_rolling``): the
tire inflated, pressed to ``loading.load`` on the stiff start zone, then towed with that load
on its hub and zero torque on its axle until its sinkage is steady or ``loading.travel`` is
rolled; then lifted off to measure the rut (``rut_profile.csv``), as a rigid wheel.

Besides the common run files: the fields of tire and soil, ``plastic_zone.png`` (the deformed
tire on the soil) and the contact pressure under the tire at the end (``contact_pressure.csv``
and ``.png``)."""
from __future__ import annotations

import dataclasses

from mpi4py import MPI

from rollsim.log import get_logger

from ..materials import NeoHookean
from ..pneumatic import TIRE_PENALTY, PneumaticIndentation
from ..pneumatic_rolling import PneumaticRolling
from ..rolling import STEADY_MIN_TRAVEL
from ..rundir import TravelProgress, write_contact_pressure
from ..scene_model import TIRE_STIFF_LENGTH, pneumatic_mesh
from .base import REPORT_S_OVER_D, ProtocolRun

__all__ = ["run_pneumatic_indentation", "run_pneumatic_rolling", "SINKAGE_STEP", "TRAVEL_STEP"]

log = get_logger("run")

#: the largest sinkage increment aimed at per step, in d
SINKAGE_STEP = 0.004
#: the towed tire's travel step, in soil elements under the tire
TRAVEL_STEP = 0.25


def _tire(scene, run: ProtocolRun, tagged, tire, kind, petsc_options):
    """The scene's tire of class ``kind`` over the soil of ``tagged``, attached to ``run``."""
    w, options = scene.wheel, run.solver_options
    pn = kind(tagged, tire, run.soil.by_layer, NeoHookean(w.E_carcass, w.nu_carcass),
              gamma=options["gamma"], friction=options["friction"],
              penalty=TIRE_PENALTY if options["penalty"] is None else options["penalty"],
              volumetric_strain=options["volumetric_strain"], linear_solver=options["linear_solver"],
              petsc_options=petsc_options)
    run.attach(tagged, pn)
    return pn


def _loaded(run: ProtocolRun, pn) -> dict:
    """The tire's state now (:meth:`PneumaticIndentation.tire_state`) and its contact pressure
    files."""
    tire_state = pn.tire_state()
    gathered = run.comm.gather(pn.contact.contact_points(), root=0)       # (points, areas, pressures) per rank
    if run.root:
        write_contact_pressure(run.out, *zip(*gathered), run.scene.wheel.inflation, tire_state["sinkage_m"])
    return tire_state


def _close(run: ProtocolRun, pn, tire_state: dict | None = None) -> dict:
    """The picture of the deformed tire on the soil (the last field frame) and the tire's state
    with its contact pressure files (``tire_state``: taken before, by :func:`_loaded`; default:
    now); returns the tire's state."""
    tire_state = tire_state or _loaded(run, pn)
    run.close_fields(lambda writer: writer.render_plastic_zone(
        run.out / "plastic_zone.png", f"tire on soil: equivalent plastic strain at s = {tire_state['sinkage_m']:.4f} m"))
    return tire_state


def _files(summary: dict, write_fields: bool) -> None:
    summary["files"].update({"plastic_zone": "plastic_zone.png" if write_fields else None,
                             "contact_pressure": ["contact_pressure.csv", "contact_pressure.png"]})


def run_pneumatic_indentation(scene, out_dir, comm: MPI.Comm, *, progress: bool = True,
                              petsc_options: dict | None = None, write_fields: bool = True,
                              penalty: float | None = None) -> dict:
    """Pneumatic indentation of ``scene`` on ``comm``; writes the run directory ``out_dir`` and
    returns the summary (with a ``tire`` object: :meth:`PneumaticIndentation.tire_state`)."""
    run = ProtocolRun(scene, out_dir, comm, progress=progress, write_fields=write_fields,
                      petsc_options=petsc_options, penalty=penalty)
    d, s_max, w = run.d, scene.loading.max_sinkage, scene.wheel
    tagged, tire = pneumatic_mesh(scene, comm)
    pn = _tire(scene, run, tagged, tire, PneumaticIndentation, petsc_options)
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
    summary = run.summary(status, reason, tire=_close(run, pn))
    _files(summary, write_fields)
    return run.finish(summary, diagnostics)


def run_pneumatic_rolling(scene, out_dir, comm: MPI.Comm, *, progress: bool = True,
                          petsc_options: dict | None = None, write_fields: bool = True,
                          penalty: float | None = None, steady_rtol: float = 0.02, steady_qh_rtol: float = 0.05,
                          steady_min_travel: float | None = None) -> dict:
    """The towed pneumatic tire of ``scene`` at constant load on ``comm`` (steady state as for the
    rigid wheel: ``steady_rtol`` / ``steady_qh_rtol``, looked for after ``steady_min_travel`` m on
    the test soil, default ``STEADY_MIN_TRAVEL`` d); writes the run directory ``out_dir`` and
    returns the summary (steady sinkage and ``Q_H``, the rolling radius, the ``tire`` object)."""
    run = ProtocolRun(scene, out_dir, comm, progress=progress, write_fields=write_fields,
                      petsc_options=petsc_options, penalty=penalty)
    d, load, travel, w = run.d, scene.loading.load, scene.loading.travel, scene.wheel
    tagged, tire = pneumatic_mesh(scene, comm, rolling=True)
    pn = _tire(scene, run, tagged, tire, PneumaticRolling, petsc_options)
    x_soft = TIRE_STIFF_LENGTH * d
    min_travel = STEADY_MIN_TRAVEL * d if steady_min_travel is None else float(steady_min_travel)
    step = TRAVEL_STEP * d / scene.model.elements_per_d
    bar = TravelProgress(travel, d, enabled=progress and run.root)
    outcome = {"steady": None, "loaded": None, "contact_length": 0.0, "lift_failure": None, "lifted": False}

    def on_step(st):
        run.record(st, st.travel, float(len(run.rows) + 1))
        bar.update(st)

    def rolling():
        run.announce(f"inflation {w.inflation / 1e3:g} kPa, Q_V = {load / 1e3:g} kN, travel {travel:g} m")
        pn.gravity_step()
        pn.inflate(w.inflation)
        pn.touch()
        if pn.press_to_load(load, SINKAGE_STEP * d, 0.25 * d, on_step=run.record_sinkage_step) != "ok":
            return f"pressing the tire on the stiff start zone: the load {load:g} N is not carried by a sinkage of d/4"
        steady = outcome["steady"] = pn.roll_at_load(load, travel, step, x_soft=x_soft, steady_rtol=steady_rtol,
                                                     steady_qh_rtol=steady_qh_rtol, min_travel=min_travel,
                                                     on_step=on_step)
        if not steady.reached:
            log.warning("no steady state within the travel of %g m: the values are those of the last step (a "
                        "longer travel or a coarser steady tolerance may help)", travel)
        outcome["loaded"] = _loaded(run, pn)                    # the tire's state before the lift-off
        outcome["contact_length"] = pn.contact_length()
        outcome["lift_failure"] = run.lift_off(pn.lift)
        outcome["lifted"] = outcome["lift_failure"] is None
        return None

    status, reason, diagnostics = run.execute(
        rolling, lambda: {"last_converged_travel_m": pn.travel, "last_converged_sinkage_m": -pn.lowest_point(),
                          "step_cuts_total": pn.cuts})
    steady = outcome["steady"]
    rut = run.measure_rut(pn.surface_profile, x_from=x_soft, x_wheel=pn.position, x_start=pn.x_start, steady=steady,
                          sinkage=pn.roll_steps[-1].sinkage if pn.roll_steps else 0.0,
                          contact_length=outcome["contact_length"]) if outcome["lifted"] else None
    results = {"tire": _close(run, pn, outcome["loaded"]), "travel_m": pn.travel, "rotation_rad": pn.hub_rotation,
               "rolling_radius_m": pn.rolling_radius(x_soft),
               "moment_Nm": pn.roll_steps[-1].moment if pn.roll_steps else 0.0,
               "rut_depth_m": None, "rebound_m": None}
    if steady is not None:
        results.update(steady_state=dataclasses.asdict(steady), sinkage_m=steady.sinkage, QH_N=steady.QH,
                       QV_N=steady.QV)
    summary = run.summary(status, reason, **results)
    run.add_rut(summary, rut, outcome["lift_failure"])
    run.warn_heave(summary, pn.roll_steps, x_soft, pn.x_start)
    summary["model"].update(x_start_m=pn.x_start, stiff_zone_end_m=x_soft, load_rtol=pn.load_rtol,
                            moment_rtol=pn.moment_rtol, steady_rtol=steady_rtol, steady_qh_rtol=steady_qh_rtol,
                            steady_min_travel_m=min_travel, travel_step_m=step)
    _files(summary, write_fields)
    run.plot_travel(summary)
    return run.finish(summary, diagnostics)
