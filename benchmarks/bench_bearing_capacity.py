"""Throughput of the bearing-capacity model's Python API (prints figures; not a test).

    python -m benchmarks bearing_capacity [N]
"""
import argparse
import math
import time

import numpy as np

from rollsim.studies import bearing_capacity as bc


def timed(fn, repeat=5):
    best = float("inf")
    for _ in range(repeat):
        t = time.perf_counter()
        result = fn()
        best = min(best, time.perf_counter() - t)
    return best, result


def main(n: int = 10_000) -> None:
    wheel = bc.Wheel(1.524, 0.4572)
    loads = np.linspace(30e3, 150e3, n)
    clay = bc.Soil(np.linspace(80e3, 250e3, n), 0.0, 20e3)
    sand = bc.Soil(0.0, np.radians(np.linspace(38, 55, n)), 20e3)
    rows = []
    t, r = timed(lambda: bc.sinkage(loads, wheel, clay))
    rows.append(("load -> sinkage, clay (rolling)", t))
    s = r.sinkage
    t, _ = timed(lambda: bc.wheel_forces(s, wheel, clay))
    rows.append(("sinkage -> forces, clay", t))
    t, c = timed(lambda: bc.cohesion_from_sinkage(s, loads, wheel, 0.0, 20e3))
    rows.append(("inverse: c from sinkage", t))
    t, rs = timed(lambda: bc.sinkage(loads / 3, wheel, sand))
    rows.append(("load -> sinkage, sand (rolling)", t))
    t, phi = timed(lambda: bc.friction_angle_from_sinkage(rs.sinkage, loads / 3, wheel, 0.0, 20e3))
    rows.append(("inverse: phi from sinkage", t))
    flex = bc.Wheel(1.524, 0.4572, flexibility=1e-5)
    t, _ = timed(lambda: bc.sinkage(loads, flex, clay), repeat=2)
    rows.append(("load -> sinkage, flexible wheel", t))
    print(f"bearing-capacity model, {n} points per call (best of several runs)")
    for name, seconds in rows:
        print(f"  {name:34s} {seconds * 1e3:8.1f} ms  ({n / seconds / 1e3:8.0f} k points/s)")
    ok = np.isfinite(rs.sinkage)
    print(f"  round-trip error: c {np.max(np.abs(c / clay.c - 1)):.1e}, "
          f"phi {np.max(np.abs(phi[ok] / sand.phi[ok] - 1)):.1e} (relative)")
    print(f"  sand loads over capacity: {int((~ok).sum())} of {n}; largest phi {math.degrees(sand.phi.max()):.0f} deg")


if __name__ == "__main__":
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("points", type=int, nargs="?", default=10_000, help="points per call")
    main(ap.parse_args().points)
