"""``run_scene``: one finite-element simulation of a scene (``rollsim run SCENE.toml --out DIR``).

Builds the soil mesh (``rollsim.geometry``; quarter block for the centred indentation wheel on
horizontally layered soil, forces reported for the whole wheel), the materials of the layers,
the rigid wheel and its frictional contact, runs the loading protocol and writes the run
directory of ``shared/spec/interfaces.md``:

* ``summary.json`` - scene echo (SI, angles in degrees), ``status`` ``"ok"`` | ``"failed"`` (+
  ``reason``), wall time, ranks, dofs, cells, steps, Newton iterations, step cuts, the result
  (``QV_N`` at the final sinkage, ``QV_at_s_over_d``), the model (symmetry, penalty) and, on
  failure, diagnostics;
* ``history.csv`` - one row per converged step (rewritten after every step, so a killed run keeps
  its history);
* ``fields/`` - ``fields.xdmf`` (time series, time = sinkage in m) and ``deformed.xdmf``;
* ``force_sinkage.png``.

Files are written by rank 0 (XDMF collectively) through a temporary name and renamed, so a
reader never sees half a file.  ``summary.json`` is written last.
"""
from __future__ import annotations

import csv
import io
import json
import math
import os
import pathlib
import time
import traceback

import numpy as np
from mpi4py import MPI

from rollsim.log import get_logger

__all__ = ["run_scene", "layer_material", "HISTORY_COLUMNS", "scene_mesh"]

log = get_logger("run")

HISTORY_COLUMNS = ["step", "sinkage_m", "s_over_d", "QV_N", "QH_N", "travel_m", "moment_Nm", "contact_area_m2",
                   "max_penetration_m", "newton_iterations", "cuts", "plastic_points", "wall_time_s"]

#: s/d values at which Q_V is always computed (step boundaries) and reported in summary.json
REPORT_S_OVER_D = (0.01, 0.02, 0.03, 0.05, 0.08, 0.1)

_MATCH = {"compression": "compression", "extension": "extension", "plane-strain": "plane_strain",
          "plane-strain-flow": "plane_strain_flow"}


def layer_material(layer, index: int = 0, *, c_reg: float | None = None):
    """``LayerSpec`` -> ``VonMises`` / ``DruckerPrager`` (SI, radians).

    von Mises: yield stress ``q_y = c_dp`` if given, else from the cohesion ``c`` by the layer's
    ``match`` (compression / extension: ``q_y = 2 c``; plane strain: ``sqrt(3) c``).
    Drucker-Prager: ``phi_dp``/``c_dp``/``dilation`` as given, or matched to ``c``/``phi`` (dilation
    angle mapped with the same matching).  ``mohr-coulomb``: the smoothed (Abbo-Sloan) surface of
    ``solver/smoothed_mc.py`` when available, else a ``ValueError`` naming the layer.

    Purely frictional layers (``c = 0`` or ``c_dp = 0`` with a friction angle > 0) get the
    regularising cohesion ``c_reg`` (Pa; default ``materials.C_REG_DEFAULT``, 1 kPa; the scene's
    ``[model] regularising_cohesion``) in its place, with a warning in the log (README, "Purely
    frictional soil (c = 0) under the wheel": the measured effect on Q_V); ``c_reg = 0`` keeps
    c = 0 (not for mohr-coulomb, whose rounded tip needs c > 0: ``ValueError`` naming the layer).
    """
    from .materials import (C_REG_DEFAULT, PHI_COMPRESSION_MATCH_LIMIT, DruckerPrager, VonMises, mc_to_dp,
                            regularised_cohesion)
    key = f"soil.layers[{index}]"
    c_reg = C_REG_DEFAULT if c_reg is None else float(c_reg)
    c, c_dp = layer.c, layer.c_dp
    if layer.model in ("drucker-prager", "mohr-coulomb"):
        angle = layer.phi_dp if (layer.model == "drucker-prager" and layer.phi_dp is not None) else layer.phi
        reg = False
        if c_reg == 0:
            if layer.model == "mohr-coulomb" and c == 0:
                raise ValueError(f"{key}.c: the smoothed Mohr-Coulomb needs c > 0 (its rounded tip); with "
                                 "model.regularising_cohesion = 0 use drucker-prager for c = 0")
        elif angle is not None and layer.model == "drucker-prager" and layer.phi_dp is not None and c_dp is not None:
            c_dp, reg = regularised_cohesion(c_dp, angle, c_reg)
        elif angle is not None and c is not None:
            c, reg = regularised_cohesion(c, angle, c_reg)
        if reg:
            log.warning("%s: c = 0 (purely frictional) -> regularising cohesion %g Pa used (numerical device; it "
                        "raises Q_V markedly: at s/d = 0.1, +60 %% pointwise and +97 %% B-bar for 1 kPa, phi = 40 deg; "
                        "model.regularising_cohesion = 0 keeps c = 0; README, \"Purely frictional soil\")", key, c_reg)
        if (layer.model == "drucker-prager" and layer.phi_dp is None and layer.phi is not None
                and _MATCH.get(layer.match) == "compression" and layer.phi > PHI_COMPRESSION_MATCH_LIMIT):
            log.warning("%s: compression-matched Drucker-Prager with phi = %.1f deg > 36.87 deg is stronger in "
                        "triaxial extension than any Mohr-Coulomb soil and converges poorly with psi = 0; "
                        "match = 'plane-strain' is recommended", key, math.degrees(layer.phi))
    if layer.model == "von-mises":
        q_y = layer.c_dp if layer.c_dp is not None else mc_to_dp(layer.c, 0.0, _MATCH[layer.match])[1]
        return VonMises(E=layer.E, nu=layer.nu, yield_stress=q_y)
    if layer.model == "drucker-prager":
        if layer.phi_dp is not None:
            return DruckerPrager(E=layer.E, nu=layer.nu, phi_dp=layer.phi_dp, c_dp=c_dp,
                                 dilation=layer.dilation)
        return DruckerPrager.from_mohr_coulomb(layer.E, layer.nu, c, layer.phi, psi=layer.dilation,
                                               matching=_MATCH[layer.match])
    if layer.model == "mohr-coulomb":
        try:
            from .smoothed_mc import SmoothedMohrCoulomb
            return SmoothedMohrCoulomb(E=layer.E, nu=layer.nu, c=c, phi=layer.phi, dilation=layer.dilation)
        except (ImportError, TypeError) as err:
            raise ValueError(f"{key}.model: 'mohr-coulomb' is not available in the finite-element solver "
                             f"({err}); use von-mises or drucker-prager") from None
    raise ValueError(f"{key}.model: {layer.model!r} is not available in the finite-element solver "
                     "(use von-mises, drucker-prager or mohr-coulomb)")


