"""Rigid-wheel rolling (transient) and its mesh convergence, five problems.

``protocols``: The two rolling protocols agree, and the effect of wheel friction at constant load.

    python -m benchmarks rolling protocols --out bench_rolling_protocols.json
    mpirun -n 2 python -m benchmarks rolling protocols --load 100 --mu 0 0.8

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

    mpirun -n 2 python -m benchmarks rolling protocols --mu 0 --length 2.6 --cl-travel 1.5 \\
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

``report``: Towed rigid wheel, protocol rolling-continuous (half model): report case vs the bearing-capacity
model, and the effect of halving the sinkage ramp rate.

    python -m benchmarks rolling report --out bench_rolling.json                 # defaults below
    python -m benchmarks rolling report --mu 0 0.8 --length 3.5 --half-width 1.5 --depth 1.5   # report block
    mpirun -n 2 python -m benchmarks rolling report --mu 0 --s0 0.01 --s-end 0.055 --travel 2.25 --halve \\
        --length 5.7 --half-width 0.8 --depth 0.8 --read 0.03 0.04 0.05 --window 0.005      # ramp 0.02 vs 0.01

Report case 2 (von Mises, c_dp = 200 kPa -> c = 100 kPa, phi = 0; E = 40 MPa, nu = 0.35,
gamma = 20 kN/m^3), Mn/DOT roller d = 1.524 m, b = 0.4572 m, fast preset.  The wheel is pressed to
s0 = 0.01 d at x = 0.4 d and rolls while s is ramped linearly to s_end = 0.05 d over ``travel``
(ramp rate (s_end - s0)/travel); ``--halve`` repeats with twice the travel (half the rate).
Prints Q_V, Q_H at s/d = 0.03, 0.04, 0.05 (``--read``; linear interpolation along the run, or a
least-squares line over s/d +- ``--window``), the
bearing-capacity model (rolling, inclined-footing method, D = s) at the same sinkage, steps,
Newton iterations, linear solves, cuts and wall time.

``convergence``: Mesh convergence of the constant-load steady sinkage, for both volumetric strains.

    python -m benchmarks rolling convergence --soil clay --refinement 8 10 12 \\
        --out benchmarks/results/rolling_convergence_clay.json
    python -m benchmarks rolling convergence --soil case5 --refinement 8 10 12 \\
        --out benchmarks/results/rolling_convergence_case5.json
    python -m benchmarks rolling convergence --table benchmarks/results/rolling_convergence_*.json

Scenes (Mn/DOT roller, d = 1.524 m, b = 0.4572 m, towed at constant load on a half block of
2.6 x 0.8 x 0.8 d with a 0.5 d stiff start zone, as the ``protocols`` problem):

* ``clay``: von Mises q_y = 300 kPa, 100 kN, mu = 0;
* ``case2``: the clay of report case 2, von Mises q_y = 200 kPa, 133.5 kN, mu = 0.8;
* ``case5``: Drucker-Prager phi_dp = 27.5 deg, c_dp = 194.6 kPa (psi = 0), 133.5 kN, mu = 0.8;
* ``sand``: the dense sand of layered case 13, Drucker-Prager phi_dp = 61.6 deg, c_dp = 18.5 kPa
  (psi = 0, a steep non-associated cone), 133.5 kN, mu = 0.8.

Each level is ``--refinement`` elements per diameter under the wheel (the presets are 8 / 20 / 50).
The scored sinkage of a (soil, strain, block) is the steady sinkage at the detected steady state
when every level of it reached one, else the mean over the rolled steps from 1 d of travel on (the
steady-state test's one-contact-length window does not average out the coarse levels'
element-passing ripple; the mean mixes in the approach when the wheel settles late).  For each
strain it is extrapolated from the three finest levels (Richardson, with
the observed order from the generalised three-level formula of Celik et al., J. Fluids Eng. 130
(2008) 078001); a level's error is against that value.  Prints a Markdown table (``--table``
rebuilds it from saved JSON files without solving; with ``--figure`` it also draws the sinkage along
the travel of every level).  ``--relaxation-length`` (mm) runs the levels with a Duvaut-Lions
regularisation along the whole path, ``--fallbacks`` relaxes only the steps that fail, as a plain
``rollsim run`` scene does, ``--length`` / ``--travel`` (d) on a longer block (both kept apart in
the table), ``--path-refinement`` / ``--cross-refinement`` / ``--depth-refinement`` on hexahedra
shorten the refined strip's elements along / across the path or in depth only (at 6-10 per d the
contact arc is one or two elements long and the wheel's half width one or two elements wide),
``--travel-step`` (mm) rolls with fixed steps instead of the solver's (kept apart in the table).
Each level keeps its sinkage along the travel (``travel_sinkage``); ``--progress`` prints a line
per rolled step on stderr.  An existing ``--out`` file is resumed: the levels it holds are not
solved again.

``cells``: A rolling scene on tetrahedra against hexahedra refined across the wheel, in one run.

    mpirun -n 2 python -m benchmarks rolling cells --out benchmarks/results/rolling_cells.json
    mpirun -n 2 python -m benchmarks rolling cells --variant "tetrahedra, fast" standard \\
        --work runs --out benchmarks/results/rolling_cells_standard.json
    python -m benchmarks rolling cells --table benchmarks/results/rolling_cells.json

Runs the scene (default ``examples/rolling_constant_load_mndot.toml``: the Mn/DOT roller at 133.5 kN
towed onto the case-5 soil) through ``rollsim run``'s driver once per mesh variant, one after the
other on the same ranks: the ``fast`` tetrahedra, hexahedra at 6 elements per d along the path with
8 across the wheel's width (``[model] cell_type = "hexahedra"``) with the scene's default strain and
with B-bar, and the ``standard`` preset.  Prints cells, dofs, steps, Newton iterations, cuts, wall
time, the mean sinkage over the rolled steps from 1 d of travel on (and its standard deviation: the
element-passing ripple) and the steady sinkage when detected, with each variant's wall-time ratio to
the first.  An existing ``--out`` file is resumed: the variants it holds are not run again.  With
``--work`` the run directories are kept there, and a variant that was killed continues from its last
checkpoint.

``retry``: Cost of retrying a failed rolling step with the wheel's pose held, against cutting it at once.

    python -m benchmarks rolling retry --soil case5 --refinement 6 --hexahedra --relaxation-length 0.5 \\
        --volumetric-strain cell-average --out benchmarks/results/pose_retry.json
    python -m benchmarks rolling retry --soil clay --refinement 6 --hexahedra \\
        --volumetric-strain cell-average --out benchmarks/results/pose_retry.json
    python -m benchmarks rolling retry --soil case2 --refinement 6 --hexahedra \\
        --volumetric-strain pointwise --out benchmarks/results/pose_retry.json
    python -m benchmarks rolling retry --table benchmarks/results/pose_retry.json

A constant-load level of the ``convergence`` problem runs twice in one process: with the
step's bordered Newton solve retried, when it fails, with the pose held until the soil has
converged (``WheelRolling.POSE_HOLDS = (0.1, 0.0)``), and with the step cut at once (the
default, ``(0.1,)``).  Prints Newton iterations (failed attempts included), steps and cuts,
wall time and the sinkage of each, and their ratios.  An existing ``--out`` file is resumed: the
runs it holds are not solved again.
"""
from __future__ import annotations

