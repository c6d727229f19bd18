"""MCAP files that open in Foxglove with the bodies animated (issue 16), read back with the
independent ``mcap`` / ``mcap-ros2-support`` readers: every transform equals Pinocchio's forward
kinematics from the same joint values and URDF, the URDF of each description topic parses with
Pinocchio and urdf-rs and names the joints of the JointState topic, and schema names, encodings
and stamps are those ROS 2 writes. The CLI is tested too (``predict --out x.mcap``, from a file
and streamed from stdin, also killed mid-stream) when its binary is built."""

import json
import pathlib
import subprocess
import time

import numpy as np
import pytest

import sgplvm
from _cli import sgplvm_binary

pin = pytest.importorskip("pinocchio")
mcap_reader = pytest.importorskip("mcap.reader")
mcap_ros2_reader = pytest.importorskip("mcap_ros2.reader")
from mcap_ros2.decoder import DecoderFactory  # noqa: E402

ROOT = pathlib.Path(__file__).resolve().parents[3]
DEMOS = ROOT / "data" / "demos" / "bimanual.mcap"
TF_DEPS = ["geometry_msgs/TransformStamped", "std_msgs/Header", "builtin_interfaces/Time",
           "geometry_msgs/Transform", "geometry_msgs/Vector3", "geometry_msgs/Quaternion"]


def iso(t):
    """4×4 matrix of a geometry_msgs/Transform."""
    q = t.rotation
    m = np.eye(4)
    m[:3, :3] = pin.Quaternion(q.w, q.x, q.y, q.z).toRotationMatrix()
    m[:3, 3] = [t.translation.x, t.translation.y, t.translation.z]
    return m


def read_scene(path):
    """Everything in a scene file, by topic: list of (log_time, stamp_ns, message)."""
    out = {}
    for m in mcap_ros2_reader.read_ros2_messages(str(path)):
        stamp = None
        if hasattr(m.ros_msg, "header"):
            stamp = m.ros_msg.header.stamp.sec * 10**9 + m.ros_msg.header.stamp.nanosec
        out.setdefault(m.channel.topic, []).append((m.log_time_ns, stamp, m.ros_msg))
    return out


def world_poses(static, dynamic):
    """Poses in ``world`` of every frame of one TF tree (static + one /tf message)."""
    parent = {}
    for msg in static + dynamic:
        for t in msg.transforms:
            parent[t.child_frame_id] = (t.header.frame_id, iso(t.transform))

    def pose(frame):
        if frame == "world":
            return np.eye(4)
        p, m = parent[frame]
        return pose(p) @ m

    return {f: pose(f) for f in parent}


def pinocchio_poses(urdf_text, names, values):
    """Pose of every link frame (root frame) from Pinocchio, for joint values by name."""
    model = pin.buildModelFromXML(urdf_text)
    data = model.createData()
    q = pin.neutral(model)
    for n, v in zip(names, values):
        q[model.joints[model.getJointId(n)].idx_q] = v
    pin.framesForwardKinematics(model, data, q)
    return {f.name: data.oMf[i].homogeneous for i, f in enumerate(model.frames)
            if f.type == pin.FrameType.BODY}


def check_transforms(scene, bodies, placements):
    """Every link of every body at every frame equals placement × Pinocchio FK, to 1e-9."""
    static = [m for _, _, m in scene["/tf_static"]]
    tfs = scene["/tf"]
    descriptions = {b: scene[f"/{b}/robot_description"][0][2].data for b in bodies}
    checked = 0
    for k, (t, stamp, tf) in enumerate(tfs):
        assert all(x.header.stamp.sec * 10**9 + x.header.stamp.nanosec == t for x in tf.transforms)
        poses = world_poses(static, [tf])
        for body, topic in bodies.items():
            _, _, js = scene[topic][k]
            ref = pinocchio_poses(descriptions[body], list(js.name), list(js.position))
            assert len(ref) >= 8
            for link, m in ref.items():
                assert link.startswith(f"{body}/")
                np.testing.assert_allclose(poses[link], placements[body] @ m, rtol=0, atol=1e-9,
                                           err_msg=f"{link} at frame {k}")
                checked += 1
    return checked