def frictional_layers(scene) -> dict:
    """``{"soil.layers[i]": layer}``: the purely frictional layers (c = 0, friction angle > 0)."""
    out = {}
    for i, layer in enumerate(scene.soil.layers):
        if layer.model == "drucker-prager" and layer.phi_dp is not None:
            c, angle = layer.c_dp, layer.phi_dp
        else:
            c, angle = layer.c, layer.phi
        if layer.model != "von-mises" and c == 0 and angle is not None and angle > 0:
            out[f"soil.layers[{i}]"] = layer
    return out


def regularised_layers(scene) -> dict:
    """``{"soil.layers[i]": c_reg (Pa)}`` for the purely frictional layers that ``layer_material``
    gives the scene's regularising cohesion (reported in summary.json: it raises Q_V markedly);
    none when ``[model] regularising_cohesion`` is 0."""
    c_reg = scene.model.regularising_cohesion
    return {key: c_reg for key in frictional_layers(scene)} if c_reg > 0 else {}


#: penalty alpha for scenes with a purely frictional layer (c = 0, regularised): about 3x faster
#: than the default alpha = 10 there, measured (README, "Purely frictional soil under the wheel")
FRICTIONAL_PENALTY = 1.0


def scene_penalty(scene, penalty: float | None) -> float | None:
    """The contact penalty alpha for ``scene``: ``penalty`` if given, :data:`FRICTIONAL_PENALTY`
    when a layer is purely frictional (see :func:`frictional_layers`), else None (the default)."""
    frictional = frictional_layers(scene)
    if penalty is not None or not frictional:
        return penalty
    log.info("purely frictional layer(s) %s: contact penalty alpha = %g (pass penalty to override)",
             ", ".join(frictional), FRICTIONAL_PENALTY)
    return FRICTIONAL_PENALTY


