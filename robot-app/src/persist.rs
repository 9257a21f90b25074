//! The persisted configuration: a record in a flash page, two pages used in turn.
//!
//! # The record
//!
//! ```text
//! offset  size  field
//!      0     4  magic "RPRM" (RECORD_MAGIC, little-endian u32)
//!      4     4  schema: RECORD_SCHEMA, the postcard-schema hash of ParamSet
//!      8     4  sequence number (the newer of two records has the larger one, wrapping)
//!     12     4  body length n (≤ MAX_BODY_LEN)
//!     16     n  body: postcard(ParamSet), the robot configuration (calibration included:
//!               per-wheel radii and track width) and the supervisor settings
//!   16+n     4  CRC-32/ISO-HDLC of bytes 0 .. 16+n
//! ```
//!
//! All integers are little-endian. The schema hash is the record's own (not the link
//! protocol's): a change of the link that leaves [`ParamSet`] alone keeps stored records
//! readable, and any change of `ParamSet`'s shape makes them foreign.
//!
//! # Versioning: one rule
//!
//! A record is loaded only by a firmware whose [`RECORD_SCHEMA`] equals the record's
//! schema word; any other record is [`LoadError::ForeignSchema`], ignored whole, with no
//! migration: the board boots with its built-in parameters and logs why. A field whose
//! meaning or unit changes without its type changing is renamed, so that the hash (which
//! covers the names) moves with it. `docs/protocol.md` states the same rule for users.
//!
//! [`decode`] tells every way a page can fail apart ([`LoadError`]); the board then falls
//! back to its built-in defaults and logs which one it was.
//!
//! # Two pages, in turn
//!
//! A write erases a page, and an erase or write cut short by a reset leaves it invalid.
//! So the board keeps two pages (two flash sectors), A and B: [`Slots::scan`] reads
//! both and picks the valid record with the newest sequence number; [`Slots::next_write`]
//! (or [`WritePlan::for_pages`], which keeps only the sequence numbers) names the *other*
//! page and the next sequence number. If a write is cut short, the previous record is
//! still there. The firmware only erases, writes and reads flash;
//! every decision is here.

use core::fmt;

use controller_core::params::{ParamError, Params, RobotConfig};
use controller_core::supervisor::{SupervisorConfig, SupervisorConfigError};
use link::protocol::schema_hash_of;
use link::{crc32, ParamSet};

/// First word of a record.
pub const RECORD_MAGIC: u32 = u32::from_le_bytes(*b"RPRM");
/// Schema hash of the record's body, [`ParamSet`] (postcard-schema, computed at compile
/// time).
pub const RECORD_SCHEMA: u32 = schema_hash_of::<ParamSet>();
/// Bytes before the body.
pub const HEADER_LEN: usize = 16;
/// Bytes of CRC after the body.
pub const CRC_LEN: usize = 4;
/// Largest body accepted, bytes (the link's limit for a message body, which a
/// `SetParams` must fit).
pub const MAX_BODY_LEN: usize = link::MAX_BODY_LEN;
/// Largest record, bytes: a page image of this size always holds one.
pub const MAX_RECORD_LEN: usize = HEADER_LEN + MAX_BODY_LEN + CRC_LEN;

/// A record read back.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Loaded {
    /// The configuration (validated).
    pub params: ParamSet,
    /// Its sequence number.
    pub sequence: u32,
}

