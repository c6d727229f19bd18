"""Robots from Python: the shipped bodies, URDF files, forward kinematics against Pinocchio."""

import numpy as np
import pytest

import sgplvm

ROBOTS = {"walkman": 14, "coman": 14, "centauro": 14, "ur5e": 12, "human": 18}


@pytest.mark.parametrize("name,dof", ROBOTS.items())
def test_builtin_bodies(name, dof):
    robot = sgplvm.Robot.builtin(name)
    assert len(robot.joint_names) == dof
    limits = np.asarray(robot.joint_limits)
    assert limits.shape == (dof, 2) and np.all(limits[:, 0] <= limits[:, 1])
    # Left arm first, then right.
    left = robot.joint_names[: dof // 2]
    right = robot.joint_names[dof // 2 :]
    assert len(set(left) & set(right)) == 0
    pose = robot.forward_kinematics(np.zeros(dof), robot.link_names[-1])
    assert pose.shape == (4, 4)
    np.testing.assert_allclose(pose[3], [0, 0, 0, 1])
    np.testing.assert_allclose(pose[:3, :3] @ pose[:3, :3].T, np.eye(3), atol=1e-12)


def test_unknown_names_raise():
    with pytest.raises(ValueError, match="(?i)walkman"):
        sgplvm.Robot.builtin("r2d2")
    robot = sgplvm.Robot.builtin("coman")
    with pytest.raises(ValueError, match="nolink"):
        robot.forward_kinematics(np.zeros(14), "nolink")
    with pytest.raises(ValueError, match="14"):
        robot.forward_kinematics(np.zeros(3), robot.link_names[-1])


def test_from_urdf_and_errors(tmp_path):
    urdf = tmp_path / "arm.urdf"
    urdf.write_text(
        """<robot name="arm">
  <link name="base"/><link name="upper"/><link name="tip"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="upper"/>
    <origin xyz="0 0 0.5"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
  <joint name="j2" type="fixed"><parent link="upper"/><child link="tip"/><origin xyz="1 0 0"/></joint>
</robot>"""
    )
    robot = sgplvm.Robot.from_urdf(str(urdf))
    assert robot.joint_names == ["j1"]
    pose = robot.forward_kinematics([np.pi / 2], "tip")
    np.testing.assert_allclose(pose[:3, 3], [0, 1, 0.5], atol=1e-12)
    bad = tmp_path / "bad.urdf"
    bad.write_text("<robot name='x'><link name='a'/><joint name='j' type='revolute'>")
    with pytest.raises(ValueError, match="bad.urdf"):
        sgplvm.Robot.from_urdf(str(bad))
    with pytest.raises((OSError, ValueError), match="missing.urdf"):
        sgplvm.Robot.from_urdf(str(tmp_path / "missing.urdf"))


@pytest.mark.parametrize("name", list(ROBOTS))
def test_forward_kinematics_matches_pinocchio(name, tmp_path):
    pin = pytest.importorskip("pinocchio")
    robot = sgplvm.Robot.builtin(name)
    path = tmp_path / f"{name}.urdf"
    path.write_text(sgplvm.Robot.builtin_urdf(name))
    model = pin.buildModelFromUrdf(str(path))
    data = model.createData()
    rng = np.random.default_rng(0)
    limits = np.asarray(robot.joint_limits)
    for _ in range(5):
        q = rng.uniform(limits[:, 0], limits[:, 1])
        q_pin = pin.neutral(model)
        for joint_name, value in zip(robot.joint_names, q):
            jid = model.getJointId(joint_name)
            q_pin[model.joints[jid].idx_q] = value
        pin.forwardKinematics(model, data, q_pin)
        pin.updateFramePlacements(model, data)
        for link in robot.link_names:
            fid = model.getFrameId(link)
            if fid >= len(model.frames):
                continue
            expected = data.oMf[fid].homogeneous
            np.testing.assert_allclose(robot.forward_kinematics(q, link), expected, atol=1e-9)
