//! The real-time side: what the loop thread asks of the OS (memory locked, SCHED_FIFO — each
//! only when permitted), the monotonic clock, absolute-deadline sleeps, and the wake-up
//! latency histogram (fixed buckets, allocated before the loop starts), plus the SIGINT flag.

use std::sync::atomic::{AtomicBool, Ordering};

use cnc402_drives::stats::Histogram;
use nix::sys::mman::{MlockAllFlags, mlockall};
use nix::sys::time::TimeSpec;
use nix::time::{ClockId, ClockNanosleepFlags, clock_gettime, clock_nanosleep};

/// SCHED_FIFO priority the loop thread asks for.
pub const RT_PRIORITY: i32 = 80;

/// Which real-time privileges the loop thread got. A refusal's text names the limit to
/// raise (RLIMIT_MEMLOCK, RLIMIT_RTPRIO) with its value, not only the errno ("Out of memory"
/// alone sent people looking for a memory leak); docs/real-machine.md says how to raise them.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RtGrant {
    /// `mlockall(MCL_CURRENT | MCL_FUTURE)` succeeded, or why not.
    pub mlockall: Result<(), String>,
    /// SCHED_FIFO at [`RT_PRIORITY`] succeeded, or why not.
    pub fifo: Result<(), String>,
}

impl RtGrant {
    /// One line for the log.
    pub fn describe(&self) -> String {
        let s = |r: &Result<(), String>| match r {
            Ok(()) => "granted".to_string(),
            Err(e) => format!("not granted ({e})"),
        };
        format!(
            "real-time loop: mlockall {}, SCHED_FIFO {} {}",
            s(&self.mlockall),
            RT_PRIORITY,
            s(&self.fifo)
        )
    }

    /// Both granted.
    pub fn is_full(&self) -> bool {
        self.mlockall.is_ok() && self.fifo.is_ok()
    }
}

/// A resource limit's soft value (`None`: unlimited or unreadable).
fn soft_limit(resource: libc::__rlimit_resource_t) -> Option<u64> {
    let mut r = libc::rlimit {
        rlim_cur: 0,
        rlim_max: 0,
    };
    // SAFETY: plain syscall writing into a valid rlimit struct.
    let rc = unsafe { libc::getrlimit(resource, &mut r) };
    (rc == 0 && r.rlim_cur != libc::RLIM_INFINITY).then_some(r.rlim_cur)
}

/// Why `mlockall` failed, naming the locked-memory limit (`memlock`: RLIMIT_MEMLOCK in
/// bytes, `None` = unlimited).
pub fn mlock_refusal(e: nix::errno::Errno, memlock: Option<u64>) -> String {
    use nix::errno::Errno;
    let limit = memlock.map_or("unlimited".to_string(), |b| format!("{} kB", b / 1024));
    match e {
        Errno::ENOMEM | Errno::EPERM => format!(
            "{}: the locked-memory limit (RLIMIT_MEMLOCK, `ulimit -l`) is {limit}, too small to \
             lock the whole process; raise it to unlimited for this user (limits.d: \
             `USER - memlock unlimited`; systemd: LimitMEMLOCK=infinity) or grant CAP_IPC_LOCK",
            e.desc()
        ),
        _ => format!("{} (RLIMIT_MEMLOCK {limit})", e.desc()),
    }
}

/// Why SCHED_FIFO at [`RT_PRIORITY`] was refused, naming the real-time priority limit
/// (`rtprio`: RLIMIT_RTPRIO, `None` = unlimited).
pub fn fifo_refusal(e: nix::errno::Errno, rtprio: Option<u64>) -> String {
    use nix::errno::Errno;
    let limit = rtprio.map_or("unlimited".to_string(), |p| p.to_string());
    match e {
        Errno::EPERM => format!(
            "{}: the real-time priority limit (RLIMIT_RTPRIO, `ulimit -r`) is {limit}, SCHED_FIFO \
             {RT_PRIORITY} needs at least {RT_PRIORITY}; raise it for this user (limits.d: \
             `USER - rtprio 99`; systemd: LimitRTPRIO=99) or grant CAP_SYS_NICE{}",
            e.desc(),
            if rtprio.is_none_or(|p| p >= RT_PRIORITY as u64) {
                " (the limit allows it: a cgroup without real-time runtime refuses it, \
                 see docs/real-machine.md)"
            } else {
                ""
            }
        ),
        _ => format!("{} (RLIMIT_RTPRIO {limit})", e.desc()),
    }
}

