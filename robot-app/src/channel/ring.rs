//! A fixed-capacity, lock-free, single-producer single-consumer queue whose two ends can
//! live in different execution contexts (an interrupt and a task, or two threads).
//!
//! Why not `heapless::spsc`: its 0.9 `Producer` and `Consumer` see the queue through a
//! slice view whose length is only known at run time, so every index wrap is a `%` by a
//! run-time value, and the compiler keeps a division-by-zero panic path for it. The
//! control interrupt must have none (the firmware's panic check proves it from the
//! binary). Here the capacity is a const generic power of two and the wrap is a mask.
//!
//! The algorithm is Lamport's: `tail` is written only by the producer, `head` only by the
//! consumer, both count items since creation (wrapping), and a slot is owned by the
//! producer while it is outside `head..tail` and by the consumer while it is inside. A
//! `Release` store of the counter publishes the slot; the other side's `Acquire` load
//! sees its contents. Neither side ever waits for the other: a full queue refuses the
//! item, an empty one returns `None`.

// The one module of the crate with `unsafe`: slots shared between two contexts need
// interior mutability, and their ownership is decided by the two counters, which the
// compiler cannot check.
#![allow(unsafe_code)]

use core::cell::UnsafeCell;
use core::mem::MaybeUninit;
use core::sync::atomic::{AtomicUsize, Ordering};

/// A queue of up to `N` items of `T`; `N` is a power of two (checked at compile time).
/// Split it once into its [`Producer`] and [`Consumer`] with [`Ring::split`].
pub struct Ring<T, const N: usize> {
    /// Items taken since creation (wrapping); written by the consumer only.
    head: AtomicUsize,
    /// Items added since creation (wrapping); written by the producer only.
    tail: AtomicUsize,
    slots: [UnsafeCell<MaybeUninit<T>>; N],
}

impl<T, const N: usize> Default for Ring<T, N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<T, const N: usize> Ring<T, N> {
    /// An empty queue.
    pub const fn new() -> Self {
        const {
            assert!(N.is_power_of_two(), "the capacity must be a power of two");
        }
        Self {
            head: AtomicUsize::new(0),
            tail: AtomicUsize::new(0),
            slots: [const { UnsafeCell::new(MaybeUninit::uninit()) }; N],
        }
    }

    /// The two ends. Each is the only one of its kind while it lives (they borrow the
    /// ring mutably), so there is one producer and one consumer.
    pub fn split(&mut self) -> (Producer<'_, T, N>, Consumer<'_, T, N>) {
        let ring: &Self = self;
        (Producer { ring }, Consumer { ring })
    }

    /// Items in the queue as seen now.
    fn len(&self) -> usize {
        self.tail
            .load(Ordering::Acquire)
            .wrapping_sub(self.head.load(Ordering::Acquire))
    }

    /// The slot of the item counted `count` (wrapped to the capacity by a mask).
    fn slot(&self, count: usize) -> Option<&UnsafeCell<MaybeUninit<T>>> {
        // `count & (N - 1)` < N, so this is always `Some`; `get` keeps it panic-free.
        self.slots.get(count & (N - 1))
    }
}

impl<T, const N: usize> Drop for Ring<T, N> {
    fn drop(&mut self) {
        // `&mut self`: no end is alive. Drop what is still queued.
        let (_, mut consumer) = self.split();
        while consumer.pop().is_some() {}
    }
}

/// The end that adds items. `Send` when `T` is, not `Sync`: each end is used by one
/// context at a time.
pub struct Producer<'a, T, const N: usize> {
    ring: &'a Ring<T, N>,
}

// SAFETY: the ring is not `Sync` (its `UnsafeCell`s), so neither are its ends, and each
// end lives in one context. Sending an end moves items of `T` from one context to the
// other (so `T: Send`), and the counters give every slot exactly one owner at a time
// (module doc), whose `Release` store of its counter hands the slot over.
unsafe impl<T: Send, const N: usize> Send for Producer<'_, T, N> {}

