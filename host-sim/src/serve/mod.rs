//! The virtual robot: the robot's own application logic against the simulated hardware,
//! speaking the runtime link over TCP (`host-sim serve`).
//!
//! It runs exactly what the firmware runs — robot-app's [`ControlSide`] (supervisor and
//! controller) and [`LinkService`] (decoding, replies, heartbeat timeout counted in
//! control steps, path staging, run reports) — against [`SimHardware`], in one thread:
//! bytes from the socket into the link side, one control step, the link side's poll,
//! bytes out. Everything the station does with a robot works against it; ArduPilot's SITL
//! is the precedent.
//!
//! What it adds, because it knows the truth:
//!
//! - [`link::Uplink::GroundTruth`] after every telemetry frame, for the same step: the
//!   plant's pose, body velocity and wheel speeds when the sensors were read;
//! - [`link::Uplink::GroundTruthRun`] right after the robot's own run report: the true
//!   pose against the reference at every steering period of the run ([`TrueRun`]), the
//!   same statistics `host-sim run` computes.
//!
//! # The operator's hands
//!
//! The virtual robot watches the link in both directions as an operator at the bench
//! would, and acts on the plant only:
//!
//! - **A committed path** puts the robot at the path's start pose, at rest (a new
//!   hardware: encoders, noise and injected faults start again, as in a fresh
//!   `host-sim run`). It moves the plant only: the robot's own estimate is set by the
//!   pose command (`SetPose`, which `station run` sends after the upload, or a long
//!   press), as on the robot; re-armed without one, the robot goes on from where its
//!   odometry says it is.
//! - **The plant holds still until the robot is armed**: while it waits, each control
//!   step reads the sensors of a copy of the hardware, so the noise the run will see
//!   starts at the arming step, the run's first, exactly as in `host-sim run`, and the
//!   supply filter holds the one reading it would take at arming. The gyro alone reads
//!   on, as a real IMU does while its robot waits: the robot learns its bias at rest and
//!   sees a turn by hand.
//! - **Arming in motion** (an `Arm` whose `initial_motion` is set): the plant's wheels are
//!   spun up to that motion at the arming step. When the asserted motion (f32 on the
//!   wire) is the scenario's start motion rounded to f32, the scenario's own f64 values are
//!   used, and likewise for a committed start pose equal to the scenario's start: the
//!   plant then starts exactly where `host-sim run` starts it.
//!
//! After a run the plant goes on (braking, coasting) until the next path is committed.
//!
//! # Miswired, and the bench's hands
//!
//! Between the plant and the robot's board sit the wires ([`miswire`]): a robot served
//! with `--miswire` (or its scenario's `[virtual_robot] miswire`) has motors or encoders
//! inverted or swapped, encoders of another resolution or a supply reading that is off,
//! exactly where a real robot's wiring would have them; the robot's own wiring
//! corrections are what undoes them. For tests only, [`hands`] turn a wheel by hand,
//! press the button, watch the LED and measure the pose with a tape.
//!
//! It reports its brown-out reset at level 3, as a set-up robot does.
//!
//! # In Foxglove
//!
//! With a [`LiveStream`] (`serve --foxglove`), every step may be sampled as a trace row
//! ([`VirtualRobot::trace_row`]) and streamed; the stream's parameter changes reach the
//! link side as the robot's own requests ([`VirtualRobot::request_locally`]), whose
//! replies go to no host.

pub mod hands;
mod hosts;
mod live;
pub mod miswire;
mod truth;

use std::io::ErrorKind;
use std::net::TcpListener;
use std::num::NonZeroU32;
use std::time::{Duration, Instant};

