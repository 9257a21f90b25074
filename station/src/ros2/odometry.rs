//! The robot's telemetry as ROS 2 sees a diff-drive base: `odom` (nav_msgs/Odometry),
//! the `tf` transform odom → base_link, and `joint_states` for the two wheels.
//!
//! The pose is the robot's own odometry (its world frame is ROS 2's `odom` frame), the
//! twist is the body velocity of the measured wheel speeds (v = (R_r·ω_r + R_l·ω_l)/2,
//! ω = (R_r·ω_r − R_l·ω_l)/L, in base_link), and the wheels' positions are their
//! measured speeds integrated over the robot's control steps between samples (the
//! telemetry carries speeds, not angles), so they start at 0 when the bridge starts.

use controller_core::params::RobotConfig;
use link::TelemetryFrame;
use ros2_client::builtin_interfaces::Time;

use super::messages::{
    Covariance, Header, JointState, Odometry, Point, Pose, PoseWithCovariance, Quaternion,
    TfMessage, Transform, TransformStamped, Twist, TwistWithCovariance, Vector3,
};

/// What the messages are named and how uncertain they say they are (the bridge's
/// parameters of the same names).
#[derive(Clone, Debug, PartialEq)]
pub struct OdometryFrames {
    /// The odometry's frame (`odom_frame_id`, `odom`).
    pub odom_frame_id: String,
    /// The robot's frame (`base_frame_id`, `base_link`).
    pub base_frame_id: String,
    /// The wheels' joint names (`left_wheel_names[0]`, `right_wheel_names[0]`).
    pub wheel_joint_names: [String; 2],
    /// Diagonal of the pose's covariance (x, y, z, roll, pitch, yaw), m² and rad².
    pub pose_covariance_diagonal: [f64; 6],
    /// Diagonal of the twist's covariance, (m/s)² and (rad/s)².
    pub twist_covariance_diagonal: [f64; 6],
}

impl Default for OdometryFrames {
    /// diff_drive_controller's names, and its example's covariances.
    fn default() -> Self {
        Self {
            odom_frame_id: "odom".into(),
            base_frame_id: "base_link".into(),
            wheel_joint_names: ["left_wheel_joint".into(), "right_wheel_joint".into()],
            pose_covariance_diagonal: [0.001, 0.001, 0.001, 0.001, 0.001, 0.01],
            twist_covariance_diagonal: [0.001, 0.001, 0.001, 0.001, 0.001, 0.01],
        }
    }
}

/// The wheels' angles, rad, integrated from the measured speeds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WheelAngles {
    last_step: Option<u32>,
    /// Left wheel, rad (forward positive).
    pub left_rad: f64,
    /// Right wheel, rad.
    pub right_rad: f64,
}

impl WheelAngles {
    /// Advances by `frame`'s wheel speeds over the control steps since the last frame
    /// (none for the first), at `control_rate_hz`.
    pub fn advance(&mut self, frame: &TelemetryFrame, control_rate_hz: u32) {
        if let Some(last) = self.last_step {
            let dt_s = f64::from(frame.step.wrapping_sub(last)) / f64::from(control_rate_hz.max(1));
            self.left_rad += f64::from(frame.wheel_speed.left_rad_s) * dt_s;
            self.right_rad += f64::from(frame.wheel_speed.right_rad_s) * dt_s;
        }
        self.last_step = Some(frame.step);
    }
}

/// The body velocity (v m/s, ω rad/s) of `frame`'s measured wheel speeds on `robot`.
pub fn body_velocity(frame: &TelemetryFrame, robot: &RobotConfig) -> (f64, f64) {
    let left = f64::from(robot.wheel_radius_left_m) * f64::from(frame.wheel_speed.left_rad_s);
    let right = f64::from(robot.wheel_radius_right_m) * f64::from(frame.wheel_speed.right_rad_s);
    let track = f64::from(robot.track_width_m);
    ((right + left) / 2.0, (right - left) / track)
}

/// `odom` for `frame`, stamped `stamp`.
pub fn odometry(
    frame: &TelemetryFrame,
    robot: &RobotConfig,
    frames: &OdometryFrames,
    stamp: Time,
) -> Odometry {
    let (v, omega) = body_velocity(frame, robot);
    Odometry {
        header: Header {
            stamp,
            frame_id: frames.odom_frame_id.clone(),
        },
        child_frame_id: frames.base_frame_id.clone(),
        pose: PoseWithCovariance {
            pose: pose(frame),
            covariance: Covariance::from_diagonal(frames.pose_covariance_diagonal),
        },
        twist: TwistWithCovariance {
            twist: Twist {
                linear: Vector3 {
                    x: v,
                    ..Vector3::default()
                },
                angular: Vector3 {
                    z: omega,
                    ..Vector3::default()
                },
            },
            covariance: Covariance::from_diagonal(frames.twist_covariance_diagonal),
        },
    }
}

