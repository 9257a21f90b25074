//! Every interleaving of a channel's two sides, in one thread.
//!
//! Each side of a hand-over is a small program of steps, each step one or a few calls of
//! its end's API as the real context makes them (the models below), on the real
//! [`Mailbox`] and [`Ring`]. A schedule is the order in which the two sides take their
//! steps. A step that finds nothing to do (a receiver polling an empty mailbox, a producer
//! facing a full ring) must leave everything as it was (checked), so taking it again
//! before the other side has made progress is the same schedule again: a side may block
//! at most once between two progress steps of the other ([`Pacer`]). That makes the set
//! of schedules finite, and still tries every poll against every state the other side can
//! leave.
//!
//! [`every_state`] explores the graph of the points the two sides can reach (a point is
//! both programs and the channel as its ends show it): for each point and each side, it
//! replays a schedule to the point and one step further, on a fresh channel. Every
//! schedule, with any number of failed polls, is a walk through that graph, so checking
//! every step from every point checks every interleaving; it then counts the schedules
//! without running them. [`every_schedule`] runs each schedule from the start instead,
//! keeping nothing between runs; for a round trip or two the two must agree, which checks
//! that a point holds everything the next steps depend on.
//!
//! After every step:
//!
//! - the mailbox: the receiver only ever sees a fully written item, the sender never gets
//!   the item (to change or to read) while it is published or not yet collected, no item
//!   is lost or seen twice, both sides agree whose the item is, and the handshake always
//!   completes (no deadlock, no livelock, one end);
//! - the ring: items come out in order, none lost or duplicated, a full ring refuses (and
//!   `push_with` builds nothing), an empty one gives nothing, the two ends' counts agree
//!   with the items in flight, and every item is dropped exactly once, including those
//!   still queued when the ring is dropped mid-schedule.
//!
//! Steps are whole API calls. That is exact for these channels: inside a call, the only
//! shared value a side reads is one that the other side can move in one direction only
//! (the mailbox's state byte leaves a state only by its owner's hand; the ring's other
//! counter only grows), so the other side running in the middle of a call changes
//! nothing the call decides. What the step order cannot show, the memory ordering of the
//! atomics, is what the two-thread tests check under Miri's weak-memory emulation. (A
//! model checker such as loom would cover both, but only if the channels used its atomics
//! and cells instead of `core`'s.)

extern crate std;

use std::collections::{BTreeMap, VecDeque};
use std::rc::Rc;
use std::vec::Vec;

use super::mailbox::{Mailbox, Receiver, Sender};
use super::ring::{Consumer, Producer, Ring};

/// One of the two sides of a channel: the one that hands items over, or the one that
/// takes them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Side {
    /// The mailbox's sender, the ring's producer.
    Giver,
    /// The mailbox's receiver, the ring's consumer.
    Taker,
}

impl Side {
    const BOTH: [Side; 2] = [Side::Giver, Side::Taker];

    const fn index(self) -> usize {
        match self {
            Side::Giver => 0,
            Side::Taker => 1,
        }
    }

    const fn other(self) -> Side {
        match self {
            Side::Giver => Side::Taker,
            Side::Taker => Side::Giver,
        }
    }
}

/// What a step did to the channel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Moved {
    /// Changed something (the side's program moved on).
    Progress,
    /// Found nothing to do; the channel is as it was.
    Blocked,
}

/// Which sides may take the next step, kept along a replay: a side that blocked may try
/// again once the other side has made progress (before that, it would find the same
/// state and block the same way).
#[derive(Clone, Copy, Debug, Default)]
struct Pacer {
    /// Steps that made progress, per side.
    progress: [u32; 2],
    /// For a side whose last step blocked: the other side's progress at that point.
    blocked_at: [Option<u32>; 2],
    /// Sides whose program has ended.
    finished: [bool; 2],
    /// What the last step did.
    last: Option<Moved>,
}

impl Pacer {
    fn record(&mut self, side: Side, moved: Moved, finished: bool) {
        let i = side.index();
        match moved {
            Moved::Progress => {
                self.progress[i] += 1;
                self.blocked_at[i] = None;
            }
            Moved::Blocked => self.blocked_at[i] = Some(self.progress[side.other().index()]),
        }
        self.finished[i] = finished;
        self.last = Some(moved);
    }

