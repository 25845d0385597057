//! The NC interpreter: executes a parsed program ([`cnc402_lang::ast::Program`]) against a
//! modal state and produces [canonical operations](canon::CanonOp) one at a time
//! ([`Interpreter::next_canon`]: work coordinates, each with its source (file, line, N) and
//! the state it ran under; a canned cycle stays one operation), or the motion
//! [`Segment`](cnc402_motion::segment::Segment)s they [lower](lower::lower) to
//! ([`Interpreter::next_segment`]: machine coordinates, cycles expanded). No I/O, no clock.
//!
//! Behaviour follows Fanuc (M series); where LinuxCNC differs the tests say so. Decisions worth
//! knowing:
//! - Positions in canonical operations are work coordinates (mm; the `CanonState` carries the
//!   work → machine offset of every axis: work zero, G92, tool length on the tool axis).
//! - Positions in segments are absolute machine coordinates of every configured axis (work
//!   offset G54–G59 applied, inches converted to mm). The program starts at
//!   [`Options::start`] (machine 0 by default). Numbers without a decimal point are read as
//!   whole units (`X10` = 10 mm: "calculator-type input"), not as Fanuc's least increments.
//! - G4: `X` seconds or `P` whole milliseconds. Cycle `P` dwells are milliseconds too.
//! - Canned cycles: Fanuc sequence, data (R, Z, Q, P) modal until G80 or a group 01 code; a
//!   block drills when it has a position, drilling-axis or R word; K and L both repeat; in G91
//!   R is measured from the initial level and Z from R. G73 retracts by `peck_retract`, G83
//!   re-enters to `peck_clearance` above the last depth (config `[interp]`).
//! - G74/G84 are rigid taps (`Tap` segments, as is a G1 of a linear axis with the spindle
//!   axis): feed moves of the drilling axis with the spindle axis C,
//!   C = C0 + depth·360/pitch (negative for G74), pitch = F/S (G94) or F (G95). They need M3
//!   (G84) or M4 (G74) or M29; a turning spindle is stopped before and restarted after the
//!   block. With Q, peck tapping: in by Q, out by `tap_peck_retract` (Fanuc No. 5213; default
//!   `peck_retract`), every move coupled.
//! - G76/G87 (and M19) orientation = spindle stop + `SpindleOrient` to the physical angle
//!   `interp.spindle_orient_angle` (motion resolves it against the spindle offset; program C
//!   does not change); the shift is +Q along the plane's first axis (G17 +X, G18 +Z, G19
//!   +Y). G87 always returns to the initial level (Fanuc: G99 is not used with G87) and
//!   needs R below Z (it starts below the part; otherwise an error at the Z word). G86
//!   stops the spindle at the bottom and restarts it after the rapid out; G88 dwells, stops
//!   the spindle, emits a program stop (the operator's manual retract in Fanuc), then rapids
//!   out and restarts the spindle.
//! - Offsets ([`offsets`]): machine = programmed + work offset (G54–G59, G10 L2) + G92 shift
//!   plus the tool length offset (G43/G44 Hn, Fanuc type A: always Z; the block that sets it
//!   moves by the change). G28/G30 go through the intermediate point to the config's
//!   reference positions and cancel the offset vector on Z there (G43 stays modal; Z's next
//!   move restores it), as Fanuc; the spindle axis goes to its reference by a `SpindleOrient`
//!   to the physical angle (refused while it turns), after which C reads the reference (as
//!   on Fanuc: later absolute C words count from it), and a move to where the tool already is
//!   makes no segment. Tables changed by a program (G10, `#5221…`, `#1xxxx`) and
//!   the G92 shift last for the run: `load` starts from the config again.
//! - M7/M8/M9 make a `Coolant` segment before the block's motion; M2/M30 turn coolant off.
//!   G61/G63/G64 set how path segments end (`Segment::ends`; `G64 P` the tolerance, else
//!   `interp.path_tolerance`); taps and every move of a canned cycle end in an exact stop.
//!   Motion still stops at every segment (blending comes with the lookahead planner).
//! - M1 stops only with [`Options::optional_stop`]; `/` blocks are skipped with
//!   [`Options::block_delete`]; M2/M30 end the run; a `%` after the first block ends it.
//!
//! Custom Macro B ([`macros`]):
//! - A file holds one or more programs (`O` lines). `M98 P`/`G65 P`/`G66 P` look in the
//!   running file, then in the injected [`ProgramLibrary`] (none by default: not found;
//!   [`host_fs::FsLibrary`] looks next to the main program, `O9001.nc`, `O9001.CNC`, …
//!   case-insensitive, then in the config's `program_dir`). `M98 P30009001` =
//!   3 × O9001 (Fanuc 0 prefix); `L` overrides. M98 shares the caller's locals; G65/G66 get a
//!   new set (argument specification I, `M` is `#13`; and II: repeated I J K sets → `#4–#33`,
//!   a later word wins where the two meet). Nesting: 15 programs, 4 macro levels.
//!   A `G65` block with H and only P/Q/R besides is an old macro instruction (`G65 H02 P#1 Q#2
//!   R3`); with any other address H is the argument `#11`.
//! - `M99` returns (repeats first); `M99 P n` returns to `N n` of the caller, or jumps in a
//!   main program; `M99` alone in a main program restarts it endlessly as on Fanuc with
//!   [`MainM99::Repeat`] (a machine run), or ends it after one pass with [`MainM99::End`] (the
//!   default: a dump, a dry run; [`Interpreter::main_m99_line`] says where).
//!   The end of a sub-program's text returns like M99.
//! - Vacant: `#0`, unset variables; a word whose value is vacant is left out; arithmetic reads
//!   0; `EQ`/`NE` compare vacant as a value of its own. Common `#100–#199` clear at `load`;
//!   `#500–#999` persist through an injected [`PersistentVars`] (default: memory only;
//!   [`host_fs::attach_variables_file`] reads `interp.variables_file` and, if writable, writes
//!   it durably before the next block runs; a damaged file is the first `next_segment` error).
//! - No I/O by default: the file system comes in only through [`host_fs`], which the binaries
//!   construct and inject.
//! - System variables: `#3000=n(text)` alarm `3000+n`; `G65 H99 Pn` alarm `500+n`; `#3006`
//!   message + program stop; `#4001–#4022` group codes (G40/G50/G69/G15 read as the cancel
//!   codes cnc402 accepts as no-ops; groups it lacks read vacant); `#4109 F #4111 H #4113 M
//!   #4114 N #4115 O #4119 S #4120 T` (`B D E` vacant); `#5001+i` programmed block end (work
//!   coordinates without the tool length offset, no sync); `#5021+i` machine and `#5041+i`
//!   work position (with the offset): sync points through [`MotionSync`] (default
//!   [`ExactStop`]); `#5081+i` the tool length offset vector; `#5221+20k+i` work offsets
//!   G54–G59 and the tool offsets `#10001–#13400` (`#2001–#2400`), read/write (for the run
//!   only, the config file is not changed).
//! - `interp.block_limit` blocks in a row without motion end the program as a runaway, naming
//!   the lines the loop ran over. Motion is [`canon::makes_motion`]: a move that changes a
//!   position, an arc, a canned cycle, a dwell > 0 (messages and zero moves are not).

