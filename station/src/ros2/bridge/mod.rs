//! `station ros2`'s loop: the robot's link on one side, the ROS 2 node on the other.
//!
//! One thread does everything but the parameter services: it waits a few milliseconds
//! for the robot's messages, publishes what telemetry came (odom, tf, joint_states at
//! the robot's telemetry rate, which is `publish_rate`), forwards every `cmd_vel` as it
//! arrives (the robot applies its own timeout and limits), and carries out paths, pose
//! resets and parameter changes, which need the robot disarmed: the bridge disarms it,
//! does the work, and re-arms the velocity mode when it was started with `--arm`.
//!
//! - **Velocity mode** (`--arm`): armed when the link comes up, kept armed by heartbeats,
//!   re-armed at most once a second after the robot disarmed by itself (its heartbeat
//!   timeout, the button) but never after a fault (the faults are reported on
//!   `diagnostics` and wait for a person), disarmed when the bridge stops.
//! - **A path**: simplified ([`super::path_simplify`]), refused on `diagnostics` when it
//!   cannot be; otherwise uploaded from the robot's current pose and followed at
//!   `path_speed` for its length's time plus [`PATH_SETTLE_S`]; `cmd_vel` is not
//!   forwarded meanwhile. The robot's run report is printed and shown on `diagnostics`.
//! - **The link drops**: `diagnostics` says so, and a new connection is tried every
//!   second ([`super::connection`]).
//!
//! This module holds the loop and the link's side; `requests` what ROS 2 asks.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use controller_core::supervisor::{DisarmReason, Event, State};
use ros2_client::builtin_interfaces::Time;
use ros2_client::ParameterValue;

use super::connection::{FromRobot, LinkError, Robot, RobotAddress, RECONNECT_EVERY};
use super::diagnostics::{diagnostics, BridgeStatus};
use super::odometry::{joint_states, odometry, transform, WheelAngles};
use super::parameters::{
    robot_values, BridgeParameters, Multipliers, ParameterError, ROBOT_PARAMETERS,
};
use super::topics::{create_node, BridgeNode, NodeError, ParameterCheck};

mod requests;

/// A path run lasts its length at `path_speed`, plus this long to settle, s.
pub const PATH_SETTLE_S: f64 = 5.0;
/// How long the loop waits for the robot each time round.
const POLL: Duration = Duration::from_millis(5);
/// `diagnostics` at least this often.
const DIAGNOSTICS_EVERY: Duration = Duration::from_secs(1);
/// The velocity mode is re-armed at most this often.
const REARM_EVERY: Duration = Duration::from_secs(1);

/// What `station ros2` was asked.
pub struct BridgeOptions {
    /// Where the robot is.
    pub robot: RobotAddress,
    /// Arm the velocity mode and keep it armed.
    pub arm: bool,
    /// The DDS domain (ROS_DOMAIN_ID).
    pub domain_id: u16,
    /// The node's name.
    pub node_name: String,
    /// The bridge's parameters given at start (`--param NAME=VALUE`).
    pub parameters: Vec<(String, ParameterValue)>,
    /// Set by Ctrl-C: disarm and stop.
    pub interrupt: Arc<AtomicBool>,
    /// Stop after this long (`None`: until Ctrl-C).
    pub duration: Option<Duration>,
}

/// Why the bridge could not run.
#[derive(Debug, thiserror::Error)]
pub enum BridgeError {
    /// A parameter given at start was refused.
    #[error("--param: {0}")]
    Parameter(String),
    /// The node could not be made.
    #[error(transparent)]
    Node(#[from] NodeError),
}

/// What the bridge did, for its closing line.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct BridgeCounts {
    /// `cmd_vel` messages forwarded to the robot.
    pub cmd_vel_forwarded: u64,
    /// `odom` messages published.
    pub odom_published: u64,
    /// Paths followed to the end of their run.
    pub paths_followed: u32,
    /// Times the link came up.
    pub connections: u32,
}

/// What the bridge is doing with the robot.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Activity {
    /// Nothing (disarmed, or not started with `--arm`).
    Idle,
    /// The velocity mode is armed.
    Velocity,
    /// A path is being followed, until the robot reports the run.
    FollowingPath,
}

