//! What a run amounted to: `summary.json`.
//!
//! The error statistics are accumulated as the run goes by
//! [`robot_app::metrics::ErrorStats`], the same code the robot runs on its own estimate,
//! so a summary recorded from a robot over the link and one written by the simulator
//! mean the same thing (settle time: 1 cm and 1° to the end; RMS and maximum over the
//! last 10 s). Nothing here grows with the run: a day-long soak keeps one number per
//! hour.
//!
//! Two sets of errors, named for what they are:
//!
//! - `true_error`: the true pose (what a ruler on the floor measures) against the
//!   reference, at every steering period of the run, whatever the controller is doing —
//!   a controller that faults before its first steering step still gets an error. Only a
//!   simulation (or a robot with an absolute position fix) has it; a real robot's summary
//!   leaves it out.
//! - `estimated_error`: the controller's own estimate (odometry) against its own
//!   reference, at its steering updates. The two differ when the robot is not what the
//!   controller believes (mismatch, slip), which no feedback on odometry alone can see.

use controller_core::supervisor::{Fault, Faults, State};
use robot_app::metrics::ErrorSummary;
use serde::Serialize;

pub use robot_app::metrics::{
    ErrorSample, ErrorStats, FINAL_WINDOW_BUCKETS, SETTLE_HEADING_RAD, SETTLE_POSITION_M,
};

/// Length of the final window of the RMS and max statistics, s.
pub const FINAL_WINDOW_S: f64 = FINAL_WINDOW_BUCKETS as f64;

/// One set of error statistics (see [`ErrorSummary`]), m, rad and s.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ErrorReport {
    /// First time after which position error < 1 cm and |heading error| < 1° hold to the
    /// end, s from arming; `null` if they do not hold at the end.
    pub settle_time_s: Option<f64>,
    /// Position error at the last sample, m.
    pub final_position_error_m: f64,
    /// Heading error θ_r − θ at the last sample, rad (signed).
    pub final_heading_error_rad: f64,
    /// RMS position error over the last 10 s, m.
    pub rms_position_error_m: f64,
    /// Largest position error over the last 10 s, m.
    pub max_position_error_m: f64,
    /// Samples the figures come from; 0 when there was none (e.g. a fault before the
    /// first steering update), and then every figure above is 0 and means nothing.
    pub samples: u32,
}

impl From<ErrorSummary> for ErrorReport {
    fn from(s: ErrorSummary) -> Self {
        Self {
            settle_time_s: s.settle_time_s.map(f64::from),
            final_position_error_m: f64::from(s.final_position_error_m),
            final_heading_error_rad: f64::from(s.final_heading_error_rad),
            rms_position_error_m: f64::from(s.rms_position_error_m),
            max_position_error_m: f64::from(s.max_position_error_m),
            samples: s.samples,
        }
    }
}

/// How the supervisor ended the run.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct SupervisorReport {
    /// Its state at the end (`Disarmed`, `Armed`, `Faulted`, `Persisting`).
    pub final_state: String,
    /// The faults latched at the end, by name (empty if none).
    pub faults: Vec<String>,
    /// Control ticks missed (late steps) over the run.
    pub missed_ticks: u32,
    /// Overrun steps over the run.
    pub overruns: u32,
}

impl SupervisorReport {
    /// The report of `state` with `faults` latched.
    pub fn new(state: State, faults: &Faults, missed_ticks: u32, overruns: u32) -> Self {
        Self {
            final_state: format!("{state:?}"),
            faults: fault_names(faults)
                .iter()
                .map(|s| (*s).to_string())
                .collect(),
            missed_ticks,
            overruns,
        }
    }
}

/// The names of the faults set in `faults` (the supervisor's and the core's).
pub fn fault_names(faults: &Faults) -> Vec<&'static str> {
    faults.iter().map(Fault::name).collect()
}

/// What one injected fault did.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct FaultReport {
    /// The fault's kind (`encoder-disconnect`, …).
    pub fault: String,
    /// When it was injected, s.
    pub injected_s: f64,
    /// True when the supervisor stopped driving after it (a fault, or a disarm).
    pub detected: bool,
    /// When it did, s (`null` if it did not).
    pub detected_s: Option<f64>,
    /// Detection latency, s (`null` if not detected).
    pub latency_s: Option<f64>,
    /// What stopped the robot: the latched faults' names or the disarm reason.
    pub detected_by: Vec<String>,
    /// When the duties reached 0, s (`null` if they did not).
    pub motors_zero_s: Option<f64>,
    /// When both true wheel speeds were below 0.1 rad/s after that, s (`null` if never).
    pub wheels_stopped_s: Option<f64>,
    /// True distance driven from the injection to the end of the run, m.
    pub distance_after_m: f64,
    /// The first warning at or after the injection that the robot drove on with (the
    /// gyro failed, or disagreed with odometry), by name (`null` if none).
    pub warning: Option<String>,
    /// Its latency from the injection, s (`null` if none).
    pub warning_latency_s: Option<f64>,
}

