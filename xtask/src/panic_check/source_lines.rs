//! Source lines of an address, inlined frames included, from the ELF's DWARF line and
//! inlining information: what turns "`bl` at 0x08001c3c in TIM5" into the line of the
//! core that panics. Only for the report: the proof does not depend on it.

use std::path::Path;

use addr2line::gimli::{self, EndianSlice, RunTimeEndian};
use anyhow::{Context as _, Result};
use object::{Object, ObjectSection};

use super::image::demangle;

type Reader<'data> = EndianSlice<'data, RunTimeEndian>;

/// One frame at an address: a function, and where in it.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Frame {
    /// Demangled function name without its hash (`?` when DWARF has none).
    pub function: String,
    /// `file:line` (`?` when unknown), with the workspace and registry prefixes dropped.
    pub location: String,
}

/// The DWARF of one image, borrowed from the ELF's bytes.
pub struct SourceLines<'data> {
    context: addr2line::Context<Reader<'data>>,
    /// Prefix dropped from file names (the workspace root, with a trailing `/`).
    workspace: String,
}

impl<'data> SourceLines<'data> {
    /// Reads the DWARF sections of the ELF image `data`; `workspace` is the directory
    /// whose prefix is dropped from file names.
    pub fn parse(data: &'data [u8], workspace: &Path) -> Result<Self> {
        let file = object::File::parse(data).context("not an object file")?;
        let endian = if file.is_little_endian() {
            RunTimeEndian::Little
        } else {
            RunTimeEndian::Big
        };
        let load = |id: gimli::SectionId| -> Result<Reader<'data>, gimli::Error> {
            let bytes = file
                .section_by_name(id.name())
                .and_then(|section| section.data().ok())
                .unwrap_or(&[]);
            Ok(EndianSlice::new(bytes, endian))
        };
        let dwarf = gimli::Dwarf::load(load).context("reading the DWARF sections")?;
        let context = addr2line::Context::from_dwarf(dwarf).context("reading the DWARF units")?;
        let mut workspace = workspace.to_string_lossy().into_owned();
        if !workspace.ends_with('/') {
            workspace.push('/');
        }
        Ok(Self { context, workspace })
    }

    /// The frames at `addr`, innermost (inlined) first, the function that holds the code
    /// last. Empty when DWARF does not cover it.
    pub fn frames(&self, addr: u32) -> Vec<Frame> {
        let mut frames = Vec::new();
        let Ok(mut iter) = self.context.find_frames(u64::from(addr)).skip_all_loads() else {
            return frames;
        };
        while let Ok(Some(frame)) = iter.next() {
            let function = frame
                .function
                .as_ref()
                .and_then(|f| f.raw_name().ok())
                .map_or_else(|| "?".to_owned(), |raw| demangle(raw.as_ref()));
            let location = match frame.location {
                Some(addr2line::Location {
                    file: Some(file),
                    line,
                    ..
                }) => format!(
                    "{}:{}",
                    self.shorten(file),
                    line.map_or_else(|| "?".to_owned(), |l| l.to_string())
                ),
                _ => "?".to_owned(),
            };
            frames.push(Frame { function, location });
        }
        frames
    }

    /// `file` relative to the workspace; registry sources from the crate directory on
    /// (`…/registry/src/<index>/rtic-2.4.0/src/…` → `rtic-2.4.0/src/…`); the standard
    /// library from `library/` on (`/rustc/<commit>/library/core/…` → `library/core/…`).
    fn shorten<'a>(&self, file: &'a str) -> &'a str {
        if let Some(relative) = file.strip_prefix(&self.workspace) {
            return relative;
        }
        for marker in ["/registry/src/", "/rustc/"] {
            if let Some(at) = file.find(marker) {
                // Drop the index directory or the compiler's commit hash too.
                let after = &file[at + marker.len()..];
                if let Some(slash) = after.find('/') {
                    return &after[slash + 1..];
                }
            }
        }
        file
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn file_names_are_shortened_to_what_a_reader_needs() {
        // No DWARF needed: only the workspace prefix matters.
        let shortener_for = |workspace: &str| {
            let lines = SourceLines {
                context: addr2line::Context::from_dwarf(gimli::Dwarf::default()).unwrap(),
                workspace: workspace.into(),
            };
            move |file: &str| lines.shorten(file).to_owned()
        };
        let shorten = shortener_for("/home/dev/robot/");
        assert_eq!(
            shorten("/home/dev/robot/controller-core/src/path.rs"),
            "controller-core/src/path.rs"
        );
        assert_eq!(
            shorten("/home/dev/.cargo/registry/src/index.crates.io-1949cf8c6b5b557f/rtic-2.4.0/src/export.rs"),
            "rtic-2.4.0/src/export.rs"
        );
        assert_eq!(
            shorten(
                "/rustc/59807616e1fa2540724bfbac14d7976d7e4a3860/library/core/src/ops/function.rs"
            ),
            "library/core/src/ops/function.rs"
        );
        assert_eq!(shorten("/elsewhere/x.rs"), "/elsewhere/x.rs");
    }
}
