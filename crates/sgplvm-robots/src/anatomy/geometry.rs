//! An anatomy's geometry from the kinematics alone: the hold posture, the body frame from the
//! shoulder points (`arm_points.rs` finds each arm's), and each arm's neutral posture.

use nalgebra::{Isometry3, Rotation3, UnitQuaternion, Vector3};

use super::arm_points::arm_geometry;
use super::discover::{file_of, FoundArms, RawArm};
use super::mount::{Mount, HANG_MISS_DEG};
use super::{
    Anatomy, AnatomyArm, AnatomyError, AnatomyResult, AnatomySpec, CommandJoints, MIN_BONE_MM,
};
use crate::generator::{KEY_POSES, NEUTRAL};
use crate::kinematics::Chain;
use crate::models::Side;
use crate::urdf::{MeshSearch, Robot};
use crate::{IkOptions, IkTarget};

/// Builds the anatomy of `robot` from its found arms and the user's `spec`.
pub(super) fn build(robot: Robot, found: FoundArms, spec: &AnatomySpec) -> AnatomyResult<Anatomy> {
    let file = spec
        .source
        .as_ref()
        .map_or_else(|| file_of(&robot), |p| p.display().to_string());
    let chains = found
        .arms
        .iter()
        .map(|raw| chain_of(&robot, raw))
        .collect::<AnatomyResult<Vec<Chain>>>()?;
    for (raw, chain) in found.arms.iter().zip(&chains) {
        if chain.dof() < 3 {
            return Err(AnatomyError::TooFewJoints {
                file: file_of(&robot),
                side: raw.side.as_str(),
                from: raw.base.clone(),
                to: raw.hand.clone(),
                count: chain.dof(),
            });
        }
    }
    let arm_joints: Vec<usize> = chains
        .iter()
        .flat_map(|c| c.robot_indices().iter().copied())
        .collect();
    let mut hold = hold_configuration(&robot, &arm_joints, spec, &file)?;
    let torso = match found.arms.as_slice() {
        [left, right] => lowest_common_ancestor(&robot, &left.base, &right.base)?,
        // One arm: the link it hangs from is the torso.
        [one] => one.base.clone(),
        _ => {
            return Err(AnatomyError::Frame {
                file: file.clone(),
                message: format!("expected one or two arms, found {}", found.arms.len()),
            })
        }
    };
    let torso_in_root = robot.forward_kinematics(&hold, &torso)?;
    let mut arms = Vec::with_capacity(found.arms.len());
    for (raw, chain) in found.arms.iter().zip(chains) {
        arms.push(arm_geometry(&robot, raw, chain, &hold, &torso_in_root)?);
    }
    for (raw, arm) in found.arms.iter().zip(&arms) {
        check_bones(raw, arm, &robot)?;
    }
    let body_in_torso = body_frame(&arms, &torso_in_root, spec, &file)?;
    let mount = mount_and_neutral(&robot, &mut arms, &body_in_torso, spec, &file)?;
    for arm in &arms {
        for (k, &i) in arm.chain.robot_indices().iter().enumerate() {
            hold[i] = arm.neutral[k];
        }
    }
    let held: Vec<usize> = (0..robot.dof())
        .filter(|i| !arm_joints.contains(i))
        .collect();
    let command = command_joints(&robot, &arm_joints, &spec.command_joints, &file)?;
    let mut anatomy = Anatomy {
        found: found.found,
        arms,
        torso_link: torso,
        body_in_torso,
        torso_in_root,
        mount,
        hold,
        held,
        command,
        notes: found.notes,
        meshes: MeshSearch::for_robot(&robot).unwrap_or_default(),
        hulls: super::HullCache::default(),
        proofs: crate::kinematics::ApartProofs::default(),
        robot,
    };
    anatomy.notes.extend(notes(&anatomy));
    Ok(anatomy)
}

/// The chain of one found arm.
fn chain_of(robot: &Robot, raw: &RawArm) -> AnatomyResult<Chain> {
    Ok(robot.chain(&raw.base, &raw.hand)?)
}

