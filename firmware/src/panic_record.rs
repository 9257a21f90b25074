//! The record of the last panic or hard fault, in RAM that survives a reset.
//!
//! [`WORDS`] words in `.uninit` (cortex-m-rt neither loads nor zeroes that section), with
//! the layout and checks of `robot_app::panic_record`. The panic and hard-fault handlers
//! [`store`] a record. It stays until a host has read it over the link and cleared it:
//! `init` [`read`]s it for the boot log, the link service reads it for `GetPanicRecord`
//! and clears it for `ClearPanicRecord` (`crate::link_task`). A later failure
//! overwrites it: it is the last one's.

use core::mem::MaybeUninit;
use core::ptr::{addr_of, addr_of_mut};

use robot_app::panic_record::{PanicRecord, CLEARED, WORDS};

#[link_section = ".uninit.panic_record"]
static mut RECORD: MaybeUninit<[u32; WORDS]> = MaybeUninit::uninit();

/// Writes `record` (volatile word stores: the handler may be the last code that runs).
///
/// Called only from the panic and hard-fault handlers, with interrupts masked or from the
/// fault's own priority; a clear they interrupt never resumes (the handlers end in a
/// reset), so the record they write is the one that stays.
pub fn store(record: &PanicRecord) {
    write_words(&record.to_words());
}

/// The record the RAM holds, if it is an intact one (after a power-on the RAM holds
/// noise, which the checks reject). Does not clear it.
pub fn read() -> Option<PanicRecord> {
    let mut words = [0u32; WORDS];
    let base = addr_of!(RECORD).cast::<u32>();
    for (i, word) in words.iter_mut().enumerate() {
        // SAFETY: `i < WORDS`, inside the static; a volatile read of RAM that may never
        // have been written by this program yields whatever the RAM holds, which
        // `from_words` validates.
        *word = unsafe { base.add(i).read_volatile() };
    }
    PanicRecord::from_words(&words)
}

/// Forgets the record.
pub fn clear() {
    write_words(&CLEARED);
}

fn write_words(words: &[u32; WORDS]) {
    let base = addr_of_mut!(RECORD).cast::<u32>();
    for (i, word) in words.iter().enumerate() {
        // SAFETY: `i < WORDS`, inside the static. Writers are the failure handlers and the
        // link task's `clear`; a handler that interrupts a clear writes the whole record
        // and never returns to it (see `store`).
        unsafe { base.add(i).write_volatile(*word) };
    }
}
