//! What keeps the robot safe across the link, on the fake board: the heartbeat timeout,
//! the button over the link, and persisting parameters (the Persisting state, the flash
//! pages, missed ticks during the erase).

mod support;

use controller_core::kinematics::WheelSpeeds;
use controller_core::supervisor::{Bridge, DisarmReason, Event, RunMode, State};
use link::{ArmMode, BrownOutReset, NotPermitted, Refusal, Reply, Request};
use robot_app::persist::{self, Slot, Slots};
use robot_app::Channels;
use support::{app_config, default_params, Rig, RATE_HZ};

const BAUD: u32 = 921_600;

fn hold() -> Request {
    Request::Arm {
        mode: ArmMode::HoldWheelSpeeds(WheelSpeeds::new(4.0, 4.0)),
        initial_motion: None,
        run_time_limit_steps: None,
    }
}

#[test]
fn the_robot_disarms_when_heartbeats_stop() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    let timeout = default_params().supervisor.heartbeat_timeout_steps;
    rig.heartbeat_every = Some(timeout / 2);
    assert_eq!(rig.ask(hold()), Ok(Reply::Ack));
    // Heartbeats at half the timeout: armed for four timeouts.
    rig.run(4 * timeout);
    assert_eq!(rig.last.map(|a| a.state), Some(State::Armed));
    assert!(rig.last.is_some_and(|a| a.duty.left > 0.0));
    // They stop: disarmed within one timeout, and the host is told why.
    rig.heartbeat_every = None;
    let mut disarmed_after = None;
    for step in 1..=timeout + 10 {
        if rig.step().state == State::Disarmed {
            disarmed_after = Some(step);
            break;
        }
    }
    let after = disarmed_after.expect("disarmed");
    assert!(after <= timeout, "{after} steps");
    assert!(after > timeout / 2, "not before the timeout: {after} steps");
    rig.run(2);
    assert_eq!(
        rig.events().last(),
        Some(&Event::Disarmed(DisarmReason::LinkLost))
    );
    // The motors brake, then coast.
    assert_eq!(rig.last.map(|a| a.duty.left), Some(0.0));
    let brake = default_params().supervisor.brake_steps;
    rig.run(brake);
    assert_eq!(rig.last.map(|a| a.bridge), Some(Bridge::Coast));
}

#[test]
fn the_button_overrides_the_link() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    rig.heartbeat_every = Some(100);
    assert_eq!(rig.ask(hold()), Ok(Reply::Ack));
    rig.run(200);
    assert_eq!(rig.last.map(|a| a.state), Some(State::Armed));
    // Pressed: disarmed on the press, whatever the link says.
    rig.button = true;
    rig.run(50);
    assert_eq!(rig.last.map(|a| a.state), Some(State::Disarmed));
    assert!(rig
        .events()
        .contains(&Event::Disarmed(DisarmReason::Button)));
    // While it is held the link cannot arm.
    assert_eq!(
        rig.ask(hold()),
        Err(Refusal::NotPermitted(NotPermitted::ButtonHeld))
    );
    rig.run(100);
    assert_eq!(rig.last.map(|a| a.state), Some(State::Disarmed));
    assert!(rig
        .last
        .is_some_and(|a| a.duty.left == 0.0 && a.duty.right == 0.0));
    // Released (the release of the press that disarmed does not arm) and the wheels at
    // rest, the link can.
    rig.button = false;
    rig.run(150);
    assert_eq!(rig.last.map(|a| a.state), Some(State::Disarmed));
    assert_eq!(rig.ask(hold()), Ok(Reply::Ack));
    assert_eq!(rig.last.map(|a| a.state), Some(State::Armed));
    assert!(rig
        .events()
        .contains(&Event::Armed(RunMode::HoldWheelSpeeds)));
}

/// Two 512-byte flash pages, erased.
struct Flash {
    pages: [[u8; 512]; 2],
    writes: usize,
}

impl Flash {
    fn new() -> Self {
        Self {
            pages: [[0xff; 512]; 2],
            writes: 0,
        }
    }

    fn scan(&self) -> Slots {
        Slots::scan(&self.pages[0], &self.pages[1], RATE_HZ)
    }

    fn page(&mut self, slot: Slot) -> &mut [u8; 512] {
        match slot {
            Slot::A => &mut self.pages[0],
            Slot::B => &mut self.pages[1],
        }
    }
}

