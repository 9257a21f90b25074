//! The system clock: the board's external oscillator ([`HSE`]) → PLL → `board::SYSCLK_HZ`,
//! or the HSI when the HSE does not start, with the voltage scale the datasheet requires,
//! then a read-back of every register against the plan in use (`board::CLOCK_PLAN` from
//! the HSE, `board::FALLBACK_CLOCK_PLAN` from the HSI; both give the same bus and timer
//! clocks, checked at compile time).
//!
//! RM0383 (PWR_CR.VOS) allows the voltage scale to change only while the PLL is off, and
//! the new scale takes effect only once the PLL is on; PWR_CSR.VOSRDY rises when the
//! regulator has reached it. The reset value of PWR_CR on the F411 is scale 2, rated to
//! 84 MHz only (DS10314), so 100 MHz needs scale 1, set before the PLL starts:
//!
//! 1. RCC_APB1ENR.PWREN = 1, read back (the PWR clock must run before PWR_CR is written);
//! 2. PWR_CR.VOS = the plan's scale, by read-modify-write (the PAC's reset value of PWR_CR
//!    is 0, i.e. VOS = 00 = scale 3: never `write` it), with the PLL still off;
//! 3. the HSE, started here and waited for at most
//!    `robot_app::stm32f4::oscillator::HSE_STARTUP_TIMEOUT_US` (timed by the cycle
//!    counter, in HSI cycles): RCC_CR.HSEBYP first for an external clock (it may change
//!    only while the HSE is off), then HSEON, then HSERDY. stm32f4xx-hal 0.23 waits for
//!    HSERDY without a timeout, so it is given the HSE only once it runs; an HSE that did
//!    not start is switched off again (HSEON, then HSEBYP cleared) and the plan is the
//!    HSI's, with a warning in the log and [`ClockReport::source`] saying so;
//! 4. stm32f4xx-hal's `freeze`: flash wait states, prefetch and caches first, then the
//!    PLL (M, N, P, Q, PLLSRC), PLLON, wait for PLLRDY, AHB/APB prescalers, SW = PLL;
//! 5. wait for VOSRDY (bounded);
//! 6. read back RCC_CFGR, RCC_PLLCFGR, FLASH_ACR and PWR_CR and compare them, and the
//!    HAL's frequencies, with the plan.
//!
//! The HAL switches SYSCLK to the PLL right after PLLRDY, in the same call, so step 5
//! comes after the switch, not before it as RM0383 asks: between the write of SW and the
//! first read of VOSRDY the core runs at SYSCLK without VOSRDY having been seen. That
//! window is the rest of `freeze` (a few dozen instructions, no flash writes; counted in
//! firmware/README.md), plus however long VOSRDY then takes. [`ClockReport::vos_polls`]
//! tells which: 1 means VOSRDY was already up at the first read. The HAL cannot take over
//! clocks configured by hand (its `Clocks` has no public constructor and `freeze` always
//! rewrites RCC_PLLCFGR, which RM0383 forbids while the PLL runs), so owning the whole
//! sequence would leave every HAL peripheral with wrong frequencies.
//!
//! The HAL's waits for PLLRDY are unbounded; the independent watchdog, started before
//! this function with `WATCHDOG_INIT`, bounds them: a PLL that never locks resets the chip
//! with the motor outputs never configured (reset state, inputs; the STBY pull-down keeps
//! the driver off). The waits here are bounded and end in an error, or for the HSE in the
//! fallback.

use core::fmt;

use link::ClockSource;
use robot_app::stm32f4::chip::{VoltageScale, HSI_HZ};
use robot_app::stm32f4::clock::{ClockPlan, ClockTree, PllConfig, PLLSRC_HSE, SWS_PLL};
use robot_app::stm32f4::clock_read_back::SysclkReadBack;
use robot_app::stm32f4::oscillator::{cycles_in_us, Hse, HSE_STARTUP_TIMEOUT_US};
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::{self, Rcc};

