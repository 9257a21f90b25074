//! `docs/protocol.md` against the build: the page is the wire specification a third party
//! writes a client from, so `cargo xtask ci` fails when it and the `link` crate disagree.
//!
//! Checked, each difference named with what to write:
//!
//! - every type the two message enums carry (`Downlink`, `Uplink` and, through them,
//!   `Request`, `Reply` and every core type down to the primitives) has a section whose
//!   table lists its fields or variants in wire order with their types, and the page has
//!   no section the build does not carry;
//! - the constants table: the protocol version, the schema hash
//!   ([`link::SCHEMA_HASH`]), the header, CRC and size limits, the capacities of the
//!   bounded strings and sequences, the telemetry cap and the baud rate;
//! - the example frame: its body, header, CRC and wire bytes are what the link encodes.
//!
//! It needs no build beyond xtask's own and no network: a host check of a few
//! milliseconds.

mod compare;
mod page;
mod schema;

use anyhow::{bail, Context as _, Result};
use link::{Downlink, ProtocolId, Request, Uplink};
use postcard_schema::Schema;

use crate::steps::Context;

pub use self::page::EXAMPLE_MARKER;

/// The page, relative to the workspace root.
pub const PAGE: &str = "docs/protocol.md";

/// The header of the example frame: made up, so that the example does not change with the
/// schema hash.
pub const EXAMPLE_ID: ProtocolId = ProtocolId {
    version: 1,
    schema_hash: 0x0102_0304,
};

/// The message of the example frame.
pub fn example_message() -> Downlink {
    Downlink {
        seq: 300,
        request: Request::Ping { nonce: 0 },
    }
}

/// Checks the page against the build; prints a one-line summary when they agree.
pub fn check(ctx: &Context) -> Result<()> {
    let path = ctx.root.join(PAGE);
    let text =
        std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
    let summary = check_text(&text)?;
    println!("{PAGE}: {summary}");
    Ok(())
}

/// The page's text against the build: a summary, or every difference.
fn check_text(text: &str) -> Result<String> {
    let page = page::parse(text).with_context(|| format!("reading {PAGE}"))?;
    let build = schema::Model::of(&[Downlink::SCHEMA, Uplink::SCHEMA])?;
    let mut problems = compare::differences(&build, &page);
    problems.extend(constant_differences(&page.constants));
    problems.extend(example_differences(&page.example)?);
    if !problems.is_empty() {
        bail!(
            "{PAGE} disagrees with the build in {} place(s):\n\n{}",
            problems.len(),
            problems.join("\n\n")
        );
    }
    let variants = |name: &str| match build.types.get(name) {
        Some(schema::Shape::Enum(v)) => v.len(),
        _ => 0,
    };
    Ok(format!(
        "{} ({} requests, {} replies, {} robot messages, {} types) as the build has it",
        ProtocolId::OURS,
        variants("Request"),
        variants("Reply"),
        variants("Uplink"),
        build.types.len()
    ))
}

/// The build's constants, as the page must state them (the page may space the digits).
fn constants() -> Vec<(&'static str, String)> {
    let rates = link::TELEMETRY_RATE_HZ;
    vec![
        ("PROTOCOL_VERSION", link::PROTOCOL_VERSION.to_string()),
        ("SCHEMA_HASH", format!("0x{:08x}", link::SCHEMA_HASH)),
        ("HEADER_LEN", link::protocol::HEADER_LEN.to_string()),
        ("CRC_LEN", link::frame::CRC_LEN.to_string()),
        ("MAX_BODY_LEN", link::MAX_BODY_LEN.to_string()),
        ("MAX_FRAME_LEN", link::MAX_FRAME_LEN.to_string()),
        ("VERSION_CAP", link::VERSION_CAP.to_string()),
        ("GIT_HASH_CAP", link::GIT_HASH_CAP.to_string()),
        ("NAME_CAP", link::NAME_CAP.to_string()),
        ("FIELD_CAP", link::FIELD_CAP.to_string()),
        ("PROBLEM_CAP", link::PROBLEM_CAP.to_string()),
        ("SEGMENTS_PER_CHUNK", link::SEGMENTS_PER_CHUNK.to_string()),
        (
            "MAX_SEGMENTS",
            controller_core::path::MAX_SEGMENTS.to_string(),
        ),
        (
            "TELEMETRY_RATE_HZ",
            format!("{}..={}", rates.start(), rates.end()),
        ),
        ("LINK_BAUD", link::LINK_BAUD.to_string()),
    ]
}

/// A constant's value as text to compare: spaces removed, lower case.
fn normalised(text: &str) -> String {
    text.chars()
        .filter(|c| !c.is_whitespace())
        .collect::<String>()
        .to_ascii_lowercase()
}

