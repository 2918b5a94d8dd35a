"""The run directory written by ``rollsim run`` (format: docs/cli.md, "Run directory").

* ``summary.json`` - scene echo (SI, angles in degrees), ``status`` ``"ok"`` | ``"failed"`` |
  ``"interrupted"`` (+ ``reason``), wall time, ranks, dofs, cells, steps, Newton iterations, step
  cuts, the results, the model as applied (symmetry, mesh preset, strain, contact, regularisation)
  and, on failure, diagnostics; written last;
* ``history.csv`` - one row per converged step (:data:`HISTORY_COLUMNS`; rewritten after every
  step, so a killed run keeps its history);
* ``fields/`` - XDMF time series and the deformed mesh (``rollsim.solver.fields``);
* ``force_sinkage.png`` and, for rolling, ``rolling.png`` (sinkage and forces against travel).

Files are written by rank 0 (XDMF collectively) through ``rollsim.files``, so a reader never sees
half a file.  :class:`TravelProgress` prints the progress of rolling runs.
"""
from __future__ import annotations

import collections
import csv
import io
import json
import math
import pathlib
import time

import numpy as np
from mpi4py import MPI

from rollsim.files import atomic_write_bytes, atomic_write_text
from rollsim.log import get_logger

__all__ = ["HISTORY_COLUMNS", "history_row", "history_csv", "make_run_directory", "write_history",
           "finish_run", "plot_force_sinkage", "plot_travel", "json_default", "TravelProgress"]

log = get_logger("run")

HISTORY_COLUMNS = ["step", "sinkage_m", "s_over_d", "QV_N", "QH_N", "travel_m", "moment_Nm", "contact_area_m2",
                   "max_penetration_m", "newton_iterations", "cuts", "plastic_points", "wall_time_s"]


def make_run_directory(out_dir, comm: MPI.Comm) -> pathlib.Path:
    """The run directory with its ``fields/``, made by rank 0; every rank waits for it."""
    out = pathlib.Path(out_dir)
    if comm.rank == 0:
        (out / "fields").mkdir(parents=True, exist_ok=True)
    comm.barrier()
    return out


def history_row(st, d: float, travel: float, t_start: float) -> dict:
    """The ``history.csv`` row (:data:`HISTORY_COLUMNS`) of a converged indentation or rolling step."""
    return {"step": st.step, "sinkage_m": st.sinkage, "s_over_d": st.sinkage / d, "QV_N": st.QV, "QH_N": st.QH,
            "travel_m": travel, "moment_Nm": st.moment, "contact_area_m2": st.contact_area,
            "max_penetration_m": st.max_penetration, "newton_iterations": st.iterations, "cuts": st.cuts,
            "plastic_points": st.plastic, "wall_time_s": time.perf_counter() - t_start}


def history_csv(rows) -> str:
    """``history.csv`` text of the rows (:data:`HISTORY_COLUMNS`)."""
    buf = io.StringIO()
    w = csv.DictWriter(buf, fieldnames=HISTORY_COLUMNS, lineterminator="\n")
    w.writeheader()
    for r in rows:
        w.writerow({k: (f"{v:.10g}" if isinstance(v, float) else v) for k, v in r.items()})
    return buf.getvalue()


def write_history(out: pathlib.Path, rows, comm: MPI.Comm) -> None:
    """Rewrite ``history.csv`` from rank 0 (after every converged step)."""
    if comm.rank == 0:
        atomic_write_text(out / "history.csv", history_csv(rows))


def wheel_words(wheel) -> str:
    """The scene's wheel in words: "rigid cylinder", "pneumatic tire (450 kPa)"."""
    if wheel.type == "pneumatic":
        return f"pneumatic tire ({wheel.inflation / 1e3:g} kPa)"
    return f"rigid {wheel.shape}"


def _pyplot():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _save(fig, path: pathlib.Path) -> None:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=120)
    _pyplot().close(fig)
    atomic_write_bytes(path, buf.getvalue())


