"""Live safety as the robot receives it (issue 50): silences, bursts, loss and reordering never
make a command jump, and only the named suit drives.

Each impairment run drives ``sgplvm teleop`` through a real transport made worse on purpose and
takes at least ``SGPLVM_IMPAIRED_COMMANDS`` (10,000) commands: an Xsens MVN stream over UDP
through a user-space proxy (:class:`impair.UdpProxy`), and Cyclone DDS publishers of the
human's JointState and of a skeleton's TF (:func:`impair.dds_schedule`). A Cyclone subscriber in
a process of its own records every command with the time it arrived; every step between two
commands is checked against each joint's velocity limit × the interval between their receipts
plus the delivery spread measured over the run, and × the interval between the node's source
timestamps exactly (:func:`impair.check_steps`); the held and stale states the node counted are
the ones its status topic said. With ``SGPLVM_IMPAIRMENT_REPORT=FILE`` each run's figures are
appended to FILE (BENCHMARKS.md's).

Like test_teleop.py these run only in a loopback-only network namespace (``.ci/run``).
"""

import os
import socket
import time

import numpy as np
import pytest

import impair
from test_teleop import (  # noqa: F401  (the fixtures `tmp` and `data` are used by name)
    DEMOS,
    LATCHED,
    DataWriter,
    Header,
    JointState,
    Ros2,
    TFMessage,
    Teleop,
    Time,
    Topic,
    TransformStamped,
    _mvn_frames,
    _tf_arm_messages,
    _tf_static_message,
    data,
    joint_state,
    limits,
    next_domain,
    tmp,
)

import sgplvm  # noqa: E402
from _cli import sgplvm_binary  # noqa: E402

COMMANDS = int(os.environ.get("SGPLVM_IMPAIRED_COMMANDS", "10000"))
TIMEOUT = 0.1  # the node's default --timeout


@pytest.fixture(scope="module")
def model(tmp):
    """A model of COMAN (a short training: the tests are about the node)."""
    import subprocess

    path = tmp / "coman_impaired.sgp"
    subprocess.run(
        [str(sgplvm_binary()), "train", "--data", str(DEMOS), "--max-iters", "80", "--validation", "none",
         "--robot", "coman", "--out", str(path)],
        check=True, capture_output=True,
    )  # fmt: skip
    return path


def human_rows(data):
    """The shipped demonstrations' human frames (40 Hz) in the demonstrations' joint order and
    in the human model's."""
    d = data["all"]
    rows = np.asarray(d["human"]["positions"])
    order = [data["names"].index(n) for n in sgplvm.Robot.builtin("human").joint_names]
    return rows, rows[:, order]


def velocity_limits(names):
    return limits(sgplvm.Robot.builtin_urdf("coman"), names)[2]


def check_status(status, summary, robot="coman"):
    """The status topic said every stale episode the node counted, each state at its level, and
    the input stale with it. Returns the states in the order said."""
    said = impair.transitions(status, robot)
    level = {"waiting": 0, "following": 0, "holding": 1, "moving to the last trusted target": 1, "stale input": 3}
    for reason, lv in said:
        assert level[reason] == lv, (reason, lv)
    stale = sum(1 for reason, _ in said if reason == "stale input")
    assert stale == summary["robots"][robot]["stale"] >= 1, (stale, summary["robots"][robot], said[:20])
    for _, entries in status:
        states = {name: lv for name, lv, _, _ in entries}
        if states.get(f"sgplvm/{robot}") == 3:
            assert states["sgplvm/input"] == 3, entries
    return said


def robot_counts(summary, robot="coman"):
    """The node's own counts of what its rule did, for the report."""
    r = summary["robots"][robot]
    return {k: r[k] for k in ("stale", "untrusted", "velocity_clamped", "collision_limited")}


def wait_log(tmp, domain, text, timeout=30.0):
    """Until the node's log says `text` (its MVN socket is bound once it says where)."""
    end = time.monotonic() + timeout
    while text not in (tmp / f"teleop{domain}.err").read_text():
        assert time.monotonic() < end, f"the node never said {text!r}"
        time.sleep(0.05)


