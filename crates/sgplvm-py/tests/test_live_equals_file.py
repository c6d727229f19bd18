"""Live equals file (issue 48): one motion in seven conventions whose rest poses differ — CMU's
own, an Xsens MVN export (T-pose, flat clavicles: the upper arm's twist untold by the rest; the
left hand ends at an End Site only, which a TF tree does not carry), a Bandai Namco layout (every
bone on one line at zero rotation), a Mixamo rig (2.5 times the scale), a DAZ Genesis 8 rig (an
A-pose, twist bones sharing each segment's twist), a Blender Rigify rig (`DEF-` bones, a T-pose,
each arm segment split in two deforming bones, the second twisting) and a Rokoko Studio layout
(the pelvis' first bone along y, every bone above along its own x: the spine folds at rest) — made from a shipped CMU capture by ``bvh_rigs.py`` (BVH written and read independently of
the Rust importer). Each file is imported (``sgplvm import``), and the same frames are streamed
as a tracker and a suit would send them, built here from the BVH's own forward kinematics,
never with the project's ``replay``:

- as ROS 2 TF (Cyclone DDS): every joint's transform in its parent's frame, metres; ``teleop
  --input tf --calibration FILE.mcap`` must command what ``predict --raw`` makes of the imported
  frames, to 1e-6 rad;
- as Xsens MVN type-02 datagrams (the specification's tables, ``mvn_spec.py``): each segment's
  position and its orientation from the capture's rest pose in MVN's axes (x forward, y left,
  z up); ``import --mvn --calibration FILE.mcap`` must record the imported angles to MVN's
  single precision (1e-4 rad).

And one model trained on a capture imported from a rig whose rest leaves the twist untold
carries the calibration: ``teleop`` with that model alone fits the stream through it, with no
seconds of watching. Runs in CI's loopback namespace, as test_teleop.py does."""

import json
import pathlib
import re
import socket
import subprocess
import time

import numpy as np
import pytest

import bvh_rigs
from test_teleop import (  # noqa: F401  (the fixtures `tmp` and `models` are used by name)
    JointState,
    Ros2,
    Teleop,
    TFMessage,
    _quaternion,
    _transform,
    limits,
    models,
    next_domain,
    predict_raw,
    relaxed_urdf,
    stamp_ns,
    tmp,
)

import sgplvm
from _cli import sgplvm_binary

CAPTURE = pathlib.Path(__file__).resolve().parents[3] / "data" / "capture" / "cmu-13_26.bvh"
STYLES = ["cmu", "xsens", "bandai", "mixamo", "daz", "rigify", "rokoko"]
FRAMES = 60
# Frames 600… of the 120 Hz capture, every 3rd: 40 Hz, the import's rate, so that the imported
# frames are the file's (no interpolation between them).
FIRST, STEP, FRAME_TIME = 600, 3, 0.025


class Rig:
    """A convention's BVH, its import and what the import said."""

    def __init__(self, folder, style):
        self.style = style
        self.bvh = bvh_rigs.rerig(bvh_rigs.read(CAPTURE), style, FIRST, FRAMES, STEP)
        self.bvh.frame_time = FRAME_TIME
        self.path = folder / f"{style}.bvh"
        bvh_rigs.write(self.bvh, self.path)
        self.mcap = folder / f"{style}.mcap"
        out = subprocess.run(
            [str(sgplvm_binary()), "import", str(self.path), "--out", str(self.mcap), "--json"],
            capture_output=True, text=True, timeout=120,
        )
        assert out.returncode == 0, out.stderr
        self.report = json.loads(out.stdout)[0]
        assert not self.report["calibration_frame_dropped"], self.report
        self.metres = self.report["calibration"]["metres_per_unit"]
        human = sgplvm.load_demonstrations(self.mcap)
        self.names = list(human["human"]["joint_names"])
        self.rows = np.asarray(human["human"]["positions"])
        self.times_ns = np.asarray(human["times_ns"]).astype(np.int64)
        assert len(self.rows) == FRAMES, (len(self.rows), self.report)
        # The body axes the import found, by the joints it names (left from the right arm's root
        # to the left's, up from the pelvis to the neck), in the file's world at rest.
        m = re.search(r"left from `([^`]+)` to `([^`]+)`.*up from `([^`]+)` to `([^`]+)`", self.report["body_axes"])
        assert m, self.report["body_axes"]
        right, left, pelvis, neck = (self.bvh.index(n) for n in m.groups())
        rest, _ = bvh_rigs.world_rest(self.bvh)
        up = rest[neck] - rest[pelvis]
        up = up / np.linalg.norm(up)
        lv = rest[left] - rest[right]
        lv = lv - up * (lv @ up)
        lv = lv / np.linalg.norm(lv)
        self.axes = np.column_stack([np.cross(lv, up), lv, up])