def plot_force_sinkage(path: pathlib.Path, rows, scene, status: str) -> None:
    """``force_sinkage.png``: Q_V against the sinkage (and s/d)."""
    plt = _pyplot()
    d = scene.wheel.diameter
    s = [0.0] + [r["sinkage_m"] for r in rows]
    q = [0.0] + [r["QV_N"] / 1e3 for r in rows]
    fig, ax = plt.subplots(figsize=(6, 4.2))
    ax.plot(s, q, "o-", ms=3, label=f"FE indentation ({scene.model.mesh_name})")
    ax.set_xlabel("sinkage s (m)")
    ax.set_ylabel("Q_V (kN)")
    ax.grid(alpha=0.3)
    sec = ax.secondary_xaxis("top", functions=(lambda x: x / d, lambda r: r * d))
    sec.set_xlabel("s/d")
    ax.set_title(f"{wheel_words(scene.wheel)} d = {d:g} m, b = {scene.wheel.width:g} m"
                 + ("" if status == "ok" else f"  [{status}]"), fontsize=10)
    ax.legend(loc="lower right")
    fig.tight_layout()
    _save(fig, path)


def write_contact_pressure(out: pathlib.Path, points, areas, pressures, inflation: float, sinkage: float) -> None:
    """``contact_pressure.csv`` (current x, y, z in m, pressure in Pa and tributary area in m² of
    every point of the modelled part of the tire's surface in contact, x along the travel,
    y across; pressure times area sums to the normal contact force) and ``contact_pressure.png``
    (pressure against x, coloured by y, with the inflation pressure); ``points``, ``areas``,
    ``pressures``: the ranks' arrays.  Rank 0 only; a failing plot is logged."""
    pts = np.concatenate([np.reshape(p, (-1, 3)) for p in points])
    a = np.concatenate([np.ravel(w) for w in areas])
    p = np.concatenate([np.ravel(q) for q in pressures])
    order = np.lexsort((pts[:, 1], pts[:, 0]))
    pts, a, p = pts[order], a[order], p[order]
    lines = ["x_m,y_m,z_m,pressure_Pa,area_m2"] + [f"{x:.6g},{y:.6g},{z:.6g},{q:.6g},{w:.6g}"
                                                   for (x, y, z), q, w in zip(pts, p, a)]
    atomic_write_text(out / "contact_pressure.csv", "\n".join(lines) + "\n")
    try:
        plt = _pyplot()
        fig, ax = plt.subplots(figsize=(6, 4.2))
        sc = ax.scatter(pts[:, 0], p / 1e3, c=pts[:, 1], s=12, cmap="viridis")
        fig.colorbar(sc, ax=ax, label="y, across the tire (m)")
        ax.axhline(inflation / 1e3, color="k", ls="--", lw=1, label=f"inflation {inflation / 1e3:g} kPa")
        ax.set_xlabel("x, along the travel from the axle (m)")
        ax.set_ylabel("contact pressure (kPa)")
        ax.set_title(f"contact pressure under the tire at s = {sinkage:.4f} m", fontsize=10)
        ax.grid(alpha=0.3)
        ax.legend(loc="upper right")
        fig.tight_layout()
        _save(fig, out / "contact_pressure.png")
    except Exception as err:  # noqa: BLE001 - a plot must not lose the run
        log.warning("contact pressure plot failed: %s", err)


def plot_travel(path: pathlib.Path, rows, scene, summary: dict, rut_csv: pathlib.Path) -> None:
    """Sinkage and Q_H against travel (and the rut profile for the constant-load protocol)."""
    plt = _pyplot()
    x = np.array([r["travel_m"] for r in rows])
    s = np.array([r["sinkage_m"] for r in rows])
    qh = np.array([r["QH_N"] for r in rows]) / 1e3
    qv = np.array([r["QV_N"] for r in rows]) / 1e3
    x0 = summary["model"]["x_start_m"]
    fig, (ax1, ax2) = plt.subplots(2, 1, figsize=(7, 6), sharex=True)
    ax1.plot(x0 + x, 1e3 * s, "o-", ms=2.5, label="sinkage under the wheel")
    if rut_csv.exists():
        prof = np.loadtxt(rut_csv, delimiter=",", skiprows=1, ndmin=2)
        if prof.size:
            ax1.plot(prof[:, 0], 1e3 * prof[:, 1], "-", color="0.4", label="surface settlement (rut) on the path")
    st = summary.get("steady_state")
    if st and st.get("reached"):
        ax1.axhline(1e3 * st["sinkage"], color="C3", lw=0.8, ls="--", label=f"steady s = {1e3 * st['sinkage']:.1f} mm")
    if summary.get("rut_depth_m") is not None:
        ax1.axhline(1e3 * summary["rut_depth_m"], color="0.4", lw=0.8, ls=":",
                    label=f"rut depth {1e3 * summary['rut_depth_m']:.1f} mm")
    zone = summary["model"].get("stiff_zone_end_m")
    for ax in (ax1, ax2):
        if zone:
            ax.axvspan(0, zone, color="0.9", zorder=0)
        ax.grid(alpha=0.3)
    ax1.set_ylabel("sinkage / settlement (mm)")
    ax1.invert_yaxis()
    ax1.legend(fontsize=8, loc="lower right")
    ax2.plot(x0 + x, qh, "o-", ms=2.5, color="C1", label="Q_H (towing force)")
    ax2.plot(x0 + x, qv, "-", color="C0", lw=0.8, label="Q_V")
    ax2.set_xlabel("wheel centre x (m)" + ("  (grey: stiff start zone)" if zone else ""))
    ax2.set_ylabel("force (kN)")
    ax2.legend(fontsize=8)
    d = scene.wheel.diameter
    fig.suptitle(f"{summary['protocol']}: {wheel_words(scene.wheel)} d = {d:g} m, b = {scene.wheel.width:g} m, "
                 f"mu = {scene.wheel.friction:g}" + ("" if summary["status"] == "ok" else f" [{summary['status']}]"),
                 fontsize=10)
    fig.tight_layout()
    _save(fig, path)


