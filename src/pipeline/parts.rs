//! A latent space per arm from demonstrations: which columns of each body are its left and
//! its right arm, and the per-part model ([`PartsGplvm`]) trained and transferred on a
//! demonstration file's frames as the single latent space is ([`super::training`]).
//!
//! The core takes explicit column groups; here they are derived from what the facade knows of
//! a body: a robot's anatomy (its arms' joint chains: the built-in robots, or a URDF with the
//! description file beside it), else its joint names — the human model's `jLeft…`/`jRight…`, and
//! the usual conventions `L…`/`R…` before a capital letter (WALK-MAN, COMAN), `left_…`/`right_…`,
//! `l_…`/`r_…`, and CENTAURO's `j_arm1_…` (left) / `j_arm2_…` (right).

use std::collections::BTreeMap;
use std::path::Path;

use sgplvm_core::{PartSpec, PartsCallback, PartsConfig, PartsGplvm, TrainOptions};
use sgplvm_robots::anatomy::Anatomy;
use sgplvm_robots::dataset::BodyData;
use sgplvm_robots::retarget::file::{retargeted_arms, RetargetedArms};
use sgplvm_robots::Side;

use super::{to_mat, Demonstrations, FrameSet, PipelineError};

/// The names of the two parts of [`Parts::Arms`], left then right.
pub const ARM_PARTS: [&str; 2] = ["left_arm", "right_arm"];

/// How the bodies are divided into parts (`--parts`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Parts {
    /// A latent space per arm: [`ARM_PARTS`].
    Arms,
}

impl Parts {
    /// Every choice, by the name users type.
    pub const ALL: [Parts; 1] = [Parts::Arms];

    /// The name users type: `arms`.
    pub fn name(self) -> &'static str {
        match self {
            Parts::Arms => "arms",
        }
    }
}

impl std::str::FromStr for Parts {
    type Err = String;

    /// `arms`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Parts::ALL
            .into_iter()
            .find(|p| p.name() == s)
            .ok_or_else(|| format!("unknown body parts '{s}'; expected one of: arms"))
    }
}

/// The side a joint's name says it is on, by the conventions in the module docs.
fn side_by_name(joint: &str) -> Option<Side> {
    let lower = joint.to_ascii_lowercase();
    let starts = |p: &str| lower.starts_with(p);
    if starts("jleft") || starts("left_") || starts("left") || starts("l_") || starts("j_arm1_") {
        return Some(Side::Left);
    }
    if starts("jright") || starts("right_") || starts("right") || starts("r_") || starts("j_arm2_")
    {
        return Some(Side::Right);
    }
    let mut chars = joint.chars();
    match (chars.next(), chars.next()) {
        (Some('L'), Some(c)) if c.is_ascii_uppercase() => Some(Side::Left),
        (Some('R'), Some(c)) if c.is_ascii_uppercase() => Some(Side::Right),
        // Any side word, as the anatomy reads names (`arm_left_1_joint`, `J_arm_l_01`).
        _ => sgplvm_robots::anatomy::words::side_of(joint),
    }
}

/// The columns of body `body` (joint names `joints`) in its left and its right arm: by the
/// arms of `anatomy` when given, else by the joints' names. A column in neither arm, or an arm
/// without columns, is [`PipelineError::Parts`] naming it — except the arm a one-armed
/// anatomy does not have, whose columns are empty.
pub fn arm_columns(
    body: &str,
    joints: &[String],
    anatomy: Option<&Anatomy>,
) -> Result<[Vec<usize>; 2], PipelineError> {
    let sides = anatomy.map_or_else(|| vec![Side::Left, Side::Right], Anatomy::sides);
    arms_of(body, joints, anatomy, &sides)
}

