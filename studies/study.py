"""The study runner: a base scene plus sweeps, expanded into named cases and run in batch.

A study file (TOML)::

    base = "../examples/indentation_mndot.toml"   # a scene file, relative to the study file,
                                                  # or an inline [base] table in scene format
    runner = "analytic"                           # analytic (bearing-capacity model) | fe
    reference_loads = ["53 kN", "133.5 kN"]       # sinkage is read off each curve at these loads
    ranks_per_case = 1                            # under mpirun: ranks that share one case

    [set]                                         # scene keys applied to every case (not in names)
    "model.accuracy" = "fast"

    [[sweep]]                                     # every [[sweep]] block multiplies the cases
    mode = "grid"                                 # grid (all combinations) | zip (side by side)
    "soil.layers[0].E" = ["20 MPa", "40 MPa"]
    "wheel.friction" = [0.4, 0.8]

    [[sweep]]                                     # or the rows of a CSV (e.g. the report's cases)
    csv = "../data/cases_indentation.csv"
    rows = [1, 2, 3]                              # optional, by the CSV's "case" column
    "wheel.diameter" = "{d_m} m"                  # scene key = template over the row's columns
    "soil.layers[0].c_dp" = "{c_dp_kPa} kPa"

Results: ``DIR/cases/<case>/`` (one run directory each, ``summary.json`` written last),
``DIR/results.csv`` (rewritten atomically; swept parameters as SI numbers, the unit in the
column name), ``DIR/study.json`` (the expanded cases).

Resume: each case's ``summary.json`` records a fingerprint of what produced it (the fully
resolved scene, the runner and its options, the package version).  A case whose summary is
present, readable and of the same fingerprint is not run again; a changed case (an edited
``[set]``, base scene, sweep value or CSV row) or a corrupt or half-written one is rerun.
"""
from __future__ import annotations

import copy
import csv
import hashlib
import itertools
import json
import math
import pathlib
import re
import shutil
import time
from dataclasses import dataclass, field
from typing import Callable

import numpy as np
from mpi4py import MPI

from rollsim import __version__
from rollsim.files import atomic_write_text, complete_directory, read_text, read_toml
from rollsim.log import get_logger
from rollsim.mpi import root_block
from rollsim.scene import Scene, parse_scene
from rollsim.presets import PRESETS
from rollsim.units import FORCE, InputError, to_si

log = get_logger("study")
RUNNERS = ("analytic", "fe")
FE_COST_HINT = {("indentation", "fast"): "about 1 minute", ("indentation", "standard"): "10-30 minutes",
                ("indentation", "accurate"): "hours", ("rolling", "fast"): "10-20 minutes",
                ("rolling", "standard"): "hours", ("rolling", "accurate"): "days"}
#: the cost of a run grows about as (elements per d)**COST_EXPONENT (measured on the rolling levels:
#: see docs/speed-accuracy-details.md, "Constant-load rolling: mesh convergence")
COST_EXPONENT = 4.0


def _cost_hint(protocol: str, accuracy: str, refinement: float | None) -> str:
    """The :data:`FE_COST_HINT` of a preset, or for ``refinement`` elements per d its ratio to the
    fast preset's cost."""
    if refinement is None:
        return FE_COST_HINT[protocol, accuracy]
    ratio = (refinement / PRESETS["fast"].elements_per_d) ** COST_EXPONENT
    return f"about {ratio:.2g}x the fast preset's {FE_COST_HINT[protocol, 'fast']}"


_INDEX = re.compile(r"^([A-Za-z_]\w*)(?:\[(\d+)\])?$")


@dataclass(frozen=True)
class Case:
    """One case of a study: its name, the overrides applied to the base scene, and the scene."""

    name: str
    overrides: dict
    scene: Scene
    raw: dict = field(repr=False, compare=False)


@dataclass(frozen=True)
class Study:
    path: pathlib.Path
    runner: str
    reference_loads: tuple[float, ...]
    ranks_per_case: int
    cases: tuple[Case, ...]