/// Locks memory and switches the calling thread to SCHED_FIFO where the process may; never
/// fails (the loop runs anyway, just with worse latency, unless the run requires both: see
/// [`RtGrant::is_full`]).
pub fn request_realtime() -> RtGrant {
    let mlock = mlockall(MlockAllFlags::MCL_CURRENT | MlockAllFlags::MCL_FUTURE)
        .map_err(|e| mlock_refusal(e, soft_limit(libc::RLIMIT_MEMLOCK)));
    let param = libc::sched_param {
        sched_priority: RT_PRIORITY,
    };
    // SAFETY: plain syscall on the calling thread with a valid parameter struct.
    let rc = unsafe { libc::pthread_setschedparam(libc::pthread_self(), libc::SCHED_FIFO, &param) };
    let fifo = if rc == 0 {
        Ok(())
    } else {
        Err(fifo_refusal(
            nix::errno::Errno::from_raw(rc),
            soft_limit(libc::RLIMIT_RTPRIO),
        ))
    };
    RtGrant {
        mlockall: mlock,
        fifo,
    }
}

/// CLOCK_MONOTONIC in nanoseconds.
pub fn monotonic_ns() -> u64 {
    match clock_gettime(ClockId::CLOCK_MONOTONIC) {
        Ok(t) => t.tv_sec() as u64 * 1_000_000_000 + t.tv_nsec() as u64,
        Err(_) => 0,
    }
}

/// Sleeps until CLOCK_MONOTONIC reaches `deadline_ns` (absolute; a signal does not shorten it).
/// Any other error of `clock_nanosleep` is returned: ignoring it would turn the loop into a
/// busy spin (at SCHED_FIFO 80, one that starves the rest of the machine).
pub fn sleep_until(deadline_ns: u64) -> Result<(), nix::errno::Errno> {
    sleep_until_with(deadline_ns, |ts| {
        clock_nanosleep(
            ClockId::CLOCK_MONOTONIC,
            ClockNanosleepFlags::TIMER_ABSTIME,
            ts,
        )
        .map(|_| ())
    })
}

/// [`sleep_until`] with the sleep call given (tests): EINTR repeats it, any other error is
/// returned at once.
fn sleep_until_with(
    deadline_ns: u64,
    mut sleep: impl FnMut(&TimeSpec) -> Result<(), nix::errno::Errno>,
) -> Result<(), nix::errno::Errno> {
    let ts = TimeSpec::new(
        (deadline_ns / 1_000_000_000) as _,
        (deadline_ns % 1_000_000_000) as _,
    );
    loop {
        match sleep(&ts) {
            Err(nix::errno::Errno::EINTR) => continue,
            Err(e) => return Err(e),
            Ok(()) => return Ok(()),
        }
    }
}

/// Wake-up latency figures in microseconds.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct LatencySummary {
    pub samples: u64,
    pub p50_us: f64,
    pub p99_us: f64,
    pub max_us: f64,
    /// Wake-ups later than the late threshold (half a period).
    pub late: u64,
    /// Deadlines the loop let pass: a wake-up a whole period or more late runs one tick and
    /// starts the deadlines afresh from there instead of running the missed ticks in a burst
    /// (a burst would put tens of SYNCs on the bus at once). The path advances one period
    /// per tick either way, so it is stretched in time, not distorted.
    pub skipped: u64,
}

/// Range of a [`LatencyHistogram`]'s 1 ms buckets (above its 1 µs ones).
pub const COARSE_RANGE_MS: usize = 2000;

/// The deadline a tick runs at, given its scheduled deadline `next` and the time it `woke`
/// (ns, CLOCK_MONOTONIC): `next` itself when the wake-up was less than a period late,
/// otherwise `woke` (the deadlines start afresh there) and the number of whole periods let
/// pass. The caller's next deadline is the returned one plus a period.
pub fn tick_deadline(next: u64, woke: u64, period_ns: u64) -> (u64, u64) {
    let late = woke.saturating_sub(next);
    if period_ns > 0 && late >= period_ns {
        (woke, late / period_ns)
    } else {
        (next, 0)
    }
}

