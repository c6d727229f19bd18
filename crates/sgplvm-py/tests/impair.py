"""Impaired transports between a person and ``sgplvm teleop``, and the check of what a robot
receives (issue 50; a helper module for ``test_live_impaired.py``, not a test).

- :class:`UdpProxy`: a user-space proxy between an MVN sender and the node (the kernel here has
  no netem): every datagram delayed by a base plus jitter; some dropped, duplicated or held back
  (reordered); whole frames split into parts as MVN splits them (§2.4.1.3), parts sent in any
  order and some lost; and outages of the stale timeout ± 20 ms, the link down (datagrams lost)
  or stalled (datagrams released at its end, in a burst).
- :func:`dds_schedule`: when a DDS publisher writes each frame and with what stamp: bursts,
  pauses of the stale timeout ± 20 ms (the stamps jumping with them), stamps reordered, the
  publisher's clock skewed and offset (and, optionally, stepped back).
- :class:`Subscriber`: a Cyclone DDS participant in a process of its own (so that the times it
  takes samples are not those of the publishing process's Python threads) recording every command
  with the time it was received and the node's source timestamp, and every status.
- :func:`check_steps`: every step between two consecutive commands against each joint's velocity
  limit × the interval between their receipts, plus the spread of the delivery times measured
  over the run; and, exactly, against the interval between the node's source timestamps.

Nothing here sends anywhere but to 127.0.0.1 (or 127.0.0.2): the tests run in a loopback-only
network namespace.
"""

from __future__ import annotations

import heapq
import json
import os
import random
import select
import socket
import struct
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field

import numpy as np

HEADER_BYTES = 24


def free_udp_port(host: str = "127.0.0.1") -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        probe.bind((host, 0))
        return probe.getsockname()[1]


def split_datagram(datagram: bytes, parts: int) -> list[bytes]:
    """A whole-frame MVN datagram (§2.4.1, datagram counter 0x80) as `parts` datagrams of one
    sample: the items shared out, each header with its index (bit 7 on the last), its number of
    items and its payload size."""
    items = datagram[11]
    payload = datagram[HEADER_BYTES:]
    size = len(payload) // items
    bounds = np.linspace(0, items, parts + 1).round().astype(int)
    out = []
    for i in range(parts):
        a, b = int(bounds[i]), int(bounds[i + 1])
        header = bytearray(datagram[:HEADER_BYTES])
        header[10] = i | (0x80 if i == parts - 1 else 0)
        header[11] = b - a
        header[22:24] = struct.pack(">H", (b - a) * size)
        out.append(bytes(header) + payload[a * size : b * size])
    return out


@dataclass
class Impairment:
    """What the proxy does to the stream; probabilities per datagram (frame, for `split`)."""

    base_delay: float = 0.001
    jitter: float = 0.004
    drop: float = 0.02
    duplicate: float = 0.02
    reorder: float = 0.02
    reorder_delay: float = 0.012
    split: float = 0.10
    lose_part: float = 0.3
    outage_every: float = 1.5
    outages: tuple = (0.08, 0.12)


@dataclass
class ProxyCounts:
    received: int = 0
    forwarded: int = 0
    dropped: int = 0
    duplicated: int = 0
    reordered: int = 0
    split: int = 0
    parts_lost: int = 0
    outage_lost: int = 0
    outage_burst: int = 0
    outages: list = field(default_factory=list)


