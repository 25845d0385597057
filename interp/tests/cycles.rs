//! Canned cycles checked by their geometry rather than by a golden file: peck depths with the
//! configured d, tap coupling, return planes of every cycle, G91 levels, repeats, planes, and
//! the G76/G87 shift. Fanuc behaviour throughout; LinuxCNC differences are noted where they are.

use cnc402_config::MachineConfig;
use cnc402_interp::run_program;
use cnc402_lang::SourceFile;
use cnc402_motion::segment::{
    AxisPos, Segment, SegmentEnd, SegmentKind, SpindleDir, StopKind, TapSegment,
};

const X: usize = 0;
const Y: usize = 1;
const Z: usize = 2;
const C: usize = 3;

fn run_cfg(cfg: &MachineConfig, text: &str) -> Vec<Segment> {
    run_program(cfg, &SourceFile::new("t.nc", text)).unwrap_or_else(|e| panic!("{e}"))
}

fn run(text: &str) -> Vec<Segment> {
    run_cfg(&MachineConfig::default_machine(), text)
}

fn end(s: &Segment) -> Option<AxisPos> {
    match &s.kind {
        SegmentKind::Rapid { end }
        | SegmentKind::Linear { end, .. }
        | SegmentKind::Tap(TapSegment { end, .. })
        | SegmentKind::Arc { end, .. } => Some(*end),
        _ => None,
    }
}

/// (kind letter R/F/T (rapid, feed, tap), value of axis `i`) for the motion segments of line
/// `line`.
fn moves(segs: &[Segment], line: u32, i: usize) -> Vec<(char, f64)> {
    segs.iter()
        .filter(|s| s.source.line == line)
        .filter_map(|s| {
            let k = match s.kind {
                SegmentKind::Rapid { .. } => 'R',
                SegmentKind::Linear { .. } => 'F',
                SegmentKind::Tap(_) => 'T',
                _ => return None,
            };
            end(s).map(|e| (k, (e[i] * 1e6).round() / 1e6))
        })
        .collect()
}

#[test]
fn g73_pecks_use_the_configured_retract() {
    let mut cfg = MachineConfig::default_machine();
    cfg.interp.peck_retract = 0.3;
    let segs = run_cfg(&cfg, "G0 Z10\nG73 X0 Y0 Z-5 R1 Q2 F100\nM30\n");
    assert_eq!(
        moves(&segs, 2, Z),
        vec![
            ('R', 1.0),
            ('F', -1.0),
            ('R', -0.7),
            ('F', -3.0),
            ('R', -2.7),
            ('F', -5.0),
            ('R', 10.0)
        ]
    );
}

#[test]
fn g83_pecks_return_to_r_and_reenter_to_the_configured_clearance() {
    let mut cfg = MachineConfig::default_machine();
    cfg.interp.peck_clearance = 1.0;
    let segs = run_cfg(&cfg, "G0 Z10\nG99 G83 X0 Y0 Z-7 R2 Q3 F100\nM30\n");
    assert_eq!(
        moves(&segs, 2, Z),
        vec![
            ('R', 2.0),
            ('F', -1.0),
            ('R', 2.0),
            ('R', 0.0),
            ('F', -4.0),
            ('R', 2.0),
            ('R', -3.0),
            ('F', -7.0),
            ('R', 2.0)
        ]
    );
}

