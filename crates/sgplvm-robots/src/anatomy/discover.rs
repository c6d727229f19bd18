//! Finding a robot's arms in its URDF tree — two, or one on a single-arm robot (a mobile
//! manipulator, an arm on a table): as the user named them, by sgplvm's link convention, by
//! the joints' names, else by the tree's structure; and each arm's hand link.

use super::words::{hand_score, names_a_finger, names_an_arm_part, part_of, side_of, Part};
use super::{AnatomyError, AnatomyResult, AnatomySpec, Found};
use crate::models::Side;
use crate::names::few;
use crate::urdf::{JointKind, Robot};

/// One arm as found: the link its chain starts at, its hand link, and (by the convention) the
/// link at its shoulder.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct RawArm {
    pub side: Side,
    pub base: String,
    pub hand: String,
    pub shoulder_link: Option<String>,
}

/// The arms (left then right; one on a single-arm robot), how they were found and what was
/// noticed.
#[derive(Debug, Clone)]
pub(super) struct FoundArms {
    pub found: Found,
    pub arms: Vec<RawArm>,
    pub notes: Vec<String>,
}

/// The URDF's file name for messages.
pub(super) fn file_of(robot: &Robot) -> String {
    robot.source().to_string()
}

/// The tree's child joints per link.
struct Tree<'a> {
    robot: &'a Robot,
    children: Vec<Vec<usize>>,
    /// Per joint: whether it, or any joint below it, is movable.
    moves: Vec<bool>,
    /// Per joint: whether it mimics another (`<mimic>`): moved by that joint, never commanded.
    mimics: Vec<bool>,
}

impl<'a> Tree<'a> {
    fn new(robot: &'a Robot) -> Self {
        let mut children = vec![Vec::new(); robot.links.len()];
        for (j, joint) in robot.joints.iter().enumerate() {
            children[joint.parent].push(j);
        }
        // Deepest joints first, so that each joint's children are known before it.
        let mut order: Vec<usize> = (0..robot.joints.len()).collect();
        order.sort_by_key(|&j| std::cmp::Reverse(robot.path_to(robot.joints[j].child).len()));
        let mut moves = vec![false; robot.joints.len()];
        for j in order {
            moves[j] = robot.joints[j].can_move()
                || children[robot.joints[j].child].iter().any(|&c| moves[c]);
        }
        let mimicking: std::collections::HashSet<&str> = robot
            .urdf
            .joints
            .iter()
            .filter(|j| j.mimic.is_some())
            .map(|j| j.name.as_str())
            .collect();
        let mimics = robot
            .joints
            .iter()
            .map(|j| mimicking.contains(j.name.as_str()))
            .collect();
        Tree {
            robot,
            children,
            moves,
            mimics,
        }
    }

    fn link_name(&self, l: usize) -> &str {
        &self.robot.links[l]
    }

    fn joint_name(&self, j: usize) -> &str {
        &self.robot.joints[j].name
    }

    /// Whether joint `j` can move (a joint with one value allowed cannot).
    fn movable(&self, j: usize) -> bool {
        self.robot.joints[j].can_move()
    }

    /// Whether joint `j` turns (revolute or continuous, and can move).
    fn revolute(&self, j: usize) -> bool {
        self.movable(j)
            && matches!(
                self.robot.joints[j].kind,
                JointKind::Revolute | JointKind::Continuous
            )
    }

    /// Whether the subtree under joint `j` (the joint included) moves anything.
    fn moves(&self, j: usize) -> bool {
        self.moves[j]
    }

    /// The child joints of `link` whose subtrees move anything, but for a head: a head turning
    /// on an arm's link (Rethink's Sawyer pans its head on the arm's first link) does not end
    /// the arm there.
    fn onward(&self, link: usize) -> Vec<usize> {
        self.children[link]
            .iter()
            .copied()
            .filter(|&c| {
                self.moves(c)
                    && part_of(self.joint_name(c)) != Part::Head
                    && part_of(self.link_name(self.robot.joints[c].child)) != Part::Head
            })
            .collect()
    }

