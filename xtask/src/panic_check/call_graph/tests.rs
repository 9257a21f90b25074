//! The call graph over small hand-assembled images.

use super::*;
use crate::panic_check::image::Segment;

const BX_LR: u16 = 0x4770;
const NOP: u16 = 0xbf00;
const BLX_R3: u16 = 0x4798;
const PUSH_R7_LR: u16 = 0xb580;
const POP_R7_PC: u16 = 0xbd80;
const UDF: u16 = 0xdefe;

/// `BL` (T1) or `B.W` (T4) from `from` to `to`: the encoding the manual gives (A7.7.18,
/// A7.7.12), first halfword first.
fn wide_branch(from: u32, to: u32, link: bool) -> [u16; 2] {
    let offset = to.wrapping_sub(from.wrapping_add(4));
    let s = (offset >> 24) & 1;
    let i1 = (offset >> 23) & 1;
    let i2 = (offset >> 22) & 1;
    let j1 = (!(i1 ^ s)) & 1;
    let j2 = (!(i2 ^ s)) & 1;
    let imm10 = (offset >> 12) & 0x3ff;
    let imm11 = (offset >> 1) & 0x7ff;
    let hw1 = 0xf000 | (s << 10) | imm10;
    let hw2 = 0x8000 | (u32::from(link) << 14) | (j1 << 13) | 0x1000 | (j2 << 11) | imm11;
    [hw1 as u16, hw2 as u16]
}

#[test]
fn the_test_encoder_agrees_with_the_assembler() {
    // From an LLVM-assembled object: 22: 27 f1 e0 fc  bl 0x1279e6 ;
    // 1279ec: d8 f6 08 bb  b.w 0x0
    assert_eq!(wide_branch(0x22, 0x1279e6, true), [0xf127, 0xfce0]);
    assert_eq!(wide_branch(0x1279ec, 0x0, false), [0xf6d8, 0xbb08]);
}

/// A hand-assembled image: functions, their halfwords, mapping symbols.
#[derive(Default)]
struct Assembler {
    functions: Vec<Function>,
    halfwords: Vec<(u32, u16)>,
    mappings: Vec<(u32, Mapping)>,
}

const BASE: u32 = 0x0800_0000;

impl Assembler {
    /// Places `code` at `addr` as function `name` (size = the code's length), with a `$t`.
    fn function(&mut self, name: &str, addr: u32, code: &[u16]) -> &mut Self {
        self.functions.push(Function {
            name: name.into(),
            addr,
            size: 2 * code.len() as u32,
        });
        self.mappings.push((addr, Mapping::Thumb));
        self.place(addr, code)
    }

    fn place(&mut self, addr: u32, code: &[u16]) -> &mut Self {
        for (i, &hw) in code.iter().enumerate() {
            self.halfwords.push((addr + 2 * i as u32, hw));
        }
        self
    }

    /// Marks `addr` onward as data (`$d`).
    fn data_from(&mut self, addr: u32) -> &mut Self {
        self.mappings.push((addr, Mapping::Data));
        self
    }

    fn image(&self) -> Image {
        let end = self
            .halfwords
            .iter()
            .map(|&(a, _)| a + 2)
            .max()
            .unwrap_or(BASE);
        let mut bytes = vec![0u8; (end - BASE) as usize];
        for &(addr, hw) in &self.halfwords {
            let at = (addr - BASE) as usize;
            bytes[at..at + 2].copy_from_slice(&hw.to_le_bytes());
        }
        Image::new(
            self.functions.clone(),
            vec![Segment { addr: BASE, bytes }],
            self.mappings.clone(),
            Segment {
                addr: 0,
                bytes: Vec::new(),
            },
        )
    }
}

fn id(image: &Image, name: &str) -> FunctionId {
    image.find_function(|n| n == name).unwrap()
}

fn names(image: &Image, ids: &[FunctionId]) -> Vec<String> {
    ids.iter()
        .map(|&f| image.function(f).name.clone())
        .collect()
}

fn is_panic(f: &Function) -> bool {
    f.name.starts_with("panic")
}

const ROOT: u32 = BASE + 0x100;
const LEAF: u32 = BASE + 0x200;
const MIDDLE: u32 = BASE + 0x300;
const TAIL: u32 = BASE + 0x400;
const PANIC: u32 = BASE + 0x500;
const UNREACHABLE: u32 = BASE + 0x600;