/// The board's side of a persist: steps until the link side asks for a write, does it
/// with the erase stalling the loop for 30 periods, reports `ok`.
fn serve_persist(rig: &mut Rig<'_>, flash: &mut Flash, ok: bool) {
    serve_persist_and(rig, flash, ok, |_| {});
}

/// [`serve_persist`], with `during` done to the rig while the flash is being written.
fn serve_persist_and(
    rig: &mut Rig<'_>,
    flash: &mut Flash,
    ok: bool,
    mut during: impl FnMut(&mut Rig<'_>),
) {
    let mut job = None;
    for _ in 0..20 {
        rig.step();
        job = rig.link.persist_job().map(|job| *job.params);
        if job.is_some() {
            break;
        }
    }
    let job = job.expect("a persist job");
    during(rig);
    assert_eq!(rig.last.map(|a| a.state), Some(State::Persisting));
    assert!(rig.last.is_some_and(|a| a.bridge == Bridge::Coast));
    let plan = flash.scan().next_write();
    let page = flash.page(plan.slot);
    *page = [0xff; 512];
    if ok {
        persist::encode(&job, plan.sequence, page).expect("fits");
        flash.writes += 1;
    }
    // The erase stalled the CPU: the next step comes 30 periods late, twice.
    rig.periods = 30;
    rig.run(2);
    rig.periods = 1;
    rig.link.persist_finished(ok);
}

#[test]
fn persisting_writes_the_other_page_and_missed_ticks_are_no_fault() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, true);
    let mut flash = Flash::new();
    let mut tuned = default_params();
    tuned.robot.track_width_m = 0.155;
    assert!(matches!(
        rig.ask(Request::SetParams(tuned)),
        Ok(Reply::ParamsApplied { .. })
    ));

    let seq = rig.send(Request::PersistParams);
    serve_persist(&mut rig, &mut flash, true);
    rig.run(5);
    assert_eq!(rig.reply(seq), Some(Ok(Reply::Ack)));
    assert_eq!(rig.last.map(|a| a.state), Some(State::Disarmed), "no fault");
    let events = rig.events();
    assert!(events.contains(&Event::PersistStarted));
    assert!(events.contains(&Event::PersistEnded));
    assert!(!events.contains(&Event::Faulted));
    // What the next boot reads: the tuned configuration, in page A.
    let slots = flash.scan();
    let (slot, loaded) = slots.newest().expect("a record");
    assert_eq!((slot, loaded.params, loaded.sequence), (Slot::A, tuned, 1));

    // Again: page B, sequence 2; page A keeps the previous one.
    let seq = rig.send(Request::PersistParams);
    serve_persist(&mut rig, &mut flash, true);
    rig.run(5);
    assert_eq!(rig.reply(seq), Some(Ok(Reply::Ack)));
    let slots = flash.scan();
    assert_eq!(
        slots.newest().map(|(s, l)| (s, l.sequence)),
        Some((Slot::B, 2))
    );
    assert!(slots.a.is_ok());
    assert_eq!(flash.writes, 2);

    // The robot still arms afterwards.
    rig.heartbeat_every = Some(100);
    assert_eq!(rig.ask(hold()), Ok(Reply::Ack));
}

#[test]
fn a_failed_write_is_reported_and_the_robot_leaves_persisting() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, true);
    let mut flash = Flash::new();
    let seq = rig.send(Request::PersistParams);
    serve_persist(&mut rig, &mut flash, false);
    rig.run(5);
    assert_eq!(
        rig.reply(seq),
        Some(Err(Refusal::NotPermitted(NotPermitted::StorageFailed)))
    );
    assert_eq!(rig.last.map(|a| a.state), Some(State::Disarmed));
    assert_eq!(flash.scan().newest(), None);
}

#[test]
fn persisting_is_refused_while_armed_busy_or_without_storage() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, false);
    assert_eq!(
        rig.ask(Request::PersistParams),
        Err(Refusal::NotPermitted(NotPermitted::NoStorage))
    );
    drop(rig);

    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, true);
    rig.heartbeat_every = Some(100);
    assert_eq!(rig.ask(hold()), Ok(Reply::Ack));
    assert_eq!(rig.ask(Request::PersistParams), Err(Refusal::Armed));
    assert_eq!(rig.ask(Request::Disarm), Ok(Reply::Ack));
    rig.heartbeat_every = None;
    // One persist at a time; arming waits until it is over.
    let first = rig.send(Request::PersistParams);
    rig.run(5);
    assert!(rig.link.persist_job().is_some());
    assert_eq!(rig.ask(Request::PersistParams), Err(Refusal::Busy));
    assert_eq!(rig.ask(hold()), Err(Refusal::Busy));
    rig.link.persist_finished(true);
    rig.run(5);
    assert_eq!(rig.reply(first), Some(Ok(Reply::Ack)));
}

