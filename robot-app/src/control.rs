//! The control side: what runs in the control interrupt once per control period.
//!
//! [`ControlSide::step`] takes the step's [`Sensors`], at most one request forwarded by
//! the link side, runs the supervisor around the controller, and returns the
//! [`Actuation`] for the pins. On the way it answers the request (installing a staged
//! configuration or path in place, only while disarmed), queues the supervisor's event,
//! samples telemetry at the rate the link side set, accumulates the run metrics, builds
//! the report of a run that ended, and publishes its state and counters. It never waits,
//! allocates, logs or panics, and its work per step is bounded: one request, one reply,
//! one event, one telemetry sample, one report. The whole sequence, and where the other
//! tasks come in, is drawn in `docs/realtime.md`.
//!
//! The steering law (the outer loop) runs one period behind the step that hands it its
//! job: in the step itself by default, or, once [`ControlSide::lend_outer_loop`] was
//! called, in a lower-priority task between this step and the next (`crate::outer`).

use core::num::NonZeroU32;

use controller_core::controller::{Controller, MotorCommand, TickDeltas};
use controller_core::gyro::GyroSample;
use controller_core::outer_loop::{OuterLoop, OuterLoopAway};
use controller_core::pid::PidParts as CorePidParts;
use controller_core::supervisor::{
    Bridge, Command, CommandRefusal, Event, Faults, Inputs, RunMode, State, Supervisor,
    SupervisorOutput, SupervisorSetError,
};
use link::{PidParts, RawCounts, RunReport, TelemetryFrame, TuneReport};

use crate::channel::{ControlEnd, ControlRefusal, Op, Published, Report, Staged, ToLink};
use crate::metrics::{ErrorSample, ErrorStats, ErrorSummary};
use crate::outer::{OuterLoopMailbox, OuterLoopWorker};

/// What the board read for this control step, as the board reads it: the robot's
/// wiring corrections (`controller_core::wiring`) are applied by the control side.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sensors {
    /// Encoder ticks since the previous step of the board's left and right encoder
    /// inputs, each counting up the way the board calls forward.
    pub ticks: TickDeltas,
    /// Control periods since the previous step: 1 on time, more after missed ticks.
    pub periods: NonZeroU32,
    /// The board's reading of the motor supply, V (NaN when no reading is available),
    /// before the wiring's supply scale.
    pub supply_v: f32,
    /// Raw (undebounced) button level, true while pressed.
    pub button_pressed: bool,
    /// The previous step was still running when this period began.
    pub overrun: bool,
    /// A counter the lowest-priority work increments (any change proves it runs).
    pub background_heartbeat: u32,
    /// The gyro's newest reading, if one arrived since the previous step (`None`: no IMU,
    /// or no new reading).
    pub gyro: Option<GyroSample>,
}

impl Sensors {
    /// An on-time step at rest on a supply of `supply_v` (V), button released.
    pub const fn at_rest(supply_v: f32) -> Self {
        Self {
            ticks: TickDeltas { left: 0, right: 0 },
            periods: NonZeroU32::MIN,
            supply_v,
            button_pressed: false,
            overrun: false,
            background_heartbeat: 0,
            gyro: None,
        }
    }
}

/// What the board applies after a control step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Actuation {
    /// Duties to write to the board's left and right motor outputs (the wiring
    /// corrections applied), each in [−1, 1]; exactly 0 unless armed.
    pub duty: MotorCommand,
    /// What the bridge does (drive, brake, coast).
    pub bridge: Bridge,
    /// Feed the watchdog in this step.
    pub feed_watchdog: bool,
    /// Supervisor state after the step.
    pub state: State,
    /// The mode used when armed.
    pub run_mode: RunMode,
    /// Missed control ticks since start (saturating).
    pub missed_ticks_total: u32,
    /// Overrun steps since start (saturating).
    pub overruns_total: u32,
    /// The status LED's level in this step (see [`led_on`]).
    pub led_on: bool,
    /// The supply is below the battery's warning threshold.
    pub battery_low: bool,
    /// Latched faults.
    pub faults: Faults,
    /// The step's state change, if any (already queued for the link; for the board's log).
    pub event: Option<Event>,
    /// Something was queued for the link side in this step: wake its task.
    pub link_has_work: bool,
    /// The outer loop was lent with a job in this step: run the
    /// [`OuterLoopWorker`] before the next step.
    pub steering_lent: bool,
}

