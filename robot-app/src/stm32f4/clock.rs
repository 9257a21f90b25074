//! The clock tree: main PLL parameters, flash wait states, the regulator's voltage scale
//! and the bus prescalers, computed and checked against the limits in [`Chip`], and the
//! decoding of RCC_PLLCFGR / RCC_CFGR / FLASH_ACR for checking what was really written.
//!
//! Frequencies are in Hz throughout.

use core::fmt;

use super::chip::{Chip, VoltageScale};

/// Why a clock configuration is not allowed, naming the quantity and its value.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ClockError {
    /// PLLM outside 2–63, Hz-free: the divider value.
    PllM(u8),
    /// PLLN outside the chip's range.
    PllN(u16),
    /// PLLP not one of 2, 4, 6, 8.
    PllP(u8),
    /// PLLQ outside 2–15.
    PllQ(u8),
    /// VCO input (source / PLLM) outside 1–2 MHz, Hz.
    VcoInput(u32),
    /// VCO output outside the chip's range, Hz.
    VcoOutput(u32),
    /// PLL48CLK above 48 MHz, Hz.
    Pll48(u32),
    /// No PLLM/PLLN/PLLP gives exactly this SYSCLK from the source, Hz.
    NoExactPll(u32),
    /// HCLK above the highest voltage scale's limit, Hz.
    Hclk(u32),
    /// No APB prescaler (1–16) brings HCLK under the APB limit, Hz.
    Apb(u32),
    /// A prescaler field value that is not a divider, raw bits.
    PrescalerBits(u8),
}

impl fmt::Display for ClockError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            ClockError::PllM(m) => write!(f, "PLLM must be in 2..=63, got {m}"),
            ClockError::PllN(n) => write!(f, "PLLN outside the chip's range, got {n}"),
            ClockError::PllP(p) => write!(f, "PLLP must be 2, 4, 6 or 8, got {p}"),
            ClockError::PllQ(q) => write!(f, "PLLQ must be in 2..=15, got {q}"),
            ClockError::VcoInput(hz) => write!(f, "VCO input must be 1-2 MHz, got {hz} Hz"),
            ClockError::VcoOutput(hz) => {
                write!(f, "VCO output outside the chip's range, got {hz} Hz")
            }
            ClockError::Pll48(hz) => write!(f, "PLL48CLK must be <= 48 MHz, got {hz} Hz"),
            ClockError::NoExactPll(hz) => write!(f, "no PLL setting gives exactly {hz} Hz"),
            ClockError::Hclk(hz) => write!(f, "HCLK above the chip's maximum, got {hz} Hz"),
            ClockError::Apb(hz) => write!(f, "no APB prescaler fits HCLK {hz} Hz"),
            ClockError::PrescalerBits(b) => write!(f, "not a prescaler field value: {b:#b}"),
        }
    }
}

impl core::error::Error for ClockError {}

/// Main PLL parameters (RCC_PLLCFGR): f_VCO = f_source × N / M, SYSCLK = f_VCO / P,
/// PLL48CLK = f_VCO / Q.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PllConfig {
    /// Input divider PLLM, 2–63.
    pub m: u8,
    /// Multiplier PLLN (chip range, [`Chip::plln_range`]).
    pub n: u16,
    /// SYSCLK divider PLLP: 2, 4, 6 or 8.
    pub p: u8,
    /// 48 MHz-domain divider PLLQ, 2–15.
    pub q: u8,
}

/// The frequencies a [`PllConfig`] produces, Hz.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PllOutput {
    /// VCO input, source / M.
    pub vco_in_hz: u32,
    /// VCO output, VCO input × N.
    pub vco_out_hz: u32,
    /// SYSCLK, VCO output / P.
    pub sysclk_hz: u32,
    /// PLL48CLK (USB, SDIO, RNG), VCO output / Q.
    pub pll48_hz: u32,
}

/// RCC_PLLCFGR field positions (RM0383 §6.3.2; the same on RM0368 and RM0390).
const PLLM_MASK: u32 = 0x3F;
const PLLN_SHIFT: u32 = 6;
const PLLN_MASK: u32 = 0x1FF;
const PLLP_SHIFT: u32 = 16;
const PLLQ_SHIFT: u32 = 24;
const PLLQ_MASK: u32 = 0xF;

