"""The two rolling protocols agree, and the effect of wheel friction at constant load.

    python -m benchmarks rolling_protocols --out bench_rolling_protocols.json
    mpirun -n 2 python -m benchmarks rolling_protocols --load 100 --mu 0 0.8

Soil: clay, von Mises q_y = ``--yield-stress`` (default 300 kPa, i.e. c = 150 kPa), E = 40 MPa,
nu = 0.35, gamma = 20 kN/m^3; Mn/DOT roller wheel d = 1.524 m, b = 0.4572 m; half block
(``--length/--half-width/--depth`` in d), ``--accuracy`` preset (or ``--refinement``, elements per d),
``--volumetric-strain`` (default pointwise), ``--relaxation-length`` (mm; Duvaut-Lions, default off),
``--fallbacks`` (the relaxation fallbacks of a plain ``rollsim run`` scene; default off: fail instead);
``--phi-dp`` > 0 makes the soil a Drucker-Prager cone with c_dp = ``--yield-stress``.

For each friction coefficient mu:

1. ``rolling-constant-load`` at Q_V = ``--load`` kN: pressed on the stiff start zone
   (``--stiff`` d), rolled until steady, lifted; steady sinkage s_cl, Q_H, rut depth, rebound.
2. ``rolling-continuous`` on the same block without stiff zone: pressed to s0 and rolled while the
   sinkage is ramped to ``--s-end`` d over ``--travel`` d; the sinkage s_cont at which the curve
   Q_V(s) crosses the load (linear interpolation along the run; ``--ramp`` d < travel holds the
   final sinkage).
3. With ``--hold``: the continuous protocol ramped to s_cl over ``--ramp`` d (``--s0`` from the
   start) and held there to ``--travel`` d: the steady Q_V at s_cl (mean of the held steps after
   0.5 d) and the sinkage at which this steady curve carries the load (Q_V slope from the ramp's
   last half).  This removes the ramp-rate bias of step 2 (the wheel is still descending there).

    mpirun -n 2 python -m benchmarks rolling_protocols --mu 0 --length 2.6 --cl-travel 1.5 \
        --skip-continuous --hold --s0 0.002 --ramp 1.0 --travel 2.0 --cont-length 3.2

``--checkpoint DIR`` writes the state of each rolling run every ``--checkpoint-every`` steps;
started again with the same arguments (on any number of ranks) a killed run continues from its
last checkpoint, and with other arguments it stops (exit 2) naming them.

Prints s_cl, s_cont and their difference (the agreement criterion is 5 %), Q_H of both,
the friction effect on the steady sinkage (mu vs the first mu), wall times, steps and linear solves.
``--table`` prints the held Q_V of saved runs as a Markdown table without solving, each change
against the same strain's mesh twice as coarse along one axis (mesh convergence at a held sinkage)
and each pointwise Q_V against B-bar's on its mesh, and, for each mesh held at two sinkages, the
sinkage at which the steady Q_V(s) carries the load. Runs of other soils, friction or travel are
compared only among themselves, in rows that name what sets them apart.
"""
from __future__ import annotations

import argparse
import dataclasses
import json
import math
import pathlib
import sys
import time

import numpy as np
from mpi4py import MPI

from _bench import add_volumetric_strain, dump_json

from rollsim.files import atomic_write_text, complete_directory
from rollsim.geometry import CylinderWheel, MeshOptions, build_soil_block, rolling_block
from rollsim.geometry.mesh import ANISOTROPIC_REFINEMENTS
from rollsim.log import setup_logging
from rollsim.mpi import root_block
from rollsim.solver import DruckerPrager, SolverDivergedError, VonMises
from rollsim.solver.checkpoint import staged
from rollsim.solver.drivers.rolling_constant_load import measure_rut
from rollsim.solver.options import DEFAULT_RELAXATION_FALLBACK, DEFAULT_TRAVEL_RELAXATION_FALLBACK
from rollsim.solver.rolling import STEADY_MIN_TRAVEL, WheelRolling, constant_load_control
from rollsim.solver.rundir import TravelProgress
from rollsim.solver.stepping import StepControl

D, B, GAMMA = 1.524, 0.4572, 20e3
#: the axis along which each anisotropic mesh field shortens the refined strip's hexahedra
SHORTER = dict(zip(ANISOTROPIC_REFINEMENTS, ("along the path", "across the path", "in depth")))
#: depth of the refined strip (d) unless ``--refined-depth`` is given
REFINED_DEPTH = 0.4


def _block(comm, args, stiff, length=None):
    blk = rolling_block(D, length=length or args.length, half_width=args.half_width, depth=args.depth, stiff_length=stiff,
                        path_half_width=args.path_half_width, refined_depth=args.refined_depth)
    mesh = (MeshOptions.from_refinement(D, args.refinement, hexahedra=args.hexahedra) if args.refinement
            else MeshOptions.from_accuracy(D, args.accuracy, hexahedra=args.hexahedra))
    return build_soil_block(comm, blk, dataclasses.replace(mesh, **{k: getattr(args, k) for k in SHORTER}))