/// Why a page holds no usable record. Each is a distinct case for the log.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum LoadError {
    /// The header is all 0xFF: an erased page (nothing was ever saved there).
    Erased,
    /// The first word is not [`RECORD_MAGIC`]: something else, or noise.
    NoRecord {
        /// The first word found.
        magic: u32,
    },
    /// The body length is larger than [`MAX_BODY_LEN`] or than the page.
    BadLength {
        /// The length found, bytes.
        length: u32,
    },
    /// The CRC does not match: a write was cut short, or the flash is damaged.
    Corrupt,
    /// An intact record of another [`ParamSet`] shape (another firmware version).
    ForeignSchema {
        /// The schema hash found.
        found: u32,
    },
    /// Intact, our schema, but the body does not decode (should not happen).
    Undecodable,
    /// The robot configuration fails `Params::new`.
    InvalidRobot(ParamError),
    /// The supervisor settings fail `SupervisorConfig::validate`.
    InvalidSupervisor(SupervisorConfigError),
    /// The record's control rate is not the board's (its tick timer is fixed).
    WrongControlRate {
        /// The record's `control_rate_hz`.
        found: u32,
    },
}

impl LoadError {
    /// A short name for logs that cannot format (`"erased"`, `"corrupt"`, …).
    pub const fn name(&self) -> &'static str {
        match self {
            LoadError::Erased => "erased",
            LoadError::NoRecord { .. } => "no record",
            LoadError::BadLength { .. } => "bad length",
            LoadError::Corrupt => "corrupt (CRC)",
            LoadError::ForeignSchema { .. } => "foreign schema",
            LoadError::Undecodable => "undecodable",
            LoadError::InvalidRobot(_) => "invalid robot configuration",
            LoadError::InvalidSupervisor(_) => "invalid supervisor settings",
            LoadError::WrongControlRate { .. } => "wrong control rate",
        }
    }
}

impl fmt::Display for LoadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            LoadError::Erased => f.write_str("no parameters saved (erased page)"),
            LoadError::NoRecord { magic } => {
                write!(f, "no parameter record (first word 0x{magic:08x})")
            }
            LoadError::BadLength { length } => {
                write!(
                    f,
                    "parameter record with an impossible length ({length} bytes)"
                )
            }
            LoadError::Corrupt => f.write_str("parameter record corrupt (CRC mismatch)"),
            LoadError::ForeignSchema { found } => write!(
                f,
                "parameter record of another firmware (schema 0x{found:08x}, this one \
                 0x{RECORD_SCHEMA:08x})"
            ),
            LoadError::Undecodable => f.write_str("parameter record does not decode"),
            LoadError::InvalidRobot(e) => write!(f, "saved robot configuration invalid: {e}"),
            LoadError::InvalidSupervisor(e) => {
                write!(f, "saved supervisor settings invalid: {e}")
            }
            LoadError::WrongControlRate { found } => write!(
                f,
                "saved configuration is for a {found} Hz loop, not this board's"
            ),
        }
    }
}

impl core::error::Error for LoadError {}

/// Why a record could not be written into a page image.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StoreError {
    /// The page image is shorter than the record ([`MAX_RECORD_LEN`] always suffices).
    PageTooSmall {
        /// Bytes available.
        available: usize,
    },
    /// The configuration's encoding exceeds [`MAX_BODY_LEN`].
    TooLarge,
}

impl fmt::Display for StoreError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StoreError::PageTooSmall { available } => write!(
                f,
                "a page image of {available} bytes cannot hold the record ({MAX_RECORD_LEN} \
                 always suffice)"
            ),
            StoreError::TooLarge => f.write_str("the configuration exceeds the record's body"),
        }
    }
}

impl core::error::Error for StoreError {}

