//! The emulated firmware as the simulation loop's [`RobotLogic`]: each step's sensors go
//! to the firmware's plant port, its answer comes back as the step's decision.
//!
//! **The plant holds still until the firmware reports armed.** Until then the loop's
//! first step is not taken: its sensor readings (the plant at its start, read once) are
//! sent again and again, while the station configures the robot, uploads the path and
//! arms it over the link, which takes the firmware's control steps to do. The answer
//! that says Armed (the step that arms drives) becomes the run's step 0, and the plant
//! moves from there. So the run starts in the same state however long the station took, and from then on every step
//! is the same computation as in `host-sim run`.
//!
//! **The station's requests after arming go in step** ([`super::station`]): before each
//! step's sensors, the request that step is to take (a velocity command of the
//! scenario's timeline, else a heartbeat when one is due) is handed to the built-in
//! station, and the sensors go once the firmware has it. Nothing is handed over from
//! the link cut of a link-loss run on.
//!
//! **The gyro's readings go from the step after arming on.** A reading in the repeated
//! first step would reach the disarmed firmware again and again (its bias learned from
//! it, its heading turned by it), where `host-sim run` sees it once; so the first step
//! must have none (a gyro of `latency_periods` ≥ 1 gives none then), and the run is
//! refused otherwise, as is a rest before arming, which the plant's hold replaces.

use std::io::{ErrorKind, Read, Write};
use std::net::TcpStream;
use std::num::NonZeroU32;
use std::sync::Arc;
use std::time::{Duration, Instant};

use controller_core::controller::MotorCommand;
use controller_core::kinematics::{BodyVelocity, Pose};
use controller_core::supervisor::{ArmRequest, Bridge, Event, State, SupervisorOutput};
use lockstep::{
    BoardDecoder, BoardReport, BoardStep, FromBoard, PlantStep, FINISH, PLANT_STEP_MAX_LEN,
};

use link::Request;

use super::relay::LinkSwitch;
use super::station::StepRequests;
use crate::hardware::Sensors;
use crate::run::{Decision, Estimate, RobotLogic, RunError};

/// Longest wait for one answer of the firmware (it answers within microseconds of
/// emulated time; this only catches a firmware that stopped).
const ANSWER_TIMEOUT: Duration = Duration::from_secs(20);

/// When the link is cut, and what happened after.
#[derive(Clone, Debug)]
pub struct LinkLoss {
    /// The step (from arming) at which the link is cut.
    pub at_step: u64,
    /// The first step from then on with both duties 0 and the bridge not driving.
    pub motors_zero_step: Option<u64>,
    /// The first disarm or fault event from then on, as text.
    pub stopped_by: Option<String>,
}

/// The built-in station as the plant loop sees it (module doc).
pub struct InStepStation {
    /// Where the requests go.
    pub requests: StepRequests,
    /// A heartbeat every this many control steps (at least 1).
    pub heartbeat_every_steps: u64,
}

/// The firmware behind its plant port.
pub struct Firmware {
    plant: TcpStream,
    decoder: BoardDecoder,
    /// Bytes read from the plant port and not decoded yet.
    unread: Vec<u8>,
    /// Waiting for the first armed answer (module doc).
    holding: bool,
    /// How long the station may take to arm the robot.
    arm_timeout: Duration,
    /// Steps since arming.
    steps: u64,
    /// Answers while holding.
    held_steps: u64,
    link: Arc<LinkSwitch>,
    link_loss: Option<LinkLoss>,
    station: Option<InStepStation>,
    /// Steps since the last heartbeat handed over.
    since_heartbeat: u64,
    /// The velocity command the next step takes.
    velocity: Option<BodyVelocity>,
}

impl Firmware {
    /// The firmware whose plant port is `plant` (its ready byte already read), holding
    /// still for at most `arm_timeout` until armed; the link is cut through `link` at
    /// `link_loss_at_step` (from arming), if given; the requests after arming go through
    /// `station` in step, if the built-in station runs (module doc).
    pub fn new(
        plant: TcpStream,
        arm_timeout: Duration,
        link: Arc<LinkSwitch>,
        link_loss_at_step: Option<u64>,
        station: Option<InStepStation>,
    ) -> std::io::Result<Self> {
        plant.set_nodelay(true)?;
        plant.set_read_timeout(Some(Duration::from_millis(50)))?;
        Ok(Self {
            plant,
            decoder: BoardDecoder::new(),
            unread: Vec::new(),
            holding: true,
            arm_timeout,
            steps: 0,
            held_steps: 0,
            link,
            link_loss: link_loss_at_step.map(|at_step| LinkLoss {
                at_step,
                motors_zero_step: None,
                stopped_by: None,
            }),
            station,
            since_heartbeat: 0,
            velocity: None,
        })
    }

