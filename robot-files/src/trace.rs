//! `trace.csv`: one row per sample of a run, the same columns whether the simulator ran
//! it or the ground station recorded it from a robot's telemetry (columns the source
//! does not know, e.g. the truth of a real robot, are NaN).

use std::fmt::Write as _;
use std::io;

use controller_core::pid::PidParts;
use controller_core::prelude::{BodyVelocity, MotorCommand, Pose, TrackingError, WheelSpeeds};
use controller_core::supervisor::{Faults, State};

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
    /// What the sample holds beyond `trace.csv`'s columns (not written to it).
    pub detail: SampleDetail,
}

/// What a sample of a run holds beyond `trace.csv`'s columns: the parts a run's MCAP
/// recording (the `robot-foxglove` crate) plots as well. `trace.csv` leaves them out, so
/// its columns stay those of the paper's figures.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct SampleDetail {
    /// The rate V̇ of the Lyapunov function the law predicts, per s (≤ 0 when the proof
    /// holds).
    pub lyapunov_rate: f32,
    /// The wheel PIDs' outputs by part [left, right], V (P, I, D and feed-forward, which
    /// add up to the voltage asked of the motor before saturation).
    pub pid: [PidParts; 2],
    /// The supervisor's latched faults.
    pub faults: Faults,
}

impl TraceRow {
    /// Column names of `trace.csv`, comma-separated (units in the names), one per
    /// [`TraceRow::numeric_columns`] and the state last.
    pub const CSV_HEADER: &'static str = "t_s,x_m,y_m,theta_rad,x_est_m,y_est_m,theta_est_rad,\
x_ref_m,y_ref_m,theta_ref_rad,x_e_m,y_e_m,theta_e_rad,x_e_true_m,y_e_true_m,theta_e_true_rad,\
pos_err_true_m,heading_err_true_rad,\
lyapunov_v,v_cmd_m_s,omega_cmd_rad_s,v_true_m_s,omega_true_rad_s,\
setpoint_left_rad_s,setpoint_right_rad_s,speed_est_left_rad_s,speed_est_right_rad_s,\
speed_true_left_rad_s,speed_true_right_rad_s,volts_left_v,volts_right_v,duty_left,duty_right,\
supply_v,state";

    /// This row's numeric columns, in [`TraceRow::CSV_HEADER`] order (all but the last,
    /// the supervisor's state), each with the decimals `trace.csv` prints it with: time
    /// to 1 ms, poses and errors to 1e-6 (m, rad), velocities to 1e-5 (m/s, rad/s),
    /// wheel speeds, volts and duties to 1e-4, the supply to 1 mV. Single-precision
    /// values are widened exactly, so they print as their own digits.
    pub fn numeric_columns(&self) -> [(f64, usize); CSV_COLUMNS - 1] {
        let p = &self.true_pose;
        let f = f64::from;
        [
            (self.t_s, 3),
            (p.x_m, 6),
            (p.y_m, 6),
            (p.theta_rad, 6),
            (f(self.est_pose.x_m), 6),
            (f(self.est_pose.y_m), 6),
            (f(self.est_pose.theta_rad), 6),
            (f(self.reference.x_m), 6),
            (f(self.reference.y_m), 6),
            (f(self.reference.theta_rad), 6),
            (f(self.error.x_e_m), 6),
            (f(self.error.y_e_m), 6),
            (f(self.error.theta_e_rad), 6),
            (self.true_tracking[0], 6),
            (self.true_tracking[1], 6),
            (self.true_tracking[2], 6),
            (self.true_error.0, 6),
            (self.true_error.1, 6),
            (f(self.lyapunov), 6),
            (f(self.command.v_m_s), 5),
            (f(self.command.omega_rad_s), 5),
            (self.true_velocity.0, 5),
            (self.true_velocity.1, 5),
            (f(self.setpoint.left_rad_s), 4),
            (f(self.setpoint.right_rad_s), 4),
            (f(self.measured.left_rad_s), 4),
            (f(self.measured.right_rad_s), 4),
            (self.true_wheel[0], 4),
            (self.true_wheel[1], 4),
            (f(self.volts[0]), 4),
            (f(self.volts[1]), 4),
            (f(self.duty.left), 4),
            (f(self.duty.right), 4),
            (f(self.supply_v), 3),
        ]
    }

