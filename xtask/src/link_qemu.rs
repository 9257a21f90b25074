//! The link on an emulated Cortex-M4F: builds `cortex-m4f/qemu-link`, runs it under
//! `qemu-system-arm` (netduinoplus2) with its USART1 connected to a TCP socket of this
//! process, and talks to it through the `link` crate:
//!
//! - every valid request must get exactly the reply the protocol prescribes (replies are
//!   matched by `seq`; a reply to anything else counts as misread);
//! - corrupted frames (a flipped bit, a truncated frame, garbage, an oversized frame, an
//!   intact frame with an undecodable body) are sent before some requests; each must be
//!   dropped without an answer, and the guest's counters must equal those of a decoder
//!   fed the same bytes here, field for field;
//! - frames with another protocol's header must be answered with
//!   `Uplink::VersionMismatch`.
//!
//! It prints `link on Cortex-M4F: N frames exchanged, M corrupted frames dropped,
//! 0 misread`, where N counts valid requests answered correctly and M the corrupted
//! frames the guest dropped.
//!
//! QEMU connects to our listening socket (`server=off`), so no port is picked and then
//! released for QEMU to race for. Bytes sent before the guest enables its USART are
//! lost, so the guest sends one 0x00 ("ready") first and nothing is sent before it.

use std::io::{ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use anyhow::{bail, ensure, Context as _, Result};
use controller_core::kinematics::{BodyVelocity, Point, Pose, WheelSpeeds};
use controller_core::law::LawKind;
use controller_core::path::Path as RobotPath;
use controller_core::reference::ReferenceMode;
use link::upload::chunks;
use link::{
    check_telemetry_rate, encode, encode_raw, params_hash, path_checksum, ArmMode, Decoder,
    Downlink, NotPermitted, PathBegin, PathCommit, ProtocolId, Received, Refusal, Reply, Request,
    Uplink, MAX_FRAME_LEN,
};

use crate::elf_size;
use crate::steps::{build_target_executables, display_command, Context};

/// How long QEMU may take to connect, start and finish; only catches a hung guest.
const TIMEOUT: Duration = Duration::from_secs(60);
/// Longest wait for one reply.
const REPLY_TIMEOUT: Duration = Duration::from_secs(10);
/// Name the guest reports in its `RobotInfo`.
const GUEST_NAME: &str = "qemu-link";

/// The CI step (see the module doc).
pub fn check(ctx: &Context) -> Result<()> {
    let executables = build_target_executables(ctx, "qemu-link", &[])?;
    let elf = executables
        .first()
        .context("building qemu-link produced no executable")?;
    report_size(elf)?;

    let listener = TcpListener::bind("127.0.0.1:0").context("binding a local TCP port")?;
    let port = listener.local_addr()?.port();
    let mut qemu = Qemu::start(elf, port)?;
    let outcome = connect(&listener, &mut qemu).and_then(|stream| {
        let mut session = Session::new(stream)?;
        session.wait_ready()?;
        session.run_script()?;
        Ok(session.tally)
    });
    let (status, output) = qemu.finish()?;
    for line in output.lines() {
        println!("    | {line}");
    }
    let tally = outcome?;
    ensure!(status.success(), "QEMU exited with {status}");
    if !tally.problems.is_empty() {
        bail!("{}", tally.problems.join("; "));
    }
    println!(
        "link on Cortex-M4F: {} frames exchanged, {} corrupted frames dropped, {} misread",
        tally.exchanged, tally.corrupted_dropped, tally.misread
    );
    ensure!(tally.misread == 0, "{} frames misread", tally.misread);
    Ok(())
}

/// Prints the program's sections (the codec's cost on the target is part of `.text`).
fn report_size(elf: &Path) -> Result<()> {
    let usage = elf_size::measure(elf)?;
    let parts: Vec<String> = usage
        .sections
        .iter()
        .map(|s| format!("{} {} B", s.name, s.size))
        .collect();
    println!(
        "qemu-link size: {} (flash {} B, static RAM {} B)",
        parts.join(", "),
        usage.flash,
        usage.ram
    );
    Ok(())
}

/// QEMU running the guest, its output drained on threads.
struct Qemu {
    child: Child,
    readers: Vec<thread::JoinHandle<String>>,
    started: Instant,
}

impl Qemu {
    fn start(elf: &Path, port: u16) -> Result<Self> {
        let mut cmd = Command::new("qemu-system-arm");
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
            "-chardev",
            &format!("socket,id=link,host=127.0.0.1,port={port},server=off,nodelay=on"),
            "-serial",
            "chardev:link",
            "-kernel",
        ])
        .arg(elf)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
        let shown = display_command(&cmd);
        println!("$ {shown}");
        let mut child = cmd.spawn().with_context(|| {
            format!("could not start `{shown}` (is qemu-system-arm installed?)")
        })?;
        let readers = vec![
            drain(child.stdout.take().context("no stdout pipe")?),
            drain(child.stderr.take().context("no stderr pipe")?),
        ];
        Ok(Self {
            child,
            readers,
            started: Instant::now(),
        })
    }

    /// True while QEMU runs.
    fn running(&mut self) -> Result<bool> {
        Ok(self.child.try_wait().context("waiting for QEMU")?.is_none())
    }

    /// Waits for QEMU to exit (killing it after [`TIMEOUT`]); its status and output.
    fn finish(mut self) -> Result<(std::process::ExitStatus, String)> {
        let status = loop {
            if let Some(status) = self.child.try_wait().context("waiting for QEMU")? {
                break status;
            }
            if self.started.elapsed() > TIMEOUT {
                // Our own child, by handle: nothing else is touched.
                let _ = self.child.kill();
                let _ = self.child.wait();
                bail!("QEMU did not finish within {} s", TIMEOUT.as_secs());
            }
            thread::sleep(Duration::from_millis(10));
        };
        let output = self
            .readers
            .drain(..)
            .map(|r| r.join().unwrap_or_default())
            .collect::<Vec<_>>()
            .join("");
        Ok((status, output))
    }
}

