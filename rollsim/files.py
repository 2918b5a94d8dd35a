"""Atomic file writes: a reader sees the old file or the new one, never half of one.

Every output file of rollsim (run directories, studies, design tables, checkpoints) is written
through :func:`atomic_path`: the data go to a hidden temporary file beside the target, which is
flushed to disk and renamed onto it; on any failure the temporary file is removed and the old
file, if any, is left as it was.
"""
from __future__ import annotations

import contextlib
import os
import pathlib
from typing import Iterator

__all__ = ["atomic_path", "atomic_write_text", "atomic_write_bytes"]


@contextlib.contextmanager
def atomic_path(path) -> Iterator[pathlib.Path]:
    """A temporary path beside ``path`` (same suffix, so ``np.savez`` keeps the name), renamed
    onto ``path`` when the block ends without an exception and removed when it raises."""
    path = pathlib.Path(path)
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.tmp{path.suffix}")
    try:
        yield tmp
        if tmp.exists():
            with open(tmp, "rb+") as f:
                os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def atomic_write_bytes(path, data: bytes) -> None:
    """Write ``data`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)


def atomic_write_text(path, text: str) -> None:
    """Write ``text`` to ``path`` atomically."""
    with atomic_path(path) as tmp:
        tmp.write_text(text)
