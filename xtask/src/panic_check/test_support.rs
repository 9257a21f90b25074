//! Hand-assembled images for the tests of the call graph, the report and the check.

use super::image::{Function, FunctionId, Image, Mapping, Segment};

/// `bx lr`.
pub const BX_LR: u16 = 0x4770;
/// `nop`.
pub const NOP: u16 = 0xbf00;
/// `blx r3`.
pub const BLX_R3: u16 = 0x4798;
/// `push {r7, lr}`.
pub const PUSH_R7_LR: u16 = 0xb580;
/// `pop {r7, pc}`.
pub const POP_R7_PC: u16 = 0xbd80;
/// `udf #254`.
pub const UDF: u16 = 0xdefe;
/// `beq .` (a branch to itself).
pub const BEQ_SELF: u16 = 0xd0fe;
/// `ldr r0, [pc, #4]`.
pub const LDR_LITERAL: u16 = 0x4801;

/// `BL` (T1) or `B.W` (T4) from `from` to `to`: the encoding the manual gives (A7.7.18,
/// A7.7.12), first halfword first.
pub fn wide_branch(from: u32, to: u32, link: bool) -> [u16; 2] {
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

/// Where the hand-assembled code starts (the start of flash on an STM32).
pub const BASE: u32 = 0x0800_0000;

/// A hand-assembled image: functions, their halfwords, mapping symbols, vectors.
#[derive(Default)]
pub struct Assembler {
    /// The functions placed so far.
    pub functions: Vec<Function>,
    /// Every halfword placed, by address.
    pub halfwords: Vec<(u32, u16)>,
    /// Mapping symbols.
    pub mappings: Vec<(u32, Mapping)>,
    /// Vector table entries: (entry, handler address with the Thumb bit).
    pub vectors: Vec<(u32, u32)>,
}

impl Assembler {
    /// Places `code` at `addr` as function `name` (size = the code's length), with a `$t`.
    pub fn function(&mut self, name: &str, addr: u32, code: &[u16]) -> &mut Self {
        self.functions.push(Function {
            name: name.into(),
            addr,
            size: 2 * code.len() as u32,
        });
        self.mappings.push((addr, Mapping::Thumb));
        self.place(addr, code)
    }

    /// Places `code` at `addr` without a symbol.
    pub fn place(&mut self, addr: u32, code: &[u16]) -> &mut Self {
        for (i, &hw) in code.iter().enumerate() {
            self.halfwords.push((addr + 2 * i as u32, hw));
        }
        self
    }

    /// Marks `addr` onward as data (`$d`).
    pub fn data_from(&mut self, addr: u32) -> &mut Self {
        self.mappings.push((addr, Mapping::Data));
        self
    }

    /// Points vector table entry `entry` at `handler` (Thumb bit set).
    pub fn vector(&mut self, entry: u32, handler: u32) -> &mut Self {
        self.vectors.push((entry, handler | 1));
        self
    }

    /// The image: one code segment from [`BASE`], the vector table at address 0.
    pub fn image(&self) -> Image {
        let entries = self.vectors.iter().map(|&(e, _)| e + 1).max().unwrap_or(0);
        let mut vector_table = vec![0u8; 4 * entries as usize];
        for &(entry, value) in &self.vectors {
            let at = 4 * entry as usize;
            vector_table[at..at + 4].copy_from_slice(&value.to_le_bytes());
        }
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
                bytes: vector_table,
            },
        )
    }
}

/// The function named `name`.
pub fn id(image: &Image, name: &str) -> FunctionId {
    image.find_function(|n| n == name).unwrap()
}

/// The names of `ids`.
pub fn names(image: &Image, ids: &[FunctionId]) -> Vec<String> {
    ids.iter()
        .map(|&f| image.function(f).name.clone())
        .collect()
}