/// Wake-up latency: a [`cnc402_drives::stats::Histogram`] with 1 µs buckets up to its size
/// and 1 ms buckets from there up to [`COARSE_RANGE_MS`] more (an emulated guest's p99 is
/// tens of ms), plus the count of late wake-ups. The buckets are allocated in `new`;
/// `record` is allocation-free. p50/p99 are within half a bucket of the exact nearest-rank
/// sample (0.5 µs below the fine range's end, 0.5 ms above); min, max and mean are exact.
#[derive(Clone, Debug)]
pub struct LatencyHistogram {
    hist: Histogram,
    late_threshold_ns: u64,
    late: u64,
}

impl LatencyHistogram {
    /// Buckets for 0..`range_us` µs; wake-ups later than `late_threshold_ns` count as late.
    pub fn new(range_us: usize, late_threshold_ns: u64) -> LatencyHistogram {
        LatencyHistogram {
            hist: Histogram::micros_then_millis(range_us.max(1), COARSE_RANGE_MS),
            late_threshold_ns,
            late: 0,
        }
    }

    /// Records one wake-up `latency_ns` after its deadline.
    #[inline]
    pub fn record(&mut self, latency_ns: u64) {
        self.hist.record(latency_ns);
        if latency_ns > self.late_threshold_ns {
            self.late += 1;
        }
    }

    /// The histogram.
    pub fn histogram(&self) -> &Histogram {
        &self.hist
    }

    /// p50/p99/max/late (µs; zeros without samples).
    pub fn summary(&self) -> LatencySummary {
        let us = |ns: f64| ns / 1000.0;
        match self.hist.summary() {
            Some(s) => LatencySummary {
                samples: s.count,
                p50_us: us(s.p50_ns),
                p99_us: us(s.p99_ns),
                max_us: us(s.max_ns as f64),
                late: self.late,
                skipped: 0,
            },
            None => LatencySummary::default(),
        }
    }
}

static SIGINT_SEEN: AtomicBool = AtomicBool::new(false);

extern "C" fn on_sigint(_: libc::c_int) {
    SIGINT_SEEN.store(true, Ordering::SeqCst);
}

/// Installs a SIGINT handler that only sets a flag (async-signal-safe); the run polls it
/// ([`sigint_seen`]) and stops the machine the same way as a fault.
pub fn install_sigint_handler() -> Result<(), String> {
    use nix::sys::signal::{SaFlags, SigAction, SigHandler, SigSet, Signal, sigaction};
    let act = SigAction::new(
        SigHandler::Handler(on_sigint),
        SaFlags::SA_RESTART,
        SigSet::empty(),
    );
    // SAFETY: the handler only stores to an atomic.
    unsafe { sigaction(Signal::SIGINT, &act) }
        .map(|_| ())
        .map_err(|e| e.desc().to_string())
}

/// True once SIGINT arrived (after [`install_sigint_handler`]).
pub fn sigint_seen() -> bool {
    SIGINT_SEEN.load(Ordering::SeqCst)
}

#[cfg(test)]
mod tests {

    use nix::errno::Errno;

    /// Regression (rt_refusal_said_only_out_of_memory): a non-root user's mlockall failed
    /// with "Out of memory" and nothing else; the text now names the limit and its value.
    #[test]
    fn rt_refusals_name_the_limit_to_raise() {
        let m = mlock_refusal(Errno::ENOMEM, Some(8 * 1024 * 1024));
        assert!(m.contains("RLIMIT_MEMLOCK"), "{m}");
        assert!(m.contains("8192 kB"), "{m}");
        assert!(m.contains("memlock unlimited"), "{m}");
        let f = fifo_refusal(Errno::EPERM, Some(0));
        assert!(f.contains("RLIMIT_RTPRIO"), "{f}");
        assert!(f.contains("is 0"), "{f}");
        assert!(f.contains("CAP_SYS_NICE"), "{f}");
        assert!(!f.contains("cgroup"), "{f}");
        // Allowed by the limit, refused anyway: the cgroup's real-time runtime.
        assert!(fifo_refusal(Errno::EPERM, None).contains("cgroup"));
    }
    use super::*;

