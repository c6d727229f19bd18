//! Step 3 of loading a URDF (see the [module documentation](super)): assembling the checked
//! joints into a kinematic tree. Unknown links, a link with two parents or its own parent,
//! cycles and several roots are errors.

use std::collections::HashMap;

use super::check::{Ctx, RawJoint};
use super::JointInfo;
use crate::error::{RobotError, RobotResult};

/// Joints resolved onto link indices.
pub(super) struct Tree {
    pub(super) joints: Vec<JointInfo>,
    /// Per link, the joint whose child it is.
    pub(super) parent_joint: Vec<Option<usize>>,
    /// Indices of the movable joints, in configuration order.
    pub(super) movable: Vec<usize>,
}

/// Resolves each joint's links and checks that no link has two parents or is its own parent.
pub(super) fn build_tree(
    ctx: &Ctx,
    links: &[String],
    link_index: &HashMap<String, usize>,
    raw: Vec<RawJoint>,
) -> RobotResult<Tree> {
    let file = ctx.file;
    let mut parent_joint: Vec<Option<usize>> = vec![None; links.len()];
    let mut joints = Vec::with_capacity(raw.len());
    let mut movable = Vec::new();
    for (ji, j) in raw.into_iter().enumerate() {
        let find = |role: &'static str, l: &str| {
            link_index
                .get(l)
                .copied()
                .ok_or_else(|| RobotError::UnknownLink {
                    file: file.to_string(),
                    line: j.line,
                    joint: j.name.clone(),
                    role,
                    link: l.to_string(),
                })
        };
        let parent = find("parent", &j.parent)?;
        let child = find("child", &j.child)?;
        if parent == child {
            return Err(RobotError::Cycle {
                file: file.to_string(),
                links: vec![j.child.clone()],
            });
        }
        if let Some(other) = parent_joint[child] {
            let other: &JointInfo = &joints[other];
            return Err(ctx.invalid_at(
                j.line,
                format!("<joint name=\"{}\">", j.name),
                format!(
                    "link \"{}\" is already the child of joint \"{}\", expected each link to have at most one parent joint",
                    j.child, other.name
                ),
            ));
        }
        parent_joint[child] = Some(ji);
        let q_index = if j.kind.is_movable() {
            movable.push(ji);
            Some(movable.len() - 1)
        } else {
            None
        };
        joints.push(JointInfo {
            name: j.name,
            kind: j.kind,
            parent,
            child,
            origin: j.origin,
            axis: j.axis,
            limits: j.limits,
            velocity: j.velocity,
            effort: j.effort,
            q_index,
        });
    }
    Ok(Tree {
        joints,
        parent_joint,
        movable,
    })
}

/// The root link: the only link without a parent joint, with every link reaching it.
pub(super) fn find_root(
    file: &str,
    links: &[String],
    joints: &[JointInfo],
    parent_joint: &[Option<usize>],
) -> RobotResult<usize> {
    let roots: Vec<usize> = (0..links.len())
        .filter(|&l| parent_joint[l].is_none())
        .collect();
    if roots.len() > 1 {
        return Err(RobotError::MultipleRoots {
            file: file.to_string(),
            roots: roots.iter().map(|&l| links[l].clone()).collect(),
        });
    }
    // Every link has at most one parent; a link that does not reach the root by following
    // parents lies on (or below) a cycle.
    // One pass: a link is `Done` once its chain of parents is known to end at a root, so each
    // link is walked once (a per-start walk is quadratic on a long chain).
    #[derive(Clone, Copy, PartialEq)]
    enum Mark {
        New,
        OnPath,
        Done,
    }
    let mut mark = vec![Mark::New; links.len()];
    for start in 0..links.len() {
        let mut cur = start;
        while mark[cur] == Mark::New {
            mark[cur] = Mark::OnPath;
            match parent_joint[cur] {
                Some(j) => cur = joints[j].parent,
                None => break,
            }
        }
        if let (Mark::OnPath, Some(pj)) = (mark[cur], parent_joint[cur]) {
            let mut cycle = vec![links[cur].clone()];
            let mut c = joints[pj].parent;
            while c != cur {
                cycle.push(links[c].clone());
                match parent_joint[c] {
                    Some(pj) => c = joints[pj].parent,
                    None => break,
                }
            }
            cycle.reverse();
            return Err(RobotError::Cycle {
                file: file.to_string(),
                links: cycle,
            });
        }
        let mut c = start;
        while mark[c] == Mark::OnPath {
            mark[c] = Mark::Done;
            match parent_joint[c] {
                Some(j) => c = joints[j].parent,
                None => break,
            }
        }
    }
    let Some(&root_link) = roots.first() else {
        // Unreachable in practice: no root means a cycle, which the loop above reports.
        return Err(RobotError::Cycle {
            file: file.to_string(),
            links: links.to_vec(),
        });
    };
    Ok(root_link)
}