def soil(args):
    """The soil: von Mises q_y = ``--yield-stress``, or with ``--phi-dp`` > 0 a Drucker-Prager cone
    (c_dp = ``--yield-stress``, psi = 0)."""
    if args.phi_dp > 0:
        return DruckerPrager(E=40e6, nu=0.35, phi_dp=np.radians(args.phi_dp), c_dp=args.yield_stress * 1e3)
    return VonMises(E=40e6, nu=0.35, yield_stress=args.yield_stress * 1e3)


def regularisation(args) -> dict:
    """Keywords of ``WheelRolling`` for the soil's regularisation: the relaxation length and, with
    ``--fallbacks``, the relaxation fallbacks a plain scene gets."""
    kw = {"relaxation_length": 1e-3 * args.relaxation_length}
    if args.fallbacks:
        kw.update(relaxation_fallback=DEFAULT_RELAXATION_FALLBACK,
                  travel_relaxation_fallback=DEFAULT_TRAVEL_RELAXATION_FALLBACK)
    return kw


def travel_control(travel: float, step_mm: float) -> StepControl | None:
    """Constant-load travel steps of ``step_mm`` (mm; back to it after a cut), or ``None`` for the
    solver's default (``WheelRolling.travel_step``)."""
    if not step_mm:
        return None
    return constant_load_control(travel, 1e-3 * step_mm)


def constant_load(comm, mu, args):
    t0 = time.perf_counter()
    mat = soil(args)
    tm = _block(comm, args, args.stiff)
    roll = WheelRolling(tm, CylinderWheel(D, B, B / 12), mat, gamma=GAMMA, friction=mu,
                        volumetric_strain=args.volumetric_strain, volumetric_projection=args.volumetric_projection,
                        **regularisation(args))
    roll.gravity_step()
    load = args.load * 1e3
    out = {"mu": mu, "cells": tm.stats.cells, "dofs": roll.n_dofs, "status": "ok"}
    on_step, before = resumable(roll, args, "constant_load", mu, args.cl_travel * D)
    resumed, time_before = before is not None, before or 0.0
    try:
        if not resumed:
            res = roll.press_to_load(load, 0.25 * D)
            if res.status != "ok":
                raise SolverDivergedError(f"press: {res.status} {res.reason}", None, [])
        done = roll.position - roll.x_start
        ss = roll.roll_at_load(load, args.cl_travel * D - done, x_soft=args.stiff * D, steady_rtol=args.steady_rtol,
                               min_travel=args.steady_min_travel * D, on_step=on_step,
                               control=travel_control(args.cl_travel * D, args.travel_step), resumed=resumed)
        L = roll.contact_length()
        # the rolled steps only: the lift-off moves the wheel vertically without a torque balance
        max_rel_moment = max(abs(st.moment) / (load * D) for st in roll.steps if st.travel > 0)
        out.update(steady=ss.reached, s_cl=ss.sinkage, QH_cl=ss.QH, travel_at_steady=ss.travel,
                   max_rel_moment=max_rel_moment, linear_solves=int(sum(st.linear_solves for st in roll.steps)))
        try:
            roll.lift()
        except SolverDivergedError as err:      # as rollsim run: the rolling result stands, the rut is lost
            out["lift_failure"] = str(err)
        else:
            rut = measure_rut(roll, ss, args.stiff * D, L)
            out.update(rut_depth=rut["rut_depth_m"], rebound=rut["rebound_m"])
    except SolverDivergedError as err:
        out["status"] = f"failed: {err}"
    out.update(steps=len(roll.steps), newton_iterations=roll.newton_iterations, cuts=roll.cuts,
               time_s=comm.allreduce(time.perf_counter() - t0, op=MPI.MAX) + time_before,
               relaxed_travel=[[float(a), float(b)] for a, b in roll.relaxed_travel],
               travel_failures=[float(x) for x in roll.travel_failures],
               curve=[(st.travel, st.sinkage, st.QV, st.QH) for st in roll.steps])
    out["settled"] = settled(out["curve"], load, args.settled * D)
    return out


#: fewest steps a mean over held or late rolled steps is taken from (fewer: no figure)
MIN_STEPS = 3


def settled(curve, load: float, from_travel: float) -> dict | None:
    """Statistics of the rolled steps at the load (not the press or the lift-off) of a
    constant-load ``curve`` [(travel, sinkage, Q_V, Q_H)] from ``from_travel`` (m) on: mean and
    standard deviation of the sinkage and of Q_H, mean |ds/dx|, and Q_H at ds/dx = 0 from a
    least-squares line of Q_H against the step's slope ds/dx (None: fewer than ``MIN_STEPS`` steps)."""
    x, s, q, qh = np.array(curve, dtype=float).reshape(-1, 4).T
    on = (q > 0.99 * load) & (x > 0)
    x, s, qh = x[on], s[on], qh[on]
    slope = np.diff(s) / np.diff(x)
    late = x[1:] >= from_travel
    if late.sum() < MIN_STEPS:
        return None
    s, qh, slope = s[1:][late], qh[1:][late], slope[late]
    return {"from_travel": from_travel, "steps": len(s), "sinkage_mean": float(s.mean()),
            "sinkage_std": float(s.std()), "QH_mean": float(qh.mean()), "QH_std": float(qh.std()),
            "mean_abs_slope": float(np.abs(slope).mean()), "QH_at_zero_slope": float(np.polyfit(slope, qh, 1)[1])}


