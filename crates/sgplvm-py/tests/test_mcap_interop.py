"""MCAP interoperability with the reference Python client (`mcap` + `mcap-ros2-support`).

- The shipped demonstrations (data/demos/bimanual.mcap, written by the Rust generator) are read
  with the Python packages: ROS 2 profile, CDR JointState, labels and split as metadata.
- Files written by `sgplvm.write_joint_states` are read back by the Python client, and files
  the Python client writes are read by `sgplvm.read_joint_states`, value for value.

Requires `pip install mcap mcap-ros2-support`; the round-trip tests also need the built module.
"""

import json
from pathlib import Path

import numpy as np
import pytest

mcap_reader = pytest.importorskip("mcap.reader")
mcap_ros2_decoder = pytest.importorskip("mcap_ros2.decoder")
mcap_ros2_writer = pytest.importorskip("mcap_ros2.writer")
from mcap.writer import CompressionType  # noqa: E402

ROOT = Path(__file__).resolve().parents[3]
DEMO = ROOT / "data" / "demos" / "bimanual.mcap"
TOPICS = {
    "/human/joint_states": 18,
    "/walkman/joint_command": 14,
    "/coman/joint_command": 14,
    "/centauro/joint_command": 14,
}

JOINT_STATE_MSGDEF = """\
std_msgs/Header header
string[] name
float64[] position
float64[] velocity
float64[] effort
================================================================================
MSG: std_msgs/Header
builtin_interfaces/Time stamp
string frame_id
================================================================================
MSG: builtin_interfaces/Time
int32 sec
uint32 nanosec
"""


def read_with_python(path, topic=None):
    """All decoded JointState messages of `path` as {topic: (times, names, positions)}."""
    out = {}
    with open(path, "rb") as f:
        reader = mcap_reader.make_reader(f, decoder_factories=[mcap_ros2_decoder.DecoderFactory()])
        for schema, channel, message, ros in reader.iter_decoded_messages(
            topics=None if topic is None else [topic]
        ):
            assert schema.name == "sensor_msgs/msg/JointState"
            assert schema.encoding == "ros2msg"
            assert channel.message_encoding == "cdr"
            times, names, rows = out.setdefault(channel.topic, ([], list(ros.name), []))
            assert list(ros.name) == names
            times.append(message.log_time)
            rows.append(list(ros.position))
            assert ros.header.stamp.sec * 10**9 + ros.header.stamp.nanosec == message.log_time
    return {t: (np.array(v[0]), v[1], np.array(v[2])) for t, v in out.items()}


@pytest.mark.skipif(not DEMO.exists(), reason="data/demos/bimanual.mcap not generated")
def test_shipped_demonstrations_read_with_the_python_client():
    with open(DEMO, "rb") as f:
        reader = mcap_reader.make_reader(f)
        header = reader.get_header()
        assert header.profile == "ros2"
        assert header.library == "sgplvm"
        summary = reader.get_summary()
        topics = {c.topic for c in summary.channels.values()}
        assert topics == set(TOPICS)
        meta = {m.name: m.metadata for m in reader.iter_metadata()}
    dataset = json.loads(meta["sgplvm.dataset"]["json"])
    data = read_with_python(DEMO)
    n = dataset["frames"]
    for topic, dof in TOPICS.items():
        times, names, positions = data[topic]
        assert positions.shape == (n, dof)
        assert np.all(np.diff(times) > 0)
    # All bodies share the frame clock.
    np.testing.assert_array_equal(data["/human/joint_states"][0], data["/coman/joint_command"][0])
    train, test = set(dataset["train"]), set(dataset["test"])
    assert 200 <= len(train) <= 300 and 200 <= len(test) <= 600
    assert not train & test
    segments = dataset["segments"]
    assert segments[0]["start"] == 0 and segments[-1]["end"] == n
    for f in list(train)[:50]:
        seg = next(s for s in segments if s["start"] <= f < s["end"])
        assert seg["from_pose"] == 0  # training trajectories start at the neutral pose