impl Actuation {
    /// What to apply when no control step ran: motors stopped and coasting, the watchdog
    /// not fed, nothing to do.
    pub const MOTORS_OFF: Actuation = Actuation {
        duty: MotorCommand::STOP,
        bridge: Bridge::Coast,
        feed_watchdog: false,
        state: State::Disarmed,
        run_mode: RunMode::FollowPath,
        missed_ticks_total: 0,
        overruns_total: 0,
        led_on: false,
        battery_low: false,
        faults: Faults::NONE,
        event: None,
        link_has_work: false,
        steering_lent: false,
    };
}

/// The status LED at control step `step` of a loop at `rate` steps per second: off while
/// disarmed but for a 50 ms blink every second, steady while armed, flashing at 5 Hz
/// while faulted and at 1 Hz while persisting.
pub fn led_on(state: State, step: u32, rate: NonZeroU32) -> bool {
    let per_s = rate.get();
    match state {
        State::Disarmed => blink(step, per_s, per_s / 20),
        State::Armed => true,
        State::Faulted => blink(step, per_s / 5, per_s / 10),
        State::Persisting => blink(step, per_s, per_s / 2),
    }
}

/// On for the first `on` steps of every `period` steps (always on for a period of 0).
fn blink(step: u32, period: u32, on: u32) -> bool {
    NonZeroU32::new(period).is_none_or(|p| step % p < on)
}

/// Telemetry sampling in control periods.
#[derive(Clone, Copy, Debug)]
struct TelemetryClock {
    /// The rate the period was computed for, Hz (0: off).
    hz: u8,
    /// Periods between samples (0: off).
    period: u32,
    /// Periods since the last sample.
    since: u32,
}

impl TelemetryClock {
    /// True when a sample is due after a step of `periods` periods, at `hz` (Hz) on a loop
    /// of `rate` periods per second.
    fn due(&mut self, hz: u8, rate: NonZeroU32, periods: NonZeroU32) -> bool {
        if hz != self.hz {
            self.hz = hz;
            // At least one period: a rate above the loop's samples every step.
            self.period = NonZeroU32::new(u32::from(hz)).map_or(0, |hz| (rate.get() / hz).max(1));
            self.since = 0;
        }
        if self.period == 0 {
            return false;
        }
        self.since = self.since.saturating_add(periods.get());
        if self.since < self.period {
            return false;
        }
        // Keep the remainder, so late steps do not slow the average rate, but never
        // owe more than one sample.
        self.since -= self.period;
        if self.since >= self.period {
            self.since = 0;
        }
        true
    }
}

/// The control side (see the module doc). Owned by the control interrupt.
pub struct ControlSide<'a> {
    end: ControlEnd<'a>,
    controller: Controller<OuterLoopMailbox<'a>>,
    /// The outer loop's other end, until [`ControlSide::lend_outer_loop`] hands it out.
    worker: Option<OuterLoopWorker<'a>>,
    supervisor: Supervisor,
    metrics: ErrorStats,
    rate: NonZeroU32,
    /// Control steps since start (wrapping).
    step: u32,
    /// Control periods since the robot was last armed to follow the path.
    run_periods: u32,
    /// A path-following run is in progress (its report is due when it ends).
    in_run: bool,
    /// Armed in tune mode (a tune's end is reported once).
    in_tune: bool,
    /// Tunes ended since start.
    tunes_ended: u16,
    /// Path-following runs ended since start.
    runs_ended: u16,
    /// Largest |measured wheel speed| (rad/s) and |duty| of the run so far.
    run_max_wheel_rad_s: f32,
    run_max_duty: f32,
    telemetry: TelemetryClock,
    /// The board's encoder inputs' positions since start, counts (wrapping).
    raw_counts: RawCounts,
}

