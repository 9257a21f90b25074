//! The bridge's ROS 2 node: its DDS participant, its topics and their QoS, and its
//! parameter services.
//!
//! | topic | type | direction |
//! |---|---|---|
//! | `cmd_vel` | geometry_msgs/Twist (TwistStamped with `use_stamped_vel`) | to the robot |
//! | `path` | nav_msgs/Path | to the robot |
//! | `set_pose` | geometry_msgs/PoseWithCovarianceStamped | to the robot |
//! | `odom` | nav_msgs/Odometry | from the robot |
//! | `tf` | tf2_msgs/TFMessage | from the robot |
//! | `joint_states` | sensor_msgs/JointState | from the robot |
//! | `diagnostics` | diagnostic_msgs/DiagnosticArray | from the bridge |
//!
//! Every topic is reliable, volatile, keep-last 10: ROS 2's default profile, which
//! `ros2 topic pub`, teleop and nav2 use for these. The participant is RustDDS's with its
//! defaults: unicast discovery to the local participants on 127.0.0.1 besides
//! multicast, so peers on the same host find it without multicast.

use std::sync::mpsc::{channel, Receiver};

use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::qos::{Durability, History, WhenFull};
use ros2_client::{
    Context, MessageTypeName, Name, Node, NodeName, NodeOptions, ParameterValue, Publisher,
    QosProfile, Subscription,
};
use serde::de::DeserializeOwned;
use serde::Serialize;

use super::messages::{
    DiagnosticArray, JointState, MessageType, Odometry, Path, PoseWithCovarianceStamped, TfMessage,
    Twist, TwistStamped,
};

/// Why the node could not be made.
#[derive(Debug, thiserror::Error)]
pub enum NodeError {
    /// RustDDS or ros2-client refused (sockets, names).
    #[error("cannot create the ROS 2 node: {0}")]
    Create(String),
}

fn create(e: impl core::fmt::Debug) -> NodeError {
    NodeError::Create(format!("{e:?}"))
}

/// `cmd_vel`, of the type chosen at start.
pub enum CommandSubscription {
    /// geometry_msgs/Twist.
    Twist(Subscription<Twist>),
    /// geometry_msgs/TwistStamped.
    Stamped(Subscription<TwistStamped>),
}

impl CommandSubscription {
    /// The commands that arrived since the last call, oldest first.
    pub fn take_all(&self) -> Vec<Twist> {
        let mut out = Vec::new();
        match self {
            CommandSubscription::Twist(s) => {
                while let Ok(Some((twist, _))) = s.take() {
                    out.push(twist);
                }
            }
            CommandSubscription::Stamped(s) => {
                while let Ok(Some((stamped, _))) = s.take() {
                    out.push(stamped.twist);
                }
            }
        }
        out
    }
}

/// The node's publishers and subscriptions.
pub struct Topics {
    /// `odom`.
    pub odom: Publisher<Odometry>,
    /// `tf`.
    pub tf: Publisher<TfMessage>,
    /// `joint_states`.
    pub joint_states: Publisher<JointState>,
    /// `diagnostics`.
    pub diagnostics: Publisher<DiagnosticArray>,
    /// `cmd_vel`.
    pub cmd_vel: CommandSubscription,
    /// `path`.
    pub path: Subscription<Path>,
    /// `set_pose`.
    pub set_pose: Subscription<PoseWithCovarianceStamped>,
}

/// ROS 2's default profile: reliable, volatile, keep-last 10.
fn default_qos() -> QosProfile {
    QosProfile::publisher_default()
        .reliability_reliable(WhenFull::DEFAULT)
        .durability(Durability::Volatile)
        .history(History::KeepLast { depth: 10 })
}

/// The check a parameter change passes before it is accepted: `Err` is the answer to
/// whoever set it.
pub type ParameterCheck = dyn Fn(&str, &ParameterValue) -> Result<(), String> + Send + Sync;

/// A parameter set through the node (its services, or the bridge itself).
#[derive(Clone, Debug, PartialEq)]
pub struct ParameterChange {
    /// The parameter.
    pub name: String,
    /// Its new value.
    pub value: ParameterValue,
}

/// The node, its topics, and the parameter changes it receives.
pub struct BridgeNode {
    /// The node (its parameters: [`Node::get_parameter`], [`Node::set_parameter`]).
    pub node: Node,
    /// The topics.
    pub topics: Topics,
    /// Each accepted parameter change, as it was made.
    pub changes: Receiver<ParameterChange>,
}

/// The node `name` on DDS domain `domain_id`, with `parameters` declared, each change
/// checked by `validate` (its error is the answer to the setter) before it is accepted;
/// `cmd_vel` stamped or not. Its parameter services run on a thread of their own.
pub fn create_node(
    domain_id: u16,
    name: &str,
    parameters: &[(String, ParameterValue)],
    validate: Box<ParameterCheck>,
    stamped_cmd_vel: bool,
) -> Result<BridgeNode, NodeError> {
    let participant = DomainParticipantBuilder::new(domain_id)
        .build()
        .map_err(create)?;
    let context = Context::from_domain_participant(participant).map_err(create)?;
    let (sender, changes) = channel();
    let mut options = NodeOptions::new()
        .enable_rosout(false)
        .parameter_validator(validate)
        .parameter_set_action(Box::new(move |name, value| {
            // The receiver lives as long as the bridge; a change after it is gone is moot.
            let _ = sender.send(ParameterChange {
                name: name.to_string(),
                value: value.clone(),
            });
            Ok(())
        }));
    for (name, value) in parameters {
        options = options.declare_parameter(name, value.clone());
    }
    let mut node = context
        .new_node(NodeName::new("/", name).map_err(create)?, options)
        .map_err(create)?;
    let spinner = node.spinner().map_err(create)?;
    std::thread::Builder::new()
        .name("ros2-parameters".into())
        .spawn(move || futures::executor::block_on(spinner.spin()))
        .map_err(create)?;
    let topics = Topics {
        odom: publisher(&mut node, "odom")?,
        tf: publisher(&mut node, "tf")?,
        joint_states: publisher(&mut node, "joint_states")?,
        diagnostics: publisher(&mut node, "diagnostics")?,
        cmd_vel: if stamped_cmd_vel {
            CommandSubscription::Stamped(subscription(&mut node, "cmd_vel")?)
        } else {
            CommandSubscription::Twist(subscription(&mut node, "cmd_vel")?)
        },
        path: subscription(&mut node, "path")?,
        set_pose: subscription(&mut node, "set_pose")?,
    };
    Ok(BridgeNode {
        node,
        topics,
        changes,
    })
}

fn topic<M: MessageType>(
    node: &mut Node,
    name: &str,
) -> Result<ros2_client::dds::rustdds::Topic, NodeError> {
    node.create_topic(
        &Name::new("/", name).map_err(create)?,
        MessageTypeName::new(M::PACKAGE, M::NAME),
        &default_qos(),
    )
    .map_err(create)
}

fn publisher<M: MessageType + Serialize>(
    node: &mut Node,
    name: &str,
) -> Result<Publisher<M>, NodeError> {
    let topic = topic::<M>(node, name)?;
    node.create_publisher(&topic, None).map_err(create)
}

fn subscription<M: MessageType + DeserializeOwned + 'static>(
    node: &mut Node,
    name: &str,
) -> Result<Subscription<M>, NodeError> {
    let topic = topic::<M>(node, name)?;
    node.create_subscription(&topic, None).map_err(create)
}
