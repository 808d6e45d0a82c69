"""pbd.experiment: trials are pure functions of (config, trial); Ray gives the local results."""

import pytest

import pbd
from pbd.experiment import strip_timing
from conftest import GRASP_MODEL, MODEL

CONFIG = {
    "model": str(MODEL),
    "scene": "sorting-new",
    "objects": 2,
    "task": {"red": "bin-right", "blue": "bin-left"},
    "seed": 11,
}


def test_a_trial_is_a_pure_function_of_config_and_index():
    a = pbd.experiment.execute_trial(CONFIG, 1)
    b = pbd.experiment.execute_trial(CONFIG, 1)
    assert strip_timing(a) == strip_timing(b)
    assert a["trial"] == 1 and all(r["scene"] == 1 for r in a["rows"])
    c = pbd.experiment.execute_trial(dict(CONFIG, model=pbd.ProceduralModel.load(MODEL)), 1)
    assert strip_timing(c) == strip_timing(a)


def test_four_trials_on_ray_equal_the_local_run():
    ray = pytest.importorskip("ray")
    local = pbd.experiment.run(CONFIG, 4, backend="local", progress=False)
    ray.init(num_cpus=2, include_dashboard=False, log_to_driver=False)
    try:
        remote = pbd.experiment.run(CONFIG, 4, backend="ray", progress=False)
    finally:
        ray.shutdown()
    assert [r["trial"] for r in remote] == [0, 1, 2, 3]
    assert strip_timing(remote) == strip_timing(local)


def test_unknown_backend_and_kind():
    with pytest.raises(pbd.PbdValueError):
        pbd.experiment.run(CONFIG, 1, backend="slurm", progress=False)
    with pytest.raises(pbd.PbdLookupError):
        pbd.experiment.run(CONFIG, 1, kind="nope", progress=False)


def test_grasp_trials_give_the_rows_of_pbd_grasp_eval(tmp_path):
    config = {"model": str(GRASP_MODEL), "test": 2, "candidates": 2, "seed": 3}
    objects = pbd.experiment.grasp_objects(config)
    assert len(objects) == 2
    results = pbd.experiment.run(config, None, kind="grasp", progress=False)
    assert [r["object"] for r in results] == objects
    summary = pbd.grasp.eval(tmp_path / "eval", **config)
    assert [r["result"]["object"] for r in results] == summary["objects"]
    assert all(len(r["result"]["trials"]) == 4 for r in results)
    with pytest.raises(pbd.PbdValueError, match="out of range"):
        pbd.experiment.grasp_trial(config, 2)
