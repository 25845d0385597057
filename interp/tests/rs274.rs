//! Cross-check against LinuxCNC's `rs274` (package linuxcnc-uspace): the Fanuc-dialect
//! programs in `tests/rs274/*.ngc` use the subset both controls share (G0–G3, G17–G19, G20/G21, G90/G91,
//! G81–G83, G73, G85, G86, G88, G89), and both must produce the same end points (and arc centres) in the
//! same order. Skips with a notice when `rs274` is not installed.
//!
//! Fanuc/LinuxCNC differences, where the `fanuc` dialect follows Fanuc (the tests of
//! `moves`, `cycles`, `planes`, `inch`, `diff_g89_g98` and `offsets` in the Fanuc dialect):
//! - G73/G83: LinuxCNC's retract/clearance is a fixed 0.010 in; cnc402 reads `peck_retract` /
//!   `peck_clearance` from the config (set to 0.254 mm here to compare).
//! - G88: Fanuc rapids out to the return level when the operator restarts after the stop;
//!   LinuxCNC leaves the retract to the operator. That one rapid (the first after the program
//!   stop) is left out of cnc402's list before comparing.
//! - G89 with G98: Fanuc feeds out to R and then rapids to the initial level; LinuxCNC 2.9
//!   feeds straight out to the initial level (`diff_g89_g98.ngc` asserts exactly this; G85
//!   agrees).
//! - G86: LinuxCNC dwells P at the bottom; Fanuc's G86 has no dwell.
//! - G99 → G98 inside one series of cycles, and a higher R under G99: LinuxCNC positions
//!   with one rapid to the hole's XY at the return level; Fanuc positions at the current
//!   level first. G98 when the initial level is below R: LinuxCNC first rises to R and
//!   returns there; Fanuc returns to the initial level.
//! - Dwell P: LinuxCNC seconds, Fanuc milliseconds.
//! - G43/G44 H or G49 in a block without Z: Fanuc moves Z by the change in that block;
//!   LinuxCNC applies it at the next move.
//! - G10 L2 in G91: Fanuc adds to the offset; LinuxCNC sets it. G10 L20: LinuxCNC sets the
//!   offset from the current position; on Fanuc L20 is the G54.1 P1-P48 table, which cnc402
//!   refuses. G10 L2 P0: LinuxCNC's active system, refused in the Fanuc dialect.
//! - G92.1/G92.2/G92.3 and LinuxCNC's language (O-words, `#<name>`, `@`/`^`): refused.
//!
//! The `linuxcnc` dialect (docs/dialects.md) does each of these as LinuxCNC:
//! `fanuc_programs_in_the_linuxcnc_dialect_match_rs274_exactly` runs the same programs
//! (with the config's peck distances set to something else) and `lc_*.ngc` exercise the rest;
//! every move agrees with rs274, and `the_linuxcnc_programs_differ_in_the_fanuc_dialect`
//! checks that those programs do tell the dialects apart. What remains, in both dialects:
//! - G76 (LinuxCNC: lathe threading), G87 (LinuxCNC: I/J/K offsets, not Q), G74 (absent in
//!   LinuxCNC) and rigid G84 keep Fanuc's meaning and are covered by `tests/cycles.rs`.
//! - Repeats: LinuxCNC uses L only; cnc402 also accepts K.
//! - G30: LinuxCNC's one G30 position is parameters 5181-5186 of its parameter file;
//!   cnc402's is the machine's `second_reference` (set to rs274's 0 to compare), and P2-P4
//!   stay accepted.
//! - G92: LinuxCNC keeps the shift in its parameter file across runs; cnc402 starts every
//!   program with none (as rs274 with a fresh parameter file does).
//! - G10 L1/L10/L11 (LinuxCNC's tool table) are not built; G10 L10-L13 and G44 keep Fanuc's
//!   meaning.
//! - Only moves are compared: dwells and spindle events are checked in `tests/linuxcnc.rs`.
//!
//! Offsets (`offsets.ngc`, `lc_offsets.ngc`, with the tool table `offsets.tbl`: H1 = -7 in,
//! H2 = -6.5 in, in inches because rs274 reads its tool table in inches). rs274 prints
//! canonical positions without the offsets, so they are added back here (SET_G5X_OFFSET,
//! SET_G92_OFFSET, USE_TOOL_LENGTH_OFFSET) to compare machine positions. They agree on G43 H
//! with Z, G49, G91/G90 G28 (intermediate point, then the reference of the named axes only),
//! G81 with the offset, G92 (the current point reads as given; a G10 L2 change keeps the
//! shift), G10 L2 in G90, and G28 in G43 (Fanuc cancels the vector at the reference and
//! restores it at Z's next move, LinuxCNC keeps it applied: the reference is in machine
//! coordinates, so the positions agree).

