//! The commands of the `sgplvm` program, one module each, with the argument groups they share
//! ([`args`]), the progress bars ([`progress`]), the reading of frames and trajectories
//! ([`frames`]) and everything they print as a result ([`report`]).

mod args;
mod body;
mod calibration;
mod demo;
mod evaluate;
mod experiment;
mod export;
mod frames;
mod generate;
mod import;
mod joints;
mod limits;
mod predict;
mod progress;
#[cfg(feature = "live")]
mod replay;
mod report;
mod retarget;
mod robot;
mod simulate;
#[cfg(feature = "live")]
mod teleop;
mod train;
mod transfer;

use anyhow::Result;
use clap::Subcommand;

#[derive(Subcommand)]
pub enum Command {
    /// Train on WALK-MAN, transfer to COMAN and CENTAURO, print test errors; write the models,
    /// Figs. 7 and 8 and the test predictions.
    ///
    /// Into --out: each model (`walkman.sgp`, `walkman_to_coman.sgp`, ...), Fig. 7
    /// (`latent_space.svg`, `.png`: the shared latent space), Fig. 8
    /// (`coman_trajectories.svg`, `.png`: predicted against desired joints on every test
    /// motion) and the test frames as each model predicts them (`walkman_test.mcap`,
    /// `walkman_to_coman_test.mcap`, ...: `predict`'s topics, for Foxglove).
    Demo(demo::DemoArgs),
    /// Generate demonstrations following the paper's protocol (defaults reproduce data/demos).
    Generate(generate::GenerateArgs),
    /// Train a model: one robot gives the full model, several the multi-robot model.
    Train(train::TrainArgs),
    /// Transfer a trained model to another robot (only that robot's kernel is trained).
    Transfer(transfer::TransferArgs),
    /// Predict robot joint commands from human frames (MCAP JointState or CSV; `-` streams CSV).
    Predict(predict::PredictArgs),
    /// Test error of a model on the test frames of a demonstration file, overall and per joint.
    Evaluate(evaluate::EvaluateArgs),
    /// Replay a joint trajectory on a robot in the rapier physics engine (PD control at 1 kHz):
    /// tracking error per joint, joint-limit violations and self-collisions.
    ///
    /// Either `--trajectory FILE` (robot joint commands, MCAP JointState or CSV) on `--robot` or
    /// `--urdf`, or `--model MODEL --input HUMAN_FILE --robot NAME` to predict and then replay.
    Simulate(simulate::SimulateArgs),
    /// The paper's Section IV-B: Figs. 4-6, 9 and 10 (and 11 with --all-frames, 12 with
    /// --bayesian), results.json and report.md.
    ///
    /// Into --out: results.json (every run), report.md (the paper's claims judged), and each
    /// figure as SVG and PNG: fig4 and fig5 (test error against iterations, and against
    /// seconds as fig4_seconds and fig5_seconds: no and input back constraints), fig6 (the
    /// three back constraints), fig9 (less data), fig10 (transfer to each robot from each
    /// other robot), with --all-frames, fig11 (the sparse model on every frame) and, with
    /// --bayesian, fig12 (the Bayesian model's ARD weights per space; its curves join Figs.
    /// 4-6). `--from-results FILE` redraws them from an earlier results.json.
    ///
    /// Runs every training here, one after another. On a Ray cluster the same trainings run
    /// in parallel with identical results: `pip install "sgplvm[ray]"`, then in Python
    /// `sgplvm.ray.run_experiment(config="paper", out=DIR)` (see docs/clusters.md).
    Experiment(experiment::ExperimentArgs),
    /// One body's joint series from a demonstration file as CSV or MCAP (e.g. the human's test
    /// frames, the input of `predict` and `simulate --model`).
    Export(export::ExportArgs),
    /// The joint names of a built-in body (e.g. the human's 18) or of a model, in column order.
    Joints(joints::JointsArgs),
    /// Motion capture in: BVH files become the human's 18 joint angles (MCAP or CSV), with how
    /// faithfully they reproduce the capture.
    Import(import::ImportArgs),
    /// Robot commands for recorded human motion (inverse kinematics of the hands), and the
    /// train/test split: demonstrations for `train`, `transfer` and `experiment`.
    Retarget(retarget::RetargetArgs),
    /// What sgplvm makes of a robot: its arms (found by the URDF's names or structure, or named
    /// with --arm), the joints held, the body frame, each arm's reach and neutral posture; with
    /// --write, the description file beside the URDF that every command reads.
    Robot(robot::RobotArgs),
    /// Live teleoperation: a ROS 2 node (no ROS install) that turns the human's JointState into
    /// each robot's commands, within its limits and its model's trust, with a status topic.
    #[cfg(feature = "live")]
    Teleop(Box<teleop::TeleopArgs>),
    /// Publish recorded human frames on a ROS 2 topic at their own timestamps (for `teleop`).
    #[cfg(feature = "live")]
    Replay(replay::ReplayArgs),
}

impl Command {
    /// Runs the command.
    pub fn run(self) -> Result<()> {
        match self {
            Command::Demo(args) => demo::run(args),
            Command::Generate(args) => generate::run(args),
            Command::Train(args) => train::run(args),
            Command::Transfer(args) => transfer::run(args),
            Command::Predict(args) => predict::run(args),
            Command::Evaluate(args) => evaluate::run(args),
            Command::Simulate(args) => simulate::run(args),
            Command::Experiment(args) => experiment::run(args),
            Command::Export(args) => export::run(args),
            Command::Joints(args) => joints::run(args),
            Command::Import(args) => import::run(args),
            Command::Retarget(args) => retarget::run(args),
            Command::Robot(args) => robot::run(args),
            #[cfg(feature = "live")]
            Command::Teleop(args) => teleop::run(*args),
            #[cfg(feature = "live")]
            Command::Replay(args) => replay::run_replay(args),
        }
    }
}