/// [`arm_columns`] where only the arms `sides` hold columns: a side not among them has none
/// (a column of its arm is an error), each of them at least one.
fn arms_of(
    body: &str,
    joints: &[String],
    anatomy: Option<&Anatomy>,
    sides: &[Side],
) -> Result<[Vec<usize>; 2], PipelineError> {
    match anatomy {
        Some(a) => arms_by(body, joints, sides, ArmsFrom::Anatomy, |joint| {
            [Side::Left, Side::Right].into_iter().find(|&s| {
                a.arm(s)
                    .is_some_and(|arm| arm.chain.joint_names().iter().any(|n| n == joint))
            })
        }),
        None => arms_by(body, joints, sides, ArmsFrom::Names, side_by_name),
    }
}

/// What says which arm a column moves, for the error that names a column in neither.
#[derive(Clone, Copy)]
enum ArmsFrom {
    /// The robot's anatomy (built in, or its URDF).
    Anatomy,
    /// The arms' joints as `retarget` recorded them in the file.
    Retarget,
    /// The joint's name.
    Names,
}

/// The columns of `body` (joint names `joints`) in each arm, each joint's side by `side_of`
/// (read from `from`); only the arms `sides` hold columns, each at least one.
fn arms_by(
    body: &str,
    joints: &[String],
    sides: &[Side],
    from: ArmsFrom,
    side_of: impl Fn(&str) -> Option<Side>,
) -> Result<[Vec<usize>; 2], PipelineError> {
    let bad = |detail: String| PipelineError::Parts {
        body: body.to_string(),
        detail,
    };
    let mut arms = [Vec::new(), Vec::new()];
    for (c, joint) in joints.iter().enumerate() {
        let Some(side) = side_of(joint) else {
            let how = match from {
                ArmsFrom::Anatomy => "is in neither arm of its anatomy",
                ArmsFrom::Retarget => "is in neither arm retarget drove",
                ArmsFrom::Names => "does not say which arm it moves (a side word: left/l/right/r, jLeft…/jRight…, L…/R…)",
            };
            return Err(bad(format!(
                "joint '{joint}' (column {c}) {how}; a latent space per arm needs every column \
                 in one arm (give the robot's URDF, or the parts' columns in Python)"
            )));
        };
        if !sides.contains(&side) {
            return Err(bad(format!(
                "joint '{joint}' (column {c}) moves its {} arm, which retarget did not drive",
                side.as_str()
            )));
        }
        arms[side.index()].push(c);
    }
    if let Some(side) = sides.iter().find(|s| arms[s.index()].is_empty()) {
        return Err(bad(format!(
            "no joint of its {} arm among {joints:?}",
            side.as_str()
        )));
    }
    Ok(arms)
}

impl Demonstrations {
    /// The data of the experiment's study of a latent space per arm
    /// ([`crate::experiment::PartsData`]): the arms' columns of the human and every robot (as
    /// [`Demonstrations::arm_parts`] finds them, built-in anatomies or names), and the test and
    /// training frames whose arms are recombined ([`crate::experiment::pairs`] over the
    /// dataset's segments: the blocks of a block split, the motions of generated data).
    pub fn parts_data(&self) -> Result<crate::experiment::PartsData, PipelineError> {
        self.check_splits()?;
        let ds = &self.dataset;
        let human_arms = arm_columns(&ds.human.name, &ds.human.joint_names, None)?;
        let robot_arms = ds
            .robots
            .iter()
            .map(|body| self.robot_arms(body, None))
            .collect::<Result<Vec<_>, _>>()?;
        if let Some((body, _)) = ds
            .robots
            .iter()
            .zip(&robot_arms)
            .find(|(_, arms)| arms.iter().any(Vec::is_empty))
        {
            return Err(PipelineError::Parts {
                body: body.name.clone(),
                detail: "it has one arm; the study recombines two arms' motions".into(),
            });
        }
        let blocks: Vec<(usize, usize)> = ds.segments.iter().map(|s| (s.start, s.end)).collect();
        let test_pairs = crate::experiment::pairs(&ds.test, &blocks);
        let train_pairs = crate::experiment::pairs(&ds.train, &blocks);
        for (set, pairs) in [("test", &test_pairs), ("training", &train_pairs)] {
            if pairs.is_empty() {
                return Err(PipelineError::Parts {
                    body: self.source_name.clone(),
                    detail: format!(
                        "a segment holds more than half of its {set} frames: no pairing of \
                         every frame with a frame of another motion to recombine"
                    ),
                });
            }
        }
        Ok(crate::experiment::PartsData {
            human_arms,
            robot_arms,
            test_pairs,
            train_pairs,
        })
    }
}

