"""Whole-arm retargeting against mink (issue 43, "Side by side with mink"): the same robot, the
same capture and, as far as mink allows, the same tasks, both results measured by this script's
own code (not sgplvm's Rust metrics), in one run.

* The human: ``data/demos/captured.mcap``'s frames of the human model's 18 joint angles. Its arm
  landmarks come from ``data/urdf/human.urdf`` through ``sgplvm.Robot.builtin("human")``'s forward
  kinematics, in its root frame (T8: x forward, y left, z up): the shoulder centre (where the
  shoulder flexion, abduction and rotation axes meet, after the clavicle joints), the elbow (the
  elbow flexion joint's origin), the wrist centre (where the two wrist axes meet) and the hand
  link. Per frame and arm: the upper arm's unit direction (shoulder centre → elbow), the
  forearm's (elbow → wrist centre) and the hand relative to the fixed shoulder point in units of
  reach (``sgplvm robot NAME --json``: arms, shoulder points, reach, elbow joint).
* sgplvm: ``sgplvm.retarget([robot], human, times_ns)`` (default ``match="arms"``), timed.
* mink: the robot's URDF loaded into MuJoCo as it is (a fixed base: MuJoCo's URDF import puts the
  root link in the world body; it drops the visual geoms and fuses the massless fixed links such
  as ``left_hand`` into their parents, so the hand point is added as a site with ``MjSpec``).
  Per frame, differential IK solved to convergence (≤ 40 steps, until no joint moves 1e-3 rad,
  each step bounded to 0.4 rad — sgplvm's settings) from the previous frame's solution:
  ``AxisAlignTask`` on the upper-arm and forearm bodies (each segment's direction is a fixed
  axis of that body on these robots: the same error ‖û − u‖ as sgplvm's direction task),
  ``FrameTask`` on the hand site with orientation cost 0 (its target rotation reset to the hand's
  own each step, so that its error is the position error), ``PostureTask`` towards the same
  neutral posture, ``ConfigurationLimit`` and ``CollisionAvoidanceLimit`` (10 mm margin) over
  every pair of the robot's own geoms that mink admits. Costs are the square roots of sgplvm's
  weights (mink weighs ‖cost·e‖²): upper arm 1, forearm 1, hand 2/reach, posture 0.1. The
  command is then the nearest safe one, as sgplvm's safety step: one ``solve_ik`` from the
  command before with a ``PostureTask`` on the converged posture, ``VelocityLimit`` (the URDF's
  velocities over the frame's dt), ``ConfigurationLimit`` and ``CollisionAvoidanceLimit``. mink
  runs twice: as it is usually run (from the previous frame only) and as sgplvm runs (also from
  the neutral posture, that one kept where its objective is lower by 0.1 %); the rows without
  the command step show the converged IK, and sgplvm's objective is compared at both.
* Measured alike: per frame and arm the direction errors (degrees), the hand error (fraction of
  reach), hands within 5 % of reach, self-collision with MuJoCo's ``mj_geomDistance`` over the
  pairs that can meet (sgplvm's rule: not neighbours, apart at the neutral posture), the fastest
  joint against its URDF velocity limit, and frames per second.

    python benches/retarget_vs_mink.py [--robot coman] [--frames N] [--solver daqp]

Needs the Python module (``maturin develop --release``), the CLI (``cargo build --release``) and
``pip install mink==1.3.0 mujoco==4.0.0`` (mink brings qpsolvers with daqp).
"""

import argparse
import json
import math
import pathlib
import platform
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from importlib.metadata import version

import numpy as np

import mink
import mujoco
import sgplvm

ROOT = pathlib.Path(__file__).resolve().parents[1]
SIDES = ("left", "right")
# sgplvm's defaults (crates/sgplvm-robots/src/retarget/whole_arm.rs, safety.rs).
WEIGHTS = {"upper_arm": 1.0, "forearm": 1.0, "hand": 4.0, "posture": 0.01}
MARGIN_M = 0.01
DETECT_IK_M = 0.05  # the IK's collision rows: detection distance and gain
GAIN_IK = 0.5
DETECT_SAFETY_M = 0.08  # the command's safety step
MAX_STEPS = 40
TOLERANCE = 1e-3
STEP_BOUND = 0.4
DAMPING = 1e-8


