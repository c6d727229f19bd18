//! How a command file says which commands it holds: raw, or within the robot's URDF limits.

use std::collections::BTreeMap;

use sgplvm::robots::limits::{CommandLimits, LimitCounts};

/// What a command output holds.
pub enum Commands {
    /// The model's output, bounded by nothing.
    Raw,
    /// Within the position limits, and the velocity limits when `timed`.
    Limited {
        /// The limits.
        limits: CommandLimits,
        /// Whether the frames have times (else the velocity limits cannot apply).
        timed: bool,
    },
}

impl Commands {
    /// One line saying what the commands of `robot` are, for a CSV comment.
    pub fn describe(&self, robot: &str) -> String {
        match self {
            Commands::Raw => format!(
                "{robot} commands: raw model output, not bounded by the robot's joint limits (--raw)"
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
        ("sgplvm.predict".into(), map)
    }
}