/// Every tap move is a `Tap` segment of Z with C ending in an exact stop, and satisfies
/// C = C0 + (R − Z)·360/pitch (G84, M3) or its negative (G74, M4); its signed pitch is
/// ΔZ/ΔC·360 (−pitch for G84 into a hole below R, +pitch for G74); the tool leaves the hole
/// on the same helix and C returns to C0.
#[test]
fn taps_couple_c_to_z_one_turn_per_pitch() {
    for (prog, hand, pitch) in [
        ("M3 S400\nG0 Z10\nG84 X5 Y5 Z-12 R2 F600\nM30\n", 1.0, 1.5),
        ("M4 S400\nG0 Z10\nG74 X5 Y5 Z-12 R2 F400\nM30\n", -1.0, 1.0),
        (
            "M3 S400\nG95\nG0 Z10\nG84 X5 Y5 Z-12 R2 Q4 F1.75\nM30\n",
            1.0,
            1.75,
        ),
        (
            "G0 Z10\nM29 S300\nG74 X5 Y5 Z-12 R2 Q5 F375\nM30\n",
            -1.0,
            1.25,
        ),
    ] {
        let segs = run(prog);
        assert!(
            !segs
                .iter()
                .any(|s| matches!(s.kind, SegmentKind::Linear { .. })),
            "{prog}: a tap move left as a plain feed"
        );
        let taps: Vec<_> = segs
            .iter()
            .filter(|s| matches!(s.kind, SegmentKind::Tap(_)))
            .collect();
        assert!(taps.len() >= 2, "{prog}");
        let mut prev = segs
            .iter()
            .take_while(|s| !matches!(s.kind, SegmentKind::Tap(_)))
            .filter_map(end)
            .last()
            .unwrap();
        for s in &taps {
            let e = end(s).unwrap();
            let want = hand * (2.0 - e[Z]) * 360.0 / pitch;
            assert!((e[C] - want).abs() < 1e-9, "{prog}: C {} want {want}", e[C]);
            let SegmentKind::Tap(t) = s.kind else {
                unreachable!()
            };
            assert_eq!((t.tool, t.spindle), (Z as u8, C as u8), "{prog}");
            assert_eq!(t.pitch, -hand * pitch, "{prog}");
            let geometric = (e[Z] - prev[Z]) / (e[C] - prev[C]) * 360.0;
            assert!((t.pitch - geometric).abs() < 1e-12, "{prog}: {geometric}");
            assert_eq!(s.ends, SegmentEnd::ExactStop, "{prog}");
            prev = e;
            let feed = t.feed;
            assert!(
                (feed
                    - pitch
                        * if prog.contains("M29 S300") {
                            300.0
                        } else {
                            400.0
                        })
                .abs()
                    < 1e-9
            );
        }
        let deepest = taps
            .iter()
            .map(|s| end(s).unwrap()[Z])
            .fold(f64::MAX, f64::min);
        assert!((deepest + 12.0).abs() < 1e-9);
        let last = end(taps.last().unwrap()).unwrap();
        assert_eq!((last[Z], last[C]), (2.0, 0.0), "{prog}");
    }
}

/// Fanuc high-speed peck tapping: each peck goes Q deeper than the last depth (as G73),
/// backing out by the configured d between pecks (`tap_peck_retract`, Fanuc No. 5213, not
/// G73's `peck_retract`); every move is a coupled tap move.
#[test]
fn peck_tap_goes_in_by_q_and_out_by_d() {
    let mut cfg = MachineConfig::default_machine();
    cfg.interp.tap_peck_retract = 1.0;
    cfg.interp.peck_retract = 0.3;
    let segs = run_cfg(&cfg, "M3 S500\nG0 Z5\nG99 G84 X0 Y0 Z-8 R0 Q3 F500\nM30\n");
    assert_eq!(
        moves(&segs, 3, Z),
        vec![
            ('R', 0.0),
            ('T', -3.0),
            ('T', -2.0),
            ('T', -6.0),
            ('T', -5.0),
            ('T', -8.0),
            ('T', 0.0)
        ]
    );
}

/// G84 and G73 pecks in one program back out by their own amounts: the tap by
/// `tap_peck_retract` (Fanuc No. 5213), the drill by `peck_retract` (No. 5114).
#[test]
fn peck_tap_and_g73_use_separate_retracts() {
    let mut cfg = MachineConfig::default_machine();
    cfg.interp.tap_peck_retract = 1.5;
    cfg.interp.peck_retract = 0.25;
    let segs = run_cfg(
        &cfg,
        "M3 S500\nG0 Z5\nG99 G84 X0 Y0 Z-6 R0 Q4 F500\nG80\nG99 G73 X10 Y0 Z-6 R0 Q4 F100\nM30\n",
    );
    assert_eq!(
        moves(&segs, 3, Z),
        vec![
            ('R', 0.0),
            ('T', -4.0),
            ('T', -2.5),
            ('T', -6.0),
            ('T', 0.0)
        ]
    );
    assert_eq!(
        moves(&segs, 5, Z),
        vec![
            ('R', 0.0),
            ('F', -4.0),
            ('R', -3.75),
            ('F', -6.0),
            ('R', 0.0)
        ]
    );
}

