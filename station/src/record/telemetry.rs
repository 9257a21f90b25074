//! Telemetry frames the run expected and the ones that arrived: the gaps in the robot's
//! step numbers, and the robot's own count of dropped samples.

/// Past this fraction of missing telemetry frames, the station warns.
pub const MISSING_TELEMETRY_WARNING: f64 = 0.05;

/// How much of a run's telemetry reached the station (`summary.json`'s `telemetry`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct TelemetryCount {
    /// The telemetry rate, Hz.
    pub rate_hz: u8,
    /// Control steps between frames: control rate / telemetry rate.
    pub period_steps: u32,
    /// Frames the run should have given: received plus missing.
    pub expected_frames: u64,
    /// Frames of the run received (the trace's rows).
    pub received_frames: u64,
    /// Frames missing, from the gaps in the received frames' step numbers, and before the
    /// first and after the last to the run's ends.
    pub missing_frames: u64,
    /// Telemetry frames the robot could not send for want of room on the link while the
    /// run was recorded (its `telemetry_dropped`); `None` when its statistics did not
    /// come. The rest of the missing frames were lost on the line.
    pub dropped_on_robot: Option<u32>,
}

impl TelemetryCount {
    /// Missing frames over expected ones (0 when none was expected).
    pub fn missing_fraction(&self) -> f64 {
        if self.expected_frames == 0 {
            0.0
        } else {
            self.missing_frames as f64 / self.expected_frames as f64
        }
    }

    /// One line: received of expected, and where the missing ones went.
    pub fn text(&self) -> String {
        if self.missing_frames == 0 {
            return format!(
                "telemetry: {} of {} frames at {} Hz, none missing",
                self.received_frames, self.expected_frames, self.rate_hz
            );
        }
        let mut text = format!(
            "telemetry: {} of {} frames at {} Hz ({} missing, {:.1} %",
            self.received_frames,
            self.expected_frames,
            self.rate_hz,
            self.missing_frames,
            100.0 * self.missing_fraction()
        );
        match self.dropped_on_robot {
            Some(dropped) => {
                let on_line = self.missing_frames.saturating_sub(u64::from(dropped));
                text += &format!(
                    "; {dropped} dropped on the robot for want of link room, {on_line} lost on the line)"
                );
            }
            None => text += "; the robot's count of dropped frames did not come)",
        }
        text
    }

    /// A warning when more than [`MISSING_TELEMETRY_WARNING`] of the frames are missing.
    pub fn warning(&self) -> Option<String> {
        (self.missing_fraction() > MISSING_TELEMETRY_WARNING).then(|| {
            format!(
                "{:.1} % of the telemetry is missing (over {:.0} %): the trace has gaps; a \
lower --hz, or a cleaner line, would keep more",
                100.0 * self.missing_fraction(),
                100.0 * MISSING_TELEMETRY_WARNING
            )
        })
    }
}

/// Counts the frames of a run from their step numbers, one every `period` steps.
#[derive(Clone, Copy, Debug, Default)]
pub struct GapCounter {
    first: Option<u64>,
    last: u64,
    received: u64,
    missing_between: u64,
}

impl GapCounter {
    /// A frame at run step `k` (steps since the run's start, increasing), on a stream
    /// of one frame every `period` steps.
    pub fn push(&mut self, k: u64, period: u32) {
        let period = u64::from(period.max(1));
        if self.first.is_some() {
            let gap = k.saturating_sub(self.last);
            // Rounded: a late control step moves a frame by a step or two.
            let slots = (gap + period / 2) / period;
            self.missing_between += slots.saturating_sub(1);
        } else {
            self.first = Some(k);
        }
        self.last = k;
        self.received += 1;
    }

    /// (received, missing) for a run of `steps` steps (frames due at steps 0 ≤ k <
    /// `steps`, one every `period`).
    pub fn count(&self, steps: u64, period: u32) -> (u64, u64) {
        let period = u64::from(period.max(1));
        let Some(first) = self.first else {
            return (0, steps.div_ceil(period));
        };
        let before = first / period;
        let after = steps.saturating_sub(self.last + 1) / period;
        (self.received, self.missing_between + before + after)
    }
}