    /// The serial chain of movable joints starting at joint `j`: each link passed on has one
    /// child branch that moves anything ([`Tree::onward`]: a head aside); it ends where the
    /// tree branches (a gripper's fingers) or nothing moves below.
    fn serial_from(&self, j: usize) -> Vec<usize> {
        let mut chain = vec![j];
        let mut link = self.robot.joints[j].child;
        loop {
            match self.onward(link).as_slice() {
                [one] => {
                    if self.movable(*one) {
                        chain.push(*one);
                    }
                    link = self.robot.joints[*one].child;
                }
                _ => return chain,
            }
        }
    }

    /// The hand link of an arm whose last joint is `last`: among the links fixed to its child
    /// link, the one whose name says hand most (`hand`, `palm` before `tool`, `tcp`, `ee`,
    /// `flange` before `gripper`), nearest first; the child link itself when none does.
    fn hand_link(&self, last: usize) -> String {
        let start = self.robot.joints[last].child;
        let mut best = (hand_score(self.link_name(start)), 0usize, start);
        let mut frontier = vec![(start, 0usize)];
        while let Some((link, depth)) = frontier.pop() {
            for &c in &self.children[link] {
                if !self.movable(c) {
                    let child = self.robot.joints[c].child;
                    let score = hand_score(self.link_name(child));
                    let cand = (score, depth + 1, child);
                    if score > best.0 || (score == best.0 && score > 0 && depth + 1 < best.1) {
                        best = cand;
                    }
                    frontier.push((child, depth + 1));
                }
            }
        }
        self.link_name(best.2).to_string()
    }

    /// Whether the tree branches between joint `upper` and joint `lower` below it: a link from
    /// `upper`'s child down to `lower`'s parent with more than one child branch that moves
    /// anything, a head aside (a palm's fingers). An arm is serial: what lies past such a
    /// branch is a hand.
    fn branches_between(&self, upper: usize, lower: usize) -> bool {
        let stop = self.robot.joints[upper].child;
        let mut link = self.robot.joints[lower].parent;
        loop {
            if self.onward(link).len() > 1 {
                return true;
            }
            if link == stop {
                return false;
            }
            match self.robot.parent_joint[link] {
                Some(j) => link = self.robot.joints[j].parent,
                None => return false,
            }
        }
    }

    /// Movable joints from the root down to `link`, root first.
    fn movable_path(&self, link: usize) -> Vec<usize> {
        self.robot
            .path_to(link)
            .into_iter()
            .filter(|&j| self.movable(j))
            .collect()
    }
}

/// The arms of `robot`: as `spec` names them (both, or one: a single arm, the other side's
/// joints held), else by the convention, the names or the structure.
pub(super) fn arms(robot: &Robot, spec: &AnatomySpec) -> AnatomyResult<FoundArms> {
    let tree = Tree::new(robot);
    if spec.left.is_none() && spec.right.is_none() {
        return convention(&tree)
            .or_else(|| by_names(&tree))
            .map_or_else(|| by_structure(&tree), Ok);
    }
    let found = match &spec.source {
        Some(p) => Found::File(p.display().to_string()),
        None => Found::Named,
    };
    let what = |side: &str| match &spec.source {
        Some(p) => format!("{}: arms.{side}", p.display()),
        None => format!("--arm {side}"),
    };
    let mut arms = Vec::with_capacity(2);
    for side in [Side::Left, Side::Right] {
        if let Some(a) = spec.arm(side) {
            arms.push(named(&tree, side, &a.from, &a.to, &what(side.as_str()))?);
        }
    }
    check_shared(&tree, &arms)?;
    let notes = match arms.as_slice() {
        [one] => vec![format!(
            "one arm named ({}): a single-arm robot, driven by the person's {} arm; every other joint is held",
            one.side.as_str(),
            one.side.as_str()
        )],
        _ => Vec::new(),
    };
    Ok(FoundArms { found, arms, notes })
}

/// An arm named FROM:TO, checked.
fn named(tree: &Tree, side: Side, from: &str, to: &str, what: &str) -> AnatomyResult<RawArm> {
    let robot = tree.robot;
    let id = |link: &str| {
        robot
            .link_index
            .get(link)
            .copied()
            .ok_or_else(|| AnatomyError::NoSuchLink {
                file: file_of(robot),
                what: what.to_string(),
                link: link.to_string(),
                hint: close_names(link, &robot.links),
            })
    };
    let (f, t) = (id(from)?, id(to)?);
    let path = robot.path_to(t);
    let above: Vec<usize> = std::iter::once(robot.root)
        .chain(path.iter().map(|&j| robot.joints[j].child))
        .collect();
    if f != t && !above.contains(&f) {
        let names: Vec<&str> = above.iter().map(|&l| robot.links[l].as_str()).collect();
        return Err(AnatomyError::NotAChain {
            file: file_of(robot),
            what: what.to_string(),
            from: from.to_string(),
            to: to.to_string(),
            path: names.join(" → "),
        });
    }
    Ok(RawArm {
        side,
        base: from.to_string(),
        hand: to.to_string(),
        shoulder_link: None,
    })
}

