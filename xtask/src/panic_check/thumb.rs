//! Thumb and Thumb-2 (ARMv7-M) decoding, as far as control flow goes.
//!
//! Every instruction is classified by how it can move the program counter: not at all
//! ([`Flow::Next`]), a direct call or branch to an address computed from the encoding, a
//! return, a table branch, a trap, or an indirect transfer through a register or memory.
//! Instructions that do not write the PC are not decoded further: only their length
//! matters. Encodings are those of the ARMv7-M Architecture Reference Manual (DDI 0403E),
//! section A5 ("The Thumb Instruction Set Encoding") and the instruction pages it points
//! to; the section of each form is named where it is matched.

use std::fmt;

/// How an instruction can move the program counter.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Flow {
    /// Does not write the PC: execution goes on with the next instruction. This includes
    /// `IT`, `SVC` (returns to the next instruction), `BKPT` and everything that computes or
    /// loads into registers other than the PC.
    Next,
    /// `BL` (A7.7.18): a call to `target`.
    Call {
        /// The callee's address (Thumb bit clear).
        target: u32,
    },
    /// `B` (A7.7.12, encodings T1–T4), `CBZ` / `CBNZ` (A7.7.21): a jump to `target`,
    /// possibly conditional (by its own condition or an enclosing `IT` block).
    Branch {
        /// The destination's address.
        target: u32,
    },
    /// `TBB` / `TBH` (A7.7.185): a jump to one of the offsets in the table that follows.
    /// The offsets are unsigned and count forward from the instruction, so the targets
    /// lie after it; the check takes them to stay inside the function.
    TableBranch,
    /// A plain return: `BX LR`, `MOV PC, LR`, `POP {…, PC}` (16-bit, and `LDM SP!` /
    /// `LDR PC, [SP], #4`, its 32-bit forms).
    Return,
    /// An indirect transfer that is not a plain return: the destination comes from a
    /// register or from memory, so the call graph cannot follow it.
    Indirect(Indirect),
    /// `UDF` (A7.7.191): permanently undefined, traps to the UsageFault / HardFault
    /// handler. The compiler puts one after calls that cannot return.
    Trap,
}

/// An indirect control transfer (see [`Flow::Indirect`]). The numbers are register
/// numbers (0–15; 13 = SP, 14 = LR, 15 = PC).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Indirect {
    /// `BLX Rm`: a call through a register (function pointer, trait object).
    BlxRegister(u8),
    /// `BX Rm` with `Rm` other than LR: a jump through a register.
    BxRegister(u8),
    /// `MOV PC, Rm` with `Rm` other than LR.
    MovPc(u8),
    /// `ADD PC, Rm`: a computed jump.
    AddPc(u8),
    /// `LDR PC, …` other than `LDR PC, [SP], #4`: a jump through memory.
    LoadPc,
    /// `LDM` / `LDMDB` with the PC in the list, other than `LDM SP!, {…, PC}`.
    LoadMultiplePc,
}

impl fmt::Display for Indirect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Indirect::BlxRegister(rm) => write!(f, "blx {}", Reg(*rm)),
            Indirect::BxRegister(rm) => write!(f, "bx {}", Reg(*rm)),
            Indirect::MovPc(rm) => write!(f, "mov pc, {}", Reg(*rm)),
            Indirect::AddPc(rm) => write!(f, "add pc, {}", Reg(*rm)),
            Indirect::LoadPc => f.write_str("ldr pc, [...]"),
            Indirect::LoadMultiplePc => f.write_str("ldm with pc in the register list"),
        }
    }
}

/// A register number printed the way the manual names it.
struct Reg(u8);

impl fmt::Display for Reg {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            13 => f.write_str("sp"),
            14 => f.write_str("lr"),
            15 => f.write_str("pc"),
            n => write!(f, "r{n}"),
        }
    }
}

