//! The hosts connected to the virtual robot: the newest connection commands it, the older
//! ones observe.
//!
//! The rule, as `docs/` states it for users:
//!
//! - **Every connection receives everything the robot sends**: replies, telemetry,
//!   events, reports and the ground truth, from the next frame boundary after it
//!   connected. A viewer or a logger can run beside the station that drives the robot.
//! - **Only the newest connection commands.** Its bytes go to the robot's link side, as a
//!   serial line's would. A new connection takes the command from the one before, which
//!   stays connected as an observer; the robot's heartbeat timeout then covers a
//!   commanding host that went quiet, as on the real link.
//! - **An observer's requests are refused**, each with
//!   [`NotPermitted::AnotherHostCommands`] under its own `seq`, so a station that
//!   connects, is overtaken and asks again is told why, instead of waiting for a reply
//!   that never comes.
//! - A connection whose socket falls more than [`MAX_QUEUED_BYTES`] behind is closed: a
//!   stalled observer must not grow the simulator's memory without bound.
//!
//! This is the virtual robot's rule only: a robot on a serial line has one host.

use std::io::{ErrorKind, Read, Write};
use std::net::TcpStream;

use link::{encode, Decoder, Downlink, NotPermitted, Received, Refusal, Uplink, MAX_FRAME_LEN};

/// Bytes a connection may fall behind before it is closed (about 10 s of the link's top
/// telemetry rate with the ground truth).
pub const MAX_QUEUED_BYTES: usize = 1 << 20;

/// The frame delimiter of the link's framing (COBS, then 0x00).
const DELIMITER: u8 = 0x00;

/// One connection and what is queued for it.
struct Host {
    stream: TcpStream,
    /// Bytes for this host, oldest first.
    queued: Vec<u8>,
    /// The robot's stream has reached a frame boundary since this host connected: it
    /// gets whole frames only.
    synced: bool,
    /// The last byte queued ended a frame: a refusal may go in here.
    at_boundary: bool,
    /// Frames this observer sent, decoded to answer each with a refusal.
    decoder: Decoder,
    /// Refusals waiting for the next frame boundary of the robot's stream.
    refusals: Vec<u8>,
}

impl Host {
    /// A host joining the robot's stream; `synced` when the stream is at a frame
    /// boundary now.
    fn new(stream: TcpStream, synced: bool) -> Self {
        Self {
            stream,
            queued: Vec::new(),
            synced,
            at_boundary: true,
            decoder: Decoder::new(),
            refusals: Vec::new(),
        }
    }

    /// Queues the robot's `bytes` from the first frame boundary on, and any refusal that
    /// waited for one.
    fn queue(&mut self, bytes: &[u8]) {
        let mut rest = bytes;
        if !self.synced {
            match rest.iter().position(|&b| b == DELIMITER) {
                Some(end) => {
                    self.synced = true;
                    rest = rest.get(end + 1..).unwrap_or_default();
                }
                None => return,
            }
        }
        if self.at_boundary {
            self.queued.append(&mut self.refusals);
        }
        if let Some(&last) = rest.last() {
            self.queued.extend_from_slice(rest);
            self.at_boundary = last == DELIMITER;
            if self.at_boundary {
                self.queued.append(&mut self.refusals);
            }
        }
    }

    /// Answers every request in `bytes` (from an observer) with a refusal.
    fn refuse(&mut self, bytes: &[u8]) {
        for outcome in self.decoder.feed::<Downlink>(bytes) {
            let Ok(Received::Message(Downlink { seq, .. })) = outcome else {
                continue;
            };
            let reply = Uplink::Reply {
                seq,
                result: Err(Refusal::NotPermitted(NotPermitted::AnotherHostCommands)),
            };
            let mut wire = [0u8; MAX_FRAME_LEN];
            if let Ok(len) = encode(&reply, &mut wire) {
                self.refusals
                    .extend_from_slice(wire.get(..len).unwrap_or_default());
            }
        }
        if self.at_boundary || !self.synced {
            self.queued.append(&mut self.refusals);
        }
    }

    /// Reads what the host sent into `buf`'s chunks, handing each to `take`; false when
    /// the connection is gone.
    fn read(&mut self, buf: &mut [u8], take: &mut dyn FnMut(&mut Self, &[u8])) -> bool {
        loop {
            match self.stream.read(buf) {
                Ok(0) => return false,
                Ok(n) => take(self, buf.get(..n).unwrap_or_default()),
                Err(e) if e.kind() == ErrorKind::WouldBlock => return true,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(_) => return false,
            }
        }
    }

