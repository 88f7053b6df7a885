"""Study files: refusals naming the key and the fix, the expansion into cases with content hashes, the physics of
what a serial run records, and the faults a rerun survives (a corrupt part or field is recomputed, never read)."""

import numpy as np
import pytest

from tissuesim.cli import main
from tissuesim.study.cases import expand
from tissuesim.study.load import StudyError, parse_study
from tissuesim.study.runner import run_study
from tissuesim.study.store import Store

# a 60-vertex cube builds in a fraction of a second: the tests measure the machinery, not the physics' accuracy
SMALL = """
[[models]]
name = "cube"
resolution = 60
[[methods]]
name = "hybrid"
[[methods]]
name = "embedded"
[materials]
youngs_modulus = [5500.0, 11000.0]
[loads]
forces = [0.5, 1.0]
directions = ["tension"]
[record]
field = true
"""


def _cases(text, tmp_path):
    return expand(parse_study(text, tmp_path / "study.toml"))


def _refusal(text, tmp_path) -> str:
    with pytest.raises(StudyError) as caught:
        _cases(text, tmp_path)
    return str(caught.value)


def _rows(table):
    return {row["case_id"]: row for row in table.to_pylist()}


def test_the_study_expands_into_the_product_of_its_lists(tmp_path):
    cases = _cases(SMALL, tmp_path)
    assert len(cases) == 2 * 2 * 2
    assert len({case.case_id for case in cases}) == len(cases)
    assert [c.case_id for c in cases] == [c.case_id for c in _cases(SMALL, tmp_path)]   # deterministic
    changed = _cases(SMALL.replace("forces = [0.5, 1.0]", "forces = [0.5, 2.0]"), tmp_path)
    assert len({c.case_id for c in cases} & {c.case_id for c in changed}) == 4           # only the 1 N cases differ
    # the methods share the reference of a material and a load
    assert len({case.reference_key for case in cases}) == 2 * 2


def test_presets_ranges_and_random_loads_expand(tmp_path):
    text = ('[[models]]\nname = "cube"\n[[methods]]\nname = "hybrid"\n[materials]\npresets = ["liver"]\n'
            'poisson_ratio = { start = 0.2, stop = 0.4, count = 3 }\n'
            '[loads.random]\ncount = 5\nseed = 7\nforce = [0.5, 2.0]\n')
    cases = _cases(text, tmp_path)
    assert len(cases) == (1 + 3) * 5
    assert [c.material[2] for c in cases[5::5]] == pytest.approx([0.2, 0.3, 0.4], abs=1e-12)
    assert cases[0].material[0] == "liver" and cases[0].random == (7, 0, 0.5, 2.0)