impl<'a> ControlSide<'a> {
    /// The control side around `controller` and `supervisor`, talking to the link side
    /// through `end`; `worker` is the other end of the controller's outer-loop holder.
    /// [`crate::start`] builds both sides from one configuration.
    pub(crate) fn new(
        end: ControlEnd<'a>,
        controller: Controller<OuterLoopMailbox<'a>>,
        supervisor: Supervisor,
        worker: OuterLoopWorker<'a>,
    ) -> Self {
        let rate = controller.params().control_rate();
        Self {
            end,
            controller,
            worker: Some(worker),
            supervisor,
            metrics: ErrorStats::new(rate),
            rate,
            step: 0,
            run_periods: 0,
            in_run: false,
            in_tune: false,
            tunes_ended: 0,
            runs_ended: 0,
            run_max_wheel_rad_s: 0.0,
            run_max_duty: 0.0,
            telemetry: TelemetryClock {
                hz: 0,
                period: 0,
                since: 0,
            },
            raw_counts: RawCounts { left: 0, right: 0 },
        }
    }

    /// The controller (its telemetry, parameters, and its outer loop while held).
    pub const fn controller(&self) -> &Controller<OuterLoopMailbox<'a>> {
        &self.controller
    }

    /// From now on, lends the outer loop with each job to the returned worker, to run in
    /// a lower-priority task between two steps (`crate::outer`), instead of running it
    /// in the step. `None` if it was handed out already.
    pub fn lend_outer_loop(&mut self) -> Option<OuterLoopWorker<'a>> {
        let worker = self.worker.take()?;
        self.controller.holder_mut().lend_from_now_on();
        Some(worker)
    }

    /// The supervisor (its state, settings, faults).
    pub const fn supervisor(&self) -> &Supervisor {
        &self.supervisor
    }

    /// Control steps since start.
    pub const fn steps(&self) -> u32 {
        self.step
    }

    /// The run metrics of the current or last path-following run, from the controller's
    /// own (estimated) tracking error at every steering update. Costs a square root: call
    /// it outside the control step's hot path (e.g. on a `Disarmed` event).
    pub fn run_summary(&self) -> ErrorSummary {
        self.metrics.summary()
    }

    /// One control period (see the module doc).
    pub fn step(&mut self, sensors: Sensors) -> Actuation {
        self.step = self.step.wrapping_add(1);
        let mut link_has_work = false;

        // 0. The outer loop comes back with its outcome. Not back yet: it overran the
        //    period, which the supervisor counts as an overrun of this step.
        let outer_loop_held = self.controller.collect_steering();

        // 1. At most one request from the link, and only when its reply and this step's
        //    event both have room: replies are never dropped. Not while the outer loop
        //    is away: an installation rebuilds it.
        let mut command = None;
        let mut answered = None;
        if outer_loop_held && self.end.uplink.free() >= 2 {
            if let Some(request) = self.end.commands.pop() {
                let kind = request.op.kind();
                let result = match request.op {
                    Op::Command(c) => {
                        command = Some(c);
                        None
                    }
                    Op::BeginPersist => {
                        command = Some(Command::BeginPersist);
                        None
                    }
                    Op::EndPersist => {
                        command = Some(Command::EndPersist);
                        None
                    }
                    Op::Install => Some(self.install_staged()),
                };
                answered = Some((request.seq, kind, result));
            }
        }

        // 2. The supervisor steps the controller, on the wheels' ticks and the supply as
        //    the wiring corrections make them of the board's readings.
        self.raw_counts.left = self.raw_counts.left.wrapping_add(sensors.ticks.left);
        self.raw_counts.right = self.raw_counts.right.wrapping_add(sensors.ticks.right);
        let wiring = self.controller.params().config().wiring;
        let out = self.supervisor.step(
            &mut self.controller,
            Inputs {
                ticks: wiring.ticks_from_board(sensors.ticks),
                periods: sensors.periods,
                supply_v: wiring.supply_from_board(sensors.supply_v),
                button_pressed: sensors.button_pressed,
                overrun: sensors.overrun || !outer_loop_held,
                background_heartbeat: sensors.background_heartbeat,
                command,
                gyro: sensors.gyro,
            },
        );

        // The outer loop's job, if this step handed one over and it is lent out.
        let steering_lent = self.controller.lend_steering();

        // 3. Reply and event.
        if let Some((seq, op, result)) = answered {
            let result = result.unwrap_or_else(|| command_outcome(command, out.command_result));
            // Room was checked before taking the request.
            let _ = self.end.uplink.push(ToLink::Reply { seq, op, result });
            link_has_work = true;
        }
        if let Some(event) = out.event {
            let queued = self.end.uplink.push(ToLink::Event {
                step: self.step,
                event,
            });
            if queued.is_ok() {
                link_has_work = true;
            } else {
                self.end.count_event_drop();
            }
        }

        // 4. Run metrics (and the report of a run that ended) and telemetry.
        let run_ended = self.track_run(&out, sensors.periods);
        let tune_ended = self.track_tune(&out);
        if run_ended || tune_ended {
            link_has_work = true;
        }
        if self
            .telemetry
            .due(self.end.telemetry_hz(), self.rate, sensors.periods)
        {
            // Built in its slot: a 160-byte frame is not copied on the way.
            if self
                .end
                .telemetry
                .push_with(|| telemetry_frame(&self.controller, self.step, &out, self.raw_counts))
            {
                link_has_work = true;
            } else {
                self.end.count_telemetry_drop();
            }
        }

        self.end.publish(Published {
            state: out.state,
            step: self.step,
            missed_ticks: out.missed_ticks_total,
            overruns: out.overruns_total,
        });
        Actuation {
            // Read after the step: an installation in it may have changed the wiring.
            duty: self
                .controller
                .params()
                .config()
                .wiring
                .duties_to_board(out.duty),
            bridge: out.bridge,
            feed_watchdog: out.feed_watchdog,
            state: out.state,
            run_mode: out.run_mode,
            missed_ticks_total: out.missed_ticks_total,
            overruns_total: out.overruns_total,
            led_on: led_on(out.state, self.step, self.rate),
            battery_low: out.battery_low,
            faults: out.faults,
            event: out.event,
            link_has_work,
            steering_lent,
        }
    }

    /// Installs what is staged, atomically, if the robot is disarmed (the supervisor
    /// refuses otherwise); hands the staging area back either way. Rebuilds the
    /// controller and the supervisor in place. Out of line: its frame is paid only when
    /// installing.
    #[inline(never)]
    fn install_staged(&mut self) -> Result<(), ControlRefusal> {
        let result = match self.end.staging.staged() {
            Some(staged) => install(staged, &mut self.controller, &mut self.supervisor),
            None => Err(ControlRefusal::Busy),
        };
        if result.is_ok() {
            self.metrics.restart();
        }
        self.end.staging.finish();
        result
    }

    /// Feeds the run metrics: restarted when the robot is armed to follow the path, fed
    /// with the controller's estimated error at every steering update while it does.
    /// When the run ends (the robot leaves armed path following), queues its
    /// [`RunReport`] for the link side and returns true.
    fn track_run(&mut self, out: &SupervisorOutput, periods: NonZeroU32) -> bool {
        if out.event == Some(Event::Armed(RunMode::FollowPath)) {
            self.metrics.restart();
            self.run_periods = 0;
            self.run_max_wheel_rad_s = 0.0;
            self.run_max_duty = 0.0;
            self.in_run = true;
        }
        if out.state != State::Armed || out.run_mode != RunMode::FollowPath {
            if !self.in_run {
                return false;
            }
            self.end_run();
            return true;
        }
        let t = self.controller.telemetry();
        if t.steering_updated {
            self.metrics.push(ErrorSample {
                step: self.run_periods,
                position_m: t.error.position_m(),
                heading_rad: t.error.theta_e_rad,
            });
        }
        // Written out: loops over two-element arrays cost every armed step about 140
        // instructions more on the Cortex-M4F at the firmware's opt-level "z".
        let wheel = max_abs(self.run_max_wheel_rad_s, t.wheel_speed.left_rad_s);
        self.run_max_wheel_rad_s = max_abs(wheel, t.wheel_speed.right_rad_s);
        let duty = max_abs(self.run_max_duty, out.duty.left);
        self.run_max_duty = max_abs(duty, out.duty.right);
        self.run_periods = self.run_periods.saturating_add(periods.get());
        false
    }

    /// The run ended in this step: its report goes to the link side (dropped if the
    /// previous one is still there, which takes two runs ending between two link polls).
    /// Out of line: its report's storage is on the stack only in the step that ends a run.
    #[inline(never)]
    fn end_run(&mut self) {
        self.in_run = false;
        self.runs_ended = self.runs_ended.wrapping_add(1);
        let report = self.run_report();
        let _ = self.end.reports.push(Report::Run(report));
    }

    /// Watches for a wheel-loop tune's end (armed in tune mode, then anything else: done,
    /// a fault, the button or the link): its outcome goes to the link side (as a run's
    /// report does). Returns true when it ended this step.
    fn track_tune(&mut self, out: &SupervisorOutput) -> bool {
        if out.event == Some(Event::Armed(RunMode::Tune)) {
            self.in_tune = true;
        }
        if !self.in_tune || (out.state == State::Armed && out.run_mode == RunMode::Tune) {
            return false;
        }
        self.end_tune();
        true
    }

    /// The tune ended: its report goes to the link side (as a run's does). Out of line,
    /// like [`ControlSide::end_run`].
    #[inline(never)]
    fn end_tune(&mut self) {
        self.in_tune = false;
        self.tunes_ended = self.tunes_ended.wrapping_add(1);
        let report = self.tune_report();
        let _ = self.end.reports.push(Report::Tune(report));
    }

    /// The outcome of the last wheel-loop tune ([`TuneReport::NONE`] before any).
    pub fn tune_report(&self) -> TuneReport {
        match self.supervisor.tune_outcome() {
            Some(outcome) if self.tunes_ended > 0 => TuneReport {
                tunes_ended: self.tunes_ended,
                outcome,
            },
            _ => TuneReport::NONE,
        }
    }

    /// The report of the current or last path-following run (a square root: see
    /// [`ControlSide::run_summary`]).
    pub fn run_report(&self) -> RunReport {
        RunReport {
            runs_ended: self.runs_ended,
            run_steps: self.run_periods,
            estimated: self.metrics.summary(),
            max_wheel_speed_rad_s: self.run_max_wheel_rad_s,
            max_duty: self.run_max_duty,
        }
    }
}

