//! The record of the last panic or hard fault, in RAM that survives a reset.
//!
//! [`WORDS`] words in `.uninit` (cortex-m-rt neither loads nor zeroes that section), with
//! the layout and checks of `robot_app::panic_record`. The panic and hard-fault handlers
//! [`store`] a record; `init` calls [`take`], which returns it once (and clears it) if it
//! is intact, and keeps it for whoever reports it (the boot log now, the link's
//! information and statistics later).

use core::mem::MaybeUninit;
use core::ptr::{addr_of, addr_of_mut};

use robot_app::panic_record::{PanicRecord, CLEARED, WORDS};

#[link_section = ".uninit.panic_record"]
static mut RECORD: MaybeUninit<[u32; WORDS]> = MaybeUninit::uninit();

/// Writes `record` (volatile word stores: the handler may be the last code that runs).
///
/// Called only from the panic and hard-fault handlers, with interrupts masked or from the
/// fault's own priority, so nothing else writes the record at the same time.
pub fn store(record: &PanicRecord) {
    write_words(&record.to_words());
}

/// The record left by the previous run, if the RAM holds an intact one; clears it.
/// Called once, from `init`, before interrupts are enabled.
pub fn take() -> Option<PanicRecord> {
    let mut words = [0u32; WORDS];
    let base = addr_of!(RECORD).cast::<u32>();
    for (i, word) in words.iter_mut().enumerate() {
        // SAFETY: `i < WORDS`, inside the static; a volatile read of RAM that may never
        // have been written by this program yields whatever the RAM holds, which
        // `from_words` validates.
        *word = unsafe { base.add(i).read_volatile() };
    }
    write_words(&CLEARED);
    PanicRecord::from_words(&words)
}

fn write_words(words: &[u32; WORDS]) {
    let base = addr_of_mut!(RECORD).cast::<u32>();
    for (i, word) in words.iter().enumerate() {
        // SAFETY: `i < WORDS`, inside the static; callers never run concurrently (see
        // `store` and `take`).
        unsafe { base.add(i).write_volatile(*word) };
    }
}