    /// False once the side has finished, or when it blocked and the other side has made
    /// no progress since.
    fn may_move(&self, side: Side) -> bool {
        let i = side.index();
        !self.finished[i] && self.blocked_at[i] != Some(self.progress[side.other().index()])
    }

    fn complete(&self) -> bool {
        self.finished == [true, true]
    }
}

/// Where a replayed schedule ends: everything the next steps can depend on (`key`: both
/// programs and the channel as its ends show it), and the pacing.
#[derive(Clone, Debug)]
struct Reached<K> {
    key: K,
    pacer: Pacer,
}

/// Picks the side that takes the next step, seeing the pacing so far; None ends the
/// schedule.
type Chooser<'a> = &'a mut dyn FnMut(&Pacer) -> Option<Side>;

/// Runs a schedule on a fresh channel, as the chooser picks it step by step, checking the
/// invariants after every step (panicking, with the schedule, when one fails).
type Replay<'a, K> = &'a dyn Fn(Chooser<'_>) -> Reached<K>;

/// A chooser that follows `schedule`, then ends.
fn follow(schedule: &[Side]) -> impl FnMut(&Pacer) -> Option<Side> + '_ {
    let mut steps = schedule.iter().copied();
    move |_| steps.next()
}

/// What an explorer counted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
struct Explored {
    /// Complete schedules in which a side blocks at most once between two progress steps
    /// of the other (see the module doc).
    schedules: u64,
    /// The longest of them, in steps.
    longest: usize,
    /// Distinct points reached (0 from [`every_schedule`], which keeps none).
    states: usize,
    /// Steps replayed in all (the cost).
    steps_replayed: u64,
}

/// The longest schedule the explorers accept: far more than any program here needs, so
/// reaching it means the sides kept moving without the hand-over ending (a livelock).
const MAX_STEPS: usize = 200;

/// Runs every schedule `replay` allows, each one once from the start (depth first:
/// after each run, the deepest step where the taker could have moved instead of the
/// giver is taken the other way), nothing kept between runs: the reference the
/// state-graph explorer is checked against, affordable for a round trip or two only.
fn every_schedule<K>(replay: Replay<'_, K>) -> Explored {
    let mut out = Explored::default();
    // The schedule: each step's side, and whether the taker is still to be tried there.
    let mut path: Vec<(Side, bool)> = Vec::new();
    loop {
        let mut depth = 0;
        let reached = replay(&mut |pacer: &Pacer| {
            if depth == path.len() {
                let movable = Side::BOTH.map(|side| pacer.may_move(side));
                let side = match movable {
                    [true, _] => Side::Giver,
                    [false, true] => Side::Taker,
                    [false, false] => return None,
                };
                assert!(depth < MAX_STEPS, "no end after {MAX_STEPS} steps");
                path.push((side, movable == [true, true]));
            }
            depth += 1;
            path.get(depth - 1).map(|&(side, _)| side)
        });
        let schedule: Vec<Side> = path.iter().map(|&(side, _)| side).collect();
        assert!(
            reached.pacer.complete(),
            "deadlock: neither side can move after {}",
            At(&schedule)
        );
        out.schedules += 1;
        out.longest = out.longest.max(path.len());
        out.steps_replayed += path.len() as u64;
        while path.last().is_some_and(|&(_, taker_left)| !taker_left) {
            path.pop();
        }
        match path.last_mut() {
            Some(last) => *last = (Side::Taker, false),
            None => return out,
        }
    }
}

/// A point of the state graph: the shortest schedule found to it, and where each side's
/// next step leads (None once that side has finished).
struct Point<K> {
    schedule: Vec<Side>,
    finished: [bool; 2],
    next: [Option<K>; 2],
}

