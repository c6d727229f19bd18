//! The transforms received on `/tf` and `/tf_static`, kept per child frame: a short history of
//! stamped transforms for the dynamic frames, one transform for each static frame (latched,
//! valid at every time). From them: a frame's pose composed along the tree, and whether a
//! set of frames is complete at one stamp.

use std::collections::{BTreeMap, BTreeSet, VecDeque};

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion};

use crate::msgs::{TFMessage, TransformStamped};

/// Stamped transforms kept per dynamic frame (at 120 Hz, about a second).
pub const HISTORY: usize = 128;

/// Longest parent chain followed before a tree is taken to loop.
const MAX_DEPTH: usize = 1024;

/// A frame id as TF compares them: without a leading `/` (ROS 1's `/world` is `world`).
pub fn frame_id(id: &str) -> &str {
    id.trim_start_matches('/')
}

/// One child frame's transforms relative to its parent.
#[derive(Debug, Clone)]
struct History {
    parent: String,
    /// Published on `/tf_static`: one transform, valid at every time.
    is_static: bool,
    /// (stamp ns, child in parent), stamps increasing.
    entries: VecDeque<(i64, Isometry3<f64>)>,
}

/// What a TF transform could not be used for.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TransformError {
    /// A transform that is not a finite pose with a unit-length (non-zero) quaternion.
    #[error("transform {parent} → {child}: {message}")]
    Bad {
        /// Parent frame.
        parent: String,
        /// Child frame.
        child: String,
        /// What is wrong.
        message: String,
    },
    /// The parent chain of a frame loops.
    #[error("the parents of frame `{frame}` loop back onto it; expected a tree")]
    Loop {
        /// The frame.
        frame: String,
    },
}

/// The transforms received (module docs).
#[derive(Debug, Clone, Default)]
pub struct TfBuffer {
    frames: BTreeMap<String, History>,
    /// Counts the changes of the tree's shape (a new frame, a new parent).
    generation: u64,
}

/// A TF transform as an isometry (child in parent), checked.
pub fn isometry(t: &TransformStamped) -> Result<Isometry3<f64>, TransformError> {
    let bad = |message: String| TransformError::Bad {
        parent: t.header.frame_id.clone(),
        child: t.child_frame_id.clone(),
        message,
    };
    let (p, q) = (&t.transform.translation, &t.transform.rotation);
    let all = [p.x, p.y, p.z, q.x, q.y, q.z, q.w];
    if !all.iter().all(|v| v.is_finite()) {
        return Err(bad(format!("values {all:?}; expected finite numbers")));
    }
    let q = Quaternion::new(q.w, q.x, q.y, q.z);
    let norm = q.norm();
    // tf2 normalises what it is given; a quaternion far from unit length is a mistake.
    if (norm - 1.0).abs() > 1e-3 {
        return Err(bad(format!(
            "rotation quaternion of norm {norm}; expected a unit quaternion"
        )));
    }
    Ok(Isometry3::from_parts(
        Translation3::new(p.x, p.y, p.z),
        UnitQuaternion::from_quaternion(q),
    ))
}

impl TfBuffer {
    /// An empty buffer.
    pub fn new() -> TfBuffer {
        TfBuffer::default()
    }

    /// Adds the transforms of `msg` (from `/tf_static` when `is_static`); returns how many were
    /// taken and the errors of those that were not.
    pub fn insert(&mut self, msg: &TFMessage, is_static: bool) -> (usize, Vec<TransformError>) {
        let mut taken = 0;
        let mut errors = Vec::new();
        for t in &msg.transforms {
            match self.insert_one(t, is_static) {
                Ok(()) => taken += 1,
                Err(e) => errors.push(e),
            }
        }
        (taken, errors)
    }

    /// Adds one transform.
    pub fn insert_one(
        &mut self,
        t: &TransformStamped,
        is_static: bool,
    ) -> Result<(), TransformError> {
        let iso = isometry(t)?;
        let child = frame_id(&t.child_frame_id).to_string();
        let parent = frame_id(&t.header.frame_id).to_string();
        if child.is_empty() || parent.is_empty() || child == parent {
            return Err(TransformError::Bad {
                parent,
                child,
                message: "expected a named parent and a different, named child frame".into(),
            });
        }
        let stamp = t.header.stamp.to_ns();
        if !self.frames.contains_key(&child) {
            self.generation += 1;
        }
        let h = self.frames.entry(child).or_insert_with(|| History {
            parent: parent.clone(),
            is_static,
            entries: VecDeque::new(),
        });
        // A new parent, or a frame moving between /tf and /tf_static: what was kept is void.
        if h.parent != parent || h.is_static != is_static {
            self.generation += 1;
            h.parent = parent;
            h.is_static = is_static;
            h.entries.clear();
        }
        if is_static {
            h.entries.clear();
            h.entries.push_back((stamp, iso));
            return Ok(());
        }
        let at = h.entries.partition_point(|(s, _)| *s < stamp);
        match h.entries.get_mut(at) {
            Some(e) if e.0 == stamp => e.1 = iso,
            _ => h.entries.insert(at, (stamp, iso)),
        }
        while h.entries.len() > HISTORY {
            h.entries.pop_front();
        }
        Ok(())
    }