@pytest.mark.parametrize("text, expected", [
    ('[[methods]]\nname = "hybrid"\n', "models: missing"),
    ('[[models]]\nname = "cube"\ncolour = 1\n[[methods]]\nname = "hybrid"\n', "models[0].colour: unknown key"),
    ('[[models]]\nname = "torus"\n[[methods]]\nname = "hybrid"\n', "models[0].name: unknown built-in model"),
    ('[[models]]\nname = "cube"\n[[methods]]\nname = "hybrid"\n[materials]\npresets = ["lung"]\n',
     "materials.presets[0]: unknown preset 'lung'"),
    ('[[models]]\nname = "cube"\n[[methods]]\nname = "magic"\n', "methods[0].name: unknown method 'magic'"),
    ('[[models]]\nname = "cube"\n[[methods]]\nname = "hybrid"\noptions = { youngs_modulus = 1.0 }\n',
     "methods[0].options.youngs_modulus: a study sets the material in [materials]"),
    ('[[models]]\nname = "cube"\n[[methods]]\nname = "hybrid"\noptions = { speed = 1.0 }\n',
     "methods[0].options.speed: the hybrid method has no option 'speed'"),
    ('[[models]]\nname = "cube"\n[[methods]]\nname = "hybrid"\n[loads]\ndirections = [[0.0, 0.0, 2.0]]\n',
     "loads.directions[0]: [0.0, 0.0, 2.0] is not a unit vector"),
    ('[[models]]\nname = "cube"\n[[methods]]\nname = "hybrid"\n[loads.random]\ncount = 2\nforce = [3.0, 1.0]\n',
     "loads.random.force: [3, 1] is not [lowest, highest]"),
    ('[[models]]\nfile = "absent.obj"\n[[methods]]\nname = "hybrid"\n', "models[0].file: no file"),
    ('[[models]]\nname = "cube"\n[[methods]]\nname = "hybrid"\n[materials]\npoisson_ratio = [0.5]\n',
     "materials: "),
    ('[[models]]\nname = "cube"\n[[methods]]\nname = "hybrid"\n[loads]\nkind = "probe"\nradius = 0.01\n',
     "loads.depths: a probe is pressed to depths"),
    ('[[models]]\nname = "cube"\n[[methods]]\nname = "hybrid"\n[loads]\ndepths = [0.001]\n',
     "loads.depths: a pin-head is loaded by forces"),
    ('[[models]]\nname = "cube"\n[[methods]]\nname = "hybrid"\n[loads]\nkind = "grasper"\nradius = 0.01\n',
     "loads.displacements: a grasper is moved by displacements [m], e.g. displacements = [0.001, 0.002]"),
    ('[[models]]\nname = "cube"\n[[methods]]\nname = "hybrid"\n[loads]\nkind = "grasper"\ndisplacements = [0.001]\n',
     "loads.radius: a grasper needs its jaws' reach [m], e.g. radius = 0.005"),
    ('[[models]]\nname = "cube"\n[[methods]]\nname = "hybrid"\n[loads]\nkind = "grasper"\nradius = 0.01\n'
     'depths = [0.001]\n', 'loads.depths: a grasper is moved by displacements; remove depths or set kind = "probe"'),
    ('[[models]]\nname = "cube"\n[[methods]]\nname = "hybrid"\n[loads]\ndisplacements = [0.001]\n',
     'loads.displacements: a pin-head is loaded by forces; remove displacements or set kind = "grasper"'),
    ('[[models]]\nname = "cube"\n[[methods]]\nname = "hybrid"\n[loads]\nkind = "probe"\nradius = 0.01\n'
     'depths = [0.001]\npoint = [0.0, 0.0, 0.08]\n', "loads.point: only a grasper's jaws close on a given point"),
    ('[[models]]\nname = "cube"\n[[methods]]\nname = "hybrid"\n[loads]\nkind = "grasper"\nradius = 0.01\n'
     'displacements = [0.001]\n[loads.random]\ncount = 2\nforce = [1.0, 2.0]\n',
     "loads.random: random loads are pin-head loads"),
])
def test_a_bad_study_is_refused_naming_the_key(tmp_path, text, expected):
    assert expected in _refusal(text, tmp_path)


def test_the_cli_prints_a_bad_study_in_one_line(tmp_path, capsys):
    path = tmp_path / "bad.toml"
    path.write_text('[[models]]\nname = "torus"\n[[methods]]\nname = "hybrid"\n')
    assert main(["study", str(path), "--output", str(tmp_path / "out"), "--workers", "0"]) == 1
    error = capsys.readouterr().err.strip()
    assert len(error.splitlines()) == 1 and "models[0].name" in error
    assert not (tmp_path / "out").exists()                  # refused before anything was written