def cli_robot(name):
    """`sgplvm robot NAME --json` from the built CLI."""
    exe = ROOT / "target" / "release" / "sgplvm"
    out = subprocess.run([str(exe), "robot", name, "--json"], check=True, capture_output=True, text=True)
    return json.loads(out.stdout)


def urdf_joints(path):
    """Joint name → (parent link, child link, type, velocity limit) from a URDF."""
    joints = {}
    for j in ET.parse(path).getroot().iter("joint"):
        limit = j.find("limit")
        velocity = float(limit.get("velocity", "0")) if limit is not None else 0.0
        joints[j.get("name")] = (j.find("parent").get("link"), j.find("child").get("link"), j.get("type"), velocity)
    return joints


def meeting_point(origins, axes):
    """The point nearest to the lines (origin, unit axis), and its largest distance to them."""
    a = np.zeros((3, 3))
    b = np.zeros(3)
    for p, d in zip(origins, axes):
        m = np.eye(3) - np.outer(d, d)
        a += m
        b += m @ p
    x = np.linalg.solve(a, b)
    spread = max(np.linalg.norm((np.eye(3) - np.outer(d, d)) @ (x - p)) for p, d in zip(origins, axes))
    return x, spread


class Body:
    """One body's arm landmarks as points fixed on its links, evaluated with sgplvm's FK."""

    def __init__(self, name):
        self.name = name
        self.info = cli_robot(name)
        self.robot = sgplvm.Robot.builtin(name)
        self.urdf = ROOT / "data" / "urdf" / f"{name}.urdf"
        self.joints = urdf_joints(self.urdf)
        self.tree = ET.parse(self.urdf).getroot()
        self.names = list(self.robot.joint_names)
        self.hold = np.array(self.robot.hold_configuration, dtype=float)
        # Rows: the body frame's axes (forward, left, up) in the root frame.
        self.body = np.array(self.info["body_axes_in_root"], dtype=float)
        torso = self.fk(self.hold, self.info["torso_link"])
        self.arms = []
        for arm in self.info["arms"]:
            chain = arm["joints"]
            k = chain.index(arm["elbow_joint"])
            shoulder_joints, wrist_joints = chain[k - 3 : k], chain[-2:]
            shoulder, sh_link, sh_spread = self.meeting(shoulder_joints)
            wrist, wr_link, wr_spread = self.meeting(wrist_joints)
            if max(sh_spread, wr_spread) > 1e-3:
                raise SystemExit(f"{name} {arm['side']}: the shoulder or wrist axes do not meet ({sh_spread:.4f}, {wr_spread:.4f} m)")
            fixed = (torso @ np.append(np.array(arm["shoulder"], dtype=float), 1.0))[:3]
            self.arms.append(
                {
                    "side": arm["side"],
                    "joints": chain,
                    "elbow_joint": arm["elbow_joint"],
                    "reach": float(arm["reach_m"]),
                    "fixed_shoulder": fixed,
                    "neutral": dict(zip(chain, arm["neutral"])),
                    # landmark → (link, point in that link's frame)
                    "points": {
                        "shoulder": (sh_link, shoulder),
                        "elbow": (self.joints[arm["elbow_joint"]][1], np.zeros(3)),
                        "wrist": (wr_link, wrist),
                        "hand": (arm["to"], np.zeros(3)),
                    },
                }
            )

    def fk(self, q, link):
        return np.asarray(self.robot.forward_kinematics(list(q), link), dtype=float)

    def meeting(self, joint_names):
        """Where the joints' axes meet, in the frame of the last one's child link (at the hold
        posture; the point is on every one of these axes, so fixed on that link)."""
        origins, axes = [], []
        for j in joint_names:
            child = self.fk(self.hold, self.joints[j][1])
            axis = self.tree.find(f"joint[@name='{j}']/axis")
            a = np.array([float(v) for v in axis.get("xyz").split()]) if axis is not None else np.array([1.0, 0, 0])
            origins.append(child[:3, 3])
            axes.append(child[:3, :3] @ (a / np.linalg.norm(a)))
        x, spread = meeting_point(origins, axes)
        link = self.joints[joint_names[-1]][1]
        t = self.fk(self.hold, link)
        return t[:3, :3].T @ (x - t[:3, 3]), link, spread

    def landmarks(self, q):
        """Per arm: shoulder centre, elbow, wrist centre, hand, root frame."""
        cache = {}
        out = []
        for arm in self.arms:
            pts = {}
            for key, (link, local) in arm["points"].items():
                if link not in cache:
                    cache[link] = self.fk(q, link)
                t = cache[link]
                pts[key] = t[:3, :3] @ local + t[:3, 3]
            out.append(pts)
        return out

    def posture(self, q):
        """Per arm, body frame: upper-arm and forearm unit directions, hand from the fixed
        shoulder point in units of reach."""
        result = []
        for arm, p in zip(self.arms, self.landmarks(q)):
            u = p["elbow"] - p["shoulder"]
            f = p["wrist"] - p["elbow"]
            result.append(
                (
                    self.body @ (u / np.linalg.norm(u)),
                    self.body @ (f / np.linalg.norm(f)),
                    self.body @ (p["hand"] - arm["fixed_shoulder"]) / arm["reach"],
                )
            )
        return result

    def velocity_limits(self):
        return np.array([self.joints[n][3] for n in self.names])


