//! tapmaster: the drives crate's `Master` on a SocketCAN interface, running a synthetic rigid
//! tap (Z and C coupled at a fixed pitch, smooth ramps, down and back out) in real time — a
//! peer for testing `simdrive` on vcan independently of `cnc402 run`.
//!
//!   tapmaster --iface vcan0 [--config PATH] [--pitch MM] [--revs N] [--seconds S]
//!
//! Prints the boot, the stop reason if a safety monitor trips, and the loop's wake-up lateness.
//! Exit 0 ran and disabled; 1 a safety stop; 2 usage; 6 boot or bus failure.

use cnc402_config::MachineConfig;
use cnc402_drives::master::{Master, TimedBus};
use cnc402_drives::socketcan::SocketCanBus;
use cnc402_hil::latency::summarize;

fn usage(msg: &str) -> ! {
    eprintln!(
        "tapmaster: {msg}\nusage: tapmaster --iface NAME [--config PATH] [--pitch MM] [--revs N] [--seconds S]"
    );
    std::process::exit(2);
}

/// Position along a move of length 1 at fraction `u` of its time, with a smooth (cosine)
/// velocity profile: 0 → 1, zero velocity at both ends.
fn smooth(u: f64) -> f64 {
    let u = u.clamp(0.0, 1.0);
    u - (2.0 * std::f64::consts::PI * u).sin() / (2.0 * std::f64::consts::PI)
}

fn main() {
    let mut iface = None;
    let mut config = String::from(cnc402_config::DEFAULT_PATH);
    let mut pitch = 1.5_f64;
    let mut revs = 4.0_f64;
    let mut seconds = 1.5_f64;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut val = || {
            args.next()
                .unwrap_or_else(|| usage(&format!("{a} needs a value")))
        };
        let num = |s: String| s.parse::<f64>().ok().filter(|v| v.is_finite() && *v > 0.0);
        match a.as_str() {
            "--iface" => iface = Some(val()),
            "--config" => config = val(),
            "--pitch" => pitch = num(val()).unwrap_or_else(|| usage("bad --pitch")),
            "--revs" => revs = num(val()).unwrap_or_else(|| usage("bad --revs")),
            "--seconds" => seconds = num(val()).unwrap_or_else(|| usage("bad --seconds")),
            _ => usage(&format!("unknown argument {a}")),
        }
    }
    let iface = iface.unwrap_or_else(|| usage("--iface is required"));
    let cfg = MachineConfig::load(&config).unwrap_or_else(|e| usage(&e.to_string()));
    let (Some(zi), Some(ci)) = (
        cfg.axes.iter().position(|a| a.name == 'Z'),
        cfg.axes.iter().position(|a| a.name == 'C'),
    ) else {
        usage("the config needs axes Z and C")
    };
    let mut bus = SocketCanBus::open(&iface).unwrap_or_else(|e| {
        eprintln!("tapmaster: {e}");
        std::process::exit(6)
    });
    let mut m = Master::new(&cfg).unwrap_or_else(|e| usage(&e.to_string()));
    let boot = m.boot(&mut bus).unwrap_or_else(|e| {
        eprintln!("tapmaster: boot failed: {e}");
        std::process::exit(6)
    });
    eprintln!(
        "tapmaster: {} drives enabled after {} cycles",
        boot.drives.len(),
        boot.enable_cycles
    );
    let start = m.positions();
    let n = m.axis_count();
    let period = m.period();
    let leg = (seconds / period.as_secs_f64()).round().max(1.0) as u64;
    let ticks = 2 * leg + 50;
    let mut now = boot.enabled_at + period;
    let mut late = Vec::with_capacity(ticks as usize);
    let mut rc = 0;
    for t in 0..ticks {
        let wait = now.saturating_since(TimedBus::now(&bus));
        if !wait.is_zero() {
            std::thread::sleep(wait);
        }
        late.push(TimedBus::now(&bus).saturating_since(now).as_nanos() as u64);
        // Down (C forward) for `leg` ticks, back out (C reverse), then hold.
        let s = if t < leg {
            smooth(t as f64 / leg as f64)
        } else {
            1.0 - smooth((t - leg) as f64 / leg as f64)
        };
        let c = 360.0 * revs * s;
        let mut cmd = start;
        cmd[ci] = start[ci] + c;
        cmd[zi] = start[zi] - c / 360.0 * pitch;
        if let Err(stop) = m.cycle(&mut bus, now, &cmd[..n]) {
            eprintln!("tapmaster: STOP: {stop}");
            rc = 1;
            break;
        }
        now += period;
    }
    if rc == 0
        && let Err(e) = m.disable(&mut bus)
    {
        eprintln!("tapmaster: disable failed: {e}");
        rc = 6;
    }
    if let Some(l) = summarize(&mut late, period.as_nanos() as u64) {
        eprintln!(
            "tapmaster: {} cycles, wake-up lateness p50 {} p99 {} max {} µs, {} late by a period",
            l.samples,
            l.p50_ns / 1000,
            l.p99_ns / 1000,
            l.max_ns / 1000,
            l.late_by_a_period
        );
    }
    std::process::exit(rc);
}
