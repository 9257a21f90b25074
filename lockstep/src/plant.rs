//! What the plant sends: one [`PlantStep`] per control step, and the board's
//! [`StepDecoder`] of it.

use core::num::NonZeroU32;

use controller_core::controller::TickDeltas;

use crate::wire::{Assembler, Parse, Reader, Writer};
use crate::{ToBoard, FINISH, PLANT_STEP_MAX_LEN, STEP_PRESSED_TAG, STEP_TAG};

/// What the board's sensors read for one control step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PlantStep {
    /// Encoder ticks since the previous step, forward positive.
    pub ticks: TickDeltas,
    /// Control periods since the previous step (1 on time, never 0).
    pub periods: NonZeroU32,
    /// The supply measurement, V.
    pub supply_v: f32,
    /// The arm button's raw level, true while pressed.
    pub button_pressed: bool,
}

impl PlantStep {
    /// Writes the message into `out`; its length.
    pub fn encode(&self, out: &mut [u8; PLANT_STEP_MAX_LEN]) -> usize {
        let mut w = Writer { out, at: 0 };
        w.u8(if self.button_pressed {
            STEP_PRESSED_TAG
        } else {
            STEP_TAG
        });
        w.signed(self.ticks.left);
        w.signed(self.ticks.right);
        w.varint(self.periods.get());
        w.f32(self.supply_v);
        w.at
    }

    /// The step in `bytes` (tag included).
    fn parse(bytes: &[u8]) -> Parse<Self> {
        let mut r = Reader { bytes, at: 0 };
        let read = |r: &mut Reader<'_>| {
            let tag = r.u8()?;
            Some((tag, r.signed()?, r.signed()?, r.varint()?, r.f32()?))
        };
        match read(&mut r) {
            None => Parse::Partial,
            Some((tag, left, right, periods, supply_v)) => match NonZeroU32::new(periods) {
                Some(periods) => Parse::Whole(Self {
                    ticks: TickDeltas { left, right },
                    periods,
                    supply_v,
                    button_pressed: tag == STEP_PRESSED_TAG,
                }),
                None => Parse::Invalid,
            },
        }
    }
}

/// The board's decoder of what the plant sends.
#[derive(Clone, Debug)]
pub struct StepDecoder(Assembler<PLANT_STEP_MAX_LEN>);

impl Default for StepDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl StepDecoder {
    /// A decoder waiting for a tag.
    pub const fn new() -> Self {
        Self(Assembler::new())
    }

    /// Takes one received byte; the message it completes, if any.
    pub fn push(&mut self, byte: u8) -> Option<ToBoard> {
        self.0.push(
            byte,
            |tag| matches!(tag, STEP_TAG | STEP_PRESSED_TAG | FINISH),
            |bytes| match bytes.first() {
                Some(&FINISH) => Parse::Whole(ToBoard::Finish),
                _ => match PlantStep::parse(bytes) {
                    Parse::Whole(step) => Parse::Whole(ToBoard::Step(step)),
                    Parse::Partial => Parse::Partial,
                    Parse::Invalid => Parse::Invalid,
                },
            },
        )
    }

    /// Bytes and messages dropped: unknown tags, steps of 0 periods.
    pub const fn errors(&self) -> u32 {
        self.0.errors
    }
}
