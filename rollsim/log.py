"""Logging that speaks once under MPI: rank 0 logs, the other ranks only errors (a warning is
the same on every rank, so it is printed once).

Other libraries' messages go through the root logger: only their warnings and errors are shown,
unless ``verbose``.  (The form compiler's build steps - ``running build_ext``, the compiler
command lines - are logged at INFO on the root logger, whose level the build itself raises.)"""
from __future__ import annotations

import logging
import sys

from mpi4py import MPI

LOGGER_NAME = "rollsim"


class _RankFilter(logging.Filter):
    def __init__(self, rank: int):
        super().__init__()
        self.rank = rank

    def filter(self, record: logging.LogRecord) -> bool:
        return self.rank == 0 or record.levelno >= logging.ERROR


def get_logger(name: str | None = None) -> logging.Logger:
    return logging.getLogger(LOGGER_NAME if name is None else f"{LOGGER_NAME}.{name}")


def setup_logging(comm: MPI.Comm = MPI.COMM_WORLD, quiet: bool = False, verbose: bool = False) -> None:
    """Configure the ``rollsim`` logger for a command-line run on ``comm``: progress at INFO
    (WARNING when ``quiet``, DEBUG when ``verbose``), and other libraries' messages below WARNING
    only when ``verbose``."""
    other = logging.StreamHandler(sys.stderr)
    other.addFilter(_RankFilter(comm.rank))
    other.setLevel(logging.DEBUG if verbose else logging.WARNING)
    logging.basicConfig(handlers=[other], format="%(name)s: %(message)s", force=True,
                        level=logging.INFO if verbose else logging.WARNING)
    logger = logging.getLogger(LOGGER_NAME)
    logger.handlers.clear()
    handler = logging.StreamHandler(sys.stderr)
    handler.addFilter(_RankFilter(comm.rank))
    prefix = f"[rank {comm.rank}] " if comm.size > 1 and comm.rank else ""
    handler.setFormatter(logging.Formatter(prefix + "%(message)s"))
    logger.addHandler(handler)
    logger.setLevel(logging.WARNING if quiet else logging.DEBUG if verbose else logging.INFO)
    logger.propagate = False
