//! `sgplvm retarget`: robot joint commands for recorded human motion, by inverse kinematics of
//! the hands (optionally elbows or hand orientations), and the train/test split: demonstrations
//! that `train`, `transfer` and `experiment` read like the generated ones.

use std::path::PathBuf;

use anyhow::{bail, Result};
use clap::{Args, ValueEnum};
use sgplvm::robots::anatomy::Anatomy;
use sgplvm::robots::limits::command_velocity_limits;
use sgplvm::robots::names::count;
use sgplvm::robots::retarget::file::{retarget_files, FilesRetargeted, TestChoice};
use sgplvm::robots::retarget::split::{SplitOptions, MIN_TRAIN_FRAMES};
use sgplvm::robots::retarget::whole_arm::{Weights, WholeArmOptions, JUMP_RAD, STILL_RAD};
use sgplvm::robots::retarget::{Match, ReachReport, Redundancy, RetargetOptions};
use sgplvm::robots::Robot;

use super::args::JsonArg;
use super::body::BodyArgs;

#[derive(Args)]
pub struct RetargetArgs {
    /// Human demonstrations (MCAP, e.g. from `sgplvm import`); several are joined, one file
    /// after another (each stays a file for `--split files`).
    #[arg(long, required = true)]
    demos: Vec<PathBuf>,
    /// Built-in robots, comma-separated (walkman, coman, centauro, ur5e).
    #[arg(long, value_delimiter = ',')]
    robots: Vec<String>,
    /// A robot of your own, its URDF as its maker publishes it (the arms found by its names or
    /// structure, or named with --arm or in ROBOT.anatomy.json beside it: `sgplvm robot
    /// FILE.urdf` shows what is found); repeat for several. Named by --robot in the same order,
    /// else by the URDF's robot name.
    #[arg(long)]
    urdf: Vec<PathBuf>,
    /// Names of the --urdf robots, in their order.
    #[arg(long)]
    robot: Vec<String>,
    /// Output demonstrations (MCAP: the human, each robot's /NAME/joint_command, blocks as
    /// segments and the split as metadata).
    #[arg(long)]
    out: PathBuf,
    /// What the robot matches: arms (the person's arm posture: upper arm and forearm
    /// directions and the hand, weighed, out of self-collision, a function of the pose),
    /// hands (positions only, each frame continuing the last), hands+elbows (the elbow follows
    /// the person's as far as the hand allows), poses (hand orientation too).
    #[arg(long = "match", value_parser = parse_match, default_value = "arms")]
    mode: Match,
    /// With --match arms: the tasks' weights, comma-separated NAME=VALUE of upper (the upper
    /// arm's direction), forearm, hand (its position, as a fraction of the reach), orientation
    /// (the hand's turn; 0: free), twist (the upper arm's turn, its twist where the elbow is
    /// straight; 0: free) and posture (the pull towards the neutral posture).
    #[arg(long, value_parser = parse_weights, default_value = "upper=1,forearm=1,hand=0.5,orientation=1,twist=1,posture=0.01")]
    weights: Weights,
    /// With --match arms: how far apart the robot's own collision shapes stay, metres (0
    /// turns the self-collision limit off).
    #[arg(long, default_value_t = 0.01)]
    margin: f64,
    /// How each arm's redundancy (7 joints for 3 hand coordinates) is resolved: `continuous`
    /// (each frame continues the last: the hands follow closely, but one hand position may come
    /// with several postures, depending on the path) or `canonical` (the IK solution from the
    /// neutral posture, a function of the hand targets alone, as the generator's key postures:
    /// a more consistent mapping to learn, but the arm lags wherever that solution moves faster
    /// than the velocity limits, and it runs about 1.4× slower).
    #[arg(long, value_enum, default_value = "continuous")]
    redundancy: RedundancyArg,
    /// Keep each joint within its URDF velocity limit of the command before (then, where the
    /// limits hold a frame back, its posture depends on the frames before it: not a function of
    /// the pose). By default every frame's posture is the pose's own; `predict`, `simulate` and
    /// `teleop` keep the limits on what is sent.
    #[arg(long, conflicts_with = "no_velocity_limits")]
    velocity_limits: bool,
    /// The default since velocity limits became opt-in (--velocity-limits); accepted as before.
    #[arg(long, hide = true)]
    no_velocity_limits: bool,
    /// How to choose test motions: `blocks` (every --test-every-th block of --block-seconds;
    /// a capture too short for one test block trains on every frame, with a warning), `files`
    /// (the --test-files, whole), `people` (every file of the --test-people, whole: strangers
    /// to the model) or `none` (every frame for training, no test frames).
    #[arg(long, value_enum, default_value = "blocks")]
    split: SplitArg,
    /// With --split files: the test files, by name (file stem) or 0-based index.
    #[arg(long, value_delimiter = ',')]
    test_files: Vec<String>,
    /// With --split people: the test people, by the names `sgplvm import --person` gave them.
    #[arg(long, value_delimiter = ',')]
    test_people: Vec<String>,
    /// Length of a block, seconds (blocks are the segments of the output).
    #[arg(long, default_value_t = 4.0)]
    block_seconds: f64,
    /// With --split blocks: one block in this many is a test block.
    #[arg(long, default_value_t = 4)]
    test_every: usize,
    /// Frames this close (seconds) to a boundary between training and test blocks are in
    /// neither set.
    #[arg(long, default_value_t = 0.5)]
    guard_seconds: f64,
    /// Keep every k-th training frame (neighbouring 40 Hz frames are nearly the same pose)
    /// [default: 12, less for a short capture so that at least 200 training frames remain].
    #[arg(long)]
    train_subsample: Option<usize>,
    /// Keep every k-th test frame.
    #[arg(long, default_value_t = 3)]
    test_subsample: usize,
    #[command(flatten)]
    body: BodyArgs,
    #[command(flatten)]
    json: JsonArg,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum RedundancyArg {
    /// Continuing the previous frame.
    Continuous,
    /// The IK solution from the neutral posture.
    Canonical,
}

#[derive(Clone, Copy, PartialEq, Eq, ValueEnum)]
enum SplitArg {
    /// Every --test-every-th block of time is a test block.
    Blocks,
    /// The files named by --test-files are test files.
    Files,
    /// Every file of the --test-people (as `sgplvm import --person` named them) is a test
    /// file: test people are never in training.
    People,
    /// No test frames: every frame is for training (a short capture).
    None,
}

fn parse_weights(s: &str) -> Result<Weights, String> {
    let mut w = Weights::default();
    for part in s.split(',').filter(|p| !p.trim().is_empty()) {
        let (name, value) = part
            .split_once('=')
            .ok_or_else(|| format!("`{part}`: expected NAME=VALUE"))?;
        let v: f64 = value
            .trim()
            .parse()
            .ok()
            .filter(|v: &f64| v.is_finite() && *v >= 0.0)
            .ok_or_else(|| format!("`{part}`: expected a weight ≥ 0"))?;
        match name.trim() {
            "upper" => w.upper_arm = v,
            "forearm" => w.forearm = v,
            "hand" => w.hand = v,
            "orientation" => w.orientation = v,
            "twist" => w.twist = v,
            "posture" => w.posture = v,
            other => {
                return Err(format!(
                    "`{other}`: expected upper, forearm, hand, orientation, twist or posture"
                ))
            }
        }
    }
    Ok(w)
}

fn parse_match(s: &str) -> Result<Match, String> {
    Match::parse(s)
        .ok_or_else(|| format!("unknown `{s}`; expected arms, hands, hands+elbows or poses"))
}

pub fn run(args: RetargetArgs) -> Result<()> {
    // The robots, checked before the work starts.
    let mut robots: Vec<(String, Anatomy)> = Vec::new();
    for name in &args.robots {
        if name == "human" {
            bail!("--robots: `human` is the demonstrator, not a robot");
        }
        robots.push((
            name.clone(),
            args.body
                .load(name, None, "give its URDF with --urdf FILE")?,
        ));
    }
    if args.robot.len() > args.urdf.len() {
        bail!(
            "{} --robot names for {} --urdf files; name each URDF robot once, in order",
            args.robot.len(),
            args.urdf.len()
        );
    }
    for (k, path) in args.urdf.iter().enumerate() {
        let name = match args.robot.get(k) {
            Some(n) => n.clone(),
            None => topic_safe(Robot::from_urdf_file(path)?.name()),
        };
        let anatomy = args.body.load(&name, Some(path), "")?;
        for n in anatomy.notes() {
            eprintln!("{name}: note: {n}");
        }
        robots.push((name, anatomy));
    }
    let names: Vec<&str> = robots.iter().map(|(n, _)| n.as_str()).collect();
    args.body.check_robots(&names)?;
    if robots.is_empty() {
        bail!("no robot to retarget to: name built-in ones with --robots or give --urdf FILE");
    }
    for (k, (name, _)) in robots.iter().enumerate() {
        if robots[..k].iter().any(|(n, _)| n == name) {
            bail!("robot `{name}` named twice");
        }
    }
    if args.velocity_limits {
        // As predict says it: a limit the URDF does not state is assumed, and it holds frames.
        for (name, anatomy) in &robots {
            let (_, assumed) = command_velocity_limits(anatomy.robot(), &anatomy.arm_joint_names());
            if let Some(note) = assumed {
                eprintln!("warning: {name}: {note}");
            }
        }
    }
    if args.split != SplitArg::Files && !args.test_files.is_empty() {
        bail!("--test-files goes with --split files");
    }
    if args.split != SplitArg::People && !args.test_people.is_empty() {
        bail!("--test-people goes with --split people");
    }
    if let Some(bvh) = args
        .demos
        .iter()
        .find(|p| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("bvh")))
    {
        bail!(
            "{}: a motion capture (BVH), not demonstrations: import it first (sgplvm import {} --out FILE.mcap), then --demos FILE.mcap",
            bvh.display(),
            bvh.display()
        );
    }
    let options = RetargetOptions {
        mode: args.mode,
        redundancy: match args.redundancy {
            RedundancyArg::Canonical => Redundancy::Canonical,
            RedundancyArg::Continuous => Redundancy::Continuous,
        },
        velocity_limits: args.velocity_limits,
        whole_arm: WholeArmOptions {
            weights: args.weights.clone(),
            margin_m: args.margin.max(0.0),
            self_collision: args.margin > 0.0,
            ..WholeArmOptions::default()
        },
        ..RetargetOptions::default()
    };
    let split = SplitOptions {
        block_s: args.block_seconds,
        guard_s: args.guard_seconds,
        train_subsample: args.train_subsample.unwrap_or(12),
        test_subsample: args.test_subsample,
        // A step asked for is kept; the default one is lowered for a short capture.
        min_train_frames: if args.train_subsample.is_some() {
            0
        } else {
            MIN_TRAIN_FRAMES
        },
        ..SplitOptions::default()
    };
    let test = match args.split {
        SplitArg::Blocks => TestChoice::EveryNthBlock(args.test_every),
        // `--test-people "a, b"`: names as written, the spaces after the commas aside.
        SplitArg::Files => TestChoice::Files(trimmed(&args.test_files)),
        SplitArg::People => TestChoice::People(trimmed(&args.test_people)),
        SplitArg::None => TestChoice::AllTraining,
    };
    let done = retarget_files(&args.demos, &robots, &options, &split, &test, &args.out)?;
    if let Some(why) = &done.split.fallback {
        eprintln!("warning: {why}");
    }
    if let Some(note) = mixed_rates(&args.demos, &done.rates_hz) {
        eprintln!("warning: {note}");
    }
    if args.json.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "split": done.split,
                "test_files": done.test_files,
                "train_people": done.train_people,
                "test_people": done.test_people,
                "reach": done.reach,
                "seconds": done.seconds
            }))?
        );
    } else {
        print_reports(&done, &args);
    }
    Ok(())
}

