//! The files of a run a program writes: `trace.csv` ([`crate::trace`]) and `summary.json`
//! ([`crate::metrics::Summary`]); the figures are [`crate::figures`]'. And the settle time
//! as a person reads it.

use std::fs;
use std::path::{Path as FsPath, PathBuf};

use crate::metrics::Summary;
use crate::trace::{trace_csv, TraceRow};

/// Why a run's files could not be written.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The output directory could not be created.
    #[error("creating {}: {source}", dir.display())]
    CreateDir {
        /// The directory.
        dir: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// A file could not be written.
    #[error("writing {}: {source}", file.display())]
    Write {
        /// The file.
        file: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The summary could not be turned into JSON.
    #[error("serialising the summary: {0}")]
    Summary(#[from] serde_json::Error),
}

/// Writes `trace` as `trace.csv` and `summary` as `summary.json` (pretty-printed, one
/// trailing newline) into `dir`, created if needed. Returns the files written.
pub fn write_trace_and_summary(
    dir: &FsPath,
    summary: &Summary,
    trace: &[TraceRow],
) -> Result<Vec<PathBuf>, OutputError> {
    fs::create_dir_all(dir).map_err(|source| OutputError::CreateDir {
        dir: dir.to_path_buf(),
        source,
    })?;
    let trace_file = dir.join("trace.csv");
    write(&trace_file, trace_csv(trace))?;
    let summary_file = dir.join("summary.json");
    write(&summary_file, serde_json::to_string_pretty(summary)? + "\n")?;
    Ok(vec![trace_file, summary_file])
}

/// Writes `text` to `file`.
fn write(file: &FsPath, text: String) -> Result<(), OutputError> {
    fs::write(file, text).map_err(|source| OutputError::Write {
        file: file.to_path_buf(),
        source,
    })
}

/// A settle time (s) as "x.xx s", `None` as "not settled".
pub fn settle_text(settle: Option<f64>) -> String {
    match settle {
        Some(t) => format!("{t:.2} s"),
        None => "not settled".to_string(),
    }
}
