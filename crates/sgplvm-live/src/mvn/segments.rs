//! The segment ID tables of §3.1 (Tables 1 and 2) and names both ways.

/// The 23 body segments in ID order: `BODY_SEGMENTS[id - 1]` (§3.1 Table 1).
pub const BODY_SEGMENTS: [&str; 23] = [
    "Pelvis",
    "L5",
    "L3",
    "T12",
    "T8",
    "Neck",
    "Head",
    "RightShoulder",
    "RightUpperArm",
    "RightForeArm",
    "RightHand",
    "LeftShoulder",
    "LeftUpperArm",
    "LeftForeArm",
    "LeftHand",
    "RightUpperLeg",
    "RightLowerLeg",
    "RightFoot",
    "RightToe",
    "LeftUpperLeg",
    "LeftLowerLeg",
    "LeftFoot",
    "LeftToe",
];

/// The prop segments, IDs 24 to 23 + number of props (§3.1 Table 1).
pub const PROP_SEGMENTS: [&str; 4] = ["Prop1", "Prop2", "Prop3", "Prop4"];

/// The finger tracking segments of both hands in stream order, left hand first (§3.1 Table 2):
/// IDs 24 + number of props onwards.
pub const FINGER_SEGMENTS: [&str; 40] = [
    "LeftCarpus",
    "LeftFirstMetacarpal",
    "LeftFirstProximalPhalange",
    "LeftFirstDistalPhalange",
    "LeftSecondMetacarpal",
    "LeftSecondProximalPhalange",
    "LeftSecondMiddlePhalange",
    "LeftSecondDistalPhalange",
    "LeftThirdMetacarpal",
    "LeftThirdProximalPhalange",
    "LeftThirdMiddlePhalange",
    "LeftThirdDistalPhalange",
    "LeftFourthMetacarpal",
    "LeftFourthProximalPhalange",
    "LeftFourthMiddlePhalange",
    "LeftFourthDistalPhalange",
    "LeftFifthMetacarpal",
    "LeftFifthProximalPhalange",
    "LeftFifthMiddlePhalange",
    "LeftFifthDistalPhalange",
    "RightCarpus",
    "RightFirstMetacarpal",
    "RightFirstProximalPhalange",
    "RightFirstDistalPhalange",
    "RightSecondMetacarpal",
    "RightSecondProximalPhalange",
    "RightSecondMiddlePhalange",
    "RightSecondDistalPhalange",
    "RightThirdMetacarpal",
    "RightThirdProximalPhalange",
    "RightThirdMiddlePhalange",
    "RightThirdDistalPhalange",
    "RightFourthMetacarpal",
    "RightFourthProximalPhalange",
    "RightFourthMiddlePhalange",
    "RightFourthDistalPhalange",
    "RightFifthMetacarpal",
    "RightFifthProximalPhalange",
    "RightFifthMiddlePhalange",
    "RightFifthDistalPhalange",
];

/// The name of segment `id` in a stream with `props` props: a body segment, a prop, a finger
/// segment, or `None` past them.
pub fn segment_name(id: u32, props: u8) -> Option<&'static str> {
    let props = u32::from(props.min(4));
    let index = usize::try_from(id.checked_sub(1)?).ok()?;
    if let Some(n) = BODY_SEGMENTS.get(index) {
        return Some(n);
    }
    let past_body = index - BODY_SEGMENTS.len();
    if past_body < props as usize {
        return PROP_SEGMENTS.get(past_body).copied();
    }
    FINGER_SEGMENTS.get(past_body - props as usize).copied()
}

/// The ID of the segment called `name` in a stream with `props` props (the inverse of
/// [`segment_name`]); `None` for a name MVN does not stream (a prop beyond `props` included).
pub fn segment_id(name: &str, props: u8) -> Option<u32> {
    let props = usize::from(props.min(4));
    let body = BODY_SEGMENTS.len();
    let at = |i: usize| u32::try_from(i + 1).ok();
    if let Some(i) = BODY_SEGMENTS.iter().position(|n| *n == name) {
        return at(i);
    }
    if let Some(i) = PROP_SEGMENTS[..props].iter().position(|n| *n == name) {
        return at(body + i);
    }
    let i = FINGER_SEGMENTS.iter().position(|n| *n == name)?;
    at(body + props + i)
}
