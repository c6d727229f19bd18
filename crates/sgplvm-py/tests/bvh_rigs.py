"""BVH read, forward kinematics, re-rigging and writing for tests, written independently of the
Rust importer (``sgplvm_capture``): a motion capture in one convention becomes the same motion in
another convention's skeleton, and a file becomes the live streams a suit or a tracker would send
(ROS 2 TF transforms, Xsens MVN segment poses). A helper module, not a test.

BVH semantics (Biovision): every joint's frame is its parent's frame moved by the joint's
offset (or its position channels) and turned by its rotation channels in the order they are
listed (``Zrotation Xrotation Yrotation`` is ``Rz @ Rx @ Ry``); with every rotation channel at
zero every joint's frame has the world's axes, and the offsets draw the rest pose.

Conventions made from a capture (the rest pose is what differs, the motion is the same):

- ``cmu``: the capture as it is (names, rest pose and channels kept), cut and resampled;
- ``xsens``: Xsens MVN BVH export names (``Hips``, ``Chest`` …, ``LeftCollar``,
  ``LeftShoulder`` for the upper arm, ``LeftElbow``, ``LeftWrist``), a T-pose with flat clavicles
  (the arms straight out to the sides, which leaves the upper arm's twist untold), centimetres,
  ``Zrotation Xrotation Yrotation``, each hand ending at an End Site and the right one with a
  prop joint beside it;
- ``bandai``: the Bandai Namco Research motion datasets' layout: ``joint_Root``, ``Hips``,
  ``Spine``, ``Chest``, ``Shoulder_L``, ``UpperArm_L``, ``LowerArm_L``, ``Hand_L``; every bone
  along its joint's local x (the zero pose is a line of bones no person takes) and six channels
  on every joint;
- ``rokoko``: Rokoko Studio's layout: CMU's names, the pelvis in the world's axes with its first
  spine bone along y, every bone above it (and in the arms) along its joint's local x: the
  spine's zero pose folds at a right angle above the pelvis; ``Yrotation Xrotation Zrotation``;
- ``mixamo``: ``mixamorig:`` names, a T-pose, 2.5 times the scale (a rig scaled in its tool),
  ``Zrotation Yrotation Xrotation``;
- ``daz``: DAZ Genesis 8 names (``hip``, ``chestUpper``, ``neckLower``, ``lCollar``,
  ``lShldrBend``, ``lForearmBend``, ``lHand``), an A-pose (arms 45° below the shoulders),
  ``Yrotation Zrotation Xrotation``, and twist bones in the arms' chains (``lShldrTwist``,
  ``lForearmTwist``) carrying part of each segment's twist (:func:`with_twist_bones`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np


@dataclass
class Joint:
    name: str
    parent: int | None
    offset: np.ndarray
    channels: list[str]
    end_site: np.ndarray | None = None


@dataclass
class Bvh:
    joints: list[Joint]
    frame_time: float
    frames: np.ndarray  # frames × channels
    first: list[int] = field(default_factory=list)  # each joint's first channel

    def index(self, name: str) -> int:
        return next(i for i, j in enumerate(self.joints) if j.name == name)

    def children(self, i: int) -> list[int]:
        return [k for k, j in enumerate(self.joints) if j.parent == i]


def read(path) -> Bvh:
    words = open(path).read().split()
    joints: list[Joint] = []
    stack: list[int] = []
    k = 0
    pending_end = False
    while words[k] != "MOTION":
        w = words[k]
        if w in ("ROOT", "JOINT"):
            joints.append(Joint(words[k + 1], stack[-1] if stack else None, np.zeros(3), []))
            k += 2
        elif w == "End":
            pending_end = True
            k += 2
        elif w == "{":
            stack.append(-1 if pending_end else len(joints) - 1)
            k += 1
        elif w == "}":
            stack.pop()
            pending_end = False
            k += 1
        elif w == "OFFSET":
            v = np.array([float(x) for x in words[k + 1 : k + 4]])
            if pending_end:
                joints[stack[-2]].end_site = v
            else:
                joints[-1].offset = v
            k += 4
        elif w == "CHANNELS":
            n = int(words[k + 1])
            joints[-1].channels = words[k + 2 : k + 2 + n]
            k += 2 + n
        else:
            k += 1
    n_frames = int(words[k + 2])
    frame_time = float(words[k + 5])
    values = np.array([float(x) for x in words[k + 6 :]])
    bvh = Bvh(joints, frame_time, values.reshape(n_frames, -1))
    bvh.first = list(np.cumsum([0] + [len(j.channels) for j in joints])[:-1])
    return bvh


def axis_rotation(axis: str, degrees: float) -> np.ndarray:
    a = math.radians(degrees)
    c, s = math.cos(a), math.sin(a)
    return {
        "X": np.array([[1, 0, 0], [0, c, -s], [0, s, c]]),
        "Y": np.array([[c, 0, s], [0, 1, 0], [-s, 0, c]]),
        "Z": np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]]),
    }[axis]


def local(bvh: Bvh, frame: int, j: int):
    """Joint ``j``'s translation and rotation in its parent's frame at ``frame``."""
    joint = bvh.joints[j]
    t = joint.offset.copy()
    r = np.eye(3)
    positions = {}
    for c, ch in enumerate(joint.channels):
        v = bvh.frames[frame, bvh.first[j] + c]
        if ch.endswith("position"):
            positions[ch[0]] = v
        else:
            r = r @ axis_rotation(ch[0], v)
    if positions:
        t = np.array([positions.get(a, t[i]) for i, a in enumerate("XYZ")])
    return t, r


def world(bvh: Bvh, frame: int):
    """Every joint's world position and rotation at ``frame``."""
    p, r = [None] * len(bvh.joints), [None] * len(bvh.joints)
    for j, joint in enumerate(bvh.joints):
        t, q = local(bvh, frame, j)
        if joint.parent is None:
            p[j], r[j] = t, q
        else:
            p[j] = p[joint.parent] + r[joint.parent] @ t
            r[j] = r[joint.parent] @ q
    return p, r


