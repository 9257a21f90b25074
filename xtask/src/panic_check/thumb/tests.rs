//! The decoder against encodings produced by an assembler for `thumbv7em` (LLVM's, with
//! `-show-encoding`; the branch offsets resolved by assembling to an object and
//! disassembling it) and checked field by field against the ARMv7-M manual. Bytes are
//! written as the assembler prints them (little-endian halfwords, first halfword first).

use super::*;

/// Decodes the little-endian bytes `bytes` (2 or 4) as one instruction at `addr`.
fn at(addr: u32, bytes: &[u8]) -> Result<Instruction, DecodeError> {
    let halfword = |i: usize| u16::from_le_bytes([bytes[i], bytes[i + 1]]);
    let second = (bytes.len() == 4).then(|| halfword(2));
    decode(addr, halfword(0), second)
}

/// The flow of a 16-bit instruction, checking its length on the way.
fn flow16(addr: u32, bytes: [u8; 2]) -> Flow {
    let insn = at(addr, &bytes).unwrap();
    assert_eq!(insn.len, 2, "{bytes:02x?} is 16-bit");
    insn.flow
}

/// The flow of a 32-bit instruction, checking its length on the way.
fn flow32(addr: u32, bytes: [u8; 4]) -> Flow {
    let insn = at(addr, &bytes).unwrap();
    assert_eq!(insn.len, 4, "{bytes:02x?} is 32-bit");
    insn.flow
}

fn branch(target: u32) -> Flow {
    Flow::Branch { target }
}

#[test]
fn tells_16_from_32_bit_encodings_by_the_first_halfword() {
    // bits 15:11 = 11101, 11110, 11111 start a 32-bit instruction; 11100 is B (T2).
    assert!(is_32bit(0xe8bd)); // pop.w
    assert!(is_32bit(0xf000)); // bl / b.w
    assert!(is_32bit(0xf8df)); // ldr.w literal
    assert!(!is_32bit(0xe7fe)); // b .
    assert!(!is_32bit(0xbf00)); // nop
    assert!(!is_32bit(0x4770)); // bx lr
}

#[test]
fn direct_calls_bl_forward_and_backward_over_a_megabyte() {
    // 1e: ff f7 ef ff  bl 0x0 ; 22: 27 f1 e0 fc  bl 0x1279e6 ; 1279e8: d8 f6 0a fb  bl 0x0
    assert_eq!(
        flow32(0x1e, [0xff, 0xf7, 0xef, 0xff]),
        Flow::Call { target: 0x0 }
    );
    assert_eq!(
        flow32(0x22, [0x27, 0xf1, 0xe0, 0xfc]),
        Flow::Call { target: 0x1279e6 }
    );
    assert_eq!(
        flow32(0x1279e8, [0xd8, 0xf6, 0x0a, 0xfb]),
        Flow::Call { target: 0x0 }
    );
    // The same encoding elsewhere: the target moves with the instruction.
    assert_eq!(
        flow32(0x0800_0022, [0x27, 0xf1, 0xe0, 0xfc]),
        Flow::Call {
            target: 0x0800_0000 + 0x1279e6
        }
    );
}

#[test]
fn wide_branches_b_w_and_conditional_b_w() {
    // B (T4): 16: ff f7 f3 bf  b.w 0x0 ; 1a: 27 f1 e4 bc  b.w 0x1279e6 ;
    // 1279ec: d8 f6 08 bb  b.w 0x0
    assert_eq!(flow32(0x16, [0xff, 0xf7, 0xf3, 0xbf]), branch(0x0));
    assert_eq!(flow32(0x1a, [0x27, 0xf1, 0xe4, 0xbc]), branch(0x1279e6));
    assert_eq!(flow32(0x1279ec, [0xd8, 0xf6, 0x08, 0xbb]), branch(0x0));
    // B<c> (T3): e: 3f f4 f7 af  beq.w 0x0 ; 12: c4 f2 ba 82  blt.w 0x458a ;
    // 458c: 7b f4 38 ad  bne.w 0x0
    assert_eq!(flow32(0xe, [0x3f, 0xf4, 0xf7, 0xaf]), branch(0x0));
    assert_eq!(flow32(0x12, [0xc4, 0xf2, 0xba, 0x82]), branch(0x458a));
    assert_eq!(flow32(0x458c, [0x7b, 0xf4, 0x38, 0xad]), branch(0x0));
    // J1 = 1 (hw2 bit 13), from the firmware: 800062e: 3f f4 cd ae  beq.w 0x80003cc ;
    // 8000634: bf f4 02 af  bhs.w 0x800043c
    assert_eq!(
        flow32(0x0800_062e, [0x3f, 0xf4, 0xcd, 0xae]),
        branch(0x0800_03cc)
    );
    assert_eq!(
        flow32(0x0800_0634, [0xbf, 0xf4, 0x02, 0xaf]),
        branch(0x0800_043c)
    );
}

