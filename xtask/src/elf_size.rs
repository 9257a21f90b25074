//! Flash and static RAM of an ARM ELF, read from its section headers (no external tools),
//! and the firmware's budget check.
//!
//! - **flash** = every allocated section that has file contents (`SHF_ALLOC` and not
//!   `SHT_NOBITS`): `.vector_table`, `.text`, `.rodata`, and `.data`, whose initial values
//!   are stored in flash and copied to RAM at reset (its load image).
//! - **static RAM** = every allocated section placed in the Cortex-M SRAM region
//!   (0x2000_0000–0x3FFF_FFFF): `.data`, `.bss`, `.uninit`. The stack is not a section
//!   (flip-link puts it below these), so it is not counted.
//!
//! Debug and defmt sections are not allocated and cost nothing on the chip.

use std::path::Path;

use anyhow::{bail, ensure, Context as _, Result};

use crate::steps::{build_target_executables, Context};

/// The firmware's flash budget, bytes: sectors 0–4 of the STM32F411's flash, well below
/// sectors 6–7, which hold the persisted parameters
/// (`robot_app::stm32f4::flash::FIRMWARE_FLASH_BUDGET`).
pub const FLASH_BUDGET: u64 = robot_app::stm32f4::flash::FIRMWARE_FLASH_BUDGET as u64;
/// The firmware's static RAM budget, bytes (no heap; the rest of the 128 KiB is stack).
pub const RAM_BUDGET: u64 = 12 * 1024;

/// The Cortex-M architectural SRAM region.
const SRAM_REGION: std::ops::Range<u64> = 0x2000_0000..0x4000_0000;

const SHF_ALLOC: u32 = 0x2;
const SHT_NOBITS: u32 = 8;

/// One section header, with its name resolved.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Section {
    /// Section name, e.g. `.text`.
    pub name: String,
    /// `sh_type`.
    pub kind: u32,
    /// `sh_flags`.
    pub flags: u32,
    /// `sh_addr`: where the section lives at run time.
    pub addr: u64,
    /// `sh_size`, bytes.
    pub size: u64,
}

impl Section {
    fn is_alloc(&self) -> bool {
        self.flags & SHF_ALLOC != 0
    }

    /// True when the section occupies flash (its contents, or its load image).
    fn in_flash(&self) -> bool {
        self.is_alloc() && self.kind != SHT_NOBITS && self.size > 0
    }

    /// True when the section occupies static RAM.
    fn in_ram(&self) -> bool {
        self.is_alloc() && SRAM_REGION.contains(&self.addr) && self.size > 0
    }
}

/// Memory used by an image.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct MemoryUse {
    /// Flash bytes (see the module doc).
    pub flash: u64,
    /// Static RAM bytes (see the module doc).
    pub ram: u64,
    /// The allocated sections that were counted.
    pub sections: Vec<Section>,
}

impl MemoryUse {
    /// Sums the sections of an ELF image.
    pub fn of(sections: Vec<Section>) -> Self {
        let flash = sections
            .iter()
            .filter(|s| s.in_flash())
            .map(|s| s.size)
            .sum();
        let ram = sections.iter().filter(|s| s.in_ram()).map(|s| s.size).sum();
        let sections = sections
            .into_iter()
            .filter(|s| s.in_flash() || s.in_ram())
            .collect();
        Self {
            flash,
            ram,
            sections,
        }
    }
}

fn u16_at(data: &[u8], offset: usize) -> Result<u16> {
    let bytes = data
        .get(offset..offset + 2)
        .with_context(|| format!("truncated ELF: no u16 at {offset:#x}"))?;
    Ok(u16::from_le_bytes([bytes[0], bytes[1]]))
}

fn u32_at(data: &[u8], offset: usize) -> Result<u32> {
    let bytes = data
        .get(offset..offset + 4)
        .with_context(|| format!("truncated ELF: no u32 at {offset:#x}"))?;
    Ok(u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]))
}