//!
//! Cutter radius compensation (`comp_g17.ngc`, `comp_g18.ngc`, tool table `comp.tbl`: ⌀ in
//! inches, so D1 = R 5.08 mm and D2 = R 2.54 mm): with `cutter_comp_corner = "arc"` and the
//! type B start-up (both defaults) the tool-centre path is LinuxCNC's, within 1 µm. What
//! differs, where cnc402 follows Fanuc or source 004 (not in those programs):
//! - G19: LinuxCNC refuses compensation in the Y-Z plane; cnc402 compensates there
//!   (`g19_compensation_is_refused_by_linuxcnc_and_done_here`, and `tests/comp.rs`).
//! - D: LinuxCNC's D names a tool whose table diameter is halved; cnc402's D is a memory-C
//!   offset number whose radius + wear is used (`[tool_offsets]`).
//! - Start on an arc: LinuxCNC allows an arc as the entry move; Fanuc (and cnc402) refuse it.
//! - `"intersection"`/`"chamfer"` corners and the type A start-up have no LinuxCNC
//!   counterpart (checked by geometry in `tests/comp.rs`).

use std::path::{Path, PathBuf};
use std::process::Command;

use cnc402_config::MachineConfig;
use cnc402_interp::run_program;
use cnc402_lang::SourceFile;
use cnc402_motion::segment::{ArcDir, Plane, SegmentKind, StopKind};

#[derive(Clone, Debug, PartialEq)]
struct Move {
    kind: char,
    end: [f64; 3],
    /// Arc: centre in the plane (first, second axis) and rotation sign.
    arc: Option<(f64, f64, i32)>,
}

fn find_rs274() -> Option<PathBuf> {
    let path = std::env::var_os("PATH")?;
    std::env::split_paths(&path)
        .map(|d| d.join("rs274"))
        .find(|p| p.is_file())
}

/// `rs274`, or `None` with a notice that the cross-check is skipped.
fn rs274_or_notice() -> Option<PathBuf> {
    let exe = find_rs274();
    if exe.is_none() {
        eprintln!(
            "NOTICE: rs274 (LinuxCNC) is not installed; cross-check skipped. apt-get install linuxcnc-uspace"
        );
    }
    exe
}

fn nums(args: &str) -> Vec<f64> {
    args.split(',')
        .filter_map(|a| a.trim().parse().ok())
        .collect()
}

/// Motion calls of `rs274 -g` output, as machine positions (offsets added back).
fn rs274_moves(exe: &Path, file: &Path) -> Vec<Move> {
    rs274_moves_with(exe, file, None)
}