@pytest.fixture(scope="module")
def rigs(tmp):
    folder = tmp / "rigs"
    folder.mkdir(exist_ok=True)
    return {style: Rig(folder, style) for style in STYLES}


def test_the_rigs_rest_poses_differ(rigs):
    """The conventions are what they claim: each import names its skeleton, the Xsens and
    Bandai rests leave the twist to the elbow's hinge (untold by the rest), CMU's tells it, and
    the Mixamo rig, 2.5 times CMU's scale, is read in units of its own (not "unknown")."""
    twist = {s: [a["twist"]["kind"] for a in r.report["calibration"]["arms"]] for s, r in rigs.items()}
    assert twist["xsens"] == twist["bandai"] == twist["rokoko"] == ["elbow_hinge"] * 2, twist
    # Rokoko's spine folds above the pelvis at rest: up runs along the bones above the fold.
    assert "up from `Spine` to `Neck`" in rigs["rokoko"].report["body_axes"], rigs["rokoko"].report["body_axes"]
    assert twist["cmu"] == ["rest_pose"] * 2, twist
    mixamo, cmu = rigs["mixamo"].report, rigs["cmu"].report
    assert mixamo["units"] != "unknown", mixamo["units"]
    assert mixamo["arm_length"] / mixamo["calibration"]["metres_per_unit"] == pytest.approx(
        2.5 * cmu["arm_length"] / cmu["calibration"]["metres_per_unit"], rel=1e-9
    )
    # The twist-bone rigs are read as their makers name them, each segment split in two.
    for style, scheme in (("daz", "DAZ"), ("rigify", "Rigify")):
        assert scheme in rigs[style].report["skeleton"], rigs[style].report["skeleton"]
        names = {j.name for j in rigs[style].bvh.joints}
        assert set(bvh_rigs.TWIST_BONES[style].values()) <= names, sorted(names)
    # One motion: the rigs' imports agree where the rest tells the twist alike.
    for style in STYLES:
        assert rigs[style].rows.shape == rigs["cmu"].rows.shape


def _tf_messages(rig):
    """Per frame, one TFMessage: every joint of the BVH (props included) in its parent's frame,
    metres; the root in `world`."""
    bvh = rig.bvh
    out = []
    for f, t in enumerate(rig.times_ns):
        transforms = []
        for j, joint in enumerate(bvh.joints):
            p, r = bvh_rigs.local(bvh, f, j)
            parent = "world" if joint.parent is None else bvh.joints[joint.parent].name
            transforms.append(_transform(parent, joint.name, int(t), p * rig.metres, r))
        out.append(TFMessage(transforms))
    return out


def _drive_by_tf(tmp, rig, model, extra):
    """``teleop --input tf`` with `model` (and `extra` arguments) driven by the rig's TF stream:
    the frames it answered and the worst command's distance from ``predict --raw`` on the
    imported frames (within the relaxed URDF's position limits), with the node's log."""
    domain = next_domain()
    urdf = relaxed_urdf(tmp, "coman")
    node = Teleop(tmp, domain, [
        "--model", str(model), "--robot", "coman", "--input", "tf", *extra,
        "--gate", "reconstruction", "--reconstruction-threshold", "1e9", "--margin", "0", "--urdf", f"coman={urdf[0]}",
    ])
    try:
        ros = Ros2(domain)
        w = ros.writer("/tf", TFMessage)
        ros.reader("/coman/joint_command", JointState)
        ros.wait_matched()
        for message in _tf_messages(rig):
            w.write(message)
            time.sleep(0.025)
        commands = ros.take("/coman/joint_command", settle=0.5)
    finally:
        _, err = node.stop()
    joints, raw = predict_raw(tmp, model, "coman", rig.names, rig.rows, rig.times_ns)
    lo, hi, _ = limits(urdf[1], joints)
    index = {int(t): k for k, t in enumerate(rig.times_ns)}
    worst, answered = 0.0, set()
    for c in commands:
        k = index[stamp_ns(c.header.stamp)]
        answered.add(k)
        worst = max(worst, float(np.max(np.abs(np.array(c.position) - np.clip(raw[k], lo, hi)))))
    return answered, worst, err


@pytest.mark.parametrize("style", STYLES)
def test_a_tf_stream_commands_what_the_imported_file_predicts(tmp, models, rigs, style):
    rig = rigs[style]
    answered, worst, err = _drive_by_tf(tmp, rig, models["coman"], ["--calibration", str(rig.mcap)])
    assert len(answered) >= FRAMES - 2, (len(answered), err)
    assert worst <= 1e-6, (style, worst)


