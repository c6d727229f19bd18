//! Collision meshes in the physics replay: a small robot whose shapes are mesh files written
//! here (an ASCII STL, a binary STL, an OBJ cube), found relative to the URDF, through a
//! package path, or not at all; the hulls collide, honour `scale`, and a mesh that cannot be
//! found or read is listed in the report and named in the summary instead of a panic.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use sgplvm_robots::physics::{replay, MeshProblem, ReplayOptions, ReplayReport, Trajectory};
use sgplvm_robots::urdf::MeshSearch;

/// A fresh temporary folder.
fn scratch(tag: &str) -> PathBuf {
    static N: AtomicUsize = AtomicUsize::new(0);
    let n = N.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!(
        "sgplvm-physics-meshes-{tag}-{}-{n}",
        std::process::id()
    ));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// The 12 triangles of the cube [-0.5, 0.5]³.
fn cube_triangles() -> Vec<[[f32; 3]; 3]> {
    let c = |i: usize| -> [f32; 3] {
        [
            if i & 1 == 0 { -0.5 } else { 0.5 },
            if i & 2 == 0 { -0.5 } else { 0.5 },
            if i & 4 == 0 { -0.5 } else { 0.5 },
        ]
    };
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    quads
        .iter()
        .flat_map(|q| [[c(q[0]), c(q[1]), c(q[2])], [c(q[0]), c(q[2]), c(q[3])]])
        .collect()
}

fn write(path: &Path, bytes: &[u8]) {
    std::fs::create_dir_all(path.parent().unwrap()).unwrap();
    std::fs::write(path, bytes).unwrap();
}

fn ascii_stl() -> Vec<u8> {
    let mut text = String::from("solid cube\n");
    for t in cube_triangles() {
        text.push_str("  facet normal 0 0 0\n    outer loop\n");
        for v in t {
            text.push_str(&format!("      vertex {} {} {}\n", v[0], v[1], v[2]));
        }
        text.push_str("    endloop\n  endfacet\n");
    }
    text.push_str("endsolid cube\n");
    text.into_bytes()
}

fn binary_stl() -> Vec<u8> {
    let triangles = cube_triangles();
    let mut bytes = vec![0u8; 80];
    bytes.extend_from_slice(&(triangles.len() as u32).to_le_bytes());
    for t in triangles {
        for _ in 0..3 {
            bytes.extend_from_slice(&0f32.to_le_bytes());
        }
        for v in t {
            for x in v {
                bytes.extend_from_slice(&x.to_le_bytes());
            }
        }
        bytes.extend_from_slice(&0u16.to_le_bytes());
    }
    bytes
}

fn obj() -> Vec<u8> {
    let mut text = String::from("# cube\nmtllib cube.mtl\n");
    for i in 0..8 {
        let s = |bit| if i & bit == 0 { -0.5 } else { 0.5 };
        text.push_str(&format!("v {} {} {}\n", s(1), s(2), s(4)));
    }
    for f in [
        [1, 3, 4, 2],
        [5, 6, 8, 7],
        [1, 2, 6, 5],
        [3, 7, 8, 4],
        [1, 5, 7, 3],
        [2, 4, 8, 6],
    ] {
        text.push_str(&format!("f {} {} {} {}\n", f[0], f[1], f[2], f[3]));
    }
    text.into_bytes()
}

/// base (a mesh) ─j1→ l1 (a small sphere 1 m away) ─j2→ l2 (a mesh `x` m from the base, on
/// the x axis, where the trajectory slides it: at rest, j2 at 0, it is 0.5 m further, so that
/// an overlap is the motion's, not the model's own). base and l2 are not neighbours: l1 has a
/// shape.
fn robot(base_mesh: &str, l2_mesh: &str, x: f64) -> String {
    let inertial = r#"<inertial><mass value="1"/><inertia ixx="0.01" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial>"#;
    format!(
        r#"<robot name="meshy">
  <link name="base">{inertial}<collision><geometry>{base_mesh}</geometry></collision></link>
  <link name="l1">{inertial}<collision><geometry><sphere radius="0.01"/></geometry></collision></link>
  <link name="l2">{inertial}<collision><origin xyz="0 0 0" rpy="0 0 0.3"/><geometry>{l2_mesh}</geometry></collision></link>
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/>
    <origin xyz="1 0 0"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="10" velocity="3"/></joint>
  <joint name="j2" type="prismatic"><parent link="l1"/><child link="l2"/>
    <origin xyz="{} 0 0"/><axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="10" velocity="3"/></joint>
</robot>"#,
        x - 1.0 + 0.5
    )
}

