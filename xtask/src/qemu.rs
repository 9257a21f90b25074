//! The core on an emulated Cortex-M4F: builds `cortex-m4f/qemu-m4f`, runs it under
//! `qemu-system-arm` (netduinoplus2, semihosting, `-icount shift=0`), and checks that
//!
//! - its trajectory digest equals the one the host computes for the same scenario
//!   ([`m4f_scenario::run_scenario`], called right here), bit for bit,
//!
//! and prints what a full control step (steering law included) and a wheel step cost,
//! in instructions: reported, not capped. The robot's budget is the control interrupt's
//! CPU load, which processor in the loop measures (`crate::pil`).
//!
//! Instruction counts are exact and repeatable: with `-icount shift=0` QEMU advances its
//! virtual clock by 1 ns per executed instruction, so SysTick (clocked from the processor
//! clock) counts instructions, whatever the host machine is doing. Without `-icount` the
//! counts would follow wall-clock time and vary 2–5×.

use std::io::Read;
use std::path::Path;
use std::process::{Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use anyhow::{bail, ensure, Context as _, Result};
use m4f_scenario::{run_scenario, Digest, Scenario};

use crate::steps::{build_target_executables, display_command, Context};

/// The whole QEMU run takes well under a second; this only catches a hung guest.
const TIMEOUT: Duration = Duration::from_secs(120);

/// What the QEMU program printed that xtask checks.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Report {
    /// The trajectory digest.
    pub digest: Digest,
    /// Instructions per full control step.
    pub control_step: u64,
    /// Instructions per wheel-only step.
    pub wheel_step: u64,
}

impl Report {
    /// Finds the digest line and the two instruction-count lines in `output`.
    pub fn parse(output: &str) -> Result<Self> {
        let digest = output
            .lines()
            .find_map(Digest::parse_line)
            .context("no `digest …` line in QEMU's output")?;
        Ok(Self {
            digest,
            control_step: instructions(output, "control step")?,
            wheel_step: instructions(output, "wheel step")?,
        })
    }
}

/// The N of the line `<what> on Cortex-M4F: N instructions`.
fn instructions(output: &str, what: &str) -> Result<u64> {
    let prefix = format!("{what} on Cortex-M4F:");
    let line = output
        .lines()
        .map(str::trim)
        .find(|l| l.starts_with(&prefix))
        .with_context(|| format!("no `{prefix} N instructions` line in QEMU's output"))?;
    let count = line[prefix.len()..]
        .trim()
        .strip_suffix("instructions")
        .map(str::trim)
        .with_context(|| format!("cannot read the count in {line:?}"))?;
    count
        .parse()
        .with_context(|| format!("cannot read the count in {line:?}"))
}

/// The CI step (see the module doc).
pub fn check(ctx: &Context) -> Result<()> {
    let executables = build_target_executables(ctx, "qemu-m4f", &[])?;
    let elf = executables
        .first()
        .context("building qemu-m4f produced no executable")?;
    let output = run_qemu(elf)?;
    let report = Report::parse(&output)?;

    let host =
        run_scenario(&Scenario::paper_circle()).context("setting up the scenario on the host")?;
    println!("host:   {host}");
    println!("target: {}", report.digest);
    let mut problems = Vec::new();
    if report.digest == host {
        println!("digest: host and Cortex-M4F are bit-identical");
    } else {
        problems.push(format!(
            "the Cortex-M4F digest differs from the host's: {}",
            describe_difference(&host, &report.digest)
        ));
    }
    println!(
        "core on Cortex-M4F (QEMU): full control step {} instructions, wheel step {} \
         (reported, not capped)",
        report.control_step, report.wheel_step
    );
    if !problems.is_empty() {
        bail!("{}", problems.join("; "));
    }
    Ok(())
}

/// Names what differs between two digests.
fn describe_difference(host: &Digest, target: &Digest) -> String {
    let mut parts = Vec::new();
    if host.steps != target.steps {
        parts.push(format!("steps {} vs {}", host.steps, target.steps));
    }
    if host.hash != target.hash {
        parts.push("trajectory hash".to_owned());
    }
    if host.pose_bits != target.pose_bits {
        parts.push(format!(
            "final odometry pose {:?} vs {:?}",
            host.pose(),
            target.pose()
        ));
    }
    if host.true_pose_bits != target.true_pose_bits {
        parts.push(format!(
            "final true pose {:?} vs {:?}",
            host.true_pose(),
            target.true_pose()
        ));
    }
    parts.join(", ")
}