use controller_core::kinematics::{BodyVelocity, Pose, WheelSpeeds};
use controller_core::law::LawKind;
use controller_core::reference::Reference;
use controller_core::supervisor::{Event, ResetCause, RunMode, State};
use link::{
    encode, BrownOutReset, ClockSource, Decoder, Downlink, GroundTruth, ParamSet, Received,
    Refusal, Reply, Request, Uplink, MAX_FRAME_LEN,
};
use robot_app::stm32f4::bridge::BridgeChip;
use robot_app::{
    start, AppConfig, Channels, ControlSide, Identity, LinkOptions, LinkService, NoBoardStats,
    Sensors,
};
use robot_files::plant::DriverKind;
use robot_files::scenario::{Scenario, StartState};
use robot_files::trace::{SampleDetail, TraceRow};
use robot_files::truth::{tracking_error_f64, true_error, TruePose};

use crate::hardware::{Actuation, SimHardware};
use crate::plant::{Plant, PlantError};

use self::hands::{Bench, HandStep, Hands};
use self::hosts::Hosts;
pub use self::live::LiveStream;
use self::miswire::{MiswireError, Miswiring, Wires};
pub use self::truth::TrueRun;

/// The UART rate the virtual robot's link pretends to have, baud: fast enough for the
/// link's top telemetry rate (100 Hz).
pub const VIRTUAL_BAUD: u32 = 921_600;

/// Why the virtual robot could not be built.
#[derive(Debug, thiserror::Error)]
pub enum ServeError {
    /// The scenario's robot or supervisor settings are invalid.
    #[error("robot configuration: {0}")]
    Start(String),
    /// The scenario's plant is invalid.
    #[error(transparent)]
    Plant(#[from] PlantError),
    /// The scenario's reference could not be built.
    #[error("reference: {0}")]
    Reference(controller_core::reference::ReferenceError),
    /// The scenario's `[virtual_robot] miswire` list is invalid.
    #[error("[virtual_robot] miswire: {0}")]
    Miswire(#[from] MiswireError),
}

/// What one control step of the virtual robot did, for its log.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StepReport {
    /// Control step (since start).
    pub step: u32,
    /// The supervisor's state change in this step, if any.
    pub event: Option<Event>,
    /// The supervisor's state after the step.
    pub state: State,
    /// Control steps since the last heartbeat the robot accepted (counted by the
    /// virtual robot from the link's traffic).
    pub steps_since_heartbeat: u32,
}

/// The simulated robot behind the link (see the module doc).
pub struct VirtualRobot<'a> {
    scenario: Scenario,
    control: ControlSide<'a>,
    link: LinkService<'a>,
    hardware: SimHardware,
    /// The plant holds still (placed, not yet armed).
    frozen: bool,
    tap_in: Decoder,
    tap_out: Decoder,
    /// `initial_motion` of the last `Arm` seen on the link.
    arm_motion: Option<BodyVelocity>,
    /// The background counter the supervisor watches.
    background: u32,
    truth: Option<TrueRun>,
    persisted: Option<ParamSet>,
    /// Bytes received and not yet taken by the link side.
    pending_in: Vec<u8>,
    /// Bytes for the host, oldest first.
    outgoing: Vec<u8>,
    /// Control step of the last `Heartbeat` the link side took.
    last_heartbeat_step: u32,
    /// The wires between the plant and the board.
    wires: Wires,
    /// The bench's hands (tests only).
    hands: Option<Hands>,
    /// The last step's supervisor outcome and the plant's truth when its sensors were
    /// read (pose, body velocity, wheel speeds): what [`VirtualRobot::trace_row`] shows.
    last_step: Option<LastStep>,
    /// The reply to the request sent with [`VirtualRobot::request_locally`], once it came.
    local_reply: Option<Result<Reply, Refusal>>,
}

/// A step's supervisor outcome and the plant's truth when its sensors were read.
#[derive(Clone, Copy, Debug)]
struct LastStep {
    out: robot_app::Actuation,
    pose: TruePose,
    /// Body velocity (m/s, rad/s).
    velocity: (f64, f64),
    /// Wheel speeds [left, right], rad/s.
    wheels: [f64; 2],
}