/// A URDF's robot name as the name of its topics (`/NAME/joint_command`): every character a
/// ROS 2 name may not hold (`berkeley-humanoid-lite`'s hyphens) an underscore, said on stderr.
fn topic_safe(urdf_name: &str) -> String {
    let mut safe: String = urdf_name
        .chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' {
                c
            } else {
                '_'
            }
        })
        .collect();
    if safe.is_empty() {
        safe = "robot".into();
    } else if safe.starts_with(|c: char| c.is_ascii_digit()) {
        safe.insert_str(0, "robot_");
    }
    if safe != urdf_name {
        eprintln!(
            "{safe}: note: named `{safe}`: the URDF's robot name `{urdf_name}` is no ROS 2 topic name (--robot NAME to choose another)"
        );
    }
    safe
}

fn print_reports(done: &FilesRetargeted, args: &RetargetArgs) {
    let (reports, frames, seconds) = (&done.reach, done.frames, done.seconds);
    println!(
        "retargeted {frames} frames to {} robot(s) in {seconds:.1} s ({:.0} frames/s per robot); match: {}",
        reports.len(),
        frames as f64 * reports.len() as f64 / seconds.max(1e-9),
        args.mode.name()
    );
    if args.mode == Match::Arms {
        print_postures(reports, args.velocity_limits);
    } else {
        print_hands(reports);
    }
    println!("split: {}", split_line(done, args));
    println!("wrote {}", args.out.display());
}