    /// Sends what is queued, as far as the socket takes it now; false when the
    /// connection is gone or too far behind.
    fn flush(&mut self) -> bool {
        while !self.queued.is_empty() {
            match self.stream.write(&self.queued) {
                Ok(0) => return false,
                Ok(n) => {
                    self.queued.drain(..n);
                }
                Err(e) if e.kind() == ErrorKind::WouldBlock => break,
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(_) => return false,
            }
        }
        self.queued.len() <= MAX_QUEUED_BYTES
    }
}

/// Every connection of the virtual robot (module doc): the last one commands, the others
/// observe.
#[derive(Default)]
pub struct Hosts {
    /// Oldest first; the commanding host, if any, is the last.
    hosts: Vec<Host>,
    /// The last host in `hosts` commands (false once it disconnected, until the next
    /// connection).
    commanding: bool,
    /// The robot's stream, as written so far, ends inside a frame.
    inside_frame: bool,
}

impl Hosts {
    /// Adds a connection, which takes the command.
    pub fn connect(&mut self, stream: TcpStream) {
        self.hosts.push(Host::new(stream, !self.inside_frame));
        self.commanding = true;
    }

    /// Connections open.
    #[cfg(test)]
    fn len(&self) -> usize {
        self.hosts.len()
    }

    /// Reads every connection: the commanding host's bytes go to `to_robot`, an
    /// observer's requests are refused. Closed connections are dropped.
    pub fn read(&mut self, buf: &mut [u8], to_robot: &mut dyn FnMut(&[u8])) {
        let last = self.hosts.len().checked_sub(1);
        let commanding = self.commanding;
        let mut lost_commanding = false;
        let mut index = 0;
        self.hosts.retain_mut(|host| {
            let commands = commanding && Some(index) == last;
            index += 1;
            let open = if commands {
                host.read(buf, &mut |_, bytes| to_robot(bytes))
            } else {
                host.read(buf, &mut |host, bytes| host.refuse(bytes))
            };
            lost_commanding |= commands && !open;
            open
        });
        if lost_commanding {
            self.commanding = false;
        }
    }

    /// Queues the robot's `bytes` for every connection and sends what each can take now.
    /// Closed connections, and those too far behind, are dropped.
    pub fn write(&mut self, bytes: &[u8]) {
        if let Some(&last) = bytes.last() {
            self.inside_frame = last != DELIMITER;
        }
        let last = self.hosts.len().checked_sub(1);
        let commanding = self.commanding;
        let mut lost_commanding = false;
        let mut index = 0;
        self.hosts.retain_mut(|host| {
            let commands = commanding && Some(index) == last;
            index += 1;
            host.queue(bytes);
            let open = host.flush();
            lost_commanding |= commands && !open;
            open
        });
        if lost_commanding {
            self.commanding = false;
        }
    }
}

#[cfg(test)]
mod tests {
    use std::net::TcpListener;
    use std::time::{Duration, Instant};

    use link::{Request, Uplink};

    use super::*;

    /// A connected pair: the hosts' side and the peer's.
    fn pair(listener: &TcpListener) -> (TcpStream, TcpStream) {
        let peer = TcpStream::connect(listener.local_addr().expect("bound")).expect("connects");
        let (ours, _) = listener.accept().expect("accepted");
        ours.set_nonblocking(true).expect("non-blocking");
        peer.set_read_timeout(Some(Duration::from_millis(20)))
            .expect("timeout");
        (ours, peer)
    }

    fn frame(message: &Uplink) -> Vec<u8> {
        let mut wire = [0u8; MAX_FRAME_LEN];
        let len = encode(message, &mut wire).expect("fits");
        wire[..len].to_vec()
    }

    fn request(seq: u16) -> Vec<u8> {
        let mut wire = [0u8; MAX_FRAME_LEN];
        let len = encode(
            &Downlink {
                seq,
                request: Request::Info,
            },
            &mut wire,
        )
        .expect("fits");
        wire[..len].to_vec()
    }

    /// Everything `peer` receives within about `wait`, decoded.
    fn received(peer: &mut TcpStream, hosts: &mut Hosts, wait: Duration) -> Vec<Uplink> {
        let mut decoder = Decoder::new();
        let mut out = Vec::new();
        let until = Instant::now() + wait;
        let mut buf = [0u8; 4096];
        while Instant::now() < until {
            hosts.write(&[]);
            if let Ok(n) = peer.read(&mut buf) {
                for m in decoder.feed::<Uplink>(&buf[..n]).flatten() {
                    if let Received::Message(m) = m {
                        out.push(m);
                    }
                }
            }
        }
        out
    }

