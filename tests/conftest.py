"""Shared test fixtures: MPI-aware temporary directories, serial-only marker, cleanup."""
from __future__ import annotations

import gc
import os
import pathlib
import shutil
import tempfile

import pytest
from mpi4py import MPI

import rollsim.compat  # noqa: F401  (longer JIT lock wait: the serial suite runs in parallel workers)


def assert_all(comm: MPI.Comm, condition, message: str = "") -> None:
    """Assert ``condition`` on every rank together: if it fails on any rank, every rank fails here
    (a rank-local assert would leave the others waiting in the test's next collective)."""
    ok = comm.allreduce(bool(condition), op=MPI.LAND)
    assert ok, message or f"failed on a rank (here: {bool(condition)})"


@pytest.fixture(scope="session")
def comm() -> MPI.Comm:
    return MPI.COMM_WORLD


@pytest.fixture
def tmp_mpi_path(comm):
    """A temporary directory shared by all ranks (made on rank 0, removed after the test)."""
    path = pathlib.Path(tempfile.mkdtemp(prefix="rollsim-")) if comm.rank == 0 else None
    path = comm.bcast(path, root=0)
    yield path
    comm.barrier()
    if comm.rank == 0:
        shutil.rmtree(path, ignore_errors=True)


def pytest_collection_modifyitems(items):
    """Slow tests first: the serial phase's workers then share them out before the short ones."""
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)   # a stable sort


def pytest_runtest_setup(item):
    if item.get_closest_marker("serial") and MPI.COMM_WORLD.size > 1:
        pytest.skip("serial-only test")
    if (item.get_closest_marker("slow") and MPI.COMM_WORLD.size > 1
            and os.environ.get("ROLLSIM_SLOW_IN_PARALLEL", "0") != "1"):
        pytest.skip("slow: checked in the serial phase (ROLLSIM_SLOW_IN_PARALLEL=1 runs it here)")


@pytest.fixture(autouse=True)
def _collect_and_sync():
    """Free PETSc objects deterministically and keep ranks in step between tests."""
    yield
    gc.collect()
    MPI.COMM_WORLD.barrier()