def _sinkage_at_load(s_fit, slope, s_hold, q_hold, load):
    """The sinkage (m) at which the steady curve through ``q_hold`` (N) at ``s_hold`` with the
    ``slope`` (N/m) fitted over the sinkages ``s_fit`` carries ``load``; None where the slope does
    not grow or the line is read further from ``s_hold`` than the width of ``s_fit``."""
    if slope <= 0:
        return None
    s = s_hold + (load - q_hold) / slope
    return s if abs(s - s_hold) <= np.ptp(s_fit) else None


def held_steps(travel, ramp: float) -> np.ndarray:
    """Mask of the steps averaged into the steady Q_V of a held run: those at a travel (m) past the
    ramp (``ramp`` d) and half a diameter of holding."""
    return np.asarray(travel) >= (ramp + 0.5) * D


def continuous(comm, mu, args, s_hold=None):
    """The continuous protocol; with ``s_hold`` (m) the sinkage is ramped to it over ``--ramp`` d
    and then held to the end of ``--travel`` (steady rolling at a fixed sinkage)."""
    t0 = time.perf_counter()
    mat = soil(args)
    roll = WheelRolling(_block(comm, args, 0.0, args.cont_length), CylinderWheel(D, B, B / 12), mat, gamma=GAMMA,
                        friction=mu, volumetric_strain=args.volumetric_strain,
                        volumetric_projection=args.volumetric_projection, **regularisation(args))
    roll.gravity_step()
    out = {"mu": mu, "status": "ok", "s_hold": s_hold, "dofs": roll.n_dofs}
    s_end = args.s_end * D if s_hold is None else s_hold
    on_step, before = resumable(roll, args, "continuous" if s_hold is None else "hold", mu, args.travel * D)
    time_before = before or 0.0
    try:
        roll.press(args.s0 * D)
        done, ramp = roll.position - roll.x_start, (args.ramp or args.travel) * D
        if args.travel * D - done > 1e-9 * D:     # the rest of the roll and of its ramp
            roll.roll(args.travel * D - done, s_end, ramp=ramp - done if ramp > done + 1e-9 * D else None,
                      dx=1e-3 * args.roll_step if args.roll_step else None, on_step=on_step,
                      predictor=args.predictor)
    except SolverDivergedError as err:
        out["status"] = f"failed: {err}"
    rolled = [st for st in roll.steps if st.travel > 0]
    q = np.array([st.QV for st in rolled])
    s = np.array([st.sinkage for st in rolled])
    qh = np.array([st.QH for st in rolled])
    x = np.array([st.travel for st in rolled])
    load = args.load * 1e3
    if s_hold is not None and args.ramp:
        # steady Q_V at the held sinkage (over the held steps), and the sinkage where
        # the steady curve carries the load: s_hold + (load - Q_hold) / (dQ_V/ds over the ramp's last half)
        held = held_steps(x, args.ramp)
        late = (x >= 0.5 * args.ramp * D) & (x < args.ramp * D)
        if held.sum() >= MIN_STEPS and late.sum() >= MIN_STEPS:
            slope = float(np.polyfit(s[late], q[late], 1)[0])
            q_hold = float(q[held].mean())
            out.update(QV_hold=q_hold, QV_hold_std=float(q[held].std()), QH_hold=float(qh[held].mean()),
                       slope=slope, s_steady=_sinkage_at_load(s[late], slope, s_hold, q_hold, load),
                       hold_steps=int(held.sum()))
    above = np.nonzero(q >= load)[0]
    if len(above) and above[0] > 0:
        i = above[0]
        w = (load - q[i - 1]) / (q[i] - q[i - 1])
        out.update(s_cont=float(s[i - 1] + w * (s[i] - s[i - 1])), QH_cont=float(qh[i - 1] + w * (qh[i] - qh[i - 1])))
    else:
        out["s_cont"] = None
    out.update(steps=len(roll.steps), newton_iterations=roll.newton_iterations, cuts=roll.cuts,
               time_s=comm.allreduce(time.perf_counter() - t0, op=MPI.MAX) + time_before,
               curve=[(st.travel, st.sinkage, st.QV, st.QH) for st in roll.steps])
    return out


#: arguments that do not change a rolling run's path (a checkpoint written with other
#: values of them is continued)
_NOT_THE_PATH = ("out", "progress", "checkpoint", "checkpoint_every", "table", "skip_continuous",
                 "skip_constant_load")


def checkpoint_dir(args, protocol: str, mu: float) -> pathlib.Path | None:
    """The checkpoint directory of one run (``protocol`` at friction ``mu``) under ``--checkpoint``."""
    where = getattr(args, "checkpoint", None)      # absent from the levels of the other benchmarks
    return pathlib.Path(where) / f"{protocol}_mu{mu:g}" if where else None