/// Runs `elf` under QEMU, echoes its output (indented) and returns its stdout. Fails on a
/// non-zero exit status (the program exits 1 on panic or hard fault) or a timeout.
pub fn run_qemu(elf: &Path) -> Result<String> {
    let mut cmd = Command::new("qemu-system-arm");
    cmd.args([
        "-cpu",
        "cortex-m4",
        "-machine",
        "netduinoplus2",
        "-nographic",
        "-monitor",
        "none",
        "-serial",
        "none",
        "-semihosting-config",
        "enable=on,target=native",
        "-icount",
        "shift=0",
        "-kernel",
    ])
    .arg(elf)
    .stdin(Stdio::null())
    .stdout(Stdio::piped())
    .stderr(Stdio::piped());
    let shown = display_command(&cmd);
    println!("$ {shown}");
    let mut child = cmd
        .spawn()
        .with_context(|| format!("could not start `{shown}` (is qemu-system-arm installed?)"))?;
    let readers = [
        drain(child.stdout.take().context("no stdout pipe")?),
        drain(child.stderr.take().context("no stderr pipe")?),
    ];

    let started = Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().context("waiting for QEMU")? {
            break status;
        }
        if started.elapsed() > TIMEOUT {
            // Our own child, by handle: nothing else is touched.
            let _ = child.kill();
            let _ = child.wait();
            bail!(
                "QEMU did not finish within {} s (guest hung?)",
                TIMEOUT.as_secs()
            );
        }
        thread::sleep(Duration::from_millis(20));
    };
    let [stdout, stderr] = readers.map(|r| r.join().unwrap_or_default());
    for line in stdout.lines().chain(stderr.lines()) {
        println!("    | {line}");
    }
    ensure!(status.success(), "QEMU exited with {status}");
    Ok(stdout)
}

/// Reads a pipe to its end on a thread, so that a chatty child never blocks.
fn drain(mut pipe: impl Read + Send + 'static) -> thread::JoinHandle<String> {
    thread::spawn(move || {
        let mut bytes = Vec::new();
        let _ = pipe.read_to_end(&mut bytes);
        String::from_utf8_lossy(&bytes).into_owned()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const OUTPUT: &str = "\
digest steps=20000 hash=db7fcf5b7c379afd pose=be504ba2,3f9ddd7f,c03ea51d true_pose=be50b308,3f9dd9c0,c03e96cc
final pose: odometry (-0.20341352, 1.233322, -2.9788277), true (-0.20380795, 1.2332077, -2.977954)
SysTick ticks per instruction: 0.168000
control step on Cortex-M4F: 412 instructions
  (412.4 per step, mean over 10000 steps)
wheel step on Cortex-M4F: 181 instructions
  (180.9 per step, mean over 10000 steps)
";

    #[test]
    fn parses_the_programs_report() {
        let report = Report::parse(OUTPUT).unwrap();
        assert_eq!(report.control_step, 412);
        assert_eq!(report.wheel_step, 181);
        assert_eq!(report.digest.steps, 20_000);
        assert_eq!(report.digest.hash, 0xdb7f_cf5b_7c37_9afd);
    }

    #[test]
    fn missing_lines_are_errors() {
        assert!(Report::parse("").is_err());
        let no_wheel: String = OUTPUT
            .lines()
            .filter(|l| !l.starts_with("wheel"))
            .map(|l| format!("{l}\n"))
            .collect();
        assert!(Report::parse(&no_wheel).is_err());
        assert!(Report::parse(&OUTPUT.replace("412 instructions", "many instructions")).is_err());
    }

    #[test]
    fn differences_are_named() {
        let a = run_scenario(&Scenario::paper_circle()).unwrap();
        let mut b = a;
        b.hash ^= 1;
        b.true_pose_bits[0] ^= 1;
        let text = describe_difference(&a, &b);
        assert!(text.contains("trajectory hash") && text.contains("final true pose"));
        assert!(!text.contains("odometry"));
    }
}