/// Explores every point the two sides can reach, and every step from each, replaying a
/// schedule to the point for each step (breadth first, so schedules stay short). Every
/// schedule of any length, with any number of failed polls, is a walk through these
/// points, so checking every step from every point checks every interleaving. It also
/// checks that
///
/// - a step blocks exactly when it leaves the point as it was (a failed poll changes
///   nothing, a successful step changes something),
/// - from every point short of the end some side can make progress (no deadlock), and
///   progress never comes back to a point (no livelock): every schedule ends, at the one
///   end point,
///
/// and counts the schedules [`every_schedule`] would run, without running them.
fn every_state<K: Clone + Ord + core::fmt::Debug>(replay: Replay<'_, K>) -> Explored {
    let mut out = Explored::default();
    let root = replay(&mut follow(&[]));
    let mut points = BTreeMap::new();
    points.insert(
        root.key.clone(),
        Point {
            schedule: Vec::new(),
            finished: root.pacer.finished,
            next: [None, None],
        },
    );
    let mut queue = VecDeque::from([root.key.clone()]);
    while let Some(key) = queue.pop_front() {
        let (schedule, finished) = {
            let point = &points[&key];
            (point.schedule.clone(), point.finished)
        };
        let mut next = [None, None];
        for side in Side::BOTH {
            if finished[side.index()] {
                continue;
            }
            let mut longer = schedule.clone();
            longer.push(side);
            assert!(longer.len() <= MAX_STEPS, "no end: {}", At(&longer));
            let reached = replay(&mut follow(&longer));
            out.steps_replayed += longer.len() as u64;
            let stayed = reached.key == key;
            assert_eq!(
                reached.pacer.last == Some(Moved::Blocked),
                stayed,
                "{}: a step must block exactly when it changes nothing ({key:?} -> {:?})",
                At(&longer),
                reached.key
            );
            if !points.contains_key(&reached.key) {
                queue.push_back(reached.key.clone());
                points.insert(
                    reached.key.clone(),
                    Point {
                        schedule: longer,
                        finished: reached.pacer.finished,
                        next: [None, None],
                    },
                );
            }
            next[side.index()] = Some(reached.key);
        }
        let progress = next.iter().flatten().any(|to| *to != key);
        assert!(
            progress || finished == [true, true],
            "deadlock at {key:?}, reached by {}",
            At(&schedule)
        );
        if let Some(point) = points.get_mut(&key) {
            point.next = next;
        }
    }
    let ends: Vec<&K> = points
        .iter()
        .filter(|(_, p)| p.finished == [true, true])
        .map(|(k, _)| k)
        .collect();
    assert_eq!(ends.len(), 1, "more than one way to end: {ends:?}");
    out.states = points.len();
    let mut memo = BTreeMap::new();
    let (schedules, longest) = count(&points, &root.key, [false, false], &mut memo, 0);
    out.schedules = schedules;
    out.longest = longest;
    out
}

/// The schedules counted from each point and set of blocked sides, and their longest;
/// None while that count is under way (meeting it again is a cycle).
type Counts<K> = BTreeMap<(K, [bool; 2]), Option<(u64, usize)>>;

/// Schedules from `key` with `blocked` sides (those that blocked since the other's last
/// progress, which may not move), and the longest of them; panics on a cycle of progress.
fn count<K: Clone + Ord + core::fmt::Debug>(
    points: &BTreeMap<K, Point<K>>,
    key: &K,
    blocked: [bool; 2],
    memo: &mut Counts<K>,
    depth: usize,
) -> (u64, usize) {
    match memo.get(&(key.clone(), blocked)) {
        Some(Some(known)) => return *known,
        Some(None) => panic!("livelock: progress leads back to {key:?}"),
        None => {}
    }
    assert!(depth <= MAX_STEPS, "no end from {key:?}");
    memo.insert((key.clone(), blocked), None);
    let point = &points[key];
    let mut total = (0, 0);
    if point.finished == [true, true] {
        total = (1, 0);
    }
    for side in Side::BOTH {
        let i = side.index();
        let Some(to) = &point.next[i] else { continue };
        let after = if to == key {
            if blocked[i] {
                continue;
            }
            let mut b = blocked;
            b[i] = true;
            b
        } else {
            [false, false]
        };
        let (n, longest) = count(points, to, after, memo, depth + 1);
        total = (total.0 + n, total.1.max(longest + 1));
    }
    memo.insert((key.clone(), blocked), Some(total));
    total
}

