"""The documentation: it builds without a warning, its links inside the repository resolve (pages
and headings; the code's ``docs/page.md, "Heading"`` pointers too), every page is in the index,
and the scene-format page lists exactly the keys the validator reads."""
from __future__ import annotations

import ast
import pathlib
import re
import subprocess
import sys

import pytest

ROOT = pathlib.Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"
PAGES = [ROOT / "README.md", *sorted(DOCS.glob("*.md")), *sorted((ROOT / "docker").glob("*.md"))]
#: the code whose comments and docstrings point into the docs (``docs/page.md, "Heading"``)
CODE_DIRS = ("solver", "geometry", "studies", "rollsim", "benchmarks", "tools")


@pytest.mark.serial
@pytest.mark.slow
def test_docs_build_without_warnings(tmp_path):
    """Sphinx + MyST with the API reference, warnings as errors."""
    run = subprocess.run([sys.executable, "-m", "sphinx", "-W", "--keep-going", "-b", "html", "-q",
                          "-d", str(tmp_path / "doctrees"), str(DOCS), str(tmp_path / "html")],
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stdout + run.stderr
    assert (tmp_path / "html" / "scene.html").is_file()
    assert (tmp_path / "html" / "generated" / "rollsim.solver.drivers.html").is_file()


def _slug(title: str) -> str:
    """The anchor GitHub and MyST give a heading."""
    text = re.sub(r"[`*]", "", title.strip().lower())
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def _anchors(path: pathlib.Path) -> set[str]:
    """The anchors of a page's headings, down to the level MyST gives anchors (docs/conf.py)."""
    anchors, fence = set(), False
    for line in path.read_text().splitlines():
        if line.lstrip().startswith("```"):
            fence = not fence
        elif not fence and (m := re.match(r"^#{1,4} (.*)", line)):
            anchors.add(_slug(m.group(1)))
    return anchors


def _links(path: pathlib.Path):
    text = re.sub(r"```.*?```", "", path.read_text(), flags=re.S)
    for m in re.finditer(r"\]\(([^)\s]+)\)", text):
        target = m.group(1)
        if not re.match(r"[a-z]+:", target):
            yield target


def _broken(pages) -> list[str]:
    broken = []
    for page in pages:
        for target in _links(page):
            file, _, anchor = target.partition("#")
            dest = (page.parent / file).resolve() if file else page
            if not dest.exists():
                broken.append(f"{page.relative_to(ROOT)}: {target} (no such file)")
            elif anchor and dest.suffix == ".md" and anchor not in _anchors(dest):
                broken.append(f"{page.relative_to(ROOT)}: {target} (no such heading)")
    return broken


def test_links_inside_the_repository_resolve():
    assert not _broken(PAGES), "\n".join(_broken(PAGES))


def test_link_check_catches_a_dead_link(tmp_path):
    page = tmp_path / "page.md"
    page.write_text("# Title\n\n[ok](#title) [gone](missing.md) [no heading](page.md#nothing)\n")
    global ROOT
    saved, ROOT = ROOT, tmp_path
    try:
        assert _broken([page]) == ["page.md: missing.md (no such file)", "page.md: page.md#nothing (no such heading)"]
    finally:
        ROOT = saved


def test_every_page_is_in_the_index():
    """A page outside the toctree of docs/index.md is not reachable from the built docs."""
    toc = re.search(r"```\{toctree\}(.*?)```", (DOCS / "index.md").read_text(), flags=re.S).group(1)
    listed = {line.strip() for line in toc.splitlines() if line.strip() and not line.strip().startswith(":")}
    pages = {page.stem for page in DOCS.glob("*.md")} - {"index"}
    assert pages - listed == set(), f"pages missing from the toctree of docs/index.md: {pages - listed}"
    assert listed - pages == set(), f"toctree entries without a page: {listed - pages}"


def test_benchmark_commands_name_a_benchmark():
    """Every ``python -m benchmarks NAME`` in the docs and the benchmarks' own docstrings names
    one the entry point lists (it lists without importing them: no MPI start)."""
    listed = subprocess.run([sys.executable, "-m", "benchmarks"], cwd=ROOT, capture_output=True, text=True,
                            timeout=60)
    assert listed.returncode == 0, listed.stderr
    names = {line.split()[0] for line in listed.stdout.splitlines()[1:] if line.strip()}
    assert names == {p.stem[len("bench_"):] for p in (ROOT / "benchmarks").glob("bench_*.py")}
    cited = {(path.name, m.group(1)) for path in [*PAGES, *(ROOT / "benchmarks").glob("*.py")]
             for m in re.finditer(r"python -m benchmarks ([a-z][\w-]*)", path.read_text())}
    assert len(cited) > 20
    assert not [c for c in cited if c[1] not in names], [c for c in cited if c[1] not in names]
    wrong = subprocess.run([sys.executable, "-m", "benchmarks", "no_such_benchmark"], cwd=ROOT,
                           capture_output=True, text=True, timeout=60)
    assert wrong.returncode == 2 and "no_such_benchmark" in wrong.stderr


def test_cited_benchmark_results_exist():
    """Every ``benchmarks/results/...`` file a docs page cites (a table's source; a glob or a
    prefix of a family of files counts when something matches) is in the repository."""
    cited = {m.group(0).rstrip("/.") for page in PAGES
             for m in re.finditer(r"benchmarks/results/[\w./*-]+", page.read_text())}
    assert len(cited) > 20
    missing = sorted(c for c in cited if not list(ROOT.glob(c + "*")))
    assert not missing, missing


_POINTER = re.compile(r'docs/([\w.-]+\.md)(?:,\s*"([^"\n]+)")?')


def _dead_pointers(files, docs: pathlib.Path = DOCS) -> list[str]:
    """``docs/page.md`` mentions in ``files`` whose page does not exist, and ``docs/page.md,
    "Heading"`` ones whose page has no such heading (a heading that begins with it counts)."""
    dead = []
    for path in files:
        for m in _POINTER.finditer(path.read_text()):
            page, heading = docs / m.group(1), m.group(2)
            if not page.is_file():
                dead.append(f"{path.name}: docs/{m.group(1)} (no such page)")
            elif heading and not any(a == _slug(heading) or a.startswith(_slug(heading) + "-")
                                     for a in _anchors(page)):
                dead.append(f'{path.name}: docs/{m.group(1)}, "{heading}" (no such heading)')
    return dead


def test_code_pointers_into_the_docs_resolve():
    files = sorted(p for d in CODE_DIRS for p in (ROOT / d).rglob("*.py"))
    assert len(files) > 50
    assert not _dead_pointers(files), "\n".join(_dead_pointers(files))


def test_pointer_check_catches_a_dead_pointer(tmp_path):
    (tmp_path / "page.md").write_text("# Title\n\n## Run directory (`rollsim run`)\n")
    code = tmp_path / "code.py"
    code.write_text('"""See docs/page.md, "Run directory"; docs/page.md, "Title"; docs/gone.md;\n'
                    'docs/page.md, "Nothing"."""\n')
    assert _dead_pointers([code], docs=tmp_path) == ["code.py: docs/gone.md (no such page)",
                                                      'code.py: docs/page.md, "Nothing" (no such heading)']


def _documented_keys() -> set[str]:
    """``table.key`` of every row of docs/scene.md's key tables (``soil.layers[]`` for layers)."""
    keys = set()
    for line in (DOCS / "scene.md").read_text().splitlines():
        if m := re.match(r"^\| `([a-z]+\.[a-z_.\[\]A-Z]+)` \|", line):
            keys.add(m.group(1))
    return keys


#: the reader of each table in rollsim/scene.py: (function, variable) -> table
_TABLE_OF = {("_wheel", "t"): "wheel", ("_layer", "t"): "soil.layers[]", ("_soil", "t"): "soil",
             ("_loading", "t"): "loading", ("parse_scene", "model_table"): "model", ("_rolling_cells", "t"): "model",
             ("_rolling_method", "t"): "model"}


def _validator_keys() -> set[str]:
    """The keys rollsim/scene.py reads: the literal first argument of every ``quantity``, ``choice``,
    ``raw`` or ``has`` call on a table, by the function and variable that read it."""
    tree = ast.parse((ROOT / "rollsim" / "scene.py").read_text())
    keys = set()
    for func in (n for n in tree.body if isinstance(n, ast.FunctionDef)):
        for call in ast.walk(func):
            if (isinstance(call, ast.Call) and isinstance(call.func, ast.Attribute)
                    and call.func.attr in ("quantity", "choice", "raw", "has")
                    and isinstance(call.func.value, ast.Name) and call.args
                    and isinstance(call.args[0], ast.Constant)):
                table = _TABLE_OF.get((func.name, call.func.value.id))
                if table is not None:
                    keys.add(f"{table}.{call.args[0].value}")
    return keys


def test_scene_page_lists_every_key_the_validator_reads():
    documented, read = _documented_keys(), _validator_keys()
    assert len(read) > 30 and "model.relaxation_length" in read and "soil.layers[].dilation" in read
    assert read - documented == set(), f"keys the validator reads but docs/scene.md does not list: {read - documented}"
    assert documented - read == set(), f"keys docs/scene.md lists but the validator does not read: {documented - read}"


def test_documented_defaults_of_the_model_table():
    """The [model] defaults on the page are those the validator applies."""
    from rollsim.scene import parse_scene
    scene = parse_scene({"wheel": {"diameter": 1.0, "width": 0.3}, "soil": {"gamma": 2e4, "layers": [
        {"model": "von-mises", "E": 4e7, "nu": 0.3, "c_dp": 1e5}]},
        "loading": {"protocol": "indentation", "max_sinkage": 0.1}})
    page = (DOCS / "scene.md").read_text()
    m = scene.model
    for key, shown in (("accuracy", f'`"{m.accuracy}"`'), ("kinematics", f'`"{m.kinematics}"`'),
                       ("linear_solver", f'`"{m.linear_solver}"`'),
                       ("volumetric_strain", f'`"{m.volumetric_strain}"` for indentation and for rolling on '
                                             '`standard` and `accurate`'),
                       ("regularising_cohesion", f"{m.regularising_cohesion / 1e3:g} kPa"),
                       ("plateau_tolerance", f"| {m.plateau_tolerance:g} |")):
        row = next(line for line in page.splitlines() if line.startswith(f"| `model.{key}` |"))
        assert shown in row, (key, row)


def test_table_key_lists_match_the_validator():
    """rollsim.scene.TABLE_KEYS (used to say a key "does not apply") lists what the validator reads."""
    from rollsim.scene import TABLE_KEYS
    read = _validator_keys()
    for table, keys in TABLE_KEYS.items():
        assert {f"{table}.{k}" for k in keys} == {k for k in read if k.rpartition(".")[0] == table}, table