/// The telemetry sample of step `step`: the supervisor's outputs `out` and `controller`'s
/// telemetry (pose and error in the world frame, m and rad; wheel speeds in rad/s), and
/// the board's encoder positions `raw_counts`.
fn telemetry_frame(
    controller: &Controller<OuterLoopMailbox<'_>>,
    step: u32,
    out: &SupervisorOutput,
    raw_counts: RawCounts,
) -> TelemetryFrame {
    let t = controller.telemetry();
    let [left, right] = controller.wheel_pid_parts();
    TelemetryFrame {
        step,
        state: out.state,
        run_mode: out.run_mode,
        faults: out.faults,
        pose: t.pose,
        tracking_error: t.error,
        lyapunov: t.law.lyapunov,
        lyapunov_rate: t.law.lyapunov_rate,
        wheel_setpoint: t.wheel_setpoint,
        wheel_speed: t.wheel_speed,
        duty: out.duty,
        pid_left: pid_parts(left),
        pid_right: pid_parts(right),
        supply_v: t.supply_v,
        missed_ticks: out.missed_ticks_total,
        gyro_yaw_rate_radps: t.gyro.yaw_rate_radps,
        gyro_bias_radps: t.gyro.bias_radps,
        fused_heading_rad: controller.fused_heading_rad(),
        odometry_heading_rad: controller.odometry_heading_rad(),
        gyro_health: t.gyro.health,
        raw_counts,
    }
}