/// A turning spindle is stopped before the tap and restarted (same S and direction) after it;
/// a spindle at rest in M29 stays at rest. (M29 is cancelled by G80 and group 01 codes, as
/// Fanuc, so it comes after the positioning block.)
#[test]
fn tap_stops_and_restarts_a_turning_spindle_only() {
    let segs = run("M3 S600\nG0 Z10\nG84 X0 Y0 Z-5 R2 F600\nM30\n");
    let line3: Vec<_> = segs
        .iter()
        .filter(|s| s.source.line == 3)
        .map(|s| &s.kind)
        .collect();
    assert_eq!(
        line3.first(),
        Some(&&SegmentKind::Spindle {
            rpm: 0.0,
            dir: SpindleDir::Stop,
            spindle: 1,
        })
    );
    assert_eq!(
        line3.last(),
        Some(&&SegmentKind::Spindle {
            rpm: 600.0,
            dir: SpindleDir::Cw,
            spindle: 1,
        })
    );
    let rigid = run("G0 Z10\nM29 S600\nG84 X0 Y0 Z-5 R2 F600\nM30\n");
    assert!(
        !rigid
            .iter()
            .any(|s| matches!(s.kind, SegmentKind::Spindle { .. }))
    );
}

/// Final drilling-axis level of every cycle under G98 (initial level 10) and G99 (R = 2).
/// G87 returns to the initial level in both (Fanuc: G99 is not used with G87).
#[test]
fn every_cycle_returns_to_its_plane() {
    for cyc in [73, 74, 76, 81, 82, 83, 84, 85, 86, 87, 88, 89] {
        for (ret, want) in [(98, 10.0), (99, 2.0)] {
            let spindle = if cyc == 74 { "M4 S500" } else { "M3 S500" };
            let (r, z) = if cyc == 87 { (-8.0, -2.0) } else { (2.0, -5.0) };
            let want = if cyc == 87 { 10.0 } else { want };
            let prog = format!(
                "{spindle}\nG0 X0 Y0 Z10\nG{ret} G{cyc} X5 Y5 Z{z} R{r} Q1 P100 F500\nM30\n"
            );
            let segs = run(&prog);
            let last = segs
                .iter()
                .filter(|s| s.source.line == 3)
                .filter_map(end)
                .next_back()
                .unwrap();
            assert_eq!((last[X], last[Y], last[Z]), (5.0, 5.0, want), "{prog}");
            let deepest = segs
                .iter()
                .filter_map(end)
                .map(|e| e[Z])
                .fold(f64::MAX, f64::min);
            let want_deep = if cyc == 87 { -8.0 } else { -5.0 };
            assert!((deepest - want_deep).abs() < 1e-9, "{prog}: {deepest}");
        }
    }
}

