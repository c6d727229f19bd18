//! Markers of a scene: what a `visualization_msgs/msg/Marker` draws ([`MarkerShape`]), one
//! marker ([`SceneMarker`]), the markers published together at one time on one topic
//! ([`TimedMarkers`]), and their fields as the MarkerArray encoder takes them.

use super::msgs;

/// What a [`SceneMarker`] draws.
#[derive(Debug, Clone, PartialEq)]
pub enum MarkerShape {
    /// A sphere (`SPHERE`) of diameters `scale`.
    Sphere,
    /// A text facing the viewer (`TEXT_VIEW_FACING`), `scale[2]` high.
    Text(String),
}

/// One `visualization_msgs/msg/Marker` (action ADD, orientation identity).
#[derive(Debug, Clone, PartialEq)]
pub struct SceneMarker {
    /// Frame it is drawn in, e.g. `coman/LElb` or [`WORLD_FRAME`](super::WORLD_FRAME).
    pub frame: String,
    /// Namespace (`ns`): with `id`, what names the marker.
    pub ns: String,
    /// Identifier within the namespace.
    pub id: i32,
    /// What it draws.
    pub shape: MarkerShape,
    /// Position in `frame`, metres.
    pub position: [f64; 3],
    /// Size, metres.
    pub scale: [f64; 3],
    /// Colour (red, green, blue, alpha in [0, 1]).
    pub color: [f32; 4],
    /// How long it stays after its time, nanoseconds (0: forever).
    pub lifetime_ns: i64,
}

/// Markers published together (one `visualization_msgs/msg/MarkerArray`) on `topic` at
/// `time_ns` (log time and every marker's stamp).
#[derive(Debug, Clone, PartialEq)]
pub struct TimedMarkers {
    /// Topic, e.g. `/coman/events`.
    pub topic: String,
    /// Time, nanoseconds (≥ 0).
    pub time_ns: i64,
    /// The markers.
    pub markers: Vec<SceneMarker>,
}

/// The fields of `m`'s markers as [`msgs::encode_marker_array`] encodes them.
pub(super) fn marker_fields(m: &TimedMarkers) -> Vec<msgs::MarkerFields<'_>> {
    m.markers
        .iter()
        .map(|k| {
            let (kind, text) = match &k.shape {
                MarkerShape::Sphere => (msgs::MARKER_SPHERE, ""),
                MarkerShape::Text(t) => (msgs::MARKER_TEXT_VIEW_FACING, t.as_str()),
            };
            msgs::MarkerFields {
                frame: &k.frame,
                ns: &k.ns,
                id: k.id,
                kind,
                position: k.position,
                scale: k.scale,
                color: k.color,
                lifetime_ns: k.lifetime_ns,
                text,
            }
        })
        .collect()
}