/// What the split did, in the terms it was asked in: which blocks or files are for testing,
/// and the frames kept.
fn split_line(done: &FilesRetargeted, args: &RetargetArgs) -> String {
    let s = &done.split;
    let chosen = match args.split {
        _ if s.fallback.is_some() => format!(
            "none: every frame for training ({} of {} s, too few for one in {} to test)",
            count(s.blocks, "block"),
            args.block_seconds,
            args.test_every
        ),
        SplitArg::None => "none: every frame for training".to_string(),
        SplitArg::Files => format!(
            "files kept whole for testing: {} ({} of {}; {} of the {} of {} s)",
            done.test_files.join(", "),
            done.test_files.len(),
            count(done.files.len(), "file"),
            s.test_blocks,
            count(s.blocks, "block"),
            args.block_seconds
        ),
        SplitArg::People => format!(
            "people kept whole for testing: {} ({} files of {}); training people: {}",
            done.test_people.join(", "),
            done.test_files.len(),
            count(done.files.len(), "file"),
            done.train_people.join(", ")
        ),
        SplitArg::Blocks => format!(
            "one block of {} s in {} for testing: {} of {}",
            args.block_seconds,
            args.test_every,
            s.test_blocks,
            count(s.blocks, "block")
        ),
    };
    let step = if args.train_subsample.is_none() && s.train_step < 12 {
        format!(
            "1 in {}: a short capture keeps at least {MIN_TRAIN_FRAMES} where it has them",
            s.train_step
        )
    } else {
        format!("1 in {}", s.train_step)
    };
    if s.test_frames == 0 {
        return format!(
            "{chosen}; {} training frames kept ({step}), no test frames",
            s.train_frames
        );
    }
    format!(
        "{chosen}; {} training and {} test frames kept ({step}; 1 in {}), {} left out \
         beside the train/test boundaries",
        s.train_frames,
        s.test_frames,
        args.test_subsample,
        count(s.guard_frames, "guard frame")
    )
}

