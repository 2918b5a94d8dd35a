"""The ``rollsim`` command line. ``main(argv) -> int`` is what tests call.

Exit status: 0 success; 2 invalid input (one line on stderr naming the field);
3 the physics has no answer (e.g. the load exceeds the wheel's capacity); 1 other.
With ``--json`` the last line of stdout is exactly one JSON object, errors included.
"""
from __future__ import annotations

import argparse
import json
import math
import sys

from rollsim import __version__
from rollsim.files import output_directory
from rollsim.units import ANGLE, FLEXIBILITY, FORCE, LENGTH, PRESSURE, UNIT_WEIGHT, InputError, to_si

EXIT_OK, EXIT_FAILURE, EXIT_INPUT, EXIT_NO_ANSWER = 0, 1, 2, 3
PARALLEL_COMMANDS = ("run", "study")  # commands that run on all ranks of COMM_WORLD
MNDOT_DIAMETER, MNDOT_WIDTH = "1.524 m", "0.4572 m"  # the Mn/DOT test-roller tire (60 x 18 in)


class NoAnswer(Exception):
    """The physics has no answer for this input (exit 3); ``payload`` goes to --json."""

    def __init__(self, message: str, payload: dict):
        super().__init__(message)
        self.payload = payload


class _Parser(argparse.ArgumentParser):
    """argparse with one-line errors and exit status 2 (the field: the command, or "command")."""

    def error(self, message):
        words = self.prog.split()
        raise InputError(words[-1] if len(words) > 1 else "command", message.removeprefix("argument command: "))


def _quantity(kind):
    def parse(text):
        return text, kind  # converted later so errors can name the flag
    return parse


UNITS_HELP = ("Quantities are SI numbers (m, N, Pa, N/m^3, m/N; angles in degrees) or strings "
              "with units, e.g. '60 in', '15 ton', '170 kPa', '127 pcf', '0.01 m/kN'. "
              "Outputs are SI.")


def _add_model_options(p, *, rolling_default=True):
    p.add_argument("--mode", choices=("indentation", "rolling"),
                   default="rolling" if rolling_default else "indentation", help="wheel case (default %(default)s)")
    p.add_argument("--method", choices=("footing", "load"), default="footing",
                   help="rolling: inclined-footing (preferred) or inclined-load method (default %(default)s)")
    p.add_argument("--shape", choices=("cylinder", "torus"), default="cylinder",
                   help="indentation: wheel cross-section (default %(default)s)")
    p.add_argument("--depth", choices=("modified", "theory"), default="modified",
                   help="equivalent footing depth: modified D = s (report's recommendation) "
                        "or theory D = eta s/6 (default %(default)s)")
    p.add_argument("--flex", type=_quantity(FLEXIBILITY), default=("0", FLEXIBILITY), metavar="LAMBDA",
                   help="wheel flexibility lambda in m/N, 0 = rigid (default 0)")


def _add_wheel(p, suffix=""):
    p.add_argument(f"--d{suffix}", type=_quantity(LENGTH), metavar="D",
                   default=None if suffix else (MNDOT_DIAMETER, LENGTH),
                   help="wheel diameter, m" + ("" if suffix else f" (default {MNDOT_DIAMETER}, Mn/DOT roller)"))
    p.add_argument(f"--b{suffix}", type=_quantity(LENGTH), metavar="B",
                   default=None if suffix else (MNDOT_WIDTH, LENGTH),
                   help="wheel width, m" + ("" if suffix else f" (default {MNDOT_WIDTH})"))