/// A schedule (so far), shown in failure messages as `G` for each step of the giver and
/// `T` for each of the taker; formatted only when a message is.
#[derive(Clone, Copy)]
struct At<'a>(&'a [Side]);

impl core::fmt::Display for At<'_> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("schedule ")?;
        for side in self.0 {
            f.write_str(match side {
                Side::Giver => "G",
                Side::Taker => "T",
            })?;
        }
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------
// The mailbox: write, publish; see, use, finish; see done, collect; round after round.

/// The item handed over: the round's value in two halves, which an in-place sender
/// writes one step apart (a receiver that saw the item between the two would find them
/// different), and the receipt the receiver writes into it in place.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, PartialOrd, Ord)]
struct Item {
    halves: [u32; 2],
    receipt: u32,
}

/// Round `round`'s item as the sender prepares it (never all zero, unlike the initial
/// item).
const fn prepared(round: u32) -> Item {
    Item {
        halves: [round + 1; 2],
        receipt: 0,
    }
}

/// Round `round`'s item once the receiver has used it.
const fn used(round: u32) -> Item {
    Item {
        halves: [round + 1; 2],
        receipt: 1000 + round,
    }
}

/// The sender's program. Even rounds prepare the item in place in two steps and publish
/// it in a third; odd rounds replace it and publish it in one ([`Sender::stage`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum SenderStep {
    WriteFirstHalf,
    WriteSecondHalf,
    Publish,
    Stage,
    AwaitDone,
    Collect,
    Finished,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct SenderProgram {
    round: u32,
    step: SenderStep,
    rounds: u32,
}

impl SenderProgram {
    fn new(rounds: u32) -> Self {
        Self {
            round: 0,
            step: Self::first_step(0),
            rounds,
        }
    }

    const fn first_step(round: u32) -> SenderStep {
        if round % 2 == 0 {
            SenderStep::WriteFirstHalf
        } else {
            SenderStep::Stage
        }
    }

    /// Preparing the next item: the mailbox is (to this side's knowledge) empty.
    fn preparing(&self) -> bool {
        matches!(
            self.step,
            SenderStep::WriteFirstHalf
                | SenderStep::WriteSecondHalf
                | SenderStep::Publish
                | SenderStep::Stage
        )
    }

    fn step(&mut self, tx: &mut Sender<'_, Item>, at: At<'_>) -> Moved {
        let round = self.round;
        match self.step {
            SenderStep::WriteFirstHalf => {
                let item = tx
                    .item_mut()
                    .unwrap_or_else(|| panic!("{at}: emptied by the sender, yet not its own"));
                item.halves[0] = round + 1;
                item.receipt = 0;
                self.step = SenderStep::WriteSecondHalf;
            }
            SenderStep::WriteSecondHalf => {
                let item = tx
                    .item_mut()
                    .unwrap_or_else(|| panic!("{at}: the half-written item was taken away"));
                item.halves[1] = round + 1;
                self.step = SenderStep::Publish;
            }
            SenderStep::Publish => {
                assert!(tx.publish(), "{at}: publish refused on an empty mailbox");
                self.step = SenderStep::AwaitDone;
            }
            SenderStep::Stage => {
                assert_eq!(
                    tx.stage(prepared(round)),
                    Ok(()),
                    "{at}: stage refused on an empty mailbox"
                );
                self.step = SenderStep::AwaitDone;
            }
            SenderStep::AwaitDone => {
                // Whatever the receiver is doing, the item is not the sender's to change,
                // and nothing the sender tries can take it back or publish over it.
                assert!(
                    tx.item_mut().is_none(),
                    "{at}: the sender got `&mut` to a lent item"
                );
                assert!(!tx.publish(), "{at}: published over a lent item");
                assert_eq!(tx.stage(Item::default()), Err(Item::default()), "{at}");
                assert!(!tx.is_empty(), "{at}");
                let Some(done) = tx.done() else {
                    assert!(
                        tx.item().is_none(),
                        "{at}: the sender read a published item"
                    );
                    // Collecting an item not yet finished does nothing.
                    tx.clear();
                    assert!(!tx.is_empty(), "{at}: collected an item not finished");
                    return Moved::Blocked;
                };
                assert_eq!(
                    *done,
                    used(round),
                    "{at}: not the item the receiver finished"
                );
                self.step = SenderStep::Collect;
            }
            SenderStep::Collect => {
                tx.clear();
                assert!(tx.is_empty(), "{at}: collecting did not empty the mailbox");
                assert!(tx.done().is_none(), "{at}");
                // The item stays, for the next one to be prepared in.
                assert_eq!(tx.item(), Some(&used(round)), "{at}");
                self.round += 1;
                self.step = if self.round == self.rounds {
                    SenderStep::Finished
                } else {
                    Self::first_step(self.round)
                };
            }
            SenderStep::Finished => unreachable!("{at}: the explorer moved a finished side"),
        }
        Moved::Progress
    }
}