def test_a_serial_run_is_elastic_scales_with_the_material_and_resumes(tmp_path):
    cases = _cases(SMALL, tmp_path)
    store = Store(tmp_path / "out")
    summary = run_study(cases, store, progress=False)
    assert (summary.done, summary.failed, summary.skipped) == (8, 0, 0)
    rows = list(_rows(store.combine()).values())
    for method in {r["method"] for r in rows}:
        by = {(r["youngs_modulus_Pa"], r["force_N"]): r for r in rows if r["method"] == method}
        base = by[(5500.0, 0.5)]["max_displacement_m"]
        assert by[(5500.0, 1.0)]["max_displacement_m"] == pytest.approx(2 * base, rel=1e-9)      # linear in load
        assert by[(11000.0, 0.5)]["max_displacement_m"] == pytest.approx(base / 2, rel=1e-9)     # 1/E
        relative = {r["relative_rmse"] for r in by.values()}
        assert max(relative) - min(relative) < 1e-9                                               # dimensionless
    again = run_study(cases, store, progress=False)
    assert (again.done, again.skipped) == (0, 8)


def test_a_corrupt_part_or_field_is_recomputed_not_read(tmp_path):
    cases = _cases(SMALL, tmp_path)[:3]
    store = Store(tmp_path / "out")
    run_study(cases, store, progress=False)
    before = _rows(store.combine())
    part = store.part(cases[0].case_id)
    part.write_bytes(part.read_bytes()[: len(part.read_bytes()) // 2])            # a part cut short
    field = store.field(cases[1].case_id)
    store._write_field(cases[1].case_id, np.zeros_like(field))                     # a field changed under its part
    assert not store.done(cases[0]) and not store.done(cases[1]) and store.done(cases[2])
    summary = run_study(cases, store, progress=False)
    assert (summary.done, summary.skipped) == (2, 1)
    after = _rows(store.combine())
    for case in cases[:2]:
        assert after[case.case_id]["max_displacement_m"] == before[case.case_id]["max_displacement_m"]
    assert np.array_equal(store.field(cases[1].case_id), field)


# a 60-vertex sphere rests on one bottom node: no support holds it, so every case on it fails
FAILING = SMALL.replace('[[methods]]\nname = "hybrid"', '[[models]]\nname = "sphere"\nresolution = 60\n'
                        '[[methods]]\nname = "hybrid"').replace("field = true", "field = false")


def test_a_failing_case_is_recorded_and_the_study_goes_on(tmp_path):
    cases = _cases(FAILING, tmp_path)
    store = Store(tmp_path / "out")
    summary = run_study(cases, store, progress=False)
    assert (summary.done, summary.failed) == (8, 8)
    rows = store.combine().to_pylist()
    failed = [r for r in rows if r["status"] == "failed"]
    assert {r["model"] for r in failed} == {"sphere"}
    assert all("BoundaryConditionError" in r["error"] and "rigid-body" in r["error"] for r in failed)
    assert all(r["rmse_m"] is not None for r in rows if r["status"] == "done")
    assert run_study(cases, store, progress=False).skipped == 16      # a failure is a result: not rerun


def test_an_unsettled_solve_keeps_its_last_positions_as_the_experiments_do(tmp_path):
    text = SMALL.replace('name = "embedded"', 'name = "mass-spring"').replace("field = true", "max_steps = 1")
    store = Store(tmp_path / "out")
    assert run_study(_cases(text, tmp_path), store, progress=False).done == 8
    rows = store.combine().to_pylist()
    assert {r["method"] for r in rows if not r["converged"]} == {"mass-spring"}
    assert all(r["converged"] for r in rows if r["method"] == "hybrid")     # a direct solve settles at once


def test_the_report_plots_the_error_against_what_the_study_varies(tmp_path):
    from tissuesim.study.report import write_report

    store = Store(tmp_path / "out")
    run_study(_cases(FAILING, tmp_path), store, progress=False)
    report = write_report(store.combine().to_pylist(), tmp_path / "out", title="small").read_text()
    assert "| hybrid | 8 | 4 |" in report and "| embedded | 8 | 4 |" in report
    # E and the force vary; ν, the radius and the model's resolution do not
    assert sorted(p.name for p in (tmp_path / "out").glob("*.png")) == ["error_vs_force_N.png",
                                                                        "error_vs_youngs_modulus_Pa.png"]
    assert report.count("BoundaryConditionError") == 8


def test_a_probe_is_pressed_to_its_depths_and_measured_against_the_pressed_reference(tmp_path):
    text = ('[[models]]\nname = "cube"\nresolution = 400\n[[methods]]\nname = "hybrid"\n[loads]\nkind = "probe"\n'
            'radius = 0.025\ndepths = [0.001, 0.002]\ndirections = ["pressure"]\n')
    cases = _cases(text, tmp_path)
    store = Store(tmp_path / "out")
    assert run_study(cases, store, progress=False).done == 2
    rows = sorted(store.combine().to_pylist(), key=lambda r: r["depth_m"])
    # straight down on a symmetric cube: a lateral force only from the mesh's asymmetry (a percent at most)
    assert all(r["tool"] == "probe" and abs(r["force_x"]) < 1e-2 * abs(r["force_z"]) for r in rows)
    assert rows[0]["force_z"] < 0.0                                   # the probe pushes the tissue down
    # linear elasticity: twice the depth, twice the force, to the contact tolerance (1e-3 of R over a 1 mm press)
    assert rows[1]["force_z"] == pytest.approx(2 * rows[0]["force_z"], rel=0.05)
    assert rows[1]["relative_rmse"] == pytest.approx(rows[0]["relative_rmse"], rel=0.05)


def test_the_command_says_what_is_left_and_estimates_its_time_from_a_case_run_first(tmp_path, capsys):
    path = tmp_path / "study.toml"
    path.write_text(SMALL)
    output = str(tmp_path / "out")
    assert main(["study", str(path), "--output", output, "--workers", "0", "--quiet"]) == 0
    first = capsys.readouterr()
    assert "8 cases on 1 mesh, 4 fem references" in first.err
    # a fresh study runs its first case before the others, and estimates their time from it
    assert "7 to run, 1 already done; about" in first.err and "at the time of the case just run here" in first.err
    assert "8 cases done, 0 failed, 0 already done before" in first.out
    path.write_text(SMALL.replace("forces = [0.5, 1.0]", "forces = [0.5, 1.0, 2.0]"))
    assert main(["study", str(path), "--output", output, "--workers", "0", "--quiet"]) == 0
    second = capsys.readouterr()
    # a resumed study runs its first case left here too: the finished cases' recorded times leave their references out
    assert "3 to run, 9 already done; about" in second.err and "at the time of the case just run here" in second.err
    assert "4 cases done, 0 failed, 8 already done before" in second.out


@pytest.mark.parametrize("arguments, expected", [
    (["--workers", "-1"], "--workers must be 0 (serial) or more"),
    (["--workers", "2", "--scheduler", "tcp://127.0.0.1:1"], "give one of them"),
])
def test_the_command_refuses_contradictory_options(tmp_path, capsys, arguments, expected):
    path = tmp_path / "study.toml"
    path.write_text(SMALL)
    assert main(["study", str(path), "--output", str(tmp_path / "out"), *arguments]) == 1
    assert expected in capsys.readouterr().err


def test_file_folder_and_bundle_models_are_known_by_their_content(tmp_path):
    from tissuesim.io import write_surface
    from tissuesim.mesh.hybrid import HybridMesh
    from tissuesim.mesh.models import cube

    (tmp_path / "organs").mkdir()
    write_surface(tmp_path / "organs" / "a.obj", cube(60))
    write_surface(tmp_path / "organs" / "b.obj", cube(80))
    (tmp_path / "renamed.obj").write_bytes((tmp_path / "organs" / "a.obj").read_bytes())
    HybridMesh.build(cube(60), fine_volume=True, progress=False).save(tmp_path / "cube.npz")
    methods = '[[methods]]\nname = "hybrid"\n'
    folder = _cases('[[models]]\nfolder = "organs"\n' + methods, tmp_path)
    renamed = _cases('[[models]]\nfile = "renamed.obj"\n' + methods, tmp_path)
    assert [c.model.label for c in folder] == ["a", "b"] and folder[0].case_id != folder[1].case_id
    # the same bytes under another name and place are the same model: a rerun finds the finished case
    assert renamed[0].case_id == folder[0].case_id
    with pytest.raises(StudyError, match="the same case twice"):
        _cases('[[models]]\nfile = "organs/a.obj"\n[[models]]\nfile = "renamed.obj"\n' + methods, tmp_path)
    bundle = _cases('[[models]]\nbundle = "cube.npz"\n' + methods, tmp_path)
    store = Store(tmp_path / "out")
    assert run_study(renamed + bundle, store, progress=False).done == 2
    rows = {r["model_kind"]: r for r in store.combine().to_pylist()}
    # a bundle is the hybrid mesh as built: the same answer as building it from the same surface
    assert rows["bundle"]["max_displacement_m"] == pytest.approx(rows["file"]["max_displacement_m"], rel=1e-9)


GRASPER = """
[[models]]
name = "cube"
resolution = 200
[[methods]]
name = "hybrid"
[[methods]]
name = "fem"
[loads]
kind = "grasper"
radius = 0.01
displacements = [0.0005, 0.001, 0.002]
directions = ["tension", [1.0, 0.0, 0.0]]
[record]
field = true
"""


def test_a_grasper_pull_has_a_reaction_linear_in_its_travel_for_the_linear_material(tmp_path):
    cases = _cases(GRASPER, tmp_path)
    assert len(cases) == 2 * 2 * 3 and len({case.reference_key for case in cases}) == 2 * 3
    store = Store(tmp_path / "out")
    assert run_study(cases, store, progress=False).done == 12
    rows = store.combine().to_pylist()
    for method in {r["method"] for r in rows}:
        for direction in (0.0, 1.0):                  # tension (up, on the top face's load node), then along x
            group = sorted((r for r in rows if r["method"] == method and r["direction_x"] == direction),
                           key=lambda r: r["depth_m"])
            forces = np.array([[r["force_x"], r["force_y"], r["force_z"]] for r in group])
            travels = np.array([r["depth_m"] for r in group])
            # N/m: the same at every travel where the model is linear, to 0.5 % (the held vertices are on their
            # targets to the grasper's tolerance, radius / 1000: 2 % of the smallest travel, 0.2 % in the force here)
            stiffness = forces / travels[:, None]
            assert np.linalg.norm(stiffness - stiffness[0], axis=1).max() <= 5e-3 * np.linalg.norm(stiffness[0])
            pull = [0.0, 0.0, 1.0] if direction == 0.0 else [1.0, 0.0, 0.0]
            assert forces[0] @ pull > 0.9 * np.linalg.norm(forces[0])   # the jaws pull the tissue their way
            assert all(r["status"] == "done" and r["tool"] == "grasper" for r in group)
            assert max(r["max_displacement_m"] for r in group) >= travels[-1] * (1 - 1e-3)
    assert all(r["relative_rmse"] == 0.0 for r in rows if r["method"] == "fem")   # the reference pulled alike
    assert store.field(rows[0]["case_id"]).shape == (rows[0]["surface_nodes"], 3)


def test_a_grasp_the_grasper_refuses_fails_its_case_with_the_reason(tmp_path):
    text = GRASPER.replace("displacements = [0.0005, 0.001, 0.002]", "displacements = [0.001]\npoint = [0.0, 0.0, "
                                                                    "0.2]").replace("field = true", "metrics = false")
    store = Store(tmp_path / "out")
    summary = run_study(_cases(text, tmp_path), store, progress=False)
    assert (summary.done, summary.failed) == (0, 4)
    errors = {r["error"] for r in store.combine().to_pylist()}
    assert len(errors) == 1 and errors.pop().startswith("SolverError: nothing to grasp: the nearest surface vertex")
