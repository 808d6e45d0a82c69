"""Bad input raises a PbdError subclass carrying the Rust message; it never crashes the interpreter."""

import numpy as np
import pytest

import pbd


@pytest.fixture(scope="module")
def arm():
    return pbd.Robot.from_urdf(None).chain("left/base_link", "left/wrist_palm_link")


def test_hierarchy():
    for cls in [pbd.PbdValueError, pbd.PbdFormatError, pbd.PbdLookupError, pbd.PbdFileError, pbd.PbdSimError]:
        assert issubclass(cls, pbd.PbdError)
    assert issubclass(pbd.PbdValueError, ValueError)
    assert issubclass(pbd.PbdFormatError, pbd.PbdValueError)
    assert issubclass(pbd.PbdLookupError, LookupError)
    assert issubclass(pbd.PbdFileError, OSError)


@pytest.mark.parametrize(
    "q, words",
    [
        ([0.0, 1.0], "has 2 values"),
        (np.zeros(8), "7 joint variables"),
        ([np.nan] * 7, "not a finite number"),
        ([np.inf] * 7, "not a finite number"),
        (np.zeros((7, 1)), "1-D"),
        ("abcdefg", "sequence of numbers"),
        (None, "sequence of numbers"),
    ],
)
def test_bad_q(arm, q, words):
    with pytest.raises(pbd.PbdValueError, match=words):
        arm.fk(q)
    with pytest.raises(pbd.PbdValueError):
        arm.jacobian(q)


def test_wrong_size_lists_the_joints(arm):
    with pytest.raises(pbd.PbdValueError) as e:
        arm.fk([0.0])
    assert "left/base_yaw_joint" in str(e.value)


def test_unknown_link_suggests():
    robot = pbd.Robot.from_urdf(None)
    with pytest.raises(pbd.PbdLookupError, match="unknown link 'left/base_lnk'"):
        robot.chain("left/base_lnk", "left/wrist_palm_link")


def test_missing_and_malformed_files(tmp_path):
    with pytest.raises(pbd.PbdFileError, match="cannot read"):
        pbd.Robot.from_urdf(tmp_path / "missing.urdf")
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='x'><link name='a'/><joint name='j'")
    with pytest.raises(pbd.PbdFormatError):
        pbd.Robot.from_urdf(bad)
    with pytest.raises(pbd.PbdFileError):
        pbd.Demonstration.open(tmp_path / "missing.mcap")
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"not an mcap file at all")
    with pytest.raises(pbd.PbdError):
        pbd.Demonstration.open(junk)
    with pytest.raises(pbd.PbdError):
        pbd.infer(junk)
    with pytest.raises(pbd.PbdFileError):
        pbd.ProceduralModel.load(tmp_path / "missing.json")


def test_bad_ik_target(arm):
    with pytest.raises(pbd.PbdValueError, match="4x4"):
        arm.ik(np.eye(3))
    t = np.eye(4)
    t[0, 0] = 2.0
    with pytest.raises(pbd.PbdValueError, match="not a rotation"):
        arm.ik(t)
    t = np.eye(4)
    t[1, 3] = np.nan
    with pytest.raises(pbd.PbdValueError, match="finite"):
        arm.ik(t)


def test_bad_options():
    with pytest.raises(pbd.PbdValueError, match="unknown field"):
        pbd.record("x.mcap", no_such_option=1)
    with pytest.raises(pbd.PbdLookupError):
        pbd.execute(None, scene="no-such-scene")
    with pytest.raises(pbd.PbdValueError):
        pbd.bayes.NormalInverseGamma(0.0, -1.0, 1.0, 1.0)
    with pytest.raises(pbd.PbdValueError):
        pbd.bayes.Hmm([0.5, 0.5], np.array([[0.5, 0.5]]))
    h = pbd.bayes.Hmm([0.5, 0.5], np.array([[0.9, 0.1], [0.2, 0.8]]))
    with pytest.raises(pbd.PbdValueError, match="T x 2"):
        h.forward(np.zeros((4, 3)))
    with pytest.raises(pbd.PbdValueError):
        h.forward(np.full((4, 2), np.nan))
    with pytest.raises(pbd.PbdValueError):
        pbd.bayes.CategoryCounts([1, -2, 3])


def test_matrices_accept_nested_lists_and_reject_bad_shapes():
    h = pbd.bayes.Hmm([0.5, 0.5], [[0.9, 0.1], [0.2, 0.8]])
    assert np.isfinite(h.forward([[0.0, -1.0], [-2.0, 0.0]]))
    for bad in ([1.0, 2.0, 3.0], "abc", np.zeros((0, 2))):
        with pytest.raises(pbd.PbdValueError):
            h.forward(bad)
    with pytest.raises(pbd.PbdValueError):
        pbd.Sim().step(-1)
