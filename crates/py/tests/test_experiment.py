"""pbd.experiment: trials are pure functions of (config, trial); Ray gives the local results."""

import pytest

import pbd
from pbd.experiment import strip_timing
from conftest import GRASP_MODEL, HERE, MODEL

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
    assert (tmp_path / "eval" / "fig6_7.svg").read_text().startswith("<svg")
    assert [r["result"]["object"] for r in results] == summary["objects"]
    assert all(len(r["result"]["trials"]) == 4 for r in results)
    with pytest.raises(pbd.PbdValueError, match="out of range"):
        pbd.experiment.grasp_trial(config, 2)


FEATURES = str(HERE.parents[1] / "pbd" / "tests" / "data" / "household_features.json")


def test_sorting_trials_are_the_rows_of_the_sorting_experiment(tmp_path):
    import csv

    config = {"feature": "color", "classes": ["red", "blue", "green"], "features": FEATURES, "seed": 5}
    summary = pbd.experiment.sorting(tmp_path / "out", trials=3, max_examples=2, **config)
    assert (tmp_path / "out" / "success.svg").stat().st_size > 0
    with open(tmp_path / "out" / "success.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 6 and summary["rows"]
    for row in rows:
        n, t = int(row["examples_per_class"]), int(row["trial"])
        r = pbd.experiment.sorting_trial(dict(config, examples=n), t)
        assert (r["correct"], r["tested"]) == (int(row["correct"]), int(row["tested"]))
        assert f"{r['success_rate']:.6f}" == row["success_rate"]
        assert r["map_structure"] == row["map_structure"]
        p = r["chi2_p_value"]
        assert (row["chi2_p_value"] == "NA") if p is None else abs(p / float(row["chi2_p_value"]) - 1) < 1e-5
    local = pbd.experiment.run(dict(config, examples=1), 3, kind="sorting", progress=False)
    assert [r["trial"] for r in local] == [0, 1, 2]
    with pytest.raises(pbd.PbdError, match="examples"):
        pbd.experiment.sorting_trial(dict(config, examples=1000), 0)
    with pytest.raises(pbd.PbdValueError):
        pbd.experiment.sorting_trial(dict(config, colour="red"), 0)


def test_grasp_generate_draws_its_pre_grasps_into_an_mcap(tmp_path):
    out = tmp_path / "candidates.mcap"
    report = pbd.grasp.generate(GRASP_MODEL, "jif-1", n=3, mcap=out)
    assert report["pre_grasps"], report.text
    data = out.read_bytes()
    assert data[:8] == b"\x89MCAP0\r\n"
    assert b"/grasp/candidates" in data


def test_perception_trials_are_the_scenes_of_pbd_experiment_perception(tmp_path):
    config = {"scene": "sorting-demo", "objects": 2, "seed": 5}
    trials = pbd.experiment.run(config, 2, kind="perception", progress=False)
    assert [t["trial"] for t in trials] == [0, 1]
    assert trials[1] == pbd.experiment.perception_trial(config, 1)
    for t in trials:
        assert len(t["objects"]) == 2
        for o in t["objects"]:
            assert o["segments"] >= 0
            if o["segments"] > 0:
                assert 0.0 <= o["centroid_error_xy"] < 0.08
    report = pbd.experiment.perception(tmp_path / "perception", scenes=2, objects=2, seed=5, progress=None)
    summary = report["summary"]
    assert summary["objects"] == 4
    assert summary["missed"] == sum(o["segments"] == 0 for t in trials for o in t["objects"])
    assert summary["phantoms"] == sum(t["phantoms"] for t in trials)
    for name in ("objects.csv", "summary.md", "errors.svg"):
        assert (tmp_path / "perception" / name).is_file()
    with pytest.raises(pbd.PbdValueError):
        pbd.experiment.perception_trial(dict(config, objects=0), 0)
