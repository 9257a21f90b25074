//! # station
//!
//! The ground station: one command-line tool for the robot (over a serial port) and for
//! its virtual twin (`host-sim serve`, over TCP), speaking the runtime link of the `link`
//! crate.
//!
//! | module | what it is |
//! |---|---|
//! | [`transport`] | serial port or TCP, behind one trait |
//! | [`client`] | requests and replies: numbering, re-sending, matching by `seq`, errors |
//! | [`ops`] | one function per request: info, parameters (the robot-file code of `robot_files`), path upload, arming |
//! | [`record`] | a scenario run: heartbeats paced by the robot's step counter, trace rows, the robot's run report as the simulator's summary |
//! | [`watch`] | the live terminal view of the telemetry |
//! | [`teleop`] | `station drive`'s keys and the velocity command they set |
//! | [`foxglove`] | the live telemetry streamed to Foxglove, the parameters as its parameter set |
//! | [`calibrate`] | UMBmark odometry calibration: the squares, the fit for filleted corners, the corrected geometry |
//! | [`ros2`] | `station ros2`: the robot as a ROS 2 node on RustDDS (topics, parameters, paths, diagnostics) |
//!
//! A run recorded through the station is written with the simulator's own output code,
//! `robot_files` (`trace.csv`, `summary.json`, and Figs. 5–7 with the `figures` feature,
//! the default), so a robot's run and a simulated one read the same; the station does not
//! build the simulator itself. A real robot knows only its estimate: its summary has `estimated_error` and no
//! `true_error`. The virtual robot also sends its ground truth, and its summary then has
//! both. Per-step metrics (settle time, RMS) come from the robot, computed at the control
//! rate ([`link::RunReport`]), never from decimated telemetry.
//!
//! # Exit status
//!
//! `station` exits with
//!
//! - **0** when the command did what it was asked;
//! - **1** on any other error (no robot, a refused request, a bad file…);
//! - **2** for a bad command line (clap's);
//! - **3** ([`EXIT_NOT_AS_ASKED`]) when a run did not end as asked, with a line saying
//!   what ended it: `run` and `calibrate`'s runs that did not end at their time limit (the
//!   robot's heartbeat timeout, a fault, the button, a link failure, Ctrl-C), a
//!   `record --duration-s` cut short before its duration, a `tune` that did not finish.
//!   What was recorded is written all the same, and a run's `summary.json` says
//!   `"complete": false` and what ended it (`ended_by`, `end_reason`).

#![deny(missing_docs)]
#![forbid(unsafe_code)]

pub mod bringup;
pub mod calibrate;
pub mod client;
pub mod foxglove;
pub mod ops;
pub mod record;
pub mod ros2;
pub mod teleop;
#[cfg(test)]
pub(crate) mod test_frames;
pub mod transport;
pub mod watch;

pub use client::{Client, StationError};

/// `error` and its sources, `: `-separated, each cause once ([`causes_text`]).
pub fn error_text(error: &(dyn std::error::Error + 'static)) -> String {
    causes_text(std::iter::successors(Some(error), |e| e.source()))
}

/// The texts of `causes` (an error, then its source, then the source's source…),
/// `: `-separated. A cause whose text already ends the text so far is left out: an error
/// of another crate that prints its source in its own message and also returns it as
/// its `source()` is said once.
pub fn causes_text<'a>(
    causes: impl IntoIterator<Item = &'a (dyn std::error::Error + 'static)>,
) -> String {
    let mut text = String::new();
    for cause in causes {
        let part = cause.to_string();
        if text.is_empty() {
            text = part;
        } else if !text.ends_with(&part) {
            text.push_str(": ");
            text.push_str(&part);
        }
    }
    text
}

/// The exit status of a command whose run did not end as asked (crate doc).
pub const EXIT_NOT_AS_ASKED: u8 = 3;

/// A run, recording or tune that did not end as asked: the sentence says what ended it.
/// `station` exits with [`EXIT_NOT_AS_ASKED`] on it.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct NotAsAsked(pub String);

#[cfg(test)]
mod tests {
    use std::error::Error;
    use std::io;

    use super::*;

    fn closed() -> io::Error {
        io::Error::new(
            io::ErrorKind::ConnectionAborted,
            "the robot closed the connection",
        )
    }

    #[test]
    fn no_error_of_the_station_prints_its_source_in_its_own_message() {
        let errors: Vec<Box<dyn Error>> = vec![
            Box::new(StationError::Io(closed())),
            Box::new(transport::ConnectError::Connect {
                address: "127.0.0.1:5760".to_string(),
                source: closed(),
            }),
            Box::new(ops::ParamsError::Link(StationError::Io(closed()))),
        ];
        for error in errors {
            let own = error.to_string();
            let source = error.source().map(ToString::to_string);
            assert!(
                source.is_some_and(|s| !own.contains(&s)),
                "{own} / {:?}",
                error.source()
            );
            let text = error_text(error.as_ref());
            assert_eq!(text.matches("the robot closed").count(), 1, "{text}");
        }
    }

    #[test]
    fn a_cause_an_error_already_prints_is_said_once() {
        // robot-files' errors print their source and return it.
        let error = robot_files::output::OutputError::Write {
            file: "out/trace.csv".into(),
            source: closed(),
        };
        assert_eq!(
            error_text(&error),
            "writing out/trace.csv: the robot closed the connection"
        );
        assert_eq!(
            error_text(&StationError::Io(closed())),
            "link to the robot failed: the robot closed the connection"
        );
    }
}
