//! A small record of the last panic or hard fault, kept in RAM that survives a reset, so
//! the next boot can report what happened even when the log frame of the failure was
//! lost (a panic that interrupts a log frame cannot log, and no probe may be attached).
//!
//! The firmware keeps [`WORDS`] words in a section that the start-up code neither loads
//! nor zeroes (`.uninit`), writes them with [`PanicRecord::to_words`] from its panic and
//! hard-fault handlers, and at the next boot reads them back with
//! [`PanicRecord::from_words`], which accepts them only if the magic, the layout version,
//! the lengths and the CRC-32 all check out (after a power-on the RAM holds noise). The
//! words stay, across further resets, until a host has read them over the link and
//! cleared them
//! ([`PanicRecordStore`], `GetPanicRecord` and `ClearPanicRecord`). This module is the
//! board-free half: layout, bounded copies, CRC, the report on the link.

use core::fmt;

use link::{PanicReport, PANIC_FILE_CAP, PANIC_MESSAGE_CAP};

/// Words of RAM the record occupies (128 bytes).
pub const WORDS: usize = 32;
/// Bytes of the source file path kept (its end: the file name matters most).
pub const FILE_BYTES: usize = 52;
/// Bytes of the message kept (its beginning).
pub const MESSAGE_BYTES: usize = 56;

const MAGIC: u32 = 0x5041_4E43; // "PANC"
const VERSION: u32 = 1;
const HEADER_WORDS: usize = 5;
const FILE_WORDS: usize = FILE_BYTES / 4;
const _: () = assert!(HEADER_WORDS + FILE_WORDS + MESSAGE_BYTES / 4 == WORDS);
const _: () = assert!(FILE_BYTES % 4 == 0 && MESSAGE_BYTES % 4 == 0);
// The link carries the record whole.
const _: () = assert!(FILE_BYTES == PANIC_FILE_CAP && MESSAGE_BYTES == PANIC_MESSAGE_CAP);

/// Where a board keeps the record of the failure that ended a previous run: on the
/// firmware, RAM that survives a reset; the virtual robot keeps none. The link service
/// answers `GetPanicRecord` and `ClearPanicRecord` through it.
pub trait PanicRecordStore {
    /// The record, if the store holds an intact one. Reading does not clear it.
    fn panic_record(&self) -> Option<PanicRecord>;
    /// Forgets the record (a host has shown it).
    fn clear_panic_record(&self);
}

/// What ended the previous run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FailureKind {
    /// A Rust panic (file, line and message prefix are known).
    Panic,
    /// A HardFault exception (the record's `pc` is the faulting instruction).
    HardFault,
}

impl FailureKind {
    const fn code(self) -> u32 {
        match self {
            FailureKind::Panic => 1,
            FailureKind::HardFault => 2,
        }
    }

    const fn from_code(code: u32) -> Option<Self> {
        match code {
            1 => Some(FailureKind::Panic),
            2 => Some(FailureKind::HardFault),
            _ => None,
        }
    }

    /// `"panic"` or `"hard fault"`.
    pub const fn name(self) -> &'static str {
        match self {
            FailureKind::Panic => "panic",
            FailureKind::HardFault => "hard fault",
        }
    }
}

/// A bounded UTF-8 text buffer of `N` bytes that truncates at a character boundary and
/// never fails: what does not fit is dropped. Used to keep a message prefix without any
/// allocation or panic.
#[derive(Clone, Copy, PartialEq, Eq)]
pub struct BoundedText<const N: usize> {
    bytes: [u8; N],
    len: usize,
}

impl<const N: usize> BoundedText<N> {
    /// An empty buffer.
    pub const fn new() -> Self {
        Self {
            bytes: [0; N],
            len: 0,
        }
    }

    /// The text kept so far.
    pub fn as_str(&self) -> &str {
        let kept = self.bytes.get(..self.len).unwrap_or(&[]);
        match core::str::from_utf8(kept) {
            Ok(s) => s,
            // Only whole characters are ever stored, so this cannot happen; stay total.
            Err(e) => {
                core::str::from_utf8(kept.get(..e.valid_up_to()).unwrap_or(&[])).unwrap_or("")
            }
        }
    }

