use super::*;
use nalgebra::{Matrix3, Matrix4, Rotation3};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::FRAC_PI_2;

const PLANAR: &str = r#"<robot name="planar">
  <link name="base"/><link name="l1"/><link name="l2"/><link name="tip"/>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="j2" type="revolute"><origin xyz="1 0 0"/><parent link="l1"/><child link="l2"/>
    <axis xyz="0 0 1"/><limit lower="-3" upper="3" effort="1" velocity="1"/></joint>
  <joint name="t" type="fixed"><origin xyz="0.5 0 0"/><parent link="l2"/><child link="tip"/></joint>
</robot>"#;

fn planar() -> Chain {
    Robot::from_urdf_str(PLANAR, "planar.urdf")
        .unwrap()
        .chain("base", "tip")
        .unwrap()
}

#[test]
fn planar_two_link_fk_matches_the_formula() {
    let c = planar();
    assert_eq!(c.dof(), 2);
    for &(a, b) in &[(0.0, 0.0), (0.3, -1.1), (2.5, 1.7), (-1.0, 2.9)] {
        let p = c.forward(&[a, b]);
        let want = Vector3::new(
            a.cos() + 0.5 * (a + b).cos(),
            a.sin() + 0.5 * (a + b).sin(),
            0.0,
        );
        assert!((p.translation.vector - want).norm() < 1e-15, "{a} {b}");
        let want_rot = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), a + b);
        assert!(p.rotation.angle_to(&want_rot) < 1e-12);
    }
}

#[test]
fn rpy_origins_and_prismatic_joints_match_hand_computed_poses() {
    let xml = r#"<robot name="r">
      <link name="base"/><link name="a"/><link name="tip"/>
      <joint name="turn" type="fixed"><origin xyz="0 0 1" rpy="0.3 -0.4 1.2"/>
        <parent link="base"/><child link="a"/></joint>
      <joint name="slide" type="prismatic"><origin xyz="0.1 0 0" rpy="0 0 1.5707963267948966"/>
        <parent link="a"/><child link="tip"/><axis xyz="1 0 0"/>
        <limit lower="0" upper="1" effort="1" velocity="1"/></joint>
    </robot>"#;
    let r = Robot::from_urdf_str(xml, "r.urdf").unwrap();
    let (roll, pitch, yaw) = (0.3_f64, -0.4_f64, 1.2_f64);
    let rx = Matrix3::new(
        1.0,
        0.0,
        0.0,
        0.0,
        roll.cos(),
        -roll.sin(),
        0.0,
        roll.sin(),
        roll.cos(),
    );
    let ry = Matrix3::new(
        pitch.cos(),
        0.0,
        pitch.sin(),
        0.0,
        1.0,
        0.0,
        -pitch.sin(),
        0.0,
        pitch.cos(),
    );
    let rz = Matrix3::new(
        yaw.cos(),
        -yaw.sin(),
        0.0,
        yaw.sin(),
        yaw.cos(),
        0.0,
        0.0,
        0.0,
        1.0,
    );
    let ra = rz * ry * rx; // URDF: R = Rz(yaw) Ry(pitch) Rx(roll)
    let d = 0.7;
    let p = r.forward_kinematics(&[d], "tip").unwrap();
    // tip = (0,0,1) + Ra (0.1, 0, 0) + Ra Rz(π/2) (d, 0, 0) = ... + Ra (0.1, d, 0)
    let want = Vector3::new(0.0, 0.0, 1.0) + ra * Vector3::new(0.1, d, 0.0);
    assert!((p.translation.vector - want).norm() < 1e-15);
    let rot = Rotation3::from_matrix_unchecked(
        ra * Rotation3::from_axis_angle(&Vector3::z_axis(), FRAC_PI_2).into_inner(),
    );
    assert!((p.rotation.to_rotation_matrix().into_inner() - rot.into_inner()).norm() < 1e-15);
}

fn fd_check(c: &Chain, q: &[f64]) -> f64 {
    let j = c.jacobian(q);
    let h = 1e-6;
    let mut worst: f64 = 0.0;
    for i in 0..c.dof() {
        let mut qp = q.to_vec();
        let mut qm = q.to_vec();
        qp[i] += h;
        qm[i] -= h;
        let (tp, tm) = (c.forward(&qp), c.forward(&qm));
        let lin = (tp.translation.vector - tm.translation.vector) / (2.0 * h);
        let ang = (tp.rotation * tm.rotation.inverse()).scaled_axis() / (2.0 * h);
        for k in 0..3 {
            worst = worst.max((j[(k, i)] - lin[k]).abs());
            worst = worst.max((j[(3 + k, i)] - ang[k]).abs());
        }
    }
    worst
}