/// Why a halfword (pair) is not an instruction the check can vouch for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum DecodeError {
    /// The first halfword of a 32-bit encoding is the last one of the code range.
    Truncated {
        /// The lone first halfword.
        first: u16,
    },
    /// `BLX <label>`: a call that switches to the ARM instruction set, which ARMv7-M does
    /// not have (UNDEFINED there).
    BlxImmediate {
        /// The encoding, first halfword in the upper 16 bits.
        encoding: u32,
    },
    /// An undefined encoding in the branch and miscellaneous control space (A5.3.4).
    Undefined {
        /// The encoding, first halfword in the upper 16 bits.
        encoding: u32,
    },
    /// A 32-bit data-processing instruction with the PC as destination (other than the
    /// compare forms `TST`/`TEQ`/`CMN`/`CMP`, which use that field for "no destination"):
    /// UNPREDICTABLE on ARMv7-M, and never produced by a compiler. Seeing one means the
    /// bytes are probably not code.
    PcDestination {
        /// The encoding, first halfword in the upper 16 bits.
        encoding: u32,
    },
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DecodeError::Truncated { first } => write!(
                f,
                "first halfword {first:#06x} of a 32-bit instruction at the end of the code"
            ),
            DecodeError::BlxImmediate { encoding } => write!(
                f,
                "{encoding:#010x} is BLX <label>, a switch to ARM state (undefined on ARMv7-M)"
            ),
            DecodeError::Undefined { encoding } => write!(
                f,
                "{encoding:#010x} is undefined in the branch and control space"
            ),
            DecodeError::PcDestination { encoding } => write!(
                f,
                "{encoding:#010x} is a data-processing instruction writing the PC (unpredictable)"
            ),
        }
    }
}

/// One decoded instruction.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Instruction {
    /// Length in bytes: 2 or 4.
    pub len: u32,
    /// How it can move the PC.
    pub flow: Flow,
}

/// True when `first` is the first halfword of a 32-bit instruction: bits 15:11 are
/// `0b11101`, `0b11110` or `0b11111` (A5.1).
pub fn is_32bit(first: u16) -> bool {
    first >> 11 >= 0b11101
}

/// Decodes the instruction at `addr` whose first halfword is `first`; `second` is the
/// halfword after it, if the code range has one (needed only for 32-bit encodings).
pub fn decode(addr: u32, first: u16, second: Option<u16>) -> Result<Instruction, DecodeError> {
    if !is_32bit(first) {
        return Ok(Instruction {
            len: 2,
            flow: decode16(addr, first),
        });
    }
    let second = second.ok_or(DecodeError::Truncated { first })?;
    Ok(Instruction {
        len: 4,
        flow: decode32(addr, first, second)?,
    })
}

/// How an instruction moves the stack pointer down (what a function's frame is made of).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StackEffect {
    /// It does not lower SP (loads, stores, pops, arithmetic on other registers).
    None,
    /// It lowers SP by this many bytes: `PUSH`, `VPUSH`, `STR Rt, [SP, #-4]!`,
    /// `SUB SP, SP, #imm` (every immediate form).
    Down(u32),
    /// It lowers SP by a register's value (`SUB SP, SP, Rm`): a frame of unknown size.
    Dynamic,
}