use super::wait::within_cycles;
use super::{CLOCK_PLAN, FALLBACK_CLOCK_PLAN, HSE, SYSCLK_HZ};

/// The HSE's startup bound in cycles of the HSI, which the core runs on while it waits.
const HSE_STARTUP_CYCLES: u32 = cycles_in_us(HSE_STARTUP_TIMEOUT_US, HSI_HZ);

/// Polls of PWR_CSR.VOSRDY before giving up: at least 10 ms even at one poll per cycle of
/// 100 MHz.
const VOS_READY_POLLS: u32 = 1_000_000;

/// What the clock set-up found.
#[derive(Clone, Copy, Debug)]
pub struct ClockReport {
    /// Reads of VOSRDY until it was set (1: already set at the first read).
    pub vos_polls: u32,
    /// SYSCLK, Hz, as read back from the registers.
    pub sysclk_hz: u32,
    /// The oscillator the PLL runs from: [`HSE`], or the HSI if it did not start.
    pub source: ClockSource,
}

/// A clock register that does not hold what the plan says.
#[derive(Clone, Copy, Debug, PartialEq, Eq, defmt::Format)]
pub enum ClockFault {
    /// The PLL was already on at reset, so VOS could not be changed.
    PllAlreadyOn,
    /// VOSRDY did not rise within [`VOS_READY_POLLS`] reads.
    VosNotReady,
    /// PWR_CR.VOS reads back as another scale (PWR_CR.VOS bits).
    Vos(u8),
    /// RCC_CFGR.SWS is not the PLL (SWS bits).
    NotOnPll(u8),
    /// RCC_PLLCFGR's M/N/P/Q differ from the plan (the register value).
    Pll(u32),
    /// The prescalers give other bus clocks (RCC_CFGR value).
    Prescalers(u32),
    /// FLASH_ACR.LATENCY below the plan's wait states, or prefetch/caches off (FLASH_ACR).
    Flash(u32),
    /// The HAL's idea of the clocks differs from the plan (its SYSCLK, Hz).
    HalClocks(u32),
}

impl fmt::Display for ClockFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(self, f)
    }
}