/// Parses the section headers of a little-endian ELF32 image (what an ARM Cortex-M link
/// produces).
pub fn sections(data: &[u8]) -> Result<Vec<Section>> {
    ensure!(data.get(..4) == Some(b"\x7fELF"), "not an ELF file");
    ensure!(
        data.get(4) == Some(&1),
        "not a 32-bit ELF (EI_CLASS != ELFCLASS32)"
    );
    ensure!(data.get(5) == Some(&1), "not a little-endian ELF");
    let shoff = u32_at(data, 0x20)? as usize;
    let shentsize = usize::from(u16_at(data, 0x2e)?);
    let shnum = usize::from(u16_at(data, 0x30)?);
    let shstrndx = usize::from(u16_at(data, 0x32)?);
    ensure!(
        shentsize >= 40,
        "section header entries of {shentsize} bytes, expected 40"
    );
    ensure!(
        shnum > 0,
        "no section headers (or more than 0xff00, not supported)"
    );
    ensure!(
        shstrndx < shnum,
        "section name table index {shstrndx} out of range"
    );

    struct Raw {
        name: u32,
        kind: u32,
        flags: u32,
        addr: u32,
        offset: u32,
        size: u32,
    }
    let raw = (0..shnum)
        .map(|i| {
            let h = shoff + i * shentsize;
            Ok(Raw {
                name: u32_at(data, h)?,
                kind: u32_at(data, h + 4)?,
                flags: u32_at(data, h + 8)?,
                addr: u32_at(data, h + 12)?,
                offset: u32_at(data, h + 16)?,
                size: u32_at(data, h + 20)?,
            })
        })
        .collect::<Result<Vec<_>>>()?;

    let names = &raw[shstrndx];
    let names = data
        .get(names.offset as usize..(names.offset as usize + names.size as usize))
        .context("section name table lies outside the file")?;
    raw.iter()
        .map(|r| {
            let tail = names
                .get(r.name as usize..)
                .context("section name offset outside the name table")?;
            let end = tail.iter().position(|&b| b == 0).unwrap_or(tail.len());
            Ok(Section {
                name: String::from_utf8_lossy(&tail[..end]).into_owned(),
                kind: r.kind,
                flags: r.flags,
                addr: u64::from(r.addr),
                size: u64::from(r.size),
            })
        })
        .collect()
}

/// Reads `path` and sums its memory use.
pub fn measure(path: &Path) -> Result<MemoryUse> {
    let data = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let sections = sections(&data).with_context(|| format!("parsing {}", path.display()))?;
    Ok(MemoryUse::of(sections))
}

/// Prints the memory use of `path` section by section and the line
/// `<label> size: flash N B (budget F), static RAM M B (budget R)`; fails when over budget.
pub fn check_budget(
    label: &str,
    path: &Path,
    flash_budget: u64,
    ram_budget: u64,
) -> Result<MemoryUse> {
    let usage = measure(path)?;
    println!("{}:", path.display());
    for s in &usage.sections {
        let place = match (s.in_flash(), s.in_ram()) {
            (true, true) => "flash + RAM",
            (true, false) => "flash",
            _ => "RAM",
        };
        println!(
            "    {:<16} {:#010x} {:>8} B  {place}",
            s.name, s.addr, s.size
        );
    }
    println!(
        "{label} size: flash {} B (budget {flash_budget}), static RAM {} B (budget {ram_budget})",
        usage.flash, usage.ram
    );
    let mut over = Vec::new();
    if usage.flash > flash_budget {
        over.push(format!("flash {} B > {flash_budget} B", usage.flash));
    }
    if usage.ram > ram_budget {
        over.push(format!("static RAM {} B > {ram_budget} B", usage.ram));
    }
    if !over.is_empty() {
        bail!("over budget: {}", over.join(", "));
    }
    Ok(usage)
}

/// The CI step: release-builds the firmware and checks its ELF against the budget.
pub fn check_firmware(ctx: &Context) -> Result<()> {
    let executables = build_target_executables(ctx, "firmware", &[])?;
    let elf = match executables.as_slice() {
        [one] => one,
        [] => bail!(
            "the firmware build produced no executable: `firmware` has no binary target yet \
             (expected firmware/src/main.rs or a [[bin]])"
        ),
        many => bail!("the firmware build produced several executables: {many:?}"),
    };
    check_budget("firmware", elf, FLASH_BUDGET, RAM_BUDGET)?;
    print_largest_symbols(elf, 12)?;
    Ok(())
}