def resumable(roll: WheelRolling, args, protocol: str, mu: float, travel: float):
    """Continue ``roll`` (after its gravity step) from its checkpoint under ``--checkpoint``, if
    there is one (:func:`resume`), and its ``on_step``: a progress line to ``travel`` (m), and every
    ``--checkpoint-every`` steps the state.  Returns (``on_step``, what :func:`resume` returned)."""
    ckpt = checkpoint_dir(args, protocol, mu)
    before = resume(roll, ckpt, args)
    progress = TravelProgress(travel, D, enabled=args.progress and roll.comm.rank == 0,
                              start=roll.position - roll.x_start)

    def on_step(st):
        progress.update(st)
        if ckpt is not None and st.travel > 0 and len(roll.steps) % args.checkpoint_every == 0:
            write_checkpoint(roll, ckpt, args)
    return on_step, before


def write_checkpoint(roll: WheelRolling, ckpt: pathlib.Path, args) -> None:
    """The roll's state in ``ckpt``, with the arguments that set its path (``args.json``), written
    whole beside it and then put in its place (a kill leaves the previous checkpoint or this one)."""
    with staged(ckpt, roll.comm) as stage:
        with root_block(roll.comm) as on_root:
            if on_root:
                atomic_write_text(stage / "args.json", json.dumps({k: v for k, v in vars(args).items()
                                                                   if k not in _NOT_THE_PATH}, indent=1))
        roll.write_checkpoint(stage)


def resume(roll: WheelRolling, ckpt: pathlib.Path | None, args) -> float | None:
    """Continue ``roll`` (after its gravity step) from the checkpoint ``ckpt`` if there is one: the
    wall time (s) of the steps before it (the roll counts their Newton iterations), else None.  Raises ``SystemExit``
    (status 2) when the checkpoint was written with other arguments."""
    if ckpt is None:
        return None
    found = roll.comm.bcast(complete_directory(ckpt) if roll.comm.rank == 0 else None)
    if found is None:
        return None
    saved = json.loads((found / "args.json").read_text())
    defaults = parser()          # an argument added after the checkpoint was written: its default
    changed = [k for k, v in vars(args).items()
               if k not in _NOT_THE_PATH and saved.get(k, defaults.get_default(k)) != v]
    if changed:
        if roll.comm.rank == 0:
            print(f"--checkpoint: {ckpt} was written with other {', '.join('--' + k.replace('_', '-') for k in changed)}"
                  " (remove it to start over)", file=sys.stderr)
        raise SystemExit(2)
    roll.read_checkpoint(found)
    if roll.comm.rank == 0:
        print(f"continuing from {ckpt} at {(roll.position - roll.x_start) / D:.3f} d of travel "
              f"({len(roll.steps)} steps, {roll.newton_iterations} Newton iterations)", flush=True)
    return sum(st.time for st in roll.steps)


def parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--mu", type=float, nargs="+", default=[0.0, 0.8])
    p.add_argument("--load", type=float, default=100.0, help="Q_V, kN (whole wheel)")
    p.add_argument("--yield-stress", type=float, default=300.0, help="von Mises yield stress (or c_dp), kPa")
    p.add_argument("--phi-dp", type=float, default=0.0, help="Drucker-Prager friction angle, deg (0: von Mises)")
    p.add_argument("--accuracy", default="fast")
    p.add_argument("--refinement", type=float, help="elements per d under the wheel (overrides --accuracy)")
    p.add_argument("--length", type=float, default=2.4)
    p.add_argument("--half-width", type=float, default=0.8)
    p.add_argument("--depth", type=float, default=0.8)
    p.add_argument("--stiff", type=float, default=0.5, help="stiff start zone length, d")
    p.add_argument("--hexahedra", action="store_true",
                   help="structured 27-node hexahedra (B-bar: Q2-P1) instead of 10-node tetrahedra")
    for name, axis in SHORTER.items():
        p.add_argument(f"--{name.replace('_', '-')}", type=float, default=1.0,
                       help=f"with --hexahedra: the refined strip's elements this many times shorter {axis}")
    p.add_argument("--path-half-width", type=float, default=0.3, help="half width of the refined strip, d")
    p.add_argument("--refined-depth", type=float, default=REFINED_DEPTH, help="depth of the refined strip, d")
    p.add_argument("--cl-travel", type=float, default=1.3, help="constant-load travel limit, d")
    p.add_argument("--travel-step", type=float, default=0.0,
                   help="constant-load travel step, mm (0: the solver's default, WheelRolling.travel_step)")
    p.add_argument("--roll-step", type=float, default=0.0,
                   help="continuous travel step, mm (0: the solver's default, WheelRolling.travel_step)")
    p.add_argument("--predictor", choices=("none", "extrapolate"), default="none",
                   help="continuous and held rolling: Newton's start in each travel step (StepControl.predictor)")
    p.add_argument("--steady-rtol", type=float, default=0.02)
    p.add_argument("--steady-min-travel", type=float, default=STEADY_MIN_TRAVEL,
                   help="constant load: look for steady state after this travel (d) on the test soil")
    p.add_argument("--settled", type=float, default=1.0,
                   help="constant load: sinkage and Q_H statistics of the steps from this travel (d) on")
    p.add_argument("--s0", type=float, default=0.005)
    p.add_argument("--s-end", type=float, default=0.03)
    p.add_argument("--travel", type=float, default=1.2, help="continuous protocol travel, d")
    p.add_argument("--ramp", type=float, help="continuous: ramp the sinkage over this travel (d), then hold it")
    p.add_argument("--cont-length", type=float, help="block length of the continuous run, d (default --length)")
    p.add_argument("--hold", action="store_true",
                   help="also roll at the constant-load steady sinkage (ramped over --ramp d, then held)")
    p.add_argument("--hold-sinkage", type=float, nargs="+",
                   help="with --skip-constant-load: the constant-load steady sinkage (mm) of each --mu to hold")
    add_volumetric_strain(p)
    p.add_argument("--volumetric-projection", type=int, choices=(0, 1),
                   help="with --hexahedra and cell-average: the degree of the per-cell projection of the "
                        "volumetric strain (1, the default: Q2-P1; 0: the cell mean, Q2-P0)")
    p.add_argument("--relaxation-length", type=float, default=0.0,
                   help="Duvaut-Lions relaxation length of the soil, mm of travel (0: off)")
    p.add_argument("--fallbacks", action="store_true",
                   help="relax a failed step as a plain rollsim run scene does (default: fail)")
    p.add_argument("--progress", action="store_true",
                   help="one line per rolled step on stderr (travel, sinkage, forces, time left)")
    p.add_argument("--skip-continuous", action="store_true")
    p.add_argument("--skip-constant-load", action="store_true")
    p.add_argument("--checkpoint", metavar="DIR",
                   help="write the state of each rolling run to DIR every --checkpoint-every steps, and "
                        "continue from it when started again with the same arguments (any number of ranks)")
    p.add_argument("--checkpoint-every", type=int, default=10, metavar="STEPS")
    p.add_argument("--out")
    p.add_argument("--table", nargs="+", metavar="JSON", help="print the held Q_V of saved runs and stop")
    return p


#: arguments that set a held run's mesh and strain (the table's columns), and those only the
#: constant-load run reads; every other argument of the path, with the run's friction, is the
#: held run's scene, and only runs of one scene are compared
_NOT_THE_SCENE = ("volumetric_strain", "volumetric_projection", "refinement", "accuracy", "cross_refinement", "path_refinement",
                  "depth_refinement", "roll_step", "refined_depth", "hold_sinkage", "hold", "mu",
                  "length", "stiff", "cl_travel", "travel_step", "steady_rtol", "steady_min_travel", "settled",
                  "s_end")


def _scene(args: dict, mu: float) -> str:
    """The scene of a held run saved with ``args`` at friction ``mu``, as sorted JSON (arguments
    added after the run was saved count at their defaults)."""
    defaults = vars(parser().parse_args([]))
    keys = {k for k in set(args) | set(defaults) if k not in _NOT_THE_PATH + _NOT_THE_SCENE}
    scene = {k: args.get(k, defaults.get(k)) for k in keys}
    scene["cont_length"] = scene["cont_length"] or args.get("length", defaults["length"])
    return json.dumps(dict(scene, mu=mu), sort_keys=True)


def strain_name(args: dict) -> str:
    """The soil strain of a run saved with ``args``: its ``--volumetric-strain``, and for the cell
    mean (``--volumetric-projection 0``) "cell mean" (the default projection, Q2-P1, is "cell-average")."""
    return "cell mean" if args.get("volumetric_projection") == 0 else args["volumetric_strain"]


def held_runs(paths) -> list:
    """The held runs saved in ``paths`` (JSON files of this script) as (key, args, hold, mesh name),
    sorted by key = (scene of :func:`_scene`, strain, elements per d, held sinkage, refinement across,
    along, in depth, travel step in mm (0: the solver's default), depth of the refined strip in d)."""
    rows = []
    for path in paths:
        with open(path) as f:
            saved = json.load(f)
        a = saved["args"]
        for r in saved["results"]:
            h = r.get("hold")
            if not h or "QV_hold" not in h:
                continue
            step, strip = a.get("roll_step", 0.0), a.get("refined_depth", REFINED_DEPTH)
            shorter = [f"{a.get(k, 1.0):g}x {axis}" for k, axis in SHORTER.items() if a.get(k, 1.0) != 1.0]
            mesh = ", ".join(shorter) or "isotropic"
            rows.append(((_scene(a, h["mu"]), strain_name(a), a["refinement"] or 0.0, h["s_hold"],
                          a.get("cross_refinement", 1.0), a.get("path_refinement", 1.0),
                          a.get("depth_refinement", 1.0), step, strip), a, h,
                         mesh + (f" to {strip:g} d deep" if strip != REFINED_DEPTH else "")
                         + (f", {step:g} mm steps" if step else "")))
    return sorted(rows, key=lambda row: row[0])


