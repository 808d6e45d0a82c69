"""record → infer → learn → execute from Python; the same inference as `pbd infer`; Ctrl-C."""

import json
import subprocess
import signal
import threading
import time
import _thread

import numpy as np
import pytest

import pbd
from conftest import MODEL, pbd_cli


def test_record_and_demonstration(touch_demo):
    path, report = touch_demo
    assert report["percepts"] > 0
    assert "recorded" in str(report)
    demo = pbd.Demonstration.open(path)
    assert len(demo) == report["percepts"]
    assert demo.times.shape == (len(demo),) and np.all(np.diff(demo.times) > 0)
    assert demo.topics["/pbd/percept"] == len(demo)
    times, msgs = demo.messages("/pbd/percept")
    assert times.shape == (len(demo),) and msgs[0]["t"] == demo.percepts[0]["t"]
    assert "Demonstration(" in repr(demo)


def strip_paths(file):
    file = dict(file)
    file.pop("demo", None)
    return file


def test_infer_from_python_equals_the_json_pbd_infer_writes(touch_demo, tmp_path):
    path, _ = touch_demo
    out = tmp_path / "py.infer.json"
    run = pbd.infer(path, output=out)
    assert run["file"]["inference"]["posterior"]["map"] == "reach_and_touch"
    written = json.loads(out.read_text())
    assert run["file"] == written
    cli = pbd_cli()
    if cli is None:
        pytest.skip("no pbd binary built (cargo build --release -p pbd-cli); compared with the file only")
    cli_out = tmp_path / "cli.infer.json"
    subprocess.run([cli, "infer", str(path), "-o", str(cli_out)], check=True, capture_output=True)
    assert strip_paths(json.loads(cli_out.read_text())) == strip_paths(written)


def test_procedural_model_learn_update_predict(tmp_path):
    model = pbd.ProceduralModel.load(MODEL)
    assert model.places == ["bin-left", "bin-right"]
    assert "Colour decides the place" in model.explain()
    features = {"histogram": [[40, 1.0]], "pixels": [150, 140], "colors": [[7, 1.0]]}  # blue
    p = model.predict(features)
    assert p["map_place"] == "bin-left", p
    ex = {"features": features, "reference": "bin-left"}
    n = model.num_demonstrations
    assert model.update(ex) == 1 and model.num_demonstrations == n + 1
    again = pbd.ProceduralModel.from_json(model.to_json())
    assert again.predict(features) == model.predict(features)
    import pickle

    assert pickle.loads(pickle.dumps(model)).to_json() == model.to_json()


def test_objects_the_teacher_left_alone_fit_the_relevance_background():
    model = pbd.ProceduralModel.load(MODEL)
    assert model.background_objects == 0
    green = {"histogram": [[20, 1.0]], "pixels": [150, 140], "colors": [[6, 1.0]]}
    before = model.predict(green)["relevance"]["bayes_factor"]["log_b10"]
    for _ in range(3):
        model.observe_background(green)
    assert model.background_objects == 3
    # Green things were left alone: a green object is less likely part of the task than before.
    after = model.predict(green)["relevance"]["bayes_factor"]["log_b10"]
    assert after < before - 1.0, (before, after)
    with pytest.raises(ValueError):
        model.observe_background({"histogram": [], "pixels": [0, 0], "colors": []})


def test_execute_in_a_scene():
    report = pbd.execute(pbd.ProceduralModel.load(MODEL), scene="sorting-new", object="blue_block", seed=1)
    assert report["objects"], report
    assert "bin-left" in str(report) or report["objects"][0]["decision"]


def test_callback_exception_stops_the_recording(tmp_path):
    class Stop(Exception):
        pass

    seen = []

    def progress(event, text, value):
        seen.append(event)
        if len(seen) > 20:
            raise Stop()

    path = tmp_path / "stopped.mcap"
    with pytest.raises(Stop):
        pbd.record(path, script="touch", progress=progress)
    # The recording finished its file with what was captured.
    assert len(pbd.Demonstration.open(path)) > 0


