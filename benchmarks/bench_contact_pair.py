"""Two-body penalty contact accuracy: elastic cylinder on an elastic block vs Hertz.

Plane strain, quarter model: cylinder R = 0.5 m, E = 20 MPa; block 1 m x 1 m, E = 10 MPa;
nu = 0.3; the cylinder's cut is pushed down 10 mm (a ~ 0.054 m).  For element sizes ``--fine``
(m, in a 0.1 m zone round the contact), penalty factors ``--alpha`` (kappa = alpha E_max / h)
and either surface as the slave, prints the contact half-width a (from the pressure's second
moment) and the peak pressure p0 against Hertz with the combined modulus, the L2 distance of the
pressure at the integration points from Hertz's ellipse, and the Newton iterations.

    python benchmarks/bench_contact_pair.py --out benchmarks/results/contact_pair.json
"""
from __future__ import annotations

import argparse
import pathlib
import sys
import time

from mpi4py import MPI

from _bench import dump_json

sys.path.insert(0, str(pathlib.Path(__file__).parents[1] / "tests"))
from test_contact_pair import hertz_pair_run  # noqa: E402


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--fine", type=float, nargs="+", default=[0.01, 0.005, 0.0025], help="element size, m")
    p.add_argument("--alpha", type=float, nargs="+", default=[1.0, 3.0, 10.0, 30.0])
    p.add_argument("--slave", nargs="+", choices=["top", "rim"], default=["top", "rim"],
                   help="slave surface: the block's top (flat, softer) or the cylinder's rim")
    p.add_argument("--out")
    args = p.parse_args(argv)
    comm = MPI.COMM_WORLD
    rows = []
    if comm.rank == 0:
        print("| slave | element (mm) | alpha | a / a_Hertz - 1 | p0 / p0_Hertz - 1 | pressure L2 / Hertz "
              "| Newton its (steps) | time (s) |\n|---|---|---|---|---|---|---|---|", flush=True)
    for slave in args.slave:
        for fine in args.fine:
            for alpha in args.alpha:
                t0 = time.perf_counter()
                r = hertz_pair_run(comm, fine, alpha, slave)
                dt = comm.allreduce(time.perf_counter() - t0, op=MPI.MAX)
                row = {"slave": slave, "fine": fine, "alpha": alpha, "a_err": r["a"] / r["a_hertz"] - 1,
                       "p0_err": r["p0"] / r["p0_hertz"] - 1, **r, "time_s": dt}
                rows.append(row)
                if comm.rank == 0:
                    print(f"| {slave} | {1e3 * fine:g} | {alpha:g} | {100 * row['a_err']:+.2f} % "
                          f"| {100 * row['p0_err']:+.2f} % | {100 * r['l2']:.1f} % "
                          f"| {r['newton_iterations']} ({r['steps']}) | {dt:.1f} |", flush=True)
    dump_json(comm, args.out, {"results": rows})
    return 0


if __name__ == "__main__":
    sys.exit(main())
