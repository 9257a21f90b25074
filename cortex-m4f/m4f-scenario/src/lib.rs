//! # m4f-scenario
//!
//! One closed-loop run of `controller-core` against a small deterministic plant, reduced
//! to a [`Digest`] of its trajectory. The same code runs
//!
//! - on the host (this crate's tests and `cargo xtask ci` call [`run_scenario`] directly),
//! - on an emulated Cortex-M4F (`cortex-m4f/qemu-m4f`, run by `cargo xtask ci` under QEMU),
//!
//! and the two digests must be bit-identical: that is the proof that the core computes the
//! same numbers on the robot as in every host test and simulation.
//!
//! Everything here is `no_std`, `f32`, and uses only IEEE-754 add, subtract, multiply,
//! divide and conversions, plus [`controller_core::math`] for trigonometry. Never call a
//! method such as `f32::sin` here: on the host it would resolve to `std` and compute other
//! bits than the target.
//!
//! ```
//! use m4f_scenario::{run_scenario, Scenario};
//!
//! let digest = run_scenario(&Scenario::paper_circle()).unwrap();
//! assert_eq!(digest.steps, Scenario::paper_circle().total_steps());
//! // The printed line parses back to the same digest (this is how xtask reads QEMU's).
//! let line = format!("{digest}");
//! assert_eq!(m4f_scenario::Digest::parse_line(&line), Some(digest));
//! ```

#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod digest;
pub mod plant;
pub mod scenario;

pub use digest::{canonical_bits, Digest, Fnv1a64};
pub use plant::{Plant, PlantConfig};
pub use scenario::{run_scenario, run_scenario_with, Scenario, Segment, SetupError, StepRecord};
