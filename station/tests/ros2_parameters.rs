//! `station ros2`'s parameters through ROS 2's parameter services, called as `ros2 param`
//! calls them (`get_parameters`, `set_parameters`), against the virtual robot over TCP:
//! the node shows the robot's values, a change of a robot parameter is written to the
//! robot and read back from it, and bad values are refused by name. Wall-clock time
//! only bounds how long the test waits.

use std::net::TcpListener;
use std::sync::atomic::AtomicBool;
use std::sync::mpsc::channel;
use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

use host_sim::serve::{serve, ServeOptions, VirtualRobot};
use robot_app::Channels;
use robot_files::scenario::Scenario;
use ros2_client::dds::rustdds::DomainParticipantBuilder;
use ros2_client::parameters::raw;
use ros2_client::rcl_interfaces::{
    GetParametersRequest, GetParametersResponse, SetParametersRequest, SetParametersResponse,
};
use ros2_client::service::Client;
use ros2_client::{
    Context, Name, Node, NodeName, NodeOptions, Parameter, ParameterValue, QosProfile,
    ServiceMapping, ServiceTypeName,
};
use station::ros2::bridge::{run, BridgeOptions};
use station::ros2::connection::RobotAddress;

/// The test's own DDS domain and node.
const DOMAIN: u16 = 76;
const NODE: &str = "station_parameters_test";

/// A virtual robot of paper-circle at real time on a free local port, for `max_s`.
fn virtual_robot(max_s: f64) -> String {
    let scenario = Scenario::load("paper-circle").expect("built in");
    let listener = TcpListener::bind("127.0.0.1:0").expect("a free port");
    let address = listener.local_addr().expect("bound").to_string();
    thread::spawn(move || {
        let mut channels = Channels::new();
        let mut robot = VirtualRobot::new(&mut channels, &scenario).expect("valid");
        let options = ServeOptions {
            speed: 1.0,
            max_steps: Some((max_s * 1000.0) as u64),
        };
        let _ = serve(&mut robot, &listener, options, &mut |_| {}, None);
    });
    address
}

struct ParameterClient {
    node: Node,
    get: Client<GetParametersRequest, GetParametersResponse>,
    set: Client<SetParametersRequest, SetParametersResponse>,
}

impl ParameterClient {
    fn new() -> Self {
        let participant = DomainParticipantBuilder::new(DOMAIN)
            .build()
            .expect("a participant");
        let context = Context::from_domain_participant(participant).expect("a context");
        let mut node = context
            .new_node(
                NodeName::new("/", "parameter_client").expect("a name"),
                NodeOptions::new()
                    .enable_rosout(false)
                    .start_parameter_services(false),
            )
            .expect("a node");
        let spinner = node.spinner().expect("a spinner");
        thread::spawn(move || futures::executor::block_on(spinner.spin()));
        let qos = QosProfile::publisher_default()
            .history(ros2_client::qos::History::KeepLast { depth: 1 });
        let target = format!("/{NODE}");
        let get = node
            .create_client(
                ServiceMapping::Enhanced,
                &Name::new(&target, "get_parameters").expect("a name"),
                &ServiceTypeName::new("rcl_interfaces", "GetParameters"),
                qos.clone(),
                qos.clone(),
            )
            .expect("a client");
        let set = node
            .create_client(
                ServiceMapping::Enhanced,
                &Name::new(&target, "set_parameters").expect("a name"),
                &ServiceTypeName::new("rcl_interfaces", "SetParameters"),
                qos.clone(),
                qos,
            )
            .expect("a client");
        Self { node, get, set }
    }

    fn get(&self, name: &str) -> ParameterValue {
        let request = GetParametersRequest {
            names: vec![name.to_string()],
        };
        let response = futures::executor::block_on(async {
            self.get.wait_for_service(&self.node).await;
            let id = self.get.async_send_request(request).await.expect("sent");
            self.get.async_receive_response(id).await.expect("answered")
        });
        response
            .values
            .into_iter()
            .next()
            .map(ParameterValue::from)
            .expect("one value")
    }