def run_node(tmp, domain, args, commands_topic="/coman/joint_command"):
    node = Teleop(tmp, domain, ["--max-frames", str(COMMANDS + 50), *args])
    sub = impair.Subscriber(tmp, domain, commands_topic)
    return node, sub


def finish(node, sub):
    """The node's summary and log, and what the subscriber received (the node stops at
    --max-frames, else here)."""
    try:
        summary, err = node.stop(timeout=60)
    finally:
        node.kill()
    time.sleep(0.5)
    received, status = sub.stop()
    return summary, err, received, status


def test_the_issues_sequence_moves_within_the_limits_as_received(tmp, data, model):
    """Issue 50's measurement: 40 Hz frames (80 ordinary, 40 one radian off on every joint, 40
    ordinary), 400 ms of silence with the stamps jumping 400 ms, 40 more; every step within the
    velocity limits as received, the holds and the stale input said on the status topic."""
    domain = next_domain()
    names = data["names"]
    rows, _ = human_rows(data)
    start = int(data["all"]["train"][0])
    frames = [rows[start + i] + (1.0 if 80 <= i < 120 else 0.0) for i in range(200)]
    node, sub = run_node(tmp, domain, ["--model", str(model), "--robot", "coman"])
    try:
        ros = Ros2(domain)
        w = ros.writer("/human/joint_states", JointState)
        ros.wait_matched()
        sub.wait_matched()
        stamp, t = 10**12, time.monotonic()
        for i, row in enumerate(frames[:160] + [None] + frames[160:]):
            if row is None:  # the silence: the sender's clock goes on
                t += 0.4 - 0.025
                stamp += 400_000_000 - 25_000_000
                continue
            time.sleep(max(0.0, t - time.monotonic()))
            w.write(joint_state(names, row, stamp))
            t, stamp = t + 0.025, stamp + 25_000_000
        time.sleep(0.3)
    finally:
        summary, err, (rx, src, joints, q), status = finish(node, sub)
    figures = impair.check_steps(rx, src, q, velocity_limits(joints))
    said = check_status(status, summary)
    assert "holding" in [r for r, _ in said] and summary["robots"]["coman"]["untrusted"] >= 1, said
    impair.report("issue 50 sequence (JointState, 40 Hz)", {**figures, **robot_counts(summary)})


