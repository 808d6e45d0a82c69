"""A recording in the ROS 2 encoding (`pbd record --encoding ros2`) against readers pbd did not write:
`rosbags` (rosbag2 in pure Python) opens it as a rosbag2 MCAP file and deserialises its
`sensor_msgs/JointState`, `geometry_msgs/WrenchStamped`, `sensor_msgs/Image` and `CameraInfo` with the
definitions the file carries; the values are those of the same run recorded in pbd's default encoding,
read with Foxglove's `mcap` package. Foxglove's own ROS 2 decoder (`mcap-ros2-support`) decodes every
message of every channel from the schemas the file carries. `pbd infer` reads both files to the same
inference.
"""

import json

import pytest

import pbd

rosbags = pytest.importorskip("rosbags", reason="the rosbags package is not installed")
mcap_reader = pytest.importorskip("mcap.reader", reason="the mcap package is not installed")
from rosbags.highlevel import AnyReader  # noqa: E402
from rosbags.typesys import Stores, get_typestore  # noqa: E402


@pytest.fixture(scope="module")
def recordings(tmp_path_factory):
    d = tmp_path_factory.mktemp("ros2bag")
    paths = {}
    for encoding in ["foxglove", "ros2"]:
        path = d / f"touch-{encoding}.mcap"
        pbd.record(path, script="touch", seed=3, images=True, image_format="raw", encoding=encoding)
        paths[encoding] = path
    return paths


def json_messages(path, topic):
    with open(path, "rb") as f:
        reader = mcap_reader.make_reader(f)
        return [json.loads(m.data) for _, _, m in reader.iter_messages(topics=[topic])]


def test_rosbags_reads_joint_states_wrenches_and_images(recordings):
    ros, fox = recordings["ros2"], recordings["foxglove"]
    store = get_typestore(Stores.EMPTY)
    with AnyReader([ros], default_typestore=store) as reader:
        topics = {c.topic: c.msgtype for c in reader.connections}
        assert topics["/joint_states"] == "sensor_msgs/msg/JointState"
        assert topics["/fingertips/left/1"] == "geometry_msgs/msg/WrenchStamped"
        assert topics["/camera/head_left/image"] == "sensor_msgs/msg/Image"
        assert topics["/camera/head_left/camera_info"] == "sensor_msgs/msg/CameraInfo"
        assert topics["/tf"] == "tf2_msgs/msg/TFMessage"

        def read(topic):
            conns = [c for c in reader.connections if c.topic == topic]
            return [(t, reader.deserialize(raw, c.msgtype)) for c, t, raw in reader.messages(connections=conns)]

        joints = read("/joint_states")
        expected = json_messages(fox, "/joint_states")
        assert len(joints) == len(expected) > 10
        for (t, m), e in zip(joints, expected):
            assert list(m.name) == e["name"]
            assert m.header.stamp.sec == e["timestamp"]["sec"]
            assert m.header.stamp.nanosec == e["timestamp"]["nsec"]
            assert t == e["timestamp"]["sec"] * 10**9 + e["timestamp"]["nsec"]
            # pbd's JSON rounds to 6 decimals; CDR carries the doubles.
            assert max(abs(a - b) for a, b in zip(m.position, e["position"])) <= 5e-7
            assert max(abs(a - b) for a, b in zip(m.velocity, e["velocity"])) <= 5e-7
        # The fingers moved: the recording is of a touch, not of a parked robot.
        assert max(abs(a - b) for a, b in zip(joints[0][1].position, joints[-1][1].position)) > 0.1

        fingertips = json_messages(fox, "/fingertips")
        peak = 0.0
        for arm in ["left", "right"]:
            for finger in [1, 2, 3]:
                wrenches = read(f"/fingertips/{arm}/{finger}")
                assert len(wrenches) == len(fingertips)
                for (_, w), e in zip(wrenches, fingertips):
                    reading = next(f for f in e["fingertips"] if f["arm"] == arm and f["finger"] == finger)
                    force = [w.wrench.force.x, w.wrench.force.y, w.wrench.force.z]
                    want = [reading["force"][k] for k in "xyz"]
                    assert max(abs(a - b) for a, b in zip(force, want)) <= 5e-7
                    assert w.header.frame_id == "world"
                    peak = max(peak, sum(x * x for x in force) ** 0.5)
        assert peak > 0.2, "the touch pressed a fingertip"

        images = read("/camera/head_left/image")
        infos = read("/camera/head_left/camera_info")
        assert len(images) == len(infos) > 5
        _, image = images[-1]
        assert image.encoding == "rgb8"
        assert image.step == 3 * image.width and len(image.data) == image.height * image.step
        assert image.width > 100 and image.height > 100
        assert len(set(image.data[::97].tolist())) > 20, "an image with content"
        _, info = infos[-1]
        assert (info.width, info.height) == (image.width, image.height)
        fx, cx, fy, cy = info.k[0], info.k[2], info.k[4], info.k[5]
        assert fx > 0 and fy > 0 and 0 < cx < image.width and 0 < cy < image.height
        assert info.header.frame_id == image.header.frame_id
        # The image's optical frame is one of /tf's frames.
        children = {t.child_frame_id for _, m in read("/tf") for t in m.transforms}
        assert image.header.frame_id in children


def test_infer_reads_both_encodings_alike(recordings, tmp_path):
    results = {}
    for encoding, path in recordings.items():
        demo = pbd.infer(path, output=tmp_path / f"{encoding}.infer.json")
        results[encoding] = json.loads((tmp_path / f"{encoding}.infer.json").read_text())["inference"]
    assert results["foxglove"] == results["ros2"]
    assert results["ros2"]["posterior"]["hypotheses"], demo


def test_foxglove_ros2_decoder_decodes_every_message(recordings):
    decoder = pytest.importorskip("mcap_ros2.decoder", reason="the mcap-ros2-support package is not installed")
    counts = {}
    with open(recordings["ros2"], "rb") as f:
        reader = mcap_reader.make_reader(f, decoder_factories=[decoder.DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        for schema, channel, _, msg in reader.iter_decoded_messages():
            counts[(channel.topic, schema.name)] = counts.get((channel.topic, schema.name), 0) + 1
            if schema.name == "visualization_msgs/msg/MarkerArray" and channel.topic == "/scene":
                kinds = {m.type for m in msg.markers}
                assert {1, 3} <= kinds, kinds  # cubes (table, bins) and cylinders (the object's bands)
            if schema.name == "pbd_msgs/msg/Percept":
                assert len(msg.hands) == 2 and msg.table_z > 0.5
    for topic, ty in [
        ("/tf", "tf2_msgs/msg/TFMessage"),
        ("/robot", "visualization_msgs/msg/MarkerArray"),
        ("/scene", "visualization_msgs/msg/MarkerArray"),
        ("/pbd/percept", "pbd_msgs/msg/Percept"),
        ("/teleop/command", "pbd_msgs/msg/HandCommand"),
        ("/pbd/truth", "pbd_msgs/msg/Truth"),
    ]:
        assert counts.get((topic, ty), 0) >= 1, (topic, ty, sorted(counts))