    /// True when something was dropped because the buffer was full.
    pub fn is_full(&self) -> bool {
        self.len == N
    }

    /// Appends as many whole characters of `s` as fit.
    pub fn push_str(&mut self, s: &str) {
        for c in s.chars() {
            let mut utf8 = [0u8; 4];
            let encoded = c.encode_utf8(&mut utf8).as_bytes();
            let end = self.len + encoded.len();
            match self.bytes.get_mut(self.len..end) {
                Some(slot) => slot.copy_from_slice(encoded),
                None => return,
            }
            self.len = end;
        }
    }

    /// Replaces the content with the last bytes of `s` that fit, starting at a character
    /// boundary (for file paths, whose end is the informative part).
    pub fn set_suffix(&mut self, s: &str) {
        let mut start = s.len().saturating_sub(N);
        while !s.is_char_boundary(start) {
            start += 1;
        }
        self.len = 0;
        self.push_str(s.get(start..).unwrap_or(""));
    }
}

impl<const N: usize> Default for BoundedText<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> fmt::Write for BoundedText<N> {
    fn write_str(&mut self, s: &str) -> fmt::Result {
        self.push_str(s);
        Ok(())
    }
}

impl<const N: usize> fmt::Debug for BoundedText<N> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Debug::fmt(self.as_str(), f)
    }
}

/// The last failure: what, where, the start of its message.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PanicRecord {
    kind: FailureKind,
    line: u32,
    pc: u32,
    file: BoundedText<FILE_BYTES>,
    message: BoundedText<MESSAGE_BYTES>,
}

impl PanicRecord {
    /// A panic at `file:line`; `message` is filled by the caller through
    /// [`PanicRecord::message_mut`] (a `fmt::Write` that keeps the first bytes).
    pub fn panic(file: &str, line: u32) -> Self {
        let mut record = Self {
            kind: FailureKind::Panic,
            line,
            pc: 0,
            file: BoundedText::new(),
            message: BoundedText::new(),
        };
        record.file.set_suffix(file);
        record
    }

    /// A hard fault at program counter `pc`.
    pub fn hard_fault(pc: u32) -> Self {
        Self {
            kind: FailureKind::HardFault,
            line: 0,
            pc,
            file: BoundedText::new(),
            message: BoundedText::new(),
        }
    }

    /// The message buffer, to write into.
    pub fn message_mut(&mut self) -> &mut BoundedText<MESSAGE_BYTES> {
        &mut self.message
    }

    /// Panic or hard fault.
    pub fn kind(&self) -> FailureKind {
        self.kind
    }

    /// The end of the source path (at most [`FILE_BYTES`] bytes); empty for a hard fault.
    pub fn file(&self) -> &str {
        self.file.as_str()
    }

    /// The source line; 0 for a hard fault.
    pub fn line(&self) -> u32 {
        self.line
    }

    /// The faulting program counter; 0 for a panic.
    pub fn pc(&self) -> u32 {
        self.pc
    }

    /// The start of the message (at most [`MESSAGE_BYTES`] bytes).
    pub fn message(&self) -> &str {
        self.message.as_str()
    }

    /// The record as the link carries it.
    pub fn report(&self) -> PanicReport {
        PanicReport {
            kind: match self.kind {
                FailureKind::Panic => link::FailureKind::Panic,
                FailureKind::HardFault => link::FailureKind::HardFault,
            },
            file: link::bounded(self.file()),
            line: self.line,
            pc: self.pc,
            message: link::bounded(self.message()),
        }
    }