    /// Writes this row as one record of `out`: the numeric columns with their fixed
    /// decimals (`NaN` for an unknown value), then the state's name.
    pub fn write_record<W: io::Write>(&self, out: &mut csv::Writer<W>) -> csv::Result<()> {
        let mut field = String::with_capacity(24);
        for (value, decimals) in self.numeric_columns() {
            field.clear();
            // Writing to a String cannot fail.
            let _ = write!(field, "{value:.decimals$}");
            out.write_field(&field)?;
        }
        field.clear();
        let _ = write!(field, "{:?}", self.state);
        out.write_field(&field)?;
        out.write_record(None::<&[u8]>)
    }
}

/// Columns of `trace.csv`.
pub const CSV_COLUMNS: usize = 35;

/// Writes `trace` as CSV to `out`: a header (units in the column names) and one line per
/// row, `\n`-terminated; no field needs quoting (numbers, `NaN`, `inf` and state names).
pub fn write_trace_csv<W: io::Write>(out: W, trace: &[TraceRow]) -> csv::Result<()> {
    let mut writer = csv::WriterBuilder::new()
        .terminator(csv::Terminator::Any(b'\n'))
        .quote_style(csv::QuoteStyle::Necessary)
        .from_writer(out);
    writer.write_record(TraceRow::CSV_HEADER.split(','))?;
    for row in trace {
        row.write_record(&mut writer)?;
    }
    writer.flush()?;
    Ok(())
}

/// `trace` as CSV text ([`write_trace_csv`]).
pub fn trace_csv(trace: &[TraceRow]) -> String {
    let mut out = Vec::with_capacity(64 + trace.len() * 300);
    // Writing to memory cannot fail, and every field is UTF-8.
    let _ = write_trace_csv(&mut out, trace);
    String::from_utf8(out).unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row() -> TraceRow {
        TraceRow {
            t_s: 1.0005,
            true_pose: TruePose {
                x_m: 0.1234564,
                y_m: -0.5,
                theta_rad: f64::NAN,
            },
            est_pose: Pose {
                x_m: 0.1,
                y_m: 0.2,
                theta_rad: -0.0,
            },
            reference: Pose::default(),
            error: TrackingError::default(),
            true_error: (0.25, f64::INFINITY),
            true_tracking: [1e-7, -1e-7, 3.0],
            lyapunov: 0.5,
            command: BodyVelocity {
                v_m_s: 0.3,
                omega_rad_s: -0.123456,
            },
            true_velocity: (0.299999, 0.0),
            setpoint: WheelSpeeds {
                left_rad_s: 9.87654,
                right_rad_s: -9.0,
            },
            measured: WheelSpeeds::default(),
            true_wheel: [9.5, -9.5],
            volts: [3.3, -3.3],
            duty: MotorCommand {
                left: 0.55,
                right: -0.55,
            },
            supply_v: 6.0005,
            state: State::Armed,
            detail: SampleDetail::default(),
        }
    }

    #[test]
    fn the_header_names_every_column() {
        assert_eq!(TraceRow::CSV_HEADER.split(',').count(), CSV_COLUMNS);
        assert_eq!(row().numeric_columns().len() + 1, CSV_COLUMNS);
    }

    #[test]
    fn rows_have_fixed_decimals_and_no_quotes() {
        let text = trace_csv(&[row()]);
        let mut lines = text.split('\n');
        assert_eq!(lines.next(), Some(TraceRow::CSV_HEADER));
        let expected = "1.000,0.123456,-0.500000,NaN,0.100000,0.200000,-0.000000,\
0.000000,0.000000,0.000000,0.000000,0.000000,0.000000,0.000000,-0.000000,3.000000,\
0.250000,inf,0.500000,0.30000,-0.12346,0.30000,0.00000,9.8765,-9.0000,0.0000,0.0000,\
9.5000,-9.5000,3.3000,-3.3000,0.5500,-0.5500,6.001,Armed";
        assert_eq!(lines.next(), Some(expected));
        assert_eq!(lines.next(), Some(""));
        assert_eq!(lines.next(), None);
        // The same digits as formatting each value with its decimals directly.
        let direct: Vec<String> = row()
            .numeric_columns()
            .iter()
            .map(|(v, d)| format!("{v:.d$}"))
            .collect();
        assert!(expected.starts_with(&direct.join(",")));
    }
}