/// The robot's pose in `frame`, as a ROS 2 pose (z = 0, yaw only).
fn pose(frame: &TelemetryFrame) -> Pose {
    Pose {
        position: Point {
            x: f64::from(frame.pose.x_m),
            y: f64::from(frame.pose.y_m),
            z: 0.0,
        },
        orientation: Quaternion::from_yaw(f64::from(frame.pose.theta_rad)),
    }
}

/// `tf` for `frame`: base_link in odom.
pub fn transform(frame: &TelemetryFrame, frames: &OdometryFrames, stamp: Time) -> TfMessage {
    let pose = pose(frame);
    TfMessage {
        transforms: vec![TransformStamped {
            header: Header {
                stamp,
                frame_id: frames.odom_frame_id.clone(),
            },
            child_frame_id: frames.base_frame_id.clone(),
            transform: Transform {
                translation: Vector3 {
                    x: pose.position.x,
                    y: pose.position.y,
                    z: 0.0,
                },
                rotation: pose.orientation,
            },
        }],
    }
}

/// `joint_states` for the wheels at `angles` and `frame`'s speeds.
pub fn joint_states(
    frame: &TelemetryFrame,
    angles: &WheelAngles,
    frames: &OdometryFrames,
    stamp: Time,
) -> JointState {
    JointState {
        header: Header {
            stamp,
            frame_id: frames.base_frame_id.clone(),
        },
        name: frames.wheel_joint_names.to_vec(),
        position: vec![angles.left_rad, angles.right_rad],
        velocity: vec![
            f64::from(frame.wheel_speed.left_rad_s),
            f64::from(frame.wheel_speed.right_rad_s),
        ],
        effort: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller_core::kinematics::{Pose as RobotPose, WheelSpeeds};

    fn frame(step: u32, left: f32, right: f32) -> TelemetryFrame {
        let mut frame = crate::test_frames::still(step);
        frame.wheel_speed = WheelSpeeds::new(left, right);
        frame.pose = RobotPose::new(1.5, -0.25, 2.0);
        frame
    }

    #[test]
    fn a_left_turn_in_place_has_positive_yaw_rate_and_no_speed() {
        let robot = RobotConfig::REFERENCE_ROBOT;
        let (v, omega) = body_velocity(&frame(0, -2.0, 2.0), &robot);
        assert!(v.abs() < 1e-9);
        let expected = 4.0 * f64::from(robot.wheel_radius_left_m) / f64::from(robot.track_width_m);
        assert!((omega - expected).abs() < 1e-6, "{omega} vs {expected}");
        let (v, omega) = body_velocity(&frame(0, 3.0, 3.0), &robot);
        assert!(v > 0.0 && omega.abs() < 1e-9);
    }

    #[test]
    fn odometry_carries_the_robots_pose_and_frames() {
        let robot = RobotConfig::REFERENCE_ROBOT;
        let frames = OdometryFrames::default();
        let odom = odometry(&frame(7, 1.0, 1.0), &robot, &frames, Time::ZERO);
        assert_eq!(odom.header.frame_id, "odom");
        assert_eq!(odom.child_frame_id, "base_link");
        assert_eq!(odom.pose.pose.position.x, 1.5);
        assert_eq!(odom.pose.pose.position.y, -0.25);
        assert!((odom.pose.pose.orientation.yaw_rad() - 2.0).abs() < 1e-6);
        assert_eq!(odom.pose.covariance.0[35], 0.01);
        assert_eq!(odom.pose.covariance.0[1], 0.0);
        let tf = transform(&frame(7, 1.0, 1.0), &frames, Time::ZERO);
        assert_eq!(tf.transforms[0].transform.translation.x, 1.5);
        assert_eq!(tf.transforms[0].child_frame_id, "base_link");
    }

    #[test]
    fn wheel_angles_integrate_the_speeds_over_the_robots_steps() {
        let mut angles = WheelAngles::default();
        angles.advance(&frame(1000, 2.0, -1.0), 1000);
        assert_eq!((angles.left_rad, angles.right_rad), (0.0, 0.0));
        // 500 steps at 1 kHz: 0.5 s.
        angles.advance(&frame(1500, 2.0, -1.0), 1000);
        assert!((angles.left_rad - 1.0).abs() < 1e-9);
        assert!((angles.right_rad + 0.5).abs() < 1e-9);
        // The step counter wraps.
        let mut angles = WheelAngles::default();
        angles.advance(&frame(u32::MAX, 1.0, 1.0), 1000);
        angles.advance(&frame(999, 1.0, 1.0), 1000);
        assert!((angles.left_rad - 1.0).abs() < 1e-9);
    }
}