/// [`rs274_moves`] with a tool table (`rs274 -t`).
fn rs274_moves_with(exe: &Path, file: &Path, tools: Option<&Path>) -> Vec<Move> {
    // rs274 keeps state in files of its working directory (its parameter file); two of them
    // started at once by parallel tests sometimes printed nothing at all. One at a time, and
    // each in a directory of its own (so that no other process's files are in the way).
    static ONE_AT_A_TIME: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _turn = ONE_AT_A_TIME.lock().unwrap_or_else(|e| e.into_inner());
    let stem = file
        .file_stem()
        .map_or_else(|| "p".into(), |s| s.to_string_lossy());
    let cwd = std::env::temp_dir().join(format!("cnc402-rs274-{}-{stem}", std::process::id()));
    std::fs::create_dir_all(&cwd).expect("a working directory for rs274");
    let file = &std::path::absolute(file).expect("an absolute program path");
    let mut cmd = Command::new(exe);
    // rs274 shares its tool table through `$HOME/.tool.mmap`: rs274 processes of other test
    // binaries or checkouts running at once read each other's tables unless each has a HOME
    // of its own (the lock above only orders this binary's own).
    cmd.current_dir(&cwd).env("HOME", &cwd);
    if let Some(t) = tools {
        cmd.arg("-t")
            .arg(std::path::absolute(t).expect("an absolute tool table path"));
    }
    let out = cmd.arg("-g").arg(file).output().expect("rs274 runs");
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    assert!(
        text.contains("PROGRAM_END()"),
        "rs274 stopped before the end of {}:\n{}",
        file.display(),
        text.lines().rev().take(4).collect::<Vec<_>>().join("\n")
    );
    let mut plane = Plane::XY;
    // rs274 reports lengths in the program's units.
    let mut scale = 1.0;
    // G5x + G92 offsets and the tool length offset, X Y Z, in the program's units.
    let mut g5x = [0.0; 3];
    let mut g92 = [0.0; 3];
    let mut tlo = [0.0; 3];
    let off = |i: usize, g5x: &[f64; 3], g92: &[f64; 3], tlo: &[f64; 3]| g5x[i] + g92[i] + tlo[i];
    let mut v = Vec::new();
    for line in text.lines() {
        let Some(call) = line.split("N..... ").nth(1) else {
            assert!(
                !line.contains("rror") && !line.contains("differs"),
                "rs274 rejected {}: {line}",
                file.display()
            );
            continue;
        };
        let args = call
            .split_once('(')
            .map(|(_, a)| a.trim_end_matches(')'))
            .unwrap_or("");
        if call.starts_with("SET_G5X_OFFSET") {
            let n = nums(args);
            g5x.copy_from_slice(&n[1..4]);
        } else if call.starts_with("SET_G92_OFFSET") {
            let n = nums(args);
            g92.copy_from_slice(&n[0..3]);
        } else if call.starts_with("USE_TOOL_LENGTH_OFFSET") {
            let first = args.split(',').next().unwrap_or("");
            for (i, t) in first.split_whitespace().take(3).enumerate() {
                tlo[i] = t.parse().unwrap_or(0.0);
            }
        } else if call.starts_with("USE_LENGTH_UNITS") {
            scale = if args.contains("INCHES") { 25.4 } else { 1.0 };
        } else if call.starts_with("SELECT_PLANE") {
            plane = if args.contains("XZ") {
                Plane::ZX
            } else if args.contains("YZ") {
                Plane::YZ
            } else {
                Plane::XY
            };
        } else if call.starts_with("STRAIGHT_TRAVERSE") || call.starts_with("STRAIGHT_FEED") {
            let n: Vec<f64> = nums(args)
                .iter()
                .enumerate()
                .map(|(i, x)| (x + if i < 3 { off(i, &g5x, &g92, &tlo) } else { 0.0 }) * scale)
                .collect();
            let kind = if call.starts_with("STRAIGHT_T") {
                'R'
            } else {
                'F'
            };
            v.push(Move {
                kind,
                end: [n[0], n[1], n[2]],
                arc: None,
            });
        } else if call.starts_with("ARC_FEED") {
            let n = nums(args);
            // (first, second, normal) axis indices of the plane, for the offsets.
            let (a, b, c) = match plane {
                Plane::XY => (0, 1, 2),
                Plane::ZX => (2, 0, 1),
                Plane::YZ => (1, 2, 0),
            };
            let o = |i: usize| off(i, &g5x, &g92, &tlo);
            let (e1, e2, c1, c2, rot, en) = (
                (n[0] + o(a)) * scale,
                (n[1] + o(b)) * scale,
                (n[2] + o(a)) * scale,
                (n[3] + o(b)) * scale,
                n[4] as i32,
                (n[5] + o(c)) * scale,
            );
            let end = match plane {
                Plane::XY => [e1, e2, en],
                Plane::ZX => [e2, en, e1],
                Plane::YZ => [en, e1, e2],
            };
            v.push(Move {
                kind: 'A',
                end,
                arc: Some((c1, c2, rot.signum())),
            });
        }
    }
    v
}