/// Prints the `count` largest code and data symbols of the ELF at `path` (demangled,
/// hash suffix dropped), with their sizes.
fn print_largest_symbols(path: &Path, count: usize) -> Result<()> {
    use object::{Object as _, ObjectSymbol as _, SymbolKind};
    let data = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
    let file = object::File::parse(&*data).context("parsing the ELF")?;
    let mut symbols: Vec<(u64, String)> = file
        .symbols()
        .filter(|s| matches!(s.kind(), SymbolKind::Text | SymbolKind::Data) && s.size() > 0)
        .filter_map(|s| {
            let name = s.name().ok()?;
            Some((s.size(), format!("{:#}", rustc_demangle::demangle(name))))
        })
        .collect();
    symbols.sort_by(|a, b| b.cmp(a));
    println!("largest symbols (flash and RAM):");
    for (size, name) in symbols.iter().take(count) {
        println!("    {size:>7} B  {name}");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A minimal ELF32 LE image: a header and the given sections (plus the null section
    /// and the name table).
    fn elf(sections: &[(&str, u32, u32, u32, u32)]) -> Vec<u8> {
        let mut names = vec![0u8];
        let mut name_offsets = Vec::new();
        for (name, ..) in sections {
            name_offsets.push(names.len() as u32);
            names.extend_from_slice(name.as_bytes());
            names.push(0);
        }
        let shstrtab_name = names.len() as u32;
        names.extend_from_slice(b".shstrtab\0");

        let mut data = vec![0u8; 52];
        data[..4].copy_from_slice(b"\x7fELF");
        data[4] = 1; // ELFCLASS32
        data[5] = 1; // little-endian
        let names_offset = data.len() as u32;
        data.extend_from_slice(&names);
        while data.len() % 4 != 0 {
            data.push(0);
        }
        let shoff = data.len() as u32;
        let shnum = sections.len() as u16 + 2;
        data[0x20..0x24].copy_from_slice(&shoff.to_le_bytes());
        data[0x2e..0x30].copy_from_slice(&40u16.to_le_bytes());
        data[0x30..0x32].copy_from_slice(&shnum.to_le_bytes());
        data[0x32..0x34].copy_from_slice(&(shnum - 1).to_le_bytes());

        let mut header = |name: u32, kind: u32, flags: u32, addr: u32, offset: u32, size: u32| {
            for word in [name, kind, flags, addr, offset, size, 0, 0, 4, 0] {
                data.extend_from_slice(&word.to_le_bytes());
            }
        };
        header(0, 0, 0, 0, 0, 0);
        for ((_, kind, flags, addr, size), name) in sections.iter().zip(&name_offsets) {
            header(*name, *kind, *flags, *addr, 0, *size);
        }
        header(shstrtab_name, 3, 0, 0, names_offset, names.len() as u32);
        data
    }

    const PROGBITS: u32 = 1;
    const A: u32 = SHF_ALLOC;
    const AW: u32 = SHF_ALLOC | 1;
    const AX: u32 = SHF_ALLOC | 4;

    #[test]
    fn sums_flash_and_ram_like_a_cortex_m_link() {
        let image = elf(&[
            (".vector_table", PROGBITS, A, 0x0800_0000, 0x400),
            (".text", PROGBITS, AX, 0x0800_0400, 0x3000),
            (".rodata", PROGBITS, A, 0x0800_3400, 0x200),
            (".data", PROGBITS, AW, 0x2001_f000, 0x10),
            (".bss", SHT_NOBITS, AW, 0x2001_f010, 0x100),
            (".uninit", SHT_NOBITS, AW, 0x2001_f110, 0x40),
            (".defmt", PROGBITS, 0, 0, 0x500),
            (".debug_info", PROGBITS, 0, 0, 0x9000),
        ]);
        let usage = MemoryUse::of(sections(&image).unwrap());
        assert_eq!(usage.flash, 0x400 + 0x3000 + 0x200 + 0x10);
        assert_eq!(usage.ram, 0x10 + 0x100 + 0x40);
        let counted: Vec<_> = usage.sections.iter().map(|s| s.name.as_str()).collect();
        assert_eq!(
            counted,
            [
                ".vector_table",
                ".text",
                ".rodata",
                ".data",
                ".bss",
                ".uninit"
            ]
        );
    }

    #[test]
    fn rejects_what_is_not_an_elf32() {
        assert!(sections(b"not an elf at all").is_err());
        let mut image = elf(&[]);
        image[4] = 2; // ELFCLASS64
        assert!(sections(&image).is_err());
        let image = elf(&[(".text", PROGBITS, AX, 0x0800_0000, 4)]);
        assert!(sections(&image[..60]).is_err(), "truncated");
    }
}