/// Writes the record of `params` with `sequence` at the start of `page` (the rest is left
/// as it is: erased flash reads 0xFF); returns the record's length.
pub fn encode(params: &ParamSet, sequence: u32, page: &mut [u8]) -> Result<usize, StoreError> {
    let available = page.len();
    let too_small = StoreError::PageTooSmall { available };
    let (header, rest) = page.split_at_mut_checked(HEADER_LEN).ok_or(too_small)?;
    let body_room = rest.len().min(MAX_BODY_LEN);
    // The link's own encoder: the same code that encodes the configuration for the link
    // and its hash, not a second copy.
    let body_len = match link::encode_body(params, rest.get_mut(..body_room).unwrap_or_default()) {
        Ok(len) => len,
        Err(_) if body_room < MAX_BODY_LEN => return Err(too_small),
        Err(_) => return Err(StoreError::TooLarge),
    };
    let length = u32::try_from(body_len).map_err(|_| StoreError::TooLarge)?;
    for (i, word) in [RECORD_MAGIC, RECORD_SCHEMA, sequence, length]
        .into_iter()
        .enumerate()
    {
        if let Some(slot) = header.get_mut(i * 4..i * 4 + 4) {
            slot.copy_from_slice(&word.to_le_bytes());
        }
    }
    let end = HEADER_LEN + body_len;
    let crc = crc32(page.get(..end).unwrap_or_default());
    page.get_mut(end..end + CRC_LEN)
        .ok_or(too_small)?
        .copy_from_slice(&crc.to_le_bytes());
    Ok(end + CRC_LEN)
}

/// Reads the record at the start of `page` for a board whose loop runs at
/// `control_rate_hz` (Hz): a configuration that passes the core's checks, or why not.
pub fn decode(page: &[u8], control_rate_hz: u32) -> Result<Loaded, LoadError> {
    let word = |i: usize| {
        page.get(i * 4..i * 4 + 4)
            .and_then(|b| b.try_into().ok())
            .map(u32::from_le_bytes)
    };
    let (Some(magic), Some(schema), Some(sequence), Some(length)) =
        (word(0), word(1), word(2), word(3))
    else {
        return Err(LoadError::BadLength { length: 0 });
    };
    if [magic, schema, sequence, length]
        .iter()
        .all(|&w| w == u32::MAX)
    {
        return Err(LoadError::Erased);
    }
    if magic != RECORD_MAGIC {
        return Err(LoadError::NoRecord { magic });
    }
    let body_len = usize::try_from(length).unwrap_or(usize::MAX);
    let end = HEADER_LEN.saturating_add(body_len);
    let (Some(covered), Some(stored)) = (
        page.get(..end).filter(|_| body_len <= MAX_BODY_LEN),
        page.get(end..end.saturating_add(CRC_LEN))
            .and_then(|b| b.try_into().ok())
            .map(u32::from_le_bytes),
    ) else {
        return Err(LoadError::BadLength { length });
    };
    if crc32(covered) != stored {
        return Err(LoadError::Corrupt);
    }
    if schema != RECORD_SCHEMA {
        return Err(LoadError::ForeignSchema { found: schema });
    }
    let body = covered.get(HEADER_LEN..).unwrap_or_default();
    // The body is a `ParamSet`, which postcard writes as its two fields one after the
    // other. Read as two halves, each by a function of its own, it is not moved whole
    // through the deserializer's results, whose copies are stack.
    let Some((robot, rest)) = take_robot(body) else {
        return Err(LoadError::Undecodable);
    };
    let Some((supervisor, [])) = take_supervisor(rest) else {
        return Err(LoadError::Undecodable);
    };
    let checked = Params::new(robot).map_err(LoadError::InvalidRobot)?;
    if robot.control_rate_hz != control_rate_hz {
        return Err(LoadError::WrongControlRate {
            found: robot.control_rate_hz,
        });
    }
    supervisor
        .validate(&checked)
        .map_err(LoadError::InvalidSupervisor)?;
    Ok(Loaded {
        params: ParamSet { robot, supervisor },
        sequence,
    })
}

/// A robot configuration from the front of `bytes`, and the bytes after it. Not inlined
/// (nor [`take_supervisor`]): the deserializer's temporaries, copies of what it reads,
/// are then in a frame that is gone before [`decode`] goes on.
#[inline(never)]
fn take_robot(bytes: &[u8]) -> Option<(RobotConfig, &[u8])> {
    postcard::take_from_bytes(bytes).ok()
}

