"""Study outputs a user can trust: SI numbers in results.csv, effect lines that join only cases
differing in the plotted parameter, resume that reruns changed and corrupt cases."""
from __future__ import annotations

import csv
import json
import pathlib

import pytest
from mpi4py import MPI

from rollsim.cli import main
from rollsim.studies import study as st
from rollsim.studies.report import effect_series

ROOT = pathlib.Path(__file__).resolve().parents[1]
BASE = (ROOT / "examples" / "indentation_mndot.toml").as_posix()
STUDY = """
reference_loads = ["100 kN"]
[set]
"model.accuracy" = "fast"
[[sweep]]
"soil.layers[0].c_dp" = ["150 kPa", "250 kPa"]
"soil.layers[0].phi_dp" = ["0 deg", "10 deg"]
"""


def _write(directory: pathlib.Path, body: str, name: str = "study.toml") -> pathlib.Path:
    path = directory / name
    if MPI.COMM_WORLD.rank == 0:
        path.write_text(f'base = "{BASE}"\n' + body)
    MPI.COMM_WORLD.barrier()
    return path


def _results(out: pathlib.Path) -> list[dict]:
    with (out / "results.csv").open(newline="") as f:
        return list(csv.DictReader(f))


def test_results_csv_holds_si_numbers_with_units_in_the_header(tmp_mpi_path):
    out = tmp_mpi_path / "out"
    assert main(["study", str(_write(tmp_mpi_path, STUDY)), "--out", str(out), "--quiet", "--no-report"]) == 0
    if MPI.COMM_WORLD.rank == 0:
        rows = _results(out)
        assert {"soil.layers[0].c_dp_Pa", "soil.layers[0].phi_dp_deg"} <= set(rows[0])
        assert sorted(float(r["soil.layers[0].c_dp_Pa"]) for r in rows) == [150e3, 150e3, 250e3, 250e3]
        assert sorted(float(r["soil.layers[0].phi_dp_deg"]) for r in rows) == pytest.approx([0, 0, 10, 10])


def test_effect_lines_join_only_cases_that_differ_in_the_plotted_parameter():
    params = {"a": {"E_Pa": 2e7, "mu": 0.4}, "b": {"E_Pa": 4e7, "mu": 0.4},
              "c": {"E_Pa": 2e7, "mu": 0.8}, "d": {"E_Pa": 4e7, "mu": 0.8}, "e": {"E_Pa": 3e7, "mu": 0.6}}
    series = effect_series(params, list(params), "E_Pa")
    assert sorted(series) == [["a", "b"], ["c", "d"]]       # "e" shares mu with no other case


def _analytic(tmp_path, body):
    return st.load_study(_write(tmp_path, body))


def test_parameters_without_effect_on_the_runner_are_flagged(tmp_mpi_path):
    body = STUDY + '[[sweep]]\n"wheel.friction" = [0.4, 0.8]\n"soil.layers[0].nu" = [0.3, 0.3]\nmode = "zip"\n'
    assert st.ineffective_keys(_analytic(tmp_mpi_path, body)) == ["wheel.friction"]
    assert st.ineffective_keys(_analytic(tmp_mpi_path, STUDY)) == []


def test_resume_reruns_changed_and_corrupt_cases(tmp_mpi_path, caplog):
    comm = MPI.COMM_WORLD
    out = tmp_mpi_path / "out"
    path = _write(tmp_mpi_path, STUDY)
    runner = st.analytic_runner((100e3,))
    first = st.run_study(st.load_study(path), out, comm, runner, quiet=True)
    before = {r["case"]: r["sinkage_100kN_m"] for r in first}
    # the same study again: nothing to run
    study = st.load_study(path)
    states = st._plan(study, out, comm)
    assert set(states.values()) == {"done"}
    # an edited [set] (weaker soil for every case): every case is stale and rerun
    edited = _write(tmp_mpi_path, STUDY.replace('"model.accuracy" = "fast"',
                                                '"model.accuracy" = "fast"\n"soil.gamma" = "18 kN/m^3"'))
    study = st.load_study(edited)
    assert set(st._plan(study, out, comm).values()) == {"changed"}
    rows = st.run_study(study, out, comm, runner, quiet=True)
    assert all(r["sinkage_100kN_m"] != before[r["case"]] for r in rows)
    # a corrupt summary is rerun, not trusted
    victim = study.cases[0].name
    if comm.rank == 0:
        (out / "cases" / victim / "summary.json").write_text('{"status": "ok", "compar')
    comm.barrier()
    states = st._plan(study, out, comm)
    assert states[victim] == "corrupt" and sum(v == "done" for v in states.values()) == len(states) - 1
    rows = st.run_study(study, out, comm, runner, quiet=True)
    assert all(r["status"] == "ok" for r in rows)
    if comm.rank == 0:
        assert json.loads((out / "study.json").read_text())["rerun"] == {"changed": [], "corrupt": [victim]}


