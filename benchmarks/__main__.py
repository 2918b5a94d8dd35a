"""Run a benchmark by name, from the repository's root.

    python -m benchmarks                    # list them, one line each
    python -m benchmarks NAME --help        # what NAME measures and its options
    python -m benchmarks NAME [ARGS ...]    # run it (also under mpirun -n N)

NAME is a ``bench_NAME.py`` of this folder; it runs as that script would.  What the figures
mean and the tables they regenerate: ``docs/benchmarks.md``.
"""
from __future__ import annotations

import ast
import pathlib
import runpy
import sys

HERE = pathlib.Path(__file__).resolve().parent


def benchmarks() -> dict[str, pathlib.Path]:
    """The benchmarks by name (``bench_NAME.py``), sorted."""
    return {p.stem[len("bench_"):]: p for p in sorted(HERE.glob("bench_*.py"))}


def summary(path: pathlib.Path) -> str:
    """The first sentence of the script's docstring (read without importing it)."""
    doc = (ast.get_docstring(ast.parse(path.read_text())) or "").strip()
    first = " ".join(doc.split("\n\n")[0].split())
    first = first.split(". ")[0].rstrip(".:")
    return first if len(first) <= 90 else first[:first.rfind(" ", 0, 88)] + " ..."


def main(argv: list[str]) -> int:
    known = benchmarks()
    if not argv or argv[0] in ("-h", "--help", "list"):
        print(__doc__.strip().splitlines()[0] + "\n")
        width = max(map(len, known))
        for name, path in known.items():
            print(f"  {name:<{width}}  {summary(path)}")
        return 0
    name, args = argv[0], argv[1:]
    if name not in known:
        print(f"benchmarks: no benchmark named {name!r}; one of: {', '.join(known)}", file=sys.stderr)
        return 2
    sys.path.insert(0, str(HERE))
    sys.argv = [str(known[name]), *args]
    try:
        runpy.run_path(str(known[name]), run_name="__main__")
    except SystemExit as done:
        return done.code if isinstance(done.code, int) else (0 if done.code is None else 1)
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
