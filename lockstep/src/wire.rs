//! The wire form shared by every message: a fixed buffer writer, a reader that refuses to
//! run past its bytes, and the assembler that collects a message's bytes until they
//! parse. Integers are LEB128 varints (zig-zag for signed), `f32` their four IEEE bytes,
//! little-endian.

/// Writer into a fixed buffer (bytes past its end are dropped; the buffers are sized
/// for the longest message).
pub(crate) struct Writer<'a> {
    pub(crate) out: &'a mut [u8],
    pub(crate) at: usize,
}

impl Writer<'_> {
    pub(crate) fn bytes(&mut self, bytes: &[u8]) {
        if let Some(slot) = self.out.get_mut(self.at..self.at + bytes.len()) {
            slot.copy_from_slice(bytes);
        }
        self.at += bytes.len();
    }
    pub(crate) fn u8(&mut self, v: u8) {
        self.bytes(&[v]);
    }
    pub(crate) fn u16(&mut self, v: u16) {
        self.bytes(&v.to_le_bytes());
    }
    pub(crate) fn u32(&mut self, v: u32) {
        self.bytes(&v.to_le_bytes());
    }
    pub(crate) fn f32(&mut self, v: f32) {
        self.u32(v.to_bits());
    }
    /// LEB128: seven bits a byte, the high bit set on all but the last.
    pub(crate) fn varint(&mut self, mut v: u32) {
        while v >= 0x80 {
            self.u8(v as u8 | 0x80);
            v >>= 7;
        }
        self.u8(v as u8);
    }
    /// Zig-zag, then LEB128: small magnitudes of either sign take one byte.
    pub(crate) fn signed(&mut self, v: i32) {
        self.varint(((v << 1) ^ (v >> 31)) as u32);
    }
}

/// Reader of a message that may not have arrived whole: every read is `None` past the
/// bytes there are.
pub(crate) struct Reader<'a> {
    pub(crate) bytes: &'a [u8],
    pub(crate) at: usize,
}

impl Reader<'_> {
    pub(crate) fn array<const N: usize>(&mut self) -> Option<[u8; N]> {
        let bytes = self.bytes.get(self.at..self.at + N)?;
        self.at += N;
        bytes.try_into().ok()
    }
    pub(crate) fn u8(&mut self) -> Option<u8> {
        self.array::<1>().map(|[b]| b)
    }
    pub(crate) fn u16(&mut self) -> Option<u16> {
        self.array().map(u16::from_le_bytes)
    }
    pub(crate) fn u32(&mut self) -> Option<u32> {
        self.array().map(u32::from_le_bytes)
    }
    pub(crate) fn f32(&mut self) -> Option<f32> {
        self.u32().map(f32::from_bits)
    }
    /// A LEB128 varint of up to five bytes (longer ones read as their first five).
    pub(crate) fn varint(&mut self) -> Option<u32> {
        let mut value = 0u32;
        for shift in [0, 7, 14, 21, 28] {
            let byte = self.u8()?;
            value |= u32::from(byte & 0x7F) << shift;
            if byte & 0x80 == 0 {
                break;
            }
        }
        Some(value)
    }
    pub(crate) fn signed(&mut self) -> Option<i32> {
        self.varint().map(|z| ((z >> 1) as i32) ^ -((z & 1) as i32))
    }
}

/// What the bytes assembled so far hold.
pub(crate) enum Parse<T> {
    /// A whole message.
    Whole(T),
    /// Not yet: more bytes to come.
    Partial,
    /// Not a valid message.
    Invalid,
}

impl<T> Parse<T> {
    /// `Whole` for a message read, `Partial` when the reader ran out of bytes.
    pub(crate) fn read(value: Option<T>) -> Self {
        value.map_or(Parse::Partial, Parse::Whole)
    }
}

/// Collects a message's bytes until they parse.
#[derive(Clone, Debug)]
pub(crate) struct Assembler<const N: usize> {
    pub(crate) buf: [u8; N],
    pub(crate) len: usize,
    pub(crate) errors: u32,
}

impl<const N: usize> Assembler<N> {
    pub(crate) const fn new() -> Self {
        Self {
            buf: [0; N],
            len: 0,
            errors: 0,
        }
    }

    /// Takes `byte`. A first byte that `is_tag` refuses is dropped and counted; then the
    /// bytes so far go to `parse` until it has a whole message (or an invalid one,
    /// dropped and counted, as is one longer than `N` bytes).
    pub(crate) fn push<T>(
        &mut self,
        byte: u8,
        is_tag: impl Fn(u8) -> bool,
        parse: impl Fn(&[u8]) -> Parse<T>,
    ) -> Option<T> {
        if self.len == 0 && !is_tag(byte) {
            self.errors = self.errors.wrapping_add(1);
            return None;
        }
        let Some(slot) = self.buf.get_mut(self.len) else {
            self.len = 0;
            self.errors = self.errors.wrapping_add(1);
            return None;
        };
        *slot = byte;
        self.len += 1;
        match parse(self.buf.get(..self.len).unwrap_or_default()) {
            Parse::Partial => None,
            Parse::Whole(message) => {
                self.len = 0;
                Some(message)
            }
            Parse::Invalid => {
                self.len = 0;
                self.errors = self.errors.wrapping_add(1);
                None
            }
        }
    }
}