#[test]
fn narrow_branches_b_b_cond_cbz_cbnz() {
    // B (T2): a: f9 e7  b 0x0 ; c: 0c e0  b 0x28
    assert_eq!(flow16(0xa, [0xf9, 0xe7]), branch(0x0));
    assert_eq!(flow16(0xc, [0x0c, 0xe0]), branch(0x28));
    // B<c> (T1): 6: fb d0  beq 0x0 ; 8: 0e dc  bgt 0x28
    assert_eq!(flow16(0x6, [0xfb, 0xd0]), branch(0x0));
    assert_eq!(flow16(0x8, [0x0e, 0xdc]), branch(0x28));
    // CBZ / CBNZ: 2: 80 b1  cbz r0, 0x26 ; 4: 87 b9  cbnz r7, 0x28
    assert_eq!(flow16(0x2, [0x80, 0xb1]), branch(0x26));
    assert_eq!(flow16(0x4, [0x87, 0xb9]), branch(0x28));
}

#[test]
fn plain_returns() {
    assert_eq!(flow16(0, [0x70, 0x47]), Flow::Return); // bx lr
    assert_eq!(flow16(0, [0xf7, 0x46]), Flow::Return); // mov pc, lr
    assert_eq!(flow16(0, [0x90, 0xbd]), Flow::Return); // pop {r4, r7, pc}
    assert_eq!(flow32(0, [0xbd, 0xe8, 0x30, 0x80]), Flow::Return); // pop.w {r4, r5, pc}
    assert_eq!(flow32(0, [0x5d, 0xf8, 0x04, 0xfb]), Flow::Return); // ldr pc, [sp], #4
}

#[test]
fn pops_and_loads_without_the_pc_are_not_transfers() {
    assert_eq!(flow16(0, [0x80, 0xbc]), Flow::Next); // pop {r7}
    assert_eq!(flow32(0, [0x5d, 0xf8, 0x04, 0x1b]), Flow::Next); // ldr r1, [sp], #4
    assert_eq!(flow32(0, [0xdf, 0xf8, 0x08, 0x00]), Flow::Next); // ldr.w r0, [pc, #8]
}

#[test]
fn register_transfers_leave_the_analysis() {
    use Indirect::*;
    assert_eq!(flow16(0, [0x18, 0x47]), Flow::Indirect(BxRegister(3))); // bx r3
    assert_eq!(flow16(0, [0x90, 0x47]), Flow::Indirect(BlxRegister(2))); // blx r2
    assert_eq!(flow16(0, [0x8f, 0x46]), Flow::Indirect(MovPc(1))); // mov pc, r1
    assert_eq!(flow16(0, [0x8f, 0x44]), Flow::Indirect(AddPc(1))); // add pc, r1
}

#[test]
fn loads_into_the_pc_leave_the_analysis_unless_they_pop() {
    let load = Flow::Indirect(Indirect::LoadPc);
    assert_eq!(flow32(0, [0xd0, 0xf8, 0x08, 0xf0]), load); // ldr.w pc, [r0, #8]
    assert_eq!(flow32(0, [0x50, 0xf8, 0x08, 0xfc]), load); // ldr pc, [r0, #-8]
    assert_eq!(flow32(0, [0x52, 0xf8, 0x04, 0xff]), load); // ldr pc, [r2, #4]!
    assert_eq!(flow32(0, [0x51, 0xf8, 0x20, 0xf0]), load); // ldr.w pc, [r1, r0, lsl #2]
    assert_eq!(flow32(0, [0xdf, 0xf8, 0x08, 0xf0]), load); // ldr.w pc, [pc, #8]
    assert_eq!(flow32(0, [0x5f, 0xf8, 0x08, 0xf0]), load); // ldr.w pc, [pc, #-8]
    assert_eq!(flow32(0, [0xdd, 0xf8, 0x04, 0xf0]), load); // ldr.w pc, [sp, #4]
    assert_eq!(flow32(0, [0x5d, 0xf8, 0x08, 0xfb]), load); // ldr pc, [sp], #8

    let multiple = Flow::Indirect(Indirect::LoadMultiplePc);
    assert_eq!(flow32(0, [0x10, 0xe9, 0x10, 0x80]), multiple); // ldmdb r0, {r4, pc}
    assert_eq!(flow32(0, [0xb1, 0xe8, 0x10, 0x80]), multiple); // ldm.w r1!, {r4, pc}
}