@pytest.mark.parametrize("compression", ["zstd", "lz4", "none"])
def test_python_client_reads_what_sgplvm_writes(tmp_path, compression):
    sgplvm = pytest.importorskip("sgplvm")
    if not hasattr(sgplvm, "write_joint_states"):
        pytest.skip("sgplvm.write_joint_states not bound")
    rng = np.random.default_rng(0)
    times = 1_000_000_000 + 25_000_000 * np.arange(120, dtype=np.int64)
    names = [f"j{i}" for i in range(7)]
    positions = rng.normal(size=(120, 7))
    path = tmp_path / "ours.mcap"
    sgplvm.write_joint_states(str(path), "/arm/joint_command", times, names, positions, compression)
    got_times, got_names, got = read_with_python(path)["/arm/joint_command"]
    np.testing.assert_array_equal(got_times, times)
    assert got_names == names
    np.testing.assert_array_equal(got, positions)  # bit-exact float64


def test_sgplvm_reads_what_the_python_client_writes(tmp_path):
    sgplvm = pytest.importorskip("sgplvm")
    if not hasattr(sgplvm, "read_joint_states"):
        pytest.skip("sgplvm.read_joint_states not bound")
    path = tmp_path / "theirs.mcap"
    rng = np.random.default_rng(1)
    positions = rng.normal(size=(30, 3))
    with open(path, "wb") as f:
        w = mcap_ros2_writer.Writer(f, compression=CompressionType.LZ4)
        schema = w.register_msgdef("sensor_msgs/msg/JointState", JOINT_STATE_MSGDEF)
        for k in range(30):
            t = 5_000_000_000 + k * 25_000_000
            w.write_message(
                "/human/joint_states",
                schema,
                {
                    "header": {"stamp": {"sec": t // 10**9, "nanosec": t % 10**9}, "frame_id": ""},
                    "name": ["a", "b", "c"],
                    "position": positions[k].tolist(),
                    "velocity": [],
                    "effort": [],
                },
                log_time=t,
                publish_time=t,
            )
        w.finish()
    times, names, got = sgplvm.read_joint_states(str(path), "/human/joint_states")
    assert names == ["a", "b", "c"]
    np.testing.assert_array_equal(times, 5_000_000_000 + 25_000_000 * np.arange(30))
    np.testing.assert_array_equal(got, positions)


# A file written by our Rust writer with the JSON message encoding (and a CDR channel beside it);
# tests/mcap_json_fixture.rs checks that the writer still produces exactly these bytes.
OUR_JSON = Path(__file__).resolve().parent / "fixtures" / "sgplvm_json.mcap"
JSON_SCALES = [1.0, 1e-300, -2.5e300, 1e-5]


def test_python_client_decodes_our_json_encoding():
    with open(OUR_JSON, "rb") as f:
        reader = mcap_reader.make_reader(f, decoder_factories=[mcap_ros2_decoder.DecoderFactory()])
        seen = []
        for schema, channel, message in reader.iter_messages(topics=["/json/joint_states"]):
            assert channel.message_encoding == "json"
            assert schema.encoding == "jsonschema"
            assert schema.name == "sensor_msgs/msg/JointState"
            jsonschema = json.loads(schema.data)
            assert jsonschema["type"] == "object"
            assert set(jsonschema["properties"]) >= {"header", "name", "position"}
            seen.append((message.log_time, json.loads(message.data)))
        # The CDR channel in the same file decodes with the ROS 2 decoder.
        cdr = [ros.position for _, _, _, ros in reader.iter_decoded_messages(topics=["/cdr/joint_command"])]
    assert [list(p) for p in cdr] == [[(k + 1) / 3 * s for s in (1.0, 1e-300)] for k in range(3)]
    assert len(seen) == 12
    for k, (log_time, msg) in enumerate(seen):
        t = 999_900_000 + 25_000_000 * k
        assert log_time == t
        assert msg["header"]["stamp"] == {"sec": t // 10**9, "nanosec": t % 10**9}
        assert msg["header"]["frame_id"] == ""
        assert msg["name"] == ["a", "b", "c", "d"]
        want = [(k + 1) / 3 * s for s in JSON_SCALES]
        # Bit-exact float64 through JSON text.
        assert [float(v).hex() for v in msg["position"]] == [v.hex() for v in want]
        assert msg.get("velocity", []) == [] and msg.get("effort", []) == []