def _add_soil(p, *, c_default="0", phi_default="0"):
    p.add_argument("--c", type=_quantity(PRESSURE), default=None if c_default is None else (c_default, PRESSURE),
                   help="cohesion, Pa" + ("" if c_default is None else f" (default {c_default})"))
    p.add_argument("--phi", type=_quantity(ANGLE), default=None if phi_default is None else (phi_default, ANGLE),
                   help="friction angle, deg" + ("" if phi_default is None else f" (default {phi_default})"))
    p.add_argument("--gamma", type=_quantity(UNIT_WEIGHT), default=("20 kN/m^3", UNIT_WEIGHT),
                   help="unit weight, N/m^3 (default 20 kN/m^3)")


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="rollsim", description="Test-rolling simulation and design. " + UNITS_HELP)
    parser.add_argument("--version", action="version", version=f"rollsim {__version__}")
    sub = parser.add_subparsers(dest="command", required=True, parser_class=_Parser)
    common = _Parser(add_help=False)
    common.add_argument("--json", action="store_true", help="print one JSON object as the last line of stdout")
    common.add_argument("--quiet", action="store_true", help="no progress or notes on stderr")
    common.add_argument("--debug", action="store_true", help="show the traceback of an unexpected error")
    common.add_argument("--verbose", action="store_true",
                        help="also log every load step's Newton residuals and other libraries' messages "
                             "(e.g. the form compiler's build steps)")

    p = sub.add_parser("predict", parents=[common], help="bearing-capacity model: load <-> sinkage",
                       description="Bearing-capacity wheel model: give --load to get the sinkage, or "
                                   "--sinkage to get the forces. " + UNITS_HELP)
    _add_model_options(p)
    _add_wheel(p)
    _add_soil(p)
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--load", type=_quantity(FORCE), help="vertical wheel force Q_V, N (e.g. '133.5 kN', '15 ton')")
    g.add_argument("--sinkage", type=_quantity(LENGTH), help="sinkage s, m")

    p = sub.add_parser("invert", parents=[common], help="soil strength from measured sinkage",
                       description="Soil strength from test-roller sinkage: hold --c or --phi fixed and "
                                   "find the other, or give a second measurement (--load2 --sinkage2, "
                                   "optionally --d2 --b2) to find both, or a --record CSV for a "
                                   "strength profile. " + UNITS_HELP)
    _add_model_options(p)
    _add_wheel(p)
    _add_soil(p, c_default=None, phi_default=None)
    p.add_argument("--load", type=_quantity(FORCE), required=True, help="vertical wheel force Q_V, N")
    p.add_argument("--sinkage", type=_quantity(LENGTH), help="measured sinkage, m")
    _add_wheel(p, "2")
    p.add_argument("--load2", type=_quantity(FORCE), help="second measurement: wheel force, N")
    p.add_argument("--sinkage2", type=_quantity(LENGTH), help="second measurement: sinkage, m")
    p.add_argument("--record", help="CSV of a continuous record: columns position_m, sinkage_m")
    p.add_argument("--min-strength", type=str,
                   help="with --record: minimum acceptable strength (c in Pa when --phi is held, "
                        "phi in deg when --c is held)")
    p.add_argument("--out", help="with --record: write the strength profile CSV here")

    p = sub.add_parser("influence", parents=[common], help="influence depth of a second layer",
                       description="Depth at which a second soil layer starts to change the sinkage "
                                   "of a rigid rolling wheel (footing method). " + UNITS_HELP)
    p.add_argument("--depth", choices=("modified", "theory"), default="modified",
                   help="equivalent footing depth (default %(default)s)")
    _add_wheel(p)
    _add_soil(p)
    p.add_argument("--c2", type=_quantity(PRESSURE), help="lower layer cohesion, Pa (give --c2 and/or --phi2)")
    p.add_argument("--phi2", type=_quantity(ANGLE), help="lower layer friction angle, deg (default 0 with --c2)")
    g = p.add_mutually_exclusive_group(required=True)
    g.add_argument("--load", type=_quantity(FORCE), help="vertical wheel force Q_V, N")
    g.add_argument("--sinkage", type=_quantity(LENGTH), help="sinkage on the top layer, m")

    p = sub.add_parser("check", parents=[common], help="validate a scene file and print it in SI",
                       description="Validate a scene file (TOML) and print it in SI units "
                                   "(angles in degrees). " + UNITS_HELP)
    p.add_argument("scene", help="scene file (TOML)")

    p = sub.add_parser("run", parents=[common], help="one finite-element simulation of a scene",
                       description="Run one finite-element simulation of a scene file and write the run "
                                   "directory: summary.json, history.csv, fields/ (XDMF) and plots. "
                                   "Under mpirun the mesh is distributed over the ranks. " + UNITS_HELP)
    p.add_argument("scene", help="scene file (TOML)")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--no-fields", action="store_true", help="do not write XDMF fields")
    p.add_argument("--petsc-option", action="append", default=[], metavar="KEY=VALUE",
                   help="PETSc option for the Newton solver (repeatable), e.g. snes_linesearch_type=bt")
    p.add_argument("--checkpoint-every", type=int, default=None, metavar="N",
                   help="rigid-wheel rolling: write checkpoint/ every N rolled steps (default 10, 0: never); "
                        "a run started again on the same --out continues from it")
    p.add_argument("--restart", action="store_true",
                   help="rigid-wheel rolling: start from the beginning even if --out holds a checkpoint of this run")

    p = sub.add_parser("study", parents=[common], help="run a sweep of scenes (resumes when re-run)",
                       description="Run a study: a base scene plus sweeps (grid, zip or CSV rows), "
                                   "one run directory per case, results.csv, and the report. Under "
                                   "mpirun the cases are spread over the ranks. Safe to re-run: "
                                   "finished cases are not run again.")
    p.add_argument("study", help="study file (TOML)")
    p.add_argument("--out", required=True, help="output directory")
    p.add_argument("--dry-run", action="store_true", help="list the cases and the estimated cost, run nothing")
    p.add_argument("--no-report", action="store_true", help="do not write the report at the end")

    p = sub.add_parser("report", parents=[common], help="plots and tables for a study directory")
    p.add_argument("directory", help="a directory written by rollsim study")

    p = sub.add_parser("design", parents=[common], help="design charts, wheel comparison and lab validation",
                       description="The analytic design study: sinkage-strength charts for several "
                                   "loads and two wheels, influence depth vs load, the two-wheel "
                                   "comparison table and the validation against the laboratory "
                                   "rolling tests. Writes PNGs, CSV tables and report.md.")
    p.add_argument("--out", required=True, help="output directory")
    return parser


