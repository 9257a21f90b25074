//! Requests and replies over a [`Transport`]: numbering, re-sending, matching replies by
//! `seq`, and keeping what the robot sends on its own (telemetry, events, ground truth,
//! run reports) for whoever reads it next.

use std::collections::VecDeque;
use std::io;
use std::time::{Duration, Instant};

use link::{
    encode, Decoder, Downlink, Mismatch, Received, Refusal, Reply, Request, RxCounters, Uplink,
    MAX_FRAME_LEN,
};

use crate::transport::Transport;

/// Why a request failed. `Display` is a sentence for a terminal; a variant with a source
/// leaves its text to [`crate::error_text`] (or anyhow's `{:#}`).
#[derive(Debug, thiserror::Error)]
pub enum StationError {
    /// The link failed (port unplugged, connection closed): the OS's error is the source.
    #[error("link to the robot failed")]
    Io(#[from] io::Error),
    /// No reply, even after re-sending.
    #[error(
        "no reply to {request} from {link} after {tries} tries: {}",
        heard(received)
    )]
    Timeout {
        /// The request's name.
        request: &'static str,
        /// Times it was sent.
        tries: u32,
        /// The transport.
        link: String,
        /// What the station's decoder received and dropped while it waited.
        received: RxCounters,
    },
    /// The robot speaks another protocol.
    #[error("{}", .0.describe("the robot", "this station"))]
    Mismatch(Mismatch),
    /// The robot refused.
    #[error("the robot refused {request}: {refusal}")]
    Refused {
        /// The request's name.
        request: &'static str,
        /// Why (boxed: a refusal carries bounded strings).
        refusal: Box<Refusal>,
    },
    /// The robot answered with something else than the request calls for.
    #[error("unexpected answer to {request}: {reply}")]
    Unexpected {
        /// The request's name.
        request: &'static str,
        /// What came back.
        reply: String,
    },
    /// The user pressed Ctrl-C.
    #[error("interrupted")]
    Interrupted,
}

/// What the decoder saw while a request waited, and what that points to.
fn heard(c: &RxCounters) -> String {
    let dropped = c.dropped();
    if c.frames_ok == 0 && dropped == 0 {
        return "nothing arrived (wrong port or baud rate? robot not powered?)".to_string();
    }
    if dropped == 0 {
        return format!(
            "{} frames arrived intact, none of them the reply (is the robot busy, or another \
program answering on this link?)",
            c.frames_ok
        );
    }
    format!(
        "of the frames that arrived, {} failed their CRC, {} were malformed, {} were too \
long, {} were of another protocol or undecodable, and {} were intact: the line corrupts \
frames (noise, a loose connection or ground, a baud rate off)",
        c.crc_errors,
        c.format_errors,
        c.overflows,
        c.mismatches.wrapping_add(c.decode_errors),
        c.frames_ok
    )
}

/// `now − then`, counter by counter (they wrap).
fn since(now: RxCounters, then: RxCounters) -> RxCounters {
    RxCounters {
        frames_ok: now.frames_ok.wrapping_sub(then.frames_ok),
        crc_errors: now.crc_errors.wrapping_sub(then.crc_errors),
        format_errors: now.format_errors.wrapping_sub(then.format_errors),
        overflows: now.overflows.wrapping_sub(then.overflows),
        mismatches: now.mismatches.wrapping_sub(then.mismatches),
        decode_errors: now.decode_errors.wrapping_sub(then.decode_errors),
    }
}

/// The station's end of the link.
pub struct Client<T: Transport> {
    transport: T,
    decoder: Decoder,
    next_seq: u16,
    inbox: VecDeque<Uplink>,
    /// How long to wait for a reply before re-sending.
    pub reply_timeout: Duration,
    /// Times a request is sent before giving up.
    pub tries: u32,
}

impl<T: Transport> Client<T> {
    /// A client on `transport`, replies awaited 300 ms, each request tried 8 times (a
    /// noisy line loses a long frame such as `SetParams` more often than a short one).
    pub fn new(transport: T) -> Self {
        Self {
            transport,
            decoder: Decoder::new(),
            next_seq: 0,
            inbox: VecDeque::new(),
            reply_timeout: Duration::from_millis(300),
            tries: 8,
        }
    }

    /// The transport.
    pub fn transport(&self) -> &T {
        &self.transport
    }

    /// What this side's decoder received and dropped (CRC errors, …).
    pub fn counters(&self) -> RxCounters {
        self.decoder.counters()
    }

    /// Sends `request` and waits for its reply, re-sending on a timeout (every request
    /// is safe to repeat), [`Client::reply_timeout`] each time, [`Client::tries`] times. A
    /// refusal is an error naming it.
    pub fn request(&mut self, request: Request) -> Result<Reply, StationError> {
        let (timeout, tries) = (self.reply_timeout, self.tries);
        self.request_waiting(request, timeout, tries)
    }

