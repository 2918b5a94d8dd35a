"""The study runner: sweep expansion, resume after a kill, atomic results, rank distribution, report."""
import json
import os
import pathlib
import shutil
import textwrap
import uuid

import pytest
from mpi4py import MPI

from rollsim.cli import main
from rollsim.studies import study as st
from rollsim.units import InputError

ROOT = pathlib.Path(__file__).parents[1]
BASE = (ROOT / "examples" / "indentation_mndot.toml").as_posix()


def write_study(directory: pathlib.Path, body: str, name="study.toml") -> pathlib.Path:
    path = directory / name
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(f'base = "{BASE}"\n' + textwrap.dedent(body))
    MPI.COMM_WORLD.barrier()
    return path


GRID = """
reference_loads = ["100 kN"]
[[sweep]]
"soil.layers[0].E" = ["20 MPa", "40 MPa"]
"wheel.friction" = [0.4, 0.8]
[[sweep]]
mode = "zip"
"wheel.diameter" = ["1.2 m", "1.5 m"]
"wheel.width" = ["0.3 m", "0.45 m"]
"""


def test_grid_zip_product_expansion(tmp_mpi_path):
    study = st.load_study(write_study(tmp_mpi_path, GRID))
    assert len(study.cases) == 4 * 2
    names = [c.name for c in study.cases]
    assert len(set(names)) == 8 and names[0] == "E=20MPa_friction=0.4__diameter=1.2m_width=0.3m"
    last = study.cases[-1].scene
    assert last.soil.layers[0].E == 40e6 and last.wheel.friction == 0.8
    assert (last.wheel.diameter, last.wheel.width) == (1.5, 0.45)  # zipped, not crossed
    assert study.reference_loads == (100e3,)


def test_csv_rows_expansion(tmp_mpi_path):
    study = st.load_study(ROOT / "studies" / "examples" / "analytic_indentation_cases.toml")
    assert [c.name for c in study.cases] == [f"case-{i:02d}" for i in range(1, 13)]
    case5 = study.cases[4].scene.soil.layers[0]
    assert case5.c_dp == pytest.approx(194.6e3) and case5.phi_dp == pytest.approx(0.47996554, rel=1e-6)


@pytest.mark.parametrize("body, field", [
    ('[[sweep]]\n"soil.layers[0].nu" = [0.3, 0.6]\n', "case nu=0.6: soil.layers[0].nu"),
    ('[[sweep]]\nmode = "zip"\n"wheel.width" = ["0.3 m"]\n"wheel.diameter" = ["1 m", "2 m"]\n', "sweep[0].wheel.width"),
    ('[[sweep]]\n"soil.layers[3].E" = ["1 MPa"]\n', "soil.layers[3].E"),
    ('[[sweep]]\ncsv = "missing.csv"\n', "sweep[0].csv"),
    ('colour = 1\n', "colour"),
    ('runner = "quantum"\n', "runner"),
])
def test_bad_study_names_the_key(tmp_mpi_path, body, field):
    with pytest.raises(InputError) as e:
        st.load_study(write_study(tmp_mpi_path, body))
    assert e.value.field == field


def counting_runner(log_dir: pathlib.Path, fail=()):
    """Runs a case by writing a marker per invocation (to count runs) and a history curve."""
    def run(case, case_dir, comm):
        if comm.rank == 0:
            (log_dir / f"{case.name}.{uuid.uuid4().hex}.ran").write_text("")
        if case.name in fail:
            raise RuntimeError("diverged on purpose")
        summary = st.analytic_runner([100e3])(case, case_dir, comm)
        summary["world_rank"] = MPI.COMM_WORLD.rank
        return summary
    return run


def runs(log_dir: pathlib.Path, name: str) -> int:
    return len(list(log_dir.glob(f"{name}.*.ran")))


def _grid_study(tmp, comm):
    """The GRID study with its output and run-marker directories."""
    study = st.load_study(write_study(tmp, GRID))
    out, log_dir = tmp / "out", tmp / "log"
    if comm.rank == 0:
        log_dir.mkdir()
    comm.barrier()
    return study, out, log_dir


def test_resume_after_kill_and_failure_isolation(tmp_mpi_path):
    comm = MPI.COMM_WORLD
    study, out, log_dir = _grid_study(tmp_mpi_path, comm)
    failing = study.cases[1].name
    rows = st.run_study(study, out, comm, counting_runner(log_dir, fail={failing}), quiet=True)
    assert [r["status"] for r in rows].count("ok") == 7
    assert next(r for r in rows if r["case"] == failing)["status"] == "failed"
    # simulate a kill in the middle of case 3: summary missing, files half-written
    killed = study.cases[3].name
    if comm.rank == 0:
        (out / "cases" / killed / "summary.json").unlink()
        (out / "cases" / killed / "history.csv").write_text("step,sinkage_m\n1,0.0")
    comm.barrier()
    rows = st.run_study(study, out, comm, counting_runner(log_dir), quiet=True)
    assert all(runs(log_dir, c.name) == (2 if c.name == killed else 1) for c in study.cases)
    assert next(r for r in rows if r["case"] == killed)["status"] == "ok"
    assert next(r for r in rows if r["case"] == failing)["status"] == "failed"  # recorded, not retried
    assert not list(out.rglob("*.tmp"))
    lines = (out / "results.csv").read_text().splitlines()
    assert len(lines) == 1 + len(study.cases) and lines[0].startswith("case,")


