"""Mesh build time and size per accuracy preset: python -m benchmarks mesh [fast standard accurate].

Run under mpirun to include the distribution cost; rank 0 prints one line per case.
"""
from __future__ import annotations

import sys
import time

from mpi4py import MPI

from rollsim.geometry import (MeshOptions, build_soil_block, build_tire, indentation_block, pneumatic_tire,
                              rolling_block)

CASES = {
    "indentation quarter, tetrahedra": lambda comm, o: build_soil_block(comm, indentation_block(1.0), o),
    "rolling half, 2 layers, tetrahedra": lambda comm, o: build_soil_block(comm, rolling_block(1.0, layers=(0.3,)), o),
    "rolling half, 2 layers, hexahedra": lambda comm, o: build_soil_block(
        comm, rolling_block(1.0, layers=(0.3,)), MeshOptions(o.fine_size, o.coarse_size, o.transition, o.order, True)),
    "tire half, hexahedra": lambda comm, o: build_tire(
        comm, pneumatic_tire(1.0), MeshOptions(o.fine_size, o.coarse_size, o.transition, o.order, True)),
}


def main(argv: list[str]) -> int:
    comm = MPI.COMM_WORLD
    for accuracy in argv or ["fast", "standard"]:
        options = MeshOptions.from_accuracy(1.0, accuracy)
        for name, build in CASES.items():
            comm.barrier()
            start = time.perf_counter()
            stats = build(comm, options).stats
            elapsed = comm.allreduce(time.perf_counter() - start, op=MPI.MAX)
            if comm.rank == 0:
                print(f"{accuracy:9s} {name:38s} {stats.cells:8d} cells {stats.nodes:8d} nodes "
                      f"minSJ {stats.quality.min_scaled_jacobian:5.3f} {elapsed:7.2f} s", flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
