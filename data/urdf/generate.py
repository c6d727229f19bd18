#!/usr/bin/env python3
"""Writes the body models of sgplvm (walkman, coman, centauro, human, ur5e) as URDF files.

The kinematic numbers are those of /work/shared/ROBOTS.md (public descriptions of IIT's WALK-MAN,
COMAN and CENTAURO, and an Xsens-MVN-style 9-joint human arm for a 1.75 m person) and, for the
6-joint ur5e, Universal Robots' published UR5e DH table (see data/urdf/README.md). Everything
else is ours and deliberately simple:

* the root link is the torso (no waist joint); the only movable joints are the arm joints,
  written left arm then right arm, shoulder to wrist -- the column order of R and H;
* each link carries one collision cylinder along its segment (the vector to the next joint),
  trimmed by radius + 5 mm at both ends so that neighbouring segments do not touch at rest;
  segments shorter than that get no collision shape; the last link carries a hand box; the torso
  is a box narrow enough to clear the hanging arms; visuals repeat the collision shapes;
* inertias are those of solid cylinders / boxes of the listed masses, in frames aligned with the
  shapes; shape-less links get 0.1 kg and a 2 cm sphere's inertia;
* fixed frame links `left_shoulder`/`right_shoulder` (children of the torso, at the point
  closest to the shoulder axes at zero pose -- the first three; the ur5e's first two, which
  meet -- the shoulder joint centre) and
  `left_hand`/`right_hand` (at the hand offset below the last wrist joint).

Run from anywhere: `python3 data/urdf/generate.py` rewrites data/urdf/*.urdf (stdlib only).
"""
import math
import os

HERE = os.path.dirname(os.path.abspath(__file__))


# Decimal places of every number written (set per robot by build(): 15 for the ur5e, whose DH
# angles must not be rounded to 1e-9 when its kinematics are checked to 1e-9).
DIGITS = 9


def fmt(x):
    s = repr(round(float(x), DIGITS))
    return "0" if s in ("0.0", "-0.0") else (s[:-2] if s.endswith(".0") else s)


def vec(v):
    return " ".join(fmt(x) for x in v)


# --- small rotation helpers (URDF convention: R = Rz(yaw) Ry(pitch) Rx(roll)) -------------------
def rpy_matrix(r, p, y):
    cr, sr, cp, sp, cy, sy = math.cos(r), math.sin(r), math.cos(p), math.sin(p), math.cos(y), math.sin(y)
    return [
        [cy * cp, cy * sp * sr - sy * cr, cy * sp * cr + sy * sr],
        [sy * cp, sy * sp * sr + cy * cr, sy * sp * cr - cy * sr],
        [-sp, cp * sr, cp * cr],
    ]


def matmul(a, b):
    return [[sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)] for i in range(3)]


def matvec(a, v):
    return [sum(a[i][k] * v[k] for k in range(3)) for i in range(3)]


def add(a, b):
    return [x + y for x, y in zip(a, b)]


def norm(v):
    return math.sqrt(sum(x * x for x in v))


def rpy_aligning_z(d):
    """rpy of a frame whose z axis points along d (roll about x, then pitch about y)."""
    x, y, z = (c / norm(d) for c in d)
    # Ry(pitch) Rx(roll) z = (sin p cos r, -sin r, cos p cos r) = d.
    roll = math.atan2(-y, math.sqrt(x * x + z * z))
    pitch = math.atan2(x, z)
    return [roll, pitch, 0.0]


def solve3(a, b):
    """Solves a 3x3 system by Cramer's rule."""
    def det(m):
        return (m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1])
                - m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0])
                + m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]))
    d = det(a)
    out = []
    for c in range(3):
        m = [row[:] for row in a]
        for r in range(3):
            m[r][c] = b[r]
        out.append(det(m) / d)
    return out


def closest_point_to_lines(points, dirs):
    a = [[0.0] * 3 for _ in range(3)]
    b = [0.0] * 3
    for p, d in zip(points, dirs):
        n = norm(d)
        d = [c / n for c in d]
        proj = [[(1.0 if i == j else 0.0) - d[i] * d[j] for j in range(3)] for i in range(3)]
        for i in range(3):
            for j in range(3):
                a[i][j] += proj[i][j]
            b[i] += sum(proj[i][k] * p[k] for k in range(3))
    return solve3(a, b)


