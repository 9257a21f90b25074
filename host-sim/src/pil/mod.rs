//! `host-sim pil`: processor in the loop. The firmware itself, built for the Cortex-M4F
//! with its `qemu` board, runs under `qemu-system-arm` (machine `netduinoplus2`), and this
//! simulator serves it its wheels.
//!
//! ```text
//!  host-sim pil ──plant port (TCP, lockstep)── QEMU USART1 ┐
//!   │  plant, faults, metrics                               │ firmware (RTIC app,
//!   └─station port (TCP) ◄─relay─► QEMU USART2 (the link) ──┘ qemu board)
//!          ▲
//!      any ground station (or the built-in one, `--client builtin`)
//! ```
//!
//! - **The plant port** is lockstep: each control step's sensors go out, the firmware runs
//!   exactly one control step on them and answers with its duties and decision, and only
//!   then does the plant move ([`firmware`], `lockstep`). The run is the same
//!   computation however fast the host or the emulator is.
//! - **The station port** carries the runtime link, as the robot's serial line does; a
//!   station uploads the path, arms and watches ([`relay`]). The plant holds still until
//!   the firmware reports armed, so the start does not depend on when the station's bytes
//!   arrive. [`station`] is a minimal station for tests.
//! - **QEMU** is started with `-icount shift=0,sleep=off`: one instruction per virtual
//!   nanosecond, so SysTick counts instructions (the firmware's measurements), and no
//!   waiting in virtual time. Both serial ports are TCP sockets to this process
//!   (`server=off`: QEMU connects to ports already listening, before it starts the
//!   guest, so nothing the guest sends is lost), and the firmware sends a ready byte on
//!   the plant port once both USARTs are enabled (bytes sent earlier would be dropped).
//!
//! The run goes through the simulator's own loop ([`crate::run::run_with_logic`]), so
//! its summary and digest can be compared with `host-sim run`'s field for field.

pub mod firmware;
pub mod relay;
pub mod station;
pub mod verdict;

use std::io::Read;
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::{self, JoinHandle};
use std::time::{Duration, Instant};

use anyhow::{bail, ensure, Context as _, Result};
use controller_core::law::LawKind;
use lockstep::{BoardReport, READY};
use robot_files::scenario::Scenario;

use self::firmware::{Firmware, InStepStation, LinkLoss};
use self::relay::{LinkSwitch, Relay};
use self::station::{step_requests, StationReport, StationScript};
use crate::run::{run_with_logic, RunOptions, RunResult};

/// How a processor-in-the-loop run is set up.
#[derive(Clone, Debug)]
pub struct PilOptions {
    /// The firmware ELF, built with `--features qemu`.
    pub firmware: PathBuf,
    /// The QEMU binary.
    pub qemu: PathBuf,
    /// The station port (0: any free port, printed).
    pub station_port: u16,
    /// Run the built-in station ([`station`]) against the station port.
    pub builtin_station: bool,
    /// Cut the link this many seconds after arming.
    pub link_loss_at_s: Option<f64>,
    /// How long the station may take to arm the robot (wall clock).
    pub arm_timeout: Duration,
}

/// What a processor-in-the-loop run produced.
#[derive(Clone, Debug)]
pub struct PilOutcome {
    /// The run, as the simulator's loop recorded it (source `pil`).
    pub result: RunResult,
    /// The firmware's own figures.
    pub board: BoardReport,
    /// What the built-in station saw, if it ran.
    pub station: Option<StationReport>,
    /// The link loss and what followed, if one was asked for.
    pub link_loss: Option<LinkLoss>,
    /// Control steps the firmware ran before it was armed.
    pub held_steps: u64,
    /// Wall-clock time of the whole run, s.
    pub wall_time_s: f64,
}