#[test]
fn jacobian_matches_finite_differences() {
    let mut rng = ChaCha8Rng::seed_from_u64(1);
    for name in Robot::builtin_names() {
        let r = Robot::builtin(name).unwrap();
        for arm in r.arms().unwrap() {
            for _ in 0..5 {
                let q: Vec<f64> = arm
                    .chain
                    .limits()
                    .iter()
                    .map(|&(lo, hi)| rng.random_range(lo..=hi))
                    .collect();
                let err = fd_check(&arm.chain, &q);
                assert!(err < 1e-8, "{name}: {err}");
            }
        }
    }
    // Prismatic joints: the Panda's finger.
    let panda = Robot::from_urdf_file(
        &std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/franka_panda.urdf"),
    )
    .unwrap();
    let c = panda.chain("panda_link0", "panda_leftfinger").unwrap();
    assert_eq!(c.dof(), 8);
    let err = fd_check(&c, &[0.1, -0.3, 0.2, -1.5, 0.4, 1.2, -0.5, 0.02]);
    assert!(err < 1e-8, "{err}");
}

#[test]
fn ik_round_trips_reachable_targets_on_every_arm() {
    let mut rng = ChaCha8Rng::seed_from_u64(2);
    let opts = IkOptions::default();
    for name in Robot::builtin_names() {
        let r = Robot::builtin(name).unwrap();
        let neutral = r.neutral_configuration();
        for arm in r.arms().unwrap() {
            let q0 = arm.chain.extract(&neutral).unwrap();
            let mut worst: f64 = 0.0;
            for _ in 0..20 {
                let q: Vec<f64> = arm
                    .chain
                    .limits()
                    .iter()
                    .map(|&(lo, hi)| rng.random_range(lo..=hi))
                    .collect();
                let p = arm.chain.forward(&q).translation.vector;
                let sol = arm
                    .chain
                    .inverse_kinematics(&IkTarget::Position(p), &q0, &opts);
                assert!(sol.converged, "{name} {:?}: {sol:?}", arm.side);
                let back = arm.chain.forward(&sol.q).translation.vector;
                worst = worst.max((back - p).norm());
                for (v, &(lo, hi)) in sol.q.iter().zip(arm.chain.limits()) {
                    assert!(*v >= lo && *v <= hi, "{name}: {v} outside [{lo}, {hi}]");
                }
                assert!((sol.residual - (back - p).norm()).abs() < 1e-15);
            }
            assert!(worst < 1e-6, "{name}: {worst}");
        }
    }
}

#[test]
fn ik_reaches_full_poses() {
    let r = Robot::builtin("centauro").unwrap();
    let [arm, _] = r.arms().unwrap();
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let q0 = arm.chain.extract(&r.neutral_configuration()).unwrap();
    for _ in 0..10 {
        let q: Vec<f64> = arm
            .chain
            .limits()
            .iter()
            .map(|&(lo, hi)| rng.random_range(lo..=hi))
            .collect();
        let t = arm.chain.forward(&q);
        let sol = arm
            .chain
            .inverse_kinematics(&IkTarget::Pose(t), &q0, &IkOptions::default());
        assert!(sol.converged, "{sol:?}");
        let back = arm.chain.forward(&sol.q);
        assert!((back.translation.vector - t.translation.vector).norm() < 1e-6);
        assert!((back.rotation * t.rotation.inverse()).angle() < 1e-6);
    }
}

#[test]
fn unreachable_targets_report_non_convergence_and_the_gap() {
    let c = planar();
    let sol = c.inverse_kinematics(
        &IkTarget::Position(Vector3::new(3.0, 0.0, 0.0)),
        &[0.4, 0.4],
        &IkOptions::default(),
    );
    assert!(!sol.converged);
    // Best is the arm stretched towards the target: 1.5 m reach, 1.5 m short.
    assert!((sol.residual - 1.5).abs() < 1e-6, "{sol:?}");
    assert!(sol.iterations > 0);
    // Out of the plane: the z offset cannot be removed.
    let sol = c.inverse_kinematics(
        &IkTarget::Position(Vector3::new(1.0, 0.5, 0.2)),
        &[0.0, 0.0],
        &IkOptions::default(),
    );
    assert!(!sol.converged);
    assert!((sol.residual - 0.2).abs() < 1e-6, "{sol:?}");
    assert_eq!(sol.position_error, sol.residual);
    // A real arm and a point 3 m away: out of reach.
    let r = Robot::builtin("coman").unwrap();
    let [arm, _] = r.arms().unwrap();
    let far = IkTarget::Position(Vector3::new(0.0, 3.0, 0.0));
    let sol = arm
        .chain
        .inverse_kinematics(&far, &[0.0; 7], &IkOptions::default());
    assert!(!sol.converged && sol.residual > 2.0, "{sol:?}");
}