/// The `seq` of the requests the virtual robot sends itself
/// ([`VirtualRobot::request_locally`]); their replies go to no host.
pub const LOCAL_SEQ: u16 = 0xF0F0;

impl<'a> VirtualRobot<'a> {
    /// The virtual robot of `scenario` (its robot, supervisor, path and plant), disarmed,
    /// placed at the scenario's start, talking through `channels`.
    pub fn new(channels: &'a mut Channels, scenario: &Scenario) -> Result<Self, ServeError> {
        let reference = Reference::new(
            scenario.path.clone(),
            scenario.reference_speed_m_s,
            scenario.reference_mode,
        )
        .map_err(ServeError::Reference)?;
        let config = AppConfig {
            params: ParamSet {
                robot: scenario.robot,
                supervisor: scenario.supervisor,
            },
            reference,
            law: LawKind::Tracking,
            reset: ResetCause::PowerOn,
            identity: Identity {
                firmware_version: env!("CARGO_PKG_VERSION"),
                git_hash: "",
                chip: "host-sim virtual robot",
                robot_name: leak(&scenario.name),
                clock: ClockSource::Simulated,
                // Its flash is memory, but it answers as a robot whose supply is guarded,
                // so that what a host does before persisting runs as on a set-up robot.
                brown_out_reset: BrownOutReset::Level3,
            },
            link: LinkOptions {
                baud: VIRTUAL_BAUD,
                telemetry_hz: 0,
                storage: true,
            },
            bridge: match scenario.plant.driver.kind {
                DriverKind::Tb6612 => BridgeChip::Tb6612fng,
                DriverKind::Drv8833 => BridgeChip::Drv8833,
            },
        };
        let (control, link) =
            start(channels, config).map_err(|e| ServeError::Start(e.to_string()))?;
        let hardware = SimHardware::new(&placed(scenario, &scenario.start), &scenario.faults)?;
        let miswiring: Miswiring = scenario.miswire.parse()?;
        Ok(Self {
            scenario: scenario.clone(),
            control,
            link,
            hardware,
            frozen: true,
            tap_in: Decoder::new(),
            tap_out: Decoder::new(),
            arm_motion: None,
            background: 0,
            truth: None,
            persisted: None,
            pending_in: Vec::new(),
            outgoing: Vec::new(),
            last_heartbeat_step: 0,
            wires: Wires::new(miswiring),
            hands: None,
            last_step: None,
            local_reply: None,
        })
    }

    /// Miswires the robot as `miswiring` says (over its scenario's list).
    pub fn miswire(&mut self, miswiring: Miswiring) {
        self.wires = Wires::new(miswiring);
    }

    /// How the robot is miswired.
    pub fn miswiring(&self) -> &Miswiring {
        self.wires.miswiring()
    }

    /// Gives the bench these hands (tests only: see [`hands`]).
    pub fn attach_hands(&mut self, hands: Hands) {
        self.hands = Some(hands);
    }