/// The larger of `max` and |`value`| (a NaN value leaves `max`). The magnitude is the
/// sign bit cleared (`controller_core::math::abs`), not a comparison with 0: four of these
/// run in every armed step.
fn max_abs(max: f32, value: f32) -> f32 {
    let magnitude = controller_core::math::abs(value);
    if magnitude > max {
        magnitude
    } else {
        max
    }
}

/// The telemetry's PID parts from the core's: the wheel loop runs in volts, so each part
/// is a voltage, and P + I + D + FF is the armature voltage the loop asked for before
/// the limits after the PID (see `controller_core::pid`).
pub fn pid_parts(parts: CorePidParts) -> PidParts {
    PidParts {
        p_v: parts.p,
        i_v: parts.i,
        d_v: parts.d,
        ff_v: parts.ff,
    }
}

/// Installs `staged` into `controller` and `supervisor`: both change or neither. The
/// supervisor refuses unless disarmed; the controller is rebuilt (in place) only after it
/// accepted. Out of line: its frame is paid only when installing.
#[inline(never)]
fn install(
    staged: &Staged,
    controller: &mut Controller<OuterLoopMailbox<'_>>,
    supervisor: &mut Supervisor,
) -> Result<(), ControlRefusal> {
    // The step takes no request while the outer loop is away; checked first all the same,
    // so that the supervisor and the controller both change or neither does.
    let Some(law) = controller.steering().map(OuterLoop::law) else {
        return Err(ControlRefusal::Busy);
    };
    match staged {
        Staged::Params {
            params,
            supervisor: config,
        } => {
            supervisor
                .set_config(*config, params)
                .map_err(set_refusal)?;
            // Same path, law and pose; new geometry, gains and limits.
            controller
                .rebuild(params, law)
                .map_err(|OuterLoopAway| ControlRefusal::Busy)?;
        }
        Staged::Path(path) => {
            supervisor
                .set_config(path.supervisor, controller.params())
                .map_err(set_refusal)?;
            // The robot stays where it is: the pose command puts it at the start.
            controller
                .follow(&path.reference, path.law)
                .map_err(|OuterLoopAway| ControlRefusal::Busy)?;
        }
        // The link side never publishes an upload being assembled.
        Staged::Assembling(_) => return Err(ControlRefusal::Busy),
    }
    Ok(())
}

