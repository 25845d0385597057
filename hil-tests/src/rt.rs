//! Real-time settings and the absolute-deadline sleep for the HIL binaries: `mlockall`,
//! SCHED_FIFO (each tried, and the outcome reported rather than required), CLOCK_MONOTONIC
//! time and `clock_nanosleep(TIMER_ABSTIME)`, and a probe that measures a periodic loop's
//! wake-up lateness.

use std::io;

/// Nanoseconds per second.
const NS_PER_S: u64 = 1_000_000_000;

/// Locks all current and future pages in memory (`mlockall(MCL_CURRENT | MCL_FUTURE)`).
/// Fails with the OS error when the process is not allowed (no CAP_IPC_LOCK, low RLIMIT_MEMLOCK).
pub fn lock_memory() -> io::Result<()> {
    // SAFETY: mlockall takes only flags and touches no memory of ours.
    let rc = unsafe { libc::mlockall(libc::MCL_CURRENT | libc::MCL_FUTURE) };
    if rc == 0 {
        Ok(())
    } else {
        Err(io::Error::last_os_error())
    }
}

/// Puts the calling thread under SCHED_FIFO at `priority` (1..=99). Fails with the OS error
/// when not permitted (EPERM without CAP_SYS_NICE / RLIMIT_RTPRIO) or the priority is invalid.
pub fn set_fifo(priority: i32) -> io::Result<()> {
    let param = libc::sched_param {
        sched_priority: priority,
    };
    // SAFETY: pid 0 is the calling thread; `param` is a valid sched_param for the call.
    let rc = unsafe { libc::sched_setscheduler(0, libc::SCHED_FIFO, &param) };
    if rc == 0 {
        Ok(())
    } else {
        Err(io::Error::last_os_error())
    }
}

/// CLOCK_MONOTONIC now, in nanoseconds.
pub fn monotonic_ns() -> u64 {
    let mut ts = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `ts` is a valid, writable timespec; CLOCK_MONOTONIC always exists on Linux.
    unsafe { libc::clock_gettime(libc::CLOCK_MONOTONIC, &mut ts) };
    (ts.tv_sec as u64) * NS_PER_S + ts.tv_nsec as u64
}

/// Sleeps until CLOCK_MONOTONIC reaches `deadline_ns` (`clock_nanosleep` with TIMER_ABSTIME),
/// resuming after signal interruptions. Returns at once for a deadline in the past.
pub fn sleep_until(deadline_ns: u64) -> io::Result<()> {
    let ts = libc::timespec {
        tv_sec: (deadline_ns / NS_PER_S) as libc::time_t,
        tv_nsec: (deadline_ns % NS_PER_S) as libc::c_long,
    };
    loop {
        // SAFETY: `ts` is a valid timespec; the remainder pointer may be null with TIMER_ABSTIME.
        let rc = unsafe {
            libc::clock_nanosleep(
                libc::CLOCK_MONOTONIC,
                libc::TIMER_ABSTIME,
                &ts,
                std::ptr::null_mut(),
            )
        };
        match rc {
            0 => return Ok(()),
            libc::EINTR => continue,
            e => return Err(io::Error::from_raw_os_error(e)),
        }
    }
}

/// Runs a periodic loop of `period_ns` on absolute deadlines and appends each wake-up's
/// lateness (ns after its deadline) to `samples`, calling `tick(i)` once per cycle after the
/// wake-up. Deadlines advance by exactly one period per tick, so a late tick is counted as
/// late and followed by immediate catch-up wake-ups, never absorbed by moving the schedule.
/// Reserve `samples` beforehand to keep the loop free of allocation.
pub fn measure_wakeups(
    period_ns: u64,
    cycles: usize,
    samples: &mut Vec<u64>,
    mut tick: impl FnMut(usize),
) -> io::Result<()> {
    let mut deadline = monotonic_ns() + period_ns;
    for i in 0..cycles {
        sleep_until(deadline)?;
        let woke = monotonic_ns();
        samples.push(woke.saturating_sub(deadline));
        tick(i);
        deadline += period_ns;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sleep_until_reaches_the_deadline() {
        let deadline = monotonic_ns() + 2_000_000;
        sleep_until(deadline).unwrap();
        assert!(monotonic_ns() >= deadline);
    }

    #[test]
    fn past_deadline_returns_at_once() {
        let t0 = monotonic_ns();
        sleep_until(t0.saturating_sub(1_000_000_000)).unwrap();
        assert!(monotonic_ns() - t0 < 500_000_000);
    }

    #[test]
    fn measured_loop_keeps_its_period() {
        let mut samples = Vec::with_capacity(50);
        let mut ticks = 0;
        let t0 = monotonic_ns();
        measure_wakeups(1_000_000, 50, &mut samples, |i| {
            assert_eq!(i, ticks);
            ticks += 1;
        })
        .unwrap();
        // 50 absolute deadlines 1 ms apart: never less than 50 ms in all.
        assert!(monotonic_ns() - t0 >= 50_000_000);
        assert_eq!(samples.len(), 50);
        assert_eq!(ticks, 50);
    }

    #[test]
    fn bad_fifo_priority_is_an_error_not_a_panic() {
        assert!(set_fifo(1000).is_err());
    }
}
