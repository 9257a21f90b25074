//! The robot's channels on one [`Context`], and what a sample logs on each. A file and a
//! live server each hold their own context (sweeps write files from several threads), so
//! nothing is logged to the SDK's global context.

use std::sync::Arc;

use controller_core::path::Path;
use controller_core::supervisor::{Faults, State};
use foxglove::messages::{log::Level, FrameTransform, Log, PoseInFrame, SceneUpdate};
use foxglove::{Channel, Context};
use robot_files::trace::TraceRow;

use crate::convert::{self, log_time_ns, PlanarPose};
use crate::messages::{BodyMessage, ErrorsMessage, SupervisorMessage, WheelsMessage};
use crate::path_line::path_scene;
use crate::topics;

/// Every channel of [`topics::ALL`], and the supervisor's last state (for the events).
pub struct RobotChannels {
    tf: Channel<FrameTransform>,
    pose_estimate: Channel<PoseInFrame>,
    pose_true: Channel<PoseInFrame>,
    pose_reference: Channel<PoseInFrame>,
    path: Channel<SceneUpdate>,
    errors: Channel<ErrorsMessage>,
    body: Channel<BodyMessage>,
    wheels: Channel<WheelsMessage>,
    supervisor: Channel<SupervisorMessage>,
    events: Channel<Log>,
    last: Option<(State, Faults)>,
    samples: u64,
}

impl RobotChannels {
    /// The channels, created on `context` (each advertised to its sinks at once, so a
    /// file lists every channel, even one that never carries a message).
    pub fn new(context: &Arc<Context>) -> Self {
        Self {
            tf: context.channel_builder(topics::TF).build(),
            pose_estimate: context.channel_builder(topics::POSE_ESTIMATE).build(),
            pose_true: context.channel_builder(topics::POSE_TRUE).build(),
            pose_reference: context.channel_builder(topics::POSE_REFERENCE).build(),
            path: context.channel_builder(topics::PATH).build(),
            errors: context.channel_builder(topics::ERRORS).build(),
            body: context.channel_builder(topics::BODY).build(),
            wheels: context.channel_builder(topics::WHEELS).build(),
            supervisor: context.channel_builder(topics::SUPERVISOR).build(),
            events: context.channel_builder(topics::EVENTS).build(),
            last: None,
            samples: 0,
        }
    }

    /// Samples logged so far.
    pub fn samples(&self) -> u64 {
        self.samples
    }

    /// Logs `path` on `/path` at `t_s` (s of the run).
    pub fn log_path(&self, path: &Path, t_s: f64) {
        self.path
            .log_with_time(&path_scene(path, t_s), log_time_ns(t_s));
    }

    /// Logs one sample at its own time `row.t_s`: the transforms and poses (the true
    /// and the reference ones only when known, i.e. finite), the telemetry channels,
    /// and an event when the supervisor's state or faults changed since the last sample.
    pub fn log_sample(&mut self, row: &TraceRow) {
        let t = row.t_s;
        let ns = log_time_ns(t);
        let estimate = PlanarPose::from(row.est_pose);
        let truth = PlanarPose::from(row.true_pose);
        let reference = PlanarPose::from(row.reference);
        self.tf.log_with_time(
            &convert::frame_transform(t, topics::ESTIMATE_FRAME, estimate),
            ns,
        );
        self.pose_estimate
            .log_with_time(&convert::pose_in_frame(t, estimate), ns);
        if reference.is_finite() {
            self.tf.log_with_time(
                &convert::frame_transform(t, topics::REFERENCE_FRAME, reference),
                ns,
            );
            self.pose_reference
                .log_with_time(&convert::pose_in_frame(t, reference), ns);
        }
        if truth.is_finite() {
            self.tf
                .log_with_time(&convert::frame_transform(t, topics::TRUE_FRAME, truth), ns);
            self.pose_true
                .log_with_time(&convert::pose_in_frame(t, truth), ns);
        }
        self.errors.log_with_time(&convert::errors(row), ns);
        self.body.log_with_time(&convert::body(row), ns);
        self.wheels.log_with_time(&convert::wheels(row), ns);
        self.supervisor.log_with_time(&convert::supervisor(row), ns);
        let now = (row.state, row.detail.faults);
        if let Some(text) = change_text(self.last, now) {
            let level = if now.0 == State::Faulted {
                Level::Error
            } else {
                Level::Info
            };
            self.log_event(t, level, &text);
        }
        self.last = Some(now);
        self.samples += 1;
    }

    /// Logs an event on `/events` at `t_s` (s of the run).
    pub fn log_event(&self, t_s: f64, level: Level, text: &str) {
        self.events.log_with_time(
            &Log {
                timestamp: Some(convert::timestamp(t_s)),
                level: level as i32,
                message: text.to_string(),
                name: "supervisor".to_string(),
                file: String::new(),
                line: 0,
            },
            log_time_ns(t_s),
        );
    }
}

/// The event text of the supervisor going from `before` (None: the first sample) to
/// `now`: `armed`, `disarmed`, `persisting`, or `faulted: name, name`; None when nothing
/// changed (the first sample says its state).
fn change_text(before: Option<(State, Faults)>, now: (State, Faults)) -> Option<String> {
    if before == Some(now) {
        return None;
    }
    let (state, faults) = now;
    let text = match state {
        State::Armed => "armed".to_string(),
        State::Disarmed => "disarmed".to_string(),
        State::Persisting => "persisting".to_string(),
        State::Faulted => {
            let names: Vec<&str> = faults.iter().map(|f| f.name()).collect();
            format!("faulted: {}", names.join(", "))
        }
    };
    Some(match before {
        None => format!("first sample: {text}"),
        Some(_) => text,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller_core::supervisor::Fault;

    #[test]
    fn events_say_each_change_of_state_and_faults() {
        let none = Faults::NONE;
        assert_eq!(
            change_text(None, (State::Disarmed, none)).as_deref(),
            Some("first sample: disarmed")
        );
        assert_eq!(
            change_text(Some((State::Disarmed, none)), (State::Armed, none)).as_deref(),
            Some("armed")
        );
        assert_eq!(
            change_text(Some((State::Armed, none)), (State::Armed, none)),
            None
        );
        let faults = none.with(Fault::Geofence).with(Fault::StallLeft);
        assert_eq!(
            change_text(Some((State::Armed, none)), (State::Faulted, faults)).as_deref(),
            Some("faulted: stall_left, geofence")
        );
    }
}