def model_summary(scene, wheel_run) -> dict:
    """The ``model`` entry of ``summary.json`` shared by indentation and rolling runs: symmetry,
    mesh preset, element degree, kinematics, contact, the Duvaut-Lions relaxation length and, when
    used, the regularising cohesion.
    ``wheel_run``: a :class:`WheelIndentation` or :class:`WheelRolling` (``factor``, ``problem``,
    ``contact``)."""
    ct = wheel_run.contact
    model = {"symmetry": {4: "quarter", 2: "half", 1: "full"}[wheel_run.factor],
             "symmetry_factor": wheel_run.factor, "accuracy": scene.model.accuracy,
             "displacement_degree": wheel_run.problem.degree, "kinematics": wheel_run.problem.kinematics,
             "linear_solver": wheel_run.problem.linear_solver,
             "volumetric_strain": wheel_run.problem.volumetric_strain,
             "contact": {"method": "penalty", "alpha": ct.alpha, "kappa_Pa_per_m": ct.kappa, "h_m": ct.h,
                         "friction": ct.friction},
             "relaxation_length_m": wheel_run.relaxation_length}
    regularised = regularised_layers(scene)
    if regularised:
        model["regularising_cohesion_Pa"] = regularised
    return model


#: Duvaut-Lions relaxation length the failure hint suggests, by protocol (m of the wheel's path):
#: rolling 1 mm (sand cases 13-15), indentation 0.01 mm (c = 0, phi = 40 deg: README, "Purely
#: frictional soil (c = 0) under the wheel")
SUGGESTED_RELAXATION_LENGTH = {"indentation": "0.01 mm", "rolling": "1 mm"}


def non_associated(materials) -> bool:
    """Any frictional material (``{tag: material}`` or one) whose dilation is below its friction angle."""
    mats = materials.values() if isinstance(materials, dict) else [materials]
    return any(getattr(m, "tan_phi", 0.0) > getattr(m, "tan_psi", 0.0) * (1 + 1e-12) for m in mats)


def relaxation_hint(materials, scene) -> str:
    """What to append to a failed run's reason: the Duvaut-Lions remedy when the soil's flow is
    non-associated and the scene does not regularise it yet, and the regularising cohesion when
    the scene keeps c = 0; else ""."""
    hint = ""
    if scene.model.relaxation_length == 0 and non_associated(materials):
        length = SUGGESTED_RELAXATION_LENGTH["indentation" if scene.loading.protocol == "indentation" else "rolling"]
        hint += ("; the soil's flow is non-associated (dilation below the friction angle), whose Newton tangent can "
                 f"be near-singular: [model] relaxation_length = \"{length}\" (Duvaut-Lions regularisation; its bias "
                 "is first order in the length, so compare with half of it) may let the run converge")
    if scene.model.regularising_cohesion == 0 and frictional_layers(scene):
        hint += ("; c = 0 is kept exactly (model.regularising_cohesion = 0): the default \"1 kPa\" runs more often "
                 "but raises Q_V markedly (README, \"Purely frictional soil\")")
    return hint


def scene_mesh(scene, comm: MPI.Comm):
    """Quarter indentation block for the scene (layers from the scene, accuracy preset)."""
    from rollsim.geometry import MeshOptions, build_soil_block, indentation_block
    d = scene.wheel.diameter
    thick = [layer.thickness for layer in scene.soil.layers[:-1]]
    depth = max(1.5, sum(thick) / d + 0.5)
    block = indentation_block(d, depth=depth, cut="quarter", layers=tuple(t / d for t in thick))
    return build_soil_block(comm, block, MeshOptions.from_accuracy(d, scene.model.accuracy))


def _wheel(spec):
    from rollsim.geometry import CylinderWheel, TorusWheel
    if spec.type != "rigid":
        raise ValueError(f"wheel.type: {spec.type!r} wheels are not available in the finite-element solver "
                         "yet (use rigid)")
    if spec.shape == "torus":
        return TorusWheel(spec.diameter, spec.width)
    return CylinderWheel(spec.diameter, spec.width, spec.fillet)


def run_setup(scene, out_dir, comm) -> tuple:
    """(wheel, per-layer materials {layer id: material}, output directory) of a scene run; rank 0
    makes the directory with its ``fields/`` and every rank waits for it."""
    wheel = _wheel(scene.wheel)
    materials = {k: layer_material(layer, k - 1, c_reg=scene.model.regularising_cohesion)
                 for k, layer in enumerate(scene.soil.layers, start=1)}
    out = pathlib.Path(out_dir)
    if comm.rank == 0:
        (out / "fields").mkdir(parents=True, exist_ok=True)
    comm.barrier()
    return wheel, materials, out


def _atomic_write(path: pathlib.Path, data, binary: bool = False) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    with open(tmp, "wb" if binary else "w") as f:
        f.write(data)
    os.replace(tmp, path)


def _history_csv(rows) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=HISTORY_COLUMNS, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: (f"{v:.10g}" if isinstance(v, float) else v) for k, v in r.items()})
    return buf.getvalue()