/// Up to three link names that contain `name` or that it contains, for a hint.
fn close_names(name: &str, links: &[String]) -> String {
    let lower = name.to_lowercase();
    let close: Vec<&String> = links
        .iter()
        .filter(|l| {
            let l = l.to_lowercase();
            l.contains(&lower) || lower.contains(&l)
        })
        .take(3)
        .collect();
    if close.is_empty() {
        String::new()
    } else {
        format!(" (did you mean {}?)", few(&close, 3))
    }
}

/// The movable joints two named arms share, an error when there are any.
fn check_shared(tree: &Tree, arms: &[RawArm]) -> AnatomyResult<()> {
    let robot = tree.robot;
    let [left, right] = arms else {
        return Ok(());
    };
    let joints = |a: &RawArm| -> AnatomyResult<Vec<String>> {
        Ok(robot.chain(&a.base, &a.hand)?.joint_names().to_vec())
    };
    let (l, r) = (joints(left)?, joints(right)?);
    let shared: Vec<&String> = l.iter().filter(|j| r.contains(j)).collect();
    if shared.is_empty() {
        return Ok(());
    }
    let below = shared
        .last()
        .and_then(|n| robot.joints.iter().find(|j| &&j.name == n))
        .map_or_else(String::new, |j| robot.links[j.child].clone());
    Err(AnatomyError::SharedJoints {
        file: file_of(robot),
        arms: Box::new(super::SharedArms {
            lfrom: left.base.clone(),
            lto: left.hand.clone(),
            rfrom: right.base.clone(),
            rto: right.hand.clone(),
            joints: few(&shared, 4),
            below,
        }),
    })
}

/// The shipped robots' convention: links `left_shoulder`, `left_hand`, `right_shoulder`,
/// `right_hand`; joints both hands' paths share (a waist) belong to neither arm.
fn convention(tree: &Tree) -> Option<FoundArms> {
    let robot = tree.robot;
    let id = |n: &str| robot.link_index.get(n).copied();
    let (lh, rh) = (id("left_hand")?, id("right_hand")?);
    id("left_shoulder")?;
    id("right_shoulder")?;
    let (lp, rp) = (tree.movable_path(lh), tree.movable_path(rh));
    let shared = lp.iter().zip(&rp).take_while(|(a, b)| a == b).count();
    let arm = |side: Side, path: &[usize], hand: &str| -> Option<RawArm> {
        let first = *path.get(shared)?;
        Some(RawArm {
            side,
            base: robot.links[robot.joints[first].parent].clone(),
            hand: hand.to_string(),
            shoulder_link: Some(format!("{}_shoulder", side.as_str())),
        })
    };
    Some(FoundArms {
        found: Found::Convention,
        arms: vec![
            arm(Side::Left, &lp, "left_hand")?,
            arm(Side::Right, &rp, "right_hand")?,
        ],
        notes: Vec::new(),
    })
}

