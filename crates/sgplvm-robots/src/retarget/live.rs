//! Whole-arm retargeting one frame at a time ([`FrameRetargeter`]): what `retarget` does to a
//! file's frames ([`super::Match::Arms`], velocity limits off), for a live stream. Every frame
//! is solved from its pose alone (its path from the person's neutral, never the frame before), so a frame gives
//! the posture the same frame gets in a file. The safety of the command sent (velocity limits,
//! self-collision from the command before) is the caller's: the live node's gate keeps it.

use crate::anatomy::Anatomy;
use crate::Robot;

use super::whole_arm::{ArmPosture, ArmSolver, PersonGauge};
use super::{key_configurations, RetargetError, RetargetOptions};

/// One robot's whole-arm retargeting of single human frames (module docs).
pub struct FrameRetargeter {
    person: PersonGauge,
    solver: ArmSolver,
    joint_names: Vec<String>,
    /// The solver's working configuration, and the frame's path from the person's neutral.
    q: Vec<f64>,
    path: Vec<[ArmPosture; 2]>,
}

impl FrameRetargeter {
    /// The retargeter onto `anatomy`'s arms with `options`' whole-arm settings (weights,
    /// margin, self-collision in the solve).
    pub fn new(anatomy: &Anatomy, options: &RetargetOptions) -> Result<Self, RetargetError> {
        let human_model = Robot::builtin("human").map_err(|source| RetargetError::Robot {
            body: "human".into(),
            source,
        })?;
        let human =
            Anatomy::of(human_model).map_err(|e| RetargetError::Invalid(format!("human: {e}")))?;
        let person = PersonGauge::new(human);
        let solver = ArmSolver::new(
            anatomy,
            &person,
            &key_configurations(anatomy),
            &options.whole_arm,
        );
        let q = solver.hold().to_vec();
        Ok(FrameRetargeter {
            person,
            solver,
            joint_names: anatomy.arm_joint_names(),
            q,
            path: Vec::new(),
        })
    }

    /// The robot's arm joints the retargeting gives, in the order [`Self::retarget`] writes.
    pub fn joint_names(&self) -> &[String] {
        &self.joint_names
    }

    /// The robot's arm joints for one frame of the human model's joint angles (its 18, in the
    /// human model's order), into `out` (one value per [`Self::joint_names`]).
    pub fn retarget(&mut self, human: &[f64], out: &mut [f64]) -> Result<(), RetargetError> {
        if human.len() != self.person.joints() || out.len() != self.joint_names.len() {
            return Err(RetargetError::Invalid(format!(
                "a frame of {} human joints into {} robot joints; expected {} and {}",
                human.len(),
                out.len(),
                self.person.joints(),
                self.joint_names.len()
            )));
        }
        if let Some(k) = human.iter().position(|v| !v.is_finite()) {
            return Err(RetargetError::Invalid(format!(
                "the human frame's joint {k} is {}: expected a finite angle",
                human[k]
            )));
        }
        self.person.path(human, &mut self.path);
        self.solver.solve(&self.path, &mut self.q);
        for (o, &i) in out.iter_mut().zip(self.solver.arm_indices()) {
            *o = self.q[i];
        }
        Ok(())
    }
}
