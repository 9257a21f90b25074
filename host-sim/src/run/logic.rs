//! The robot's logic run in this process: the supervisor around the controller, as the
//! firmware runs them ([`LocalRobot`], which the loop drives through [`RobotLogic`]), and
//! the same with its own hardware for the wheel-loop studies that step the robot
//! themselves (`Robot`).
//!
//! Contract: one step of either is one `Supervisor::step` on what the firmware reads,
//! with the background heartbeat advanced as the firmware's idle loop does, and nothing
//! else; a decision is exactly what the firmware would decide on the same sensors.

use controller_core::controller::Telemetry;
use controller_core::prelude::*;
use controller_core::supervisor::{
    ArmRequest, Bridge, Command, Inputs, Supervisor, SupervisorOutput,
};
use robot_files::faults::Fault;
use robot_files::scenario::Scenario;

use super::RunError;
use crate::hardware::{Actuation, Sensors, SimHardware};

/// The controller's estimate after a step, as the loop records it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// Odometry pose, world frame (m, rad): current when `steering_updated`, otherwise
    /// possibly that of the last steering update.
    pub pose: Pose,
    /// Tracking error at the last steering update, robot frame (m, rad).
    pub error: TrackingError,
    /// This step applied a steering outcome (the law ran on the previous step's pose).
    pub steering_updated: bool,
}

/// What the robot's logic decided in one step.
pub struct Decision<'a> {
    /// The supervisor's outcome: duties, bridge, state, faults, event, counters.
    pub out: SupervisorOutput,
    /// The controller's estimate.
    pub estimate: Estimate,
    /// The controller's whole telemetry, when the logic runs in this process (for the
    /// trace); `None` when it runs elsewhere.
    pub telemetry: Option<&'a Telemetry>,
    /// The wheel PIDs' outputs by part [left, right], V, alongside `telemetry` (`None`
    /// when the logic runs elsewhere).
    pub pid_parts: Option<[controller_core::pid::PidParts; 2]>,
}

/// The robot's logic the loop runs against the simulated hardware: the supervisor around
/// the controller, here or on an emulated target.
pub trait RobotLogic {
    /// Arms before the first step, as the operator at the robot would (`false` if this
    /// logic cannot, or refused): the scenario's `arm = "follow"` start.
    fn arm_locally(&mut self, request: ArmRequest) -> bool;
    /// Tells the robot it is at `pose` (world frame, m and rad) before the first step, as
    /// the operator at the robot would (the pose command; `false` if this logic takes it
    /// over the link instead, or refused).
    fn set_pose_locally(&mut self, pose: Pose) -> bool;
    /// A velocity command (v m/s, ω rad/s, robot frame) arrives for the next step, as a
    /// host's `Velocity` request would (the scenario's `[velocity]` timeline); `false` if
    /// this logic cannot take one.
    fn command_velocity(&mut self, command: BodyVelocity) -> bool;
    /// One control step on what the firmware reads, `sensors`.
    fn step(&mut self, sensors: &Sensors) -> Result<Decision<'_>, RunError>;
}

/// The supervisor and controller of `scenario` running `law`, in this process.
pub struct LocalRobot {
    controller: Controller,
    supervisor: Supervisor,
    heartbeat: u32,
    /// The command the next step takes (a velocity command of the timeline).
    command: Option<Command>,
}

impl LocalRobot {
    /// The scenario's controller (its path, reference and start pose) with `law`, and its
    /// supervisor after a power-on reset.
    pub fn new(scenario: &Scenario, law: LawKind) -> Result<Self, RunError> {
        let params = scenario.params()?;
        let reference = Reference::new(
            scenario.path.clone(),
            scenario.reference_speed_m_s,
            scenario.reference_mode,
        )
        .map_err(RunError::Reference)?;
        let s = scenario.start;
        let start = Pose::new(s.x_m as f32, s.y_m as f32, s.theta_rad as f32);
        let controller = Controller::new(params, reference, law, start);
        Ok(Self {
            controller,
            supervisor: Supervisor::new(
                scenario.supervisor,
                &params,
                controller_core::supervisor::ResetCause::PowerOn,
            )
            .map_err(RunError::Supervisor)?,
            heartbeat: 0,
            command: None,
        })
    }
}

