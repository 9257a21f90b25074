//! What the panic check needs from a linked Cortex-M ELF, read with the `object` crate:
//! the functions (symbol table), the executable bytes, the ARM mapping symbols that tell
//! code from data (literal pools, jump tables) and the vector table.

use std::fmt;
use std::path::Path;

use anyhow::{bail, ensure, Context as _, Result};
use object::elf::EM_ARM;
use object::read::elf::ElfFile32;
use object::{Endianness, Object, ObjectSection, ObjectSymbol, SectionKind, SymbolKind};

/// Index of a function in [`Image::functions`].
pub type FunctionId = usize;

/// A function of the image: a sized function symbol.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Function {
    /// Demangled name without the hash (`core::panicking::panic_bounds_check`).
    pub name: String,
    /// Address of the first instruction (the symbol's value with the Thumb bit cleared).
    pub addr: u32,
    /// Size in bytes, from the symbol table.
    pub size: u32,
}

impl Function {
    /// One past the last byte.
    pub fn end(&self) -> u32 {
        self.addr.saturating_add(self.size)
    }

    /// True when `addr` lies inside the function.
    pub fn contains(&self, addr: u32) -> bool {
        (self.addr..self.end()).contains(&addr)
    }
}

impl fmt::Display for Function {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} @ {:#010x}", self.name, self.addr)
    }
}

/// What the bytes from an address on are, by the ARM ELF mapping symbols (`$t` Thumb
/// code, `$d` data, `$a` ARM code; "ELF for the Arm Architecture", 5.5.5).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mapping {
    /// Thumb instructions.
    Thumb,
    /// Data: a literal pool, a `TBB`/`TBH` table.
    Data,
    /// ARM (A32) instructions, which a Cortex-M cannot execute.
    Arm,
}

/// Bytes at an address.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Segment {
    /// Address of the first byte.
    pub addr: u32,
    /// The contents.
    pub bytes: Vec<u8>,
}

impl Segment {
    fn get(&self, addr: u32, len: u32) -> Option<&[u8]> {
        let start = usize::try_from(addr.checked_sub(self.addr)?).ok()?;
        let end = start.checked_add(usize::try_from(len).ok()?)?;
        self.bytes.get(start..end)
    }
}

/// The parts of a linked image the call graph needs.
#[derive(Clone, Debug)]
pub struct Image {
    /// Sized functions, sorted by address, one per address.
    functions: Vec<Function>,
    /// Executable sections.
    code: Vec<Segment>,
    /// Mapping symbols, sorted by address: the kind of the bytes from there on.
    mappings: Vec<(u32, Mapping)>,
    /// The `.vector_table` section.
    vector_table: Segment,
}

impl Image {
    /// An image from its parts (for tests and for [`Image::parse`]). Zero-sized functions
    /// are dropped; of several functions at one address the first is kept.
    pub fn new(
        mut functions: Vec<Function>,
        code: Vec<Segment>,
        mut mappings: Vec<(u32, Mapping)>,
        vector_table: Segment,
    ) -> Self {
        functions.retain(|f| f.size > 0);
        functions.sort_by_key(|f| f.addr);
        functions.dedup_by_key(|f| f.addr);
        mappings.sort_by_key(|&(addr, _)| addr);
        Self {
            functions,
            code,
            mappings,
            vector_table,
        }
    }

    /// Reads the ELF file at `path` (see [`Image::parse`]).
    pub fn load(path: &Path) -> Result<Self> {
        let data = std::fs::read(path).with_context(|| format!("reading {}", path.display()))?;
        Self::parse(&data).with_context(|| format!("reading {}", path.display()))
    }