    /// The record as it is stored: magic, CRC-32 of the rest, then the fields.
    pub fn to_words(&self) -> [u32; WORDS] {
        let mut words = [0u32; WORDS];
        words[2] = VERSION
            | (self.kind.code() << 8)
            | ((self.file.len as u32) << 16)
            | ((self.message.len as u32) << 24);
        words[3] = self.line;
        words[4] = self.pc;
        pack(
            &self.file.bytes,
            &mut words[HEADER_WORDS..HEADER_WORDS + FILE_WORDS],
        );
        pack(&self.message.bytes, &mut words[HEADER_WORDS + FILE_WORDS..]);
        words[1] = crc32_words(&words[2..]);
        words[0] = MAGIC;
        words
    }

    /// The record stored in `words`, or `None` if they do not hold one (wrong magic,
    /// version, kind or lengths, bad CRC, or text that is not UTF-8).
    pub fn from_words(words: &[u32; WORDS]) -> Option<Self> {
        if words[0] != MAGIC || words[1] != crc32_words(&words[2..]) {
            return None;
        }
        let header = words[2];
        if header & 0xFF != VERSION {
            return None;
        }
        let kind = FailureKind::from_code((header >> 8) & 0xFF)?;
        let file_len = ((header >> 16) & 0xFF) as usize;
        let message_len = (header >> 24) as usize;
        if file_len > FILE_BYTES || message_len > MESSAGE_BYTES {
            return None;
        }
        let mut file = BoundedText::<FILE_BYTES>::new();
        unpack(
            &words[HEADER_WORDS..HEADER_WORDS + FILE_WORDS],
            &mut file.bytes,
        );
        file.len = file_len;
        let mut message = BoundedText::<MESSAGE_BYTES>::new();
        unpack(&words[HEADER_WORDS + FILE_WORDS..], &mut message.bytes);
        message.len = message_len;
        let text_ok = |b: &[u8]| core::str::from_utf8(b).is_ok();
        if !text_ok(&file.bytes[..file_len]) || !text_ok(&message.bytes[..message_len]) {
            return None;
        }
        Some(Self {
            kind,
            line: words[3],
            pc: words[4],
            file,
            message,
        })
    }
}

/// The words of a cleared record (never valid).
pub const CLEARED: [u32; WORDS] = [0; WORDS];

fn pack(bytes: &[u8], words: &mut [u32]) {
    for (word, chunk) in words.iter_mut().zip(bytes.chunks(4)) {
        let mut b = [0u8; 4];
        for (dst, src) in b.iter_mut().zip(chunk) {
            *dst = *src;
        }
        *word = u32::from_le_bytes(b);
    }
}

fn unpack(words: &[u32], bytes: &mut [u8]) {
    for (chunk, word) in bytes.chunks_mut(4).zip(words) {
        for (dst, src) in chunk.iter_mut().zip(word.to_le_bytes()) {
            *dst = src;
        }
    }
}

/// CRC-32 (IEEE 802.3, reflected polynomial 0xEDB88320, initial and final XOR all ones)
/// of the little-endian bytes of `words`, four bits at a time from a 16-entry table.
pub fn crc32_words(words: &[u32]) -> u32 {
    const TABLE: [u32; 16] = nibble_table();
    let mut crc = u32::MAX;
    for word in words {
        for byte in word.to_le_bytes() {
            crc ^= u32::from(byte);
            crc = (crc >> 4) ^ TABLE[(crc & 0xF) as usize];
            crc = (crc >> 4) ^ TABLE[(crc & 0xF) as usize];
        }
    }
    !crc
}

/// The CRC of each 4-bit value, for [`crc32_words`].
const fn nibble_table() -> [u32; 16] {
    let mut table = [0u32; 16];
    let mut i = 0;
    while i < 16 {
        let mut crc = i as u32;
        let mut bit = 0;
        while bit < 4 {
            crc = if crc & 1 != 0 {
                (crc >> 1) ^ 0xEDB8_8320
            } else {
                crc >> 1
            };
            bit += 1;
        }
        table[i] = crc;
        i += 1;
    }
    table
}

#[cfg(test)]
mod tests {
    use super::*;
    use core::fmt::Write as _;