impl RobotLogic for LocalRobot {
    fn arm_locally(&mut self, request: ArmRequest) -> bool {
        self.supervisor
            .arm_locally(&mut self.controller, request)
            .is_ok()
    }

    fn set_pose_locally(&mut self, pose: Pose) -> bool {
        self.supervisor.set_pose(&mut self.controller, pose).is_ok()
    }

    fn command_velocity(&mut self, command: BodyVelocity) -> bool {
        self.command = Some(Command::Velocity(command));
        true
    }

    fn step(&mut self, sensors: &Sensors) -> Result<Decision<'_>, RunError> {
        let out = supervise(
            &mut self.supervisor,
            &mut self.controller,
            &mut self.heartbeat,
            sensors,
            self.command.take(),
        );
        let pid_parts = self.controller.wheel_pid_parts();
        let t = self.controller.telemetry();
        Ok(Decision {
            out,
            estimate: Estimate {
                pose: t.pose,
                error: t.error,
                steering_updated: t.steering_updated,
            },
            telemetry: Some(t),
            pid_parts: Some(pid_parts),
        })
    }
}

/// One step of `supervisor` around `controller` on what the firmware reads, `sensors`,
/// and the operator's `command`, with the background heartbeat advanced as the
/// firmware's idle loop would.
fn supervise(
    supervisor: &mut Supervisor,
    controller: &mut Controller,
    heartbeat: &mut u32,
    sensors: &Sensors,
    command: Option<Command>,
) -> SupervisorOutput {
    *heartbeat = heartbeat.wrapping_add(1);
    supervisor.step(
        controller,
        Inputs {
            ticks: sensors.ticks,
            periods: core::num::NonZeroU32::new(sensors.periods)
                .unwrap_or(core::num::NonZeroU32::MIN),
            supply_v: sensors.supply_v,
            button_pressed: sensors.button_pressed,
            overrun: false,
            background_heartbeat: *heartbeat,
            command,
            gyro: sensors.gyro,
        },
    )
}

/// The supervisor, controller and hardware of `scenario` running `law` with `faults`, for
/// the wheel-loop studies that drive the robot step by step and may break the loop at
/// the plant's input ([`crate::margins`], [`crate::tune`]).
pub(crate) struct Robot {
    pub(crate) controller: Controller,
    pub(crate) supervisor: Supervisor,
    pub(crate) hardware: SimHardware,
    heartbeat: u32,
}

impl Robot {
    pub(crate) fn new(
        scenario: &Scenario,
        law: LawKind,
        faults: &[Fault],
    ) -> Result<Self, RunError> {
        let LocalRobot {
            controller,
            supervisor,
            heartbeat,
            command: _,
        } = LocalRobot::new(scenario, law)?;
        Ok(Self {
            controller,
            supervisor,
            hardware: SimHardware::new(scenario, faults)?,
            heartbeat,
        })
    }

    /// One control step (module doc); returns the supervisor's decision.
    pub(crate) fn step(&mut self) -> SupervisorOutput {
        self.step_with_added_volts([0.0; 2])
    }

    /// One control step with `added_v` (V, [left, right]) added to what the supervisor
    /// drives, as a disturbance at the plant's input (while the bridge drives): the loop
    /// is broken there to measure it ([`crate::margins`]).
    pub(crate) fn step_with_added_volts(&mut self, added_v: [f64; 2]) -> SupervisorOutput {
        let periods = self.hardware.periods_until_next_step();
        let sensors = self.hardware.sense(periods);
        let out = supervise(
            &mut self.supervisor,
            &mut self.controller,
            &mut self.heartbeat,
            &sensors,
            None,
        );
        let mut duty = out.duty;
        if added_v != [0.0; 2] && out.bridge == Bridge::Drive {
            let supply = self.hardware.plant().supply_v();
            duty.left += (added_v[0] / supply) as f32;
            duty.right += (added_v[1] / supply) as f32;
        }
        self.hardware.actuate(Actuation {
            duty,
            bridge: out.bridge,
        });
        self.hardware.advance();
        out
    }
}
