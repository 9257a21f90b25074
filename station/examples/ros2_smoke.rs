//! Smoke test of RustDDS against another DDS: publishes `odom` at 10 Hz (x counts the
//! samples) and prints every `cmd_vel` it receives, for `--seconds` (default 10).

use std::time::{Duration, Instant};

use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::{Context, MessageTypeName, Name, NodeName, NodeOptions, QosProfile};
use station::ros2::messages::{self, MessageType};

fn main() -> anyhow::Result<()> {
    let seconds: u64 = std::env::args().nth(1).map_or(Ok(10), |s| s.parse())?;
    let domain: u16 = std::env::var("ROS_DOMAIN_ID").map_or(Ok(0), |s| s.parse())?;
    let participant = DomainParticipantBuilder::new(domain).build()?;
    let context = Context::from_domain_participant(participant)?;
    let mut node = context.new_node(NodeName::new("/", "smoke")?, NodeOptions::new())?;
    let qos = QosProfile::publisher_default();
    let odom_topic = node.create_topic(
        &Name::new("/", "odom")?,
        MessageTypeName::new(messages::Odometry::PACKAGE, messages::Odometry::NAME),
        &qos,
    )?;
    let cmd_topic = node.create_topic(
        &Name::new("/", "cmd_vel")?,
        MessageTypeName::new(messages::Twist::PACKAGE, messages::Twist::NAME),
        &qos,
    )?;
    let odom = node.create_publisher::<messages::Odometry>(&odom_topic, None)?;
    let cmd = node.create_subscription::<messages::Twist>(&cmd_topic, None)?;
    let end = Instant::now() + Duration::from_secs(seconds);
    let mut sent = 0u32;
    let mut received = 0u32;
    while Instant::now() < end {
        while let Some((twist, _)) = cmd.take()? {
            received += 1;
            println!(
                "cmd_vel {received}: v {} w {}",
                twist.linear.x, twist.angular.z
            );
        }
        sent += 1;
        let mut message = messages::Odometry {
            header: messages::Header {
                stamp: ros2_client::builtin_interfaces::Time::now(),
                frame_id: "odom".into(),
            },
            child_frame_id: "base_link".into(),
            pose: Default::default(),
            twist: Default::default(),
        };
        message.pose.pose.position.x = f64::from(sent);
        odom.publish(message)
            .map_err(|e| anyhow::anyhow!("{e:?}"))?;
        std::thread::sleep(Duration::from_millis(100));
    }
    println!("sent {sent} odom, received {received} cmd_vel");
    Ok(())
}
