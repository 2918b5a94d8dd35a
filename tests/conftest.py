"""Shared test fixtures: MPI-aware temporary directories, serial-only marker, cleanup."""
from __future__ import annotations

import gc
import json
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


#: seconds per test of the tests that took 5 s or more in one serial run (``--store-durations``)
DURATIONS = pathlib.Path(__file__).with_name("durations.json")
LONG_TEST_S = 5.0


def pytest_addoption(parser):
    parser.addoption("--store-durations", action="store_true",
                     help=f"write the tests that take {LONG_TEST_S:g} s or more to {DURATIONS.name}")


#: fixtures that hand a test the communicator: a test that takes one can depend on the partition
COMMUNICATOR_FIXTURES = ("comm", "tmp_mpi_path")


def _takes_communicator(item) -> bool:
    return any(name in getattr(item, "fixturenames", ()) for name in COMMUNICATOR_FIXTURES)


def _runs_in_parallel(item) -> bool:
    """Under mpirun: a test that takes the communicator, unless it is a ``verification`` against an
    exact or published value, whose parallel path the partition-independence tests check."""
    return _takes_communicator(item) and item.get_closest_marker("verification") is None


def pytest_collection_modifyitems(config, items):
    """Under mpirun keep only the tests that take the communicator (:data:`COMMUNICATOR_FIXTURES`):
    the others (return maps, parsers, the analytic model, ...) cannot depend on the partition and
    ran in the serial pass; nor do the ``verification`` tests run there (:func:`_runs_in_parallel`).
    Then share the long tests (measured in durations.json; a ``slow`` test not in it counts as a
    minute) out among pytest-xdist's workers.  xdist 3.1 first hands each
    worker a block of consecutive tests, a quarter of its share; the long tests are dealt to those
    blocks, longest first to the least loaded, so no worker ends on a queue of them while another
    idles.  The other tests keep their file order."""
    misplaced = [item.nodeid for item in items if item.get_closest_marker("end_to_end")
                 and (not _runs_in_parallel(item) or item.get_closest_marker("slow"))]
    if misplaced:
        raise pytest.UsageError(f"end_to_end tests must run in the mpirun pass (take the communicator, not "
                                f"slow or verification): {', '.join(misplaced)}")
    if MPI.COMM_WORLD.size > 1:
        takes = [_runs_in_parallel(item) for item in items]
        config.hook.pytest_deselected(items=[item for item, t in zip(items, takes) if not t])
        items[:] = [item for item, t in zip(items, takes) if t]
    workers = int(getattr(config, "workerinput", {}).get("workercount", 1))
    known = json.loads(DURATIONS.read_text()) if DURATIONS.exists() else {}

    def cost(item) -> float:
        if _skipped_for_the_mpi_pass(item):
            return 0.0
        return known.get(item.nodeid, 60.0 if item.get_closest_marker("slow") else 0.0)

    long = sorted((item for item in items if cost(item) > 0), key=cost, reverse=True)
    short = [item for item in items if cost(item) == 0]
    block = max(len(items) // workers // 4, 2)
    dealt = [[] for _ in range(workers)]
    for item in long:
        open_blocks = [k for k in range(workers) if len(dealt[k]) < block] or range(workers)
        dealt[min(open_blocks, key=lambda k: sum(map(cost, dealt[k])))].append(item)
    ordered = []
    for k in range(workers):
        fill = max(block - len(dealt[k]), 0) if k < workers - 1 else 0
        ordered += dealt[k] + short[:fill]
        short = short[fill:]
    items[:] = ordered + short


_durations: dict[str, float] = {}


_skipped: set[str] = set()


def pytest_runtest_logreport(report):
    _durations[report.nodeid] = _durations.get(report.nodeid, 0.0) + report.duration
    if report.skipped:
        _skipped.add(report.nodeid)


def pytest_sessionfinish(session):
    """With ``--store-durations`` in a serial run: the controller (not an xdist worker) updates the
    file with the tests that ran (those under LONG_TEST_S leave it; skipped ones are not measured)."""
    config = session.config
    if config.getoption("store_durations") and not hasattr(config, "workerinput") and MPI.COMM_WORLD.size == 1:
        known = json.loads(DURATIONS.read_text()) if DURATIONS.exists() else {}
        known.update({k: round(v) for k, v in _durations.items() if k not in _skipped})
        long = {k: v for k, v in sorted(known.items(), key=lambda kv: -kv[1]) if v >= LONG_TEST_S}
        DURATIONS.write_text(json.dumps(long, indent=1) + "\n")


def _skipped_for_the_mpi_pass(item) -> bool:
    """An ``end_to_end`` test in a serial run that the mpirun pass follows (tools/test.sh)."""
    return (item.get_closest_marker("end_to_end") is not None and MPI.COMM_WORLD.size == 1
            and os.environ.get("ROLLSIM_MPI_PASS_FOLLOWS", "0") == "1")


def pytest_runtest_setup(item):
    if item.get_closest_marker("serial") and MPI.COMM_WORLD.size > 1:
        pytest.skip("serial-only test")
    if _skipped_for_the_mpi_pass(item):
        pytest.skip("end-to-end: runs in the mpirun -n 2 pass that follows (tools/test.sh)")
    if (item.get_closest_marker("slow") and MPI.COMM_WORLD.size > 1
            and os.environ.get("ROLLSIM_SLOW_IN_PARALLEL", "0") != "1"):
        pytest.skip("slow: checked in the serial phase (ROLLSIM_SLOW_IN_PARALLEL=1 runs it here)")


@pytest.fixture(autouse=True)
def _collect_and_sync():
    """Free PETSc objects deterministically and keep ranks in step between tests."""
    yield
    gc.collect()
    MPI.COMM_WORLD.barrier()