/// A supervisor configuration from the front of `bytes`, and the bytes after it
/// ([`take_robot`]).
#[inline(never)]
fn take_supervisor(bytes: &[u8]) -> Option<(SupervisorConfig, &[u8])> {
    postcard::take_from_bytes(bytes).ok()
}

/// One of the two pages.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Slot {
    /// The first page.
    A,
    /// The second page.
    B,
}

impl Slot {
    /// The other page.
    pub const fn other(self) -> Slot {
        match self {
            Slot::A => Slot::B,
            Slot::B => Slot::A,
        }
    }
}

/// Where to write next: the page and the sequence number for the record.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct WritePlan {
    /// The page to erase and write.
    pub slot: Slot,
    /// The sequence number to write.
    pub sequence: u32,
}

impl WritePlan {
    /// The plan after the newest valid record, given as its page and sequence number:
    /// the other page and the next number (page A and 1 when there is none).
    fn after(newest: Option<(Slot, u32)>) -> Self {
        match newest {
            Some((slot, sequence)) => WritePlan {
                slot: slot.other(),
                sequence: sequence.wrapping_add(1),
            },
            None => WritePlan {
                slot: Slot::A,
                sequence: 1,
            },
        }
    }

    /// The plan for pages `a` and `b` (as [`Slots::next_write`] makes it from
    /// [`Slots::scan`]), reading one page at a time and keeping only its sequence number:
    /// the link task writes flash with it, and two decoded records would cost its stack
    /// 600 bytes.
    #[inline(always)]
    pub fn for_pages(a: &[u8], b: &[u8], control_rate_hz: u32) -> Self {
        let a = valid_sequence(a, control_rate_hz);
        let b = valid_sequence(b, control_rate_hz);
        Self::after(newest_sequence(a, b))
    }
}

/// The sequence number of the valid record on `page` ([`decode`]), if it holds one.
/// Inlined, so that the decoded record's storage is the caller's, shared with its other
/// temporaries, rather than a frame of its own on top of [`decode`]'s.
#[inline(always)]
fn valid_sequence(page: &[u8], control_rate_hz: u32) -> Option<u32> {
    decode(page, control_rate_hz)
        .ok()
        .map(|loaded| loaded.sequence)
}

/// Of two pages' valid records, given by their sequence numbers, the newest (A when both
/// are equally new): its page and number.
fn newest_sequence(a: Option<u32>, b: Option<u32>) -> Option<(Slot, u32)> {
    match (a, b) {
        (Some(a), Some(b)) if is_newer(b, a) => Some((Slot::B, b)),
        (Some(a), _) => Some((Slot::A, a)),
        (None, Some(b)) => Some((Slot::B, b)),
        (None, None) => None,
    }
}

/// What the two pages hold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Slots {
    /// Page A's record, or why it has none.
    pub a: Result<Loaded, LoadError>,
    /// Page B's record, or why it has none.
    pub b: Result<Loaded, LoadError>,
}

impl Slots {
    /// Reads both pages (see [`decode`]).
    pub fn scan(a: &[u8], b: &[u8], control_rate_hz: u32) -> Self {
        Self {
            a: decode(a, control_rate_hz),
            b: decode(b, control_rate_hz),
        }
    }

    /// The valid record with the newest sequence number (A when both are equally new),
    /// or `None` when neither page has one: then use the defaults.
    pub fn newest(&self) -> Option<(Slot, &Loaded)> {
        let sequence = |page: &Result<Loaded, LoadError>| page.as_ref().ok().map(|l| l.sequence);
        let (slot, _) = newest_sequence(sequence(&self.a), sequence(&self.b))?;
        let page = match slot {
            Slot::A => &self.a,
            Slot::B => &self.b,
        };
        page.as_ref().ok().map(|loaded| (slot, loaded))
    }