    /// Sets `name`; the answer's `successful` and `reason`.
    fn set(&self, name: &str, value: ParameterValue) -> (bool, String) {
        let request = SetParametersRequest {
            parameter: vec![raw::Parameter::from(Parameter {
                name: name.to_string(),
                value,
            })],
        };
        let response = futures::executor::block_on(async {
            self.set.wait_for_service(&self.node).await;
            let id = self.set.async_send_request(request).await.expect("sent");
            self.set.async_receive_response(id).await.expect("answered")
        });
        let result = response.results.into_iter().next().expect("one result");
        (result.successful, result.reason)
    }
}

fn double(value: ParameterValue) -> f64 {
    match value {
        ParameterValue::Double(x) => x,
        other => panic!("not a double: {other:?}"),
    }
}

#[test]
fn robot_parameters_set_through_ros2_are_written_to_the_robot() {
    let address = virtual_robot(60.0);
    let interrupt = Arc::new(AtomicBool::new(false));
    let bridge = thread::spawn({
        let interrupt = interrupt.clone();
        move || {
            run(BridgeOptions {
                robot: RobotAddress::Tcp(address),
                arm: true,
                domain_id: DOMAIN,
                node_name: NODE.to_string(),
                parameters: Vec::new(),
                interrupt,
                duration: Some(Duration::from_secs(60)),
            })
        }
    });
    // The calls wait for discovery without a limit of their own: a thread, given a limit.
    let (done, finished) = channel();
    thread::spawn(move || {
        let client = ParameterClient::new();
        // The robot's values, once the link is up (0 before).
        let deadline = Instant::now() + Duration::from_secs(30);
        let mut radius = 0.0;
        while radius == 0.0 && Instant::now() < deadline {
            radius = double(client.get("wheel_radius"));
            thread::sleep(Duration::from_millis(100));
        }
        let timeout = double(client.get("cmd_vel_timeout"));
        let written = client.set("wheel_radius", ParameterValue::Double(radius * 1.1));
        let read_back = double(client.get("wheel_radius"));
        let timeout_written = client.set("cmd_vel_timeout", ParameterValue::Double(0.25));
        let timeout_read_back = double(client.get("cmd_vel_timeout"));
        let negative = client.set("wheel_radius", ParameterValue::Double(-1.0));
        let too_fast = client.set("publish_rate", ParameterValue::Double(500.0));
        let fixed = client.set("odom_frame_id", ParameterValue::String("world".into()));
        let _ = done.send((
            radius,
            timeout,
            written,
            read_back,
            timeout_written,
            timeout_read_back,
            negative,
            too_fast,
            fixed,
        ));
    });
    let outcome = finished.recv_timeout(Duration::from_secs(50));
    interrupt.store(true, std::sync::atomic::Ordering::Relaxed);
    let counts = bridge
        .join()
        .expect("the bridge ran")
        .expect("the bridge started");
    let (
        radius,
        timeout,
        written,
        read_back,
        timeout_written,
        timeout_read_back,
        negative,
        too_fast,
        fixed,
    ) = outcome.expect("the parameter calls were answered");
    assert!(counts.connections >= 1);
    assert!(
        (radius - 0.0335).abs() < 0.01,
        "the robot's radius: {radius}"
    );
    assert!((timeout - 0.5).abs() < 1e-9, "cmd_vel_timeout {timeout}");
    assert!(written.0, "{written:?}");
    // Read back from the robot, through f32.
    assert!(
        (read_back - radius * 1.1).abs() < 1e-6,
        "{read_back} vs {}",
        radius * 1.1
    );
    assert!(timeout_written.0, "{timeout_written:?}");
    assert!((timeout_read_back - 0.25).abs() < 1e-9);
    assert!(
        !negative.0 && negative.1.contains("wheel_radius"),
        "{negative:?}"
    );
    assert!(
        !too_fast.0 && too_fast.1.contains("publish_rate"),
        "{too_fast:?}"
    );
    assert!(!fixed.0 && fixed.1.contains("odom_frame_id"), "{fixed:?}");
}
