//! `docs/foxglove-layout.json` names only channels that exist and fields their messages
//! have: every Plot path resolves in its topic's protobuf schema, every other panel's
//! topic is one of the robot's.

use std::collections::HashMap;

use foxglove::prost_types::{DescriptorProto, FileDescriptorSet};
use foxglove::Encode;
use prost::Message as _;
use robot_foxglove::messages::{BodyMessage, ErrorsMessage, SupervisorMessage, WheelsMessage};
use robot_foxglove::topics;

const LAYOUT: &str = include_str!("../../docs/foxglove-layout.json");

/// Every message of `T`'s schema (nested ones included) by its simple name, and the
/// schema's own simple name.
fn descriptors<T: Encode>() -> (String, HashMap<String, DescriptorProto>) {
    let schema = T::get_schema().expect("a derived message has a schema");
    let set = FileDescriptorSet::decode(schema.data.as_ref()).expect("a descriptor set");
    let mut all = HashMap::new();
    let mut stack: Vec<DescriptorProto> =
        set.file.into_iter().flat_map(|f| f.message_type).collect();
    while let Some(mut message) = stack.pop() {
        stack.append(&mut message.nested_type);
        all.insert(message.name().to_string(), message);
    }
    let simple = schema
        .name
        .rsplit('.')
        .next()
        .unwrap_or_default()
        .to_string();
    (simple, all)
}

/// True when `path` (`a.b.c`) is a field path of message `name`.
fn resolves(path: &str, name: &str, all: &HashMap<String, DescriptorProto>) -> bool {
    let Some(message) = all.get(name) else {
        return false;
    };
    let (head, rest) = match path.split_once('.') {
        Some((h, r)) => (h, Some(r)),
        None => (path, None),
    };
    let Some(field) = message.field.iter().find(|f| f.name() == head) else {
        return false;
    };
    match rest {
        None => true,
        Some(rest) => {
            let inner = field.type_name().rsplit('.').next().unwrap_or_default();
            resolves(rest, inner, all)
        }
    }
}

fn schemas() -> HashMap<&'static str, (String, HashMap<String, DescriptorProto>)> {
    HashMap::from([
        (topics::ERRORS, descriptors::<ErrorsMessage>()),
        (topics::BODY, descriptors::<BodyMessage>()),
        (topics::WHEELS, descriptors::<WheelsMessage>()),
        (topics::SUPERVISOR, descriptors::<SupervisorMessage>()),
    ])
}

#[test]
fn every_plotted_path_is_a_field_of_its_topic() {
    let layout: serde_json::Value = serde_json::from_str(LAYOUT).expect("the layout is JSON");
    let panels = layout["configById"].as_object().expect("panels");
    let schemas = schemas();
    let mut plotted = 0;
    for (id, config) in panels {
        for path in config["paths"].as_array().into_iter().flatten() {
            let value = path["value"].as_str().expect("a path's value");
            let (topic, field) = value.split_once('.').expect("topic.field");
            let (name, all) = schemas
                .get(topic)
                .unwrap_or_else(|| panic!("{id}: {topic} is not a telemetry channel"));
            assert!(resolves(field, name, all), "{id}: {value} is no field");
            plotted += 1;
        }
        if let Some(topic) = config["topicPath"].as_str() {
            assert!(topics::ALL.contains(&topic), "{id}: no channel {topic}");
        }
        for topic in config["topics"]
            .as_object()
            .into_iter()
            .flatten()
            .map(|t| t.0)
        {
            assert!(
                topics::ALL.contains(&topic.as_str()),
                "{id}: no channel {topic}"
            );
        }
    }
    assert!(plotted >= 10, "{plotted} paths plotted");
    // A wrong name is caught.
    let (name, all) = &schemas[topics::WHEELS];
    assert!(!resolves("left.speed_rad_s", name, all));
    assert!(resolves("left.pid.ff_v", name, all));
}
