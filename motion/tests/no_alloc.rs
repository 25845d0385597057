//! Proves the per-tick path allocates nothing: a counting global allocator, and `start()` /
//! `tick()` / `request_stop()` run over lines, arcs, taps, spindle ramps, dwells, events and a
//! stop with the counter armed.

mod common;

use cnc402_config::MachineConfig;
use cnc402_motion::*;
use common::*;

use cnc402_testkit::{CountingAlloc, allocs, arm};

#[global_allocator]
static GLOBAL: CountingAlloc = CountingAlloc;

#[test]
fn ticks_and_starts_allocate_nothing() {
    let c = MachineConfig::default_machine();
    let segs = vec![
        seg(
            SegmentKind::Spindle {
                rpm: 2000.0,
                dir: SpindleDir::Cw,
                spindle: 1,
            },
            1,
        ),
        rapid(xyzc(10.0, 5.0, 2.0, 0.0), 2),
        lin(xyzc(30.0, 5.0, 0.0, 0.0), 1200.0, 3),
        seg(
            SegmentKind::Arc {
                end: xyzc(40.0, 15.0, -1.0, 0.0),
                center: [30.0, 15.0, 0.0],
                plane: Plane::XY,
                dir: ArcDir::Ccw,
                turns: 1,
                feed: 2000.0,
            },
            4,
        ),
        seg(SegmentKind::Dwell { seconds: 0.05 }, 5),
        seg(
            SegmentKind::Message {
                text: "tap next".into(),
            },
            6,
        ),
        seg(
            SegmentKind::Spindle {
                rpm: 0.0,
                dir: SpindleDir::Stop,
                spindle: 1,
            },
            7,
        ),
        // G76-style orientation from wherever the M3 … M5 run stopped.
        seg(
            SegmentKind::SpindleOrient {
                angle: 271.5,
                program: None,
                spindle: 1,
            },
            7,
        ),
        lin(xyzc(40.0, 15.0, -16.0, 15.0 / 1.5 * 360.0), 600.0 * 1.5, 8),
        lin(xyzc(40.0, 15.0, -1.0, 0.0), 600.0 * 1.5, 9),
        seg(
            SegmentKind::Spindle {
                rpm: 3000.0,
                dir: SpindleDir::Ccw,
                spindle: 1,
            },
            10,
        ),
        lin(xyzc(0.0, 0.0, -1.0, 0.0), 3000.0, 11),
    ];
    // Planning happens off the real-time path; plan everything first.
    let mut planner = Planner::new(&c);
    let planned: Vec<PlannedMove> = segs.iter().map(|s| planner.plan(s).unwrap()).collect();
    let mut ip = Interpolator::new(&c, AxisPos::default());
    let mut ticks = 0u64;
    let mut sum = 0.0;

    let before = allocs();
    arm(true);
    let mut started = 0;
    for (i, mv) in planned.iter().enumerate() {
        if ip.start(*mv).is_err() {
            break;
        }
        started += 1;
        loop {
            let t = ip.tick();
            ticks += 1;
            sum += t.pos.0[0] + t.pos.0[3];
            // Stop half-way through the last move.
            if i == planned.len() - 1 && ticks % 1000 == 999 {
                ip.request_stop();
            }
            if t.finished || t.state == TickState::Held {
                break;
            }
        }
    }
    while !ip.is_held() {
        sum += ip.tick().pos.0[3];
        ticks += 1;
    }
    arm(false);

    assert!(ip.is_held());
    assert_eq!(started, planned.len(), "every move ran");
    assert!(ticks > 3000, "{ticks}");
    assert!(sum.is_finite());
    assert_eq!(
        allocs() - before,
        0,
        "allocations in start/tick/request_stop"
    );
}

#[test]
fn the_counter_sees_allocations() {
    // The check above can fail: an allocation while armed is counted.
    let before = allocs();
    arm(true);
    let v: Vec<u64> = std::hint::black_box(Vec::with_capacity(16));
    arm(false);
    drop(v);
    assert!(allocs() > before);
}
