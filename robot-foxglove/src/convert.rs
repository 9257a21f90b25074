//! A sample of a run ([`TraceRow`], the row `trace.csv` is printed from, with its
//! [`SampleDetail`](robot_files::trace::SampleDetail)) as the messages of each channel.
//! Poses are widened to `f64` exactly, so a reader finds `trace.csv`'s digits.

use controller_core::prelude::Pose;
use foxglove::messages::{FrameTransform, PoseInFrame, Quaternion, Timestamp, Vector3};
use robot_files::trace::TraceRow;
use robot_files::truth::TruePose;

use crate::messages::{
    BodyMessage, BodyVelocityMessage, ErrorsMessage, SupervisorMessage, TrackingErrorMessage,
    WheelMessage, WheelsMessage,
};
use crate::topics::WORLD_FRAME;

/// A planar pose in `f64`: x, y (m) and heading (rad), world frame.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlanarPose {
    /// x, m.
    pub x_m: f64,
    /// y, m.
    pub y_m: f64,
    /// Heading, rad, counter-clockwise from x.
    pub theta_rad: f64,
}

impl PlanarPose {
    /// True when every coordinate is a finite number (the truth of a real robot is NaN).
    pub fn is_finite(&self) -> bool {
        self.x_m.is_finite() && self.y_m.is_finite() && self.theta_rad.is_finite()
    }

    /// The heading as a rotation about z.
    pub fn rotation(&self) -> Quaternion {
        let half = 0.5 * self.theta_rad;
        Quaternion {
            x: 0.0,
            y: 0.0,
            z: half.sin(),
            w: half.cos(),
        }
    }

    /// The position, z = 0.
    pub fn translation(&self) -> Vector3 {
        Vector3 {
            x: self.x_m,
            y: self.y_m,
            z: 0.0,
        }
    }
}

impl From<Pose> for PlanarPose {
    fn from(p: Pose) -> Self {
        Self {
            x_m: f64::from(p.x_m),
            y_m: f64::from(p.y_m),
            theta_rad: f64::from(p.theta_rad),
        }
    }
}

impl From<TruePose> for PlanarPose {
    fn from(p: TruePose) -> Self {
        Self {
            x_m: p.x_m,
            y_m: p.y_m,
            theta_rad: p.theta_rad,
        }
    }
}

/// Nanoseconds of a sample at `t_s` seconds of the run (simulated or the robot's own
/// step clock): the log time of its messages. Negative or non-finite times are 0.
pub fn log_time_ns(t_s: f64) -> u64 {
    if t_s.is_finite() && t_s > 0.0 {
        (t_s * 1e9).round() as u64
    } else {
        0
    }
}

/// The message timestamp of a sample at `t_s` seconds.
pub fn timestamp(t_s: f64) -> Timestamp {
    let ns = log_time_ns(t_s);
    Timestamp::new(
        u32::try_from(ns / 1_000_000_000).unwrap_or(u32::MAX),
        (ns % 1_000_000_000) as u32,
    )
}

/// `pose` as a `PoseInFrame` in the world frame at `t_s`.
pub fn pose_in_frame(t_s: f64, pose: PlanarPose) -> PoseInFrame {
    PoseInFrame {
        timestamp: Some(timestamp(t_s)),
        frame_id: WORLD_FRAME.to_string(),
        pose: Some(foxglove::messages::Pose {
            position: Some(pose.translation()),
            orientation: Some(pose.rotation()),
        }),
    }
}

/// The transform from the world frame to `child` at `t_s`: `child`'s origin at `pose`.
pub fn frame_transform(t_s: f64, child: &str, pose: PlanarPose) -> FrameTransform {
    FrameTransform {
        timestamp: Some(timestamp(t_s)),
        parent_frame_id: WORLD_FRAME.to_string(),
        child_frame_id: child.to_string(),
        translation: Some(pose.translation()),
        rotation: Some(pose.rotation()),
    }
}

/// `/errors` of `row`.
pub fn errors(row: &TraceRow) -> ErrorsMessage {
    let f = f64::from;
    ErrorsMessage {
        estimated: TrackingErrorMessage {
            x_e_m: f(row.error.x_e_m),
            y_e_m: f(row.error.y_e_m),
            theta_e_rad: f(row.error.theta_e_rad),
        },
        truth: TrackingErrorMessage {
            x_e_m: row.true_tracking[0],
            y_e_m: row.true_tracking[1],
            theta_e_rad: row.true_tracking[2],
        },
        true_position_m: row.true_error.0,
        true_heading_rad: row.true_error.1,
        lyapunov_v: f(row.lyapunov),
        lyapunov_rate_per_s: f(row.detail.lyapunov_rate),
    }
}

/// `/body` of `row`.
pub fn body(row: &TraceRow) -> BodyMessage {
    BodyMessage {
        command: BodyVelocityMessage {
            v_m_s: f64::from(row.command.v_m_s),
            omega_rad_s: f64::from(row.command.omega_rad_s),
        },
        truth: BodyVelocityMessage {
            v_m_s: row.true_velocity.0,
            omega_rad_s: row.true_velocity.1,
        },
    }
}

/// `/wheels` of `row`.
pub fn wheels(row: &TraceRow) -> WheelsMessage {
    let f = f64::from;
    WheelsMessage {
        left: WheelMessage {
            setpoint_rad_s: f(row.setpoint.left_rad_s),
            measured_rad_s: f(row.measured.left_rad_s),
            true_rad_s: row.true_wheel[0],
            volts_v: f(row.volts[0]),
            duty: f(row.duty.left),
            pid: row.detail.pid[0].into(),
        },
        right: WheelMessage {
            setpoint_rad_s: f(row.setpoint.right_rad_s),
            measured_rad_s: f(row.measured.right_rad_s),
            true_rad_s: row.true_wheel[1],
            volts_v: f(row.volts[1]),
            duty: f(row.duty.right),
            pid: row.detail.pid[1].into(),
        },
    }
}

/// `/supervisor` of `row`.
pub fn supervisor(row: &TraceRow) -> SupervisorMessage {
    SupervisorMessage {
        state: row.state.into(),
        supply_v: f64::from(row.supply_v),
        faults: row.detail.faults.into(),
        any_fault: row.detail.faults.any(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rotation_is_the_heading_about_z() {
        let pose = PlanarPose {
            x_m: 1.0,
            y_m: -2.0,
            theta_rad: 2.5,
        };
        let q = pose.rotation();
        assert_eq!((q.x, q.y), (0.0, 0.0));
        assert!((2.0 * q.z.atan2(q.w) - 2.5).abs() < 1e-12);
        // A quarter turn left: +z.
        let left = PlanarPose {
            theta_rad: core::f64::consts::FRAC_PI_2,
            ..pose
        }
        .rotation();
        assert!(left.z > 0.0 && (left.z - left.w).abs() < 1e-12);
    }

    #[test]
    fn log_times_are_nanoseconds_of_the_run() {
        assert_eq!(log_time_ns(1.5), 1_500_000_000);
        assert_eq!(log_time_ns(0.001), 1_000_000);
        assert_eq!(log_time_ns(-1.0), 0);
        assert_eq!(log_time_ns(f64::NAN), 0);
        let t = timestamp(12.25);
        assert_eq!((t.sec(), t.nsec()), (12, 250_000_000));
    }
}
