//! Whole-arm retargeting one frame at a time ([`FrameRetargeter`]): what `retarget` does to a
//! file's frames ([`super::Match::Arms`], velocity limits off), for a live stream. Every frame
//! is solved from its pose alone (the fixed starts, never the frame before), so a frame gives
//! the posture the same frame gets in a file. The safety of the command sent (velocity limits,
//! self-collision from the command before) is the caller's: the live node's gate keeps it.

use crate::anatomy::Anatomy;
use crate::Robot;

use super::whole_arm::{reference_configuration, ArmPosture, ArmSolver, PostureGauge};
use super::{key_configurations, RetargetError, RetargetOptions};

/// One robot's whole-arm retargeting of single human frames (module docs).
pub struct FrameRetargeter {
    human: Anatomy,
    human_gauge: PostureGauge,
    solver: ArmSolver,
    joint_names: Vec<String>,
    /// The human model's joint count, and the solver's working configuration.
    human_joints: usize,
    q: Vec<f64>,
}

impl FrameRetargeter {
    /// The retargeter onto `anatomy`'s arms with `options`' whole-arm settings (weights,
    /// margin, self-collision in the solve).
    pub fn new(anatomy: &Anatomy, options: &RetargetOptions) -> Result<Self, RetargetError> {
        let human_model = Robot::builtin("human").map_err(|source| RetargetError::Robot {
            body: "human".into(),
            source,
        })?;
        let human_joints = human_model.joint_names().len();
        let human =
            Anatomy::of(human_model).map_err(|e| RetargetError::Invalid(format!("human: {e}")))?;
        let at = reference_configuration(&human);
        let human_gauge = PostureGauge::at(&human, &at);
        let reference = human_gauge.measure(&human, &at);
        let solver = ArmSolver::new(
            anatomy,
            &reference,
            key_configurations(anatomy),
            &options.whole_arm,
        );
        let q = solver.hold().to_vec();
        Ok(FrameRetargeter {
            human,
            human_gauge,
            solver,
            joint_names: anatomy.arm_joint_names(),
            human_joints,
            q,
        })
    }

    /// The robot's arm joints the retargeting gives, in the order [`Self::retarget`] writes.
    pub fn joint_names(&self) -> &[String] {
        &self.joint_names
    }

    /// The robot's arm joints for one frame of the human model's joint angles (its 18, in the
    /// human model's order), into `out` (one value per [`Self::joint_names`]).
    pub fn retarget(&mut self, human: &[f64], out: &mut [f64]) -> Result<(), RetargetError> {
        if human.len() != self.human_joints || out.len() != self.joint_names.len() {
            return Err(RetargetError::Invalid(format!(
                "a frame of {} human joints into {} robot joints; expected {} and {}",
                human.len(),
                out.len(),
                self.human_joints,
                self.joint_names.len()
            )));
        }
        if let Some(k) = human.iter().position(|v| !v.is_finite()) {
            return Err(RetargetError::Invalid(format!(
                "the human frame's joint {k} is {}: expected a finite angle",
                human[k]
            )));
        }
        let target: [ArmPosture; 2] = self.human_gauge.measure(&self.human, human);
        self.solver.solve(&target, &mut self.q);
        for (o, &i) in out.iter_mut().zip(self.solver.arm_indices()) {
            *o = self.q[i];
        }
        Ok(())
    }
}
