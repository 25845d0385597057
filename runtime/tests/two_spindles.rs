//! Source 001's machine on the embedded simulator: five feed axes and two spindles on one
//! bus (`examples/two-spindles/machine.toml`, 1750 µs). Both spindles turn at once, each at
//! its own speed and direction, while the feed axes move; then a rigid tap on spindle 2
//! (Z with U) and one on spindle 1 (Z with C), each coupled within a count.

use std::io::Write;
use std::sync::{Arc, Mutex};

use cnc402_config::MachineConfig;
use cnc402_lang::SourceFile;
use cnc402_runtime::{RunOptions, RunReport, run_program};

const DIR: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/../examples/two-spindles");

/// A `Write` the test keeps a handle on (the run takes the trace writer by value).
#[derive(Clone, Default)]
struct Shared(Arc<Mutex<Vec<u8>>>);
impl Write for Shared {
    fn write(&mut self, b: &[u8]) -> std::io::Result<usize> {
        self.0.lock().unwrap().extend_from_slice(b);
        Ok(b.len())
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Ok(())
    }
}

fn machine() -> MachineConfig {
    MachineConfig::load(format!("{DIR}/machine.toml")).unwrap_or_else(|e| panic!("{e}"))
}

/// Runs `text` on the two-spindle machine: the report and the trace's rows (t, line, then
/// per axis cmd and act) with its header.
fn run(text: &str) -> (RunReport, Vec<String>, Vec<Vec<f64>>) {
    let cfg = machine();
    let src = SourceFile::new("two.nc", text);
    let ast = cnc402_lang::parse(&src).unwrap();
    let trace = Shared::default();
    let opts = RunOptions {
        trace: Some(Box::new(trace.clone())),
        ..RunOptions::default()
    };
    let r = run_program(&cfg, src, ast, opts, &mut |_| {}).unwrap_or_else(|e| panic!("{e:?}"));
    assert!(r.ok, "{:?}", r.error);
    let csv = String::from_utf8(trace.0.lock().unwrap().clone()).unwrap();
    let mut lines = csv.lines();
    let head = lines.next().unwrap().split(',').map(String::from).collect();
    let rows = lines
        .map(|l| {
            l.split(',')
                .map(|f| f.parse().unwrap_or(f64::NAN))
                .collect()
        })
        .collect();
    (r, head, rows)
}

#[test]
fn the_example_machine_loads_at_the_period_its_bus_needs() {
    let cfg = machine();
    let names: String = cfg.axes.iter().map(|a| a.name).collect();
    assert_eq!(names, "XYZABCU");
    assert_eq!(cfg.spindle_axes(), [Some(5), Some(6)]);
    assert_eq!(cfg.bus.period_us, 1750);
    let load = cnc402_config::busload::BusLoad::of_machine(&cfg);
    assert!(load.fits() && load.percent() > 90.0, "{}", load.percent());
}