    /// Hands the station the request this step is to take, if any (module doc).
    fn hand_over(&mut self) -> Result<(), RunError> {
        let Some(station) = &self.station else {
            return Ok(());
        };
        self.since_heartbeat += 1;
        if self.holding
            || self
                .link_loss
                .as_ref()
                .is_some_and(|l| self.steps >= l.at_step)
        {
            self.velocity = None;
            return Ok(());
        }
        let request = match self.velocity.take() {
            Some(v) => Request::Velocity {
                v_m_s: v.v_m_s,
                omega_rad_s: v.omega_rad_s,
            },
            None if self.since_heartbeat >= station.heartbeat_every_steps => Request::Heartbeat,
            None => return Ok(()),
        };
        if request == Request::Heartbeat {
            self.since_heartbeat = 0;
        }
        station.requests.send(request).map_err(RunError::Logic)
    }

    /// Control steps the firmware ran while the plant held still (configuring, arming).
    pub const fn held_steps(&self) -> u64 {
        self.held_steps
    }

    /// The link loss and what followed, if one was asked for.
    pub fn link_loss(&self) -> Option<&LinkLoss> {
        self.link_loss.as_ref()
    }

    /// Ends the run: asks for the firmware's report, which it sends before it exits.
    pub fn finish(&mut self) -> Result<BoardReport, RunError> {
        self.plant.write_all(&[FINISH]).map_err(io_error)?;
        match self.receive()? {
            FromBoard::Report(report) => Ok(report),
            FromBoard::Step(_) => Err(RunError::Logic(
                "the firmware answered FINISH with a step".into(),
            )),
        }
    }

    fn receive(&mut self) -> Result<FromBoard, RunError> {
        let deadline = Instant::now() + ANSWER_TIMEOUT;
        let mut bytes = [0u8; 256];
        loop {
            while !self.unread.is_empty() {
                let byte = self.unread.remove(0);
                if let Some(message) = self.decoder.push(byte) {
                    return Ok(message);
                }
            }
            match self.plant.read(&mut bytes) {
                Ok(0) => {
                    return Err(RunError::Logic(
                        "the firmware's plant port closed (QEMU exited)".into(),
                    ))
                }
                Ok(n) => self
                    .unread
                    .extend_from_slice(bytes.get(..n).unwrap_or_default()),
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                    if Instant::now() > deadline {
                        return Err(RunError::Logic(format!(
                            "no answer from the firmware within {} s",
                            ANSWER_TIMEOUT.as_secs()
                        )));
                    }
                }
                Err(e) => return Err(io_error(e)),
            }
        }
    }

    /// Sends one step's sensors and waits for the answer.
    fn exchange(&mut self, step: &PlantStep) -> Result<BoardStep, RunError> {
        let mut bytes = [0u8; PLANT_STEP_MAX_LEN];
        let len = step.encode(&mut bytes);
        self.plant
            .write_all(bytes.get(..len).unwrap_or_default())
            .map_err(io_error)?;
        match self.receive()? {
            FromBoard::Step(answer) => Ok(answer),
            FromBoard::Report(_) => Err(RunError::Logic(
                "the firmware sent its report in the middle of the run".into(),
            )),
        }
    }

    /// Records what the step did after the link loss.
    fn watch_link_loss(&mut self, answer: &BoardStep) {
        let step = self.steps;
        let Some(loss) = self.link_loss.as_mut() else {
            return;
        };
        if step == loss.at_step {
            self.link.cut();
        }
        if step < loss.at_step {
            return;
        }
        if loss.stopped_by.is_none() {
            if let Some(event @ (Event::Disarmed(_) | Event::Faulted)) = answer.event {
                loss.stopped_by = Some(format!("{event:?}"));
            }
        }
        if loss.motors_zero_step.is_none()
            && answer.duty == MotorCommand::STOP
            && answer.bridge != Bridge::Drive
        {
            loss.motors_zero_step = Some(step);
        }
    }
}