/// The stack effect of the instruction `first` (and `second`, for a 32-bit one): the
/// prologue forms of ARMv7-M (A7.7.99 PUSH, A7.7.175 SUB (SP minus immediate),
/// A7.7.176 SUB (SP minus register), A7.7.251 VPUSH).
pub fn stack_effect(first: u16, second: Option<u16>) -> StackEffect {
    if !is_32bit(first) {
        return match first {
            // PUSH (T1): 1011 010 M register_list; M = LR.
            _ if first & 0xfe00 == 0xb400 => {
                StackEffect::Down(4 * (u32::from(first & 0xff).count_ones() + bits(first, 8, 8)))
            }
            // SUB SP, SP, #imm7:'00' (T1): 1011 0000 1 imm7.
            _ if first & 0xff80 == 0xb080 => StackEffect::Down(bits(first, 6, 0) << 2),
            _ => StackEffect::None,
        };
    }
    let Some(second) = second else {
        return StackEffect::None;
    };
    match (first, second) {
        // PUSH (T2) = STMDB SP!, {list}: 1110 1001 0010 1101 / 0 M 0 register_list.
        (0xe92d, _) => StackEffect::Down(4 * u32::from(second & 0x5fff).count_ones()),
        // PUSH (T3) = STR Rt, [SP, #-4]!: 1111 1000 0100 1101 / Rt 1101 0000 0100.
        (0xf84d, _) if second & 0x0fff == 0x0d04 => StackEffect::Down(4),
        // VPUSH: 1110 1101 0D10 1101 / Vd 101x imm8, imm8 = words to push.
        _ if first & 0xffbf == 0xed2d && second & 0x0e00 == 0x0a00 => {
            StackEffect::Down(4 * bits(second, 7, 0))
        }
        // SUB{S}.W SP, SP, #const (T2): 11110 i 0 1101 S 1101 / 0 imm3 1101 imm8.
        _ if first & 0xfbef == 0xf1ad && second & 0x8f00 == 0x0d00 => {
            StackEffect::Down(thumb_expand_imm(immediate12(first, second)))
        }
        // SUBW SP, SP, #imm12 (T3): 11110 i 1 0101 0 1101 / 0 imm3 1101 imm8.
        _ if first & 0xfbff == 0xf2ad && second & 0x8f00 == 0x0d00 => {
            StackEffect::Down(immediate12(first, second))
        }
        // SUB{S}.W SP, SP, Rm{, shift} (T1): 1110 1011 101S 1101 / 0 imm3 1101 imm2 type Rm.
        _ if first & 0xffef == 0xebad && second & 0x8f00 == 0x0d00 => StackEffect::Dynamic,
        _ => StackEffect::None,
    }
}

/// i:imm3:imm8 of the 32-bit data-processing (immediate) encodings.
fn immediate12(first: u16, second: u16) -> u32 {
    (bits(first, 10, 10) << 11) | (bits(second, 14, 12) << 8) | bits(second, 7, 0)
}

/// ThumbExpandImm (A5.3.2): a modified immediate's value.
fn thumb_expand_imm(imm12: u32) -> u32 {
    let byte = imm12 & 0xff;
    if imm12 >> 10 == 0 {
        match (imm12 >> 8) & 0b11 {
            0b00 => byte,
            0b01 => byte << 16 | byte,
            0b10 => byte << 24 | byte << 8,
            _ => byte << 24 | byte << 16 | byte << 8 | byte,
        }
    } else {
        (0x80 | (imm12 & 0x7f)).rotate_right(imm12 >> 7)
    }
}

/// The value of the PC as an instruction at `addr` reads it: its address plus 4.
fn pc(addr: u32) -> u32 {
    addr.wrapping_add(4)
}

/// Sign-extends the low `bits` bits of `value`.
fn sign_extend(value: u32, bits: u32) -> i32 {
    let shift = 32 - bits;
    ((value << shift) as i32) >> shift
}

fn bits(value: u16, high: u32, low: u32) -> u32 {
    (u32::from(value) >> low) & ((1 << (high - low + 1)) - 1)
}

fn bit(value: u16, n: u32) -> bool {
    (value >> n) & 1 == 1
}