/// The receiver's program: see the item, use it in place, finish with it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum ReceiverStep {
    See,
    Use,
    Finish,
    Finished,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct ReceiverProgram {
    round: u32,
    step: ReceiverStep,
    rounds: u32,
}

impl ReceiverProgram {
    fn new(rounds: u32) -> Self {
        Self {
            round: 0,
            step: ReceiverStep::See,
            rounds,
        }
    }

    /// Holding the item: seen, not yet handed back.
    fn holds(&self) -> bool {
        matches!(self.step, ReceiverStep::Use | ReceiverStep::Finish)
    }

    fn step(&mut self, rx: &mut Receiver<'_, Item>, at: At<'_>) -> Moved {
        let round = self.round;
        match self.step {
            ReceiverStep::See => {
                let Some(item) = rx.staged() else {
                    assert!(rx.staged_mut().is_none(), "{at}");
                    // Finishing with nothing staged does nothing (the sender's next steps
                    // would find the mailbox not empty).
                    rx.finish();
                    return Moved::Blocked;
                };
                // The next round's item, whole: not a half-written one, not the last
                // round's again, none skipped.
                assert_eq!(
                    *item,
                    prepared(round),
                    "{at}: the receiver saw a wrong item"
                );
                self.step = ReceiverStep::Use;
            }
            ReceiverStep::Use => {
                let item = rx
                    .staged_mut()
                    .unwrap_or_else(|| panic!("{at}: the seen item was taken away"));
                assert_eq!(*item, prepared(round), "{at}: changed while the receiver's");
                item.receipt = used(round).receipt;
                self.step = ReceiverStep::Finish;
            }
            ReceiverStep::Finish => {
                assert_eq!(rx.staged(), Some(&used(round)), "{at}");
                rx.finish();
                assert!(rx.staged().is_none(), "{at}: still staged after finish");
                self.round += 1;
                self.step = if self.round == self.rounds {
                    ReceiverStep::Finished
                } else {
                    ReceiverStep::See
                };
            }
            ReceiverStep::Finished => unreachable!("{at}: the explorer moved a finished side"),
        }
        Moved::Progress
    }
}

/// Whose the item is, as the two programs see it, must agree: while the sender prepares
/// an item the receiver waits for it, and while the receiver holds one the sender waits
/// for it back; the receiver is never more than the one round ahead it reaches by
/// finishing an item the sender has not collected yet.
fn check_ownership(tx: &SenderProgram, rx: &ReceiverProgram, at: At<'_>) {
    if tx.preparing() {
        assert_eq!(
            (rx.step, rx.round),
            (ReceiverStep::See, tx.round),
            "{at}: the receiver moved on an item being prepared"
        );
    }
    if rx.holds() {
        assert_eq!(
            (tx.step, tx.round),
            (SenderStep::AwaitDone, rx.round),
            "{at}: the sender moved on an item the receiver holds"
        );
    }
    let ahead = rx.round.wrapping_sub(tx.round);
    assert!(
        ahead == 0
            || (ahead == 1 && matches!(tx.step, SenderStep::AwaitDone | SenderStep::Collect)),
        "{at}: sender in round {}, receiver in round {}",
        tx.round,
        rx.round
    );
}

