"""Extreme soils: each run ends as expected or with a clear message, never hangs; two problems.

``matrix``: Extremes matrix: every corner of the soil range run with default settings, each cell ending
``ok``, ``exceeds_capacity`` or a named clean failure within a wall-time guard (never a hang).

    python -m benchmarks extremes matrix --out benchmarks/results/extremes_fast.json
    python -m benchmarks extremes matrix --model relaxation_fallback=0 --out benchmarks/results/extremes_fast.json
    python -m benchmarks extremes matrix --accuracy standard --out benchmarks/results/extremes_standard.json
    python -m benchmarks extremes matrix --model relaxation_fallback="0.005 mm" --cells relaxed \\
        --out benchmarks/results/extremes_fast.json      # the cells the plain scenes relaxed, length halved
    python -m benchmarks extremes matrix --cells fast --out fast_subset.json      # the test suite's cells
    python -m benchmarks extremes matrix --table benchmarks/results/extremes_fast.json

Each cell is a plain ``rollsim run`` indentation scene (Mn/DOT wheel d = 1.524 m, mu = 0.8,
gamma = 20 kN/m^3, pushed to s/d = 0.1, no ``[model]`` key but the preset): its materials, the
regularising cohesion put in place of c = 0, the contact penalty and the solver options are the
scene's (``rollsim.solver.scene_model``), on the plane-strain section of the wheel (symmetric half
block 1.5 x 1.5 d, the preset's elements per d) so that the whole matrix runs in about half an hour
on one core.  ``--model KEY=VALUE`` sets ``[model]`` keys in every scene (e.g.
``relaxation_fallback=0``: no relaxation after a failure; such rows are kept apart in the table).

Matrix: phi_dp in {0, 30, 55, 65} deg (0: von Mises) x psi in {0, phi/2, phi} x c_dp in
{0, 1, 20, 200} kPa (c = 0 needs phi > 0) x nu in {0.2, 0.35, 0.49} x E/(gamma d) in
{300, 1300, 5000}; plus two layers with a 30:1 strength contrast both ways (von Mises 20 / 600 kPa,
top 0.4 d), a tiny load (1 kN/m by load control: elastic) and a load 10x the capacity reached at
s/d = 0.1 (load control: ``exceeds_capacity``).  The results file is resumed: cells already in it
are not run again.  The table counts the outcomes per phi_dp and c_dp with the largest steps,
Newton iterations, cuts and wall time, and lists every cell that did not end as expected.

``wheel``: Extreme soils on the 3D wheel (quarter block, fast preset): each case either converges or
fails with a clear message and the last converged state kept - never hangs (wall-clock guard).

    python -m benchmarks extremes wheel --out bench_extremes_3d.json
    python -m benchmarks extremes wheel --cases tiny_load above_capacity --max-wall 120

Mn/DOT wheel d = 1.524 m, b = 0.4572 m, fillet b/12, mu = 0.8, gamma = 20 kN/m^3; pushed to
s/d = ``--sinkage`` (displacement control) unless the case is load-controlled.  Base soil: report
case 5 (Drucker-Prager phi_dp = 27.5 deg, c_dp = 194.6 kPa, E = 40 MPa, nu = 0.35, psi = 0).

cases: phi_dp_60 (phi_dp = 60 deg, c_dp = 50 kPa, psi = 0), nu_0.49 (von Mises c_dp = 200 kPa),
E_300 / E_5000 (E/(gamma d) = 300 / 5000 with the base strength), tiny_load (Q_V = 1 kN by load
control: elastic only, no plastic point), above_capacity (load control at 10x the capacity
reached at the sinkage limit: "exceeds capacity"), layers_30_1 / layers_1_30 (top 0.4 d with
c_dp = 20 kPa over 600 kPa and the reverse, von Mises).

Prints one row per case: outcome, sinkage reached, Q_V, steps, Newton iterations, cuts, Newton
plateaus accepted, plastic points, wall time, and the message on failure.
"""
from __future__ import annotations