impl PllConfig {
    /// The frequencies this setting gives from `source_hz`, or the first RM limit it
    /// breaks on `chip`: PLLM 2–63, VCO input 1–2 MHz, PLLN and VCO output in the chip's
    /// range, PLLP ∈ {2, 4, 6, 8}, PLLQ 2–15 with PLL48CLK ≤ 48 MHz.
    pub const fn check(&self, chip: Chip, source_hz: u32) -> Result<PllOutput, ClockError> {
        if self.m < 2 || self.m > 63 {
            return Err(ClockError::PllM(self.m));
        }
        let vco_in_hz = source_hz / self.m as u32;
        if source_hz % self.m as u32 != 0 || vco_in_hz < 1_000_000 || vco_in_hz > 2_000_000 {
            return Err(ClockError::VcoInput(vco_in_hz));
        }
        let (n_min, n_max) = chip.plln_range();
        if self.n < n_min || self.n > n_max {
            return Err(ClockError::PllN(self.n));
        }
        let vco_out_hz = vco_in_hz * self.n as u32;
        let (vco_min, vco_max) = chip.vco_range_hz();
        if vco_out_hz < vco_min || vco_out_hz > vco_max {
            return Err(ClockError::VcoOutput(vco_out_hz));
        }
        if !matches!(self.p, 2 | 4 | 6 | 8) {
            return Err(ClockError::PllP(self.p));
        }
        if self.q < 2 || self.q > 15 {
            return Err(ClockError::PllQ(self.q));
        }
        let pll48_hz = vco_out_hz / self.q as u32;
        if pll48_hz > 48_000_000 {
            return Err(ClockError::Pll48(pll48_hz));
        }
        Ok(PllOutput {
            vco_in_hz,
            vco_out_hz,
            sysclk_hz: vco_out_hz / self.p as u32,
            pll48_hz,
        })
    }

    /// The PLLM, PLLN, PLLP and PLLQ fields of an RCC_PLLCFGR value (PLLSRC and the
    /// reserved bits ignored).
    pub const fn from_pllcfgr(bits: u32) -> PllConfig {
        PllConfig {
            m: (bits & PLLM_MASK) as u8,
            n: ((bits >> PLLN_SHIFT) & PLLN_MASK) as u16,
            p: (((bits >> PLLP_SHIFT) & 0b11) as u8 + 1) * 2,
            q: ((bits >> PLLQ_SHIFT) & PLLQ_MASK) as u8,
        }
    }

    /// This setting as RCC_PLLCFGR's M, N, P and Q fields (PLLSRC = 0, i.e. HSI).
    pub const fn pllcfgr_fields(&self) -> u32 {
        (self.m as u32 & PLLM_MASK)
            | ((self.n as u32 & PLLN_MASK) << PLLN_SHIFT)
            | (((self.p as u32 / 2).saturating_sub(1) & 0b11) << PLLP_SHIFT)
            | ((self.q as u32 & PLLQ_MASK) << PLLQ_SHIFT)
    }
}

