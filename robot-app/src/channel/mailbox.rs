//! A one-item hand-over between two contexts for data too large to queue: the sender
//! prepares the item (in place, or by replacing it), the receiver uses it in place and
//! marks it done, and the sender reads it back (to learn what was applied) and empties
//! the box.
//!
//! ```text
//!   Empty ──publish (sender)──► Staged ──finish (receiver)──► Done ──clear (sender)──► Empty
//! ```
//!
//! The item is always initialised (the box starts with one), so the sender can prepare
//! the next item in place while the box is Empty, building it in the slot it will be
//! read from instead of on the stack. The state is one atomic byte; whoever the state
//! names owns the item (the sender in Empty and Done, the receiver in Staged), and the
//! owner's `Release` store of the next state hands it over. Nobody waits: a sender finds
//! the box occupied, a receiver finds nothing staged. Each end can move to the context
//! that uses it, but no end can be shared between two.

// Like the ring: the item is shared between two contexts and its owner is decided by the
// state byte, which the compiler cannot check.
#![allow(unsafe_code)]

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicU8, Ordering};

const EMPTY: u8 = 0;
const STAGED: u8 = 1;
const DONE: u8 = 2;

/// A slot for one `T` handed from a [`Sender`] to a [`Receiver`] and back. Split it once
/// with [`Mailbox::split`].
pub struct Mailbox<T> {
    state: AtomicU8,
    item: UnsafeCell<T>,
}

impl<T: Default> Default for Mailbox<T> {
    fn default() -> Self {
        Self::new(T::default())
    }
}

impl<T> Mailbox<T> {
    /// An empty mailbox whose slot holds `item` until the sender prepares another.
    pub const fn new(item: T) -> Self {
        Self {
            state: AtomicU8::new(EMPTY),
            item: UnsafeCell::new(item),
        }
    }

    /// The two ends; each is the only one of its kind while it lives. The mailbox starts
    /// empty again, its item as it was (no end of an earlier split can be alive).
    pub fn split(&mut self) -> (Sender<'_, T>, Receiver<'_, T>) {
        *self.state.get_mut() = EMPTY;
        let mailbox: &Self = self;
        (Sender { mailbox }, Receiver { mailbox })
    }
}

/// The end that prepares and publishes items and collects them back.
///
/// It can move to another context (it is `Send` when `T` is) but not be shared by two
/// (it is not `Sync`): `item` and `done` lend the item through `&self`, and two contexts
/// reading one item at once would need `T: Sync`, which the mailbox does not ask for.
///
/// ```compile_fail
/// use core::cell::Cell;
/// use robot_app::channel::mailbox::Mailbox;
///
/// fn shareable<T: Sync>(_: &T) {}
/// let mut mailbox = Mailbox::new(Cell::new(0u32));
/// let (tx, _rx) = mailbox.split();
/// shareable(&tx);
/// ```
pub struct Sender<'a, T> {
    mailbox: &'a Mailbox<T>,
}

// SAFETY: the mailbox is not `Sync` (its `UnsafeCell`), so neither are its ends, and each
// end lives in one context. Sending an end moves access to the item to another context,
// and the item itself moves between the two (so `T: Send`); the state byte gives it one
// owner at a time (module doc), whose `Release` store hands it over.
unsafe impl<T: Send> Send for Sender<'_, T> {}

impl<T> Sender<'_, T> {
    /// The item, to prepare in place, while the mailbox is empty; None otherwise.
    pub fn item_mut(&mut self) -> Option<&mut T> {
        let m = self.mailbox;
        if m.state.load(Ordering::Acquire) != EMPTY {
            return None;
        }
        // SAFETY: Empty: the sender owns the item, and the receiver only reads it once a
        // Release store of Staged (by `publish`, which needs `&mut self` and so cannot
        // run while the returned borrow lives) publishes it.
        Some(unsafe { &mut *m.item.get() })
    }

    /// The item, to read, while the mailbox is empty; None otherwise.
    pub fn item(&self) -> Option<&T> {
        let m = self.mailbox;
        if m.state.load(Ordering::Acquire) != EMPTY {
            return None;
        }
        // SAFETY: Empty: the sender owns the item (see `item_mut`), and `publish` needs
        // `&mut self`, so it cannot hand the item over while the returned borrow lives.
        Some(unsafe { &*m.item.get() })
    }

    /// Hands the item, as prepared, to the receiver; false (nothing done) when the
    /// mailbox is not empty.
    pub fn publish(&mut self) -> bool {
        let m = self.mailbox;
        if m.state.load(Ordering::Acquire) != EMPTY {
            return false;
        }
        m.state.store(STAGED, Ordering::Release);
        true
    }

    /// Replaces the item with `item` and publishes it, or gives `item` back when the
    /// mailbox is not empty.
    pub fn stage(&mut self, item: T) -> Result<(), T> {
        match self.item_mut() {
            Some(slot) => *slot = item,
            None => return Err(item),
        }
        self.publish();
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
        // Acquire load above) and will not touch it again until it is published anew,
        // which only this sender does, not while the returned borrow of `self` lives.
        Some(unsafe { &*m.item.get() })
    }

    /// Empties a mailbox the receiver has finished with (the item stays, for the sender
    /// to prepare the next one in); does nothing in any other state.
    pub fn clear(&mut self) {
        let m = self.mailbox;
        if m.state.load(Ordering::Acquire) == DONE {
            m.state.store(EMPTY, Ordering::Release);
        }
    }
}

