//! An anatomy's geometry from the kinematics alone: the hold posture, the shoulder points, the
//! body frame, each arm's reach (the straightened arm) and its neutral posture.

use nalgebra::{Isometry3, Matrix3, Rotation3, UnitQuaternion, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::discover::{file_of, FoundArms, RawArm};
use super::{Anatomy, AnatomyArm, AnatomyError, AnatomyResult, AnatomySpec, CommandJoints};
use crate::generator::{KEY_POSES, NEUTRAL};
use crate::kinematics::Chain;
use crate::models::Side;
use crate::urdf::{MeshSearch, Robot};
use crate::{IkOptions, IkTarget};

/// Axes closer than this (sine of their angle) count as parallel.
const PARALLEL: f64 = 0.05;
/// Axes of a shoulder meet when the point nearest to them is this close to each, as a fraction
/// of the arm's length along its links (at least 5 mm).
const MEET_FRACTION: f64 = 0.02;

/// Builds the anatomy of `robot` from its found arms and the user's `spec`.
pub(super) fn build(robot: Robot, found: FoundArms, spec: &AnatomySpec) -> AnatomyResult<Anatomy> {
    let file = spec
        .source
        .as_ref()
        .map_or_else(|| file_of(&robot), |p| p.display().to_string());
    let chains = [
        chain_of(&robot, &found.arms[0])?,
        chain_of(&robot, &found.arms[1])?,
    ];
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
    let torso = lowest_common_ancestor(&robot, &found.arms[0].base, &found.arms[1].base)?;
    let torso_in_root = robot.forward_kinematics(&hold, &torso)?;
    let mut arms = Vec::with_capacity(2);
    for (raw, chain) in found.arms.iter().zip(chains) {
        arms.push(arm_geometry(&robot, raw, chain, &hold, &torso_in_root)?);
    }
    let [mut left, mut right]: [AnatomyArm; 2] =
        arms.try_into().map_err(|_| AnatomyError::Frame {
            file: file.clone(),
            message: "expected two arms".into(),
        })?;
    let body_in_torso = body_frame(&left, &right, &torso_in_root, spec, &file)?;
    for arm in [&mut left, &mut right] {
        arm.neutral = neutral_posture(&robot, arm, &body_in_torso, spec, &file)?;
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
        arms: [left, right],
        torso_link: torso,
        body_in_torso,
        torso_in_root,
        hold,
        held,
        command,
        notes: found.notes,
        meshes: MeshSearch::for_robot(&robot).unwrap_or_default(),
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

/// The point nearest (least squares) to the lines through `origins` along `axes`, and its
/// largest distance to one of them; `None` when the lines are parallel.
fn nearest_point(origins: &[Vector3<f64>], axes: &[Vector3<f64>]) -> Option<(Vector3<f64>, f64)> {
    let mut a = Matrix3::zeros();
    let mut b = Vector3::zeros();
    for (o, d) in origins.iter().zip(axes) {
        let p = Matrix3::identity() - d * d.transpose();
        a += p;
        b += p * o;
    }
    let point = a.try_inverse()? * b;
    let spread = origins
        .iter()
        .zip(axes)
        .map(|(o, d)| {
            let v = point - o;
            (v - d * d.dot(&v)).norm()
        })
        .fold(0.0, f64::max);
    Some((point, spread))
}

/// Which end of the arm a group of meeting axes is sought at.
#[derive(Clone, Copy, PartialEq, Eq)]
enum End {
    /// The shoulder: groups ending before the elbow, the one ending nearest it first (a
    /// person's collarbone joints come before the shoulder's).
    Shoulder,
    /// The wrist: groups starting after the elbow, the one ending nearest the hand first.
    Wrist,
}

/// The chain joint most in the middle of the arm at `q` (farthest from both its first joint
/// and the hand), the first and last joints aside: a first guess of the elbow, which tells the
/// shoulder's joints from the wrist's.
fn elbow_guess(chain: &Chain, q: &[f64]) -> usize {
    let origins = chain.joint_origins(q);
    let hand = chain.forward(q).translation.vector;
    let n = origins.len();
    let score = |i: usize| {
        (origins[i] - origins[0])
            .norm()
            .min((origins[i] - hand).norm())
    };
    let best = (1..n.saturating_sub(1).max(1))
        .map(score)
        .fold(0.0, f64::max);
    // Joints at one point (an elbow and a forearm roll) tie: the first of them.
    (1..n.saturating_sub(1).max(1))
        .find(|&i| score(i) >= best - 1e-3)
        .unwrap_or(0)
}

/// Where a group of the chain's axes meets at `q`: among groups of two or three consecutive
/// revolute joints on `end`'s side of the (guessed) elbow, no two of them parallel, the group
/// whose axes meet (within [`MEET_FRACTION`] of the arm's length), nearest the elbow (shoulder)
/// or the hand (wrist) first, then the most axes; else the group whose axes come nearest. Gives
/// the group's first joint, its size, the point (base frame) and its distance to the farthest
/// axis.
fn meeting_axes(chain: &Chain, q: &[f64], end: End) -> (usize, usize, Vector3<f64>, f64) {
    let frames = chain.joint_frames(q);
    let axes = chain.joint_axes(q);
    let origins: Vec<Vector3<f64>> = frames.iter().map(|f| f.translation.vector).collect();
    let length: f64 = origins
        .windows(2)
        .map(|w| (w[1] - w[0]).norm())
        .sum::<f64>()
        + (chain.forward(q).translation.vector - origins[origins.len() - 1]).norm();
    let meet = (MEET_FRACTION * length).max(0.005);
    let n = chain.dof();
    let elbow = elbow_guess(chain, q);
    let mut groups = Vec::new();
    for len in [3usize, 2] {
        for start in 0..n {
            let range = start..(start + len).min(n);
            let side = match end {
                End::Shoulder => range.end <= elbow,
                End::Wrist => range.start > elbow,
            };
            if !side || range.len() < 2 || range.clone().any(|i| chain.is_prismatic(i)) {
                continue;
            }
            let parallel = range.clone().any(|i| {
                range
                    .clone()
                    .filter(|&k| k > i)
                    .any(|k| axes[i].cross(&axes[k]).norm() < PARALLEL)
            });
            if parallel {
                continue;
            }
            if let Some((p, spread)) = nearest_point(&origins[range.clone()], &axes[range.clone()])
            {
                // Rank: nearer the elbow (shoulder) or the hand (wrist) first.
                let rank = match end {
                    End::Shoulder => elbow - range.end,
                    End::Wrist => n - range.end,
                };
                groups.push((start, range.len(), p, spread, rank));
            }
        }
    }
    let meeting = groups
        .iter()
        .filter(|g| g.3 <= meet)
        .min_by(|a, b| (a.4, std::cmp::Reverse(a.1)).cmp(&(b.4, std::cmp::Reverse(b.1))));
    let chosen = meeting.or_else(|| groups.iter().min_by(|a, b| a.3.total_cmp(&b.3)));
    match (chosen, end) {
        (Some(&(start, len, p, spread, _)), _) => (start, len, p, spread),
        (None, End::Shoulder) => (0, 1, origins[0], 0.0),
        (None, End::Wrist) => (n - 1, 1, origins[n - 1], 0.0),
    }
}

/// A point of the chain's base frame at `q` expressed in the frame of chain joint `after`
/// (before its motion), so that it rides on the joints before `after`.
fn riding(chain: &Chain, q: &[f64], after: usize, point: Vector3<f64>) -> Vector3<f64> {
    if after == 0 {
        point
    } else {
        (chain.joint_frames(q)[after].inverse() * nalgebra::Point3::from(point)).coords
    }
}

/// The configuration within the limits that maximises `f`, by projected gradient ascent
/// (central differences) from the given starts and seeded random ones.
fn maximise(
    f: &dyn Fn(&[f64]) -> f64,
    limits: &[(f64, f64)],
    starts: Vec<Vec<f64>>,
) -> (Vec<f64>, f64) {
    let bounded: Vec<(f64, f64)> = limits
        .iter()
        .map(|&(lo, hi)| (lo.max(-std::f64::consts::PI), hi.min(std::f64::consts::PI)))
        .map(|(lo, hi)| if lo <= hi { (lo, hi) } else { (hi, lo) })
        .collect();
    let clamp = |q: &mut [f64]| {
        for (v, &(lo, hi)) in q.iter_mut().zip(limits) {
            if lo <= hi {
                *v = v.clamp(lo, hi);
            }
        }
    };
    let mut rng = ChaCha8Rng::seed_from_u64(0x5ee_d0e5);
    let mut all = starts;
    for _ in 0..6 {
        all.push(
            bounded
                .iter()
                .map(|&(lo, hi)| {
                    if hi > lo {
                        rng.random_range(lo..=hi)
                    } else {
                        lo
                    }
                })
                .collect(),
        );
    }
    let mut best = (Vec::new(), f64::NEG_INFINITY);
    for mut q in all {
        clamp(&mut q);
        let mut value = f(&q);
        let mut step = 0.3;
        let mut grad = vec![0.0; q.len()];
        for _ in 0..400 {
            let h = 1e-6;
            for i in 0..q.len() {
                let mut a = q.clone();
                let mut b = q.clone();
                a[i] += h;
                b[i] -= h;
                grad[i] = (f(&a) - f(&b)) / (2.0 * h);
                let (lo, hi) = limits[i];
                if (q[i] >= hi && grad[i] > 0.0) || (q[i] <= lo && grad[i] < 0.0) {
                    grad[i] = 0.0;
                }
            }
            let biggest = grad.iter().fold(0.0_f64, |m, g| m.max(g.abs()));
            if biggest < 1e-10 {
                break;
            }
            let mut trial: Vec<f64> = q
                .iter()
                .zip(&grad)
                .map(|(v, g)| v + step * g / biggest)
                .collect();
            clamp(&mut trial);
            let t = f(&trial);
            if t > value {
                q = trial;
                value = t;
                step = (step * 2.0).min(1.0);
            } else {
                step *= 0.5;
                if step < 1e-9 {
                    break;
                }
            }
        }
        if value > best.1 {
            best = (q, value);
        }
    }
    best
}

/// One arm's geometry: its pose on the torso, shoulder, reach and elbow (the neutral posture
/// comes once the body frame is known).
///
/// The reach is the largest shoulder-to-hand distance over the joints beyond the shoulder
/// (those before it and the shoulder's own at 0 within their limits): the straightened arm,
/// measured without swinging the hand around shoulder axes that miss the shoulder point. The
/// elbow is the joint beyond the shoulder whose bending shortens that straightened arm most.
fn arm_geometry(
    robot: &Robot,
    raw: &RawArm,
    chain: Chain,
    hold: &[f64],
    torso_in_root: &Isometry3<f64>,
) -> AnatomyResult<AnatomyArm> {
    let base_in_torso = torso_in_root.inverse() * robot.forward_kinematics(hold, &raw.base)?;
    let zero: Vec<f64> = chain
        .limits()
        .iter()
        .map(|&(lo, hi)| if lo <= hi { 0.0_f64.clamp(lo, hi) } else { 0.0 })
        .collect();
    let (group, size, axes_point, spread) = meeting_axes(&chain, &zero, End::Shoulder);
    // The shoulder rides on the joints before its group (TALOS turns its whole shoulder
    // first; a person lifts the collarbone); the convention's shoulder link names the point.
    let point = match &raw.shoulder_link {
        Some(link) => {
            let at = base_in_torso.inverse()
                * (torso_in_root.inverse() * robot.forward_kinematics(hold, link)?);
            at.translation.vector
        }
        None => axes_point,
    };
    let after = group;
    let local = riding(&chain, &zero, after, point);
    let (wrist_after, _, wrist_point, _) = meeting_axes(&chain, &zero, End::Wrist);
    let wrist_local = riding(&chain, &zero, wrist_after, wrist_point);
    let distal = (group + size).min(chain.dof())..chain.dof();
    let with = |tail: &[f64]| -> Vec<f64> {
        let mut q = zero.clone();
        q[distal.clone()].copy_from_slice(tail);
        q
    };
    let span = |q: &[f64]| (chain.forward(q).translation.vector - point).norm();
    let distal_limits = &chain.limits()[distal.clone()];
    let mid: Vec<f64> = distal_limits
        .iter()
        .map(|&(lo, hi)| {
            if lo.is_finite() && hi.is_finite() {
                0.5 * (lo + hi)
            } else {
                0.0
            }
        })
        .collect();
    let measure = |tail: &[f64]| span(&with(tail));
    let (tail, reach) = maximise(
        &measure,
        distal_limits,
        vec![zero[distal.clone()].to_vec(), mid],
    );
    let straight = with(&tail);
    let zero_pose_reach = span(&zero);
    let bend = |i: usize| {
        let h = 1e-3;
        let mut a = straight.clone();
        let mut b = straight.clone();
        a[i] += h;
        b[i] -= h;
        (span(&a) - 2.0 * reach + span(&b)) / (h * h)
    };
    let elbow = distal
        .clone()
        .min_by(|&a, &b| bend(a).total_cmp(&bend(b)))
        .unwrap_or(0);
    Ok(AnatomyArm {
        side: raw.side,
        shoulder: (base_in_torso * nalgebra::Point3::from(point)).coords,
        shoulder_spread_m: if raw.shoulder_link.is_some() {
            0.0
        } else {
            spread
        },
        shoulder_after: after,
        shoulder_local: local,
        wrist_after,
        wrist_local,
        base_in_torso,
        reach,
        straight,
        zero_pose_reach,
        neutral: zero,
        elbow,
        chain,
    })
}

/// Parses a direction given in the torso frame and checks it.
fn unit(v: &Vector3<f64>, what: &str, file: &str) -> AnatomyResult<Vector3<f64>> {
    let n = v.norm();
    if !(n.is_finite() && n > 1e-9) {
        return Err(AnatomyError::Frame {
            file: file.to_string(),
            message: format!("{what} {v:?} is not a direction (expected a non-zero vector)"),
        });
    }
    Ok(v / n)
}

/// The body frame's rotation into the torso frame: left from the right shoulder to the left,
/// up (the root's z, or as given) made square to it, forward = left × up (or as given).
fn body_frame(
    left: &AnatomyArm,
    right: &AnatomyArm,
    torso_in_root: &Isometry3<f64>,
    spec: &AnatomySpec,
    file: &str,
) -> AnatomyResult<UnitQuaternion<f64>> {
    let across = left.shoulder - right.shoulder;
    if across.norm() < 1e-3 {
        return Err(AnatomyError::Frame {
            file: file.to_string(),
            message: format!(
                "the two shoulders are {:.1} mm apart: left cannot be told from right",
                across.norm() * 1e3
            ),
        });
    }
    let l = across.normalize();
    let square = |v: Vector3<f64>, what: &str| -> AnatomyResult<Vector3<f64>> {
        let s = v - l * l.dot(&v);
        if s.norm() < 0.3 {
            return Err(AnatomyError::Frame {
                file: file.to_string(),
                message: format!(
                    "the {what} direction {v:?} runs nearly along the shoulders (left is {l:?} in the torso link's frame): expected a direction square to them"
                ),
            });
        }
        Ok(s.normalize())
    };
    let (forward, up) = match (&spec.forward, &spec.up) {
        (Some(f), None) => {
            let f = square(unit(f, "forward", file)?, "forward")?;
            (f, f.cross(&l))
        }
        (f, u) => {
            let up_root = torso_in_root.rotation.inverse() * Vector3::z();
            let u = square(
                match u {
                    Some(u) => unit(u, "up", file)?,
                    None => up_root,
                },
                "up",
            )?;
            let fwd = l.cross(&u);
            if let Some(f) = f {
                let given = unit(f, "forward", file)?;
                if given.dot(&fwd) < 0.7 {
                    return Err(AnatomyError::Frame {
                        file: file.to_string(),
                        message: format!(
                            "forward {given:?} and up {u:?} do not fit the shoulders (left {l:?}): with them forward is {fwd:?}"
                        ),
                    });
                }
            }
            (fwd, u)
        }
    };
    let r = Rotation3::from_basis_unchecked(&[forward, l, up]);
    Ok(UnitQuaternion::from_rotation_matrix(&r))
}

/// The neutral posture of `arm`: as `spec` gives it, else IK of the generator's neutral key
/// pose (arms down, slightly forward) within the limits, pulled towards the zero posture.
fn neutral_posture(
    robot: &Robot,
    arm: &AnatomyArm,
    body_in_torso: &UnitQuaternion<f64>,
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
    let rel = match arm.side {
        Side::Left => KEY_POSES[NEUTRAL].left,
        Side::Right => KEY_POSES[NEUTRAL].right,
    };
    let in_torso = arm.shoulder + arm.reach * (body_in_torso * Vector3::from(rel));
    let target = arm.base_in_torso.inverse() * nalgebra::Point3::from(in_torso);
    let zero = arm.neutral.clone();
    let options = IkOptions {
        tolerance: 1e-6,
        max_iters: 200,
        restarts: 8,
        posture_gain: 0.5,
        rest: Some(zero.clone()),
        ..IkOptions::default()
    };
    Ok(arm
        .chain
        .inverse_kinematics(&IkTarget::Position(target.coords), &zero, &options)
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

/// What a user should know about the anatomy found: a root frame that is not x forward, y
/// left, z up; an arm whose zero pose is not its straightened one; shoulders whose axes do
/// not meet.
fn notes(a: &Anatomy) -> Vec<String> {
    let mut notes = Vec::new();
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
            format!("({:.2}, {:.2}, {:.2})", v.x, v.y, v.z)
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