impl Activity {
    fn describe(self) -> &'static str {
        match self {
            Activity::Idle => "idle",
            Activity::Velocity => "velocity mode (cmd_vel)",
            Activity::FollowingPath => "following a path",
        }
    }
}

struct Bridge {
    options: BridgeOptions,
    node: BridgeNode,
    settings: BridgeParameters,
    link_up: Arc<AtomicBool>,
    robot: Option<Robot>,
    multipliers: Option<Multipliers>,
    status: BridgeStatus,
    activity: Activity,
    angles: WheelAngles,
    counts: BridgeCounts,
    next_connect: Instant,
    last_arm: Option<Instant>,
    last_diagnostics: Option<Instant>,
}

/// Runs the bridge until Ctrl-C or its duration; disarms the robot when it armed it.
pub fn run(options: BridgeOptions) -> Result<BridgeCounts, BridgeError> {
    let mut settings = BridgeParameters::default();
    for (name, value) in &options.parameters {
        match settings.set(name, value, true) {
            Ok(true) => {}
            Ok(false) if ROBOT_PARAMETERS.contains(&name.as_str()) => {
                return Err(BridgeError::Parameter(format!(
                    "{name} is the robot's: set it while the bridge runs (ros2 param set), \
                     or with `station params set`"
                )))
            }
            Ok(false) => return Err(BridgeError::Parameter(format!("no parameter {name}"))),
            Err(e) => return Err(BridgeError::Parameter(e.to_string())),
        }
    }
    let link_up = Arc::new(AtomicBool::new(false));
    let checking = Arc::new(AtomicBool::new(false));
    let mut declared: Vec<(String, ParameterValue)> = settings
        .values()
        .into_iter()
        .map(|(n, v)| (n.to_string(), v))
        .collect();
    // Zero until the robot has been reached, then the robot's values.
    declared.extend(
        ROBOT_PARAMETERS
            .iter()
            .map(|n| (n.to_string(), ParameterValue::Double(0.0))),
    );
    let node = create_node(
        options.domain_id,
        &options.node_name,
        &declared,
        validator(settings.clone(), link_up.clone(), checking.clone()),
        settings.use_stamped_vel,
    )?;
    checking.store(true, Ordering::Relaxed);
    let status = BridgeStatus {
        link: options.robot.describe(),
        link_down: Some("not connected yet".into()),
        activity: Activity::Idle.describe().into(),
        ..BridgeStatus::default()
    };
    let mut bridge = Bridge {
        options,
        node,
        settings,
        link_up,
        robot: None,
        multipliers: None,
        status,
        activity: Activity::Idle,
        angles: WheelAngles::default(),
        counts: BridgeCounts::default(),
        next_connect: Instant::now(),
        last_arm: None,
        last_diagnostics: None,
    };
    let started = Instant::now();
    loop {
        let stop = bridge.options.interrupt.load(Ordering::Relaxed)
            || bridge
                .options
                .duration
                .is_some_and(|d| started.elapsed() >= d);
        if stop {
            break;
        }
        bridge.step();
    }
    bridge.stop();
    Ok(bridge.counts)
}

/// The check every parameter change passes before it is accepted, once `checking` is set
/// (the declarations of the node's creation pass unchecked): the value's type and range,
/// the robot's parameters only while the link is up.
fn validator(
    settings: BridgeParameters,
    link_up: Arc<AtomicBool>,
    checking: Arc<AtomicBool>,
) -> Box<ParameterCheck> {
    let settings = Mutex::new(settings);
    Box::new(move |name, value| {
        if !checking.load(Ordering::Relaxed) {
            return Ok(());
        }
        if ROBOT_PARAMETERS.contains(&name) {
            if !link_up.load(Ordering::Relaxed) {
                return Err(format!("{name} is the robot's, and the link to it is down"));
            }
            return match value {
                ParameterValue::Double(x) if x.is_finite() && *x > 0.0 => Ok(()),
                ParameterValue::Integer(i) if *i > 0 => Ok(()),
                _ => Err(format!("{name} must be a finite number > 0")),
            };
        }
        let mut trial = settings
            .lock()
            .map_err(|_| "the bridge stopped".to_string())?
            .clone();
        match trial.set(name, value, false) {
            Ok(true) => Ok(()),
            Ok(false) => Err(ParameterError::Unknown { name: name.into() }.to_string()),
            Err(e) => Err(e.to_string()),
        }
    })
}

