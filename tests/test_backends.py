"""Backends: sweeps and diagnoses give the same numbers on local threads and on Ray.

The Ray tests run against a Ray instance started on this machine (2 CPUs) and
need the ray extra (pip install 'skidsteer[ray]'); without it they skip and say
so, except under CI (SKIDSTEER_REQUIRE_RAY_TESTS=1, set by scripts/test.sh),
where they fail.  "The same" is exact: a run on Ray starts from the pickled
bytes of the model and settled state the driver made, and MuJoCo is
deterministic, so any difference at all is a defect.
"""

from __future__ import annotations

import importlib.util
import json
import os
import sys
from concurrent.futures import ThreadPoolExecutor

import pytest

import skidsteer  # noqa: F401
from skidsteer.experiments import sweep
from skidsteer.simulation import backends
from skidsteer.simulation.backends import BackendUnavailable, LocalBackend, make_backend
from skidsteer.cli import main

RAY_REQUIRED = os.environ.get("SKIDSTEER_REQUIRE_RAY_TESTS") == "1"
HAVE_RAY = importlib.util.find_spec("ray") is not None


# ------------------------------------------------------------------ without Ray

def test_backend_choices_and_options_are_checked():
    with pytest.raises(ValueError, match="unknown backend 'slurm'.*local, ray"):
        make_backend("slurm")
    with pytest.raises(ValueError, match="--address is for the ray backend"):
        make_backend("local", address="auto")
    with pytest.raises(ValueError, match="nthread must be at least 1, got 0"):
        LocalBackend(0)


def test_local_backend_keeps_the_order_of_its_tasks():
    # with 3 threads the short tasks finish first; the results must not follow them
    import time

    def task(delay, value):
        time.sleep(delay)
        return value

    args = [(0.05 * (5 - i), i) for i in range(6)]
    assert list(LocalBackend(3).map(task, args)) == list(range(6))


def test_ray_backend_without_the_extra_says_how_to_install_it(monkeypatch, capsys, tmp_path):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray raises ImportError
    with pytest.raises(BackendUnavailable, match=r"pip install 'skidsteer\[ray\]'"):
        make_backend("ray")
    code = main(["sweep", "--out", str(tmp_path / "d"), "--omega", "30", "--surface",
                 "concrete", "--duration", "1", "--backend", "ray", "--quiet"])
    assert code == 2
    assert "skidsteer[ray]" in capsys.readouterr().err
    assert not (tmp_path / "d").exists()  # nothing written


def test_a_worker_with_other_versions_refuses_to_run(monkeypatch):
    monkeypatch.setenv(backends._VERSIONS_ENV, "mujoco==0.0.1 skidsteer==0.0.1")
    with pytest.raises(RuntimeError, match=r"mujoco==0\.0\.1.*install the driver's versions"):
        backends.worker_setup()
    monkeypatch.setenv(backends._VERSIONS_ENV, backends._versions())
    backends.worker_setup()  # the same versions pass


# ------------------------------------------------------------------ on Ray

@pytest.fixture(scope="module")
def ray_backend():
    if not HAVE_RAY:
        message = ("the Ray backend's tests need the ray extra: pip install "
                   "'skidsteer[ray]' (ray is not installed)")
        if RAY_REQUIRED:
            pytest.fail(message + "; SKIDSTEER_REQUIRE_RAY_TESTS=1")
        # issue 6 asks for exactly this: without the optional extra the Ray tests
        # skip and say why; CI installs the extra and fails here instead (above)
        pytest.skip(message)
    # 2 CPUs as this machine has; a small object store (a model pickles to ~5 MB)
    backend = make_backend("ray", num_cpus=2, object_store_memory=200 * 2**20)
    yield backend
    backend.close()


def _files(directory):
    return {p.name: p.read_bytes() for p in sorted(directory.iterdir())}


@pytest.mark.slow  # 29 s beside the other worker (7 s alone)
def test_a_sweep_on_ray_writes_the_same_files_as_a_local_one(ray_backend, tmp_path):
    # two floors (two models), two omegas, perturbed repeat trials (seeded)
    runs = sweep.plan([30.0, 64.0], ["concrete", "carpet"], ["extended"], trials=2,
                      duration_s=3.0)
    sweep.run_sweep(tmp_path / "local", runs, progress=False, backend=LocalBackend(2))
    sweep.run_sweep(tmp_path / "ray", runs, progress=False, backend=ray_backend)
    local, on_ray = _files(tmp_path / "local"), _files(tmp_path / "ray")
    assert len(local) == len(runs) + 1  # + runs.csv
    assert local == on_ray