    /// The control side (supervisor, controller).
    pub fn control(&self) -> &ControlSide<'a> {
        &self.control
    }

    /// The link side.
    pub fn link(&self) -> &LinkService<'a> {
        &self.link
    }

    /// The simulated hardware (the plant's true state).
    pub fn hardware(&self) -> &SimHardware {
        &self.hardware
    }

    /// The configuration last persisted with `PersistParams` (kept in memory).
    pub fn persisted(&self) -> Option<&ParamSet> {
        self.persisted.as_ref()
    }

    /// Queues bytes received from the host.
    pub fn receive(&mut self, bytes: &[u8]) {
        self.pending_in.extend_from_slice(bytes);
    }

    /// Bytes waiting for the host.
    pub fn outgoing(&self) -> &[u8] {
        &self.outgoing
    }

    /// The host took the first `sent` bytes of [`VirtualRobot::outgoing`].
    pub fn consume(&mut self, sent: usize) {
        self.outgoing.drain(..sent.min(self.outgoing.len()));
    }

    /// Sends the link side `request` as if a host had, with [`LOCAL_SEQ`], when no host's
    /// bytes are half-way through (else `false`: try again at a later step). Its reply is
    /// kept for [`VirtualRobot::take_local_reply`] and not sent to any host.
    pub fn request_locally(&mut self, request: Request) -> bool {
        if !self.pending_in.is_empty() {
            return false;
        }
        let mut wire = [0u8; MAX_FRAME_LEN];
        let Ok(len) = encode(
            &Downlink {
                seq: LOCAL_SEQ,
                request,
            },
            &mut wire,
        ) else {
            return false;
        };
        self.pending_in
            .extend_from_slice(wire.get(..len).unwrap_or_default());
        true
    }

    /// The reply to the last [`VirtualRobot::request_locally`], once it came.
    pub fn take_local_reply(&mut self) -> Option<Result<Reply, Refusal>> {
        self.local_reply.take()
    }

    /// The last step as a trace row (the rows `trace.csv` and the Foxglove channels
    /// show): the controller's telemetry, the supervisor's outcome, and the truth when
    /// the sensors were read; the reference, and the true errors against it, only while
    /// a path-following run is measured (NaN otherwise). `None` before the first step.
    pub fn trace_row(&self) -> Option<TraceRow> {
        let LastStep {
            out,
            pose,
            velocity,
            wheels,
        } = self.last_step?;
        let controller = self.control.controller();
        let t = controller.telemetry();
        let nan = f64::NAN;
        let reference = self.truth.as_ref().map(TrueRun::reference_pose);
        Some(TraceRow {
            t_s: f64::from(self.control.steps()) / f64::from(self.scenario.robot.control_rate_hz),
            true_pose: pose,
            est_pose: t.pose,
            reference: reference.unwrap_or(Pose::new(f32::NAN, f32::NAN, f32::NAN)),
            error: t.error,
            true_error: reference.map_or((nan, nan), |r| true_error(&r, &pose)),
            true_tracking: reference.map_or([nan; 3], |r| tracking_error_f64(&pose, &r)),
            lyapunov: t.law.lyapunov,
            command: t.command,
            true_velocity: velocity,
            setpoint: t.wheel_setpoint,
            measured: t.wheel_speed,
            true_wheel: wheels,
            volts: [t.wheel_loop.volts.left_v, t.wheel_loop.volts.right_v],
            duty: out.duty,
            supply_v: t.supply_v,
            state: out.state,
            detail: SampleDetail {
                lyapunov_rate: t.law.lyapunov_rate,
                pid: controller.wheel_pid_parts(),
                faults: out.faults,
            },
        })
    }

    /// The robot's active configuration (what `GetParams` answers).
    pub fn active_params(&self) -> ParamSet {
        *self.link.active_params()
    }

    /// The path the robot follows now, world frame.
    pub fn path(&self) -> Option<&controller_core::path::Path> {
        self.control
            .controller()
            .steering()
            .map(|steering| steering.reference().path())
    }

    /// One control period (module doc).
    pub fn step(&mut self) -> StepReport {
        // 1. Received bytes into the link side, as far as it takes them.
        let taken = self.link.receive(&self.pending_in, &NoBoardStats);
        let mut heartbeat_taken = false;
        for outcome in self.tap_in.feed::<Downlink>(&self.pending_in[..taken]) {
            if let Ok(Received::Message(Downlink { request, .. })) = outcome {
                match request {
                    Request::Arm { initial_motion, .. } => self.arm_motion = initial_motion,
                    Request::Heartbeat => heartbeat_taken = true,
                    _ => {}
                }
            }
        }
        self.pending_in.drain(..taken);

        // 2. The hands, then the sensors: of a copy while the plant holds still (module
        // doc). The hands turn the encoders at the plant's resolution, before the wires,
        // and a robot they rotate on the spot turns before its gyro reads.
        let pose = self.hardware.plant().pose();
        let wheels = self.hardware.plant().wheel_speeds();
        let velocity = self.hardware.plant().body_velocity();
        let by_hand = match &mut self.hands {
            Some(hands) => hands.step(&bench(&self.scenario, self.hardware.plant()), &pose),
            None => HandStep::default(),
        };
        if by_hand.yaw_rad != 0.0 {
            self.hardware.rotate_by_hand(by_hand.yaw_rad);
        }
        // The truth the step reports is the robot's as its sensors read it: turned.
        let pose = self.hardware.plant().pose();
        let mut probe = None;
        let sensed = if self.frozen {
            let mut copy = self.hardware.clone();
            let sensed = copy.sense(1);
            self.hardware.keep_gyro_of(&copy);
            probe = Some(copy);
            sensed
        } else {
            let periods = self.hardware.periods_until_next_step();
            self.hardware.sense(periods)
        };
        self.background = self.background.wrapping_add(1);
        let periods = NonZeroU32::new(sensed.periods).unwrap_or(NonZeroU32::MIN);
        let wheel_ticks = controller_core::controller::TickDeltas {
            left: sensed.ticks.left.wrapping_add(by_hand.ticks.left),
            right: sensed.ticks.right.wrapping_add(by_hand.ticks.right),
        };
        let out = self.control.step(Sensors {
            ticks: self.wires.board_ticks(wheel_ticks),
            periods,
            supply_v: self.wires.board_supply(sensed.supply_v),
            button_pressed: sensed.button_pressed || by_hand.pressed,
            overrun: false,
            background_heartbeat: self.background,
            gyro: self.wires.board_gyro(sensed.gyro),
        });
        if let Some(hands) = &mut self.hands {
            hands.see_led(out.led_on);
        }
        let step = self.control.steps();
        self.last_step = Some(LastStep {
            out,
            pose,
            velocity,
            wheels,
        });
        if heartbeat_taken {
            self.last_heartbeat_step = step;
        }
        self.link.poll();
        self.persist();

        // 3. Arming starts the plant (and the true metrics).
        if let Some(Event::Armed(mode)) = out.event {
            if let Some(copy) = probe.take().filter(|_| self.frozen) {
                self.hardware = copy;
                self.frozen = false;
                if let Some(motion) = self.arm_motion {
                    let (v, omega) = self.start_motion(motion);
                    // A motion the motors could not have given the wheels is not the
                    // plant's state: refused, the robot starts from rest, as a real one
                    // armed with a false claim would (the ground truth shows it).
                    let _ = self.hardware.start_moving(v, omega);
                }
            }
            // The virtual robot runs its outer loop in the step: it is always held.
            let steering = self.control.controller().steering();
            if let (RunMode::FollowPath, Some(steering)) = (mode, steering) {
                let params = self.control.controller().params();
                self.truth = Some(TrueRun::new(
                    steering.reference(),
                    params.control_rate(),
                    params.steering_divider(),
                    &pose,
                ));
            }
        }
        let running = out.state == State::Armed
            && self.control.supervisor().run_mode() == RunMode::FollowPath;
        if running {
            if let Some(truth) = &mut self.truth {
                truth.observe(&pose, wheels, periods.get());
            }
        }

        // 4. Frames out, with the ground truth after each telemetry frame and after the
        //    robot's run report.
        let sent = self.link.outgoing().len();
        let mut committed = false;
        let mut frames = Vec::new();
        let mut frame_start = self.outgoing.len();
        for &byte in self.link.outgoing() {
            self.outgoing.push(byte);
            let decoded = self.tap_out.push::<Uplink>(byte);
            if let Some(Ok(Received::Message(Uplink::Reply {
                seq: LOCAL_SEQ,
                result,
            }))) = &decoded
            {
                // A reply to the virtual robot itself: for no host.
                self.local_reply = Some(result.clone());
                self.outgoing.truncate(frame_start);
            }
            if decoded.is_some() {
                frame_start = self.outgoing.len();
            }
            match decoded {
                Some(Ok(Received::Message(Uplink::Telemetry(frame)))) => {
                    frames.push(Uplink::GroundTruth(GroundTruth {
                        step: frame.step,
                        pose: Pose::new(pose.x_m as f32, pose.y_m as f32, pose.theta_rad as f32),
                        velocity: BodyVelocity::new(velocity.0 as f32, velocity.1 as f32),
                        wheel_speed: WheelSpeeds::new(wheels[0] as f32, wheels[1] as f32),
                    }));
                }
                Some(Ok(Received::Message(Uplink::RunReport(report)))) => {
                    if let Some(truth) = self.truth.take() {
                        frames.push(Uplink::GroundTruthRun(truth.report(report.runs_ended)));
                    }
                }
                Some(Ok(Received::Message(Uplink::Reply {
                    result: Ok(Reply::PathCommitted(_)),
                    ..
                }))) => committed = true,
                _ => {}
            }
            for frame in frames.drain(..) {
                let mut wire = [0u8; MAX_FRAME_LEN];
                if let Ok(len) = encode(&frame, &mut wire) {
                    self.outgoing
                        .extend_from_slice(wire.get(..len).unwrap_or_default());
                }
                frame_start = self.outgoing.len();
            }
        }
        self.link.consume(sent);
        if committed {
            self.place_at_start();
        }

        // 5. The plant runs once armed.
        if !self.frozen {
            self.hardware.actuate(Actuation {
                duty: self.wires.wheel_duties(out.duty),
                bridge: out.bridge,
            });
            self.hardware.advance();
        }
        StepReport {
            step,
            event: out.event,
            state: out.state,
            steps_since_heartbeat: step.wrapping_sub(self.last_heartbeat_step),
        }
    }

    /// The body motion (m/s, rad/s) to spin the plant up to for an asserted `motion`:
    /// the scenario's own f64 values when `motion` is the scenario's start motion in f32.
    fn start_motion(&self, motion: BodyVelocity) -> (f64, f64) {
        let s = &self.scenario.start;
        if motion.v_m_s == s.v_m_s as f32 && motion.omega_rad_s == s.omega_rad_s as f32 {
            (s.v_m_s, s.omega_rad_s)
        } else {
            (f64::from(motion.v_m_s), f64::from(motion.omega_rad_s))
        }
    }

    /// Puts the robot at the active path's start pose, at rest, on a new hardware, and
    /// holds the plant still until armed.
    fn place_at_start(&mut self) {
        let pose = self.link.active_params().supervisor.start_pose;
        let s = &self.scenario.start;
        let same = pose.x_m == s.x_m as f32
            && pose.y_m == s.y_m as f32
            && pose.theta_rad == s.theta_rad as f32;
        let start = if same {
            StartState {
                v_m_s: 0.0,
                omega_rad_s: 0.0,
                ..*s
            }
        } else {
            StartState {
                x_m: f64::from(pose.x_m),
                y_m: f64::from(pose.y_m),
                theta_rad: f64::from(pose.theta_rad),
                v_m_s: 0.0,
                omega_rad_s: 0.0,
            }
        };
        if let Ok(hardware) =
            SimHardware::new(&placed(&self.scenario, &start), &self.scenario.faults)
        {
            self.hardware = hardware;
            self.frozen = true;
        }
    }

    /// The flash work of a `PersistParams`, in memory.
    fn persist(&mut self) {
        if let Some(job) = self.link.persist_job() {
            self.persisted = Some(*job.params);
            self.link.persist_finished(true);
        }
    }
}