/// Why no arm was found when the tree has no chain that could be one: its arm joints fixed (a
/// description made for training the legs, the arms locked), else no names and no chain.
fn no_chain_why(tree: &Tree) -> String {
    let locked: Vec<&str> = (0..tree.robot.joints.len())
        .filter(|&j| {
            tree.robot.joints[j].kind == JointKind::Fixed
                && part_of(tree.joint_name(j)) == Part::Arm
        })
        .map(|j| tree.joint_name(j))
        .collect();
    if locked.is_empty() {
        // Chains there are, but their names say legs, a head or grippers (EngineAI's SA01:
        // two 6-joint legs and no arm).
        let other: Vec<&str> = (0..tree.robot.joints.len())
            .filter(|&j| tree.revolute(j) && !armlike(tree, j))
            .map(|j| tree.joint_name(j))
            .collect();
        if !other.is_empty() && (0..tree.robot.joints.len()).all(|j| !armlike(tree, j)) {
            return format!(
                "its {} revolute joints are named as legs, a head or grippers ({}): no arm",
                other.len(),
                few(&other, 3)
            );
        }
        return "no joint name says left or right, and the tree has no serial chain of four or more revolute joints".into();
    }
    // Arm joints that turn as well: the chain is broken by branches, not locked (ToddlerBot's
    // gear trains: a `left_sho_yaw_drive` pinion beside each `left_sho_yaw_driven` joint).
    let turning = (0..tree.robot.joints.len())
        .filter(|&j| tree.revolute(j) && part_of(tree.joint_name(j)) == Part::Arm)
        .count();
    if turning >= 2 * locked.len().max(3) {
        return format!(
            "its {turning} revolute arm joints do not make a serial chain from the torso to each hand (the tree branches between them: gear trains, motors or sensors on the arm, beside {} fixed ones such as {})",
            locked.len(),
            few(&locked, 2)
        );
    }
    format!(
        "{} named as arm joints are fixed in this file ({}): its arms cannot move (a description made for walking, the arms locked?); use the maker's description whose arm joints are revolute",
        crate::names::count(locked.len(), "joint"),
        few(&locked, 4)
    )
}

/// Whether joint `j` can be an arm joint by its words (and its child link's, unless its own
/// name says arm: a `wrist_roll` joint may carry the link a maker calls `gripper`); a joint
/// that mimics another never is (Toyota's HSR: three of each gripper finger's four joints,
/// `hand_l_spring_proximal_joint` …, whose names say left and hand).
fn armlike(tree: &Tree, j: usize) -> bool {
    let own = part_of(tree.joint_name(j));
    let link_name = tree.link_name(tree.robot.joints[j].child);
    let link = part_of(link_name);
    // A joint whose only arm word is `arm` (a namespace) moving a finger's link is a finger.
    let finger = !names_an_arm_part(tree.joint_name(j)) && names_a_finger(link_name);
    tree.revolute(j)
        && !tree.mimics[j]
        && !finger
        && !matches!(own, Part::Gripper | Part::Leg | Part::Head | Part::Torso)
        && (own == Part::Arm || !matches!(link, Part::Gripper | Part::Leg | Part::Head))
}

/// The side joint `j`'s name (else its child link's) says.
fn side_said(tree: &Tree, j: usize) -> Option<Side> {
    side_of(tree.joint_name(j)).or_else(|| side_of(tree.link_name(tree.robot.joints[j].child)))
}

/// Arms by the joints' names: per side, the serial run of arm-like joints of that side with
/// the most arm words (then the most joints). A run ends where the tree branches into several
/// moving parts (a hand's fingers: `hand_left_mrl_joint` says `hand`, yet it is a finger).
fn by_names(tree: &Tree) -> Option<FoundArms> {
    let robot = tree.robot;
    let arm = |side: Side| -> Option<RawArm> {
        let cands: Vec<usize> = (0..robot.joints.len())
            .filter(|&j| armlike(tree, j) && side_said(tree, j) == Some(side))
            .collect();
        let best = cands
            .iter()
            .map(|&j| {
                let mut path: Vec<usize> = tree
                    .movable_path(robot.joints[j].child)
                    .into_iter()
                    .filter(|k| cands.contains(k))
                    .collect();
                if let Some(cut) = path
                    .windows(2)
                    .position(|w| tree.branches_between(w[0], w[1]))
                {
                    path.truncate(cut + 1);
                }
                let words = path
                    .iter()
                    .filter(|&&k| part_of(tree.joint_name(k)) == Part::Arm)
                    .count();
                (words, path.len(), std::cmp::Reverse(j), path)
            })
            .max_by(|a, b| (a.0, a.1, a.2).cmp(&(b.0, b.1, b.2)))?;
        let path = best.3;
        if path.len() < 3 {
            return None;
        }
        let first = path[0];
        let last = *path.last()?;
        Some(RawArm {
            side,
            base: robot.links[robot.joints[first].parent].clone(),
            hand: tree.hand_link(last),
            shoulder_link: None,
        })
    };
    Some(FoundArms {
        found: Found::Names,
        arms: vec![arm(Side::Left)?, arm(Side::Right)?],
        notes: Vec::new(),
    })
}