#[test]
fn batch_equals_single_and_lengths_are_checked() {
    let c = planar();
    let qs = [0.1, 0.2, -0.5, 1.0, 2.0, -2.0, 9.9];
    let poses = c.forward_batch(&qs);
    assert_eq!(poses.len(), 3);
    for (k, p) in poses.iter().enumerate() {
        assert_eq!(*p, c.forward(&qs[2 * k..2 * k + 2]));
    }
    assert!(c.try_forward(&[0.1]).is_err());
    assert!(c.try_jacobian(&[0.1, 0.2, 0.3]).is_err());
    assert_eq!(c.forward(&[0.1]), c.forward(&[0.1, 0.0]));
    let r = Robot::from_urdf_str(PLANAR, "planar.urdf").unwrap();
    let batch = r.forward_kinematics_batch(&qs[..6], "tip").unwrap();
    assert_eq!(batch, poses);
    assert!(r.forward_kinematics_batch(&qs, "tip").is_err());
    assert!(r.forward_kinematics(&[0.0], "tip").is_err());
}

#[test]
fn chain_errors_name_the_links() {
    let r = Robot::from_urdf_str(PLANAR, "planar.urdf").unwrap();
    let e = r.chain("tip", "base").unwrap_err().to_string();
    assert_eq!(e, "robot \"planar\": link \"base\" is not a descendant of link \"tip\", so they do not bound a chain");
    let e = r.chain("base", "hand").unwrap_err().to_string();
    assert_eq!(e, "robot \"planar\": no link named \"hand\"");
    let c = r.chain("l1", "tip").unwrap();
    assert_eq!(c.joint_names(), &["j2".to_string()]);
    assert_eq!(c.robot_indices(), &[1]);
    let empty = r.chain("l2", "tip").unwrap();
    assert_eq!(empty.dof(), 0);
    assert_eq!(
        empty.forward(&[]).translation.vector,
        Vector3::new(0.5, 0.0, 0.0)
    );
    assert!(empty.forward_batch(&[]).is_empty());
}

#[test]
fn posture_task_keeps_redundant_arms_near_rest_and_still_converges() {
    let r = Robot::builtin("human").unwrap();
    let [arm, _] = r.arms().unwrap();
    let zero = vec![0.0; 9];
    let s = r
        .forward_kinematics(&[0.0; 18], &arm.shoulder_link)
        .unwrap()
        .translation
        .vector;
    let dist = |q: &[f64]| q.iter().map(|v| v * v).sum::<f64>().sqrt();
    for offset in [
        Vector3::new(0.25, 0.0, -0.10),
        Vector3::new(0.3, 0.2, 0.1),
        Vector3::new(0.4, -0.1, -0.3),
    ] {
        let target = IkTarget::Position(s + offset);
        let plain = arm
            .chain
            .inverse_kinematics(&target, &zero, &IkOptions::default());
        let opts = IkOptions {
            posture_gain: 0.5,
            ..IkOptions::default()
        };
        let natural = arm.chain.inverse_kinematics(&target, &zero, &opts);
        assert!(plain.converged && natural.converged, "{natural:?}");
        let back = arm.chain.forward(&natural.q).translation.vector;
        assert!((back - (s + offset)).norm() < 1e-6);
        assert!(
            dist(&natural.q) < dist(&plain.q),
            "{} vs {}",
            dist(&natural.q),
            dist(&plain.q)
        );
    }
}

#[test]
fn public_types_are_send_and_sync() {
    fn check<T: Send + Sync>() {}
    check::<Robot>();
    check::<Chain>();
    check::<IkSolution>();
}

/// The UR5e's standard DH table as Universal Robots publish it: (a, d, α) per joint, θ = q.
const UR5E_DH: [(f64, f64, f64); 6] = [
    (0.0, 0.1625, FRAC_PI_2),
    (-0.425, 0.0, 0.0),
    (-0.3922, 0.0, 0.0),
    (0.0, 0.1333, FRAC_PI_2),
    (0.0, 0.0997, -FRAC_PI_2),
    (0.0, 0.0996, 0.0),
];

