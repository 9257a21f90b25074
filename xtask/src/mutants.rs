//! `cargo xtask mutants`: mutation testing with cargo-mutants, and its score.
//!
//! Runs `cargo mutants --no-shuffle` on `controller-core` and, when the workspace has it,
//! the runtime-link protocol crate `link`, then prints the score, the missed mutants and
//! the wall time. Extra arguments go to cargo-mutants unchanged, so one file can be run
//! on its own: `cargo xtask mutants -f controller-core/src/pid.rs` (the glob is matched
//! against the path from the workspace root, or against the file name when it has no
//! `/`).
//!
//! - **Score** = caught / (caught + missed), in %.
//! - **Unviable** mutants (they do not compile) and **timeouts** (the tests did not end
//!   within cargo-mutants' limit, usually an endless loop) are counted but left out of the
//!   score: neither caught nor missed. Timeouts are listed so that someone looks at them.
//! - Mutants excluded by `.cargo/mutants.toml` (equivalent mutants, each with its reason
//!   there) are never generated, so they are out of the denominator; their number is
//!   printed.
//!
//! Not part of `cargo xtask ci`: every mutant is a build and a test run, so a run takes
//! many times longer than CI. cargo-mutants is never installed from here; when it is
//! missing the command says how to install it. Fails (exit status 1) when a mutant was
//! missed or timed out.

use std::path::Path;
use std::process::Command;
use std::time::Instant;

use anyhow::{bail, Context as _, Result};

use crate::steps::{display_command, Context};

/// Packages mutated, in order, when they are members of the workspace.
const PACKAGES: [&str; 2] = ["controller-core", "link"];
/// cargo-mutants writes `mutants.out` in here (relative to the workspace root), so the
/// results stay under the ignored `target/`.
const OUTPUT_PARENT: &str = "target";
/// How to get the tool, printed when it is missing.
const INSTALL: &str = "cargo install cargo-mutants --locked";

/// Runs cargo-mutants with `extra_args` passed through; true when no mutant was missed
/// and none timed out.
pub fn run(ctx: &Context, extra_args: &[String]) -> Result<bool> {
    if let Some(arg) = extra_args
        .iter()
        .find(|a| *a == "-o" || a.starts_with("--output"))
    {
        bail!("`{arg}`: the output directory is fixed ({OUTPUT_PARENT}/mutants.out)");
    }
    let version = cargo_mutants_version(ctx)?;
    let packages = workspace_packages(ctx)?;
    let mutated: Vec<&str> = PACKAGES
        .into_iter()
        .filter(|p| packages.iter().any(|q| q == p))
        .collect();
    if mutated.is_empty() {
        bail!("none of {PACKAGES:?} is a member of the workspace");
    }
    println!("==> {version} on {}", mutated.join(", "));
    for missing in PACKAGES.iter().filter(|p| !mutated.contains(p)) {
        println!("    ({missing}: not in the workspace, skipped)");
    }

    let mut base_args: Vec<String> = Vec::new();
    for package in &mutated {
        base_args.extend(["--package".into(), (*package).into()]);
    }
    base_args.extend_from_slice(extra_args);

    let excluded = count_excluded(ctx, &base_args)?;

    let started = Instant::now();
    let mut cmd = ctx.cargo(&["mutants", "--no-shuffle", "--output", OUTPUT_PARENT]);
    cmd.args(&base_args);
    println!("$ {}", display_command(&cmd));
    let status = cmd
        .status()
        .with_context(|| format!("could not start `{}`", display_command(&cmd)))?;
    let wall_s = started.elapsed().as_secs();
    // cargo-mutants' exit codes: 0 all caught, 2 some missed, 3 some timed out; anything
    // else (1 usage, 4 the unmutated tests fail, …) means there is no score to report.
    if !matches!(status.code(), Some(0 | 2 | 3)) {
        bail!("cargo-mutants failed ({status}); see its output above");
    }

    let out_dir = ctx.root.join(OUTPUT_PARENT).join("mutants.out");
    let tally = Tally::read(&out_dir)?;
    tally.print(excluded, wall_s, &out_dir);
    Ok(tally.missed.is_empty() && tally.timeouts.is_empty())
}

/// `cargo-mutants 27.1.0`, or an error naming the install command.
fn cargo_mutants_version(ctx: &Context) -> Result<String> {
    let output = ctx.cargo(&["mutants", "--version"]).output();
    match output {
        Ok(out) if out.status.success() => {
            Ok(String::from_utf8_lossy(&out.stdout).trim().to_string())
        }
        _ => bail!("cargo-mutants is not installed; install it with `{INSTALL}`"),
    }
}