/// G91 (Fanuc): R is the distance from the initial level, Z from R; X/Y increments repeat with
/// K. LinuxCNC agrees on R/Z; its repeat word is L, which cnc402 accepts as well.
#[test]
fn g91_levels_and_repeats() {
    for rep in ["K3", "L3"] {
        let segs = run(&format!(
            "G0 X0 Y0 Z20\nG91 G99 G81 X10 Y5 Z-7 R-15 {rep} F100\nM30\n"
        ));
        let holes: Vec<_> = segs
            .iter()
            .filter_map(|s| match s.kind {
                SegmentKind::Linear { end, .. } => Some((end[X], end[Y], end[Z])),
                _ => None,
            })
            .collect();
        assert_eq!(
            holes,
            vec![(10.0, 5.0, -2.0), (20.0, 10.0, -2.0), (30.0, 15.0, -2.0)]
        );
        // G99 in G91: R stays measured from the initial level (20), not from the R level.
        let last = segs.iter().filter_map(end).next_back().unwrap();
        assert_eq!(last[Z], 5.0);
    }
    // K0: the data is stored, nothing moves; the next block with a position drills with it.
    let segs = run("G0 Z20\nG81 X1 Z-1 R2 K0 F100\nX2\nM30\n");
    assert!(segs.iter().all(|s| s.source.line != 2));
    assert_eq!(
        moves(&segs, 3, Z),
        vec![('R', 20.0), ('R', 2.0), ('F', -1.0), ('R', 20.0)]
    );
}

/// G17 drills along Z, G18 along Y, G19 along X; the other two are the hole position.
#[test]
fn cycles_drill_along_the_planes_normal() {
    let cases = [
        ("G17", "X5 Y6 Z-3 R1", Z, [(X, 5.0), (Y, 6.0)]),
        ("G18", "Z5 X6 Y-3 R1", Y, [(Z, 5.0), (X, 6.0)]),
        ("G19", "Y5 Z6 X-3 R1", X, [(Y, 5.0), (Z, 6.0)]),
    ];
    for (plane, words, axis, pos) in cases {
        let segs = run(&format!(
            "G0 X10 Y10 Z10\n{plane} G99 G81 {words} F100\nM30\n"
        ));
        let feeds: Vec<_> = segs
            .iter()
            .filter_map(|s| match s.kind {
                SegmentKind::Linear { end, .. } => Some(end),
                _ => None,
            })
            .collect();
        assert_eq!(feeds.len(), 1);
        assert_eq!(feeds[0][axis], -3.0, "{plane}");
        for (i, v) in pos {
            assert_eq!(feeds[0][i], v, "{plane}");
        }
        assert_eq!(segs.iter().filter_map(end).next_back().unwrap()[axis], 1.0);
    }
}

/// G76: at the bottom the spindle stops and is oriented to the configured physical angle (a
/// `SpindleOrient` that motion resolves; program C stays where it was), the tool shifts +Q
/// along the plane's first axis, retracts, shifts back, restarts.
#[test]
fn g76_orients_and_shifts_by_q() {
    let mut cfg = MachineConfig::default_machine();
    for (angle, plane, words, shift_axis) in [
        (0.0, "G17", "X0 Y0 Z-5 R2", X),
        (90.0, "G18", "Z0 X0 Y-5 R2", Z),
        (271.5, "G19", "Y0 Z0 X-5 R2", Y),
    ] {
        cfg.interp.spindle_orient_angle = angle;
        let segs = run_cfg(
            &cfg,
            &format!("G0 X10 Y10 Z10 C200\nM3 S500\n{plane} G98 G76 {words} Q0.4 F100\nM30\n"),
        );
        let l3: Vec<_> = segs.iter().filter(|s| s.source.line == 3).collect();
        let stop = l3
            .iter()
            .position(|s| {
                s.kind
                    == SegmentKind::Spindle {
                        rpm: 0.0,
                        dir: SpindleDir::Stop,
                        spindle: 1,
                    }
            })
            .unwrap();
        assert_eq!(
            l3[stop + 1].kind,
            SegmentKind::SpindleOrient {
                angle,
                program: None,
                spindle: 1,
            },
            "{plane}"
        );
        let bottom = end(l3[stop - 1]).unwrap();
        let shifted = end(l3[stop + 2]).unwrap();
        assert_eq!(
            shifted[C], 200.0,
            "{plane}: program C unchanged by the orientation"
        );
        assert!(
            (shifted[shift_axis] - bottom[shift_axis] - 0.4).abs() < 1e-9,
            "{plane}"
        );
        let back = end(l3[stop + 4]).unwrap();
        assert_eq!(back[shift_axis], bottom[shift_axis]);
        assert_eq!(
            l3.last().unwrap().kind,
            SegmentKind::Spindle {
                rpm: 500.0,
                dir: SpindleDir::Cw,
                spindle: 1,
            }
        );
    }
}

