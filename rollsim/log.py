"""Logging that speaks once under MPI: rank 0 logs, other ranks only warnings and errors."""
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
        return self.rank == 0 or record.levelno >= logging.WARNING


def get_logger(name: str | None = None) -> logging.Logger:
    return logging.getLogger(LOGGER_NAME if name is None else f"{LOGGER_NAME}.{name}")


def setup_logging(comm: MPI.Comm = MPI.COMM_WORLD, quiet: bool = False, verbose: bool = False) -> None:
    """Configure the ``rollsim`` logger for a command-line run on ``comm``."""
    logger = logging.getLogger(LOGGER_NAME)
    logger.handlers.clear()
    handler = logging.StreamHandler(sys.stderr)
    handler.addFilter(_RankFilter(comm.rank))
    prefix = f"[rank {comm.rank}] " if comm.size > 1 and comm.rank else ""
    handler.setFormatter(logging.Formatter(prefix + "%(message)s"))
    logger.addHandler(handler)
    logger.setLevel(logging.WARNING if quiet else logging.DEBUG if verbose else logging.INFO)
    logger.propagate = False
