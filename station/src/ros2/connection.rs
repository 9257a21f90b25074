//! The bridge's link to the robot: connecting (serial or TCP), heartbeats, the velocity
//! mode, path runs, the pose command and parameter writes, and noticing that the link is
//! gone.
//!
//! The link counts as down when a request fails or no message has come for
//! [`SILENCE_LIMIT`] (the robot streams telemetry at the publish rate, at least 1 Hz).
//! The bridge then drops the connection and opens a new one every
//! [`RECONNECT_EVERY`]; the robot meanwhile stops by its own `cmd_vel_timeout` and
//! disarms by its heartbeat timeout.

use std::time::{Duration, Instant};

use controller_core::kinematics::Pose;
use controller_core::law::LawKind;
use controller_core::path::Path;
use controller_core::reference::ReferenceMode;
use controller_core::supervisor::Event;
use link::{
    ArmMode, CommitSummary, ParamSet, Request, RobotInfo, RunReport, TelemetryFrame, Uplink,
};

use crate::client::{Client, StationError};
use crate::ops;
use crate::record::{set_telemetry_rate, HeartbeatPacer};
use crate::transport::{ConnectError, Serial, Tcp, Transport};

/// No message from the robot for this long: the link is down.
pub const SILENCE_LIMIT: Duration = Duration::from_secs(1);
/// While the link is down, a new connection is tried this often.
pub const RECONNECT_EVERY: Duration = Duration::from_secs(1);

/// Where the robot is.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum RobotAddress {
    /// A serial port at a baud rate (8N1).
    Serial {
        /// The port (`/dev/ttyACM0`).
        port: String,
        /// Baud.
        baud: u32,
    },
    /// A TCP address (`127.0.0.1:5760`, the virtual robot of `host-sim serve`).
    Tcp(String),
}

impl RobotAddress {
    /// `text` as a TCP address when it is `HOST:PORT` (and not a path), else as a serial
    /// port at `baud`.
    pub fn parse(text: &str, baud: u32) -> Self {
        let is_tcp = !text.starts_with('/')
            && text
                .rsplit_once(':')
                .is_some_and(|(host, port)| !host.is_empty() && port.parse::<u16>().is_ok());
        if is_tcp {
            RobotAddress::Tcp(text.to_string())
        } else {
            RobotAddress::Serial {
                port: text.to_string(),
                baud,
            }
        }
    }

    /// The address, for messages.
    pub fn describe(&self) -> String {
        match self {
            RobotAddress::Serial { port, baud } => format!("{port} at {baud} baud"),
            RobotAddress::Tcp(address) => address.clone(),
        }
    }

    fn open(&self) -> Result<Box<dyn Transport>, ConnectError> {
        Ok(match self {
            RobotAddress::Serial { port, baud } => Box::new(Serial::open(port, *baud)?),
            RobotAddress::Tcp(address) => Box::new(Tcp::connect(address)?),
        })
    }
}

/// Why the link could not be used.
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    /// No connection could be made.
    #[error(transparent)]
    Connect(#[from] ConnectError),
    /// A request failed.
    #[error(transparent)]
    Station(#[from] StationError),
    /// Nothing came from the robot for [`SILENCE_LIMIT`].
    #[error("nothing from the robot for {0:?}")]
    Silent(Duration),
}

impl LinkError {
    /// True when the link itself failed (no connection, an I/O error, no reply, silence,
    /// another protocol), not when the robot refused a request.
    pub fn is_link_failure(&self) -> bool {
        !matches!(
            self,
            LinkError::Station(StationError::Refused { .. } | StationError::Unexpected { .. })
        )
    }
}

/// What the robot sent that the bridge acts on.
#[derive(Clone, Debug, PartialEq)]
pub enum FromRobot {
    /// A telemetry sample.
    Telemetry(TelemetryFrame),
    /// A supervisor state change at a control step.
    Event(u32, Event),
    /// A path-following run ended.
    RunEnded(RunReport),
}

/// How a path is followed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathRun {
    /// Reference speed, m/s.
    pub speed_m_s: f32,
    /// The run's time limit, control steps.
    pub time_limit_steps: u32,
}

/// A connected robot.
pub struct Robot {
    client: Client<Box<dyn Transport>>,
    /// Who it is.
    pub info: RobotInfo,
    /// Its parameters, as last read or written.
    pub params: ParamSet,
    pacer: HeartbeatPacer,
    latest_step: Option<u32>,
    last_heard: Instant,
}

impl Robot {
    /// Connects, reads who the robot is and its parameters, and sets its telemetry rate
    /// to `telemetry_hz` (or the fastest below it that it takes).
    pub fn connect(address: &RobotAddress, telemetry_hz: u8) -> Result<Self, LinkError> {
        let mut client = Client::new(address.open()?);
        let info = ops::info(&mut client)?;
        let params = ops::get_params(&mut client)?;
        set_telemetry_rate(&mut client, telemetry_hz)?;
        Ok(Self {
            client,
            info,
            pacer: HeartbeatPacer::new(params.supervisor.heartbeat_timeout_steps),
            params,
            latest_step: None,
            last_heard: Instant::now(),
        })
    }

