//! The lockstep port between an emulated board and a simulated plant: the firmware's
//! `qemu` board and `host-sim pil`, over one emulated USART.
//!
//! The plant owns time. Each [`PlantStep`] it sends carries what the board's sensors
//! read for one control step (encoder ticks, the periods since the previous step, the
//! supply measurement, the button, and the gyro's reading when there is one) and
//! triggers exactly one control step; the board
//! answers with one [`BoardStep`] (the duties, the bridge, the supervisor's decision and
//! the controller's estimate), and the plant advances only after it has that answer. So
//! the closed loop computes the same numbers however fast or slow either side runs, and
//! however the host's bytes fall against the emulator's virtual time.
//!
//! ```text
//!  board ─► READY ('R', once, after both USARTs are enabled)
//!  plant ─► PlantStep   ('S', 'P' with the button pressed; 8 bytes typically;    ┐ one
//!                        'G', 'H' the same with a gyro reading, 5 bytes more)     │
//!  board ─► BoardStep   ('A' 10 bytes, or 'D' 40 bytes or more with the details)    ┘ step
//!  …
//!  plant ─► FINISH ('F')
//!  board ─► BoardReport ('F' + 80 bytes), then the emulator exits
//! ```
//!
//! Messages are short because the emulated USART is slow: QEMU hands the guest one byte
//! per main-loop turn (about 0.1 ms each, measured), so bytes per step set the run's
//! speed. Integers are LEB128 varints (zig-zag for signed), `f32` their four IEEE bytes,
//! little-endian, so values cross exactly. A [`BoardStep`] carries its details (faults,
//! event, counters, the controller's pose and error) only when the steering law ran or
//! one of them changed; the [`BoardDecoder`] keeps the last ones, so every decoded step
//! is whole.
//!
//! The transport (a TCP socket behind the emulated USART) neither loses nor corrupts
//! bytes, so there is no checksum; a byte that is no known tag, or a step whose period
//! count is 0, is dropped and counted ([`StepDecoder::errors`]), and the plant then times
//! out waiting for the answer.

#![cfg_attr(not(test), no_std)]
#![deny(missing_docs)]
#![forbid(unsafe_code)]

mod board;
mod plant;
mod report;
mod wire;

pub use self::board::{BoardDecoder, BoardEncoder, BoardStep};
pub use self::plant::{PlantStep, StepDecoder};
pub use self::report::{BoardReport, TaskFigures};

/// The board's first byte on the port: both USARTs are enabled, send.
pub const READY: u8 = b'R';
/// Tag of a [`PlantStep`] with the button released.
pub const STEP_TAG: u8 = b'S';
/// Tag of a [`PlantStep`] with the button pressed.
pub const STEP_PRESSED_TAG: u8 = b'P';
/// Tag of a [`PlantStep`] with the button released and a gyro reading.
pub const STEP_GYRO_TAG: u8 = b'G';
/// Tag of a [`PlantStep`] with the button pressed and a gyro reading.
pub const STEP_GYRO_PRESSED_TAG: u8 = b'H';
/// Tag of a [`BoardStep`] without its details (the decoder repeats the last ones).
pub const BOARD_STEP_TAG: u8 = b'A';
/// Tag of a [`BoardStep`] with its details.
pub const BOARD_DETAIL_TAG: u8 = b'D';
/// The plant's last message, and the tag of the board's [`BoardReport`] that answers it.
pub const FINISH: u8 = b'F';

/// Most bytes of a [`PlantStep`] on the wire: tag, three varints of up to 5 bytes, an
/// `f32`, and the gyro's reading (an `f32` and its age, one byte).
pub const PLANT_STEP_MAX_LEN: usize = 1 + 3 * 5 + 4 + 4 + 1;
/// Most bytes of a [`BoardStep`] on the wire: tag, two `f32`, the status byte, and the
/// details (faults, event, two varint counters, six `f32`).
pub const BOARD_STEP_MAX_LEN: usize = 1 + 8 + 1 + 2 + 2 + 2 * 5 + 24;
/// Most bytes of any message the board sends: a [`BoardStep`] or a [`BoardReport`].
pub(crate) const BOARD_MESSAGE_MAX_LEN: usize = if BOARD_STEP_MAX_LEN > BOARD_REPORT_LEN {
    BOARD_STEP_MAX_LEN
} else {
    BOARD_REPORT_LEN
};
/// Bytes of a [`BoardReport`] on the wire, tag included.
pub const BOARD_REPORT_LEN: usize = 1 + 6 * 3 * 4 + 2 * 4;

/// What the plant sends.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ToBoard {
    /// One control step.
    Step(PlantStep),
    /// The run is over: report and stop.
    Finish,
}

/// What the board sends (after [`READY`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum FromBoard {
    /// The answer to a [`PlantStep`].
    Step(BoardStep),
    /// The answer to [`FINISH`].
    Report(BoardReport),
}

#[cfg(test)]
mod tests;
