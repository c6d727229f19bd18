//! ASF/AMC read as a BVH: the joints' world positions equal the ASF's own forward kinematics
//! (computed here apart from the conversion), a CMU skeleton imports with its arms found, and
//! bad files fail naming the file, the line and what was expected.

use std::path::{Path, PathBuf};

use nalgebra::{Rotation3, Vector3};

use super::*;

fn fixture(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fixtures")
        .join(name)
}

/// World positions of every joint of `bvh` in frame `f` (and of each End Site, keyed by its
/// joint), by composing each joint's local transform down the tree.
fn bvh_positions(bvh: &Bvh, f: usize) -> (Vec<Vector3<f64>>, Vec<Option<Vector3<f64>>>) {
    let values = bvh.frame(f);
    let mut rot: Vec<Rotation3<f64>> = Vec::new();
    let mut pos: Vec<Vector3<f64>> = Vec::new();
    let mut ends = Vec::new();
    for j in &bvh.joints {
        let (t, r) = j.local(values);
        let (p, g) = match j.parent {
            None => (t, r),
            Some(p) => (pos[p] + rot[p] * t, rot[p] * r),
        };
        ends.push(j.end_site.map(|e| p + g * e));
        pos.push(p);
        rot.push(g);
    }
    (pos, ends)
}

/// The ASF's own forward kinematics of one AMC frame (`values`: bone name → its numbers):
/// each bone's global rotation `G = G_parent · C · M · C⁻¹`, its end `start + length · G ·
/// direction`. Returns each bone's start and end.
fn asf_positions(
    s: &Skeleton,
    values: &HashMap<String, Vec<f64>>,
) -> Vec<(Vector3<f64>, Vector3<f64>)> {
    let root = &values["root"];
    let m_root = turns(&[0, 1, 2], &root[3..6]);
    let g_root = s.root_axis * m_root * s.root_axis.inverse();
    let origin = Vector3::new(root[0], root[1], root[2]);
    let order = parents_first(s, "t").unwrap();
    let mut g = vec![Rotation3::identity(); s.bones.len()];
    let mut ends = vec![(Vector3::zeros(), Vector3::zeros()); s.bones.len()];
    for b in order {
        let bone = &s.bones[b];
        let (gp, start) = match s.parent[b] {
            None => (g_root, origin),
            Some(p) => (g[p], ends[p].1),
        };
        let m = values
            .get(&bone.name)
            .map_or_else(Rotation3::identity, |v| turns(&bone.dof, v));
        g[b] = gp * bone.axis * m * bone.axis.inverse();
        ends[b] = (start, start + bone.length * (g[b] * bone.direction));
    }
    ends
}

#[test]
fn a_cmu_motion_read_as_bvh_puts_every_joint_where_the_asf_does() {
    let asf = fixture("cmu-12.asf");
    let amc = fixture("cmu-02_01-60frames.amc");
    let skeleton = parse_asf(&std::fs::read_to_string(&asf).unwrap(), "12.asf").unwrap();
    let bvh = read_asf_amc(&asf, &amc).unwrap();
    assert_eq!(bvh.frames(), 60);
    assert_eq!(bvh.joints.len(), 1 + skeleton.bones.len());
    // The AMC's frames as numbers by bone, read plainly here.
    let text = std::fs::read_to_string(&amc).unwrap();
    let mut frames: Vec<HashMap<String, Vec<f64>>> = Vec::new();
    for line in text.lines().filter(|l| !l.starts_with([':', '#'])) {
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            [n] if n.parse::<u32>().is_ok() => frames.push(HashMap::new()),
            [name, rest @ ..] => {
                let v = rest.iter().map(|w| w.parse().unwrap()).collect();
                frames.last_mut().unwrap().insert(name.to_string(), v);
            }
            [] => {}
        }
    }
    for f in [0, 17, 59] {
        let (pos, end_sites) = bvh_positions(&bvh, f);
        let want = asf_positions(&skeleton, &frames[f]);
        for (b, bone) in skeleton.bones.iter().enumerate() {
            let j = bvh.joint(&bone.name).unwrap();
            assert!(
                (pos[j] - want[b].0).norm() < 1e-9,
                "{} frame {f}",
                bone.name
            );
            if let Some(end) = end_sites[j] {
                assert!(
                    (end - want[b].1).norm() < 1e-9,
                    "{} end, frame {f}",
                    bone.name
                );
            }
        }
    }
}

