//! The velocity mode's figures on a run of a scenario with a `[velocity]` timeline: how
//! soon a step in the command moves the limited command, when the ramp to zero starts
//! after the last command, and the largest velocity, acceleration and jerk of the limited
//! command against the robot's limits.
//!
//! The run is `run_with_logic`'s, with the supervisor and controller in this process; a
//! recorder between the loop and the robot keeps, at every step, the limited command
//! (telemetry's `command`) and whether the robot was armed. Acceleration and jerk are
//! first and second differences of the limited command per control period, from the
//! step that armed.

use controller_core::kinematics::BodyVelocity;
use controller_core::law::LawKind;
use controller_core::supervisor::{ArmRequest, State};
use controller_core::velocity::{AxisLimits, VelocityModeConfig};
use robot_files::scenario::Scenario;

use crate::hardware::Sensors;
use crate::run::{run_with_logic, Decision, LocalRobot, RobotLogic, RunError, RunOptions};

/// Largest number of control periods between a step in the command and the first change
/// of the limited command that the velocity mode allows.
pub const MAX_LATENCY_PERIODS: u64 = 2;

/// One axis's largest |velocity|, |acceleration| and |jerk| seen, in the axis's units.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct AxisPeaks {
    /// Largest |velocity| (m/s or rad/s).
    pub velocity: f64,
    /// Largest |acceleration| (m/s² or rad/s²).
    pub acceleration: f64,
    /// Largest |jerk| (m/s³ or rad/s³).
    pub jerk: f64,
}

impl AxisPeaks {
    /// Within `limits`, to a relative 10⁻³ (the `f32` arithmetic's rounding, divided by
    /// a period twice).
    pub fn within(&self, limits: &AxisLimits) -> bool {
        let ok = |seen: f64, limit: f32| seen <= f64::from(limit) * 1.001;
        ok(self.velocity, limits.max_velocity)
            && ok(self.acceleration, limits.max_acceleration)
            && ok(self.jerk, limits.max_jerk)
    }
}

/// The figures of one run (module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct VelocityFigures {
    /// The scenario.
    pub scenario: String,
    /// Control rate, Hz.
    pub control_rate_hz: u32,
    /// The robot's velocity-mode settings.
    pub config: VelocityModeConfig,
    /// Steps in the command (timeline entries) measured.
    pub steps_measured: usize,
    /// The most control periods from a step's arrival to the limited command's first
    /// change (0: it changed in the step the command arrived).
    pub max_latency_periods: u64,
    /// Control periods from the last command's arrival to the first step the limited
    /// command moved towards zero (`None`: it never did).
    pub ramp_delay_periods: Option<u64>,
    /// Peaks of the forward speed v.
    pub linear: AxisPeaks,
    /// Peaks of the yaw rate ω.
    pub angular: AxisPeaks,
    /// Still armed at the end of the run.
    pub armed_at_end: bool,
}

impl VelocityFigures {
    /// Why the figures break the velocity mode's contract, if they do: a latency over
    /// [`MAX_LATENCY_PERIODS`], a ramp that does not start `cmd_vel_timeout` ± 1 period
    /// after the last command, a limit exceeded, or the robot disarmed.
    pub fn problems(&self) -> Vec<String> {
        let mut problems = Vec::new();
        if self.steps_measured == 0 {
            problems.push("no step in the command was measured".to_string());
        }
        if self.max_latency_periods > MAX_LATENCY_PERIODS {
            problems.push(format!(
                "a step reached the limited command after {} periods (at most {MAX_LATENCY_PERIODS})",
                self.max_latency_periods
            ));
        }
        let timeout = u64::from(self.config.cmd_vel_timeout_steps);
        match self.ramp_delay_periods {
            Some(d) if d.abs_diff(timeout) <= 1 => {}
            Some(d) => problems.push(format!(
                "the ramp to zero started {d} periods after the last command, not {timeout} ± 1"
            )),
            None => problems.push("the limited command never ramped to zero".to_string()),
        }
        if !self.linear.within(&self.config.linear_x) {
            problems.push(format!("linear.x beyond its limits: {:?}", self.linear));
        }
        if !self.angular.within(&self.config.angular_z) {
            problems.push(format!("angular.z beyond its limits: {:?}", self.angular));
        }
        if !self.armed_at_end {
            problems.push("the robot did not stay armed".to_string());
        }
        problems
    }
}

impl std::fmt::Display for VelocityFigures {
    /// One line.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let rate = f64::from(self.control_rate_hz);
        let (l, a) = (&self.config.linear_x, &self.config.angular_z);
        let ramp = match self.ramp_delay_periods {
            Some(d) => format!("{:.3} s", d as f64 / rate),
            None => "never".to_string(),
        };
        write!(
            f,
            "velocity mode ({}): a step in the command moves the limited command after \
             {} periods (most of {} steps; at most {MAX_LATENCY_PERIODS}); the ramp to zero \
             starts {ramp} after the last command (timeout {:.3} s ± 1 period); limits: \
             |v| {:.3}/{} m/s, |a| {:.3}/{} m/s², |jerk| {:.2}/{} m/s³, |ω| {:.3}/{} rad/s, \
             |α| {:.3}/{} rad/s², |jerk| {:.1}/{} rad/s³; {}",
            self.scenario,
            self.max_latency_periods,
            self.steps_measured,
            f64::from(self.config.cmd_vel_timeout_steps) / rate,
            self.linear.velocity,
            l.max_velocity,
            self.linear.acceleration,
            l.max_acceleration,
            self.linear.jerk,
            l.max_jerk,
            self.angular.velocity,
            a.max_velocity,
            self.angular.acceleration,
            a.max_acceleration,
            self.angular.jerk,
            a.max_jerk,
            if self.armed_at_end {
                "stayed armed"
            } else {
                "DISARMED"
            }
        )
    }
}

