//! The persisted parameter record on any page ([`check`]).
//!
//! The input is read twice: as a flash page as it is, and as the body of an intact
//! record (our magic and schema, a correct CRC) so that every input also reaches the
//! body's decoding and the core's validation. Each read must give what the record's
//! definition (`robot_app::persist`'s module doc) gives, written here step by step;
//! a record that loads must pass the core's validation with every number finite, and
//! store back to a record that loads the same.

use controller_core::params::Params;
use link::{crc32, ParamSet};
use robot_app::persist::{
    self, LoadError, Loaded, Slot, Slots, WritePlan, CRC_LEN, HEADER_LEN, MAX_BODY_LEN,
    MAX_RECORD_LEN, RECORD_MAGIC, RECORD_SCHEMA,
};

use crate::messages::assert_canonical;
use crate::numbers::assert_all_finite;

/// The board's control rate the pages are read for, Hz (the firmware's tick).
pub const CONTROL_RATE_HZ: u32 = 1000;

/// The sequence number of the record the check seals around its input.
const SEALED_SEQUENCE: u32 = 7;

/// Reads `input` as a page and as the body of an intact record, and the two as the pair
/// of pages the board scans; panics naming the broken property.
pub fn check(input: &[u8]) {
    let sealed = seal(input);
    for page in [input, &sealed[..]] {
        check_page(page);
    }
    check_pair(input, &sealed);
}

/// An intact record with `body` as its body (any length), sequence number 7.
pub fn seal(body: &[u8]) -> Vec<u8> {
    let length = u32::try_from(body.len()).unwrap_or(u32::MAX);
    let mut page: Vec<u8> = [RECORD_MAGIC, RECORD_SCHEMA, SEALED_SEQUENCE, length]
        .iter()
        .flat_map(|word| word.to_le_bytes())
        .collect();
    page.extend_from_slice(body);
    let crc = crc32(&page);
    page.extend_from_slice(&crc.to_le_bytes());
    page
}

fn check_page(page: &[u8]) {
    let loaded = persist::decode(page, CONTROL_RATE_HZ);
    assert!(!loaded.is_err_and(|e| e.name().is_empty() || e.to_string().is_empty()));
    if let Ok(loaded) = &loaded {
        assert_valid(loaded);
        assert_stores_back(page, loaded);
    }
    assert_eq!(
        comparable(&loaded),
        comparable(&by_definition(page)),
        "the page {page:02x?} loads as the record format says"
    );
}

/// What `page` holds by the record format, step by step.
fn by_definition(page: &[u8]) -> Result<Loaded, LoadError> {
    let word = |i: usize| -> Option<u32> {
        Some(u32::from_le_bytes(
            page.get(4 * i..4 * i + 4)?.try_into().ok()?,
        ))
    };
    let (Some(magic), Some(schema), Some(sequence), Some(length)) =
        (word(0), word(1), word(2), word(3))
    else {
        return Err(LoadError::BadLength { length: 0 });
    };
    if page[..HEADER_LEN].iter().all(|&b| b == 0xFF) {
        return Err(LoadError::Erased);
    }
    if magic != RECORD_MAGIC {
        return Err(LoadError::NoRecord { magic });
    }
    let body_len = length as usize;
    if body_len > MAX_BODY_LEN || page.len() < HEADER_LEN + body_len + CRC_LEN {
        return Err(LoadError::BadLength { length });
    }
    let (covered, rest) = page.split_at(HEADER_LEN + body_len);
    if crc32(covered).to_le_bytes() != rest[..CRC_LEN] {
        return Err(LoadError::Corrupt);
    }
    if schema != RECORD_SCHEMA {
        return Err(LoadError::ForeignSchema { found: schema });
    }
    let Ok((params, [])) = postcard::take_from_bytes::<ParamSet>(&covered[HEADER_LEN..]) else {
        return Err(LoadError::Undecodable);
    };
    let checked = Params::new(params.robot).map_err(LoadError::InvalidRobot)?;
    if params.robot.control_rate_hz != CONTROL_RATE_HZ {
        return Err(LoadError::WrongControlRate {
            found: params.robot.control_rate_hz,
        });
    }
    params
        .supervisor
        .validate(&checked)
        .map_err(LoadError::InvalidSupervisor)?;
    Ok(Loaded { params, sequence })
}