/// The PLL setting stm32f4xx-hal 0.23 writes for `sysclk_hz` from `source_hz` (no
/// 48 MHz clock requested), if it gives exactly `sysclk_hz` within the limits of `chip`.
///
/// The HAL's search (`rcc::pll::MainPll::fast_setup`), which the firmware cannot
/// override: P is the largest even divider up to 8 that keeps P × SYSCLK ≤ 432 MHz; M
/// runs from ⌈source / 2 MHz⌉ to ⌊source / 1 MHz⌋ and the first one whose whole-Hz VCO
/// input reaches P × SYSCLK with the smallest shortfall wins, so the VCO input is as
/// close to RM0383's recommended 2 MHz as an exact setting allows; N = P × SYSCLK / VCO
/// input; Q is the smallest that keeps PLL48CLK ≤ 48 MHz. For 100 MHz this gives:
///
/// | source | M / N / P / Q | VCO in / out |
/// |---|---|---|
/// | HSI, 16 MHz | 8 / 200 / 4 / 9 | 2 / 400 MHz |
/// | HSE, 25 MHz (Black Pill crystal) | 16 / 256 / 4 / 9 | 1.5625 / 400 MHz |
/// | HSE, 8 MHz (Nucleo, ST-LINK MCO) | 4 / 200 / 4 / 9 | 2 / 400 MHz |
///
/// From 25 MHz no whole M gives 2 MHz (M = 13 gives 1.92 MHz, exact only as a fraction,
/// which the HAL's whole-Hz arithmetic does not find); 1.5625 MHz is inside RM0383's
/// 1–2 MHz range, and the jitter 2 MHz would save matters for USB and I2S, which the robot
/// does not use.
pub const fn pll_for(chip: Chip, source_hz: u32, sysclk_hz: u32) -> Result<PllConfig, ClockError> {
    if sysclk_hz == 0 {
        return Err(ClockError::NoExactPll(sysclk_hz));
    }
    let p = {
        let even = (432_000_000 / sysclk_hz) & !1;
        if even > 8 {
            8
        } else {
            even
        }
    };
    if p < 2 {
        return Err(ClockError::NoExactPll(sysclk_hz));
    }
    let target = sysclk_hz as u64 * p as u64;
    let m_min = source_hz.div_ceil(2_000_000);
    let m_max = source_hz / 1_000_000;
    let mut best: Option<(u32, u64)> = None;
    let mut m = if m_min < 1 { 1 } else { m_min };
    while m <= m_max {
        let vco_in = (source_hz / m) as u64;
        let shortfall = target - vco_in * (target / vco_in);
        let better = match best {
            Some((_, least)) => shortfall < least,
            None => true,
        };
        if better {
            best = Some((m, shortfall));
        }
        m += 1;
    }
    let Some((m, 0)) = best else {
        return Err(ClockError::NoExactPll(sysclk_hz));
    };
    let vco_in = (source_hz / m) as u64;
    let n = target / vco_in;
    let q = target.div_ceil(48_000_000);
    let candidate = PllConfig {
        m: if m > u8::MAX as u32 { 0 } else { m as u8 },
        n: if n > u16::MAX as u64 { 0 } else { n as u16 },
        p: p as u8,
        q: if q > u8::MAX as u64 { 0 } else { q as u8 },
    };
    match candidate.check(chip, source_hz) {
        Ok(out) if out.sysclk_hz == sysclk_hz => Ok(candidate),
        Ok(_) => Err(ClockError::NoExactPll(sysclk_hz)),
        Err(e) => Err(e),
    }
}

/// Flash wait states (FLASH_ACR.LATENCY) for `hclk_hz` at 2.7–3.6 V: the smallest count
/// whose HCLK bound in [`Chip::flash_wait_state_limits_hz`] covers it.
pub const fn flash_wait_states(chip: Chip, hclk_hz: u32) -> Result<u8, ClockError> {
    let limits = chip.flash_wait_state_limits_hz();
    let mut i = 0;
    while i < limits.len() {
        if hclk_hz <= limits[i] {
            return Ok(i as u8);
        }
        i += 1;
    }
    Err(ClockError::Hclk(hclk_hz))
}

/// The lowest-power voltage scale (PWR_CR.VOS) whose HCLK limit covers `hclk_hz`.
pub const fn required_scale(chip: Chip, hclk_hz: u32) -> Result<VoltageScale, ClockError> {
    let limits = chip.scale_limits_hz();
    let mut i = 0;
    while i < limits.len() {
        if hclk_hz <= limits[i].1 {
            return Ok(limits[i].0);
        }
        i += 1;
    }
    Err(ClockError::Hclk(hclk_hz))
}

/// The smallest APB divider (1, 2, 4, 8, 16) that keeps `hclk_hz / divider` at or below
/// `max_hz`.
pub const fn apb_divider(hclk_hz: u32, max_hz: u32) -> Result<u8, ClockError> {
    let mut div: u32 = 1;
    while div <= 16 {
        if hclk_hz / div <= max_hz && hclk_hz % div == 0 {
            return Ok(div as u8);
        }
        div *= 2;
    }
    Err(ClockError::Apb(hclk_hz))
}

/// The clock of the timers on an APB bus, Hz: the bus clock when its divider is 1, twice
/// the bus clock otherwise (RM0383 §6.2, clock tree; TIMPRE = 0 on the STM32F446).
pub const fn timer_clock_hz(pclk_hz: u32, apb_divider: u8) -> u32 {
    if apb_divider == 1 {
        pclk_hz
    } else {
        pclk_hz * 2
    }
}

