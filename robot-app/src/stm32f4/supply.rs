//! The supply (battery) measurement: a resistor divider into an ADC input, the ADC clock
//! and sampling time, and the conversion of a reading to volts.
//!
//! ```text
//!  V_supply ── R_top ──┬── ADC pin           R_top 39 kΩ, R_bottom 10 kΩ, C 100 nF
//!                      R_bottom  C           ratio 0.2041: 12.6 V (3S full) → 2.57 V,
//!  GND ────────────────┴─────────┘           full scale 16.2 V at V_DDA = 3.3 V
//! ```

/// A two-resistor divider from the supply to the ADC input, Ω.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Divider {
    /// From the supply to the ADC input, Ω.
    pub top_ohm: f32,
    /// From the ADC input to ground, Ω.
    pub bottom_ohm: f32,
}

impl Divider {
    /// V_pin / V_supply.
    pub fn ratio(&self) -> f32 {
        self.bottom_ohm / (self.top_ohm + self.bottom_ohm)
    }

    /// The divider's output (Thévenin) resistance seen by the ADC, Ω.
    pub fn source_ohm(&self) -> f32 {
        self.top_ohm * self.bottom_ohm / (self.top_ohm + self.bottom_ohm)
    }

    /// The supply voltage that puts `vref` (V_DDA) on the pin, V.
    pub fn full_scale_v(&self, vref: f32) -> f32 {
        vref / self.ratio()
    }

    /// Corner frequency of the divider with `capacitor_f` from the pin to ground, Hz.
    pub fn corner_hz(&self, capacitor_f: f32) -> f32 {
        1.0 / (core::f32::consts::TAU * self.source_ohm() * capacitor_f)
    }
}

/// The largest 12-bit reading.
pub const ADC_MAX: u16 = 4095;

/// The supply voltage, V, for a 12-bit right-aligned reading `raw` (bits above 11 are
/// ignored) with V_REF+ = `vref` V: V_pin = raw × vref / 4096, V = V_pin / ratio.
pub fn supply_volts(raw: u16, vref: f32, divider: &Divider) -> f32 {
    let pin = f32::from(raw & ADC_MAX) * vref / 4096.0;
    pin / divider.ratio()
}

/// The ADC prescaler (ADC_CCR.ADCPRE): ADCCLK = PCLK2 / 2, 4, 6 or 8.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AdcPrescaler {
    /// PCLK2 / 2 (ADCPRE = 00).
    Div2,
    /// PCLK2 / 4 (ADCPRE = 01).
    Div4,
    /// PCLK2 / 6 (ADCPRE = 10).
    Div6,
    /// PCLK2 / 8 (ADCPRE = 11).
    Div8,
}

impl AdcPrescaler {
    /// The ADCPRE field value.
    pub const fn bits(self) -> u8 {
        match self {
            AdcPrescaler::Div2 => 0b00,
            AdcPrescaler::Div4 => 0b01,
            AdcPrescaler::Div6 => 0b10,
            AdcPrescaler::Div8 => 0b11,
        }
    }

    /// The division of PCLK2.
    pub const fn divider(self) -> u32 {
        (self.bits() as u32 + 1) * 2
    }

    /// The smallest prescaler that keeps ADCCLK at or below `max_adc_hz`, or `None` if
    /// even ÷8 is too fast.
    pub const fn for_pclk2(pclk2_hz: u32, max_adc_hz: u32) -> Option<AdcPrescaler> {
        let all = [
            AdcPrescaler::Div2,
            AdcPrescaler::Div4,
            AdcPrescaler::Div6,
            AdcPrescaler::Div8,
        ];
        let mut i = 0;
        while i < all.len() {
            if pclk2_hz / all[i].divider() <= max_adc_hz {
                return Some(all[i]);
            }
            i += 1;
        }
        None
    }
}

/// An ADC channel sampling time (ADC_SMPRx.SMPy).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SampleTime {
    /// 3 ADCCLK cycles (000).
    Cycles3,
    /// 15 cycles (001).
    Cycles15,
    /// 28 cycles (010).
    Cycles28,
    /// 56 cycles (011).
    Cycles56,
    /// 84 cycles (100).
    Cycles84,
    /// 112 cycles (101).
    Cycles112,
    /// 144 cycles (110).
    Cycles144,
    /// 480 cycles (111).
    Cycles480,
}

impl SampleTime {
    /// The SMPy field value.
    pub const fn bits(self) -> u8 {
        match self {
            SampleTime::Cycles3 => 0,
            SampleTime::Cycles15 => 1,
            SampleTime::Cycles28 => 2,
            SampleTime::Cycles56 => 3,
            SampleTime::Cycles84 => 4,
            SampleTime::Cycles112 => 5,
            SampleTime::Cycles144 => 6,
            SampleTime::Cycles480 => 7,
        }
    }

    /// ADCCLK cycles of sampling.
    pub const fn cycles(self) -> u32 {
        match self {
            SampleTime::Cycles3 => 3,
            SampleTime::Cycles15 => 15,
            SampleTime::Cycles28 => 28,
            SampleTime::Cycles56 => 56,
            SampleTime::Cycles84 => 84,
            SampleTime::Cycles112 => 112,
            SampleTime::Cycles144 => 144,
            SampleTime::Cycles480 => 480,
        }
    }

