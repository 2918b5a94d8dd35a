"""Penalty contact accuracy: rigid cylinder on an elastic plane-strain block vs Hertz.

Prints, for several penalty factors alpha (kappa = alpha E/h) and element sizes, the contact
half-width a (from the pressure's second moment) and the peak pressure p0 against Hertz
(a = sqrt(4 R P'/(pi E*)), p0 = 2P'/(pi a)), the penetration / h and the Newton iterations.
R = 0.5 m, E = 10 MPa, nu = 0.3, block 1 m x 1 m (half, symmetric), indentation 6 mm (a ~ 0.04 m).

    python -m benchmarks contact_hertz [--out bench_contact_hertz.json]
"""
from __future__ import annotations

import argparse
import json
import pathlib
import sys
import time

from mpi4py import MPI

sys.path.insert(0, str(pathlib.Path(__file__).parents[1] / "tests"))
from test_contact import _hertz_run  # noqa: E402


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=None)
    args = ap.parse_args()
    comm = MPI.COMM_WORLD
    rows = []
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


if __name__ == "__main__":
    main()