/// The anatomy the facade knows for robot `name`: its URDF's (`urdf`) when given, else the
/// built-in robot's; `None` for the human and robots it does not know (their names decide).
pub fn known_anatomy(name: &str, urdf: Option<&Path>) -> Result<Option<Anatomy>, PipelineError> {
    let parts = |e: sgplvm_robots::AnatomyError| PipelineError::Parts {
        body: name.to_string(),
        detail: format!("its anatomy: {e}"),
    };
    match urdf {
        Some(path) => Anatomy::load(path, &Default::default())
            .map(Some)
            .map_err(parts),
        None => Ok(sgplvm_robots::Robot::builtin(name)
            .ok()
            .and_then(|robot| Anatomy::of(robot).ok())),
    }
}

impl Demonstrations {
    /// The arm parts ([`ARM_PARTS`]) of the human and `robots`: each body's columns by
    /// [`arm_columns`], robots by their anatomy (`urdfs`: robot name → URDF, else built in)
    /// when known. Robots with one arm (all on the same side) make one part, the person's
    /// other arm no input; robots trained together with different arms are an error.
    pub fn arm_parts(
        &self,
        robots: &[String],
        urdfs: &BTreeMap<String, std::path::PathBuf>,
    ) -> Result<Vec<PartSpec>, PipelineError> {
        let human = &self.dataset.human;
        let mut sides: [Vec<(String, Vec<usize>)>; 2] = [Vec::new(), Vec::new()];
        let [l, r] = arm_columns(&human.name, &human.joint_names, None)?;
        sides[0].push((human.name.clone(), l));
        sides[1].push((human.name.clone(), r));
        for name in robots {
            let body = self.robot(name)?;
            let [l, r] = self.robot_arms(body, urdfs.get(name).map(|p| p.as_path()))?;
            sides[0].push((name.clone(), l));
            sides[1].push((name.clone(), r));
        }
        let mut parts = Vec::new();
        for (part, columns) in ARM_PARTS.iter().zip(sides) {
            let robots = &columns[1..];
            let (with, without): (Vec<_>, Vec<_>) = robots.iter().partition(|(_, c)| !c.is_empty());
            match (with.first(), without.first()) {
                (Some((has, _)), Some((lacks, _))) => {
                    return Err(PipelineError::Parts {
                        body: lacks.clone(),
                        detail: format!(
                            "it has no {} while '{has}' has; robots trained together need the \
                             same arms",
                            part.replace('_', " ")
                        ),
                    })
                }
                (Some(_), None) => parts.push(PartSpec::new(*part, columns)),
                // No robot has this arm: the person's arm is no input.
                _ => {}
            }
        }
        Ok(parts)
    }

    /// The arms `retarget` drove on robot `name` (which of the person's arms, and each arm's
    /// joints), where `retarget` wrote the file the demonstrations came from and said so
    /// ([`sgplvm_robots::retarget::file::retargeted_arms`]).
    pub(crate) fn retargeted_arms(
        &self,
        name: &str,
    ) -> Result<Option<RetargetedArms>, PipelineError> {
        let path = Path::new(&self.source_name);
        if !path.is_file() {
            return Ok(None);
        }
        let mut arms = retargeted_arms(path).map_err(|e| PipelineError::Parts {
            body: name.to_string(),
            detail: e.to_string(),
        })?;
        Ok(arms.remove(name))
    }