# ------------------------------------------------------------------------ expansion
def set_key(data: dict, key: str, value) -> None:
    """Set the dotted scene ``key`` (``soil.layers[0].E``) in the raw scene dict ``data``."""
    node = data
    parts = key.split(".")
    for i, part in enumerate(parts):
        m = _INDEX.match(part)
        if not m:
            raise InputError(key, "not a scene key (expected e.g. soil.layers[0].E)")
        name, index = m.group(1), m.group(2)
        last = i == len(parts) - 1
        if index is None:
            if last:
                node[name] = value
            else:
                node = node.setdefault(name, {})
                if not isinstance(node, dict):
                    raise InputError(key, f"{name} is not a table")
        else:
            items = node.get(name)
            if not isinstance(items, list) or int(index) >= len(items):
                raise InputError(key, f"the base scene has no {name}[{index}]")
            if last:
                items[int(index)] = value
            else:
                node = items[int(index)]


#: unit of a scene quantity, by its key's last part: the suffix of its results.csv column
UNIT_OF_KEY = {**dict.fromkeys(("diameter", "width", "fillet", "hub_diameter", "t_tread", "thickness", "max_sinkage",
                                "travel", "relaxation_length"), "m"),
               **dict.fromkeys(("E", "c", "c_dp", "inflation", "E_carcass", "regularising_cohesion"), "Pa"),
               **dict.fromkeys(("phi", "phi_dp", "dilation"), "deg"),
               "gamma": "N_per_m3", "load": "N"}


def scene_value(scene: Scene, key: str):
    """The value of the dotted ``key`` in the resolved scene: SI, angles in degrees."""
    node = scene.to_dict()
    for part in key.split("."):
        name, index = _INDEX.match(part).groups()
        node = node[name] if index is None else node[name][int(index)]
    return node


def parameters(case: "Case") -> dict:
    """``{results.csv column: value}`` of the case's swept keys: SI numbers with the unit in the
    column name (``soil.layers[0].E_Pa``), choices as given."""
    out = {}
    for key in case.overrides:
        value = scene_value(case.scene, key)
        unit = UNIT_OF_KEY.get(key.rpartition(".")[2].split("[")[0])
        out[f"{key}_{unit}" if unit and isinstance(value, (int, float)) else key] = value
    return out


def fill_template(template: str, row: dict, field: str, source: str) -> str:
    """``template`` with every ``{column}`` replaced by the row's value; only plain column names
    are allowed (no attributes, indexing or format specs), and braces must pair."""
    def value(m):
        name = m.group(1)
        if not re.fullmatch(r"\w+", name):
            raise InputError(field, f"{{{name}}}: a template names a column only, e.g. '{{E_MPa}} MPa'")
        if name not in row:
            raise InputError(field, f"no column {name!r} in {source}")
        return str(row[name])
    text = re.sub(r"\{([^{}]*)\}", value, template)
    if "{" in text or "}" in text:
        raise InputError(field, f"unbalanced brace in {template!r}")
    return text


def _short(key: str, value) -> str:
    label = key.split(".")[-1]
    text = re.sub(r"[^A-Za-z0-9.+-]+", "", str(value))
    return f"{label}={text}"


