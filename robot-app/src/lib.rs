//! # robot-app
//!
//! (crate doc written below)

#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
#![deny(unsafe_code)]

pub mod channel;
pub mod control;
pub mod hw;
pub mod metrics;
pub mod panic_record;
pub mod persist;
pub mod service;
mod start;

pub use crate::channel::{Channels, ControlEnd, LinkEnd};
pub use crate::control::{Actuation, ControlSide, Sensors};
pub use crate::service::{BoardStats, Identity, LinkOptions, LinkService, NoBoardStats};
pub use crate::start::{start, AppConfig, StartError};
