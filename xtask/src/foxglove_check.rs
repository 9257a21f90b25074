//! The Foxglove output read by code nobody in this project wrote.
//!
//! - [`check_file`]: `host-sim run paper-circle --mcap` and `station run paper-circle
//!   --mcap` against `host-sim serve` (10× real time); PyPI's `mcap` and
//!   `mcap-protobuf-support` (in a venv, `crate::python_venv`) find every channel and
//!   schema, decode every message, and find the poses equal to each run's `trace.csv`
//!   (`tools/foxglove-check/mcap_check.py`, which prints `mcap: N channels, M messages,
//!   poses equal trace.csv`). The 30 s run at 100 Hz must be at most 10 MB.
//! - [`check_live`]: npm's `@foxglove/ws-protocol` 0.8 on a `ws` socket (installed into
//!   `target/foxglove-live`) subscribes to `host-sim serve --foxglove` while a station
//!   runs paper-circle on it, and must receive every channel
//!   (`tools/foxglove-check/live_check.js`, which prints `foxglove live: N channels, M
//!   messages in S s`, the rates and the arrival delays).
//!
//! Every server listens on 127.0.0.1 on a port the system chose, and is stopped when the
//! check ends, whatever happened.

use std::io::Read as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use anyhow::{bail, ensure, Context as _, Result};

use crate::pil::target_dir;
use crate::protocol_client::start_server;
use crate::steps::{display_command, Context};

/// The Python reader, relative to the workspace root.
const MCAP_CHECK: &str = "tools/foxglove-check/mcap_check.py";
/// The live client, relative to the workspace root.
const LIVE_CHECK: &str = "tools/foxglove-check/live_check.js";
/// PyPI's MCAP reader and its protobuf decoder, pinned.
const PYTHON_REQUIREMENTS: [&str; 2] = ["mcap==1.6.0", "mcap-protobuf-support==0.6.0"];
/// npm's Foxglove client and the socket it is handed, pinned.
const NPM_PACKAGES: &str =
    r#"{"private": true, "dependencies": {"@foxglove/ws-protocol": "0.8.0", "ws": "8.23.1"}}"#;
/// Most a 30 s run at 100 Hz may take, bytes.
const FILE_BUDGET_BYTES: u64 = 10_000_000;
/// The virtual robot's speed in these checks: simulated time per wall-clock time.
const SPEED: &str = "10";
/// How long the live client may wait for every channel and the run's end, s.
const LIVE_TIMEOUT_S: &str = "60";

/// A fresh folder `target/foxglove-check/NAME`.
fn fresh_dir(ctx: &Context, name: &str) -> Result<PathBuf> {
    let dir = target_dir(ctx).join("foxglove-check").join(name);
    if dir.exists() {
        std::fs::remove_dir_all(&dir).with_context(|| format!("removing {}", dir.display()))?;
    }
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    Ok(dir)
}

/// Runs `cmd`, echoing its standard output; fails unless it succeeds. Returns the output.
fn run_echoed(cmd: &mut Command) -> Result<String> {
    let shown = display_command(cmd);
    println!("$ {shown}");
    let output = cmd
        .stdin(Stdio::null())
        .output()
        .with_context(|| format!("could not start `{shown}`"))?;
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    print!("{stdout}");
    eprint!("{}", String::from_utf8_lossy(&output.stderr));
    ensure!(
        output.status.success(),
        "`{shown}` failed ({})",
        output.status
    );
    Ok(stdout)
}

/// `station --connect ADDRESS run paper-circle --out OUT [--mcap FILE]`.
fn station_run(station: &Path, address: &str, out: &Path, mcap: Option<&Path>) -> Command {
    let mut cmd = Command::new(station);
    cmd.args(["--connect", address, "run", "paper-circle", "--out"])
        .arg(out);
    if let Some(mcap) = mcap {
        cmd.arg("--mcap").arg(mcap);
    }
    cmd
}

/// The file check (module doc).
pub fn check_file(ctx: &Context) -> Result<()> {
    let dir = fresh_dir(ctx, "file")?;
    let host_sim = crate::steps::host_binary(ctx, "host-sim")?;
    let station = crate::steps::host_binary(ctx, "station")?;
    let sim_mcap = dir.join("host-sim.mcap");
    run_echoed(
        Command::new(&host_sim)
            .args(["run", "paper-circle", "--out"])
            .arg(dir.join("host-sim"))
            .arg("--mcap")
            .arg(&sim_mcap),
    )?;
    let bytes = std::fs::metadata(&sim_mcap)
        .with_context(|| format!("no {}", sim_mcap.display()))?
        .len();
    println!(
        "host-sim run paper-circle (30 s, trace at 100 Hz): {:.2} MB of MCAP (budget {:.0} MB)",
        bytes as f64 / 1e6,
        FILE_BUDGET_BYTES as f64 / 1e6
    );
    ensure!(
        bytes <= FILE_BUDGET_BYTES,
        "the 30 s run's MCAP file is {bytes} bytes, over {FILE_BUDGET_BYTES}"
    );
    let station_mcap = dir.join("station.mcap");
    {
        let (_server, address, _) = start_server(&host_sim, &["--speed", SPEED])?;
        run_echoed(&mut station_run(
            &station,
            &address,
            &dir.join("station"),
            Some(&station_mcap),
        ))?;
    }
    let python = crate::python_venv::venv_python(ctx, "mcap-check", &PYTHON_REQUIREMENTS)?;
    let stdout = run_echoed(
        Command::new(python)
            .arg(ctx.root.join(MCAP_CHECK))
            .arg(&sim_mcap)
            .arg(dir.join("host-sim").join("trace.csv"))
            .arg(&station_mcap)
            .arg(dir.join("station").join("trace.csv")),
    )?;
    ensure!(
        stdout
            .lines()
            .any(|l| l.starts_with("mcap: ") && l.ends_with(" poses equal trace.csv")),
        "the reader did not print `mcap: N channels, M messages, poses equal trace.csv`"
    );
    Ok(())
}