def _si(args, name: str, *, flag: str | None = None):
    """The SI value of option ``name`` (None when not given), errors naming the flag."""
    value = getattr(args, name)
    if value is None:
        return None
    text, kind = value
    return to_si(text, kind, flag or "--" + name.replace("_", "-"))


def _angle(args, name):
    value = _si(args, name)
    return None if value is None else math.radians(value)


def _wheel(args, suffix=""):
    from rollsim.studies.bearing_capacity import Wheel
    d, b = _si(args, "d" + suffix), _si(args, "b" + suffix)
    flex = _si(args, "flex") if hasattr(args, "flex") else 0.0
    for name, v in (("--d" + suffix, d), ("--b" + suffix, b)):
        if v is not None and v <= 0:
            raise InputError(name, "must be positive")
    if d is not None and b is not None and b > d:
        raise InputError("--b" + suffix, f"wheel width {b} m exceeds its diameter {d} m")
    return Wheel(d, b, getattr(args, "shape", "cylinder"), flex)


def _options(args):
    from rollsim.studies.bearing_capacity import Options
    return Options(mode=args.mode, method=args.method, depth=args.depth)


def _soil(args, c=None, phi=None):
    from rollsim.studies.bearing_capacity import Soil
    c = _si(args, "c") if c is None else c
    phi = _angle(args, "phi") if phi is None else phi
    gamma = _si(args, "gamma")
    if c is not None and c < 0:
        raise InputError("--c", "must be zero or positive")
    if phi is not None and not 0 <= phi < math.radians(90):
        raise InputError("--phi", "must be in [0, 90) deg")
    if gamma <= 0:
        raise InputError("--gamma", "must be positive")
    return Soil(c, phi, gamma)


def _note(args, text):
    if not args.quiet:
        print(text, file=sys.stderr)


def _validity_note(args, s_over_d):
    from rollsim.studies.bearing_capacity import VALIDITY_RANGE
    lo, hi = VALIDITY_RANGE
    if not lo <= s_over_d <= hi:
        _note(args, f"note: s/d = {s_over_d:.4f} is outside the model's range {lo}-{hi}"
                    + (" (not to be used beyond 0.1)" if s_over_d > 0.1 else ""))


