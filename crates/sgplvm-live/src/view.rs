//! The live view: a Foxglove WebSocket server (the Foxglove SDK, `foxglove.sdk.v1`) serving
//! the human and each robot as `sgplvm predict`'s scene files hold them — the same topics,
//! schemas and CDR messages ([`sgplvm_robots::scene::SceneStream`]) — so that the layout that
//! opens those files (`data/foxglove/sgplvm.json`) shows the live node too.
//!
//! Topics: `/human/joint_states` and each `/ROBOT/joint_command` (the command as sent), each
//! body's `/NAME/robot_description` (its URDF) and `/tf_static` (sent again every second, for
//! viewers that join later: a WebSocket has no latched topics), `/tf` at the input rate,
//! `/ROBOT/prediction_std` (the predictive standard deviation per joint), `/latent` (the
//! latent point) and `/ROBOT/trust` (`[reconstruction error, its threshold, sd, its threshold,
//! state]`: the gate's two signals, whichever `--gate` uses; state 0 following, 1 holding,
//! 2 moving to the last trusted target, 3 stale input, 4 waiting for a first trusted frame).
//!
//! A robot loaded from a URDF file has its meshes found beside that file and through
//! `ROS_PACKAGE_PATH` / `AMENT_PREFIX_PATH` ([`MeshSearch`]): its description names each one
//! found by its absolute `file://` URI, and the server answers Foxglove's asset requests
//! (the protocol's `fetchAsset`) for exactly those files, under that URI or the one the URDF
//! gives (`package://…`, a relative path), so that a viewer on another machine draws them too.

use std::collections::HashMap;
use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use foxglove::{
    ChannelBuilder, Context, RawChannel, Schema, WebSocketServer, WebSocketServerHandle,
};
use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use sgplvm_robots::physics::MAX_MESH_BYTES;
use sgplvm_robots::scene::{ArrayTopic, SceneBody, SceneOptions, SceneStream};
use sgplvm_robots::urdf::MeshSearch;
use sgplvm_robots::Robot;

use crate::LiveError;

/// How often the descriptions and `/tf_static` are sent again.
const STATIC_PERIOD: Duration = Duration::from_secs(1);

/// One robot in the view.
pub struct ViewRobot {
    /// Its name (the prefix of its topics and frames).
    pub name: String,
    /// Its body.
    pub body: Robot,
    /// Its joints, in the order of the commands given to [`LiveView::frame`].
    pub joints: Vec<String>,
    /// Its whole configuration (the body's joint order) where it is not commanded: the joints
    /// it holds (a waist, legs) are drawn there.
    pub rest: Vec<f64>,
}

/// A running live view.
pub struct LiveView {
    server: Option<WebSocketServerHandle>,
    channels: Vec<Arc<RawChannel>>,
    stream: SceneStream,
    last_static: Option<Instant>,
    port: u16,
    /// Not a number in every latent dimension: what `/latent` shows for a frame whose pose
    /// could not be reconstructed.
    no_latent: Vec<f64>,
    _context: Arc<Context>,
}

fn placed(name: &str, robot: Robot, topic: String, y: f64, rest: Option<Vec<f64>>) -> SceneBody {
    SceneBody {
        rest,
        name: name.to_string(),
        meshes: MeshSearch::for_robot(&robot),
        robot,
        placement: Isometry3::from_parts(
            Translation3::new(0.0, y, 0.0),
            UnitQuaternion::identity(),
        ),
        joint_topic: topic,
    }
}

/// The mesh files the view serves, by every URI a viewer may ask for.
type Assets = HashMap<String, PathBuf>;

/// Every mesh file of `bodies` that their searches find.
fn assets<'a>(bodies: impl IntoIterator<Item = &'a SceneBody>) -> Assets {
    bodies.into_iter().flat_map(|b| b.mesh_files()).collect()
}

/// The content of the asset `uri`: one of `assets` only (a viewer cannot read other files).
fn fetch(assets: &Assets, uri: &str) -> Result<Vec<u8>, String> {
    let path = assets
        .get(uri)
        .ok_or_else(|| format!("{uri}: not a mesh of the robots in this view"))?;
    let size = std::fs::metadata(path)
        .map_err(|e| format!("{}: {e}", path.display()))?
        .len();
    if size > MAX_MESH_BYTES {
        return Err(format!(
            "{}: {size} bytes; meshes of at most {MAX_MESH_BYTES} bytes are served",
            path.display()
        ));
    }
    std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))
}