def _expand_block(block: dict, where: str, study_dir: pathlib.Path) -> list[tuple[str, dict]]:
    """(name part, overrides) for every case of one [[sweep]] block."""
    block = dict(block)
    if "csv" in block:
        path = (study_dir / block.pop("csv")).resolve()
        rows_wanted = block.pop("rows", None)
        if not path.is_file():
            raise InputError(f"{where}.csv", f"no such file: {path}")
        text = read_text(path, f"{where}.csv")
        rows = list(csv.DictReader(line for line in text.splitlines() if not line.startswith("#")))
        if not rows:
            raise InputError(f"{where}.csv", f"{path.name} has no rows")
        if rows_wanted is not None:
            if isinstance(rows_wanted, list) and not rows_wanted:
                raise InputError(f"{where}.rows", "is empty: list the cases to run, or omit rows for all")
            if not isinstance(rows_wanted, list) or "case" not in rows[0]:
                raise InputError(f"{where}.rows", "give a list of values of the CSV's 'case' column")
            by_case = {r["case"]: r for r in rows}
            missing = [str(c) for c in rows_wanted if str(c) not in by_case]
            if missing:
                raise InputError(f"{where}.rows", f"no case {', '.join(missing)} in {path.name}")
            rows = [by_case[str(c)] for c in rows_wanted]
        out = []
        for i, row in enumerate(rows):
            overrides = {}
            for key, template in block.items():
                if not isinstance(template, str):
                    raise InputError(f"{where}.{key}", "a CSV sweep maps a key to a template string like '{E_MPa} MPa'")
                overrides[key] = fill_template(template, row, f"{where}.{key}", path.name)
            label = f"case-{int(row['case']):02d}" if str(row.get("case", "")).isdigit() else f"row-{i + 1:02d}"
            out.append((label, overrides))
        return out
    mode = block.pop("mode", "grid")
    if mode not in ("grid", "zip"):
        raise InputError(f"{where}.mode", "must be grid or zip")
    if not block:
        raise InputError(where, "a sweep needs at least one key")
    for key, values in block.items():
        if not isinstance(values, list) or not values:
            raise InputError(f"{where}.{key}", "must be a non-empty list of values")
    keys = list(block)
    if mode == "zip":
        lengths = {len(v) for v in block.values()}
        if len(lengths) > 1:
            raise InputError(f"{where}.{keys[0]}", "zipped lists must have the same length")
        combos = list(zip(*block.values()))
    else:
        combos = list(itertools.product(*block.values()))
    return [("_".join(_short(k, v) for k, v in zip(keys, combo)), dict(zip(keys, combo))) for combo in combos]


def load_study(path) -> Study:
    """Read a study file and expand and validate every case (``InputError`` names the key)."""
    path = pathlib.Path(path)
    data = read_toml(path, str(path))
    allowed = {"base", "runner", "reference_loads", "ranks_per_case", "set", "sweep"}
    for key in data:
        if key not in allowed:
            raise InputError(key, "unknown key")
    base = data.get("base")
    if isinstance(base, str):
        base = read_toml(path.parent / base, "base")
    if not isinstance(base, dict):
        raise InputError("base", "give a scene file path or an inline [base] table")
    fixed = data.get("set", {})
    if not isinstance(fixed, dict):
        raise InputError("set", 'a table of scene keys applied to every case, e.g. "model.accuracy" = "fast"')
    for key, value in fixed.items():
        set_key(base, key, value)
    runner = data.get("runner", "analytic")
    if runner not in RUNNERS:
        raise InputError("runner", f"must be one of {', '.join(RUNNERS)}, got {runner!r}")
    loads = data.get("reference_loads", [])
    if not isinstance(loads, list):
        raise InputError("reference_loads", "must be a list of loads")
    reference_loads = tuple(to_si(v, FORCE, f"reference_loads[{i}]") for i, v in enumerate(loads))
    if any(v <= 0 for v in reference_loads):
        raise InputError("reference_loads", "loads must be positive")
    ranks = data.get("ranks_per_case", 1)
    if not isinstance(ranks, int) or ranks < 1:
        raise InputError("ranks_per_case", "must be a positive integer")
    blocks = data.get("sweep", [])
    if not isinstance(blocks, list):
        raise InputError("sweep", "use [[sweep]] tables")
    expanded = [_expand_block(b, f"sweep[{i}]", path.parent) for i, b in enumerate(blocks)] or [[("base", {})]]
    cases, names = [], set()
    for combo in itertools.product(*expanded):
        name = "__".join(part for part, _ in combo)
        overrides = {k: v for _, o in combo for k, v in o.items()}
        if name in names:
            raise InputError("sweep", f"two cases are both named {name!r}")
        names.add(name)
        raw = copy.deepcopy(base)
        for key, value in overrides.items():
            set_key(raw, key, value)
        try:
            scene = parse_scene(raw)
        except InputError as e:
            raise InputError(f"case {name}: {e.field}", e.message) from None
        cases.append(Case(name, overrides, scene, raw))
    return Study(path, runner, reference_loads, ranks, tuple(cases))


