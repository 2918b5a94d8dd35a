"""run_scene (solver/run.py): the run directory (docs/cli.md), failures, protocols."""
from __future__ import annotations

import csv
import dataclasses
import json
import math

import pytest

from rollsim.scene import load_scene, parse_scene
from rollsim.solver.run import run_scene
from rollsim.solver.rundir import HISTORY_COLUMNS
from rollsim.solver.scene_model import layer_material, layer_materials


def _scene(max_sinkage="0.03 m", **layer):
    lay = {"model": "von-mises", "E": "40 MPa", "nu": 0.35, "c_dp": "200 kPa"}
    lay.update(layer)
    lay = {k: v for k, v in lay.items() if v is not None}
    return parse_scene({"wheel": {"diameter": "1.524 m", "width": "0.4572 m", "friction": 0.8},
                        "soil": {"gamma": "20 kN/m^3", "layers": [lay]},
                        "loading": {"protocol": "indentation", "max_sinkage": max_sinkage},
                        "model": {"accuracy": "fast"}})


@pytest.mark.end_to_end
def test_run_scene_writes_the_run_directory(comm, tmp_mpi_path):
    scene = _scene()
    summary = run_scene(scene, tmp_mpi_path, comm, progress=False)
    assert summary["status"] == "ok", summary.get("reason")
    assert summary["ranks"] == comm.size and summary["dofs"] > 0 and summary["steps"] >= 2
    assert summary["model"]["symmetry"] == "quarter" and summary["model"]["symmetry_factor"] == 4
    assert summary["model"]["volumetric_strain"] == "cell-average"     # the indentation scene default
    assert summary["model"]["elements_per_d"] == 8                      # the fast preset
    if comm.rank == 0:
        s = json.loads((tmp_mpi_path / "summary.json").read_text())
        assert s["status"] == "ok" and s["scene"] == scene.to_dict()
        for key in ("wall_time_s", "ranks", "dofs", "steps", "newton_iterations"):
            assert key in s
        rows = list(csv.DictReader((tmp_mpi_path / "history.csv").open()))
        assert list(rows[0]) == HISTORY_COLUMNS
        assert len(rows) == s["steps"]
        assert float(rows[-1]["sinkage_m"]) == pytest.approx(0.03)
        assert float(rows[-1]["QV_N"]) == pytest.approx(s["QV_N"])
        assert s["QV_at_s_over_d"]["0.01"] > 0                 # report stops are step boundaries
        assert (tmp_mpi_path / "force_sinkage.png").stat().st_size > 1000
        for name in ("fields.xdmf", "fields.h5", "deformed.xdmf", "deformed.h5"):
            assert (tmp_mpi_path / "fields" / name).exists(), name
        # the plastic-zone picture, gathered from every rank and drawn off-screen
        assert (tmp_mpi_path / "plastic_zone.png").stat().st_size > 10_000
        assert not list(tmp_mpi_path.glob("*.npz"))
        assert not list(tmp_mpi_path.glob(".*.tmp"))
    comm.barrier()


def test_refinement_replaces_the_preset_element_size(comm):
    """[model] refinement sets the elements per d of the block under the wheel: 12 instead of the
    fast preset's 8 (measured: 1.8x the cells of the quarter block)."""
    from rollsim.solver.scene_model import indentation_mesh
    fast = _scene()
    finer = dataclasses.replace(fast, model=dataclasses.replace(fast.model, refinement=12.0))
    cells = [indentation_mesh(scene, comm).stats.cells for scene in (fast, finer)]
    assert 1.5 < cells[1] / cells[0] < 3.4, cells


@pytest.mark.end_to_end
def test_cell_average_volumetric_strain_reaches_the_solver(comm, tmp_mpi_path):
    """[model] volumetric_strain = "cell-average" runs B-bar: recorded in the summary, and it lowers
    the force of the (mildly locking) pointwise P2 tetrahedra at the same sinkage."""
    forces = {}
    for vs in ("pointwise", "cell-average"):
        scene = dataclasses.replace(_scene("0.0076 m"), model=dataclasses.replace(_scene().model, volumetric_strain=vs))
        summary = run_scene(scene, tmp_mpi_path / vs, comm, progress=False, write_fields=False)
        assert summary["status"] == "ok" and summary["model"]["volumetric_strain"] == vs
        forces[vs] = summary["QV_N"]
    assert forces["cell-average"] < 0.97 * forces["pointwise"], forces