def test_ctrl_c_interrupts_a_long_call_and_keeps_the_file(tmp_path):
    path = tmp_path / "interrupted.mcap"
    done = threading.Event()

    def interrupt_once_recording():
        # Ctrl-C once the recording is under way (its file exists), as a user would: a fixed delay
        # raced the start of the call on a loaded machine.
        deadline = time.monotonic() + 60.0
        while not path.exists() and time.monotonic() < deadline and not done.is_set():
            time.sleep(0.05)
        time.sleep(0.5)
        if not done.is_set():
            _thread.interrupt_main()

    # A process started in the background by a shell (as CI may run this) inherits SIGINT ignored,
    # and then interrupt_main() does nothing: give SIGINT Python's own handler for this test.
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    helper = threading.Thread(target=interrupt_once_recording, daemon=True)
    helper.start()
    try:
        with pytest.raises(KeyboardInterrupt):
            pbd.record(path, scene="sorting", script="sort")
    finally:
        done.set()
        helper.join()
        signal.signal(signal.SIGINT, previous)
    assert len(pbd.Demonstration.open(path)) > 0


def test_sim_steps_renders_and_commands():
    sim = pbd.Sim("pick-place", seed=2)
    assert "pick-place" in repr(sim) and sim.objects
    n = len(sim.joint_names)
    assert sim.q.shape == (n,)
    img = sim.image("head/left")
    assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3 and img.std() > 0
    target = sim.q.copy()
    i = sim.joint_names.index("left/elbow_pitch_joint")
    target[i] += 0.2
    sim.set_targets(target)
    sim.step(500)
    assert abs(sim.time - 0.5) < 1e-9
    assert abs(sim.q[i] - target[i]) < 0.05
    w = sim.fingertip_wrenches()
    assert len(w) == 6 and w["right/3"][0].shape == (3,)
    assert sim.object_pose(sim.objects[0]).shape == (4, 4)
    with pytest.raises(pbd.PbdLookupError):
        sim.image("nose/camera")
    with pytest.raises(pbd.PbdValueError):
        sim.set_targets(np.zeros(3))
    with pytest.raises(pbd.PbdLookupError):
        pbd.Sim("no-such-scene")


def test_sim_runs_skills_one_by_one_from_its_own_senses():
    sim = pbd.Sim("pick-place", seed=3)
    sim.step(200)
    with pytest.raises(pbd.PbdError, match="locate first"):
        sim.grasp()
    percept = sim.perceive()
    assert percept["segments"], percept
    hint = percept["segments"][0]["centroid"]  # the robot's own triangulation is the search hint
    located = sim.locate(np.asarray(hint))
    assert located["ok"] and len(located["centroid"]) == 3, located
    place = sim.scene_spec["places"][0]["name"]
    grasped = sim.grasp("auto", then_place=place)
    assert grasped["ok"] and grasped["weighed"] > 0, grasped
    assert sim.holding == grasped["arm"]
    assert sim.transport(place)["ok"]
    assert sim.place()["ok"]
    assert sim.holding is None
    sim.step(500)
    # The world's truth, for the evaluation only: the object is in the place.
    p = sim.object_pose(sim.objects[0])[:3, 3]
    spec = sim.scene_spec["places"][0]
    assert abs(p[0] - spec["center"][0]) <= spec["size"][0] / 2
    assert abs(p[1] - spec["center"][1]) <= spec["size"][1] / 2
    with pytest.raises(pbd.PbdValueError):
        sim.locate([0.5, 0.0])
    with pytest.raises(pbd.PbdValueError):
        sim.grasp("middle")


def test_sim_runs_the_pick_place_schema():
    report = pbd.Sim("pick-place", seed=4).pick_place()
    assert report["success"], report
    assert report["phases"][0][0] == "search-track"


def test_sim_scene_and_catalog_as_dicts():
    base = pbd.Sim("sorting")
    spec = base.scene_spec
    assert spec["objects"] and "table" in spec
    spec["objects"] = spec["objects"][:1]
    one = pbd.Sim(spec, seed=1)
    assert len(one.objects) == 1
    catalog = base.catalog
    two = pbd.Sim(spec, catalog=catalog)
    assert two.objects == one.objects
    spec["table"]["height"] = -1.0
    with pytest.raises(pbd.PbdValueError):
        pbd.Sim(spec)
    with pytest.raises(pbd.PbdValueError):
        pbd.Sim({"no": "scene"})


def test_long_calls_release_the_gil(tmp_path):
    ticks = []
    stop = threading.Event()

    def count():
        while not stop.is_set():
            ticks.append(1)
            stop.wait(0.01)

    t = threading.Thread(target=count)
    t.start()
    try:
        pbd.record(tmp_path / "gil.mcap", script="touch", seed=1)
    finally:
        stop.set()
        t.join()
    # ~3 s of recording: a thread blocked on the GIL would have ticked a handful of times at most.
    assert len(ticks) > 50, len(ticks)
