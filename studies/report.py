"""``rollsim report DIR``: plots and a results table for a study directory, as one Markdown page.

Writes into DIR: force_sinkage.png (curves with their fits), effect_<key>.png (sinkage at
the first reference load against each swept numeric parameter, computed points over the
bearing-capacity model), pair_<key>.png (cases differing only in one two-valued key, such
as friction 0.4 vs 0.8), for pneumatic wheels flexibility_<key>.png (lambda against each swept
parameter) and tire_sinkage_vs_model.png, and report.md.
"""
from __future__ import annotations

import csv
import json
import math
import pathlib
import re

import numpy as np

from rollsim.files import read_text
from rollsim.scene import TRANSIENT_ONLY
from rollsim.studies.study import other_parameters
from rollsim.units import InputError

MAX_CURVES = 16  # force-sinkage curves per figure
MAX_ZONES = 6  # plastic-zone pictures shown in a study report


def _plt():
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def _save(fig, path: pathlib.Path) -> str:
    """Lay out, write (PNG, 120 dpi) and close ``fig``; returns the file's name."""
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    _plt().close(fig)
    return path.name


def _read_csv(path: pathlib.Path) -> list[dict]:
    return list(csv.DictReader(read_text(path, path.name).splitlines()))


def _check_numbers(rows: list[dict], path: pathlib.Path) -> None:
    """Every result column the report plots holds a number (or nothing): checked before any
    file is written, so a corrupt results.csv writes nothing."""
    for i, r in enumerate(rows, start=2):
        if None in r or "case" not in r:
            raise InputError(path.name, f"line {i}: not a results table row")
        for k, v in r.items():
            if v and k.startswith(("sinkage_", "model_sinkage_", "ratio", "k1", "k2", "k3", "k4", "R2")):
                try:
                    float(v)
                except ValueError:
                    raise InputError(path.name, f"line {i}, {k}: not a number: {v!r}") from None


def _number(text):
    """The SI value of a swept value ("40 MPa", 0.8) or None when it is not a quantity."""
    if isinstance(text, (int, float)):
        return float(text)
    from rollsim.units import registry
    try:
        q = registry().Quantity(str(text))
    except Exception:
        return None
    try:
        return float(q.to_base_units().magnitude) if not q.dimensionless else float(q.to("").magnitude) \
            if str(q.units) == "dimensionless" else float(q.to("degree").magnitude)
    except Exception:
        return None


def _safe(key: str) -> str:
    return re.sub(r"[^A-Za-z0-9]+", "_", key).strip("_")