    /// One 12-bit conversion, s: (sampling + 12) cycles of ADCCLK (RM0383 §11.5).
    pub fn conversion_s(self, adc_hz: u32) -> f32 {
        (self.cycles() + 12) as f32 / adc_hz as f32
    }
}

/// The ADC's sample-and-hold: internal capacitance and switch resistance (DS10314, ADC
/// characteristics: C_ADC 4 pF typical, 7 pF used here as the worst case; R_ADC 6 kΩ
/// max).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SampleAndHold {
    /// C_ADC, F.
    pub capacitance_f: f32,
    /// R_ADC, Ω.
    pub resistance_ohm: f32,
}

/// The STM32F4's sample-and-hold, worst case.
pub const STM32F4_SAMPLE_AND_HOLD: SampleAndHold = SampleAndHold {
    capacitance_f: 7.0e-12,
    resistance_ohm: 6_000.0,
};

/// The largest source resistance, Ω, for which the sample capacitor settles to within
/// ¼ LSB of a 12-bit conversion in `sample` at `adc_hz` (DS10314, ADC characteristics,
/// equation 1: R_AIN < (k − 0.5) / (f_ADC × C_ADC × ln(2^(N+2))) − R_ADC). Negative
/// means no source is fast enough.
pub fn max_source_ohm(sample: SampleTime, adc_hz: u32, sh: SampleAndHold) -> f32 {
    const LN_2_POW_14: f32 = 9.704_061; // ln(2^(12 + 2))
    (sample.cycles() as f32 - 0.5) / (adc_hz as f32 * sh.capacitance_f * LN_2_POW_14)
        - sh.resistance_ohm
}

#[cfg(test)]
mod tests {
    use super::*;

    const DIVIDER: Divider = Divider {
        top_ohm: 39_000.0,
        bottom_ohm: 10_000.0,
    };

    #[test]
    fn divider_maps_a_full_3s_pack_into_range() {
        assert!((DIVIDER.ratio() - 0.204_08).abs() < 1e-5);
        assert!((DIVIDER.full_scale_v(3.3) - 16.17).abs() < 0.01);
        assert!((DIVIDER.source_ohm() - 7_959.2).abs() < 0.1);
        // 100 nF: corner at 200 Hz, 20 kHz PWM ripple attenuated about 100 times.
        assert!((DIVIDER.corner_hz(100e-9) - 199.96).abs() < 0.05);
        // 12.6 V reads as 3191 of 4095.
        let raw = (12.6 * DIVIDER.ratio() / 3.3 * 4096.0) as u16;
        assert_eq!(raw, 3191);
    }

    #[test]
    fn reading_to_volts() {
        assert_eq!(supply_volts(0, 3.3, &DIVIDER), 0.0);
        let v = supply_volts(3191, 3.3, &DIVIDER);
        assert!((v - 12.597).abs() < 0.002, "{v}");
        // One LSB is 3.95 mV at the supply.
        let lsb = supply_volts(1001, 3.3, &DIVIDER) - supply_volts(1000, 3.3, &DIVIDER);
        assert!((lsb - 0.003_948).abs() < 1e-5, "{lsb}");
        // Bits above 11 (a corrupt reading) are masked, not scaled.
        assert_eq!(
            supply_volts(0xF000 | 100, 3.3, &DIVIDER),
            supply_volts(100, 3.3, &DIVIDER)
        );
        assert!(supply_volts(ADC_MAX, 3.3, &DIVIDER) < DIVIDER.full_scale_v(3.3));
    }

    #[test]
    fn adc_clock_per_chip() {
        // F411: PCLK2 100 MHz / 4 = 25 MHz; F401: 84 / 4 = 21 MHz; F446: 50 / 2 = 25 MHz.
        assert_eq!(
            AdcPrescaler::for_pclk2(100_000_000, 36_000_000),
            Some(AdcPrescaler::Div4)
        );
        assert_eq!(
            AdcPrescaler::for_pclk2(84_000_000, 36_000_000),
            Some(AdcPrescaler::Div4)
        );
        assert_eq!(
            AdcPrescaler::for_pclk2(50_000_000, 36_000_000),
            Some(AdcPrescaler::Div2)
        );
        assert_eq!(AdcPrescaler::for_pclk2(300_000_000, 36_000_000), None);
        assert_eq!(AdcPrescaler::Div6.divider(), 6);
    }

    #[test]
    fn sampling_time_covers_the_divider() {
        let adc_hz = 25_000_000;
        let sh = STM32F4_SAMPLE_AND_HOLD;
        // 480 cycles at 25 MHz allow about 276 kOhm; 28 cycles about 10 kOhm; 15 cycles
        // are too short for the 8 kOhm divider without relying on the capacitor.
        let r480 = max_source_ohm(SampleTime::Cycles480, adc_hz, sh);
        assert!((r480 - 276_400.0).abs() < 500.0, "{r480}");
        assert!(max_source_ohm(SampleTime::Cycles28, adc_hz, sh) > DIVIDER.source_ohm());
        assert!(max_source_ohm(SampleTime::Cycles15, adc_hz, sh) < DIVIDER.source_ohm());
        // A conversion at 480 cycles takes 19.7 us, far inside one 1 ms control period.
        let t = SampleTime::Cycles480.conversion_s(adc_hz);
        assert!((t - 19.68e-6).abs() < 0.01e-6, "{t}");
        assert_eq!(SampleTime::Cycles480.bits(), 0b111);
    }
}