/// Every joint at 0 within its limits, the held ones as `spec.hold` says (checked) and mimic
/// joints following a held master.
fn hold_configuration(
    robot: &Robot,
    arm_joints: &[usize],
    spec: &AnatomySpec,
    file: &str,
) -> AnatomyResult<Vec<f64>> {
    let mut q = robot.neutral_configuration();
    let names = robot.joint_names();
    let limits = robot.joint_limits();
    let what = |name: &str| match &spec.source {
        Some(_) => format!("hold.{name}"),
        None => format!("--hold {name}"),
    };
    for (name, &value) in &spec.hold {
        let Some(i) = robot.joint_index(name) else {
            return Err(AnatomyError::Joint {
                file: file.to_string(),
                what: what(name),
                message: format!(
                    "no movable joint of that name (the robot's movable joints: {})",
                    crate::names::few(&names, 6)
                ),
            });
        };
        if arm_joints.contains(&i) {
            return Err(AnatomyError::Joint {
                file: file.to_string(),
                what: what(name),
                message: "is an arm joint: arm joints are commanded, not held (hold joints outside the arms)".into(),
            });
        }
        let (lo, hi) = limits[i];
        if !(value >= lo && value <= hi) {
            return Err(AnatomyError::Joint {
                file: file.to_string(),
                what: what(name),
                message: format!("{value} is outside the joint's limits [{lo}, {hi}]"),
            });
        }
        q[i] = value;
    }
    for joint in &robot.urdf.joints {
        let (Some(mimic), Some(i)) = (&joint.mimic, robot.joint_index(&joint.name)) else {
            continue;
        };
        let master = robot.joint_index(&mimic.joint);
        if spec.hold.contains_key(&joint.name) || arm_joints.contains(&i) {
            continue;
        }
        if let Some(m) = master.filter(|m| !arm_joints.contains(m)) {
            let value = mimic.multiplier.unwrap_or(1.0) * q[m] + mimic.offset.unwrap_or(0.0);
            let (lo, hi) = limits[i];
            q[i] = if lo <= hi { value.clamp(lo, hi) } else { value };
        }
    }
    Ok(q)
}

/// The deepest link both `a` and `b` hang from.
fn lowest_common_ancestor(robot: &Robot, a: &str, b: &str) -> AnatomyResult<String> {
    let above = |link: &str| -> AnatomyResult<Vec<usize>> {
        let id = robot.link_id(link)?;
        Ok(std::iter::once(robot.root)
            .chain(robot.path_to(id).iter().map(|&j| robot.joints[j].child))
            .collect())
    };
    let (pa, pb) = (above(a)?, above(b)?);
    let common = pa
        .iter()
        .zip(&pb)
        .take_while(|(x, y)| x == y)
        .last()
        .map_or(robot.root, |(x, _)| *x);
    Ok(robot.links[common].clone())
}

/// A direction as messages print it: `(0.00, 0.00, 1.00)`.
fn direction(v: &Vector3<f64>) -> String {
    format!("({:.2}, {:.2}, {:.2})", v.x, v.y, v.z)
}

/// Parses a direction given in the torso frame and checks it.
fn unit(v: &Vector3<f64>, what: &str, file: &str) -> AnatomyResult<Vector3<f64>> {
    let n = v.norm();
    if !(n.is_finite() && n > 1e-9) {
        return Err(AnatomyError::Frame {
            file: file.to_string(),
            message: format!(
                "{what} {} is not a direction (expected a non-zero vector)",
                direction(v)
            ),
        });
    }
    Ok(v / n)
}

