//! Source 001 (MLT980 programming-free drilling): `examples/mlt980/O0001.CNC` run with the
//! variable pages filled through `nvfile::set_vars` (what `cnc402 vars set` calls), for every
//! hole pattern × every cycle the source lists × G98/G99. Checked from the segment stream:
//! hole positions, depths, return planes, spindle direction and speed, feeds, and that the
//! modal state O0001 saves at its start is restored at its end. Bad pages end in the alarms.

#![allow(clippy::type_complexity)]

use std::path::{Path, PathBuf};

use cnc402_config::MachineConfig;
use cnc402_interp::host_fs::{self, ProgramDir, VarsAccess};
use cnc402_interp::{Interpreter, nvfile};
use cnc402_lang::{NcError, SourceFile};
use cnc402_motion::segment::{Plane, Segment, SegmentKind, SpindleDir, StopKind};

const X: usize = 0;
const Y: usize = 1;
const Z: usize = 2;
const EPS: f64 = 1e-6;
/// G55 in the shipped config: X +100.
const OFF_X: f64 = 100.0;

fn examples() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../examples/mlt980")
}

/// A fresh variables file for one case.
fn var_file(tag: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("cnc402-mlt980-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let p = dir.join(format!("{tag}.vars"));
    let _ = std::fs::remove_file(&p);
    p
}

/// The modal state the operator's machine is in before O0001 (restored at its end): G1, G18, G91,
/// G55, F123, S456, T7. The driver calls O0001 as a sub-program; O0001's M30 ends the run.
const DRIVER: &str = "G18 G55 G91 G1 F123 S456 T7\nM98 P1\n";

struct Run {
    segs: Vec<Segment>,
    err: Option<NcError>,
    it: Interpreter,
}

fn run(tag: &str, vars: &[(u32, f64)]) -> Run {
    let path = var_file(tag);
    let sets: Vec<(u32, Option<f64>)> = vars.iter().map(|&(n, v)| (n, Some(v))).collect();
    nvfile::set_vars(&path, &sets).unwrap();
    let mut cfg = MachineConfig::default_machine();
    cfg.interp.variables_file = Some(path.clone());
    let mut it = Interpreter::new(&cfg);
    host_fs::attach_variables_file(&mut it, &cfg, VarsAccess::Write);
    it.set_program_library(Some(Box::new(ProgramDir::new(examples()))));
    let src = SourceFile::new("driver.nc", DRIVER);
    it.load(src.clone(), cnc402_lang::parse(&src).unwrap());
    let mut segs = Vec::new();
    let mut err = None;
    loop {
        match it.next_segment() {
            Ok(Some(s)) => segs.push(s),
            Ok(None) => break,
            Err(e) => {
                err = Some(e);
                break;
            }
        }
    }
    let _ = std::fs::remove_file(&path);
    Run { segs, err, it }
}

const CYCLES: [u32; 9] = [81, 82, 73, 83, 74, 84, 85, 76, 87];

/// Initial plane Z50 (work); R 45 below it (Z5); bottom 20 below R (Z-15). G87 (back boring):
/// R 70 below the initial plane (Z-20, the bore's underside), Z +15 up from there (Z-5).
fn process_vars(cycle: u32, ret: u32) -> Vec<(u32, f64)> {
    let back = cycle == 87;
    vec![
        (512, 50.0),
        (503, if back { -70.0 } else { -45.0 }),
        (502, if back { 15.0 } else { -20.0 }),
        (515, 6.0),
        (516, 1.0),
        (517, 1200.0),
        (519, f64::from(cycle)),
        (520, if cycle == 74 { 4.0 } else { 3.0 }),
        (521, 800.0),
        (522, 150.0),
        (523, 300.0),
        (524, f64::from(ret)),
    ]
}

/// (pattern number, its variables, the expected hole centres in work XY, whether order matters)
fn patterns() -> Vec<(u32, Vec<(u32, f64)>, Vec<(f64, f64)>, bool)> {
    let mut v = Vec::new();
    // 1 linear: from (10, 20), pitch (15, 5), 4 holes; the first is one pitch from the start.
    let lin: Vec<_> = (1..=4)
        .map(|k| (10.0 + 15.0 * k as f64, 20.0 + 5.0 * k as f64))
        .collect();
    v.push((
        1,
        vec![
            (500, 10.0),
            (501, 20.0),
            (509, 15.0),
            (510, 5.0),
            (511, 4.0),
        ],
        lin,
        true,
    ));
    // 2 arc: centre (50, 40), radius 30, from 10° in steps of 25°, 5 holes.
    let arc: Vec<_> = (0..5)
        .map(|k| {
            let a = (10.0 + 25.0 * k as f64).to_radians();
            (50.0 + 30.0 * a.cos(), 40.0 + 30.0 * a.sin())
        })
        .collect();
    v.push((
        2,
        vec![
            (500, 50.0),
            (501, 40.0),
            (504, 30.0),
            (505, 10.0),
            (506, 25.0),
            (507, 5.0),
        ],
        arc,
        true,
    ));
    // 3 ring: centre (50, 40), radius 20, from 0°, 6 holes (60° apart).
    let ring: Vec<_> = (0..6)
        .map(|k| {
            let a = (60.0 * k as f64).to_radians();
            (50.0 + 20.0 * a.cos(), 40.0 + 20.0 * a.sin())
        })
        .collect();
    v.push((
        3,
        vec![
            (500, 50.0),
            (501, 40.0),
            (504, 20.0),
            (505, 0.0),
            (507, 6.0),
        ],
        ring,
        true,
    ));
    // 4 grid: first hole (10, 10), pitch (12, 9), 3 rows × 4 columns.
    let mut grid = Vec::new();
    for r in 0..3 {
        for c in 0..4 {
            grid.push((10.0 + 12.0 * c as f64, 10.0 + 9.0 * r as f64));
        }
    }
    let gvars = vec![
        (500, 10.0),
        (501, 10.0),
        (509, 12.0),
        (510, 9.0),
        (508, 3.0),
        (511, 4.0),
    ];
    v.push((4, gvars.clone(), grid, false));
    // 5 staggered: as the grid, odd rows shifted by #525 = 6 in X.
    let mut stag = Vec::new();
    for r in 0..3 {
        for c in 0..4 {
            let shift = if r % 2 == 1 { 6.0 } else { 0.0 };
            stag.push((10.0 + 12.0 * c as f64 + shift, 10.0 + 9.0 * r as f64));
        }
    }
    let mut svars = gvars;
    svars.push((525, 6.0));
    v.push((5, svars, stag, false));
    v
}

fn end_of(s: &Segment) -> Option<cnc402_motion::segment::AxisPos> {
    match &s.kind {
        SegmentKind::Rapid { end }
        | SegmentKind::Linear { end, .. }
        | SegmentKind::Tap(cnc402_motion::segment::TapSegment { end, .. })
        | SegmentKind::Arc { end, .. } => Some(*end),
        _ => None,
    }
}

fn sorted(mut v: Vec<(f64, f64)>) -> Vec<(f64, f64)> {
    v.sort_by(|a, b| (a.0, a.1).partial_cmp(&(b.0, b.1)).unwrap());
    v
}

fn close(a: &[(f64, f64)], b: &[(f64, f64)]) -> bool {
    a.len() == b.len()
        && a.iter()
            .zip(b)
            .all(|(p, q)| (p.0 - q.0).abs() < EPS && (p.1 - q.1).abs() < EPS)
}

#[test]
fn every_pattern_every_cycle_both_return_planes() {
    let mut failures = Vec::new();
    let mut cases = 0;
    for (pat, pvars, holes, ordered) in patterns() {
        for cycle in CYCLES {
            for ret in [98u32, 99] {
                cases += 1;
                let mut vars = process_vars(cycle, ret);
                vars.extend(pvars.iter().copied());
                vars.push((530, f64::from(pat)));
                let tag = format!("p{pat}-g{cycle}-{ret}");
                let r = run(&tag, &vars);
                if std::env::var("MLT980_DUMP").as_deref() == Ok(tag.as_str()) {
                    for s in &r.segs {
                        eprintln!("{}:{} {:?}", s.source.file, s.source.line, s.kind);
                    }
                }
                if let Err(why) = check(&r, pat, cycle, ret, &holes, ordered) {
                    failures.push(format!("{tag}: {why}"));
                }
            }
        }
    }
    assert_eq!(cases, 5 * 9 * 2);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

fn check(
    r: &Run,
    _pat: u32,
    cycle: u32,
    ret: u32,
    holes: &[(f64, f64)],
    ordered: bool,
) -> Result<(), String> {
    if let Some(e) = &r.err {
        return Err(format!("error: {e}"));
    }
    let segs = &r.segs;
    let initial: f64 = 50.0;
    let back = cycle == 87;
    let r_level = initial + if back { -70.0 } else { -45.0 };
    let cut_end = r_level + if back { 15.0 } else { -20.0 };
    let lowest = r_level.min(cut_end);
    let ret_level = if ret == 99 && !back { r_level } else { initial };
    let feed = match cycle {
        74 | 84 | 76 | 87 => 1200.0,
        _ => 150.0,
    };
    // Holes: the feed moves (taps for G74/G84) that end at the cut's end level.
    let mut found = Vec::new();
    let mut hole_idx = Vec::new();
    for (i, s) in segs.iter().enumerate() {
        let feed_end = match &s.kind {
            SegmentKind::Linear { end, feed } if !matches!(cycle, 74 | 84) => Some((end, feed)),
            SegmentKind::Tap(t) if matches!(cycle, 74 | 84) => Some((&t.end, &t.feed)),
            _ => None,
        };
        if let Some((end, f)) = feed_end
            && (end[Z] - cut_end).abs() < EPS
        {
            if (f - feed).abs() > EPS {
                return Err(format!("hole feed {f}, want {feed}"));
            }
            found.push((end[X] - OFF_X, end[Y]));
            hole_idx.push(i);
        }
    }
    let (want, got) = if ordered {
        (holes.to_vec(), found.clone())
    } else {
        (sorted(holes.to_vec()), sorted(found.clone()))
    };
    if !close(&want, &got) {
        return Err(format!("holes {got:?}, want {want:?}"));
    }
    // Depth: nothing goes below the lowest level; everything between holes stays at or
    // below the return level, which is reached after every hole.
    let min_z = segs
        .iter()
        .filter_map(end_of)
        .map(|e| e[Z])
        .fold(f64::INFINITY, f64::min);
    if (min_z - lowest).abs() > EPS {
        return Err(format!("lowest Z {min_z}, want {lowest}"));
    }
    for (k, &i) in hole_idx.iter().enumerate() {
        let stop = hole_idx.get(k + 1).copied().unwrap_or(segs.len());
        let max_z = segs[i..stop]
            .iter()
            .filter_map(end_of)
            .map(|e| e[Z])
            .fold(f64::NEG_INFINITY, f64::max);
        if (max_z - ret_level).abs() > EPS {
            return Err(format!(
                "after hole {k}: highest Z {max_z}, want return level {ret_level}"
            ));
        }
    }
    // Spindle: every start is the page's direction at S800; the last spindle segment stops it.
    let dir = if cycle == 74 {
        SpindleDir::Ccw
    } else {
        SpindleDir::Cw
    };
    let spindle: Vec<_> = segs
        .iter()
        .filter_map(|s| match s.kind {
            SegmentKind::Spindle { rpm, dir, .. } => Some((rpm, dir)),
            _ => None,
        })
        .collect();
    if spindle.first() != Some(&(800.0, dir)) {
        return Err(format!(
            "first spindle command {:?}, want 800 {dir:?}",
            spindle.first()
        ));
    }
    if let Some(bad) = spindle
        .iter()
        .find(|s| s.1 != SpindleDir::Stop && *s != &(800.0, dir))
    {
        return Err(format!("spindle command {bad:?}"));
    }
    if spindle.last().map(|s| s.1) != Some(SpindleDir::Stop) {
        return Err("the spindle is not stopped at the end".into());
    }
    // The run ends with M30 and the state saved at O0001's start is back.
    if !matches!(
        segs.last().map(|s| &s.kind),
        Some(SegmentKind::Stop {
            kind: StopKind::EndRewind
        })
    ) {
        return Err("no M30 at the end".into());
    }
    let st = r.it.state();
    let restored = (
        st.motion,
        st.plane,
        st.incremental,
        st.work_offset,
        st.feed,
        st.speed,
        st.tool_selected,
        st.cycle,
    );
    let want = (
        cnc402_interp::state::Motion::Linear,
        Plane::ZX,
        true,
        1,
        123.0,
        456.0,
        7,
        None,
    );
    if restored != want {
        return Err(format!(
            "modal state at the end {restored:?}, want {want:?}"
        ));
    }
    Ok(())
}

/// A good page for pattern 1 with G81.
fn good() -> Vec<(u32, f64)> {
    let mut v = process_vars(81, 98);
    v.extend([
        (500, 10.0),
        (501, 20.0),
        (509, 15.0),
        (510, 5.0),
        (511, 4.0),
        (530, 1.0),
    ]);
    v
}

fn with(mut v: Vec<(u32, f64)>, n: u32, x: Option<f64>) -> Vec<(u32, f64)> {
    v.retain(|p| p.0 != n);
    if let Some(x) = x {
        v.push((n, x));
    }
    v
}

fn o0001_line(n: u32) -> u32 {
    let text = std::fs::read_to_string(examples().join("O0001.CNC")).unwrap();
    let pre = format!("N{n} ");
    text.lines().position(|l| l.starts_with(&pre)).unwrap() as u32 + 1
}

#[test]
fn bad_pages_end_in_the_sources_alarms_at_their_lines() {
    let cases: Vec<(Vec<(u32, f64)>, &str, u32, &str)> = vec![
        (
            with(good(), 520, Some(5.0)),
            "O0001.CNC",
            o0001_line(101),
            "alarm 501",
        ),
        (
            with(good(), 520, None),
            "O0001.CNC",
            o0001_line(101),
            "alarm 501",
        ),
        (
            with(good(), 524, Some(97.0)),
            "O0001.CNC",
            o0001_line(102),
            "alarm 502",
        ),
        (
            with(good(), 524, None),
            "O0001.CNC",
            o0001_line(102),
            "alarm 502",
        ),
        (
            with(good(), 519, Some(86.0)),
            "O0001.CNC",
            o0001_line(103),
            "alarm 503",
        ),
        (
            with(good(), 519, Some(84.0))
                .into_iter()
                .chain([(520, 4.0)])
                .collect::<Vec<_>>(),
            "O0001.CNC",
            o0001_line(104),
            "alarm 504",
        ),
        (
            with(good(), 512, None),
            "O0001.CNC",
            o0001_line(105),
            "alarm 505",
        ),
        (with(good(), 530, Some(6.0)), "O9006.CNC", 4, "alarm 508"),
        (with(good(), 530, None), "O9006.CNC", 4, "alarm 508"),
        (
            with(with(good(), 530, Some(3.0)), 507, Some(0.0)),
            "O9003.CNC",
            40,
            "alarm 507",
        ),
    ];
    for (i, (vars, file, line, msg)) in cases.into_iter().enumerate() {
        let vars = if i == 5 {
            with(vars, 520, Some(4.0))
        } else {
            vars
        };
        let r = run(&format!("bad{i}"), &vars);
        let e = r.err.unwrap_or_else(|| panic!("case {i}: no alarm"));
        assert!(e.file.ends_with(file), "case {i}: {e}");
        assert_eq!(e.line, line, "case {i}: {e}");
        assert!(e.message.starts_with(msg), "case {i}: {e}");
        // Nothing was drilled before the alarm.
        assert!(
            !r.segs
                .iter()
                .any(|s| matches!(s.kind, SegmentKind::Linear { .. })),
            "case {i}: cut before the alarm"
        );
    }
}

#[test]
fn damaged_variables_file_is_an_error_at_start() {
    let path = var_file("damaged");
    nvfile::set_vars(&path, &[(520, Some(3.0))]).unwrap();
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("520 3.0", "520 4.0");
    std::fs::write(&path, text).unwrap();
    let mut cfg = MachineConfig::default_machine();
    cfg.interp.variables_file = Some(path.clone());
    let mut it = Interpreter::new(&cfg);
    host_fs::attach_variables_file(&mut it, &cfg, VarsAccess::Write);
    let src = SourceFile::new("t.nc", "G0 X#520\n");
    it.load(src.clone(), cnc402_lang::parse(&src).unwrap());
    let e = it.next_segment().unwrap_err();
    assert!(e.message.contains("checksum mismatch"), "{e}");
    assert_eq!(it.next_segment().unwrap(), None);
    let _ = std::fs::remove_file(&path);
}