impl LiveView {
    /// Starts the server on `addr` (port 0: any free port) for the human (`human_joints`, the
    /// model's human columns) and `robots`, with a latent space of `latent_dim` dimensions (a
    /// per-part model's parts side by side; 0 where the robots are retargeted, no model).
    pub fn start(
        addr: SocketAddr,
        human_joints: Vec<String>,
        robots: Vec<ViewRobot>,
        latent_dim: usize,
    ) -> Result<LiveView, LiveError> {
        let human = Robot::builtin("human").map_err(|e| LiveError::Config(e.to_string()))?;
        // The human at y = +0.6 m, the robots at −0.6 m, −1.5 m, … (as predict's scenes).
        let mut bodies = vec![(
            placed("human", human, "/human/joint_states".into(), 0.6, None),
            human_joints,
        )];
        let mut arrays = Vec::new();
        for (k, r) in robots.into_iter().enumerate() {
            arrays.push(ArrayTopic::float64(
                &format!("/{}/prediction_std", r.name),
                "joint",
                r.joints.len(),
            ));
            arrays.push(ArrayTopic::float64(
                &format!("/{}/trust", r.name),
                "reconstruction error, reconstruction threshold, sd, sd threshold, state",
                5,
            ));
            let topic = format!("/{}/joint_command", r.name);
            bodies.push((
                placed(&r.name, r.body, topic, -0.6 - 0.9 * k as f64, Some(r.rest)),
                r.joints,
            ));
        }
        arrays.push(ArrayTopic::float64("/latent", "latent", latent_dim));
        let assets = assets(bodies.iter().map(|(b, _)| b));
        let stream = SceneStream::new(bodies, arrays, &SceneOptions::default())
            .map_err(|e| LiveError::Config(e.to_string()))?;
        let context = Context::new();
        let mut channels = Vec::with_capacity(stream.channels().len());
        for spec in stream.channels() {
            let channel = ChannelBuilder::new(spec.topic.clone())
                .message_encoding("cdr")
                .schema(Schema::new(
                    spec.schema_name,
                    "ros2msg",
                    spec.schema.as_bytes().to_vec(),
                ))
                .context(&context)
                .build_raw()
                .map_err(|e| LiveError::View(format!("channel {}: {e}", spec.topic)))?;
            channels.push(channel);
        }
        let mut server = WebSocketServer::new()
            .name("sgplvm teleop")
            .bind(addr.ip().to_string(), addr.port())
            .context(&context);
        if !assets.is_empty() {
            server = server
                .fetch_asset_handler_blocking_fn(move |_client, uri: String| fetch(&assets, &uri));
        }
        let server = server
            .start_blocking()
            .map_err(|e| LiveError::View(format!("cannot serve on {addr}: {e}")))?;
        let port = server.port();
        Ok(LiveView {
            server: Some(server),
            channels,
            stream,
            last_static: None,
            port,
            no_latent: vec![f64::NAN; latent_dim],
            _context: context,
        })
    }

    /// The port the server listens on.
    pub fn port(&self) -> u16 {
        self.port
    }

    /// Sends one frame: the human's joints, each robot's command, and per robot its standard
    /// deviations and trust (`[reconstruction error, threshold, sd, threshold, state]`), then
    /// the latent point (`None`: not a number, the pose not reconstructed; every other topic
    /// is shown all the same).
    pub fn frame(
        &mut self,
        time_ns: i64,
        human: &[f64],
        robots: &[(&[f64], &[f64], [f64; 5])],
        latent: Option<&[f64]>,
    ) -> Result<(), LiveError> {
        if self
            .last_static
            .is_none_or(|t| t.elapsed() >= STATIC_PERIOD)
        {
            for (c, data) in self
                .stream
                .static_messages(time_ns)
                .map_err(|e| LiveError::View(e.to_string()))?
            {
                self.channels[c as usize].log(&data);
            }
            self.last_static = Some(Instant::now());
        }
        let mut joints: Vec<&[f64]> = Vec::with_capacity(robots.len() + 1);
        joints.push(human);
        joints.extend(robots.iter().map(|r| r.0));
        let mut arrays: Vec<&[f64]> = Vec::with_capacity(2 * robots.len() + 1);
        for r in robots {
            arrays.push(r.1);
            arrays.push(&r.2);
        }
        arrays.push(latent.unwrap_or(&self.no_latent));
        let messages = self
            .stream
            .frame(time_ns, &joints, &arrays)
            .map_err(|e| LiveError::View(e.to_string()))?;
        for (c, data) in messages {
            self.channels[*c as usize].log(data);
        }
        Ok(())
    }
}