fn set_refusal(error: SupervisorSetError) -> ControlRefusal {
    match error {
        SupervisorSetError::NotDisarmed(state) => state_refusal(state),
        SupervisorSetError::Invalid(_) | SupervisorSetError::InvalidTune(_) => {
            ControlRefusal::Invalid
        }
    }
}

/// Why something that needs the robot disarmed was refused in `state`.
const fn state_refusal(state: State) -> ControlRefusal {
    match state {
        State::Armed => ControlRefusal::Armed,
        State::Faulted => ControlRefusal::Faulted,
        State::Disarmed | State::Persisting => ControlRefusal::Busy,
    }
}

/// The reply to a supervisor command. A command the supervisor refuses only because it is
/// already done (clearing faults or ending persistence while disarmed) succeeds, so a
/// host may repeat any request whose reply it lost.
fn command_outcome(
    command: Option<Command>,
    result: Option<Result<(), CommandRefusal>>,
) -> Result<(), ControlRefusal> {
    match result {
        None | Some(Ok(())) => Ok(()),
        Some(Err(CommandRefusal::ButtonHeld)) => Err(ControlRefusal::ButtonHeld),
        Some(Err(CommandRefusal::WheelsTurning)) => Err(ControlRefusal::WheelsTurning),
        // The link side refuses a non-finite pose or velocity by its field before
        // forwarding it.
        Some(Err(CommandRefusal::NonFinitePose | CommandRefusal::NonFiniteVelocity)) => {
            Err(ControlRefusal::Invalid)
        }
        // The link side refuses a pulse out of bounds by its field before forwarding it.
        Some(Err(CommandRefusal::MotorTestOutOfBounds)) => Err(ControlRefusal::Invalid),
        Some(Err(CommandRefusal::WrongMode(_))) => Err(ControlRefusal::NotInVelocityMode),
        Some(Err(CommandRefusal::WrongState(State::Faulted))) => Err(ControlRefusal::Faulted),
        Some(Err(CommandRefusal::WrongState(_)))
            if matches!(command, Some(Command::Velocity(_))) =>
        {
            Err(ControlRefusal::NotInVelocityMode)
        }
        Some(Err(CommandRefusal::WrongState(State::Disarmed))) => match command {
            Some(Command::ClearFaults | Command::EndPersist) => Ok(()),
            _ => Err(ControlRefusal::Busy),
        },
        Some(Err(CommandRefusal::WrongState(state))) => Err(state_refusal(state)),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const KHZ: NonZeroU32 = match NonZeroU32::new(1000) {
        Some(r) => r,
        None => NonZeroU32::MIN,
    };

    #[test]
    fn the_led_tells_the_state() {
        let on =
            |state, steps: core::ops::Range<u32>| steps.filter(|&s| led_on(state, s, KHZ)).count();
        assert_eq!(on(State::Disarmed, 0..1000), 50);
        assert_eq!(on(State::Armed, 0..1000), 1000);
        assert_eq!(on(State::Faulted, 0..1000), 500);
        assert_eq!(
            on(State::Faulted, 0..100),
            100,
            "on for the first 100 ms of 200"
        );
        assert_eq!(on(State::Persisting, 0..1000), 500);
        // A loop too slow for the pattern's periods shows steady on, never divides by 0.
        let one = NonZeroU32::MIN;
        assert!(led_on(State::Faulted, 3, one));
    }

    #[test]
    fn telemetry_is_due_at_the_rate_in_control_periods() {
        let mut clock = TelemetryClock {
            hz: 0,
            period: 0,
            since: 0,
        };
        let one = NonZeroU32::MIN;
        assert!(!(0..100).any(|_| clock.due(0, KHZ, one)), "off");
        let due: usize = (0..1000).filter(|_| clock.due(50, KHZ, one)).count();
        assert_eq!(due, 50);
        // A late step counts the periods it covered.
        let three = NonZeroU32::new(3).unwrap_or(one);
        let due: usize = (0..100).filter(|_| clock.due(100, KHZ, three)).count();
        assert_eq!(due, 30, "one per 10 periods: 300 periods in steps of 3");
        // Faster than the loop: every step.
        let mut clock = TelemetryClock {
            hz: 0,
            period: 0,
            since: 0,
        };
        let slow = NonZeroU32::new(50).unwrap_or(one);
        assert!((0..10).all(|_| clock.due(100, slow, one)));
    }

    #[test]
    fn repeated_commands_that_are_already_done_succeed() {
        let wrong = |s| Some(Err(CommandRefusal::WrongState(s)));
        assert_eq!(
            command_outcome(Some(Command::ClearFaults), wrong(State::Disarmed)),
            Ok(())
        );
        assert_eq!(
            command_outcome(Some(Command::EndPersist), wrong(State::Disarmed)),
            Ok(())
        );
        assert_eq!(
            command_outcome(Some(Command::BeginPersist), wrong(State::Armed)),
            Err(ControlRefusal::Armed)
        );
        assert_eq!(
            command_outcome(Some(Command::ClearFaults), wrong(State::Armed)),
            Err(ControlRefusal::Armed)
        );
        assert_eq!(
            command_outcome(Some(Command::Heartbeat), wrong(State::Persisting)),
            Err(ControlRefusal::Busy)
        );
        assert_eq!(
            command_outcome(Some(Command::Disarm), Some(Err(CommandRefusal::ButtonHeld))),
            Err(ControlRefusal::ButtonHeld)
        );
    }

    #[test]
    fn run_maxima_are_of_magnitudes_and_ignore_nan() {
        assert_eq!(max_abs(0.5, -2.0), 2.0);
        assert_eq!(max_abs(0.5, 0.25), 0.5);
        assert_eq!(max_abs(0.5, -0.25), 0.5);
        assert_eq!(max_abs(0.5, f32::NAN), 0.5);
        assert_eq!(max_abs(0.0, -0.0), 0.0);
    }

    #[test]
    fn pid_parts_keep_each_part_in_its_place() {
        let parts = pid_parts(CorePidParts {
            p: 1.0,
            i: 2.0,
            d: 3.0,
            ff: 4.0,
        });
        assert_eq!(
            (parts.p_v, parts.i_v, parts.d_v, parts.ff_v),
            (1.0, 2.0, 3.0, 4.0)
        );
    }
}
