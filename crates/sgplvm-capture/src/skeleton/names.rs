//! The arms' segment names: the naming schemes ([`SCHEMES`]), name normalisation (namespaces,
//! case, separators aside) and an explicit map of the model's joints to a skeleton's segments
//! ([`ArmMap`]).

use std::collections::BTreeMap;

use serde::Deserialize;

use super::Role;
use crate::CaptureError;
use sgplvm_robots::Side;

/// One naming scheme of the four arm segments, without the side.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Scheme {
    /// Name shown in reports.
    pub name: &'static str,
    /// Clavicle (shoulder girdle) segment names, normalised.
    pub clavicle: &'static [&'static str],
    /// Upper-arm segment names.
    pub upper_arm: &'static [&'static str],
    /// Forearm segment names.
    pub forearm: &'static [&'static str],
    /// Hand segment names.
    pub hand: &'static [&'static str],
}

/// The naming schemes recognised without a map, tried in this order. Names are compared
/// normalised ([`normalise`]) with the side as a prefix or suffix (`left`, `l`, `right`,
/// `r`). Order matters where a name means different segments: `Shoulder` is the clavicle in
/// CMU and Mixamo files but the upper arm in Xsens BVH exports, whose clavicle is `Collar`.
pub const SCHEMES: &[Scheme] = &[
    Scheme {
        name: "Xsens BVH / SMPL (Collar, Shoulder, Elbow, Wrist)",
        clavicle: &["collar"],
        upper_arm: &["shoulder"],
        forearm: &["elbow"],
        hand: &["wrist"],
    },
    Scheme {
        // MakeHuman's "CMU MB" rig (as MocapNET's BVH files have it): `lcollar`, `lshoulder`,
        // `lelbow`, `lhand`. After the scheme above, whose `wrist` is the hand where both are.
        name: "MakeHuman (collar, shoulder, elbow, hand)",
        clavicle: &["collar"],
        upper_arm: &["shoulder"],
        forearm: &["elbow"],
        hand: &["hand"],
    },
    Scheme {
        name: "CMU / Mixamo / LAFAN1 (Shoulder, Arm, ForeArm, Hand)",
        clavicle: &["shoulder"],
        upper_arm: &["arm"],
        forearm: &["forearm"],
        hand: &["hand"],
    },
    Scheme {
        name: "Xsens MVN / Rigify (Shoulder, UpperArm, ForeArm, Hand)",
        clavicle: &["shoulder"],
        upper_arm: &["upperarm"],
        forearm: &["forearm", "lowerarm"],
        hand: &["hand"],
    },
    Scheme {
        // Genesis 3 and 8 split the upper arm and the forearm into a bend and a twist bone
        // (`lShldrBend` → `lShldrTwist` → `lForearmBend` → `lForearmTwist` → `lHand`).
        name: "Poser / DAZ (Collar, Shldr or ShldrBend, ForeArm or ForearmBend, Hand)",
        clavicle: &["collar"],
        upper_arm: &["shldr", "shldrbend", "shoulder"],
        forearm: &["forearm", "forearmbend"],
        hand: &["hand"],
    },
    Scheme {
        name: "Unreal / 3ds Max (Clavicle, UpperArm, LowerArm, Hand)",
        clavicle: &["clavicle"],
        upper_arm: &["upperarm"],
        forearm: &["lowerarm", "forearm"],
        hand: &["hand"],
    },
    Scheme {
        // The BVH format's own examples (Biovision, as its description by Thingvold and
        // Maddock gives them): `LeftCollar`, `LeftUpArm`, `LeftLowArm`, `LeftHand`.
        name: "Biovision (Collar, UpArm, LowArm, Hand)",
        clavicle: &["collar"],
        upper_arm: &["uparm"],
        forearm: &["lowarm"],
        hand: &["hand"],
    },
    Scheme {
        // MakeHuman's game rig (its `zombieWalk1.bvh`, `walk1.bvh`): `Clavicle_L`, `UpArm_L`,
        // `LoArm_L`, `Hand_L`, each clavicle below a helper joint `__Clavicle_L` on the spine.
        name: "MakeHuman game rig (Clavicle, UpArm, LoArm, Hand)",
        clavicle: &["clavicle"],
        upper_arm: &["uparm"],
        forearm: &["loarm"],
        hand: &["hand"],
    },
    Scheme {
        // OptiTrack Motive's skeletons (`Hip`, `Ab`, `Chest`, `LShoulder`, `LUArm`, `LFArm`,
        // `LHand`), as its BVH export and its NatNet stream name them.
        name: "OptiTrack Motive (Shoulder, UArm, FArm, Hand)",
        clavicle: &["shoulder"],
        upper_arm: &["uarm"],
        forearm: &["farm"],
        hand: &["hand"],
    },
    Scheme {
        // The bones of CMU's own ASF skeleton, as BVH files converted straight from the AMC
        // files name them: lclavicle, lhumerus, lradius, lwrist (a short bone on the forearm's
        // line that turns it), lhand (the hand, where the wrist flexes), lfingers, lthumb.
        name: "CMU ASF (clavicle, humerus, radius, hand)",
        clavicle: &["clavicle"],
        upper_arm: &["humerus"],
        forearm: &["radius"],
        hand: &["hand"],
    },
];

