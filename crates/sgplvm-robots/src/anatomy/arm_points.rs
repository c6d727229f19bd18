//! Each arm's points from its joints' axes alone: the shoulder (where the first joints' axes
//! meet, riding on the joints before them), the wrist centre, the elbow, and the reach of the
//! straightened arm within its limits.

use nalgebra::{Isometry3, Matrix3, Vector3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

use super::discover::RawArm;
use super::{AnatomyArm, AnatomyResult, MIN_BONE_MM};
use crate::kinematics::Chain;
use crate::urdf::Robot;

/// A joint bends the arm to a point when bending it shortens the straightened arm's distance
/// to that point at least this fast (second derivative, per metre of reach).
const BENDS: f64 = 0.01;
/// Axes closer than this (sine of their angle) count as parallel.
const PARALLEL: f64 = 0.05;
/// Axes of a shoulder meet when the point nearest to them is this close to each, as a fraction
/// of the arm's length along its links (at least 5 mm).
const MEET_FRACTION: f64 = 0.02;

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

/// The chain joint most in the middle of the arm (farthest from its first joint, its last
/// and the hand), the first joint aside: a first guess of the elbow, which tells the
/// shoulder's joints from the wrist's. Judged at the zero configuration `zero`, unless the arm
/// is folded there and stretches out at the middle of its joints' ranges (Kinova's Jaco 2: its
/// zero pose folds the arm down onto itself, the hand 27 % of the reach from the shoulder, and
/// its ranges are centred on the arm standing straight up).
fn elbow_guess(chain: &Chain, zero: &[f64]) -> usize {
    let mid = chain.mid_range(zero);
    let stretch =
        |q: &[f64]| (chain.forward(q).translation.vector - chain.joint_origins(q)[0]).norm();
    let q = if stretch(&mid) > 1.5 * stretch(zero) {
        &mid
    } else {
        zero
    };
    let origins = chain.joint_origins(q);
    let hand = chain.forward(q).translation.vector;
    let n = origins.len();
    // Farthest from the first joint, the last (a wrist's) and the hand: a hand as long as the
    // forearm beyond the wrist (Leju's Kuavo, Trossen's WXAI) puts the middle of the arm at
    // the wrist.
    // The last joint itself may be the elbow, a forearm beyond it and no wrist (PAL's ARI:
    // shoulder pitch, roll, the upper arm's turn, the elbow): an arm of at most four joints
    // whose last is revolute and bends what lies beyond it (its axis across the line to the
    // hand), not a roll along it (Toyota's HSR's wrist roll, a seven-joint arm's with a long
    // tool): it is then far from the hand.
    let axes = chain.joint_axes(q);
    let last_bends = n <= 4 && !chain.is_prismatic(n - 1) && {
        let beyond = hand - origins[n - 1];
        beyond.norm() > 1e-9 && axes[n - 1].dot(&beyond.normalize()).abs() < 0.5
    };
    let score = |i: usize| {
        let to_last = if i + 1 == n {
            f64::INFINITY
        } else {
            (origins[i] - origins[n - 1]).norm()
        };
        (origins[i] - origins[0])
            .norm()
            .min((origins[i] - hand).norm())
            .min(to_last)
    };
    let candidates = 1..if n >= 3 && last_bends {
        n
    } else {
        n.saturating_sub(1).max(1)
    };
    let best = candidates.clone().map(score).fold(0.0, f64::max);
    // Joints at one point (an elbow and a forearm roll) tie: the first of them.
    candidates
        .clone()
        .find(|&i| score(i) >= best - 1e-3)
        .unwrap_or(0)
}

/// How near a group's axes must come to one point to meet: [`MEET_FRACTION`] of the arm's
/// length along its links at `q` (at least 5 mm).
fn meet_tolerance(chain: &Chain, q: &[f64]) -> f64 {
    let origins = chain.joint_origins(q);
    let length: f64 = origins
        .windows(2)
        .map(|w| (w[1] - w[0]).norm())
        .sum::<f64>()
        + (chain.forward(q).translation.vector - origins[origins.len() - 1]).norm();
    (MEET_FRACTION * length).max(0.005)
}

/// Where a group of the chain's axes meets at `q`: among groups of two or three consecutive
/// revolute joints on `end`'s side of the (guessed) elbow, no two of them parallel, the group
/// whose axes meet (within [`MEET_FRACTION`] of the arm's length), nearest the elbow (shoulder)
/// or the hand (wrist) first, then the most axes; else the group whose axes come nearest. Gives
/// the group's first joint, its size, the point (base frame) and its distance to the farthest
/// axis.
fn meeting_axes(
    chain: &Chain,
    q: &[f64],
    end: End,
    elbow: usize,
) -> (usize, usize, Vector3<f64>, f64) {
    let frames = chain.joint_frames(q);
    let axes = chain.joint_axes(q);
    let origins: Vec<Vector3<f64>> = frames.iter().map(|f| f.translation.vector).collect();
    let meet = meet_tolerance(chain, q);
    let n = chain.dof();
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

/// The wrist of the part of the arm after chain joint `after_shoulder` as a function of the
/// configuration: the point where the axes of a group of joints beyond it meet at `zero`
/// (nearest the hand, see [`meeting_axes`]), riding on the group's first joint; `None` where no
/// such group's axes meet.
fn wrist_point<'a>(
    chain: &'a Chain,
    zero: &[f64],
    after_shoulder: usize,
) -> Option<impl Fn(&[f64]) -> Vector3<f64> + 'a> {
    let (after, size, point, spread) = meeting_axes(chain, zero, End::Wrist, after_shoulder);
    if size < 2 || spread > meet_tolerance(chain, zero) {
        return None;
    }
    let local = nalgebra::Point3::from(riding(chain, zero, after, point));
    Some(move |q: &[f64]| (chain.joint_frames(q)[after] * local).coords)
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

/// The least distance (metres) of the last link's centre of mass from the last joint's axis
/// for the link to count as carrying the forearm and the hand beyond that joint.
const FOREARM_LEVER_M: f64 = 0.02;

/// The hand point in the tip link's frame: its origin, unless the tip link is the last joint's
/// own link, its origin lies on that joint's axis (the joint moves nothing of it), the joint
/// stands alone (at least [`FOREARM_LEVER_M`] from the joint before: an elbow, not a wrist
/// whose axes meet) and the link's centre of mass lies at least that far off the axis: a
/// forearm with its hand in one link past the elbow (Poppy's, ROBOTIS' OP3), whose hand is
/// taken twice the centre of mass from the joint (a link of even mass ends there).
fn hand_point(robot: &Robot, chain: &Chain) -> Vector3<f64> {
    let none = Vector3::zeros();
    let (Some(&tip), Some(&last)) = (
        robot.link_index.get(chain.tip()),
        chain.robot_indices().last(),
    ) else {
        return none;
    };
    let joint = robot.movable[last];
    let zero = vec![0.0; chain.dof()];
    let tip_at = chain.forward(&zero).translation.vector;
    // The joint alone (the one before it at least the lever away) and the tip on it.
    let alone_under_tip = match chain.joint_origins(&zero).as_slice() {
        [.., before, at] => (at - before).norm() >= FOREARM_LEVER_M && (tip_at - at).norm() < 1e-6,
        _ => false,
    };
    if robot.parent_joint[tip] != Some(joint) || !alone_under_tip {
        return none;
    }
    let Some(link) = robot.urdf.links.iter().find(|l| l.name == chain.tip()) else {
        return none;
    };
    let c = &link.inertial.origin.xyz;
    let com = Vector3::new(c[0], c[1], c[2]);
    let axis = robot.joints[joint].axis.into_inner();
    let lever = com - axis * com.dot(&axis);
    if lever.norm() >= FOREARM_LEVER_M {
        2.0 * com
    } else {
        none
    }
}

/// One arm's geometry: its pose on the torso, shoulder, reach and elbow (the neutral posture
/// comes once the body frame is known).
///
/// The reach is the largest shoulder-to-hand distance over the joints beyond the shoulder
/// (those before it and the shoulder's own at 0 within their limits): the straightened arm,
/// measured without swinging the hand around shoulder axes that miss the shoulder point. The
/// elbow is the joint beyond the shoulder whose bending shortens that straightened arm most,
/// measured to the wrist where the wrist's axes meet.
pub(super) fn arm_geometry(
    robot: &Robot,
    raw: &RawArm,
    chain: Chain,
    hold: &[f64],
    torso_in_root: &Isometry3<f64>,
) -> AnatomyResult<AnatomyArm> {
    let base_in_torso = torso_in_root.inverse() * robot.forward_kinematics(hold, &raw.base)?;
    let hand_local = hand_point(robot, &chain);
    let chain = chain.with_tip_point(hand_local);
    let zero: Vec<f64> = chain
        .limits()
        .iter()
        .map(|&(lo, hi)| if lo <= hi { 0.0_f64.clamp(lo, hi) } else { 0.0 })
        .collect();
    let elbow_first = elbow_guess(&chain, &zero);
    let (group, size, axes_point, spread) = meeting_axes(&chain, &zero, End::Shoulder, elbow_first);
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
    let distal = (group + size).min(chain.dof())..chain.dof();
    let with = |tail: &[f64]| -> Vec<f64> {
        let mut q = zero.clone();
        q[distal.clone()].copy_from_slice(tail);
        q
    };
    let span = |q: &[f64]| (chain.forward(q).translation.vector - point).norm();
    let distal_limits = &chain.limits()[distal.clone()];
    let mid = chain.mid_range(&zero)[distal.clone()].to_vec();
    let measure = |tail: &[f64]| span(&with(tail));
    let (tail, reach) = maximise(
        &measure,
        distal_limits,
        vec![zero[distal.clone()].to_vec(), mid],
    );
    let straight = with(&tail);
    let zero_pose_reach = span(&zero);
    // How much bending joint `i` shortens the straightened arm, measured to the wrist (where
    // the axes of a group of joints after the shoulder's meet, nearest the hand), not to the
    // hand: a gripper as long as a forearm (Trossen's WXAI) makes the wrist's pitch shorten the
    // reach to its tip as much as the elbow does. To the hand where no joint bends the arm to
    // that point: it is the elbow itself where the elbow's axes meet the forearm's roll
    // (Aldebaran's NAO and Pepper), or there is no wrist.
    let elbow = {
        let wrist = wrist_point(&chain, &zero, group + size - 1);
        let bend_to = |i: usize, to: &dyn Fn(&[f64]) -> Vector3<f64>| {
            let length = |q: &[f64]| (to(q) - point).norm();
            let h = 1e-3;
            let mut a = straight.clone();
            let mut b = straight.clone();
            a[i] += h;
            b[i] -= h;
            (length(&a) - 2.0 * length(&straight) + length(&b)) / (h * h)
        };
        let hand = |q: &[f64]| chain.forward(q).translation.vector;
        let most_bending = |to: &dyn Fn(&[f64]) -> Vector3<f64>| {
            distal
                .clone()
                .map(|i| (i, bend_to(i, to)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
        };
        match wrist.as_ref().and_then(|w| most_bending(w)) {
            Some((i, bend)) if bend < -BENDS * reach => Some(i),
            _ => most_bending(&hand).map(|(i, _)| i),
        }
        .unwrap_or(0)
    };
    // The wrist's axes start after the elbow found, not the guessed one: Aldebaran's NAO and
    // Pepper turn the upper arm (elbow yaw) and bend (elbow roll) at one point, and the bend's
    // axis meets the forearm's roll at the elbow, not at a wrist. No joint after the elbow:
    // the wrist is the hand point.
    // Nor where the wrist's axes meet on the elbow's own axis (Toyota's HSR: the wrist's roll
    // meets its flex, which is the arm's elbow): the forearm would have no length.
    let on_elbow_axis = |point: &Vector3<f64>| {
        let frames = chain.joint_frames(&zero);
        let axis = chain.joint_axes(&zero)[elbow];
        let from = point - frames[elbow].translation.vector;
        (from - axis * from.dot(&axis)).norm() * 1000.0 < MIN_BONE_MM
    };
    let wrist = (elbow + 1 < chain.dof())
        .then(|| meeting_axes(&chain, &zero, End::Wrist, elbow))
        .filter(|(_, _, point, _)| !on_elbow_axis(point));
    let (wrist_after, wrist_local) = match wrist {
        Some((after, _, point, _)) => (after, riding(&chain, &zero, after, point)),
        None => (chain.dof(), hand_local),
    };
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
        hand_local,
        base_in_torso,
        reach,
        straight,
        zero_pose_reach,
        neutral: zero,
        elbow,
        chain,
    })
}
