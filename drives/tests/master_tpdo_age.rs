//! Regression tests for "one lost TPDO permanently skews the feedback timing": the master
//! counted SYNCs against TPDOs, so after one lost TPDO every later sample looked a cycle late
//! and was compared with a command one cycle too old (X at 250 mm/s: +0.25 mm per loss on a
//! 0.16 mm lag against a 0.5 mm window; C at 6000 rpm: +36° per loss on 23° against 90°). Runs X and C at full speed through
//! the bus `FaultInjector`, against a clean run of the same deterministic machine.

// Several per-axis arrays are indexed together.
#![allow(clippy::needless_range_loop)]

mod master_common;

use std::time::Duration;

use cnc402_config::MachineConfig;
use cnc402_drives::bus::{Action, Direction, FaultRule};
use cnc402_drives::master::{Feedback, SafetyStop};
use master_common::{MovingRig, smoothstep, tpdo_of};

const X: usize = 0;
const C: usize = 3;
/// Cycles of the run; X cruises at 250 mm/s from ~190, C at 6000 rpm from ~1500.
const CYCLES: u64 = 1800;

/// The shared fault rig; the run's motion needs no state of its own.
type Rig = MovingRig<()>;

impl Rig {
    fn booted(rules: &[FaultRule]) -> Rig {
        // Without drive models the monitor expects the delayed command, so the drives' steady
        // lag is in every error and a mis-aged sample pushes it past the window (with models
        // the lag is expected: master_following_error.rs).
        let mut config = MachineConfig::default_machine();
        for a in config.axes.iter_mut() {
            a.dynamics = None;
        }
        Rig::booted_with(&config, rules, ())
    }

    /// One cycle of the run: X to 250 mm/s and C to 6000 rpm on smooth velocity ramps
    /// within their acceleration limits, then cruising; Y and Z hold.
    fn cycle(&mut self) -> Result<Feedback, SafetyStop> {
        let t = self.k as f64 * 1e-3;
        let v_x = 250.0 * smoothstep(t / 0.1875);
        let v_c = 36000.0 * smoothstep(t / 1.5);
        self.pos[X] += v_x * 1e-3;
        self.pos[C] += v_c * 1e-3;
        self.k += 1;
        let pos = self.pos;
        self.base.cycle(&pos)
    }

    fn run(&mut self, cycles: u64) -> Vec<Feedback> {
        (0..cycles)
            .map(|_| {
                let k = self.k;
                self.cycle().unwrap_or_else(|s| panic!("cycle {k}: {s}"))
            })
            .collect()
    }
}

/// The clean run: the reference every faulted run is held against.
fn clean() -> Vec<Feedback> {
    let mut rig = Rig::booted(&[]);
    let fbs = rig.run(CYCLES);
    // Steady tracking lags (dead time not counted) of 0.16 mm and 23°: one cycle's travel
    // more (0.25 mm, 36°) per stale-looking sample, twice, is past the 0.5 mm and 90° windows.
    let (fx, fc) = (fbs[1700].following_error[X], fbs[1700].following_error[C]);
    assert!(fx > 0.1 && fx < 0.25, "X lag {fx}");
    assert!(fc > 15.0 && fc < 30.0, "C lag {fc}");
    fbs
}

/// Runs with the rules added at cycle `at` (the rule counts matches from then on).
fn faulted(at: u64, rules: &[FaultRule]) -> (Vec<Feedback>, Rig) {
    let mut rig = Rig::booted(&[]);
    let mut fbs = rig.run(at);
    for r in rules {
        rig.bus.add_rule(*r);
    }
    fbs.extend(rig.run(CYCLES - at));
    (fbs, rig)
}

/// From cycle `from` on, except in the cycles `lost` (and until the next sample after one),
/// axis `i`'s freshness, age and following
/// error are those of the clean run (the samples are the same, only their transport was
/// disturbed; the clean run has its own late samples when heartbeats push a TPDO past the
/// cycle edge).
fn assert_as_clean(clean: &[Feedback], run: &[Feedback], i: usize, from: usize, lost: &[usize]) {
    let mut holding_lost = false;
    for k in from..run.len() {
        // Until the next sample the run holds the older one (its age counts up from there).
        holding_lost = lost.contains(&k) || (holding_lost && !run[k].fresh[i]);
        if holding_lost {
            continue;
        }
        assert_eq!(run[k].fresh[i], clean[k].fresh[i], "axis {i} cycle {k}");
        assert_eq!(run[k].age[i], clean[k].age[i], "axis {i} cycle {k}");
        let (a, b) = (run[k].following_error[i], clean[k].following_error[i]);
        assert!((a - b).abs() < 1e-9, "axis {i} cycle {k}: {a} vs clean {b}");
    }
}