/// The divider an RCC_CFGR.PPREx field (3 bits) selects: `0xx` → 1, `100` → 2, `101`
/// → 4, `110` → 8, `111` → 16.
pub const fn apb_divider_from_ppre(bits: u8) -> u8 {
    if bits & 0b100 == 0 {
        1
    } else {
        2 << (bits & 0b11)
    }
}

/// The divider an RCC_CFGR.HPRE field (4 bits) selects: `0xxx` → 1, `1000`–`1011` → 2,
/// 4, 8, 16, `1100`–`1111` → 64, 128, 256, 512 (there is no 32).
pub const fn ahb_divider_from_hpre(bits: u8) -> u16 {
    match bits & 0xF {
        0b1000 => 2,
        0b1001 => 4,
        0b1010 => 8,
        0b1011 => 16,
        0b1100 => 64,
        0b1101 => 128,
        0b1110 => 256,
        0b1111 => 512,
        _ => 1,
    }
}

/// RCC_CFGR.SWS (bits 3:2) when SYSCLK runs from the main PLL.
pub const SWS_PLL: u8 = 0b10;

/// RCC_PLLCFGR.PLLSRC (bit 22): set when the PLL runs from the HSE, clear for the HSI.
pub const PLLSRC_HSE: u32 = 1 << 22;

/// The bus and timer clocks, Hz.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ClockTree {
    /// SYSCLK.
    pub sysclk_hz: u32,
    /// HCLK (core, AHB, DWT cycle counter).
    pub hclk_hz: u32,
    /// PCLK1 (APB1).
    pub pclk1_hz: u32,
    /// PCLK2 (APB2; the ADC clock is derived from it).
    pub pclk2_hz: u32,
    /// Clock of the APB1 timers (TIM2–TIM5).
    pub timclk1_hz: u32,
    /// Clock of the APB2 timers (TIM1, TIM9–TIM11).
    pub timclk2_hz: u32,
}

impl ClockTree {
    /// True when `self` and `other` give every bus and timer the same clock (a `const`
    /// comparison, for compile-time checks).
    pub const fn same_as(&self, other: &ClockTree) -> bool {
        self.sysclk_hz == other.sysclk_hz
            && self.hclk_hz == other.hclk_hz
            && self.pclk1_hz == other.pclk1_hz
            && self.pclk2_hz == other.pclk2_hz
            && self.timclk1_hz == other.timclk1_hz
            && self.timclk2_hz == other.timclk2_hz
    }

    /// The tree for `sysclk_hz` and RCC_CFGR's HPRE (bits 7:4), PPRE1 (12:10) and PPRE2
    /// (15:13) fields taken from `cfgr`.
    pub const fn from_cfgr(sysclk_hz: u32, cfgr: u32) -> ClockTree {
        let hclk_hz = sysclk_hz / ahb_divider_from_hpre(((cfgr >> 4) & 0xF) as u8) as u32;
        let ppre1 = apb_divider_from_ppre(((cfgr >> 10) & 0b111) as u8);
        let ppre2 = apb_divider_from_ppre(((cfgr >> 13) & 0b111) as u8);
        let pclk1_hz = hclk_hz / ppre1 as u32;
        let pclk2_hz = hclk_hz / ppre2 as u32;
        ClockTree {
            sysclk_hz,
            hclk_hz,
            pclk1_hz,
            pclk2_hz,
            timclk1_hz: timer_clock_hz(pclk1_hz, ppre1),
            timclk2_hz: timer_clock_hz(pclk2_hz, ppre2),
        }
    }

    /// The first limit of `chip` this tree breaks (HCLK, PCLK1, PCLK2), if any.
    pub const fn check(&self, chip: Chip) -> Result<(), ClockError> {
        if self.hclk_hz > chip.max_hclk_hz() || self.sysclk_hz > chip.max_hclk_hz() {
            return Err(ClockError::Hclk(self.hclk_hz));
        }
        if self.pclk1_hz > chip.max_pclk1_hz() || self.pclk2_hz > chip.max_pclk2_hz() {
            return Err(ClockError::Apb(self.hclk_hz));
        }
        Ok(())
    }
}

