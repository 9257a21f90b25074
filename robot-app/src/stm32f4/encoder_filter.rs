//! The digital input filter of the quadrature-encoder timer inputs (TIMx_CCMR1.IC1F and
//! IC2F), chosen against the shortest real pulse of an encoder channel.
//!
//! A filter setting samples the input at f_SAMPLING and accepts a new level only after N
//! consecutive equal samples (RM0383 §13.4.7, TIMx_CCMR1, IC1F). So a pulse shorter than
//! (N − 1) / f_SAMPLING is always rejected, and a level held for N / f_SAMPLING always
//! passes (delayed by that much). The filter must pass the encoder's shortest real
//! pulse with margin and reject everything shorter, such as the ringing that 20 kHz motor
//! PWM edges couple into the encoder wires.

/// The timer's dead-time and filter clock divider, TIMx_CR1.CKD: t_DTS = CKD × t_CK_INT.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Ckd {
    /// CKD = 00: f_DTS = f_CK_INT (the reset value, and what the HAL leaves).
    Div1,
    /// CKD = 01: f_DTS = f_CK_INT / 2.
    Div2,
    /// CKD = 10: f_DTS = f_CK_INT / 4.
    Div4,
}

impl Ckd {
    /// The divider from f_CK_INT to f_DTS.
    pub const fn divider(self) -> u32 {
        match self {
            Ckd::Div1 => 1,
            Ckd::Div2 => 2,
            Ckd::Div4 => 4,
        }
    }
}

/// What one ICxF code does: the sampling clock and the number of equal samples needed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FilterTiming {
    /// The ICxF field value, 0–15.
    pub code: u8,
    /// f_SAMPLING, Hz.
    pub sample_hz: f32,
    /// N, consecutive equal samples that validate a new level.
    pub samples: u8,
}

impl FilterTiming {
    /// A level held at least this long always passes, s: N / f_SAMPLING.
    pub const fn pass_s(&self) -> f32 {
        self.samples as f32 / self.sample_hz
    }

    /// A pulse shorter than this is always rejected, s: (N − 1) / f_SAMPLING.
    pub const fn reject_s(&self) -> f32 {
        self.samples.saturating_sub(1) as f32 / self.sample_hz
    }
}

/// (f_SAMPLING source divider, N) of each ICxF code: divider 0 means f_CK_INT itself,
/// otherwise f_DTS / divider (RM0383 TIMx_CCMR1, bits IC1F[3:0]).
const CODES: [(u32, u8); 16] = [
    (1, 1),  // 0000: no filter, sampling at f_DTS
    (0, 2),  // 0001: f_CK_INT, N = 2
    (0, 4),  // 0010: f_CK_INT, N = 4
    (0, 8),  // 0011: f_CK_INT, N = 8
    (2, 6),  // 0100: f_DTS/2, N = 6
    (2, 8),  // 0101: f_DTS/2, N = 8
    (4, 6),  // 0110: f_DTS/4, N = 6
    (4, 8),  // 0111: f_DTS/4, N = 8
    (8, 6),  // 1000: f_DTS/8, N = 6
    (8, 8),  // 1001: f_DTS/8, N = 8
    (16, 5), // 1010: f_DTS/16, N = 5
    (16, 6), // 1011: f_DTS/16, N = 6
    (16, 8), // 1100: f_DTS/16, N = 8
    (32, 5), // 1101: f_DTS/32, N = 5
    (32, 6), // 1110: f_DTS/32, N = 6
    (32, 8), // 1111: f_DTS/32, N = 8
];

/// The timing of ICxF `code` (taken modulo 16) on a timer clocked at `timer_clock_hz`
/// with `ckd`.
pub const fn timing(code: u8, timer_clock_hz: u32, ckd: Ckd) -> FilterTiming {
    let code = code & 0xF;
    let (divider, samples) = CODES[code as usize];
    let timer_hz = timer_clock_hz as f32;
    let sample_hz = if divider == 0 {
        timer_hz
    } else {
        timer_hz / (ckd.divider() * divider) as f32
    };
    FilterTiming {
        code,
        sample_hz,
        samples,
    }
}

/// Cycles per second of one encoder channel, Hz: `lines_per_motor_rev` cycles per motor
/// turn, `gear_ratio` motor turns per wheel turn, the wheel at `wheel_speed_rad_s`.
pub const fn channel_frequency_hz(
    lines_per_motor_rev: u32,
    gear_ratio: f32,
    wheel_speed_rad_s: f32,
) -> f32 {
    lines_per_motor_rev as f32 * gear_ratio * wheel_speed_rad_s.abs() / core::f32::consts::TAU
}

