//! What the plant sends: one [`PlantStep`] per control step, and the board's
//! [`StepDecoder`] of it.

use core::num::NonZeroU32;

use controller_core::controller::TickDeltas;
use controller_core::gyro::GyroSample;

use crate::wire::{Assembler, Parse, Reader, Writer};
use crate::{
    ToBoard, FINISH, PLANT_STEP_MAX_LEN, STEP_GYRO_PRESSED_TAG, STEP_GYRO_TAG, STEP_PRESSED_TAG,
    STEP_TAG,
};

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
    /// The gyro's reading for this step, as the F411 board's IMU would hand it over;
    /// `None`: no IMU, or no new sample.
    pub gyro: Option<GyroSample>,
}

/// The tag of a step with this button level and gyro reading.
const fn tag(button_pressed: bool, gyro: bool) -> u8 {
    match (button_pressed, gyro) {
        (false, false) => STEP_TAG,
        (true, false) => STEP_PRESSED_TAG,
        (false, true) => STEP_GYRO_TAG,
        (true, true) => STEP_GYRO_PRESSED_TAG,
    }
}

impl PlantStep {
    /// Writes the message into `out`; its length.
    pub fn encode(&self, out: &mut [u8; PLANT_STEP_MAX_LEN]) -> usize {
        let mut w = Writer { out, at: 0 };
        w.u8(tag(self.button_pressed, self.gyro.is_some()));
        w.signed(self.ticks.left);
        w.signed(self.ticks.right);
        w.varint(self.periods.get());
        w.f32(self.supply_v);
        if let Some(gyro) = self.gyro {
            w.f32(gyro.yaw_rate_radps);
            w.u8(gyro.age_periods);
        }
        w.at
    }

    /// The step in `bytes` (tag included).
    fn parse(bytes: &[u8]) -> Parse<Self> {
        let mut r = Reader { bytes, at: 0 };
        let read = |r: &mut Reader<'_>| {
            let tag = r.u8()?;
            let fields = (r.signed()?, r.signed()?, r.varint()?, r.f32()?);
            let gyro = if matches!(tag, STEP_GYRO_TAG | STEP_GYRO_PRESSED_TAG) {
                Some(GyroSample {
                    yaw_rate_radps: r.f32()?,
                    age_periods: r.u8()?,
                })
            } else {
                None
            };
            Some((tag, fields, gyro))
        };
        match read(&mut r) {
            None => Parse::Partial,
            Some((tag, (left, right, periods, supply_v), gyro)) => match NonZeroU32::new(periods) {
                Some(periods) => Parse::Whole(Self {
                    ticks: TickDeltas { left, right },
                    periods,
                    supply_v,
                    button_pressed: matches!(tag, STEP_PRESSED_TAG | STEP_GYRO_PRESSED_TAG),
                    gyro,
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
            |tag| {
                matches!(
                    tag,
                    STEP_TAG | STEP_PRESSED_TAG | STEP_GYRO_TAG | STEP_GYRO_PRESSED_TAG | FINISH
                )
            },
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