def cmd_predict(args) -> dict:
    from rollsim.studies.bearing_capacity import sinkage, wheel_forces
    wheel, soil, opts = _wheel(args), _soil(args), _options(args)
    if soil.c == 0 and soil.phi == 0:
        raise InputError("--c", "a soil with c = 0 and phi = 0 has no strength; give --c or --phi")
    if opts.mode == "rolling" and wheel.flexibility > 0 and opts.method != "footing":
        raise InputError("--method", "a flexible rolling wheel uses the footing method")
    if args.load is not None:
        load = _si(args, "load")
        if load <= 0:
            raise InputError("--load", "must be positive")
        result = sinkage(load, wheel, soil, opts)
        if result.exceeds_capacity:
            raise NoAnswer(f"the load {load / 1e3:.1f} kN exceeds the wheel's capacity "
                           f"{float(result.max_QV) / 1e3:.1f} kN (reached at s = {float(result.sinkage_at_max):.4f} m): "
                           "no steady sinkage",
                           {"error": "exceeds_capacity", "max_QV_N": float(result.max_QV),
                            "sinkage_at_max_m": float(result.sinkage_at_max)})
        s, forces = float(result.sinkage), result.forces
    else:
        s = _si(args, "sinkage")
        if not 0 < s < wheel.diameter / 2:
            raise InputError("--sinkage", "must be positive and less than half the wheel diameter")
        forces = wheel_forces(s, wheel, soil, opts)
    d_e = float(forces.d_e)
    out = {"mode": opts.mode, "method": opts.method if opts.mode == "rolling" else None, "depth": opts.depth,
           "shape": wheel.shape, "sinkage_m": s, "QV_N": float(forces.QV), "QH_N": float(forces.QH),
           "Q_N": float(forces.Q), "s_over_d": s / d_e, "beta_deg": math.degrees(float(forces.beta)),
           "effective_diameter_m": d_e, "in_validity_range": 0.01 <= s / d_e <= 0.08}
    _validity_note(args, s / d_e)
    if not args.json:
        print(f"{opts.mode} of a {'rigid' if wheel.flexibility == 0 else 'flexible'} {wheel.shape} "
              f"d = {wheel.diameter:g} m, b = {wheel.width:g} m on c = {soil.c / 1e3:g} kPa, "
              f"phi = {math.degrees(soil.phi):g} deg, gamma = {soil.gamma / 1e3:g} kN/m^3")
        print(f"sinkage s = {s:.4f} m (s/d = {s / d_e:.4f})")
        print(f"Q_V = {out['QV_N'] / 1e3:.2f} kN, Q_H = {out['QH_N'] / 1e3:.2f} kN, Q = {out['Q_N'] / 1e3:.2f} kN")
    return out