#[test]
fn one_lost_tpdo_does_not_skew_the_feedback_age() {
    let clean = clean();
    let at = 1600;
    let rules = [
        FaultRule::new(tpdo_of(1), Direction::Rx, Action::Drop).limit(1),
        FaultRule::new(tpdo_of(4), Direction::Rx, Action::Drop).limit(1),
    ];
    let (run, rig) = faulted(at, &rules);
    assert_eq!((rig.bus.applied(0), rig.bus.applied(1)), (1, 1));
    // The cycle of the loss has no sample; from the next one on all is as in the clean run.
    let lost = at as usize;
    assert!(!run[lost].fresh[X] && !run[lost].fresh[C]);
    assert_as_clean(&clean, &run, X, lost + 1, &[]);
    assert_as_clean(&clean, &run, C, lost + 1, &[]);
    let max = rig.master.max_following_errors();
    assert!(max[X] < 0.25 && max[C] < 30.0, "{} {}", max[X], max[C]);
}

#[test]
fn two_scattered_lost_tpdos_do_not_add_up_to_a_false_following_error_stop() {
    let clean = clean();
    let at = 1520;
    // X loses its 31st and 151st TPDO after `at`, C its 81st and 201st.
    let rules = [
        FaultRule::new(tpdo_of(1), Direction::Rx, Action::Drop)
            .skip(30)
            .every(120)
            .limit(2),
        FaultRule::new(tpdo_of(4), Direction::Rx, Action::Drop)
            .skip(80)
            .every(120)
            .limit(2),
    ];
    let (run, rig) = faulted(at, &rules);
    assert_eq!((rig.bus.applied(0), rig.bus.applied(1)), (2, 2));
    let stale = |i: usize| -> Vec<usize> {
        (at as usize..run.len())
            .filter(|&k| !run[k].fresh[i] && clean[k].fresh[i])
            .collect()
    };
    assert_eq!(stale(X).len(), 2, "{:?}", stale(X));
    assert_eq!(stale(C).len(), 2, "{:?}", stale(C));
    assert_as_clean(&clean, &run, X, at as usize, &stale(X));
    assert_as_clean(&clean, &run, C, at as usize, &stale(C));
}

#[test]
fn a_loss_at_standstill_is_written_off_within_the_resync_cycles() {
    // No motion: the two readings of an ambiguous sample agree, so the count decides until
    // the excess is written off after RESYNC_CYCLES cycles of one TPDO each.
    let standstill = |drop: bool| -> Vec<u32> {
        let mut rig = Rig::booted(&[]);
        let hold = rig.pos;
        let mut ages = Vec::new();
        for k in 0..100 {
            if k == 50 && drop {
                rig.bus
                    .add_rule(FaultRule::new(tpdo_of(4), Direction::Rx, Action::Drop).limit(1));
            }
            let fb = rig.base.cycle(&hold).unwrap();
            ages.push(fb.age[C]);
        }
        ages
    };
    let (clean, run) = (standstill(false), standstill(true));
    let resync = cnc402_drives::master::cyclic::RESYNC_CYCLES as usize;
    // Cycle 50 has no sample; the next `resync − 1` look a cycle late, then the loss is
    // written off and the ages are the clean run's again.
    for k in 50..50 + resync {
        assert_eq!(run[k], clean[k] + 1, "cycle {k}: {run:?}");
    }
    assert_eq!(run[50 + resync..], clean[50 + resync..], "{run:?}");
}

#[test]
fn a_drive_late_by_a_cycle_every_cycle_is_still_compared_one_cycle_older() {
    let clean = clean();
    // Every C TPDO from boot on is held back one period: it is read a cycle after its SYNC's
    // answer was due, so its sample is one cycle older.
    let late = FaultRule::new(
        tpdo_of(4),
        Direction::Rx,
        Action::Delay(Duration::from_millis(1)),
    );
    let mut rig = Rig::booted(&[late]);
    let run = rig.run(CYCLES);
    assert!(rig.bus.applied(0) > CYCLES as u32);
    let mut compared = 0;
    for k in 10..run.len() {
        if !run[k].fresh[C] {
            continue;
        }
        // Never taken for on time. The sample read in cycle k with age a is the one the
        // clean run read on time in cycle k − a: held against the same command, it must give
        // the same following error (a wrong age would be off by a cycle's travel).
        let a = run[k].age[C] as usize;
        assert!(a >= 1, "cycle {k}");
        let j = k - a;
        if clean[j].fresh[C] && clean[j].age[C] == 0 {
            let (e, e_clean) = (run[k].following_error[C], clean[j].following_error[C]);
            assert!(
                (e - e_clean).abs() < 1e-9,
                "cycle {k} age {a}: {e} vs clean {e_clean}"
            );
            compared += 1;
        }
    }
    assert!(compared > 1200, "{compared}");
    let max = rig.master.max_following_errors();
    assert!(max[C] < 30.0, "{}", max[C]);
}
