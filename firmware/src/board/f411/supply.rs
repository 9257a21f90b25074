//! The supply voltage on PA1 (ADC1 channel 1) through the divider of
//! `board::SUPPLY_DIVIDER`, read without ever waiting.
//!
//! One software-started conversion per control step: [`Supply::start`] at the end of a
//! step, [`Supply::read_volts`] at the start of the next, 1 ms later, long after the
//! 19.7 µs conversion has finished. If it has not (EOC clear), the previous value stays.
//!
//! Registers (RM0383 §11.12): ADC_CCR.ADCPRE = [`ADC_PRESCALER`] (÷4: 25 MHz from the
//! F411's 100 MHz PCLK2, the limit is 36 MHz); CR1 = 0 (12 bits, no scan); CR2: ALIGN = 0
//! (right), CONT = 0 (single), EOCS = 0, ADON = 1; SMPR2.SMP1 = 480 cycles; SQR1.L = 0
//! (one conversion); SQR3.SQ1 = 1. The first conversion starts at the end of the first
//! control step, well after the ADC's power-up time (t_STAB, a few µs).

use robot_app::stm32f4::supply::supply_volts;
use stm32f4xx_hal::gpio::{Analog, PA1};
use stm32f4xx_hal::pac;
use stm32f4xx_hal::rcc::{Enable, Rcc, Reset};

use super::{ADC_PRESCALER, ADC_REFERENCE_V, SUPPLY_DIVIDER, SUPPLY_SAMPLE_TIME};

/// ADC1 channel of PA1.
const CHANNEL: u8 = 1;

/// The supply measurement.
pub struct Supply {
    adc: pac::ADC1,
    _pin: PA1<Analog>,
    latest_v: Option<f32>,
}

impl Supply {
    /// Configures ADC1 for single conversions of PA1; nothing is converted yet.
    pub fn new(adc: pac::ADC1, common: &pac::ADC_COMMON, pin: PA1<Analog>, rcc: &mut Rcc) -> Self {
        pac::ADC1::enable(rcc);
        pac::ADC1::reset(rcc);
        // SAFETY: ADCPRE is a 2-bit field; `bits` is 0..=3.
        common
            .ccr()
            .modify(|_, w| unsafe { w.adcpre().bits(ADC_PRESCALER.bits()) });
        adc.cr1().write(|w| w);
        // SAFETY: SMPx is a 3-bit field and `bits` is 0..=7; L = 0 is one conversion; SQ1
        // is a 5-bit channel number.
        adc.smpr2()
            .modify(|_, w| unsafe { w.smp(CHANNEL).bits(SUPPLY_SAMPLE_TIME.bits()) });
        adc.sqr1().write(|w| w.l().set(0));
        adc.sqr3().write(|w| unsafe { w.sq1().bits(CHANNEL) });
        adc.cr2().write(|w| w.adon().set_bit());
        Self {
            adc,
            _pin: pin,
            latest_v: None,
        }
    }

    /// Starts one conversion (returns at once).
    pub fn start(&mut self) {
        self.adc.cr2().modify(|_, w| w.swstart().set_bit());
    }

    /// The supply voltage, V, from the conversion started by the last [`Supply::start`]
    /// if it has finished (reading DR clears EOC), else the previous value; `None` until
    /// the first conversion.
    pub fn read_volts(&mut self) -> Option<f32> {
        if self.adc.sr().read().eoc().bit_is_set() {
            let raw = self.adc.dr().read().data().bits();
            self.latest_v = Some(supply_volts(raw, ADC_REFERENCE_V, &SUPPLY_DIVIDER));
        }
        self.latest_v
    }
}
