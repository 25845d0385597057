//! Controlled stop along the path: mid-tap Z and C decelerate on their shared path parameter
//! (coupled within one count), every axis stays within its limits, and the spindle in speed
//! mode ramps down too.

mod common;

use cnc402_config::MachineConfig;
use cnc402_motion::*;
use common::*;

/// Runs `segs` and requests a stop after `stop_after` ticks; returns all ticks up to and
/// including the first `Held` one (plus 5 more held ticks).
fn run_with_stop(
    cfg: &MachineConfig,
    start: AxisPos,
    segs: &[Segment],
    stop_after: usize,
) -> Vec<Tick> {
    let mut planner = Planner::new(cfg);
    planner.set_position(start);
    let mut ip = Interpolator::new(cfg, start);
    let mut out = vec![idle_tick(&ip, 0)];
    let mut next = 0;
    let mut held_extra = 0;
    loop {
        if ip.is_idle() && next < segs.len() {
            ip.start(planner.plan(&segs[next]).unwrap()).unwrap();
            next += 1;
        }
        if out.len() == stop_after + 1 {
            ip.request_stop();
        }
        let t = ip.tick();
        out.push(t);
        if t.state == TickState::Held {
            held_extra += 1;
            if held_extra > 5 {
                break;
            }
        }
        assert!(out.len() < 10_000_000);
    }
    out
}

fn tap(z0: f64, depth: f64, pitch: f64, rpm: f64) -> Vec<Segment> {
    let zb = z0 - depth;
    vec![
        lin(xyzc(0.0, 0.0, zb, depth / pitch * 360.0), rpm * pitch, 10),
        lin(xyzc(0.0, 0.0, z0, 0.0), rpm * pitch, 11),
    ]
}

fn worst_coupling(ticks: &[Tick], z0: f64, pitch: f64) -> (i64, i64) {
    let (zc, cc) = (10000.0, 131072.0 / 360.0);
    ticks.iter().fold((0, 0), |w, t| {
        let (z, c) = (t.pos.0[2], t.pos.0[3]);
        let c_ideal = (z0 - z) * 360.0 / pitch;
        let z_ideal = z0 - c * pitch / 360.0;
        let dc = ((c * cc).round() - (c_ideal * cc).round()).abs() as i64;
        let dz = ((z * zc).round() - (z_ideal * zc).round()).abs() as i64;
        (w.0.max(dz), w.1.max(dc))
    })
}

#[test]
fn stop_mid_tap_keeps_z_and_c_coupled_while_decelerating() {
    let c = MachineConfig::default_machine();
    let z0 = 2.0;
    let segs = tap(z0, 20.0, 1.5, 2000.0);
    // Stop in the acceleration phase, at cruise, and on the way back up.
    for stop_after in [5, 40, 300, 700, 900] {
        let ticks = run_with_stop(&c, xyzc(0.0, 0.0, z0, 0.0), &segs, stop_after);
        let w = worst_coupling(&ticks, z0, 1.5);
        assert!(w.0 <= 1 && w.1 <= 1, "stop at {stop_after}: {w:?}");
        check_limits(&c, &ticks);
        assert!(
            ticks.iter().all(|t| !t.finished || t.line == 10),
            "no move completes after the stop"
        );
        let held = ticks.last().unwrap();
        assert_eq!(held.state, TickState::Held);
        assert_eq!(held.path_velocity, 0.0);
        // Within the tap's stroke, and it did stop early.
        assert!(held.pos.0[2] <= z0 && held.pos.0[2] >= z0 - 20.0);
        // Bounded by the time to swing a from +a_max to −a_max plus braking from v_max.
        let MoveKind::Path(m) = Planner::new(&c).plan(&segs[0]).unwrap().kind else {
            panic!()
        };
        let l = m.limits;
        let bound = l.velocity / l.acceleration + 2.0 * l.acceleration / l.jerk;
        let stop_ticks = ticks.len() - 1 - 6 - stop_after;
        assert!(
            (stop_ticks as f64) * 1e-3 <= bound + 2e-3,
            "{stop_after}: {stop_ticks}"
        );
    }
}

#[test]
fn stop_is_shorter_than_finishing_and_never_turns_back() {
    let c = MachineConfig::default_machine();
    let segs = [lin(xyzc(100.0, 0.0, 0.0, 0.0), 12000.0, 1)];
    let ticks = run_with_stop(&c, AxisPos::default(), &segs, 200);
    check_limits(&c, &ticks);
    let x: Vec<f64> = ticks.iter().map(|t| t.pos.0[0]).collect();
    assert!(x.windows(2).all(|w| w[1] >= w[0]), "monotone");
    let end = *x.last().unwrap();
    assert!(end > 10.0 && end < 100.0, "{end}");
    // Stopping from 200 mm/s with a = 2000, j = 50000: 200/2000 + 2000/50000 = 0.14 s.
    let held_at = ticks
        .iter()
        .position(|t| t.state == TickState::Held)
        .unwrap();
    assert!((held_at - 200) as f64 * 1e-3 <= 0.141 + 1e-3, "{held_at}");
}