    /// Robot `body`'s arm columns: by the anatomy of its URDF (`urdf`) when given, else by the
    /// arms' joints `retarget` recorded in the file, else by its built-in anatomy, else by its
    /// names. Where the file says which of the person's arms drove the robot
    /// ([`Demonstrations::retargeted_arms`]), the columns follow it: a one-armed robot's arm is
    /// on that side, and of a two-armed anatomy only the arms driven hold columns.
    fn robot_arms(
        &self,
        body: &BodyData,
        urdf: Option<&Path>,
    ) -> Result<[Vec<usize>; 2], PipelineError> {
        let recorded = self.retargeted_arms(&body.name)?;
        if let Some(arms) = recorded
            .as_ref()
            .filter(|r| urdf.is_none() && r.joints.iter().any(|j| !j.is_empty()))
        {
            return arms_by(
                &body.name,
                &body.joint_names,
                &arms.sides,
                ArmsFrom::Retarget,
                |joint| {
                    [Side::Left, Side::Right]
                        .into_iter()
                        .find(|s| arms.joints[s.index()].iter().any(|n| n == joint))
                },
            );
        }
        let anatomy = known_anatomy(&body.name, urdf)?;
        let Some(anatomy) = &anatomy else {
            return arm_columns(&body.name, &body.joint_names, None);
        };
        let Some(driven) = recorded.map(|r| r.sides) else {
            return arm_columns(&body.name, &body.joint_names, Some(anatomy));
        };
        let found = anatomy.sides();
        match (found.as_slice(), driven.as_slice()) {
            ([a], [d]) if a != d => {
                let mut arms = arm_columns(&body.name, &body.joint_names, Some(anatomy))?;
                arms.swap(a.index(), d.index());
                Ok(arms)
            }
            (a, d) if d.iter().all(|s| a.contains(s)) => {
                arms_of(&body.name, &body.joint_names, Some(anatomy), d)
            }
            (a, d) => {
                let names = |s: &[Side]| s.iter().map(|s| s.as_str()).collect::<Vec<_>>();
                Err(PipelineError::Parts {
                    body: body.name.clone(),
                    detail: format!(
                        "{}: retarget drove its arms {:?}, its anatomy here has {:?}; give it the \
                         arms retarget had (`sgplvm robot URDF --arm SIDE=FROM:TO --write`)",
                        self.source_name,
                        names(d),
                        names(a)
                    ),
                })
            }
        }
    }

    /// Trains a latent space per part of `parts` on the human and `robots` (every part with
    /// `config`, on the frames [`FrameSet::for_config`] says; budgets chosen on held-out frames
    /// with `patience`, as [`Demonstrations::train`]), and the parent above them
    /// (`parent_latent_dim`; `None`: none). Joint names and trust groups are stored.
    pub fn train_parts(
        &self,
        robots: &[String],
        config: &PartsConfig,
        options: &TrainOptions,
        patience: Option<usize>,
        callback: Option<PartsCallback<'_>>,
    ) -> Result<PartsGplvm, PipelineError> {
        let frames = FrameSet::for_config(&config.model);
        let training = self.training_spaces(robots, frames)?;
        let validation = patience.map(|p| self.validation_of(frames, p));
        let mut model = PartsGplvm::fit(
            config,
            &training.views(),
            training.input(),
            options,
            validation.as_ref(),
            callback,
        )?;
        for (name, joints, _) in &training.bodies {
            model.set_column_names(name, joints.clone())?;
        }
        model.set_trust_groups(&training.groups)?;
        if let Some(bounds) = &training.pose_bounds {
            model.set_pose_bounds(bounds)?;
        }
        Ok(model)
    }

