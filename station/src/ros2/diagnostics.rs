//! The bridge's `diagnostics` (diagnostic_msgs/DiagnosticArray): one status for the link
//! to the robot, one for the robot (its supervisor state, mode and latched faults), and
//! one for the commands the bridge took from ROS 2 (the last path refused, and why).

use controller_core::supervisor::{RunMode, State};
use link::TelemetryFrame;
use ros2_client::builtin_interfaces::Time;

use super::messages::{DiagnosticArray, DiagnosticStatus, Header, KeyValue};

/// The name of the link's status.
pub const LINK_STATUS: &str = "station ros2: link";
/// The name of the robot's status.
pub const ROBOT_STATUS: &str = "station ros2: robot";
/// The name of the commands' status.
pub const COMMAND_STATUS: &str = "station ros2: commands";

/// What the bridge knows that diagnostics reports.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct BridgeStatus {
    /// The robot's link (`127.0.0.1:5760`, `/dev/ttyACM0 at 230400 baud`).
    pub link: String,
    /// The robot's name, once it said it.
    pub robot_name: String,
    /// Why the link is down (`None`: up).
    pub link_down: Option<String>,
    /// The latest telemetry, if any since the link came up.
    pub latest: Option<TelemetryFrame>,
    /// What the bridge is doing with the robot (`velocity mode`, `following a path`,
    /// `idle`).
    pub activity: String,
    /// The last path or command refused, and why (`None`: none since the bridge started).
    pub last_refusal: Option<String>,
}

/// The array for `status`, stamped `stamp`.
pub fn diagnostics(status: &BridgeStatus, stamp: Time) -> DiagnosticArray {
    DiagnosticArray {
        header: Header {
            stamp,
            frame_id: String::new(),
        },
        status: vec![
            link_status(status),
            robot_status(status),
            command_status(status),
        ],
    }
}

fn value(key: &str, value: impl Into<String>) -> KeyValue {
    KeyValue {
        key: key.into(),
        value: value.into(),
    }
}

fn link_status(status: &BridgeStatus) -> DiagnosticStatus {
    let (level, message) = match &status.link_down {
        None => (DiagnosticStatus::OK, "link up".to_string()),
        Some(why) => (
            DiagnosticStatus::ERROR,
            format!("link down: {why}; reconnecting"),
        ),
    };
    DiagnosticStatus {
        level,
        name: LINK_STATUS.into(),
        message,
        hardware_id: status.robot_name.clone(),
        values: vec![value("link", status.link.clone())],
    }
}

fn state_name(state: State) -> &'static str {
    match state {
        State::Disarmed => "disarmed",
        State::Armed => "armed",
        State::Faulted => "faulted",
        State::Persisting => "persisting",
    }
}

fn mode_name(mode: RunMode) -> String {
    format!("{mode:?}")
}

fn robot_status(status: &BridgeStatus) -> DiagnosticStatus {
    let (level, message, values) = match (&status.link_down, &status.latest) {
        (Some(_), _) | (None, None) => (
            DiagnosticStatus::STALE,
            "no telemetry".to_string(),
            Vec::new(),
        ),
        (None, Some(frame)) => {
            let faults = robot_files::metrics::fault_names(&frame.faults);
            let level = if faults.is_empty() {
                DiagnosticStatus::OK
            } else {
                DiagnosticStatus::ERROR
            };
            let message = if faults.is_empty() {
                state_name(frame.state).to_string()
            } else {
                format!("{}: {}", state_name(frame.state), faults.join(", "))
            };
            let values = vec![
                value("state", state_name(frame.state)),
                value("mode", mode_name(frame.run_mode)),
                value(
                    "faults",
                    if faults.is_empty() {
                        "none".to_string()
                    } else {
                        faults.join(", ")
                    },
                ),
                value("supply_v", format!("{:.2}", frame.supply_v)),
                value("step", frame.step.to_string()),
                value("missed_ticks", frame.missed_ticks.to_string()),
            ];
            (level, message, values)
        }
    };
    DiagnosticStatus {
        level,
        name: ROBOT_STATUS.into(),
        message,
        hardware_id: status.robot_name.clone(),
        values,
    }
}

fn command_status(status: &BridgeStatus) -> DiagnosticStatus {
    let (level, message) = match &status.last_refusal {
        None => (DiagnosticStatus::OK, status.activity.clone()),
        Some(why) => (
            DiagnosticStatus::WARN,
            format!("{}; refused: {why}", status.activity),
        ),
    };
    DiagnosticStatus {
        level,
        name: COMMAND_STATUS.into(),
        message,
        hardware_id: status.robot_name.clone(),
        values: vec![value("activity", status.activity.clone())],
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller_core::supervisor::Fault;

    #[test]
    fn a_link_down_is_an_error_and_the_robot_goes_stale() {
        let status = BridgeStatus {
            link: "127.0.0.1:5760".into(),
            link_down: Some("connection refused".into()),
            latest: Some(crate::test_frames::still(5)),
            ..BridgeStatus::default()
        };
        let array = diagnostics(&status, Time::ZERO);
        assert_eq!(array.status[0].level, DiagnosticStatus::ERROR);
        assert!(array.status[0].message.contains("connection refused"));
        assert_eq!(array.status[1].level, DiagnosticStatus::STALE);
    }

    #[test]
    fn latched_faults_are_named() {
        let mut frame = crate::test_frames::still(5);
        frame.state = State::Faulted;
        frame.faults.set(Fault::StallLeft);
        let status = BridgeStatus {
            latest: Some(frame),
            ..BridgeStatus::default()
        };
        let robot = &diagnostics(&status, Time::ZERO).status[1];
        assert_eq!(robot.level, DiagnosticStatus::ERROR);
        assert_eq!(robot.message, "faulted: stall_left");
        let ok = BridgeStatus {
            latest: Some(crate::test_frames::still(5)),
            ..BridgeStatus::default()
        };
        assert_eq!(
            diagnostics(&ok, Time::ZERO).status[1].level,
            DiagnosticStatus::OK
        );
    }

    #[test]
    fn a_refused_path_is_a_warning_with_the_reason() {
        let status = BridgeStatus {
            activity: "velocity mode".into(),
            last_refusal: Some("path: too many waypoints".into()),
            ..BridgeStatus::default()
        };
        let commands = &diagnostics(&status, Time::ZERO).status[2];
        assert_eq!(commands.level, DiagnosticStatus::WARN);
        assert!(commands.message.contains("too many waypoints"));
    }
}