#[test]
fn a_cmu_asf_amc_imports_with_its_arms_found() {
    let options = crate::ImportOptions::default();
    let paths = [fixture("cmu-12.asf"), fixture("cmu-02_01-60frames.amc")];
    let captures = crate::import_files(&paths, &options).unwrap();
    assert_eq!(captures.len(), 1);
    let c = &captures[0];
    assert!(
        c.source.skeleton.contains("CMU ASF"),
        "{}",
        c.source.skeleton
    );
    assert_eq!(c.joint_names.len(), 18);
    assert!(c.positions.iter().all(|v| v.is_finite()));
    assert!(c.source.fit.elbow_worst_m < 1e-9 && c.source.fit.wrist_worst_m < 1e-3);
    // The .amc alone takes the only .asf beside it; where there is none (its subject's would
    // be 02.asf), a clear error.
    let alone = crate::import_files(&paths[1..], &options).unwrap();
    assert_eq!(alone[0].positions, c.positions);
    let dir = std::env::temp_dir().join(format!("sgplvm-amc-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let lone = dir.join("02_01.amc");
    std::fs::copy(&paths[1], &lone).unwrap();
    let e = match crate::import_files(&[lone], &options) {
        Ok(_) => panic!("imported without a skeleton"),
        Err(e) => e.to_string(),
    };
    std::fs::remove_dir_all(&dir).ok();
    assert!(e.contains("02.asf") && e.contains("ASF skeleton"), "{e}");
    // An .asf alone is no motion.
    let e = match crate::import_files(&paths[..1], &options) {
        Ok(_) => panic!("an .asf alone imported"),
        Err(e) => e.to_string(),
    };
    assert!(e.contains("no motion"), "{e}");
}

#[test]
fn bad_asf_and_amc_files_name_the_line_and_what_was_expected() {
    let asf = std::fs::read_to_string(fixture("cmu-12.asf")).unwrap();
    let skeleton = parse_asf(&asf, "12.asf").unwrap();
    let convert = |amc: &str| asf_amc_to_bvh(&skeleton, amc, "12.asf", "m.amc").map(|_| ());
    let e = convert(":DEGREES\n1\nroot 0 0 0 0 0 0\nlhumerus 1 2\n")
        .unwrap_err()
        .to_string();
    assert!(
        e.starts_with("m.amc:4:") && e.contains("lhumerus: 2 values; its dof in 12.asf has 3"),
        "{e}"
    );
    let e = convert("1\nnose 1 2 3\n").unwrap_err().to_string();
    assert!(
        e.starts_with("m.amc:2:") && e.contains("no bone `nose`"),
        "{e}"
    );
    let e = convert("root 0 0 0 0 0 0\n").unwrap_err().to_string();
    assert!(e.contains("before the first frame number"), "{e}");
    let e = convert("1\nroot 0 0 0 0 0 nan\n").unwrap_err().to_string();
    assert!(e.contains("`nan` is not a finite number"), "{e}");
    assert!(convert(":DEGREES\n")
        .unwrap_err()
        .to_string()
        .contains("no frames"));
    let broken = asf.replace("lhumerus lradius", "lhumerus nowhere");
    let e = parse_asf(&broken, "b.asf").unwrap_err().to_string();
    assert!(
        e.contains("b.asf:") && e.contains("no bone `nowhere`"),
        "{e}"
    );
    let e = parse_asf("# nothing\n", "e.asf").unwrap_err().to_string();
    assert!(e.contains("no :bonedata bones"), "{e}");
}