impl<T, const N: usize> Producer<'_, T, N> {
    /// Adds `item` at the back, or gives it back when the queue is full.
    pub fn push(&mut self, item: T) -> Result<(), T> {
        let ring = self.ring;
        let tail = ring.tail.load(Ordering::Relaxed);
        let head = ring.head.load(Ordering::Acquire);
        if tail.wrapping_sub(head) >= N {
            return Err(item);
        }
        let Some(slot) = ring.slot(tail) else {
            return Err(item);
        };
        // SAFETY: the slot of `tail` is outside `head..tail` (the queue is not full), so
        // the consumer does not read it and no item lives in it; only this producer (the
        // only one) writes slots.
        unsafe { (*slot.get()).write(item) };
        ring.tail.store(tail.wrapping_add(1), Ordering::Release);
        Ok(())
    }

    /// Adds the item `make` returns at the back, written straight into its slot, and
    /// returns true; when the queue is full, returns false without calling `make`. For
    /// large items: `push` moves a finished item in, and it must survive a full queue.
    pub fn push_with(&mut self, make: impl FnOnce() -> T) -> bool {
        let ring = self.ring;
        let tail = ring.tail.load(Ordering::Relaxed);
        let head = ring.head.load(Ordering::Acquire);
        if tail.wrapping_sub(head) >= N {
            return false;
        }
        let Some(slot) = ring.slot(tail) else {
            return false;
        };
        // SAFETY: as in `push`: the slot of `tail` is free and only this producer writes.
        unsafe { (*slot.get()).write(make()) };
        ring.tail.store(tail.wrapping_add(1), Ordering::Release);
        true
    }

    /// Free places as seen now (more may appear as the consumer takes items).
    pub fn free(&self) -> usize {
        N.saturating_sub(self.ring.len())
    }
}

/// The end that takes items. `Send` when `T` is, not `Sync`: `peek` lends the front
/// item through `&self`, and two contexts reading one item at once would need `T: Sync`,
/// which the ring does not ask for.
///
/// ```compile_fail
/// use core::cell::Cell;
/// use robot_app::channel::ring::Ring;
///
/// fn shareable<T: Sync>(_: &T) {}
/// let mut ring = Ring::<Cell<u32>, 2>::new();
/// let (_tx, rx) = ring.split();
/// shareable(&rx);
/// ```
pub struct Consumer<'a, T, const N: usize> {
    ring: &'a Ring<T, N>,
}

// SAFETY: as for the `Producer`.
unsafe impl<T: Send, const N: usize> Send for Consumer<'_, T, N> {}

impl<T, const N: usize> Consumer<'_, T, N> {
    /// The item at the front, left in the queue.
    pub fn peek(&self) -> Option<&T> {
        let ring = self.ring;
        let head = ring.head.load(Ordering::Relaxed);
        if ring.tail.load(Ordering::Acquire) == head {
            return None;
        }
        let slot = ring.slot(head)?;
        // SAFETY: `head` is inside `head..tail`, so the producer wrote and published this
        // slot (the Acquire load above sees its write) and will not touch it until the
        // head moves past it, which only this consumer does, and not while the returned
        // borrow of `self` lives.
        Some(unsafe { (*slot.get()).assume_init_ref() })
    }

    /// Takes the item at the front.
    pub fn pop(&mut self) -> Option<T> {
        let ring = self.ring;
        let head = ring.head.load(Ordering::Relaxed);
        if ring.tail.load(Ordering::Acquire) == head {
            return None;
        }
        let slot = ring.slot(head)?;
        // SAFETY: as in `peek`; the item is moved out and the head then moves past the
        // slot, so it is never read again before the producer writes it anew.
        let item = unsafe { (*slot.get()).assume_init_read() };
        ring.head.store(head.wrapping_add(1), Ordering::Release);
        Some(item)
    }

    /// Items waiting, as seen now.
    pub fn len(&self) -> usize {
        self.ring.len()
    }

    /// True when no item is waiting (as seen now).
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

#[cfg(test)]
mod tests {
    extern crate std;

    use super::*;
    use std::sync::atomic::AtomicU32;
    use std::vec::Vec;

    #[test]
    fn items_come_out_in_order_and_a_full_queue_refuses() {
        let mut ring = Ring::<u32, 4>::new();
        let (mut tx, mut rx) = ring.split();
        assert_eq!(tx.free(), 4);
        for i in 0..4 {
            assert_eq!(tx.push(i), Ok(()));
        }
        assert_eq!(tx.push(99), Err(99));
        assert_eq!(tx.free(), 0);
        assert_eq!(rx.peek(), Some(&0));
        assert_eq!(rx.pop(), Some(0));
        assert_eq!(tx.push(4), Ok(()));
        let out: Vec<u32> = core::iter::from_fn(|| rx.pop()).collect();
        assert_eq!(out, [1, 2, 3, 4]);
        assert!(rx.is_empty());
        assert_eq!(rx.peek(), None);
    }