/// The mounting of a UR5e arm on the ur5e torso (`sign` +1 left, −1 right): base x0 up, z0
/// (the pan axis) horizontal, out of the torso side and turned 30° backward, base origin
/// 0.13 m out and d1 sin 30° forward of the torso's middle, 0.2 m up.
fn ur5e_mount(sign: f64) -> Matrix4<f64> {
    let (c, s) = (3f64.sqrt() / 2.0, -0.5);
    // Columns x0 = (0, 0, 1), y0 = z0 × x0 = (sign c, −s, 0), z0 = (s, sign c, 0).
    #[rustfmt::skip]
    let m = Matrix4::new(
        0.0, sign * c, s, 0.08125,
        0.0, -s, sign * c, sign * 0.13,
        1.0, 0.0, 0.0, 0.2,
        0.0, 0.0, 0.0, 1.0,
    );
    m
}

#[test]
fn ur5e_forward_kinematics_matches_poses_worked_out_from_the_dh_table() {
    // In the arm's base frame (DH frame 0; our `*_shoulder_link` frame at q1 = 0): frame
    // i = frame i−1 · Rz(q_i) Tz(d_i) Tx(a_i) Rx(α_i). At q = 0 the joint axes are z0 = +z,
    // z1 = z2 = z3 = −y, z4 = −z, z5 = −y, and the origins step by d1 z0 = (0, 0, .1625),
    // a2 x1 = (−.425, 0, 0), a3 x2 = (−.3922, 0, 0), d4 z3 = (0, −.1333, 0), d5 z4 =
    // (0, 0, −.0997), d6 z5 = (0, −.0996, 0) to the flange; the tool axes are x6 = +x, z6 = −y.
    let r = Robot::builtin("ur5e").unwrap();
    let h = FRAC_PI_2;
    // (q, flange position, x6, z6), worked out by hand:
    type Case = ([f64; 6], [f64; 3], [f64; 3], [f64; 3]);
    let cases: [Case; 3] = [
        // q = 0: (a2 + a3, −d4 − d6, d1 − d5).
        (
            [0.0; 6],
            [-0.8172, -0.2329, 0.0628],
            [1.0, 0.0, 0.0],
            [0.0, -1.0, 0.0],
        ),
        // Shoulder lift −π/2 about −y, i.e. Ry(π/2): (x, y, z) → (z, y, −x), turns the arm
        // below the shoulder, (−.8172, −.2329, −.0997), into (−.0997, −.2329, .8172): the arm
        // points up; x6 → (0, 0, −1), z6 unchanged.
        (
            [0.0, -h, 0.0, 0.0, 0.0, 0.0],
            [-0.0997, -0.2329, 0.9797],
            [0.0, 0.0, -1.0],
            [0.0, -1.0, 0.0],
        ),
        // q1 = q3 = q5 = π/2, inside out: wrist 2 (about −z: (x, y, z) → (y, −x, z)) turns
        // d5 z4 + d6 z5 = (0, −.0996, −.0997) into (−.0996, 0, −.0997); with d4 z3 and a3 x2
        // the elbow (about −y: (x, y, z) → (−z, y, x)) turns (−.4918, −.1333, −.0997) into
        // (.0997, −.1333, −.4918); with a2 x1 and d1 z0 the pan (about +z: (x, y, z) →
        // (−y, x, z)) turns (−.3253, −.1333, −.3293) into (.1333, −.3253, −.3293).
        // Tool axes: x6 = +x, z6 = −z.
        (
            [h, 0.0, h, 0.0, h, 0.0],
            [0.1333, -0.3253, -0.3293],
            [1.0, 0.0, 0.0],
            [0.0, 0.0, -1.0],
        ),
    ];
    let zero = vec![0.0; 12];
    for (side, offset) in [("left", 0), ("right", 6)] {
        // Both arms are the same UR5e: the same poses in their own base frames.
        let base = r
            .forward_kinematics(&zero, &format!("{side}_shoulder_link"))
            .unwrap();
        for (q_arm, p, x6, z6) in cases {
            let mut q = vec![0.0; 12];
            q[offset..offset + 6].copy_from_slice(&q_arm);
            let hand = r.forward_kinematics(&q, &format!("{side}_hand")).unwrap();
            let rel = base.inverse() * hand;
            for (got, want) in [
                (rel.translation.vector, p),
                (rel.rotation * Vector3::x(), x6),
                (rel.rotation * Vector3::z(), z6),
            ] {
                assert!(
                    (got - Vector3::from(want)).norm() < 1e-9,
                    "{side} {q_arm:?}: {got:?} vs {want:?}"
                );
            }
        }
        // The mounting: base origin and axes x0 = +z, z0 = (−1/2, ±√3/2, 0) in the torso.
        let sign = if side == "left" { 1.0 } else { -1.0 };
        let mount = ur5e_mount(sign);
        let got = base.to_homogeneous();
        assert!((got - mount).norm() < 1e-12, "{side}: {got} vs {mount}");
        // The shoulder centre is where the pan and lift axes cross, d1 along z0: x = 0.
        let centre = r
            .forward_kinematics(&zero, &format!("{side}_shoulder"))
            .unwrap()
            .translation
            .vector;
        let want = Vector3::new(0.0, sign * (0.13 + 0.1625 * 3f64.sqrt() / 2.0), 0.2);
        assert!((centre - want).norm() < 1e-12, "{side}: {centre}");
    }
}