/// The body frame's rotation into the torso frame: left from the right shoulder to the left,
/// up (the root's z, or as given; where the root's z runs along the shoulders, from the root
/// towards them) made square to it, forward = left × up (or as given). With
/// one arm there is no across: up as with two, forward (the root's x, or as given) made
/// square to it, left = up × forward.
fn body_frame(
    arms: &[AnatomyArm],
    torso_in_root: &Isometry3<f64>,
    spec: &AnatomySpec,
    file: &str,
) -> AnatomyResult<UnitQuaternion<f64>> {
    let frame_error = |message: String| AnatomyError::Frame {
        file: file.to_string(),
        message,
    };
    let up_given = match &spec.up {
        Some(u) => Some(unit(u, "up", file)?),
        None => None,
    };
    let up_root = torso_in_root.rotation.inverse() * Vector3::z();
    let [left, right] = arms else {
        // A single arm: up, then forward made square to it.
        let u = up_given.unwrap_or(up_root);
        let f = match &spec.forward {
            Some(f) => unit(f, "forward", file)?,
            None => torso_in_root.rotation.inverse() * Vector3::x(),
        };
        let square = f - u * u.dot(&f);
        if square.norm() < 0.3 {
            return Err(frame_error(format!(
                "forward {} runs nearly along up {} (in the torso link's frame): give --forward square to up",
                direction(&f),
                direction(&u)
            )));
        }
        let forward = square.normalize();
        let r = Rotation3::from_basis_unchecked(&[forward, u.cross(&forward), u]);
        return Ok(UnitQuaternion::from_rotation_matrix(&r));
    };
    let across = left.shoulder - right.shoulder;
    if across.norm() < 1e-3 {
        return Err(frame_error(format!(
            "the two shoulders are {:.1} mm apart: left cannot be told from right",
            across.norm() * 1e3
        )));
    }
    let l = across.normalize();
    let square = |v: Vector3<f64>, what: &str| -> AnatomyResult<Vector3<f64>> {
        let s = v - l * l.dot(&v);
        if s.norm() < 0.3 {
            return Err(frame_error(format!(
                "the {what} direction {} runs nearly along the shoulders (left is {} in the torso link's frame): expected a direction square to them; where one arm stands above the other (two arms on one column), name one of them alone",
                direction(&v),
                direction(&l)
            )));
        }
        Ok(s.normalize())
    };
    let (forward, up) = match (&spec.forward, up_given) {
        (Some(f), None) => {
            let f = square(unit(f, "forward", file)?, "forward")?;
            (f, f.cross(&l))
        }
        (f, u) => {
            let u = match u {
                Some(u) => square(u, "up")?,
                // The root's z along the shoulders (a model drawn y up, as biomechanics and
                // animation draw people): up is from the root towards the shoulders.
                None => square(up_root, "up").or_else(|e| {
                    let root = torso_in_root.inverse() * nalgebra::Point3::origin();
                    let rise = 0.5 * (left.shoulder + right.shoulder) - root.coords;
                    let rise = rise - l * l.dot(&rise);
                    if rise.norm() > 0.05 {
                        Ok(rise.normalize())
                    } else {
                        Err(e)
                    }
                })?,
            };
            let fwd = l.cross(&u);
            if let Some(f) = f {
                let given = unit(f, "forward", file)?;
                if given.dot(&fwd) < 0.7 {
                    return Err(frame_error(format!(
                        "forward {} and up {} do not fit the shoulders (left {}): with them forward is {}",
                        direction(&given),
                        direction(&u),
                        direction(&l),
                        direction(&fwd)
                    )));
                }
            }
            (fwd, u)
        }
    };
    let r = Rotation3::from_basis_unchecked(&[forward, l, up]);
    Ok(UnitQuaternion::from_rotation_matrix(&r))
}

/// The mount (`mount.rs`) and each arm's neutral posture through it: the mount `spec` gives,
/// else none unless an arm cannot hang (within its limits its upper arm stays more than
/// [`HANG_MISS_DEG`] from a person's hanging one), then [`Mount::cannot_hang`].
fn mount_and_neutral(
    robot: &Robot,
    arms: &mut [AnatomyArm],
    body_in_torso: &UnitQuaternion<f64>,
    spec: &AnatomySpec,
    file: &str,
) -> AnatomyResult<Mount> {
    let mut mount = match spec.mount_roll_deg {
        Some(deg) if Mount::valid_roll(deg) => Mount::given(deg),
        Some(deg) => {
            return Err(AnatomyError::Frame {
                file: file.to_string(),
                message: format!(
                    "mount roll {deg}°: expected a finite angle within ±180° (degrees the person's arm is turned outward about the forward axis)"
                ),
            })
        }
        None => Mount::default(),
    };
    for arm in arms.iter_mut() {
        arm.neutral = neutral_posture(robot, arm, body_in_torso, &mount, spec, file)?;
    }
    // A neutral posture the user gave stays theirs (`neutral_posture` returns it), mounted or
    // not; whether the arm can hang is the robot's, whatever its neutral.
    if spec.mount_roll_deg.is_none() {
        let missed = arms
            .iter()
            .map(|arm| hanging_miss_deg(arm, body_in_torso))
            .fold(0.0, f64::max);
        if missed > HANG_MISS_DEG {
            mount = Mount::cannot_hang(missed);
            for arm in arms.iter_mut() {
                arm.neutral = neutral_posture(robot, arm, body_in_torso, &mount, spec, file)?;
            }
        } else {
            mount = Mount::hangs(missed);
        }
    }
    Ok(mount)
}