    /// The page that does not hold the newest record, and the sequence number after it
    /// (page A and 1 when there is none).
    pub fn next_write(&self) -> WritePlan {
        WritePlan::after(self.newest().map(|(slot, loaded)| (slot, loaded.sequence)))
    }
}

/// Serial-number order: `a` is newer than `b` when it is less than 2³¹ ahead (so the
/// sequence may wrap).
const fn is_newer(a: u32, b: u32) -> bool {
    let ahead = a.wrapping_sub(b);
    ahead != 0 && ahead < 1 << 31
}

#[cfg(test)]
mod tests {
    use super::*;
    use controller_core::kinematics::{Pose, WheelSpeeds};
    use controller_core::params::RobotConfig;
    use controller_core::supervisor::SupervisorConfig;

    const RATE: u32 = 1000;

    fn params() -> ParamSet {
        let mut robot = RobotConfig::REFERENCE_ROBOT;
        // A calibrated robot: unequal wheels.
        robot.wheel_radius_left_m = 0.0324;
        robot.track_width_m = 0.1512;
        ParamSet {
            robot,
            supervisor: SupervisorConfig::at_rate(
                RATE,
                Pose::new(0.5, -0.2, 1.0),
                WheelSpeeds::new(4.0, 4.0),
            ),
        }
    }

    fn page(params: &ParamSet, sequence: u32) -> [u8; 512] {
        let mut page = [0xff; 512];
        let len = encode(params, sequence, &mut page);
        assert!(len.is_ok(), "{len:?}");
        page
    }

    /// Rewrites the CRC after a deliberate change of the record.
    fn reseal(page: &mut [u8]) {
        let body = u32::from_le_bytes(page[12..16].try_into().unwrap()) as usize;
        let crc = crc32(&page[..HEADER_LEN + body]);
        page[HEADER_LEN + body..HEADER_LEN + body + 4].copy_from_slice(&crc.to_le_bytes());
    }

    #[test]
    fn a_record_reads_back_as_written() {
        let p = params();
        let mut page = [0xff; 512];
        let len = encode(&p, 7, &mut page).expect("fits");
        assert_eq!(
            decode(&page, RATE),
            Ok(Loaded {
                params: p,
                sequence: 7
            })
        );
        // The body is postcard's encoding of the ParamSet.
        let body = postcard::to_allocvec(&p).unwrap();
        assert_eq!(&page[HEADER_LEN..HEADER_LEN + body.len()], &body[..]);
        assert_eq!(&page[..4], b"RPRM");
        // The length returned is the whole record's: header, body and CRC, and nothing
        // after it is written.
        assert_eq!(len, HEADER_LEN + body.len() + CRC_LEN);
        assert!(page[len..].iter().all(|&b| b == 0xff));
        assert!(len <= MAX_RECORD_LEN);
    }

    #[test]
    fn the_sequence_is_newer_when_less_than_half_the_range_ahead() {
        assert!(is_newer(1, 0) && !is_newer(0, 1) && !is_newer(5, 5));
        // Across the wrap.
        assert!(is_newer(2, u32::MAX - 1));
        // Half the range ahead is as far behind: neither is newer.
        assert!(is_newer((1 << 31) - 1, 0));
        assert!(!is_newer(1 << 31, 0) && !is_newer(0, 1 << 31));
    }

    #[test]
    fn the_store_errors_say_what_went_wrong() {
        assert_eq!(
            StoreError::PageTooSmall { available: 40 }.to_string(),
            format!(
                "a page image of 40 bytes cannot hold the record ({MAX_RECORD_LEN} always \
                 suffice)"
            )
        );
        assert_eq!(
            StoreError::TooLarge.to_string(),
            "the configuration exceeds the record's body"
        );
    }

    #[test]
    fn an_erased_page_is_erased() {
        assert_eq!(decode(&[0xff; 512], RATE), Err(LoadError::Erased));
    }