def check_schemas(path):
    with open(path, "rb") as f:
        reader = mcap_reader.make_reader(f)
        header = reader.get_header()
        summary = reader.get_summary()
    assert header.profile == "ros2"
    schemas = {s.id: s for s in summary.schemas.values()}
    by_topic = {}
    for c in summary.channels.values():
        s = schemas[c.schema_id]
        assert c.message_encoding == "cdr" and s.encoding == "ros2msg"
        by_topic[c.topic] = (s.name, s.data.decode())
    name, text = by_topic["/tf"]
    assert name == "tf2_msgs/msg/TFMessage"
    assert text.startswith("geometry_msgs/TransformStamped[] transforms\n")
    for dep in TF_DEPS:
        assert f"\n{'=' * 80}\nMSG: {dep}\n" in text
    assert by_topic["/tf_static"][0] == "tf2_msgs/msg/TFMessage"
    return by_topic


@pytest.mark.parametrize("robot", ["coman", "human", "walkman"])
def test_write_joint_states_with_a_robot_writes_tf_equal_to_pinocchio(tmp_path, robot):
    r = sgplvm.Robot.builtin(robot)
    rng = np.random.default_rng(7)
    lo, hi = np.array(r.joint_limits).T
    n = 6
    q = lo + (hi - lo) * rng.random((n, len(lo)))
    times = 1_700_000_000_000_000_000 + np.arange(n, dtype=np.int64) * 25_000_000
    path = tmp_path / f"{robot}.mcap"
    sgplvm.write_joint_states(path, f"/{robot}/joint_command", times, r.joint_names, q, robot=robot)
    by_topic = check_schemas(path)
    assert by_topic[f"/{robot}/robot_description"][0] == "std_msgs/msg/String"
    scene = read_scene(path)
    assert [t for t, _, _ in scene["/tf"]] == list(times)
    assert scene["/tf_static"][0][0] == times[0]
    checked = check_transforms(scene, {robot: f"/{robot}/joint_command"}, {robot: np.eye(4)})
    assert checked >= n * 8
    # The description names the joints of the JointState topic, for Pinocchio and for urdf-rs.
    urdf = scene[f"/{robot}/robot_description"][0][2].data
    model = pin.buildModelFromXML(urdf)
    assert list(model.names)[1:] == r.joint_names
    file = tmp_path / "description.urdf"
    file.write_text(urdf)
    assert sgplvm.Robot.from_urdf(file).joint_names == r.joint_names
    # Without `robot`, the file holds the joint states only (as before).
    plain = tmp_path / "plain.mcap"
    sgplvm.write_joint_states(plain, "/j", times, r.joint_names, q)
    assert set(read_scene(plain)) == {"/j"}


def test_a_wrong_transform_is_caught(tmp_path):
    # The check must be able to fail: shift one joint value in the file's reading.
    r = sgplvm.Robot.builtin("coman")
    q = np.zeros((2, len(r.joint_names)))
    q[:, 3] = -1.0
    times = np.array([0, 25_000_000], dtype=np.int64)
    path = tmp_path / "c.mcap"
    sgplvm.write_joint_states(path, "/c", times, r.joint_names, q, robot="coman")
    scene = read_scene(path)
    scene["/c"][1][2].position[3] = -1.001
    with pytest.raises(AssertionError):
        check_transforms(scene, {"coman": "/c"}, {"coman": np.eye(4)})


def test_unknown_robot_or_joint_is_a_value_error(tmp_path):
    times = np.array([0], dtype=np.int64)
    with pytest.raises(ValueError, match="nobody"):
        sgplvm.write_joint_states(tmp_path / "x.mcap", "/x", times, ["a"], [[0.0]], robot="nobody")
    with pytest.raises(ValueError, match="`a`"):
        sgplvm.write_joint_states(tmp_path / "x.mcap", "/x", times, ["a"], [[0.0]], robot="coman")
    assert not (tmp_path / "x.mcap").exists()