/// A complete clock configuration: SYSCLK from the PLL, HCLK = SYSCLK, the smallest APB
/// dividers within the chip's limits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ClockPlan {
    /// The main PLL.
    pub pll: PllConfig,
    /// What the PLL gives.
    pub pll_output: PllOutput,
    /// APB1 divider (1–16).
    pub apb1_divider: u8,
    /// APB2 divider (1–16).
    pub apb2_divider: u8,
    /// The resulting bus and timer clocks.
    pub tree: ClockTree,
    /// FLASH_ACR.LATENCY for HCLK at 2.7–3.6 V.
    pub flash_wait_states: u8,
    /// The lowest voltage scale rated for HCLK.
    pub scale: VoltageScale,
}

/// The clock plan for `sysclk_hz` from `source_hz` on `chip`: PLL by [`pll_for`], AHB
/// divider 1, APB dividers by [`apb_divider`], wait states by [`flash_wait_states`],
/// voltage scale by [`required_scale`].
pub const fn plan(chip: Chip, source_hz: u32, sysclk_hz: u32) -> Result<ClockPlan, ClockError> {
    let pll = match pll_for(chip, source_hz, sysclk_hz) {
        Ok(pll) => pll,
        Err(e) => return Err(e),
    };
    let pll_output = match pll.check(chip, source_hz) {
        Ok(out) => out,
        Err(e) => return Err(e),
    };
    let hclk_hz = pll_output.sysclk_hz;
    let apb1_divider = match apb_divider(hclk_hz, chip.max_pclk1_hz()) {
        Ok(d) => d,
        Err(e) => return Err(e),
    };
    let apb2_divider = match apb_divider(hclk_hz, chip.max_pclk2_hz()) {
        Ok(d) => d,
        Err(e) => return Err(e),
    };
    let flash_wait_states = match flash_wait_states(chip, hclk_hz) {
        Ok(ws) => ws,
        Err(e) => return Err(e),
    };
    let scale = match required_scale(chip, hclk_hz) {
        Ok(s) => s,
        Err(e) => return Err(e),
    };
    let pclk1_hz = hclk_hz / apb1_divider as u32;
    let pclk2_hz = hclk_hz / apb2_divider as u32;
    let tree = ClockTree {
        sysclk_hz: pll_output.sysclk_hz,
        hclk_hz,
        pclk1_hz,
        pclk2_hz,
        timclk1_hz: timer_clock_hz(pclk1_hz, apb1_divider),
        timclk2_hz: timer_clock_hz(pclk2_hz, apb2_divider),
    };
    match tree.check(chip) {
        Ok(()) => {}
        Err(e) => return Err(e),
    }
    Ok(ClockPlan {
        pll,
        pll_output,
        apb1_divider,
        apb2_divider,
        tree,
        flash_wait_states,
        scale,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stm32f4::chip::HSI_HZ;

    #[test]
    fn f411_at_100_mhz_from_hsi() {
        let plan = plan(Chip::F411, HSI_HZ, 100_000_000).unwrap();
        assert_eq!(
            plan.pll,
            PllConfig {
                m: 8,
                n: 200,
                p: 4,
                q: 9
            }
        );
        assert_eq!(plan.pll_output.vco_in_hz, 2_000_000);
        assert_eq!(plan.pll_output.vco_out_hz, 400_000_000);
        assert_eq!(plan.pll_output.pll48_hz, 44_444_444);
        // RM0383 Table 5, 2.7-3.6 V: 90 MHz < HCLK <= 100 MHz needs 3 wait states.
        assert_eq!(plan.flash_wait_states, 3);
        // DS10314: above 84 MHz only scale 1 is rated.
        assert_eq!(plan.scale, VoltageScale::Scale1);
        // APB1 is limited to 50 MHz: divider 2, so its timers run at 2 x 50 MHz.
        assert_eq!((plan.apb1_divider, plan.apb2_divider), (2, 1));
        assert_eq!(plan.tree.pclk1_hz, 50_000_000);
        assert_eq!(plan.tree.timclk1_hz, 100_000_000);
        assert_eq!(plan.tree.pclk2_hz, 100_000_000);
        assert_eq!(plan.tree.timclk2_hz, 100_000_000);
    }

    #[test]
    fn f411_at_100_mhz_from_the_boards_external_oscillators() {
        // The Black Pill's 25 MHz crystal: no whole M gives a 2 MHz VCO input; the HAL's
        // search takes the first M with an exact VCO, 16 (1.5625 MHz).
        let crystal = plan(Chip::F411, 25_000_000, 100_000_000).unwrap();
        assert_eq!(
            crystal.pll,
            PllConfig {
                m: 16,
                n: 256,
                p: 4,
                q: 9
            }
        );
        assert_eq!(crystal.pll_output.vco_in_hz, 1_562_500);
        assert_eq!(crystal.pll_output.vco_out_hz, 400_000_000);
        // The Nucleo's 8 MHz from the ST-LINK: 2 MHz, as from the HSI.
        let mco = plan(Chip::F411, 8_000_000, 100_000_000).unwrap();
        assert_eq!(
            mco.pll,
            PllConfig {
                m: 4,
                n: 200,
                p: 4,
                q: 9
            }
        );
        assert_eq!(mco.pll_output.vco_in_hz, 2_000_000);
        // Whatever the source, the buses, timers, wait states and scale are the same.
        let hsi = plan(Chip::F411, HSI_HZ, 100_000_000).unwrap();
        for other in [crystal, mco] {
            assert!(other.tree.same_as(&hsi.tree));
            assert_eq!(other.tree, hsi.tree);
            assert_eq!(
                (other.flash_wait_states, other.scale),
                (3, VoltageScale::Scale1)
            );
        }
        // M = 13 would give 1.92 MHz and an exact 100 MHz too, but only as a fraction of
        // a Hz at the VCO input, which neither the HAL nor `check` takes.
        let thirteen = PllConfig {
            m: 13,
            n: 208,
            p: 4,
            q: 9,
        };
        assert_eq!(
            thirteen.check(Chip::F411, 25_000_000),
            Err(ClockError::VcoInput(1_923_076))
        );
        // The F401 port example at 72 MHz from either oscillator.
        assert_eq!(
            plan(Chip::F401, 25_000_000, 72_000_000).map(|p| p.pll),
            Ok(PllConfig {
                m: 25,
                n: 432,
                p: 6,
                q: 9
            })
        );
        assert!(plan(Chip::F401, 8_000_000, 72_000_000).is_ok());
    }

    #[test]
    fn the_search_is_the_hal_s() {
        // stm32f4xx-hal 0.23's `fast_setup` without a 48 MHz clock, transcribed with its
        // whole-Hz arithmetic, against `pll_for` over every source and SYSCLK the chips
        // allow in whole MHz.
        fn hal(source: u32, sysclk: u32) -> (u32, u32, u32, u32, u32) {
            let m_min = source.div_ceil(2_000_000);
            let m_max = source / 1_000_000;
            let div = 8.min((432_000_000 / sysclk) & !1);
            let target = sysclk * div;
            let m = (m_min..=m_max)
                .min_by_key(|m| {
                    let vco_in = source / m;
                    target - vco_in * (target / vco_in)
                })
                .unwrap();
            let vco_in = source / m;
            let n = target / vco_in;
            let q = (vco_in * n).div_ceil(48_000_000);
            (m, n, div, q, vco_in * n / div)
        }
        for source in [8_000_000, HSI_HZ, 25_000_000, 12_000_000, 24_000_000] {
            for mhz in 24..=100 {
                let sysclk = mhz * 1_000_000;
                let (m, n, p, q, hal_sysclk) = hal(source, sysclk);
                match pll_for(Chip::F411, source, sysclk) {
                    Ok(c) => {
                        assert_eq!(
                            (
                                u32::from(c.m),
                                u32::from(c.n),
                                u32::from(c.p),
                                u32::from(c.q)
                            ),
                            (m, n, p, q),
                            "{source} Hz -> {sysclk} Hz"
                        );
                        assert_eq!(hal_sysclk, sysclk);
                    }
                    // Refused: the HAL's setting is not exact or breaks a limit.
                    Err(_) => assert!(
                        hal_sysclk != sysclk
                            || PllConfig {
                                m: m as u8,
                                n: n as u16,
                                p: p as u8,
                                q: q as u8
                            }
                            .check(Chip::F411, source)
                            .is_err(),
                        "{source} Hz -> {sysclk} Hz"
                    ),
                }
            }
        }
    }

    #[test]
    fn f401_at_72_mhz_and_f446_at_100_mhz() {
        // RM0368 requires 192 <= PLLN <= 432 on the F401. The HAL's choice for 84 MHz
        // from the HSI (M = 8, N = 168, P = 4) breaks it; an exact 84 MHz exists only
        // with a 1.6 MHz VCO input. The firmware runs the F401 at 72 MHz, for which the
        // HAL's own choice is valid.
        let hal_84 = PllConfig {
            m: 8,
            n: 168,
            p: 4,
            q: 7,
        };
        assert_eq!(hal_84.check(Chip::F401, HSI_HZ), Err(ClockError::PllN(168)));
        assert_eq!(
            pll_for(Chip::F401, HSI_HZ, 84_000_000),
            Err(ClockError::PllN(168)),
            "the HAL's choice, refused"
        );
        let exact_84 = PllConfig {
            m: 10,
            n: 210,
            p: 4,
            q: 7,
        };
        assert_eq!(
            exact_84.check(Chip::F401, HSI_HZ).map(|out| out.sysclk_hz),
            Ok(84_000_000)
        );
        let f401 = plan(Chip::F401, HSI_HZ, 72_000_000).unwrap();
        assert_eq!(
            f401.pll,
            PllConfig {
                m: 8,
                n: 216,
                p: 6,
                q: 9
            }
        );
        assert_eq!(f401.pll_output.vco_out_hz, 432_000_000);
        assert_eq!(f401.pll_output.pll48_hz, 48_000_000);
        assert_eq!(f401.flash_wait_states, 2); // RM0368 Table 6: 60 < HCLK <= 84 MHz
        assert_eq!(f401.scale, VoltageScale::Scale2); // above scale 3's 60 MHz
        assert_eq!(f401.tree.pclk1_hz, 36_000_000);
        assert_eq!(f401.tree.timclk1_hz, 72_000_000);

        let f446 = plan(Chip::F446, HSI_HZ, 100_000_000).unwrap();
        assert_eq!(f446.flash_wait_states, 3); // RM0390 Table 5: 90 < HCLK <= 120 MHz
        assert_eq!(f446.scale, VoltageScale::Scale3); // DS10693: scale 3 up to 120 MHz
                                                      // APB1 max 45 MHz: 100 / 4 = 25 MHz, timers at 50 MHz; APB2 max 90: 100 / 2.
        assert_eq!((f446.apb1_divider, f446.apb2_divider), (4, 2));
        assert_eq!(f446.tree.timclk1_hz, 50_000_000);
        assert_eq!(f446.tree.pclk2_hz, 50_000_000);
    }

    #[test]
    fn wait_states_follow_the_rm_table_at_each_bound() {
        // RM0383 Table 5 (2.7-3.6 V): 0 WS to 30 MHz, 1 to 64, 2 to 90, 3 to 100.
        let ws = |hz| flash_wait_states(Chip::F411, hz);
        assert_eq!(ws(30_000_000), Ok(0));
        assert_eq!(ws(30_000_001), Ok(1));
        assert_eq!(ws(64_000_000), Ok(1));
        assert_eq!(ws(64_000_001), Ok(2));
        assert_eq!(ws(90_000_000), Ok(2));
        assert_eq!(ws(90_000_001), Ok(3));
        assert_eq!(ws(100_000_000), Ok(3));
        assert_eq!(ws(100_000_001), Err(ClockError::Hclk(100_000_001)));
        // The HAL's rule, (HCLK - 1) / 30 MHz, asks for 2 WS at 64 MHz where the F411
        // needs 1: conservative, never too few on these parts.
        for chip in [Chip::F401, Chip::F411, Chip::F446] {
            for mhz in 1..=chip.max_hclk_hz() / 1_000_000 {
                let hz = mhz * 1_000_000;
                let hal = ((hz - 1) / 30_000_000) as u8;
                assert!(hal >= flash_wait_states(chip, hz).unwrap(), "{chip:?} {hz}");
            }
        }
    }

    #[test]
    fn voltage_scale_follows_the_datasheet() {
        let s = |hz| required_scale(Chip::F411, hz);
        assert_eq!(s(64_000_000), Ok(VoltageScale::Scale3));
        assert_eq!(s(64_000_001), Ok(VoltageScale::Scale2));
        assert_eq!(s(84_000_000), Ok(VoltageScale::Scale2));
        assert_eq!(s(84_000_001), Ok(VoltageScale::Scale1));
        assert_eq!(s(100_000_001), Err(ClockError::Hclk(100_000_001)));
        assert_eq!(
            required_scale(Chip::F401, 60_000_001),
            Ok(VoltageScale::Scale2)
        );
    }

    #[test]
    fn pll_check_rejects_each_limit() {
        let ok = PllConfig {
            m: 8,
            n: 200,
            p: 4,
            q: 9,
        };
        assert!(ok.check(Chip::F411, HSI_HZ).is_ok());
        let with = |f: fn(&mut PllConfig)| {
            let mut c = ok;
            f(&mut c);
            c.check(Chip::F411, HSI_HZ)
        };
        assert_eq!(with(|c| c.m = 1), Err(ClockError::PllM(1)));
        assert_eq!(with(|c| c.m = 4), Err(ClockError::VcoInput(4_000_000)));
        assert_eq!(with(|c| c.m = 32), Err(ClockError::VcoInput(500_000)));
        assert_eq!(with(|c| c.n = 49), Err(ClockError::PllN(49)));
        assert_eq!(with(|c| c.n = 217), Err(ClockError::VcoOutput(434_000_000)));
        assert_eq!(with(|c| c.p = 3), Err(ClockError::PllP(3)));
        assert_eq!(with(|c| c.q = 1), Err(ClockError::PllQ(1)));
        assert_eq!(with(|c| c.q = 8), Err(ClockError::Pll48(50_000_000)));
        // The F401's VCO starts at 192 MHz: N = 96 (192 MHz at 2 MHz in) is its minimum
        // output but PLLN itself must be >= 192 there.
        let low = PllConfig {
            m: 16,
            n: 150,
            p: 2,
            q: 4,
        };
        assert!(low.check(Chip::F411, HSI_HZ).is_ok());
        assert_eq!(low.check(Chip::F401, HSI_HZ), Err(ClockError::PllN(150)));
        assert_eq!(
            pll_for(Chip::F411, HSI_HZ, 100_000_001),
            Err(ClockError::NoExactPll(100_000_001))
        );
    }

    #[test]
    fn pllcfgr_fields_round_trip() {
        let c = PllConfig {
            m: 8,
            n: 200,
            p: 4,
            q: 9,
        };
        let bits = c.pllcfgr_fields();
        // M = 8 in 5:0, N = 200 in 14:6, P = 4 -> 01 in 17:16, Q = 9 in 27:24.
        assert_eq!(bits, 8 | (200 << 6) | (1 << 16) | (9 << 24));
        // PLLSRC (bit 22) and the reserved bit 29 of the reset value do not disturb it.
        assert_eq!(PllConfig::from_pllcfgr(bits | (1 << 22) | (1 << 29)), c);
        // The reset value 0x2400_3010: M = 16, N = 192, P = 2, Q = 4.
        assert_eq!(
            PllConfig::from_pllcfgr(0x2400_3010),
            PllConfig {
                m: 16,
                n: 192,
                p: 2,
                q: 4
            }
        );
    }

    #[test]
    fn cfgr_prescalers_decode() {
        assert_eq!(apb_divider_from_ppre(0b011), 1);
        assert_eq!(apb_divider_from_ppre(0b100), 2);
        assert_eq!(apb_divider_from_ppre(0b111), 16);
        assert_eq!(ahb_divider_from_hpre(0b0111), 1);
        assert_eq!(ahb_divider_from_hpre(0b1011), 16);
        assert_eq!(ahb_divider_from_hpre(0b1100), 64);
        // HPRE /1, PPRE1 /2 (100), PPRE2 /1, SW = SWS = PLL.
        let cfgr = (0b100 << 10) | ((SWS_PLL as u32) << 2) | 0b10;
        let tree = ClockTree::from_cfgr(100_000_000, cfgr);
        assert_eq!(tree, plan(Chip::F411, HSI_HZ, 100_000_000).unwrap().tree);
        assert_eq!(tree.check(Chip::F411), Ok(()));
        // APB1 undivided at 100 MHz breaks the F411's 50 MHz limit.
        assert!(ClockTree::from_cfgr(100_000_000, 0)
            .check(Chip::F411)
            .is_err());
    }

    #[test]
    fn errors_name_the_value() {
        assert_eq!(
            ClockError::VcoOutput(434_000_000).to_string(),
            "VCO output outside the chip's range, got 434000000 Hz"
        );
    }
}