def scene_column(rows) -> tuple[list, dict]:
    """The tables' scene column for ``rows``: its head and, per scene (of :func:`_scene`), its cell,
    the arguments in which the scene differs from the others, as options (friction aside, which
    has its column); no column (empty lists) for one scene."""
    scenes = {key[0]: json.loads(key[0]) for key, *_ in rows}
    differ = sorted(k for k in set().union(*scenes.values()) if k != "mu"
                    and len({json.dumps(s.get(k)) for s in scenes.values()}) > 1)
    cells = {key: [", ".join(f"--{k.replace('_', '-')} {_option(s.get(k))}" for k in differ)] * bool(differ)
             for key, s in scenes.items()}
    return ["scene"] * bool(differ), cells


def _option(value) -> str:
    return " ".join(map(_option, value)) if isinstance(value, list) else f"{value:g}" if isinstance(
        value, (int, float)) and not isinstance(value, bool) else str(value)


def coarser_meshes(refinements: tuple) -> list:
    """The discretisations (refinement across, along, in depth, travel step, depth of the refined
    strip) coarser than ``refinements``: for a run at a set travel step the same mesh at the
    solver's default step; then the meshes twice as coarse along one axis at the same step, and for
    a set step after them the same coarser meshes at the default step, in that order; all with the
    same strip, and for a strip of another depth than ``REFINED_DEPTH`` then again with that one."""
    mesh, step, strip = refinements[:3], refinements[3], refinements[4]
    coarser = [mesh[:i] + (mesh[i] / 2,) + mesh[i + 1:] for i in range(3) if mesh[i] >= 2]
    if not step:
        found = [c + (0.0,) for c in coarser]
    else:
        found = [mesh + (0.0,)] + [c + (step,) for c in coarser] + [c + (0.0,) for c in coarser]
    return [c + (strip,) for c in found] + ([c + (REFINED_DEPTH,) for c in found] if strip != REFINED_DEPTH else [])


def against_coarser(value: float, found: dict, group: tuple, refinements: tuple) -> tuple[str, str]:
    """("change", "against") cells: ``value`` against ``found[group + c]`` = (value, mesh name) of the
    first mesh ``c`` of :func:`coarser_meshes` that was run; empty cells when none was."""
    parent = next((found[group + c] for c in coarser_meshes(refinements) if group + c in found), None)
    return (f"{100 * (value / parent[0] - 1):+.1f} %", parent[1]) if parent else ("", "")


def _markdown(head, body) -> str:
    return "\n".join(["| " + " | ".join(head) + " |", "|---" * len(head) + "|"]
                     + ["| " + " | ".join(cells) + " |" for cells in body])


def hold_table(rows) -> str:
    """Markdown table of the held runs ``rows`` (of :func:`held_runs`); each change is against the run
    of the same scene, strain, elements per d and held sinkage on the first of
    :func:`coarser_meshes` that was run, named in the column "against"; a strain other than
    cell-average is also compared with the cell-average run of the same scene and mesh.  Runs of
    more than one scene get a column naming the arguments that tell them apart."""
    dofs = all("dofs" in h for _, _, h, _ in rows) and bool(rows)   # not kept by runs of earlier versions
    scene_head, scene = scene_column(rows)
    head = scene_head + ["strain", "elements / d", "refined strip", "μ", "held sinkage"] + ["dofs"] * dofs + [
        "Q_V (± std)", "change", "against", "against cell-average", "Q_H", "steps", "Newton its", "cuts",
        "wall time"]
    held = {key: (h["QV_hold"], mesh) for key, _, h, mesh in rows}
    body = []
    for key, a, h, mesh in rows:
        q = h["QV_hold"]
        change, against = against_coarser(q, held, key[:4], key[4:])
        bbar = held.get((key[0], "cell-average") + key[2:]) if key[1] != "cell-average" else None
        body.append(scene[key[0]] + [
            key[1], f"{a['refinement']:g}" if a["refinement"] else a["accuracy"],
            mesh, f"{h['mu']:g}", f"{1e3 * h['s_hold']:.2f} mm"] + [str(h.get("dofs", ""))] * dofs + [
            f"{q / 1e3:.1f} ± {h['QV_hold_std'] / 1e3:.1f} kN", change, against,
            f"{100 * (q / bbar[0] - 1):+.1f} %" if bbar else "", f"{h['QH_hold'] / 1e3:.1f} kN",
            str(h["steps"]), str(h["newton_iterations"]), str(h["cuts"]), f"{h['time_s']:.0f} s"])
    return _markdown(head, body)


#: length (in d) of the stretches of held travel over which the trend table averages Q_V
STRETCH = 0.2


def held_curve(args: dict, hold: dict) -> tuple[np.ndarray, np.ndarray] | None:
    """Travel (in d) and Q_V (N) of the held steps of a saved run (those averaged into
    ``QV_hold``), or None for a run without its kept curve, a ramp or ``MIN_STEPS`` held steps."""
    if not hold.get("curve") or not args.get("ramp"):
        return None
    x, q = np.array([(step[0], step[2]) for step in hold["curve"]]).T
    held = held_steps(x, args["ramp"])
    return (x[held] / D, q[held]) if held.sum() >= MIN_STEPS else None


