//! The robot in Foxglove: every run as an MCAP file, and the live robot over Foxglove's
//! WebSocket protocol, on the same channels and message types, so one layout
//! (`docs/foxglove-layout.json`) opens a file or the live robot. host-sim and the station
//! both use this crate; the firmware never does.
//!
//! | module | what it holds |
//! |---|---|
//! | [`topics`] | the channels' topics and the coordinate frames |
//! | [`messages`] | the telemetry's own message types (`derive(foxglove::Encode)`) |
//! | [`convert`] | a trace row as each channel's message; poses as `PoseInFrame`s and `FrameTransform`s |
//! | [`path_line`] | the path as a `SceneUpdate` line, arcs tessellated |
//! | [`channels`] | the channels on one context, and what a sample logs on each |
//! | [`mcap_file`] | a run's file |
//! | `live` | the WebSocket server and the parameter set (feature `live`) |
//!
//! Log times are the run's own clock (simulated time, or the robot's step count over
//! its control rate), never the wall clock, so a file of a run replays as it ran.

pub mod channels;
pub mod convert;
#[cfg(feature = "live")]
pub mod live;
pub mod mcap_file;
pub mod messages;
pub mod path_line;
pub mod topics;

pub use channels::RobotChannels;
pub use mcap_file::{write_run_mcap, McapError, McapWritten, RunRecord};
