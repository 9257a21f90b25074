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
#[cfg(test)]
pub(crate) mod test_frames {
    use controller_core::kinematics::Pose;
    use controller_core::supervisor::{RunMode, State};
    use link::TelemetryFrame;

    /// A disarmed robot at rest at the origin, at control step `step`.
    pub fn still(step: u32) -> TelemetryFrame {
        TelemetryFrame {
            step,
            state: State::Disarmed,
            run_mode: RunMode::FollowPath,
            faults: Default::default(),
            pose: Pose::new(0.0, 0.0, 0.0),
            tracking_error: Default::default(),
            lyapunov: 0.0,
            lyapunov_rate: 0.0,
            wheel_setpoint: Default::default(),
            wheel_speed: Default::default(),
            duty: controller_core::controller::MotorCommand::STOP,
            pid_left: Default::default(),
            pid_right: Default::default(),
            supply_v: 6.0,
            missed_ticks: 0,
            gyro_yaw_rate_radps: 0.0,
            gyro_bias_radps: 0.0,
            fused_heading_rad: 0.0,
            odometry_heading_rad: 0.0,
            gyro_health: Default::default(),
            raw_counts: Default::default(),
        }
    }
}