/// Runs `scenario` with `law` on the emulated firmware (module doc).
pub fn run(scenario: &Scenario, law: LawKind, options: &PilOptions) -> Result<PilOutcome> {
    if let Some(gyro) = scenario.gyro {
        ensure!(
            gyro.rest_before_arming_s == 0.0,
            "processor in the loop arms the firmware at the first step (the plant holds still \
             until then, `firmware`): the scenario's [gyro] rest_before_arming_s must be 0, not {}",
            gyro.rest_before_arming_s
        );
    }
    let started = Instant::now();
    let plant_listener = TcpListener::bind("127.0.0.1:0").context("binding the plant port")?;
    let link_listener = TcpListener::bind("127.0.0.1:0").context("binding QEMU's link port")?;
    let station_listener = TcpListener::bind(("127.0.0.1", options.station_port))
        .with_context(|| format!("binding the station port {}", options.station_port))?;
    let mut qemu = Qemu::start(
        options,
        plant_listener.local_addr()?,
        link_listener.local_addr()?,
    )?;
    let outcome = (|| {
        let mut plant = accept(&plant_listener, &mut qemu, "plant")?;
        let link = accept(&link_listener, &mut qemu, "link")?;
        wait_ready(&mut plant)?;
        let switch = Arc::new(LinkSwitch::default());
        let relay = Relay::start(station_listener, link, Arc::clone(&switch))?;
        println!("station port: {} (the firmware's link)", relay.address);
        let stop = Arc::new(AtomicBool::new(false));
        let (requests, inbox) = step_requests();
        let station = options.builtin_station.then(|| {
            let (address, script, stop) = (
                relay.address,
                StationScript::for_scenario(scenario, law),
                Arc::clone(&stop),
            );
            thread::spawn(move || station::drive(address, &script, &inbox, &stop))
        });
        // A heartbeat every tenth of the robot's heartbeat timeout.
        let in_step = station.is_some().then(|| InStepStation {
            requests,
            heartbeat_every_steps: u64::from(scenario.supervisor.heartbeat_timeout_steps / 10)
                .max(1),
        });
        let rate = f64::from(scenario.robot.control_rate_hz);
        let link_loss_at_step = options.link_loss_at_s.map(|s| (s * rate).round() as u64);
        let mut firmware = Firmware::new(
            plant,
            options.arm_timeout,
            switch,
            link_loss_at_step,
            in_step,
        )?;
        let run = run_with_logic(scenario, law, RunOptions::default(), &mut firmware, "pil");
        let board = run.as_ref().ok().map(|_| firmware.finish());
        stop.store(true, Ordering::SeqCst);
        let station = join_station(station);
        relay.stop();
        // A station that failed before arming leaves the firmware waiting: its own error
        // is the cause, so it is reported first.
        let result = match (run, &station) {
            (Err(run), Err(station)) => bail!("{station:#}\n(and so: {run})"),
            (run, _) => run?,
        };
        let board = board.context("no report")??;
        Ok(PilOutcome {
            result,
            board,
            station: station?,
            link_loss: firmware.link_loss().cloned(),
            held_steps: firmware.held_steps(),
            wall_time_s: 0.0,
        })
    })();
    let (status, output) = qemu.finish();
    let mut outcome = match outcome {
        Ok(outcome) => outcome,
        Err(e) => {
            for line in output.lines() {
                eprintln!("    qemu | {line}");
            }
            return Err(e);
        }
    };
    let status = status?;
    ensure!(status.success(), "QEMU exited with {status}\n{output}");
    outcome.wall_time_s = started.elapsed().as_secs_f64();
    Ok(outcome)
}

fn join_station(
    station: Option<JoinHandle<Result<StationReport>>>,
) -> Result<Option<StationReport>> {
    match station {
        None => Ok(None),
        Some(handle) => match handle.join() {
            Ok(report) => report.map(Some).context("the built-in station"),
            Err(_) => bail!("the built-in station's thread panicked"),
        },
    }
}

/// QEMU running the firmware, its output drained on threads.
struct Qemu {
    child: Child,
    readers: Vec<JoinHandle<String>>,
}