def test_the_sweep_command_runs_on_ray(ray_backend, tmp_path, capsys):
    # the fixture's Ray instance is already up: the command joins it and leaves it up
    args = ["sweep", "--omega", "20", "--surface", "tile", "--duration", "2", "--quiet"]
    assert main(args + ["--out", str(tmp_path / "ray"), "--backend", "ray"]) == 0
    assert main(args + ["--out", str(tmp_path / "local")]) == 0
    assert _files(tmp_path / "ray") == _files(tmp_path / "local")
    assert ray_backend._ray.is_initialized()


def test_ray_map_cancels_only_what_a_consumer_leaves_pending(ray_backend):
    # all consumed: nothing is cancelled (ray.cancel on a finished task can kill the
    # driver in Ray 2.60, ray-project/ray#54846); stopped early: the rest is cancelled
    def _sleep_then(delay_s, value):  # nested: pickled by value for the workers
        import time

        time.sleep(delay_s)
        return value

    assert list(ray_backend.map(_sleep_then, [(0.0, i) for i in range(4)])) == [0, 1, 2, 3]
    results = ray_backend.map(_sleep_then, [(0.0, 0)] + [(3.0, i) for i in range(1, 5)])
    assert next(results) == 0
    ray = ray_backend._ray
    refs = list(ray_backend._last_refs)
    results.close()
    # with 2 CPUs, tasks 1 and 2 are running when the consumer stops and 3 and 4 wait
    # for a CPU: those are cancelled for sure (uncancelled they would return their
    # value after ~6 s).  A running task gets Ray's cancellation only as an interrupt
    # that may arrive after it has finished (seen in CI), so it is not asserted on.
    for ref in refs[3:]:
        with pytest.raises(ray.exceptions.TaskCancelledError):
            ray.get(ref, timeout=60)


@pytest.fixture(scope="module")
def slip_dataset(tmp_path_factory):
    from skidsteer.diagnosis.synth import make_dataset

    root = tmp_path_factory.mktemp("ray-diagnose") / "data"
    # 8 s: the shortest records the band features take (see test_diagnose.py); one
    # command, its last trial held out: what is tested is that Ray gives the local
    # numbers, on as few runs as a diagnosis takes (the CI budget: with two commands
    # this test took 464 s of a worker under CI=true; one command's local diagnosis
    # takes 66 s here).  4 trials: the trials' spread needs 3 degrees of freedom
    # (comparison.MIN_SPREAD_DOF); the simulations are per command, not per trial
    make_dataset(root, "slip_lambda_max", seed=3, duration_s=8.0, file_format="csv",
                 omegas=(60.0,), trials=4)
    return root


@pytest.mark.slow
def test_a_diagnosis_on_ray_gives_the_local_numbers(ray_backend, slip_dataset):
    from skidsteer.reports.diagnosis import diagnose

    # ground_roughness draws random floors (heightfields in the pickled models) and
    # chooses one.  One candidate (the CI budget: with slip_lambda_max beside it, 110
    # simulations a diagnosis where this takes 84, and the test held a pytest worker
    # for 641 s under CI=true in stop 54's suite); the pair and the ranking of several
    # causes are local code and tested in test_diagnose.py.  The two diagnoses run
    # side by side: each simulates one command at a time for most of its searches, so
    # together they keep both cores busy; the fit's decisions follow the backend's
    # width, widened here as on a wide cluster (Ray still runs 2 at a time)
    candidates = ["ground_roughness"]
    ray_backend.concurrency, width = 10**6, ray_backend.concurrency
    try:
        with ThreadPoolExecutor(max_workers=2) as pool:
            local = pool.submit(diagnose, slip_dataset, progress=False, candidates=candidates,
                                backend=LocalBackend(2))
            on_ray = pool.submit(diagnose, slip_dataset, progress=False,
                                 candidates=candidates, backend=ray_backend)
            local, on_ray = local.result(), on_ray.result()
    finally:
        ray_backend.concurrency = width
    for result in (local, on_ray):
        result.pop("wall_time_s")
    # as text, so that a NaN (an unscored feature) equals itself
    assert json.dumps(on_ray, sort_keys=True) == json.dumps(local, sort_keys=True)
    assert [r["cause"] for r in local["ranking"]] == ["ground_roughness"]
    assert local["ranking"][0]["realisation"] is not None
    # one command: its held-out trial repeats the trained command, so nothing is named
    assert local["verdict"] == "unexplained" and "repeat the commands" in local["reason"]