@pytest.mark.verification
def test_c0_indentation_scene_without_regularising_cohesion(comm, tmp_mpi_path):
    """A c = 0 drucker-prager layer with [model] regularising_cohesion = 0 runs with c = 0 exactly,
    rate-independent and then with a Duvaut-Lions relaxation length (which ends with the run; its
    convergence in the length: tests/test_indentation.py); the summary records both settings."""
    scene = _scene("0.0076 m", model="drucker-prager", c=0, phi=40, match="plane-strain", c_dp=None)
    q = {}
    for length in (0.0, 3e-5):
        sc = dataclasses.replace(scene, model=dataclasses.replace(scene.model, regularising_cohesion=0.0,
                                                                  relaxation_length=length))
        summary = run_scene(sc, tmp_mpi_path / f"L{length:g}", comm, progress=False, write_fields=False)
        assert summary["status"] == "ok", summary.get("reason")
        model = summary["model"]
        assert model["relaxation_length_m"] == length and "regularising_cohesion_Pa" not in model
        assert model["contact"]["alpha"] == 1.0
        kinds = {e["kind"]: e for e in model["regularisation"]}
        assert "regularising_cohesion" not in kinds and ("duvaut_lions" in kinds) == (length > 0), kinds
        assert model["relaxation_fallback_m"] == 1e-5           # the default; a relaxed stretch is listed
        assert ("duvaut_lions_fallback" in kinds) == bool(model["relaxed_spans_m"]), kinds
        if length:
            assert kinds["duvaut_lions"]["value"] == length and kinds["duvaut_lions"]["effect"]["percent"][1] > 0
        q[length] = summary["QV_N"]
    assert q[3e-5] > q[0.0] > 0, q          # the regularisation's overstress is positive


@pytest.mark.serial
def test_fields_readable_by_pyvista(tmp_path, comm):
    pv = pytest.importorskip("pyvista")
    run_scene(_scene("0.01 m"), tmp_path, comm, progress=False)
    reader = pv.get_reader(str(tmp_path / "fields" / "fields.xdmf"))
    reader.set_active_time_point(len(reader.time_values) - 1)
    blocks = reader.read()             # DOLFINx 0.5 XDMF: one grid per function
    names = {n for i in range(blocks.n_blocks) if blocks[i] is not None for n in blocks[i].array_names}
    assert {"displacement", "equivalent_plastic_strain", "q"} <= names
    assert blocks["mesh"].n_cells > 0
    deformed = pv.get_reader(str(tmp_path / "fields" / "deformed.xdmf")).read()
    assert deformed.bounds[5] > 0            # the surface beside the wheel heaves: moved vertices
    assert deformed.bounds[4] == pytest.approx(-1.5 * 1.524)


def test_unknown_protocol_is_refused_with_the_key(comm, tmp_mpi_path):
    scene = _scene()
    other = dataclasses.replace(scene, loading=dataclasses.replace(scene.loading, protocol="pneumatic-inflation"))
    with pytest.raises(ValueError, match="loading.protocol"):
        run_scene(other, tmp_mpi_path, comm, progress=False)


@pytest.mark.end_to_end
def test_divergence_is_reported_not_raised(comm, tmp_mpi_path, monkeypatch):
    """A solver failure after cutting ends with status failed + reason and the last converged state."""
    import rollsim.solver.indentation as ind
    from rollsim.solver import StepControl
    monkeypatch.setattr(ind, "DEFAULT_STEP_CONTROL", StepControl(dt=0.1, dt_min=1e-4, max_cuts=0,
                                                                 max_iterations=8))
    summary = run_scene(_scene(), tmp_mpi_path, comm, progress=False, write_fields=False)
    assert summary["status"] == "failed" and summary["reason"]
    if comm.rank == 0:
        s = json.loads((tmp_mpi_path / "summary.json").read_text())
        assert s["status"] == "failed" and "diagnostics" in s


@pytest.mark.end_to_end
def test_failed_c0_run_names_both_remedies(comm, tmp_mpi_path, monkeypatch):
    """A failed run on a non-associated c = 0 layer kept exactly suggests the relaxation length
    (indentation: 0.01 mm) and the regularising cohesion; a von Mises soil gets neither."""
    import rollsim.solver.indentation as ind
    from rollsim.solver import StepControl
    monkeypatch.setattr(ind, "DEFAULT_STEP_CONTROL", StepControl(dt=0.1, dt_min=1e-4, max_cuts=0, max_iterations=2))
    scene = _scene("0.0076 m", model="drucker-prager", c=0, phi=40, match="plane-strain", c_dp=None)
    scene = dataclasses.replace(scene, model=dataclasses.replace(scene.model, regularising_cohesion=0.0))
    summary = run_scene(scene, tmp_mpi_path / "c0", comm, progress=False, write_fields=False)
    assert summary["status"] == "failed"
    assert 'relaxation_length = "0.01 mm"' in summary["reason"] and "regularising_cohesion" in summary["reason"]
    summary = run_scene(_scene(), tmp_mpi_path / "vm", comm, progress=False, write_fields=False)
    assert summary["status"] == "failed" and "relaxation_length" not in summary["reason"]