    /// Parses a 32-bit ARM ELF executable.
    pub fn parse(data: &[u8]) -> Result<Self> {
        let file = ElfFile32::<Endianness>::parse(data).context("not a 32-bit ELF file")?;
        let machine = file.elf_header().e_machine.get(file.endian());
        ensure!(machine == EM_ARM, "e_machine is {machine}, not EM_ARM (40)");

        let mut code = Vec::new();
        let mut vector_table = None;
        for section in file.sections() {
            let name = section.name().unwrap_or("");
            let segment = || -> Result<Segment> {
                Ok(Segment {
                    addr: u32::try_from(section.address())
                        .with_context(|| format!("section {name} above 4 GiB"))?,
                    bytes: section
                        .data()
                        .with_context(|| format!("section {name} has no readable data"))?
                        .to_vec(),
                })
            };
            if name == ".vector_table" {
                vector_table = Some(segment()?);
            } else if section.kind() == SectionKind::Text {
                code.push(segment()?);
            }
        }
        let vector_table = vector_table.context("no .vector_table section")?;

        let mut functions = Vec::new();
        let mut mappings = Vec::new();
        for symbol in file.symbols() {
            let Ok(raw_name) = symbol.name() else {
                continue;
            };
            let Ok(value) = u32::try_from(symbol.address()) else {
                continue;
            };
            if let Some(mapping) = mapping_symbol(raw_name) {
                mappings.push((value, mapping));
            } else if symbol.kind() == SymbolKind::Text && symbol.is_definition() {
                let size = u32::try_from(symbol.size())
                    .with_context(|| format!("symbol {raw_name} larger than 4 GiB"))?;
                functions.push(Function {
                    name: demangle(raw_name),
                    addr: value & !1,
                    size,
                });
            }
        }
        if mappings.is_empty() {
            bail!(
                "no ARM mapping symbols ($t/$d): without them literal pools cannot be told \
                 from code (was the ELF stripped?)"
            );
        }
        Ok(Self::new(functions, code, mappings, vector_table))
    }

    /// The function `id`.
    pub fn function(&self, id: FunctionId) -> &Function {
        &self.functions[id]
    }

    /// The function whose bytes contain `addr`.
    pub fn function_containing(&self, addr: u32) -> Option<FunctionId> {
        let after = self.functions.partition_point(|f| f.addr <= addr);
        let id = after.checked_sub(1)?;
        self.functions[id].contains(addr).then_some(id)
    }

    /// The first function whose demangled name satisfies `matches`.
    pub fn find_function(&self, matches: impl Fn(&str) -> bool) -> Option<FunctionId> {
        self.functions.iter().position(|f| matches(&f.name))
    }

    /// The little-endian halfword of code at `addr`, if an executable section holds it.
    pub fn halfword(&self, addr: u32) -> Option<u16> {
        self.code
            .iter()
            .find_map(|s| s.get(addr, 2))
            .map(|b| u16::from_le_bytes([b[0], b[1]]))
    }

    /// What the byte at `addr` is, by the last mapping symbol at or before it (Thumb code
    /// when none precedes it).
    pub fn mapping(&self, addr: u32) -> Mapping {
        let after = self.mappings.partition_point(|&(a, _)| a <= addr);
        after
            .checked_sub(1)
            .map_or(Mapping::Thumb, |i| self.mappings[i].1)
    }

    /// The next mapping symbol after `addr`, if any: where the kind of bytes may change.
    pub fn next_mapping_after(&self, addr: u32) -> Option<u32> {
        let after = self.mappings.partition_point(|&(a, _)| a <= addr);
        self.mappings.get(after).map(|&(a, _)| a)
    }

    /// The handler address in vector table entry `entry` (16 + IRQ number for an
    /// interrupt), with the Thumb bit cleared.
    pub fn vector(&self, entry: u32) -> Result<u32> {
        let offset = entry
            .checked_mul(4)
            .context("vector table entry number overflows")?;
        let bytes = self
            .vector_table
            .get(self.vector_table.addr.wrapping_add(offset), 4)
            .with_context(|| {
                format!(
                    "vector table entry {entry} lies past the end of .vector_table ({} B)",
                    self.vector_table.bytes.len()
                )
            })?;
        let value = u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]);
        ensure!(
            value & 1 == 1,
            "vector table entry {entry} is {value:#010x}, without the Thumb bit: not a handler"
        );
        Ok(value & !1)
    }
}

