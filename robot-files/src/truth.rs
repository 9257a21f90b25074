//! Ground truth against the reference: the true pose, and the true error measured at
//! every steering period against the scenario's own reference, evaluated here,
//! independently of the controller. In time-indexed mode that is the reference point at
//! that time and its heading; in path-following mode, where the controller may aim ahead
//! on purpose, the closest point of the path and the path's heading there. World frame,
//! m and rad, except where a function says robot frame.

use controller_core::path::Path;
use controller_core::prelude::{Point, Pose};
use controller_core::reference::ReferenceMode;

use crate::scenario::Scenario;

/// The true pose, world frame: position in m, heading in rad (counter-clockwise from x,
/// wrapped to (−π, π]).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TruePose {
    /// x, m.
    pub x_m: f64,
    /// y, m.
    pub y_m: f64,
    /// θ, rad, in (−π, π].
    pub theta_rad: f64,
}

impl TruePose {
    /// `pose` (single precision, as the link and the controller hold it) widened exactly.
    pub fn from_pose(pose: Pose) -> Self {
        Self {
            x_m: f64::from(pose.x_m),
            y_m: f64::from(pose.y_m),
            theta_rad: f64::from(pose.theta_rad),
        }
    }
}

/// Wrap an angle to (−π, π], rad.
pub fn wrap_angle(a: f64) -> f64 {
    use core::f64::consts::{PI, TAU};
    let w = a - TAU * ((a + PI) / TAU).floor();
    // w is in [−π, π); map −π to π.
    if w <= -PI {
        w + TAU
    } else {
        w
    }
}

/// Eq. (9) in f64: the reference seen from the true pose, robot frame: [x_e m, y_e m,
/// θ_e rad].
pub fn tracking_error_f64(pose: &TruePose, reference: &Pose) -> [f64; 3] {
    let dx = f64::from(reference.x_m) - pose.x_m;
    let dy = f64::from(reference.y_m) - pose.y_m;
    let (s, c) = pose.theta_rad.sin_cos();
    [
        c * dx + s * dy,
        -s * dx + c * dy,
        wrap_angle(f64::from(reference.theta_rad) - pose.theta_rad),
    ]
}

/// The true error as the metrics use it: the distance from the true pose to `reference`
/// (m) and the heading error θ_r − θ wrapped to (−π, π] (rad).
pub fn true_error(reference: &Pose, pose: &TruePose) -> (f64, f64) {
    let dx = f64::from(reference.x_m) - pose.x_m;
    let dy = f64::from(reference.y_m) - pose.y_m;
    let heading = wrap_angle(f64::from(reference.theta_rad) - pose.theta_rad);
    (dx.hypot(dy), heading)
}

/// The reference the true error is measured against (module doc), evaluated here,
/// independently of the controller, in `f64` where the controller uses fixed point: in
/// time-indexed mode the arc length s₀ + v_r·k/rate (k control periods since arming)
/// modulo the lap, so a reference that drifts in the controller shows up in the true
/// error. The simulator, the virtual robot and the station all measure against it.
#[derive(Clone, Debug)]
pub struct TrueReference {
    path: Path,
    /// Time-indexed: (start offset m, speed m/s, control rate Hz); None when following.
    time_indexed: Option<(f64, f64, f64)>,
}

impl TrueReference {
    /// The reference of `scenario` (its path, speed and mode) on a loop of
    /// `control_rate_hz` control periods per second.
    pub fn new(scenario: &Scenario, control_rate_hz: u32) -> Self {
        Self::of(
            scenario.path.clone(),
            scenario.reference_speed_m_s,
            scenario.reference_mode,
            control_rate_hz,
        )
    }

    /// The reference along `path` at `speed_m_s` (m/s) in `mode`, on a loop of
    /// `control_rate_hz` control periods per second.
    pub fn of(path: Path, speed_m_s: f32, mode: ReferenceMode, control_rate_hz: u32) -> Self {
        let time_indexed = match mode {
            ReferenceMode::TimeIndexed { start_offset_m } => Some((
                f64::from(path.normalize_m(start_offset_m)),
                f64::from(speed_m_s),
                f64::from(control_rate_hz),
            )),
            ReferenceMode::PathFollowing { .. } => None,
        };
        Self { path, time_indexed }
    }

    /// The reference pose (world frame, m and rad) `periods` control periods after
    /// arming, for a robot at `pose`.
    pub fn at(&self, periods: u64, pose: &TruePose) -> Pose {
        let path = &self.path;
        let s_m = match self.time_indexed {
            Some((start_m, speed_m_s, rate_hz)) => {
                let s = start_m + speed_m_s * periods as f64 / rate_hz;
                let length = f64::from(path.length_m());
                if path.is_closed() {
                    s.rem_euclid(length) as f32
                } else {
                    s.min(length) as f32
                }
            }
            None => {
                let p = Point::new(pose.x_m as f32, pose.y_m as f32);
                path.project(p, 0.0, f32::INFINITY, f32::INFINITY)
            }
        };
        let sample = path.sample(s_m);
        Pose::new(sample.point.x_m, sample.point.y_m, sample.heading_rad)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::f64::consts::PI;

    #[test]
    fn wrap_angle_range() {
        for a in [-10.0, -PI, 0.0, PI, 3.5, 100.0] {
            let w = wrap_angle(a);
            assert!(w > -PI && w <= PI, "{a} -> {w}");
            let turns = (a - w) / (2.0 * PI);
            assert!((turns - turns.round()).abs() < 1e-9, "{a} -> {w}");
        }
    }
}
