//! The live view: a Foxglove WebSocket server (the Foxglove SDK, `foxglove.sdk.v1`) serving
//! the human and each robot as `sgplvm predict`'s scene files hold them — the same topics,
//! schemas and CDR messages ([`sgplvm_robots::scene::SceneStream`]) — so that the layout that
//! opens those files (`data/foxglove/sgplvm.json`) shows the live node too.
//!
//! Topics: `/human/joint_states` and each `/ROBOT/joint_command` (the command as sent), each
//! body's `/NAME/robot_description` (its URDF) and `/tf_static` (sent again every second, for
//! viewers that join later: a WebSocket has no latched topics), `/tf` at the input rate,
//! `/ROBOT/prediction_std` (the predictive standard deviation per joint), `/latent` (the
//! latent point) and `/ROBOT/trust` (`[sd, threshold, state]`, state 0 following, 1 holding,
//! 2 moving to the last trusted target, 3 stale input, 4 waiting for a first trusted frame).

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::{Duration, Instant};

use foxglove::{
    ChannelBuilder, Context, RawChannel, Schema, WebSocketServer, WebSocketServerHandle,
};
use nalgebra::{Isometry3, Translation3, UnitQuaternion};
use sgplvm_robots::scene::{ArrayTopic, SceneBody, SceneOptions, SceneStream};
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
}

/// A running live view.
pub struct LiveView {
    server: Option<WebSocketServerHandle>,
    channels: Vec<Arc<RawChannel>>,
    stream: SceneStream,
    last_static: Option<Instant>,
    port: u16,
    _context: Arc<Context>,
}

fn placed(name: &str, robot: Robot, topic: String, y: f64) -> SceneBody {
    SceneBody {
        name: name.to_string(),
        robot,
        placement: Isometry3::from_parts(
            Translation3::new(0.0, y, 0.0),
            UnitQuaternion::identity(),
        ),
        joint_topic: topic,
    }
}

impl LiveView {
    /// Starts the server on `addr` (port 0: any free port) for the human (`human_joints`, the
    /// model's human columns) and `robots`, with a latent space of `latent_dim` dimensions.
    pub fn start(
        addr: SocketAddr,
        human_joints: Vec<String>,
        robots: Vec<ViewRobot>,
        latent_dim: usize,
    ) -> Result<LiveView, LiveError> {
        let human = Robot::builtin("human").map_err(|e| LiveError::Config(e.to_string()))?;
        // The human at y = +0.6 m, the robots at −0.6 m, −1.5 m, … (as predict's scenes).
        let mut bodies = vec![(
            placed("human", human, "/human/joint_states".into(), 0.6),
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
                "sd, threshold, state",
                3,
            ));
            let topic = format!("/{}/joint_command", r.name);
            bodies.push((
                placed(&r.name, r.body, topic, -0.6 - 0.9 * k as f64),
                r.joints,
            ));
        }
        arrays.push(ArrayTopic::float64("/latent", "latent", latent_dim));
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
        let server = WebSocketServer::new()
            .name("sgplvm teleop")
            .bind(addr.ip().to_string(), addr.port())
            .context(&context)
            .start_blocking()
            .map_err(|e| LiveError::View(format!("cannot serve on {addr}: {e}")))?;
        let port = server.port();
        Ok(LiveView {
            server: Some(server),
            channels,
            stream,
            last_static: None,
            port,
            _context: context,
        })
    }

    /// The port the server listens on.
    pub fn port(&self) -> u16 {
        self.port
    }

    /// Sends one frame: the human's joints, each robot's command, and per robot its standard
    /// deviations and trust (`[sd, threshold, state]`), then the latent point.
    pub fn frame(
        &mut self,
        time_ns: i64,
        human: &[f64],
        robots: &[(&[f64], &[f64], [f64; 3])],
        latent: &[f64],
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
        arrays.push(latent);
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
