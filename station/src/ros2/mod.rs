//! `station ros2`: the robot as a ROS 2 node, on RustDDS (no ROS installation).

pub mod messages;
pub mod path_simplify;