/// Reads a pipe to its end on a thread, so that a chatty child never blocks.
fn drain(mut pipe: impl Read + Send + 'static) -> thread::JoinHandle<String> {
    thread::spawn(move || {
        let mut bytes = Vec::new();
        let _ = pipe.read_to_end(&mut bytes);
        String::from_utf8_lossy(&bytes).into_owned()
    })
}

/// Accepts QEMU's connection (QEMU connects before it starts the guest).
fn connect(listener: &TcpListener, qemu: &mut Qemu) -> Result<TcpStream> {
    listener.set_nonblocking(true)?;
    let started = Instant::now();
    loop {
        match listener.accept() {
            Ok((stream, _)) => {
                stream.set_nonblocking(false)?;
                stream.set_nodelay(true)?;
                stream.set_read_timeout(Some(Duration::from_millis(100)))?;
                return Ok(stream);
            }
            Err(e) if e.kind() == ErrorKind::WouldBlock => {
                ensure!(
                    qemu.running()?,
                    "QEMU exited before connecting to the link socket"
                );
                ensure!(
                    started.elapsed() < TIMEOUT,
                    "QEMU did not connect within {} s",
                    TIMEOUT.as_secs()
                );
                thread::sleep(Duration::from_millis(5));
            }
            Err(e) => return Err(e).context("accepting QEMU's connection"),
        }
    }
}

/// What the exchange counted.
#[derive(Default)]
struct Tally {
    /// Valid requests answered with the right reply.
    exchanged: u32,
    /// Corrupted frames sent (each must be dropped by the guest).
    corrupted_sent: u32,
    /// Corrupted frames the guest reported dropping (its Stats).
    corrupted_dropped: u32,
    /// Replies that were wrong, missing, or answered something not asked.
    misread: u32,
    /// What went wrong, for the step's error.
    problems: Vec<String>,
}

/// The kinds of corruption sent, in turn.
#[derive(Clone, Copy, Debug)]
enum Corruption {
    BitFlip,
    Truncated,
    Garbage,
    Oversized,
    BadBody,
}