/// The mailbox's state as its ends show it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
enum Shown {
    /// The sender's to prepare ([`Sender::item`]).
    Empty,
    /// Published ([`Receiver::staged`]).
    Staged,
    /// Finished, not collected ([`Sender::done`]).
    Done,
}

/// The mailbox as its ends show it (read-only calls): in exactly one of its three states,
/// with its item.
fn observe(tx: &Sender<'_, Item>, rx: &Receiver<'_, Item>, at: At<'_>) -> (Shown, Item) {
    let shown = (tx.is_empty(), tx.item(), rx.staged(), tx.done());
    match shown {
        (true, Some(item), None, None) => (Shown::Empty, *item),
        (false, None, Some(item), None) => (Shown::Staged, *item),
        (false, None, None, Some(item)) => (Shown::Done, *item),
        _ => panic!("{at}: the mailbox is not in one state: {shown:?}"),
    }
}

/// The point a mailbox schedule reaches: both programs and the mailbox.
type MailboxPoint = (SenderProgram, ReceiverProgram, (Shown, Item));

/// Runs the schedule `choose` picks on a fresh mailbox, `rounds` round trips long.
fn replay_mailbox(choose: Chooser<'_>, rounds: u32) -> Reached<MailboxPoint> {
    let mut mailbox = Mailbox::new(Item::default());
    let (mut tx, mut rx) = mailbox.split();
    let mut sender = SenderProgram::new(rounds);
    let mut receiver = ReceiverProgram::new(rounds);
    let mut pacer = Pacer::default();
    let mut schedule = Vec::new();
    while let Some(side) = choose(&pacer) {
        schedule.push(side);
        let at = At(&schedule);
        assert!(
            pacer.may_move(side),
            "{at}: the explorer moved a side it may not"
        );
        let (moved, finished) = match side {
            Side::Giver => (
                sender.step(&mut tx, at),
                sender.step == SenderStep::Finished,
            ),
            Side::Taker => (
                receiver.step(&mut rx, at),
                receiver.step == ReceiverStep::Finished,
            ),
        };
        pacer.record(side, moved, finished);
        check_ownership(&sender, &receiver, at);
    }
    let shown = observe(&tx, &rx, At(&schedule));
    if pacer.complete() {
        assert_eq!((sender.round, receiver.round), (rounds, rounds));
        assert_eq!(
            shown,
            (Shown::Empty, used(rounds - 1)),
            "after the last round trip"
        );
    }
    Reached {
        key: (sender, receiver, shown),
        pacer,
    }
}

// ---------------------------------------------------------------------------------------
// The ring: the producer pushes 0, 1, 2, …; the consumer peeks at each, then pops it.

/// Capacity of the ring explored: small, so that it fills, and items wrap around it.
const RING_CAPACITY: usize = 2;

/// An item in the ring: its number, and a share of a counter that tells how many items
/// are alive (so a leaked or twice-dropped item shows).
#[derive(Debug)]
struct Token {
    value: u32,
    _alive: Rc<()>,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct ProducerProgram {
    next: u32,
    items: u32,
}

impl ProducerProgram {
    /// Pushes item `next`: even ones with [`Producer::push`], odd ones built in place with
    /// [`Producer::push_with`].
    fn step(
        &mut self,
        producer: &mut Producer<'_, Token, RING_CAPACITY>,
        alive: &Rc<()>,
        at: At<'_>,
    ) -> Moved {
        let value = self.next;
        let pushed = if value % 2 == 0 {
            let token = Token {
                value,
                _alive: Rc::clone(alive),
            };
            match producer.push(token) {
                Ok(()) => true,
                Err(back) => {
                    assert_eq!(back.value, value, "{at}: a refused item came back changed");
                    false
                }
            }
        } else {
            let mut built = false;
            let pushed = producer.push_with(|| {
                built = true;
                Token {
                    value,
                    _alive: Rc::clone(alive),
                }
            });
            assert_eq!(
                built, pushed,
                "{at}: push_with built an item it did not push"
            );
            pushed
        };
        if !pushed {
            assert_eq!(producer.free(), 0, "{at}: refused with room left");
            return Moved::Blocked;
        }
        self.next += 1;
        Moved::Progress
    }