    #[test]
    fn push_with_builds_only_when_there_is_room() {
        let mut ring = Ring::<u32, 2>::new();
        let (mut tx, mut rx) = ring.split();
        let mut built = 0;
        for i in 0..3 {
            let pushed = tx.push_with(|| {
                built += 1;
                10 + i
            });
            assert_eq!(pushed, i < 2, "item {i}");
        }
        assert_eq!(built, 2, "a full queue does not build the item");
        assert_eq!(rx.pop(), Some(10));
        assert!(tx.push_with(|| 12));
        let out: Vec<u32> = core::iter::from_fn(|| rx.pop()).collect();
        assert_eq!(out, [11, 12]);
    }

    #[test]
    fn counters_wrap_without_losing_items() {
        let mut ring = Ring::<u8, 2>::new();
        ring.head.store(usize::MAX - 1, Ordering::Relaxed);
        ring.tail.store(usize::MAX - 1, Ordering::Relaxed);
        let (mut tx, mut rx) = ring.split();
        for round in 0..10u8 {
            assert_eq!(tx.push(round), Ok(()));
            assert_eq!(tx.push(round + 100), Ok(()));
            assert_eq!(tx.push(0), Err(0));
            assert_eq!(rx.len(), 2);
            assert_eq!(rx.pop(), Some(round));
            assert_eq!(rx.pop(), Some(round + 100));
        }
    }

    #[test]
    fn a_single_slot_ring_works() {
        let mut ring = Ring::<u16, 1>::new();
        let (mut tx, mut rx) = ring.split();
        assert_eq!(tx.push(1), Ok(()));
        assert_eq!(tx.push(2), Err(2));
        assert_eq!(rx.pop(), Some(1));
        assert_eq!(tx.push(3), Ok(()));
        assert_eq!(rx.pop(), Some(3));
    }

    #[test]
    fn the_ends_can_move_to_another_context() {
        fn sendable<T: Send>(_: &T) {}
        // `Cell` is `Send` but not `Sync`: an end may carry it, not share it.
        let mut ring = Ring::<core::cell::Cell<u32>, 2>::new();
        let (tx, rx) = ring.split();
        sendable(&tx);
        sendable(&rx);
    }

    /// Counts drops, to check that queued items are dropped exactly once.
    struct Counted<'a>(&'a AtomicU32);
    impl Drop for Counted<'_> {
        fn drop(&mut self) {
            self.0.fetch_add(1, Ordering::Relaxed);
        }
    }

    #[test]
    fn queued_items_are_dropped_once() {
        let drops = AtomicU32::new(0);
        {
            let mut ring = Ring::<Counted<'_>, 4>::new();
            let (mut tx, mut rx) = ring.split();
            for _ in 0..3 {
                assert!(tx.push(Counted(&drops)).is_ok());
            }
            drop(rx.pop());
            assert_eq!(drops.load(Ordering::Relaxed), 1);
        }
        assert_eq!(drops.load(Ordering::Relaxed), 3);
    }

    #[test]
    fn two_threads_pass_every_item_in_order() {
        // Under Miri, 400 items (about a second there): they wrap the 8 places 50 times,
        // and Miri's own scheduler (preempting at random points) and weak-memory
        // emulation (stale counter values where the orderings allow them) vary the
        // interleavings that natively only sheer numbers do.
        const ITEMS: u32 = if cfg!(miri) { 400 } else { 200_000 };
        let mut ring = Ring::<u32, 8>::new();
        let (mut tx, mut rx) = ring.split();
        std::thread::scope(|s| {
            s.spawn(move || {
                let mut next = 0;
                while next < ITEMS {
                    if tx.push(next).is_ok() {
                        next += 1;
                    } else {
                        std::thread::yield_now();
                    }
                }
            });
            let mut expected = 0;
            while expected < ITEMS {
                match rx.pop() {
                    Some(item) => {
                        assert_eq!(item, expected);
                        expected += 1;
                    }
                    None => std::thread::yield_now(),
                }
            }
        });
    }
}