fn constant_differences(stated: &[(String, String)]) -> Vec<String> {
    let build = constants();
    let mut out = Vec::new();
    for (name, value) in &build {
        match stated.iter().find(|(n, _)| n == name) {
            None => out.push(format!(
                "the constants table has no `{name}`; add the row\n    | `{name}` | `{value}` | … |"
            )),
            Some((_, text)) if normalised(text) != normalised(value) => out.push(format!(
                "the constants table gives `{name}` as `{text}`, the build has `{value}`"
            )),
            Some(_) => {}
        }
    }
    for (name, _) in stated {
        if !build.iter().any(|(n, _)| n == name) {
            out.push(format!(
                "the constants table lists `{name}`, which this check does not know; remove \
                 it or add it to xtask's protocol_page::constants"
            ));
        }
    }
    out
}

/// The example frame's parts, as the link builds them: body, header, CRC, frame.
fn example_parts() -> Result<Vec<(&'static str, Vec<u8>)>> {
    let body = postcard::to_allocvec(&example_message()).context("encoding the example")?;
    let header = EXAMPLE_ID.to_header().to_vec();
    let payload: Vec<u8> = header.iter().chain(&body).copied().collect();
    let crc = link::crc32(&payload).to_le_bytes().to_vec();
    let mut frame = vec![0u8; link::MAX_FRAME_LEN];
    let len = link::encode_raw(EXAMPLE_ID, &body, &mut frame)
        .map_err(|e| anyhow::anyhow!("framing the example: {e}"))?;
    frame.truncate(len);
    Ok(vec![
        ("body", body),
        ("header", header),
        ("crc", crc),
        ("frame", frame),
    ])
}

fn hex(bytes: &[u8]) -> String {
    bytes
        .iter()
        .map(|b| format!("{b:02x}"))
        .collect::<Vec<_>>()
        .join(" ")
}

fn example_differences(stated: &[(String, Vec<u8>)]) -> Result<Vec<String>> {
    let mut out = Vec::new();
    if stated.is_empty() {
        out.push(format!(
            "the page has no example frame (a fenced block after the line `{EXAMPLE_MARKER}`)"
        ));
        return Ok(out);
    }
    let build = example_parts()?;
    for (name, bytes) in &build {
        match stated.iter().find(|(n, _)| n == name) {
            None => out.push(format!(
                "the example frame has no `{name}:` line; add\n    {name}: {}",
                hex(bytes)
            )),
            Some((_, page)) if page != bytes => out.push(format!(
                "the example frame's `{name}` is `{}`, the link gives `{}`",
                hex(page),
                hex(bytes)
            )),
            Some(_) => {}
        }
    }
    for (name, _) in stated {
        if !build.iter().any(|(n, _)| n == name) {
            out.push(format!(
                "the example frame has a line `{name}:`, which this check does not know"
            ));
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constants_are_compared_as_text_and_each_difference_is_named() {
        assert_eq!(normalised("230 400"), "230400");
        assert_eq!(normalised("0x5F1FC9D1"), "0x5f1fc9d1");
        let mut stated: Vec<(String, String)> = constants()
            .into_iter()
            .map(|(n, v)| (n.to_string(), v))
            .collect();
        assert_eq!(constant_differences(&stated), Vec::<String>::new());
        stated.retain(|(n, _)| n != "MAX_BODY_LEN");
        stated[1].1 = "0x00000001".into();
        stated.push(("SPARE".into(), "1".into()));
        let found = constant_differences(&stated);
        assert_eq!(found.len(), 3, "{found:#?}");
        assert!(
            found[0].contains("`SCHEMA_HASH` as `0x00000001`"),
            "{}",
            found[0]
        );
        assert!(found[1].contains("no `MAX_BODY_LEN`"), "{}", found[1]);
        assert!(found[2].contains("`SPARE`"), "{}", found[2]);
    }

    #[test]
    fn the_example_frame_is_checked_byte_for_byte() {
        let parts: Vec<(String, Vec<u8>)> = example_parts()
            .unwrap()
            .into_iter()
            .map(|(n, b)| (n.to_string(), b))
            .collect();
        // seq 300 (varint ac 02), Ping (variant 1), nonce 0.
        assert_eq!(parts[0].1, [0xac, 0x02, 0x01, 0x00]);
        assert_eq!(example_differences(&parts).unwrap(), Vec::<String>::new());
        let mut wrong = parts.clone();
        wrong[3].1[1] ^= 1;
        let found = example_differences(&wrong).unwrap();
        assert_eq!(found.len(), 1);
        assert!(
            found[0].starts_with("the example frame's `frame`"),
            "{}",
            found[0]
        );
    }
}