import argparse
import dataclasses
import math
import re
import sys
import time

from mpi4py import MPI

from _bench import add_results_arguments, dump_json, run_problems, saved_results, show_table

from rollsim.geometry import (CylinderWheel, MeshOptions, PlaneStrainBlock, build_plane_strain_block, build_soil_block,
                              indentation_block)
from rollsim.scene import parse_scene
from rollsim.solver import DruckerPrager, SolverDivergedError, StepControl, VonMises
from rollsim.solver.contact import Circle
from rollsim.solver.indentation import DEFAULT_STEP_CONTROL, WheelIndentation
from rollsim.solver.scene_model import block_depth, layer_materials, solver_options

D, GAMMA, MU = 1.524, 20e3, 0.8
S_OVER_D = 0.1
PHI_DP = (0.0, 30.0, 55.0, 65.0)
PSI = ("0", "phi/2", "phi")
C_KPA = (0.0, 1.0, 20.0, 200.0)
NU = (0.2, 0.35, 0.49)
E_RATIO = (300.0, 1300.0, 5000.0)
SPECIAL = ("layers_30_1", "layers_1_30", "tiny_load", "above_capacity")
#: base soil of the special cells: phi_dp = 30 deg, psi = 0, c_dp = 200 kPa, nu = 0.35, E/(gamma d) = 1300
BASE = dict(phi_dp=30.0, psi="0", c_kpa=200.0, nu=0.35, e_ratio=1300.0)
#: the outcome each special cell must end with (every matrix cell: "ok")
EXPECTED = {"above_capacity": "exceeds_capacity"}
#: s/d the push lands on exactly (step boundaries, as the driver's report points)
STOPS = (0.01, 0.02, 0.05)
TINY_LOAD = 1e3                  # N per m of wheel width
ABOVE_CAPACITY_FACTOR = 10.0


@dataclasses.dataclass(frozen=True)
class Cell:
    """One soil of the matrix (angles in degrees, c_dp in kPa), or a special case of ``SPECIAL``."""

    phi_dp: float
    psi: str
    c_kpa: float
    nu: float
    e_ratio: float
    special: str = ""

    @property
    def name(self) -> str:
        if self.special:
            return self.special
        return f"phi{self.phi_dp:g}_psi{self.psi}_c{self.c_kpa:g}_nu{self.nu:g}_E{self.e_ratio:g}"

    @property
    def dilation(self) -> float:
        """psi, degrees."""
        return {"0": 0.0, "phi/2": self.phi_dp / 2, "phi": self.phi_dp}[self.psi]

    @property
    def expected(self) -> str:
        return EXPECTED.get(self.special, "ok")

    def layers(self) -> list[dict]:
        """The ``[[soil.layers]]`` tables of the cell's scene."""
        E = f"{self.e_ratio * GAMMA * D / 1e6:.6g} MPa"
        if self.special.startswith("layers"):
            top, bottom = (20, 600) if self.special == "layers_30_1" else (600, 20)
            return [{"model": "von-mises", "E": E, "nu": self.nu, "c_dp": f"{top} kPa", "thickness": f"{0.4 * D:g} m"},
                    {"model": "von-mises", "E": E, "nu": self.nu, "c_dp": f"{bottom} kPa"}]
        if self.phi_dp == 0:
            return [{"model": "von-mises", "E": E, "nu": self.nu, "c_dp": f"{self.c_kpa:g} kPa"}]
        return [{"model": "drucker-prager", "E": E, "nu": self.nu, "phi_dp": f"{self.phi_dp:g} deg",
                 "c_dp": f"{self.c_kpa:g} kPa", "dilation": f"{self.dilation:g} deg"}]

    def scene(self, accuracy: str, model: dict | None = None):
        """The indentation scene of the cell: no ``[model]`` key but the preset and ``model``."""
        return parse_scene({
            "wheel": {"type": "rigid", "shape": "cylinder", "diameter": f"{D} m", "width": "0.4572 m",
                      "friction": MU},
            "soil": {"gamma": f"{GAMMA / 1e3:g} kN/m^3", "layers": self.layers()},
            "loading": {"protocol": "indentation", "max_sinkage": f"{S_OVER_D * D:g} m"},
            "model": {"accuracy": accuracy, **(model or {})}})