# ----------------------------------------------------------------------- execution
def fingerprint(case: "Case", study: "Study") -> str:
    """Content hash of what a case's result depends on: the resolved scene (SI), the runner, the
    reference loads and the package version."""
    content = {"scene": case.scene.to_dict(), "runner": study.runner,
               "reference_loads_N": list(study.reference_loads), "version": __version__}
    return hashlib.sha256(json.dumps(content, sort_keys=True, default=str).encode()).hexdigest()


def case_state(case_dir: pathlib.Path, expected: str) -> str:
    """``"done"`` (summary.json readable, same fingerprint), ``"changed"`` (another fingerprint),
    ``"corrupt"`` (unreadable or incomplete) or ``"new"`` (no summary)."""
    path = case_dir / "summary.json"
    if not path.is_file():
        return "new"
    try:
        summary = json.loads(path.read_text())
        status, recorded = summary["status"], summary.get("fingerprint")
    except (OSError, UnicodeDecodeError, ValueError, KeyError, TypeError):
        return "corrupt"
    if not isinstance(status, str):
        return "corrupt"
    return "done" if recorded == expected else "changed"


def has_checkpoint(case_dir: pathlib.Path) -> bool:
    """True when an unfinished case left a rolling checkpoint: its run continues from it (the
    run checks that the checkpoint is of the same scene) instead of starting again."""
    return complete_directory(case_dir / "run" / "checkpoint") is not None


def _plan(study: "Study", out: pathlib.Path, comm: MPI.Comm) -> dict:
    """``{case name: state}`` read on rank 0 and broadcast (every rank runs the same cases)."""
    states = None
    with root_block(comm) as on_root:  # a failed read on rank 0 fails every rank, not a hang
        if on_root:
            states = {c.name: case_state(out / "cases" / c.name, fingerprint(c, study)) for c in study.cases}
    return comm.bcast(states, root=0)


CaseRunner = Callable[[Case, pathlib.Path, MPI.Comm], dict]