# --- writing --------------------------------------------------------------------------------------
def inertial_xml(mass, origin_xyz, origin_rpy, ixx, iyy, izz, indent="    "):
    return (
        f"{indent}<inertial>\n"
        f"{indent}  <origin xyz=\"{vec(origin_xyz)}\" rpy=\"{vec(origin_rpy)}\"/>\n"
        f"{indent}  <mass value=\"{fmt(mass)}\"/>\n"
        f"{indent}  <inertia ixx=\"{fmt(ixx)}\" ixy=\"0\" ixz=\"0\" iyy=\"{fmt(iyy)}\" iyz=\"0\" izz=\"{fmt(izz)}\"/>\n"
        f"{indent}</inertial>\n"
    )


def shape_xml(tag, xyz, rpy, geometry, material=None, indent="    "):
    mat = f"\n{indent}  <material name=\"{material}\"/>" if material and tag == "visual" else ""
    return (
        f"{indent}<{tag}>\n"
        f"{indent}  <origin xyz=\"{vec(xyz)}\" rpy=\"{vec(rpy)}\"/>\n"
        f"{indent}  <geometry>{geometry}</geometry>{mat}\n"
        f"{indent}</{tag}>\n"
    )


def link_with_cylinder(name, seg, radius, density, material, mass=None):
    """A link whose shape is a cylinder along `seg` (link frame), trimmed at both ends.

    `mass` (kg) replaces the cylinder's density-based mass when a data sheet gives one; a link
    too short for a shape then gets the inertia of a solid sphere of `radius` at its joint."""
    length = norm(seg)
    trim = radius + 0.005
    usable = length - 2 * trim
    if usable < 0.01:
        if mass is None:
            mass, r = 0.1, 0.02
        else:
            r = radius
        i = 0.4 * mass * r ** 2
        return f"  <link name=\"{name}\">\n" + inertial_xml(mass, [0, 0, 0], [0, 0, 0], i, i, i) + "  </link>\n"
    mid = [c / 2 for c in seg]
    rpy = rpy_aligning_z(seg)
    if mass is None:
        mass = density * math.pi * radius ** 2 * usable
    ixx = mass * (3 * radius ** 2 + usable ** 2) / 12
    izz = mass * radius ** 2 / 2
    geom = f"<cylinder radius=\"{fmt(radius)}\" length=\"{fmt(usable)}\"/>"
    return (
        f"  <link name=\"{name}\">\n"
        + inertial_xml(mass, mid, rpy, ixx, ixx, izz)
        + shape_xml("visual", mid, rpy, geom, material)
        + shape_xml("collision", mid, rpy, geom)
        + "  </link>\n"
    )


def link_with_hand(name, offset, width, thickness, density, material, mass=None):
    """The last arm link: a box from 2 cm past the wrist to the hand point (plus 2 cm); `mass`
    (kg) replaces the box's density-based mass when a data sheet gives one."""
    length = norm(offset)
    start = 0.02 / length
    mid = [c * (start + 0.5) for c in offset]
    rpy = rpy_aligning_z(offset)
    size = [width, thickness, length]
    if mass is None:
        mass = density * width * thickness * length
    ixx = mass * (thickness ** 2 + length ** 2) / 12
    iyy = mass * (width ** 2 + length ** 2) / 12
    izz = mass * (width ** 2 + thickness ** 2) / 12
    geom = f"<box size=\"{vec(size)}\"/>"
    return (
        f"  <link name=\"{name}\">\n"
        + inertial_xml(mass, mid, rpy, ixx, iyy, izz)
        + shape_xml("visual", mid, rpy, geom, material)
        + shape_xml("collision", mid, rpy, geom)
        + "  </link>\n"
    )


