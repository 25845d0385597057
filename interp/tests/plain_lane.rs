//! The plain-block lane (a G0/G1 block of literal words run from its bytes) against the
//! general block layer: random programs that mix plain moves with everything that must switch
//! the lane off (modes, offsets, cycles, compensation, corners, macros, tapping, limits,
//! overflow, loops) give the same canonical operations, segments, errors, final state and
//! system variables with the lane on and off, in each dialect.

use std::io::Cursor;

use cnc402_config::{AxisKind, MachineConfig};
use cnc402_interp::Interpreter;
use cnc402_lang::Dialect;
use proptest::prelude::*;

/// Most operations compared per program (loops may be endless).
const MAX_OPS: usize = 3_000;

/// The default machine (X Y Z, spindle C) without soft limits, or with them on X only, and
/// with a rotary A when asked.
fn machine(limits: bool, rotary_a: bool) -> MachineConfig {
    let mut c = MachineConfig::default_machine();
    c.interp.variables_file = None;
    c.interp.block_limit = 40;
    // Without limits a target past f64's range reaches the finiteness checks.
    for a in &mut c.axes {
        a.soft_limits = None;
    }
    if limits {
        c.axes[0].soft_limits = Some((-120.0, 120.0));
    }
    if rotary_a {
        let mut a = c.axes[1].clone();
        a.name = 'A';
        a.kind = AxisKind::Rotary;
        a.node = None;
        c.axes.push(a);
    }
    c
}

/// What a run shows: every operation (or segment) in order, how it ended, the final modal
/// state and the variables a program reads back (position, last N, path length).
fn run(
    cfg: &MachineConfig,
    text: &str,
    dialect: Option<Dialect>,
    lane: bool,
    canon: bool,
) -> String {
    let mut it = Interpreter::new(cfg);
    it.set_plain_lane(lane);
    let mut out = String::new();
    if let Err(e) = it.load_stream(
        "p.nc",
        Box::new(Cursor::new(text.as_bytes().to_vec())),
        dialect,
    ) {
        return format!("load: {e:?}");
    }
    for _ in 0..MAX_OPS {
        let next = if canon {
            it.next_canon().map(|o| o.map(|o| format!("{o:?}")))
        } else {
            it.next_lowered()
                .map(|o| o.map(|(s, st)| format!("{s:?} {st:?}")))
        };
        match next {
            Ok(Some(o)) => {
                out.push_str(&o);
                out.push('\n');
            }
            Ok(None) => break,
            Err(e) => {
                out.push_str(&format!("error: {e:?}\n"));
                break;
            }
        }
    }
    out.push_str(&format!("{:?}\n", it.state()));
    for n in [5001, 5002, 5003, 4114, 4001, 4003, 4109] {
        out.push_str(&format!("#{n}={:?} ", it.var(n)));
    }
    out.push_str(&format!("len={:?}", it.path_length()));
    out
}

/// A number as a CAM or a hand writes it: 0–6 decimals, signs, leading zeros, `.5`, `5.`,
/// and now and then one past the limits or past f64's range.
fn number() -> impl Strategy<Value = String> {
    prop_oneof![
        6 => (-200i64..200, 0u32..6).prop_map(|(v, d)| {
            let s = format!("{:.*}", d as usize, v as f64 / 7.0);
            s.replace("0.", if v % 3 == 0 { "." } else { "0." })
        }),
        2 => (-50i32..50).prop_map(|v| v.to_string()),
        1 => (0u32..100).prop_map(|v| format!("+{v}.")),
        1 => (0u32..100).prop_map(|v| format!("00{v}.0100")),
        1 => Just("1".repeat(320)),
        1 => Just("-0".to_string()),
        1 => Just("1e3".to_string()),
        1 => Just("10.0000000001".to_string()),
    ]
}