def euler(r: np.ndarray, order: str) -> list[float]:
    """Degrees of the rotations about ``order``'s axes whose product (in that order) is ``r``."""
    i, j, k = ("XYZ".index(a) for a in order)
    # Rotation = R_i(a) R_j(b) R_k(c), a Tait–Bryan order (three distinct axes).
    sign = 1.0 if (j - i) % 3 == 1 else -1.0
    b = math.asin(max(-1.0, min(1.0, sign * r[i, k])))
    a = math.atan2(-sign * r[j, k], r[k, k])
    c = math.atan2(-sign * r[i, j], r[i, i])
    return [math.degrees(a), math.degrees(b), math.degrees(c)]


def minimal_rotation(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """The smallest rotation taking unit ``a`` to unit ``b``."""
    a, b = a / np.linalg.norm(a), b / np.linalg.norm(b)
    v, c = np.cross(a, b), float(a @ b)
    if c < -1 + 1e-12:
        # Half a turn about any axis across a.
        axis = np.cross(a, [1.0, 0, 0] if abs(a[0]) < 0.9 else [0, 1.0, 0])
        axis /= np.linalg.norm(axis)
        return 2 * np.outer(axis, axis) - np.eye(3)
    vx = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + vx + vx @ vx / (1 + c)


# The arm and spine joints of a CMU (cgspeed) capture and their names in each convention.
CMU_ROLES = {
    "Hips": "pelvis", "Spine1": "torso", "Neck": "neck", "Head": "head",
    "LeftShoulder": "lclav", "LeftArm": "lupper", "LeftForeArm": "lfore", "LeftHand": "lhand",
    "RightShoulder": "rclav", "RightArm": "rupper", "RightForeArm": "rfore", "RightHand": "rhand",
}  # fmt: skip

NAMES = {
    "xsens": {"pelvis": "Hips", "torso": "Chest4", "neck": "Neck", "head": "Head",
              "lclav": "LeftCollar", "lupper": "LeftShoulder", "lfore": "LeftElbow", "lhand": "LeftWrist",
              "rclav": "RightCollar", "rupper": "RightShoulder", "rfore": "RightElbow", "rhand": "RightWrist"},
    "bandai": {"pelvis": "Hips", "torso": "Chest", "neck": "Neck", "head": "Head",
               "lclav": "Shoulder_L", "lupper": "UpperArm_L", "lfore": "LowerArm_L", "lhand": "Hand_L",
               "rclav": "Shoulder_R", "rupper": "UpperArm_R", "rfore": "LowerArm_R", "rhand": "Hand_R"},
    "daz": {"pelvis": "hip", "torso": "chestUpper", "neck": "neckLower", "head": "head",
            "lclav": "lCollar", "lupper": "lShldrBend", "lfore": "lForearmBend", "lhand": "lHand",
            "rclav": "rCollar", "rupper": "rShldrBend", "rfore": "rForearmBend", "rhand": "rHand"},
    "rigify": {"pelvis": "DEF-spine", "torso": "DEF-spine.003", "neck": "DEF-spine.004", "head": "DEF-spine.006",
               "lclav": "DEF-shoulder.L", "lupper": "DEF-upper_arm.L", "lfore": "DEF-forearm.L", "lhand": "DEF-hand.L",
               "rclav": "DEF-shoulder.R", "rupper": "DEF-upper_arm.R", "rfore": "DEF-forearm.R", "rhand": "DEF-hand.R"},
    "mixamo": {r: "mixamorig:" + n for r, n in {
        "pelvis": "Hips", "torso": "Spine2", "neck": "Neck", "head": "Head",
        "lclav": "LeftShoulder", "lupper": "LeftArm", "lfore": "LeftForeArm", "lhand": "LeftHand",
        "rclav": "RightShoulder", "rupper": "RightArm", "rfore": "RightForeArm", "rhand": "RightHand"}.items()},
}  # fmt: skip

ORDER = {"cmu": None, "xsens": "ZXY", "bandai": "ZXY", "mixamo": "ZYX", "daz": "YZX", "rigify": "XYZ", "rokoko": "YXZ"}
SCALE = {"cmu": 1.0, "xsens": 1.0, "bandai": 1.0, "mixamo": 2.5, "daz": 1.0, "rigify": 1.0, "rokoko": 1.0}

# The twist bones of the ``daz`` and ``rigify`` styles: (segment's joint, twist bone's name), per
# role. Each takes part of its segment's twist; the segment's orientation a suit would stream is
# the twist bone's. DAZ's Genesis 8 names them; Blender's Rigify splits each segment in two
# deforming bones, the second (`.001`) the twisting half.
TWIST_BONES = {
    "daz": {"lupper": "lShldrTwist", "lfore": "lForearmTwist",
            "rupper": "rShldrTwist", "rfore": "rForearmTwist"},
    "rigify": {"lupper": "DEF-upper_arm.L.001", "lfore": "DEF-forearm.L.001",
               "rupper": "DEF-upper_arm.R.001", "rfore": "DEF-forearm.R.001"},
}  # fmt: skip


def body_axes(bvh: Bvh, torso: str, left_roots: tuple[str, str], pelvis: str, neck: str) -> np.ndarray:
    """Columns forward, left, up of the body at rest (world axes): left from the right clavicle's
    root to the left's, up from the pelvis to the neck, forward = left × up."""
    p, _ = world_rest(bvh)
    li, ri = bvh.index(left_roots[0]), bvh.index(left_roots[1])
    # Roots at one place (CMU's clavicles start at the torso joint): the next joints down.
    while np.linalg.norm(p[li] - p[ri]) < 1e-9:
        li, ri = bvh.children(li)[0], bvh.children(ri)[0]
    left = p[li] - p[ri]
    up = p[bvh.index(neck)] - p[bvh.index(pelvis)]
    up /= np.linalg.norm(up)
    left = left - up * (left @ up)
    left /= np.linalg.norm(left)
    return np.column_stack([np.cross(left, up), left, up])


def world_rest(bvh: Bvh):
    p = [None] * len(bvh.joints)
    for j, joint in enumerate(bvh.joints):
        p[j] = joint.offset.copy() if joint.parent is None else p[joint.parent] + joint.offset
    return p, None


def rerig(src: Bvh, style: str, first: int, frames: int, step: int) -> Bvh:
    """``frames`` frames of ``src`` from ``first``, every ``step``-th, in the convention ``style``
    (module docs): each joint's world rotation becomes ``W · Q`` with ``Q`` a constant that turns
    the new rest pose's bone onto the old one, so every joint stays where the capture put it."""
    roles = {src.index(n): r for n, r in CMU_ROLES.items()}
    names = NAMES.get(style, {})
    axes = body_axes(src, "Spine1", ("LeftShoulder", "RightShoulder"), "Hips", "Neck")
    left, up = axes[:, 1], axes[:, 2]
    q = [np.eye(3) for _ in src.joints]
    def bone_of(j: int):
        """The joint's bone: its first child's offset, down the chain past zero offsets."""
        at, v = j, np.zeros(3)
        while np.linalg.norm(v) == 0:
            kids = src.children(at)
            if not kids:
                return src.joints[at].end_site if at == j else v + (src.joints[at].end_site if src.joints[at].end_site is not None else 0)
            at = kids[0]
            v = v + src.joints[at].offset
        return v

    for j, joint in enumerate(src.joints):
        bone = bone_of(j)
        if bone is None or np.linalg.norm(bone) == 0 or style == "cmu":
            continue
        role = roles.get(j, "")
        if style == "rokoko" and src.joints[j].name in ("Hips", "LowerBack"):
            # Rokoko Studio: the pelvis in the world's axes, its first spine bone along y.
            continue
        if style in ("bandai", "rokoko"):
            # Every bone along local x: Q takes x onto the old bone.
            q[j] = minimal_rotation(np.array([1.0, 0, 0]), bone)
        elif role[1:] in ("clav", "upper", "fore", "hand"):
            # A T-pose with flat clavicles: every arm bone straight out to its side (DAZ's
            # Genesis 8: an A-pose, the arms 45° below).
            side = left if role[0] == "l" else -left
            if style == "daz":
                side = (side - up) / math.sqrt(2.0)
            q[j] = minimal_rotation(side, bone)
    if style == "daz":
        # The fingers keep their pose on the hand: turned with it into the A-pose.
        hands = {j for j, role in roles.items() if role[1:] == "hand"}
        for j in range(len(src.joints)):
            at = src.joints[j].parent
            while at is not None and at not in hands:
                at = src.joints[at].parent
            if at is not None:
                q[j] = q[at]
    out_joints: list[Joint] = []
    scale = SCALE[style]
    # Clavicles that start at the torso joint itself (CMU's) start half a unit to their side
    # in the Bandai rig, as the datasets' do: a line of bones needs them apart to tell left.
    moved = {}
    if style in ("bandai", "rokoko"):
        for j, role in roles.items():
            if role[1:] == "clav" and np.linalg.norm(src.joints[j].offset) == 0:
                moved[j] = (left if role[0] == "l" else -left) * 0.5
    for j, joint in enumerate(src.joints):
        parent = joint.parent
        qp = q[parent] if parent is not None else np.eye(3)
        name = names.get(roles.get(j, ""), ("mixamorig:" if style == "mixamo" else "") + joint.name)
        offset = scale * (qp.T @ moved.get(j, joint.offset))
        end = None if joint.end_site is None else scale * (q[j].T @ joint.end_site)
        order = ORDER[style]
        if style == "cmu":
            channels = list(joint.channels)
        elif style == "bandai":
            channels = ["Xposition", "Yposition", "Zposition"] + [a + "rotation" for a in order]
        else:
            channels = (["Xposition", "Yposition", "Zposition"] if parent is None else []) + [a + "rotation" for a in order]
        out_joints.append(Joint(name, parent, offset, channels, end))
    if style == "xsens":
        # Each hand ends at an End Site, the right one with a prop joint beside it (as an Xsens
        # export with a prop on the right hand: a ROS 2 TF tree of it has no frame where the
        # left hand ends).
        for r in ("lhand", "rhand"):
            h = next(i for i, rr in roles.items() if rr == r)
            out_joints[h].end_site = scale * (q[h].T @ (bone_of(h) * 1.5))
            if r == "rhand":
                out_joints.append(Joint(out_joints[h].name + "Prop", h, np.array([0.0, -2.0, 3.0]), ["Zrotation", "Xrotation", "Yrotation"]))
    rows = []
    for f in range(first, first + frames * step, step):
        p, r = world(src, f)
        row = []
        for j, joint in enumerate(out_joints):
            if j >= len(src.joints):
                row.extend([0.0, 0.0, 0.0])
                continue
            parent = joint.parent
            w = r[j] @ q[j]
            wp = (r[parent] @ q[parent]) if parent is not None else np.eye(3)
            rot = wp.T @ w
            if style == "cmu":
                row.extend(src.frames[f, src.first[j] : src.first[j] + len(joint.channels)])
                continue
            if joint.channels[0].endswith("position"):
                t = scale * p[j] if parent is None else joint.offset
                row.extend(list(t))
            row.extend(euler(rot, ORDER[style]))
        rows.append(row)
    out = Bvh(out_joints, src.frame_time * step, np.array(rows))
    out.first = list(np.cumsum([0] + [len(j.channels) for j in out_joints])[:-1])
    if style == "xsens":
        # No fingers: the hands end at their End Sites (and the right one's prop).
        hands = [names["lhand"], names["rhand"]]
        out = without_descendants(out, hands, keep=[h + "Prop" for h in hands])
    if style in TWIST_BONES:
        out = with_twist_bones(out, {names[r]: t for r, t in TWIST_BONES[style].items()})
    return out


def without_descendants(bvh: Bvh, ancestors: list[str], keep: list[str] = ()) -> Bvh:
    """``bvh`` without the joints below those named in ``ancestors`` (but those named in
    ``keep``), their channels left out of every frame."""
    top = {bvh.index(n) for n in ancestors}

    def below(j: int) -> bool:
        p = bvh.joints[j].parent
        while p is not None:
            if p in top:
                return True
            p = bvh.joints[p].parent
        return False

    kept = [j for j, joint in enumerate(bvh.joints) if not below(j) or joint.name in keep]
    new = {old: k for k, old in enumerate(kept)}
    joints = [
        Joint(bvh.joints[j].name, None if bvh.joints[j].parent is None else new[bvh.joints[j].parent],
              bvh.joints[j].offset, bvh.joints[j].channels, bvh.joints[j].end_site)
        for j in kept
    ]
    columns = [c for j in kept for c in range(bvh.first[j], bvh.first[j] + len(bvh.joints[j].channels))]
    out = Bvh(joints, bvh.frame_time, bvh.frames[:, columns])
    out.first = list(np.cumsum([0] + [len(j.channels) for j in joints])[:-1])
    return out


def with_twist_bones(bvh: Bvh, twist_bones: dict) -> Bvh:
    """``bvh`` with a twist bone halfway down each joint named in ``twist_bones`` (joint name →
    twist bone's name), as DAZ's Genesis 3 and 8 have them: the segment's child hangs from the
    twist bone, which turns about the bone's own axis by up to 40° (upper arm) or 20° (forearm),
    a motion of its own, and the segment's joint by as much less, so that every position and
    every orientation below is the same motion."""
    joints: list[Joint] = []
    new_index: dict[int, int] = {}
    inserted: dict[int, tuple[int, np.ndarray, float]] = {}  # twist index → (segment, axis, max °)
    for j, joint in enumerate(bvh.joints):
        parent = None if joint.parent is None else new_index[joint.parent]
        old_parent = None if joint.parent is None else bvh.joints[joint.parent]
        if old_parent is not None and old_parent.name in twist_bones:
            name = twist_bones[old_parent.name]
            half = joint.offset / 2
            rotations = [c for c in old_parent.channels if c.endswith("rotation")]
            joints.append(Joint(name, parent, half, rotations))
            most = 40.0 if "Shldr" in name else 20.0
            inserted[len(joints) - 1] = (joint.parent, half / np.linalg.norm(half), most)
            parent, offset = len(joints) - 1, half
        else:
            offset = joint.offset
        new_index[j] = len(joints)
        joints.append(Joint(joint.name, parent, offset, list(joint.channels), joint.end_site))
    out = Bvh(joints, bvh.frame_time, np.zeros((len(bvh.frames), sum(len(j.channels) for j in joints))))
    out.first = list(np.cumsum([0] + [len(j.channels) for j in joints])[:-1])
    for f in range(len(bvh.frames)):
        for j, joint in enumerate(bvh.joints):
            n = new_index[j]
            out.frames[f, out.first[n] : out.first[n] + len(joint.channels)] = bvh.frames[
                f, bvh.first[j] : bvh.first[j] + len(joint.channels)
            ]
        for t, (segment, axis, most) in inserted.items():
            a = most * math.sin(0.13 * f + t)
            turn = _about(axis, a)
            n = new_index[segment]
            seg = joints[n]
            _, r = local(out, f, n)
            rot = r @ turn.T
            order = "".join(c[0] for c in seg.channels if c.endswith("rotation"))
            k = [i for i, c in enumerate(seg.channels) if c.endswith("rotation")]
            for i, v in zip(k, euler(rot, order)):
                out.frames[f, out.first[n] + i] = v
            out.frames[f, out.first[t] : out.first[t] + 3] = euler(turn, order)
    return out


def _about(axis: np.ndarray, degrees: float) -> np.ndarray:
    """The rotation by ``degrees`` about unit ``axis`` (Rodrigues)."""
    a = math.radians(degrees)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(a) * k + (1 - math.cos(a)) * k @ k


def write(bvh: Bvh, path) -> None:
    """Writes ``bvh`` (its joints in depth-first order, as the file's channels are laid out)."""
    lines = ["HIERARCHY"]
    order: list[int] = []

    def emit(j: int, depth: int) -> None:
        pad = "\t" * depth
        joint = bvh.joints[j]
        order.append(j)
        lines.append(f"{pad}{'ROOT' if joint.parent is None else 'JOINT'} {joint.name}")
        lines.append(pad + "{")
        lines.append(f"{pad}\tOFFSET {' '.join(repr(float(v)) for v in joint.offset)}")
        lines.append(f"{pad}\tCHANNELS {len(joint.channels)} {' '.join(joint.channels)}")
        for k in bvh.children(j):
            emit(k, depth + 1)
        if joint.end_site is not None:
            lines.append(f"{pad}\tEnd Site")
            lines.append(pad + "\t{")
            lines.append(f"{pad}\t\tOFFSET {' '.join(repr(float(v)) for v in joint.end_site)}")
            lines.append(pad + "\t}")
        lines.append(pad + "}")

    emit(0, 0)
    lines += ["MOTION", f"Frames: {len(bvh.frames)}", f"Frame Time: {bvh.frame_time!r}"]
    for row in bvh.frames:
        values = [v for j in order for v in row[bvh.first[j] : bvh.first[j] + len(bvh.joints[j].channels)]]
        lines.append(" ".join(repr(float(v)) for v in values))
    with open(path, "w") as f:
        f.write("\n".join(lines) + "\n")