/// A 16-bit instruction (A5.2).
fn decode16(addr: u32, hw: u16) -> Flow {
    match hw {
        // A5.2.3 Special data instructions and branch and exchange.
        // BX Rm: 0100 0111 0 Rm 000. BLX Rm: 0100 0111 1 Rm 000.
        _ if hw & 0xff80 == 0x4700 => match bits(hw, 6, 3) as u8 {
            14 => Flow::Return,
            rm => Flow::Indirect(Indirect::BxRegister(rm)),
        },
        _ if hw & 0xff80 == 0x4780 => Flow::Indirect(Indirect::BlxRegister(bits(hw, 6, 3) as u8)),
        // MOV Rd, Rm (T1, high registers): 0100 0110 D Rm Rdn, Rd = D:Rdn.
        _ if hw & 0xff00 == 0x4600 && rd_high(hw) == 15 => match bits(hw, 6, 3) as u8 {
            14 => Flow::Return,
            rm => Flow::Indirect(Indirect::MovPc(rm)),
        },
        // ADD Rdn, Rm (T2, high registers): 0100 0100 DN Rm Rdn.
        _ if hw & 0xff00 == 0x4400 && rd_high(hw) == 15 => {
            Flow::Indirect(Indirect::AddPc(bits(hw, 6, 3) as u8))
        }
        // A5.2.5 Miscellaneous 16-bit instructions.
        // CBZ / CBNZ: 1011 op 0 i 1 imm5 Rn; target = PC + i:imm5:'0'.
        _ if hw & 0xf500 == 0xb100 => Flow::Branch {
            target: pc(addr).wrapping_add((bits(hw, 9, 9) << 6) | (bits(hw, 7, 3) << 1)),
        },
        // POP (T1): 1011 110 P register_list; P = PC in the list.
        _ if hw & 0xff00 == 0xbd00 => Flow::Return,
        // A5.2.6 Conditional branch and supervisor call: 1101 cond imm8.
        // cond 1110 is UDF (T1), cond 1111 is SVC.
        _ if hw & 0xff00 == 0xde00 => Flow::Trap,
        _ if hw & 0xff00 == 0xdf00 => Flow::Next,
        _ if hw & 0xf000 == 0xd000 => Flow::Branch {
            target: pc(addr).wrapping_add(sign_extend(bits(hw, 7, 0) << 1, 9) as u32),
        },
        // B (T2): 11100 imm11.
        _ if hw & 0xf800 == 0xe000 => Flow::Branch {
            target: pc(addr).wrapping_add(sign_extend(bits(hw, 10, 0) << 1, 12) as u32),
        },
        _ => Flow::Next,
    }
}

/// The destination of the 16-bit high-register forms: D (bit 7) : Rdn (bits 2:0).
fn rd_high(hw: u16) -> u32 {
    (bits(hw, 7, 7) << 3) | bits(hw, 2, 0)
}

