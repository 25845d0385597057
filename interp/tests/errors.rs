//! The bad-input corpus: malformed programs the parser accepts but the interpreter must refuse,
//! each with the error's line, column and message. Parser-level errors are `lang`'s corpus.

use cnc402_config::MachineConfig;
use cnc402_interp::run_program;
use cnc402_lang::SourceFile;

/// (program, line, column, the message starts with)
const CASES: &[(&str, u32, u32, &str)] = &[
    // Feed (seed 000: "zero feed in a motion block").
    ("G1 X10\n", 1, 1, "zero feed in a motion block"),
    ("G1 X10 F0\n", 1, 8, "zero feed in a motion block"),
    (
        "G0 X1\nG3 X0 Y1 I-0.5 J0.5\n",
        2,
        1,
        "zero feed in a motion block",
    ),
    (
        "G0 Z10\nG81 X0 R2 Z-2\n",
        2,
        1,
        "zero feed in a motion block",
    ),
    (
        "M3 S500\nG0 Z10\nG84 X0 R2 Z-2\n",
        3,
        1,
        "zero feed in a motion block",
    ),
    ("G1 X1 F-5\n", 1, 7, "F must not be negative"),
    (
        "G95 G1 X1 F0.1\n",
        1,
        5,
        "feed per revolution (G95) with S0",
    ),
    // Arcs.
    (
        "G2 X10 Y1 I5 F100\n",
        1,
        4,
        "arc end point is not on the circle: start radius 5, end radius 5.09902",
    ),
    (
        "G18 G2 X10 Z1 I5 F100\n",
        1,
        12,
        "arc end point is not on the circle",
    ),
    (
        "G2 X20 R5 F100\n",
        1,
        8,
        "R arc with impossible radius: R 5 but the end point is 20 away",
    ),
    (
        "G3 X-20 Y0 R-9.9 F100\n",
        1,
        12,
        "R arc with impossible radius",
    ),
    (
        "G2 X0 Y0 R5 F100\n",
        1,
        10,
        "R arc ending at its start point",
    ),
    ("G2 X10 F100\n", 1, 1, "G2 needs the centre (I, J) or R"),
    ("G19 G3 Y10 F100\n", 1, 5, "G3 needs the centre (J, K) or R"),
    ("G2 X0 Y0 I0 J0 F100\n", 1, 1, "arc radius is zero"),
    ("G2 X10 R0 F100\n", 1, 8, "arc radius is zero"),
    (
        "G0 X290 Y0\nG2 X290 Y0 I8 F100\n",
        2,
        4,
        "X 306 is outside the soft limits -300..300",
    ),
    // Canned cycle data.
    (
        "G0 Z10\nG81 X1 Y1 Z-5 F100\n",
        2,
        1,
        "canned cycle G81 needs R (the R level)",
    ),
    (
        "G0 Z10\nG81 X1 Y1 R2 F100\n",
        2,
        1,
        "canned cycle G81 needs Z (the bottom of the hole)",
    ),
    (
        "G0 Y10\nG18 G81 X1 Z1 R2 F100\n",
        2,
        5,
        "canned cycle G81 needs Y (the bottom of the hole)",
    ),
    (
        "G0 Z10\nG83 X1 R2 Z-5 F100\n",
        2,
        1,
        "G83 needs Q (the peck depth)",
    ),
    (
        "G0 Z10\nG73 X1 R2 Z-5 Q0 F100\n",
        2,
        15,
        "Q (peck depth) must be > 0, not 0",
    ),
    (
        "G0 Z10\nG76 X1 R2 Z-5 Q-1 F100\n",
        2,
        15,
        "Q (shift) must be >= 0, not -1",
    ),
    (
        "G0 Z10\nG81 X0 R2 Z2 F100\n",
        2,
        11,
        "G81: the bottom equals the R level",
    ),
    (
        "G0 Z10\nG81 X0 R2 Z-2 K2 L2 F100\n",
        2,
        18,
        "K and L both give the repeat count",
    ),
    (
        "G0 Z10\nG81 X0 R2 Z-2 K-1 F100\n",
        2,
        15,
        "the repeat count must be a whole number >= 0, not -1",
    ),
    (
        "G0 Z10\nG81 X0 R2 Z-2 L1.5 F100\n",
        2,
        15,
        "the repeat count must be a whole number >= 0, not 1.5",
    ),
    (
        "G0 Z10\nG82 X0 R2 Z-2 P1.5 F100\n",
        2,
        15,
        "P1.5 is not a dwell: P is whole milliseconds",
    ),
    (
        "G0 Z10\nG81 X0 R2 Z-2 C10 F100\n",
        2,
        15,
        "axis C cannot move in a canned cycle (G81)",
    ),
    (
        "G0 Z10\nG81 X0 R2 Z-2 F100\nG18\n",
        3,
        1,
        "G18 while a canned cycle is active",
    ),
    (
        "G0 Z10\nG81 X0 R2 Z-2 F100\nG53 X1\n",
        3,
        1,
        "G53 cannot be used in a canned cycle",
    ),
    (
        "G0 Z10\nG87 X0 R-20 Z-5 Q1 F100\n",
        2,
        1,
        "G87 (back boring) needs the spindle turning",
    ),
    // Rigid tapping.
    (
        "M3\nG0 Z10\nG84 X1 R2 Z-5 F100\n",
        3,
        1,
        "tapping with S = 0 (G84)",
    ),
    (
        "M4 S500\nG0 Z10\nG84 X1 R2 Z-5 F500\n",
        3,
        1,
        "G84 (right-hand tap) with the spindle turning the wrong way (M4 is active)",
    ),
    (
        "M3 S500\nG0 Z10\nG74 X1 R2 Z-5 F500\n",
        3,
        1,
        "G74 (left-hand tap) with the spindle turning the wrong way (M3 is active)",
    ),
    (
        "S500\nG0 Z10\nG84 X1 R2 Z-5 F500\n",
        3,
        1,
        "G84 (right-hand tap) needs the spindle direction M3 or rigid mode M29",
    ),
    (
        "M3 S500\nM5\nG0 Z10\nG74 X1 R2 Z-5 F500\n",
        4,
        1,
        "G74 (left-hand tap) needs the spindle direction M4 or rigid mode M29",
    ),
    // Codes and groups.
    ("G7 X1\n", 1, 1, "unknown G code G7"),
    ("G0 X1\nG100\n", 2, 1, "unknown G code G100"),
    ("M18\n", 1, 1, "unknown M code M18"),
    ("G1.5 X1\n", 1, 1, "unknown G code G1.5"),
    (
        "G1.25 X1\n",
        1,
        1,
        "G1.25 is not a G code: G codes here are whole numbers",
    ),
    ("M3.5\n", 1, 1, "M3.5 is not a M code"),
    (
        "G0 G1 X1 F10\n",
        1,
        4,
        "G0 and G1 are both in modal group 01 (motion)",
    ),
    (
        "G90 G91\n",
        1,
        5,
        "G90 and G91 are both in modal group 03 (G90/G91)",
    ),
    (
        "G17 G18\n",
        1,
        5,
        "G17 and G18 are both in modal group 02 (plane)",
    ),
    (
        "G20 G21\n",
        1,
        5,
        "G20 and G21 are both in modal group 06 (units)",
    ),
    (
        "G54 G55\n",
        1,
        5,
        "G54 and G55 are both in modal group 14 (work offset)",
    ),
    (
        "G98 G99\n",
        1,
        5,
        "G98 and G99 are both in modal group 10 (cycle return)",
    ),
    (
        "G94 G95\n",
        1,
        5,
        "G94 and G95 are both in modal group 05 (feed mode)",
    ),
    (
        "G81 G83 X1 Z-1 R1 Q1 F1\n",
        1,
        5,
        "G81 and G83 are both in modal group 09 (canned cycle)",
    ),
    (
        "G4 G53 X1\n",
        1,
        4,
        "G4 and G53 are both in modal group 00 (one-shot)",
    ),
    ("G1 G81 X1 Z-1 R1 F1\n", 1, 4, "G1 and G81 in one block"),
    (
        "G1 G4 X1\n",
        1,
        1,
        "G1 cannot share a block with G4 (dwell)",
    ),
    ("M3 M4 S100\n", 1, 4, "M3 and M4 in one block"),
    ("M2 M30\n", 1, 4, "M2 and M30 in one block"),
    ("M98 P100\n", 1, 1, "program O0100 not found"),
    ("G65 P9999 A1\n", 1, 1, "program O9999 not found"),
    // Cutter radius compensation (G40/G41/G42, D).
    ("G41 G1 X10 F100\n", 1, 1, "G41 without D"),
    (
        "G42 D401 G1 X10 F100\n",
        1,
        5,
        "D401 is not in the tool offset table",
    ),
    (
        "G0 X-10\nG41 D1 G2 X10 Y0 I10 F100\n",
        2,
        8,
        "cutter compensation started on an arc",
    ),
    (
        "G81 X0 Y0 Z-1 R1 F100\nG41 D1\n",
        2,
        1,
        "G41 while a canned cycle is active",
    ),
    ("G41 D1\nG18\n", 2, 1, "G18 while cutter compensation is on"),
    ("G41 D1\nG40 G2 X10 I5 F100\n", 2, 1, "G40 on an arc"),
    ("G41 D1\nG42\n", 2, 1, "G42 while G41 is on"),
    (
        "G41 D1\nG28 X0\n",
        2,
        1,
        "G28 while cutter compensation is on",
    ),
    // Tool length compensation (G43/G44/G49, H).
    (
        "G43 H1.5 Z10\n",
        1,
        5,
        "H1.5 is not a tool offset number: the table has 1..400 (H0: no offset)",
    ),
    (
        "G43 H401 Z10\n",
        1,
        5,
        "H401 is not a tool offset number: the table has 1..400",
    ),
    ("G43 H-1 Z10\n", 1, 5, "H-1 is not a tool offset number"),
    (
        "G0 Z10\nG81 X0 R2 Z-2 F100\nG43 H1\n",
        3,
        1,
        "G43 (or a new H) while a canned cycle is active",
    ),
    (
        "G43 H1 G81 X0 R2 Z-2 F100\n",
        1,
        1,
        "G43 (or a new H) while a canned cycle is active",
    ),
    (
        "G2 X1 Y1 R1 F100\nG43 H1\n",
        2,
        1,
        "G43 (or a new H) in G2/G3 mode: the offset is applied by a straight move",
    ),
    (
        "G4 P100 G43 H1\n",
        1,
        9,
        "G43 (or a new H) cannot share a block with G4",
    ),
    (
        "G43 H1 G28 Z0\n",
        1,
        1,
        "G43 (or a new H) cannot share a block with G28",
    ),
    (
        "G43 H1 G44 Z10\n",
        1,
        8,
        "G43 and G44 are both in modal group 08 (tool length compensation)",
    ),
    ("G1\nG43 H1\n", 2, 1, "zero feed in a motion block"),
    (
        "G43 H1 Z50\nG44 H2 Z50\n",
        2,
        8,
        "Z 215.52 is outside the soft limits -250..50",
    ),
    // G10: programmable data input.
    ("G10 P1 X0\n", 1, 1, "G10 needs L (what to set)"),
    (
        "G10 L2 X0\n",
        1,
        1,
        "G10 L2 needs P (the work offset: P1-P6 for G54-G59)",
    ),
    (
        "G10 L2 P0 X0\n",
        1,
        8,
        "G10 L2 P0 sets the external work offset, which cnc402 does not have",
    ),
    ("G10 L2 P7 X0\n", 1, 8, "G10 L2 P7: P1-P6 select G54-G59"),
    (
        "G10 L10 R5\n",
        1,
        1,
        "G10 L10 needs P (the tool offset number 1..400)",
    ),
    ("G10 L12 P1\n", 1, 1, "G10 L12 needs R (the offset value)"),
    (
        "G10 L10 P0 R1\n",
        1,
        9,
        "G10 L10 P0 is not a tool offset number: the table has 1..400",
    ),
    (
        "G10 L11 P401 R1\n",
        1,
        9,
        "G10 L11 P401 is not a tool offset number",
    ),
    (
        "G10 L11 P1 R1 X5\n",
        1,
        15,
        "address X is not used in this block",
    ),
    (
        "G10 L20 P1 X0\n",
        1,
        5,
        "G10 L20 (Fanuc: the additional work offsets of G54.1 P1-P48) is not supported",
    ),
    ("G10 L3 P1 R1\n", 1, 5, "G10 L3 is not supported"),
    (
        "G10 L2 P1 G81 X0\n",
        1,
        11,
        "G81 cannot share a block with G10",
    ),
    (
        "G10 L2 P1 Z-300\nG0 Z0\n",
        2,
        4,
        "Z -300 is outside the soft limits -250..50",
    ),
    // G28/G29/G30: reference position return.
    (
        "G28 X400\n",
        1,
        5,
        "X 400 is outside the soft limits -300..300 (machine coordinates)",
    ),
    (
        "G90 G28 Z60\n",
        1,
        9,
        "Z 60 is outside the soft limits -250..50",
    ),
    (
        "G43 H1 Z0\nG90 G28 Z250\n",
        2,
        9,
        "Z 70 is outside the soft limits -250..50",
    ),
    (
        "G91 G28 Z0 P2\n",
        1,
        12,
        "address P is not used in this block",
    ),
    (
        "G28\n",
        1,
        1,
        "G28 needs the axes to return (their intermediate point)",
    ),
    (
        "G30 P5 Z0\n",
        1,
        5,
        "G30 P5: P2, P3 or P4 selects the reference position",
    ),
    (
        "G30 P3 Z0\n",
        1,
        8,
        "G30 P3: axis Z has no third_reference in the machine config",
    ),
    (
        "G30 X0\n",
        1,
        5,
        "G30 P2: axis X has no second_reference in the machine config",
    ),
    (
        "G29 Z0\n",
        1,
        5,
        "G29: no intermediate point for axis Z (no G28 or G30 named it)",
    ),
    (
        "G0 Z10\nG81 X0 R2 Z-2 F100\nG28 Z0\n",
        3,
        1,
        "G28 while a canned cycle is active",
    ),
    (
        "M3 S100\nG28 C90\n",
        2,
        5,
        "G28 C: the spindle turns in speed mode (M3/M4); C is positioned only at rest",
    ),
    // Regression (review item 2): `G28 C0` while the spindle turned made a zero-length rapid.
    (
        "G0 X0 Y0 Z0\nS500 M3\nG28 C0\n",
        3,
        5,
        "G28 C: the spindle turns in speed mode (M3/M4); C is positioned only at rest",
    ),
    (
        "G28 C0\nM4 S100\nG91 G29 C0\n",
        3,
        9,
        "G29 C: the spindle turns in speed mode (M3/M4); C is positioned only at rest",
    ),
    // G92.
    (
        "G92\n",
        1,
        1,
        "G92 needs an axis word (the current position's new coordinate)",
    ),
    ("G92 X0 G81\n", 1, 8, "G81 cannot share a block with G92"),
    (
        "G92 X-290\nG0 X30\n",
        2,
        4,
        "X 320 is outside the soft limits -300..300",
    ),
    // Group 15, coolant, unsupported neighbours.
    (
        "G0 X1 G61 G64\n",
        1,
        11,
        "G61 and G64 are both in modal group 15",
    ),
    (
        "G62\n",
        1,
        1,
        "G62 (automatic corner override) is not supported yet",
    ),
    (
        "G27 X0\n",
        1,
        1,
        "G27 (reference position return check) is not supported yet",
    ),
    (
        "M8 M9\n",
        1,
        4,
        "M8 and M9 in one block: they contradict each other",
    ),
    (
        "M9 M7\n",
        1,
        4,
        "M9 and M7 in one block: they contradict each other",
    ),
    ("M7 M7\n", 1, 4, "M7 and M7 in one block"),
    // Tool offset variables.
    (
        "#10401=1\n",
        1,
        1,
        "#10401 is not a tool offset of this control (1..400)",
    ),
    (
        "#1=#13401\n",
        1,
        4,
        "#13401 is not a tool offset of this control",
    ),
    // Words the block cannot use.
    ("G0 X1 Q5\n", 1, 7, "address Q is not used in this block"),
    (
        "G1 X1 I5 F100\n",
        1,
        7,
        "address I is not used in this block",
    ),
    ("G0 X1 R5\n", 1, 7, "address R is not used in this block"),
    // P on a spindle block selects the spindle (Fanuc multi-spindle): 5 is none.
    ("M3 S100 P5\n", 1, 9, "P5 is not a spindle"),
    ("M3 S100 P2\n", 1, 9, "spindle 2 is not configured"),
    ("M5 P1.5\n", 1, 4, "P1.5 is not a spindle"),
    ("G0 X1 P2\n", 1, 7, "address P is not used in this block"),
    ("G4 X1 Y1\n", 1, 7, "address Y is not used in this block"),
    ("G0 A10\n", 1, 4, "address A is not used in this block"),
    (
        "G17 G2 X1 Y1 K1 I1 F10\n",
        1,
        14,
        "K1 in a G17 (XY) arc: the centre offset along the plane's normal must be 0",
    ),
    (
        "G0 X1 X2\n",
        1,
        7,
        "address X given twice in one block (first at 1:4)",
    ),
    // Values of the wrong kind.
    (
        "T1.5 M6\n",
        1,
        1,
        "T (tool number) must be a whole number >= 0, not 1.5",
    ),
    (
        "T-2\n",
        1,
        1,
        "T (tool number) must be a whole number >= 0, not -2",
    ),
    (
        "G4 P1.5\n",
        1,
        4,
        "P1.5 is not a dwell: P is whole milliseconds",
    ),
    ("G4 X-1\n", 1, 4, "dwell time must not be negative"),
    (
        "G4 X1 P100\n",
        1,
        7,
        "G4 takes X (seconds) or P (milliseconds), not both",
    ),
    ("S-5\n", 1, 1, "S must not be negative"),
    (
        "S7000 M3\n",
        1,
        1,
        "S7000 is above the spindle's max_rpm 6000",
    ),
    ("G0 X[1/0]\n", 1, 5, "division by zero"),
    ("G0 X[SQRT[-1]]\n", 1, 5, "SQRT of a negative number (-1)"),
    // Regression (review item 3): G49 in a G53/G28/G30 block without Z left the vector in the
    // position (Z stayed at -170 until its next word) while #4008 read 49.
    (
        "G0 X0 Y0 Z0\nG43 H1 Z10\nG49 G53 X0\n",
        3,
        1,
        "G49 with G53 cancels the tool length offset on the Z move, and this block does not move Z",
    ),
    (
        "G43 H1 Z10\nG91 G28 X0 G49\n",
        2,
        12,
        "G49 with G28 cancels the tool length offset on the Z move",
    ),
    (
        "G43 H1 Z10\nG30 Y0 G49\n",
        2,
        8,
        "G49 with G30 cancels the tool length offset on the Z move",
    ),
    // G53.
    ("G53 G2 X1 I1 F10\n", 1, 1, "G53 works only with G0 or G1"),
    (
        "G91 G53 G0 X1\n",
        1,
        5,
        "G53 in G91 (Fanuc ignores it; cnc402 refuses)",
    ),
    // Soft limits: checked before any segment of the block exists.
    (
        "G0 X400\n",
        1,
        4,
        "X 400 is outside the soft limits -300..300 (machine coordinates)",
    ),
    (
        "G20 G0 X12\n",
        1,
        8,
        "X 304.8 is outside the soft limits -300..300",
    ),
    (
        "G55 G0 X250\n",
        1,
        8,
        "X 350 is outside the soft limits -300..300",
    ),
    ("G0 Z60\n", 1, 4, "Z 60 is outside the soft limits -250..50"),
    (
        "G53 G0 Y-201\n",
        1,
        8,
        "Y -201 is outside the soft limits -200..200",
    ),
    (
        "G0 Z10\nG81 X0 Y0 Z-300 R2 F100\n",
        2,
        11,
        "Z -300 is outside the soft limits -250..50",
    ),
    (
        "G0 Z10\nG81 X0 Y0 Z-5 R60 F100\n",
        2,
        15,
        "Z 60 is outside the soft limits -250..50",
    ),
    (
        "G0 X250 Z10\nG91 G81 X20 Z-5 R-5 K4 F100\n",
        2,
        9,
        "X 310 is outside the soft limits -300..300",
    ),
    (
        "M3 S100\nG0 X295 Z10\nG76 X299 R2 Z-5 Q2 F100\n",
        3,
        17,
        "X 301 is outside the soft limits -300..300",
    ),
    (
        "G91 G1 X200 F100\nX200\n",
        2,
        1,
        "X 400 is outside the soft limits -300..300",
    ),
    ("G0 X1 L2\n", 1, 7, "address L is not used in this block"),
    (
        "G1 X1 F100 D1.5\n",
        1,
        12,
        "D (tool radius offset number) must be a whole number >= 0, not 1.5",
    ),
    ("G0 X1 E5\n", 1, 7, "address E is not used in this block"),
    (
        "G0 X1 Y1 Z1 C1 B1\n",
        1,
        16,
        "address B is not used in this block",
    ),
    (
        "G18 G2 X1 Z1 J1 F100\n",
        1,
        14,
        "J1 in a G18 (ZX) arc: the centre offset along the plane's normal must be 0",
    ),
    (
        "M4 S500\nG0 Z10\nG74 X0 R2 Z-5 S0 F100\n",
        3,
        15,
        "tapping with S = 0 (G74)",
    ),
    (
        "G0 Z10\nG82 X0 R2 Z-5 P-100 F100\n",
        2,
        15,
        "P-100 is not a dwell: P is whole milliseconds",
    ),
    (
        "G0 Z10\nG81 X0 R2 Z-5 K10000 F100\n",
        2,
        15,
        "repeat count above 9999",
    ),
    ("G1 X10 F[0]\n", 1, 8, "zero feed in a motion block"),
    (
        "G0 Z10\nG73 X1 R2 Z-5 F100\n",
        2,
        1,
        "G73 needs Q (the peck depth)",
    ),
    ("M6 M6\n", 1, 4, "M6 and M6 in one block"),
    (
        "G0 Z10\nG81 X0 R2 Z-5 F100\nG80 G81 X1\n",
        3,
        5,
        "G80 and G81 are both in modal group 09 (canned cycle)",
    ),
    // Custom Macro B.
    ("#0=5\n", 1, 1, "#0 is always vacant and cannot be written"),
    ("G0 X1\nGOTO 10\n", 2, 6, "sequence number N10 not found"),
    (
        "WHILE [1 LT 2] DO 1\nEND 2\n",
        1,
        1,
        "WHILE … DO 1 has no END 1",
    ),
    (
        "IF [1 EQ 1] GOTO 5\n",
        1,
        18,
        "sequence number N5 not found",
    ),
    ("G0 X#34\n", 1, 5, "#34 is not a variable of this control"),
    (
        "G0 X1 Z-#[#1+2000]\n",
        1,
        9,
        "#2000 is not a variable of this control",
    ),
    // Later issues' constructs: refused where they are, not skipped.
    // The C-like language runs now (interp/src/hll): its run-time errors are located too.
    ("double d = 1 / 0;\n", 1, 12, "division by zero"),
    // The spindle axis.
    (
        "M3 S100\nG0 C90\n",
        2,
        4,
        "C positioning while the spindle turns",
    ),
];

