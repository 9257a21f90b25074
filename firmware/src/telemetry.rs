//! What the robot reports over defmt/RTT, and the status LED pattern.
//!
//! The control task samples a [`Report`] every `1000 / TELEMETRY_HZ` steps and hands it to
//! a low-priority task that logs it, so the 1 kHz loop never formats or waits for the
//! probe. Supervisor events (armed, disarmed, faulted, …) are logged as they happen.

use controller_core::controller::{MotorCommand, Telemetry};
use controller_core::kinematics::{Pose, TrackingError, WheelSpeeds};
use controller_core::supervisor::{Faults, RunMode, State, Supervised};

/// One telemetry line: pose, errors, wheel speeds, duties, faults and loop timing.
#[derive(Clone, Copy, Debug, defmt::Format)]
pub struct Report {
    /// Control steps since boot (1 ms each).
    pub step: u32,
    /// Supervisor state.
    pub state: State,
    /// Mode used when armed.
    pub mode: RunMode,
    /// Odometry pose, world frame (m, m, rad).
    pub pose: Pose,
    /// Tracking error against the reference, robot frame (m, m, rad); 0 unless following.
    pub error: TrackingError,
    /// Wheel-speed set-points, rad/s.
    pub setpoint: WheelSpeeds,
    /// Measured wheel speeds, rad/s.
    pub speed: WheelSpeeds,
    /// Duties written to the motors, −1…1 (0 unless armed).
    pub duty: MotorCommand,
    /// Latched faults (supervisor and core).
    pub faults: Faults,
    /// Overrun steps since boot.
    pub overruns: u32,
    /// Control periods that passed without a step of their own since boot (a step that
    /// started more than one period late counts the periods it missed).
    pub missed_ticks: u32,
    /// Supply voltage at the motor driver, V (`None` until the first conversion).
    pub supply_v: Option<f32>,
    /// CPU cycles of the last control step (encoders → supervisor → PWM), DWT CYCCNT.
    pub cycles: u32,
    /// Longest control step since boot, cycles.
    pub max_cycles: u32,
}

impl Report {
    /// The report of the step `step` that produced `out` and the controller telemetry `t`,
    /// which took `cycles` CPU cycles (longest so far: `max_cycles`), with `timing`'s
    /// missed ticks and the supply.
    pub fn new(
        step: u32,
        out: &Supervised,
        t: &Telemetry,
        timing: StepTiming,
        supply_v: Option<f32>,
    ) -> Self {
        Self {
            step,
            state: out.state,
            mode: out.run_mode,
            pose: t.pose,
            error: t.error,
            setpoint: t.wheel_setpoint,
            speed: t.wheel_speed,
            duty: out.duty,
            faults: out.faults,
            overruns: out.overruns_total,
            missed_ticks: timing.missed_ticks,
            supply_v,
            cycles: timing.cycles,
            max_cycles: timing.max_cycles,
        }
    }
}

/// Timing of the control steps, for a [`Report`].
#[derive(Clone, Copy, Debug, Default)]
pub struct StepTiming {
    /// CPU cycles of the last step.
    pub cycles: u32,
    /// Longest step since boot, cycles.
    pub max_cycles: u32,
    /// Control periods without a step of their own since boot.
    pub missed_ticks: u32,
}

/// The status LED at control step `step`: off while disarmed except a 50 ms blink every
/// second (alive), steady while armed, 5 Hz flashing while faulted, 1 Hz while writing
/// flash.
pub fn led_on(state: State, step: u32) -> bool {
    match state {
        State::Disarmed => step % 1000 < 50,
        State::Armed => true,
        State::Faulted => step % 200 < 100,
        State::Persisting => step % 1000 < 500,
    }
}