/// The kind of an ARM mapping symbol (`$t`, `$d`, `$a`, optionally followed by `.suffix`).
fn mapping_symbol(name: &str) -> Option<Mapping> {
    let kind = match name.get(..2)? {
        "$t" => Mapping::Thumb,
        "$d" => Mapping::Data,
        "$a" => Mapping::Arm,
        _ => return None,
    };
    (name.len() == 2 || name[2..].starts_with('.')).then_some(kind)
}

/// A Rust (legacy or v0) symbol demangled without its hash; other names as they are.
pub fn demangle(raw: &str) -> String {
    format!("{:#}", rustc_demangle::demangle(raw))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn function(name: &str, addr: u32, size: u32) -> Function {
        Function {
            name: name.into(),
            addr,
            size,
        }
    }

    fn image() -> Image {
        Image::new(
            vec![
                function("b", 0x100, 0x10),
                function("a", 0x80, 0x20),
                function("alias_of_a", 0x80, 0),
                function("c", 0x110, 4),
            ],
            vec![Segment {
                addr: 0x80,
                bytes: (0..0x94u8).collect(),
            }],
            vec![(0x80, Mapping::Thumb), (0x9c, Mapping::Data)],
            Segment {
                addr: 0,
                bytes: [0x2002_0000u32, 0x81, 0x100, 0x111]
                    .iter()
                    .flat_map(|w| w.to_le_bytes())
                    .collect(),
            },
        )
    }

    #[test]
    fn finds_the_function_around_an_address() {
        let image = image();
        let name = |addr| {
            image
                .function_containing(addr)
                .map(|id| &image.function(id).name[..])
        };
        assert_eq!(name(0x7f), None);
        assert_eq!(name(0x80), Some("a"));
        assert_eq!(name(0x9f), Some("a"));
        assert_eq!(name(0xa0), None, "gap between a and b");
        assert_eq!(name(0x10f), Some("b"));
        assert_eq!(name(0x113), Some("c"));
        assert_eq!(name(0x114), None);
    }

    #[test]
    fn reads_halfwords_and_mappings() {
        let image = image();
        assert_eq!(image.halfword(0x80), Some(0x0100));
        assert_eq!(image.halfword(0x82), Some(0x0302));
        assert_eq!(image.halfword(0x113), None, "past the end");
        assert_eq!(image.mapping(0x9b), Mapping::Thumb);
        assert_eq!(image.mapping(0x9c), Mapping::Data);
        assert_eq!(image.next_mapping_after(0x80), Some(0x9c));
        assert_eq!(image.next_mapping_after(0x9c), None);
    }

    #[test]
    fn reads_vectors_and_rejects_non_thumb_entries() {
        let image = image();
        assert_eq!(image.vector(1).unwrap(), 0x80);
        assert_eq!(image.vector(3).unwrap(), 0x110);
        assert!(image.vector(2).is_err(), "0x100 has no Thumb bit");
        assert!(image.vector(4).is_err(), "past the table");
    }

    #[test]
    fn mapping_symbols_and_names() {
        assert_eq!(mapping_symbol("$t"), Some(Mapping::Thumb));
        assert_eq!(mapping_symbol("$d.12"), Some(Mapping::Data));
        assert_eq!(mapping_symbol("$a"), Some(Mapping::Arm));
        assert_eq!(mapping_symbol("$tx"), None);
        assert_eq!(mapping_symbol("main"), None);
        assert_eq!(
            demangle("_RNvNtCs7ldSeZOOJos_4core9panicking18panic_bounds_check"),
            "core::panicking::panic_bounds_check"
        );
        assert_eq!(
            demangle("_ZN15controller_core4path4Path6sample17hab7545a357ae9eb1E"),
            "controller_core::path::Path::sample"
        );
        assert_eq!(demangle("__aeabi_memcpy"), "__aeabi_memcpy");
    }
}