class UdpProxy:
    """Datagrams to :attr:`ingress` come out of :attr:`egress` to `to`, impaired."""

    def __init__(self, to: tuple, impairment: Impairment, seed: int):
        self.to = to
        self.imp = impairment
        self.rng = random.Random(seed)
        self.rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.rx.bind(("127.0.0.1", 0))
        self.tx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.tx.bind(("127.0.0.1", 0))
        self.ingress = self.rx.getsockname()
        self.egress = self.tx.getsockname()
        self.counts = ProxyCounts()
        self._due: list = []
        self._seq = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def start(self) -> "UdpProxy":
        self._thread.start()
        return self

    def stop(self) -> ProxyCounts:
        self._stop.set()
        self._thread.join(timeout=5)
        self.rx.close()
        self.tx.close()
        return self.counts

    def _later(self, at: float, data: bytes) -> None:
        heapq.heappush(self._due, (at, self._seq, data))
        self._seq += 1

    def _delay(self) -> float:
        return self.imp.base_delay + self.rng.uniform(0, self.imp.jitter)

    def _impair(self, data: bytes, now: float, outage) -> None:
        c, imp, rng = self.counts, self.imp, self.rng
        c.received += 1
        if outage is not None:
            start, length, burst = outage
            if burst:  # the link stalls: everything comes out at its end
                c.outage_burst += 1
                self._later(start + length + self._delay(), data)
            else:  # the link is down: lost
                c.outage_lost += 1
            return
        if rng.random() < imp.drop:
            c.dropped += 1
            return
        datagrams = [data]
        if data[10] == 0x80 and data[11] >= 3 and rng.random() < imp.split:
            c.split += 1
            datagrams = split_datagram(data, rng.choice([2, 3]))
            rng.shuffle(datagrams)
            if rng.random() < imp.lose_part:
                c.parts_lost += 1
                datagrams.pop()
        for d in datagrams:
            if rng.random() < imp.reorder:
                c.reordered += 1
                self._later(now + imp.reorder_delay + self._delay(), d)
            else:
                self._later(now + self._delay(), d)
            if rng.random() < imp.duplicate:
                c.duplicated += 1
                self._later(now + self._delay(), d)

    def _run(self) -> None:
        imp, rng = self.imp, self.rng
        next_outage = time.monotonic() + imp.outage_every
        outage = None
        while not self._stop.is_set():
            now = time.monotonic()
            if outage is None and now >= next_outage:
                length = imp.outages[len(self.counts.outages) % len(imp.outages)]
                burst = (len(self.counts.outages) // len(imp.outages)) % 2 == 1
                outage = (now, length, burst)
                self.counts.outages.append((length, burst))
            if outage is not None and now >= outage[0] + outage[1]:
                outage = None
                next_outage = now + imp.outage_every * rng.uniform(0.7, 1.3)
            while self._due and self._due[0][0] <= now:
                _, _, d = heapq.heappop(self._due)
                self.tx.sendto(d, self.to)
                self.counts.forwarded += 1
            wait = 0.01 if not self._due else max(0.0, self._due[0][0] - now)
            ready, _, _ = select.select([self.rx], [], [], min(wait, 0.002))
            if ready:
                data = self.rx.recv(65536)
                self._impair(data, time.monotonic(), outage)


@dataclass
class Event:
    """One write of a DDS publisher: when (seconds after its start), the stamp it carries, the
    frame (an index into the rows) and whether the pose is one the model must not trust."""

    at: float
    stamp_ns: int
    row: int
    off: bool = False


def dds_schedule(
    frames: int,
    rate: float,
    timeout: float,
    seed: int,
    *,
    skew: float = 0.02,
    offset_s: float = -5.0,
    step_back_s: float | None = None,
    off_segments: bool = True,
) -> tuple[list[Event], dict]:
    """`frames` writes at `rate` Hz, impaired (module docs): every ~2 s a pause of `timeout` ±
    20 ms (alternately), every ~1.5 s a burst of 8 frames written at once at the last one's time,
    every ~0.4 s two frames written in swapped order (the older stamp second), stamps on a clock
    `skew` fast and `offset_s` off (stepped back by `step_back_s` halfway when given), and every
    ~3 s (with `off_segments`) 12 frames 1 rad off on every joint. Returns the events and what
    was put in."""
    rng = random.Random(seed)
    period = 1.0 / rate
    events: list[Event] = []
    t = 0.0
    back = 0.0
    what = {"pauses": [], "bursts": 0, "swaps": 0, "off_segments": 0, "step_back_s": step_back_s}
    next_pause, next_burst, next_swap, next_off = 2.0, 1.5, 0.4, 3.0
    off_left = 0
    while len(events) < frames:
        if step_back_s and back == 0.0 and len(events) >= frames // 2:
            back = step_back_s
        if t >= next_pause:
            pause = timeout + (0.02 if len(what["pauses"]) % 2 == 0 else -0.02)
            what["pauses"].append(pause)
            t += pause
            next_pause = t + 2.0 * rng.uniform(0.8, 1.2)
        if off_segments and t >= next_off:
            off_left, next_off = 12, t + 3.0 * rng.uniform(0.8, 1.2)
            what["off_segments"] += 1
        stamp = int((offset_s - back + t * (1.0 + skew)) * 1e9) + 10**12
        events.append(Event(t, stamp, len(events), off_left > 0))
        off_left = max(0, off_left - 1)
        t += period
    k = 0
    while k < len(events):
        e = events[k]
        if e.at >= next_burst and k + 8 <= len(events):
            last = events[k + 7].at
            for b in events[k : k + 8]:
                b.at = last
            what["bursts"] += 1
            next_burst = last + 1.5 * rng.uniform(0.8, 1.2)
            k += 8
            continue
        if e.at >= next_swap and k + 1 < len(events) and events[k + 1].at > e.at:
            a, b = events[k], events[k + 1]
            events[k], events[k + 1] = (
                Event(a.at, b.stamp_ns, b.row, b.off),
                Event(b.at, a.stamp_ns, a.row, a.off),
            )
            what["swaps"] += 1
            next_swap = b.at + 0.4 * rng.uniform(0.8, 1.2)
            k += 2
            continue
        k += 1
    return events, what


def play(events: list[Event], write, stop=lambda: False) -> int:
    """Calls ``write(event)`` at each event's time; returns how many were written (until
    `stop()` says so)."""
    start = time.monotonic()
    for n, e in enumerate(events):
        delay = start + e.at - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        if stop():
            return n
        write(e)
    return len(events)


# ----- the subscriber, in a process of its own -----


class Subscriber:
    """``python impair.py subscribe``: records `topic`'s commands and `/sgplvm/status` until
    :meth:`stop`."""

    def __init__(self, tmp, domain: int, topic: str):
        self.out = tmp / f"received{domain}.json"
        self.ready = tmp / f"ready{domain}"
        self.proc = subprocess.Popen(
            [sys.executable, __file__, "subscribe", str(domain), topic, str(self.out), str(self.ready)],
            stdin=subprocess.PIPE,
        )

    def wait_matched(self, timeout: float = 30.0) -> None:
        end = time.monotonic() + timeout
        while not self.ready.exists():
            assert self.proc.poll() is None, "the subscriber exited"
            assert time.monotonic() < end, "the subscriber found no node"
            time.sleep(0.05)

    def stop(self):
        """Commands (received ns, source ns, names, positions) and statuses (received ns,
        [(name, level, message, values)])."""
        self.proc.stdin.close()
        assert self.proc.wait(timeout=60) == 0
        got = json.loads(self.out.read_text())
        c = got["commands"]
        return (
            np.array(c["received"], dtype=np.int64),
            np.array(c["source"], dtype=np.int64),
            c["names"],
            np.array(c["positions"], dtype=float).reshape(len(c["received"]), -1),
        ), got["status"]


def _subscribe(domain: int, topic: str, out: str, ready: str) -> None:
    sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
    from cyclonedds.core import Listener
    from cyclonedds.sub import DataReader
    from cyclonedds.topic import Topic
    from test_teleop import RELIABLE, DiagnosticArray, JointState, Ros2

    ros = Ros2(domain)
    lock = threading.Lock()
    commands = {"received": [], "source": [], "names": None, "positions": []}
    status = []

    def on_command(reader):
        now = time.time_ns()
        with lock:
            for s in reader.take(N=1000):
                if isinstance(s, JointState):
                    commands["received"].append(now)
                    commands["source"].append(s.sample_info.source_timestamp)
                    commands["names"] = list(s.name)
                    commands["positions"].extend(float(v) for v in s.position)

    def on_status(reader):
        now = time.time_ns()
        with lock:
            for s in reader.take(N=1000):
                if isinstance(s, DiagnosticArray):
                    status.append(
                        (now, [(e.name, int(e.level), e.message, {kv.key: kv.value for kv in e.values}) for e in s.status])
                    )

    readers = []
    for name, cls, callback in [(topic, JointState, on_command), ("/sgplvm/status", DiagnosticArray, on_status)]:
        t = Topic(ros.dp, "rt" + name, cls, qos=RELIABLE)
        readers.append(DataReader(ros.dp, t, qos=RELIABLE, listener=Listener(on_data_available=callback)))
    while not all(r.get_matched_publications() for r in readers):
        time.sleep(0.02)
    open(ready, "w").close()
    sys.stdin.read()  # until the test closes it
    time.sleep(0.3)
    with lock:
        with open(out, "w") as f:
            json.dump({"commands": commands, "status": status}, f)


# ----- the checks -----


def check_steps(received, source, q, vel, *, rad_tol: float = 1e-6) -> dict:
    """Asserts that no step between consecutive commands moves a joint more than its velocity
    limit × the interval between their receipts plus the delivery spread (the largest minus the
    smallest of receipt − source timestamp over the run), nor more than the limit × the interval
    between their source timestamps (the node's send clock; `rad_tol` for rounding). Returns the
    figures."""
    moves = np.abs(np.diff(q, axis=0))
    gap_rx = np.diff(received) * 1e-9
    gap_tx = np.diff(source) * 1e-9
    delivery = (received - source) * 1e-9
    spread = float(delivery.max() - delivery.min())
    limit = vel[None, :]
    by_tx = moves - limit * gap_tx[:, None] - rad_tol
    worst_tx = int(np.argmax(by_tx.max(axis=1)))
    assert np.all(by_tx <= 0), (
        f"step {worst_tx + 1}: moved {moves[worst_tx].max():.6f} rad in {gap_tx[worst_tx] * 1e3:.3f} ms "
        f"between the node's source timestamps"
    )
    by_rx = moves - limit * (gap_rx + spread)[:, None] - rad_tol
    worst_rx = int(np.argmax(by_rx.max(axis=1)))
    assert np.all(by_rx <= 0), (
        f"step {worst_rx + 1}: moved {moves[worst_rx].max():.6f} rad {gap_rx[worst_rx] * 1e3:.3f} ms after the "
        f"previous command was received (delivery spread {spread * 1e3:.2f} ms)"
    )
    moving = moves.max(axis=1) > rad_tol
    speed = lambda gap: (moves / limit).max(axis=1)[moving] / np.maximum(gap[moving], 1e-9)  # noqa: E731
    beyond = lambda allowance: int(np.sum(np.any(moves > limit * (gap_rx + allowance)[:, None] + rad_tol, axis=1)))  # noqa: E731
    return {
        "commands": int(len(q)),
        "delivery_spread_ms": round(spread * 1e3, 3),
        "delivery_p50_ms": round(float(np.percentile(delivery, 50)) * 1e3, 3),
        "delivery_p99_ms": round(float(np.percentile(delivery - delivery.min(), 99)) * 1e3, 3),
        "worst_fraction_of_limit_send_clock": round(float(speed(gap_tx).max()), 4) if moving.any() else 0.0,
        "steps_beyond_limit_receipt_clock_no_allowance": beyond(0.0),
        "steps_beyond_limit_receipt_clock_2ms": beyond(0.002),
        "steps_beyond_limit_receipt_clock_spread": beyond(spread),
    }


def transitions(status, robot: str) -> list[tuple[str, int]]:
    """`robot`'s reasons as the status topic said them, each change once, with its level."""
    out: list[tuple[str, int]] = []
    for _, entries in status:
        for name, level, _, values in entries:
            if name == f"sgplvm/{robot}" and (not out or out[-1][0] != values["reason"]):
                out.append((values["reason"], level))
    return out


def report(name: str, figures: dict) -> None:
    """Prints the run's figures and, when ``SGPLVM_IMPAIRMENT_REPORT`` names a file, appends
    them to it as one JSON line (BENCHMARKS.md's figures)."""
    line = json.dumps({"run": name, **figures}, sort_keys=True)
    print(line)
    path = os.environ.get("SGPLVM_IMPAIRMENT_REPORT")
    if path:
        with open(path, "a") as f:
            f.write(line + "\n")


if __name__ == "__main__" and sys.argv[1:2] == ["subscribe"]:
    _subscribe(int(sys.argv[2]), sys.argv[3], sys.argv[4], sys.argv[5])
