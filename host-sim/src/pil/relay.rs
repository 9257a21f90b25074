//! The station port: the firmware's link USART, exposed as a TCP port for any ground
//! station, the way the robot exposes it on its serial line.
//!
//! Two threads copy bytes between QEMU's link socket and the station that is connected
//! (one at a time; a new connection replaces nothing until the previous one closed).
//! What the firmware sends while no station is connected is read and dropped, so the
//! emulated USART never blocks. A [`LinkSwitch`] cuts the link both ways, as a cable
//! pulled out: the processor-in-the-loop run's link-loss test.

use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::{Arc, Mutex};
use std::thread::{self, JoinHandle};
use std::time::Duration;

use anyhow::{Context as _, Result};

/// Whether the link carries bytes, and how many it dropped while cut.
#[derive(Debug, Default)]
pub struct LinkSwitch {
    cut: AtomicBool,
    dropped: AtomicU64,
}

impl LinkSwitch {
    /// Cuts the link: from now on nothing passes either way.
    pub fn cut(&self) {
        self.cut.store(true, Ordering::SeqCst);
    }

    /// True once cut.
    pub fn is_cut(&self) -> bool {
        self.cut.load(Ordering::SeqCst)
    }

    /// Bytes dropped because the link was cut.
    pub fn dropped(&self) -> u64 {
        self.dropped.load(Ordering::Relaxed)
    }

    /// True when `n` bytes may pass; counts them as dropped otherwise.
    fn pass(&self, n: usize) -> bool {
        if self.is_cut() {
            self.dropped.fetch_add(n as u64, Ordering::Relaxed);
            return false;
        }
        true
    }
}

/// The running relay.
pub struct Relay {
    /// Where stations connect.
    pub address: SocketAddr,
    stop: Arc<AtomicBool>,
    threads: Vec<JoinHandle<()>>,
}

impl Relay {
    /// Serves `listener` as the station port of the firmware's link socket `firmware`.
    pub fn start(
        listener: TcpListener,
        firmware: TcpStream,
        switch: Arc<LinkSwitch>,
    ) -> Result<Self> {
        let address = listener.local_addr()?;
        let stop = Arc::new(AtomicBool::new(false));
        let station: Arc<Mutex<Option<TcpStream>>> = Arc::new(Mutex::new(None));
        firmware.set_read_timeout(Some(Duration::from_millis(20)))?;
        listener.set_nonblocking(true)?;
        let to_station = {
            let (mut firmware, station, switch, stop) = (
                firmware.try_clone()?,
                Arc::clone(&station),
                Arc::clone(&switch),
                Arc::clone(&stop),
            );
            thread::spawn(move || firmware_to_station(&mut firmware, &station, &switch, &stop))
        };
        let to_firmware = {
            let (station, stop) = (Arc::clone(&station), Arc::clone(&stop));
            thread::spawn(move || {
                station_to_firmware(&listener, firmware, &station, &switch, &stop);
            })
        };
        Ok(Self {
            address,
            stop,
            threads: vec![to_station, to_firmware],
        })
    }

    /// Stops both threads and waits for them.
    pub fn stop(mut self) {
        self.stop.store(true, Ordering::SeqCst);
        for thread in self.threads.drain(..) {
            let _ = thread.join();
        }
    }
}

/// Copies the firmware's bytes to the connected station (or drops them) until QEMU
/// closes the socket or `stop`.
fn firmware_to_station(
    firmware: &mut TcpStream,
    station: &Mutex<Option<TcpStream>>,
    switch: &LinkSwitch,
    stop: &AtomicBool,
) {
    let mut bytes = [0u8; 1024];
    while !stop.load(Ordering::Relaxed) {
        let n = match firmware.read(&mut bytes) {
            Ok(0) => return,
            Ok(n) => n,
            Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => continue,
            Err(_) => return,
        };
        if !switch.pass(n) {
            continue;
        }
        let Ok(mut guard) = station.lock() else {
            return;
        };
        if let Some(stream) = guard.as_mut() {
            if stream.write_all(&bytes[..n]).is_err() {
                *guard = None;
            }
        }
    }
}

/// Accepts stations one after the other and copies their bytes to the firmware until
/// `stop`.
fn station_to_firmware(
    listener: &TcpListener,
    mut firmware: TcpStream,
    station: &Mutex<Option<TcpStream>>,
    switch: &LinkSwitch,
    stop: &AtomicBool,
) {
    let mut bytes = [0u8; 1024];
    while !stop.load(Ordering::Relaxed) {
        let mut reader = match listener.accept() {
            Ok((stream, _)) => stream,
            Err(e) if e.kind() == ErrorKind::WouldBlock => {
                thread::sleep(Duration::from_millis(10));
                continue;
            }
            Err(_) => return,
        };
        let setup = (|| -> Result<TcpStream> {
            reader.set_nonblocking(false)?;
            reader.set_nodelay(true)?;
            reader.set_read_timeout(Some(Duration::from_millis(20)))?;
            reader.try_clone().context("cloning the station's socket")
        })();
        let Ok(writer) = setup else {
            continue;
        };
        if let Ok(mut guard) = station.lock() {
            *guard = Some(writer);
        }
        while !stop.load(Ordering::Relaxed) {
            let n = match reader.read(&mut bytes) {
                Ok(0) => break,
                Ok(n) => n,
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                    continue
                }
                Err(_) => break,
            };
            if switch.pass(n) && firmware.write_all(&bytes[..n]).is_err() {
                return;
            }
        }
        if let Ok(mut guard) = station.lock() {
            *guard = None;
        }
    }
}