def joint_xml(name, kind, parent, child, xyz, rpy=(0, 0, 0), axis=None, limits=None, vel=0, effort=0):
    s = f"  <joint name=\"{name}\" type=\"{kind}\">\n"
    s += f"    <origin xyz=\"{vec(xyz)}\" rpy=\"{vec(rpy)}\"/>\n"
    s += f"    <parent link=\"{parent}\"/>\n    <child link=\"{child}\"/>\n"
    if axis is not None:
        s += f"    <axis xyz=\"{vec(axis)}\"/>\n"
    if limits is not None:
        s += (f"    <limit lower=\"{fmt(limits[0])}\" upper=\"{fmt(limits[1])}\" "
              f"effort=\"{fmt(effort)}\" velocity=\"{fmt(vel)}\"/>\n")
        s += "    <dynamics damping=\"0.1\" friction=\"0\"/>\n"
    s += "  </joint>\n"
    return s


def arm_xml(arm, root, radius, density, effort):
    """Links and joints of one arm; returns (xml, shoulder centre in root frame)."""
    joints = arm["joints"]
    out = ""
    # Zero-pose frames to find the shoulder centre.
    rot = [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
    pos = [0.0, 0.0, 0.0]
    points, dirs = [], []
    parent = root
    for k, j in enumerate(joints):
        pos = add(pos, matvec(rot, j["xyz"]))
        rot = matmul(rot, rpy_matrix(*j.get("rpy", (0, 0, 0))))
        if k in arm["shoulder_axes"]:
            points.append(pos)
            dirs.append(matvec(rot, j["axis"]))
        child = j["link"]
        out += joint_xml(j["name"], "revolute", parent, child, j["xyz"], j.get("rpy", (0, 0, 0)),
                         j["axis"], (j["lower"], j["upper"]), j["velocity"], j.get("effort", effort))
        if k + 1 < len(joints):
            seg = joints[k + 1]["xyz"]
            out += link_with_cylinder(child, seg, j.get("radius", radius), density, "arm", j.get("mass"))
        else:
            out += link_with_hand(child, arm["hand"], arm.get("hand_width", 0.08), 0.03, density, "hand",
                                  j.get("mass"))
        parent = child
    hand = arm["side"] + "_hand"
    out += f"  <link name=\"{hand}\"/>\n"
    out += joint_xml(hand + "_frame", "fixed", parent, hand, arm["hand"])
    centre = closest_point_to_lines(points, dirs)
    return out, centre


def mirror_origin(xyz):
    return [xyz[0], -xyz[1], xyz[2]]


def build(robot):
    global DIGITS
    DIGITS = robot.get("digits", 9)
    try:
        return build_xml(robot)
    finally:
        DIGITS = 9


def build_xml(robot):
    name = robot["name"]
    root = robot["root"]
    radius = robot["radius"]
    density = robot["density"]
    body = ""
    centres = {}
    for arm in robot["arms"]:
        xml, centre = arm_xml(arm, root, radius, density, robot["effort"])
        body += xml
        centres[arm["side"]] = centre
    # Torso box: clears the hanging arms (half width = shoulder y - radius - 2 cm) and ends 3 cm
    # below the shoulder centres.
    half_w = robot.get("torso_half_width",
                       min(abs(centres["left"][1]), abs(centres["right"][1])) - radius - 0.02)
    top = min(centres["left"][2], centres["right"][2]) - 0.03 - robot.get("torso_top_clearance", 0.0)
    height = robot["torso_height"]
    depth = robot["torso_depth"]
    centre = [robot.get("torso_x", 0.0), 0.0, top - height / 2]
    mass = robot["torso_mass"]
    size = [depth, 2 * half_w, height]
    geom = f"<box size=\"{vec(size)}\"/>"
    torso = (
        f"  <link name=\"{root}\">\n"
        + inertial_xml(mass, centre, [0, 0, 0], mass * (size[1] ** 2 + size[2] ** 2) / 12,
                       mass * (size[0] ** 2 + size[2] ** 2) / 12, mass * (size[0] ** 2 + size[1] ** 2) / 12)
        + shape_xml("visual", centre, [0, 0, 0], geom, "body")
        + shape_xml("collision", centre, [0, 0, 0], geom)
        + "  </link>\n"
    )
    frames = ""
    for side in ("left", "right"):
        frames += f"  <link name=\"{side}_shoulder\"/>\n"
        frames += joint_xml(f"{side}_shoulder_frame", "fixed", root, f"{side}_shoulder", centres[side])
    head = (
        f"<?xml version=\"1.0\"?>\n"
        f"<!-- {robot['comment']}\n"
        f"     Generated by data/urdf/generate.py from {robot.get('source', 'the numbers in ROBOTS.md')}; do not edit by hand. -->\n"
        f"<robot name=\"{name}\">\n"
        f"  <material name=\"body\"><color rgba=\"0.6 0.6 0.65 1\"/></material>\n"
        f"  <material name=\"arm\"><color rgba=\"0.85 0.45 0.1 1\"/></material>\n"
        f"  <material name=\"hand\"><color rgba=\"0.2 0.2 0.2 1\"/></material>\n"
    )
    return head + torso + frames + body + "</robot>\n"


def mirror_arm(left, side_names, overrides):
    """Right arm: origins with y negated; names/limits/axes/rpy from `overrides` per joint index."""
    joints = []
    for k, j in enumerate(left["joints"]):
        r = dict(j)
        r["xyz"] = mirror_origin(j["xyz"])
        r["name"], r["link"] = side_names[k]
        r.update(overrides.get(k, {}))
        joints.append(r)
    arm = dict(left)
    arm["joints"] = joints
    arm["side"] = "right"
    arm["hand"] = mirror_origin(left["hand"])
    return arm


def deg(x):
    return x * math.pi / 180


def coman():
    v = 4.0
    rows = [
        ("LShSag", "LShp", [-0.0149765, 0.0825, 0.157708], [0, 1, 0], -3.4034, 1.6581),
        ("LShLat", "LShr", [0, 0.0733, 0], [1, 0, 0], -0.31415, 2.094),
        ("LShYaw", "LShy", [0, 0, -0.0448085], [0, 0, 1], -1.5708, 1.5708),
        ("LElbj", "LElb", [0.015, 0, -0.135192], [0, 1, 0], -2.3562, 0),
        ("LForearmPlate", "LForearm", [-0.015, 0, -0.1078], [0, 0, 1], -1.5708, 1.5708),
        ("LWrj1", "LWrMot2", [0, 0, -0.08688], [0, 1, 0], -0.524, 0.524),
        ("LWrj2", "LWrMot3", [0, 0, 0], [1, 0, 0], -0.785375, 1.395),
    ]
    left = {"side": "left", "shoulder_axes": [0, 1, 2], "hand": [0, 0, -0.07],
            "joints": [dict(name=n, link=l, xyz=x, axis=a, lower=lo, upper=hi, velocity=v)
                       for n, l, x, a, lo, hi in rows]}
    names = [("R" + n[1:], "R" + l[1:]) for n, l, *_ in rows]
    right = mirror_arm(left, names, {1: dict(lower=-2.094, upper=0.31415),
                                     6: dict(lower=-1.395, upper=0.785375)})
    return dict(name="coman", root="DWYTorso", radius=0.035, density=1200.0, effort=50.0,
                torso_height=0.35, torso_depth=0.16, torso_mass=8.0, arms=[left, right],
                comment="COMAN upper body (IIT): torso and two 7-joint arms.")


def walkman():
    v = 6.283
    rows = [
        ("LShSag", "LShp", [0.045646, 0.219164, 0.001531], [0, 0, -0.3491], [0, 0.743145, 0.669131], -2.87979, 2.79253),
        ("LShLat", "LShr", [0, 0.116568, 0.03364], [0, 0, 0], [1, 0, 0], 0.0872665, 3.85718),
        ("LShYaw", "LShy", [0, 0, -0.222], [0, 0, 0], [0, 0, 1], -2.84489, 2.84489),
        ("LElbj", "LElb", [0.036, 0, -0.15], [0, 0, 0], [0, 1, 0], -2.96706, 0.593412),
        ("LForearmPlate", "LForearm", [-0.075, 0, -0.1955], [0, 0, 0], [0, 0, 1], -2.529, 2.529),
        ("LWrj1", "LWrMot2", [0, 0, 0], [0, 0, 0], [0, 1, 0], -1.48, 1.48),
        ("LWrj2", "LWrMot3", [0, 0, -0.092], [0, 0, 0], [1, 0, 0], -1.48, 1.48),
    ]
    left = {"side": "left", "shoulder_axes": [0, 1, 2], "hand": [0, -0.0305, -0.21], "hand_width": 0.1,
            "joints": [dict(name=n, link=l, xyz=x, rpy=r, axis=a, lower=lo, upper=hi, velocity=v)
                       for n, l, x, r, a, lo, hi in rows]}
    names = [("R" + n[1:], "R" + l[1:]) for n, l, *_ in rows]
    right = mirror_arm(left, names, {
        0: dict(rpy=[0, 0, 0.3491], axis=[0, 0.743145, -0.669131], lower=-2.84489, upper=2.80998),
        1: dict(lower=-3.85718, upper=-0.122173),
        2: dict(lower=-2.86234, upper=2.82743),
    })
    return dict(name="walkman", root="DWYTorso", radius=0.045, density=1200.0, effort=200.0,
                torso_height=0.45, torso_depth=0.25, torso_mass=20.0, arms=[left, right],
                comment="WALK-MAN upper body (IIT): torso and two 7-joint arms; its shoulder axes do not meet in one point.")


def centauro():
    vels = [5.7 + (20.0 - 5.7) * k / 6 for k in range(7)]  # spread over the published 5.7-20 rad/s
    rows = [
        ("j_arm1_1", "arm1_1", [0.04576, 0.169137, 0.190626], [0, 0, -0.523603], [0, 0.984808, 0.173648], -3.403, 1.658),
        ("j_arm1_2", "arm1_2", [-0.09115, 0.06106, 0.010766], [0, 0, 0], [-1, 0, 0], -3.49, 0),
        ("j_arm1_3", "arm1_3", [0.09115, 0, -0.21915], [0, 0, 0], [0, 0, -1], -2.618, 2.618),
        ("j_arm1_4", "arm1_4", [0.04, 0.05615, -0.074], [0, 0, 0], [0, 1, 0], -2.53, 0.349),
        ("j_arm1_5", "arm1_5", [-0.015, -0.05615, -0.061], [0, 0, 0], [0, 0, -1], -2.618, 2.618),
        ("j_arm1_6", "arm1_6", [0, 0.049, -0.18], [0, 0, 0], [0, 1, 0], -1.57, 1.57),
        ("j_arm1_7", "arm1_7", [0, -0.049, -0.169], [0, 0, 0], [0, 0, -1], -2.618, 2.618),
    ]
    left = {"side": "left", "shoulder_axes": [0, 1, 2], "hand": [0, 0, -0.07],
            "joints": [dict(name=n, link=l, xyz=x, rpy=r, axis=a, lower=lo, upper=hi, velocity=vels[k])
                       for k, (n, l, x, r, a, lo, hi) in enumerate(rows)]}
    names = [(n.replace("arm1", "arm2"), l.replace("arm1", "arm2")) for n, l, *_ in rows]
    right = mirror_arm(left, names, {
        0: dict(rpy=[0, 0, 0.523603], axis=[0, -0.984808, 0.173648], lower=-1.658, upper=3.403),
        1: dict(lower=0, upper=3.49),
        3: dict(axis=[0, -1, 0], lower=-0.349, upper=2.53),
        5: dict(axis=[0, -1, 0]),
    })
    return dict(name="centauro", root="torso_2", radius=0.04, density=1200.0, effort=100.0,
                torso_height=0.4, torso_depth=0.2, torso_mass=15.0, arms=[left, right],
                comment="CENTAURO 2017 upper body (IIT): torso and two 7-joint arms.")


def human(height=1.75):
    h = height
    clav_in, clav = 0.016 * h, 0.085 * h
    upper, fore, hand = 0.168 * h, 0.138 * h, 0.108 * h
    v = 10.0
    rows = [  # name, link, origin, axis, lower, upper (deg)
        ("jLeftC7Shoulder_elevation", "left_clavicle_base", [0, clav_in, 0.15], [1, 0, 0], -10, 45),
        ("jLeftC7Shoulder_protraction", "left_clavicle", [0, 0, 0], [0, 0, -1], -25, 25),
        ("jLeftShoulder_flexion", "left_upper_arm_flex", [0, clav, 0], [0, -1, 0], -60, 180),
        ("jLeftShoulder_abduction", "left_upper_arm_abd", [0, 0, 0], [1, 0, 0], -45, 180),
        ("jLeftShoulder_rotation", "left_upper_arm", [0, 0, 0], [0, 0, -1], -70, 90),
        ("jLeftElbow_flexion", "left_forearm_flex", [0, 0, -upper], [0, -1, 0], 0, 150),
        ("jLeftElbow_pronation", "left_forearm", [0, 0, 0], [0, 0, 1], -80, 80),
        ("jLeftWrist_flexion", "left_hand_flex", [0, 0, -fore], [-1, 0, 0], -70, 80),
        ("jLeftWrist_deviation", "left_hand_segment", [0, 0, 0], [0, -1, 0], -20, 30),
    ]
    radii = [0.02, 0.025, 0.045, 0.045, 0.045, 0.04, 0.04, 0.03, 0.03]
    left = {"side": "left", "shoulder_axes": [2, 3, 4], "hand": [0, 0, -hand], "hand_width": 0.085,
            "joints": [dict(name=n, link=l, xyz=x, axis=a, lower=deg(lo), upper=deg(hi), velocity=v, radius=radii[k])
                       for k, (n, l, x, a, lo, hi) in enumerate(rows)]}
    names = [(n.replace("Left", "Right"), l.replace("left", "right")) for n, l, *_ in rows]
    # Same angle, mirrored motion: an axial vector mirrored in the sagittal plane is (-x, y, -z).
    right = mirror_arm(left, names, {k: dict(axis=[-j["axis"][0], j["axis"][1], -j["axis"][2]])
                                     for k, j in enumerate(left["joints"])})
    return dict(name="human", root="T8", radius=0.045, density=1050.0, effort=50.0,
                torso_height=0.5, torso_depth=0.2, torso_mass=25.0, torso_top_clearance=0.0,
                arms=[left, right],
                comment=f"Human upper body, {height} m, Xsens-MVN-style joint angles: two 9-joint arms "
                        "(sternoclavicular elevation/protraction, shoulder flexion/abduction/rotation, "
                        "elbow flexion, forearm pronation, wrist flexion/deviation).")


# UR5e, from Universal Robots' "Parameters for calculations of kinematics and dynamics" (the
# standard Denavit-Hartenberg table of the e-Series; theta offsets all 0, so q = the angles the
# robot's controller reports) and the UR5e user manual's joint limits.
UR5E_DH = [  # (a, d, alpha) of joints 1-6, metres and radians
    (0.0, 0.1625, math.pi / 2),
    (-0.425, 0.0, 0.0),
    (-0.3922, 0.0, 0.0),
    (0.0, 0.1333, math.pi / 2),
    (0.0, 0.0997, -math.pi / 2),
    (0.0, 0.0996, 0.0),
]
UR5E_MASSES = [3.761, 8.058, 2.846, 1.37, 1.3, 0.365]  # kg, links 1-6, same table
# Pan axes turned this far backward from pointing straight out (see ur5e()).
UR5E_PAN_TURN = math.radians(-30.0)


def ur5e():
    """Two UR5e arms on the sides of a box torso, written as the DH table itself.

    Each arm's first joint carries the mounting (base frame = DH frame 0); joint k+1's origin is
    row k of the table, Tz(d) Tx(a) Rx(alpha) = xyz (a, 0, d), rpy (alpha, 0, 0); every axis is
    the frame's z; the hand is the tool flange (UR's tool0), d6 along the last axis. So link k's
    frame is DH frame k-1 turned by q_k, and the hand frame is DH frame 6.

    Mounting: base x0 up, so that q = 0 (the DH zero: upper arm and forearm in line along -x0)
    hangs the arm straight down like the humanoids' arms; base z0 (the shoulder pan axis)
    horizontal, pointing out of the torso side and turned 30 degrees backward. (Pointing straight
    out, the left pan joint would have to turn at 3.7 rad/s, beyond the UR5e's 180 deg/s, on the
    generator's move from `forward_high` to `v_up`; turned 25 to 45 degrees back, every command
    stays below 3.1 rad/s.) The bases sit at y = +-0.13 m, the torso's half width, placed so
    that the shoulder centres (where the pan and lift axes cross) are at x = 0; the torso box
    stands 6 cm behind that (its front face at x = 0.04 m, the bases on brackets at its front
    corners) and ends 27 cm below the shoulders, so that a forearm reaching in front of the
    chest clears it. A UR5e has one handedness, so the right arm is not a mirror image of the
    left one: at q = 0 the left flange sits behind its shoulder, the right one in front of it."""
    c, s = math.cos(UR5E_PAN_TURN), math.sin(UR5E_PAN_TURN)
    base_y, shoulder_z = 0.13, 0.2
    d1 = UR5E_DH[0][1]
    limits = [2 * math.pi, 2 * math.pi, math.pi, 2 * math.pi, 2 * math.pi, 2 * math.pi]
    efforts = [150.0, 150.0, 150.0, 28.0, 28.0, 28.0]
    radii = [0.045, 0.045, 0.04, 0.035, 0.035, 0.035]
    names = ["shoulder_pan", "shoulder_lift", "elbow", "wrist_1", "wrist_2", "wrist_3"]
    links = ["shoulder_link", "upper_arm_link", "forearm_link", "wrist_1_link", "wrist_2_link",
             "wrist_3_link"]

    def arm(side, sign):
        # z0 = (s, sign c, 0), x0 = +z, y0 = z0 x x0 = (sign c, -s, 0);
        # R = Rz(yaw) Ry(-pi/2) has columns (0, 0, 1), (-sin yaw, cos yaw, 0), (-cos yaw, -sin yaw, 0).
        yaw = math.atan2(-sign * c, -s)
        pan_axis = [s, sign * c, 0.0]
        base = [0.0 - d1 * pan_axis[0], sign * base_y, shoulder_z]
        origins = [(base, [0.0, -math.pi / 2, yaw])]
        origins += [([a, 0.0, d], [alpha, 0.0, 0.0]) for a, d, alpha in UR5E_DH[:-1]]
        joints = [dict(name=f"{side}_{names[k]}_joint", link=f"{side}_{links[k]}",
                       xyz=origins[k][0], rpy=origins[k][1], axis=[0, 0, 1],
                       lower=-limits[k], upper=limits[k], velocity=math.pi, effort=efforts[k],
                       radius=radii[k], mass=UR5E_MASSES[k])
                  for k in range(6)]
        a6, d6, _ = UR5E_DH[-1]
        return {"side": side, "shoulder_axes": [0, 1], "hand": [a6, 0.0, d6], "hand_width": 0.075,
                "joints": joints}

    return dict(name="ur5e", root="torso", radius=0.045, density=1200.0, effort=150.0,
                torso_height=0.35, torso_depth=0.2, torso_x=-0.06, torso_mass=15.0, torso_half_width=base_y,
                torso_top_clearance=-0.11, digits=15, arms=[arm("left", 1.0), arm("right", -1.0)],
                source="Universal Robots' published UR5e DH table and user manual (see data/urdf/README.md)",
                comment="Two 6-joint UR5e arms (Universal Robots) on a torso. Each arm is UR's standard "
                        "DH table of the UR5e ('Parameters for calculations of kinematics and "
                        "dynamics': d1 0.1625, a2 -0.425, a3 -0.3922, d4 0.1333, d5 0.0997, d6 0.0996 m; "
                        "alpha pi/2, 0, 0, pi/2, -pi/2, 0), joint k+1's origin being row k, with the "
                        "link masses of the same table; limits from the UR5e user manual (+-360 deg, "
                        "the elbow +-180 deg as in UR's ROS description; 180 deg/s; 150/150/150/28/28/28 "
                        "Nm). Bases at y +-0.13 m (brackets at the torso's front corners), x0 up so "
                        "that q = 0 hangs the arms down, pan axes horizontal and turned 30 deg "
                        "backward from pointing straight out; shoulder centres at (0, +-0.270729, "
                        "0.2). Hand = tool flange. A UR5e has one handedness: the right arm is not a "
                        "mirror image of the left.")

def main():
    for make in (walkman, coman, centauro, human, ur5e):
        robot = make()
        path = os.path.join(HERE, robot["name"] + ".urdf")
        with open(path, "w") as f:
            f.write(build(robot))
        print("wrote", path)


if __name__ == "__main__":
    main()