    /// What the robot sent within `wait`, a heartbeat sent when one is due (paced by the
    /// robot's step counter, always, armed or not: a disarmed robot ignores them).
    pub fn poll(&mut self, wait: Duration) -> Result<Vec<FromRobot>, LinkError> {
        let mut out = Vec::new();
        let mut wait = wait;
        while let Some(message) = self.client.next_message(wait)? {
            wait = Duration::ZERO;
            self.last_heard = Instant::now();
            match message {
                Uplink::Telemetry(frame) => {
                    self.latest_step = Some(frame.step);
                    out.push(FromRobot::Telemetry(frame));
                }
                Uplink::Event { step, event } => out.push(FromRobot::Event(step, event)),
                Uplink::RunReport(report) => out.push(FromRobot::RunEnded(report)),
                _ => {}
            }
        }
        if self.pacer.due(self.latest_step) {
            self.client.send_only(Request::Heartbeat)?;
        }
        let silent = self.last_heard.elapsed();
        if silent > SILENCE_LIMIT {
            return Err(LinkError::Silent(silent));
        }
        Ok(out)
    }

    /// Arms the velocity mode (from rest, the robot's stored run limit).
    pub fn arm_velocity(&mut self) -> Result<(), LinkError> {
        self.client.command(Request::Arm {
            mode: ArmMode::FollowVelocity,
            initial_motion: None,
            run_time_limit_steps: None,
        })?;
        Ok(())
    }

    /// Sends a velocity command (v m/s, ω rad/s, robot frame); streamed, its reply not
    /// awaited.
    pub fn velocity(&mut self, v_m_s: f32, omega_rad_s: f32) -> Result<(), LinkError> {
        self.client
            .send_only(Request::Velocity { v_m_s, omega_rad_s })?;
        Ok(())
    }

    /// Disarms.
    pub fn disarm(&mut self) -> Result<(), LinkError> {
        self.client.command(Request::Disarm)?;
        Ok(())
    }

    /// The pose command (the robot disarmed): its odometry is at `pose` now.
    pub fn set_pose(&mut self, pose: Pose) -> Result<(), LinkError> {
        ops::set_pose(&mut self.client, pose)?;
        Ok(())
    }

    /// Writes `params` (the robot disarmed) and keeps them as the robot's.
    pub fn set_params(&mut self, params: ParamSet) -> Result<(), LinkError> {
        ops::set_params(&mut self.client, params)?;
        self.params = ops::get_params(&mut self.client)?;
        self.pacer = HeartbeatPacer::new(self.params.supervisor.heartbeat_timeout_steps);
        Ok(())
    }

    /// Sets the telemetry rate (the publish rate), Hz; returns the one the robot took.
    pub fn set_telemetry_rate(&mut self, hz: u8) -> Result<u8, LinkError> {
        Ok(set_telemetry_rate(&mut self.client, hz)?)
    }

    /// Uploads `path` (the robot disarmed) to be followed from `start_pose` with the
    /// tracking law, path-following reference, and arms it for `run`.
    pub fn follow_path(
        &mut self,
        path: &Path,
        start_pose: Pose,
        run: PathRun,
    ) -> Result<CommitSummary, LinkError> {
        let plan = ops::PathPlan {
            path,
            speed_m_s: run.speed_m_s,
            mode: ReferenceMode::PathFollowing { lookahead_m: 0.0 },
            law: LawKind::Tracking,
            start_pose,
        };
        let summary = ops::upload(
            &mut self.client,
            &plan,
            ops::fresh_upload_id(),
            &mut |_, _| {},
        )?;
        ops::arm(&mut self.client, None, Some(run.time_limit_steps))?;
        Ok(summary)
    }

    /// The link, for messages.
    pub fn describe(&self) -> String {
        self.client.transport().describe()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_address_is_tcp_when_it_has_a_port() {
        assert_eq!(
            RobotAddress::parse("127.0.0.1:5760", 230_400),
            RobotAddress::Tcp("127.0.0.1:5760".into())
        );
        assert_eq!(
            RobotAddress::parse("localhost:5760", 230_400),
            RobotAddress::Tcp("localhost:5760".into())
        );
        assert_eq!(
            RobotAddress::parse("/dev/ttyACM0", 115_200),
            RobotAddress::Serial {
                port: "/dev/ttyACM0".into(),
                baud: 115_200
            }
        );
        assert!(matches!(
            RobotAddress::parse("COM3", 230_400),
            RobotAddress::Serial { .. }
        ));
    }
}