def angle_deg(a, b):
    return math.degrees(math.atan2(np.linalg.norm(np.cross(a, b)), float(np.dot(a, b))))


class MinkRobot:
    """The robot in MuJoCo with mink's tasks and limits."""

    def __init__(self, body, solver):
        self.body = body
        self.solver = solver
        spec = mujoco.MjSpec.from_string(body.urdf.read_text())
        model0 = spec.compile()
        mj_bodies = {model0.body(b).name for b in range(model0.nbody)}
        parent_of = {child: parent for parent, child, _, _ in body.joints.values()}

        def mj_body(link):
            # Fixed, massless links are fused into their parents by MuJoCo's URDF import.
            while link not in mj_bodies and link in parent_of:
                link = parent_of[link]
            return link if link in mj_bodies else "world"

        data0 = mujoco.MjData(model0)
        self.qadr = np.array([model0.joint(n).qposadr[0] for n in body.names])
        self.qpos_of = lambda q: self._to_mj(model0, q)
        data0.qpos[:] = self._to_mj(model0, body.hold)
        mujoco.mj_kinematics(model0, data0)

        def local(link, point_world):
            b = model0.body(mj_body(link)).id
            r = data0.xmat[b].reshape(3, 3)
            return r.T @ (point_world - data0.xpos[b])

        marks = body.landmarks(body.hold)
        self.sites = []
        for arm, p in zip(body.arms, marks):
            name = f"{arm['side']}_hand_point"
            hand_link = arm["points"]["hand"][0]
            spec.body(mj_body(hand_link)).add_site(name=name, pos=local(hand_link, p["hand"]))
            self.sites.append(name)
        self.model = spec.compile()
        self.data = mujoco.MjData(self.model)
        # Each segment's direction as a fixed axis of one body: the upper arm on the elbow
        # joint's parent, the forearm on the elbow joint's child (checked below).
        self.segments = []
        for arm in body.arms:
            parent, child, _, _ = body.joints[arm["elbow_joint"]]
            self.segments.append(((mj_body(parent), "shoulder", "elbow"), (mj_body(child), "elbow", "wrist")))
        self.axes = [[self.axis_of(s, seg, body.hold) for seg in segs] for s, segs in enumerate(self.segments)]
        rng = np.random.default_rng(0)
        lo, hi = np.array(body.robot.joint_limits).T
        for _ in range(3):
            q = rng.uniform(lo, hi)
            for s, segs in enumerate(self.segments):
                for k, seg in enumerate(segs):
                    if np.linalg.norm(self.axis_of(s, seg, q) - self.axes[s][k]) > 1e-9:
                        raise SystemExit(f"{body.name}: segment {seg} is not a fixed axis of body {seg[0]}: no AxisAlignTask for it")
        # The MuJoCo world frame is sgplvm's root frame: the hand sites agree.
        q = rng.uniform(lo, hi)
        self.data.qpos[:] = self._to_mj(self.model, q)
        mujoco.mj_kinematics(self.model, self.data)
        for name, p in zip(self.sites, body.landmarks(q)):
            gap = np.linalg.norm(self.data.site(name).xpos - p["hand"])
            if gap > 1e-9:
                raise SystemExit(f"{body.name}: MuJoCo's {name} is {gap} m from sgplvm's hand")

        w = WEIGHTS
        self.upper = [
            mink.AxisAlignTask(self.segments[s][0][0], "body", axis=self.axes[s][0], cost=math.sqrt(w["upper_arm"]))
            for s in range(2)
        ]
        self.fore = [
            mink.AxisAlignTask(self.segments[s][1][0], "body", axis=self.axes[s][1], cost=math.sqrt(w["forearm"]))
            for s in range(2)
        ]
        self.hand = [
            mink.FrameTask(self.sites[s], "site", position_cost=math.sqrt(w["hand"]) / body.arms[s]["reach"], orientation_cost=0.0)
            for s in range(2)
        ]
        self.posture = mink.PostureTask(self.model, cost=math.sqrt(w["posture"]))
        neutral = body.hold.copy()
        for arm in body.arms:
            for n, v in arm["neutral"].items():
                neutral[body.names.index(n)] = v
        self.neutral_q = neutral
        self.posture.set_target(self._to_mj(self.model, neutral))
        self.tasks = self.upper + self.fore + self.hand + [self.posture]

        geoms = list(range(self.model.ngeom))
        self.avoid_ik = mink.CollisionAvoidanceLimit(
            self.model, [(geoms, geoms)], gain=GAIN_IK,
            minimum_distance_from_collisions=MARGIN_M, collision_detection_distance=DETECT_IK_M,
        )
        self.avoid_cmd = mink.CollisionAvoidanceLimit(
            self.model, [(geoms, geoms)], gain=1.0,
            minimum_distance_from_collisions=MARGIN_M, collision_detection_distance=DETECT_SAFETY_M,
        )
        self.pairs = sorted(self.avoid_ik.geom_id_pairs)
        arm_joints = [n for arm in body.arms for n in arm["joints"]]
        self.limits_ik = [
            mink.ConfigurationLimit(self.model),
            mink.VelocityLimit(self.model, {n: STEP_BOUND for n in arm_joints}),  # the step bound (dt = 1)
            self.avoid_ik,
        ]
        vmax = body.velocity_limits()
        self.cmd_task = mink.PostureTask(self.model, cost=1.0)
        self.limits_cmd = [
            mink.ConfigurationLimit(self.model),
            mink.VelocityLimit(self.model, {n: vmax[body.names.index(n)] for n in arm_joints}),
            self.avoid_cmd,
        ]
        self.cfg = mink.Configuration(self.model)
        self.cmd_cfg = mink.Configuration(self.model)

    def _to_mj(self, model, q):
        out = np.zeros(model.nq)
        out[self.qadr] = q
        return out

    def to_sg(self, qpos):
        return np.asarray(qpos)[self.qadr]

    def axis_of(self, s, seg, q):
        """Segment `seg` (mj body, from, to) of arm s as a unit axis in that body's frame."""
        model, data = self.model, self.data
        data.qpos[:] = self._to_mj(model, q)
        mujoco.mj_kinematics(model, data)
        p = self.body.landmarks(q)[s]
        d = p[seg[2]] - p[seg[1]]
        b = model.body(seg[0]).id
        return data.xmat[b].reshape(3, 3).T @ (d / np.linalg.norm(d))

    def set_targets(self, targets):
        """targets: per arm (upper-arm direction, forearm direction, hand point), root frame."""
        self.hand_targets = [h for _, _, h in targets]
        for s, (u, f, _) in enumerate(targets):
            self.upper[s].set_target(u)
            self.fore[s].set_target(f)

    def aim_hands(self, cfg):
        # Orientation is free: the target turned as the hand is, so that the error is the
        # position's.
        for s in range(2):
            now = cfg.get_transform_frame_to_world(self.sites[s], "site")
            self.hand[s].set_target(mink.SE3.from_rotation_and_translation(now.rotation(), self.hand_targets[s]))

    def cost(self, qpos):
        """The tasks' weighted squared errors at `qpos` (sgplvm's objective)."""
        cfg = self.cfg
        cfg.update(qpos)
        self.aim_hands(cfg)
        return sum(float(np.sum((t.cost * t.compute_error(cfg)) ** 2)) for t in self.tasks)

    def converge(self, qpos):
        """Differential IK from `qpos` to convergence; returns (qpos, steps, failed)."""
        cfg = self.cfg
        cfg.update(qpos)
        steps = 0
        for _ in range(MAX_STEPS):
            self.aim_hands(cfg)
            try:
                v = mink.solve_ik(cfg, self.tasks, 1.0, self.solver, damping=DAMPING, limits=self.limits_ik)
            except mink.NoSolutionFound:
                return cfg.q.copy(), steps, True
            cfg.integrate_inplace(v, 1.0)
            steps += 1
            if np.max(np.abs(v)) < TOLERANCE:
                break
        return cfg.q.copy(), steps, False

    def command(self, previous, ideal, dt):
        """The nearest safe command to `ideal` from `previous` over `dt` seconds."""
        cfg = self.cmd_cfg
        cfg.update(previous)
        self.cmd_task.set_target(ideal)
        try:
            v = mink.solve_ik(cfg, [self.cmd_task], dt, self.solver, damping=DAMPING, limits=self.limits_cmd)
        except mink.NoSolutionFound:
            return previous.copy(), True
        return cfg.integrate(v, dt), False