impl RobotLogic for Firmware {
    /// The station arms the firmware over the link; nothing arms it locally.
    fn arm_locally(&mut self, _request: ArmRequest) -> bool {
        false
    }

    /// The station sends the pose command over the link (`SetPose`), before it arms.
    fn set_pose_locally(&mut self, _pose: Pose) -> bool {
        false
    }

    /// The command goes over the link, in step, through the built-in station (module
    /// doc); `false` without one, or while the plant holds still for arming.
    fn command_velocity(&mut self, command: BodyVelocity) -> bool {
        if self.station.is_none() || self.holding {
            return false;
        }
        self.velocity = Some(command);
        true
    }

    fn step(&mut self, sensors: &Sensors) -> Result<Decision<'_>, RunError> {
        let step = PlantStep {
            ticks: sensors.ticks,
            periods: NonZeroU32::new(sensors.periods).unwrap_or(NonZeroU32::MIN),
            supply_v: sensors.supply_v,
            button_pressed: sensors.button_pressed,
            gyro: sensors.gyro,
        };
        if self.holding && step.gyro.is_some() {
            return Err(RunError::Logic(
                "the gyro has a reading at the first step, which processor in the loop repeats \
                 until the firmware is armed: give the scenario's [gyro] latency_periods = 1 or more"
                    .into(),
            ));
        }
        self.hand_over()?;
        let started = Instant::now();
        let answer = loop {
            let answer = self.exchange(&step)?;
            if !self.holding || answer.state == State::Armed {
                break answer;
            }
            self.held_steps += 1;
            if started.elapsed() > self.arm_timeout {
                return Err(RunError::Logic(format!(
                    "the firmware was not armed within {} s ({} control steps, state {:?})",
                    self.arm_timeout.as_secs(),
                    self.held_steps,
                    answer.state
                )));
            }
        };
        self.holding = false;
        self.watch_link_loss(&answer);
        self.steps += 1;
        Ok(Decision {
            out: SupervisorOutput {
                duty: answer.duty,
                bridge: answer.bridge,
                feed_watchdog: true,
                state: answer.state,
                run_mode: answer.run_mode,
                faults: answer.faults,
                battery_low: answer.battery_low,
                overruns_total: answer.overruns_total,
                missed_ticks_total: answer.missed_ticks_total,
                event: answer.event,
                command_result: None,
                controller_duty: answer.duty,
            },
            estimate: Estimate {
                pose: answer.pose,
                error: answer.error,
                steering_updated: answer.steering_updated,
            },
            telemetry: None,
            pid_parts: None,
        })
    }
}

fn io_error(e: std::io::Error) -> RunError {
    RunError::Logic(format!("plant port: {e}"))
}

#[cfg(test)]
mod tests {
    use std::net::TcpListener;

    use super::super::station::step_requests;
    use super::*;

    #[test]
    fn each_step_hands_over_its_velocity_command_else_a_due_heartbeat_and_nothing_from_the_cut() {
        let listener = TcpListener::bind("127.0.0.1:0").expect("bind");
        let plant = TcpStream::connect(listener.local_addr().expect("address")).expect("connect");
        let _plant_peer = listener.accept().expect("accept");
        let (requests, inbox) = step_requests();
        let station = std::thread::spawn(move || inbox.pass_everything_on());
        let mut firmware = Firmware::new(
            plant,
            Duration::from_secs(1),
            Arc::new(LinkSwitch::default()),
            Some(6),
            Some(InStepStation {
                requests,
                heartbeat_every_steps: 2,
            }),
        )
        .expect("firmware");
        let command = BodyVelocity::new(0.3, -1.5);
        // Step 0: the plant holds still while the station arms; nothing goes, and a
        // command is not taken.
        assert!(!firmware.command_velocity(command));
        firmware.hand_over().expect("step 0");
        firmware.holding = false;
        for step in 1..=7 {
            firmware.steps = step;
            if step == 3 {
                assert!(firmware.command_velocity(command));
            }
            firmware.hand_over().expect("a step");
        }
        drop(firmware);
        let sent = station.join().expect("the station's thread");
        let velocity = Request::Velocity {
            v_m_s: 0.3,
            omega_rad_s: -1.5,
        };
        // Heartbeat due at 1; the command at 3 holds back the heartbeat due then to 4;
        // the link is cut at 6.
        assert_eq!(sent, [Request::Heartbeat, velocity, Request::Heartbeat]);
    }
}