impl Qemu {
    fn start(options: &PilOptions, plant: SocketAddr, link: SocketAddr) -> Result<Self> {
        ensure!(
            options.firmware.is_file(),
            "no firmware at {} (build it with `cargo build --profile firmware -p firmware \
             --target thumbv7em-none-eabihf --features qemu`)",
            options.firmware.display()
        );
        let chardev = |id: &str, at: SocketAddr| {
            format!(
                "socket,id={id},host={},port={},server=off,nodelay=on",
                at.ip(),
                at.port()
            )
        };
        let mut cmd = Command::new(&options.qemu);
        cmd.args([
            "-cpu",
            "cortex-m4",
            "-machine",
            "netduinoplus2",
            "-nographic",
            "-monitor",
            "none",
            "-semihosting-config",
            "enable=on,target=native",
            "-icount",
            "shift=0,sleep=off",
            "-chardev",
            &chardev("plant", plant),
            "-serial",
            "chardev:plant",
            "-chardev",
            &chardev("link", link),
            "-serial",
            "chardev:link",
            "-kernel",
        ])
        .arg(&options.firmware)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
        let mut child = cmd.spawn().with_context(|| {
            format!(
                "starting {} (install qemu-system-arm, or give --qemu)",
                options.qemu.display()
            )
        })?;
        let mut readers = Vec::new();
        if let Some(out) = child.stdout.take() {
            readers.push(drain(out));
        }
        if let Some(err) = child.stderr.take() {
            readers.push(drain(err));
        }
        Ok(Self { child, readers })
    }

    fn running(&mut self) -> bool {
        matches!(self.child.try_wait(), Ok(None))
    }

    /// Waits for QEMU to exit (the firmware exits after its report; killed after 10 s
    /// otherwise); its status and output.
    fn finish(mut self) -> (Result<ExitStatus>, String) {
        let deadline = Instant::now() + Duration::from_secs(10);
        let status = loop {
            match self.child.try_wait() {
                Ok(Some(status)) => break Ok(status),
                Ok(None) if Instant::now() < deadline => thread::sleep(Duration::from_millis(10)),
                Ok(None) => {
                    // Our own child, by handle.
                    let _ = self.child.kill();
                    let _ = self.child.wait();
                    break Err(anyhow::anyhow!("QEMU did not exit after the run"));
                }
                Err(e) => break Err(e).context("waiting for QEMU"),
            }
        };
        let output = self
            .readers
            .drain(..)
            .map(|r| r.join().unwrap_or_default())
            .collect::<Vec<_>>()
            .join("");
        (status, output)
    }
}

impl Drop for Qemu {
    fn drop(&mut self) {
        if self.running() {
            // Our own child, by handle: a run that failed must not leave it behind.
            let _ = self.child.kill();
            let _ = self.child.wait();
        }
    }
}

/// Reads a pipe to its end on a thread, so that a chatty child never blocks.
fn drain(mut pipe: impl Read + Send + 'static) -> JoinHandle<String> {
    thread::spawn(move || {
        let mut bytes = Vec::new();
        let _ = pipe.read_to_end(&mut bytes);
        String::from_utf8_lossy(&bytes).into_owned()
    })
}

/// Accepts QEMU's connection on `listener` (it connects before starting the guest).
fn accept(listener: &TcpListener, qemu: &mut Qemu, what: &str) -> Result<TcpStream> {
    listener.set_nonblocking(true)?;
    let started = Instant::now();
    loop {
        match listener.accept() {
            Ok((stream, _)) => {
                stream.set_nonblocking(false)?;
                stream.set_nodelay(true)?;
                return Ok(stream);
            }
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => {
                ensure!(
                    qemu.running(),
                    "QEMU exited before connecting its {what} port"
                );
                ensure!(
                    started.elapsed() < Duration::from_secs(30),
                    "QEMU did not connect its {what} port within 30 s"
                );
                thread::sleep(Duration::from_millis(5));
            }
            Err(e) => return Err(e).with_context(|| format!("accepting QEMU's {what} port")),
        }
    }
}

/// Waits for the firmware's ready byte on the plant port.
fn wait_ready(plant: &mut TcpStream) -> Result<()> {
    plant.set_read_timeout(Some(Duration::from_secs(30)))?;
    let mut byte = [0u8; 1];
    plant
        .read_exact(&mut byte)
        .context("waiting for the firmware's ready byte")?;
    ensure!(
        byte[0] == READY,
        "the firmware's first byte was {:#04x}, not the ready byte {READY:#04x}",
        byte[0]
    );
    Ok(())
}

/// The default QEMU binary.
pub fn default_qemu() -> PathBuf {
    PathBuf::from("qemu-system-arm")
}

/// The firmware ELF built by `cargo build --profile firmware --features qemu` in the
/// workspace whose `target` directory is `target_dir`.
pub fn default_firmware(target_dir: &Path) -> PathBuf {
    target_dir
        .join("thumbv7em-none-eabihf")
        .join("firmware")
        .join("firmware")
}