def cmd_invert(args) -> dict:
    from rollsim.studies import bearing_capacity as bc
    opts, wheel = _options(args), _wheel(args)
    gamma = _soil(args, c=0.0, phi=0.0).gamma
    load = _si(args, "load")
    if load <= 0:
        raise InputError("--load", "must be positive")
    c, phi = _si(args, "c"), _angle(args, "phi")
    second = [n for n in ("load2", "sinkage2", "d2", "b2") if getattr(args, n) is not None]
    if args.record:
        return _invert_record(args, wheel, gamma, load, c, phi, opts)
    for flag in ("out", "min_strength"):
        if getattr(args, flag) is not None:
            raise InputError("--" + flag.replace("_", "-"), "applies with --record only")
    if second and (args.load2 is None or args.sinkage2 is None):
        raise InputError("--load2" if args.load2 is None else "--sinkage2", "a second measurement needs both "
                         "--load2 and --sinkage2")
    if args.sinkage is None:
        raise InputError("--sinkage", "give the measured sinkage (or --record)")
    s = _si(args, "sinkage")
    if not 0 < s < wheel.diameter / 2:
        raise InputError("--sinkage", "must be positive and less than half the wheel diameter")
    if second:
        if c is not None or phi is not None:
            raise InputError("--c", "with a second measurement both c and phi are found; do not hold one fixed")
        if args.load2 is None or args.sinkage2 is None:
            raise InputError("--load2" if args.load2 is None else "--sinkage2", "a second measurement needs both "
                             "--load2 and --sinkage2")
        d2 = _si(args, "d2") if args.d2 is not None else wheel.diameter
        b2 = _si(args, "b2") if args.b2 is not None else wheel.width
        wheel2 = bc.Wheel(d2, b2, wheel.shape, wheel.flexibility)
        load2, s2 = _si(args, "load2"), _si(args, "sinkage2")
        if load2 <= 0:
            raise InputError("--load2", "must be positive")
        if not 0 < s2 < d2 / 2:
            raise InputError("--sinkage2", "must be positive and less than half the wheel diameter")
        try:
            r = bc.strength_from_two_measurements(s, load, wheel, s2, load2, wheel2, gamma, opts)
        except InputError as e:
            raise NoAnswer(e.message, {"error": "no_solution", "message": e.message}) from None
        out = {"c_Pa": r.c, "phi_deg": math.degrees(r.phi), "ill_conditioned": r.ill_conditioned,
               "dc_Pa_per_1pct_sinkage": r.dc_per_percent,
               "dphi_deg_per_1pct_sinkage": math.degrees(r.dphi_per_percent)}
        if r.ill_conditioned:
            _note(args, "warning: the two measurements are ill-conditioned (nearly parallel curves): a 1 % "
                        f"sinkage error moves c by {r.dc_per_percent / 1e3:.1f} kPa and phi by "
                        f"{math.degrees(r.dphi_per_percent):.2f} deg; use wheels or loads that differ more")
    else:
        if (c is None) == (phi is None):
            raise InputError("--c", "hold exactly one of --c or --phi fixed (or give a second measurement)")
        if c is not None:
            found = float(bc.friction_angle_from_sinkage(s, load, wheel, c, gamma, opts))
            if math.isnan(found):
                raise NoAnswer("no friction angle in 0-70 deg gives this sinkage with the given cohesion",
                               {"error": "no_solution", "c_Pa": c})
            out = {"c_Pa": c, "phi_deg": math.degrees(found)}
        else:
            found = float(bc.cohesion_from_sinkage(s, load, wheel, phi, gamma, opts))
            if math.isnan(found):
                raise NoAnswer("friction and weight alone carry more than this load at this sinkage: no c >= 0 fits",
                               {"error": "no_solution", "phi_deg": math.degrees(phi)})
            out = {"c_Pa": found, "phi_deg": math.degrees(phi)}
    _validity_note(args, s / wheel.diameter)
    if not args.json:
        print(f"c = {out['c_Pa'] / 1e3:.2f} kPa, phi = {out['phi_deg']:.2f} deg")
    return out