    #[test]
    fn crc_matches_the_standard_check_value() {
        // CRC-32/ISO-HDLC of the bytes "12345678" (what zlib's crc32 gives).
        let words = [u32::from_le_bytes(*b"1234"), u32::from_le_bytes(*b"5678")];
        assert_eq!(crc32_words(&words), 0x9AE0_DAAF);
    }

    #[test]
    fn round_trip_keeps_file_end_and_message_start() {
        let long_path = "/home/someone/projects/robot/firmware/src/some/deep/module/motor.rs";
        let mut r = PanicRecord::panic(long_path, 123);
        write!(
            r.message_mut(),
            "index out of bounds: the len is {} but the index is {}",
            3,
            17
        )
        .unwrap();
        let back = PanicRecord::from_words(&r.to_words()).unwrap();
        assert_eq!(back, r);
        assert_eq!(back.kind(), FailureKind::Panic);
        assert_eq!(back.line(), 123);
        assert!(back.file().ends_with("deep/module/motor.rs"));
        assert_eq!(back.file().len(), FILE_BYTES);
        assert_eq!(
            back.message(),
            "index out of bounds: the len is 3 but the index is 17"
        );
        let hf = PanicRecord::hard_fault(0x0800_1234);
        let back = PanicRecord::from_words(&hf.to_words()).unwrap();
        assert_eq!(
            (back.kind(), back.pc(), back.file()),
            (FailureKind::HardFault, 0x0800_1234, "")
        );
    }

    #[test]
    fn the_link_report_carries_the_whole_record() {
        let long_path = "/home/someone/projects/robot/firmware/src/some/deep/module/motor.rs";
        let mut r = PanicRecord::panic(long_path, 123);
        r.message_mut().push_str(&"m".repeat(MESSAGE_BYTES + 10));
        let report = r.report();
        assert_eq!(report.kind, link::FailureKind::Panic);
        assert_eq!(report.file.as_str(), r.file());
        assert_eq!(report.file.len(), FILE_BYTES);
        assert_eq!(report.message.len(), MESSAGE_BYTES);
        assert_eq!(report.line, 123);
        let fault = PanicRecord::hard_fault(0x0800_1234).report();
        assert_eq!(
            (fault.kind, fault.pc, fault.file.as_str()),
            (link::FailureKind::HardFault, 0x0800_1234, "")
        );
    }

    #[test]
    fn truncation_is_at_character_boundaries() {
        let mut t = BoundedText::<5>::new();
        t.push_str("ab€c"); // € is 3 bytes: "ab€" is exactly 5
        assert_eq!(t.as_str(), "ab€");
        assert!(t.is_full());
        let mut t = BoundedText::<4>::new();
        t.push_str("ab€");
        assert_eq!(t.as_str(), "ab");
        let mut t = BoundedText::<4>::new();
        t.set_suffix("x€yz"); // the last 4 bytes start inside €
        assert_eq!(t.as_str(), "yz");
        t.set_suffix("ok");
        assert_eq!(t.as_str(), "ok");
    }

    #[test]
    fn noise_and_damage_are_rejected() {
        assert_eq!(PanicRecord::from_words(&CLEARED), None);
        let good = PanicRecord::panic("src/main.rs", 7).to_words();
        assert!(PanicRecord::from_words(&good).is_some());
        // Any single flipped bit anywhere is caught.
        for i in 0..WORDS {
            for bit in [0, 13, 31] {
                let mut w = good;
                w[i] ^= 1 << bit;
                assert_eq!(PanicRecord::from_words(&w), None, "word {i} bit {bit}");
            }
        }
        // Lengths beyond the buffers are refused even with a matching CRC.
        let mut w = good;
        w[2] = (w[2] & 0x00FF_FFFF) | (200 << 24);
        w[1] = crc32_words(&w[2..]);
        assert_eq!(PanicRecord::from_words(&w), None);
        // Random RAM after power-on.
        let mut seed = 1u32;
        for _ in 0..1000 {
            let mut w = [0u32; WORDS];
            for x in w.iter_mut() {
                seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
                *x = seed;
            }
            assert_eq!(PanicRecord::from_words(&w), None);
        }
    }
}