/// Per robot, how the hands followed (the hand-matching modes).
fn print_hands(reports: &[ReachReport]) {
    let mm = |m: f64| m * 1000.0;
    let w = name_width(reports);
    println!("{:<w$} reached (of targets): median    worst | unreachable (worst miss) | velocity-limited (worst) | other configuration (worst)", "robot");
    for r in reports {
        let reached = match (r.median_m, r.worst_m) {
            (Some(m), Some(w)) => format!("{:>9.3} mm {:>6.2} mm", mm(m), mm(w)),
            _ => format!("{:>22}", "none reached"),
        };
        println!(
            "{:<w$} {:>6} of {:<6} {reached} | {:>5} ({:>5.1} mm) | {:>6} ({:>6.1} mm)  | {:>6} ({:>6.1} mm){}",
            r.robot,
            r.reached,
            r.targets,
            r.unreachable,
            mm(r.unreachable_worst_m),
            r.velocity_limited,
            mm(r.velocity_limited_worst_m),
            r.other_configuration,
            mm(r.other_configuration_worst_m),
            match (r.elbow_median_m, r.orientation_median_rad) {
                (Some(e), _) => format!("  elbow {:.1} mm median", mm(e)),
                (_, Some(o)) => format!("  orientation {:.1}° median", o.to_degrees()),
                _ => String::new(),
            }
        );
    }
}

