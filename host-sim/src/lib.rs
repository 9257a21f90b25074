//! # host-sim
//!
//! The `controller-core` stack against a simulated two-wheel differential-drive robot:
//! where gains are tuned before flashing, where Jin & Tack (2011)'s experiments are
//! reproduced, and where CI proves the loop closes.
//!
//! - [`plant`] — per wheel an H-bridge in slow decay (PWM duty × supply, quantised as the
//!   firmware writes it; duty 0 brakes, a disabled driver or a disconnected motor coasts)
//!   and a DC motor (armature and bridge resistance, K_t, K_e, gearbox efficiency by
//!   power-flow direction, inertia reflected through the gearbox, viscous and Coulomb
//!   friction), coupled through the chassis' mass, yaw inertia and centre of mass with
//!   static friction that sees the coupling, integrated exactly over each control period
//!   while it stays in one regime and with RK4 at ≥ 10 × the control rate otherwise;
//!   wheel slip; fault hooks (disconnected motor, jammed wheel, slip patch, supply
//!   sag); the true pose.
//! - [`encoder`] — quadrature quantisation (lines × 4 × gear) with optional edge jitter.
//! - [`hardware`] — the simulated robot as the firmware sees it: encoder ticks, the supply
//!   measurement and the button in, duties and the bridge state (drive, brake, coast) out,
//!   with the scenario's faults injected on a timeline.
//! - [`run`] — the loop that runs the firmware's decision path, the supervisor around the
//!   controller, against that hardware, and the metrics of the result.
//! - [`fault_suite`] — every kind of fault, one at a time, against its detector's limit.
//! - [`pil`] — processor in the loop: the firmware itself, on an emulated Cortex-M4F
//!   (QEMU), against this plant in lockstep, driven by a ground station over its link.
//! - [`margins`] — the wheel loop's gain and phase margins, from its linearised model and
//!   measured by a frequency sweep on the simulated robot.
//! - [`output`] — a run's files (trace, summary, Figs. 5–7) and its human summary.
//! - [`mcap`] — a run as an MCAP file for Foxglove (the `robot_foxglove` crate's channels).
//! - [`plot`] — SVG figures of the wheel loop's step response.
//! - [`sweep`] — Monte-Carlo over mismatch, noise and start pose, on every core.
//! - [`robustness`] — the wheel loop with fixed gains against supplies from 4.8 to 12.6 V
//!   and motors ±30 % off.
//! - [`tune`] — the core's wheel-loop tune on the simulated robot, its identification
//!   against the linearised plant and the tuned loop's step response.
//! - [`serve`] — the virtual robot: robot-app's control and link sides against the
//!   simulated hardware, speaking the runtime link over TCP, with ground truth.
//!
//! - [`commands`] — the `host-sim` commands, one module each: what each computes and
//!   writes, the report it prints, and the rules by which it fails.
//!
//! What it reads and writes — scenarios and robot files, the fault timeline, the plant's
//! parameter types, a run's trace, metrics and Figs. 5–7 — is the `robot_files` crate's,
//! shared with the ground station.
//!
//! ```no_run
//! use controller_core::law::LawKind;
//! use host_sim::run_scenario;
//! use robot_files::scenario::Scenario;
//!
//! let scenario = Scenario::load("paper-circle")?;
//! let result = run_scenario(&scenario, LawKind::Tracking)?;
//! println!("settled at {:?} s", result.summary.headline_error().settle_time_s);
//! # Ok::<(), Box<dyn std::error::Error>>(())
//! ```

#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod commands;
pub mod encoder;
pub mod fault_matrix;
pub mod fault_suite;
pub mod gyro;
pub mod hardware;
pub mod margins;
pub mod mcap;
pub mod output;
pub mod pil;
pub mod plant;
pub mod plot;
pub mod robustness;
pub mod run;
pub mod serve;
pub mod sweep;
pub mod tune;
pub mod velocity_check;

pub use run::{run_scenario, run_scenario_with, RunError, RunOptions, RunResult};