#[test]
fn stop_while_braking_into_the_end_point_finishes_the_braking() {
    let c = MachineConfig::default_machine();
    let segs = [lin(xyzc(10.0, 0.0, 0.0, 0.0), 12000.0, 1)];
    let mut p = Planner::new(&c);
    let MoveKind::Path(m) = p.plan(&segs[0]).unwrap().kind else {
        panic!()
    };
    let ticks = run_with_stop(&c, AxisPos::default(), &segs, m.ticks as usize - 3);
    check_limits(&c, &ticks);
    // Braking at the full limits stops a hair before the (gentler, stretched) planned end.
    let x = ticks.last().unwrap().pos.0[0];
    assert!(x <= 10.0 && x > 9.999, "{x}");
    assert!(ticks.windows(2).all(|w| w[1].pos.0[0] >= w[0].pos.0[0]));
    assert!(ticks.iter().all(|t| !t.finished));
}

#[test]
fn stop_ramps_the_spindle_down_and_clear_stop_allows_a_new_start() {
    let c = MachineConfig::default_machine();
    let segs = [
        seg(
            SegmentKind::Spindle {
                rpm: 5000.0,
                dir: SpindleDir::Ccw,
                spindle: 1,
            },
            1,
        ),
        lin(xyzc(50.0, 20.0, 0.0, 0.0), 3000.0, 2),
    ];
    let ticks = run_with_stop(&c, AxisPos::default(), &segs, 1000);
    check_limits(&c, &ticks);
    let held = ticks.iter().find(|t| t.state == TickState::Held).unwrap();
    assert_eq!(held.spindle_velocity[0], 0.0);
    // The spindle (1 s ramp at most from 30000 deg/s) takes longer than the path: the
    // interpolator reports Stopping until it is at rest.
    let first_held = ticks
        .iter()
        .position(|t| t.state == TickState::Held)
        .unwrap();
    assert!(first_held - 1000 > 800, "{first_held}");
    assert!(
        ticks[1001..first_held]
            .iter()
            .all(|t| t.state == TickState::Stopping)
    );

    // Resume: clear the stop, re-sync the planner from the interpolator, move on.
    let mut planner = Planner::new(&c);
    let mut ip = Interpolator::new(&c, AxisPos::default());
    ip.start(planner.plan(&segs[0]).unwrap()).unwrap();
    for _ in 0..100 {
        ip.tick();
    }
    ip.request_stop();
    assert!(!ip.clear_stop(), "not at rest yet");
    let e = ip.start(planner.plan(&segs[1]).unwrap()).unwrap_err();
    assert_eq!(e.kind, MotionErrorKind::Stopped);
    while !ip.is_held() {
        ip.tick();
    }
    assert!(ip.clear_stop());
    assert!(ip.is_idle());
    let offset = ip.spindle_offset();
    assert!(offset < 0.0, "M4 turned C negative: {offset}");
    planner = Planner::new(&c);
    planner.set_position(ip.program_position());
    let end = xyzc(5.0, 0.0, -1.0, 360.0);
    ip.start(planner.plan(&lin(end, 300.0, 3)).unwrap())
        .unwrap();
    let mut last = ip.tick();
    while !last.finished {
        last = ip.tick();
    }
    assert_eq!(last.pos.0[2], -1.0);
    assert_eq!(last.pos.0[3], 360.0 + offset);
}

#[test]
fn stop_during_a_dwell_holds_at_once() {
    let c = MachineConfig::default_machine();
    let segs = [seg(SegmentKind::Dwell { seconds: 2.0 }, 4)];
    let ticks = run_with_stop(&c, xyzc(1.0, 1.0, 1.0, 0.0), &segs, 10);
    assert_eq!(ticks[11].state, TickState::Held);
    assert!(ticks.iter().all(|t| t.pos == xyzc(1.0, 1.0, 1.0, 0.0)));
}

#[test]
fn stop_before_the_first_tick_of_a_move_does_not_run_it() {
    let c = MachineConfig::default_machine();
    let mut planner = Planner::new(&c);
    let mut ip = Interpolator::new(&c, AxisPos::default());
    ip.start(
        planner
            .plan(&lin(xyzc(50.0, 0.0, 0.0, 0.0), 3000.0, 1))
            .unwrap(),
    )
    .unwrap();
    ip.request_stop();
    let t = ip.tick();
    assert_eq!(t.state, TickState::Held);
    assert_eq!(t.pos, AxisPos::default());
}
