//! How a command file says which commands it holds: raw, or within the robot's URDF limits.

use std::collections::BTreeMap;

use sgplvm::robots::limits::{CommandLimits, LimitCounts};
use sgplvm::robots::safety::SafetyStep;
use sgplvm::robots::series::seconds_from_ns;

/// What a command output holds.
pub enum Commands {
    /// The model's output, bounded by nothing.
    Raw,
    /// Within the position limits, and the velocity limits when `timed`; out of
    /// self-collision when `safety` is given.
    Limited {
        /// The limits.
        limits: CommandLimits,
        /// Whether the frames have times (else the velocity limits cannot apply).
        timed: bool,
        /// The nearest safe command (the robot's own shapes kept a margin apart).
        safety: Option<Box<SafetyStep>>,
    },
}

impl Commands {
    /// Bounds a series of commands (`rows`, row-major, `d` per command, at `times_ns`): within
    /// the limits, then out of self-collision one after another; what held them back (`None`
    /// for raw commands, or without a self-collision limit).
    pub fn apply(
        &mut self,
        rows: &mut [f64],
        d: usize,
        times_ns: &[i64],
    ) -> (Option<LimitCounts>, Option<KeptApart>) {
        let Commands::Limited {
            limits,
            timed,
            safety,
        } = self
        else {
            return (None, None);
        };
        // Seconds from the first frame, subtracted in nanoseconds: an absolute clock (1.7e9 s)
        // leaves a double too few digits for a velocity limit's step.
        let t0 = times_ns.first().copied().unwrap_or(0);
        let times: Vec<f64> = if *timed {
            times_ns.iter().map(|&t| seconds_from_ns(t - t0)).collect()
        } else {
            Vec::new()
        };
        let counts = limits.apply_all(rows, &times);
        let kept = safety.as_mut().map(|s| keep_apart(s, rows, d, &times));
        (Some(counts), kept)
    }

    /// One line saying what the commands of `robot` are, for a CSV comment.
    pub fn describe(&self, robot: &str) -> String {
        match self {
            Commands::Raw => format!(
                "{robot} commands: raw model output, not bounded by the robot's joint limits (--raw)"
            ),
            Commands::Limited {
                timed: true,
                safety: Some(safety),
                ..
            } if !safety.collision().pairs().is_empty() => format!(
                "{robot} commands: within the robot's URDF position and velocity limits and out of self-collision (--raw for the model's output)"
            ),
            Commands::Limited { timed: true, .. } => format!(
                "{robot} commands: within the robot's URDF position and velocity limits (--raw for the model's output)"
            ),
            Commands::Limited { timed: false, .. } => format!(
                "{robot} commands: within the robot's URDF position limits (the input has no times: velocity limits not applied; --raw for the model's output)"
            ),
        }
    }

    /// The MCAP metadata record `sgplvm.predict` saying the same, with the counts when known.
    pub fn metadata(
        &self,
        robot: &str,
        counts: Option<&LimitCounts>,
    ) -> (String, BTreeMap<String, String>) {
        let mut map = BTreeMap::new();
        map.insert("robot".to_string(), robot.to_string());
        let (commands, limits) = match self {
            Commands::Raw => ("raw", "none"),
            Commands::Limited { timed: true, .. } => ("limited", "position and velocity"),
            Commands::Limited { timed: false, .. } => ("limited", "position"),
        };
        map.insert("commands".into(), commands.into());
        map.insert("limits".into(), limits.into());
        if let Some(c) = counts {
            map.insert("frames".into(), c.commands.to_string());
            map.insert("frames_limited".into(), c.commands_clamped.to_string());
        }
        if let Commands::Limited {
            safety: Some(s), ..
        } = self
        {
            map.insert(
                "self_collision_pairs".into(),
                s.collision().pairs().len().to_string(),
            );
        }
        ("sgplvm.predict".into(), map)
    }
}

/// What the self-collision limit did to a series of commands.
#[derive(Default)]
pub struct KeptApart {
    /// Pairs of collision shapes it checked (none: it could check nothing).
    pub pairs: usize,
    /// Commands it saw.
    pub seen: usize,
    /// Commands it moved.
    pub commands: usize,
    /// The nearest pair of links it kept apart, and their distance (metres).
    pub closest: Option<(String, String, f64)>,
}

impl KeptApart {
    /// Counts one command's outcome.
    pub fn add(&mut self, outcome: sgplvm::robots::safety::SafetyOutcome) {
        self.seen += 1;
        if outcome.changed && !outcome.near.is_empty() {
            self.commands += 1;
        }
        for n in outcome.near {
            if self.closest.as_ref().is_none_or(|c| n.2 < c.2) {
                self.closest = Some(n);
            }
        }
    }

    /// One line for stderr.
    pub fn summary(&self, robot: &str) -> String {
        match &self.closest {
            Some((a, b, d)) => format!(
                "{} {robot} commands kept out of self-collision (closest: {a} and {b}, {:.1} mm){}",
                self.commands,
                d * 1e3,
                if self.seen >= 10 && 2 * self.commands > self.seen {
                    // Galbot's camera held every command before its collision model was mended.
                    format!("; warning: that is most of the {} commands — if the robot itself does not touch there, its collision meshes are coarser than it (--margin 0 turns the check off)", self.seen)
                } else {
                    String::new()
                }
            ),
            None if self.pairs == 0 => format!(
                "self-collision not checked for {robot}: no pair of its collision shapes can meet"
            ),
            None => format!("no {robot} command came near a self-collision"),
        }
    }
}

/// Keeps a series of commands (`rows`, row-major, `d` per command, at `times` seconds, or
/// untimed) out of self-collision, one command after another.
fn keep_apart(safety: &mut SafetyStep, rows: &mut [f64], d: usize, times: &[f64]) -> KeptApart {
    let mut kept = KeptApart {
        pairs: safety.collision().pairs().len(),
        ..KeptApart::default()
    };
    let mut out = vec![0.0; d];
    for (f, row) in rows.chunks_exact_mut(d.max(1)).enumerate() {
        let now = times.get(f).copied().unwrap_or(f as f64);
        kept.add(safety.step(row, now, &mut out));
        row.copy_from_slice(&out);
    }
    kept
}