@pytest.fixture(scope="module")
def model_file(tmp_path_factory):
    demo = sgplvm.load_demonstrations(DEMOS)
    idx = demo["train"][::20]
    human = demo["human"]["positions"][idx]
    coman = demo["robots"]["coman"]["positions"][idx]
    names = {"human": demo["human"]["joint_names"], "coman": demo["robots"]["coman"]["joint_names"]}
    m = sgplvm.SharedGPLVM().fit({"human": human, "coman": coman}, max_iters=30,
                                 column_names=names, validation=None)
    path = tmp_path_factory.mktemp("model") / "coman.sgp"
    m.save(path)
    return path, demo


def seconds(demo, k):
    return float(demo["times_ns"][k]) / 1e9


def stamp_ns(demo, k):
    """The stamp predict gives a CSV time in seconds (the same double arithmetic)."""
    return round(seconds(demo, k) * 1e9)


def human_csv_lines(demo, frames):
    names = demo["human"]["joint_names"]
    lines = ["time," + ",".join(names)]
    for k in frames:
        values = ",".join(repr(float(v)) for v in demo["human"]["positions"][k])
        lines.append(f"{seconds(demo, k)!r},{values}")
    return lines


HUMAN_AT = np.array([[1, 0, 0, 0], [0, 1, 0, 0.6], [0, 0, 1, 0], [0, 0, 0, 1.0]])
ROBOT_AT = np.array([[1, 0, 0, 0], [0, 1, 0, -0.6], [0, 0, 1, 0], [0, 0, 0, 1.0]])
BODIES = {"human": "/human/joint_states", "coman": "/coman/joint_command"}


def check_placements(scene):
    """The two bodies stand side by side (human left, robot right), as docs/live.md says."""
    placed = {t.child_frame_id.split("/")[0]: iso(t.transform)
              for t in scene["/tf_static"][0][2].transforms if t.header.frame_id == "world"}
    np.testing.assert_array_equal(placed["human"], HUMAN_AT)
    np.testing.assert_array_equal(placed["coman"], ROBOT_AT)


def test_cli_predict_to_mcap_draws_both_bodies_as_pinocchio_does(tmp_path, model_file):
    binary = sgplvm_binary()
    model, demo = model_file
    out = tmp_path / "pred.mcap"
    subprocess.run([str(binary), "predict", "--model", str(model), "--input", str(DEMOS),
                    "--robot", "coman", "--out", str(out)], check=True, capture_output=True)
    scene = read_scene(out)
    n = len(demo["times_ns"])
    for topic in ["/tf", "/latent", "/coman/joint_command"]:
        assert len(scene[topic]) == n
    # Checking every frame against Pinocchio takes long: a slice of the file.
    sub = {k: (v[::500] if len(v) == n else v) for k, v in scene.items()}
    assert check_transforms(sub, BODIES, {"human": HUMAN_AT, "coman": ROBOT_AT}) > 100
    check_placements(scene)
    # Every topic the shipped Foxglove layout shows is in the file.
    layout = json.loads((ROOT / "data" / "foxglove" / "sgplvm.json").read_text())
    shown = set()
    for panel in layout["configById"].values():
        shown |= {layer["topic"] for layer in panel.get("layers", {}).values() if "topic" in layer}
        shown |= {p["value"].split(".")[0] for p in panel.get("paths", [])}
    assert shown and shown <= set(scene), shown - set(scene)
    assert all(np.all(np.array(m.data) > 0) for _, _, m in scene["/coman/prediction_std"])
    assert len({len(m.data) for _, _, m in scene["/latent"]}) == 1
    no_tf = tmp_path / "plain.mcap"
    subprocess.run([str(binary), "predict", "--model", str(model), "--input", str(DEMOS),
                    "--robot", "coman", "--out", str(no_tf), "--no-tf"], check=True, capture_output=True)
    assert set(read_scene(no_tf)) == {"/coman/joint_command"}


