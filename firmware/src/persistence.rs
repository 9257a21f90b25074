//! The parameters in flash: loaded at boot, written on the link's `PersistParams`.
//!
//! Every decision is `robot_app::persist`'s (the record, its CRC and schema hash, which
//! of the two pages is newer and which to write next); this module only reads the two
//! pages, erases, programs and reads back, around the watchdog:
//!
//! 1. the supervisor is in its Persisting state (motors off) — the link service asks
//!    for the write only then;
//! 2. the watchdog is lengthened to `board::WATCHDOG_PERSIST` (`Watchdog::set_timeout`
//!    waits for IWDG_SR.PVU/RVU to clear, feeds, writes PR and RLR, waits again,
//!    feeds), under the watchdog's lock, so the control task's feed cannot interleave
//!    with the key sequence;
//! 3. the other page's sector is erased and the record programmed
//!    (`board::Storage::erase_and_program`): the CPU stalls for up to ~2 s, the control
//!    task misses its ticks (the supervisor does not count them as a fault while
//!    Persisting), and bytes arriving on the link are lost (the host re-sends);
//! 4. the watchdog goes back to `board::WATCHDOG_RUN`;
//! 5. the page is read back: the write succeeded only if it holds the record byte for
//!    byte.

use link::ParamSet;
use robot_app::persist::{self, Slots, WritePlan, MAX_RECORD_LEN};
use robot_app::service::PersistJob;
use rtic::Mutex;

use crate::board::{self, Storage, Watchdog};

/// The configuration to start with: the newest intact record of ours, or `defaults`
/// when there is none (or no storage); the log says which and why.
pub fn load(storage: Option<&Storage>, defaults: ParamSet) -> ParamSet {
    let rate = defaults.robot.control_rate_hz;
    let Some(storage) = storage else {
        defmt::info!("parameters: built-in defaults (this board has no storage)");
        return defaults;
    };
    let slots = Slots::scan(
        storage.page(persist::Slot::A),
        storage.page(persist::Slot::B),
        rate,
    );
    if let Some((slot, loaded)) = slots.newest() {
        defmt::info!(
            "parameters: loaded from flash (page {=str}, record {=u32})",
            slot_name(slot),
            loaded.sequence
        );
        return loaded.params;
    }
    let reason = |page: &Result<persist::Loaded, persist::LoadError>| match page {
        Ok(_) => "valid",
        Err(e) => e.name(),
    };
    defmt::warn!(
        "parameters: built-in defaults (page A: {=str}, page B: {=str})",
        reason(&slots.a),
        reason(&slots.b)
    );
    defaults
}

/// Writes `job`'s configuration (see the module doc); true when it reads back intact.
///
/// The plan and the write are functions of their own, never inlined here: the plan
/// decodes the two pages and the write holds the record image, and on the link task's
/// stack only the deeper of the two should count, not their sum.
pub fn write(
    job: &PersistJob<'_>,
    storage: &mut Storage,
    watchdog: &mut impl Mutex<T = Watchdog>,
) -> bool {
    let plan = plan(storage, job.params.robot.control_rate_hz);
    program(job, plan, storage, watchdog)
}

/// Which page to write, and the record's sequence number ([`WritePlan::for_pages`]).
#[inline(never)]
fn plan(storage: &Storage, control_rate_hz: u32) -> WritePlan {
    WritePlan::for_pages(
        storage.page(persist::Slot::A),
        storage.page(persist::Slot::B),
        control_rate_hz,
    )
}

/// Steps 2 to 5 of the module doc: `job`'s record written by `plan` and read back.
#[inline(never)]
fn program(
    job: &PersistJob<'_>,
    plan: WritePlan,
    storage: &mut Storage,
    watchdog: &mut impl Mutex<T = Watchdog>,
) -> bool {
    let mut record = [0xFF; MAX_RECORD_LEN];
    let len = match persist::encode(job.params, plan.sequence, &mut record) {
        Ok(len) => len,
        Err(_) => {
            defmt::error!("persist: the configuration does not fit a record");
            return false;
        }
    };
    let record = record.get(..len).unwrap_or_default();
    if watchdog
        .lock(|w| w.set_timeout(board::WATCHDOG_PERSIST))
        .is_err()
    {
        defmt::error!("persist: the watchdog did not take the long timeout; not erasing");
        return false;
    }
    let written = storage.erase_and_program(plan.slot, record);
    let restored = watchdog
        .lock(|w| w.set_timeout(board::WATCHDOG_RUN))
        .is_ok();
    if !restored {
        defmt::error!("persist: the watchdog did not take the run-time timeout back");
    }
    if let Err(e) = written {
        defmt::error!("persist: flash error {}", e);
        return false;
    }
    // Byte for byte: the record is what `persist::decode` reads back as `job`'s
    // configuration (robot-app's round-trip tests), so its bytes in flash are.
    let ok = storage.page(plan.slot).get(..len) == Some(record);
    if ok {
        defmt::info!(
            "persist: record {=u32} written to page {=str}",
            plan.sequence,
            slot_name(plan.slot)
        );
    } else {
        defmt::error!("persist: the record did not read back intact");
    }
    ok && restored
}

fn slot_name(slot: persist::Slot) -> &'static str {
    match slot {
        persist::Slot::A => "A",
        persist::Slot::B => "B",
    }
}