/// What the recorder keeps of one step.
#[derive(Clone, Copy, Debug)]
struct Sample {
    limited: BodyVelocity,
    armed: bool,
}

/// [`LocalRobot`] with every step's limited command kept.
struct Recorder {
    robot: LocalRobot,
    samples: Vec<Sample>,
}

impl RobotLogic for Recorder {
    fn arm_locally(&mut self, request: ArmRequest) -> bool {
        self.robot.arm_locally(request)
    }

    fn set_pose_locally(&mut self, pose: controller_core::kinematics::Pose) -> bool {
        self.robot.set_pose_locally(pose)
    }

    fn command_velocity(&mut self, command: BodyVelocity) -> bool {
        self.robot.command_velocity(command)
    }

    fn step(&mut self, sensors: &Sensors) -> Result<Decision<'_>, RunError> {
        let decision = self.robot.step(sensors)?;
        if let Some(t) = decision.telemetry {
            self.samples.push(Sample {
                limited: t.command,
                armed: decision.out.state == State::Armed,
            });
        }
        Ok(decision)
    }
}

/// Runs `scenario` (it must have a `[velocity]` timeline) and measures its figures.
pub fn measure(scenario: &Scenario) -> Result<VelocityFigures, RunError> {
    let Some(timeline) = &scenario.velocity else {
        return Err(RunError::Argument {
            name: "scenario",
            rule: "must have a [velocity] timeline",
            value: 0.0,
        });
    };
    let mut recorder = Recorder {
        robot: LocalRobot::new(scenario, LawKind::Tracking)?,
        samples: Vec::new(),
    };
    run_with_logic(
        scenario,
        LawKind::Tracking,
        RunOptions::default(),
        &mut recorder,
        "simulator",
    )?;
    let samples = &recorder.samples;
    let changed = |j: usize| j > 0 && samples[j].limited != samples[j - 1].limited;
    let first_change_from = |k: usize| (k..samples.len()).find(|&j| changed(j));

    let mut max_latency_periods = 0;
    let mut steps_measured = 0;
    for entry in &timeline.entries {
        let k = entry.at_step as usize;
        if let Some(j) = first_change_from(k) {
            max_latency_periods = max_latency_periods.max((j - k) as u64);
            steps_measured += 1;
        }
    }
    let ramp_delay_periods = timeline
        .last_sent_before(samples.len() as u64)
        .and_then(|last| {
            let last = last as usize;
            let towards_zero = |j: usize| {
                let (now, before) = (samples[j].limited, samples[j - 1].limited);
                now.v_m_s.abs() < before.v_m_s.abs()
                    || now.omega_rad_s.abs() < before.omega_rad_s.abs()
            };
            ((last + 1)..samples.len())
                .find(|&j| towards_zero(j))
                .map(|j| (j - last) as u64)
        });

    let period_s = 1.0 / f64::from(scenario.robot.control_rate_hz);
    let armed_from = samples
        .iter()
        .position(|s| s.armed)
        .unwrap_or(samples.len());
    let axis = |pick: fn(&BodyVelocity) -> f32| {
        let mut peaks = AxisPeaks::default();
        let mut previous_velocity = 0.0;
        let mut previous_acceleration = 0.0;
        for s in &samples[armed_from..] {
            let v = f64::from(pick(&s.limited));
            let a = (v - previous_velocity) / period_s;
            let jerk = (a - previous_acceleration) / period_s;
            peaks.velocity = peaks.velocity.max(v.abs());
            peaks.acceleration = peaks.acceleration.max(a.abs());
            peaks.jerk = peaks.jerk.max(jerk.abs());
            (previous_velocity, previous_acceleration) = (v, a);
        }
        peaks
    };
    Ok(VelocityFigures {
        scenario: scenario.name.clone(),
        control_rate_hz: scenario.robot.control_rate_hz,
        config: scenario.robot.velocity,
        steps_measured,
        max_latency_periods,
        ramp_delay_periods,
        linear: axis(|c| c.v_m_s),
        angular: axis(|c| c.omega_rad_s),
        armed_at_end: samples.last().is_some_and(|s| s.armed),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_built_in_timeline_keeps_the_contract() {
        let scenario = Scenario::builtin("velocity-steps")
            .expect("built in")
            .expect("valid");
        let figures = measure(&scenario).expect("runs");
        assert_eq!(figures.problems(), Vec::<String>::new(), "{figures}");
        assert_eq!(figures.steps_measured, 4);
        // The limits acted: the ramps ran at the acceleration limit.
        assert!(figures.linear.acceleration > 0.9 * 1.5, "{figures}");
    }

    #[test]
    fn a_scenario_without_a_timeline_is_refused() {
        let scenario = Scenario::builtin("paper-line")
            .expect("built in")
            .expect("valid");
        assert!(measure(&scenario).is_err());
    }
}