def _mvn_datagrams(rig):
    """Per frame, a type-02 datagram: T8 and the arms' segments from the BVH (positions in metres
    and orientations from the capture's rest pose, both in MVN's axes: the body's forward, left
    and up at rest), the other segments standing in MVN's null pose beside them."""
    import mvn_spec

    bvh, b = rig.bvh, rig.axes
    names = bvh_rigs.NAMES.get(rig.style) or {r: n for n, r in bvh_rigs.CMU_ROLES.items()}
    segments = {"T8": names["torso"]}
    for side, s in (("Left", "l"), ("Right", "r")):
        for part, role in (("Shoulder", "clav"), ("UpperArm", "upper"), ("ForeArm", "fore"), ("Hand", "hand")):
            segments[side + part] = names[s + role]
    # Where a segment's twist is shared with a twist bone (DAZ, Rigify), the suit's segment turns as the
    # whole segment: as the twist bone, which ends it.
    twist = {names[r]: t for r, t in bvh_rigs.TWIST_BONES.get(rig.style, {}).items()}
    still = mvn_spec.t_pose()
    out = []
    for f in range(len(rig.times_ns)):
        p, r = bvh_rigs.world(bvh, f)
        poses = {}
        for segment, joint in segments.items():
            j, o = bvh.index(joint), bvh.index(twist.get(joint, joint))
            poses[segment] = (b.T @ p[j] * rig.metres, b.T @ r[o] @ b)
        shift = poses["T8"][0] - np.array(still["T8"][0])
        frame = {n: (tuple(np.array(pos) + shift), q) for n, (pos, q) in still.items()}
        frame.update({n: (tuple(pos), _quaternion(rot)) for n, (pos, rot) in poses.items()})
        out.append(mvn_spec.quaternion_datagram(f + 1, frame, time_code_ms=int(round(f * FRAME_TIME * 1000))))
    return out


def _stderr_until(proc, text):
    """The lines ``proc`` writes to stderr up to the first holding ``text`` (it has ended, or
    never says it, if none does: the assertion shows what it said)."""
    seen = []
    for line in proc.stderr:
        seen.append(line)
        if text in line:
            return "".join(seen)
    proc.wait(timeout=60)
    raise AssertionError(f"it never said {text!r}: {''.join(seen)}")


def _free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


@pytest.mark.parametrize("style", STYLES)
def test_an_mvn_stream_records_the_imported_angles(tmp, rigs, style):
    import mvn_spec

    rig = rigs[style]
    port = _free_port()
    out = tmp / f"mvn_{style}.mcap"
    proc = subprocess.Popen(
        [str(sgplvm_binary()), "import", "--mvn", f"127.0.0.1:{port}", "--calibration", str(rig.mcap),
         "--max-frames", str(FRAMES), "--out", str(out), "--json"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )
    # Sent once the importer listens (a fixed wait lost the stream on a loaded machine).
    started = _stderr_until(proc, "recording the MVN stream")
    for d in _mvn_datagrams(rig):
        mvn_spec.send([d], port=port)
        time.sleep(0.005)
    stdout, stderr = proc.communicate(timeout=60)
    stderr = started + stderr
    assert proc.returncode == 0, stderr
    recorded = sgplvm.load_demonstrations(out)["human"]
    order = [recorded["joint_names"].index(n) for n in rig.names]
    angles = np.asarray(recorded["positions"])[:, order]
    assert angles.shape == rig.rows.shape, (angles.shape, stderr)
    worst = float(np.max(np.abs(angles - rig.rows)))
    assert worst <= 1e-4, (style, worst)


def test_a_model_carries_its_capture_s_calibration_to_the_stream(tmp, rigs):
    """Xsens' T-pose leaves the twist untold: a stream alone would watch the elbows first. A
    model trained on the import of that file carries the file's calibration, and teleop with it
    (no --calibration, no watching) commands at once what predict makes of the file."""
    rig = rigs["xsens"]
    binary = str(sgplvm_binary())
    demos, model = tmp / "xsens_demos.mcap", tmp / "xsens.sgp"
    for args in (
        ["retarget", "--demos", str(rig.mcap), "--robots", "coman", "--out", str(demos)],
        ["train", "--data", str(demos), "--robot", "coman", "--max-iters", "30", "--out", str(model)],
    ):
        out = subprocess.run([binary, *args], capture_output=True, text=True, timeout=300)
        assert out.returncode == 0, (args, out.stderr)
    answered, worst, err = _drive_by_tf(tmp, rig, model, [])
    # From the first frames on: no seconds spent watching the elbows.
    assert min(answered) <= 1 and len(answered) >= FRAMES - 2, (sorted(answered)[:5], err)
    assert worst <= 1e-6, worst