#[test]
fn ur5e_forward_kinematics_equals_the_dh_product_everywhere() {
    // The textbook product T = M · Π Rz(θ_i) Tz(d_i) Tx(a_i) Rx(α_i), written out here (not
    // with the chain code), at random configurations within the limits of both arms; the hand
    // frame is DH frame 6, the tool flange.
    fn dh(mount: &Matrix4<f64>, q: &[f64]) -> Matrix4<f64> {
        let mut t = *mount;
        for (&(a, d, alpha), &th) in UR5E_DH.iter().zip(q) {
            let (st, ct, sa, ca) = (th.sin(), th.cos(), alpha.sin(), alpha.cos());
            #[rustfmt::skip]
            let step = Matrix4::new(
                ct, -st * ca, st * sa, a * ct,
                st, ct * ca, -ct * sa, a * st,
                0.0, sa, ca, d,
                0.0, 0.0, 0.0, 1.0,
            );
            t *= step;
        }
        t
    }
    let r = Robot::builtin("ur5e").unwrap();
    let limits = r.joint_limits();
    let mut rng = ChaCha8Rng::seed_from_u64(12);
    for _ in 0..50 {
        let q: Vec<f64> = limits
            .iter()
            .map(|&(lo, hi)| rng.random_range(lo..=hi))
            .collect();
        for (side, sign, arm_q) in [("left", 1.0, &q[..6]), ("right", -1.0, &q[6..])] {
            let want = dh(&ur5e_mount(sign), arm_q);
            let got = r
                .forward_kinematics(&q, &format!("{side}_hand"))
                .unwrap()
                .to_homogeneous();
            let err = (got - want).abs().max();
            assert!(err < 1e-12, "{side} {arm_q:?}: {err}");
        }
    }
}

#[test]
fn bounds_narrow_the_limits_and_a_joint_point_follows_in_the_null_space() {
    let robot = Robot::builtin("coman").unwrap();
    let arm = robot.chain("DWYTorso", "left_hand").unwrap();
    let q_goal = [-0.6, 0.4, 0.3, -1.1, 0.2, 0.1, 0.2];
    let tip = arm.forward(&q_goal).translation.vector;
    let elbow_joint = 3; // LElbj: its origin is the elbow
    let elbow = arm.joint_origins(&q_goal)[elbow_joint];
    // From the zero configuration the hand alone lands somewhere on its redundancy; asking for
    // the elbow too brings the elbow to the goal's while the hand stays put.
    let opts = IkOptions::default();
    let hand_only = arm.inverse_kinematics(&IkTarget::Position(tip), &[0.0; 7], &opts);
    let with_elbow = arm.inverse_kinematics(
        &IkTarget::PositionAndJoint {
            tip,
            joint: elbow_joint,
            point: elbow,
        },
        &[0.0; 7],
        &opts,
    );
    assert!(hand_only.converged && with_elbow.converged);
    assert!(with_elbow.position_error < 1e-8);
    let miss = |q: &[f64]| (arm.joint_origins(q)[elbow_joint] - elbow).norm();
    assert!(miss(&with_elbow.q) < 1e-3, "elbow {}", miss(&with_elbow.q));
    assert!(miss(&with_elbow.q) < miss(&hand_only.q));
    // Bounds of ±0.05 rad around zero: no joint leaves them, and the far target is not reached.
    let bounded = IkOptions {
        bounds: Some(vec![(-0.05, 0.05); 7]),
        restarts: 0,
        ..IkOptions::default()
    };
    let sol = arm.inverse_kinematics(&IkTarget::Position(tip), &[0.0; 7], &bounded);
    assert!(sol.q.iter().all(|v| v.abs() <= 0.05 + 1e-12), "{:?}", sol.q);
    assert!(!sol.converged);
}