/// Now, as a ROS 2 stamp (the station's clock).
fn now() -> Time {
    Time::now()
}

impl Bridge {
    fn step(&mut self) {
        if self.robot.is_none() {
            if Instant::now() >= self.next_connect {
                self.connect();
            }
            if self.robot.is_none() {
                std::thread::sleep(POLL);
            }
        }
        if let Some(robot) = self.robot.as_mut() {
            match robot.poll(POLL) {
                Ok(messages) => {
                    for message in messages {
                        self.on_robot(message);
                    }
                }
                Err(e) => self.link_lost(&e),
            }
        }
        self.commands();
        self.paths();
        self.pose_resets();
        self.parameter_changes();
        self.keep_armed();
        let due = self
            .last_diagnostics
            .is_none_or(|t| t.elapsed() >= DIAGNOSTICS_EVERY);
        if due {
            self.publish_diagnostics();
        }
    }

    fn connect(&mut self) {
        self.next_connect = Instant::now() + RECONNECT_EVERY;
        match Robot::connect(&self.options.robot, self.settings.telemetry_rate_hz()) {
            Ok(robot) => {
                self.status.link_down = None;
                self.status.robot_name = robot.info.robot_name.to_string();
                self.status.latest = None;
                self.counts.connections += 1;
                println!(
                    "ros2 bridge: link up to {} ({}), node /{} on domain {}",
                    robot.describe(),
                    robot.info.robot_name,
                    self.options.node_name,
                    self.options.domain_id
                );
                let multipliers = *self
                    .multipliers
                    .get_or_insert_with(|| Multipliers::of(&robot.params.robot));
                let values = robot_values(&robot.params, &multipliers);
                self.robot = Some(robot);
                self.link_up.store(true, Ordering::Relaxed);
                self.show_robot_values(values);
                self.angles = WheelAngles::default();
                self.activity = Activity::Idle;
                if self.options.arm {
                    self.arm_velocity();
                }
                self.publish_diagnostics();
            }
            Err(e) => {
                let text = crate::error_text(&e);
                if self.status.link_down.as_deref() != Some(text.as_str()) {
                    eprintln!(
                        "ros2 bridge: no link to {}: {text}",
                        self.options.robot.describe()
                    );
                    self.status.link_down = Some(text);
                    self.publish_diagnostics();
                }
            }
        }
    }

