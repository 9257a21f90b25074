//! `cargo xtask fuzz [SECONDS]`: every fuzz target of `fuzz/` (cargo-fuzz, libFuzzer, on
//! nightly) for `SECONDS` each, one after the other, and a table of what each run did.
//! Not part of `ci`: CI replays the committed corpus on stable (`fuzz-checks`' tests).
//!
//! For each target, libFuzzer starts from three corpus directories and writes what it
//! finds into the first only:
//!
//! | directory | what it holds |
//! |---|---|
//! | `target/fuzz/corpus/<target>/` | this machine's working corpus, kept from run to run |
//! | `fuzz/corpus/<target>/` | the committed, minimised corpus (read only here) |
//! | `target/fuzz/seeds/<target>/` | seeds built from the project's messages, record, scenarios and robot files, written before each run (`fuzz_checks::seeds`) |
//!
//! A crash, a failed property or an input slower than [`UNIT_TIMEOUT_S`] fails the
//! target; libFuzzer writes the input to `fuzz/artifacts/<target>/` and the table names
//! it. The targets are built with debug assertions (integer overflow panics) and
//! AddressSanitizer, cargo-fuzz's default. Sets itself up ([`setup::ensure_fuzzing`]).
//! On a shared machine run it under `nice`.
//!
//! To fold what the runs found into the committed corpus, keeping it small, merge the
//! working corpus into an empty directory and commit what is left of it
//! (`cargo +nightly fuzz run TARGET NEW -- -merge=1 target/fuzz/corpus/TARGET
//! fuzz/corpus/TARGET`, or `cargo +nightly fuzz cmin TARGET DIR` on a copy).

use std::io::{BufRead as _, BufReader};
use std::path::{Path, PathBuf};
use std::process::Stdio;
use std::time::Instant;

use anyhow::{bail, Context as _, Result};

use crate::setup;
use crate::steps::{display_command, run_command, Context};

/// Seconds each target runs when no time is given.
pub const DEFAULT_SECONDS: u32 = 60;

/// An input that takes longer than this is a failure (a hang), s.
pub const UNIT_TIMEOUT_S: u32 = 10;

/// What one target's run did.
struct Figures {
    target: String,
    seconds: f64,
    executions: Option<u64>,
    /// libFuzzer's final `cov:` (code edges reached) and `ft:` (features).
    coverage: Option<(u64, u64)>,
    /// libFuzzer's final `corp:` units and their size.
    corpus: Option<String>,
    /// Why it failed, and where the input went.
    failure: Option<String>,
}

/// Runs every target for `seconds` each; fails when one failed (all run regardless).
pub fn run(ctx: &Context, seconds: u32) -> Result<()> {
    setup::ensure_fuzzing(ctx)?;
    let targets = targets(ctx)?;
    let seeds = ctx.root.join("target/fuzz/seeds");
    run_command(&mut ctx.cargo(&[
        "run",
        "--quiet",
        "--package",
        "fuzz-checks",
        "--example",
        "write_seeds",
        "--",
        &seeds.to_string_lossy(),
    ]))?;
    let mut figures = Vec::new();
    for target in &targets {
        println!("\nfuzz: {target}, {seconds} s");
        figures.push(run_target(ctx, target, seconds, &seeds)?);
    }
    print_table(&figures);
    let failed: Vec<&str> = figures
        .iter()
        .filter(|f| f.failure.is_some())
        .map(|f| f.target.as_str())
        .collect();
    if !failed.is_empty() {
        bail!("fuzz targets failed: {}", failed.join(", "));
    }
    Ok(())
}

/// The targets `fuzz/Cargo.toml` declares (`cargo fuzz list`).
fn targets(ctx: &Context) -> Result<Vec<String>> {
    let mut cmd = setup::nightly_cargo(ctx, &["fuzz", "list"]);
    let shown = display_command(&cmd);
    let output = cmd
        .stderr(Stdio::inherit())
        .output()
        .with_context(|| format!("could not start `{shown}`"))?;
    if !output.status.success() {
        bail!("`{shown}` failed ({})", output.status);
    }
    let targets: Vec<String> = String::from_utf8_lossy(&output.stdout)
        .lines()
        .map(str::trim)
        .filter(|line| !line.is_empty())
        .map(str::to_string)
        .collect();
    if targets.is_empty() {
        bail!("`{shown}` lists no fuzz target");
    }
    Ok(targets)
}