def _invert_record(args, wheel, gamma, load, c, phi, opts) -> dict:
    import csv

    import numpy as np

    from rollsim.files import atomic_path, output_file, read_text
    from rollsim.studies.bearing_capacity import strength_profile
    if (c is None) == (phi is None):
        raise InputError("--c", "with --record hold exactly one of --c or --phi fixed")
    if args.min_strength is None:
        raise InputError("--min-strength", "a record needs the minimum acceptable strength")
    minimum = (math.radians(to_si(args.min_strength, ANGLE, "--min-strength")) if c is not None
               else to_si(args.min_strength, PRESSURE, "--min-strength"))
    out_path = output_file(args.out, "--out") if args.out is not None else None
    rows = list(csv.DictReader(read_text(args.record, "--record").splitlines()))
    if not rows or not {"position_m", "sinkage_m"} <= set(rows[0]):
        raise InputError("--record", "the CSV needs columns position_m and sinkage_m")
    try:
        position = np.array([float(r["position_m"]) for r in rows])
        s = np.array([float(r["sinkage_m"]) for r in rows])
    except ValueError as e:
        raise InputError("--record", f"not a number: {e}") from None
    if np.any(s <= 0) or np.any(s >= wheel.diameter / 2):
        raise InputError("--record", "sinkage_m must be positive and less than half the wheel diameter")
    prof = strength_profile(position, s, load, wheel, gamma, c=c, phi=phi, minimum=minimum, opts=opts)
    scale, unit = (1.0, "Pa") if prof.quantity == "c" else (180.0 / math.pi, "deg")
    column = f"{prof.quantity}_{unit}"
    if out_path is not None:
        out_path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(out_path) as tmp, tmp.open("w", newline="") as f:
            w = csv.writer(f)
            w.writerow(["position_m", "sinkage_m", column, "pass"])
            for row in zip(prof.position, prof.sinkage, prof.strength * scale, prof.passes):
                w.writerow([f"{row[0]:g}", f"{row[1]:g}", f"{row[2]:.6g}", "yes" if row[3] else "no"])
    n_fail = int((~prof.passes).sum())
    out = {"points": len(rows), "failing_points": n_fail, "verdict": "pass" if n_fail == 0 else "fail",
           f"min_{column}": float(np.nanmin(prof.strength) * scale) if np.any(np.isfinite(prof.strength)) else None,
           "failing_positions_m": [float(x) for x in prof.position[~prof.passes]]}
    if not args.json:
        print(f"{len(rows)} points, {n_fail} below the minimum: {out['verdict'].upper()}")
    return out


def cmd_influence(args) -> dict:
    from rollsim.studies.bearing_capacity import Wheel
    from rollsim.studies.layered import influence_depth
    wheel = _wheel(args)
    wheel = Wheel(wheel.diameter, wheel.width)
    top = _soil(args)
    if top.c == 0 and top.phi == 0:
        raise InputError("--c", "the top layer needs --c or --phi")
    if args.c2 is None and args.phi2 is None:
        raise InputError("--c2", "give the lower layer's strength (--c2 and/or --phi2)")
    c2 = 0.0 if args.c2 is None else _si(args, "c2")
    phi2 = 0.0 if args.phi2 is None else _angle(args, "phi2")
    if c2 < 0:
        raise InputError("--c2", "must be zero or positive")
    if not 0 <= phi2 < math.radians(90):
        raise InputError("--phi2", "must be in [0, 90) deg")
    load, s = _si(args, "load"), _si(args, "sinkage")
    if load is not None and load <= 0:
        raise InputError("--load", "must be positive")
    if s is not None and not 0 < s < wheel.diameter / 2:
        raise InputError("--sinkage", "must be positive and less than half the wheel diameter")
    r = influence_depth(wheel, top, c2, phi2, load=load, s=s, depth=args.depth)
    if r.exceeds_capacity:
        raise NoAnswer("the load exceeds the top layer's rolling capacity: no steady sinkage",
                       {"error": "exceeds_capacity"})
    out = {"H_m": float(r.H_m), "case": str(r.case), "H_over_d": float(r.H_m) / wheel.diameter,
           "sinkage_m": float(r.sinkage_m), "B_m": float(r.B_m), "L_m": float(r.L_m),
           "Ks": None if math.isnan(float(r.Ks)) else float(r.Ks), "Ks_extrapolated": bool(r.Ks_extrapolated)}
    if r.Ks_extrapolated:
        _note(args, "note: Ks extrapolated outside the Meyerhof-Hanna chart (phi1 20-50 deg, q2/q1 0-1)")
    if not args.json:
        print(f"influence depth H = {out['H_m']:.3f} m (H/d = {out['H_over_d']:.2f}), case {out['case']}")
    return out


def cmd_check(args) -> dict:
    from rollsim.scene import load_scene
    scene = load_scene(args.scene).to_dict()
    if not args.json:
        print(json.dumps(scene, indent=2))
    return scene


def _petsc_options(items) -> dict:
    options = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise InputError("--petsc-option", f"expected KEY=VALUE, got {item!r}")
        options[key.strip().lstrip("-")] = value.strip()
    return options