/// G87 back boring: shifted rapid down to R (below the bore), shift back, spindle on, feed up to
/// Z, shift again and rapid out to the initial level. LinuxCNC's G87 takes I/J/K offsets instead
/// of Q and is not compared.
#[test]
fn g87_back_boring_sequence() {
    let segs = run("M3 S500\nG0 X0 Y0 Z10\nG87 X5 Y5 Z-4 R-20 Q1.5 F100\nM30\n");
    let seq: Vec<String> = segs
        .iter()
        .filter(|s| s.source.line == 3)
        .map(|s| match &s.kind {
            SegmentKind::Rapid { end } => format!("R{},{}", end[X], end[Z]),
            SegmentKind::Linear { end, .. } => format!("F{},{}", end[X], end[Z]),
            SegmentKind::Spindle { rpm, .. } => format!("S{rpm}"),
            SegmentKind::SpindleOrient { angle, .. } => format!("O{angle}"),
            k => format!("{k:?}"),
        })
        .collect();
    assert_eq!(
        seq,
        [
            "R5,10", "S0", "O0", "R6.5,10", "R6.5,-20", "R5,-20", "S500", "F5,-4", "S0", "O0",
            "R6.5,-4", "R6.5,10", "R5,10", "S500"
        ]
    );
}

/// G87 starts below the part: an R level above Z is an error at the Z word (at the block when
/// both are modal), in G90 and G91 and in every plane, before any of the hole's motion.
#[test]
fn g87_with_r_above_z_is_a_located_error() {
    let cfg = MachineConfig::default_machine();
    for (text, line, col) in [
        (
            "M3 S500\nG0 X0 Y0 Z10\nG87 X5 Y5 Z-20 R-4 Q1.5 F100\nM30\n",
            3,
            11,
        ),
        // G91: R -20 from the initial 10 is -10, Z -3 from there is -13, below R.
        (
            "M3 S500\nG0 X0 Y0 Z10\nG91 G87 X5 Y5 Z-3 R-20 Q1.5 F100\nM30\n",
            3,
            15,
        ),
        // G18 drills along Y.
        (
            "M3 S500\nG18 G0 X0 Z0 Y10\nG87 X5 Z5 Y-20 R-4 Q1 F100\nM30\n",
            3,
            11,
        ),
        // Modal data, a later hole: the error is at that block.
        (
            "M3 S500\nG0 X0 Y0 Z10\nG87 X5 Y5 Z-4 R-20 Q1.5 F100\nR0\nM30\n",
            4,
            1,
        ),
    ] {
        let e = run_program(&cfg, &SourceFile::new("t.nc", text)).unwrap_err();
        assert_eq!((e.line, e.col), (line, col), "{text}: {e}");
        assert!(
            e.message
                .contains("G87 (back boring) starts below the part: the R level must be below"),
            "{e}"
        );
    }
}

/// G88: feed, dwell, spindle stop, program stop (Fanuc: the operator retracts by hand), then on
/// restart a rapid to the return level and the spindle back on. LinuxCNC's G88 has no rapid out.
#[test]
fn g88_stops_at_the_bottom() {
    let segs = run("M3 S500\nG0 X0 Y0 Z10\nG99 G88 X1 Z-4 R2 P250 F100\nM30\n");
    let kinds: Vec<_> = segs
        .iter()
        .filter(|s| s.source.line == 3)
        .map(|s| &s.kind)
        .collect();
    assert!(matches!(kinds[3], SegmentKind::Dwell { seconds } if *seconds == 0.25));
    assert_eq!(
        *kinds[4],
        SegmentKind::Spindle {
            rpm: 0.0,
            dir: SpindleDir::Stop,
            spindle: 1,
        }
    );
    assert_eq!(
        *kinds[5],
        SegmentKind::Stop {
            kind: StopKind::Program
        }
    );
    assert!(matches!(kinds[6], SegmentKind::Rapid { end } if end[Z] == 2.0));
}

