//! The protocol client written from `docs/protocol.md` (`tools/protocol-client/`), against
//! the virtual robot: proof that the page is enough to talk to the robot.
//!
//! The step finds `python3` (installing it with apt-get as root when missing, or naming
//! the package), builds `host-sim`, starts `host-sim serve` on `127.0.0.1` with port 0
//! (the port the system chose is in the line it prints first), runs the client against
//! it and stops the server whatever happened. The client prints `protocol conformance: N
//! telemetry frames decoded from docs/protocol.md`; the step fails unless that line
//! comes with a zero exit status.

use std::io::{BufRead as _, BufReader};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc;
use std::time::Duration;

use anyhow::{bail, ensure, Context as _, Result};

use crate::steps::{display_command, Context};

/// The client, relative to the workspace root.
pub const CLIENT: &str = "tools/protocol-client/protocol_client.py";

/// How long `host-sim serve` may take to say where it listens.
const LISTEN_TIMEOUT: Duration = Duration::from_secs(30);

/// The server, killed and reaped when dropped.
pub struct Server(Child);

impl Drop for Server {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// Runs the client against a fresh virtual robot.
pub fn check(ctx: &Context) -> Result<()> {
    let python = crate::setup::ensure_python3()?;
    let host_sim = crate::steps::host_binary(ctx, "host-sim")?;
    let (server, address, _) = start_server(&host_sim, &[])?;
    let mut cmd = Command::new(python);
    cmd.arg(ctx.root.join(CLIENT))
        .args(["--connect", &address])
        .current_dir(&ctx.root)
        .stdin(Stdio::null());
    let shown = display_command(&cmd);
    println!("$ {shown}");
    let output = cmd
        .output()
        .with_context(|| format!("could not start `{shown}`"))?;
    drop(server);
    let stdout = String::from_utf8_lossy(&output.stdout);
    let stderr = String::from_utf8_lossy(&output.stderr);
    print!("{stdout}");
    eprint!("{stderr}");
    ensure!(
        output.status.success(),
        "`{shown}` failed ({})",
        output.status
    );
    conformance_frames(&stdout).with_context(|| {
        format!("`{shown}` did not print `protocol conformance: N telemetry frames decoded from docs/protocol.md`")
    })?;
    Ok(())
}

/// Starts `host-sim serve` on an ephemeral port of 127.0.0.1 with `args` added; the
/// server, its address, and the lines it prints after the first.
pub fn start_server(
    host_sim: &Path,
    args: &[&str],
) -> Result<(Server, String, mpsc::Receiver<String>)> {
    let mut cmd = Command::new(host_sim);
    cmd.args(["serve", "--listen", "127.0.0.1:0"])
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::inherit());
    let shown = display_command(&cmd);
    println!("$ {shown} &");
    let mut child = cmd
        .spawn()
        .with_context(|| format!("could not start `{shown}`"))?;
    let stdout = child
        .stdout
        .take()
        .context("no stdout from host-sim serve")?;
    let server = Server(child);
    let (lines, received) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if lines.send(line).is_err() {
                break;
            }
        }
    });
    let line = received
        .recv_timeout(LISTEN_TIMEOUT)
        .with_context(|| format!("`{shown}` said nothing within {LISTEN_TIMEOUT:?}"))?;
    println!("{line}");
    let address = listening_address(&line)
        .with_context(|| format!("`{shown}` printed `{line}`, not where it listens"))?;
    Ok((server, address, received))
}

/// The address in `virtual robot (NAME) listening on ADDRESS, …`.
fn listening_address(line: &str) -> Option<String> {
    let rest = line.split_once(" listening on ")?.1;
    let address = rest.split(',').next()?.trim();
    (!address.is_empty() && !address.ends_with(":0")).then(|| address.to_string())
}

/// N of the client's closing line, when it decoded at least one frame.
fn conformance_frames(stdout: &str) -> Result<u32> {
    for line in stdout.lines() {
        if let Some(rest) = line.strip_prefix("protocol conformance: ") {
            let n: u32 = rest
                .strip_suffix(" telemetry frames decoded from docs/protocol.md")
                .context("an unexpected closing line")?
                .parse()
                .context("N is not a number")?;
            ensure!(n > 0, "the client decoded no telemetry frame");
            return Ok(n);
        }
    }
    bail!("no closing line")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_servers_line_gives_its_address() {
        assert_eq!(
            listening_address(
                "virtual robot (paper-circle) listening on 127.0.0.1:40123, 1× real time; heartbeat timeout 500 steps"
            ),
            Some("127.0.0.1:40123".to_string())
        );
        assert_eq!(
            listening_address("virtual robot (x) listening on 127.0.0.1:0, 1× real time"),
            None
        );
        assert_eq!(listening_address("error: listening failed"), None);
    }

    #[test]
    fn the_clients_closing_line_must_count_frames() {
        assert_eq!(
            conformance_frames(
                "protocol conformance: 100 telemetry frames decoded from docs/protocol.md\n"
            )
            .unwrap(),
            100
        );
        assert!(conformance_frames(
            "protocol conformance: 0 telemetry frames decoded from docs/protocol.md"
        )
        .is_err());
        assert!(conformance_frames("protocol conformance FAILED: …").is_err());
    }
}