    fn finished(&self) -> bool {
        self.next == self.items
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord)]
struct ConsumerProgram {
    next: u32,
    items: u32,
    /// The next item has been peeked at; the next step pops it.
    peeked: bool,
}

impl ConsumerProgram {
    fn step(&mut self, consumer: &mut Consumer<'_, Token, RING_CAPACITY>, at: At<'_>) -> Moved {
        if !self.peeked {
            let Some(front) = consumer.peek() else {
                assert!(consumer.is_empty(), "{at}");
                assert!(consumer.pop().is_none(), "{at}: popped from an empty ring");
                return Moved::Blocked;
            };
            assert_eq!(
                front.value, self.next,
                "{at}: out of order, lost or repeated"
            );
            self.peeked = true;
        } else {
            let item = consumer
                .pop()
                .unwrap_or_else(|| panic!("{at}: the peeked item is gone"));
            assert_eq!(item.value, self.next, "{at}: pop and peek disagree");
            self.next += 1;
            self.peeked = false;
        }
        Moved::Progress
    }

    fn finished(&self) -> bool {
        self.next == self.items
    }
}

/// The point a ring schedule reaches: both programs and the ring as its ends show it
/// (items queued, free places, the front item's number).
type RingPoint = (
    ProducerProgram,
    ConsumerProgram,
    (usize, usize, Option<u32>),
);

/// Runs the schedule `choose` picks on a fresh ring, `items` items long.
fn replay_ring(choose: Chooser<'_>, items: u32) -> Reached<RingPoint> {
    let alive = Rc::new(());
    let mut pacer = Pacer::default();
    let key = {
        let mut ring = Ring::<Token, RING_CAPACITY>::new();
        let (mut producer, mut consumer) = ring.split();
        let mut pushing = ProducerProgram { next: 0, items };
        let mut popping = ConsumerProgram {
            next: 0,
            items,
            peeked: false,
        };
        let mut schedule = Vec::new();
        while let Some(side) = choose(&pacer) {
            schedule.push(side);
            let at = At(&schedule);
            assert!(
                pacer.may_move(side),
                "{at}: the explorer moved a side it may not"
            );
            let (moved, finished) = match side {
                Side::Giver => (pushing.step(&mut producer, &alive, at), pushing.finished()),
                Side::Taker => (popping.step(&mut consumer, at), popping.finished()),
            };
            pacer.record(side, moved, finished);
            let queued = (pushing.next - popping.next) as usize;
            assert!(queued <= RING_CAPACITY, "{at}: {queued} items in the ring");
            assert_eq!(consumer.len(), queued, "{at}");
            assert_eq!(producer.free(), RING_CAPACITY - queued, "{at}");
            assert_eq!(Rc::strong_count(&alive), 1 + queued, "{at}: items alive");
        }
        let shown = (
            consumer.len(),
            producer.free(),
            consumer.peek().map(|t| t.value),
        );
        (pushing, popping, shown)
        // The ring is dropped here with whatever is still queued.
    };
    assert_eq!(
        Rc::strong_count(&alive),
        1,
        "an item was not dropped with the ring"
    );
    Reached { key, pacer }
}

// ---------------------------------------------------------------------------------------

/// Replays of a toy model with no channel: two programs of `lengths` steps; the taker
/// blocks until the giver has made `taker_waits_for` steps.
fn replay_toy(choose: Chooser<'_>, lengths: [u32; 2], taker_waits_for: u32) -> Reached<[u32; 2]> {
    let mut pacer = Pacer::default();
    let mut done = [0, 0];
    while let Some(side) = choose(&pacer) {
        let i = side.index();
        let moved = if side == Side::Taker && done[0] < taker_waits_for {
            Moved::Blocked
        } else {
            done[i] += 1;
            Moved::Progress
        };
        pacer.record(side, moved, done[i] == lengths[i]);
    }
    Reached { key: done, pacer }
}

#[test]
fn both_explorers_count_every_interleaving_of_two_programs() {
    // Two sides that never block, of 3 and 2 steps: C(5, 2) = 10 orders.
    let replay = |c: Chooser<'_>| replay_toy(c, [3, 2], 0);
    let all = every_schedule(&replay);
    assert_eq!((all.schedules, all.longest), (10, 5));
    let states = every_state(&replay);
    assert_eq!(
        (states.schedules, states.longest, states.states),
        (10, 5, 12)
    );
}

#[test]
fn a_side_blocks_at_most_once_between_two_moves_of_the_other() {
    // One giver step, then one taker step; before the giver's, the taker may poll once:
    // G T, and T(blocked) G T.
    let replay = |c: Chooser<'_>| replay_toy(c, [1, 1], 1);
    let all = every_schedule(&replay);
    assert_eq!((all.schedules, all.longest), (2, 3));
    let states = every_state(&replay);
    assert_eq!((states.schedules, states.longest, states.states), (2, 3, 3));
}

#[test]
#[should_panic(expected = "deadlock")]
fn a_deadlock_fails_the_state_graph() {
    // A taker waiting for a giver step that never comes.
    every_state(&|c: Chooser<'_>| replay_toy(c, [1, 1], 2));
}

#[test]
#[should_panic(expected = "deadlock")]
fn a_deadlock_fails_the_run_of_every_schedule() {
    every_schedule(&|c: Chooser<'_>| replay_toy(c, [1, 1], 2));
}

/// Round trips through the mailbox: two of each kind (prepared in place, and staged);
/// under Miri three (two in place, one staged), a second and a half less there.
const ROUNDS: u32 = if cfg!(miri) { 3 } else { 4 };
/// Items through the ring: around its two places two and a half times.
const RING_ITEMS: u32 = 5;

#[test]
fn every_interleaving_of_the_mailbox_handshake_hands_each_item_over_once() {
    let explored = every_state(&|c: Chooser<'_>| replay_mailbox(c, ROUNDS));
    // Exact, so that a change in the mailbox's blocking (or in the explorer) shows.
    assert_eq!(
        (explored.schedules, explored.states),
        (MAILBOX_SCHEDULES, MAILBOX_STATES),
        "{explored:?}"
    );
}

#[test]
fn every_interleaving_of_pushes_and_pops_keeps_the_ring_in_order() {
    let explored = every_state(&|c: Chooser<'_>| replay_ring(c, RING_ITEMS));
    assert_eq!(
        (explored.schedules, explored.states),
        (RING_SCHEDULES, RING_STATES),
        "{explored:?}"
    );
}

#[test]
fn the_state_graph_counts_what_running_every_schedule_runs() {
    // Running every schedule one by one checks the state graph's shortcut: it relies on
    // a point (the programs and what the ends show) being all that the next steps
    // depend on. A few round trips only: the schedules double with every step.
    let (rounds, items) = if cfg!(miri) { (1, 2) } else { (2, 4) };
    for (name, all, states) in [
        (
            "mailbox",
            every_schedule(&|c: Chooser<'_>| replay_mailbox(c, rounds)),
            every_state(&|c: Chooser<'_>| replay_mailbox(c, rounds)),
        ),
        (
            "ring",
            every_schedule(&|c: Chooser<'_>| replay_ring(c, items)),
            every_state(&|c: Chooser<'_>| replay_ring(c, items)),
        ),
    ] {
        assert_eq!(
            (all.schedules, all.longest),
            (states.schedules, states.longest),
            "{name}"
        );
        assert!(all.schedules > 1, "{name}");
    }
}

/// Complete schedules of [`ROUNDS`] mailbox round trips (a side blocking at most once
/// between two moves of the other): 2^26, or 2^20 for three round trips.
const MAILBOX_SCHEDULES: u64 = if cfg!(miri) { 1_048_576 } else { 67_108_864 };
/// Points they pass through.
const MAILBOX_STATES: usize = if cfg!(miri) { 23 } else { 29 };
/// Complete schedules of [`RING_ITEMS`] items through a ring of [`RING_CAPACITY`].
const RING_SCHEDULES: u64 = 4_096;
/// Points they pass through.
const RING_STATES: usize = 24;
