//! `trace.csv`: one row per sample of a run, the same columns whether the simulator ran
//! it or the ground station recorded it from a robot's telemetry (columns the source
//! does not know, e.g. the truth of a real robot, are NaN).

use controller_core::prelude::{BodyVelocity, MotorCommand, Pose, TrackingError, WheelSpeeds};
use controller_core::supervisor::State;

use crate::truth::TruePose;

/// One row of `trace.csv`. World frame for poses (m, rad); robot frame for x_e, y_e.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceRow {
    /// Time since the start, s.
    pub t_s: f64,
    /// True pose.
    pub true_pose: TruePose,
    /// The controller's odometry estimate.
    pub est_pose: Pose,
    /// Reference pose of the true-error measurement.
    pub reference: Pose,
    /// The controller's tracking error (9) of its estimate: x_e, y_e (m), θ_e (rad).
    pub error: TrackingError,
    /// True position error (m) and heading error (rad) as the metrics use them.
    pub true_error: (f64, f64),
    /// Tracking error (9) of the true pose against the reference: x_e, y_e (m, robot
    /// frame), θ_e (rad).
    pub true_tracking: [f64; 3],
    /// The steering law's Lyapunov function V.
    pub lyapunov: f32,
    /// Body command after limits: v (m/s), ω (rad/s).
    pub command: BodyVelocity,
    /// True body velocity: v (m/s), ω (rad/s).
    pub true_velocity: (f64, f64),
    /// Wheel-speed set-points, rad/s.
    pub setpoint: WheelSpeeds,
    /// The controller's wheel-speed estimate, rad/s.
    pub measured: WheelSpeeds,
    /// True wheel speeds [left, right], rad/s.
    pub true_wheel: [f64; 2],
    /// Armature voltages the wheel loops commanded [left, right], V.
    pub volts: [f32; 2],
    /// Commanded duties, −1…1.
    pub duty: MotorCommand,
    /// The filtered supply the controller used, V.
    pub supply_v: f32,
    /// The supervisor's state.
    pub state: State,
}

impl TraceRow {
    /// Column names of [`TraceRow::write_csv`], comma-separated (units in the names).
    pub const CSV_HEADER: &'static str = "t_s,x_m,y_m,theta_rad,x_est_m,y_est_m,theta_est_rad,\
x_ref_m,y_ref_m,theta_ref_rad,x_e_m,y_e_m,theta_e_rad,x_e_true_m,y_e_true_m,theta_e_true_rad,\
pos_err_true_m,heading_err_true_rad,\
lyapunov_v,v_cmd_m_s,omega_cmd_rad_s,v_true_m_s,omega_true_rad_s,\
setpoint_left_rad_s,setpoint_right_rad_s,speed_est_left_rad_s,speed_est_right_rad_s,\
speed_true_left_rad_s,speed_true_right_rad_s,volts_left_v,volts_right_v,duty_left,duty_right,\
supply_v,state";

    /// Appends this row as CSV (no newline) to `out`.
    pub fn write_csv(&self, out: &mut String) {
        use std::fmt::Write;
        let p = &self.true_pose;
        // Writing to a String cannot fail.
        let _ = write!(
            out,
            "{:.3},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},\
{:.6},{:.6},{:.6},{:.6},{:.6},{:.6},{:.5},{:.5},{:.5},{:.5},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},\
{:.4},{:.4},{:.4},{:.4},{:.3},{:?}",
            self.t_s,
            p.x_m,
            p.y_m,
            p.theta_rad,
            self.est_pose.x_m,
            self.est_pose.y_m,
            self.est_pose.theta_rad,
            self.reference.x_m,
            self.reference.y_m,
            self.reference.theta_rad,
            self.error.x_e_m,
            self.error.y_e_m,
            self.error.theta_e_rad,
            self.true_tracking[0],
            self.true_tracking[1],
            self.true_tracking[2],
            self.true_error.0,
            self.true_error.1,
            self.lyapunov,
            self.command.v_m_s,
            self.command.omega_rad_s,
            self.true_velocity.0,
            self.true_velocity.1,
            self.setpoint.left_rad_s,
            self.setpoint.right_rad_s,
            self.measured.left_rad_s,
            self.measured.right_rad_s,
            self.true_wheel[0],
            self.true_wheel[1],
            self.volts[0],
            self.volts[1],
            self.duty.left,
            self.duty.right,
            self.supply_v,
            self.state,
        );
    }
}

/// `trace` as CSV text: a header (units in the column names) and one line per row.
pub fn trace_csv(trace: &[TraceRow]) -> String {
    let mut out = String::with_capacity(64 + trace.len() * 300);
    out.push_str(TraceRow::CSV_HEADER);
    out.push('\n');
    for row in trace {
        row.write_csv(&mut out);
        out.push('\n');
    }
    out
}