def run_mink(robot, targets, times_s, two_starts=False):
    """Every frame: converge from the previous frame's posture (with `two_starts`, also from the
    neutral posture, kept where better by 0.1 %: sgplvm's rule), then the safe command."""
    n = len(targets)
    ideal = np.zeros((n, len(robot.body.names)))
    sent = np.zeros_like(ideal)
    neutral = robot.qpos_of(robot.neutral_q)
    q = neutral.copy()
    cmd = None
    steps = fails = 0
    t0 = time.perf_counter()
    for f in range(n):
        robot.set_targets(targets[f])
        q, k, failed = robot.converge(q)
        steps += k
        fails += failed
        if two_starts:
            cold, k, failed = robot.converge(neutral)
            steps += k
            fails += failed
            if robot.cost(cold) < robot.cost(q) * (1.0 - 1e-3) - 1e-6:
                q = cold
        if cmd is None:
            cmd = q.copy()
        else:
            cmd, failed = robot.command(cmd, q, times_s[f] - times_s[f - 1])
            fails += failed
        ideal[f] = robot.to_sg(q)
        sent[f] = robot.to_sg(cmd)
    return sent, ideal, time.perf_counter() - t0, steps / n, fails


def mj_cost(mj, target, q):
    mj.set_targets(target)
    return mj.cost(mj.qpos_of(q))