/// Runs the sequence of the module doc and returns the HAL's `Rcc` (with frequencies that
/// match the plan) and what it found. On a fault the clock may be running from the PLL;
/// the caller stops (the motors are not configured yet).
pub fn configure(
    rcc: pac::RCC,
    pwr: &pac::PWR,
    flash: &pac::FLASH,
) -> Result<(Rcc, ClockReport), ClockFault> {
    // 1. PWR clock on; the read-back makes sure the write has reached RCC before PWR is
    //    accessed (RM0383 §6.3.11 and the errata's "delay after an RCC peripheral clock
    //    enabling").
    rcc.apb1enr().modify(|_, w| w.pwren().set_bit());
    let _ = rcc.apb1enr().read().pwren().bit();
    cortex_m::asm::dsb();

    // 2. Voltage scale, with the PLL off.
    if rcc.cr().read().pllon().bit_is_set() {
        return Err(ClockFault::PllAlreadyOn);
    }
    let vos = CLOCK_PLAN.scale.vos_bits();
    // SAFETY: VOS is a 2-bit field and `vos_bits` is one of the encodings RM0383 defines
    // for this chip (the plan only picks scales the chip has).
    pwr.cr().modify(|_, w| unsafe { w.vos().bits(vos) });

    // 3. The HSE, bounded; the HAL gets it only if it runs.
    let hse_started = start_hse(&rcc, HSE);
    let (plan, config): (&ClockPlan, _) = if hse_started {
        let config = rcc::Config::hse(HSE.hz().Hz());
        let config = if HSE.bypass() {
            config.bypass_hse_oscillator()
        } else {
            config
        };
        (&CLOCK_PLAN, config)
    } else {
        (&FALLBACK_CLOCK_PLAN, rcc::Config::hsi())
    };

    // 4. The HAL: flash latency, PLL, prescalers, switch.
    let rcc = rcc.freeze(config.sysclk(SYSCLK_HZ.Hz()));

    // 5. Voltage scale reached.
    let mut vos_polls = 0;
    loop {
        vos_polls += 1;
        if pwr.csr().read().vosrdy().bit_is_set() {
            break;
        }
        if vos_polls >= VOS_READY_POLLS {
            return Err(ClockFault::VosNotReady);
        }
    }

    // 6. Read back.
    let read_vos = pwr.cr().read().vos().bits();
    if VoltageScale::from_vos_bits(read_vos) != plan.scale {
        return Err(ClockFault::Vos(read_vos));
    }
    let cfgr = rcc.cfgr().read().bits();
    let sws = ((cfgr >> 2) & 0b11) as u8;
    if sws != SWS_PLL {
        return Err(ClockFault::NotOnPll(sws));
    }
    let pllcfgr = rcc.pllcfgr().read().bits();
    let from_hse = pllcfgr & PLLSRC_HSE != 0;
    if PllConfig::from_pllcfgr(pllcfgr) != plan.pll || from_hse != hse_started {
        return Err(ClockFault::Pll(pllcfgr));
    }
    if ClockTree::from_cfgr(plan.pll_output.sysclk_hz, cfgr) != plan.tree {
        return Err(ClockFault::Prescalers(cfgr));
    }
    let acr = flash.acr().read();
    if acr.latency().bits() < plan.flash_wait_states
        || acr.prften().bit_is_clear()
        || acr.icen().bit_is_clear()
        || acr.dcen().bit_is_clear()
    {
        return Err(ClockFault::Flash(acr.bits()));
    }
    let hal = &rcc.clocks;
    let tree = &plan.tree;
    if hal.sysclk().raw() != tree.sysclk_hz
        || hal.hclk().raw() != tree.hclk_hz
        || hal.pclk1().raw() != tree.pclk1_hz
        || hal.pclk2().raw() != tree.pclk2_hz
        || hal.timclk1().raw() != tree.timclk1_hz
        || hal.timclk2().raw() != tree.timclk2_hz
    {
        return Err(ClockFault::HalClocks(hal.sysclk().raw()));
    }
    let report = ClockReport {
        vos_polls,
        sysclk_hz: tree.sysclk_hz,
        source: HSE.report(hse_started),
    };
    Ok((rcc, report))
}

/// SYSCLK as RCC_CFGR and RCC_PLLCFGR give it now, for the board's [`HSE`]
/// (`robot_app::stm32f4::clock_read_back`): what the chip runs on, read independently of
/// the plan `configure` checked.
pub fn read_back() -> SysclkReadBack {
    // SAFETY: two reads of RCC registers, which have no side effects; the HAL's `Rcc`
    // owns RCC for writing and never relies on the values read here.
    let rcc = unsafe { &*pac::RCC::ptr() };
    SysclkReadBack::from_registers(
        rcc.cfgr().read().bits(),
        rcc.pllcfgr().read().bits(),
        HSE.hz(),
    )
}

/// Step 3 of the module doc: starts `hse` and waits for HSERDY for at most
/// [`HSE_STARTUP_CYCLES`]; true when it runs. One that did not start is switched off
/// again, so the HAL never waits for it.
fn start_hse(rcc: &pac::RCC, hse: Hse) -> bool {
    if hse.bypass() {
        // Only while HSEON = 0, which it is after reset.
        rcc.cr().modify(|_, w| w.hsebyp().set_bit());
    }
    rcc.cr().modify(|_, w| w.hseon().set_bit());
    if within_cycles(HSE_STARTUP_CYCLES, || rcc.cr().read().hserdy().bit_is_set()) {
        return true;
    }
    rcc.cr().modify(|_, w| w.hseon().clear_bit());
    // HSEBYP may change only once the HSE is off: HSERDY low again (6 HSE cycles after
    // HSEON clears; it never rose here, so at once).
    if within_cycles(HSE_STARTUP_CYCLES, || {
        rcc.cr().read().hserdy().bit_is_clear()
    }) {
        rcc.cr().modify(|_, w| w.hsebyp().clear_bit());
    }
    false
}