/// cnc402's motion segments in the same form (the G88 restart rapid left out, see above, in
/// the Fanuc dialect: in the LinuxCNC one there is none).
fn our_moves(cfg: &MachineConfig, file: &Path) -> Vec<Move> {
    let text = std::fs::read_to_string(file).unwrap();
    let src = SourceFile::new(file.display().to_string(), text);
    let linuxcnc = cnc402_interp::parse_program(cfg, &src, None)
        .is_ok_and(|p| p.dialect == cnc402_lang::Dialect::LinuxCnc);
    let segs = run_program(cfg, &src).unwrap_or_else(|e| panic!("{e}"));
    let mut v = Vec::new();
    let mut after_stop = false;
    for s in &segs {
        let m = match &s.kind {
            SegmentKind::Rapid { end } => {
                if after_stop {
                    after_stop = false;
                    continue;
                }
                Move {
                    kind: 'R',
                    end: [end[0], end[1], end[2]],
                    arc: None,
                }
            }
            SegmentKind::Linear { end, .. } => Move {
                kind: 'F',
                end: [end[0], end[1], end[2]],
                arc: None,
            },
            SegmentKind::Arc {
                end,
                center,
                plane,
                dir,
                ..
            } => {
                let (c1, c2) = match plane {
                    Plane::XY => (center[0], center[1]),
                    Plane::ZX => (center[2], center[0]),
                    Plane::YZ => (center[1], center[2]),
                };
                let rot = if *dir == ArcDir::Cw { -1 } else { 1 };
                Move {
                    kind: 'A',
                    end: [end[0], end[1], end[2]],
                    arc: Some((c1, c2, rot)),
                }
            }
            SegmentKind::Stop {
                kind: StopKind::Program,
            } => {
                after_stop = !linuxcnc;
                continue;
            }
            _ => continue,
        };
        after_stop = false;
        v.push(m);
    }
    v
}

/// Drops moves that end where the previous one ended (rs274 emits some zero-length moves that
/// cnc402 does not, e.g. the rapid to R when the tool is already there).
fn dedup(v: Vec<Move>) -> Vec<Move> {
    let mut out: Vec<Move> = Vec::new();
    let mut at = [0.0; 3];
    for m in v {
        let same = m.end.iter().zip(at).all(|(a, b)| (a - b).abs() < 1e-4);
        at = m.end;
        if !same || m.kind == 'A' {
            out.push(m);
        }
    }
    out
}

/// rs274 prints 4 decimals (of an inch in G20: 2.54 µm).
fn close(a: &Move, b: &Move) -> bool {
    let e = a.end.iter().zip(b.end).all(|(x, y)| (x - y).abs() < 2e-3);
    let arc = match (a.arc, b.arc) {
        (None, None) => true,
        (Some((a1, a2, ar)), Some((b1, b2, br))) => {
            (a1 - b1).abs() < 2e-3 && (a2 - b2).abs() < 2e-3 && ar == br
        }
        _ => false,
    };
    a.kind == b.kind && e && arc
}

fn config() -> MachineConfig {
    let mut cfg = MachineConfig::default_machine();
    cfg.interp.peck_retract = 0.254;
    cfg.interp.peck_clearance = 0.254;
    cfg
}

fn dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/rs274")
}

#[test]
fn same_end_points_as_linuxcnc() {
    let Some(exe) = rs274_or_notice() else {
        return;
    };
    let cfg = config();
    let mut report = Vec::new();
    for name in ["moves.ngc", "cycles.ngc", "planes.ngc", "inch.ngc"] {
        compare(&cfg, &exe, name, &mut report);
    }
    assert!(report.is_empty(), "{}", report.join("\n"));
}

