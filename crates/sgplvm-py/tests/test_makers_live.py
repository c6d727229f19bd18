"""``teleop`` on robots of makers not shipped here, as example-robot-data carries them (issue 51):
for each, a model trained the guides' way on a short capture (``retarget`` then ``train``, no
flag), then ``teleop --urdf NAME=FILE`` fed the capture's human frames as JointState by Cyclone DDS
— every frame answered with a command naming the robot's command joints, within its URDF's
position limits — and ``teleop --retarget`` (no model) likewise. Runs in CI's loopback namespace
with test_teleop.py."""

import xml.etree.ElementTree as ET

import numpy as np
import pytest

from test_makers_robots import ROBOTS, capture, cli, urdf  # noqa: F401  (`capture` is a fixture)
from test_teleop import JointState, Ros2, Teleop, next_domain, send, tmp  # noqa: F401

import sgplvm

FRAMES = 80


def position_limits(path, names):
    """Each joint's (lower, upper) read from the URDF by hand; continuous joints unbounded."""
    joints = {j.get("name"): j for j in ET.parse(path).getroot().iter("joint")}
    out = []
    for n in names:
        j = joints[n]
        limit = j.find("limit")
        if j.get("type") == "continuous" or limit is None or limit.get("lower") is None:
            out.append((-np.inf, np.inf))
        else:
            out.append((float(limit.get("lower")), float(limit.get("upper"))))
    return np.array(out)


@pytest.mark.parametrize("name", sorted(ROBOTS))
def test_a_maker_s_robot_is_driven_live_as_published(name, capture, tmp):
    path = urdf(name)
    folder = tmp / f"makers-{name}"
    folder.mkdir(exist_ok=True)
    cli("retarget", "--demos", capture, "--urdf", path, "--robot", name, "--out", folder / "demos.mcap", cwd=folder)
    cli("train", "--data", folder / "demos.mcap", "--robot", name, "--out", folder / "m.sgp", cwd=folder)
    human = sgplvm.load_demonstrations(capture)
    names = list(human["human"]["joint_names"])
    rows = np.asarray(human["human"]["positions"])[:FRAMES]
    times = np.asarray(human["times_ns"])[:FRAMES]
    for how in (["--model", str(folder / "m.sgp")], ["--retarget"]):
        domain = next_domain()
        node = Teleop(folder, domain, [*how, "--robot", name, "--urdf", f"{name}={path}", "--gate", "reconstruction", "--reconstruction-threshold", "1e9"])
        try:
            ros = Ros2(domain)
            w = ros.writer("/human/joint_states", JointState)
            ros.reader(f"/{name}/joint_command", JointState)
            ros.wait_matched()
            send(w, names, rows, times)
            commands = ros.take(f"/{name}/joint_command", settle=0.5)
        finally:
            summary, err = node.stop()
        assert len(commands) >= 0.9 * FRAMES, (how, len(commands), err)
        limits = position_limits(path, commands[0].name)
        q = np.array([c.position for c in commands])
        assert np.all(q >= limits[:, 0] - 1e-9) and np.all(q <= limits[:, 1] + 1e-9), (how, err)
        assert summary["robots"][name]["stale"] <= 1, (how, summary)
