//! The system clock: HSI → PLL → `board::SYSCLK_HZ`, with the voltage
//! scale the datasheet requires, then a read-back of every register against
//! `board::CLOCK_PLAN`.
//!
//! RM0383 (PWR_CR.VOS) allows the voltage scale to change only while the PLL is off, and
//! the new scale takes effect only once the PLL is on; PWR_CSR.VOSRDY rises when the
//! regulator has reached it. The reset value of PWR_CR on the F411 is scale 2, rated to
//! 84 MHz only (DS10314), so 100 MHz needs scale 1, set before the PLL starts:
//!
//! 1. RCC_APB1ENR.PWREN = 1, read back (the PWR clock must run before PWR_CR is written);
//! 2. PWR_CR.VOS = the plan's scale, by read-modify-write (the PAC's reset value of PWR_CR
//!    is 0, i.e. VOS = 00 = scale 3: never `write` it), with the PLL still off;
//! 3. stm32f4xx-hal's `freeze`: flash wait states, prefetch and caches first, then the
//!    PLL (M, N, P, Q), PLLON, wait for PLLRDY, AHB/APB prescalers, SW = PLL;
//! 4. wait for VOSRDY (bounded);
//! 5. read back RCC_CFGR, RCC_PLLCFGR, FLASH_ACR and PWR_CR and compare them, and the
//!    HAL's frequencies, with the plan.
//!
//! The HAL switches SYSCLK to the PLL right after PLLRDY, in the same call, so step 4
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
//! the driver off). The waits here are bounded and end in an error.

use core::fmt;

use robot_app::stm32f4::chip::VoltageScale;
use robot_app::stm32f4::clock::{ClockTree, PllConfig, SWS_PLL};
use stm32f4xx_hal::pac;
use stm32f4xx_hal::prelude::*;
use stm32f4xx_hal::rcc::{self, Rcc};

use super::{CLOCK_PLAN, SYSCLK_HZ};

/// Polls of PWR_CSR.VOSRDY before giving up: at least 10 ms even at one poll per cycle of
/// 100 MHz.
const VOS_READY_POLLS: u32 = 1_000_000;

/// What the clock set-up found.
#[derive(Clone, Copy, Debug, defmt::Format)]
pub struct ClockReport {
    /// Reads of VOSRDY until it was set (1: already set at the first read).
    pub vos_polls: u32,
    /// SYSCLK, Hz, as read back from the registers.
    pub sysclk_hz: u32,
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

    // 3. The HAL: flash latency, PLL, prescalers, switch.
    let rcc = rcc.freeze(rcc::Config::hsi().sysclk(SYSCLK_HZ.Hz()));

    // 4. Voltage scale reached.
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

    // 5. Read back.
    let read_vos = pwr.cr().read().vos().bits();
    if VoltageScale::from_vos_bits(read_vos) != CLOCK_PLAN.scale {
        return Err(ClockFault::Vos(read_vos));
    }
    let cfgr = rcc.cfgr().read().bits();
    let sws = ((cfgr >> 2) & 0b11) as u8;
    if sws != SWS_PLL {
        return Err(ClockFault::NotOnPll(sws));
    }
    let pllcfgr = rcc.pllcfgr().read().bits();
    if PllConfig::from_pllcfgr(pllcfgr) != CLOCK_PLAN.pll || pllcfgr & (1 << 22) != 0 {
        return Err(ClockFault::Pll(pllcfgr));
    }
    if ClockTree::from_cfgr(CLOCK_PLAN.pll_output.sysclk_hz, cfgr) != CLOCK_PLAN.tree {
        return Err(ClockFault::Prescalers(cfgr));
    }
    let acr = flash.acr().read();
    if acr.latency().bits() < CLOCK_PLAN.flash_wait_states
        || acr.prften().bit_is_clear()
        || acr.icen().bit_is_clear()
        || acr.dcen().bit_is_clear()
    {
        return Err(ClockFault::Flash(acr.bits()));
    }
    let hal = &rcc.clocks;
    let tree = &CLOCK_PLAN.tree;
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
    };
    Ok((rcc, report))
}