def cmd_run(args) -> dict:
    from mpi4py import MPI

    from rollsim.log import setup_logging
    from rollsim.scene import load_scene
    comm = MPI.COMM_WORLD
    setup_logging(comm, quiet=args.quiet, verbose=args.verbose)
    scene = load_scene(args.scene)
    output_directory(args.out)
    options = _petsc_options(args.petsc_option)
    if scene.wheel.type != "rigid" and scene.loading.protocol == "rolling-continuous":
        raise InputError("wheel.type", 'a pneumatic wheel runs with protocol = "indentation" or '
                         '"rolling-constant-load"')
    resumable = {}
    if scene.wheel.type == "rigid" and scene.loading.protocol.startswith("rolling") and scene.model.rolling != "steady":
        if args.checkpoint_every is not None and args.checkpoint_every < 0:
            raise InputError("--checkpoint-every", "must be 0 (never) or a positive number of steps")
        resumable = {"restart": args.restart} | ({} if args.checkpoint_every is None
                                                 else {"checkpoint_every": args.checkpoint_every})
    elif args.checkpoint_every is not None or args.restart:
        raise InputError("--checkpoint-every" if args.checkpoint_every is not None else "--restart",
                         "only a rigid wheel's transient rolling run writes checkpoints")
    from rollsim.solver.run import run_scene
    summary = run_scene(scene, args.out, comm, progress=not args.quiet, petsc_options=options or None,
                        write_fields=not args.no_fields, **resumable)
    if comm.rank == 0:
        from rollsim.studies.report import run_report
        run_report(args.out)
    if not args.json and comm.rank == 0:
        extra = ""
        if summary.get("rolling") == "steady" and summary.get("rut_depth_m") is not None:
            extra = (f"; steady rolling, Q_H = {summary['QH_N'] / 1e3:.2f} kN, rut depth "
                     f"{summary['rut_depth_m']:.4f} m")
        elif summary.get("steady_state"):
            ss = summary["steady_state"]
            extra = (f"; steady state {'reached' if ss['reached'] else 'NOT reached'}, Q_H = "
                     f"{summary['QH_N'] / 1e3:.2f} kN"
                     + (f", rut depth {summary['rut_depth_m']:.4f} m" if summary.get("rut_depth_m") is not None else ""))
        print(f"{summary['status']}: {summary['steps']} steps, Q_V = {summary['QV_N'] / 1e3:.2f} kN at "
              f"s = {summary['sinkage_m']:.4f} m{extra}; {args.out}/summary.json")
    if summary["status"] != "ok":
        raise RunFailed(summary.get("reason", "failed"), {"error": summary["status"],
                                                          "reason": summary.get("reason", "")})
    keys = ("status", "steps", "sinkage_m", "QV_N", "QH_N", "wall_time_s", "ranks", "dofs", "rut_depth_m",
            "rebound_m", "steady_state")
    return {k: summary[k] for k in keys if k in summary}


class RunFailed(Exception):
    """A simulation ended in a failure state (exit 1); its run directory holds the diagnostics."""

    def __init__(self, message: str, payload: dict):
        super().__init__(message)
        self.payload = payload


def cmd_study(args) -> dict:
    from mpi4py import MPI

    from rollsim.log import setup_logging
    from rollsim.studies import study as st
    comm = MPI.COMM_WORLD
    setup_logging(comm, quiet=args.quiet, verbose=args.verbose)
    study = st.load_study(args.study)  # every case is validated before anything is written
    if not args.dry_run:
        output_directory(args.out)
    if args.dry_run:
        if comm.rank == 0 and not args.json:
            print("\n".join(st.dry_run_lines(study)))
        return {"cases": [c.name for c in study.cases], "runner": study.runner}
    runner = (st.analytic_runner(study.reference_loads) if study.runner == "analytic"
              else st.fe_runner(study.reference_loads))
    rows = st.run_study(study, args.out, comm, runner, quiet=args.quiet)
    report = None
    if not args.no_report and comm.rank == 0:
        from rollsim.studies.report import write_report
        report = str(write_report(args.out))
    counts = {s: sum(r["status"] == s for r in rows) for s in ("ok", "failed")}
    if comm.rank == 0 and not args.json:
        print(f"{len(rows)} cases: {counts['ok']} ok, {counts['failed']} failed; results {args.out}/results.csv"
              + (f"; report {report}" if report else ""))
    return {"cases": len(rows), **counts, "results": f"{args.out}/results.csv", "report": report}


