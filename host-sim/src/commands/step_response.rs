//! `host-sim step-response`: the wheel-speed loop alone, a set-point step from rest on
//! the scenario's robot and plant, to tune the wheel PID; `step_response.svg` in the
//! output folder.

use std::fmt;
use std::path::PathBuf;

use anyhow::Result;
use robot_files::scenario::Scenario;

use super::{create_dir, default_dir, load, ms_or, Failed, Report};
use crate::plot;
use crate::run::{wheel_step_response, StepResponse};

/// The longest step `host-sim step-response` runs, s.
pub const MAX_DURATION_S: f64 = 60.0;

/// What `host-sim step-response` was asked.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// A built-in scenario name or a path to a TOML file (its robot and plant are used).
    pub scenario: String,
    /// The wheel set-point, rad/s.
    pub setpoint_rad_s: f64,
    /// How long the step runs, s.
    pub duration_s: f64,
    /// The output folder (`None`: `host-sim-out/<scenario>/step`).
    pub out: Option<PathBuf>,
}

/// The rule on the arguments: a finite set-point (rad/s) and a duration in
/// (0, [`MAX_DURATION_S`]] s.
pub fn check_arguments(setpoint_rad_s: f64, duration_s: f64) -> Result<(), Failed> {
    if setpoint_rad_s.is_finite() && duration_s > 0.0 && duration_s <= MAX_DURATION_S {
        Ok(())
    } else {
        Err(Failed(
            "--setpoint-rad-s must be finite and --duration-s in (0, 60]".into(),
        ))
    }
}

/// The step, the gains it ran with and where the plot went.
#[derive(Clone, Debug)]
pub struct StepReport {
    /// The scenario (its left wheel's gains and its supply are printed).
    pub scenario: Scenario,
    /// The set-point as asked, rad/s.
    pub setpoint_rad_s: f64,
    /// The left wheel's response.
    pub response: StepResponse,
    /// `step_response.svg`.
    pub file: PathBuf,
}

impl fmt::Display for StepReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let w = self.scenario.robot.left_wheel;
        let r = &self.response;
        writeln!(
            f,
            "wheel-speed step 0 → {} rad/s from rest on {} V, K_p = {} V/(rad/s), \
T_i = {} s, T_d = {} s, feed-forward k_S = {} V, k_V = {} V/(rad/s):",
            self.setpoint_rad_s,
            self.scenario.plant.driver.supply_v,
            w.kp_v_per_rad_s,
            w.ti_s,
            w.td_s,
            w.ks_v,
            w.kv_v_per_rad_s
        )?;
        let opt = |v: Option<f64>| ms_or(v, 0, "never");
        writeln!(
            f,
            "  rise (10→90 %) {}, overshoot {:.1} %, settling (±5 %) {}, steady-state error {:+.3} rad/s",
            opt(r.rise_time_s),
            r.overshoot_pct,
            opt(r.settling_time_s),
            r.steady_state_error_rad_s
        )?;
        writeln!(f, "  wrote {}", self.file.display())
    }
}

impl Report for StepReport {}

/// Runs the step and writes its plot.
pub fn run(options: &Options) -> Result<StepReport> {
    let scenario = load(&options.scenario)?;
    check_arguments(options.setpoint_rad_s, options.duration_s)?;
    let response = wheel_step_response(&scenario, options.setpoint_rad_s, options.duration_s)?;
    let dir = options
        .out
        .clone()
        .unwrap_or_else(|| default_dir(&scenario, "step"));
    create_dir(&dir)?;
    let file = dir.join("step_response.svg");
    plot::step_response(&file, &scenario.name, &response)?;
    Ok(StepReport {
        scenario,
        setpoint_rad_s: options.setpoint_rad_s,
        response,
        file,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_finite_set_point_and_a_duration_up_to_a_minute_are_accepted() {
        assert_eq!(check_arguments(15.0, 1.0), Ok(()));
        assert_eq!(check_arguments(-15.0, MAX_DURATION_S), Ok(()));
        let refused = Err(Failed(
            "--setpoint-rad-s must be finite and --duration-s in (0, 60]".into(),
        ));
        assert_eq!(check_arguments(f64::NAN, 1.0), refused);
        assert_eq!(check_arguments(f64::INFINITY, 1.0), refused);
        assert_eq!(check_arguments(15.0, 0.0), refused);
        assert_eq!(check_arguments(15.0, 60.5), refused);
        assert_eq!(check_arguments(15.0, f64::NAN), refused);
    }
}