    #[test]
    fn quantiles_from_buckets() {
        let mut h = LatencyHistogram::new(100, 500_000);
        for us in 1..=100u64 {
            h.record(us * 1000 - 500);
        }
        h.record(2_000_000);
        let s = h.summary();
        assert_eq!(s.samples, 101);
        // Nearest rank: the 51st and 100th samples, 50.5 and 99.5 µs (bucket middles).
        assert_eq!(s.p50_us, 50.5);
        assert_eq!(s.p99_us, 99.5);
        assert_eq!(s.max_us, 2000.0);
        assert_eq!(s.late, 1);
    }

    #[test]
    fn sleep_until_ignores_errors_other_than_eintr_busy_spin() {
        use nix::errno::Errno;
        // A clock error is returned after one call, not retried (or ignored) forever.
        let mut calls = 0;
        let r = sleep_until_with(1_500_000_000, |ts| {
            calls += 1;
            assert_eq!((ts.tv_sec(), ts.tv_nsec()), (1, 500_000_000));
            Err(Errno::EINVAL)
        });
        assert_eq!((r, calls), (Err(Errno::EINVAL), 1));
        // A signal repeats the sleep.
        let mut calls = 0;
        let r = sleep_until_with(0, |_| {
            calls += 1;
            if calls < 3 { Err(Errno::EINTR) } else { Ok(()) }
        });
        assert_eq!((r, calls), (Ok(()), 3));
    }

    #[test]
    fn absolute_sleep_reaches_its_deadline() {
        let t0 = monotonic_ns();
        assert_eq!(sleep_until(t0 + 2_000_000), Ok(()));
        assert!(monotonic_ns() >= t0 + 2_000_000);
    }

    #[test]
    fn late_wake_ups_restart_the_deadlines_instead_of_bursting() {
        let p = 1_000_000;
        // On time or late by less than a period: the schedule holds.
        assert_eq!(tick_deadline(5 * p, 5 * p, p), (5 * p, 0));
        assert_eq!(tick_deadline(5 * p, 5 * p + p - 1, p), (5 * p, 0));
        // Woken early (cannot happen with TIMER_ABSTIME, but harmless).
        assert_eq!(tick_deadline(5 * p, 4 * p, p), (5 * p, 0));
        // 2.5 periods late: two deadlines skipped, the tick runs at the wake-up.
        assert_eq!(tick_deadline(5 * p, 7 * p + p / 2, p), (7 * p + p / 2, 2));
        // 100 ms late in the emulated guest: one tick, not a burst of 100.
        let mut next = 10 * p;
        let mut ticks = 0;
        let mut skipped = 0;
        for woke in [10 * p, 11 * p + 100 * p, 11 * p + 100 * p + p] {
            let (at, s) = tick_deadline(next, woke, p);
            ticks += 1;
            skipped += s;
            next = at + p;
        }
        assert_eq!((ticks, skipped), (3, 100));
    }

    #[test]
    fn quantiles_beyond_the_fine_range_are_not_the_maximum() {
        let mut h = LatencyHistogram::new(5000, 500_000);
        // 90 on time, 9 at 20.3 ms, one at 150 ms: p99 is 20.5 ms (the bucket's middle,
        // within 0.5 ms of the exact 20.3), not the 150 ms maximum.
        for _ in 0..90 {
            h.record(10_000);
        }
        for _ in 0..9 {
            h.record(20_300_000);
        }
        h.record(150_000_000);
        let s = h.summary();
        assert_eq!(s.p50_us, 10.5);
        assert_eq!(s.p99_us, 20_500.0);
        assert_eq!(s.max_us, 150_000.0);
        assert_eq!(s.late, 10);
        // Beyond the coarse range: the maximum.
        let mut h = LatencyHistogram::new(10, 0);
        h.record(5_000_000_000);
        assert_eq!(h.summary().p99_us, 5_000_000.0);
    }
}