/// Runs `target` for `seconds` and reads its figures from libFuzzer's output (echoed,
/// without the line libFuzzer prints for each new input).
fn run_target(ctx: &Context, target: &str, seconds: u32, seeds: &Path) -> Result<Figures> {
    let working = ctx.root.join("target/fuzz/corpus").join(target);
    std::fs::create_dir_all(&working)
        .with_context(|| format!("cannot create {}", working.display()))?;
    let dirs: [PathBuf; 3] = [
        working,
        ctx.root.join("fuzz/corpus").join(target),
        seeds.join(target),
    ];
    let dirs: Vec<String> = dirs
        .iter()
        .map(|d| d.to_string_lossy().into_owned())
        .collect();
    let max_time = format!("-max_total_time={seconds}");
    let timeout = format!("-timeout={UNIT_TIMEOUT_S}");
    let mut args = vec!["fuzz", "run", "--debug-assertions", target];
    args.extend(dirs.iter().map(String::as_str));
    args.extend(["--", &max_time, &timeout, "-print_final_stats=1"]);
    let mut cmd = setup::nightly_cargo(ctx, &args);
    let shown = display_command(&cmd);
    println!("$ {shown}");
    let started = Instant::now();
    let mut child = cmd
        .stdout(Stdio::inherit())
        .stderr(Stdio::piped())
        .spawn()
        .with_context(|| format!("could not start `{shown}`"))?;
    let mut figures = Figures {
        target: target.to_string(),
        seconds: 0.0,
        executions: None,
        coverage: None,
        corpus: None,
        failure: None,
    };
    let mut artifact = None;
    if let Some(stderr) = child.stderr.take() {
        for line in BufReader::new(stderr).lines() {
            let line = line.context("reading libFuzzer's output")?;
            read_line(&line, &mut figures, &mut artifact);
            if !is_new_input_line(&line) {
                eprintln!("{line}");
            }
        }
    }
    let status = child.wait().context("waiting for cargo fuzz")?;
    figures.seconds = started.elapsed().as_secs_f64();
    if !status.success() {
        figures.failure = Some(match artifact {
            Some(path) => format!("{status}; input in {path}"),
            None => format!("{status}"),
        });
    }
    Ok(figures)
}

/// Takes what a line of libFuzzer's output says about the run.
fn read_line(line: &str, figures: &mut Figures, artifact: &mut Option<String>) {
    if let Some(path) = line.split("Test unit written to ").nth(1) {
        *artifact = Some(path.trim().to_string());
    }
    if let Some(value) = line.strip_prefix("stat::number_of_executed_units:") {
        figures.executions = value.trim().parse().ok();
    }
    // `#123456	DONE   cov: 1909 ft: 4523 corp: 216/36Kb lim: 697 exec/s: …`
    if line.contains(" DONE ") || line.contains("\tDONE ") {
        let field = |name: &str| {
            let mut words = line.split_whitespace();
            words.find(|w| *w == name)?;
            words.next().map(str::to_string)
        };
        let number = |name: &str| field(name).and_then(|v| v.parse::<u64>().ok());
        if let (Some(cov), Some(ft)) = (number("cov:"), number("ft:")) {
            figures.coverage = Some((cov, ft));
        }
        figures.corpus = field("corp:");
    }
}

/// libFuzzer's line for each input it keeps or shortens (`#N NEW …`, `#N REDUCE …`):
/// thousands in a long run.
fn is_new_input_line(line: &str) -> bool {
    let mut words = line.split_whitespace();
    words.next().is_some_and(|w| w.starts_with('#'))
        && words.next().is_some_and(|w| matches!(w, "NEW" | "REDUCE"))
}

fn print_table(figures: &[Figures]) {
    println!("\nfuzz: the runs");
    println!(
        "    {:<14} {:>7} {:>12} {:>9} {:>7} {:>7} {:>14}  result",
        "target", "time s", "executions", "exec/s", "cov", "ft", "corpus"
    );
    for f in figures {
        let executions = f.executions.map_or("?".to_string(), |e| e.to_string());
        let rate = f
            .executions
            .map_or("?".to_string(), |e| format!("{:.0}", e as f64 / f.seconds));
        let (cov, ft) = f
            .coverage
            .map_or(("?".to_string(), "?".to_string()), |(c, t)| {
                (c.to_string(), t.to_string())
            });
        let corpus = f.corpus.clone().unwrap_or_else(|| "?".to_string());
        let result = f.failure.as_deref().unwrap_or("ok");
        println!(
            "    {:<14} {:>7.0} {:>12} {:>9} {:>7} {:>7} {:>14}  {result}",
            f.target, f.seconds, executions, rate, cov, ft, corpus
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn empty() -> Figures {
        Figures {
            target: "t".to_string(),
            seconds: 0.0,
            executions: None,
            coverage: None,
            corpus: None,
            failure: None,
        }
    }

    #[test]
    fn the_figures_come_from_libfuzzers_closing_lines() {
        let mut figures = empty();
        let mut artifact = None;
        for line in [
            "#206214\tDONE   cov: 1909 ft: 4523 corp: 216/36Kb lim: 697 exec/s: 9819 rss: 448Mb",
            "stat::number_of_executed_units: 206214",
            "artifact_prefix='/x/'; Test unit written to /x/crash-da39a3ee",
        ] {
            read_line(line, &mut figures, &mut artifact);
        }
        assert_eq!(figures.executions, Some(206_214));
        assert_eq!(figures.coverage, Some((1909, 4523)));
        assert_eq!(figures.corpus.as_deref(), Some("216/36Kb"));
        assert_eq!(artifact.as_deref(), Some("/x/crash-da39a3ee"));
    }

    #[test]
    fn only_the_per_input_lines_are_left_out() {
        assert!(is_new_input_line(
            "#1024\tNEW    cov: 100 ft: 200 corp: 10/1Kb lim: 4 exec/s: 0 rss: 40Mb L: 3/3 MS: 1"
        ));
        assert!(is_new_input_line("#2048\tREDUCE cov: 100 ft: 200"));
        assert!(!is_new_input_line("#4096\tpulse  cov: 100 ft: 200"));
        assert!(!is_new_input_line("#206214\tDONE   cov: 1909"));
        assert!(!is_new_input_line("==42== ERROR: libFuzzer: deadly signal"));
    }
}
