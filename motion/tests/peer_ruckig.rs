//! Our rest-to-rest double-S against a proven peer: Ruckig (rsruckig) computes the
//! time-optimal jerk-limited trajectory for the same distance and limits. Durations must agree
//! and so must the sampled motion (the rest-to-rest time-optimal profile is unique).

use cnc402_motion::profile::{Limits, PathProfile, ProfileError, double_s, rest_to_rest};
use proptest::prelude::*;
use rsruckig::prelude::*;

fn ruckig(dist: f64, l: Limits) -> Trajectory<1> {
    ruckig_v(dist, 0.0, 0.0, l)
}

fn ruckig_v(dist: f64, v0: f64, v1: f64, l: Limits) -> Trajectory<1> {
    let mut otg = Ruckig::<1, ThrowErrorHandler>::new(None, 0.001);
    let mut input = InputParameter::new(None);
    input.current_position[0] = 0.0;
    input.current_velocity[0] = v0;
    input.target_velocity[0] = v1;
    input.target_position[0] = dist;
    input.max_velocity[0] = l.velocity;
    input.max_acceleration[0] = l.acceleration;
    input.max_jerk[0] = l.jerk;
    let mut traj = Trajectory::new(None);
    otg.calculate(&input, &mut traj)
        .expect("ruckig solves rest-to-rest");
    traj
}

fn ruckig_pos(traj: &Trajectory<1>, t: f64) -> (f64, f64) {
    let mut p = DataArrayOrVec::new(None, 0.0);
    let mut v = DataArrayOrVec::new(None, 0.0);
    traj.at_time(
        t,
        &mut Some(&mut p),
        &mut Some(&mut v),
        &mut None,
        &mut None,
        &mut None,
    );
    (p[0], v[0])
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, ..ProptestConfig::default() })]

    #[test]
    fn double_s_matches_ruckig(
        dist in 1e-4..500.0f64,
        v in 1.0..500.0f64,
        a in 10.0..20000.0f64,
        j in 100.0..500000.0f64,
    ) {
        let l = Limits { velocity: v, acceleration: a, jerk: j };
        let ours = rest_to_rest(dist, l).unwrap();
        let traj = ruckig(dist, l);
        let (t1, t2) = (ours.duration(), traj.get_duration());
        prop_assert!((t1 - t2).abs() <= 1e-7 * t2.max(1e-3), "ours {} ruckig {}", t1, t2);
        for i in 0..=50 {
            let t = t2 * i as f64 / 50.0;
            let (p, vel) = ruckig_pos(&traj, t);
            let st = ours.sample(t);
            prop_assert!((st.s - p).abs() <= 1e-6 * dist.max(1e-3), "t {}: {} vs {}", t, st.s, p);
            prop_assert!((st.v - vel).abs() <= 1e-5 * v, "t {}: v {} vs {}", t, st.v, vel);
        }
    }

    /// With boundary velocities (lookahead blending), where our ramp-cruise-ramp family is
    /// feasible it must be as fast as Ruckig's trajectory and reach the same end within every
    /// limit. Never slower; faster only where rsruckig 3.0.1 misses the optimum (see
    /// `rsruckig_misses_the_optimum_with_a_fast_start_and_a_slow_end`, where ours is checked
    /// to be a valid profile by integration).
    #[test]
    fn double_s_with_boundary_velocities_matches_ruckig(
        dist in 1e-3..500.0f64,
        f0 in 0.0..1.0f64,
        f1 in 0.0..1.0f64,
        v in 1.0..500.0f64,
        a in 10.0..20000.0f64,
        j in 100.0..500000.0f64,
    ) {
        let l = Limits { velocity: v, acceleration: a, jerk: j };
        let (v0, v1) = (f0 * v, f1 * v);
        let ours = match double_s(dist, v0, v1, l) {
            Ok(p) => p,
            Err(ProfileError::TooShort { need }) => {
                prop_assert!(need > dist);
                return Ok(());
            }
            Err(e) => return Err(TestCaseError::fail(format!("{e:?}"))),
        };
        let traj = ruckig_v(dist, v0, v1, l);
        let (t1, t2) = (ours.duration(), traj.get_duration());
        prop_assert!(t1 - t2 <= 1e-6 * t2.max(1e-3), "ours {} slower than ruckig {}", t1, t2);
        let e = ours.sample(t1);
        prop_assert_eq!((e.s, e.v), (dist, v1));
        prop_assert!(ours.max_jerk() <= j * (1.0 + 1e-12));
        for i in 0..=200 {
            let st = ours.sample(t1 * i as f64 / 200.0);
            prop_assert!(st.v <= v * (1.0 + 1e-9) && st.v >= -1e-9 * v);
            prop_assert!(st.a.abs() <= a * (1.0 + 1e-9));
        }
        let before = ours.sample(t1 * (1.0 - 1e-13));
        prop_assert!((before.s - dist).abs() <= 1e-8 * dist.max(1.0), "{} {}", before.s, dist);
    }
}

/// Regression (found by the property test above on a random seed): rsruckig 3.0.1 gives
/// 0.0863 s for this move, ours 0.0689 s. Ours is a valid profile: within the velocity,
/// acceleration and jerk limits, starting and ending at the given velocities, and the
/// integral of its velocity is the distance (so its position is not "teleported" to the end).
/// The peer is not time-optimal here, so the comparison above only asks "never slower".
#[test]
fn rsruckig_misses_the_optimum_with_a_fast_start_and_a_slow_end() {
    let (dist, f0, f1, v, a, j) = (
        14.07071339617012,
        0.8820489184297057,
        0.027504285325469238,
        358.61493583509423,
        10992.954523971111,
        435228.2212753986,
    );
    let l = Limits {
        velocity: v,
        acceleration: a,
        jerk: j,
    };
    let (v0, v1) = (f0 * v, f1 * v);
    let ours = double_s(dist, v0, v1, l).unwrap();
    let t = ours.duration();
    let peer = ruckig_v(dist, v0, v1, l).get_duration();
    assert!(t < peer - 0.01, "ours {t} s, rsruckig {peer} s");
    let n = 200_000;
    let dt = t / n as f64;
    let mut prev = ours.sample(0.0);
    assert_eq!(prev.v, v0);
    let mut integral = 0.0;
    for i in 1..=n {
        let s = ours.sample(dt * i as f64);
        integral += 0.5 * (s.v + prev.v) * dt;
        assert!(s.v <= v * (1.0 + 1e-12) && s.v >= 0.0, "v {}", s.v);
        assert!(s.a.abs() <= a * (1.0 + 1e-12), "a {}", s.a);
        assert!((s.a - prev.a).abs() / dt <= j * (1.0 + 1e-6), "jerk");
        prev = s;
    }
    assert!(
        (integral - dist).abs() < 1e-9 * dist,
        "{integral} vs {dist}"
    );
    assert_eq!((prev.s, prev.v), (dist, v1));
}
