//! What processor in the loop refuses about a gyro, before any emulator runs: a reading
//! in the first step (which the plant repeats until the firmware is armed) and a rest
//! before arming (which the plant's hold replaces).

use std::net::{TcpListener, TcpStream};
use std::sync::Arc;
use std::time::Duration;

use controller_core::controller::TickDeltas;
use controller_core::gyro::GyroSample;
use controller_core::law::LawKind;
use host_sim::hardware::Sensors;
use host_sim::pil::firmware::Firmware;
use host_sim::pil::relay::LinkSwitch;
use host_sim::pil::{self, PilOptions};
use host_sim::run::RobotLogic;
use robot_files::scenario::Scenario;

fn sensors(gyro: Option<GyroSample>) -> Sensors {
    Sensors {
        ticks: TickDeltas { left: 0, right: 0 },
        periods: 1,
        supply_v: 7.4,
        button_pressed: false,
        gyro,
    }
}

#[test]
fn a_gyro_reading_in_the_held_first_step_is_refused_naming_the_latency() {
    // A plant port with nobody behind it: the refusal comes before anything is sent.
    let listener = TcpListener::bind("127.0.0.1:0").unwrap();
    let plant = TcpStream::connect(listener.local_addr().unwrap()).unwrap();
    let (_board_end, _) = listener.accept().unwrap();
    let mut firmware = Firmware::new(
        plant,
        Duration::from_secs(1),
        Arc::new(LinkSwitch::default()),
        None,
        None,
    )
    .unwrap();
    let reading = GyroSample {
        yaw_rate_radps: 0.01,
        age_periods: 0,
    };
    let refused = match firmware.step(&sensors(Some(reading))) {
        Err(e) => e.to_string(),
        Ok(_) => panic!("a held step with a gyro reading was sent"),
    };
    assert!(refused.contains("latency_periods"), "{refused}");
}

#[test]
fn a_rest_before_arming_is_refused_before_the_emulator_starts() {
    let scenario = Scenario::load("paper-circle-gyro").unwrap();
    let rest = scenario.gyro.unwrap().rest_before_arming_s;
    assert!(rest > 0.0, "the built-in gyro scenario rests before arming");
    let options = PilOptions {
        firmware: "/nonexistent/firmware".into(),
        qemu: "/nonexistent/qemu".into(),
        station_port: 0,
        builtin_station: true,
        link_loss_at_s: None,
        arm_timeout: Duration::from_secs(1),
    };
    let refused = pil::run(&scenario, LawKind::Tracking, &options)
        .err()
        .map(|e| e.to_string())
        .unwrap_or_default();
    assert!(refused.contains("rest_before_arming_s"), "{refused}");
}