#[test]
fn every_bad_program_is_refused_where_it_is_wrong() {
    let cfg = MachineConfig::default_machine();
    assert!(CASES.len() >= 50, "{}", CASES.len());
    let mut bad = Vec::new();
    for (i, &(text, line, col, msg)) in CASES.iter().enumerate() {
        let src = SourceFile::new("bad.nc", text);
        match run_program(&cfg, &src) {
            Ok(segs) => bad.push(format!("#{i} {text:?}: no error, {} segments", segs.len())),
            Err(e) => {
                if (e.line, e.col) != (line, col) || !e.message.starts_with(msg) {
                    bad.push(format!(
                        "#{i} {text:?}\n   want {line}:{col} {msg}\n   got  {}:{} {}",
                        e.line, e.col, e.message
                    ));
                }
                assert_eq!(&*e.file, "bad.nc");
            }
        }
    }
    assert!(
        bad.is_empty(),
        "{} of {} cases wrong:\n{}",
        bad.len(),
        CASES.len(),
        bad.join("\n")
    );
}

/// A block that fails produces none of its segments: the cycle's first holes are inside the
/// limits, the third is not, and nothing of the block comes out.
#[test]
fn a_failing_cycle_emits_nothing_of_its_block() {
    let cfg = MachineConfig::default_machine();
    let src = SourceFile::new("p.nc", "G0 X250 Z10\nG91 G81 X20 Z-5 R-5 K4 F100\n");
    let program = cnc402_lang::parse(&src).unwrap();
    let mut it = cnc402_interp::Interpreter::new(&cfg);
    it.load(src, program);
    let first = it.next_segment().unwrap().unwrap();
    assert_eq!(first.source.line, 1);
    let e = it.next_segment().unwrap_err();
    assert_eq!(e.line, 2);
    assert_eq!(
        it.next_segment().unwrap(),
        None,
        "the run ends at the error"
    );
}

/// Lines after M30 are not run (so their errors are never seen), and `/` lines are skipped with
/// block delete on.
#[test]
fn nothing_runs_after_the_end_and_deleted_blocks_are_skipped() {
    let cfg = MachineConfig::default_machine();
    let segs = run_program(&cfg, &SourceFile::new("p.nc", "/G7\nG0 X1\nM30\nG7\n")).unwrap();
    assert_eq!(segs.len(), 2);
    let opts = cnc402_interp::Options {
        block_delete: false,
        ..Default::default()
    };
    let e =
        cnc402_interp::run_program_with(&cfg, opts, &SourceFile::new("p.nc", "/G7\n")).unwrap_err();
    assert_eq!((e.line, e.col), (1, 2));
}