def _plot(path: pathlib.Path, rows, scene, status: str) -> None:
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    d = scene.wheel.diameter
    s = [0.0] + [r["sinkage_m"] for r in rows]
    q = [0.0] + [r["QV_N"] / 1e3 for r in rows]
    fig, ax = plt.subplots(figsize=(6, 4.2))
    ax.plot(s, q, "o-", ms=3, label=f"FE indentation ({scene.model.accuracy})")
    ax.set_xlabel("sinkage s (m)")
    ax.set_ylabel("Q_V (kN)")
    ax.grid(alpha=0.3)
    sec = ax.secondary_xaxis("top", functions=(lambda x: x / d, lambda r: r * d))
    sec.set_xlabel("s/d")
    ax.set_title(f"rigid {scene.wheel.shape} d = {d:g} m, b = {scene.wheel.width:g} m"
                 + ("" if status == "ok" else f"  [{status}]"), fontsize=10)
    ax.legend(loc="lower right")
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=120)
    plt.close(fig)
    _atomic_write(path, buf.getvalue(), binary=True)


def history_row(st, d: float, travel: float, t_start: float) -> dict:
    """The ``history.csv`` row (:data:`HISTORY_COLUMNS`) of a converged indentation or rolling step."""
    return {"step": st.step, "sinkage_m": st.sinkage, "s_over_d": st.sinkage / d, "QV_N": st.QV, "QH_N": st.QH,
            "travel_m": travel, "moment_Nm": st.moment, "contact_area_m2": st.contact_area,
            "max_penetration_m": st.max_penetration, "newton_iterations": st.iterations, "cuts": st.cuts,
            "plastic_points": st.plastic, "wall_time_s": time.perf_counter() - t_start}


def run_protected(body, comm: MPI.Comm, state) -> tuple[str, str, dict]:
    """Run a protocol, ``body()``, so that it never hangs or raises: ``(status, reason, diagnostics)``.

    Signals stop it at a step boundary (``"interrupted"``); a solver failure or any exception gives
    ``"failed"`` with the reason; ``body`` may also return a failure reason itself.  ``state()``
    gives the diagnostics of the last converged state.  All ranks agree on the outcome (a
    rank-local exception would otherwise hang the others)."""
    from .stepping import RunInterrupted, SolverDivergedError, stop_on_signals
    status, reason, diagnostics = "ok", "", {}
    try:
        with stop_on_signals():
            why = body()
        if why:
            status, reason = "failed", why
    except RunInterrupted as err:
        status, reason = "interrupted", str(err)
        diagnostics = {"signal": err.signal_name, **state()}
        log.warning("run interrupted: %s", reason)
    except SolverDivergedError as err:
        status, reason = "failed", str(err)
        hist = getattr(err, "history", None) or []
        diagnostics = {**state(), "last_step_residual_norms": list(hist[-1].residual_norms) if hist else []}
        log.warning("run failed: %s", reason)
    except Exception as err:          # noqa: BLE001 - report, never hang
        status, reason = "failed", f"{type(err).__name__}: {err}"
        diagnostics = {"traceback": traceback.format_exc()}
        log.error("run failed: %s", reason)
    if "failed" in comm.allgather(status) and status != "failed":
        status, reason = "failed", "failed on another rank"
    return status, reason, diagnostics


