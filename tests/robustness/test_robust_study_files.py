"""Study files a hostile or careless user writes are refused up front in one line, with nothing written: a study of
millions or billions of cases is counted, not expanded; a range of ten billion values is refused by its key; arrays
nested thousands deep, a folder named as a model file and files outside the study's folder (when confined) are named;
an output path that is a file is said to be one. A resumed study estimates its time from a case run now."""

import re
import time

import pytest

from tissuesim.cli import main
from tissuesim.study import cases, work
from tissuesim.study.load import StudyError, read_study

HEAD = '[[models]]\nname = "cube"\nresolution = 60\n[[methods]]\nname = "hybrid"\n'


def _study(tmp_path, capsys, text, *arguments):
    """``tissuesim study`` of ``text`` (written as study.toml) into tmp_path/out, serial: status, stdout, stderr."""
    path = tmp_path / "study.toml"
    path.write_text(text)
    status = main(["study", str(path), "--output", str(tmp_path / "out"), "--workers", "0", "--quiet", *arguments])
    captured = capsys.readouterr()
    return status, captured.out, captured.err.strip().splitlines()


def _refused(tmp_path, capsys, text, *arguments) -> str:
    """The one line a refused study prints; nothing was written."""
    status, out, lines = _study(tmp_path, capsys, text, *arguments)
    assert status == 1 and out == "" and len(lines) == 1, lines
    assert lines[0].startswith("tissuesim study: error: ")
    assert not (tmp_path / "out").exists()
    return lines[0]


@pytest.fixture
def never_expanded(monkeypatch):
    """The study's materials and loads are counted, never listed: listing them fails the test (where it hung)."""
    def listed(study):
        raise AssertionError("the study's cases were expanded before they were counted")
    monkeypatch.setattr(cases, "_materials", listed)
    monkeypatch.setattr(cases, "_loads", listed)


def test_a_billion_random_loads_are_counted_and_refused_at_once(tmp_path, capsys, never_expanded):
    line = _refused(tmp_path, capsys, HEAD + "[loads.random]\ncount = 1000000000\nforce = [0.1, 1.0]\n")
    assert "loads.random.count: 1000000000 random loads, more than the 100000 cases a study runs" in line
    assert "split them over several studies" in line


def test_a_product_of_two_long_lists_is_counted_and_refused_at_once(tmp_path, capsys, never_expanded):
    values = ", ".join(str(1000.0 + i) for i in range(20_000))
    ratios = ", ".join(str(0.1 + 1e-6 * i) for i in range(20_000))
    line = _refused(tmp_path, capsys, HEAD + f"[materials]\nyoungs_modulus = [{values}]\npoisson_ratio = [{ratios}]\n")
    assert "400000000 cases (1 model × 1 method × 400000000 materials × 1 load)" in line and "split it" in line


def test_a_range_of_ten_billion_values_is_refused_by_its_key(tmp_path, capsys):
    line = _refused(tmp_path, capsys, HEAD + "[materials]\nyoungs_modulus = { start = 1000.0, stop = 9000.0, "
                                             "count = 10000000000 }\n")
    assert "materials.youngs_modulus.count: 10000000000 values, more than the 100000 cases" in line


def test_an_array_nested_thousands_deep_is_one_line(tmp_path, capsys):
    line = _refused(tmp_path, capsys, HEAD + "[methods.options]\nx = " + "[" * 5000 + "]" * 5000 + "\n")
    assert "study.toml" in line and "nested" in line and "flatten" in line


def test_a_folder_named_as_a_model_file_is_called_a_folder(tmp_path, capsys):
    (tmp_path / "meshes").mkdir()
    line = _refused(tmp_path, capsys, '[[models]]\nfile = "meshes"\n[[methods]]\nname = "hybrid"\n')
    assert "models[0].file" in line and "is a folder, not a file" in line


def test_a_non_finite_method_option_is_refused_by_its_key(tmp_path, capsys):
    line = _refused(tmp_path, capsys, HEAD + "[methods.options]\nnear_field = nan\n")
    assert "methods[0].options.near_field" in line and "not a finite number" in line


def test_files_outside_the_studys_folder_are_refused_when_confined(tmp_path, capsys):
    (tmp_path / "study").mkdir()
    (tmp_path / "liver.obj").write_text("v 0 0 0\n")
    text = '[[models]]\nfile = "../liver.obj"\n[[methods]]\nname = "hybrid"\n'
    (tmp_path / "study" / "study.toml").write_text(text)
    assert read_study(tmp_path / "study" / "study.toml").study.models[0].file == "../liver.obj"
    with pytest.raises(StudyError, match=r"models\[0\]\.file: '\.\./liver\.obj' lies outside the study file's folder"):
        read_study(tmp_path / "study" / "study.toml", confine=True)
    line = _refused(tmp_path / "study", capsys, text, "--confine")
    assert "outside the study file's folder" in line


def test_an_output_path_that_is_a_file_is_said_to_be_one(tmp_path, capsys):
    (tmp_path / "out").write_text("not a folder")
    status, out, lines = _study(tmp_path, capsys, HEAD)
    assert status == 1 and out == "" and len(lines) == 1
    assert f"output path {str(tmp_path / 'out')!r} is a file, not a folder" in lines[0] and "Errno" not in lines[0]
    assert (tmp_path / "out").read_text() == "not a folder"


def test_a_resumed_study_estimates_its_time_from_a_case_run_now(tmp_path, capsys, monkeypatch):
    text = HEAD + "[loads]\nforces = [0.5, 1.0]\n"
    assert _study(tmp_path, capsys, text)[0] == 0
    measured = work.run_case

    def slow(case, reference):
        time.sleep(0.5)                 # cases now take far longer than the finished ones did
        return measured(case, reference)

    monkeypatch.setattr(work, "run_case", slow)
    status, _, lines = _study(tmp_path, capsys, text.replace("[0.5, 1.0]", "[0.5, 1.0, 2.0, 3.0, 4.0, 5.0]"))
    estimate = next(line for line in lines if "to run" in line)
    assert status == 0 and estimate.startswith("3 to run, 3 already done; about ")
    # 3 cases at 0.5 s or more each on 1 worker: 1.5 s or more, not the finished cases' milliseconds
    assert int(re.search(r"about (\d+) s", estimate).group(1)) >= 2