    #[test]
    fn the_newest_connection_commands_and_the_older_ones_observe() {
        let listener = TcpListener::bind("127.0.0.1:0").expect("a free port");
        let mut hosts = Hosts::default();
        let (ours, mut first) = pair(&listener);
        hosts.connect(ours);
        let (ours, mut second) = pair(&listener);
        hosts.connect(ours);
        assert_eq!(hosts.len(), 2);

        // Both send a request: only the second's reaches the robot.
        first.write_all(&request(7)).expect("sent");
        second.write_all(&request(9)).expect("sent");
        std::thread::sleep(Duration::from_millis(50));
        let mut to_robot = Vec::new();
        let mut buf = [0u8; 4096];
        hosts.read(&mut buf, &mut |b| to_robot.extend_from_slice(b));
        assert_eq!(to_robot, request(9));

        // The robot's frames reach both; the first also gets its refusal, under its seq.
        let ping = frame(&Uplink::Event {
            step: 3,
            event: controller_core::supervisor::Event::FaultsCleared,
        });
        hosts.write(&ping);
        let to_first = received(&mut first, &mut hosts, Duration::from_millis(200));
        let to_second = received(&mut second, &mut hosts, Duration::from_millis(200));
        assert!(to_first.contains(&Uplink::Reply {
            seq: 7,
            result: Err(Refusal::NotPermitted(NotPermitted::AnotherHostCommands)),
        }));
        assert!(to_first
            .iter()
            .any(|m| matches!(m, Uplink::Event { step: 3, .. })));
        assert_eq!(
            to_second,
            vec![Uplink::Event {
                step: 3,
                event: controller_core::supervisor::Event::FaultsCleared
            }]
        );
    }

    #[test]
    fn a_connection_joins_the_robots_stream_at_a_frame_boundary() {
        let listener = TcpListener::bind("127.0.0.1:0").expect("a free port");
        let mut hosts = Hosts::default();
        let (ours, mut peer) = pair(&listener);
        let event = |step| Uplink::Event {
            step,
            event: controller_core::supervisor::Event::FaultsCleared,
        };
        let (one, two) = (frame(&event(1)), frame(&event(2)));
        // The host connects in the middle of frame one: it gets frame two only.
        hosts.write(&one[..3]);
        hosts.connect(ours);
        let mut rest = one[3..].to_vec();
        rest.extend_from_slice(&two[..2]);
        hosts.write(&rest);
        hosts.write(&two[2..]);
        assert_eq!(
            received(&mut peer, &mut hosts, Duration::from_millis(200)),
            vec![event(2)]
        );
    }

    #[test]
    fn a_refusal_waits_for_the_end_of_the_frame_in_flight() {
        let listener = TcpListener::bind("127.0.0.1:0").expect("a free port");
        let mut hosts = Hosts::default();
        let (ours, mut observer) = pair(&listener);
        hosts.connect(ours);
        let (ours, _commanding) = pair(&listener);
        hosts.connect(ours);
        let event = Uplink::Event {
            step: 5,
            event: controller_core::supervisor::Event::FaultsCleared,
        };
        let whole = frame(&event);
        hosts.write(&frame(&event));
        hosts.write(&whole[..4]);
        observer.write_all(&request(11)).expect("sent");
        std::thread::sleep(Duration::from_millis(50));
        let mut buf = [0u8; 4096];
        hosts.read(&mut buf, &mut |_| panic!("an observer reached the robot"));
        hosts.write(&whole[4..]);
        let got = received(&mut observer, &mut hosts, Duration::from_millis(200));
        assert_eq!(got.len(), 3, "{got:?}");
        assert_eq!(got[0], event);
        assert_eq!(got[1], event);
        assert!(matches!(got[2], Uplink::Reply { seq: 11, .. }));
    }

    #[test]
    fn when_the_commanding_host_leaves_no_observer_takes_over() {
        let listener = TcpListener::bind("127.0.0.1:0").expect("a free port");
        let mut hosts = Hosts::default();
        let (ours, mut observer) = pair(&listener);
        hosts.connect(ours);
        let (ours, commanding) = pair(&listener);
        hosts.connect(ours);
        drop(commanding);
        std::thread::sleep(Duration::from_millis(50));
        let mut buf = [0u8; 4096];
        hosts.read(&mut buf, &mut |_| {});
        assert_eq!(hosts.len(), 1);
        observer.write_all(&request(4)).expect("sent");
        std::thread::sleep(Duration::from_millis(50));
        hosts.read(&mut buf, &mut |_| panic!("an observer reached the robot"));
        let got = received(&mut observer, &mut hosts, Duration::from_millis(200));
        assert!(matches!(got[..], [Uplink::Reply { seq: 4, .. }]), "{got:?}");
    }
}