/// The end that uses staged items in place. `Send` when `T` is, not `Sync` (as the
/// [`Sender`], for `staged`).
pub struct Receiver<'a, T> {
    mailbox: &'a Mailbox<T>,
}

// SAFETY: as for the `Sender`.
unsafe impl<T: Send> Send for Receiver<'_, T> {}

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
        Some(unsafe { &*m.item.get() })
    }

    /// The staged item, to use and change in place, if one is waiting.
    pub fn staged_mut(&mut self) -> Option<&mut T> {
        let m = self.mailbox;
        if m.state.load(Ordering::Acquire) != STAGED {
            return None;
        }
        // SAFETY: Staged: the receiver owns the item (see `staged`); the sender does not
        // touch it until `finish`, which needs `&mut self` and so cannot run while the
        // returned borrow lives.
        Some(unsafe { &mut *m.item.get() })
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
        let mut mailbox = Mailbox::new([0u32; 8]);
        let (mut tx, mut rx) = mailbox.split();
        assert!(tx.is_empty());
        assert_eq!(rx.staged(), None);
        assert_eq!(tx.stage([7; 8]), Ok(()));
        assert_eq!(tx.stage([9; 8]), Err([9; 8]), "occupied");
        assert_eq!(tx.item_mut(), None, "not the sender's while staged");
        assert!(!tx.publish());
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
        assert_eq!(
            tx.item_mut(),
            None,
            "not the sender's to change until cleared"
        );
        tx.clear();
        assert!(tx.is_empty());
        assert_eq!(tx.stage([9; 8]), Ok(()));
    }

    #[test]
    fn an_item_prepared_in_place_is_what_the_receiver_reads() {
        let mut mailbox = Mailbox::new([0u32; 4]);
        let (mut tx, mut rx) = mailbox.split();
        // Prepared in two steps, published once: the receiver sees nothing before.
        tx.item_mut().unwrap()[0] = 1;
        assert_eq!(rx.staged(), None);
        tx.item_mut().unwrap()[3] = 4;
        assert!(tx.publish());
        assert_eq!(rx.staged(), Some(&[1, 0, 0, 4]));
        rx.finish();
        tx.clear();
        // The item stays after clear: the next one can start from it.
        assert_eq!(tx.item_mut(), Some(&mut [1, 0, 0, 4]));
    }

    #[test]
    fn the_ends_can_move_to_another_context() {
        fn sendable<T: Send>(_: &T) {}
        // `Cell` is `Send` but not `Sync`: an end may carry it, not share it.
        let mut mailbox = Mailbox::new(core::cell::Cell::new(0u32));
        let (tx, rx) = mailbox.split();
        sendable(&tx);
        sendable(&rx);
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
            let mut mailbox = Mailbox::new(Counted(&drops));
            let (mut tx, mut rx) = mailbox.split();
            assert!(tx.stage(Counted(&drops)).is_ok());
            assert_eq!(drops.load(Ordering::Relaxed), 1, "the first item, replaced");
            rx.finish();
            tx.clear();
            assert_eq!(drops.load(Ordering::Relaxed), 1, "kept after clear");
            assert!(tx.stage(Counted(&drops)).is_ok());
            assert_eq!(drops.load(Ordering::Relaxed), 2);
        }
        assert_eq!(
            drops.load(Ordering::Relaxed),
            3,
            "the last, with the mailbox"
        );
    }

    #[test]
    fn two_threads_hand_items_back_and_forth() {
        // Under Miri, 200 rounds (about a second there; see the ring's two-thread test).
        const ROUNDS: u32 = if cfg!(miri) { 200 } else { 20_000 };
        let mut mailbox = Mailbox::new([u32::MAX; 16]);
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