/// Arms by structure alone: serial chains of at least four revolute joints (not named as legs,
/// heads or grippers) that no other chain continues; exactly two of them, or the two of equal
/// length nearest each other in the tree (left is the one further along the root's +y); or
/// exactly one: a single-arm robot, on the side its names say, else the right.
fn by_structure(tree: &Tree) -> AnatomyResult<FoundArms> {
    let robot = tree.robot;
    let cands: Vec<usize> = (0..robot.joints.len())
        .filter(|&j| armlike(tree, j))
        .collect();
    // Each chain up to its first joint that cannot be an arm's (a single jaw's revolute joint
    // continuing the chain past the wrist).
    let chains: Vec<Vec<usize>> = cands
        .iter()
        .map(|&j| {
            tree.serial_from(j)
                .into_iter()
                .take_while(|k| cands.contains(k))
                .collect()
        })
        .collect();
    let starts: Vec<&Vec<usize>> = chains
        .iter()
        .filter(|c| {
            c.len() >= 4
                && !chains
                    .iter()
                    .any(|o| o[0] != c[0] && o.contains(&c[0]) && o.len() >= c.len())
        })
        .collect();
    let no_arms = |why: String| AnatomyError::NoArms {
        file: file_of(robot),
        why,
        description: super::description_path(std::path::Path::new(robot.source()))
            .display()
            .to_string(),
    };
    let describe = |c: &Vec<usize>| {
        format!(
            "{} → {} ({} joints)",
            tree.joint_name(c[0]),
            tree.joint_name(*c.last().unwrap_or(&c[0])),
            c.len()
        )
    };
    let raw = |side: Side, c: &Vec<usize>| RawArm {
        side,
        base: robot.links[robot.joints[c[0]].parent].clone(),
        hand: tree.hand_link(*c.last().unwrap_or(&c[0])),
        shoulder_link: None,
    };
    let pair = match starts.as_slice() {
        [a, b] => (*a, *b),
        [one] => {
            // A single-arm robot: the person's arm of the side its names say, else the right.
            let said = one.iter().find_map(|&j| side_said(tree, j));
            let side = said.unwrap_or(Side::Right);
            let why = match said {
                Some(_) => "its joint names say so",
                None => "no joint name says a side",
            };
            return Ok(FoundArms {
                found: Found::Structure,
                arms: vec![raw(side, one)],
                notes: vec![format!(
                    "one arm ({}): a single-arm robot, driven by the person's {} arm ({why}; --arm {}=FROM_LINK:TO_LINK names it and its side); every other joint is held",
                    describe(one),
                    side.as_str(),
                    side.other().as_str()
                )],
            });
        }
        [] => return Err(no_arms(no_chain_why(tree))),
        more => {
            let equal: Vec<(usize, usize)> = (0..more.len())
                .flat_map(|a| ((a + 1)..more.len()).map(move |b| (a, b)))
                .filter(|&(a, b)| more[a].len() == more[b].len())
                .collect();
            match equal.as_slice() {
                [(a, b)] => (more[*a], more[*b]),
                _ => {
                    let list: Vec<String> = more.iter().map(|c| describe(c)).collect();
                    return Err(no_arms(format!(
                        "no joint name says left or right, and {} serial chains could be arms: {}",
                        more.len(),
                        list.join("; ")
                    )));
                }
            }
        }
    };
    let zero = robot.neutral_configuration();
    let y = |c: &Vec<usize>| -> AnatomyResult<f64> {
        let link = &robot.links[robot.joints[c[0]].child];
        Ok(robot.forward_kinematics(&zero, link)?.translation.vector.y)
    };
    let (ya, yb) = (y(pair.0)?, y(pair.1)?);
    if (ya - yb).abs() < 0.01 {
        return Err(no_arms(format!(
            "two serial chains ({}; {}) could be arms, but no joint name says which is left and they are not apart along the root's y axis",
            describe(pair.0),
            describe(pair.1)
        )));
    }
    let (left, right) = if ya > yb { pair } else { (pair.1, pair.0) };
    Ok(FoundArms {
        found: Found::Structure,
        arms: vec![raw(Side::Left, left), raw(Side::Right, right)],
        notes: vec![format!(
            "no joint name says left or right: the arm starting at {} is taken as the left one, for it lies further along the root link's +y; name the arms with --arm if that is wrong",
            tree.joint_name(left[0])
        )],
    })
}
