//! The forms a robot's command takes on the wire, one per kind of controller, and where each
//! carries the stamp of the human frame it answers.

use crate::msgs::{
    Duration, Float64MultiArray, Header, JointState, JointTrajectory, JointTrajectoryPoint,
    MultiArrayDimension, MultiArrayLayout, Time, XbotJointCommand, XBOT_CTRL_POSITION,
};

/// The message a command is sent as.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CommandForm {
    /// `sensor_msgs/msg/JointState` on `/ROBOT/joint_command` (as `sgplvm predict` writes);
    /// `header.stamp` is the human frame's.
    #[default]
    JointState,
    /// `std_msgs/msg/Float64MultiArray` for ros2_control's forward position controller
    /// (`/forward_position_controller/commands`), joints in the controller's order. The message
    /// has no header: the human frame's stamp is in the one dimension's label,
    /// `joints@SEC.NANOSEC` (controllers read `data` only).
    Forward,
    /// `trajectory_msgs/msg/JointTrajectory` with one point one frame ahead
    /// (`time_from_start` = the input's frame period, or longer: as long as the velocity limits
    /// take from the command sent before), for the joint trajectory controller
    /// (`/joint_trajectory_controller/joint_trajectory`). `header.stamp` stays 0, which that
    /// controller reads as "start on receipt" (a past stamp would make it skip the point); the
    /// human frame's stamp is in `header.frame_id` as `stamp:SEC.NANOSEC`.
    Trajectory,
    /// `xbot_msgs/msg/JointCommand` on `xbotcore/command`, XBot2's command (WALK-MAN, COMAN,
    /// CENTAURO): positions as float32 with `ctrl_mode` position; `header.stamp` is the human
    /// frame's.
    Xbot,
}

impl CommandForm {
    /// The command-line name: `joint-state`, `forward`, `trajectory` or `xbot`.
    pub fn name(self) -> &'static str {
        match self {
            CommandForm::JointState => "joint-state",
            CommandForm::Forward => "forward",
            CommandForm::Trajectory => "trajectory",
            CommandForm::Xbot => "xbot",
        }
    }

    /// Parses a command-line name.
    pub fn parse(s: &str) -> Option<CommandForm> {
        [
            CommandForm::JointState,
            CommandForm::Forward,
            CommandForm::Trajectory,
            CommandForm::Xbot,
        ]
        .into_iter()
        .find(|f| f.name() == s)
    }

    /// The ROS 2 package and type name of the message.
    pub fn type_name(self) -> (&'static str, &'static str) {
        use crate::msgs::types::*;
        match self {
            CommandForm::JointState => JOINT_STATE,
            CommandForm::Forward => FLOAT64_MULTI_ARRAY,
            CommandForm::Trajectory => JOINT_TRAJECTORY,
            CommandForm::Xbot => XBOT_JOINT_COMMAND,
        }
    }

    /// The default topic for `robot`; `shared` says whether several robots share the node
    /// (the controllers' topics are then put under the robot's namespace).
    pub fn default_topic(self, robot: &str, shared: bool) -> String {
        let base = match self {
            CommandForm::JointState => return format!("/{robot}/joint_command"),
            CommandForm::Forward => "forward_position_controller/commands",
            CommandForm::Trajectory => "joint_trajectory_controller/joint_trajectory",
            CommandForm::Xbot => "xbotcore/command",
        };
        if shared {
            format!("/{robot}/{base}")
        } else {
            format!("/{base}")
        }
    }
}

/// `SEC.NANOSEC` of a stamp.
pub fn stamp_text(t: Time) -> String {
    format!("{}.{:09}", t.sec, t.nanosec)
}

/// One command as its message: `names` and `positions` in the order to send, `stamp` the human
/// frame's, `period_s` the time to reach it (the trajectory point's `time_from_start`).
pub enum Command {
    /// A JointState.
    JointState(JointState),
    /// A Float64MultiArray.
    Forward(Float64MultiArray),
    /// A JointTrajectory.
    Trajectory(JointTrajectory),
    /// An XBot2 JointCommand.
    Xbot(XbotJointCommand),
}

impl Command {
    /// Builds the message of `form`.
    pub fn build(
        form: CommandForm,
        names: &[String],
        positions: &[f64],
        stamp: Time,
        period_s: f64,
    ) -> Command {
        match form {
            CommandForm::JointState => Command::JointState(JointState {
                header: Header {
                    stamp,
                    frame_id: String::new(),
                },
                name: names.to_vec(),
                position: positions.to_vec(),
                velocity: Vec::new(),
                effort: Vec::new(),
            }),
            CommandForm::Forward => Command::Forward(Float64MultiArray {
                layout: MultiArrayLayout {
                    dim: vec![MultiArrayDimension {
                        label: format!("joints@{}", stamp_text(stamp)),
                        size: positions.len() as u32,
                        stride: positions.len() as u32,
                    }],
                    data_offset: 0,
                },
                data: positions.to_vec(),
            }),
            CommandForm::Trajectory => {
                let ns = (period_s.max(0.0) * 1e9).round() as i64;
                Command::Trajectory(JointTrajectory {
                    header: Header {
                        stamp: Time::default(),
                        frame_id: format!("stamp:{}", stamp_text(stamp)),
                    },
                    joint_names: names.to_vec(),
                    points: vec![JointTrajectoryPoint {
                        positions: positions.to_vec(),
                        velocities: Vec::new(),
                        accelerations: Vec::new(),
                        effort: Vec::new(),
                        time_from_start: Duration {
                            sec: (ns / 1_000_000_000) as i32,
                            nanosec: (ns % 1_000_000_000) as u32,
                        },
                    }],
                })
            }
            CommandForm::Xbot => Command::Xbot(XbotJointCommand {
                header: Header {
                    stamp,
                    frame_id: String::new(),
                },
                name: names.to_vec(),
                stamp_rx_feedback: 0,
                position: positions.iter().map(|&v| v as f32).collect(),
                velocity: Vec::new(),
                effort: Vec::new(),
                stiffness: Vec::new(),
                damping: Vec::new(),
                ctrl_mode: vec![XBOT_CTRL_POSITION; positions.len()],
                aux_name: String::new(),
                aux: Vec::new(),
            }),
        }
    }
}
