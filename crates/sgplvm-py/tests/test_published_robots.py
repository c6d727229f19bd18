"""Robots as their makers publish them, from Python: Unitree's G1 (a 3-joint waist, legs),
Rethink's Baxter (arms on 45° mounts, grippers with a mimic joint) and iCub (a root frame with
x backward and y right), shipped in data/urdf/published; PAL's
TALOS (a 2-joint torso, gripper mimic joints, an arm joint whose limits exclude 0) from the
``example-robot-data`` wheel. Each is read with no edit, retargeted and, for one, trained and
predicted; forward kinematics are checked against Pinocchio."""

import pathlib

import numpy as np
import pytest

import sgplvm

ROOT = pathlib.Path(__file__).resolve().parents[3]
PUBLISHED = ROOT / "data" / "urdf" / "published"
DEMOS = ROOT / "data" / "demos" / "bimanual.mcap"


def human_frames(count=400):
    demo = sgplvm.load_demonstrations(DEMOS)
    return demo["human"]["positions"][:count], demo["times_ns"][:count]


def example_robot_data():
    """The share folder of the ``example-robot-data`` wheel (its robots under
    ``example-robot-data/robots``, found by ``package://example-robot-data/...``)."""
    import importlib.metadata

    try:
        dist = importlib.metadata.distribution("example-robot-data")
    except importlib.metadata.PackageNotFoundError:
        pytest.skip("example-robot-data is not installed (pip install example-robot-data)")
    return pathlib.Path(dist.locate_file("cmeel.prefix/share"))


def talos_urdf():
    path = example_robot_data() / "example-robot-data" / "robots" / "talos_data" / "robots" / "talos_full_v2.urdf"
    if not path.is_file():
        pytest.skip(f"example-robot-data has no TALOS at {path}")
    return path


@pytest.mark.parametrize(
    "file,torso,left_first,held",
    [
        ("g1_29dof.urdf", "torso_link", "left_shoulder_pitch_joint", 15),
        ("baxter.urdf", "torso", "left_s0", 5),
        ("icub.urdf", "chest", "l_shoulder_pitch", 18),
    ],
)
def test_anatomy_found_without_editing(file, torso, left_first, held):
    robot = sgplvm.Robot.from_urdf(PUBLISHED / file)
    a = robot.anatomy
    assert a["torso_link"] == torso
    assert a["arms"][0]["side"] == "left" and a["arms"][0]["joints"][0] == left_first
    assert len(a["held"]) == held
    assert robot.command_joint_names == a["arms"][0]["joints"] + a["arms"][1]["joints"]
    assert "arms:" in robot.summary()
    forward, left, up = np.asarray(a["body_axes_in_root"])
    assert abs(np.dot(forward, left)) < 1e-9 and abs(np.dot(left, up)) < 1e-9
    if file == "icub.urdf":  # root x backward, y right
        np.testing.assert_allclose(forward, [-1, 0, 0], atol=1e-3)
        np.testing.assert_allclose(left, [0, -1, 0], atol=1e-3)


def test_arms_and_holds_given_in_python_and_kept_in_a_description_file(tmp_path):
    urdf = tmp_path / "g1.urdf"
    urdf.write_bytes((PUBLISHED / "g1_29dof.urdf").read_bytes())
    robot = sgplvm.Robot.from_urdf(
        urdf,
        arms={"left": ("torso_link", "left_wrist_yaw_link"), "right": ("torso_link", "right_wrist_yaw_link")},
        hold={"waist_yaw_joint": 0.3},
        command_joints="all",
    )
    held = dict(robot.held_joints)
    assert held["waist_yaw_joint"] == 0.3
    assert len(robot.command_joint_names) == 29
    (tmp_path / "g1.anatomy.json").write_text(robot.description())
    again = sgplvm.Robot.from_urdf(urdf)
    assert dict(again.held_joints)["waist_yaw_joint"] == 0.3
    assert again.anatomy["arms"][0]["to"] == "left_wrist_yaw_link"
    with pytest.raises(ValueError, match="share the movable joint"):
        sgplvm.Robot.from_urdf(urdf, arms={"left": ("pelvis", "left_rubber_hand"), "right": ("pelvis", "right_rubber_hand")})
    with pytest.raises(ValueError, match='"nowhere"'):
        sgplvm.Robot.from_urdf(urdf, arms={"left": ("torso_link", "nowhere"), "right": ("torso_link", "right_rubber_hand")})
    with pytest.raises(ValueError, match="outside the joint's limits"):
        sgplvm.Robot.from_urdf(urdf, hold={"waist_roll_joint": 3.0})
    # A single arm (KUKA's iiwa): one arm, driven by the person's right arm, in the root's frame.
    kuka = sgplvm.Robot.from_urdf(ROOT / "crates" / "sgplvm-robots" / "tests" / "fixtures" / "kuka_iiwa.urdf")
    assert len(kuka.joint_names) == 7
    arms = kuka.anatomy["arms"]
    assert [a["side"] for a in arms] == ["right"] and len(arms[0]["joints"]) == 7, arms
    assert kuka.anatomy["shoulder_width_m"] is None
    # It stands on its base and cannot hang: the person's arm is rolled out 90° to drive it,
    # unless told otherwise.
    assert kuka.anatomy["mount"]["why"] == "cannot_hang" and kuka.anatomy["mount"]["roll_deg"] == 90.0
    kuka_path = ROOT / "crates" / "sgplvm-robots" / "tests" / "fixtures" / "kuka_iiwa.urdf"
    as_is = sgplvm.Robot.from_urdf(kuka_path, mount_roll_deg=0.0)
    assert as_is.anatomy["mount"] == {"roll_deg": 0.0, "why": "given"}
    with pytest.raises(ValueError, match="mount_roll_deg"):
        sgplvm.Robot.from_urdf(kuka_path, mount_roll_deg=400.0)
    # A body with no arm at all has no anatomy, but still its kinematics.
    stick = tmp_path / "stick.urdf"
    stick.write_text(
        '<robot name="stick"><link name="a"/><link name="b"/><joint name="j" type="revolute">'
        '<parent link="a"/><child link="b"/><axis xyz="0 0 1"/>'
        '<limit lower="-1" upper="1" velocity="1" effort="1"/></joint></robot>'
    )
    assert sgplvm.Robot.from_urdf(stick).joint_names == ["j"]
    with pytest.raises(ValueError, match="cannot tell the robot's arms"):
        sgplvm.Robot.from_urdf(stick).anatomy


