//! The node's DDS plumbing: QoS profiles, ROS 2 names, the participant, and the publisher of
//! each command form.

use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::dds::{Context, ContextOptions, Node, Publisher};
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::{MessageTypeName, Name, NodeName, NodeOptions, QosProfile};

use super::Reliability;
use crate::commands::{Command, CommandForm};
use crate::msgs::JointState;
use crate::LiveError;

/// A publisher of one command form.
pub(super) enum CommandPublisher {
    JointState(Publisher<JointState>),
    Forward(Publisher<crate::msgs::Float64MultiArray>),
    Trajectory(Publisher<crate::msgs::JointTrajectory>),
    Xbot(Publisher<crate::msgs::XbotJointCommand>),
}

impl CommandPublisher {
    pub(super) fn publish(&self, c: Command, topic: &str) -> Result<(), LiveError> {
        let fail = |e: String| LiveError::Publish {
            topic: topic.to_string(),
            message: e,
        };
        match (self, c) {
            (CommandPublisher::JointState(p), Command::JointState(m)) => {
                p.publish(m).map_err(|e| fail(format!("{e:?}")))
            }
            (CommandPublisher::Forward(p), Command::Forward(m)) => {
                p.publish(m).map_err(|e| fail(format!("{e:?}")))
            }
            (CommandPublisher::Trajectory(p), Command::Trajectory(m)) => {
                p.publish(m).map_err(|e| fail(format!("{e:?}")))
            }
            (CommandPublisher::Xbot(p), Command::Xbot(m)) => {
                p.publish(m).map_err(|e| fail(format!("{e:?}")))
            }
            _ => Err(fail("a command of another form".into())),
        }
    }
}

/// The QoS profile of `r`.
pub(crate) fn qos(r: Reliability) -> QosProfile {
    match r {
        Reliability::BestEffort => QosProfile::subscription_default()
            .reliability_best_effort()
            .durability(Durability::Volatile)
            .history(History::KeepLast { depth: 1 }),
        Reliability::Reliable => QosProfile::publisher_default()
            .reliability_reliable(WhenFull::DEFAULT)
            .durability(Durability::Volatile)
            .history(History::KeepLast { depth: 10 }),
    }
}

/// A ROS 2 name from an absolute or relative topic name.
pub(crate) fn topic_name(topic: &str) -> Result<Name, LiveError> {
    let t = topic.trim_start_matches('/');
    let (ns, base) = match t.rsplit_once('/') {
        Some((ns, base)) => (format!("/{ns}"), base),
        None => ("/".to_string(), t),
    };
    Name::new(&ns, base).map_err(|e| LiveError::Name {
        name: topic.to_string(),
        message: format!("{e:?}"),
    })
}

/// A ROS 2 node with the given name.
pub(crate) fn new_node(domain_id: u16, name: &str) -> Result<Node, LiveError> {
    new_node_on(domain_id, name, &[])
}

/// A ROS 2 node with the given name whose participant uses only the network interfaces of
/// `interfaces` (their addresses) for multicast and announces only them in discovery; all of
/// them when empty. Each must be an address of this machine.
pub(crate) fn new_node_on(
    domain_id: u16,
    name: &str,
    interfaces: &[std::net::IpAddr],
) -> Result<Node, LiveError> {
    let dds = |e: String| LiveError::Dds { message: e };
    for ip in interfaces {
        // Binding is allowed only to an address of this machine.
        std::net::UdpSocket::bind((*ip, 0)).map_err(|e| {
            LiveError::Config(format!(
                "--dds-interface {ip}: not an address of this machine's network interfaces ({e})"
            ))
        })?;
    }
    let context = if interfaces.is_empty() {
        Context::with_options(ContextOptions::new().domain_id(domain_id))
            .map_err(|e| dds(format!("{e:?}")))?
    } else {
        let participant = DomainParticipantBuilder::new(domain_id)
            .with_only_networks(interfaces.iter().copied())
            .build()
            .map_err(|e| dds(format!("{e:?}")))?;
        Context::from_domain_participant(participant).map_err(|e| dds(format!("{e:?}")))?
    };
    let node_name = NodeName::new("/", name).map_err(|e| dds(format!("{e:?}")))?;
    context
        .new_node(node_name, NodeOptions::new().enable_rosout(false))
        .map_err(|e| dds(format!("{e:?}")))
}

/// The error of a DDS call.
pub(super) fn dds(e: String) -> LiveError {
    LiveError::Dds { message: e }
}

/// The message type name of a `(package, name)` pair of [`crate::msgs::types`].
pub(super) fn type_of((pkg, name): (&str, &str)) -> MessageTypeName {
    MessageTypeName::new(pkg, name)
}

/// The publisher of `form`'s commands on `topic`, with the given QoS.
pub(super) fn command_publisher(
    node: &mut Node,
    topic: &str,
    form: CommandForm,
    reliability: Reliability,
) -> Result<CommandPublisher, LiveError> {
    let t = node
        .create_topic(
            &topic_name(topic)?,
            type_of(form.type_name()),
            &qos(reliability),
        )
        .map_err(|e| dds(format!("{e:?}")))?;
    let q = Some(qos(reliability));
    Ok(match form {
        CommandForm::JointState => CommandPublisher::JointState(
            node.create_publisher(&t, q)
                .map_err(|e| dds(format!("{e:?}")))?,
        ),
        CommandForm::Forward => CommandPublisher::Forward(
            node.create_publisher(&t, q)
                .map_err(|e| dds(format!("{e:?}")))?,
        ),
        CommandForm::Trajectory => CommandPublisher::Trajectory(
            node.create_publisher(&t, q)
                .map_err(|e| dds(format!("{e:?}")))?,
        ),
        CommandForm::Xbot => CommandPublisher::Xbot(
            node.create_publisher(&t, q)
                .map_err(|e| dds(format!("{e:?}")))?,
        ),
    })
}
