"""The command-line contract (docs/cli.md): outputs, exit codes, one-line errors."""
import json
import math

import pytest

from rollsim.cli import main
from rollsim.studies import bearing_capacity as bc


def run(capsys, *argv):
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def last_json(out):
    return json.loads(out.strip().splitlines()[-1])


def test_predict_json_keys_and_value(capsys):
    code, out, _ = run(capsys, "predict", "--d", "60 in", "--b", "18 in", "--c", "100 kPa", "--phi", "0",
                       "--gamma", "127 pcf", "--load", "15 ton", "--json")
    assert code == 0
    data = last_json(out)
    for key in ("mode", "method", "depth", "sinkage_m", "QV_N", "QH_N", "Q_N", "s_over_d", "in_validity_range"):
        assert key in data
    assert data["mode"] == "rolling" and data["method"] == "footing" and data["depth"] == "modified"
    wheel, soil = bc.Wheel(1.524, 0.4572), bc.Soil(100e3, 0.0, 127 * 4.4482216152605 / 0.3048**3)
    expected = float(bc.sinkage(15 * 2000 * 0.45359237 * 9.80665, wheel, soil).sinkage)
    assert data["sinkage_m"] == pytest.approx(expected, rel=1e-10)
    assert data["QV_N"] == pytest.approx(133446.65, rel=1e-6)


def test_predict_from_sinkage(capsys):
    code, out, _ = run(capsys, "predict", "--mode", "indentation", "--shape", "torus", "--c", "50kPa",
                       "--sinkage", "0.05", "--json")
    data = last_json(out)
    expected = bc.wheel_forces(0.05, bc.Wheel(1.524, 0.4572, "torus"), bc.Soil(50e3, 0, 20e3),
                               bc.Options(mode="indentation"))
    assert code == 0 and data["QV_N"] == pytest.approx(float(expected.QV), rel=1e-12) and data["QH_N"] == 0


def test_exceeds_capacity_exit_3(capsys):
    code, out, err = run(capsys, "predict", "--phi", "35", "--load", "400 kN", "--json")
    assert code == 3
    data = last_json(out)
    assert data["error"] == "exceeds_capacity" and data["max_QV_N"] < 400e3 and data["sinkage_at_max_m"] > 0
    assert "exceeds" in err


@pytest.mark.parametrize("argv, field", [
    (["predict", "--d", "3 kg", "--c", "1", "--load", "1"], "--d"),
    (["predict", "--c", "-5 kPa", "--load", "10 kN"], "--c"),
    (["predict", "--c", "5 kPa", "--load", "ten kN"], "--load"),
    (["predict", "--c", "5 kPa", "--sinkage", "2 m"], "--sinkage"),
    (["predict", "--load", "10 kN"], "--c"),
    (["invert", "--load", "10 kN", "--sinkage", "0.05"], "--c"),
    (["influence", "--c", "100 kPa", "--c2", "-1", "--load", "50 kN"], "--c2"),
])
def test_bad_input_one_line_exit_2(capsys, argv, field):
    code, out, err = run(capsys, *argv)
    assert code == 2
    assert out == ""
    lines = err.strip().splitlines()
    assert len(lines) == 1 and field in lines[0]


def test_bad_input_json_error(capsys):
    code, out, _ = run(capsys, "predict", "--gamma", "abc", "--c", "1", "--load", "1", "--json")
    assert code == 2 and last_json(out) == {"error": "invalid_input", "field": "--gamma",
                                            "message": "cannot read 'abc' as a unit weight"}


def test_help_documents_units(capsys):
    assert main(["predict", "--help"]) == 0     # main returns the exit code, also for --help
    out = capsys.readouterr().out
    for text in ("m/N", "kPa", "'15 ton'", "Pa", "deg"):
        assert text in out


def test_invert_round_trips(capsys):
    soil = bc.Soil(0.0, math.radians(38.0), 18e3)
    load = float(bc.wheel_forces(0.05, bc.Wheel(1.524, 0.4572), soil).QV)
    code, out, _ = run(capsys, "invert", "--load", str(load), "--sinkage", "0.05", "--c", "0",
                       "--gamma", "18 kN/m^3", "--json")
    assert code == 0 and last_json(out)["phi_deg"] == pytest.approx(38.0, rel=1e-8)


def test_invert_two_measurements(capsys):
    soil = bc.Soil(10e3, math.radians(40), 18e3)
    q1 = float(bc.wheel_forces(0.05, bc.Wheel(1.524, 0.4572), soil).QV)
    q2 = float(bc.wheel_forces(0.04, bc.Wheel(0.5, 0.15), soil).QV)
    code, out, _ = run(capsys, "invert", "--load", str(q1), "--sinkage", "0.05", "--d2", "0.5", "--b2", "0.15",
                       "--load2", str(q2), "--sinkage2", "0.04", "--gamma", "18 kN/m^3", "--json")
    data = last_json(out)
    assert code == 0 and data["c_Pa"] == pytest.approx(10e3, rel=1e-7)
    assert data["phi_deg"] == pytest.approx(40.0, rel=1e-7) and data["ill_conditioned"] is False


def test_invert_record(capsys, tmp_path):
    wheel = bc.Wheel(1.524, 0.4572)
    rows = [(x, float(bc.sinkage(133.5e3, wheel, bc.Soil(c, 0, 20e3)).sinkage))
            for x, c in ((0.0, 220e3), (5.0, 150e3), (10.0, 190e3))]
    record = tmp_path / "record.csv"
    record.write_text("position_m,sinkage_m\n" + "".join(f"{x},{s!r}\n" for x, s in rows))
    out_csv = tmp_path / "profile.csv"
    code, out, _ = run(capsys, "invert", "--record", str(record), "--load", "133.5 kN", "--phi", "0",
                       "--min-strength", "170 kPa", "--out", str(out_csv), "--json")
    data = last_json(out)
    assert code == 0 and data["verdict"] == "fail" and data["failing_positions_m"] == [5.0]
    assert data["min_c_Pa"] == pytest.approx(150e3, rel=1e-8)
    assert out_csv.read_text().splitlines()[2].endswith(",no")


def test_influence_json(capsys):
    code, out, _ = run(capsys, "influence", "--c", "0", "--phi", "45", "--c2", "10 kPa", "--load", "133.5 kN",
                       "--json")
    data = last_json(out)
    assert code == 0 and data["case"] == "sand-over-weak-clay" and data["H_m"] > 0
