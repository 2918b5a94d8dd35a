"""MPI helpers: work done on one rank before a collective, and its failure seen by every rank."""
from __future__ import annotations

import contextlib
import pickle
from typing import Iterator

from mpi4py import MPI


class RootError(RuntimeError):
    """An exception raised on the root rank that could not be sent to the other ranks as it is."""


def _portable(exc: BaseException, root: int) -> BaseException:
    """``exc`` if it survives pickling (so other ranks raise the same type), else a ``RootError``."""
    try:
        return pickle.loads(pickle.dumps(exc))
    except Exception:  # unpicklable exception (e.g. a local class or an unpicklable argument)
        return RootError(f"{type(exc).__name__} on rank {root}: {exc}")


@contextlib.contextmanager
def root_block(comm: MPI.Comm, root: int = 0) -> Iterator[bool]:
    """A block run on rank ``root`` only (it receives ``True`` there), ahead of a collective.

    On leaving it every rank learns whether the root raised: the root re-raises its exception and
    the other ranks raise a copy of it, so no rank is left waiting in the collective that follows
    while the root unwinds::

        with root_block(comm) as on_root:
            if on_root:
                build_model()
        mesh = distribute(...)   # collective
    """
    error = None
    try:
        yield comm.rank == root
    except Exception as exc:
        error = exc
    failure = comm.bcast(None if error is None or comm.rank != root else _portable(error, root), root=root)
    if error is not None:
        raise error
    if failure is not None:
        raise failure