def test_layer_materials_from_scene():
    sc = parse_scene({"wheel": {"diameter": 1.0, "width": 0.3},
                      "soil": {"gamma": 20e3, "layers": [
                          {"model": "von-mises", "E": 1e7, "nu": 0.3, "c": 50e3, "match": "plane-strain",
                           "thickness": 0.4},
                          {"model": "drucker-prager", "E": 1e7, "nu": 0.3, "c": 10e3, "phi": 30},
                          ]},
                      "loading": {"protocol": "indentation", "max_sinkage": 0.1}})
    vm = layer_material(sc.soil.layers[0], 0)
    assert vm.yield_stress == pytest.approx(math.sqrt(3) * 50e3)
    dp = layer_material(sc.soil.layers[1], 1)
    s = math.sin(math.radians(30))
    assert math.tan(dp.phi_dp) == pytest.approx(6 * s / (3 - s))
    assert dp.c_dp == pytest.approx(6 * 10e3 * math.cos(math.radians(30)) / (3 - s))


def test_soil_materials_say_whether_c_0_is_solved_exactly():
    """A c = 0 layer is regularised by default (its cohesion listed); with regularising_cohesion = 0
    the soil is cohesionless, which the rolling relaxation estimates depend on."""
    def soil(c, c_reg=None):
        model = {} if c_reg is None else {"regularising_cohesion": c_reg}
        return layer_materials(parse_scene({
            "wheel": {"diameter": 1.0, "width": 0.3}, "model": model,
            "soil": {"gamma": 20e3, "layers": [{"model": "drucker-prager", "E": 1e7, "nu": 0.3, "c": c, "phi": 35,
                                                "match": "plane-strain"}]},
            "loading": {"protocol": "rolling-constant-load", "load": 1e4, "travel": 0.5}}))
    assert soil(0.0).regularised == {"soil.layers[0]": 1e3} and not soil(0.0).cohesionless
    assert soil(0.0, 0.0).regularised == {} and soil(0.0, 0.0).cohesionless
    assert not soil(5e3, 0.0).cohesionless


def test_example_scene_loads(comm):
    import pathlib
    scene = load_scene(pathlib.Path(__file__).parents[1] / "examples" / "indentation_mndot.toml")
    assert layer_material(scene.soil.layers[0]).c_dp == pytest.approx(194.6e3)


@pytest.mark.parametrize("example, options, field", [
    ("indentation_mndot.toml", ["--restart"], "--restart"),
    ("indentation_mndot.toml", ["--checkpoint-every", "5"], "--checkpoint-every"),
    ("rolling_continuous.toml", ["--checkpoint-every", "-1"], "--checkpoint-every"),
])
def test_checkpoint_options_are_refused_where_they_do_not_apply(comm, tmp_mpi_path, capsys, example, options,
                                                                field):
    """Checkpoints are a rigid wheel's rolling: elsewhere, or a negative interval, exit 2 naming
    the option, nothing written."""
    import pathlib

    from rollsim.cli import main
    scene = pathlib.Path(__file__).parent.parent / "examples" / example
    assert main(["run", str(scene), "--out", str(tmp_mpi_path / "run"), *options]) == 2
    assert comm.rank != 0 or field in capsys.readouterr().err
    assert not (tmp_mpi_path / "run").exists()


def test_steady_roll_refuses_checkpoint_options(comm, tmp_mpi_path, capsys):
    """A steady roll is one solve per state: --restart and --checkpoint-every are refused (exit 2,
    naming the option, nothing written)."""
    import pathlib

    from rollsim.cli import main
    example = (pathlib.Path(__file__).parent.parent / "examples" / "rolling_constant_load_mndot.toml").read_text()
    scene = tmp_mpi_path / "steady.toml"
    if comm.rank == 0:
        scene.write_text(example.replace('accuracy = "fast"', 'accuracy = "fast"\nrolling = "steady"'))
    comm.barrier()
    for option in (["--restart"], ["--checkpoint-every", "5"]):
        assert main(["run", str(scene), "--out", str(tmp_mpi_path / "run"), *option]) == 2
        assert comm.rank != 0 or option[0] in capsys.readouterr().err
        assert not (tmp_mpi_path / "run").exists()


def test_time_left_follows_the_recent_pace(monkeypatch):
    """The progress line's time left: the pace of the last ten steps (a roll that slows down as it
    plastifies is not promised the pace of its elastic start), from the travel a continued run
    starts at; none before the wheel has moved."""
    from rollsim.solver import rundir
    now = [100.0]
    monkeypatch.setattr(rundir.time, "perf_counter", lambda: now[0])
    bar = rundir.TravelProgress(travel=5.0, d=1.0, start=1.0)
    assert bar.time_left() is None
    bar.passed(1.0)
    assert bar.time_left() is None
    x = 1.0
    for pace in [1.0] * 10 + [10.0] * 10:         # s per 0.1 m
        now[0] += pace
        x += 0.1
        bar.passed(x)
        left = bar.time_left()
    assert left == pytest.approx(10.0 * (5.0 - x) / 0.1)
    fresh = rundir.TravelProgress(travel=5.0, d=1.0, start=4.0)
    now[0] += 30.0
    fresh.passed(4.5)
    assert fresh.time_left() == pytest.approx(30.0)
