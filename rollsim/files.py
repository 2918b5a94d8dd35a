"""The user's files: atomic writes (a reader sees the old file or the new one, never half of
one), reading text and TOML with one-line errors, and checking output paths before any work.

Every output file of rollsim (run directories, studies, design tables, checkpoints) is written
through :func:`atomic_path`: the data go to a hidden temporary file beside the target, which is
flushed to disk and renamed onto it; on any failure the temporary file is removed and the old
file, if any, is left as it was.  A directory whose files belong together (a checkpoint) is
written whole into :func:`staging_directory` and put in place by :func:`replace_directory`;
:func:`complete_directory` finds its last complete version.
"""
from __future__ import annotations

import contextlib
import os
import pathlib
import shutil
from typing import Iterator

__all__ = ["atomic_path", "atomic_write_text", "atomic_write_bytes", "staging_directory", "replace_directory",
           "complete_directory", "remove_directory", "read_text", "read_toml", "output_directory", "output_file"]


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


def staging_directory(path) -> pathlib.Path:
    """The hidden directory beside ``path`` where its next version is written."""
    path = pathlib.Path(path)
    return path.with_name(f".{path.name}.new")


def _previous(path: pathlib.Path) -> pathlib.Path:
    return path.with_name(f".{path.name}.old")


def replace_directory(path) -> None:
    """Put the :func:`staging_directory` of ``path`` in its place: the current version is moved
    aside, the new one renamed onto ``path``, the old one removed.  Killed at any point, it leaves
    a complete version that :func:`complete_directory` finds (one process only, e.g. rank 0)."""
    path = pathlib.Path(path)
    old = _previous(path)
    if not path.exists() and old.exists():      # killed between the renames of the last replacement
        os.replace(old, path)
    shutil.rmtree(old, ignore_errors=True)
    if path.exists():
        os.replace(path, old)
    os.replace(staging_directory(path), path)
    shutil.rmtree(old, ignore_errors=True)


def complete_directory(path) -> pathlib.Path | None:
    """The last complete version of a directory written by :func:`replace_directory`: ``path``,
    else the previous version (killed between the two renames), else None."""
    path = pathlib.Path(path)
    return next((p for p in (path, _previous(path)) if p.is_dir()), None)


def remove_directory(path) -> None:
    """Remove a directory written by :func:`replace_directory` with its staged and old versions."""
    path = pathlib.Path(path)
    for p in (path, staging_directory(path), _previous(path)):
        shutil.rmtree(p, ignore_errors=True)


def read_text(path, field: str) -> str:
    """The text of the user's file ``path``; ``InputError`` naming ``field`` when it cannot be
    read or is not UTF-8 text."""
    from rollsim.units import InputError
    path = pathlib.Path(path)
    try:
        return path.read_bytes().decode("utf-8")
    except IsADirectoryError:
        raise InputError(field, f"{path} is a directory, not a file") from None
    except OSError as e:
        raise InputError(field, f"cannot read {path} ({e.strerror})") from None
    except UnicodeDecodeError as e:
        raise InputError(field, f"{path} is not UTF-8 text (byte {e.start})") from None


def read_toml(path, field: str) -> dict:
    """The TOML document in ``path`` (see :func:`read_text`); ``InputError`` naming ``field`` when it
    is not valid TOML or nested too deeply to read."""
    import tomllib

    from rollsim.units import InputError
    text = read_text(path, field)
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise InputError(field, f"not valid TOML: {e}") from None
    except RecursionError:
        raise InputError(field, "nested too deeply to read") from None


def output_directory(path, field: str = "--out") -> pathlib.Path:
    """``path`` as an output directory: refused (``InputError`` naming ``field``) when empty, when it
    names an existing file, or when it cannot be created or written; nothing is created here."""
    from rollsim.units import InputError
    if path is None or not str(path).strip():
        raise InputError(field, "give a directory")
    path = pathlib.Path(path)
    if path.exists() and not path.is_dir():
        raise InputError(field, f"{path} exists and is not a directory")
    existing = next((p for p in (path, *path.parents) if p.exists()), pathlib.Path("."))
    if not existing.is_dir() or not os.access(existing, os.W_OK | os.X_OK):
        raise InputError(field, f"cannot write to {existing}")
    return path


def output_file(path, field: str) -> pathlib.Path:
    """``path`` as an output file: refused when empty, when it names a directory, or when its
    folder cannot be written; nothing is created here."""
    from rollsim.units import InputError
    if path is None or not str(path).strip():
        raise InputError(field, "give a file name")
    path = pathlib.Path(path)
    if path.is_dir():
        raise InputError(field, f"{path} is a directory, not a file")
    output_directory(path.parent, field)
    return path