impl Drop for LiveView {
    fn drop(&mut self) {
        if let Some(server) = self.server.take() {
            server.stop().wait_blocking();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::net::TcpStream;
    use tungstenite::client::IntoClientRequest;
    use tungstenite::stream::MaybeTlsStream;
    use tungstenite::{Message, WebSocket};

    /// A URDF file with one mesh beside it, in a fresh folder: (URDF path, mesh path).
    fn robot_with_a_mesh() -> (PathBuf, PathBuf) {
        let dir = std::env::temp_dir().join(format!("sgplvm-view-assets-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("meshes")).unwrap();
        let mesh = dir.join("meshes/arm.stl");
        std::fs::write(&mesh, "solid arm\nendsolid arm\n").unwrap();
        let urdf = dir.join("arm.urdf");
        std::fs::write(
            &urdf,
            r#"<robot name="arm"><link name="base"/>
              <link name="arm"><visual><geometry><mesh filename="meshes/arm.stl"/></geometry></visual></link>
              <joint name="j" type="revolute"><parent link="base"/><child link="arm"/>
                <axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
            </robot>"#,
        )
        .unwrap();
        (urdf, std::fs::canonicalize(mesh).unwrap())
    }

    /// Asks for `uri` and returns (status, error message or data) of the answer.
    fn fetch_over(
        ws: &mut WebSocket<MaybeTlsStream<TcpStream>>,
        uri: &str,
        id: u32,
    ) -> (u8, Vec<u8>) {
        let request = serde_json::json!({"op": "fetchAsset", "uri": uri, "requestId": id});
        ws.send(Message::text(request.to_string())).unwrap();
        loop {
            if let Message::Binary(data) = ws.read().unwrap() {
                // opcode 4, request id, status, error length, error, data.
                if data[0] == 4 && u32::from_le_bytes(data[1..5].try_into().unwrap()) == id {
                    let status = data[5];
                    let len = u32::from_le_bytes(data[6..10].try_into().unwrap()) as usize;
                    let body = if status == 0 {
                        data[10 + len..].to_vec()
                    } else {
                        data[10..10 + len].to_vec()
                    };
                    return (status, body);
                }
            }
        }
    }

    #[test]
    fn the_view_serves_the_meshes_of_its_robots_and_nothing_else() {
        let (urdf, mesh) = robot_with_a_mesh();
        let robot = Robot::from_urdf_file(&urdf).unwrap();
        let human = Robot::builtin("human").unwrap().joint_names();
        let robots = vec![ViewRobot {
            name: "arm".into(),
            body: robot,
            joints: vec!["j".into()],
            rest: vec![0.0],
        }];
        let view = LiveView::start("127.0.0.1:0".parse().unwrap(), human, robots, 2).unwrap();
        let mut request = format!("ws://127.0.0.1:{}", view.port())
            .into_client_request()
            .unwrap();
        request
            .headers_mut()
            .insert("Sec-WebSocket-Protocol", "foxglove.sdk.v1".parse().unwrap());
        let (mut ws, _) = tungstenite::connect(request).unwrap();
        // The server says it serves assets.
        let info = loop {
            if let Message::Text(text) = ws.read().unwrap() {
                if text.contains("\"serverInfo\"") {
                    break text.to_string();
                }
            }
        };
        assert!(info.contains("\"assets\""), "{info}");
        let content = std::fs::read(&mesh).unwrap();
        let file = sgplvm_robots::urdf::file_uri(&mesh);
        assert_eq!(fetch_over(&mut ws, &file, 1), (0, content.clone()));
        assert_eq!(fetch_over(&mut ws, "meshes/arm.stl", 2), (0, content));
        let (status, message) = fetch_over(&mut ws, "file:///etc/passwd", 3);
        assert_eq!(status, 1);
        assert!(String::from_utf8_lossy(&message).contains("not a mesh"));
        drop(ws);
        drop(view);
        std::fs::remove_dir_all(urdf.parent().unwrap()).unwrap();
    }
}
