//! The robot's signals a bring-up reads: telemetry frames (the board's raw encoder
//! counts, the supply) and events, counted in the robot's own control steps so that a
//! virtual robot running faster than real time reads the same.

use std::time::{Duration, Instant};

use controller_core::supervisor::Event;
use link::{RawCounts, TelemetryFrame, Uplink};

use super::BringupError;
use crate::client::Client;
use crate::transport::Transport;

/// How long the station waits for a signal before it gives up, host time.
pub const SIGNAL_LIMIT: Duration = Duration::from_secs(20);

/// What came from the robot while the station listened.
#[derive(Clone, Debug, Default)]
pub struct Heard {
    /// The newest telemetry frame.
    pub last: Option<TelemetryFrame>,
    /// The events, in order.
    pub events: Vec<Event>,
}

/// The next telemetry frame (the events before it into `heard`), waiting at most
/// [`SIGNAL_LIMIT`].
pub fn next_frame<T: Transport>(
    client: &mut Client<T>,
    heard: &mut Heard,
) -> Result<TelemetryFrame, BringupError> {
    let start = Instant::now();
    while start.elapsed() < SIGNAL_LIMIT {
        match client.next_message(Duration::from_millis(20))? {
            Some(Uplink::Telemetry(frame)) => {
                heard.last = Some(frame);
                return Ok(frame);
            }
            Some(Uplink::Event { event, .. }) => heard.events.push(event),
            _ => {}
        }
    }
    Err(BringupError::Silent("no telemetry from the robot".into()))
}

/// Reads what the robot sent while the station was not listening (into `heard`), then
/// one more frame; returns the newest frame.
pub fn catch_up<T: Transport>(
    client: &mut Client<T>,
    heard: &mut Heard,
) -> Result<TelemetryFrame, BringupError> {
    while let Some(message) = client.next_message(Duration::from_millis(1))? {
        match message {
            Uplink::Telemetry(frame) => heard.last = Some(frame),
            Uplink::Event { event, .. } => heard.events.push(event),
            _ => {}
        }
    }
    next_frame(client, heard)
}

/// An encoder that changed by at most this many counts has not moved: a still encoder
/// sitting on an edge may flicker by a count.
pub const JITTER_COUNTS: i64 = 2;

/// Reads frames from now on (what was sent while the station was not listening is only
/// caught up with) until neither of the board's encoder counts has moved (beyond
/// [`JITTER_COUNTS`]) for `still_steps` control steps; returns the last frame. Gives up
/// after [`SIGNAL_LIMIT`].
pub fn wait_still<T: Transport>(
    client: &mut Client<T>,
    still_steps: u32,
    heard: &mut Heard,
) -> Result<TelemetryFrame, BringupError> {
    let start = Instant::now();
    let mut frame = catch_up(client, heard)?;
    let mut since = frame.step;
    let mut counts = frame.raw_counts;
    while start.elapsed() < SIGNAL_LIMIT {
        frame = next_frame(client, heard)?;
        if moved(counts, frame.raw_counts) {
            counts = frame.raw_counts;
            since = frame.step;
        } else if frame.step.wrapping_sub(since) >= still_steps {
            return Ok(frame);
        }
    }
    Err(BringupError::Silent(
        "the wheels never stood still: the encoder counts kept changing".into(),
    ))
}

/// True when either count moved from `from` to `to` by more than [`JITTER_COUNTS`].
pub fn moved(from: RawCounts, to: RawCounts) -> bool {
    counted(from, to).iter().any(|c| c.abs() > JITTER_COUNTS)
}

/// Reads frames until `wanted` says one of the events heard (those sent while the
/// station was not listening among them) is the one awaited, or `steps` control steps
/// have passed since the newest frame; returns the event, if it came.
pub fn wait_event<T: Transport>(
    client: &mut Client<T>,
    steps: u32,
    heard: &mut Heard,
    wanted: impl Fn(&Event) -> bool,
) -> Result<Option<Event>, BringupError> {
    let first = catch_up(client, heard)?.step;
    loop {
        if let Some(event) = heard.events.iter().copied().find(|e| wanted(e)) {
            return Ok(Some(event));
        }
        let frame = next_frame(client, heard)?;
        if frame.step.wrapping_sub(first) >= steps {
            return Ok(heard.events.iter().copied().find(|e| wanted(e)));
        }
    }
}

/// The change of the board's counts from `before` to `after` (wrapping), counts.
pub fn counted(before: RawCounts, after: RawCounts) -> [i64; 2] {
    [
        i64::from(after.left.wrapping_sub(before.left)),
        i64::from(after.right.wrapping_sub(before.right)),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flicker_of_two_counts_either_way_has_not_moved() {
        let at = |left: i32, right: i32| RawCounts { left, right };
        assert!(!moved(at(10, 0), at(12, -2)), "+2 and −2");
        assert!(
            !moved(at(i32::MAX, 0), at(i32::MIN + 1, 0)),
            "+2 across the wrap"
        );
        assert!(moved(at(10, 0), at(13, 0)));
        assert!(
            moved(at(10, i32::MIN), at(10, i32::MAX - 2)),
            "−3 across the wrap"
        );
    }
}