/// Cycle data is modal until G80 (Fanuc); a block without position words does not drill.
#[test]
fn cycle_data_is_modal_and_g80_clears_it() {
    let segs = run("G0 Z10\nG81 X1 Z-3 R2 F100\nF200\nX2\nG80\nX3\nM30\n");
    assert!(segs.iter().all(|s| s.source.line != 3));
    assert!(segs.iter().any(|s| s.source.line == 4
        && matches!(s.kind, SegmentKind::Linear { end, feed } if end[Z] == -3.0 && feed == 200.0)));
    // After G80, X3 is a plain G0 move (group 01 stays what it was).
    let l6: Vec<_> = segs.iter().filter(|s| s.source.line == 6).collect();
    assert_eq!(l6.len(), 1);
    assert!(matches!(l6[0].kind, SegmentKind::Rapid { end } if end[X] == 3.0 && end[Z] == 10.0));
    let e = run_program(
        &MachineConfig::default_machine(),
        &SourceFile::new("t.nc", "G0 Z10\nG81 X1 Z-3 R2 F100\nG80\nG81 X2 F100\n"),
    )
    .unwrap_err();
    assert_eq!(
        (e.line, e.message.as_str()),
        (4, "canned cycle G81 needs R (the R level)")
    );
}

/// The whole matrix: every cycle × G17/G18/G19 × G98/G99 × G90/G91 with two repeats. For each
/// hole the deepest point along the drilling axis is the bottom (the R level for G87, whose
/// bore is cut upwards), the tool never goes past it or above the initial level, it ends at the
/// return level, and the holes are where the (absolute or incremental) words put them.
#[test]
fn every_cycle_in_every_plane_mode_and_return() {
    // (plane code, hole-position axes, drilling axis, letters)
    let planes = [
        ("G17", (X, Y), Z, ('X', 'Y', 'Z')),
        ("G18", (Z, X), Y, ('Z', 'X', 'Y')),
        ("G19", (Y, Z), X, ('Y', 'Z', 'X')),
    ];
    let initial = 20.0;
    for (pcode, (ia, ib), id, (la, lb, ld)) in planes {
        for cyc in [73, 74, 76, 81, 82, 83, 84, 85, 86, 87, 88, 89] {
            for ret in [98, 99] {
                for inc in [false, true] {
                    let spindle = if cyc == 74 { "M4 S500" } else { "M3 S500" };
                    // Absolute levels: R 2, bottom -6 (G87: R -6 below, Z 2 above).
                    let (r_abs, z_abs) = if cyc == 87 { (-6.0, 2.0) } else { (2.0, -6.0) };
                    let (r_w, z_w) = if inc {
                        (r_abs - initial, z_abs - r_abs)
                    } else {
                        (r_abs, z_abs)
                    };
                    let (a_w, b_w) = if inc { (5.0, 3.0) } else { (15.0, 13.0) };
                    let prog = format!(
                        "{spindle}\nG0 X10 Y10 Z10\nG0 {ld}{initial}\n{pcode} {} G{ret} G{cyc} {la}{a_w} {lb}{b_w} {ld}{z_w} R{r_w} Q1.5 P100 K2 F500\nM30\n",
                        if inc { "G91" } else { "G90" }
                    );
                    let segs = run(&prog);
                    let hole_segs: Vec<_> = segs.iter().filter(|s| s.source.line == 4).collect();
                    let ends: Vec<AxisPos> = hole_segs.iter().filter_map(|s| end(s)).collect();
                    let lo = ends.iter().map(|e| e[id]).fold(f64::MAX, f64::min);
                    let hi = ends.iter().map(|e| e[id]).fold(f64::MIN, f64::max);
                    let deepest = if cyc == 87 { r_abs } else { z_abs };
                    assert!((lo - deepest).abs() < 1e-9, "{prog}: deepest {lo}");
                    assert!(
                        hi <= initial + 1e-9,
                        "{prog}: above the initial level: {hi}"
                    );
                    let last = *ends.last().unwrap();
                    let want_ret = if ret == 99 && cyc != 87 {
                        r_abs
                    } else {
                        initial
                    };
                    assert!(
                        (last[id] - want_ret).abs() < 1e-9,
                        "{prog}: ends at {}",
                        last[id]
                    );
                    // Hole positions: the feed moves' plane coordinates.
                    let mut holes: Vec<(f64, f64)> = hole_segs
                        .iter()
                        .filter_map(|s| match s.kind {
                            SegmentKind::Linear { end, .. }
                            | SegmentKind::Tap(TapSegment { end, .. }) => Some((end[ia], end[ib])),
                            _ => None,
                        })
                        .collect();
                    holes.dedup();
                    let want: Vec<(f64, f64)> = if inc {
                        let start = (10.0, 10.0);
                        vec![
                            (start.0 + 5.0, start.1 + 3.0),
                            (start.0 + 10.0, start.1 + 6.0),
                        ]
                    } else {
                        vec![(15.0, 13.0)]
                    };
                    assert_eq!(holes, want, "{prog}");
                    // Taps: C follows the drilling axis on every feed move.
                    if cyc == 74 || cyc == 84 {
                        let hand = if cyc == 84 { 1.0 } else { -1.0 };
                        let pitch = 1.0; // F500 / S500
                        for e in ends.iter().filter(|e| e[C] != 0.0) {
                            let want_c = hand * (r_abs - e[id]) * 360.0 / pitch;
                            assert!((e[C] - want_c).abs() < 1e-9, "{prog}");
                        }
                    }
                    // The spindle ends as it started: turning at S500.
                    let last_spindle = segs
                        .iter()
                        .filter_map(|s| match s.kind {
                            SegmentKind::Spindle { rpm, dir, .. } => Some((rpm, dir)),
                            _ => None,
                        })
                        .next_back()
                        .unwrap();
                    assert_eq!(last_spindle.0, 500.0, "{prog}");
                }
            }
        }
    }
}