/// G89 under G98: cnc402 (Fanuc) feeds to R and rapids to the initial level where rs274
/// feeds straight to the initial level; everything else (and all of G85) is the same.
#[test]
fn g89_with_g98_differs_only_in_the_way_out() {
    let Some(exe) = rs274_or_notice() else {
        return;
    };
    let file = dir().join("diff_g89_g98.ngc");
    let theirs = dedup(rs274_moves(&exe, &file));
    let ours = dedup(our_moves(&config(), &file));
    // Ours: … F(bottom) F(R=2) R(initial=10); theirs: … F(bottom) F(initial=10).
    let mut expect = Vec::new();
    for m in &theirs {
        if m.kind == 'F' && m.end[2] == 10.0 {
            expect.push(Move {
                kind: 'F',
                end: [m.end[0], m.end[1], 2.0],
                arc: None,
            });
            expect.push(Move {
                kind: 'R',
                ..m.clone()
            });
        } else {
            expect.push(m.clone());
        }
    }
    // G85's way out agrees; only G89's feed to the initial level is replaced.
    assert_eq!(
        theirs
            .iter()
            .filter(|m| m.kind == 'F' && m.end[2] == 10.0)
            .count(),
        1
    );
    assert_eq!(ours.len(), expect.len());
    for (a, b) in ours.iter().zip(&expect) {
        assert!(close(a, b), "ours {a:?} expected {b:?}");
    }
}

/// G43/G49 with H, G28, G92 and G10 L2 (see the module docs for what differs and is not in
/// the program): same machine positions as rs274 with the same tool lengths.
#[test]
fn offsets_same_machine_positions_as_linuxcnc() {
    let Some(exe) = rs274_or_notice() else {
        return;
    };
    let cfg = config_with_tools();
    let file = dir().join("offsets.ngc");
    let theirs = dedup(rs274_moves_with(
        &exe,
        &file,
        Some(&dir().join("offsets.tbl")),
    ));
    let ours = dedup(our_moves(&cfg, &file));
    assert!(theirs.len() > 20, "rs274 gave {} moves", theirs.len());
    assert_eq!(
        ours.len(),
        theirs.len(),
        "ours {ours:#?}\ntheirs {theirs:#?}"
    );
    for (i, (a, b)) in ours.iter().zip(&theirs).enumerate() {
        assert!(close(a, b), "move {i}: ours {a:?}\n    rs274 {b:?}");
    }
    // The offsets are really in play: the G43 H1 Z50 move is at machine Z 50 - 177.8.
    assert!(
        ours.iter()
            .any(|m| (m.end[2] - (50.0 - 177.8)).abs() < 1e-6)
    );
}

/// [`config`] with the tool lengths of `offsets.tbl` (T1 Z-7 in, T2 Z-6.5 in).
fn config_with_tools() -> MachineConfig {
    let mut cfg = config();
    for (k, length) in [(0, -177.8), (1, -165.1)] {
        cfg.tool_offsets[k] = cnc402_config::ToolOffset {
            length,
            ..Default::default()
        };
    }
    cfg
}

/// The machine config in the LinuxCNC dialect (what every `lc_*.ngc` program also says in its
/// header), with the tool table `offsets.tbl`.
fn linuxcnc_config() -> MachineConfig {
    let mut cfg = config_with_tools();
    cfg.interp.dialect = cnc402_lang::Dialect::LinuxCnc;
    // LinuxCNC's G30 position (#5181-#5186) is 0 in rs274's fresh parameter file; the
    // machine's second reference is where cnc402 keeps it.
    for a in &mut cfg.axes {
        a.references[1] = Some(0.0);
    }
    cfg
}