/// Address of `TIM5` in [`program`].
pub const ROOT: u32 = BASE + 0x100;
/// Address of `leaf`.
pub const LEAF: u32 = BASE + 0x200;
/// Address of `middle`.
pub const MIDDLE: u32 = BASE + 0x300;
/// Address of `tail`.
pub const TAIL: u32 = BASE + 0x400;
/// Address of `core::panicking::panic_bounds_check`.
pub const PANIC: u32 = BASE + 0x500;
/// Address of `unreachable`.
pub const UNREACHABLE: u32 = BASE + 0x600;
/// Address of `USART2`.
pub const CLEAN_ROOT: u32 = BASE + 0x700;
/// Address of the panic handler, `__rustc::rust_begin_unwind`.
pub const HANDLER: u32 = BASE + 0x800;

/// `TIM5` calls `leaf` and `middle`; `middle` tail-branches to `tail` (and has a literal
/// pool whose bytes would decode as `blx r3; bl unreachable`); `tail` calls
/// `core::panicking::panic_bounds_check`, which makes an indirect call and calls the
/// panic handler (it is a sink: never explored); `unreachable` calls the panic function
/// and makes an indirect call; `USART2` only calls `leaf`.
///
/// Vectors: IRQ 50 (entry 66) → `TIM5`, IRQ 38 (entry 54) → `USART2`, IRQ 7 (entry 23)
/// → `unreachable`.
pub fn program() -> Assembler {
    let mut asm = Assembler::default();
    let [bl_leaf_1, bl_leaf_2] = wide_branch(ROOT + 2, LEAF, true);
    let [bl_middle_1, bl_middle_2] = wide_branch(ROOT + 6, MIDDLE, true);
    asm.function(
        "TIM5",
        ROOT,
        &[
            PUSH_R7_LR,
            bl_leaf_1,
            bl_leaf_2,
            bl_middle_1,
            bl_middle_2,
            BEQ_SELF, // inside TIM5: no edge
            POP_R7_PC,
        ],
    );
    asm.function("leaf", LEAF, &[NOP, BX_LR]);

    let [b_tail_1, b_tail_2] = wide_branch(MIDDLE + 2, TAIL, false);
    asm.function("middle", MIDDLE, &[LDR_LITERAL, b_tail_1, b_tail_2, NOP]);
    let [bl_unreachable_1, bl_unreachable_2] = wide_branch(MIDDLE + 10, UNREACHABLE, true);
    asm.data_from(MIDDLE + 8)
        .place(MIDDLE + 8, &[BLX_R3, bl_unreachable_1, bl_unreachable_2]);
    if let Some(middle) = asm.functions.last_mut() {
        middle.size = 14; // code and pool
    }

    let [bl_panic_1, bl_panic_2] = wide_branch(TAIL, PANIC, true);
    asm.function("tail", TAIL, &[bl_panic_1, bl_panic_2, UDF]);
    let [bl_handler_1, bl_handler_2] = wide_branch(PANIC + 2, HANDLER, true);
    asm.function(
        "core::panicking::panic_bounds_check",
        PANIC,
        &[BLX_R3, bl_handler_1, bl_handler_2],
    );
    asm.function("__rustc::rust_begin_unwind", HANDLER, &[BLX_R3, UDF]);
    let [bl_panic_3, bl_panic_4] = wide_branch(UNREACHABLE + 2, PANIC, true);
    asm.function(
        "unreachable",
        UNREACHABLE,
        &[BLX_R3, bl_panic_3, bl_panic_4, BX_LR],
    );
    let [bl_leaf_3, bl_leaf_4] = wide_branch(CLEAN_ROOT + 2, LEAF, true);
    asm.function(
        "USART2",
        CLEAN_ROOT,
        &[PUSH_R7_LR, bl_leaf_3, bl_leaf_4, POP_R7_PC],
    );
    asm.vector(16 + 50, ROOT)
        .vector(16 + 38, CLEAN_ROOT)
        .vector(16 + 7, UNREACHABLE);
    asm
}