    /// Sets the node's copies of the robot's parameters, and drops the changes that
    /// doing so reports (they are the robot's own values).
    fn show_robot_values(&mut self, values: Vec<(&'static str, ParameterValue)>) {
        for (name, value) in values {
            let _ = self.node.node.set_parameter(name, value);
        }
        while self.node.changes.try_recv().is_ok() {}
    }

    fn link_lost(&mut self, error: &LinkError) {
        let text = crate::error_text(error);
        eprintln!("ros2 bridge: link down: {text}");
        self.robot = None;
        self.link_up.store(false, Ordering::Relaxed);
        self.status.link_down = Some(text);
        self.activity = Activity::Idle;
        self.status.activity = self.activity.describe().into();
        self.next_connect = Instant::now() + RECONNECT_EVERY;
        self.publish_diagnostics();
    }

    /// Runs `work` on the connected robot: `None` when there is none, or when the link
    /// failed doing it (it is then down).
    fn with_robot<R>(
        &mut self,
        work: impl FnOnce(&mut Robot) -> Result<R, LinkError>,
    ) -> Option<Result<R, LinkError>> {
        let robot = self.robot.as_mut()?;
        match work(robot) {
            Err(e) if e.is_link_failure() => {
                self.link_lost(&e);
                None
            }
            other => Some(other),
        }
    }

    fn set_activity(&mut self, activity: Activity) {
        self.activity = activity;
        self.status.activity = activity.describe().into();
    }

    fn refuse(&mut self, why: String) {
        eprintln!("ros2 bridge: {why}");
        self.status.last_refusal = Some(why);
        self.publish_diagnostics();
    }

    fn arm_velocity(&mut self) {
        self.last_arm = Some(Instant::now());
        match self.with_robot(Robot::arm_velocity) {
            Some(Ok(())) => self.set_activity(Activity::Velocity),
            Some(Err(e)) => {
                self.set_activity(Activity::Idle);
                self.refuse(format!(
                    "cannot arm the velocity mode: {}",
                    crate::error_text(&e)
                ));
            }
            None => {}
        }
    }

    /// Disarms when the robot is armed; true when it is disarmed after.
    fn disarm(&mut self) -> bool {
        let armed = self.status.latest.is_none_or(|f| f.state == State::Armed)
            || self.activity != Activity::Idle;
        if !armed {
            return true;
        }
        match self.with_robot(Robot::disarm) {
            Some(Ok(())) => {
                self.set_activity(Activity::Idle);
                true
            }
            Some(Err(e)) => {
                self.refuse(format!("cannot disarm: {}", crate::error_text(&e)));
                false
            }
            None => false,
        }
    }

    /// Back to the velocity mode after other work, when the bridge keeps it.
    fn resume(&mut self) {
        if self.options.arm {
            self.arm_velocity();
        } else {
            self.set_activity(Activity::Idle);
        }
    }

    fn on_robot(&mut self, message: FromRobot) {
        match message {
            FromRobot::Telemetry(frame) => self.publish_telemetry(&frame),
            FromRobot::Event(_, Event::Faulted) => {
                self.set_activity(Activity::Idle);
                self.publish_diagnostics();
            }
            // A disarm a host asked for (the bridge itself, around a path, a pose or a
            // parameter write) is already accounted for.
            FromRobot::Event(_, Event::Disarmed(DisarmReason::Link)) => {}
            FromRobot::Event(_, Event::Disarmed(reason)) => {
                if self.activity == Activity::Velocity {
                    eprintln!("ros2 bridge: the robot disarmed ({reason:?})");
                    self.set_activity(Activity::Idle);
                }
            }
            FromRobot::Event(..) => {}
            FromRobot::RunEnded(report) => {
                if self.activity == Activity::FollowingPath {
                    self.path_ended(&report);
                }
            }
        }
    }

    fn publish_telemetry(&mut self, frame: &link::TelemetryFrame) {
        let Some(robot) = self.robot.as_ref() else {
            return;
        };
        let config = robot.params.robot;
        self.angles.advance(frame, config.control_rate_hz);
        let stamp = now();
        let frames = &self.settings.frames;
        let topics = &self.node.topics;
        if topics
            .odom
            .publish(odometry(frame, &config, frames, stamp))
            .is_ok()
        {
            self.counts.odom_published += 1;
        }
        if self.settings.enable_odom_tf {
            let _ = topics.tf.publish(transform(frame, frames, stamp));
        }
        let _ = topics
            .joint_states
            .publish(joint_states(frame, &self.angles, frames, stamp));
        let faulted_now = frame.state == State::Faulted
            && self
                .status
                .latest
                .is_some_and(|f| f.state != State::Faulted);
        self.status.latest = Some(*frame);
        if faulted_now {
            self.publish_diagnostics();
        }
    }

    fn keep_armed(&mut self) {
        if !self.options.arm || self.robot.is_none() || self.activity != Activity::Idle {
            return;
        }
        let Some(frame) = self.status.latest else {
            return;
        };
        let due = self.last_arm.is_none_or(|t| t.elapsed() >= REARM_EVERY);
        if frame.state == State::Disarmed && due {
            self.arm_velocity();
        }
    }

    fn publish_diagnostics(&mut self) {
        self.last_diagnostics = Some(Instant::now());
        let _ = self
            .node
            .topics
            .diagnostics
            .publish(diagnostics(&self.status, now()));
    }

    fn stop(&mut self) {
        if self.options.arm && self.robot.is_some() {
            let _ = self.with_robot(Robot::disarm);
        }
        println!(
            "ros2 bridge: stopped; cmd_vel {} forwarded, odom {} published, {} path{} \
             followed, link up {} time{}",
            self.counts.cmd_vel_forwarded,
            self.counts.odom_published,
            self.counts.paths_followed,
            if self.counts.paths_followed == 1 {
                ""
            } else {
                "s"
            },
            self.counts.connections,
            if self.counts.connections == 1 {
                ""
            } else {
                "s"
            },
        );
    }
}
