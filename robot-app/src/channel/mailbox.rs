//! A one-item hand-over between two contexts for data too large to queue: the sender
//! fills it, the receiver uses it in place and marks it done, and the sender reads it
//! back (to learn what was applied) and empties it.
//!
//! ```text
//!   Empty ──stage (sender)──► Staged ──finish (receiver)──► Done ──clear (sender)──► Empty
//! ```
//!
//! The state is one atomic byte; whoever the state names owns the item (the sender in
//! Empty and Done, the receiver in Staged), and the owner's `Release` store of the next
//! state hands it over. Nobody waits: a sender finds the box occupied, a receiver finds
//! nothing staged.

// Like the ring: the item is shared between two contexts and its owner is decided by the
// state byte, which the compiler cannot check.
#![allow(unsafe_code)]

use core::cell::UnsafeCell;
use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicU8, Ordering};

const EMPTY: u8 = 0;
const STAGED: u8 = 1;
const DONE: u8 = 2;

/// Room for one `T` handed from a [`Sender`] to a [`Receiver`] and back. Split it once
/// with [`Mailbox::split`].
pub struct Mailbox<T> {
    state: AtomicU8,
    item: UnsafeCell<MaybeUninit<T>>,
}

// SAFETY: the item moves between the two contexts (so `T: Send`) and the state byte gives
// it one owner at a time (module doc).
unsafe impl<T: Send> Sync for Mailbox<T> {}

impl<T> Default for Mailbox<T> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T> Mailbox<T> {
    /// An empty mailbox.
    pub const fn new() -> Self {
        Self {
            state: AtomicU8::new(EMPTY),
            item: UnsafeCell::new(MaybeUninit::uninit()),
        }
    }

    /// The two ends; each is the only one of its kind while it lives.
    pub fn split(&mut self) -> (Sender<'_, T>, Receiver<'_, T>) {
        let mailbox: &Self = self;
        (Sender { mailbox }, Receiver { mailbox })
    }
}

impl<T> Drop for Mailbox<T> {
    fn drop(&mut self) {
        if *self.state.get_mut() != EMPTY {
            // SAFETY: `&mut self`: no end is alive, and outside Empty the item is
            // initialised.
            unsafe { self.item.get_mut().assume_init_drop() };
        }
    }
}

/// The end that stages items and collects them back.
pub struct Sender<'a, T> {
    mailbox: &'a Mailbox<T>,
}

impl<T> Sender<'_, T> {
    /// Puts `item` in the mailbox for the receiver, or gives it back when the mailbox is
    /// not empty.
    pub fn stage(&mut self, item: T) -> Result<(), T> {
        let m = self.mailbox;
        if m.state.load(Ordering::Acquire) != EMPTY {
            return Err(item);
        }
        // SAFETY: Empty: the sender owns the (uninitialised) item; the receiver only reads
        // it once the Release store below publishes it.
        unsafe { (*m.item.get()).write(item) };
        m.state.store(STAGED, Ordering::Release);
        Ok(())
    }

    /// True while nothing is staged or waiting to be collected.
    pub fn is_empty(&self) -> bool {
        self.mailbox.state.load(Ordering::Acquire) == EMPTY
    }

    /// The item the receiver has finished with, left in the mailbox.
    pub fn done(&self) -> Option<&T> {
        let m = self.mailbox;
        if m.state.load(Ordering::Acquire) != DONE {
            return None;
        }
        // SAFETY: Done: the receiver gave the item back (its Release store is seen by the
        // Acquire load above) and will not touch it again until it is staged anew, which
        // only this sender does, not while the returned borrow of `self` lives.
        Some(unsafe { (*m.item.get()).assume_init_ref() })
    }

    /// Empties a mailbox the receiver has finished with (drops the item); does nothing
    /// in any other state.
    pub fn clear(&mut self) {
        let m = self.mailbox;
        if m.state.load(Ordering::Acquire) != DONE {
            return;
        }
        // SAFETY: Done: the sender owns the initialised item (see `done`).
        unsafe { (*m.item.get()).assume_init_drop() };
        m.state.store(EMPTY, Ordering::Release);
    }
}

/// The end that uses staged items in place.
pub struct Receiver<'a, T> {
    mailbox: &'a Mailbox<T>,
}

impl<T> Receiver<'_, T> {
    /// The staged item, if one is waiting.
    pub fn staged(&self) -> Option<&T> {
        let m = self.mailbox;
        if m.state.load(Ordering::Acquire) != STAGED {
            return None;
        }
        // SAFETY: Staged: the sender published the item (its Release store is seen by the
        // Acquire load above) and does not touch it until the receiver hands it back,
        // which only `finish` does, not while the returned borrow of `self` lives.
        Some(unsafe { (*m.item.get()).assume_init_ref() })
    }

    /// Hands a staged item back to the sender; does nothing when none is staged.
    pub fn finish(&mut self) {
        let m = self.mailbox;
        if m.state.load(Ordering::Acquire) == STAGED {
            m.state.store(DONE, Ordering::Release);
        }
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use std::sync::atomic::AtomicU32;

    #[test]
    fn an_item_goes_there_and_back() {
        let mut mailbox = Mailbox::<[u32; 8]>::new();
        let (mut tx, mut rx) = mailbox.split();
        assert!(tx.is_empty());
        assert_eq!(rx.staged(), None);
        assert_eq!(tx.stage([7; 8]), Ok(()));
        assert_eq!(tx.stage([9; 8]), Err([9; 8]), "occupied");
        assert_eq!(tx.done(), None, "not finished yet");
        tx.clear();
        assert_eq!(
            rx.staged(),
            Some(&[7; 8]),
            "clear does nothing while staged"
        );
        rx.finish();
        assert_eq!(rx.staged(), None);
        assert_eq!(tx.done(), Some(&[7; 8]));
        assert!(!tx.is_empty());
        tx.clear();
        assert!(tx.is_empty());
        assert_eq!(tx.stage([9; 8]), Ok(()));
    }

    struct Counted<'a>(&'a AtomicU32);
    impl Drop for Counted<'_> {
        fn drop(&mut self) {
            self.0.fetch_add(1, Ordering::Relaxed);
        }
    }

    #[test]
    fn items_are_dropped_once() {
        let drops = AtomicU32::new(0);
        {
            let mut mailbox = Mailbox::new();
            let (mut tx, mut rx) = mailbox.split();
            assert!(tx.stage(Counted(&drops)).is_ok());
            rx.finish();
            tx.clear();
            assert_eq!(drops.load(Ordering::Relaxed), 1);
            assert!(tx.stage(Counted(&drops)).is_ok());
        }
        assert_eq!(drops.load(Ordering::Relaxed), 2, "dropped with the mailbox");
    }

    #[test]
    fn two_threads_hand_items_back_and_forth() {
        const ROUNDS: u32 = 20_000;
        let mut mailbox = Mailbox::<[u32; 16]>::new();
        let (mut tx, mut rx) = mailbox.split();
        std::thread::scope(|s| {
            s.spawn(move || {
                let mut seen = 0;
                while seen < ROUNDS {
                    if let Some(item) = rx.staged() {
                        assert!(item.iter().all(|&x| x == seen), "torn item");
                        seen += 1;
                        rx.finish();
                    } else {
                        std::thread::yield_now();
                    }
                }
            });
            for round in 0..ROUNDS {
                while tx.stage([round; 16]).is_err() {
                    std::thread::yield_now();
                }
                while tx.done().is_none() {
                    std::thread::yield_now();
                }
                assert_eq!(tx.done(), Some(&[round; 16]));
                tx.clear();
            }
        });
    }
}