/// Compares one program's moves with rs274's; a message for each difference.
fn compare(cfg: &MachineConfig, exe: &Path, name: &str, report: &mut Vec<String>) {
    let file = dir().join(name);
    let tools = dir().join("offsets.tbl");
    let theirs = dedup(rs274_moves_with(exe, &file, Some(&tools)));
    let ours = dedup(our_moves(cfg, &file));
    assert!(
        theirs.len() >= 10,
        "{name}: rs274 gave {} moves",
        theirs.len()
    );
    for (i, (a, b)) in ours.iter().zip(&theirs).enumerate() {
        if !close(a, b) {
            report.push(format!("{name} move {i}: ours {a:?}\n    rs274 {b:?}"));
            break;
        }
    }
    if ours.len() != theirs.len() {
        report.push(format!(
            "{name}: {} moves, rs274 {}",
            ours.len(),
            theirs.len()
        ));
    }
}

/// The LinuxCNC dialect's own language (O-word subroutines and flow, named parameters, polar
/// words, G92.x): the `lc_*.ngc` programs, same moves as rs274.
#[test]
fn linuxcnc_dialect_programs_match_rs274() {
    let Some(exe) = rs274_or_notice() else {
        return;
    };
    let cfg = linuxcnc_config();
    let mut names: Vec<String> = std::fs::read_dir(dir())
        .unwrap()
        .filter_map(|e| e.ok()?.file_name().into_string().ok())
        .filter(|n| n.starts_with("lc_") && n.ends_with(".ngc"))
        .collect();
    names.sort();
    assert!(!names.is_empty());
    let mut report = Vec::new();
    for name in &names {
        compare(&cfg, &exe, name, &mut report);
    }
    assert!(report.is_empty(), "{}", report.join("\n"));
}

/// The programs the Fanuc dialect compares with documented differences, run in the LinuxCNC
/// dialect: no difference left (the G89 way out included), and the peck distances are
/// LinuxCNC's whatever the config says.
#[test]
fn fanuc_programs_in_the_linuxcnc_dialect_match_rs274_exactly() {
    let Some(exe) = rs274_or_notice() else {
        return;
    };
    let mut cfg = config_with_tools();
    cfg.interp.peck_retract = 1.0;
    cfg.interp.peck_clearance = 1.0;
    cfg.interp.dialect = cnc402_lang::Dialect::LinuxCnc;
    let mut report = Vec::new();
    for name in [
        "offsets.ngc",
        "moves.ngc",
        "cycles.ngc",
        "planes.ngc",
        "inch.ngc",
        "diff_g89_g98.ngc",
    ] {
        compare(&cfg, &exe, name, &mut report);
    }
    assert!(report.is_empty(), "{}", report.join("\n"));
}

/// The `lc_*.ngc` programs that exercise what differs read differently in the Fanuc dialect
/// (so the LinuxCNC cross-check above pins the dialect, not a shared behaviour).
#[test]
fn the_linuxcnc_programs_differ_in_the_fanuc_dialect() {
    let Some(exe) = rs274_or_notice() else {
        return;
    };
    let tmp = std::env::temp_dir().join(format!("cnc402-fanuc-{}", std::process::id()));
    std::fs::create_dir_all(&tmp).unwrap();
    for name in ["lc_offsets.ngc", "lc_cycles.ngc"] {
        let text = std::fs::read_to_string(dir().join(name)).unwrap();
        // Up to what Fanuc refuses (G10 L20 is its G54.1 table).
        let text = match text.find("\nG10 L20") {
            Some(i) => text[..=i].to_string() + "M2\n",
            None => text,
        };
        let fanuc = tmp.join(name);
        std::fs::write(&fanuc, text.replace("(dialect: linuxcnc)", "")).unwrap();
        let tools = dir().join("offsets.tbl");
        let theirs = dedup(rs274_moves_with(&exe, &fanuc, Some(&tools)));
        let ours = dedup(our_moves(&config_with_tools(), &fanuc));
        let same = ours.len() == theirs.len() && ours.iter().zip(&theirs).all(|(a, b)| close(a, b));
        assert!(!same, "{name}: the Fanuc dialect gives rs274's moves too");
    }
}