def hold_trend(x: np.ndarray, q: np.ndarray) -> float:
    """How fast Q_V still moves over the held steps (``x`` in d, ``q`` of :func:`held_curve`): the
    slope of a straight line through them per wheel diameter of travel, relative to their mean
    (about 0 once steady)."""
    return float(np.polyfit(x, q, 1)[0] / q.mean())


def held_stretches(x: np.ndarray, q: np.ndarray) -> list[float]:
    """Mean Q_V (N) over successive stretches of ``STRETCH`` d of the held travel (``x``, ``q`` of
    :func:`held_curve`), each stretch closed at its end (the first also at its start)."""
    stretch = np.maximum(np.ceil((x - x[0]) / STRETCH - 1e-6).astype(int) - 1, 0)
    return [float(q[stretch == k].mean()) for k in np.unique(stretch)]


def hold_trend_table(rows) -> str:
    """Markdown table of :func:`hold_trend` and :func:`held_stretches` for the held runs ``rows``
    (of :func:`held_runs`)."""
    scene_head, scene = scene_column(rows)
    body = []
    for key, a, h, mesh in rows:
        if (curve := held_curve(a, h)) is None:
            continue
        x, q = curve
        body.append(scene[key[0]] + [key[1], mesh, f"{1e3 * h['s_hold']:.2f} mm",
                                     f"{100 * hold_trend(x, q):+.1f} %", f"{x[0]:.1f}-{x[-1]:.1f} d",
                                     " / ".join(f"{v / 1e3:.1f}" for v in held_stretches(x, q)) + " kN"])
    head = scene_head + ["strain", "refined strip", "held sinkage", "Q_V trend over the held steps, per d of travel",
                         "held travel", f"Q_V per {STRETCH:g} d of it"]
    return _markdown(head, body) if body else ""


READ_MARGIN = 1.1   # how far (a factor) beyond its two held points a power law is read


def sinkage_at_load(rows) -> str:
    """Markdown table of the steady sinkage that carries the load, for each mesh held at two or more
    sinkages: the power law Q_V = Q_1 (s / s_1)^n through the two held points nearest the load,
    solved for Q_V = load (the constant-load steady state, read off the steady force-sinkage curve).
    Each change is against the same scene's and strain's first of :func:`coarser_meshes`. Runs
    repeated at one sinkage count once (the last read); a mesh whose force does not grow with sinkage between
    the two points, or whose power law reaches the load more than ``READ_MARGIN`` times beyond
    them, is reported as such, without a sinkage."""
    scene_head, scene = scene_column(rows)
    meshes = {}
    for key, a, h, mesh in rows:
        meshes.setdefault((key[:3], key[4:]), (a, mesh, {}))[2][h["s_hold"]] = h["QV_hold"]
    found = {}
    body = []
    for (group, refinements), (a, mesh, by_sinkage) in sorted(meshes.items(), key=lambda item: item[0]):
        points = sorted(by_sinkage.items())
        if len(points) < 2:
            continue
        load = 1e3 * a["load"]
        (s1, q1), (s2, q2) = sorted(points, key=lambda p: abs(math.log(p[1] / load)))[:2]
        n = math.log(q2 / q1) / math.log(s2 / s1)
        s = s1 * (load / q1) ** (1 / n) if n > 0 else None
        lo, hi = sorted((s1, s2))
        if s is not None and lo / READ_MARGIN <= s <= READ_MARGIN * hi:
            found[group + refinements] = (s, mesh)
            sinkage = f"{1e3 * s:.2f} mm"
            change, against = against_coarser(s, found, group, refinements)
        else:
            sinkage = ("not read: Q_V does not grow with s" if s is None else
                       f"not read: the load lies {'below' if s < lo else 'above'} the held sinkages")
            change, against = "", ""
        body.append(scene[group[0]] + [
                     group[1], f"{a['refinement']:g}" if a["refinement"] else a["accuracy"], mesh,
                     " / ".join(f"{1e3 * p[0]:.2f}" for p in points) + " mm", f"{n:.3f}",
                     f"{a['load']:g} kN", sinkage, change, against])
    head = scene_head + ["strain", "elements / d", "refined strip", "held sinkages", "n = d ln Q_V / d ln s", "load",
            "sinkage at the load", "change", "against"]
    return _markdown(head, body) if body else ""


def _steady_line(hold: dict, cl: dict, load: float) -> str:
    """Where the steady curve of a held run carries ``load`` (kN), against the constant-load sinkage if run."""
    if hold.get("s_steady") is None:
        return (f"the ramp's slope ({hold['slope'] / 1e6:.2f} kN/mm) does not reach {load:g} kN near the held "
                "sinkage (hold at two sinkages and read --table)")
    line = (f"steady curve carries {load:g} kN at s = {1e3 * hold['s_steady']:.2f} mm "
            f"(slope {hold['slope'] / 1e6:.2f} kN/mm)")
    if cl["status"] != "given":
        line += f"; constant-load / steady - 1 = {100 * (cl['s_cl'] / hold['s_steady'] - 1):+.1f} %"
    return line


