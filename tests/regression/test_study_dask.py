"""Studies on Dask: two single-threaded worker processes give the serial run's answers, and a worker killed in the
middle of a study loses no finished case; the study completes and a rerun does nothing."""

import os
import threading
import time

import distributed                    # the study extra, part of the test extra: a missing one fails, not skips
import numpy as np
import pytest

from tissuesim.study.cases import expand
from tissuesim.study.load import parse_study
from tissuesim.study.runner import run_study
from tissuesim.study.store import Store

STUDY = """
[[models]]
name = "cube"
resolution = 60
[[models]]
name = "cube"
resolution = 90
[[methods]]
name = "hybrid"
[[methods]]
name = "embedded"
[materials]
youngs_modulus = [5500.0, 11000.0]
[loads.random]
count = 3
seed = 4
force = [0.5, 2.0]
[record]
field = true
"""

# the columns a case computes (its wall times excepted)
RESULTS = ("status", "node", "force_x", "force_y", "force_z", "surface_nodes", "max_displacement_m", "rmse_m",
           "relative_rmse", "field_sha256")


@pytest.fixture(scope="module")
def client():
    cluster = distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None)
    with distributed.Client(cluster) as client:
        yield client
    cluster.close()


def _results(store):
    return {row["case_id"]: tuple(row[key] for key in RESULTS) for row in store.combine().to_pylist()}


def test_two_workers_give_the_serial_answers(tmp_path, client):
    cases = expand(parse_study(STUDY, tmp_path / "study.toml"))
    serial, parallel = Store(tmp_path / "serial"), Store(tmp_path / "parallel")
    run_study(cases, serial, progress=False)
    summary = run_study(cases, parallel, client=client, progress=False)
    assert (summary.done, summary.failed) == (len(cases), 0)
    # same code, same inputs, same floating-point operations: identical to the bit, not merely close
    assert _results(parallel) == _results(serial)
    for case in cases[:4]:
        assert np.array_equal(parallel.field(case.case_id), serial.field(case.case_id))
    # each worker built each mesh at most once (2 models), whatever number of cases it ran
    builds = client.run(lambda: __import__("tissuesim.study.work", fromlist=["CACHE"]).CACHE["builds"])
    assert all(count <= 2 for count in builds.values())


def test_a_killed_worker_loses_no_finished_case(tmp_path, client):
    # step timing makes each case last long enough to be killed in the middle of the study
    cases = expand(parse_study(STUDY.replace("field = true", "step_times = true\ntiming_steps = 20000"),
                               tmp_path / "study.toml"))
    store = Store(tmp_path / "out")
    outcome = {}
    runner = threading.Thread(target=lambda: outcome.update(summary=run_study(cases, store, client=client,
                                                                                progress=False)))
    runner.start()
    deadline = time.monotonic() + 60
    while len(list((store.root / "parts").glob("*.parquet"))) < 2 and time.monotonic() < deadline:
        time.sleep(0.05)
    finished = {p.name: p.read_bytes() for p in (store.root / "parts").glob("*.parquet")}
    assert 2 <= len(finished) < len(cases), "the kill must come in the middle of the study"
    victim = sorted(client.scheduler_info()["workers"])[0]
    client.run(os._exit, 1, workers=[victim], on_error="ignore")       # the nanny starts a fresh worker
    runner.join(timeout=120)
    summary = outcome["summary"]
    assert (summary.done, summary.failed) == (len(cases), 0)
    for name, content in finished.items():                               # nothing finished was lost or rewritten
        assert (store.root / "parts" / name).read_bytes() == content
    again = run_study(cases, store, client=client, progress=False)
    assert (again.done, again.failed, again.skipped) == (0, 0, len(cases))


def test_the_command_runs_on_an_existing_scheduler(tmp_path, client, capsys):
    from tissuesim.cli import main

    path = tmp_path / "study.toml"
    path.write_text(STUDY.replace("count = 3", "count = 1"))
    address = client.scheduler.address
    assert main(["study", str(path), "--scheduler", address, "--output", str(tmp_path / "out"), "--quiet"]) == 0
    out = capsys.readouterr()
    assert "8 cases done, 0 failed" in out.out and "Dask dashboard" in out.err
    assert len(list((tmp_path / "out" / "parts").glob("*.parquet"))) == 8
    assert (tmp_path / "out" / "report.md").is_file()
    assert client.status == "running"              # the command left the cluster it was given running
