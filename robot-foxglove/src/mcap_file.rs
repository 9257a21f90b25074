//! A run's MCAP file: its path, every sample of its trace at the sample's own (simulated
//! or robot) time, the supervisor's events and the end of the run. One context per file,
//! so files written from several threads at once (the sweeps) never mix.

use std::fs::File;
use std::io::BufWriter;
use std::path::{Path as FilePath, PathBuf};

use controller_core::path::Path;
use foxglove::messages::log::Level;
use foxglove::Context;
use robot_files::trace::TraceRow;

use crate::channels::RobotChannels;
use crate::topics;

/// What a run's file is written from.
#[derive(Clone, Copy, Debug)]
pub struct RunRecord<'a> {
    /// The path the robot followed, world frame (`None` when not known: a recording of
    /// whatever the robot does).
    pub path: Option<&'a Path>,
    /// The run's samples in time order (`trace.csv`'s rows).
    pub trace: &'a [TraceRow],
    /// How the run ended, logged on `/events` after the last sample (e.g. `run ended:
    /// the run's time limit`); `None` logs nothing.
    pub end: Option<&'a str>,
}

/// What [`write_run_mcap`] wrote.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct McapWritten {
    /// The file.
    pub file: PathBuf,
    /// Channels in it.
    pub channels: usize,
    /// Samples logged (each several messages).
    pub samples: u64,
    /// Its size, bytes.
    pub bytes: u64,
}

/// Why a run's file could not be written.
#[derive(Debug, thiserror::Error)]
pub enum McapError {
    /// The file could not be created.
    #[error("creating {file}: {source}")]
    Create {
        /// The file.
        file: PathBuf,
        /// What failed.
        source: std::io::Error,
    },
    /// The SDK could not write or finish the file.
    #[error("writing {file}: {source}")]
    Write {
        /// The file.
        file: PathBuf,
        /// What failed.
        source: foxglove::FoxgloveError,
    },
}

/// Writes `run` to `file` (replacing it): the path (if known) at the first sample's time,
/// then every sample ([`RobotChannels::log_sample`]), then the end of the run at the last
/// sample's time. Uncompressed, so no compression library is built; `cargo xtask
/// foxglove-file` holds a 30 s run at 100 Hz to its size budget.
pub fn write_run_mcap(file: &FilePath, run: &RunRecord<'_>) -> Result<McapWritten, McapError> {
    let created = File::create(file).map_err(|source| McapError::Create {
        file: file.to_path_buf(),
        source,
    })?;
    let write_error = |source| McapError::Write {
        file: file.to_path_buf(),
        source,
    };
    let context = Context::new();
    let options = foxglove::McapWriteOptions::default().compression(None);
    let writer = context
        .mcap_writer_with_options(options)
        .create(BufWriter::new(created))
        .map_err(write_error)?;
    let mut channels = RobotChannels::new(&context);
    let start_s = run.trace.first().map_or(0.0, |r| r.t_s);
    let end_s = run.trace.last().map_or(0.0, |r| r.t_s);
    if let Some(path) = run.path {
        channels.log_path(path, start_s);
    }
    for row in run.trace {
        channels.log_sample(row);
    }
    if let Some(end) = run.end {
        channels.log_event(end_s, Level::Info, end);
    }
    let samples = channels.samples();
    writer.close().map_err(write_error)?;
    let bytes = std::fs::metadata(file).map_or(0, |m| m.len());
    Ok(McapWritten {
        file: file.to_path_buf(),
        channels: topics::ALL.len(),
        samples,
        bytes,
    })
}