    /// A number that changes whenever the tree's shape does (a frame appears or changes parent).
    pub fn generation(&self) -> u64 {
        self.generation
    }

    /// Every frame named so far, as a child or as a parent.
    pub fn frame_names(&self) -> BTreeSet<String> {
        let mut names: BTreeSet<String> = self.frames.keys().cloned().collect();
        names.extend(self.frames.values().map(|h| h.parent.clone()));
        names
    }

    /// The parent of `frame`, if a transform of it was received.
    pub fn parent(&self, frame: &str) -> Option<&str> {
        self.frames.get(frame).map(|h| h.parent.as_str())
    }

    /// Whether `frame` came on `/tf_static`.
    pub fn is_static(&self, frame: &str) -> bool {
        self.frames.get(frame).is_some_and(|h| h.is_static)
    }

    /// The newest transform of `frame` in its parent, whatever its stamp.
    pub fn latest(&self, frame: &str) -> Option<Isometry3<f64>> {
        self.frames.get(frame)?.entries.back().map(|e| e.1)
    }

    /// The transform of `frame` in its parent at `stamp`: a static frame's, or the dynamic one
    /// stamped nearest `stamp` if within `tolerance_ns`.
    pub fn at(&self, frame: &str, stamp: i64, tolerance_ns: i64) -> Option<Isometry3<f64>> {
        let h = self.frames.get(frame)?;
        if h.is_static {
            return h.entries.back().map(|e| e.1);
        }
        h.entries
            .iter()
            .filter(|(s, _)| (s - stamp).abs() <= tolerance_ns)
            .min_by_key(|(s, _)| (s - stamp).abs())
            .map(|e| e.1)
    }

    /// The stamps of the dynamic transforms of `frames`.
    pub fn stamps<'a>(&self, frames: impl IntoIterator<Item = &'a str>) -> BTreeSet<i64> {
        frames
            .into_iter()
            .filter_map(|f| self.frames.get(f))
            .filter(|h| !h.is_static)
            .flat_map(|h| h.entries.iter().map(|e| e.0))
            .collect()
    }

    /// The frames of `frames` without a transform at `stamp` (within `tolerance_ns`): empty
    /// when the set is complete.
    pub fn missing<'a>(
        &self,
        frames: impl IntoIterator<Item = &'a str>,
        stamp: i64,
        tolerance_ns: i64,
    ) -> Vec<String> {
        frames
            .into_iter()
            .filter(|f| self.at(f, stamp, tolerance_ns).is_none())
            .map(str::to_string)
            .collect()
    }

    /// The pose of `frame` in `root` at `stamp`: the transforms along the tree from `root`
    /// down to `frame` composed (`T_root_frame = T_root_a · T_a_b · … · T_parent_frame`), or
    /// the frames whose transform at that stamp is missing. `root` `None`: the tree's root
    /// (the first frame up the chain without a parent), which is then returned too.
    pub fn compose(
        &self,
        frame: &str,
        root: Option<&str>,
        stamp: i64,
        tolerance_ns: i64,
    ) -> Result<(String, Isometry3<f64>), ComposeError> {
        let mut pose = Isometry3::identity();
        let mut cur = frame.to_string();
        for _ in 0..MAX_DEPTH {
            if root == Some(cur.as_str()) {
                return Ok((cur, pose));
            }
            let Some(parent) = self.parent(&cur).map(str::to_string) else {
                return match root {
                    None => Ok((cur, pose)),
                    Some(r) => Err(ComposeError::NotBelow {
                        frame: frame.to_string(),
                        root: r.to_string(),
                        top: cur,
                    }),
                };
            };
            let local = self
                .at(&cur, stamp, tolerance_ns)
                .ok_or_else(|| ComposeError::Missing { frame: cur.clone() })?;
            pose = local * pose;
            cur = parent;
        }
        Err(ComposeError::Loop(TransformError::Loop {
            frame: frame.to_string(),
        }))
    }
}

/// Why a frame's pose could not be composed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ComposeError {
    /// A frame on the way has no transform at the stamp.
    #[error("no transform of frame `{frame}` at that time")]
    Missing {
        /// The frame.
        frame: String,
    },
    /// The root asked for is not above the frame.
    #[error("frame `{frame}` does not hang from `{root}` (its tree's top is `{top}`)")]
    NotBelow {
        /// The frame.
        frame: String,
        /// The root asked for.
        root: String,
        /// Where the chain ends.
        top: String,
    },
    /// The chain loops.
    #[error(transparent)]
    Loop(TransformError),
}
