//! How bytes reach the robot: a serial port, or a TCP socket (the virtual robot of
//! `host-sim serve`). Anything else that moves bytes can be a [`Transport`] too: the
//! station's tests drive the virtual robot in their own process, in lockstep.

use std::io::{self, ErrorKind, Read, Write};
use std::net::TcpStream;
use std::time::Duration;

/// A byte pipe to the robot.
pub trait Transport {
    /// Sends all of `bytes`.
    fn send(&mut self, bytes: &[u8]) -> io::Result<()>;
    /// Reads what arrives within about `timeout` into `buf` (0 bytes when nothing did).
    fn receive(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize>;
    /// What the pipe is, for messages (`/dev/ttyACM0 at 230400 baud`, `127.0.0.1:5760`).
    fn describe(&self) -> String;
}

/// A serial port (8N1).
pub struct Serial {
    port: Box<dyn serialport::SerialPort>,
    name: String,
    baud: u32,
}

/// Why a connection could not be made.
#[derive(Debug, thiserror::Error)]
pub enum ConnectError {
    /// The serial port does not exist.
    #[error("no serial port {port}; `station ports` lists the candidates")]
    NoPort {
        /// The path asked for.
        port: String,
    },
    /// The serial port exists but could not be opened.
    #[error(
        "cannot open {port}: {reason} (is another program using it? are you in the dialout group?)"
    )]
    Open {
        /// The path asked for.
        port: String,
        /// What the system said.
        reason: String,
    },
    /// The TCP connection failed: the OS's error is the source.
    #[error("cannot connect to {address} (is `host-sim serve --listen {address}` running?)")]
    Connect {
        /// The address asked for.
        address: String,
        /// What the system said.
        source: io::Error,
    },
}

impl Serial {
    /// Opens `port` at `baud`.
    pub fn open(port: &str, baud: u32) -> Result<Self, ConnectError> {
        if !std::path::Path::new(port).exists() && cfg!(unix) {
            return Err(ConnectError::NoPort {
                port: port.to_string(),
            });
        }
        let opened = serialport::new(port, baud)
            .timeout(Duration::from_millis(20))
            .open()
            .map_err(|e| match e.kind {
                serialport::ErrorKind::NoDevice => ConnectError::NoPort {
                    port: port.to_string(),
                },
                _ => ConnectError::Open {
                    port: port.to_string(),
                    reason: e.description,
                },
            })?;
        Ok(Self {
            port: opened,
            name: port.to_string(),
            baud,
        })
    }
}

impl Transport for Serial {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.port.write_all(bytes)?;
        self.port.flush()
    }

    fn receive(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        self.port
            .set_timeout(timeout.max(Duration::from_millis(1)))?;
        match self.port.read(buf) {
            Ok(n) => Ok(n),
            // A signal (Ctrl-C) interrupts the wait: no bytes; the caller checks its flag.
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted
                ) =>
            {
                Ok(0)
            }
            Err(e) => Err(e),
        }
    }

    fn describe(&self) -> String {
        format!("{} at {} baud", self.name, self.baud)
    }
}

/// The serial ports this machine has: (path, what kind).
pub fn ports() -> Result<Vec<(String, String)>, serialport::Error> {
    let ports = serialport::available_ports()?;
    Ok(ports
        .into_iter()
        .map(|p| {
            let kind = match p.port_type {
                serialport::SerialPortType::UsbPort(usb) => format!(
                    "USB {:04x}:{:04x} {}",
                    usb.vid,
                    usb.pid,
                    usb.product.unwrap_or_default()
                ),
                serialport::SerialPortType::PciPort => "PCI".to_string(),
                serialport::SerialPortType::BluetoothPort => "Bluetooth".to_string(),
                serialport::SerialPortType::Unknown => "unknown".to_string(),
            };
            (p.port_name, kind)
        })
        .collect())
}

/// A TCP connection (the virtual robot of `host-sim serve`).
pub struct Tcp {
    stream: TcpStream,
    address: String,
}

impl Tcp {
    /// Connects to `address` (`127.0.0.1:5760`).
    pub fn connect(address: &str) -> Result<Self, ConnectError> {
        let stream = TcpStream::connect(address).map_err(|source| ConnectError::Connect {
            address: address.to_string(),
            source,
        })?;
        let _ = stream.set_nodelay(true);
        Ok(Self {
            stream,
            address: address.to_string(),
        })
    }
}

impl Transport for Tcp {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.stream.write_all(bytes)
    }

    fn receive(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        self.stream
            .set_read_timeout(Some(timeout.max(Duration::from_millis(1))))?;
        match self.stream.read(buf) {
            Ok(0) => Err(io::Error::new(
                ErrorKind::ConnectionAborted,
                "the robot closed the connection",
            )),
            Ok(n) => Ok(n),
            // A signal (Ctrl-C) interrupts the wait: no bytes; the caller checks its flag.
            Err(e)
                if matches!(
                    e.kind(),
                    ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted
                ) =>
            {
                Ok(0)
            }
            Err(e) => Err(e),
        }
    }

    fn describe(&self) -> String {
        self.address.clone()
    }
}

impl Transport for Box<dyn Transport + '_> {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        (**self).send(bytes)
    }
    fn receive(&mut self, buf: &mut [u8], timeout: Duration) -> io::Result<usize> {
        (**self).receive(buf, timeout)
    }
    fn describe(&self) -> String {
        (**self).describe()
    }
}