def test_interrupted_case_stops_the_study_and_is_rerun(tmp_mpi_path):
    """A case whose run was stopped by a signal (status "interrupted") is not recorded as done: its
    group stops there, and the next run of the study does that case and the rest.  The run
    directory of a stopped case that left a rolling checkpoint is kept for its run to continue."""
    comm = MPI.COMM_WORLD
    study, out, log_dir = _grid_study(tmp_mpi_path, comm)
    stopped = study.cases[2].name
    base = counting_runner(log_dir)
    kept = []

    def interrupted_once(case, case_dir, sub):
        if case.name == stopped:
            if sub.rank == 0:
                (case_dir / "run" / "checkpoint").mkdir(parents=True)
            return {"status": "interrupted", "reason": "interrupted by SIGINT"}
        return base(case, case_dir, sub)

    def continued(case, case_dir, sub):
        if case.name == stopped:
            kept.append((case_dir / "run" / "checkpoint").is_dir())
        return base(case, case_dir, sub)

    rows = st.run_study(study, out, comm, interrupted_once, quiet=True)
    assert next(r for r in rows if r["case"] == stopped)["status"] == "not run"
    assert not (out / "cases" / stopped / "summary.json").exists()
    assert runs(log_dir, study.cases[-1].name) == 0 or comm.size > 1   # one group: nothing after it ran
    rows = st.run_study(study, out, comm, continued, quiet=True)
    assert all(r["status"] == "ok" for r in rows)
    assert all(runs(log_dir, c.name) == 1 for c in study.cases)
    everywhere = comm.allreduce(kept, op=MPI.SUM)          # the ranks of the group that ran it
    assert everywhere and all(everywhere)


def test_atomic_write_keeps_old_file_on_crash(tmp_path, monkeypatch):
    path = tmp_path / "results.csv"
    st.atomic_write_text(path, "old\n")

    def crash(*_):
        raise KeyboardInterrupt

    monkeypatch.setattr(os, "replace", crash)
    with pytest.raises(KeyboardInterrupt):
        st.atomic_write_text(path, "new\n")
    assert path.read_text() == "old\n"


@pytest.mark.serial
def test_replaced_directory_survives_a_kill_between_its_renames(tmp_path, monkeypatch):
    """A checkpoint directory replaced by a new version: killed before or between its two renames,
    the last complete version is the old one, never a mix or none; the next replacement after
    such a kill ends with the new version."""
    from rollsim import files
    path = tmp_path / "checkpoint"

    def write(version: str) -> None:
        stage = files.staging_directory(path)
        stage.mkdir()
        for name in ("state", "meta"):
            (stage / name).write_text(version)

    def read() -> set:
        found = files.complete_directory(path)
        return {p.read_text() for p in found.iterdir()} if found else set()

    assert files.complete_directory(path) is None
    write("1")
    files.replace_directory(path)
    replace = os.replace
    for kill_after in range(2):
        calls = []

        def counted(src, dst):
            if len(calls) == kill_after:
                raise KeyboardInterrupt
            calls.append(dst)
            replace(src, dst)

        shutil.rmtree(files.staging_directory(path), ignore_errors=True)
        write("2")
        monkeypatch.setattr(os, "replace", counted)
        with pytest.raises(KeyboardInterrupt):
            files.replace_directory(path)
        monkeypatch.setattr(os, "replace", replace)
        assert read() == {"1"}
        shutil.rmtree(files.staging_directory(path), ignore_errors=True)
        write("2")
        files.replace_directory(path)
        assert read() == {"2"}
        shutil.rmtree(files.staging_directory(path), ignore_errors=True)
        write("1")
        files.replace_directory(path)
    files.remove_directory(path)
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("ranks_per_case", [1, 2])
def test_cases_spread_over_ranks(tmp_mpi_path, ranks_per_case):
    comm = MPI.COMM_WORLD
    study = st.load_study(write_study(tmp_mpi_path, GRID + f"\n", name="s.toml"))
    study = st.Study(study.path, study.runner, study.reference_loads, ranks_per_case, study.cases)
    out, log_dir = tmp_mpi_path / f"out{ranks_per_case}", tmp_mpi_path / f"log{ranks_per_case}"
    if comm.rank == 0:
        log_dir.mkdir()
    comm.barrier()
    st.run_study(study, out, comm, counting_runner(log_dir), quiet=True)
    assert all(runs(log_dir, c.name) == 1 for c in study.cases)  # every case exactly once
    summaries = [json.loads((out / "cases" / c.name / "summary.json").read_text()) for c in study.cases]
    group_size = min(ranks_per_case, comm.size)
    assert {s["ranks"] for s in summaries} == {group_size}
    assert {s["world_rank"] for s in summaries} == set(range(0, comm.size, group_size))