#[test]
fn table_branches_stay_inside() {
    assert_eq!(flow32(0, [0xdf, 0xe8, 0x00, 0xf0]), Flow::TableBranch); // tbb [pc, r0]
    assert_eq!(flow32(0, [0xdf, 0xe8, 0x11, 0xf0]), Flow::TableBranch); // tbh [pc, r1, lsl #1]
}

#[test]
fn traps_and_the_control_space_that_falls_through() {
    assert_eq!(flow16(0, [0xfe, 0xde]), Flow::Trap); // udf #254
    assert_eq!(flow32(0, [0xf0, 0xf7, 0x01, 0xa0]), Flow::Trap); // udf.w #1
    assert_eq!(flow16(0, [0x00, 0xdf]), Flow::Next); // svc #0
    assert_eq!(flow16(0, [0x00, 0xbe]), Flow::Next); // bkpt #0
    assert_eq!(flow16(0, [0x72, 0xb6]), Flow::Next); // cpsid i
    assert_eq!(flow32(0, [0x80, 0xf3, 0x11, 0x88]), Flow::Next); // msr basepri, r0
    assert_eq!(flow32(0, [0xef, 0xf3, 0x11, 0x80]), Flow::Next); // mrs r0, basepri
    assert_eq!(flow32(0, [0xbf, 0xf3, 0x4f, 0x8f]), Flow::Next); // dsb sy
    assert_eq!(flow32(0, [0xbf, 0xf3, 0x6f, 0x8f]), Flow::Next); // isb sy
}

#[test]
fn compares_with_the_pc_field_set_are_not_pc_writes() {
    assert_eq!(flow32(0, [0xb0, 0xf1, 0x01, 0x0f]), Flow::Next); // cmp.w r0, #1
    assert_eq!(flow32(0, [0x11, 0xf1, 0x04, 0x0f]), Flow::Next); // cmn.w r1, #4
    assert_eq!(flow32(0, [0x91, 0xf0, 0x03, 0x0f]), Flow::Next); // teq.w r1, #3
    assert_eq!(flow32(0, [0x11, 0xea, 0x02, 0x0f]), Flow::Next); // tst.w r1, r2
    assert_eq!(flow32(0, [0xb1, 0xeb, 0x02, 0x0f]), Flow::Next); // cmp.w r1, r2
    assert_eq!(flow32(0, [0x02, 0xf0, 0x03, 0x01]), Flow::Next); // and r1, r2, #3
    assert_eq!(flow32(0, [0x41, 0xf2, 0x34, 0x21]), Flow::Next); // movw r1, #0x1234
}

#[test]
fn undecodable_encodings_are_reported_not_guessed() {
    // The same data-processing encodings as above with Rd = PC (assemblers refuse them).
    let pc_destination = |hw1: u16, hw2: u16| {
        let encoding = (u32::from(hw1) << 16) | u32::from(hw2);
        assert_eq!(
            decode(0, hw1, Some(hw2)),
            Err(DecodeError::PcDestination { encoding })
        );
    };
    pc_destination(0xf002, 0x0f03); // and pc, r2, #3 (modified immediate, S = 0)
    pc_destination(0xf241, 0x2f34); // movw pc, #0x1234 (plain binary immediate)
    pc_destination(0xeba1, 0x0f02); // sub.w pc, r1, r2 (shifted register, S = 0)
    pc_destination(0xfa01, 0xff02); // lsl.w pc, r1, r2 (register)

    // BLX <label> (op1 = 1x0): ARM state, undefined on ARMv7-M.
    assert_eq!(
        decode(0, 0xf000, Some(0xc000)),
        Err(DecodeError::BlxImmediate {
            encoding: 0xf000_c000
        })
    );
    // cond = 1111 (no branch), op1 = 010, op = 0111100: not UDF, undefined.
    assert_eq!(
        decode(0, 0xf3c0, Some(0xa000)),
        Err(DecodeError::Undefined {
            encoding: 0xf3c0_a000
        })
    );
    // A 32-bit first halfword with nothing after it.
    assert_eq!(
        decode(0, 0xf000, None),
        Err(DecodeError::Truncated { first: 0xf000 })
    );
}

