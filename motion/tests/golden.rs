//! Golden output: the setpoint stream (drive counts per tick) of a small known program — a
//! rapid, a line, a helix, a dwell, a rigid tap down and up, a spindle run with a move, M5 —
//! is a fixture. A change to planning or interpolation shows up here as a diff to review.
//! Regenerate with `CNC402_UPDATE_GOLDEN=1 cargo test -p cnc402-motion --test golden`.

mod common;

use std::fmt::Write;

use cnc402_config::MachineConfig;
use cnc402_motion::*;
use common::*;

const FIXTURE: &str = "tests/fixtures/golden_setpoints.csv";

fn program() -> Vec<Segment> {
    vec![
        rapid(xyzc(10.0, 5.0, 2.0, 0.0), 1),
        lin(xyzc(20.0, 5.0, 0.0, 0.0), 1200.0, 2),
        seg(
            SegmentKind::Arc {
                end: xyzc(20.0, 15.0, -1.0, 0.0),
                center: [20.0, 10.0, 0.0],
                plane: Plane::XY,
                dir: ArcDir::Ccw,
                turns: 0,
                feed: 900.0,
            },
            3,
        ),
        seg(SegmentKind::Dwell { seconds: 0.02 }, 4),
        lin(xyzc(20.0, 15.0, -4.0, 3.0 / 1.5 * 360.0), 1500.0 * 1.5, 5),
        lin(xyzc(20.0, 15.0, -1.0, 0.0), 1500.0 * 1.5, 6),
        seg(
            SegmentKind::Spindle {
                rpm: 1200.0,
                dir: SpindleDir::Cw,
                spindle: 1,
            },
            7,
        ),
        lin(xyzc(25.0, 15.0, -1.0, 0.0), 3000.0, 8),
        seg(
            SegmentKind::Spindle {
                rpm: 0.0,
                dir: SpindleDir::Stop,
                spindle: 1,
            },
            9,
        ),
    ]
}

fn render(c: &MachineConfig, ticks: &[Tick]) -> String {
    let mut out = String::from("tick,line,X,Y,Z,C\n");
    for (k, t) in ticks.iter().enumerate() {
        let _ = write!(out, "{k},{}", t.line);
        for (i, ax) in c.axes.iter().enumerate() {
            let _ = write!(
                out,
                ",{}",
                to_counts_wrapping(t.pos.0[i], ax.counts_per_unit)
            );
        }
        out.push('\n');
    }
    out
}

#[test]
fn setpoint_stream_of_a_known_program_matches_the_fixture() {
    let c = MachineConfig::default_machine();
    let ticks = run(&c, AxisPos::default(), &program());
    let got = render(&c, &ticks);
    if std::env::var_os("CNC402_UPDATE_GOLDEN").is_some() {
        std::fs::write(FIXTURE, &got).expect("write fixture");
    }
    let want = std::fs::read_to_string(FIXTURE).expect("fixture present");
    if got != want {
        let (g, w): (Vec<&str>, Vec<&str>) = (got.lines().collect(), want.lines().collect());
        let first = g
            .iter()
            .zip(&w)
            .position(|(a, b)| a != b)
            .unwrap_or(g.len().min(w.len()));
        panic!(
            "setpoints differ from {FIXTURE} at row {first}: got {:?}, want {:?} ({} vs {} rows)",
            g.get(first),
            w.get(first),
            g.len(),
            w.len()
        );
    }
    // Facts a reader of the fixture can check by hand: it ends where the program ends, the
    // tap returns to C = 0 (no spindle offset yet), and M5 leaves C where it stopped.
    let last = ticks.last().unwrap();
    assert_eq!(last.pos.0[0], 25.0);
    let tap_end = ticks.iter().rfind(|t| t.line == 6).unwrap();
    assert_eq!(tap_end.pos, xyzc(20.0, 15.0, -1.0, 0.0));
}