// NcError (lang's) is large; an error ends the run, so its size costs nothing that matters.
#![allow(clippy::result_large_err)]

// The layers, lowest first; a layer uses only the ones before it (`tests/layers.rs` checks):
// host traits, expressions, variables, canonical operations, lowering, block execution,
// output (segment and canonical dumps), the C-like language, program flow, the file-system
// host. docs/architecture.md draws the whole chain.
mod block;
pub mod canon;
pub mod comp;
pub mod dump;
mod expr;
mod flow;
pub mod hll;
pub mod host;
pub mod lower;
mod vars;

// The public paths of the modules as they were before the layers.
macro_rules! facade {
    ($($(#[$m:meta])* $name:ident => $path:path;)*) => {$(
        $(#[$m])*
        pub mod $name {
            #[allow(unused_imports)]
            pub use $path::*;
        }
    )*};
}
facade! {
    /// Circular arcs: centre, radius, extremes.
    arc => crate::block::arc;
    /// Canned cycles (part of block execution).
    cycles => crate::block::cycles;
    /// Expression evaluation with Fanuc Custom Macro B semantics.
    eval => crate::expr;
    /// Custom Macro B program flow: program units, calls, control flow.
    macros => crate::flow::units;
    /// The non-volatile variables `#500–#999` and their file.
    nvfile => crate::vars::nv;
    /// Offsets and reference positions in a block; tool offset variables.
    offsets => crate::block::offsets;
    /// The modal state.
    state => crate::block::state;
    /// A block's words sorted for execution.
    words => crate::block::words;
}
pub mod host_fs;

pub use dump::segment_to_json;
pub use flow::{Interpreter, MainM99, Options, parse_program, run_program, run_program_with};
pub use host::channels::{ChannelMode, ChannelState, Channels, SharedGlobals, SingleChannel};
pub use host::{ExactStop, MotionSync, PersistentVars, ProgramLibrary, UsedFile};
pub use nvfile::{NvTable, VarFileError};
pub use state::ModalState;