/// How near (degrees), within the joint limits, `arm`'s upper arm (shoulder centre → elbow
/// centre) comes to a person's hanging upper arm (the neutral key pose's direction): the
/// smallest angle over a grid of the joints before the elbow, the only ones that turn it.
fn hanging_miss_deg(arm: &AnatomyArm, body_in_torso: &UnitQuaternion<f64>) -> f64 {
    let down = arm.base_in_torso.rotation.inverse()
        * (body_in_torso * Vector3::from(neutral_key_pose(arm.side)).normalize());
    let before = arm.elbow.max(1);
    let per_joint: usize = match before {
        0..=3 => 25,
        4 => 13,
        _ => 7,
    };
    let elbow_local = arm.elbow_centre_local();
    let grids: Vec<Vec<f64>> = arm.chain.limits()[..before]
        .iter()
        .map(|&(lo, hi)| {
            // A joint that turns all the way round (continuous, or a range of a turn or more).
            let pi = std::f64::consts::PI;
            let (lo, hi) = if hi - lo >= 2.0 * pi {
                (-pi, pi)
            } else {
                (lo, hi)
            };
            (0..per_joint)
                .map(|k| lo + (hi - lo) * k as f64 / (per_joint - 1) as f64)
                .collect()
        })
        .collect();
    let mut q = arm.neutral.clone();
    let mut best = f64::INFINITY;
    let total = per_joint.pow(before as u32);
    for index in 0..total {
        let mut rest = index;
        for (k, grid) in grids.iter().enumerate() {
            q[k] = grid[rest % per_joint];
            rest /= per_joint;
        }
        let frames = arm.chain.joint_frames(&q);
        let elbow = (frames[arm.elbow] * nalgebra::Point3::from(elbow_local)).coords;
        let upper = elbow - arm.shoulder_at(&q);
        if let Some(u) = upper.try_normalize(1e-9) {
            best = best.min(u.angle(&down).to_degrees());
        }
    }
    best
}

/// Refuses an arm whose upper arm or forearm is shorter than [`MIN_BONE_MM`] on its bone line.
fn check_bones(raw: &RawArm, arm: &AnatomyArm, robot: &Robot) -> AnatomyResult<()> {
    let (upper, fore) = arm.bone_lengths();
    for (bone, length) in [
        ("upper arm (shoulder centre → elbow centre)", upper),
        ("forearm (elbow centre → wrist centre)", fore),
    ] {
        let length_mm = 1000.0 * length;
        if length_mm.is_nan() || length_mm < MIN_BONE_MM {
            return Err(AnatomyError::NoBone {
                file: file_of(robot),
                side: raw.side.as_str(),
                from: raw.base.clone(),
                to: raw.hand.clone(),
                bone,
                length_mm,
            });
        }
    }
    Ok(())
}

/// The generator's neutral key pose of the arm of `side`: its hand relative to the shoulder in
/// units of reach, body frame.
fn neutral_key_pose(side: Side) -> [f64; 3] {
    match side {
        Side::Left => KEY_POSES[NEUTRAL].left,
        Side::Right => KEY_POSES[NEUTRAL].right,
    }
}

/// The IK settings of the neutral posture, pulled towards `rest`.
fn neutral_ik(rest: &[f64]) -> IkOptions {
    IkOptions {
        tolerance: 1e-6,
        max_iters: 200,
        restarts: 8,
        posture_gain: 0.5,
        rest: Some(rest.to_vec()),
        ..IkOptions::default()
    }
}

