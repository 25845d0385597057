//! CPU time per interpolator tick, 4 axes (X Y Z C of the shipped machine), for a line, an
//! arc (helix), a tap and a line with the spindle in speed mode; target ≤ 2 µs per tick. Peer
//! in the same run: Ruckig (rsruckig) sampling a 4-DoF trajectory for one period, the per-tick
//! work of a generator that allocates nothing in steady state.

use std::hint::black_box;
use std::sync::Arc;

use cnc402_config::MachineConfig;
use cnc402_motion::*;
use criterion::{Criterion, criterion_group, criterion_main};
use rsruckig::prelude::*;

fn seg(kind: SegmentKind) -> Segment {
    Segment {
        kind,
        source: Source {
            file: Arc::from("bench.nc"),
            line: 1,
            n: None,
        },
        ends: SegmentEnd::ExactStop,
    }
}

fn p(x: f64, y: f64, z: f64, c: f64) -> AxisPos {
    let mut a = AxisPos::default();
    a.0[..4].copy_from_slice(&[x, y, z, c]);
    a
}

/// Ticks through `there` and `back` forever, starting the next move when one finishes.
fn bench_moves(c: &mut Criterion, name: &str, pre: &[Segment], there: Segment, back: Segment) {
    let cfg = MachineConfig::default_machine();
    let mut planner = Planner::new(&cfg);
    let mut ip = Interpolator::new(&cfg, AxisPos::default());
    for s in pre {
        ip.start(planner.plan(s).unwrap()).unwrap();
        while !ip.tick().finished {}
    }
    let moves = [planner.plan(&there).unwrap(), planner.plan(&back).unwrap()];
    let mut i = 0;
    ip.start(moves[0]).unwrap();
    c.bench_function(name, |b| {
        b.iter(|| {
            let t = ip.tick();
            if t.finished {
                i ^= 1;
                ip.start(moves[i]).unwrap();
            }
            black_box(t)
        })
    });
}

fn ticks(c: &mut Criterion) {
    let start = p(0.0, 0.0, 0.0, 0.0);
    bench_moves(
        c,
        "tick_line_4axes",
        &[],
        seg(SegmentKind::Linear {
            end: p(100.0, 50.0, -10.0, 0.0),
            feed: 6000.0,
        }),
        seg(SegmentKind::Linear {
            end: start,
            feed: 6000.0,
        }),
    );
    let arc = |end, center: [f64; 3], dir| {
        seg(SegmentKind::Arc {
            end,
            center,
            plane: Plane::XY,
            dir,
            turns: 1,
            feed: 3000.0,
        })
    };
    bench_moves(
        c,
        "tick_arc_4axes",
        &[],
        arc(p(0.0, 0.0, -5.0, 0.0), [20.0, 0.0, 0.0], ArcDir::Ccw),
        arc(start, [20.0, 0.0, 0.0], ArcDir::Cw),
    );
    bench_moves(
        c,
        "tick_tap_4axes",
        &[],
        seg(SegmentKind::Linear {
            end: p(0.0, 0.0, -20.0, 20.0 / 1.5 * 360.0),
            feed: 1200.0,
        }),
        seg(SegmentKind::Linear {
            end: start,
            feed: 1200.0,
        }),
    );
    bench_moves(
        c,
        "tick_line_with_spindle_4axes",
        &[seg(SegmentKind::Spindle {
            rpm: 3000.0,
            dir: SpindleDir::Cw,
            spindle: 1,
        })],
        seg(SegmentKind::Linear {
            end: p(100.0, 50.0, -10.0, 0.0),
            feed: 6000.0,
        }),
        seg(SegmentKind::Linear {
            end: start,
            feed: 6000.0,
        }),
    );
}

fn peer_ruckig(c: &mut Criterion) {
    let mut otg = Ruckig::<4, ThrowErrorHandler>::new(None, 0.001);
    let mut input = InputParameter::new(None);
    input.target_position = daov_stack![100.0, 50.0, -10.0, 3000.0];
    input.max_velocity = daov_stack![250.0, 250.0, 200.0, 36000.0];
    input.max_acceleration = daov_stack![2000.0, 2000.0, 1500.0, 36000.0];
    input.max_jerk = daov_stack![50000.0, 50000.0, 40000.0, 720000.0];
    let mut traj = Trajectory::new(None);
    otg.calculate(&input, &mut traj).unwrap();
    let d = traj.get_duration();
    let mut pos = DataArrayOrVec::new(None, 0.0);
    let mut t = 0.0;
    c.bench_function("peer_ruckig_sample_4dof", |b| {
        b.iter(|| {
            t += 0.001;
            if t > d {
                t = 0.0;
            }
            traj.at_time(
                black_box(t),
                &mut Some(&mut pos),
                &mut None,
                &mut None,
                &mut None,
                &mut None,
            );
            black_box(&pos);
        })
    });
}

criterion_group!(benches, ticks, peer_ruckig);
criterion_main!(benches);