def test_edited_csv_row_is_rerun(tmp_mpi_path):
    """Case names come from the CSV's case column, so an edited value keeps the name: the
    fingerprint sees the change and reruns that case only."""
    comm = MPI.COMM_WORLD
    out, table = tmp_mpi_path / "out", tmp_mpi_path / "cases.csv"
    body = '[[sweep]]\ncsv = "cases.csv"\n"soil.layers[0].c_dp" = "{c_dp_kPa} kPa"\n'
    path = _write(tmp_mpi_path, 'reference_loads = ["100 kN"]\n' + body)
    if comm.rank == 0:
        table.write_text("case,c_dp_kPa\n1,150\n2,250\n")
    comm.barrier()
    runner = st.analytic_runner((100e3,))
    st.run_study(st.load_study(path), out, comm, runner, quiet=True)
    if comm.rank == 0:
        table.write_text("case,c_dp_kPa\n1,150\n2,90\n")
    comm.barrier()
    study = st.load_study(path)
    states = st._plan(study, out, comm)
    assert sorted(states.values()) == ["changed", "done"], states
    rows = {r["case"]: r for r in st.run_study(study, out, comm, runner, quiet=True)}
    changed = next(n for n, v in states.items() if v == "changed")
    assert float(rows[changed]["soil.layers[0].c_dp_Pa"]) == 90e3


@pytest.mark.timeout(120)
def test_fe_history_read_failing_on_rank0_fails_every_rank(tmp_mpi_path, monkeypatch):
    """The FE runner reads a case's history on rank 0 and broadcasts it: a failed read there
    fails the case on every rank with the same message (no rank waits in the broadcast)."""
    comm = MPI.COMM_WORLD
    import rollsim.solver.run as run

    def fake_run_scene(scene, out_dir, comm, **kw):
        return {"status": "ok", "steps": 1, "dofs": 1, "newton_iterations": 1}

    def broken_read(path):
        raise ValueError("planted read failure")

    monkeypatch.setattr(run, "run_scene", fake_run_scene)
    monkeypatch.setattr(st, "_read_history", broken_read)
    case = st.load_study(_write(tmp_mpi_path, STUDY)).cases[0]
    with pytest.raises(ValueError, match="planted read failure"):
        st.fe_runner((100e3,))(case, tmp_mpi_path, comm)


def test_tire_comparison_uses_the_computed_flexibility_in_the_model():
    """A pneumatic case's row: the model's flexible-wheel sinkage is that of a rigid wheel of the
    loaded diameter d + lambda Q (the model's definition), below the rigid wheel's."""
    from rollsim.studies import bearing_capacity as bc
    study = st.load_study(ROOT / "studies" / "examples" / "tire_flexibility.toml")
    scene = study.cases[0].scene
    d, load, lam = scene.wheel.diameter, 20e3, 1.4e-5
    tire = {"wheel_load_N": load, "sinkage_m": 0.015, "deflection_m": 0.04, "contact_length_m": 0.4,
            "equivalent_diameter_m": d + lam * load, "flexibility_m_per_N": lam, "carcass_load_share": 0.3}
    row = st.compare_tire_with_model(scene, tire)
    wheel, soil, opts = st.model_inputs(scene)
    loaded = bc.Wheel(d + lam * load, wheel.width, wheel.shape)
    assert row["model_sinkage_flex_m"] == pytest.approx(float(bc.sinkage(load, loaded, soil, opts).sinkage), rel=1e-6)
    assert row["model_sinkage_flex_m"] < row["model_sinkage_rigid_m"]
    assert row["ratio_flex"] == pytest.approx(0.015 / row["model_sinkage_flex_m"])
    assert row["d_e_over_d"] == pytest.approx(1 + lam * load / d)


def test_tire_figures_plot_lambda_against_pressure_and_load(tmp_path):
    from rollsim.studies.report import tire_figures
    cases, rows = [], []
    for p in (250e3, 450e3):
        for q in (20e3, 40e3):
            name = f"p{p:g}_q{q:g}"
            cases.append({"name": name, "parameters": {"wheel.inflation_Pa": p, "loading.load_N": q}})
            rows.append({"case": name, "status": "ok", "flexibility_m_per_N": f"{1e-5 * 450e3 / p:g}",
                         "sinkage_m": "0.015", "model_sinkage_flex_m": "0.012", "model_sinkage_rigid_m": "0.02"})
    figures = tire_figures(tmp_path, {"cases": cases}, rows)
    names = sorted(name for name, _ in figures)
    assert names == ["flexibility_loading_load_N.png", "flexibility_wheel_inflation_Pa.png",
                     "tire_sinkage_vs_model.png"], names
    assert all((tmp_path / n).stat().st_size > 0 for n in names)