class Judge:
    """The same measures for any result (frames × the robot's joints, sgplvm's order)."""

    def __init__(self, body, mj, human_postures, times_s):
        self.body = body
        self.mj = mj
        self.human = human_postures
        self.times = times_s
        # Pairs that can meet (sgplvm's rule): mink's admitted pairs (not the same body, not
        # parent and child), less those already overlapping at the neutral posture.
        self.data = mujoco.MjData(mj.model)
        self.data.qpos[:] = mj.qpos_of(mj.neutral_q)
        mujoco.mj_kinematics(mj.model, self.data)
        self.pairs = [p for p in mj.pairs if self.distance(p, 1.0) > 0.0]

    def distance(self, pair, distmax):
        fromto = np.zeros(6)
        return mujoco.mj_geomDistance(self.mj.model, self.data, pair[0], pair[1], distmax, fromto)

    def __call__(self, q):
        upper, fore, hand = [], [], []
        colliding = near = 0
        closest, worst = math.inf, (None, None)
        dists = []
        for f, row in enumerate(q):
            got = self.body.posture(row)
            for (gu, gf, gh), (hu, hf, hh) in zip(got, self.human[f]):
                upper.append(angle_deg(gu, hu))
                fore.append(angle_deg(gf, hf))
                hand.append(float(np.linalg.norm(gh - hh)))
            self.data.qpos[:] = self.mj.qpos_of(row)
            mujoco.mj_kinematics(self.mj.model, self.data)
            d, pair = min(((self.distance(p, 0.1), p) for p in self.pairs), default=(math.inf, None))
            dists.append(d)
            if d < closest:
                closest, worst = d, (pair, f)
            colliding += d < 0.0
            near += d < MARGIN_M - 1e-4
        step = np.abs(np.diff(q, axis=0))
        jumps = int(((step.max(axis=1) > 0.5) & (np.diff(self.times) < 0.1)).sum())
        speed = step / np.diff(self.times)[:, None]
        ratio = speed / self.body.velocity_limits()[None, :]
        q90 = lambda v: float(np.quantile(v, 0.9))  # noqa: E731
        return {
            "upper_deg": (float(np.median(upper)), q90(upper)),
            "forearm_deg": (float(np.median(fore)), q90(fore)),
            "hand_of_reach": (float(np.median(hand)), q90(hand)),
            "hands_within_5pct": float(np.mean(np.array(hand) <= 0.05)),
            "colliding_frames": int(colliding),
            "inside_margin_frames": int(near),
            "closest_mm": 1e3 * closest,
            "max_speed_of_limit": float(ratio.max()) if ratio.size else 0.0,
            "over_speed_frames": int(np.any(ratio > 1.0 + 1e-6, axis=1).sum()),
            "jumps": jumps,
            "distances": np.array(dists),
            "worst_pair": self.pair_name(worst[0]),
            "worst_frame": worst[1],
        }

    def pair_name(self, pair):
        if pair is None:
            return None
        model = self.mj.model
        root = self.body.info["root_link"]  # fused into MuJoCo's world body
        return " – ".join(model.body(model.geom_bodyid[g]).name.replace("world", root) for g in pair)


