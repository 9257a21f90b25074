//! # robot-files
//!
//! What the simulator (`host-sim`) and the ground station (`station`) both read and
//! write: the user's robot files and scenarios, and a run's trace, summary and figures.
//! It holds formats, their validation and the arithmetic of the metrics, no simulation:
//! the station builds it without the simulator.
//!
//! | module | what it is |
//! |---|---|
//! | [`robot_file`] | the `[robot]` and `[supervisor]` TOML sections: a robot file, and the same sections in a scenario |
//! | [`scenario`] | TOML scenarios in SI units, validated with errors that name the key; five built in |
//! | [`plant`] | the simulated robot's parameter types a scenario's `[plant]` names: bridge chip and supply, motor, body, load, wheels |
//! | [`faults`] | the fault timeline a scenario's `[[faults]]` array injects |
//! | [`truth`] | the true pose and the true error against the scenario's own reference |
//! | [`trace`] | `trace.csv`: one row per sample of a run |
//! | [`metrics`] | `summary.json`: what a run amounted to |
//! | [`output`] | writing a run's trace and summary; the settle time as text |
//! | [`figures`] | Figs. 5–7 and the comparison as SVG (feature `figures`, on by default) |
//! | [`rng`] | the deterministic random number generator of every simulated draw |
//! | [`toml_text`] | reading TOML text: how deeply it may nest, with the line of what is too deep |
//! | [`cli`] | command-line values both programs take |

#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod cli;
pub mod faults;
#[cfg(feature = "figures")]
pub mod figures;
pub mod metrics;
pub mod output;
pub mod plant;
pub mod rng;
pub mod robot_file;
pub mod scenario;
pub mod toml_text;
pub mod trace;
pub mod truth;