/// The width of the tables' robot column: the longest name, at least 12 (a URDF's name, as
/// `galbot_one_charlie`, is often longer).
fn name_width(reports: &[ReachReport]) -> usize {
    reports
        .iter()
        .map(|r| r.robot.chars().count())
        .max()
        .unwrap_or(0)
        .max(12)
}

/// The first `n` of `items` and how many more, separated by `; `.
fn first_few(items: &[String], n: usize) -> String {
    let shown = items[..items.len().min(n)].join("; ");
    match items.len().saturating_sub(n) {
        0 => shown,
        more => format!("{shown}; and {more} more (--json lists every one)"),
    }
}

/// Per robot, how the arm postures followed and how near the robot came to itself
/// (`--match arms`), and which limits held the commands (`velocity_limits`: whether the
/// commands written were held within them).
fn print_postures(reports: &[ReachReport], velocity_limits: bool) {
    let w = name_width(reports);
    println!("{:<w$} upper arm (median, 90th) | forearm (median, 90th) | hand, of reach (median, 90th; within 5 %) | frames held by: velocity, self-collision | in collision (closest, margin)", "robot");
    for r in reports {
        let Some(p) = &r.posture else { continue };
        println!(
            "{:<w$} {:>5.1}° {:>5.1}°        | {:>5.1}° {:>5.1}°         | {:>5.1} % {:>5.1} % ({:>5.1} %)                | {:>6} {:>6}                        | {} ({}, {:.0} mm)",
            r.robot,
            p.upper_arm_deg[0],
            p.upper_arm_deg[1],
            p.forearm_deg[0],
            p.forearm_deg[1],
            100.0 * p.hand_of_reach[0],
            100.0 * p.hand_of_reach[1],
            100.0 * p.hands_within_5pct,
            p.velocity_limited_frames,
            p.collision_limited_frames,
            p.colliding_frames,
            match (p.pairs, p.closest_m) {
                (0, _) => "no pair checked".to_string(),
                (_, None) => "no pair near".to_string(),
                (_, Some(d)) => format!("{:.1} mm", 1e3 * d),
            },
            1e3 * p.margin_m,
        );
        if p.frames_seconds > 0.0 {
            println!(
                "{:<12} start {:.1} s (collision model, solver), then {:.0} frames/s: the rate a live stream is followed at",
                r.robot,
                p.start_seconds,
                p.frames as f64 / p.frames_seconds
            );
        }
        if !p.velocity_limited_joints.is_empty() {
            let held: Vec<String> = p
                .velocity_limited_joints
                .iter()
                .map(|h| {
                    let unit = if h.prismatic { "m/s" } else { "rad/s" };
                    format!("{} ({:.2} {unit}) in {}", h.joint, h.limit, h.frames)
                })
                .collect();
            println!(
                "{:<12} frames held by velocity limits, per joint: {}",
                r.robot,
                first_few(&held, 4)
            );
        }
        // Joints on a position limit in at least 5 % of the frames: the robot's range, where the
        // directions' error is large.
        let on_bounds: Vec<String> = p
            .position_limited_joints
            .iter()
            .filter(|b| 20 * b.frames >= p.frames.max(1))
            .map(|b| {
                let which = if b.upper { "upper" } else { "lower" };
                let share = 100.0 * b.frames as f64 / p.frames.max(1) as f64;
                format!(
                    "{} at its {which} limit {:.2} in {share:.0} %",
                    b.joint, b.bound
                )
            })
            .collect();
        if !on_bounds.is_empty() {
            println!(
                "{:<12} commands on a position limit (the robot's range, not the person's) in 5 % of frames or more: {}",
                r.robot,
                first_few(&on_bounds, 4)
            );
        }
        if !p.collision_limited_pairs.is_empty() {
            let held: Vec<String> = p
                .collision_limited_pairs
                .iter()
                .map(|h| {
                    format!(
                        "{} ↔ {} in {} (asked as near as {:.1} mm)",
                        h.link_a,
                        h.link_b,
                        h.frames,
                        1e3 * h.closest_m
                    )
                })
                .collect();
            println!(
                "{:<12} frames held by self-collision, per pair of links: {}",
                r.robot,
                first_few(&held, 4)
            );
        }
        if p.jump_frames > 0 {
            let jumped: Vec<String> = p
                .jumping_joints
                .iter()
                .map(|j| format!("{} in {}", j.joint, j.frames))
                .collect();
            println!(
                "{:<12} posture jumps (the asked posture: a joint turned > {:.0} rad between frames where the person moved < {:.1} rad, the posture changing branch, docs/robots.md{}) in {} frame(s): {}",
                r.robot,
                JUMP_RAD,
                STILL_RAD,
                if velocity_limits {
                    "; the commands written take each within the velocity limits"
                } else {
                    ""
                },
                p.jump_frames,
                first_few(&jumped, 4)
            );
        }
        if p.from_fixed_starts {
            println!(
                "{:<12} solved each frame from fixed starts (following each frame's path from the person's neutral fit the person's key postures worse: this robot's limits stop it short); the posture is a function of the pose but may change branch between near poses",
                r.robot
            );
        }
        if p.stepped_from_before_frames > 0 {
            println!(
                "{:<12} {} frame(s) asked a posture too deep in the robot's own shapes to step out of alone: stepped from the command before (those frames depend on the path)",
                r.robot, p.stepped_from_before_frames
            );
        }
        if let Some(warning) =
            super::report::self_collision_unchecked(&r.robot, &p.unchecked, p.pairs)
        {
            eprintln!("{warning}");
        }
    }
}