    /// [`Client::request`] with its own patience: `reply_timeout` for each of `tries` sends
    /// (at least one).
    pub fn request_waiting(
        &mut self,
        request: Request,
        reply_timeout: Duration,
        tries: u32,
    ) -> Result<Reply, StationError> {
        let name = request.name();
        self.next_seq = self.next_seq.wrapping_add(1);
        let seq = self.next_seq;
        let mut frame = [0u8; MAX_FRAME_LEN];
        let len = encode(&Downlink { seq, request }, &mut frame).map_err(|e| {
            StationError::Unexpected {
                request: name,
                reply: format!("cannot encode the request: {e:?}"),
            }
        })?;
        let bytes = frame.get(..len).unwrap_or_default();
        let before = self.decoder.counters();
        for _ in 0..tries.max(1) {
            self.transport.send(bytes)?;
            let deadline = Instant::now() + reply_timeout;
            while Instant::now() < deadline {
                let messages = self.read(deadline.saturating_duration_since(Instant::now()))?;
                let mut answer = None;
                for message in messages {
                    match message {
                        Uplink::Reply { seq: s, result } if s == seq => answer = Some(result),
                        // A late reply to an earlier request: already given up on.
                        Uplink::Reply { .. } => {}
                        other => self.inbox.push_back(other),
                    }
                }
                match answer {
                    Some(Ok(reply)) => return Ok(reply),
                    Some(Err(refusal)) => {
                        return Err(StationError::Refused {
                            request: name,
                            refusal: Box::new(refusal),
                        })
                    }
                    None => {}
                }
            }
        }
        Err(StationError::Timeout {
            request: name,
            tries: tries.max(1),
            link: self.transport.describe(),
            received: since(self.decoder.counters(), before),
        })
    }

    /// `request`, whose reply must be `Ack`.
    pub fn command(&mut self, request: Request) -> Result<(), StationError> {
        let name = request.name();
        match self.request(request)? {
            Reply::Ack => Ok(()),
            other => Err(StationError::Unexpected {
                request: name,
                reply: format!("{other:?}"),
            }),
        }
    }

    /// The next message the robot sent on its own, waiting up to `timeout` for one.
    pub fn next_message(&mut self, timeout: Duration) -> Result<Option<Uplink>, StationError> {
        if let Some(message) = self.inbox.pop_front() {
            return Ok(Some(message));
        }
        let messages = self.read(timeout)?;
        self.inbox.extend(
            messages
                .into_iter()
                .filter(|m| !matches!(m, Uplink::Reply { .. })),
        );
        Ok(self.inbox.pop_front())
    }

    /// Sends `request` without waiting for its reply (a heartbeat while recording: its
    /// reply is skipped when it arrives).
    pub fn send_only(&mut self, request: Request) -> Result<(), StationError> {
        self.next_seq = self.next_seq.wrapping_add(1);
        let mut frame = [0u8; MAX_FRAME_LEN];
        if let Ok(len) = encode(
            &Downlink {
                seq: self.next_seq,
                request,
            },
            &mut frame,
        ) {
            self.transport.send(frame.get(..len).unwrap_or_default())?;
        }
        Ok(())
    }

    /// Whatever arrives within `timeout`, decoded; a frame from another protocol is an
    /// error, a corrupted frame is dropped (and counted).
    fn read(&mut self, timeout: Duration) -> Result<Vec<Uplink>, StationError> {
        let mut buf = [0u8; 1024];
        let n = self.transport.receive(&mut buf, timeout)?;
        let mut out = Vec::new();
        for outcome in self
            .decoder
            .feed::<Uplink>(buf.get(..n).unwrap_or_default())
        {
            match outcome {
                Ok(Received::Message(Uplink::VersionMismatch { received })) => {
                    // The robot could not read our frame; its header (already checked to
                    // be ours) says what it speaks, which is what we speak: the difference
                    // is in what it received.
                    return Err(StationError::Mismatch(Mismatch {
                        remote: link::ProtocolId::OURS,
                        local: received,
                    }));
                }
                Ok(Received::Message(message)) => out.push(message),
                Ok(Received::Mismatch(remote)) => {
                    return Err(StationError::Mismatch(Mismatch::with(remote)))
                }
                Err(_) => {}
            }
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn timeout(received: RxCounters) -> String {
        StationError::Timeout {
            request: "Info",
            tries: 8,
            link: "/dev/ttyACM0 at 230400 baud".to_string(),
            received,
        }
        .to_string()
    }

    #[test]
    fn a_timeout_says_what_arrived_and_what_that_points_to() {
        let silent = timeout(RxCounters::default());
        assert!(silent.ends_with("nothing arrived (wrong port or baud rate? robot not powered?)"));
        let corrupted = timeout(RxCounters {
            frames_ok: 3,
            crc_errors: 41,
            format_errors: 2,
            ..RxCounters::default()
        });
        assert!(
            corrupted.contains("41 failed their CRC, 2 were malformed")
                && corrupted.contains("3 were intact: the line corrupts frames")
                && !corrupted.contains("not powered"),
            "{corrupted}"
        );
        let intact = timeout(RxCounters {
            frames_ok: 12,
            ..RxCounters::default()
        });
        assert!(intact.contains("12 frames arrived intact, none of them the reply"));
    }
}