    #[test]
    fn a_page_of_something_else_is_no_record() {
        assert_eq!(
            decode(&[0; 64], RATE),
            Err(LoadError::NoRecord { magic: 0 })
        );
    }

    #[test]
    fn a_flipped_bit_anywhere_is_corrupt() {
        let good = page(&params(), 1);
        let body = u32::from_le_bytes(good[12..16].try_into().unwrap()) as usize;
        // Every bit of the body and of the CRC; the header's fields have their own errors.
        for byte in [8usize, 9, 20, HEADER_LEN + body / 2, HEADER_LEN + body + 1] {
            let mut bad = good;
            bad[byte] ^= 0x10;
            assert_eq!(decode(&bad, RATE), Err(LoadError::Corrupt), "byte {byte}");
        }
    }

    #[test]
    fn an_impossible_length_is_refused_not_read() {
        let mut bad = page(&params(), 1);
        bad[12..16].copy_from_slice(&100_000u32.to_le_bytes());
        assert_eq!(
            decode(&bad, RATE),
            Err(LoadError::BadLength { length: 100_000 })
        );
        // A record cut by the end of the page.
        let good = page(&params(), 1);
        assert!(matches!(
            decode(&good[..40], RATE),
            Err(LoadError::BadLength { .. })
        ));
        assert!(matches!(
            decode(&good[..10], RATE),
            Err(LoadError::BadLength { .. })
        ));
    }

    #[test]
    fn a_record_of_another_shape_is_foreign() {
        let mut foreign = page(&params(), 1);
        foreign[4..8].copy_from_slice(&0x1234_5678u32.to_le_bytes());
        reseal(&mut foreign);
        assert_eq!(
            decode(&foreign, RATE),
            Err(LoadError::ForeignSchema { found: 0x1234_5678 })
        );
    }

    #[test]
    fn invalid_values_are_refused_with_the_cores_verdict() {
        let mut p = params();
        p.robot.wheel_radius_right_m = -1.0;
        let Err(LoadError::InvalidRobot(e)) = decode(&page(&p, 1), RATE) else {
            panic!("accepted a negative radius");
        };
        assert_eq!(e.field(), "wheel_radius_right_m");
        let mut p = params();
        p.supervisor.heartbeat_timeout_steps = 0;
        assert_eq!(
            decode(&page(&p, 1), RATE),
            Err(LoadError::InvalidSupervisor(
                SupervisorConfigError::ZeroHeartbeatTimeout
            ))
        );
        assert_eq!(
            decode(&page(&params(), 1), 500),
            Err(LoadError::WrongControlRate { found: 1000 })
        );
        // A body that is not a ParamSet.
        let mut junk = page(&params(), 1);
        junk[12..16].copy_from_slice(&3u32.to_le_bytes());
        reseal(&mut junk);
        assert_eq!(decode(&junk, RATE), Err(LoadError::Undecodable));
        // A whole ParamSet and one byte more; a ParamSet one byte short (the two halves
        // are read one after the other: the second must end the body exactly).
        let whole = page(&params(), 1);
        let body = u32::from_le_bytes([whole[12], whole[13], whole[14], whole[15]]);
        for length in [body + 1, body - 1] {
            let mut cut = whole;
            cut[HEADER_LEN + body as usize] = 0;
            cut[12..16].copy_from_slice(&length.to_le_bytes());
            reseal(&mut cut);
            assert_eq!(decode(&cut, RATE), Err(LoadError::Undecodable), "{length}");
        }
    }

    #[test]
    fn a_small_page_image_is_refused() {
        let mut small = [0u8; 40];
        assert_eq!(
            encode(&params(), 1, &mut small),
            Err(StoreError::PageTooSmall { available: 40 })
        );
        let mut tiny = [0u8; 8];
        assert_eq!(
            encode(&params(), 1, &mut tiny),
            Err(StoreError::PageTooSmall { available: 8 })
        );
        let mut exact = [0u8; MAX_RECORD_LEN];
        assert!(encode(&params(), 1, &mut exact).is_ok());
    }