def test_mvn_through_an_impairing_proxy(tmp, data, model):
    """MVN type-02 datagrams at 240 Hz through a proxy that delays (1–5 ms), drops, duplicates,
    reorders, splits frames and loses parts of them, and takes the link down or stalls it for the
    stale timeout ± 20 ms: at least COMMANDS commands, none beyond the velocity limits as
    received; old, repeated and reordered samples dropped by their counters; the stale input said
    on the status topic."""
    domain = next_domain()
    _, ordered = human_rows(data)
    start = int(data["all"]["train"][0])
    cycle = _mvn_frames(ordered[start : start + 480])
    port = impair.free_udp_port()
    proxy = impair.UdpProxy(("127.0.0.1", port), impair.Impairment(), seed=50).start()
    node, sub = run_node(tmp, domain, [
        "--model", str(model), "--robot", "coman", "--input", f"mvn:127.0.0.1:{port}",
        "--mvn-from", "%s:%d" % proxy.egress,
    ])  # fmt: skip
    try:
        sub.wait_matched()
        wait_log(tmp, domain, "input: Xsens MVN stream on")
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as suit:
            t0 = time.monotonic()
            for k in range(int(1.6 * COMMANDS) + 2000):
                if node.proc.poll() is not None:
                    break
                time.sleep(max(0.0, t0 + k / 240 - time.monotonic()))
                d = bytearray(cycle[k % len(cycle)])
                d[6:10] = (k + 1).to_bytes(4, "big")
                d[12:16] = (k * 1000 // 240).to_bytes(4, "big")
                suit.sendto(bytes(d), proxy.ingress)
    finally:
        summary, err, (rx, src, joints, q), status = finish(node, sub)
        counts = proxy.stop()
    assert len(q) >= COMMANDS, (len(q), summary.get("mvn"), err[-2000:])
    figures = impair.check_steps(rx, src, q, velocity_limits(joints))
    check_status(status, summary)
    mvn = summary["mvn"]
    assert mvn["sender"] == "%s:%d" % proxy.egress and "other sender" not in mvn["dropped"], mvn
    assert mvn["dropped"].get("late", 0) >= 1 and mvn["dropped"].get("incomplete", 0) >= 1, (mvn, counts)
    assert mvn["units"].startswith("type 02: read as metres"), mvn["units"]
    impair.report(
        "MVN 240 Hz through the UDP proxy",
        {**figures, **robot_counts(summary), "mvn_dropped": mvn["dropped"],
         "proxy": {k: v for k, v in vars(counts).items() if k != "outages"}, "outages": len(counts.outages),
         "latency_p99_us": round(summary["latency"]["p99_us"])},
    )  # fmt: skip


def test_joint_state_publisher_bursts_pauses_reorders_and_skews(tmp, data, model):
    """A JointState publisher at 250 Hz that bursts, pauses for the stale timeout ± 20 ms,
    writes pairs of frames in swapped order, runs its clock 2 % fast and 5 s behind (and steps
    it back 2 s halfway), and sends poses 1 rad off now and then: at least COMMANDS commands,
    none beyond the velocity limits as received; the older stamps dropped; held and stale states
    on the status topic."""
    domain = next_domain()
    names = data["names"]
    rows, _ = human_rows(data)
    events, what = impair.dds_schedule(int(1.5 * COMMANDS), 250.0, TIMEOUT, seed=50, step_back_s=2.0)
    node, sub = run_node(tmp, domain, ["--model", str(model), "--robot", "coman"])
    try:
        ros = Ros2(domain)
        w = ros.writer("/human/joint_states", JointState)
        ros.wait_matched()
        sub.wait_matched()
        impair.play(
            events,
            lambda e: w.write(joint_state(names, rows[e.row % len(rows)] + (1.0 if e.off else 0.0), e.stamp_ns)),
            stop=lambda: node.proc.poll() is not None,
        )
    finally:
        summary, err, (rx, src, joints, q), status = finish(node, sub)
    assert len(q) >= COMMANDS, (len(q), summary, err[-2000:])
    figures = impair.check_steps(rx, src, q, velocity_limits(joints))
    said = check_status(status, summary)
    reasons = {r for r, _ in said}
    assert {"holding", "moving to the last trusted target"} <= reasons, said[:30]
    assert summary["dropped"].get("out of order", 0) >= 1, summary["dropped"]
    impair.report(
        "JointState 250 Hz, impaired publisher",
        {**figures, **robot_counts(summary), "dropped": summary["dropped"], "superseded": summary["superseded"], "pauses": len(what["pauses"]),
         "bursts": what["bursts"], "swaps": what["swaps"], "latency_p99_us": round(summary["latency"]["p99_us"])},
    )  # fmt: skip


def test_tf_publisher_bursts_pauses_reorders_and_skews(tmp, data, model):
    """A skeleton on /tf at 250 Hz (each time's transforms in two messages), impaired as the
    JointState publisher is (without the clock stepping back: the TF input follows only stamps
    newer than the last set used): at least COMMANDS commands, none beyond the velocity limits as
    received; the stale input on the status topic."""
    domain = next_domain()
    _, ordered = human_rows(data)
    start = int(data["all"]["train"][0])
    cycle = _tf_arm_messages(ordered[start : start + 480], np.zeros(480, dtype=np.int64))
    events, what = impair.dds_schedule(
        int(1.5 * COMMANDS), 250.0, TIMEOUT, seed=51, step_back_s=None, off_segments=False
    )
    ros = Ros2(domain)
    static_writer = DataWriter(ros.dp, Topic(ros.dp, "rt/tf_static", TFMessage, qos=LATCHED), qos=LATCHED)
    static_writer.write(_tf_static_message())
    node, sub = run_node(tmp, domain, ["--model", str(model), "--robot", "coman", "--input", "tf", "--calibration-seconds", "0"])

    def write(e):
        k = 2 * (e.row % (len(cycle) // 2))
        t = Time(e.stamp_ns // 10**9, e.stamp_ns % 10**9)
        for m in cycle[k : k + 2]:
            w.write(TFMessage([TransformStamped(Header(t, x.header.frame_id), x.child_frame_id, x.transform) for x in m.transforms]))

    try:
        w = ros.writer("/tf", TFMessage)
        ros.wait_matched()
        sub.wait_matched()
        time.sleep(0.5)  # the latched spine reaches the node
        impair.play(events, write, stop=lambda: node.proc.poll() is not None)
    finally:
        summary, err, (rx, src, joints, q), status = finish(node, sub)
    assert len(q) >= COMMANDS, (len(q), summary.get("tf"), err[-2000:])
    figures = impair.check_steps(rx, src, q, velocity_limits(joints))
    check_status(status, summary)
    impair.report(
        "TF 250 Hz, impaired publisher",
        {**figures, **robot_counts(summary), "superseded_sets": summary["tf"]["superseded"],
         "incomplete_sets": summary["tf"]["incomplete"], "pauses": len(what["pauses"]), "bursts": what["bursts"],
         "swaps": what["swaps"], "latency_p99_us": round(summary["latency"]["p99_us"])},
    )  # fmt: skip


@pytest.mark.parametrize("named", [True, False])
def test_only_the_named_or_first_mvn_sender_drives(tmp, data, model, named):
    """The suit sends from 127.0.0.1, a stranger from 127.0.0.2 (and a DDS publisher writes the
    JointState topic): with ``--mvn-from`` naming the suit (and DDS kept to the loopback
    interface, ``--dds-interface``), or without it (the first sender's host is locked), the
    stranger's datagrams are counted and reported on the status topic, and none of them, nor
    the JointState messages, reaches a command."""
    domain = next_domain()
    names = data["names"]
    rows, ordered = human_rows(data)
    start = int(data["all"]["train"][0])
    mine, theirs = _mvn_frames([ordered[start], ordered[start + 200]])
    port = impair.free_udp_port()
    suit = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    suit.bind(("127.0.0.1", 0))
    stranger = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    stranger.bind(("127.0.0.2", 0))
    suit_addr = "%s:%d" % suit.getsockname()
    stranger_addr = "%s:%d" % stranger.getsockname()
    node, sub = run_node(tmp, domain, [
        "--model", str(model), "--robot", "coman", "--input", f"mvn:127.0.0.1:{port}",
        "--margin", "0", *(["--mvn-from", suit_addr, "--dds-interface", "127.0.0.1"] if named else []),
    ])  # fmt: skip

    def datagram(d, k):
        d = bytearray(d)
        d[6:10] = k.to_bytes(4, "big")
        return bytes(d)

    try:
        ros = Ros2(domain)
        w = ros.writer("/human/joint_states", JointState)
        sub.wait_matched()
        wait_log(tmp, domain, "input: Xsens MVN stream on")
        if named:  # the stranger first: with a sender named, it never drives
            for k in range(40):
                stranger.sendto(datagram(theirs, 1000 + k), ("127.0.0.1", port))
                time.sleep(0.005)
        for k in range(100):
            suit.sendto(datagram(mine, 1 + k), ("127.0.0.1", port))
            stranger.sendto(datagram(theirs, 5000 + k), ("127.0.0.1", port))
            w.write(joint_state(names, rows[start + 200], 10**12 + k * 25_000_000))
            time.sleep(0.01)
        time.sleep(0.3)
    finally:
        summary, err, (rx, src, joints, q), status = finish(node, sub)
        suit.close()
        stranger.close()
    mvn = summary["mvn"]
    refused = 140 if named else 100
    assert mvn["dropped"]["other sender"] == refused and mvn["sender"] == suit_addr, mvn
    assert mvn["refused"] == [stranger_addr], mvn
    assert "127.0.0.2" in err and "refused" in err, err
    # The suit's pose is still: every command is the first one (the stranger's pose, elsewhere,
    # never moved a joint), and there is one per suit frame (no JointState frame was followed).
    assert len(q) >= 1 and np.all(np.abs(q - q[0]) == 0.0), np.abs(q - q[0]).max()
    assert summary["frames"] == mvn["frames"] <= 100, summary
    inputs = [values for _, entries in status for name, _, _, values in entries if name == "sgplvm/input"]
    last = inputs[-1]
    assert last["mvn_sender"] == suit_addr and last["mvn_refused"] == str(refused), last
    assert last["mvn_accepts"] == (f"{suit_addr} (--mvn-from)" if named else "the first sender's host, locked"), last