import argparse
import csv
import dataclasses
import json
import math
import pathlib
import re
import sys
import tempfile
import time

import numpy as np
from mpi4py import MPI

from _bench import (ORDER_RANGE, add_results_arguments, add_volumetric_strain, dump_json, observed_order, read_at,
                    run_problems, saved_results, show_table)

from rollsim.files import atomic_write_text, complete_directory, read_toml
from rollsim.geometry import CylinderWheel, MeshOptions, build_soil_block, rolling_block
from rollsim.geometry.mesh import ANISOTROPIC_REFINEMENTS
from rollsim.log import setup_logging
from rollsim.mpi import root_block
from rollsim.scene import load_scene, parse_scene
from rollsim.solver import DruckerPrager, SolverDivergedError, VonMises
from rollsim.solver.checkpoint import staged
from rollsim.solver.drivers.rolling_constant_load import measure_rut
from rollsim.solver.options import DEFAULT_RELAXATION_FALLBACK, DEFAULT_TRAVEL_RELAXATION_FALLBACK, VOLUMETRIC_STRAINS
from rollsim.solver.rolling import STEADY_MIN_TRAVEL, WheelRolling, constant_load_control
from rollsim.solver.run import run_scene
from rollsim.solver.rundir import TravelProgress
from rollsim.solver.stepping import StepControl
from rollsim.studies.bearing_capacity import Options, Soil, Wheel, wheel_forces

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
    p = argparse.ArgumentParser(prog="python -m benchmarks rolling protocols", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
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


def roll(argv: list[str] | None = None) -> int:
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


MAT = VonMises(E=40e6, nu=0.35, yield_stress=200e3)
C, PHI = 100e3, 0.0
READ = (0.03, 0.04, 0.05)


def run(comm, mu, travel_d, args):
    t0 = time.perf_counter()
    blk = rolling_block(D, length=args.length, half_width=args.half_width, depth=args.depth, stiff_length=0)
    tm = build_soil_block(comm, blk, MeshOptions.from_accuracy(D, args.accuracy))
    roll = WheelRolling(tm, CylinderWheel(D, B, B / 12), MAT, gamma=GAMMA, friction=mu)
    roll.gravity_step()
    status = "ok"
    try:
        roll.press(args.s0 * D)
        roll.roll(travel_d * D, args.s_end * D,
                  on_step=(lambda st: print(f"  mu={mu} x={st.travel:.3f} s/d={st.sinkage / D:.4f} "
                                            f"QV={st.QV / 1e3:.2f} kN QH={st.QH / 1e3:.2f} kN M={st.moment:.3g} "
                                            f"slip={st.slip:.3f} its={st.iterations} solves={st.linear_solves}",
                                            flush=True)) if comm.rank == 0 and args.verbose else None)
    except SolverDivergedError as err:
        status = f"failed: {err}"
    rolled = [st for st in roll.steps if st.travel > 0]
    s = np.array([st.sinkage / D for st in rolled])
    out = {"mu": mu, "travel_d": travel_d, "ramp_rate": (args.s_end - args.s0) / travel_d, "status": status,
           "cells": tm.stats.cells, "dofs": roll.n_dofs, "steps": len(roll.steps),
           "newton_iterations": roll.newton_iterations, "cuts": roll.cuts,
           "linear_solves": int(sum(st.linear_solves for st in rolled)),
           "max_rel_moment": max((abs(st.moment) / (st.QV * D) for st in rolled), default=0.0),
           "time_s": comm.allreduce(time.perf_counter() - t0, op=MPI.MAX), "at": {},
           "curve": [(st.travel, st.sinkage, st.QV, st.QH, st.moment, st.slip) for st in roll.steps]}
    for r in args.read:
        if s.size and s[0] <= r <= s[-1]:
            qv = read_at(s, np.array([st.QV for st in rolled]), r, args.window)
            qh = read_at(s, np.array([st.QH for st in rolled]), r, args.window)
            bc = wheel_forces(r * D, Wheel(D, B), Soil(C, PHI, GAMMA), Options(mode="rolling"))
            out["at"][f"{r:g}"] = {"QV_N": qv, "QH_N": qh, "BC_QV_N": float(bc.QV), "BC_QH_N": float(bc.QH),
                                   "QV_over_BC": qv / float(bc.QV)}
    return out


def report(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(prog="python -m benchmarks rolling report")
    ap.add_argument("--mu", type=float, nargs="+", default=[0.8])
    ap.add_argument("--accuracy", default="fast")
    ap.add_argument("--length", type=float, default=2.5, help="block length / d (report: 3.5)")
    ap.add_argument("--half-width", type=float, default=1.0, help="block half width / d (report: 1.5)")
    ap.add_argument("--depth", type=float, default=1.0, help="block depth / d (report: 1.5)")
    ap.add_argument("--travel", type=float, default=1.0, help="travel / d of the base ramp")
    ap.add_argument("--s0", type=float, default=0.01)
    ap.add_argument("--s-end", type=float, default=0.05)
    ap.add_argument("--halve", action="store_true", help="also run with half the ramp rate (2x travel)")
    ap.add_argument("--read", type=float, nargs="+", default=list(READ), help="s/d where Q_V, Q_H are read")
    ap.add_argument("--window", type=float, default=0.0,
                    help="read Q_V, Q_H by a least-squares line over s/d +- window (0: interpolate)")
    ap.add_argument("--verbose", action="store_true")
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    results = []
    for mu in args.mu:
        travels = [args.travel] + ([2 * args.travel] if args.halve else [])
        for tr in travels:
            if 0.4 + tr + 0.75 > args.length:
                raise SystemExit(f"block too short: length {args.length} d < 0.4 + travel {tr} + 0.75 d")
            res = run(comm, mu, tr, args)
            results.append(res)
            if comm.rank == 0:
                print(f"mu={mu} travel={tr:g} d (ramp ds/dx = {res['ramp_rate']:.4f}): {res['status']}, "
                      f"{res['cells']} cells, {res['dofs']} dofs, {res['steps']} steps, "
                      f"{res['newton_iterations']} Newton its, {res['linear_solves']} linear solves, "
                      f"{res['cuts']} cuts, max |M|/(Q_V d) = {res['max_rel_moment']:.2e}, {res['time_s']:.0f} s",
                      flush=True)
                for r, v in res["at"].items():
                    print(f"   s/d={r}: Q_V = {v['QV_N'] / 1e3:7.2f} kN (BC {v['BC_QV_N'] / 1e3:7.2f}, "
                          f"FE/BC {v['QV_over_BC']:.3f})  Q_H = {v['QH_N'] / 1e3:6.2f} kN (BC {v['BC_QH_N'] / 1e3:6.2f})",
                          flush=True)
        if args.halve and comm.rank == 0:
            a, b = results[-2], results[-1]
            for r in args.read:
                k = f"{r:g}"
                if k in a["at"] and k in b["at"]:
                    print(f"   ramp halved, s/d={k}: Q_V {a['at'][k]['QV_N'] / 1e3:.2f} -> {b['at'][k]['QV_N'] / 1e3:.2f} kN "
                          f"({b['at'][k]['QV_N'] / a['at'][k]['QV_N'] - 1:+.1%}), Q_H {a['at'][k]['QH_N'] / 1e3:.2f} -> "
                          f"{b['at'][k]['QH_N'] / 1e3:.2f} kN")
    dump_json(comm, args.out, {"args": vars(args), "results": results})


SOILS = {"clay": ["--yield-stress", "300", "--load", "100", "--mu", "0"],
         "case2": ["--yield-stress", "200", "--load", "133.5", "--mu", "0.8"],
         "case5": ["--yield-stress", "194.6", "--phi-dp", "27.5", "--load", "133.5", "--mu", "0.8"],
         "sand": ["--yield-stress", "18.5", "--phi-dp", "61.6", "--load", "133.5", "--mu", "0.8"]}
#: block length and constant-load travel (in d) of the study's levels
LENGTH, TRAVEL = 2.6, 1.5
#: how a plain scene's travel fallback relaxes a roll (``--fallbacks``)
FALLBACK_ROUTE = "started over relaxed"
#: values of the run keys that results saved before the key existed were run with
DEFAULTS = {"relaxation_length_mm": 0.0, "fallbacks": False, "block_length_d": LENGTH, "travel_d": TRAVEL,
            "cell_type": "tetrahedra", "travel_step_mm": 0.0, **dict.fromkeys(SHORTER, 1.0)}


def block_args(length: float = LENGTH, travel: float = TRAVEL) -> list[str]:
    """The half block (``length`` x 0.8 x 0.8 d, 0.5 d stiff start zone) and the travel, as
    arguments of the ``protocols`` problem."""
    return ["--length", f"{length:g}", "--half-width", "0.8", "--depth", "0.8", "--stiff", "0.5",
            "--cl-travel", f"{travel:g}"]


def level_args(soil: str, refinement: float, strain: str, relaxation_length: float = 0.0,
               block: list[str] | None = None, fallbacks: bool = False, hexahedra: bool = False,
               refinements: dict[str, float] | None = None, progress: bool = False, travel_step: float = 0.0):
    """The constant-load run of ``soil`` at ``refinement`` elements per d on ``block`` (arguments of
    the ``protocols`` problem; default :func:`block_args`; ``refinements``: the anisotropic
    mesh fields by name; ``progress``: a line per rolled step; ``travel_step``: mm, 0 for the
    solver's default), as parsed arguments."""
    return parser().parse_args(SOILS[soil] + (block or block_args()) + [
        "--refinement", f"{refinement:g}", "--volumetric-strain", strain, "--skip-continuous",
        "--relaxation-length", f"{relaxation_length:g}", "--travel-step", f"{travel_step:g}"]
        + [a for k, v in (refinements or {}).items() for a in (f"--{k.replace('_', '-')}", f"{v:g}")]
        + ["--fallbacks"] * fallbacks + ["--hexahedra"] * hexahedra + ["--progress"] * progress)


def keep_travel_sinkage(cl: dict) -> dict:
    """A constant-load result with its curve replaced by the sinkage along the travel (m, m):
    where a level settles, or whether it drifts."""
    cl["travel_sinkage"] = [[round(x, 5), round(s, 7)] for x, s, _, _ in cl.pop("curve")]
    return cl


def sinkage(r: dict) -> float | None:
    """The mean sinkage of a run over the rolled steps from 1 d of travel on (m; defined whether or
    not the steady-state test passed)."""
    st = r.get("settled")
    return st["sinkage_mean"] if st else None


def scorer(rows: list[dict]):
    """``(name, sinkage of a run)`` scored for the levels ``rows`` of one (soil, strain, block): the
    steady sinkage when every level detected its steady state, else the mean from 1 d."""
    if rows and all(r.get("steady") for r in rows):
        return "steady", lambda r: r["s_cl"]
    return "mean from 1 d", sinkage


def formulation(r: dict) -> str:
    """The strain of a run, with its relaxation length and its block when they are not the
    study's default."""
    ell = r.get("relaxation_length_mm", 0.0)
    text = f"{r['strain']}, {ell:g} mm relaxation" if ell else r["strain"]
    route = r.get("fallbacks")
    if route:       # True: saved when a failed roll was relaxed over 0.1 d stretches only
        text += ", fallbacks over 0.1 d stretches" if route is True else f", fallback {route}"
    if r.get("cell_type", "tetrahedra") == "hexahedra":
        text += ", Q2-P1 hexahedra" if r["strain"] == "cell-average" else ", Q2 hexahedra"
    for name, axis in SHORTER.items():
        if r.get(name, 1.0) != 1.0:
            text += f", {r[name]:g}x finer {axis}"
    length, travel = r.get("block_length_d", LENGTH), r.get("travel_d", TRAVEL)
    if (length, travel) != (LENGTH, TRAVEL):
        text += f", {length:g} d block, {travel:g} d travel"
    if r.get("travel_step_mm", 0.0):
        text += f", {r['travel_step_mm']:g} mm steps"
    return text


def remarks(r: dict) -> list[str]:
    """What the table's row of level ``r`` does not show: a failure (the level is not scored), the
    stretches of travel its fallback relaxed and where a roll started over, a rut that is a heave."""
    out = []
    if r.get("status", "ok") != "ok":
        reached = f" after {r['travel_sinkage'][-1][0]:.2f} m of travel" if r.get("travel_sinkage") else ""
        out.append(f"failed{reached}, not scored ({r['steps']} steps, {r['newton_iterations']} Newton its, "
                   f"{r['time_s']:.0f} s)")
    if r.get("relaxed_travel"):
        length = sum(b - a for a, b in r["relaxed_travel"])
        out.append(f"{len(r['relaxed_travel'])} stretch(es) relaxed, {length:.2f} m of travel")
    for failed in r.get("travel_failures", []):
        out.append(f"the rate-independent roll failed after {failed:.2f} m and started over relaxed")
    if r.get("lift_failure"):
        out.append("the lift-off failed, the rut is not measured")
    if (r.get("rut_depth") or 0.0) < 0:     # None: the travel left no rut to measure
        out.append(f"the rut is a heave of {-1e3 * r['rut_depth']:.1f} mm")
    return out


#: starts (d of travel) of the windows whose mean sinkage the table compares on long travels
WINDOWS = (1.0, 2.0, 2.5)


def rolled(r: dict) -> tuple[np.ndarray, np.ndarray]:
    """The travel (m) and sinkage (m) of the rolled steps a level kept (``travel_sinkage``): not
    the press, not the lift-off."""
    x, s = np.array(r.get("travel_sinkage") or [], dtype=float).reshape(-1, 2).T
    _, first = np.unique(x, return_index=True)
    first = np.sort(first[x[first] > 0])
    return x[first], s[first]


def window_means(r: dict, starts=WINDOWS) -> list[float | None]:
    """Mean sinkage (m) of the rolled steps from each of ``starts`` (d of travel) on (None: fewer
    than 3 steps there): does the order of the levels depend on how much of the approach the
    mean takes in?"""
    x, s = rolled(r)
    late = [x >= a * D for a in starts]
    return [float(s[on].mean()) if on.sum() >= 3 else None for on in late]


def groups(results: list[dict]) -> dict[tuple[str, str], list[dict]]:
    """The levels of ``results`` by (soil, strain with its relaxation, fallback and block), sorted."""
    out: dict[tuple[str, str], list[dict]] = {}
    for r in results:
        out.setdefault((r["soil"], formulation(r)), []).append(r)
    return dict(sorted(out.items(), key=lambda item: (item[0][0], _natural(item[0][1]))))


def _natural(label: str) -> list:
    """Sort key of a label with its numbers by value ("8x" before "16x")."""
    return [(0, float(t), "") if t.replace(".", "", 1).isdigit() else (1, 0.0, t)
            for t in re.split(r"(\d+(?:\.\d+)?)", label)]


def table(results: list[dict]) -> str:
    """Markdown table of the levels of each (soil, strain): sinkage, change against the next
    coarser level, error against the extrapolated value, cost."""
    lines = ["| soil | strain | elements / d | dofs | mean from 1 d (± std) | steady sinkage | scored "
             "| change vs coarser | error vs extrapolated | steps | Newton its | cuts | wall time (ranks) |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    notes = []
    for key, group in groups(results).items():
        rows = sorted((r for r in group if r.get("status", "ok") == "ok" and sinkage(r)),
                      key=lambda r: -r["refinement"])
        notes += [f"{key[0]}, {key[1]}, {r['refinement']:g} elements / d: {remark}"
                  for r in sorted(group, key=lambda r: r["refinement"]) for remark in remarks(r)]
        scored, score = scorer(rows)
        fit = None
        if len(rows) >= 3:
            fit = observed_order([1 / r["refinement"] for r in rows[:3]], [score(r) for r in rows[:3]])
        if fit and not ORDER_RANGE[0] <= fit[0] <= ORDER_RANGE[1]:
            notes.append(f"{key[0]}, {key[1]}: observed order {fit[0]:.2f}, outside {ORDER_RANGE[0]:g}-"
                         f"{ORDER_RANGE[1]:g}: the levels are not in the asymptotic range, no extrapolation")
            fit = None
        elif fit:
            notes.append(f"{key[0]}, {key[1]}: observed order {fit[0]:.2f}, extrapolated sinkage {1e3 * fit[1]:.2f} mm")
        elif len(rows) >= 3:
            notes.append(f"{key[0]}, {key[1]}: the three finest levels do not converge monotonically")
        windows = {r["refinement"]: window_means(r) for r in rows}
        if len(rows) >= 2 and all(None not in w for w in windows.values()):
            means = "; ".join(f"{n:g} / d: " + " / ".join(f"{1e3 * m:.2f}" for m in w)
                              for n, w in sorted(windows.items()))
            notes.append(f"{key[0]}, {key[1]}: mean sinkage from {' / '.join(f'{a:g}' for a in WINDOWS)} d "
                         f"of travel (mm): {means}")
        for r in sorted(rows, key=lambda r: r["refinement"]):
            coarser = [c for c in rows if c["refinement"] < r["refinement"]]
            change = f"{100 * (score(r) / score(coarser[0]) - 1):+.1f} %" if coarser else ""
            err = f"{100 * (score(r) / fit[1] - 1):+.1f} %" if fit else ""
            steady = f"{1e3 * r['s_cl']:.2f} mm" if r.get("steady") else "not detected"
            lines.append(f"| {key[0]} | {key[1]} | {r['refinement']:g} | {r['dofs']} "
                         f"| {1e3 * sinkage(r):.2f} ± {1e3 * r['settled']['sinkage_std']:.2f} mm "
                         f"| {steady} | {scored} "
                         f"| {change} | {err} | {r['steps']} "
                         f"| {r['newton_iterations']} | {r['cuts']} | {r['time_s']:.0f} s ({r['ranks']}) |")
    return "\n".join(lines + [""] + [f"- {n}" for n in notes])


def travel_figure(path: pathlib.Path, results: list[dict]) -> bool:
    """Sinkage along the travel of every level that kept it (``travel_sinkage``), one panel per
    (soil, strain): where each level settles, or whether it drifts.  False: no level kept it."""
    kept = {key: [r for r in group if r.get("travel_sinkage")] for key, group in groups(results).items()}
    kept = {key: group for key, group in kept.items() if group}
    if not kept:
        return False
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    cols = min(3, len(kept))
    rows = -(-len(kept) // cols)
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.0 * rows), squeeze=False)
    for ax, (key, group) in zip(axes.flat, kept.items()):
        for r in sorted(group, key=lambda r: r["refinement"]):
            x, s = rolled(r)
            ax.plot(x / D, 1e3 * s, lw=1, label=f"{r['refinement']:g} / d")
        ax.set_title(f"{key[0]}, {key[1]}", fontsize=8)
        ax.set_xlabel("travel / d", fontsize=8)
        ax.set_ylabel("sinkage (mm)", fontsize=8)
        ax.tick_params(labelsize=7)
        ax.legend(fontsize=7)
    for ax in axes.flat[len(kept):]:
        ax.axis("off")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def levels(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks rolling convergence",
                                description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--soil", choices=sorted(SOILS), default="clay")
    p.add_argument("--refinement", type=float, nargs="+", default=[8.0, 10.0, 12.0])
    p.add_argument("--volumetric-strain", choices=VOLUMETRIC_STRAINS, nargs="+", default=list(VOLUMETRIC_STRAINS))
    p.add_argument("--relaxation-length", type=float, default=0.0,
                   help="Duvaut-Lions relaxation length of the soil, mm of travel (0: off)")
    p.add_argument("--fallbacks", action="store_true",
                   help="relax a failed step as a plain rollsim run scene does (kept apart in the table)")
    p.add_argument("--length", type=float, default=LENGTH, help="block length, d (kept apart in the table)")
    p.add_argument("--travel", type=float, default=TRAVEL, help="constant-load travel limit, d")
    p.add_argument("--hexahedra", action="store_true",
                   help="structured 27-node hexahedra (B-bar: Q2-P1; kept apart in the table)")
    p.add_argument("--travel-step", type=float, default=0.0,
                   help="travel step, mm (0: the solver's default; kept apart in the table)")
    for name, axis in SHORTER.items():
        p.add_argument(f"--{name.replace('_', '-')}", type=float, default=1.0,
                       help=f"with --hexahedra: the refined strip's elements this many times shorter {axis} "
                            "(kept apart in the table)")
    add_results_arguments(p)
    p.add_argument("--progress", action="store_true",
                   help="one line per rolled step on stderr (travel, sinkage, forces, time left)")
    p.add_argument("--figure", type=pathlib.Path,
                   help="with --table: draw the sinkage along the travel of every level to this file")
    args = p.parse_args(argv)
    for name in SHORTER:
        if getattr(args, name) != 1.0 and not args.hexahedra:
            p.error(f"--{name.replace('_', '-')} needs --hexahedra")
    refinements = {name: getattr(args, name) for name in SHORTER}
    comm = MPI.COMM_WORLD
    setup_logging(comm, quiet=not args.progress)
    if args.table:
        if comm.rank == 0:
            results = saved_results(args.table)
            print(table(results))
            if args.figure and not travel_figure(args.figure, results):
                print(f"{args.figure}: not drawn, no level kept its sinkage along the travel")
        return 0
    results = saved_results(args.out)
    for strain in args.volumetric_strain:
        for n in args.refinement:
            run = {"soil": args.soil, "strain": strain, "refinement": n,
                   "relaxation_length_mm": args.relaxation_length, "fallbacks": args.fallbacks and FALLBACK_ROUTE,
                   "block_length_d": args.length, "travel_d": args.travel,
                   "cell_type": "hexahedra" if args.hexahedra else "tetrahedra",
                   "travel_step_mm": args.travel_step, **refinements}
            if any(all(r.get(k, DEFAULTS.get(k, 0.0)) == v for k, v in run.items()) for r in results):
                if comm.rank == 0:
                    print(f"{formulation(run)}, {n:g} elements / d: in {args.out}, not solved again", flush=True)
                continue
            level = level_args(args.soil, n, strain, args.relaxation_length, block_args(args.length, args.travel),
                               args.fallbacks, args.hexahedra, refinements, args.progress, args.travel_step)
            cl = keep_travel_sinkage(constant_load(comm, level.mu[0], level))
            results.append({**run, "ranks": comm.size, **cl})
            if comm.rank == 0:
                s = sinkage(cl)
                print(f"{args.soil}, {formulation(run)}, {n:g} elements / d: {cl['status']}, "
                      f"steady {cl.get('steady')}, "
                      f"s = {1e3 * (s if s else math.nan):.2f} mm, {cl['dofs']} dofs, "
                      f"{cl['newton_iterations']} Newton its, {cl['time_s']:.0f} s", flush=True)
            dump_json(comm, args.out, {"args": vars(args), "results": results})
    return show_table(comm, table, results)


ROOT = pathlib.Path(__file__).resolve().parents[1]
SCENE = ROOT / "examples" / "rolling_constant_load_mndot.toml"
#: the mesh variants, by name: ``[model]`` keys replacing the scene's mesh keys
CELL_VARIANTS = {
    "tetrahedra, fast": {"accuracy": "fast"},
    "hexahedra, 6 per d, 8 across": {"refinement": 6, "cell_type": "hexahedra", "elements_across_wheel": 8,
                                     "elements_along_path": 6},
    "hexahedra, 6 per d, 8 across, B-bar": {"refinement": 6, "cell_type": "hexahedra", "elements_across_wheel": 8,
                                            "elements_along_path": 6, "volumetric_strain": "cell-average"},
    "standard": {"accuracy": "standard"},
}
MESH_KEYS = ("accuracy", "refinement", "cell_type", "elements_across_wheel", "elements_along_path",
             "volumetric_strain")


def variant_scene(path: pathlib.Path, name: str):
    """The scene of ``path`` with its mesh keys replaced by variant ``name``'s."""
    data = read_toml(path, str(path))
    model = {k: v for k, v in data.get("model", {}).items() if k not in MESH_KEYS}
    return parse_scene({**data, "model": model | CELL_VARIANTS[name]})


def rolled_sinkage(history: pathlib.Path, d: float, load: float) -> tuple[float, float]:
    """Mean and standard deviation (m) of the sinkage over the steps rolled at the load from 1 d
    of travel on (``history.csv`` of a constant-load run; as the convergence study's mean)."""
    curve = [tuple(r[k] for k in ("travel_m", "sinkage_m", "QV_N", "QH_N")) for r in read_history(history)]
    st = settled(curve, load, d)
    return (st["sinkage_mean"], st["sinkage_std"]) if st else (math.nan, math.nan)


def run_variant(comm, path: pathlib.Path, name: str, work: pathlib.Path) -> dict:
    """Run variant ``name`` of the scene at ``path`` in ``work``; its result row."""
    scene = variant_scene(path, name)
    out = run_directory(work, name)
    summary = run_scene(scene, out, comm, progress=True, write_fields=False)
    mean, std = rolled_sinkage(out / "history.csv", scene.wheel.diameter, scene.loading.load) \
        if comm.rank == 0 else (None, None)
    mean, std = comm.bcast((mean, std))
    steady = summary.get("steady_state") or {}
    return {"variant": name, "scene": path.name, "status": summary["status"], "cells": summary["cells"],
            "dofs": summary["dofs"], "steps": summary["steps"], "newton_iterations": summary["newton_iterations"],
            "cuts": summary["step_cuts"], "time_s": summary["wall_time_s"], "ranks": comm.size,
            "strain": summary["model"]["volumetric_strain"], "sinkage_mean": mean, "sinkage_std": std,
            "steady_sinkage": summary["sinkage_m"] if steady.get("reached") else None}


def run_directory(work: pathlib.Path, name: str) -> pathlib.Path:
    """The run directory of variant ``name`` under ``work``."""
    return work / name.replace(", ", "_").replace(" ", "-")


def read_history(history: pathlib.Path) -> list[dict]:
    """Rows of a rolling run's ``history.csv`` as floats."""
    with history.open() as f:
        return [{k: float(v) for k, v in r.items()} for r in csv.DictReader(f)]


def progress_row(name: str, rows: list[dict], upto: float, window: tuple[float, float], load: float) -> dict:
    """What a run (finished or stopped) did up to ``upto`` m of travel: steps, Newton iterations,
    wall time; and its mean sinkage (m) over the steps at the load with travel in ``window``."""
    done = [r for r in rows if r["travel_m"] <= upto + 1e-9]
    held = [r["sinkage_m"] for r in rows
            if window[0] <= r["travel_m"] <= window[1] and r["QV_N"] >= 0.999 * load]
    return {"variant": name, "travel_m": max(r["travel_m"] for r in rows), "steps": len(done),
            "newton_iterations": int(sum(r["newton_iterations"] for r in done)),
            "time_s": done[-1]["wall_time_s"], "sinkage": sum(held) / len(held) if held else math.nan}


def progress_table(work: pathlib.Path, upto: float, window: tuple[float, float], load: float) -> str:
    """Markdown cells_table of the run directories under ``work`` (one per variant, stopped ones
    included) compared over their first ``upto`` m of travel, with wall-time ratios to the first;
    ``load``: the scene's wheel load (N)."""
    lines = [f"| mesh | travel rolled | steps to {upto:g} m | Newton its | wall time to {upto:g} m | time / first | "
             f"mean sinkage, {window[0]:g}-{window[1]:g} m |", "|---|---|---|---|---|---|---|"]
    base = None
    for name in CELL_VARIANTS:
        history = run_directory(work, name) / "history.csv"
        if not history.exists():
            continue
        r = progress_row(name, read_history(history), upto, window, load)
        base = base or r["time_s"]
        lines.append(f"| {name} | {r['travel_m']:.2f} m | {r['steps']} | {r['newton_iterations']} | "
                     f"{r['time_s']:.0f} s | {r['time_s'] / base:.2f} | {1e3 * r['sinkage']:.2f} mm |")
    return "\n".join(lines)


def cells_table(results: list[dict]) -> str:
    """Markdown cells_table of the variants, with wall-time ratios to the first row of each scene."""
    lines = ["| scene | mesh | strain | cells | dofs | steps | Newton its | cuts | mean from 1 d (± std) | "
             "steady | wall time (ranks) | time / first |", "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    first: dict[str, float] = {}
    for r in results:
        base = first.setdefault(r["scene"], r["time_s"])
        steady = "not detected" if r["steady_sinkage"] is None else f"{1e3 * r['steady_sinkage']:.2f} mm"
        mean = (f"{1e3 * r['sinkage_mean']:.2f} ± {1e3 * r['sinkage_std']:.2f} mm" if r["status"] == "ok"
                else f"failed: {r['status']}")
        lines.append(f"| {r['scene']} | {r['variant']} | {r['strain']} | {r['cells']} | {r['dofs']} | {r['steps']} | "
                     f"{r['newton_iterations']} | {r['cuts']} | {mean} | {steady} | {r['time_s']:.0f} s "
                     f"({r['ranks']}) | {r['time_s'] / base:.2f} |")
    return "\n".join(lines)


def cells(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks rolling cells",
                                description=__doc__.splitlines()[0])
    p.add_argument("--scene", type=pathlib.Path, default=SCENE, help="a rolling-constant-load scene (TOML)")
    p.add_argument("--variant", nargs="+", choices=list(CELL_VARIANTS), default=list(CELL_VARIANTS)[:3],
                   help="the mesh variants to run, in order (default: all but standard)")
    p.add_argument("--work", type=pathlib.Path, default=None,
                   help="keep the run directories here (default: a temporary directory); a killed variant "
                        "continues from its checkpoint")
    p.add_argument("--progress", nargs=3, type=float, metavar=("UPTO", "FROM", "TO"),
                   help="with --work: compare the run directories there (stopped runs too) over their "
                        "first UPTO m of travel, the mean sinkage over FROM-TO m, and stop")
    add_results_arguments(p)
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    setup_logging(comm)
    if args.progress:
        if args.work is None:
            p.error("--progress needs --work")
        if comm.rank == 0:
            upto, a, b = args.progress
            print(progress_table(args.work, upto, (a, b), load_scene(args.scene).loading.load))
        return 0
    if args.table:
        return show_table(comm, cells_table, saved_results(args.table))
    results = saved_results(args.out)
    done = {(r["scene"], r["variant"]) for r in results}
    if load_scene(args.scene).loading.protocol != "rolling-constant-load":
        raise SystemExit(f"{args.scene}: loading.protocol must be rolling-constant-load")
    with tempfile.TemporaryDirectory() as tmp:
        work = args.work or pathlib.Path(comm.bcast(tmp if comm.rank == 0 else None))
        for name in args.variant:
            if (args.scene.name, name) in done:
                continue
            results.append(run_variant(comm, args.scene, name, work))
            dump_json(comm, args.out, {"results": results})
            if comm.rank == 0:
                print(cells_table(results), flush=True)
    return 0


#: the variants compared: name -> ``WheelRolling.POSE_HOLDS``
RETRY_VARIANTS = {"retried with the pose held": (0.1, 0.0), "cut at once": WheelRolling.POSE_HOLDS}
#: the keys that name one level
LEVEL_KEYS = ("soil", "strain", "refinement", "relaxation_length_mm", "cell_type")


def _mm(value) -> str:
    return "-" if value is None else f"{1e3 * value:.2f} mm"


def retry_table(results: list[dict]) -> str:
    """Markdown retry_table: each level's two variants side by side and the ratio of their costs."""
    lines = ["| level | variant | Newton its | steps / cuts | wall time | mean from 1 d | steady |",
             "|---|---|---|---|---|---|---|"]
    notes = []
    levels: dict[tuple, dict[str, dict]] = {}
    for r in results:
        levels.setdefault(tuple(r[k] for k in LEVEL_KEYS), {})[r["variant"]] = r
    for key, runs in levels.items():
        name = f"{key[0]}, {formulation(next(iter(runs.values())))}, {key[2]:g} / d"
        for variant, r in ((v, runs[v]) for v in RETRY_VARIANTS if v in runs):
            lines.append(f"| {name} | {variant} | {r['newton_iterations']} | "
                         f"{r['steps']} / {r['cuts']} | {r['time_s']:.0f} s | {_mm(sinkage(r))} | "
                         f"{_mm(r['s_cl']) if r.get('steady') else 'not detected'} |")
        old, new = (runs.get(v) for v in RETRY_VARIANTS)
        if old and new and new["newton_iterations"] and sinkage(old) and sinkage(new):
            notes.append(f"- {name}: {old['newton_iterations'] / new['newton_iterations']:.2f}x fewer Newton "
                         f"iterations, {old['time_s'] / new['time_s']:.2f}x less wall time, mean sinkage "
                         f"{100 * (sinkage(new) / sinkage(old) - 1):+.1f} %")
    return "\n".join(lines + [""] + notes)


def pose_retry(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m benchmarks rolling retry",
                                description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--soil", choices=sorted(SOILS), default="case5")
    p.add_argument("--refinement", type=float, default=6.0)
    p.add_argument("--volumetric-strain", choices=VOLUMETRIC_STRAINS, default="cell-average")
    p.add_argument("--relaxation-length", type=float, default=0.0,
                   help="Duvaut-Lions relaxation length of the soil, mm of travel (0: off)")
    p.add_argument("--hexahedra", action="store_true", help="structured 27-node hexahedra (B-bar: Q2-P1)")
    p.add_argument("--progress", action="store_true", help="one line per rolled step on stderr")
    add_results_arguments(p)
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    setup_logging(comm, quiet=not args.progress)
    if args.table:
        return show_table(comm, retry_table, saved_results(args.table))
    results = saved_results(args.out)
    level = {"soil": args.soil, "strain": args.volumetric_strain, "refinement": args.refinement,
             "relaxation_length_mm": args.relaxation_length,
             "cell_type": "hexahedra" if args.hexahedra else "tetrahedra"}
    retried = level_args(args.soil, args.refinement, args.volumetric_strain, args.relaxation_length,
                                        hexahedra=args.hexahedra, progress=args.progress)
    default_holds = WheelRolling.POSE_HOLDS
    try:
        for variant, holds in RETRY_VARIANTS.items():
            run = {**level, "variant": variant}
            if any(all(r.get(k) == v for k, v in run.items()) for r in results):
                continue
            WheelRolling.POSE_HOLDS = holds
            cl = keep_travel_sinkage(constant_load(comm, retried.mu[0], retried))
            results.append({**run, "ranks": comm.size, **cl})
            if comm.rank == 0:
                s = sinkage(cl)
                print(f"{variant}: {cl['status']}, s = {1e3 * (s if s else math.nan):.2f} mm, "
                      f"{cl['newton_iterations']} Newton its, {cl['time_s']:.0f} s", flush=True)
            dump_json(comm, args.out, {"args": vars(args), "results": results})
    finally:
        WheelRolling.POSE_HOLDS = default_holds
    return show_table(comm, retry_table, results)



if __name__ == "__main__":
    sys.exit(run_problems({"protocols": roll, "report": report, "convergence": levels, "cells": cells, "retry": pose_retry}, __doc__))
