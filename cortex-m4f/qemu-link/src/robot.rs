//! A stand-in for the robot service: answers every request the way the protocol says,
//! with a configuration, an arming flag and a path instead of real motors.

use controller_core::kinematics::{Pose, WheelSpeeds};
use controller_core::params::{Params, RobotConfig};
use controller_core::supervisor::SupervisorConfig;
use link::{
    bounded, check_telemetry_rate, params_hash, ArmMode, BrownOutReset, ClockSource, Commit,
    CommitSummary, FieldProblem, LinkStats, NotPermitted, ParamSet, PathAssembler, ProtocolId,
    Refusal, Reply, Request, RobotInfo, RunReport, RxCounters, Stats,
};

/// Name the robot gives in its [`RobotInfo`].
pub const ROBOT_NAME: &str = "qemu-link";
/// Chip it reports.
pub const CHIP: &str = "STM32F405 (QEMU)";

/// What the stand-in remembers between requests.
pub struct TestRobot {
    params: ParamSet,
    armed: bool,
    path: Option<CommitSummary>,
    assembler: PathAssembler,
}

impl TestRobot {
    /// Disarmed, the reference robot at 1 kHz, no path.
    pub const fn new() -> Self {
        Self {
            params: ParamSet {
                robot: RobotConfig::REFERENCE_ROBOT,
                supervisor: SupervisorConfig::at_rate(
                    1000,
                    Pose {
                        x_m: 0.0,
                        y_m: 0.0,
                        theta_rad: 0.0,
                    },
                    WheelSpeeds::new(5.0, 5.0),
                ),
            },
            armed: false,
            path: None,
            assembler: PathAssembler::new(),
        }
    }

    /// The answer to `request`. `received` and `frames_sent` fill [`Stats`].
    pub fn answer(
        &mut self,
        request: &Request,
        received: RxCounters,
        frames_sent: u32,
    ) -> Result<Reply, Refusal> {
        match request {
            Request::Info => Ok(Reply::Info(RobotInfo {
                protocol: ProtocolId::OURS,
                firmware_version: bounded(env!("CARGO_PKG_VERSION")),
                git_hash: bounded("none"),
                chip: bounded(CHIP),
                robot_name: bounded(ROBOT_NAME),
                params_hash: params_hash(&self.params),
                bridge: link::BridgeChip::Tb6612fng,
                clock: ClockSource::Simulated,
                brown_out_reset: BrownOutReset::NotApplicable,
                reset_cause: link::ResetCause::Unknown,
            })),
            Request::Ping { nonce } => Ok(Reply::Pong { nonce: *nonce }),
            Request::GetParams => Ok(Reply::Params(self.params)),
            Request::SetParams(params) => {
                self.disarmed()?;
                let checked = Params::new(params.robot)
                    .map_err(|e| Refusal::InvalidParams(FieldProblem::from_param_error(&e)))?;
                params.supervisor.validate(&checked).map_err(|_| {
                    Refusal::InvalidParams(FieldProblem::new("supervisor", "is not valid"))
                })?;
                self.params = *params;
                Ok(Reply::ParamsApplied {
                    params_hash: params_hash(params),
                })
            }
            Request::PersistParams => {
                self.disarmed()?;
                Err(Refusal::NotPermitted(NotPermitted::NoStorage))
            }
            Request::PathBegin(begin) => {
                self.disarmed()?;
                self.assembler.begin(begin)
            }
            Request::PathChunk(chunk) => self.assembler.chunk(chunk),
            Request::PathCommit(commit) => {
                self.disarmed()?;
                let commit = self.assembler.commit(commit)?;
                if let Commit::New(committed) = &commit {
                    self.path = Some(committed.summary);
                }
                Ok(commit.reply())
            }
            Request::Arm { mode, .. } => {
                self.disarmed()?;
                match mode {
                    ArmMode::FollowPath if self.path.is_none() => {
                        Err(Refusal::NotPermitted(NotPermitted::NoPath))
                    }
                    ArmMode::Tune | ArmMode::FollowVelocity => {
                        Err(Refusal::NotPermitted(NotPermitted::Unsupported))
                    }
                    _ => {
                        self.armed = true;
                        Ok(Reply::Ack)
                    }
                }
            }
            Request::Disarm | Request::EmergencyStop => {
                self.armed = false;
                Ok(Reply::Ack)
            }
            Request::ClearFaults | Request::Heartbeat => Ok(Reply::Ack),
            Request::SetTelemetryRate { hz } => check_telemetry_rate(*hz).map(|_| Reply::Ack),
            Request::GetStats => Ok(Reply::Stats(Stats {
                link: LinkStats {
                    received,
                    frames_sent,
                    telemetry_dropped: 0,
                },
                ..Stats::default()
            })),
            // This test robot never runs the controller, so it has no run to report.
            Request::GetRunReport => Ok(Reply::RunReport(RunReport::default())),
            Request::GetTuneReport => Ok(Reply::TuneReport(link::TuneReport::NONE)),
            // No odometry here: the pose command is only checked as the robot checks it.
            Request::SetPose {
                x_m,
                y_m,
                theta_rad,
            } => {
                self.disarmed()?;
                for (field, value) in [("x_m", x_m), ("y_m", y_m), ("theta_rad", theta_rad)] {
                    if !value.is_finite() {
                        return Err(Refusal::InvalidArgument(FieldProblem::new(
                            field,
                            "must be finite",
                        )));
                    }
                }
                Ok(Reply::Ack)
            }
            // Nothing survives a reset of this test program.
            Request::GetPanicRecord => Ok(Reply::PanicRecord(None)),
            Request::ClearPanicRecord => Ok(Reply::Ack),
            // No controller here, so no velocity mode to take a command and no motor to pulse.
            Request::Velocity { .. } | Request::MotorTest { .. } => {
                Err(Refusal::NotPermitted(NotPermitted::Unsupported))
            }
        }
    }

    fn disarmed(&self) -> Result<(), Refusal> {
        if self.armed {
            Err(Refusal::Armed)
        } else {
            Ok(())
        }
    }
}