/// The neutral posture of `arm`: as `spec` gives it, else IK of the generator's neutral key
/// pose (arms down, slightly forward; turned by `mount`) within the limits, pulled towards the
/// zero posture.
fn neutral_posture(
    robot: &Robot,
    arm: &AnatomyArm,
    body_in_torso: &UnitQuaternion<f64>,
    mount: &Mount,
    spec: &AnatomySpec,
    file: &str,
) -> AnatomyResult<Vec<f64>> {
    let names = arm.chain.joint_names();
    let given: Vec<Option<f64>> = names.iter().map(|n| spec.neutral.get(n).copied()).collect();
    for key in spec.neutral.keys() {
        if robot.joint_index(key).is_none() {
            return Err(AnatomyError::Joint {
                file: file.to_string(),
                what: format!("neutral.{key}"),
                message: "no movable joint of that name".into(),
            });
        }
    }
    if given.iter().any(Option::is_some) {
        let missing: Vec<&String> = names
            .iter()
            .zip(&given)
            .filter(|(_, g)| g.is_none())
            .map(|(n, _)| n)
            .collect();
        if !missing.is_empty() {
            return Err(AnatomyError::Joint {
                file: file.to_string(),
                what: format!("neutral ({} arm)", arm.side.as_str()),
                message: format!(
                    "gives some of the arm's joints but not {}: give all of them or none",
                    crate::names::few(&missing, 4)
                ),
            });
        }
        return Ok(given.into_iter().flatten().collect());
    }
    let rel = mount.rotation(arm.side) * Vector3::from(neutral_key_pose(arm.side));
    let in_torso = arm.shoulder + arm.reach * (body_in_torso * rel);
    let target = arm.base_in_torso.inverse() * nalgebra::Point3::from(in_torso);
    let zero = arm.neutral.clone();
    Ok(arm
        .chain
        .inverse_kinematics(
            &IkTarget::Position(target.coords),
            &zero,
            &neutral_ik(&zero),
        )
        .q)
}

/// The configuration indices of the joints commands name.
fn command_joints(
    robot: &Robot,
    arm_joints: &[usize],
    which: &CommandJoints,
    file: &str,
) -> AnatomyResult<Vec<usize>> {
    match which {
        CommandJoints::Arms => Ok(arm_joints.to_vec()),
        CommandJoints::All => Ok((0..robot.dof()).collect()),
        CommandJoints::List(names) => {
            if names.is_empty() {
                return Err(AnatomyError::Joint {
                    file: file.to_string(),
                    what: "command joints".into(),
                    message: "the list is empty: expected arms, all or joint names".into(),
                });
            }
            names
                .iter()
                .map(|n| {
                    robot.joint_index(n).ok_or_else(|| AnatomyError::Joint {
                        file: file.to_string(),
                        what: format!("command joint {n}"),
                        message: format!(
                            "no movable joint of that name (the robot's movable joints: {})",
                            crate::names::few(&robot.joint_names(), 6)
                        ),
                    })
                })
                .collect()
        }
    }
}

/// What a user should know about the anatomy found: what the URDF breaks of the specification
/// (repaired where its meaning is clear); a root frame that is not x forward, y
/// left, z up; an arm that cannot hang, and so takes the person's arm rolled out (the mount);
/// an arm whose zero pose is not its straightened one; shoulders whose axes do not meet.
fn notes(a: &Anatomy) -> Vec<String> {
    // What the file breaks of the URDF specification, and what loading made of it.
    let mut notes: Vec<String> = a
        .robot
        .repairs()
        .iter()
        .map(|r| format!("{}: {r}", a.robot.source()))
        .collect();
    let [fwd, left, up] = a.body_axes_in_root();
    let root = a.robot.root_link();
    let axis_name = |v: &Vector3<f64>| {
        let names = ["x", "y", "z"];
        let k = (0..3)
            .max_by(|&i, &j| v[i].abs().total_cmp(&v[j].abs()))
            .unwrap_or(0);
        if v[k].abs() > 0.9 {
            format!("{}{}", if v[k] > 0.0 { "+" } else { "-" }, names[k])
        } else {
            direction(v)
        }
    };
    if fwd.x < 0.9 || left.y < 0.9 || up.z < 0.9 {
        notes.push(format!(
            "the root link {root} is not x forward, y left, z up: the body's forward is {}, left {} and up {} of {root}",
            axis_name(&fwd),
            axis_name(&left),
            axis_name(&up)
        ));
    }
    if matches!(a.mount.reason, super::MountReason::CannotHang { .. }) {
        notes.push(format!("mount: {}", a.mount.describe()));
    }
    for arm in &a.arms {
        if arm.zero_pose_reach < 0.95 * arm.reach {
            notes.push(format!(
                "the {} arm's zero pose is not its straightened one: the hand is {:.0} % of the arm's reach ({:.3} m) from the shoulder there",
                arm.side.as_str(),
                100.0 * arm.zero_pose_reach / arm.reach,
                arm.reach
            ));
        }
    }
    notes
}