def run_scene(scene, out_dir, comm: MPI.Comm, *, progress: bool = True, petsc_options: dict | None = None,
              write_fields: bool = True, penalty: float | None = None) -> dict:
    """Run ``scene`` on ``comm`` and write the run directory ``out_dir``; returns the summary dict.

    Only ``loading.protocol = "indentation"`` is available here (rolling protocols: ``ValueError``
    naming the key).  A solver failure after step cutting does not raise: the summary has
    ``status = "failed"`` and ``reason``, and the last converged state is written.
    """
    from .indentation import WheelIndentation

    if scene.loading.protocol.startswith("rolling"):
        from .rolling import run_rolling
        return run_rolling(scene, out_dir, comm, progress=progress, petsc_options=petsc_options,
                           write_fields=write_fields, penalty=penalty)
    if scene.loading.protocol != "indentation":
        raise ValueError(f"loading.protocol: {scene.loading.protocol!r} is not supported by run_scene; "
                         "supported: 'indentation', 'rolling-continuous', 'rolling-constant-load'")
    wheel, materials, out = run_setup(scene, out_dir, comm)
    root = comm.rank == 0
    t_start = time.perf_counter()
    d = scene.wheel.diameter
    s_max = scene.loading.max_sinkage

    tagged = scene_mesh(scene, comm)
    mats = materials if len(materials) > 1 else materials[1]
    ind = WheelIndentation(tagged, wheel, mats, gamma=scene.soil.gamma, friction=scene.wheel.friction,
                           petsc_options=petsc_options, penalty=scene_penalty(scene, penalty),
                           kinematics=scene.model.kinematics, linear_solver=scene.model.linear_solver,
                           volumetric_strain=scene.model.volumetric_strain,
                           relaxation_length=scene.model.relaxation_length)
    writer = None
    if write_fields:
        from .fields import FieldWriter
        writer = FieldWriter(ind.problem, out / "fields", cell_tags=tagged.cell_tags)
    rows: list[dict] = []

    def on_step(st):
        rows.append(history_row(st, d, 0.0, t_start))
        if writer is not None:
            writer.write(st.sinkage)
        if root:
            _atomic_write(out / "history.csv", _history_csv(rows))
            if progress:
                log.info("step %3d  s = %.5f m (s/d = %.4f)  Q_V = %10.2f kN  Newton its %d", st.step, st.sinkage,
                         st.sinkage / d, st.QV / 1e3, st.iterations)

    def indentation():
        if progress and root:
            log.info("indentation: %s wheel d = %g m, %d layer(s), %s mesh: %d cells, %d dofs, %s strain, %d rank(s)",
                     scene.wheel.shape, d, len(materials), scene.model.accuracy, tagged.stats.cells, ind.n_dofs,
                     scene.model.volumetric_strain, comm.size)
        ind.gravity_step()
        stops = [r * d for r in REPORT_S_OVER_D if r * d < s_max]
        ind.push(s_max, stops=stops, on_step=on_step)

    status, reason, diagnostics = run_protected(
        indentation, comm, lambda: {"last_converged_sinkage_m": ind.sinkage, "step_cuts_total": ind.cuts})
    if status == "failed":
        reason += relaxation_hint(materials, scene)
    if writer is not None:
        try:
            writer.write_deformed()
            writer.render_plastic_zone(out / "plastic_zone.png",
                                       f"equivalent plastic strain at s = {rows[-1]['sinkage_m'] if rows else 0:.4f} m")
        except Exception as err:  # noqa: BLE001 - a picture must not lose the run
            log.warning("plastic-zone picture failed: %s", err)
        finally:
            writer.close()

    wall = comm.allreduce(time.perf_counter() - t_start, op=MPI.MAX)
    qv_at = {}
    for r in REPORT_S_OVER_D:
        hit = [row["QV_N"] for row in rows if abs(row["s_over_d"] - r) < 1e-9]
        if hit:
            qv_at[f"{r:g}"] = hit[0]
    summary = {
        "status": status,
        "reason": reason,
        "protocol": scene.loading.protocol,
        "scene": scene.to_dict(),
        "wall_time_s": wall,
        "ranks": comm.size,
        "dofs": ind.n_dofs,
        "cells": tagged.stats.cells,
        "steps": len(rows),
        "newton_iterations": ind.newton_iterations,
        "step_cuts": ind.cuts,
        "sinkage_m": rows[-1]["sinkage_m"] if rows else 0.0,
        "QV_N": rows[-1]["QV_N"] if rows else 0.0,
        "QH_N": rows[-1]["QH_N"] if rows else 0.0,
        "max_QV_N": max((row["QV_N"] for row in rows), default=0.0),
        "QV_at_s_over_d": qv_at,
        "model": model_summary(scene, ind),
        "files": {"history": "history.csv", "fields": ["fields/fields.xdmf", "fields/deformed.xdmf"]
                  if write_fields else [], "plot": "force_sinkage.png",
                  "plastic_zone": "plastic_zone.png" if write_fields else None},
    }
    if diagnostics:
        summary["diagnostics"] = diagnostics
    return finish_run(out, rows, scene, summary, comm, progress=progress)


def finish_run(out: pathlib.Path, rows, scene, summary: dict, comm: MPI.Comm, *, progress: bool) -> dict:
    """Write history.csv, the force-sinkage plot and summary.json (last) from rank 0; returns ``summary``."""
    if comm.rank == 0:
        _atomic_write(out / "history.csv", _history_csv(rows))
        try:
            _plot(out / "force_sinkage.png", rows, scene, summary["status"])
        except Exception as err:   # noqa: BLE001 - a plot must not lose the run
            log.warning("force-sinkage plot failed: %s", err)
        _atomic_write(out / "summary.json", json.dumps(summary, indent=2, default=_json_default) + "\n")
        if progress:
            log.info("%s: %d steps, %d Newton iterations, %.1f s -> %s", summary["status"], len(rows),
                     summary["newton_iterations"], summary["wall_time_s"], out)
    comm.barrier()
    return summary


def _json_default(obj):
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return str(obj)
