//! Steering laws: pose error → body velocity command (v, ω).
//!
//! Three laws sit behind one small interface, [`steer`], selected by [`LawKind`]:
//!
//! | law | source | reference | steady error on a moving reference |
//! |---|---|---|---|
//! | [`paper`] | Jin & Tack eqs. (33)–(34) (Aicardi et al. 1995) | a fixed pose | trails by ≈ v_r/γ |
//! | [`tracking`] | the paper's Lyapunov design redone in the reference's frame | moving | zero |
//! | [`kanayama`] | Kanayama et al. 1990 | moving | zero |
//!
//! Every law reports its Lyapunov function V and its predicted rate V̇ along the
//! closed-loop error dynamics, so plots and telemetry show what it is doing.

pub mod kanayama;
pub mod paper;
pub mod tracking;

use crate::kinematics::{tracking_error, BodyVelocity, Pose, TrackingError};
use crate::params::ParamError;
use crate::reference::ReferenceState;

pub use kanayama::KanayamaGains;
pub use paper::{PaperGains, PolarError};
pub use tracking::TrackingGains;

/// Which steering law the controller runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub enum LawKind {
    /// The paper's polar regulation law, eqs. (33)–(34), exactly as published.
    Paper,
    /// Lyapunov tracking law with feed-forward: zero steady error on a moving reference.
    Tracking,
    /// Kanayama et al. (1990), the classic baseline.
    Kanayama,
}

impl LawKind {
    /// Every law, in the order used by comparisons.
    pub const ALL: [LawKind; 3] = [LawKind::Paper, LawKind::Tracking, LawKind::Kanayama];

    /// The law's short name: `paper`, `tracking` or `kanayama`.
    pub const fn name(self) -> &'static str {
        match self {
            LawKind::Paper => "paper",
            LawKind::Tracking => "tracking",
            LawKind::Kanayama => "kanayama",
        }
    }

    /// The law called `name` (see [`LawKind::name`]), if any.
    pub fn from_name(name: &str) -> Option<LawKind> {
        LawKind::ALL.into_iter().find(|law| law.name() == name)
    }
}

/// Gains of all three laws (only the selected law's gains are used).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct LawGains {
    /// Gains of the paper's law.
    pub paper: PaperGains,
    /// Gains of the tracking law.
    pub tracking: TrackingGains,
    /// Gains of Kanayama's law.
    pub kanayama: KanayamaGains,
}

impl LawGains {
    /// Checks that every gain is finite and > 0; the error names the first that is not.
    pub fn validate(&self) -> Result<(), ParamError> {
        let all = [
            ("law.paper.gamma", self.paper.gamma),
            ("law.paper.k", self.paper.k),
            ("law.paper.h", self.paper.h),
            ("law.paper.lambda", self.paper.lambda),
            ("law.tracking.lambda", self.tracking.lambda),
            ("law.tracking.k_x", self.tracking.k_x),
            ("law.tracking.k_theta", self.tracking.k_theta),
            ("law.kanayama.k_x", self.kanayama.k_x),
            ("law.kanayama.k_y", self.kanayama.k_y),
            ("law.kanayama.k_theta", self.kanayama.k_theta),
        ];
        for (field, value) in all {
            if !value.is_finite() {
                return Err(ParamError::NonFinite { field, value });
            }
            if value <= 0.0 {
                return Err(ParamError::NonPositive { field, value });
            }
        }
        Ok(())
    }
}

/// What a law computed: the command and its diagnostics.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize, postcard_schema::Schema)
)]
pub struct LawOutput {
    /// Commanded body velocity (v m/s, ω rad/s), before limits.
    pub command: BodyVelocity,
    /// Lyapunov function V at this instant (dimensionless mix of m² and rad²).
    pub lyapunov: f32,
    /// V̇ predicted by the law's proof along its closed-loop error dynamics, per s (≤ 0).
    pub lyapunov_rate: f32,
    /// Tracking error (9) of the robot against the reference, robot frame (every law).
    pub error: TrackingError,
    /// Polar error (r_e, α, β): `Some` for the paper's law, which is built on it; the
    /// other laws do not compute it (it costs an atan2 and a sqrt per steering step).
    pub polar: Option<PolarError>,
}

/// Runs law `kind` with `gains` for a robot at `robot` chasing `reference`.
pub fn steer(
    kind: LawKind,
    gains: &LawGains,
    robot: &Pose,
    reference: &ReferenceState,
) -> LawOutput {
    let error = tracking_error(robot, &reference.pose);
    steer_with_error(kind, gains, robot, reference, error)
}

/// [`steer`] with the tracking error (9) of `robot` against `reference` already computed
/// (the controller does, from the heading's sine and cosine that odometry keeps).
pub fn steer_with_error(
    kind: LawKind,
    gains: &LawGains,
    robot: &Pose,
    reference: &ReferenceState,
    error: TrackingError,
) -> LawOutput {
    match kind {
        LawKind::Paper => paper::with_tracking_error(&gains.paper, robot, &reference.pose, error),
        LawKind::Tracking => tracking::from_error(&gains.tracking, error, reference),
        LawKind::Kanayama => kanayama::from_error(&gains.kanayama, error, reference),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for law in LawKind::ALL {
            assert_eq!(LawKind::from_name(law.name()), Some(law));
        }
        assert_eq!(LawKind::from_name("pid"), None);
    }
}