#[test]
fn both_spindles_turn_at_once_each_at_its_own_speed_while_the_axes_move() {
    let (r, head, rows) = run(
        "%\nG21 G90 G94\nM3 S2000 P1\nM4 S1500 P2\nG1 X40. A15. F3000.\n\
         M5\nM5 P1\nM30\n%\n",
    );
    let col = |name: &str| head.iter().position(|h| h == name).unwrap();
    let (t, line, c, u, x) = (
        col("t"),
        col("line"),
        col("C_cmd"),
        col("U_cmd"),
        col("X_cmd"),
    );
    // On the feed line (5) both spindle axes advance every cycle at their own speed.
    let feed: Vec<&Vec<f64>> = rows.iter().filter(|v| v[line] == 5.0).collect();
    assert!(feed.len() > 100, "{}", feed.len());
    let period = feed[1][t] - feed[0][t];
    for w in feed.windows(2) {
        let dc = (w[1][c] - w[0][c]) / period;
        let du = (w[1][u] - w[0][u]) / period;
        assert!((dc - 2000.0 * 6.0).abs() < 1e-6, "C at {dc} deg/s");
        assert!((du + 1500.0 * 6.0).abs() < 1e-6, "U at {du} deg/s");
    }
    assert!(feed.last().unwrap()[x] > feed[0][x], "X moves meanwhile");
    // M5 stops spindle 2 (selected by the last P) and leaves spindle 1 turning.
    let stop2: Vec<&Vec<f64>> = rows.iter().filter(|v| v[line] == 6.0).collect();
    let (first, last) = (stop2[0], stop2[stop2.len() - 1]);
    assert!(
        last[c] - first[c] > 0.0,
        "spindle 1 still turns during M5 of spindle 2"
    );
    let end = rows.last().unwrap();
    let before = &rows[rows.len() - 2];
    assert_eq!(
        (end[c], end[u]),
        (before[c], before[u]),
        "both at rest at the end"
    );
    let cax = &r.axes[5];
    assert!(cax.max_following_error < 90.0, "{cax:?}");
}

#[test]
fn a_rigid_tap_on_spindle_2_couples_z_with_u_within_a_count() {
    let text = std::fs::read_to_string(format!("{DIR}/two-spindles.nc")).unwrap();
    let (r, _, _) = run(&text);
    assert_eq!(r.tapping.len(), 3, "{:?}", r.tapping);
    let count_um = 0.1; // Z: 10 000 counts/mm
    for (k, tap) in r.tapping.iter().enumerate() {
        eprintln!(
            "tap {k} (line {}): {:.4} µm setpoints, {:.4} µm actual",
            tap.line, tap.max_coupling_error_um_cmd, tap.max_coupling_error_um_act
        );
        assert!((tap.pitch_observed_mm - 1.5).abs() < 1e-6, "{tap:?}");
        assert!(tap.max_coupling_error_um_cmd <= count_um, "{tap:?}");
        assert!(tap.max_coupling_error_um_act <= count_um + 1e-9, "{tap:?}");
    }
    // Lines 14 and 15 tap with U (spindle 2); C did not move there.
    assert_eq!(
        (r.tapping[0].line, r.tapping[1].line, r.tapping[2].line),
        (14, 15, 18)
    );
}

#[test]
fn spindle_2_taps_while_spindle_1_turns() {
    let (r, head, rows) = run(
        "%\nG21 G90 G94\nG0 X20. Y20. Z10.\nM3 S3000 P1\nM29 S800 P2\n\
         G98 G84 X20. Y20. Z-16. R3. F1200.\nG80\nM5 P1\nM30\n%\n",
    );
    assert_eq!(r.tapping.len(), 1, "{:?}", r.tapping);
    let tap = &r.tapping[0];
    eprintln!(
        "tap on spindle 2 with spindle 1 at 3000 rpm: {:.4} µm setpoints, {:.4} µm actual",
        tap.max_coupling_error_um_cmd, tap.max_coupling_error_um_act
    );
    assert!(tap.max_coupling_error_um_cmd <= 0.1, "{tap:?}");
    assert!(tap.max_coupling_error_um_act <= 0.1 + 1e-9, "{tap:?}");
    // C turns at 3000 rpm through the whole tap (line 6).
    let col = |name: &str| head.iter().position(|h| h == name).unwrap();
    let (line, c, u) = (col("line"), col("C_cmd"), col("U_cmd"));
    let in_tap: Vec<&Vec<f64>> = rows.iter().filter(|v| v[line] == 6.0).collect();
    let turned_u = in_tap.iter().map(|v| v[u]).fold(f64::MIN, f64::max);
    assert!(turned_u > 4000.0, "U turns with Z: {turned_u}");
    for w in in_tap.windows(2) {
        let dc = w[1][c] - w[0][c];
        assert!((dc - 3000.0 * 6.0 * 0.00175).abs() < 1e-6, "C step {dc}");
    }
}