def finish_run(out: pathlib.Path, rows, scene, summary: dict, comm: MPI.Comm, *, progress: bool) -> dict:
    """Write history.csv, the force-sinkage plot and summary.json (last) from rank 0; returns ``summary``."""
    if comm.rank == 0:
        atomic_write_text(out / "history.csv", history_csv(rows))
        try:
            plot_force_sinkage(out / "force_sinkage.png", rows, scene, summary["status"])
        except Exception as err:   # noqa: BLE001 - a plot must not lose the run
            log.warning("force-sinkage plot failed: %s", err)
        atomic_write_text(out / "summary.json", json.dumps(summary, indent=2, default=json_default) + "\n")
        if progress:
            log.info("%s: %d steps, %d Newton iterations, %.1f s -> %s", summary["status"], len(rows),
                     summary["newton_iterations"], summary["wall_time_s"], out)
    comm.barrier()
    return summary


def json_default(obj):
    """JSON encoding of numpy scalars and arrays; non-finite floats as null."""
    if isinstance(obj, (np.floating, np.integer)):
        return obj.item()
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, float) and not math.isfinite(obj):
        return None
    return str(obj)


class TravelProgress:
    """Progress of a rolling run on rank 0: a bar with travel, sinkage and forces, one log line
    per step (readable in files and under mpirun), and the time left for the travel at the pace
    of the last :attr:`window` steps (a roll slows down as it sinks and plastifies, so the mean
    pace since the start would promise too little).  ``start`` (m) is the travel already done
    when the bar is made (a roll continued from a checkpoint)."""

    window = 10

    def __init__(self, travel: float, d: float, enabled: bool = True, width: int = 24, start: float = 0.0):
        self.travel, self.d, self.enabled, self.width = travel, d, enabled, width
        self.paces = collections.deque([(time.perf_counter(), start)], maxlen=self.window + 1)

    def passed(self, x: float) -> None:
        """Record that a step ended now at travel ``x`` (m)."""
        self.paces.append((time.perf_counter(), x))

    def time_left(self) -> float | None:
        """Seconds left to the end of the travel at the pace of the recorded steps; None before a
        step has advanced the wheel."""
        (t0, x0), (t1, x1) = self.paces[0], self.paces[-1]
        return (t1 - t0) / (x1 - x0) * max(self.travel - x1, 0.0) if x1 > x0 + 1e-12 * self.d else None

    def update(self, st) -> None:
        """Log one line for the converged ``RollingStep`` ``st``."""
        if not self.enabled:
            return
        frac = min(max(st.travel / self.travel, 0.0), 1.0)
        filled = int(round(frac * self.width))
        self.passed(st.travel)
        left = self.time_left()
        eta = "" if left is None else f", about {left / 60:.1f} min left"
        log.info("[%s%s] %3.0f%%  x = %.3f m  s = %.2f mm (s/d %.4f)  Q_V = %.2f kN  Q_H = %.2f kN  M = %.2g N m  "
                 "%d its/%d solves%s", "#" * filled, "." * (self.width - filled), 100 * frac, st.travel,
                 1e3 * st.sinkage, st.sinkage / self.d, st.QV / 1e3, st.QH / 1e3, st.moment, st.iterations,
                 st.linear_solves, eta)