/// Within 1 µm (rs274 prints 4 decimals of a mm in these G21 programs).
fn within_um(a: &Move, b: &Move) -> bool {
    let e = a.end.iter().zip(b.end).all(|(x, y)| (x - y).abs() <= 1e-3);
    let arc = match (a.arc, b.arc) {
        (None, None) => true,
        (Some((a1, a2, ar)), Some((b1, b2, br))) => {
            (a1 - b1).abs() <= 1e-3 && (a2 - b2).abs() <= 1e-3 && ar == br
        }
        _ => false,
    };
    a.kind == b.kind && e && arc
}

/// `comp.tbl` in mm: T1 (D1) ⌀0.4 in, T2 (D2) ⌀0.2 in.
fn comp_config() -> MachineConfig {
    let mut cfg = config();
    cfg.tool_offsets[0].radius = 5.08;
    cfg.tool_offsets[1].radius = 2.54;
    cfg
}

/// Cutter radius compensation with the arc corner setting (LinuxCNC's way) and the type B
/// start-up (LinuxCNC's too): the same tool-centre end points and arc centres as rs274, within
/// 1 µm, in G17 and G18, G41 and G42, inside and outside corners, line–arc and arc–arc joints,
/// entry and exit moves; G91, a helix, moves along the normal axis and a dwell inside the
/// contour, and reversals (`comp_mixed.ngc`).
#[test]
fn cutter_comp_same_tool_centre_path_as_linuxcnc() {
    let Some(exe) = find_rs274() else {
        eprintln!("NOTICE: rs274 (LinuxCNC) is not installed; cross-check skipped");
        return;
    };
    let cfg = comp_config();
    for name in ["comp_g17.ngc", "comp_g18.ngc", "comp_mixed.ngc"] {
        let file = dir().join(name);
        let theirs = dedup(rs274_moves_with(&exe, &file, Some(&dir().join("comp.tbl"))));
        let ours = dedup(our_moves(&cfg, &file));
        assert!(
            theirs.len() > 10,
            "{name}: rs274 gave {} moves",
            theirs.len()
        );
        for (i, (a, b)) in ours.iter().zip(&theirs).enumerate() {
            assert!(
                within_um(a, b),
                "{name} move {i}: ours {a:?}\n    rs274 {b:?}"
            );
        }
        assert_eq!(
            ours.len(),
            theirs.len(),
            "{name}: ours {ours:#?}\ntheirs {theirs:#?}"
        );
    }
}

/// LinuxCNC refuses cutter compensation in G19; cnc402 runs the same program, R from the
/// contour (the geometry is checked in `tests/comp.rs`).
#[test]
fn g19_compensation_is_refused_by_linuxcnc_and_done_here() {
    let Some(exe) = find_rs274() else {
        eprintln!("NOTICE: rs274 (LinuxCNC) is not installed; cross-check skipped");
        return;
    };
    let text =
        "G21 G19 G90\nG0 Y-20 Z-20\nG41 D1 G1 Y0 Z0 F100\nG1 Z30\nG1 Y30\nG40 G1 Y40 Z40\nM2\n";
    let cwd = std::env::temp_dir().join(format!("cnc402-rs274-{}-g19", std::process::id()));
    std::fs::create_dir_all(&cwd).unwrap();
    let file = cwd.join("g19.ngc");
    std::fs::write(&file, text).unwrap();
    let out = Command::new(exe)
        .current_dir(&cwd)
        .env("HOME", &cwd)
        .arg("-t")
        .arg(std::path::absolute(dir().join("comp.tbl")).unwrap())
        .arg("-g")
        .arg(&file)
        .output()
        .unwrap();
    let said =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    assert!(
        !said.contains("PROGRAM_END"),
        "rs274 ran G19 compensation:\n{said}"
    );
    let segs = run_program(&comp_config(), &SourceFile::new("g19.ngc", text)).unwrap();
    let wall = segs
        .iter()
        .find(|s| s.source.line == 4)
        .and_then(|s| s.kind.line_end().copied())
        .unwrap();
    // G41 going +Z in the Y-Z plane: the tool is at -Y, R = 5.08 away.
    assert!(
        (wall[1] + 5.08).abs() < 1e-9 && (wall[2] - 30.0).abs() < 1e-9,
        "{wall:?}"
    );
}
