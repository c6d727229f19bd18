"""How fast ``sgplvm teleop`` answers (issue 37): receive → publish latency of the node (p50, p99,
max, as the node measures it from taking a human message to having published every robot's
command) over 20,000 messages on loopback, three robots (one multi-robot model of WALK-MAN,
COMAN and CENTAURO), reliable QoS on input and commands:

* published by ``sgplvm replay --rate`` at 40 Hz (the paper's rate) and at higher rates, to find
  the highest rate at which every message is answered (none superseded by a newer one before
  the node took it);
* at 40 Hz by a Cyclone DDS participant (PyPI ``cyclonedds``) that also subscribes to the three
  command topics and measures the round trip (human message written → command received, one
  machine's clock; Python's own threads share the two cores with the node, so this is an upper
  bound).

DDS needs a network: run it in a loopback-only namespace (root), nothing leaves it::

    unshare -n sh -c 'ip link set lo up && ip link set lo multicast on && \\
        python benches/live_latency.py'

``--messages 2000`` gives a quick look (each 40 Hz run takes messages / 40 seconds).
"""

import argparse
import json
import pathlib
import signal
import subprocess
import sys
import threading
import time

import numpy as np

ROOT = pathlib.Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "crates" / "sgplvm-py" / "tests"))
import test_teleop as live  # noqa: E402  (the ROS 2 message definitions for Cyclone)

ROBOTS = ["walkman", "coman", "centauro"]


def run(cmd, **kw):
    return subprocess.run([str(x) for x in cmd], check=True, capture_output=True, text=True, **kw)


def start_node(binary, model, domain, work, max_frames=None):
    args = [binary, "teleop", "--model", model, "--domain-id", domain, "--input-qos", "reliable", "--json"]
    for r in ROBOTS:
        args += ["--robot", r]
    if max_frames:
        args += ["--max-frames", max_frames]
    err = open(work / f"node{domain}.err", "w")
    return subprocess.Popen([str(a) for a in args], stdout=subprocess.PIPE, stderr=err, text=True)


def stop_node(node):
    if node.poll() is None:
        node.send_signal(signal.SIGTERM)
    out, _ = node.communicate(timeout=60)
    return json.loads(out)


def at_40hz(binary, model, human, names, messages, domain, work):
    """Cyclone publishes `messages` frames at 40 Hz stamped with the wall clock; returns the
    node's summary and the round trips (µs) of every command received."""
    node = start_node(binary, model, domain, work)
    ros = live.Ros2(domain)
    w = ros.writer("/human/joint_states", live.JointState)
    readers = [ros.reader(f"/{r}/joint_command", live.JointState) for r in ROBOTS]
    ros.wait_matched()
    trips = []
    done = threading.Event()

    from cyclonedds.core import InstanceState, ReadCondition, SampleState, ViewState, WaitSet
    from cyclonedds.util import duration

    waitset = WaitSet(ros.dp)
    for r in readers:
        waitset.attach(ReadCondition(r, SampleState.Any | ViewState.Any | InstanceState.Any))

    def collect():
        # Blocks until a command is there (a busy loop here would take the node's CPU).
        while not done.is_set():
            waitset.wait(duration(milliseconds=100))
            now = time.time_ns()
            for r in readers:
                for c in r.take(N=1000):
                    trips.append((now - live.stamp_ns(c.header.stamp)) / 1e3)

    t = threading.Thread(target=collect)
    t.start()
    start = time.monotonic()
    for k in range(messages):
        due = start + k / 40.0
        delay = due - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        w.write(live.joint_state(names, human[k % len(human)], time.time_ns()))
    time.sleep(0.5)
    done.set()
    t.join()
    return stop_node(node), np.array(trips)


def at_rate(binary, model, human_mcap, messages, rate, domain, work):
    """``sgplvm replay`` publishes `messages` at `rate` messages/s; returns the node's summary."""
    node = start_node(binary, model, domain, work)
    time.sleep(0.5)
    run([binary, "replay", "--input", human_mcap, "--loop", "--rate", rate / 40.0, "--max-messages", messages,
         "--domain-id", domain, "--wait", 20], timeout=600)
    time.sleep(1.0)
    return stop_node(node)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--messages", type=int, default=20000)
    p.add_argument("--rates", default="40,1000,2000,5000,10000", help="messages/s for the replay runs")
    p.add_argument("--round-trip-messages", type=int, default=2000, help="messages of the Cyclone run (0: none)")
    args = p.parse_args()
    binary = live.sgplvm_binary()
    work = ROOT / "target" / "live-bench"
    work.mkdir(parents=True, exist_ok=True)
    model = work / "three.sgp"
    if not model.exists():
        cmd = [binary, "train", "--max-iters", 100, "--validation", "none", "--out", model]
        for r in ROBOTS:
            cmd += ["--robot", r]
        run(cmd)
    human_mcap = work / "human_all.mcap"
    run([binary, "export", "--frames", "all", "--out", human_mcap])
    times, names, human = live.sgplvm.read_joint_states(human_mcap, "/human/joint_states")
    print(f"sgplvm teleop, 3 robots ({', '.join(ROBOTS)}), reliable QoS, {args.messages} messages each run")
    print("| publisher | rate (msg/s) | answered | superseded | node p50 | node p99 | node max | round trip p50 | p99 | max |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    domain = 60
    if args.round_trip_messages:
        s, trips = at_40hz(binary, model, human, names, args.round_trip_messages, domain, work)
        lat = s["latency"]
        q = np.percentile(trips, [50, 99]) if len(trips) else [np.nan, np.nan]
        print(f"| Cyclone DDS (Python) | 40 | {s['frames']} | {s['superseded']} | {lat['p50_us']:.0f} µs | {lat['p99_us']:.0f} µs "
              f"| {lat['max_us']:.0f} µs | {q[0]:.0f} µs | {q[1]:.0f} µs | {np.max(trips) if len(trips) else np.nan:.0f} µs |",
              flush=True)
    for rate in [float(r) for r in args.rates.split(",") if r]:
        domain += 1
        s = at_rate(binary, model, human_mcap, args.messages, rate, domain, work)
        lat = s["latency"]
        print(f"| sgplvm replay | {rate:.0f} | {s['frames']} | {s['superseded']} | {lat['p50_us']:.0f} µs | {lat['p99_us']:.0f} µs "
              f"| {lat['max_us']:.0f} µs | – | – | – |", flush=True)


if __name__ == "__main__":
    main()