def run_study(study: Study, out, comm: MPI.Comm, runner: CaseRunner, *, quiet: bool = False) -> list[dict]:
    """Run the study's unfinished cases over ``comm`` and write ``results.csv``; returns the rows.

    Ranks are split into groups of ``ranks_per_case``; group g runs the unfinished
    cases g, g + G, ... A failing case is recorded as failed and the others go on; a case
    interrupted by a signal (SIGINT/SIGTERM/SIGUSR1) stops its group and is rerun on resume.
    """
    out = pathlib.Path(out)
    states = _plan(study, out, comm)
    todo = [c for c in study.cases if states[c.name] != "done"]
    rerun = {why: [n for n, st in states.items() if st == why] for why in ("changed", "corrupt")}
    no_effect = ineffective_keys(study)
    if comm.rank == 0:
        (out / "cases").mkdir(parents=True, exist_ok=True)
        atomic_write_text(out / "study.json", json.dumps(
            {"study": str(study.path), "runner": study.runner, "reference_loads_N": study.reference_loads,
             "rerun": rerun, "no_effect": no_effect,
             "cases": [{"name": c.name, "overrides": c.overrides, "parameters": parameters(c)}
                       for c in study.cases]}, indent=2))
        for key in no_effect:
            log.warning("study %s: %s is swept but the %s runner does not use it: its cases give the same result",
                        study.path.name, key, study.runner)
    comm.barrier()
    size = min(study.ranks_per_case, comm.size)
    n_groups = comm.size // size
    group = min(comm.rank // size, n_groups - 1)
    sub = comm.Split(color=group, key=comm.rank)
    if comm.rank == 0 and not quiet:
        changed = "".join(f", {len(v)} {why} since the last run (rerun)" for why, v in rerun.items() if v)
        log.info("study %s: %d cases, %d done before%s, %d to run on %d group(s) of %d rank(s)",
                 study.path.name, len(study.cases), sum(st == "done" for st in states.values()), changed,
                 len(todo), n_groups, size)
    try:
        for i, case in enumerate(todo):
            if i % n_groups != group:
                continue
            case_dir = out / "cases" / case.name
            if sub.rank == 0 and case_dir.exists() and not (states[case.name] == "new" and has_checkpoint(case_dir)):
                shutil.rmtree(case_dir)  # half-written by a killed run: start it again
            sub.barrier()
            if sub.rank == 0:
                case_dir.mkdir(parents=True, exist_ok=True)
            sub.barrier()
            t0 = time.perf_counter()
            try:
                summary = runner(case, case_dir, sub)
            except Exception as e:  # a failing case must not stop the others
                log.warning("case %s failed: %s", case.name, e)
                summary = {"status": "failed", "reason": f"{type(e).__name__}: {e}"}
            if summary.get("status") == "interrupted":
                # a signal stopped the run: leave the case unfinished (rerun on resume) and stop
                log.warning("case %s interrupted: the study stops here; run it again to resume", case.name)
                break
            summary.setdefault("wall_time_s", time.perf_counter() - t0)
            summary["case"] = case.name
            summary["fingerprint"] = fingerprint(case, study)
            if sub.rank == 0:
                atomic_write_text(case_dir / "summary.json", json.dumps(summary, indent=2, default=float))
                if not quiet:
                    log.info("[%d/%d] %s: %s (%.1f s)", i + 1, len(todo), case.name, summary["status"],
                             summary["wall_time_s"])
    finally:
        sub.Free()
    comm.barrier()
    rows = collect_results(study, out) if comm.rank == 0 else None
    return comm.bcast(rows, root=0)


def collect_results(study: Study, out: pathlib.Path) -> list[dict]:
    """One row per case from the case summaries; writes results.csv atomically."""
    rows = []
    for case in study.cases:
        path = out / "cases" / case.name / "summary.json"
        summary = json.loads(path.read_text()) if path.is_file() else {"status": "not run"}
        row = {"case": case.name}
        row.update(parameters(case))
        row["status"] = summary.get("status")
        row.update(summary.get("comparison", {}))
        rows.append(row)
    columns = list(dict.fromkeys(k for r in rows for k in r))
    lines = [",".join(columns)]
    for r in rows:
        lines.append(",".join(_csv_cell(r.get(k, "")) for k in columns))
    atomic_write_text(out / "results.csv", "\n".join(lines) + "\n")
    return rows


def _csv_cell(value) -> str:
    if isinstance(value, float):
        return "" if math.isnan(value) else f"{value:.6g}"
    text = str(value)
    return f'"{text}"' if ("," in text or '"' in text) else text


def other_parameters(params: dict, key: str) -> tuple:
    """A case's swept parameters other than ``key``, as a hashable key for grouping cases that
    differ in ``key`` only."""
    return tuple(sorted((k, repr(v)) for k, v in params.items() if k != key))


def ineffective_keys(study: "Study") -> list[str]:
    """Swept keys that the study's runner does not use: the analytic runner reads only the
    bearing-capacity model's inputs (wheel, top layer's strength, unit weight, protocol), so a
    swept E, nu, friction, dilation or mesh preset changes nothing.  Empty for the FE runner."""
    if study.runner != "analytic":
        return []
    keys = list(dict.fromkeys(k for c in study.cases for k in c.overrides))
    inputs = {c.name: repr(model_inputs(c.scene)) for c in study.cases}
    found = []
    for key in keys:
        groups: dict = {}
        for c in study.cases:
            groups.setdefault(other_parameters(c.overrides, key), []).append(c)
        varied = [g for g in groups.values() if len({repr(c.overrides.get(key)) for c in g}) > 1]
        if varied and all(len({inputs[c.name] for c in g}) == 1 for g in varied):
            found.append(key)
    return found


# ---------------------------------------------------------- curves and comparisons
def compare_with_model(scene: Scene, sinkage_m, QV_N, reference_loads, *, exact_curve: bool = False) -> dict:
    """Fit k1..k4, R^2, sinkage at the reference loads, and the bearing-capacity model's for the
    same case.  ``exact_curve``: the curve is the model's own (the analytic runner), so its sinkage
    at a load is the model's root, not a reading between sampled points."""
    from rollsim.studies import bearing_capacity as bc
    from rollsim.studies.fit import fit_force_sinkage, sinkage_at_loads
    d, gamma = scene.wheel.diameter, scene.soil.gamma
    fit = fit_force_sinkage(sinkage_m, QV_N, d, gamma)
    row = {f"k{i + 1}": k for i, k in enumerate(fit.k)}
    row["R2"] = fit.r_squared
    wheel, soil, opts = model_inputs(scene)
    for load in reference_loads:
        tag = f"{load / 1e3:g}kN"
        r = bc.sinkage(load, wheel, soil, opts)
        s_model = float(r.sinkage)
        s_curve = s_model if exact_curve else float(sinkage_at_loads(sinkage_m, QV_N, [load])[0])
        row[f"sinkage_{tag}_m"] = s_curve
        row[f"model_sinkage_{tag}_m"] = s_model
        row[f"ratio_{tag}"] = s_curve / s_model if s_model > 0 else float("nan")
    return row


def compare_steady_with_model(scene: Scene, summary: dict) -> dict:
    """Constant-load rolling: steady sinkage, Q_H, rut depth and rebound of the run, and the
    bearing-capacity model's sinkage under the same load (no force-sinkage fit: Q_V is constant)."""
    from rollsim.studies import bearing_capacity as bc
    steady = summary.get("steady_state") or {}
    row = {"steady_reached": steady.get("reached"), "steady_sinkage_m": summary.get("sinkage_m"),
           "QH_N": summary.get("QH_N"), "rut_depth_m": summary.get("rut_depth_m"),
           "rebound_m": summary.get("rebound_m")}
    wheel, soil, opts = model_inputs(scene)
    s_model = float(bc.sinkage(scene.loading.load, wheel, soil, opts).sinkage)
    row["model_sinkage_m"] = s_model
    s = row["steady_sinkage_m"]
    row["ratio"] = s / s_model if s and s_model > 0 else float("nan")
    return row


def compare_tire_with_model(scene: Scene, tire: dict) -> dict:
    """A pneumatic wheel's figures (summary.json ``tire``) and the bearing-capacity model's sinkage
    under the same wheel load, as a rigid wheel and as a flexible one with the computed lambda."""
    from rollsim.studies import bearing_capacity as bc
    keys = ("wheel_load_N", "sinkage_m", "deflection_m", "contact_length_m", "equivalent_diameter_m",
            "flexibility_m_per_N", "carcass_load_share")
    row = {k: tire.get(k) for k in keys}
    d, load, lam = scene.wheel.diameter, tire.get("wheel_load_N"), tire.get("flexibility_m_per_N")
    row["d_e_over_d"] = row["equivalent_diameter_m"] / d if row["equivalent_diameter_m"] else None
    if not load or load <= 0:
        return row
    wheel, soil, opts = model_inputs(scene)
    row["model_sinkage_rigid_m"] = float(bc.sinkage(load, wheel, soil, opts).sinkage)
    if lam is not None and lam > 0:
        flexible = bc.Wheel(wheel.diameter, wheel.width, wheel.shape, lam)
        row["model_sinkage_flex_m"] = s_model = float(bc.sinkage(load, flexible, soil, opts).sinkage)
        row["ratio_flex"] = tire["sinkage_m"] / s_model if s_model > 0 else float("nan")
    return row


def model_inputs(scene: Scene):
    """The bearing-capacity model's wheel, soil (top layer, Mohr-Coulomb) and options for a scene."""
    from rollsim.solver.materials import dp_to_mc
    from rollsim.studies import bearing_capacity as bc
    layer = scene.soil.layers[0]
    if layer.c is not None:
        c, phi = layer.c, layer.phi or 0.0
    else:  # Drucker-Prager as given: the report's tables use the compression match
        c, phi = dp_to_mc(layer.phi_dp or 0.0, layer.c_dp, "compression")
    shape = scene.wheel.shape if scene.wheel.type == "rigid" else "cylinder"
    mode = "indentation" if scene.loading.protocol == "indentation" else "rolling"
    return bc.Wheel(scene.wheel.diameter, scene.wheel.width, shape), bc.Soil(c, phi, scene.soil.gamma), \
        bc.Options(mode=mode)


def analytic_runner(reference_loads) -> CaseRunner:
    """A case runner that evaluates the bearing-capacity model's force-sinkage curve."""
    def run(case: Case, case_dir: pathlib.Path, comm: MPI.Comm) -> dict:
        from rollsim.studies import bearing_capacity as bc
        scene = case.scene
        wheel, soil, opts = model_inputs(scene)
        s_max = scene.loading.max_sinkage or 0.1 * scene.wheel.diameter
        s = np.linspace(0.0, s_max, 41)[1:]
        f = bc.wheel_forces(s, wheel, soil, opts)
        if comm.rank == 0:
            lines = ["step,sinkage_m,QV_N,QH_N,travel_m"]
            lines += [f"{i + 1},{a:.9g},{b:.9g},{c:.9g},0" for i, (a, b, c) in enumerate(zip(s, f.QV, f.QH))]
            atomic_write_text(case_dir / "history.csv", "\n".join(lines) + "\n")
        return {"status": "ok", "runner": "analytic", "scene": scene.to_dict(), "ranks": comm.size,
                "history": "history.csv",
                "comparison": compare_with_model(scene, s, f.QV, reference_loads, exact_curve=True)}
    return run


def fe_runner(reference_loads, petsc_options: dict | None = None) -> CaseRunner:
    """A case runner that runs the finite-element solver (``rollsim run``) into ``<case>/run``."""
    def run(case: Case, case_dir: pathlib.Path, comm: MPI.Comm) -> dict:
        from rollsim.solver.run import run_scene
        run_dir = case_dir / "run"
        summary = run_scene(case.scene, run_dir, comm, progress=False, petsc_options=petsc_options)
        history = None
        with root_block(comm) as on_root:  # a failed read on rank 0 fails every rank, not a hang
            if on_root:
                history = _read_history(run_dir / "history.csv")
        history = comm.bcast(history, root=0)
        result = {"status": summary["status"], "runner": "fe", "scene": case.scene.to_dict(), "ranks": comm.size,
                  "history": "run/history.csv", "steps": summary["steps"], "dofs": summary["dofs"],
                  "newton_iterations": summary["newton_iterations"]}
        if summary["status"] != "ok":
            result["reason"] = summary.get("reason", "")
        if case.scene.wheel.type == "pneumatic":
            result["comparison"] = compare_tire_with_model(case.scene, summary.get("tire") or {})
        elif case.scene.loading.protocol == "rolling-constant-load":
            result["comparison"] = compare_steady_with_model(case.scene, summary)
        elif len(history[0]) >= 4:  # a failed run's partial curve is still compared
            result["comparison"] = compare_with_model(case.scene, *history, reference_loads)
        return result
    return run


def _read_history(path: pathlib.Path):
    with path.open(newline="") as f:
        rows = [r for r in csv.DictReader(f) if float(r["sinkage_m"]) > 0]
    return np.array([float(r["sinkage_m"]) for r in rows]), np.array([float(r["QV_N"]) for r in rows])


def dry_run_lines(study: Study) -> list[str]:
    """What ``--dry-run`` prints: the cases with their overrides and the estimated cost."""
    lines = [f"{len(study.cases)} cases, runner {study.runner}, {study.ranks_per_case} rank(s) per case"]
    for c in study.cases:
        lines.append(f"  {c.name}: " + ", ".join(f"{k} = {v}" for k, v in c.overrides.items()))
    if study.runner == "analytic":
        lines.append("estimated cost: well under a second per case (bearing-capacity model)")
    else:
        kinds = sorted({(c.scene.loading.protocol.split("-")[0], c.scene.model.mesh_name, c.scene.model.refinement,
                         c.scene.model.accuracy) for c in study.cases}, key=str)
        lines.append("estimated cost per case on 2 cores (development machine): "
                     + ", ".join(f"{p} at {name}: {_cost_hint(p, accuracy, n)}" for p, name, n, accuracy in kinds))
    return lines