/// What the bench's hands need to know of the robot of `scenario` with `plant`: its
/// control rate, its encoders' counts per wheel turn (the configured ones: a miswired
/// resolution is the wires') and how far its true wheels roll in a turn on the spot.
fn bench(scenario: &Scenario, plant: &Plant) -> Bench {
    let c = &scenario.robot;
    let g = &plant.params().geometry;
    Bench {
        rate_hz: f64::from(c.control_rate_hz),
        ticks_per_turn: f64::from(c.encoder_lines_per_motor_rev) * 4.0 * f64::from(c.gear_ratio),
        wheel_turns_per_robot_turn: [g.wheel_radius_left_m, g.wheel_radius_right_m]
            .map(|r| 0.5 * g.track_width_m / r),
    }
}

/// `scenario` with the robot placed at `start` (pose and motion).
fn placed(scenario: &Scenario, start: &StartState) -> Scenario {
    let mut s = scenario.clone();
    s.start = *start;
    s
}

/// A string that lives as long as the program (the robot's name, once per virtual robot).
fn leak(text: &str) -> &'static str {
    Box::leak(text.to_string().into_boxed_str())
}

/// How `host-sim serve` runs the virtual robot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ServeOptions {
    /// Simulated time per wall-clock time (1: real time).
    pub speed: f64,
    /// Stop after this many control steps (None: run until killed).
    pub max_steps: Option<u64>,
}

