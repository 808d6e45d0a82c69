"""pbd's ROS 2 side against an implementation pbd did not write: Cyclone DDS (the `cyclonedds`
package, the rmw of several ROS 2 distributions) subscribes to the simulated Dexter that
`pbd sim serve --ros2` serves, reads standard `sensor_msgs/JointState` values, and publishes a
`std_msgs/Float64MultiArray` command (a forward position controller's) that the served head follows.

The message types below are declared from the ROS 2 `.msg` definitions (DDS names
`package::msg::dds_::Type_`, topics `rt/...`), not from pbd's code.
"""

import json
import os
import signal
import subprocess
import time
from dataclasses import dataclass

import pytest

from conftest import REPO, pbd_cli

cyclonedds = pytest.importorskip("cyclonedds", reason="the cyclonedds package is not installed")
from cyclonedds.core import Policy, Qos  # noqa: E402
from cyclonedds.domain import DomainParticipant  # noqa: E402
from cyclonedds.idl import IdlStruct  # noqa: E402
from cyclonedds.idl.types import float64, int32, sequence, uint32  # noqa: E402
from cyclonedds.pub import DataWriter  # noqa: E402
from cyclonedds.sub import DataReader  # noqa: E402
from cyclonedds.topic import Topic  # noqa: E402
from cyclonedds.util import duration  # noqa: E402


@dataclass
class Time(IdlStruct, typename="builtin_interfaces::msg::dds_::Time_"):
    sec: int32
    nanosec: uint32


@dataclass
class Header(IdlStruct, typename="std_msgs::msg::dds_::Header_"):
    stamp: Time
    frame_id: str


@dataclass
class JointState(IdlStruct, typename="sensor_msgs::msg::dds_::JointState_"):
    header: Header
    name: sequence[str]
    position: sequence[float64]
    velocity: sequence[float64]
    effort: sequence[float64]


@dataclass
class MultiArrayDimension(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayDimension_"):
    label: str
    size: uint32
    stride: uint32


@dataclass
class MultiArrayLayout(IdlStruct, typename="std_msgs::msg::dds_::MultiArrayLayout_"):
    dim: sequence[MultiArrayDimension]
    data_offset: uint32


@dataclass
class Float64MultiArray(IdlStruct, typename="std_msgs::msg::dds_::Float64MultiArray_"):
    layout: MultiArrayLayout
    data: sequence[float64]


def test_cyclone_dds_reads_the_served_joint_states_and_commands_the_head(tmp_path):
    cli = pbd_cli()
    if cli is None:
        pytest.skip("no pbd binary built (cargo build --release -p pbd-cli, or set PBD_CLI)")
    # Dexter's mapping with a forward position controller instead of the trajectory controller.
    text = (REPO / "assets" / "ros2" / "dexter.toml").read_text()
    text = text.replace('kind = "joint_trajectory"', 'kind = "position"')
    text = text.replace('"/dexter_controller/joint_trajectory"', '"/dexter_controller/commands"')
    config = tmp_path / "dexter-position.toml"
    config.write_text(text)
    domain = 100 + os.getpid() % 100
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    server = subprocess.Popen(
        [cli, "sim", "serve", "--ros2", "--scene", "pick-place", "--config", str(config), "--json"],
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    try:
        dp = DomainParticipant(domain)
        qos = Qos(
            Policy.Reliability.Reliable(max_blocking_time=duration(seconds=1)),
            Policy.Durability.TransientLocal,
            Policy.History.KeepLast(1),
        )
        states = DataReader(dp, Topic(dp, "rt/joint_states", JointState), qos=qos)
        commands = DataWriter(dp, Topic(dp, "rt/dexter_controller/commands", Float64MultiArray), qos=qos)

        first = None
        deadline = time.time() + 30
        while first is None and time.time() < deadline:
            for s in states.take(N=16):
                first = s
            time.sleep(0.02)
        assert first is not None, "no JointState from the served robot within 30 s"
        names = list(first.name)
        assert len(names) == 26 and len(first.position) == 26 and len(first.velocity) == 26
        assert "head/pan_joint" in names and "left/base_yaw_joint" in names
        assert all(abs(q) < 3.2 for q in first.position)
        t_first = first.header.stamp.sec + first.header.stamp.nanosec * 1e-9
        assert t_first > 0.0

        # Hold every joint where it is and turn the head to 0.3 rad.
        k = names.index("head/pan_joint")
        target = list(first.position)
        target[k] = 0.3
        last = first
        deadline = time.time() + 20
        while time.time() < deadline:
            commands.write(Float64MultiArray(layout=MultiArrayLayout(dim=[], data_offset=0), data=target))
            for s in states.take(N=64):
                last = s
            if abs(last.position[k] - 0.3) < 0.01:
                break
            time.sleep(0.02)
        assert abs(last.position[k] - 0.3) < 0.01, f"head pan {last.position[k]} after the command"
        t_last = last.header.stamp.sec + last.header.stamp.nanosec * 1e-9
        assert t_last > t_first
    finally:
        server.send_signal(signal.SIGTERM)
        out, err = server.communicate(timeout=60)
    assert server.returncode == 0, err.decode()
    report = json.loads(out)
    assert report["serve"]["commands"] > 0, report
    assert report["serve"]["ended"] == "stop", report