def cmd_report(args) -> dict:
    import pathlib

    from rollsim.studies.report import run_report, write_report
    directory = pathlib.Path(args.directory)
    if not directory.is_dir():
        raise InputError("directory", f"no such directory: {directory}")
    is_run = (directory / "history.csv").is_file()
    try:
        path = run_report(directory) if is_run else write_report(directory)
    except InputError:
        raise
    except (ValueError, KeyError, TypeError, IndexError, AttributeError) as e:
        raise InputError(str(directory), f"its files cannot be read ({type(e).__name__}: {e}); "
                         "run the study or the scene again") from None
    if not args.json:
        print(f"report: {path}")
    return {"report": str(path)}


def cmd_design(args) -> dict:
    from rollsim.log import setup_logging
    from rollsim.studies.design import run_design_study
    setup_logging(quiet=args.quiet, verbose=args.verbose)
    return run_design_study(output_directory(args.out), quiet=args.quiet)


COMMANDS = {"predict": cmd_predict, "invert": cmd_invert, "influence": cmd_influence, "check": cmd_check,
            "run": cmd_run, "study": cmd_study, "report": cmd_report, "design": cmd_design}


#: names of the model's API fields -> the flags that set them (errors name the flag)
_FLAG_OF_FIELD = {name: f"--{name}" for name in ("c", "phi", "gamma", "d", "b", "flex", "load", "sinkage")}


def main(argv: list[str] | None = None) -> int:
    """Run one command; returns the exit status.  Every failure is one line on stderr (rank 0
    under mpirun) and, with ``--json``, one JSON object; a traceback only with ``--debug``."""
    argv = sys.argv[1:] if argv is None else list(argv)
    as_json, debug = "--json" in argv, "--debug" in argv
    parallel = bool(argv) and argv[0] in PARALLEL_COMMANDS  # one JSON object per run, from rank 0
    speaks = not parallel or _rank() == 0
    code, payload, message = EXIT_OK, None, None
    try:
        args = build_parser().parse_args(argv)
        payload = COMMANDS[args.command](args)
    except SystemExit as e:  # --help, --version
        return e.code if isinstance(e.code, int) else EXIT_OK
    except InputError as e:
        field = _FLAG_OF_FIELD.get(e.field, e.field)
        code, payload = EXIT_INPUT, {"error": "invalid_input", "field": field, "message": e.message}
        message = f"rollsim: error: {field}: {e.message}"
    except NoAnswer as e:
        code, payload, message = EXIT_NO_ANSWER, e.payload, f"rollsim: {e}"
    except RunFailed as e:
        code, payload, message = EXIT_FAILURE, e.payload, f"rollsim: the run failed: {e}"
    except OSError as e:  # the file system refused: a path the user gave, or the machine
        code = EXIT_INPUT if isinstance(e, (FileNotFoundError, PermissionError, IsADirectoryError,
                                            NotADirectoryError, FileExistsError)) else EXIT_FAILURE
        where = e.filename or ""
        payload = {"error": "file_system", "path": str(where), "message": e.strerror or str(e)}
        message = f"rollsim: error: {where}: {e.strerror or e}"
    except Exception as e:  # noqa: BLE001 - one line, the traceback with --debug
        if debug:
            raise
        code, payload = EXIT_FAILURE, {"error": "internal", "message": f"{type(e).__name__}: {e}"}
        message = f"rollsim: internal error: {type(e).__name__}: {e} (rerun with --debug for the traceback)"
    if message and speaks:
        print(message, file=sys.stderr)
    if as_json and payload is not None and speaks:
        print(json.dumps(payload))
    return code


def _rank() -> int:
    from mpi4py import MPI
    return MPI.COMM_WORLD.rank


def entry() -> None:
    try:
        code = main()
        sys.stdout.flush()
    except BrokenPipeError:  # output piped into e.g. `head`: stop quietly
        import os
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        code = EXIT_OK
    sys.exit(code)