/// `target/foxglove-live` with the pinned npm packages installed.
fn npm_packages(ctx: &Context) -> Result<PathBuf> {
    let dir = target_dir(ctx).join("foxglove-live");
    std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
    let manifest = dir.join("package.json");
    let installed = dir
        .join("node_modules")
        .join("@foxglove")
        .join("ws-protocol");
    if std::fs::read_to_string(&manifest).is_ok_and(|m| m == NPM_PACKAGES) && installed.is_dir() {
        println!("npm packages: {}", dir.display());
        return Ok(dir.join("node_modules"));
    }
    std::fs::write(&manifest, NPM_PACKAGES)
        .with_context(|| format!("writing {}", manifest.display()))?;
    let npm = crate::setup::ensure_program("npm", "npm", "or Node.js 20 with npm")?;
    run_echoed(
        Command::new(npm)
            .args(["install", "--no-audit", "--no-fund", "--no-package-lock"])
            .current_dir(&dir),
    )?;
    Ok(dir.join("node_modules"))
}

/// The address in `foxglove live on ws://ADDRESS (…`.
fn foxglove_address(line: &str) -> Option<String> {
    let rest = line.strip_prefix("foxglove live on ws://")?;
    let address = rest.split_whitespace().next()?;
    (!address.ends_with(":0")).then(|| address.to_string())
}

/// The live check (module doc).
pub fn check_live(ctx: &Context) -> Result<()> {
    let dir = fresh_dir(ctx, "live")?;
    let node = crate::setup::ensure_program("node", "nodejs", "or Node.js 20")?;
    let modules = npm_packages(ctx)?;
    let host_sim = crate::steps::host_binary(ctx, "host-sim")?;
    let station = crate::steps::host_binary(ctx, "station")?;
    let (_server, address, lines) =
        start_server(&host_sim, &["--speed", SPEED, "--foxglove", "127.0.0.1:0"])?;
    let line = lines
        .recv_timeout(Duration::from_secs(10))
        .context("host-sim serve --foxglove did not say where it streams")?;
    println!("{line}");
    let foxglove = foxglove_address(&line)
        .with_context(|| format!("`{line}` is not where the Foxglove stream listens"))?;
    let mut client = Command::new(node);
    client
        .arg(ctx.root.join(LIVE_CHECK))
        .args([format!("ws://{foxglove}").as_str(), LIVE_TIMEOUT_S])
        .env("NODE_PATH", &modules)
        .env("ROBOT_SPEED", SPEED)
        .stdin(Stdio::null())
        .stdout(Stdio::piped());
    println!("$ {} &", display_command(&client));
    let mut child = client.spawn().context("could not start node")?;
    // The client subscribes before the run arms the robot.
    std::thread::sleep(Duration::from_secs(1));
    let ran = run_echoed(&mut station_run(&station, &address, &dir.join("run"), None));
    let mut stdout = String::new();
    if let Some(mut pipe) = child.stdout.take() {
        let _ = pipe.read_to_string(&mut stdout);
    }
    let status = child.wait().context("waiting for the live client")?;
    print!("{stdout}");
    ran?;
    ensure!(status.success(), "the live client failed ({status})");
    let Some(closing) = stdout.lines().find(|l| l.starts_with("foxglove live: ")) else {
        bail!("the live client did not print `foxglove live: N channels, M messages in S s`");
    };
    ensure!(
        closing.starts_with("foxglove live: 10 channels,"),
        "the live client did not receive every channel: `{closing}`"
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_stream_line_gives_its_address() {
        assert_eq!(
            foxglove_address(
                "foxglove live on ws://127.0.0.1:40123 (subprotocol foxglove.sdk.v1), 100 Hz of robot time"
            ),
            Some("127.0.0.1:40123".to_string())
        );
        assert_eq!(
            foxglove_address("foxglove live on ws://127.0.0.1:0 (x)"),
            None
        );
        assert_eq!(foxglove_address("virtual robot (x) listening on …"), None);
    }
}