def matrix() -> list[Cell]:
    """Every cell: the soil matrix (c = 0 only with friction, psi only with friction) and the special cases."""
    cells = []
    for phi in PHI_DP:
        for psi in (PSI if phi else PSI[:1]):
            for c in C_KPA:
                if phi == 0 and c == 0:
                    continue
                cells += [Cell(phi, psi, c, nu, e) for nu in NU for e in E_RATIO]
    return cells + [Cell(**{**BASE, "special": s}) for s in SPECIAL]


#: the test suite's cells: each axis at its extreme, the steepest non-associated cones with c = 0
FAST = ("phi65_psi0_c0_nu0.35_E1300", "phi55_psi0_c0_nu0.2_E300", "phi30_psiphi_c0_nu0.49_E5000",
        "phi0_psi0_c1_nu0.49_E300", "phi65_psiphi/2_c200_nu0.2_E5000", "layers_30_1", "layers_1_30",
        "tiny_load", "above_capacity")


def plane_strain_mesh(scene, comm: MPI.Comm):
    """Symmetric plane-strain section of the scene's indentation block (1.5 d wide, the scene's
    depth and layers, refined 0.25 d x 0.5 d under the wheel, the preset's elements per d)."""
    d = scene.wheel.diameter
    block = PlaneStrainBlock(half_width=1.5 * d, depth=block_depth(scene) * d, contact_half_width=0.25 * d,
                             refined_half_width=0.25 * d, refined_depth=0.5 * d, symmetric=True,
                             layers=tuple(layer.thickness for layer in scene.soil.layers[:-1]))
    return build_plane_strain_block(comm, block, MeshOptions.from_refinement(d, scene.model.elements_per_d))


def _wheel(scene, tagged):
    soil = layer_materials(scene)
    return WheelIndentation(tagged, Circle(scene.wheel.diameter), soil.single_or_dict, **solver_options(scene)), soil


def run_cell(comm: MPI.Comm, cell: Cell, accuracy: str = "fast", guard: float = 300.0,
             model: dict | None = None) -> dict:
    """Run ``cell`` on ``comm`` with the wall-time ``guard`` (s) and the ``[model]`` keys ``model``
    besides the preset (none: the plain scene); its row of the table."""
    t0 = time.perf_counter()
    model = dict(model or {})
    scene = cell.scene(accuracy, model)
    tagged = plane_strain_mesh(scene, comm)
    ind, soil = _wheel(scene, tagged)
    s_max = scene.loading.max_sinkage
    row = {"cell": cell.name, "accuracy": accuracy, "model": model, "expected": cell.expected, "dofs": ind.n_dofs,
           "regularising_cohesion_Pa": max(soil.regularised.values(), default=0.0)}

    def control():
        return dataclasses.replace(DEFAULT_STEP_CONTROL, max_wall_time=max(guard - (time.perf_counter() - t0), 1e-3))

    try:
        ind.gravity_step()
        if cell.special in ("tiny_load", "above_capacity"):
            load = TINY_LOAD
            if cell.special == "above_capacity":
                probe, _ = _wheel(scene, tagged)
                probe.gravity_step()
                probe.push(s_max, control=control())
                load = ABOVE_CAPACITY_FACTOR * max(st.QV for st in probe.steps)
            res = ind.push_to_load(load, s_max, control=control())
            row.update(outcome=res.status, message=res.reason, load_N_per_m=load,
                       plastic=ind.steps[-1].plastic if ind.steps else 0)
        else:
            ind.push(S_OVER_D * D, control=control(), stops=[r * D for r in STOPS])
            row.update(outcome="ok", message="")
    except SolverDivergedError as err:
        row.update(outcome=err.kind, message=str(err).splitlines()[0][:300])
    last = ind.steps[-1] if ind.steps else None
    row.update(s_over_d=ind.sinkage / D, QV_N_per_m=last.QV if last else 0.0, steps=len(ind.steps),
               newton_iterations=ind.newton_iterations, cuts=ind.cuts,
               plateaus=ind.problem.plateaus["accepted"], relaxed_stretches=len(ind.relaxed_spans),
               relaxed_s_over_d=sum(b - a for a, b in ind.relaxed_spans) / D, time_s=time.perf_counter() - t0)
    return row