def row(label, m, fps):
    return (
        f"| {label} | {m['upper_deg'][0]:.1f} / {m['upper_deg'][1]:.1f} | {m['forearm_deg'][0]:.1f} / {m['forearm_deg'][1]:.1f} "
        f"| {m['hand_of_reach'][0]:.3f} / {m['hand_of_reach'][1]:.3f} | {100 * m['hands_within_5pct']:.1f} % "
        f"| {m['colliding_frames']} ({m['inside_margin_frames']}) | {m['closest_mm']:.1f} "
        f"| {m['max_speed_of_limit']:.2f} ({m['over_speed_frames']}) | {m['jumps']} | {fps} |"
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--robot", default="coman")
    ap.add_argument("--frames", type=int, default=None, help="the first N frames (default: all)")
    ap.add_argument("--demos", default=str(ROOT / "data" / "demos" / "captured.mcap"))
    ap.add_argument("--solver", default="daqp", help="qpsolvers backend for mink (mink's own dependency: daqp)")
    args = ap.parse_args()

    demos = sgplvm.load_demonstrations(args.demos)
    human_q = np.ascontiguousarray(demos["human"]["positions"][: args.frames], dtype=float)
    times_ns = np.ascontiguousarray(demos["times_ns"][: args.frames], dtype=np.int64)
    times_s = (times_ns - times_ns[0]) * 1e-9
    n = len(times_ns)

    human = Body("human")
    if human.names != list(demos["human"]["joint_names"]):
        raise SystemExit("the capture's joints are not the human model's")
    robot = Body(args.robot)
    human_postures = [human.posture(q) for q in human_q]
    # The robot's targets, root frame: directions as the human's, the hand at the robot's
    # fixed shoulder point plus its reach times the human's hand in reach.
    targets = [
        [
            (robot.body.T @ u, robot.body.T @ f, arm["fixed_shoulder"] + arm["reach"] * (robot.body.T @ h))
            for arm, (u, f, h) in zip(robot.arms, frame)
        ]
        for frame in human_postures
    ]

    # sgplvm
    t0 = time.perf_counter()
    ours = sgplvm.retarget([args.robot], human_q, times_ns)[args.robot]
    ours_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    ours_free = sgplvm.retarget([args.robot], human_q, times_ns, velocity_limits=False)[args.robot]
    ours_free_s = time.perf_counter() - t0

    def full(result):
        q = np.tile(robot.hold, (n, 1))
        for c, name in enumerate(result["joint_names"]):
            q[:, robot.names.index(name)] = result["positions"][:, c]
        return q

    # mink
    mj = MinkRobot(robot, args.solver)
    mink_sent, mink_ideal, mink_s, mink_steps, mink_fails = run_mink(mj, targets, times_s)
    mink2_sent, mink2_ideal, mink2_s, mink2_steps, mink2_fails = run_mink(mj, targets, times_s, two_starts=True)

    judge = Judge(robot, mj, human_postures, times_s)
    results = [
        ("sgplvm `--match arms` (sent)", judge(full(ours)), f"{n / ours_s:,.0f}"),
        (f"mink {version('mink')} + {args.solver} (sent)", judge(mink_sent), f"{n / mink_s:,.0f}"),
        ("mink, two starts a frame as sgplvm (sent)", judge(mink2_sent), f"{n / mink2_s:,.0f}"),
        ("sgplvm, no velocity limits", judge(full(ours_free)), f"{n / ours_free_s:,.0f}"),
        ("mink, converged IK before the command step", judge(mink_ideal), "—"),
        ("mink two starts, converged IK before the command step", judge(mink2_ideal), "—"),
    ]
    shown = pathlib.Path(args.demos).resolve()
    shown = shown.relative_to(ROOT) if shown.is_relative_to(ROOT) else shown
    print(f"{args.robot}, {shown} ({n} frames, {1 / np.median(np.diff(times_s)) if n > 1 else 0:.0f} Hz); "
          f"{len(judge.pairs)} geom pairs that can meet (sgplvm's report: {ours['report']['posture']['pairs']}); "
          f"{platform.node()}, {platform.python_version()}, mujoco {mujoco.__version__}")
    print()
    print("| result | upper arm ° (median / p90) | forearm ° | hand / reach (median / p90) | hands ≤ 5 % of reach "
          "| frames in self-collision (inside 10 mm) | closest mm | fastest joint / its limit (frames over) "
          "| jumps > 0.5 rad in a frame | frames/s |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for label, m, fps in results:
        print(row(label, m, fps))
    print()
    p = ours["report"]["posture"]
    print(f"sgplvm: {ours_s:.2f} s ({p['steps_per_frame']:.1f} Gauss–Newton steps a frame, two starts each; "
          f"its own report: upper {p['upper_arm_deg'][0]:.1f}/{p['upper_arm_deg'][1]:.1f}°, forearm "
          f"{p['forearm_deg'][0]:.1f}/{p['forearm_deg'][1]:.1f}°, hand {p['hand_of_reach'][0]:.3f}/{p['hand_of_reach'][1]:.3f}, "
          f"{100 * p['hands_within_5pct']:.1f} % within 5 %, {p['colliding_frames']} colliding, closest {'(none near)' if p['closest_m'] is None else format(1e3 * p['closest_m'], '.1f') + ' mm'}, "
          f"velocity-limited frames {p['velocity_limited_frames']}, collision-limited {p['collision_limited_frames']})")
    print(f"mink: {mink_s:.2f} s ({mink_steps:.1f} solve_ik steps a frame from the previous frame, "
          f"{mink_fails} QP failures); two starts: {mink2_s:.2f} s ({mink2_steps:.1f} steps a frame, {mink2_fails} failures)")
    # The same objective (sgplvm's weights) at each converged posture: who found the lower one.
    # Frames where both keep the margin only (a posture inside it can buy a lower objective).
    costs = {
        label: np.array([mj_cost(mj, targets[f], q[f]) for f in range(n)])
        for label, q in (("sgplvm", full(ours_free)), ("mink", mink_ideal), ("mink two starts", mink2_ideal))
    }
    clear = {"sgplvm": results[3][1], "mink": results[4][1], "mink two starts": results[5][1]}
    for other in ("mink", "mink two starts"):
        keep = (clear["sgplvm"]["distances"] >= MARGIN_M - 1e-4) & (clear[other]["distances"] >= MARGIN_M - 1e-4)
        a, b = costs["sgplvm"][keep], costs[other][keep]
        print(f"objective at the converged posture, sgplvm (no velocity limits) against {other}, {int(keep.sum())} "
              f"frames where both keep the margin: median {np.median(a):.4f} / {np.median(b):.4f}; sgplvm's higher "
              f"by > 10 % in {int((a > 1.1 * b).sum())} frames, {other}'s in {int((b > 1.1 * a).sum())}")
    for label, m, _ in results:
        if m["worst_pair"]:
            print(f"{label}: closest pair {m['worst_pair']} at frame {m['worst_frame']}")


if __name__ == "__main__":
    main()