/// One line: mostly plain moves (some the lane reads, some it must leave), with modal
/// changes and flow between them.
fn line() -> impl Strategy<Value = String> {
    let n = number;
    prop_oneof![
        8 => (n(), n()).prop_map(|(a, b)| format!("G1 X{a} Y{b}")),
        4 => (n(), n()).prop_map(|(a, b)| format!("X{a} Y{b}")),
        2 => (n(), 1u32..5000).prop_map(|(a, f)| format!("N{f} G01 Z{a} F{f}")),
        2 => n().prop_map(|a| format!("G0 X{a}")),
        1 => n().prop_map(|a| format!("g1 x {a} z{a}")),
        1 => n().prop_map(|a| format!("G1 X{a} (cut)")),
        1 => n().prop_map(|a| format!("G1 X{a} A{a}")),
        1 => n().prop_map(|a| format!("G1 X{a} C{a}")),
        1 => n().prop_map(|a| format!("G1 X{a} X{a}")),
        1 => n().prop_map(|a| format!("G1 G0 X{a}")),
        1 => n().prop_map(|a| format!("G1. X{a}")),
        1 => n().prop_map(|a| format!("G-0 X{a}")),
        1 => n().prop_map(|a| format!("/G1 X{a}")),
        1 => n().prop_map(|a| format!("G1 X{a} F{a}")),
        1 => Just("F0".to_string()),
        1 => Just("G1 X0 Y0 F-1".to_string()),
        1 => prop::sample::select(vec![
            "G20", "G21", "G90", "G91", "G54", "G55", "G61", "G64 P0.01", "G64 P0.05 Q0.01",
            "G9 G1 X3", "G95 S500", "G94", "M3 S1000", "M5", "G43 H1", "G49", "G17", "G18",
            "G92 X10 Y-5", "G92.1", "G10 L2 P2 X5 Y5 Z-1", "G10 L2 P1 X1e300",
            "G81 R2 Z-3 F100", "G80", "G41 D1", "G40", "G2 X5 Y0 R5", "G1 X1 Y1 ,R2",
            "G1 X5 ,C1", "#1=5", "G1 X#1", "M29 S500", "G84 Z-5 R2 F1", "T1 M6", "G53 G0 Z0",
            "G28 Z0", "G4 P10", "M0", "M1", "#5221=1e308", "G28.1", "G05.1 Q1", "G08 P0",
            "G1 Z0.0000000001", "G0 X1e3", "N5", "(comment only)", "", "%", "G91 G1 @5 ^30",
            "G90 G0 @5 ^30",
        ])
        .prop_map(str::to_string),
        1 => (1u32..4).prop_map(|k| format!("#2=#2+1\nIF[#2LT{k}]GOTO7")),
        1 => Just("N7 G1 X1 Y1".to_string()),
    ]
}

fn program() -> impl Strategy<Value = String> {
    (
        prop::collection::vec(line(), 1..40),
        any::<bool>(),
        prop::sample::select(vec!["F300\n", "G91 F100\n", "G20 F10\n", ""]),
    )
        .prop_map(|(lines, end, head)| {
            let mut t = format!("{head}{}\n", lines.join("\n"));
            if end {
                t.push_str("M30\n");
            }
            t
        })
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(384))]

    #[test]
    fn the_lane_runs_every_program_as_the_general_path_does(
        text in program(),
        limits in any::<bool>(),
        rotary_a in any::<bool>(),
        dialect in prop::sample::select(vec![None, Some(Dialect::LinuxCnc), Some(Dialect::Haas)]),
        canon in any::<bool>(),
    ) {
        let cfg = machine(limits, rotary_a);
        let general = run(&cfg, &text, dialect, false, canon);
        let lane = run(&cfg, &text, dialect, true, canon);
        prop_assert_eq!(lane, general, "program:\n{}", text);
    }
}

/// The lane is taken for plain moves (so the test above compares something) and left for a
/// line with a comment or in G91 after a cycle.
#[test]
fn the_lane_takes_plain_moves_and_leaves_the_rest() {
    let cfg = machine(false, false);
    let text = "G21 G90 F1000\nG1 X1 Y2\nX3\nN40 G0 Z5\nG1 X4 (the general path's)\nG81 R1 Z-1\nX5\nG80\nX6\nM30\n";
    let mut it = Interpreter::new(&cfg);
    it.load_stream("p.nc", Box::new(Cursor::new(text)), None)
        .unwrap();
    let segs: Vec<_> = it.by_ref().collect::<Result<_, _>>().unwrap();
    assert!(segs.len() >= 8, "{segs:?}");
    // G1 X1 Y2, X3, N40 G0 Z5 and X6; not the commented line, nor X5 in the cycle.
    assert_eq!(it.plain_lane_blocks(), 4);
    assert_eq!(
        run(&cfg, text, None, true, false),
        run(&cfg, text, None, false, false)
    );
}

/// LinuxCNC's polar step of a G91 `@`/`^` block is the block's own: a plain move after it
/// clears it as the general path does.
#[test]
fn a_plain_move_after_a_linuxcnc_polar_block_clears_its_step() {
    let cfg = machine(false, false);
    let text = "G1 X1 Y1 F100\nG91 G1 @5 ^30\nX3\n";
    let lane = run(&cfg, text, Some(Dialect::LinuxCnc), true, true);
    assert_eq!(lane, run(&cfg, text, Some(Dialect::LinuxCnc), false, true));
    assert!(lane.contains("polar_step: None"), "{lane}");
}