/// Files at frame rates more than 1 % apart, said: the training subsample counts frames, so a
/// file imported at a higher rate weighs more in training.
fn mixed_rates(demos: &[PathBuf], rates_hz: &[f64]) -> Option<String> {
    let known: Vec<(&PathBuf, f64)> = demos
        .iter()
        .zip(rates_hz.iter().copied())
        .filter(|(_, r)| r.is_finite())
        .collect();
    let (lo, hi) = known
        .iter()
        .fold((f64::INFINITY, 0.0_f64), |(lo, hi), (_, r)| {
            (lo.min(*r), hi.max(*r))
        });
    (known.len() > 1 && hi > 1.01 * lo).then(|| {
        let each: Vec<String> = known
            .iter()
            .map(|(p, r)| format!("{} {r:.0} Hz", p.display()))
            .collect();
        format!(
            "the captures' frame rates differ ({}): the training frames are kept one in N frames, so a file's share of them follows its rate, not its duration; import them at one --rate",
            each.join(", ")
        )
    })
}

/// Each of `names` without the spaces around it (`--test-people "a, b"`).
fn trimmed(names: &[String]) -> Vec<String> {
    names.iter().map(|n| n.trim().to_string()).collect()
}

#[cfg(test)]
mod tests {
    use super::{mixed_rates, topic_safe, trimmed};
    use std::path::PathBuf;

    #[test]
    fn captures_at_different_rates_are_said_and_names_lose_their_spaces() {
        let files = [PathBuf::from("a.mcap"), PathBuf::from("b.mcap")];
        assert_eq!(mixed_rates(&files, &[40.0, 40.2]), None);
        let said = mixed_rates(&files, &[100.0, 40.0]).unwrap();
        assert!(said.contains("a.mcap 100 Hz, b.mcap 40 Hz"), "{said}");
        assert_eq!(mixed_rates(&files[..1], &[100.0]), None);
        let names = ["jesse".to_string(), " cxk ".to_string()];
        assert_eq!(trimmed(&names), ["jesse", "cxk"]);
    }

    #[test]
    fn a_urdf_name_becomes_a_ros_2_topic_name() {
        assert_eq!(topic_safe("g1_29dof"), "g1_29dof");
        assert_eq!(
            topic_safe("berkeley-humanoid-lite"),
            "berkeley_humanoid_lite"
        );
        assert_eq!(topic_safe("vega-1"), "vega_1");
        assert_eq!(topic_safe("3r arm"), "robot_3r_arm");
        assert_eq!(topic_safe(""), "robot");
    }
}