/// Runs the virtual robot on `listener`, paced at `options.speed` × real time. Every
/// connection receives what the robot sends; the newest one commands it, the older ones
/// observe (the client rule in `docs/protocol.md`). `log` gets every step that changed the
/// supervisor's state; `live`, if any, every step (the Foxglove stream). Returns
/// after `options.max_steps`, or on an I/O error of the listener.
pub fn serve(
    robot: &mut VirtualRobot<'_>,
    listener: &TcpListener,
    options: ServeOptions,
    log: &mut dyn FnMut(&StepReport),
    mut live: Option<&mut LiveStream>,
) -> std::io::Result<()> {
    listener.set_nonblocking(true)?;
    let rate = f64::from(robot.scenario.robot.control_rate_hz);
    let speed = if options.speed.is_finite() && options.speed > 0.0 {
        options.speed
    } else {
        1.0
    };
    let mut hosts = Hosts::default();
    let started = Instant::now();
    let mut steps: u64 = 0;
    // Steps the robot fell behind its pace and will never run: time the host process
    // lost is lost to the robot too, as it is to the station.
    let mut forgone: u64 = 0;
    let mut buf = [0u8; 4096];
    loop {
        if options.max_steps.is_some_and(|max| steps >= max) {
            return Ok(());
        }
        match listener.accept() {
            Ok((stream, _)) => {
                stream.set_nonblocking(true)?;
                let _ = stream.set_nodelay(true);
                hosts.connect(stream);
                // What the previous commanding host left half-sent is not the new one's.
                robot.pending_in.clear();
            }
            Err(e) if e.kind() == ErrorKind::WouldBlock => {}
            Err(e) => return Err(e),
        }
        // Steps due by now; at most 50 ms of simulated time at once, and a robot further
        // behind forgoes the rest: a stalled host process slows the robot down instead of
        // bursting it. A burst would run the robot's heartbeat timeout (counted in its
        // steps) out faster than any station paced by its telemetry could answer.
        let most = (rate * 0.05).max(1.0) as u64;
        let due = ((started.elapsed().as_secs_f64() * rate * speed) as u64).saturating_sub(forgone);
        let behind = due.saturating_sub(steps);
        if behind > most {
            forgone += behind - most;
        }
        let batch = behind.min(most);
        if batch == 0 {
            std::thread::sleep(Duration::from_micros(500));
            continue;
        }
        for _ in 0..batch {
            hosts.read(&mut buf, &mut |bytes| robot.receive(bytes));
            let report = robot.step();
            if report.event.is_some() {
                log(&report);
            }
            if let Some(live) = live.as_deref_mut() {
                live.after_step(robot);
            }
            hosts.write(robot.outgoing());
            robot.outgoing.clear();
            steps += 1;
        }
    }
}
