//! The spindle in speed mode for longer than 2^31 counts (and 2^31 + 2^32): C keeps counting as an
//! unwrapped f64 with no jump, and `to_counts_wrapping` gives INT32 setpoints whose
//! tick-to-tick difference is always the true count difference, across both wraps.

mod common;

use cnc402_config::MachineConfig;
use cnc402_motion::*;
use common::*;

#[test]
fn spindle_runs_past_two_wraps_of_int32_counts_without_a_jump() {
    let c = MachineConfig::default_machine();
    let ci = c.spindle_index().unwrap();
    let cpu = c.axes[ci].counts_per_unit;
    assert!((cpu - 131072.0 / 360.0).abs() < 1e-12);
    let mut planner = Planner::new(&c);
    let mut ip = Interpolator::new(&c, AxisPos::default());
    let on = seg(
        SegmentKind::Spindle {
            rpm: 6000.0,
            dir: SpindleDir::Cw,
            spindle: 1,
        },
        1,
    );
    ip.start(planner.plan(&on).unwrap()).unwrap();

    let per_tick = 36000.0 * 1e-3 * cpu; // 13107.2 counts at speed
    let mut prev = ip.position().0[ci];
    let mut prev_counts = to_counts_wrapping(prev, cpu);
    let mut wraps = 0;
    let mut at_speed = false;
    let mut k = 0u64;
    // Wraps at 2^31 and 2^31 + 2^32 counts: 49152 turns at 100 rev/s ≈ 492 s of spindle.
    while prev * cpu < 3.0 * 2f64.powi(31) + 1e6 {
        let t = ip.tick();
        k += 1;
        let pos = t.pos.0[ci];
        let counts = to_counts_wrapping(pos, cpu);
        let d = counts.wrapping_sub(prev_counts) as i64;
        let ideal = ((pos * cpu).round() - (prev * cpu).round()) as i64;
        assert_eq!(d, ideal, "tick {k}");
        if at_speed {
            assert!((pos - prev - 36.0).abs() < 1e-6, "tick {k}: {}", pos - prev);
            assert!((d as f64 - per_tick).abs() <= 1.0, "tick {k}: {d}");
        }
        at_speed |= t.finished;
        if counts < prev_counts {
            wraps += 1;
        }
        prev = pos;
        prev_counts = counts;
    }
    assert!(at_speed);
    assert_eq!(wraps, 2, "crossed i32::MAX twice");
    // Exactness: the position is computed from the ramp start, not summed tick by tick; at
    // constant speed it equals the analytic value to a few ulp.
    let ramp = 36000.0 / 36000.0 + 36000.0 / 720000.0;
    let expect = 36000.0 * (k as f64 * 1e-3) - 36000.0 * ramp / 2.0;
    assert!((prev - expect).abs() < 1e-6, "{prev} {expect}");

    // M5: it stops, and C stays where it stopped.
    let off = seg(
        SegmentKind::Spindle {
            rpm: 0.0,
            dir: SpindleDir::Stop,
            spindle: 1,
        },
        2,
    );
    ip.start(planner.plan(&off).unwrap()).unwrap();
    loop {
        let t = ip.tick();
        assert!(t.pos.0[ci] >= prev);
        assert!(t.pos.0[ci] - prev <= 36.0 + 1e-9);
        prev = t.pos.0[ci];
        if t.finished {
            break;
        }
    }
    for _ in 0..10 {
        assert_eq!(ip.tick().pos.0[ci], prev);
    }
    assert_eq!(ip.spindle_offset(), prev);
}