def test_cli_streaming_to_mcap_is_complete_after_input_ends(tmp_path, model_file):
    binary = sgplvm_binary()
    model, demo = model_file
    out = tmp_path / "stream.mcap"
    lines = human_csv_lines(demo, range(0, 200, 10))
    subprocess.run([str(binary), "predict", "--model", str(model), "--input", "-", "--robot", "coman",
                    "--out", str(out)], input="\n".join(lines) + "\n", text=True, check=True,
                   capture_output=True)
    check_schemas(out)
    scene = read_scene(out)
    assert [t for t, _, _ in scene["/tf"]] == [stamp_ns(demo, k) for k in range(0, 200, 10)]
    assert check_transforms(scene, BODIES, {"human": HUMAN_AT, "coman": ROBOT_AT}) > 100


def read_until_truncation(path):
    """Messages of a file without summary or footer, record by record up to the cut one."""
    from mcap.records import Channel, Message, Schema
    from mcap.stream_reader import StreamReader

    schemas, channels, decoders, topics = {}, {}, {}, {}
    factory = DecoderFactory()
    truncated = None
    with open(path, "rb") as f:
        try:
            for record in StreamReader(f, skip_magic=False).records:
                if isinstance(record, Schema):
                    schemas[record.id] = record
                elif isinstance(record, Channel):
                    channels[record.id] = record
                elif isinstance(record, Message):
                    channel = channels[record.channel_id]
                    schema = schemas[channel.schema_id]
                    if channel.id not in decoders:
                        decoders[channel.id] = factory.decoder_for(channel.message_encoding, schema)
                    decoded = decoders[channel.id](record.data)
                    topics.setdefault(channel.topic, []).append((record.log_time, decoded))
        except Exception as e:  # the cut record: EndOfFile or a bad record length
            truncated = type(e).__name__
    return topics, truncated


