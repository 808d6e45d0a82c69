"""Forward kinematics, Jacobians and IK through the Python API, against Pinocchio's values."""

import json

import numpy as np
import pytest

import pbd
from conftest import DATA, SHARED

WAM_URDF = SHARED / "wam7" / "wam7.urdf"


def wam_reference():
    if not WAM_URDF.is_file():
        pytest.skip(f"SKIPPED: {WAM_URDF} not found (the GPL WAM URDF lives in ../shared beside the repository)")
    return json.loads((DATA / "wam7_kinematics.json").read_text())


def test_wam_fk_and_jacobian_match_pinocchio():
    ref = wam_reference()
    robot = pbd.Robot.from_urdf(WAM_URDF)
    tip = robot.chain(ref["base_frame"], ref["tip_frame"])
    flange = robot.chain(ref["base_frame"], ref["flange_frame"])
    assert tip.joint_names == ref["joint_names"]
    worst = 0.0
    for case in ref["cases"]:
        q = np.array(case["q"])
        pose = tip.fk(q)
        want_r = np.array(case["tip_rotation_rowmajor"]).reshape(3, 3)
        worst = max(worst, np.abs(pose[:3, 3] - case["tip_position"]).max(), np.abs(pose[:3, :3] - want_r).max())
        jac = tip.jacobian(q)
        want_j = np.array(case["jacobian_world_aligned_6x7_rowmajor"]).reshape(6, 7)
        worst = max(worst, np.abs(jac - want_j).max())
        fpose, fjac = flange.fk_jacobian(q)
        want_fj = np.array(case["flange_jacobian_world_aligned_6x7_rowmajor"]).reshape(6, 7)
        worst = max(worst, np.abs(fpose[:3, 3] - case["flange_position"]).max(), np.abs(fjac - want_fj).max())
        assert np.array_equal(pose[3], [0, 0, 0, 1])
    assert worst <= 1e-9, worst


def test_dexter_jacobian_matches_finite_differences_of_fk():
    arm = pbd.Robot.from_urdf(None).chain("left/base_link", "left/wrist_palm_link")
    rng = np.random.default_rng(7)
    q = rng.uniform(arm.lower, arm.upper)
    jac = arm.jacobian(q)
    h = 1e-6
    base = arm.fk(q)
    for k in range(arm.dof):
        dq = q.copy()
        dq[k] += h
        moved = arm.fk(dq)
        v = (moved[:3, 3] - base[:3, 3]) / h
        dr = (moved[:3, :3] - base[:3, :3]) / h @ base[:3, :3].T
        w = np.array([dr[2, 1], dr[0, 2], dr[1, 0]])
        assert np.allclose(jac[:3, k], v, atol=1e-5)
        assert np.allclose(jac[3:, k], w, atol=1e-5)


def test_ik_reaches_a_pose_fk_produced():
    arm = pbd.Robot.from_urdf(None).chain("right/base_link", "right/wrist_palm_link")
    q_true = np.array([0.3, -0.4, 0.2, 1.2, -0.5, 0.6, 0.1])
    target = arm.fk(q_true)
    sol = arm.ik(target, seed=1)
    assert sol["converged"], sol
    assert sol["q"].shape == (7,)
    assert np.allclose(arm.fk(sol["q"]), target, atol=1e-4)


def test_inputs_accept_lists_ints_and_arrays():
    arm = pbd.Robot.from_urdf(None).chain("head/base_link", "head/left_camera_optical_frame")
    a = arm.fk([0, 0, 0])
    b = arm.fk(np.zeros(3, dtype=np.int32))
    c = arm.fk(np.zeros(3))
    assert np.array_equal(a, b) and np.array_equal(a, c)
    assert arm.jacobian((0.1, 0.2, 0.3)).shape == (6, 3)


def test_objects_print_usefully():
    robot = pbd.Robot.from_urdf(None)
    assert "dexter" in repr(robot) and "dofs=" in repr(robot)
    arm = robot.chain("left/base_link", "left/wrist_palm_link")
    assert "left/base_link -> left/wrist_palm_link" in repr(arm) and "dof=7" in repr(arm)
    info = robot.info()
    assert any(c["name"] for c in info["named_chains"])


def test_reach_with_manipulability_in_its_null_space_converges():
    arm = pbd.Robot.from_urdf(None).chain("left/base_link", "left/wrist_palm_link")
    q_goal = np.array([0.4, -0.3, 0.2, 1.4, 0.1, 0.3, 0.0])
    target = arm.fk(q_goal)[:3, 3]
    stack = arm.control_stack()
    stack.set_target(target)
    out = stack.run(np.array([0.0, -0.2, 0.0, 1.0, 0.0, 0.2, 0.0]), dt=0.01, steps=800)
    assert out["q"].shape == (801, 7) and out["tip"].shape == (801, 3)
    assert np.linalg.norm(out["tip"][-1] - target) < 1e-3, out["tip"][-1] - target
    assert out["predicates"][0] == "1" and out["converged_at"] is not None
    # Manipulability acts only in Reach's null space: the tip moves as Reach alone asks (3.5)-(3.7).
    du = stack.tick(out["q"][-1], 0.01)
    jac = arm.jacobian(out["q"][-1])
    steps = stack.level_steps
    assert du.shape == (7,) and steps.shape == (2, 7) and np.abs(du - steps[0]).max() > 1e-6
    assert np.abs(jac[:3] @ du - jac[:3] @ steps[0]).max() < 1e-12
    with pytest.raises(pbd.PbdValueError):
        stack.set_target([1.0, 2.0])
    with pytest.raises(pbd.PbdValueError):
        stack.tick(np.zeros(7), -1.0)