def settings(r: dict) -> str:
    """The preset of a row and the ``[model]`` keys it set ("fast" for a plain fast scene)."""
    return ", ".join([r["accuracy"]] + [f"{k} = {v}" for k, v in sorted(r.get("model", {}).items())])


def table(rows: list[dict]) -> str:
    """Markdown: per (phi_dp, c_dp) group and settings run on the whole matrix, the cells that
    ended as expected, the largest steps / Newton iterations / cuts and wall time and the relaxed
    stretches; then per settings the count of cells that ended as expected, and every cell of the
    plain settings (no ``[model]`` key) that did not."""
    groups: dict = {}
    for r in rows:
        m = re.match(r"phi([\d.]+)_psi[^_]+_c([\d.]+)_", r["cell"])
        label = f"phi_dp = {m[1]} deg, c_dp = {m[2]} kPa" if m else "special cases"
        groups.setdefault(label, {}).setdefault(settings(r), []).append(r)
    names = sorted({settings(r) for r in rows}, key=lambda name: (", " in name, name))
    n_cells = len(matrix())
    whole = [n for n in names if len({r["cell"] for r in rows if settings(r) == n}) == n_cells] or names
    head = ["soil", "cells"]
    for name in whole:       # settings run on part of the matrix: in the counts below only
        head += [f"{name}: as expected", f"{name}: largest steps / Newton its / cuts",
                 f"{name}: relaxed stretches (cells)", f"{name}: largest wall time (s)"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for label in sorted(groups, key=_order):
        by = groups[label]
        line = [label, str(max(len(rs) for rs in by.values()))]
        for name in whole:
            rs = by.get(name, [])
            if not rs:
                line += ["", "", "", ""]
                continue
            line += [f"{sum(r['outcome'] == r['expected'] for r in rs)} / {len(rs)}",
                     f"{max(r['steps'] for r in rs)} / {max(r['newton_iterations'] for r in rs)} / "
                     f"{max(r['cuts'] for r in rs)}",
                     f"{sum(r.get('relaxed_stretches', 0) for r in rs)} "
                     f"({sum(r.get('relaxed_stretches', 0) > 0 for r in rs)})",
                     f"{max(r['time_s'] for r in rs):.0f}"]
        lines.append("| " + " | ".join(line) + " |")
    lines.append("")
    for name in names:
        rs = [r for r in rows if settings(r) == name]
        bad = [r for r in rs if r["outcome"] != r["expected"]]
        counts = {k: sum(r["outcome"] == k for r in bad) for k in sorted({r["outcome"] for r in bad})}
        others = " (" + ", ".join(f"{n} {k}" for k, n in counts.items()) + ")" if bad else ""
        lines.append(f"- {name}: {len(rs) - len(bad)} of {len(rs)} cells ended as expected{others}.")
    plain = [r for r in rows if settings(r) == names[0] and r["outcome"] != r["expected"]]
    if plain:
        lines += ["", f"| {names[0]}: cell | outcome | s/d reached | steps | Newton its | cuts | relaxed stretches |",
                  "|---|---|---|---|---|---|---|"]
        lines += [f"| {r['cell']} | {r['outcome']} | {r['s_over_d']:.4f} | {r['steps']} | {r['newton_iterations']} "
                  f"| {r['cuts']} | {r.get('relaxed_stretches', 0)} |" for r in plain]
    return "\n".join(lines)


def _order(label: str):
    nums = [float(x) for x in re.findall(r"[\d.]+", label)] if not label.startswith("special") else [1e9]
    return nums, label


def select(names: list[str] | None, rows: list[dict] = (), accuracy: str = "fast") -> list[Cell]:
    """The cells named (``fast``: the test suite's subset; ``relaxed``: those the plain scenes of
    ``accuracy`` in ``rows`` relaxed; none: all)."""
    cells = matrix()
    if not names:
        return cells
    if names == ["fast"]:
        wanted = set(FAST)
    elif names == ["relaxed"]:
        wanted = {r["cell"] for r in rows if settings(r) == accuracy and r.get("relaxed_stretches", 0) > 0}
    else:
        wanted = set(names)
    unknown = wanted - {c.name for c in cells}
    if unknown:
        raise SystemExit(f"--cells: unknown cell(s) {', '.join(sorted(unknown))}")
    return [c for c in cells if c.name in wanted]


def parse_model(items: list[str]) -> dict:
    """``["key=value", ...]`` of ``--model`` -> ``{key: value}`` (a value that reads as a number is one)."""
    model = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise SystemExit(f"--model: expected KEY=VALUE, got {item!r}")
        try:
            model[key] = float(value)
        except ValueError:
            model[key] = value
    return model


def run_matrix(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks extremes matrix",
                                description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--accuracy", choices=("fast", "standard", "accurate"), default="fast")
    p.add_argument("--cells", nargs="+", help="cell names, 'fast' (the test suite's subset) or 'relaxed' (the "
                   "cells the plain scenes in --out relaxed; default: all)")
    p.add_argument("--guard", type=float, default=300.0, help="wall-time guard per cell, s")
    p.add_argument("--model", nargs="+", default=[], metavar="KEY=VALUE",
                   help='[model] keys set in every scene, e.g. relaxation_length="0.01 mm" (default: none)')
    add_results_arguments(p)
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    if args.table:
        return show_table(comm, table, saved_results(args.table))
    rows = saved_results(args.out)
    model = parse_model(args.model)
    done = {(r["cell"], settings(r)) for r in rows}
    cells = select(args.cells, rows, args.accuracy)
    for i, cell in enumerate(cells):
        if (cell.name, settings({"accuracy": args.accuracy, "model": model})) in done:
            continue
        row = run_cell(comm, cell, args.accuracy, args.guard, model)
        rows.append(row)
        if comm.rank == 0:
            print(f"[{i + 1}/{len(cells)}] {cell.name}: {row['outcome']}, s/d {row['s_over_d']:.4f}, "
                  f"{row['steps']} steps, {row['newton_iterations']} its, {row['cuts']} cuts, "
                  f"{row['time_s']:.1f} s {row['message'][:100]}", flush=True)
        dump_json(comm, args.out, {"args": vars(args), "results": rows})
    return show_table(comm, table, rows)


B = 0.4572                       # the 3D wheel's width, m
DEG = math.pi / 180
BASE_3D = dict(E=40e6, nu=0.35, phi_dp=27.5 * DEG, c_dp=194.6e3, dilation=0.0)
CASES = ("phi_dp_60", "nu_0.49", "E_300", "E_5000", "tiny_load", "above_capacity", "layers_30_1", "layers_1_30")


def materials(case):
    if case == "phi_dp_60":
        return DruckerPrager(**{**BASE_3D, "phi_dp": 60 * DEG, "c_dp": 50e3}), ()
    if case == "nu_0.49":
        return VonMises(E=40e6, nu=0.49, yield_stress=200e3), ()
    if case in ("E_300", "E_5000"):
        return DruckerPrager(**{**BASE_3D, "E": float(case[2:]) * GAMMA * D}), ()
    if case.startswith("layers"):
        weak, strong = VonMises(E=40e6, nu=0.35, yield_stress=20e3), VonMises(E=40e6, nu=0.35, yield_stress=600e3)
        top, bottom = (weak, strong) if case == "layers_30_1" else (strong, weak)
        return {1: top, 2: bottom}, (0.4,)
    return DruckerPrager(**BASE_3D), ()


def run_case(comm, case, args):
    t0 = time.perf_counter()
    mats, layers = materials(case)
    tm = build_soil_block(comm, indentation_block(D, layers=layers), MeshOptions.from_accuracy(D, args.accuracy))
    ind = WheelIndentation(tm, CylinderWheel(D, B, B / 12), mats, gamma=GAMMA, friction=0.8)
    ctl = StepControl(dt=0.05, dt_min=1e-4, dt_max=0.2, easy_iterations=8, max_cuts=10, max_wall_time=args.max_wall)
    row = {"case": case, "dofs": ind.n_dofs}
    try:
        ind.gravity_step()
        if case == "tiny_load":
            res = ind.push_to_load(1e3, 0.02 * D, control=ctl)
            row.update(outcome=res.status, message=res.reason)
        elif case == "above_capacity":
            probe = WheelIndentation(tm, CylinderWheel(D, B, B / 12), mats, gamma=GAMMA, friction=0.8)
            probe.gravity_step()
            probe.push(args.sinkage * D, control=ctl)
            target = 10 * max(st.QV for st in probe.steps)
            res = ind.push_to_load(target, args.sinkage * D, control=ctl)
            row.update(outcome=res.status, message=res.reason, target_QV=target)
        else:
            ind.push(args.sinkage * D, control=ctl)
            row.update(outcome="ok", message="")
    except SolverDivergedError as err:
        row.update(outcome="failed", message=str(err))
    last = ind.steps[-1] if ind.steps else None
    row.update(sinkage=ind.sinkage, QV=last.QV if last else 0.0, plastic=last.plastic if last else 0,
               steps=len(ind.steps), newton_iterations=ind.newton_iterations, cuts=ind.cuts,
               plateaus=ind.problem.plateaus["accepted"], time_s=comm.allreduce(time.perf_counter() - t0, op=MPI.MAX))
    return row


def run_wheel(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks extremes wheel",
                                description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--cases", nargs="+", default=list(CASES), choices=CASES)
    p.add_argument("--sinkage", type=float, default=0.05, help="s/d of the displacement-controlled pushes")
    p.add_argument("--accuracy", default="fast")
    p.add_argument("--max-wall", type=float, default=300.0, help="wall-clock guard per case, s")
    p.add_argument("--out")
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    rows = []
    if comm.rank == 0:
        print(f"{'case':15s} {'outcome':17s} {'s/d':>7s} {'Q_V kN':>9s} {'plastic':>7s} {'steps':>5s} {'its':>5s} "
              f"{'cuts':>4s} {'plat.':>5s} {'wall s':>7s}  message", flush=True)
    for case in args.cases:
        r = run_case(comm, case, args)
        rows.append(r)
        if comm.rank == 0:
            print(f"{case:15s} {r['outcome']:17s} {r['sinkage'] / D:7.4f} {r['QV'] / 1e3:9.1f} {r['plastic']:7d} "
                  f"{r['steps']:5d} {r['newton_iterations']:5d} {r['cuts']:4d} {r['plateaus']:5d} {r['time_s']:7.1f}  "
                  f"{r['message'][:160]}", flush=True)
    dump_json(comm, args.out, {"args": vars(args), "rows": rows})
    return 0



if __name__ == "__main__":
    sys.exit(run_problems({"matrix": run_matrix, "wheel": run_wheel}, __doc__))