/// M19 orients the spindle like G76/G87 do (stop, then `SpindleOrient` to the configured
/// angle), leaves it stopped and program C where it was; it shares the spindle M group.
#[test]
fn m19_stops_and_orients_the_spindle() {
    let mut cfg = MachineConfig::default_machine();
    cfg.interp.spindle_orient_angle = 123.25;
    let segs = run_cfg(&cfg, "G0 C30\nM3 S800\nM19\nG0 X5\nM30\n");
    let l3: Vec<_> = segs.iter().filter(|s| s.source.line == 3).collect();
    assert_eq!(l3.len(), 2);
    assert_eq!(
        l3[0].kind,
        SegmentKind::Spindle {
            rpm: 0.0,
            dir: SpindleDir::Stop,
            spindle: 1,
        }
    );
    assert_eq!(
        l3[1].kind,
        SegmentKind::SpindleOrient {
            angle: 123.25,
            program: None,
            spindle: 1,
        }
    );
    let after = segs.iter().find(|s| s.source.line == 4).unwrap();
    assert_eq!(end(after).unwrap()[C], 30.0);
    // The spindle stays stopped: a tap needs M3 (or M29) again.
    let e = run_program(
        &cfg,
        &SourceFile::new("t.nc", "M3 S500\nM19\nG0 Z10\nG84 Z-5 R2 F750\n"),
    )
    .unwrap_err();
    assert!(e.line == 4 && e.message.contains("M3"), "{e}");
    let e = run_program(&cfg, &SourceFile::new("t.nc", "M3 M19 S500\n")).unwrap_err();
    assert!(e.message.contains("M3 and M19"), "{e}");
    let mut no_c = cfg.clone();
    no_c.axes.truncate(3);
    let e = run_program(&no_c, &SourceFile::new("t.nc", "M19\n")).unwrap_err();
    assert!(e.message.contains("no spindle axis"), "{e}");
}