/// Names of the workspace's member packages, from `cargo metadata`.
fn workspace_packages(ctx: &Context) -> Result<Vec<String>> {
    let mut cmd = ctx.cargo(&["metadata", "--no-deps", "--format-version", "1"]);
    let out = cmd
        .output()
        .with_context(|| format!("could not start `{}`", display_command(&cmd)))?;
    if !out.status.success() {
        bail!(
            "`{}` failed: {}",
            display_command(&cmd),
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let metadata: serde_json::Value =
        serde_json::from_slice(&out.stdout).context("cargo metadata printed no JSON")?;
    let names = metadata["packages"]
        .as_array()
        .context("cargo metadata has no `packages` list")?
        .iter()
        .filter_map(|p| p["name"].as_str().map(str::to_string))
        .collect();
    Ok(names)
}

/// How many mutants `.cargo/mutants.toml` leaves out: the length of the mutant list
/// without the config file minus its length with it.
fn count_excluded(ctx: &Context, args: &[String]) -> Result<usize> {
    let list = |extra: &[&str]| -> Result<usize> {
        let mut cmd: Command = ctx.cargo(&["mutants", "--list"]);
        cmd.args(extra).args(args);
        let out = cmd
            .output()
            .with_context(|| format!("could not start `{}`", display_command(&cmd)))?;
        if !out.status.success() {
            bail!(
                "`{}` failed: {}",
                display_command(&cmd),
                String::from_utf8_lossy(&out.stderr)
            );
        }
        Ok(String::from_utf8_lossy(&out.stdout)
            .lines()
            .filter(|l| !l.trim().is_empty())
            .count())
    };
    let all = list(&["--no-config"])?;
    let kept = list(&[])?;
    Ok(all.saturating_sub(kept))
}

/// The outcome of a run, from `mutants.out`.
struct Tally {
    caught: u64,
    unviable: u64,
    missed: Vec<String>,
    timeouts: Vec<String>,
}

impl Tally {
    /// Reads the counts from `outcomes.json` and the names from `missed.txt` and
    /// `timeout.txt`.
    fn read(out_dir: &Path) -> Result<Self> {
        let path = out_dir.join("outcomes.json");
        let text = std::fs::read_to_string(&path)
            .with_context(|| format!("could not read {}", path.display()))?;
        let outcomes: serde_json::Value = serde_json::from_str(&text)
            .with_context(|| format!("{} is not JSON", path.display()))?;
        let count = |key: &str| -> Result<u64> {
            outcomes[key]
                .as_u64()
                .with_context(|| format!("{} has no count `{key}`", path.display()))
        };
        let lines = |name: &str| -> Result<Vec<String>> {
            let path = out_dir.join(name);
            Ok(std::fs::read_to_string(&path)
                .with_context(|| format!("could not read {}", path.display()))?
                .lines()
                .filter(|l| !l.trim().is_empty())
                .map(str::to_string)
                .collect())
        };
        let tally = Tally {
            caught: count("caught")?,
            unviable: count("unviable")?,
            missed: lines("missed.txt")?,
            timeouts: lines("timeout.txt")?,
        };
        let (missed, timeouts) = (count("missed")?, count("timeout")?);
        if missed != tally.missed.len() as u64 || timeouts != tally.timeouts.len() as u64 {
            bail!(
                "{}: counts disagree with missed.txt / timeout.txt",
                out_dir.display()
            );
        }
        Ok(tally)
    }

    /// Prints the missed and timed-out mutants, the counts, the score and the wall time.
    fn print(&self, excluded: usize, wall_s: u64, out_dir: &Path) {
        println!("\n==> mutation score");
        println!("missed ({}):", self.missed.len());
        for name in &self.missed {
            println!("    {name}");
        }
        if !self.timeouts.is_empty() {
            println!("timed out ({}):", self.timeouts.len());
            for name in &self.timeouts {
                println!("    {name}");
            }
        }
        let missed = self.missed.len() as u64;
        let scored = self.caught + missed;
        let score = if scored == 0 {
            "n/a (no mutant was caught or missed)".to_string()
        } else {
            format!("{:.1} %", 100.0 * self.caught as f64 / scored as f64)
        };
        println!("caught   {}", self.caught);
        println!("missed   {missed}");
        println!("score    {score} = caught / (caught + missed)");
        println!(
            "unviable {} (do not compile; not in the score)",
            self.unviable
        );
        println!(
            "timeouts {} (neither caught nor missed; not in the score)",
            self.timeouts.len()
        );
        println!("excluded {excluded} (equivalent, listed in .cargo/mutants.toml; not generated)");
        println!("wall time {} min {:02} s", wall_s / 60, wall_s % 60);
        println!("details: {}", out_dir.display());
    }
}