const CORRUPTIONS: [Corruption; 5] = [
    Corruption::BitFlip,
    Corruption::Truncated,
    Corruption::Garbage,
    Corruption::Oversized,
    Corruption::BadBody,
];

/// A deterministic xorshift64 generator: the same run every time.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        self.0
    }

    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }

    fn nonzero_byte(&mut self) -> u8 {
        1 + (self.next() % 255) as u8
    }
}

/// The host's side of the conversation.
struct Session {
    stream: TcpStream,
    /// Decodes the guest's frames.
    uplink: Decoder,
    /// Fed every byte sent: what the guest's decoder must have counted.
    mirror: Decoder,
    seq: u16,
    rng: Rng,
    exchanges: usize,
    replies_received: u32,
    tally: Tally,
}

type Expect = Result<Reply, Refusal>;

impl Session {
    fn new(stream: TcpStream) -> Result<Self> {
        Ok(Self {
            stream,
            uplink: Decoder::new(),
            mirror: Decoder::new(),
            seq: 0,
            rng: Rng(0x9e37_79b9_7f4a_7c15),
            exchanges: 0,
            replies_received: 0,
            tally: Tally::default(),
        })
    }

    /// Waits for the guest's ready byte (0x00).
    fn wait_ready(&mut self) -> Result<()> {
        let deadline = Instant::now() + TIMEOUT;
        let mut byte = [0u8; 1];
        loop {
            match self.stream.read(&mut byte) {
                Ok(1) if byte[0] == 0 => return Ok(()),
                Ok(1) => bail!(
                    "the guest's first byte was {:#04x}, not the ready byte 0x00",
                    byte[0]
                ),
                Ok(_) => bail!("QEMU closed the link before the guest was ready"),
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                    ensure!(Instant::now() < deadline, "no ready byte from the guest");
                }
                Err(e) => return Err(e).context("reading the ready byte"),
            }
        }
    }

    /// The whole conversation; ends with `GetStats`, after which the guest exits.
    fn run_script(&mut self) -> Result<()> {
        // Who is there, and its configuration.
        let info = self.exchange(Request::Info, "Info", |r| {
            matches!(r, Ok(Reply::Info(i)) if i.protocol == ProtocolId::OURS && i.robot_name == GUEST_NAME)
        })?;
        let Some(Ok(Reply::Info(info))) = info else {
            bail!("no RobotInfo from the guest");
        };
        let params = match self.exchange(
            Request::GetParams,
            "Params",
            |r| matches!(r, Ok(Reply::Params(p)) if params_hash(p) == info.params_hash),
        )? {
            Some(Ok(Reply::Params(p))) => p,
            _ => bail!("no configuration from the guest"),
        };
        self.expect(
            Request::SetParams(params),
            Ok(Reply::ParamsApplied {
                params_hash: params_hash(&params),
            }),
        )?;
        self.expect(
            Request::PersistParams,
            Err(Refusal::NotPermitted(NotPermitted::NoStorage)),
        )?;

        // Pings, heartbeats and a telemetry rate in and out of range.
        for _ in 0..60 {
            let nonce = self.rng.next() as u32;
            self.expect(Request::Ping { nonce }, Ok(Reply::Pong { nonce }))?;
        }
        for _ in 0..10 {
            self.expect(Request::Heartbeat, Ok(Reply::Ack))?;
        }
        for hz in [0, 1, 50, 100, 101] {
            let expected = check_telemetry_rate(hz).map(|_| Reply::Ack);
            self.expect(Request::SetTelemetryRate { hz }, expected)?;
        }

        // Arming before a path exists; a path upload with a lost and a repeated chunk.
        let follow = Request::Arm {
            mode: ArmMode::FollowPath,
            initial_motion: None,
            run_time_limit_steps: None,
        };
        self.expect(
            follow.clone(),
            Err(Refusal::NotPermitted(NotPermitted::NoPath)),
        )?;
        self.upload_path()?;
        self.expect(follow, Ok(Reply::Ack))?;
        for request in [
            Request::PathBegin(square_begin(9)),
            Request::SetParams(params),
        ] {
            self.expect(request, Err(Refusal::Armed))?;
        }
        self.expect(Request::Disarm, Ok(Reply::Ack))?;
        self.expect(
            Request::Arm {
                mode: ArmMode::HoldWheelSpeeds(WheelSpeeds::new(3.0, -3.0)),
                initial_motion: Some(BodyVelocity::new(0.2, 0.5)),
                run_time_limit_steps: None,
            },
            Ok(Reply::Ack),
        )?;
        self.expect(Request::EmergencyStop, Ok(Reply::Ack))?;
        self.expect(
            Request::Arm {
                mode: ArmMode::Tune,
                initial_motion: None,
                run_time_limit_steps: None,
            },
            Err(Refusal::NotPermitted(NotPermitted::Unsupported)),
        )?;
        self.expect(Request::ClearFaults, Ok(Reply::Ack))?;

        // Frames of another protocol: refused with a notice naming what they said.
        for other in [
            ProtocolId {
                version: ProtocolId::OURS.version.wrapping_add(1),
                ..ProtocolId::OURS
            },
            ProtocolId {
                schema_hash: ProtocolId::OURS.schema_hash ^ 0x0100_0000,
                ..ProtocolId::OURS
            },
        ] {
            self.foreign_frame(other)?;
        }

        // More pings, with corruption before many of them.
        for _ in 0..60 {
            let nonce = self.rng.next() as u32;
            self.expect(Request::Ping { nonce }, Ok(Reply::Pong { nonce }))?;
        }

        self.finish_with_stats()
    }

    /// Uploads a rounded square: begin, first chunk, a commit refused for the missing
    /// chunk, the missing chunk twice, a chunk of an unknown upload, the commit, and the
    /// commit again.
    fn upload_path(&mut self) -> Result<()> {
        let path = square();
        let segments = path.segments();
        let parts: Vec<_> = chunks(7, segments).collect();
        ensure!(parts.len() == 2, "the square takes two chunks");
        let count = segments.len() as u8;
        self.expect(Request::PathBegin(square_begin(7)), Ok(Reply::Ack))?;
        let stored = |received| {
            Ok(Reply::PathChunkStored {
                upload_id: 7,
                received,
                expected: count,
            })
        };
        self.expect(Request::PathChunk(parts[0].clone()), stored(4))?;
        let commit = PathCommit {
            upload_id: 7,
            segment_count: count,
            checksum: path_checksum(segments),
        };
        self.expect(
            Request::PathCommit(commit),
            Err(Refusal::UploadIncomplete {
                upload_id: 7,
                missing_index: 4,
                received: 4,
                expected: count,
            }),
        )?;
        self.expect(Request::PathChunk(parts[1].clone()), stored(count))?;
        self.expect(Request::PathChunk(parts[1].clone()), stored(count))?;
        let mut stray = parts[0].clone();
        stray.upload_id = 8;
        self.expect(
            Request::PathChunk(stray),
            Err(Refusal::UnknownUpload { upload_id: 8 }),
        )?;
        // The guest builds the path from the segments: same length, bit for bit.
        let summary = link::CommitSummary {
            upload_id: 7,
            segment_count: count,
            checksum: commit.checksum,
            length_m: path.length_m(),
            closed: true,
        };
        self.expect(
            Request::PathCommit(commit),
            Ok(Reply::PathCommitted(summary)),
        )?;
        self.expect(
            Request::PathCommit(commit),
            Ok(Reply::PathCommitted(summary)),
        )
    }

    /// The last request: the guest's counters must equal the mirror's.
    fn finish_with_stats(&mut self) -> Result<()> {
        let reply = self.exchange(Request::GetStats, "Stats", |r| {
            matches!(r, Ok(Reply::Stats(_)))
        })?;
        let Some(Ok(Reply::Stats(stats))) = reply else {
            bail!("no statistics from the guest");
        };
        let guest = stats.link.received;
        let expected = self.mirror.counters();
        if guest != expected {
            self.tally.problems.push(format!(
                "the guest counted {guest:?}, a decoder fed the same bytes counted {expected:?}"
            ));
        }
        if stats.link.frames_sent != self.replies_received {
            self.tally.problems.push(format!(
                "the guest says it sent {} frames, {} arrived",
                stats.link.frames_sent, self.replies_received
            ));
        }
        let c = &guest;
        self.tally.corrupted_dropped =
            c.crc_errors + c.format_errors + c.overflows + c.decode_errors;
        if self.tally.corrupted_dropped != self.tally.corrupted_sent {
            self.tally.problems.push(format!(
                "{} corrupted frames sent, the guest dropped {}",
                self.tally.corrupted_sent, self.tally.corrupted_dropped
            ));
        }
        Ok(())
    }

    /// Sends `request` and checks its reply equals `expected`.
    fn expect(&mut self, request: Request, expected: Expect) -> Result<()> {
        let description = format!("{expected:?}");
        self.exchange(request, &description, move |r| *r == expected)
            .map(drop)
    }

    /// Sends `request` (after a corrupted frame on some exchanges) and waits for the reply
    /// with its `seq`; `check` judges it. Returns the reply when it passed.
    fn exchange(
        &mut self,
        request: Request,
        expected: &str,
        check: impl Fn(&Expect) -> bool,
    ) -> Result<Option<Expect>> {
        self.exchanges += 1;
        if self.exchanges % 3 == 0 {
            let kind = CORRUPTIONS[(self.exchanges / 3) % CORRUPTIONS.len()];
            self.send_corrupted(kind)?;
        }
        self.seq = self.seq.wrapping_add(1);
        let name = request.name();
        let frame = frame_of(&Downlink {
            seq: self.seq,
            request,
        })?;
        self.send(&frame)?;
        let result = self.reply_to(self.seq)?;
        match result {
            Some(result) if check(&result) => {
                self.tally.exchanged += 1;
                Ok(Some(result))
            }
            Some(result) => {
                self.tally.misread += 1;
                self.tally.problems.push(format!(
                    "{name} (seq {}): expected {expected}, got {result:?}",
                    self.seq
                ));
                Ok(None)
            }
            None => {
                self.tally.misread += 1;
                self.tally
                    .problems
                    .push(format!("{name} (seq {}): no reply", self.seq));
                Ok(None)
            }
        }
    }

    /// A frame of `other` protocol: the guest must answer `VersionMismatch` with it.
    fn foreign_frame(&mut self, other: ProtocolId) -> Result<()> {
        self.seq = self.seq.wrapping_add(1);
        let body = postcard::to_allocvec(&Downlink {
            seq: self.seq,
            request: Request::Heartbeat,
        })?;
        let mut wire = [0u8; MAX_FRAME_LEN];
        let len = encode_raw(other, &body, &mut wire)?;
        self.send(&wire[..len])?;
        match self.next_uplink()? {
            Some(Uplink::VersionMismatch { received }) if received == other => {
                self.tally.exchanged += 1;
            }
            got => {
                self.tally.misread += 1;
                self.tally.problems.push(format!(
                    "a frame of {other} got {got:?}, not VersionMismatch"
                ));
            }
        }
        Ok(())
    }

    /// Sends one corrupted frame of `kind`, made so that it is exactly one frame that the
    /// guest must drop (checked against the mirror decoder).
    fn send_corrupted(&mut self, kind: Corruption) -> Result<()> {
        let nonce = self.rng.next() as u32;
        let valid = frame_of(&Downlink {
            seq: 0xbad,
            request: Request::Ping { nonce },
        })?;
        let bytes = match kind {
            Corruption::BitFlip => {
                let mut bytes = valid;
                loop {
                    let at = self.rng.below(bytes.len() - 1); // not the delimiter
                    let flipped = bytes[at] ^ (1 << self.rng.below(8));
                    if flipped != 0 {
                        bytes[at] = flipped;
                        break bytes;
                    }
                }
            }
            Corruption::Truncated => {
                let keep = 1 + self.rng.below(valid.len() - 2);
                let mut bytes = valid[..keep].to_vec();
                bytes.push(0);
                bytes
            }
            Corruption::Garbage => {
                let len = 1 + self.rng.below(40);
                let mut bytes: Vec<u8> = (0..len).map(|_| self.rng.nonzero_byte()).collect();
                bytes.push(0);
                bytes
            }
            Corruption::Oversized => {
                let len = MAX_FRAME_LEN + self.rng.below(100);
                let mut bytes: Vec<u8> = (0..len).map(|_| self.rng.nonzero_byte()).collect();
                bytes.push(0);
                bytes
            }
            Corruption::BadBody => {
                // seq 5, then a Request variant that does not exist.
                let body = [5u8, 0x7f];
                let mut wire = [0u8; MAX_FRAME_LEN];
                let len = encode_raw(ProtocolId::OURS, &body, &mut wire)?;
                wire[..len].to_vec()
            }
        };
        let before = self.mirror.counters();
        self.send(&bytes)?;
        let after = self.mirror.counters();
        ensure!(
            after.dropped() == before.dropped() + 1 && after.frames_ok == before.frames_ok,
            "test error: a {kind:?} corruption is not exactly one dropped frame"
        );
        self.tally.corrupted_sent += 1;
        Ok(())
    }

    /// Writes `bytes` to the guest and feeds them to the mirror decoder.
    fn send(&mut self, bytes: &[u8]) -> Result<()> {
        for _ in self.mirror.feed::<Downlink>(bytes) {}
        self.stream
            .write_all(bytes)
            .context("writing to the guest's USART")
    }

    /// Reads uplink frames until the reply to `seq`; any other message is a misread.
    fn reply_to(&mut self, seq: u16) -> Result<Option<Expect>> {
        loop {
            match self.next_uplink()? {
                Some(Uplink::Reply { seq: s, result }) if s == seq => return Ok(Some(result)),
                Some(other) => {
                    self.tally.misread += 1;
                    self.tally.problems.push(format!(
                        "unexpected frame while waiting for seq {seq}: {other:?}"
                    ));
                }
                None => return Ok(None),
            }
        }
    }

    /// The next message from the guest, or `None` after [`REPLY_TIMEOUT`].
    fn next_uplink(&mut self) -> Result<Option<Uplink>> {
        let deadline = Instant::now() + REPLY_TIMEOUT;
        let mut byte = [0u8; 1];
        while Instant::now() < deadline {
            match self.stream.read(&mut byte) {
                Ok(0) => bail!("QEMU closed the link"),
                Ok(_) => match self.uplink.push::<Uplink>(byte[0]) {
                    Some(Ok(Received::Message(message))) => {
                        self.replies_received += 1;
                        return Ok(Some(message));
                    }
                    Some(other) => {
                        self.tally.misread += 1;
                        self.tally
                            .problems
                            .push(format!("a frame from the guest did not decode: {other:?}"));
                    }
                    None => {}
                },
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {}
                Err(e) => return Err(e).context("reading from the guest's USART"),
            }
        }
        Ok(None)
    }
}

/// One frame of `message`.
fn frame_of(message: &Downlink) -> Result<Vec<u8>> {
    let mut wire = [0u8; MAX_FRAME_LEN];
    let len = encode(message, &mut wire)?;
    Ok(wire[..len].to_vec())
}

/// A 1 m square with 0.2 m fillets: 8 segments, two chunks.
fn square() -> RobotPath {
    let corners = [
        Point::new(0.0, 0.0),
        Point::new(1.0, 0.0),
        Point::new(1.0, 1.0),
        Point::new(0.0, 1.0),
    ];
    // Valid by construction; a failure here is a bug in this file.
    RobotPath::polyline(&corners, 0.2, true).expect("the square is a valid path")
}

fn square_begin(upload_id: u16) -> PathBegin {
    PathBegin {
        upload_id,
        segment_count: square().segments().len() as u8,
        speed_m_s: 0.25,
        mode: ReferenceMode::PathFollowing { lookahead_m: 0.05 },
        law: LawKind::Tracking,
        start_pose: Pose::new(0.2, 0.0, 0.0),
    }
}
