//! `station ros2`: the robot (serial) or the virtual robot (TCP) as a ROS 2 node, in pure
//! Rust on RustDDS (ros2-client): no ROS installation, no C library.
//!
//! | module | what it is |
//! |---|---|
//! | [`messages`] | the ROS 2 messages, as serde structs in `.msg` order |
//! | [`topics`] | the node: participant, topics and QoS, parameter services |
//! | [`parameters`] | the parameters, named as diff_drive_controller's; the robot's read from it and written back |
//! | [`path_simplify`] | a nav_msgs/Path as at most 16 filleted waypoints within a tolerance |
//! | [`odometry`] | telemetry as `odom`, `tf` and `joint_states` |
//! | [`diagnostics`] | the link, the robot's state and faults, refused commands |
//! | [`connection`] | the link to the robot: connect, heartbeats, velocity mode, paths, reconnecting |
//! | [`bridge`] | the loop between the two |

pub mod bridge;
pub mod connection;
pub mod diagnostics;
pub mod messages;
pub mod odometry;
pub mod parameters;
pub mod path_simplify;
pub mod topics;