def test_report_from_small_study(tmp_mpi_path):
    study = write_study(tmp_mpi_path, GRID)
    out = tmp_mpi_path / "rep"
    assert main(["study", str(study), "--out", str(out), "--quiet"]) == 0
    if MPI.COMM_WORLD.rank == 0:
        report = (out / "report.md").read_text()
        assert "![force-sinkage](force_sinkage.png)" in report and "| case |" in report
        for name in ("force_sinkage.png", "effect_soil_layers_0_E_Pa.png", "pair_wheel_friction.png"):
            assert (out / name).stat().st_size > 0
        # the analytic runner against the model itself: its sinkage is the model's own root
        rows = (out / "results.csv").read_text().splitlines()
        header = rows[0].split(",")
        ratio = [float(r.split(",")[header.index("ratio_100kN")]) for r in rows[1:]]
        assert all(abs(x - 1) < 1e-12 for x in ratio), ratio
        # E and the friction do not enter the model: flagged in the report
        assert "`soil.layers[0].E` is swept, but the analytic runner does not use it" in report
        assert "`wheel.friction` is swept" in report and "`wheel.diameter` is swept" not in report


@pytest.mark.serial
def test_bad_case_exit_2_nothing_written(tmp_path, capsys):
    study = tmp_path / "study.toml"
    study.write_text(f'base = "{BASE}"\n[[sweep]]\n"soil.layers[0].nu" = [0.3, 0.7]\n')
    code = main(["study", str(study), "--out", str(tmp_path / "out")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "case nu=0.7: soil.layers[0].nu" in err[0]
    assert not (tmp_path / "out").exists()


@pytest.mark.serial
def test_dry_run_lists_cases(tmp_path, capsys):
    assert main(["study", str(ROOT / "studies/examples/analytic_indentation_cases.toml"), "--out",
                 str(tmp_path / "o"), "--dry-run"]) == 0
    out = capsys.readouterr().out
    assert "12 cases" in out and "case-12:" in out and not (tmp_path / "o").exists()


def test_set_applies_to_every_case_without_naming_it(tmp_mpi_path):
    study = st.load_study(write_study(tmp_mpi_path, '[set]\n"model.accuracy" = "fast"\n"wheel.friction" = 0.4\n'
                                      + GRID.split("\n", 2)[2]))
    assert all(c.scene.model.accuracy == "fast" and c.name.startswith("E=") for c in study.cases)
    assert {c.scene.wheel.friction for c in study.cases} == {0.4, 0.8}  # the sweep wins over [set]
    finer = st.load_study(write_study(tmp_mpi_path, 'runner = "fe"\n[set]\n"model.refinement" = 12\n' + GRID.split("\n", 2)[2],
                                      name="finer.toml"))
    assert all(c.scene.model.elements_per_d == 12 for c in finer.cases)
    assert "at 12 elements per d: about 5.1x the fast preset's" in st.dry_run_lines(finer)[-1]


@pytest.mark.parametrize("name", sorted(p.name for p in (ROOT / "studies" / "examples").glob("*.toml")))
def test_shipped_studies_validate(name):
    study = st.load_study(ROOT / "studies" / "examples" / name)
    assert study.cases and all(c.scene.model.accuracy == "fast" for c in study.cases if study.runner == "fe")
    assert "estimated cost" in st.dry_run_lines(study)[-1]


@pytest.mark.parametrize("layer", [
    {"model": "von-mises", "E": "40 MPa", "nu": 0.35, "c_dp": "200 kPa"},
    {"model": "von-mises", "E": "40 MPa", "nu": 0.35, "c": "100 kPa"},
    {"model": "drucker-prager", "E": "40 MPa", "nu": 0.35, "phi_dp": "27.5 deg", "c_dp": "194.6 kPa"},
    {"model": "mohr-coulomb", "E": "40 MPa", "nu": 0.35, "c": "10 kPa", "phi": "30 deg"},
])
def test_summary_scene_echo_round_trips(layer):
    """rollsim report rebuilds the scene from summary.json's echo: every layer kind parses back to
    the same scene (a von Mises echo carries phi_dp = 0, which is not a von Mises key)."""
    from rollsim.scene import parse_scene
    from rollsim.studies.report import _scene_input
    scene = parse_scene({"wheel": {"diameter": "1.524 m", "width": "0.4572 m"},
                         "soil": {"gamma": "20 kN/m^3", "layers": [layer]},
                         "loading": {"protocol": "rolling-constant-load", "load": "100 kN", "travel": "1 m"}})
    assert parse_scene(_scene_input(scene.to_dict())) == scene
