//! Whatever arrives and whatever the sensors say, nothing panics, every request gets
//! exactly one reply, and the outputs stay in range.

mod support;

use core::num::NonZeroU32;

use controller_core::controller::TickDeltas;
use controller_core::kinematics::{BodyVelocity, Point, Pose, WheelSpeeds};
use controller_core::law::LawKind;
use controller_core::path::Segment;
use controller_core::reference::ReferenceMode;
use link::{ArmMode, PathBegin, PathChunk, PathCommit, Request};
use proptest::prelude::*;
use robot_app::service::TX_CAPACITY;
use robot_app::{Channels, NoBoardStats, Sensors};
use support::{default_params, Rig, Rng};

/// A request of any kind with arbitrary (often invalid) arguments.
fn random_request(rng: &mut Rng) -> Request {
    let f = |rng: &mut Rng| match rng.range(0, 4) {
        0 => f32::NAN,
        1 => -1.0,
        _ => rng.range(0, 300) as f32 / 100.0,
    };
    match rng.range(0, 14) {
        0 => Request::Info,
        1 => Request::Ping {
            nonce: rng.next() as u32,
        },
        2 => Request::GetParams,
        3 => {
            let mut p = default_params();
            p.robot.track_width_m = f(rng);
            p.supervisor.heartbeat_timeout_steps = rng.range(0, 600) as u32;
            Request::SetParams(p)
        }
        4 => Request::PersistParams,
        5 => Request::PathBegin(PathBegin {
            upload_id: rng.range(0, 3) as u16,
            segment_count: rng.range(0, 40) as u8,
            speed_m_s: f(rng),
            mode: ReferenceMode::PathFollowing {
                lookahead_m: f(rng),
            },
            law: LawKind::Tracking,
            start_pose: Pose::new(f(rng), 0.0, 0.0),
        }),
        6 => {
            let mut segments = heapless::Vec::new();
            for i in 0..rng.range(0, 4) {
                let _ = segments.push(Segment::Line {
                    start: Point::new(0.0, i as f32),
                    heading_rad: core::f32::consts::FRAC_PI_2,
                    length_m: f(rng),
                });
            }
            Request::PathChunk(PathChunk {
                upload_id: rng.range(0, 3) as u16,
                first_index: rng.range(0, 40) as u8,
                segments,
            })
        }
        7 => Request::PathCommit(PathCommit {
            upload_id: rng.range(0, 3) as u16,
            segment_count: rng.range(0, 40) as u8,
            checksum: rng.next() as u32,
        }),
        8 => Request::Arm {
            mode: match rng.range(0, 2) {
                0 => ArmMode::FollowPath,
                1 => ArmMode::HoldWheelSpeeds(WheelSpeeds::new(f(rng), f(rng))),
                _ => ArmMode::Tune,
            },
            initial_motion: Some(BodyVelocity::new(f(rng), f(rng))),
            run_time_limit_steps: None,
        },
        9 => Request::Disarm,
        10 => Request::EmergencyStop,
        11 => Request::ClearFaults,
        12 => Request::Heartbeat,
        13 => Request::SetTelemetryRate {
            hz: rng.next() as u8,
        },
        _ => Request::GetStats,
    }
}

#[test]
fn every_request_gets_exactly_one_reply() {
    for seed in 1..=4u64 {
        let mut channels = Channels::new();
        let mut rig = Rig::new(&mut channels, 115_200, true);
        let mut rng = Rng::new(seed);
        let mut seqs = Vec::new();
        for _ in 0..400 {
            for _ in 0..rng.range(0, 3) {
                let request = random_request(&mut rng);
                seqs.push(rig.send(request));
            }
            // A stalled line now and then.
            rig.tx_paused = rng.range(0, 9) == 0;
            rig.run(rng.range(1, 20) as u32);
            if rig.link.persist_job().is_some() {
                rig.link.persist_finished(rng.range(0, 1) == 0);
            }
            assert!(rig.link.outgoing().len() <= TX_CAPACITY);
        }
        rig.tx_paused = false;
        if rig.link.persist_job().is_some() {
            rig.link.persist_finished(true);
        }
        rig.run(500);
        for &seq in &seqs {
            assert_eq!(rig.replies_to(seq), 1, "seed {seed}, seq {seq}");
        }
        assert_eq!(rig.link.counters().replies_dropped, 0);
        assert!(rig.to_robot.is_empty(), "all bytes taken");
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    /// Arbitrary bytes in arbitrary chunks and arbitrary sensor readings: no panic, the
    /// duties stay finite and in [−1, 1], the transmit buffer within its capacity.
    #[test]
    fn garbage_in_never_panics(
        bytes in prop::collection::vec(any::<u8>(), 0..3000),
        chunk in 1usize..300,
        ticks in prop::collection::vec(any::<i32>(), 1..50),
        periods in 1u32..200,
        supply in prop_oneof![Just(6.0f32), Just(f32::NAN), Just(-1.0), any::<f32>()],
        button in any::<bool>(),
    ) {
        let mut channels = Channels::new();
        let (mut control, mut link) =
            robot_app::start(&mut channels, support::app_config(115_200, true)).expect("valid");
        let mut offset = 0;
        for (k, &t) in ticks.iter().enumerate() {
            let end = (offset + chunk).min(bytes.len());
            offset += link.receive(&bytes[offset..end], &NoBoardStats);
            let out = control.step(Sensors {
                ticks: TickDeltas { left: t, right: t.wrapping_neg() },
                periods: NonZeroU32::new(1 + (k as u32 * periods) % 300).unwrap_or(NonZeroU32::MIN),
                supply_v: supply,
                button_pressed: button,
                overrun: k % 7 == 0,
                background_heartbeat: k as u32,
                gyro: None,
            });
            for d in [out.duty.left, out.duty.right] {
                prop_assert!(d.is_finite() && (-1.0..=1.0).contains(&d));
            }
            link.poll();
            prop_assert!(link.outgoing().len() <= TX_CAPACITY);
            let half = link.outgoing().len() / 2;
            link.consume(half);
        }
        prop_assert_eq!(link.counters().replies_dropped, 0);
    }
}
