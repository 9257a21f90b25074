//! The link's bounded transmit buffer: whole frames appended at the end, sent from the
//! front.

use link::{encode, Message};

/// Bytes of the transmit buffer. With the reply reserve held back (one frame of the
/// largest size, `link::MAX_FRAME_LEN` = 400 B), 212 B are left for telemetry (157 B a
/// sample) and events; the reserve and the replies to a full command queue (4 × 48 B)
/// fit with 20 B to spare (checked at compile time in `service`).
pub const TX_CAPACITY: usize = 612;

/// Frames waiting to go out, in order, in a fixed buffer.
///
/// [`TxBuffer::pending`] is what the board sends; the bytes of that slice stay where
/// they are until [`TxBuffer::consume`], so a DMA transfer may read them while new frames
/// are appended behind them.
#[derive(Clone, Debug)]
pub(crate) struct TxBuffer {
    bytes: [u8; TX_CAPACITY],
    len: usize,
}

impl TxBuffer {
    pub(crate) const fn new() -> Self {
        Self {
            bytes: [0; TX_CAPACITY],
            len: 0,
        }
    }

    /// Bytes free for new frames.
    pub(crate) const fn free(&self) -> usize {
        TX_CAPACITY.saturating_sub(self.len)
    }

    /// The bytes to send, oldest first.
    pub(crate) fn pending(&self) -> &[u8] {
        self.bytes.get(..self.len).unwrap_or(&[])
    }

    /// Forgets the first `sent` bytes of [`TxBuffer::pending`] (all of them if `sent` is
    /// larger) and moves the rest to the front.
    pub(crate) fn consume(&mut self, sent: usize) {
        let sent = sent.min(self.len);
        let rest = self.len - sent;
        // A byte loop rather than `copy_within`: that would be the firmware's only call of
        // `memmove`, whose general implementation costs 1.5 KiB of flash, to move a few
        // hundred bytes at most. The fence keeps the optimiser from turning the loop back
        // into that call.
        for i in 0..rest {
            if let Some(&byte) = self.bytes.get(i + sent) {
                if let Some(slot) = self.bytes.get_mut(i) {
                    *slot = byte;
                }
            }
        }
        self.len = rest;
    }

    /// Appends `message` as one frame if it fits and still leaves `keep_free` bytes free;
    /// true when appended. A frame that does not fit leaves the buffer as it was.
    pub(crate) fn append<M: Message>(&mut self, message: &M, keep_free: usize) -> bool {
        let end = TX_CAPACITY.saturating_sub(keep_free);
        let Some(room) = self.bytes.get_mut(self.len..end) else {
            return false;
        };
        match encode(message, room) {
            Ok(written) => {
                self.len += written;
                true
            }
            Err(_) => false,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use link::{Decoder, Received, Reply, Uplink};

    fn pong(nonce: u32) -> Uplink {
        Uplink::Reply {
            seq: 1,
            result: Ok(Reply::Pong { nonce }),
        }
    }

    #[test]
    fn frames_go_out_in_order_and_partial_sends_keep_the_rest() {
        let mut tx = TxBuffer::new();
        assert!(tx.append(&pong(1), 0));
        assert!(tx.append(&pong(2), 0));
        let frame_len = tx.pending().len() / 2;
        let mut decoder = Decoder::new();
        let mut got = std::vec::Vec::new();
        // Send 3 bytes, then the rest.
        for chunk in [3usize, usize::MAX] {
            let n = chunk.min(tx.pending().len());
            got.extend(decoder.feed::<Uplink>(&tx.pending()[..n]));
            tx.consume(n);
        }
        assert_eq!(
            got,
            [
                Ok(Received::Message(pong(1))),
                Ok(Received::Message(pong(2)))
            ]
        );
        assert_eq!(tx.free(), TX_CAPACITY);
        assert!(frame_len > 0);
    }

    #[test]
    fn a_frame_that_does_not_fit_above_the_reserve_is_not_appended() {
        let mut tx = TxBuffer::new();
        let mut frames = 0;
        while tx.append(&pong(7), 100) {
            frames += 1;
        }
        assert!(frames > 0);
        let before = tx.pending().len();
        assert!(tx.free() >= 100, "the reserve stays free");
        assert!(!tx.append(&pong(7), 100));
        assert_eq!(tx.pending().len(), before, "unchanged");
        // Without the reserve it fits again.
        assert!(tx.append(&pong(7), 0));
        // A reserve larger than the buffer refuses everything, without panicking.
        assert!(!tx.append(&pong(7), TX_CAPACITY + 1));
    }
}
