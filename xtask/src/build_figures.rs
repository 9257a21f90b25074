//! Figures the firmware's docs quote that the build sets elsewhere, checked by tests so
//! that the text cannot drift from the build:
//!
//! - the RTT buffer: `DEFMT_RTT_BUFFER_SIZE` in `.cargo/config.toml` (defmt-rtt reads it
//!   at build time), quoted as `DEFMT_RTT_BUFFER_SIZE = N` in `firmware/README.md` and
//!   `firmware/Cargo.toml`;
//! - the code's flash: `FLASH LENGTH` in `firmware/memory/stm32f411.x`, which must be
//!   `robot_app::stm32f4::flash::code_flash_len` of the storage sectors.
//!
//! The firmware's flash budget needs no check: `crate::elf_size` reads it from
//! `robot_app::stm32f4::flash::FIRMWARE_FLASH_BUDGET`, which the docs link to.

use anyhow::{bail, ensure, Context as _, Result};

/// The value of `DEFMT_RTT_BUFFER_SIZE` in a `.cargo/config.toml` (`NAME = "256"`).
pub fn rtt_buffer_bytes(config: &str) -> Result<u32> {
    let line = config
        .lines()
        .map(str::trim)
        .find(|l| l.starts_with("DEFMT_RTT_BUFFER_SIZE"))
        .context(".cargo/config.toml sets no DEFMT_RTT_BUFFER_SIZE")?;
    let value = line
        .split_once('=')
        .map(|(_, v)| v.trim().trim_matches('"'))
        .context("DEFMT_RTT_BUFFER_SIZE has no value")?;
    value
        .parse()
        .with_context(|| format!("DEFMT_RTT_BUFFER_SIZE = {value:?} is not a number"))
}

/// `doc` quotes the RTT buffer as `DEFMT_RTT_BUFFER_SIZE` = `bytes` wherever it names the
/// variable (at least once), and never as the 1 KiB of defmt-rtt's default.
pub fn check_rtt_quotes(name: &str, doc: &str, bytes: u32) -> Result<()> {
    const NAME: &str = "DEFMT_RTT_BUFFER_SIZE";
    let values: Vec<String> = doc
        .match_indices(NAME)
        .map(|(at, _)| {
            // The figure after the name, across a line break if the text wraps there.
            doc[at + NAME.len()..]
                .trim_start_matches('`')
                .trim_start()
                .trim_start_matches('=')
                .trim_start()
                .chars()
                .take_while(char::is_ascii_digit)
                .collect()
        })
        .collect();
    ensure!(!values.is_empty(), "{name} does not quote {NAME}");
    for value in values {
        if value != bytes.to_string() {
            bail!("{name} quotes {NAME} = {value:?}, but .cargo/config.toml sets {bytes} bytes");
        }
    }
    for stale in ["1 KiB RTT", "1 KiB buffer"] {
        ensure!(
            !doc.contains(stale),
            "{name} still says \"{stale}\"; the buffer is {bytes} bytes"
        );
    }
    Ok(())
}

/// The `LENGTH` of the `FLASH` region in a linker `MEMORY` block, bytes (`256K`, `1M` or
/// a number).
pub fn flash_length(memory_x: &str) -> Result<u32> {
    let line = memory_x
        .lines()
        .map(str::trim)
        .find(|l| l.starts_with("FLASH") && l.contains("ORIGIN"))
        .context("no FLASH region")?;
    let length = line
        .split("LENGTH")
        .nth(1)
        .and_then(|rest| rest.split_once('='))
        .map(|(_, v)| v.trim())
        .context("the FLASH region has no LENGTH")?;
    let (digits, scale) = match length.chars().last() {
        Some('K') => (&length[..length.len() - 1], 1024),
        Some('M') => (&length[..length.len() - 1], 1024 * 1024),
        _ => (length, 1),
    };
    let n: u32 = digits
        .parse()
        .with_context(|| format!("LENGTH {length} is not a size"))?;
    Ok(n * scale)
}

#[cfg(test)]
mod tests {
    use super::*;
    use robot_app::stm32f4::flash::{code_flash_len, STORAGE_F411};
    use std::path::Path;

    fn read(path: &str) -> String {
        let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        std::fs::read_to_string(root.join(path)).unwrap_or_else(|e| panic!("{path}: {e}"))
    }

    #[test]
    fn the_docs_quote_the_rtt_buffer_the_build_sets() {
        let bytes = rtt_buffer_bytes(&read(".cargo/config.toml")).unwrap();
        for doc in ["firmware/README.md", "firmware/Cargo.toml"] {
            check_rtt_quotes(doc, &read(doc), bytes).unwrap();
        }
    }

    #[test]
    fn a_stale_rtt_figure_is_refused() {
        assert_eq!(
            rtt_buffer_bytes("[env]\nDEFMT_RTT_BUFFER_SIZE = \"256\"\n").unwrap(),
            256
        );
        assert!(rtt_buffer_bytes("[env]\n").is_err());
        let good = "the buffer (`DEFMT_RTT_BUFFER_SIZE` = 256 bytes)";
        check_rtt_quotes("doc", good, 256).unwrap();
        check_rtt_quotes("doc", "(DEFMT_RTT_BUFFER_SIZE = 256 bytes, …)", 256).unwrap();
        let err = check_rtt_quotes("doc", good, 1024).unwrap_err().to_string();
        assert!(err.contains("1024 bytes"), "{err}");
        check_rtt_quotes(
            "doc",
            "the buffer (`DEFMT_RTT_BUFFER_SIZE` =\n  256 bytes)",
            256,
        )
        .unwrap();
        assert!(check_rtt_quotes("doc", "no figure here", 256).is_err());
        assert!(check_rtt_quotes("doc", "the 1 KiB RTT buffer", 256).is_err());
        let stale = format!("{good}; the 1 KiB RTT buffer");
        assert!(check_rtt_quotes("doc", &stale, 256).is_err());
    }

    #[test]
    fn the_memory_map_gives_the_code_what_the_storage_leaves() {
        let length = flash_length(&read("firmware/memory/stm32f411.x")).unwrap();
        assert_eq!(length, code_flash_len(&STORAGE_F411));
        assert_eq!(
            flash_length("FLASH : ORIGIN = 0x0, LENGTH = 1M").unwrap(),
            1 << 20
        );
        assert_eq!(
            flash_length("FLASH : ORIGIN = 0x0, LENGTH = 4096").unwrap(),
            4096
        );
        assert!(flash_length("RAM : ORIGIN = 0x20000000, LENGTH = 128K").is_err());
        assert!(flash_length("/* FLASH stops at sector 6 */").is_err());
    }
}