def force_sinkage_figure(out: pathlib.Path, cases: list[dict]) -> list[str]:
    """Normalised force-sinkage curves with their k1..k4 fits, MAX_CURVES per figure."""
    from rollsim.studies.fit import ForceSinkageFit
    plt = _plt()
    names = []
    for start in range(0, len(cases), MAX_CURVES):
        chunk = cases[start:start + MAX_CURVES]
        fig, ax = plt.subplots(figsize=(7.5, 5))
        for i, c in enumerate(chunk):
            h, d, g = c["history"], c["d"], c["gamma"]
            x = np.array([float(r["sinkage_m"]) for r in h]) / d
            y = np.array([float(r["QV_N"]) for r in h]) / (g * d**3)
            line, = ax.plot(x, y, "o", ms=3, color=f"C{i % 10}", label=c["name"])
            k = c.get("k")
            if k is not None:
                xs = np.linspace(0, x.max(), 100)
                ax.plot(xs, ForceSinkageFit(k, 1.0, 0).force(xs * d, d, g) / (g * d**3), "-", color=line.get_color(),
                        lw=1)
        ax.set(xlabel="s / d", ylabel="Q_V / (gamma d^3)", title="Force-sinkage curves (points) and fits (lines)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=6, ncol=2)
        name = "force_sinkage.png" if start == 0 else f"force_sinkage_{start // MAX_CURVES + 1}.png"
        names.append(_save(fig, out / name))
    return names


def case_parameters(study: dict) -> dict[str, dict]:
    """``{case: {parameter: value}}`` of a study.json: SI numbers (choices as given)."""
    return {c["name"]: c.get("parameters") or {k: _number(v) for k, v in c["overrides"].items()}
            for c in study["cases"]}


def effect_series(params: dict[str, dict], names: list[str], key: str) -> list[list[str]]:
    """The cases to join by one line in the effect plot of ``key``: those that share every other
    swept parameter, each series ordered by ``key``; series of a single case are dropped."""
    series: dict = {}
    for name in names:
        series.setdefault(other_parameters(params[name], key), []).append(name)
    return [sorted(group, key=lambda n: params[n][key]) for group in series.values() if len(group) > 1]


def effect_figures(out: pathlib.Path, study: dict, rows: list[dict], load_tag: str | None) -> list[tuple[str, str]]:
    """Sinkage at the first reference load vs every swept numeric parameter (one line per set of
    cases that differ in that parameter only); pairs for two-valued parameters."""
    if load_tag is None:
        return []
    plt = _plt()
    params = case_parameters(study)
    ok = {r["case"]: r for r in rows if r.get("status") == "ok"}
    keys = list(dict.fromkeys(k for p in params.values() for k in p))
    figures = []
    for key in keys:
        names = [n for n in ok if isinstance(params[n].get(key), (int, float))]
        values = {params[n][key] for n in names}
        if len(values) < 2:
            continue
        series = effect_series({n: params[n] for n in names}, names, key)
        if not series:
            continue
        fig, ax = plt.subplots(figsize=(6.5, 4.2))
        for i, group in enumerate(series):
            v = [params[n][key] for n in group]
            s = [1e3 * float(ok[n].get(f"sinkage_{load_tag}_m") or "nan") for n in group]
            m = [1e3 * float(ok[n].get(f"model_sinkage_{load_tag}_m") or "nan") for n in group]
            ax.plot(v, m, "-", color="0.4", lw=1, label="bearing-capacity model" if i == 0 else None)
            ax.plot(v, s, "o-", color=f"C{(i + 3) % 10}", ms=4, lw=0.8, label="computed" if i == 0 else None)
        ax.set(xlabel=key, ylabel=f"sinkage at {load_tag} (mm)", title=f"Effect of {key}")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        name = _save(fig, out / f"effect_{_safe(key)}.png")
        figures.append((name, f"sinkage at {load_tag} against {key} (a line joins cases that differ in it only)"))
        distinct = sorted(values)
        if len(distinct) == 2:
            figures += _pair_figure(out, key, [ok[n] for n in names], params, distinct, load_tag)
    return figures


def _pair_figure(out, key, ok, params, distinct, load_tag):
    """Cases that differ only in ``key`` (two values): sinkage with one value against the other."""
    plt = _plt()
    by_rest: dict = {}
    for r in ok:
        p = params[r["case"]]
        by_rest.setdefault(other_parameters(p, key), {})[p[key]] = r
    pairs = [(g[distinct[0]], g[distinct[1]]) for g in by_rest.values() if len(g) == 2]
    if not pairs:
        return []
    a = np.array([float(p[0][f"sinkage_{load_tag}_m"] or "nan") for p in pairs]) * 1e3
    b = np.array([float(p[1][f"sinkage_{load_tag}_m"] or "nan") for p in pairs]) * 1e3
    fig, ax = plt.subplots(figsize=(4.8, 4.5))
    ax.plot(a, b, "o", color="C0")
    lim = [0, np.nanmax(np.r_[a, b, 1.0]) * 1.1]
    ax.plot(lim, lim, "k:", lw=0.8)
    ax.set(xlim=lim, ylim=lim, xlabel=f"sinkage, {key} = {distinct[0]:g} (mm)",
           ylabel=f"sinkage, {key} = {distinct[1]:g} (mm)",
           title=f"{key}: mean ratio {np.nanmean(b / a):.3f}")
    ax.grid(alpha=0.3)
    name = _save(fig, out / f"pair_{_safe(key)}.png")
    return [(name, f"{key} = {distinct[1]:g} vs {distinct[0]:g}, case by case")]


def tire_figures(out: pathlib.Path, study: dict, rows: list[dict]) -> list[tuple[str, str]]:
    """Pneumatic cases: the flexibility lambda against every swept numeric parameter (a line joins
    the cases that differ in it only), and the computed sinkage against the bearing-capacity
    model's with that lambda."""
    ok = {r["case"]: r for r in rows if r.get("status") == "ok" and _number(r.get("flexibility_m_per_N") or "")}
    if not ok:
        return []
    plt = _plt()
    params = case_parameters(study)
    figures = []
    for key in dict.fromkeys(k for n in ok for k in params[n]):
        names = [n for n in ok if isinstance(params[n].get(key), (int, float))]
        series = effect_series({n: params[n] for n in names}, names, key)
        if not series:
            continue
        fig, ax = plt.subplots(figsize=(6.5, 4.2))
        for i, group in enumerate(series):
            rest = ", ".join(f"{k} = {v:g}" for k, v in params[group[0]].items()
                             if k != key and isinstance(v, (int, float)))
            ax.plot([params[n][key] for n in group], [float(ok[n]["flexibility_m_per_N"]) for n in group], "o-",
                    color=f"C{i % 10}", ms=4, label=rest or None)
        ax.set(xlabel=key, ylabel="flexibility lambda = (d_e - d) / Q (m/N)", title=f"Tire flexibility against {key}")
        ax.grid(alpha=0.3)
        if any(ax.get_legend_handles_labels()[1]):
            ax.legend(fontsize=8)
        name = _save(fig, out / f"flexibility_{_safe(key)}.png")
        figures.append((name, f"tire flexibility against {key} (a line joins cases that differ in it only)"))
    pairs = [(float(r["sinkage_m"]), float(r["model_sinkage_flex_m"]), float(r["model_sinkage_rigid_m"]))
             for r in ok.values() if r.get("model_sinkage_flex_m")]
    if pairs:
        fe, flex, rigid = (1e3 * np.array(v) for v in zip(*pairs))
        fig, ax = plt.subplots(figsize=(4.8, 4.5))
        ax.plot(fe, flex, "o", color="C0", label="model, flexible wheel (computed lambda)")
        ax.plot(fe, rigid, "s", color="C3", mfc="none", label="model, rigid wheel")
        lim = [0, 1.1 * max(np.nanmax(np.r_[fe, flex, rigid]), 1.0)]
        ax.plot(lim, lim, "k:", lw=0.8)
        ax.set(xlim=lim, ylim=lim, xlabel="computed sinkage (mm)", ylabel="model sinkage (mm)",
               title="Tire sinkage at its wheel load")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        figures.append((_save(fig, out / "tire_sinkage_vs_model.png"), "the tire's computed sinkage against the bearing-capacity "
                        "model's, with the computed flexibility and as a rigid wheel, at the same wheel load"))
    return figures


def _markdown_table(rows: list[dict]) -> str:
    if not rows:
        return "(no cases)"
    keys = list(rows[0])
    lines = ["| " + " | ".join(keys) + " |", "|" + "---|" * len(keys)]
    for r in rows:
        cells = []
        for k in keys:
            v = r.get(k, "")
            try:
                f = float(v)
                cells.append(f"{f:.4g}" if math.isfinite(f) else "")
            except (TypeError, ValueError):
                cells.append(str(v))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def write_report(directory) -> pathlib.Path:
    """Plots and the results table of the study in ``directory``; returns the report path."""
    out = pathlib.Path(directory)
    if not (out / "study.json").is_file() or not (out / "results.csv").is_file():
        raise InputError(str(out), "not a study directory (no study.json / results.csv): run rollsim study first")
    study = json.loads(read_text(out / "study.json", "study.json"))
    rows = _read_csv(out / "results.csv")
    _check_numbers(rows, out / "results.csv")
    cases = []
    for r in rows:
        case_dir = out / "cases" / r["case"]
        if r.get("status") != "ok" or not (case_dir / "summary.json").is_file():
            continue
        summary = json.loads(read_text(case_dir / "summary.json", f"{r['case']}/summary.json"))
        scene = summary.get("scene", {})
        history = case_dir / summary.get("history", "history.csv")
        if not history.is_file():
            continue
        k = tuple(float(r[f"k{i}"]) for i in range(1, 5)) if r.get("k1") else None
        zone = history.parent / "plastic_zone.png"
        cases.append({"name": r["case"], "history": _read_csv(history), "k": k,
                      "zone": zone.relative_to(out).as_posix() if zone.is_file() else None,
                      "d": scene["wheel"]["diameter"], "gamma": scene["soil"]["gamma"]})
    loads = study.get("reference_loads_N") or []
    load_tag = f"{loads[0] / 1e3:g}kN" if loads else None
    curves = force_sinkage_figure(out, cases) if cases else []
    effects = effect_figures(out, study, rows, load_tag)
    n_ok = sum(r.get("status") == "ok" for r in rows)
    text = [f"# Study report: {pathlib.Path(study['study']).name}", "",
            f"{len(rows)} cases ({n_ok} ok), runner `{study['runner']}`; reference loads "
            + (", ".join(f"{v / 1e3:g} kN" for v in loads) or "none") + ".", ""]
    for why, names in (study.get("rerun") or {}).items():
        if names:
            text += [f"Rerun because {why} since the last run: {', '.join(names)}.", ""]
    for key in study.get("no_effect") or []:
        text += [f"Note: `{key}` is swept, but the {study['runner']} runner does not use it; "
                 "its cases give the same result.", ""]
    text += ["## Force-sinkage curves", ""]
    text += [f"![force-sinkage]({name})" for name in curves] or ["(no completed case)"]
    if effects:
        text += ["", "## Parameter effects", ""]
        for name, caption in effects:
            text += [f"![{caption}]({name})", "", f"*{caption}*", ""]
    tires = tire_figures(out, study, rows)
    if tires:
        text += ["", "## Tire flexibility", ""]
        for name, caption in tires:
            text += [f"![{caption}]({name})", "", f"*{caption}*", ""]
    zones = [(c["name"], c["zone"]) for c in cases if c.get("zone")][:MAX_ZONES]
    if zones:
        text += ["", "## Plastic zones", ""]
        text += [f"![{name}]({path})\n\n*{name}: equivalent plastic strain at the last converged step*\n"
                 for name, path in zones]
    text += ["", "## Results", "", "Fit: Q_V/(gamma d^3) = k1 sqrt(x) + k2 x + k3 x^2 + k4 x^3, x = s/d; "
             "ratio = computed sinkage / bearing-capacity model sinkage at the reference load.", "",
             _markdown_table(rows), ""]
    path = out / "report.md"
    from rollsim.studies.study import atomic_write_text
    atomic_write_text(path, "\n".join(text))
    return path


def run_report(directory) -> pathlib.Path:
    """For one run directory: the computed force-sinkage curve over the bearing-capacity model's."""
    from rollsim.scene import parse_scene
    from rollsim.studies import bearing_capacity as bc
    from rollsim.studies.study import atomic_write_text, model_inputs
    out = pathlib.Path(directory)
    summary = json.loads(read_text(out / "summary.json", "summary.json"))
    rows = _read_csv(out / "history.csv")
    scene = parse_scene(_scene_input(summary["scene"]))
    wheel, soil, opts = model_inputs(scene)
    s = np.array([float(r["sinkage_m"]) for r in rows])
    qv = np.array([float(r["QV_N"]) for r in rows])
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.5, 4.5))
    s_model = np.linspace(0, max(s.max(initial=0), scene.loading.max_sinkage or 0), 200)[1:]
    ax.plot(1e3 * s_model, bc.wheel_forces(s_model, wheel, soil, opts).QV / 1e3, "-", color="0.4",
            label="bearing-capacity model")
    ax.plot(1e3 * s, qv / 1e3, "o-", ms=3, color="C3", label=f"finite elements ({summary['status']})")
    ax.set(xlabel="sinkage s (mm)", ylabel="Q_V (kN)",
           title=f"{summary.get('protocol', '')}: d = {scene.wheel.diameter:g} m, b = {scene.wheel.width:g} m")
    ax.grid(alpha=0.3)
    ax.legend()
    _save(fig, out / "force_sinkage_vs_model.png")
    text = [f"# Run report: {out.name}", "", f"status **{summary['status']}**"
            + (f" ({summary.get('reason')})" if summary.get("reason") else "")
            + f", {summary.get('steps')} steps, {summary.get('newton_iterations')} Newton iterations, "
            f"{summary.get('wall_time_s', 0):.1f} s on {summary.get('ranks')} rank(s), {summary.get('dofs')} dofs.",
            "", "![force-sinkage vs model](force_sinkage_vs_model.png)", ""]
    if (out / "plastic_zone.png").is_file():
        text += ["![plastic zone](plastic_zone.png)", "",
                 "*Equivalent plastic strain on the deformed soil at the last converged step.*", ""]
    steady = summary.get("steady_state")
    if steady:
        s_model = float(bc.sinkage(scene.loading.load, wheel, soil, opts).sinkage)
        rut = summary.get("rut_depth_m")
        text += ["## Constant-load rolling", "",
                 "| quantity | value |", "|---|---|",
                 f"| steady state | {'reached' if steady['reached'] else 'not reached'} at travel "
                 f"{steady['travel']:.3f} m (window {steady['window']:.3f} m) |",
                 f"| steady sinkage | {1e3 * summary['sinkage_m']:.2f} mm (bearing-capacity model: "
                 f"{1e3 * s_model:.2f} mm) |",
                 f"| Q_H (towing force) | {summary['QH_N'] / 1e3:.2f} kN |",
                 f"| rut depth / rebound | " + (f"{1e3 * rut:.2f} mm / {1e3 * summary['rebound_m']:.2f} mm |"
                                                if rut is not None else "not measured |"), ""]
        for name, caption in (("rolling.png", "Sinkage, rut profile and forces against travel."),
                              ("rut.png", "The rut after lift-off (displacement x 5), plastic strain.")):
            if (out / name).is_file():
                text += [f"![{name}]({name})", "", f"*{caption}*", ""]
    if summary.get("rolling") == "steady" and summary.get("rut_depth_m") is not None:
        text += _steady_section(summary, scene, wheel, soil, opts)
    path = out / "report.md"
    atomic_write_text(path, "\n".join(text))
    return path