def test_g1_forward_kinematics_equal_pinocchio():
    pin = pytest.importorskip("pinocchio")
    path = PUBLISHED / "g1_29dof.urdf"
    robot = sgplvm.Robot.from_urdf(path)
    model = pin.buildModelFromUrdf(str(path))
    data = model.createData()
    rng = np.random.default_rng(0)
    limits = np.asarray(robot.joint_limits)
    for _ in range(5):
        q = rng.uniform(limits[:, 0], limits[:, 1])
        qp = pin.neutral(model)
        for name, value in zip(robot.joint_names, q):
            jid = model.getJointId(name)
            qp[model.idx_qs[jid]] = value
        pin.forwardKinematics(model, data, qp)
        pin.updateFramePlacements(model, data)
        for link in ["left_rubber_hand", "right_rubber_hand", "torso_link"]:
            want = data.oMf[model.getFrameId(link)].homogeneous
            np.testing.assert_allclose(robot.forward_kinematics(q, link), want, atol=1e-9)


def reached_fraction(report):
    return report["reached"] / report["targets"]


def test_retarget_numpy_holds_the_waist_and_reaches_what_is_reachable():
    human, times = human_frames()
    g1 = sgplvm.Robot.from_urdf(PUBLISHED / "g1_29dof.urdf", hold={"waist_pitch_joint": 0.1}, command_joints="all")
    out = sgplvm.retarget({"g1": g1, "coman": "coman"}, human, times, match="hands")
    r = out["g1"]
    names = r["joint_names"]
    assert len(names) == 29 and r["positions"].shape == (len(times), 29)
    # Held joints exactly at their hold values in every frame.
    for name, value in g1.held_joints:
        np.testing.assert_array_equal(r["positions"][:, names.index(name)], value)
    # Every target counted reached is within 5 mm, measured here with the robot's own FK.
    rep = r["report"]
    assert rep["unreachable"] + rep["velocity_limited"] + rep["other_configuration"] + rep["reached"] == rep["targets"]
    assert rep["worst_m"] <= 0.005
    assert reached_fraction(rep) > 0.95, rep
    assert out["coman"]["joint_names"][0] == "LShSag"
    with pytest.raises(ValueError, match="18"):
        sgplvm.retarget(["coman"], human[:, :5], times)
    with pytest.raises(ValueError, match="times_ns"):
        sgplvm.retarget(["coman"], human)


def test_talos_two_joint_torso_and_gripper_mimics_held():
    path = talos_urdf()
    robot = sgplvm.Robot.from_urdf(path)
    a = robot.anatomy
    held = dict(robot.held_joints)
    assert {"torso_1_joint", "torso_2_joint", "gripper_left_joint", "gripper_left_inner_double_joint"} <= set(held)
    assert a["arms"][0]["joints"] == [f"arm_left_{k}_joint" for k in range(1, 8)]
    human, times = human_frames(200)
    rep = sgplvm.retarget({"talos": robot}, human, times, match="hands")["talos"]["report"]
    assert rep["worst_m"] is None or rep["worst_m"] <= 0.005
    assert reached_fraction(rep) > 0.8, rep
    # Whole-arm (the default): the person's arm posture.
    posture = sgplvm.retarget({"talos": robot}, human, times)["talos"]["report"]["posture"]
    assert posture["upper_arm_deg"][0] < 10 and posture["forearm_deg"][0] < 10, posture


def test_retarget_to_a_file_then_train_and_predict_a_published_robot(tmp_path):
    out = tmp_path / "g1-demos.mcap"
    g1 = sgplvm.Robot.from_urdf(PUBLISHED / "g1_29dof.urdf")
    report = sgplvm.retarget({"g1": g1}, demos=DEMOS, out=out)
    assert report["split"]["test_frames"] > 0 and report["reach"][0]["robot"] == "g1"
    demo = sgplvm.load_demonstrations(out)
    train, test = demo["train"], demo["test"]
    R = demo["robots"]["g1"]
    assert R["joint_names"] == g1.command_joint_names
    m = sgplvm.SharedGPLVM(latent_dim=3, back_constraint="input", seed=0)
    m.fit(
        {"human": demo["human"]["positions"][train], "g1": R["positions"][train]},
        input="human",
        max_iters=30,
        validation=None,
        column_names={"human": demo["human"]["joint_names"], "g1": R["joint_names"]},
    )
    pred = m.predict(demo["human"]["positions"][test], robot="g1")
    assert pred.shape == (len(test), 14)
    direct = np.mean((R["positions"][test] - R["positions"][train].mean(0)) ** 2)
    assert np.mean((pred - R["positions"][test]) ** 2) < direct