    #[test]
    fn every_error_has_its_own_name() {
        let errors = [
            LoadError::Erased,
            LoadError::NoRecord { magic: 0 },
            LoadError::BadLength { length: 0 },
            LoadError::Corrupt,
            LoadError::ForeignSchema { found: 0 },
            LoadError::Undecodable,
            LoadError::InvalidRobot(ParamError::ZeroControlRate),
            LoadError::InvalidSupervisor(SupervisorConfigError::BadGeofence),
            LoadError::WrongControlRate { found: 0 },
        ];
        for (i, a) in errors.iter().enumerate() {
            for b in &errors[i + 1..] {
                assert_ne!(a.name(), b.name());
            }
        }
        assert_eq!(
            LoadError::ForeignSchema { found: 0xab }.to_string(),
            format!(
                "parameter record of another firmware (schema 0x000000ab, this one \
                 0x{RECORD_SCHEMA:08x})"
            )
        );
    }

    #[test]
    fn the_newest_valid_page_wins_and_the_other_is_written_next() {
        let old = params();
        let mut new = params();
        new.robot.track_width_m = 0.149;
        let erased = [0xff; 512];

        let slots = Slots::scan(&erased, &erased, RATE);
        assert_eq!(slots.newest(), None);
        assert_eq!(
            WritePlan::for_pages(&erased, &erased, RATE),
            slots.next_write()
        );
        assert_eq!(
            slots.next_write(),
            WritePlan {
                slot: Slot::A,
                sequence: 1
            }
        );

        let (a, b) = (page(&old, 1), page(&new, 2));
        let slots = Slots::scan(&a, &b, RATE);
        assert_eq!(WritePlan::for_pages(&a, &b, RATE), slots.next_write());
        assert_eq!(
            slots.newest().map(|(s, l)| (s, l.params)),
            Some((Slot::B, new))
        );
        assert_eq!(
            slots.next_write(),
            WritePlan {
                slot: Slot::A,
                sequence: 3
            }
        );

        // The sequence wraps: 0 is newer than u32::MAX.
        let (a, b) = (page(&new, 0), page(&old, u32::MAX));
        let slots = Slots::scan(&a, &b, RATE);
        assert_eq!(WritePlan::for_pages(&a, &b, RATE), slots.next_write());
        assert_eq!(
            WritePlan::for_pages(&b, &a, RATE),
            WritePlan {
                slot: Slot::A,
                sequence: 1
            },
            "the same records the other way round"
        );
        assert_eq!(slots.newest().map(|(s, _)| s), Some(Slot::A));
        assert_eq!(slots.next_write().slot, Slot::B);
        assert_eq!(slots.next_write().sequence, 1);
    }

    #[test]
    fn a_write_cut_short_leaves_the_previous_record() {
        let old = params();
        let mut new = params();
        new.supervisor.brake_steps = 123;
        let a = page(&old, 5);
        // The write of B (sequence 6) was cut after half the record.
        let full = page(&new, 6);
        let mut b = [0xff; 512];
        b[..60].copy_from_slice(&full[..60]);
        let slots = Slots::scan(&a, &b, RATE);
        assert_eq!(slots.b.map(|l| l.sequence), Err(LoadError::Corrupt));
        assert_eq!(
            slots.newest().map(|(s, l)| (s, l.params)),
            Some((Slot::A, old))
        );
        assert_eq!(
            slots.next_write(),
            WritePlan {
                slot: Slot::B,
                sequence: 6
            }
        );
        assert_eq!(WritePlan::for_pages(&a, &b, RATE), slots.next_write());
        assert_eq!(
            WritePlan::for_pages(&b, &a, RATE),
            WritePlan {
                slot: Slot::A,
                sequence: 6
            },
            "only the intact page counts, whichever it is"
        );
    }
}