def _steady_section(summary: dict, scene, wheel, soil, opts) -> list[str]:
    """The report's table of a steady roll (the last steady state) and its rut picture."""
    from rollsim.studies import bearing_capacity as bc
    lines = ["## Steady rolling", "", "| quantity | value |", "|---|---|"]
    if scene.loading.protocol == "rolling-constant-load":
        s_model = float(bc.sinkage(scene.loading.load, wheel, soil, opts).sinkage)
        lines.append(f"| steady sinkage | {1e3 * summary['sinkage_m']:.2f} mm (bearing-capacity model: "
                     f"{1e3 * s_model:.2f} mm) |")
    else:
        lines.append(f"| deepest steady state | {1e3 * summary['sinkage_m']:.2f} mm, Q_V "
                     f"{summary['QV_N'] / 1e3:.2f} kN |")
    window = summary["model"]["window_m"]
    lines += [f"| Q_H (towing force) | {summary['QH_N'] / 1e3:.2f} kN |",
              f"| spin omega R / V, rolling radius | {summary['spin']:.4f}, {summary['rolling_radius_m']:.4f} m |",
              f"| contact length (centre line) | {1e3 * summary['contact_length_m']:.1f} mm |",
              f"| rut depth / rebound | {1e3 * summary['rut_depth_m']:.2f} mm / {1e3 * summary['rebound_m']:.2f} mm |",
              f"| window (ahead, behind, depth, across; fine cells) | {window['ahead']:.3g}, {window['behind']:.3g}, "
              f"{window['depth']:.3g}, {window['across']:.3g} m; {1e3 * window['fine_cell']:.3g} mm |", ""]
    return lines + ["![rut.png](rut.png)", "", "*The surface on the wheel's centre line in its frame.*", ""]


def _scene_input(echo: dict) -> dict:
    """A summary's scene echo (SI, angles in degrees, None for unset) back into scene-file form."""
    def clean(obj):
        if isinstance(obj, dict):
            return {k: clean(v) for k, v in obj.items() if v is not None}
        if isinstance(obj, list):
            return [clean(v) for v in obj]
        return obj
    data = clean(echo)
    if data["wheel"].get("type") == "pneumatic":     # the echo carries the rigid wheel's keys too
        data["wheel"].pop("shape", None)
        data["wheel"].pop("fillet", None)
    model = data.get("model", {})
    if not data["loading"]["protocol"].startswith("rolling"):      # the echo carries the default method
        model.pop("rolling", None)
    elif model.get("rolling") == "steady":        # and the transient solver's defaults
        for key in TRANSIENT_ONLY:
            model.pop(key, None)
    for layer in data["soil"]["layers"]:
        if "c" not in layer:
            layer.pop("match", None)
        if layer.get("model") == "von-mises":      # the echo carries phi_dp = 0: not a von Mises key
            layer.pop("phi_dp", None)
            layer.pop("phi", None)
    return data