/// Replays 0.1 s at rest (no gravity, contacts detected only) with `search`.
fn run(xml: &str, search: MeshSearch) -> ReplayReport {
    let trajectory = Trajectory::new(
        vec!["j1".into(), "j2".into()],
        vec![0.0, 0.1],
        vec![0.0, -0.5, 0.0, -0.5],
    )
    .unwrap();
    let options = ReplayOptions {
        gravity: false,
        contact_response: false,
        settle_seconds: 0.0,
        meshes: search,
        ..ReplayOptions::default()
    };
    replay(xml, "meshy.urdf", &trajectory, &options).unwrap()
}

fn mesh(filename: &str, scale: f64) -> String {
    format!(r#"<mesh filename="{filename}" scale="{scale} {scale} {scale}"/>"#)
}

#[test]
fn hulls_collide_and_honour_scale_whatever_the_format_and_uri() {
    let dir = scratch("formats");
    write(
        &dir.join("pkgs/meshy_description/meshes/cube.stl"),
        &ascii_stl(),
    );
    write(&dir.join("robot/meshes/cube_binary.stl"), &binary_stl());
    write(&dir.join("robot/meshes/Cube.OBJ"), &obj());
    // A binary STL whose header begins with "solid", as a published gripper's does.
    let mut solid_header = binary_stl();
    solid_header[..80].copy_from_slice(format!("{:<80}", "solid Gripper").as_bytes());
    write(&dir.join("robot/meshes/solid_binary.stl"), &solid_header);
    let search = || {
        MeshSearch::for_urdf_file(&dir.join("robot/meshy.urdf")).with_package_path(dir.join("pkgs"))
    };
    let base = mesh("package://meshy_description/meshes/cube.stl", 0.1);
    for l2 in [
        "meshes/cube_binary.stl",
        "meshes/Cube.OBJ",
        "meshes/solid_binary.stl",
    ] {
        // Cubes of 0.1 m, centres 0.15 m apart: 5 cm apart (l2 turned by 0.3 rad: ~3.5 cm).
        let apart = run(&robot(&base, &mesh(l2, 0.1), 0.15), search());
        assert_eq!(apart.mesh_hulls, 2, "{l2}");
        assert_eq!(apart.collision_shapes, 3, "{l2}");
        assert!(apart.unchecked_meshes.is_empty(), "{l2}: {apart:?}");
        assert!(apart.collisions.is_empty(), "{l2}: {:?}", apart.collisions);
        assert_eq!(
            apart.self_collision_summary(),
            "no self-collisions among the 3 collision shapes checked"
        );
        // Scaled to 0.2 m the same cubes overlap.
        let overlap = run(&robot(&base, &mesh(l2, 0.2), 0.15), search());
        assert_eq!(
            overlap.collisions.len(),
            1,
            "{l2}: {:?}",
            overlap.collisions
        );
        let c = &overlap.collisions[0];
        assert_eq!((c.link_a.as_str(), c.link_b.as_str()), ("base", "l2"));
        // The base's 0.1 m cube sinks about 2 cm into the turned 0.2 m one.
        assert!((0.015..0.025).contains(&c.max_penetration), "{c:?}");
        assert!(overlap.self_collision_summary().starts_with(
            "1 self-collision interval between 1 pair of links among the 3 collision shapes checked"
        ));
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn meshes_not_found_or_unreadable_are_reported_not_checked() {
    let dir = scratch("missing");
    write(&dir.join("meshes/cube.stl"), &ascii_stl());
    write(
        &dir.join("meshes/truncated.stl"),
        b"solid broken\n  facet normal 0 0 1\n    outer loop\n      vertex 1 2\n",
    );
    write(&dir.join("meshes/short_binary.stl"), &binary_stl()[..200]);
    write(
        &dir.join("meshes/flat.obj"),
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    );
    write(&dir.join("meshes/notes.txt"), b"not a mesh");
    // A clone without `git lfs`: a pointer where the mesh should be (AgiBot's G2).
    write(
        &dir.join("meshes/lfs.STL"),
        b"version https://git-lfs.github.com/spec/v1\noid sha256:001ea69c\nsize 132284\n",
    );
    let search = || MeshSearch::for_urdf_file(&dir.join("meshy.urdf"));
    let base = mesh("meshes/cube.stl", 0.1);
    let cases = [
        ("meshes/missing.stl", MeshProblem::NotFound, "missing.stl"),
        (
            "package://nowhere/cube.stl",
            MeshProblem::NotFound,
            "nowhere",
        ),
        (
            "meshes/truncated.stl",
            MeshProblem::Unreadable,
            "truncated.stl",
        ),
        (
            "meshes/short_binary.stl",
            MeshProblem::Unreadable,
            "short_binary.stl",
        ),
        ("meshes/notes.txt", MeshProblem::Unreadable, "notes.txt"),
        (
            "meshes/lfs.STL",
            MeshProblem::Unreadable,
            "a Git LFS pointer",
        ),
        ("meshes/flat.obj", MeshProblem::Unusable, "flat.obj"),
    ];
    for (uri, problem, named) in cases {
        let report = run(&robot(&base, &mesh(uri, 0.2), 0.15), search());
        assert_eq!(report.mesh_hulls, 1, "{uri}");
        assert_eq!(report.collision_shapes, 2, "{uri}");
        assert_eq!(report.unchecked_meshes.len(), 1, "{uri}");
        let unchecked = &report.unchecked_meshes[0];
        assert_eq!(unchecked.link, "l2");
        assert_eq!(unchecked.uri, uri);
        assert_eq!(unchecked.problem, problem, "{uri}: {}", unchecked.message);
        assert!(unchecked.message.contains(named), "{}", unchecked.message);
        // The overlap with l2 could not be seen; the summary says so.
        assert!(report.collisions.is_empty());
        let summary = report.self_collision_summary();
        assert_eq!(
            summary,
            format!(
                "no self-collisions among the 2 collision shapes checked; 1 collision mesh of \
                 link \"l2\" could not be checked ({})",
                problem.describe()
            )
        );
        // No warning per mesh: the report lists each once.
        assert!(
            report.warnings.iter().all(|w| !w.contains(uri)),
            "{:?}",
            report.warnings
        );
    }
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn published_g1_without_its_meshes_says_what_it_could_not_check() {
    let path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../data/urdf/published/g1_29dof.urdf");
    let xml = std::fs::read_to_string(&path).unwrap();
    let trajectory = Trajectory::new(
        vec!["left_elbow_joint".into()],
        vec![0.0, 0.05],
        vec![0.0, 0.0],
    )
    .unwrap();
    let options = ReplayOptions {
        allow_missing_joints: true,
        settle_seconds: 0.0,
        // A package path without the package: every mesh is missing.
        meshes: MeshSearch::for_urdf_file(&path).with_package_path(path.parent().unwrap()),
        ..ReplayOptions::default()
    };
    let report = replay(&xml, "g1_29dof.urdf", &trajectory, &options).unwrap();
    assert_eq!(report.mesh_hulls, 0);
    // 24 collision meshes, 12 primitives (cylinders and spheres).
    assert_eq!(report.unchecked_meshes.len(), 24);
    assert_eq!(report.collision_shapes, 12);
    assert!(report
        .unchecked_meshes
        .iter()
        .all(|m| m.problem == MeshProblem::NotFound && m.message.contains("example-robot-data")));
    let summary = report.self_collision_summary();
    assert!(
        summary.contains("could not be checked (not found)"),
        "{summary}"
    );
    assert!(summary.contains("\"pelvis_contour_link\""), "{summary}");
    assert!(summary.contains("and 19 more"), "{summary}");
}
