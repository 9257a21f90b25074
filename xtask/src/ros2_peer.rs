//! `station ros2` against a DDS peer this project does not write: Cyclone DDS from Python
//! (`tools/ros2-peer/peer.py`), and the virtual robot.
//!
//! The step makes a virtual environment in `target/venvs/ros2` with PyPI's `cyclonedds`
//! (once; it bundles its C library), builds `host-sim` and `station`, starts `host-sim
//! serve` on an ephemeral port of 127.0.0.1, then `station ros2 --arm` against it on a
//! DDS domain of its own, then the peer, with Cyclone on the loopback interface with a
//! unicast peer (multicast is not needed). The peer drives the robot by `cmd_vel` at
//! 20 Hz, measures the stop after the last command, resets the pose and sends an
//! L-shaped `nav_msgs/Path`, which the robot follows; it prints
//! `ros2 (Cyclone DDS peer): cmd_vel N, odom M at F Hz, stopped S s after the last
//! command, path followed`. The step then runs the same path (its three waypoints, the
//! same fillet, speed and run length) with `station run` on a fresh virtual robot and
//! requires both runs to settle within [`SETTLE_MATCH_S`] of each other (that reference
//! run is tried twice: at real time, a loaded machine can starve its heartbeats). Every
//! process it started is stopped whatever happened.

use std::path::Path;
use std::process::{Child, Command, Stdio};

use anyhow::{ensure, Context as _, Result};

use crate::steps::{display_command, run_command, Context};

/// The peer, relative to the workspace root.
pub const PEER: &str = "tools/ros2-peer/peer.py";
/// The Cyclone DDS release the peer is checked with.
const CYCLONEDDS: &str = "cyclonedds==11.0.1";
/// The DDS domain of the test (no other participant of this machine's usual domain 0
/// joins it).
const DOMAIN: &str = "73";
/// Cyclone on the loopback interface, multicast off, discovery by a unicast peer.
const CYCLONEDDS_URI: &str = "<CycloneDDS><Domain><General><Interfaces><NetworkInterface \
name=\"lo\"/></Interfaces><AllowMulticast>false</AllowMulticast></General><Discovery><Peers>\
<Peer address=\"127.0.0.1\"/></Peers><ParticipantIndex>auto</ParticipantIndex></Discovery>\
</Domain></CycloneDDS>";
/// The bridge's parameters for the run: what the peer's path and the station's run share.
const CORNER_RADIUS_M: f64 = 0.1;
const PATH_SPEED_M_S: f64 = 0.2;
/// The bridge's run length beyond the path's time (its `PATH_SETTLE_S`).
const PATH_SETTLE_S: f64 = 5.0;
/// The two runs' settle times may differ by this much, s (the robot does not start from
/// exactly the same state: the ROS 2 run follows the drive).
const SETTLE_MATCH_S: f64 = 0.5;
/// How long the bridge may run in all, s.
const BRIDGE_LIMIT_S: &str = "90";

/// A child process, killed and reaped when dropped.
struct Running(Child);

impl Drop for Running {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

/// How the peer sends `cmd_vel`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CmdVel {
    /// `geometry_msgs/Twist`, the bridge's default.
    Twist,
    /// `geometry_msgs/TwistStamped`, to a bridge with `use_stamped_vel` set.
    TwistStamped,
}

/// Runs the peer against the bridge and the virtual robot, `cmd_vel` as Twist (CI's).
pub fn check(ctx: &Context) -> Result<()> {
    check_with(ctx, CmdVel::Twist)
}

/// Runs the peer against the bridge and the virtual robot, `cmd_vel` as `cmd_vel` says.
pub fn check_with(ctx: &Context, cmd_vel: CmdVel) -> Result<()> {
    let python = crate::python_venv::venv_python(ctx, "ros2", &[CYCLONEDDS])?;
    let host_sim = crate::steps::host_binary(ctx, "host-sim")?;
    let station = crate::steps::host_binary(ctx, "station")?;
    let (server, address, _) = crate::protocol_client::start_server(&host_sim, &[])?;

    let mut bridge_cmd = Command::new(&station);
    bridge_cmd
        .args(["ros2", "--robot", &address, "--arm", "--domain", DOMAIN])
        .args(["--duration-s", BRIDGE_LIMIT_S])
        .args(["-p", &format!("path_corner_radius={CORNER_RADIUS_M}")])
        .args(["-p", &format!("path_speed={PATH_SPEED_M_S}")])
        .args([
            "-p",
            &format!("use_stamped_vel={}", cmd_vel == CmdVel::TwistStamped),
        ])
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    println!("$ {} &", display_command(&bridge_cmd));
    let mut bridge = Running(bridge_cmd.spawn().context("could not start station ros2")?);
    let bridge_out = drain(bridge.0.stdout.take().context("no stdout")?);
    let bridge_err = drain(bridge.0.stderr.take().context("no stderr")?);

    let mut peer_cmd = Command::new(&python);
    peer_cmd
        .arg(ctx.root.join(PEER))
        .args([
            "--domain",
            DOMAIN,
            "--corner-radius",
            &CORNER_RADIUS_M.to_string(),
        ])
        .args((cmd_vel == CmdVel::TwistStamped).then_some("--stamped"))
        .current_dir(ctx.root.join("tools/ros2-peer"))
        .env("CYCLONEDDS_URI", CYCLONEDDS_URI)
        .stdin(Stdio::null());
    let shown = display_command(&peer_cmd);
    println!("$ {shown}");
    let peer = peer_cmd
        .output()
        .with_context(|| format!("could not start `{shown}`"))?;
    drop(bridge);
    drop(server);
    let stdout = String::from_utf8_lossy(&peer.stdout);
    print!("{stdout}");
    eprint!("{}", String::from_utf8_lossy(&peer.stderr));
    let bridge_lines = bridge_out.join().unwrap_or_default();
    let bridge_errors = bridge_err.join().unwrap_or_default();
    println!("--- station ros2:\n{bridge_lines}{bridge_errors}---");
    ensure!(peer.status.success(), "`{shown}` failed ({})", peer.status);
    let verdict = stdout
        .lines()
        .find(|l| l.starts_with("ros2 (Cyclone DDS peer): "))
        .context("the peer printed no `ros2 (Cyclone DDS peer): …` line")?
        .to_string();
    let ros2_settle = number_after(&stdout, "path: settle_s=")
        .context("the peer printed no settle time of the path")?;

    // The reference run is `station run` at real time: on a machine loaded enough to
    // starve its heartbeats it ends early, which says nothing of the bridge; it is run
    // once more then.
    let station_settle = match station_run(ctx, &host_sim, &station) {
        Ok(settle) => settle,
        Err(e) => {
            println!("the station's run failed ({e:#}); once more");
            station_run(ctx, &host_sim, &station)?
        }
    };
    println!(
        "the same path uploaded by the station: settled at {station_settle:.2} s; through \
         ROS 2: {ros2_settle:.2} s"
    );
    ensure!(
        (station_settle - ros2_settle).abs() <= SETTLE_MATCH_S,
        "the path through ROS 2 settled at {ros2_settle:.2} s, uploaded by the station at \
         {station_settle:.2} s (more than {SETTLE_MATCH_S} s apart)"
    );
    println!("{verdict}");
    Ok(())
}