/// A load as comparable data: a configuration by its postcard bytes (bit for bit, NaNs
/// included), a refusal by its `Debug` form.
fn comparable(load: &Result<Loaded, LoadError>) -> Result<(Vec<u8>, u32), String> {
    match load {
        Ok(loaded) => Ok((
            postcard::to_allocvec(&loaded.params).unwrap_or_default(),
            loaded.sequence,
        )),
        Err(e) => Err(format!("{e:?}")),
    }
}

/// A loaded configuration passes the core's validation at the board's rate, every
/// number in it finite.
fn assert_valid(loaded: &Loaded) {
    let ParamSet { robot, supervisor } = &loaded.params;
    assert_all_finite("a loaded configuration", &loaded.params);
    let params = Params::new(*robot)
        .unwrap_or_else(|e| panic!("a loaded robot configuration is valid, yet: {e}"));
    assert_eq!(robot.control_rate_hz, CONTROL_RATE_HZ);
    if let Err(e) = supervisor.validate(&params) {
        panic!("loaded supervisor settings are valid, yet: {e}");
    }
}

/// A loaded record, stored again, loads the same, and is the page's record when that
/// was as long as the canonical one.
fn assert_stores_back(page: &[u8], loaded: &Loaded) {
    let mut image = [0xFF; MAX_RECORD_LEN];
    let len = persist::encode(&loaded.params, loaded.sequence, &mut image)
        .unwrap_or_else(|e| panic!("a loaded configuration stores again, yet: {e}"));
    let again = persist::decode(&image, CONTROL_RATE_HZ);
    assert_eq!(
        comparable(&again),
        comparable(&Ok(*loaded)),
        "a stored configuration loads as it was"
    );
    let body = |record: &[u8]| record[HEADER_LEN..record.len() - CRC_LEN].to_vec();
    let received = &page[..HEADER_LEN + stored_length(page) + CRC_LEN];
    assert_canonical(&body(received), &body(&image[..len]));
    if len == received.len() {
        assert_eq!(
            &image[..len],
            received,
            "the canonical record is the page's"
        );
    }
}

/// The body length in a record's header.
fn stored_length(page: &[u8]) -> usize {
    u32::from_le_bytes([page[12], page[13], page[14], page[15]]) as usize
}

/// The board's two pages: the write plan that reads one page at a time is the scan's,
/// and the newest record is a valid one, on the page the plan does not write.
fn check_pair(a: &[u8], b: &[u8]) {
    let slots = Slots::scan(a, b, CONTROL_RATE_HZ);
    let plan = WritePlan::for_pages(a, b, CONTROL_RATE_HZ);
    assert_eq!(plan, slots.next_write(), "the write plan is the scan's");
    match slots.newest() {
        Some((slot, loaded)) => {
            assert_ne!(plan.slot, slot, "the newest record is not overwritten");
            assert_eq!(plan.sequence, loaded.sequence.wrapping_add(1));
            let page = match slot {
                Slot::A => &slots.a,
                Slot::B => &slots.b,
            };
            assert!(page.is_ok());
        }
        None => {
            assert!(slots.a.is_err() && slots.b.is_err());
            assert_eq!(
                plan,
                WritePlan {
                    slot: Slot::A,
                    sequence: 1
                }
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::seeds;

    #[test]
    fn a_sealed_configuration_loads() {
        let body = postcard::to_allocvec(&seeds::param_set()).unwrap();
        let sealed = seal(&body);
        let loaded = persist::decode(&sealed, CONTROL_RATE_HZ).expect("a valid record");
        assert_eq!(loaded.sequence, SEALED_SEQUENCE);
        assert_eq!(loaded.params, seeds::param_set());
        check(&body);
    }

    #[test]
    fn the_definition_refuses_what_the_board_refuses() {
        assert_eq!(by_definition(&[0xFF; 64]), Err(LoadError::Erased));
        assert_eq!(
            by_definition(&[0xFF; 10]),
            Err(LoadError::BadLength { length: 0 })
        );
        assert_eq!(
            by_definition(&seal(&[1, 2, 3])),
            Err(LoadError::Undecodable)
        );
    }
}