/// The shortest high or low time of one channel, s, at `wheel_speed_rad_s`, when the
/// encoder's duty cycle may be as low as `min_duty` (0.5 for an ideal encoder).
pub const fn shortest_pulse_s(
    lines_per_motor_rev: u32,
    gear_ratio: f32,
    wheel_speed_rad_s: f32,
    min_duty: f32,
) -> f32 {
    min_duty / channel_frequency_hz(lines_per_motor_rev, gear_ratio, wheel_speed_rad_s)
}

/// The filter that rejects the longest glitches while still passing any level held for
/// `max_pass_s`: among the codes with [`FilterTiming::pass_s`] ≤ `max_pass_s`, the one
/// with the longest [`FilterTiming::reject_s`]. Code 0 (no filter) if none fits.
pub const fn strongest_filter(timer_clock_hz: u32, ckd: Ckd, max_pass_s: f32) -> FilterTiming {
    let mut best = timing(0, timer_clock_hz, ckd);
    let mut code = 1;
    while code < 16 {
        let t = timing(code, timer_clock_hz, ckd);
        if t.pass_s() <= max_pass_s && t.reject_s() > best.reject_s() {
            best = t;
        }
        code += 1;
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reference_robot_shortest_pulse() {
        // 12 lines, 1:30: 360 cycles per channel per wheel turn. At 200 rad/s (twice the
        // core's plausibility limit of 100 rad/s; the motor's no-load speed at 12.6 V is
        // about 76 rad/s) a channel runs at 11.46 kHz: 87.3 us per cycle, 43.6 us per
        // half-cycle, 21.8 us for a 25 % duty pulse.
        let f = channel_frequency_hz(12, 30.0, 200.0);
        assert!((f - 11_459.2).abs() < 0.5, "{f}");
        let pulse = shortest_pulse_s(12, 30.0, -200.0, 0.25);
        assert!((pulse - 21.82e-6).abs() < 0.01e-6, "{pulse}");
    }

    #[test]
    fn code_table_at_100_mhz() {
        let t = timing(0b1111, 100_000_000, Ckd::Div1);
        assert_eq!((t.sample_hz, t.samples), (3_125_000.0, 8));
        assert!((t.pass_s() - 2.56e-6).abs() < 1e-12);
        assert!((t.reject_s() - 2.24e-6).abs() < 1e-12);
        // Codes 1-3 sample at f_CK_INT whatever CKD is.
        let t = timing(0b0011, 100_000_000, Ckd::Div4);
        assert_eq!((t.sample_hz, t.samples), (100_000_000.0, 8));
        // CKD /2 halves f_DTS for the other codes.
        let t = timing(0b1111, 100_000_000, Ckd::Div2);
        assert!((t.pass_s() - 5.12e-6).abs() < 1e-12);
        assert_eq!(timing(0, 100_000_000, Ckd::Div1).reject_s(), 0.0);
    }

    #[test]
    fn chosen_filter_for_each_chip_passes_the_shortest_pulse_four_times_over() {
        let pulse = shortest_pulse_s(12, 30.0, 200.0, 0.25);
        // F411/F446 timer clock 100/50 MHz, F401 84 MHz.
        for clock in [100_000_000, 84_000_000, 50_000_000] {
            let t = strongest_filter(clock, Ckd::Div1, pulse / 4.0);
            assert_eq!(t.code, 0b1111, "{clock}");
            assert!(t.pass_s() * 4.0 <= pulse);
            // Rejects glitches shorter than 2.24 us (100 MHz) to 4.48 us (50 MHz).
            assert!(t.reject_s() >= 2.2e-6);
        }
        // A faster encoder that leaves 4 us: the strongest filter passing 1 us.
        let t = strongest_filter(100_000_000, Ckd::Div1, 1.0e-6);
        assert!(t.pass_s() <= 1.0e-6 && t.code != 0);
        assert_eq!(t.code, 0b1011); // f_DTS/16, N = 6: passes 0.96 us, rejects < 0.8 us
                                    // Nothing fits a 10 ns pass time: no filter.
        assert_eq!(strongest_filter(100_000_000, Ckd::Div1, 1.0e-8).code, 0);
    }
}