def main(argv=None) -> int:
    p = parser()
    args = p.parse_args(argv)
    if args.table:
        missing = [path for path in args.table if not pathlib.Path(path).is_file()]
        if missing:
            p.error(f"--table: no such file: {missing[0]}")
        rows = held_runs(args.table)
        print(hold_table(rows))
        for table in (sinkage_at_load(rows), hold_trend_table(rows)):
            if table:
                print("\n" + table)
        return 0
    comm = MPI.COMM_WORLD
    setup_logging(comm, quiet=not args.progress)
    results = []
    for name in ("travel_step", "roll_step"):
        if getattr(args, name) < 0:
            p.error(f"--{name.replace('_', '-')}: must be >= 0 mm, got {getattr(args, name):g}")
    if args.checkpoint_every < 1:
        p.error(f"--checkpoint-every: must be >= 1 step, got {args.checkpoint_every}")
    if args.volumetric_projection is not None and not (args.hexahedra and args.volumetric_strain == "cell-average"):
        p.error("--volumetric-projection: applies to --hexahedra with --volumetric-strain cell-average")
    if args.hold_sinkage and len(args.hold_sinkage) != len(args.mu):
        p.error("--hold-sinkage: give one sinkage per --mu value")
    for i, mu in enumerate(args.mu):
        if args.skip_constant_load:
            cl = {"mu": mu, "status": "skipped", "steps": 0, "time_s": 0.0}
            if args.hold_sinkage:        # a constant-load result of an earlier run
                cl.update(status="given", s_cl=1e-3 * args.hold_sinkage[i])
        else:
            cl = constant_load(comm, mu, args)
        co = None if args.skip_continuous else continuous(comm, mu, args)
        if (args.hold or args.hold_sinkage) and cl.get("s_cl"):
            co_hold = continuous(comm, mu, args, s_hold=cl["s_cl"])
        else:
            co_hold = None
        results.append({"constant_load": cl, "continuous": co, "hold": co_hold})
        if comm.rank == 0:
            line = (f"mu = {mu:g}: constant load {cl['status']}, steady {cl.get('steady')}, s = "
                    f"{1e3 * cl.get('s_cl', float('nan')):.2f} mm, Q_H = {cl.get('QH_cl', float('nan')) / 1e3:.2f} kN, "
                    f"rut {1e3 * (cl.get('rut_depth') or float('nan')):.2f} mm, rebound "
                    f"{1e3 * (cl.get('rebound') or float('nan')):.2f} mm, |M|/(Q d) <= {cl.get('max_rel_moment', 0):.1e}, "
                    f"{cl['steps']} steps, {cl['time_s']:.0f} s")
            st = cl.get("settled")
            if st:
                line += (f"\n          constant load from {st['from_travel'] / D:g} d of travel ({st['steps']} steps): "
                         f"s = {1e3 * st['sinkage_mean']:.2f} +- {1e3 * st['sinkage_std']:.2f} mm, Q_H = "
                         f"{st['QH_mean'] / 1e3:.2f} +- {st['QH_std'] / 1e3:.2f} kN, mean |ds/dx| = "
                         f"{st['mean_abs_slope']:.4f}, Q_H at ds/dx = 0 (fit) = {st['QH_at_zero_slope'] / 1e3:.2f} kN")
            if co is not None:
                line += (f"\n          continuous {co['status']}: s at Q_V = {args.load:g} kN: "
                         + (f"{1e3 * co['s_cont']:.2f} mm (Q_H {co['QH_cont'] / 1e3:.2f} kN); constant-load / "
                            f"continuous - 1 = {100 * (cl.get('s_cl', np.nan) / co['s_cont'] - 1):+.1f} %"
                            if co.get("s_cont") else "not reached")
                         + f", {co['steps']} steps, {co['time_s']:.0f} s")
            if co_hold is not None:
                line += (f"\n          hold at s_cl ({co_hold['status']}): " + (
                    f"Q_V = {co_hold['QV_hold'] / 1e3:.2f} +- {co_hold['QV_hold_std'] / 1e3:.2f} kN (mean +- std of "
                    f"{co_hold['hold_steps']} steps), Q_H = {co_hold['QH_hold'] / 1e3:.2f} kN; " + _steady_line(
                        co_hold, cl, args.load) if "QV_hold" in co_hold else "too short to read")
                    + f", {co_hold['time_s']:.0f} s")
            print(line, flush=True)
    if comm.rank == 0 and len(results) > 1 and not args.skip_constant_load:
        base = results[0]["constant_load"].get("s_cl")
        for r in results[1:]:
            s = r["constant_load"].get("s_cl")
            if base and s:
                print(f"friction effect on the steady sinkage: mu = {r['constant_load']['mu']:g} vs "
                      f"{results[0]['constant_load']['mu']:g}: {100 * (s / base - 1):+.1f} %")
    dump_json(comm, args.out, {"args": vars(args), "results": results})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