/// A joint name without its namespace: what follows the last `:` (`mixamorig:`) or `/` (a ROS
/// TF frame's prefix, `actor1/`).
pub(crate) fn base_name(name: &str) -> &str {
    name.rsplit([':', '/']).next().unwrap_or(name)
}

/// A joint name lower-cased without its namespace (`mixamorig:`, `actor1/`), `_`, `.`, `-` and
/// spaces.
pub fn normalise(name: &str) -> String {
    let base = base_name(name);
    base.chars()
        .filter(|c| !matches!(c, '_' | '.' | '-' | ' '))
        .flat_map(|c| c.to_lowercase())
        .collect()
}

/// The names a joint answers to: its whole normalised name, then the normalised ends of its
/// name that start with a side word, cut at word boundaries (`_`, `.`, `-`, spaces, a
/// lower-to-upper case change), so that `CC_Base_L_Clavicle` answers to `lclavicle` and
/// `Bip01 L UpperArm` to `lupperarm`; and Rigify's `DEF-upper_arm.L` to `upperarml`.
pub(crate) fn name_forms(name: &str) -> Vec<String> {
    let base = base_name(name);
    let mut words: Vec<String> = Vec::new();
    let mut current = String::new();
    let mut prev_lower = false;
    for c in base.chars() {
        if matches!(c, '_' | '.' | '-' | ' ') {
            if !current.is_empty() {
                words.push(std::mem::take(&mut current));
            }
            prev_lower = false;
            continue;
        }
        if c.is_uppercase() && prev_lower && !current.is_empty() {
            words.push(std::mem::take(&mut current));
        }
        prev_lower = c.is_lowercase() || c.is_ascii_digit();
        current.extend(c.to_lowercase());
    }
    if !current.is_empty() {
        words.push(current);
    }
    let mut forms = vec![normalise(name)];
    // Rigify's deforming bones, the ones a skin follows (`DEF-upper_arm.L`), answer to their
    // names without the prefix; its control and mechanism bones (`ORG-`, `MCH-`) do not.
    if words.first().is_some_and(|w| w == "def") && words.len() > 1 {
        forms.push(words[1..].concat());
    }
    for start in 1..words.len() {
        // Only ends that start with the side (`L_Clavicle`): a prefix is cut, not a word of
        // the segment's name (`upper_arm.L` must not answer to `arm.L`).
        if matches!(words[start].as_str(), "l" | "r" | "left" | "right") {
            forms.push(words[start..].concat());
        }
    }
    forms
}

/// The forms of `base` for `side`: `leftbase`, `lbase`, `baseleft`, `basel`.
pub(crate) fn sided(base: &str, side: Side) -> [String; 4] {
    let (long, short) = match side {
        Side::Left => ("left", "l"),
        Side::Right => ("right", "r"),
    };
    [
        format!("{long}{base}"),
        format!("{short}{base}"),
        format!("{base}{long}"),
        format!("{base}{short}"),
    ]
}

/// An explicit assignment of the capture's segments to the human model's joints, read from a
/// JSON file (`--map FILE`): keys are the model's joint groups `jLeftC7Shoulder` (driven by
/// the clavicle segment), `jLeftShoulder` (upper arm), `jLeftElbow` (forearm), `jLeftWrist`
/// (hand) and their `Right` twins, or the segment names `left_clavicle`, `left_upper_arm`,
/// `left_forearm`, `left_hand` (and `right_...`); values are the capture's joint names as
/// written in the file. The clavicles may be left out (the arms then hang from the torso).
#[derive(Debug, Clone, PartialEq, Eq, Default, Deserialize)]
#[serde(transparent)]
pub struct ArmMap(pub BTreeMap<String, String>);

impl ArmMap {
    /// Reads a map file (JSON object of strings).
    pub fn read(path: &std::path::Path) -> Result<ArmMap, CaptureError> {
        let file = path.display().to_string();
        let text = std::fs::read_to_string(path).map_err(|e| CaptureError::Map {
            file: file.clone(),
            message: format!("cannot read it: {e}"),
        })?;
        serde_json::from_str(&text).map_err(|e| CaptureError::Map {
            file,
            message: format!(
                "not a JSON object of strings ({e}); expected e.g. {{\"jLeftShoulder\": \"L_UpperArm\", ...}}"
            ),
        })
    }

    /// The segment for `role` of `side`, by either key form.
    pub(super) fn get(&self, side: Side, role: Role) -> Option<&str> {
        let (joint, segment) = role.keys(side);
        self.0
            .get(&joint)
            .or_else(|| self.0.get(&segment))
            .map(String::as_str)
    }

    /// Every key this map understands.
    pub fn known_keys() -> Vec<String> {
        let mut keys = Vec::new();
        for side in [Side::Left, Side::Right] {
            for role in Role::ALL {
                let (j, s) = role.keys(side);
                keys.push(j);
                keys.push(s);
            }
        }
        keys
    }
}
