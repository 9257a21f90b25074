//! Command-line values both `host-sim` and the ground station (`station`) take.

use clap::ValueEnum;
use controller_core::law::LawKind;

/// Steering law (see `controller_core::law`), as a command-line value.
#[derive(Clone, Copy, Debug, ValueEnum)]
pub enum Law {
    /// The paper's polar law (33)–(34), as published: trails a moving reference by ≈ v_r/γ.
    Paper,
    /// The paper's Lyapunov design redone for a moving reference: zero steady error.
    Tracking,
    /// Kanayama et al. (1990), the classic baseline.
    Kanayama,
}

impl From<Law> for LawKind {
    fn from(law: Law) -> Self {
        match law {
            Law::Paper => LawKind::Paper,
            Law::Tracking => LawKind::Tracking,
            Law::Kanayama => LawKind::Kanayama,
        }
    }
}
