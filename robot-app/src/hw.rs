//! Register arithmetic of the STM32F4 boards, host-tested (filled in by the board work).