/// The run summary written as `summary.json`.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Summary {
    /// Scenario name.
    pub scenario: String,
    /// Steering law name (`paper`, `tracking` or `kanayama`).
    pub law: String,
    /// What produced the summary: `simulator`, `virtual-robot`, `robot`, `pil`.
    pub source: String,
    /// The true pose's errors (module doc); `null` for a real robot.
    pub true_error: Option<ErrorReport>,
    /// The controller's own estimate's errors (module doc).
    pub estimated_error: ErrorReport,
    /// RMS true position error of each whole hour of a run of 2 h or more, m (a soak's
    /// drift check); empty for shorter runs.
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub hourly_rms_true_position_error_m: Vec<f64>,
    /// Largest true wheel speed of either wheel, rad/s (the measured one for a robot).
    pub max_wheel_speed_rad_s: f64,
    /// Largest |duty| the robot applied, in [0, 1].
    pub max_duty: f64,
    /// How the supervisor ended the run.
    pub supervisor: SupervisorReport,
    /// What each injected fault did (empty without faults).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    pub injected_faults: Vec<FaultReport>,
    /// Simulated time, s.
    pub sim_time_s: f64,
    /// Wall-clock time of the simulation loop, s.
    pub wall_time_s: f64,
    /// Control steps simulated.
    pub steps: u64,
}

impl Summary {
    /// The errors to headline: the true ones when the summary has them, else the
    /// estimate's.
    pub fn headline_error(&self) -> ErrorReport {
        self.true_error.unwrap_or(self.estimated_error)
    }
}

/// RMS of one whole hour of samples, accumulated as they come.
#[derive(Clone, Debug, Default)]
pub struct HourlyRms {
    hours: Vec<f64>,
    sum_squares: f64,
    count: u64,
    hour: u64,
}

impl HourlyRms {
    /// Adds a sample of `error_m` (m) taken at `t_s` (s).
    pub fn push(&mut self, t_s: f64, error_m: f64) {
        let hour = (t_s / 3600.0) as u64;
        while hour > self.hour {
            self.close_hour();
        }
        self.sum_squares += error_m * error_m;
        self.count += 1;
    }

    fn close_hour(&mut self) {
        let rms = if self.count > 0 {
            (self.sum_squares / self.count as f64).sqrt()
        } else {
            0.0
        };
        self.hours.push(rms);
        self.sum_squares = 0.0;
        self.count = 0;
        self.hour += 1;
    }

    /// The RMS of each whole hour the samples cover, m, given `end_s` (s, on the
    /// samples' clock), the end of the time they cover: a run sampled every period from
    /// t = 0 to 24 h has its last sample one period before 24 h, and its 24th hour is
    /// whole all the same. Empty for runs under 2 h.
    pub fn finish(mut self, end_s: f64) -> Vec<f64> {
        let whole_hours = (end_s / 3600.0) as u64;
        while self.hour < whole_hours {
            self.close_hour();
        }
        if self.hours.len() >= 2 {
            self.hours
        } else {
            Vec::new()
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Three hours sampled every second from t = 0: the last sample is at 10 799 s, and
    /// the third hour is whole.
    fn three_hours() -> HourlyRms {
        let mut h = HourlyRms::default();
        for k in 0..3 * 3600 {
            h.push(f64::from(k), f64::from(3 + k / 3600));
        }
        h
    }

    #[test]
    fn hourly_rms_closes_every_whole_hour_including_the_last() {
        assert_eq!(three_hours().finish(3.0 * 3600.0), vec![3.0, 4.0, 5.0]);
        // A run that ends a second short of its third hour has two whole hours.
        assert_eq!(three_hours().finish(3.0 * 3600.0 - 1.0), vec![3.0, 4.0]);
        // Under 2 h: none.
        let mut short = HourlyRms::default();
        short.push(10.0, 1.0);
        short.push(4000.0, 1.0);
        assert!(short.finish(4001.0).is_empty());
    }

    #[test]
    fn fault_names_list_what_is_set() {
        let mut f = Faults::NONE;
        assert!(fault_names(&f).is_empty());
        f.set(Fault::StallLeft);
        f.set(Fault::EncoderJump);
        assert_eq!(fault_names(&f), vec!["encoder_jump", "stall_left"]);
    }
}
