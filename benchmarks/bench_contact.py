"""Penalty contact against Hertz, plane strain and 3D, two problems.

``hertz``: a rigid cylinder on an elastic plane-strain block.  For several penalty factors alpha
(kappa = alpha E/h) and element sizes, the contact half-width a (from the pressure's second
moment) and the peak pressure p0 against Hertz (a = sqrt(4 R P'/(pi E*)), p0 = 2P'/(pi a)), the
penetration / h and the wall time.  R = 0.5 m, E = 10 MPa, nu = 0.3, block 1 m x 1 m (half,
symmetric), indentation 6 mm (a ~ 0.04 m).

``pair``: two elastic bodies.  Plane strain, quarter model: cylinder R = 0.5 m, E = 20 MPa; block
1 m x 1 m, E = 10 MPa; nu = 0.3; the cylinder's cut is pushed down 10 mm (a ~ 0.054 m).
``--dim 3``: a sphere of the same radius and materials on a block 2 m x 2 m x 1 m, quarter model,
tetrahedra (a ~ 0.072 m).  For element sizes ``--fine`` (m, round the contact), penalty factors
``--alpha`` (kappa = alpha E_max / h) and either surface as the slave: a or the contact radius
and p0 against Hertz with the combined modulus, the L2 distance of the pressure at the
integration points from Hertz's, and the Newton iterations.

    python -m benchmarks contact hertz [--out bench_contact_hertz.json]
    python -m benchmarks contact pair --out benchmarks/results/contact_pair.json
    python -m benchmarks contact pair --dim 3 --out benchmarks/results/contact_pair_3d.json
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys
import time

from mpi4py import MPI

from _bench import dump_json, run_problems

sys.path.insert(0, str(pathlib.Path(__file__).parents[1] / "tests"))
from test_contact import _hertz_run  # noqa: E402
from test_contact_pair import hertz_pair_run, hertz_sphere_run  # noqa: E402

DEFAULT_FINE = {2: [0.01, 0.005, 0.0025], 3: [0.03, 0.02, 0.014]}
DEFAULT_ALPHA = {2: [1.0, 3.0, 10.0, 30.0], 3: [3.0, 10.0]}


def rigid_cylinder(argv: list[str]) -> int:
    """The ``hertz`` problem (module docstring)."""
    ap = argparse.ArgumentParser(prog="python -m benchmarks contact hertz")
    ap.add_argument("--out", default=None)
    args = ap.parse_args(argv)
    comm = MPI.COMM_WORLD
    rows = []
    if comm.rank == 0:
        print(f"{'h (m)':>7} {'alpha':>7} {'a/a_H-1':>9} {'p0/p0_H-1':>10} {'pen/h':>9} {'time s':>7}")
    for fine in (0.01, 0.005, 0.0025):
        for alpha in ((1, 3, 10, 30, 100, 1000, 1e4) if fine == 0.005 else (10, 100)):
            t0 = time.perf_counter()
            r = _hertz_run(comm, fine, alpha)
            dt = time.perf_counter() - t0
            row = {"h": fine, "alpha": alpha, "a_err": r["a"] / r["a_hertz"] - 1, "p0_err": r["p0"] / r["p0_hertz"] - 1,
                   "pen_over_h": r["pen"] / r["h"], "P_N_per_m": r["P"], "time_s": dt}
            rows.append(row)
            if comm.rank == 0:
                print(f"{fine:7.4f} {alpha:7g} {row['a_err']:+9.4f} {row['p0_err']:+10.4f} {row['pen_over_h']:9.2e} {dt:7.1f}",
                      flush=True)
    if args.out and comm.rank == 0:
        pathlib.Path(args.out).write_text(json.dumps(rows, indent=2))
    return 0


def elastic_pair(argv: list[str]) -> int:
    """The ``pair`` problem (module docstring)."""
    p = argparse.ArgumentParser(prog="python -m benchmarks contact pair")
    p.add_argument("--dim", type=int, choices=[2, 3], default=2, help="plane strain (cylinder) or 3D (sphere)")
    p.add_argument("--fine", type=float, nargs="+", help="element size, m (default: by dimension)")
    p.add_argument("--alpha", type=float, nargs="+", help="penalty factors (default: by dimension)")
    p.add_argument("--slave", nargs="+", choices=["top", "rim"], default=["top", "rim"],
                   help="slave surface: the block's top (flat, softer) or the cylinder's / sphere's rim")
    p.add_argument("--out")
    args = p.parse_args(argv)
    run = hertz_pair_run if args.dim == 2 else hertz_sphere_run
    comm = MPI.COMM_WORLD
    rows = []
    if comm.rank == 0:
        print("| slave | element (mm) | alpha | a / a_Hertz - 1 | p0 / p0_Hertz - 1 | pressure L2 / Hertz "
              "| Newton its (steps) | time (s) |\n|---|---|---|---|---|---|---|---|", flush=True)
    for slave in args.slave:
        for fine in args.fine or DEFAULT_FINE[args.dim]:
            for alpha in args.alpha or DEFAULT_ALPHA[args.dim]:
                t0 = time.perf_counter()
                r = run(comm, fine, alpha, slave)
                dt = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
                row = {"dim": args.dim, "slave": slave, "fine": fine, "alpha": alpha, "a_err": r["a"] / r["a_hertz"] - 1,
                       "p0_err": r["p0"] / r["p0_hertz"] - 1, **r, "time_s": dt}
                rows.append(row)
                if comm.rank == 0:
                    print(f"| {slave} | {1e3 * fine:g} | {alpha:g} | {100 * row['a_err']:+.2f} % "
                          f"| {100 * row['p0_err']:+.2f} % | {100 * r['l2']:.1f} % "
                          f"| {r['newton_iterations']} ({r['steps']}) | {dt:.1f} |", flush=True)
    dump_json(comm, args.out, {"results": rows})
    return 0


if __name__ == "__main__":
    sys.exit(run_problems({"hertz": rigid_cylinder, "pair": elastic_pair}, __doc__))
