"""Every command: bad input is one line naming the field (exit 2) with nothing written; an
unexpected error is one line (exit 1), its traceback only with --debug; --json prints one object."""
from __future__ import annotations

import json
import pathlib

import pytest
from mpi4py import MPI

from rollsim.cli import main

ROOT = pathlib.Path(__file__).resolve().parents[1]
SCENE = ROOT / "examples" / "indentation_mndot.toml"
pytestmark = pytest.mark.serial


def _run(capsys, argv):
    code = main(argv + ["--json"])
    out, err = capsys.readouterr()
    payload = json.loads(out.strip().splitlines()[-1])
    return code, payload, err.strip().splitlines()


@pytest.fixture
def files(tmp_path):
    (tmp_path / "binary.toml").write_bytes(b"\xff\xfe[wheel]\n")
    (tmp_path / "deep.toml").write_text("a = " + "[" * 5000 + "]" * 5000 + "\n")
    (tmp_path / "afile").write_text("x")
    (tmp_path / "c.csv").write_text("case,c_dp_kPa\n1,100\n")
    for name, template in (("brace", "{c_dp_kPa kPa"), ("attr", "{c_dp_kPa.__class__} kPa")):
        (tmp_path / f"{name}.toml").write_text(f'base = "{SCENE.as_posix()}"\n[[sweep]]\ncsv = "c.csv"\n'
                                              f'"soil.layers[0].c_dp" = "{template}"\n')
    (tmp_path / "empty.toml").write_text(f'base = "{SCENE.as_posix()}"\n[[sweep]]\ncsv = "c.csv"\nrows = []\n'
                                         '"soil.layers[0].c_dp" = "{c_dp_kPa} kPa"\n')
    return tmp_path


@pytest.mark.parametrize("argv, field", [
    (["check", "{d}/binary.toml"], "{d}/binary.toml"),
    (["check", "{d}/deep.toml"], "{d}/deep.toml"),
    (["check", "{d}"], "{d}"),
    (["design", "--out", "{d}/afile"], "--out"),
    (["design", "--out", ""], "--out"),
    (["study", "{d}/brace.toml", "--out", "{d}/o"], "sweep[0].soil.layers[0].c_dp"),
    (["study", "{d}/attr.toml", "--out", "{d}/o"], "sweep[0].soil.layers[0].c_dp"),
    (["study", "{d}/empty.toml", "--out", "{d}/o"], "sweep[0].rows"),
    (["invert", "--load", "60kN", "--sinkage", "0.05", "--d2", "0.5", "--c", "10kPa"], "--load2"),
    (["invert", "--load", "60kN", "--sinkage", "0.05", "--phi", "30", "--out", "{d}/x.csv"], "--out"),
    (["influence", "--c", "100kPa", "--load", "100kN"], "--c2"),
    (["predict", "--c", "10kPa", "--flex", "-1", "--load", "1kN"], "--flex"),
    (["predict", "--c", "1,5 kPa", "--load", "1kN"], "--c"),
    (["report", "{d}"], "{d}"),
    (["bogus"], "command"),
])
def test_bad_input_is_one_line_naming_the_field(files, capsys, argv, field):
    before = sorted(p.name for p in files.iterdir())
    argv = [a.replace("{d}", str(files)) for a in argv]
    code, payload, err = _run(capsys, argv)
    assert code == 2 and payload["error"] == "invalid_input", (payload, err)
    assert payload["field"] == field.replace("{d}", str(files))
    assert len(err) == 1 and err[0].startswith(f"rollsim: error: {payload['field']}: "), err
    assert sorted(p.name for p in files.iterdir()) == before     # nothing written


def test_unexpected_error_is_one_line_and_debug_shows_the_traceback(monkeypatch, capsys):
    import rollsim.cli as cli

    def broken(args):
        raise ZeroDivisionError("planted")

    monkeypatch.setitem(cli.COMMANDS, "predict", broken)
    code, payload, err = _run(capsys, ["predict", "--load", "1kN", "--c", "1kPa"])
    assert code == 1 and payload == {"error": "internal", "message": "ZeroDivisionError: planted"}
    assert len(err) == 1 and "--debug" in err[0]
    with pytest.raises(ZeroDivisionError):
        main(["predict", "--load", "1kN", "--c", "1kPa", "--debug"])


def test_corrupt_study_results_write_no_report(tmp_path, capsys):
    out = tmp_path / "study"
    study = tmp_path / "s.toml"
    study.write_text(f'base = "{SCENE.as_posix()}"\nreference_loads = ["100 kN"]\n[[sweep]]\n'
                     '"soil.layers[0].c_dp" = ["150 kPa", "250 kPa"]\n')
    assert main(["study", str(study), "--out", str(out), "--quiet", "--no-report"]) == 0
    results = out / "results.csv"
    results.write_text(results.read_text().replace(results.read_text().splitlines()[1].split(",")[-1], "x?"))
    before = sorted(p.name for p in out.iterdir())
    code, payload, err = _run(capsys, ["report", str(out)])
    assert code == 2 and "not a number" in payload["message"]
    assert sorted(p.name for p in out.iterdir()) == before
    assert MPI.COMM_WORLD.size == 1


def test_corrupt_study_json_is_one_line(tmp_path, capsys):
    out = tmp_path / "study"
    out.mkdir()
    (out / "study.json").write_text('{"study": "s.toml", "cases": [')
    (out / "results.csv").write_text("case,status\nbase,ok\n")
    code, payload, err = _run(capsys, ["report", str(out)])
    assert code == 2 and payload["field"] == str(out) and len(err) == 1
    assert sorted(p.name for p in out.iterdir()) == ["results.csv", "study.json"]


def test_record_output_into_a_directory_is_refused(tmp_path, capsys):
    record = tmp_path / "record.csv"
    record.write_text("position_m,sinkage_m\n0,0.02\n1,0.03\n")
    code, payload, err = _run(capsys, ["invert", "--record", str(record), "--load", "133.5kN", "--phi", "0",
                                       "--min-strength", "100 kPa", "--out", str(tmp_path)])
    assert code == 2 and payload["field"] == "--out" and "is a directory" in payload["message"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["record.csv"]