/// The peer's path as a scenario, run with `station run` on a fresh virtual robot; its
/// settle time, s.
fn station_run(ctx: &Context, host_sim: &Path, station: &Path) -> Result<f64> {
    let out = crate::pil::target_dir(ctx).join("ros2-station-run");
    std::fs::create_dir_all(&out).with_context(|| format!("creating {}", out.display()))?;
    let scenario = out.join("ros2-path.toml");
    std::fs::write(&scenario, scenario_text()).context("writing the scenario")?;
    let (server, address, _) = crate::protocol_client::start_server(host_sim, &[])?;
    let mut cmd = Command::new(station);
    cmd.args(["--connect", &address, "run"])
        .arg(&scenario)
        .arg("--out")
        .arg(&out)
        .stdin(Stdio::null());
    let result = run_command(&mut cmd);
    drop(server);
    result?;
    let summary: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(out.join("summary.json")).context("reading summary.json")?,
    )
    .context("summary.json is not JSON")?;
    summary["estimated_error"]["settle_time_s"]
        .as_f64()
        .context("the station's run did not settle")
}

/// The peer's L (0.8 m along x, then 0.5 m along y, from the origin heading +x) as
/// `station run` takes it, followed as the bridge follows a path.
fn scenario_text() -> String {
    let straight = 0.8 + 0.5 - 2.0 * CORNER_RADIUS_M;
    let arc = std::f64::consts::FRAC_PI_2 * CORNER_RADIUS_M;
    let duration = (straight + arc) / PATH_SPEED_M_S + PATH_SETTLE_S;
    format!(
        "name = \"ros2-path\"\n\
         description = \"the ROS 2 peer's L-shaped path, as the bridge follows it\"\n\
         [sim]\nduration_s = {duration}\nplant_rate_hz = 10000\nseed = 1\n\
         [path]\nkind = \"polyline\"\nwaypoints_m = [[0.0, 0.0], [0.8, 0.0], [0.8, 0.5]]\n\
         corner_radius_m = {CORNER_RADIUS_M}\nclosed = false\n\
         [reference]\nspeed_m_s = {PATH_SPEED_M_S}\nmode = \"path-following\"\nlookahead_m = 0.0\n\
         [start]\nx_m = 0.0\ny_m = 0.0\ntheta_rad = 0.0\n"
    )
}

/// The number that follows `prefix` in `text`.
fn number_after(text: &str, prefix: &str) -> Option<f64> {
    let rest = &text[text.find(prefix)? + prefix.len()..];
    let end = rest
        .find(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-'))
        .unwrap_or(rest.len());
    rest[..end].parse().ok()
}

/// Reads a pipe to its end on a thread.
fn drain(mut pipe: impl std::io::Read + Send + 'static) -> std::thread::JoinHandle<String> {
    std::thread::spawn(move || {
        let mut text = String::new();
        let _ = pipe.read_to_string(&mut text);
        text
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_peers_settle_time_is_read() {
        let out =
            "ros2 (Cyclone DDS peer): …\npath: settle_s=4.21 final_error_m=0.0012 waypoints=…\n";
        assert_eq!(number_after(out, "path: settle_s="), Some(4.21));
        assert_eq!(number_after(out, "final_error_m="), Some(0.0012));
        assert_eq!(number_after(out, "missing="), None);
    }

    #[test]
    fn the_scenario_is_the_peers_path() {
        let text = scenario_text();
        assert!(text.contains("waypoints_m = [[0.0, 0.0], [0.8, 0.0], [0.8, 0.5]]"));
        assert!(text.contains("corner_radius_m = 0.1"));
        assert!(text.contains("speed_m_s = 0.2"));
    }
}