def test_cli_streaming_killed_mid_stream_leaves_a_file_readable_to_its_last_frame(tmp_path, model_file):
    binary = sgplvm_binary()
    model, demo = model_file
    out = tmp_path / "killed.mcap"
    lines = human_csv_lines(demo, range(0, 400, 10))
    child = subprocess.Popen([str(binary), "predict", "--model", str(model), "--input", "-",
                              "--robot", "coman", "--out", str(out)],
                             stdin=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    sent = 12
    child.stdin.write("\n".join(lines[: 1 + sent]) + "\n")
    child.stdin.flush()
    # Wait (without a wall-clock assertion) until the frames are on disk, then kill.
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        topics, _ = read_until_truncation(out) if out.exists() else ({}, None)
        if len(topics.get("/tf", [])) == sent:
            break
        time.sleep(0.05)
    child.kill()
    child.wait()
    topics, truncated = read_until_truncation(out)
    assert truncated is not None  # no footer: the process never finished the file
    assert len(topics["/tf"]) == sent
    assert len(topics["/coman/joint_command"]) == sent
    assert len(topics["/human/robot_description"]) == 1
    stamps = [t for t, _ in topics["/tf"]]
    assert stamps == [stamp_ns(demo, k) for k in range(0, 10 * sent, 10)]


def coman_reach_csv(path):
    """Two seconds at 40 Hz of COMAN's left arm swung across its chest: the shoulder roll
    commanded 0.29 rad past its lower limit and the elbow bent into the torso."""
    left = ["LShSag", "LShLat", "LShYaw", "LElbj", "LForearmPlate", "LWrj1", "LWrj2"]
    right = ["R" + n[1:] for n in left]
    t = np.arange(81) * 0.025
    s = np.sin(np.pi * t / 2)
    q = np.zeros((len(t), 14))
    q[:, :4] = np.outer(s, [-0.3, -0.6, 1.2, -2.2])
    lines = ["time," + ",".join(left + right)]
    lines += [",".join(repr(float(v)) for v in [ti, *row]) for ti, row in zip(t, q)]
    path.write_text("\n".join(lines) + "\n")
    return left + right, t, q


def test_cli_simulate_to_mcap_draws_the_simulated_robot_and_its_events(tmp_path):
    binary = sgplvm_binary()
    names, t, q = coman_reach_csv(tmp_path / "reach.csv")
    out = tmp_path / "replay.mcap"
    done = subprocess.run([str(binary), "simulate", "--robot", "coman", "--trajectory",
                           str(tmp_path / "reach.csv"), "--json", "--out", str(out)],
                          check=True, capture_output=True, text=True)
    report = json.loads(done.stdout)
    scene = read_scene(out)
    by_topic = check_schemas(out)
    assert by_topic["/coman/events"][0] == "visualization_msgs/msg/MarkerArray"
    assert by_topic["/coman/joint_command"][0] == "sensor_msgs/msg/JointState"
    events_text = by_topic["/coman/events"][1]
    assert events_text.startswith("Marker[] markers\n")
    assert f"\n{'=' * 80}\nMSG: visualization_msgs/Marker\n" in events_text
    # The commanded joints as given, the simulated ones at the same stamps.
    command = scene["/coman/joint_command"]
    assert [m.name for _, _, m in command[:1]] == [names]
    np.testing.assert_array_equal([m.position for _, _, m in command], q)
    stamps = [round(x * 1e9) for x in t]
    assert [s for _, s, _ in command] == stamps
    assert [s for _, s, _ in scene["/coman/joint_states"]] == stamps
    # The robot drawn by /tf is the simulated one, link for link as Pinocchio has it.
    simulated = np.array([m.position for _, _, m in scene["/coman/joint_states"]])
    assert np.abs(simulated - q).max() > 0.05  # the torso and the limit stop the arm
    assert check_transforms(scene, {"coman": "/coman/joint_states"}, {"coman": np.eye(4)}) > 1000
    # One marker array per event, at its start, lasting as long as it does.
    events = scene["/coman/events"]
    kinds = {"joint_limit": "limit_violations", "velocity_limit": "velocity_violations",
             "collision": "collisions"}
    assert report["collisions"] and report["limit_violations"]
    assert len(events) == sum(len(report[k]) for k in kinds.values())
    seen = {k: [] for k in kinds}
    for log_time, _, msg in events:
        sphere, label = msg.markers
        assert (sphere.type, label.type) == (2, 9) and sphere.action == 0
        assert label.ns == sphere.ns + "_label" and label.id == sphere.id and label.text
        assert sphere.header.stamp.sec * 10**9 + sphere.header.stamp.nanosec == log_time
        seen[sphere.ns].append((log_time, sphere))
    # The joint's child link, from the description in the file (Pinocchio: the frame whose
    # parent joint is that joint and that is a body).
    model = pin.buildModelFromXML(scene["/coman/robot_description"][0][2].data)
    child = {}
    for f in model.frames:
        if f.type == pin.FrameType.BODY and f.parentJoint > 0:
            child.setdefault(model.names[f.parentJoint], f.name)
    for ns, key in kinds.items():
        assert len(seen[ns]) == len(report[key])
        for (log_time, sphere), event in zip(seen[ns], report[key]):
            assert log_time == round(event["time"] * 1e9)
            life = sphere.lifetime.sec * 10**9 + sphere.lifetime.nanosec
            assert life == max(round((event["end_time"] - event["time"]) * 1e9), 50_000_000)
            p = sphere.pose.position
            if ns == "collision":
                # At the contact point rapier reported, in the root (torso) frame.
                assert sphere.header.frame_id == "coman/DWYTorso"
                np.testing.assert_allclose([p.x, p.y, p.z], event["point"], rtol=0, atol=1e-12)
                assert event["link_a"] in label_text(events, sphere)
            else:
                # At the offending joint: the origin of its child link, which /tf moves.
                assert sphere.header.frame_id == child[event["joint"]]
                assert [p.x, p.y, p.z] == [0, 0, 0]
                assert event["joint"] in label_text(events, sphere)


def label_text(events, sphere):
    """The text of the label beside `sphere`."""
    for _, _, msg in events:
        s, label = msg.markers
        if (s.ns, s.id) == (sphere.ns, sphere.id):
            return label.text
    raise AssertionError(f"no label for {sphere.ns} {sphere.id}")
