"""Quiet by default: other libraries' INFO messages (the form compiler's build steps) stay out of
the terminal unless --verbose; rollsim's own progress is shown; the version is reported."""
from __future__ import annotations

import logging
import pathlib

import pytest
from mpi4py import MPI

import rollsim
from rollsim.cli import main
from rollsim.log import get_logger, setup_logging


@pytest.fixture
def restore_logging():
    root = logging.getLogger()
    saved = root.handlers[:], root.level
    yield
    root.handlers[:], root.level = saved
    logging.getLogger("rollsim").handlers.clear()


def _emit():
    logging.getLogger().setLevel(logging.INFO)          # what the compiler's build does to the root logger
    logging.info("running build_ext")
    logging.getLogger("a_library").info("compiling form")     # a library logger without a level of its own
    logging.getLogger("dolfinx").warning("a library warning")
    get_logger("run").info("step 1 progress")
    get_logger("run").warning("a rollsim warning")


def test_compiler_log_hidden_by_default(capsys, restore_logging):
    setup_logging(MPI.COMM_WORLD)
    _emit()
    err = capsys.readouterr().err
    assert "running build_ext" not in err and "compiling form" not in err
    if MPI.COMM_WORLD.rank == 0:
        assert "step 1 progress" in err and "a library warning" in err and "a rollsim warning" in err
    else:   # warnings are the same on every rank: printed once, by rank 0
        assert "warning" not in err


def test_compiler_log_shown_with_verbose(capsys, restore_logging):
    setup_logging(MPI.COMM_WORLD, verbose=True)
    _emit()
    err = capsys.readouterr().err
    if MPI.COMM_WORLD.rank == 0:
        assert "running build_ext" in err and "compiling form" in err and "step 1 progress" in err


def test_version(capsys):
    from importlib.metadata import version
    assert rollsim.__version__ == version("rollsim")
    assert main(["--version"]) == 0
    assert capsys.readouterr().out.strip() == f"rollsim {rollsim.__version__}"


def test_errors_of_parallel_commands_are_printed_once(tmp_path_factory, capsys):
    """Under mpirun every rank runs `rollsim run`; a bad scene is reported by rank 0 only."""
    comm = MPI.COMM_WORLD
    path = tmp_path_factory.mktemp("scene") / "bad.toml"
    scene = pathlib.Path(__file__).resolve().parents[1] / "examples" / "indentation_mndot.toml"
    path.write_text(scene.read_text().replace('diameter = "1.524 m"', 'diameter = "1,5 m"'))
    code = main(["run", str(path), "--out", str(path.parent / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert err == (["rollsim: error: wheel.diameter: use a decimal point, not a comma (and no thousands "
                    "separators): '1,5 m'"] if comm.rank == 0 else [])
