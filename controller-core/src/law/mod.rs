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

    const GAINS: LawGains = LawGains {
        paper: PaperGains {
            gamma: 1.0,
            k: 2.0,
            h: 1.5,
            lambda: 0.5,
        },
        tracking: TrackingGains {
            lambda: 16.0,
            k_x: 3.0,
            k_theta: 4.0,
        },
        kanayama: KanayamaGains {
            k_x: 2.5,
            k_y: 40.0,
            k_theta: 12.0,
        },
    };

    /// `GAINS` with the gain named `field` set to `value`.
    fn with(field: &str, value: f32) -> LawGains {
        let mut g = GAINS;
        let slot = match field {
            "law.paper.gamma" => &mut g.paper.gamma,
            "law.paper.k" => &mut g.paper.k,
            "law.paper.h" => &mut g.paper.h,
            "law.paper.lambda" => &mut g.paper.lambda,
            "law.tracking.lambda" => &mut g.tracking.lambda,
            "law.tracking.k_x" => &mut g.tracking.k_x,
            "law.tracking.k_theta" => &mut g.tracking.k_theta,
            "law.kanayama.k_x" => &mut g.kanayama.k_x,
            "law.kanayama.k_y" => &mut g.kanayama.k_y,
            "law.kanayama.k_theta" => &mut g.kanayama.k_theta,
            _ => panic!("no gain {field}"),
        };
        *slot = value;
        g
    }

    #[test]
    fn validation_names_the_first_bad_gain() {
        assert_eq!(GAINS.validate(), Ok(()));
        let fields = [
            "law.paper.gamma",
            "law.paper.k",
            "law.paper.h",
            "law.paper.lambda",
            "law.tracking.lambda",
            "law.tracking.k_x",
            "law.tracking.k_theta",
            "law.kanayama.k_x",
            "law.kanayama.k_y",
            "law.kanayama.k_theta",
        ];
        for name in fields {
            for bad in [f32::NAN, f32::INFINITY] {
                match with(name, bad).validate() {
                    Err(ParamError::NonFinite { field, .. }) => assert_eq!(field, name),
                    other => panic!("{name} = {bad}: {other:?}"),
                }
            }
            for bad in [0.0, -1.0] {
                assert_eq!(
                    with(name, bad).validate(),
                    Err(ParamError::NonPositive {
                        field: name,
                        value: bad
                    })
                );
            }
            // The smallest positive gain is valid.
            assert_eq!(with(name, f32::MIN_POSITIVE).validate(), Ok(()));
        }
        // Two bad gains: the first in the list is named.
        let mut two = with("law.kanayama.k_y", 0.0);
        two.paper.h = -2.0;
        assert!(matches!(
            two.validate(),
            Err(ParamError::NonPositive {
                field: "law.paper.h",
                ..
            })
        ));
    }

    #[test]
    fn steer_runs_the_selected_law_with_its_own_gains() {
        let robot = Pose::new(0.2, -0.3, 0.4);
        let reference = ReferenceState {
            pose: Pose::new(1.0, 0.5, 1.0),
            v_m_s: 0.3,
            omega_rad_s: 0.2,
            ..ReferenceState::default()
        };
        assert_eq!(
            steer(LawKind::Paper, &GAINS, &robot, &reference),
            paper::steer(&GAINS.paper, &robot, &reference.pose)
        );
        assert_eq!(
            steer(LawKind::Tracking, &GAINS, &robot, &reference),
            tracking::steer(&GAINS.tracking, &robot, &reference)
        );
        assert_eq!(
            steer(LawKind::Kanayama, &GAINS, &robot, &reference),
            kanayama::steer(&GAINS.kanayama, &robot, &reference)
        );
        // The three differ here, so a swapped dispatch would show.
        let outputs = LawKind::ALL.map(|k| steer(k, &GAINS, &robot, &reference).command);
        assert_ne!(outputs[0], outputs[1]);
        assert_ne!(outputs[1], outputs[2]);
        assert_ne!(outputs[0], outputs[2]);
    }
}