/// The stack effect of the little-endian bytes `bytes` (2 or 4).
fn effect(bytes: &[u8]) -> StackEffect {
    let halfword = |i: usize| u16::from_le_bytes([bytes[i], bytes[i + 1]]);
    let second = (bytes.len() == 4).then(|| halfword(2));
    stack_effect(halfword(0), second)
}

#[test]
fn the_prologue_forms_lower_the_stack_by_what_they_push_or_subtract() {
    // Encodings from `llvm-mc -triple=thumbv7em-none-eabihf -show-encoding`.
    // push {r4, r5, r7, lr}; push {r7}
    assert_eq!(effect(&[0xb0, 0xb5]), StackEffect::Down(16));
    assert_eq!(effect(&[0x80, 0xb4]), StackEffect::Down(4));
    // push.w {r4-r11, lr}
    assert_eq!(effect(&[0x2d, 0xe9, 0xf0, 0x4f]), StackEffect::Down(36));
    // str lr, [sp, #-4]!
    assert_eq!(effect(&[0x4d, 0xf8, 0x04, 0xed]), StackEffect::Down(4));
    // vpush {d8-d15}; vpush {s16-s18}
    assert_eq!(effect(&[0x2d, 0xed, 0x10, 0x8b]), StackEffect::Down(64));
    assert_eq!(effect(&[0x2d, 0xed, 0x03, 0x8a]), StackEffect::Down(12));
    // sub sp, #432; sub.w sp, sp, #1848; sub.w sp, sp, #15360; subw sp, sp, #1001
    assert_eq!(effect(&[0xec, 0xb0]), StackEffect::Down(432));
    assert_eq!(effect(&[0xad, 0xf5, 0xe7, 0x6d]), StackEffect::Down(1848));
    assert_eq!(effect(&[0xad, 0xf5, 0x70, 0x5d]), StackEffect::Down(15360));
    assert_eq!(effect(&[0xad, 0xf2, 0xe9, 0x3d]), StackEffect::Down(1001));
    // sub.w sp, sp, r3: unknown size.
    assert_eq!(effect(&[0xad, 0xeb, 0x03, 0x0d]), StackEffect::Dynamic);
}

#[test]
fn other_uses_of_sp_leave_the_frame_alone() {
    // sub.w r0, sp, #16 (SP is the source, not the destination); add sp, #432;
    // pop {r4, r5, r7, pc}; str r0, [sp, #12]; sub.w r0, r0, #16
    assert_eq!(effect(&[0xad, 0xf1, 0x10, 0x00]), StackEffect::None);
    assert_eq!(effect(&[0x6c, 0xb0]), StackEffect::None);
    assert_eq!(effect(&[0xb0, 0xbd]), StackEffect::None);
    assert_eq!(effect(&[0x03, 0x90]), StackEffect::None);
    assert_eq!(effect(&[0xa0, 0xf1, 0x10, 0x00]), StackEffect::None);
}

#[test]
fn modified_immediates_expand_as_the_manual_says() {
    // A5.3.2: the four byte patterns, and a rotation.
    assert_eq!(thumb_expand_imm(0x0ab), 0xab);
    assert_eq!(thumb_expand_imm(0x1ab), 0x00ab_00ab);
    assert_eq!(thumb_expand_imm(0x2ab), 0xab00_ab00);
    assert_eq!(thumb_expand_imm(0x3ab), 0xabab_abab);
    // 1848 = 0xe7 << 3: the rotation 29 of 0x80 | 0x67.
    assert_eq!(thumb_expand_imm(0xee7), 1848);
}