    /// Transfers a per-part `model` to `robot` on the frames it was trained on: the robot's
    /// arm columns found as [`Demonstrations::arm_parts`] does (`urdf`: its URDF, else built
    /// in or by names), each part learning only the robot's kernel
    /// ([`PartsGplvm::transfer`]).
    pub fn transfer_parts(
        &self,
        model: &PartsGplvm,
        robot: &str,
        urdf: Option<&Path>,
        options: &TrainOptions,
        patience: Option<usize>,
        callback: Option<PartsCallback<'_>>,
    ) -> Result<PartsGplvm, PipelineError> {
        self.check_training()?;
        self.check_joints(model, model.input_name(), &self.dataset.human.joint_names)?;
        let body = self.robot(robot)?;
        let frames = self.frames_for(model.num_points(), model.config())?;
        let ds = self.training_set(frames);
        let columns = self.robot_arms(body, urdf)?;
        let names = model.part_names();
        if names.iter().any(|p| !ARM_PARTS.contains(p)) {
            return Err(PipelineError::Parts {
                body: robot.to_string(),
                detail: format!(
                    "the model's parts are {names:?}; transfer here divides a robot into \
                     {ARM_PARTS:?}"
                ),
            });
        }
        let mut parts = BTreeMap::new();
        for (part, columns) in ARM_PARTS.iter().zip(columns) {
            let arm = part.replace('_', " ");
            match (names.contains(part), columns.is_empty()) {
                (true, false) => {
                    parts.insert(part.to_string(), columns);
                }
                (true, true) => {
                    return Err(PipelineError::Parts {
                        body: robot.to_string(),
                        detail: format!("it has no {arm}, which the model has a latent space for"),
                    })
                }
                (false, false) => {
                    return Err(PipelineError::Parts {
                        body: robot.to_string(),
                        detail: format!(
                            "its {arm} has no latent space in the model (a one-armed robot's)"
                        ),
                    })
                }
                (false, true) => {}
            }
        }
        let data = to_mat(&body.rows(&ds.train));
        let validation = patience.map(|p| self.validation_of(frames, p));
        let mut transferred = model.transfer(
            robot,
            data.as_ref(),
            &parts,
            options,
            validation.as_ref(),
            callback,
        )?;
        transferred.set_column_names(robot, body.joint_names.clone())?;
        Ok(transferred)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn names(list: &[&str]) -> Vec<String> {
        list.iter().map(|s| s.to_string()).collect()
    }

    #[test]
    fn arms_by_names_and_by_anatomy() {
        let human: Vec<String> = sgplvm_robots::Robot::builtin("human")
            .map(|r| r.joint_names().to_vec())
            .unwrap_or_else(|_| names(&["jLeftA", "jLeftB", "jRightA", "jRightB"]));
        let [l, r] = arm_columns("human", &human, None).unwrap();
        assert_eq!(l.len(), r.len());
        assert!(l.iter().all(|&c| human[c].starts_with("jLeft")));
        for robot in ["walkman", "coman", "centauro", "ur5e"] {
            let anatomy = known_anatomy(robot, None).unwrap().expect("built in");
            let joints = anatomy.arm_joint_names();
            let by_anatomy = arm_columns(robot, &joints, Some(&anatomy)).unwrap();
            let by_name = arm_columns(robot, &joints, None).unwrap();
            assert_eq!(by_anatomy, by_name, "{robot}");
            let half = joints.len() / 2;
            assert_eq!(by_anatomy[0], (0..half).collect::<Vec<_>>(), "{robot}");
        }
        let e = arm_columns(
            "g1",
            &names(&["left_elbow", "waist_yaw", "right_elbow"]),
            None,
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("'waist_yaw' (column 1)") && e.contains("g1"),
            "{e}"
        );
        // Side words anywhere in the name, as the anatomy reads them (Berkeley Humanoid Lite,
        // OpenLoong's AzureLoong).
        let [l, r] = arm_columns(
            "x",
            &names(&[
                "arm_left_shoulder_pitch_joint",
                "J_arm_l_01",
                "arm_right_elbow_pitch_joint",
                "J_arm_r_04",
            ]),
            None,
        )
        .unwrap();
        assert_eq!((l, r), (vec![0, 1], vec![2, 3]));
        let e = arm_columns("x", &names(&["LShSag", "LElbj"]), None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("no joint of its right arm"), "{e}");
        assert_eq!("arms".parse::<Parts>(), Ok(Parts::Arms));
        assert!("legs"
            .parse::<Parts>()
            .unwrap_err()
            .contains("expected one of: arms"));
    }
}
