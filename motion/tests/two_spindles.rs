//! Two spindles in the planner and interpolator: each spindle's speed mode, override and
//! orientation act on its own axis (spindle 1 = C, axis 3; spindle 2 = U, axis 4), both
//! may turn at once, and a stop brings both to rest.

mod common;

use cnc402_config::MachineConfig;
use cnc402_motion::*;
use common::*;

const C: usize = 3;
const U: usize = 4;

/// The default machine with a second spindle U (node 5, max 4000 rpm).
fn two_spindles() -> MachineConfig {
    let text = include_str!("../../config/machine.toml")
        .replace("period_us = 1000", "period_us = 2000")
        + "\n[[axis]]\nname = \"U\"\nkind = \"spindle\"\nnode = 5\ncounts_per_rev = 131072\n\
           max_velocity = 24000.0\nmax_acceleration = 24000.0\nmax_jerk = 480000.0\n\
           max_rpm = 4000.0\nfollowing_error_window = 90.0\n\
           dynamics = { delay_cycles = 1, bandwidth_hz = 150.0 }\n";
    MachineConfig::parse(&text, std::path::Path::new("m.toml")).unwrap()
}

fn spin(rpm: f64, dir: SpindleDir, spindle: u8, line: u32) -> Segment {
    seg(SegmentKind::Spindle { rpm, dir, spindle }, line)
}

fn orient(angle: f64, spindle: u8, line: u32) -> Segment {
    seg(
        SegmentKind::SpindleOrient {
            angle,
            program: None,
            spindle,
        },
        line,
    )
}

#[test]
fn both_spindles_turn_at_once_each_on_its_own_axis() {
    let cfg = two_spindles();
    let ticks = run(
        &cfg,
        AxisPos::default(),
        &[
            spin(3000.0, SpindleDir::Cw, 1, 1),
            spin(2000.0, SpindleDir::Ccw, 2, 2),
            lin(xyzc(50.0, 0.0, 0.0, 0.0), 6000.0, 3),
            spin(0.0, SpindleDir::Stop, 1, 4),
        ],
    );
    let on_move: Vec<&Tick> = ticks.iter().filter(|t| t.line == 3).collect();
    assert!(on_move.len() > 100);
    for w in on_move.windows(2) {
        let p = cfg.bus.period_s();
        assert!(((w[1].pos[C] - w[0].pos[C]) / p - 18000.0).abs() < 1e-6);
        assert!(((w[1].pos[U] - w[0].pos[U]) / p + 12000.0).abs() < 1e-6);
        assert_eq!(w[1].spindle_velocity, [18000.0, -12000.0]);
    }
    // M5 of spindle 1 ends with C at rest; U still turns.
    let last = ticks.last().unwrap();
    assert_eq!(last.spindle_velocity, [0.0, -12000.0]);
}

#[test]
fn an_override_and_an_orientation_act_on_their_own_spindle() {
    let cfg = two_spindles();
    let mut planner = Planner::new(&cfg);
    let mut ip = Interpolator::new(&cfg, AxisPos::default());
    let mut go = |ip: &mut Interpolator, s: &Segment| {
        ip.start(planner.plan(s).expect("plans")).expect("starts");
        let mut t = ip.tick();
        for _ in 0..100_000 {
            if t.finished {
                return t;
            }
            t = ip.tick();
        }
        panic!("runaway");
    };
    let t = go(&mut ip, &spin(1000.0, SpindleDir::Cw, 1, 1));
    assert_eq!(t.spindle_velocity, [6000.0, 0.0]);
    ip.set_spindle_override_of(2, 1.2);
    let t = go(&mut ip, &spin(1000.0, SpindleDir::Cw, 2, 2));
    assert!((t.spindle_velocity[1] - 7200.0).abs() < 1e-9, "{t:?}");
    assert_eq!(t.spindle_velocity[0], 6000.0, "spindle 1 keeps 100 %");
    // Spindle 2 stops and orients to 90° while spindle 1 turns on.
    go(&mut ip, &spin(0.0, SpindleDir::Stop, 2, 3));
    let t = go(&mut ip, &orient(90.0, 2, 4));
    assert!((t.pos[U].rem_euclid(360.0) - 90.0).abs() < 1e-9, "{t:?}");
    assert_eq!(t.spindle_velocity[0], 6000.0);
    // Spindle 1 runs: its orientation is refused by the planner.
    let e = planner.plan(&orient(0.0, 1, 5)).unwrap_err();
    assert_eq!(e.kind, MotionErrorKind::SpindleRunning);
    // A stop ramps spindle 1 down; held only once it is at rest.
    ip.request_stop();
    let mut held = false;
    for _ in 0..100_000 {
        let t = ip.tick();
        if ip.is_held() {
            assert_eq!(t.spindle_velocity, [0.0, 0.0]);
            held = true;
            break;
        }
    }
    assert!(held);
}

#[test]
fn a_spindle_the_machine_lacks_is_an_error() {
    let one = MachineConfig::default_machine();
    let mut planner = Planner::new(&one);
    for s in [
        spin(100.0, SpindleDir::Cw, 2, 1),
        orient(0.0, 2, 1),
        spin(1.0, SpindleDir::Cw, 0, 1),
    ] {
        let e = planner.plan(&s).unwrap_err();
        assert!(matches!(e.kind, MotionErrorKind::NoSpindle { .. }), "{e:?}");
    }
    let e = planner
        .plan(&spin(100.0, SpindleDir::Cw, 2, 1))
        .unwrap_err();
    assert!(e.to_string().contains("spindle 2"), "{e}");
    // A tap coupling Z with spindle 2's axis.
    let cfg = two_spindles();
    let mut planner = Planner::new(&cfg);
    let mut end = AxisPos::default();
    (end.0[2], end.0[U]) = (-3.0, 720.0);
    let tap = seg(
        SegmentKind::Tap(TapSegment {
            end,
            feed: 300.0,
            tool: 2,
            spindle: U as u8,
            pitch: -1.5,
        }),
        1,
    );
    assert!(planner.plan(&tap).is_ok());
}
