//! The STM32F4's register arithmetic, as pure functions with host tests, so that every
//! value the firmware writes to a clock, timer, watchdog or ADC register, and every flag
//! it reads, is computed and checked here, against the reference manual's and the
//! datasheet's figures, without hardware.
//!
//! | module | what it decides |
//! |---|---|
//! | [`chip`] | the supported parts and their limits (clock, buses, flash, PLL, LSI, ADC) |
//! | [`clock`] | PLL M/N/P/Q, flash wait states, voltage scale, APB dividers, timer clocks |
//! | [`clock_read_back`] | SYSCLK and its source decoded from RCC_CFGR and RCC_PLLCFGR |
//! | [`oscillator`] | the board's external oscillator (HSE), its startup timeout, the fallback to the HSI |
//! | [`option_bytes`] | the brown-out reset level in FLASH_OPTCR, and the value written to set it |
//! | [`watchdog`] | IWDG prescaler and reload for a timeout, and its spread over the LSI |
//! | [`tick`] | control periods elapsed since the last step, from a free-running counter |
//! | [`encoder_filter`] | the quadrature inputs' digital filter against the fastest real edge |
//! | [`bridge`] | H-bridge input states (TB6612FNG, DRV8833) and safe transitions |
//! | [`supply`] | the supply divider, ADC clock and sampling time, raw reading to volts |
//! | [`usart`] | USART_BRR for a baud rate, and the rate's error |
//! | [`flash`] | the storage sectors, erase and program times, the watchdog that outlasts them |
//! | [`reset`] | the reset cause from RCC_CSR's flags |
//! | [`stack`] | the stack's high-water mark from the painted stack |

pub mod bridge;
pub mod chip;
pub mod clock;
pub mod clock_read_back;
pub mod encoder_filter;
pub mod flash;
pub mod option_bytes;
pub mod oscillator;
pub mod reset;
pub mod stack;
pub mod supply;
pub mod tick;
pub mod usart;
pub mod watchdog;