/// A 32-bit instruction (A5.3), first halfword `hw1`, second `hw2`.
fn decode32(addr: u32, hw1: u16, hw2: u16) -> Result<Flow, DecodeError> {
    let encoding = (u32::from(hw1) << 16) | u32::from(hw2);
    let rt = bits(hw2, 15, 12);

    // A5.3.4 Branches and miscellaneous control: 11110 op ... / 1 op1 ...
    if hw1 & 0xf800 == 0xf000 && bit(hw2, 15) {
        let op1 = bits(hw2, 14, 12);
        return match op1 & 0b101 {
            // BL (T1): op1 = 1x1.
            0b101 => Ok(Flow::Call {
                target: pc(addr).wrapping_add(branch_offset_t4(hw1, hw2) as u32),
            }),
            // B (T4): op1 = 0x1.
            0b001 => Ok(Flow::Branch {
                target: pc(addr).wrapping_add(branch_offset_t4(hw1, hw2) as u32),
            }),
            // BLX (immediate): op1 = 1x0; ARM state only.
            0b100 => Err(DecodeError::BlxImmediate { encoding }),
            // op1 = 0x0 (bit 13 is J1): B<c> (T3) unless cond (hw1[9:6]) is 111x. With
            // cond 111x: op1 = 000 is MSR, MRS, hints, barriers; op1 = 010 with
            // op = 1111111 is UDF (T2); anything else is undefined.
            _ => {
                let op = bits(hw1, 10, 4);
                if bits(hw1, 9, 7) != 0b111 {
                    Ok(Flow::Branch {
                        target: pc(addr).wrapping_add(branch_offset_t3(hw1, hw2) as u32),
                    })
                } else if op1 == 0b000 {
                    Ok(Flow::Next)
                } else if op1 == 0b010 && op == 0x7f {
                    Ok(Flow::Trap)
                } else {
                    Err(DecodeError::Undefined { encoding })
                }
            }
        };
    }

    // A5.3.5 Load Multiple and Store Multiple: 1110 100 op 0 W L Rn / P M 0 register_list.
    // op = 01 is LDM (IA), op = 10 is LDMDB; L = 1 loads; P = PC in the list.
    if hw1 & 0xfe50 == 0xe810 && matches!(bits(hw1, 8, 7), 0b01 | 0b10) {
        if !bit(hw2, 15) {
            return Ok(Flow::Next);
        }
        let increment_after = bits(hw1, 8, 7) == 0b01;
        let writeback = bit(hw1, 5);
        let rn = bits(hw1, 3, 0);
        return Ok(if increment_after && writeback && rn == 13 {
            // POP (T2) is LDM SP!, {…}.
            Flow::Return
        } else {
            Flow::Indirect(Indirect::LoadMultiplePc)
        });
    }

    // A5.3.6 Table branch: TBB 1110 1000 1101 Rn / 1111 0000 000H Rm.
    if hw1 & 0xfff0 == 0xe8d0 && hw2 & 0xffe0 == 0xf000 {
        return Ok(Flow::TableBranch);
    }

    // A5.3.7 Load word: 1111 100 0 op1 10 1 Rn (LDR immediate T3/T4, LDR register T2,
    // LDR literal T2, LDRT). With Rt = PC it is a jump through memory, except POP (T3),
    // LDR PC, [SP], #4: 1111 1000 0101 1101 / 1111 1011 0000 0100.
    if hw1 & 0xff70 == 0xf850 && rt == 15 {
        return Ok(if hw1 == 0xf85d && hw2 == 0xfb04 {
            Flow::Return
        } else {
            Flow::Indirect(Indirect::LoadPc)
        });
    }

    // Data processing with Rd = hw2[11:8] = PC: A5.3.1 (modified immediate,
    // 11110 i 0 op S Rn / 0 …), A5.3.3 (plain binary immediate, 11110 i 1 … / 0 …),
    // A5.3.11 (shifted register, 1110 101 op S Rn), A5.3.12 (register, 1111 1010 …).
    let rd = bits(hw2, 11, 8);
    if rd == 15 {
        let modified_immediate = hw1 & 0xfa00 == 0xf000 && !bit(hw2, 15);
        let plain_immediate = hw1 & 0xfa00 == 0xf200 && !bit(hw2, 15);
        let shifted_register = hw1 & 0xfe00 == 0xea00;
        let register = hw1 & 0xff00 == 0xfa00 && hw2 & 0xf000 == 0xf000;
        // TST (op 0000), TEQ (0100), CMN (1000), CMP (1101) with S = 1 and Rd = 1111.
        let compare = bit(hw1, 4) && matches!(bits(hw1, 8, 5), 0b0000 | 0b0100 | 0b1000 | 0b1101);
        if ((modified_immediate || shifted_register) && !compare) || plain_immediate || register {
            return Err(DecodeError::PcDestination { encoding });
        }
    }
    Ok(Flow::Next)
}

/// The offset of `B` (T4) and `BL` (T1): S:I1:I2:imm10:imm11:'0' with I1 = NOT(J1 XOR S),
/// I2 = NOT(J2 XOR S), sign-extended from 25 bits.
fn branch_offset_t4(hw1: u16, hw2: u16) -> i32 {
    let s = bits(hw1, 10, 10);
    let i1 = !(bits(hw2, 13, 13) ^ s) & 1;
    let i2 = !(bits(hw2, 11, 11) ^ s) & 1;
    let value =
        (s << 24) | (i1 << 23) | (i2 << 22) | (bits(hw1, 9, 0) << 12) | (bits(hw2, 10, 0) << 1);
    sign_extend(value, 25)
}

/// The offset of `B<c>` (T3): S:J2:J1:imm6:imm11:'0', sign-extended from 21 bits.
fn branch_offset_t3(hw1: u16, hw2: u16) -> i32 {
    let value = (bits(hw1, 10, 10) << 20)
        | (bits(hw2, 11, 11) << 19)
        | (bits(hw2, 13, 13) << 18)
        | (bits(hw1, 5, 0) << 12)
        | (bits(hw2, 10, 0) << 1);
    sign_extend(value, 21)
}

#[cfg(test)]
mod tests;