/// Steps `steps` control periods; true if the link side asked for a flash write in any.
fn asks_for_a_write(rig: &mut Rig<'_>, steps: u32) -> bool {
    let mut asked = false;
    for _ in 0..steps {
        rig.step();
        asked |= rig.link.persist_job().is_some();
    }
    asked
}

#[test]
fn a_repeated_persist_writes_once_and_every_repeat_gets_the_same_reply() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, true);
    let mut flash = Flash::new();
    let seq = rig.fresh_seq();
    // A repeat right behind the request, while the robot is still entering Persisting.
    rig.send_with_seq(seq, Request::PersistParams);
    rig.send_with_seq(seq, Request::PersistParams);
    // And one while the flash is written (the host gave up waiting too early).
    serve_persist_and(&mut rig, &mut flash, true, |rig| {
        rig.send_with_seq(seq, Request::PersistParams);
        rig.step();
    });
    // And one while the robot leaves Persisting.
    rig.send_with_seq(seq, Request::PersistParams);
    rig.run(5);
    assert_eq!(rig.reply(seq), Some(Ok(Reply::Ack)));
    assert_eq!(rig.replies_to(seq), 1, "one reply, when the write ended");
    assert_eq!(flash.writes, 1);

    // A repeat after the reply (the reply was lost): the same reply, no second erase.
    rig.send_with_seq(seq, Request::PersistParams);
    assert!(!asks_for_a_write(&mut rig, 10), "no second write");
    assert_eq!(rig.replies_to(seq), 2);
    assert!(rig
        .received
        .iter()
        .filter_map(|m| match m {
            link::Uplink::Reply { seq: s, result } if *s == seq => Some(result),
            _ => None,
        })
        .all(|result| *result == Ok(Reply::Ack)));
    let started = |rig: &Rig<'_>| {
        rig.events()
            .iter()
            .filter(|e| **e == Event::PersistStarted)
            .count()
    };
    assert_eq!(started(&rig), 1, "Persisting entered once");

    // Once another request has come, the same seq is a new request (another session's
    // numbering): it writes.
    assert!(matches!(rig.ask(Request::Info), Ok(Reply::Info(_))));
    rig.send_with_seq(seq, Request::PersistParams);
    assert!(asks_for_a_write(&mut rig, 10));
}

#[test]
fn a_repeat_of_a_failed_persist_gets_the_failure_again_without_writing() {
    let mut channels = Channels::new();
    let mut rig = Rig::new(&mut channels, BAUD, true);
    let mut flash = Flash::new();
    let seq = rig.fresh_seq();
    rig.send_with_seq(seq, Request::PersistParams);
    serve_persist(&mut rig, &mut flash, false);
    rig.run(5);
    rig.send_with_seq(seq, Request::PersistParams);
    assert!(!asks_for_a_write(&mut rig, 10));
    let failed = Err(Refusal::NotPermitted(NotPermitted::StorageFailed));
    assert_eq!(rig.replies_to(seq), 2);
    assert_eq!(rig.reply(seq), Some(failed));
}

#[test]
fn persisting_is_refused_in_words_while_the_brown_out_reset_is_off() {
    for level in [
        BrownOutReset::Off,
        BrownOutReset::Level2,
        BrownOutReset::NotApplicable,
    ] {
        let mut channels = Channels::new();
        let mut config = app_config(BAUD, true);
        config.identity.brown_out_reset = level;
        let mut rig = Rig::with_config(&mut channels, config);
        let refused = Refusal::NotPermitted(NotPermitted::BrownOutResetOff);
        assert_eq!(rig.ask(Request::PersistParams), Err(refused.clone()));
        assert!(!asks_for_a_write(&mut rig, 10), "{level:?}");
        assert!(
            refused
                .to_string()
                .contains("brown-out reset is not at level 3"),
            "{refused}"
        );
    }
}