/// root calls leaf and middle; middle tail-branches to tail; tail calls the panic
/// function; the panic function makes an indirect call (it is a sink: never explored);
/// an unreachable function calls the panic function and makes an indirect call.
fn program() -> Assembler {
    let mut asm = Assembler::default();
    let [bl_leaf_1, bl_leaf_2] = wide_branch(ROOT + 2, LEAF, true);
    let [bl_middle_1, bl_middle_2] = wide_branch(ROOT + 6, MIDDLE, true);
    asm.function(
        "root",
        ROOT,
        &[
            PUSH_R7_LR,
            bl_leaf_1,
            bl_leaf_2,
            bl_middle_1,
            bl_middle_2,
            0xd0fe, // beq . (inside root: no edge)
            POP_R7_PC,
        ],
    );
    asm.function("leaf", LEAF, &[NOP, BX_LR]);
    let [b_tail_1, b_tail_2] = wide_branch(MIDDLE + 2, TAIL, false);
    asm.function("middle", MIDDLE, &[0x4801, b_tail_1, b_tail_2, NOP]); // ldr r0, [pc, #4]
                                                                        // middle's literal pool: a word that would decode as `blx r3; bl …` if taken for code.
    let [bl_unreachable_1, bl_unreachable_2] = wide_branch(MIDDLE + 10, UNREACHABLE, true);
    asm.data_from(MIDDLE + 8)
        .place(MIDDLE + 8, &[BLX_R3, bl_unreachable_1, bl_unreachable_2]);
    asm.functions.last_mut().unwrap().size = 14;
    let [bl_panic_1, bl_panic_2] = wide_branch(TAIL, PANIC, true);
    asm.function("tail", TAIL, &[bl_panic_1, bl_panic_2, UDF]);
    asm.function("panic_bounds_check", PANIC, &[BLX_R3, UDF]);
    let [bl_panic_3, bl_panic_4] = wide_branch(UNREACHABLE + 2, PANIC, true);
    asm.function(
        "unreachable",
        UNREACHABLE,
        &[BLX_R3, bl_panic_3, bl_panic_4, BX_LR],
    );
    asm
}

#[test]
fn follows_calls_and_tail_branches_to_the_panic_function() {
    let image = program().image();
    let root = id(&image, "root");
    let found = explore(&image, root, is_panic);

    assert_eq!(
        names(&image, &found.reached),
        ["root", "leaf", "middle", "tail", "panic_bounds_check"]
    );
    assert_eq!(
        found.panic_sites,
        [PanicSite {
            site: site(id(&image, "tail"), TAIL, EdgeKind::Call),
            callee: id(&image, "panic_bounds_check"),
        }]
    );
    assert_eq!(
        found.problems,
        [],
        "the sink's and the pool's blx are not looked at"
    );

    let chain = found.chain_to(id(&image, "panic_bounds_check"));
    let steps: Vec<_> = chain
        .iter()
        .map(|&(f, via)| {
            (
                image.function(f).name.as_str(),
                via.map(|s| (s.addr, s.kind)),
            )
        })
        .collect();
    assert_eq!(
        steps,
        [
            ("root", None),
            ("middle", Some((ROOT + 6, EdgeKind::Call))),
            ("tail", Some((MIDDLE + 2, EdgeKind::Branch))),
            ("panic_bounds_check", Some((TAIL, EdgeKind::Call))),
        ]
    );
    assert_eq!(found.chain_to(id(&image, "unreachable")), []);
}

#[test]
fn a_root_without_panic_paths_reaches_only_its_callees() {
    let image = program().image();
    let found = explore(&image, id(&image, "leaf"), is_panic);
    assert_eq!(names(&image, &found.reached), ["leaf"]);
    assert!(found.panic_sites.is_empty());
    assert!(found.problems.is_empty());
}

#[test]
fn reports_every_indirect_call_in_reachable_code() {
    let image = program().image();
    let unreachable = id(&image, "unreachable");
    let found = explore(&image, unreachable, is_panic);
    assert_eq!(
        found.problems,
        [Problem::Indirect {
            function: unreachable,
            addr: UNREACHABLE,
            kind: Indirect::BlxRegister(3),
        }]
    );
    assert_eq!(found.panic_sites.len(), 1);
}

#[test]
fn without_the_data_mapping_the_literal_pool_would_be_taken_for_code() {
    // The same program with middle's `$d` removed: its pool now decodes as an indirect
    // call and a call to `unreachable`, which proves the mapping symbols are what keeps
    // the first test clean.
    let mut asm = program();
    asm.mappings
        .retain(|&(addr, m)| !(addr == MIDDLE + 8 && m == Mapping::Data));
    let image = asm.image();
    let found = explore(&image, id(&image, "root"), is_panic);
    assert!(found.problems.contains(&Problem::Indirect {
        function: id(&image, "middle"),
        addr: MIDDLE + 8,
        kind: Indirect::BlxRegister(3),
    }));
    assert!(found.reached.contains(&id(&image, "unreachable")));
}

#[test]
fn calls_outside_every_function_and_truncated_code_are_problems() {
    let mut asm = Assembler::default();
    let [bl_1, bl_2] = wide_branch(ROOT, BASE + 0x900, true);
    asm.function("root", ROOT, &[bl_1, bl_2, 0xf000]); // ends on a 32-bit first halfword
    let image = asm.image();
    let root = id(&image, "root");
    let found = explore(&image, root, is_panic);
    assert_eq!(
        found.problems,
        [
            Problem::Undecodable {
                function: root,
                addr: ROOT + 4,
                error: DecodeError::Truncated { first: 0xf000 },
            },
            Problem::UnknownTarget {
                function: root,
                addr: ROOT,
                target: BASE + 0x900,
            },
        ]
    );
}

#[test]
fn a_branch_into_the_middle_of_another_function_reaches_that_function() {
    let mut asm = Assembler::default();
    asm.function("shared", LEAF, &[NOP, NOP, BLX_R3, BX_LR]);
    // B (T2) from ROOT to LEAF + 4: offset = LEAF + 4 - (ROOT + 4) = 0x100, imm11 = 0x80.
    let b_n = 0xe000 | 0x80;
    asm.function("root", ROOT, &[b_n]);
    let image = asm.image();
    let found = explore(&image, id(&image, "root"), is_panic);
    assert_eq!(names(&image, &found.reached), ["root", "shared"]);
    assert_eq!(found.problems.len(), 1, "shared is scanned as a whole");
}
