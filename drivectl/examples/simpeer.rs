//! simpeer: hosts one simulated CiA 402 drive per configured axis on a real CAN interface
//! (the same `SimDrive` model as `--iface sim`), so drivectl can be tested against real
//! sockets (vcan0 in the HIL guest) before `simdrive` exists.
//!
//!   simpeer --iface vcan0 [--config config/machine.toml] [--for SECONDS] [--fault NODE:KIND@S]

use std::time::Duration;

use cnc402_config::MachineConfig;
use cnc402_drives::bus::{CanBus, CanDevice};
use cnc402_drives::master::TimedBus;
use cnc402_drives::sim::{FaultKind, SimDrive};
use cnc402_drives::socketcan::SocketCanBus;
use cnc402_drives::wire::NodeId;

fn usage(msg: &str) -> ! {
    eprintln!(
        "simpeer: {msg}\nusage: simpeer --iface NAME [--config PATH] [--for SECONDS] [--fault NODE:KIND@SECONDS]"
    );
    std::process::exit(2);
}

fn main() {
    let mut iface = None;
    let mut config = String::from(cnc402_config::DEFAULT_PATH);
    let mut run_for: Option<f64> = None;
    let mut faults: Vec<(u8, FaultKind, f64)> = Vec::new();
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut val = || {
            args.next()
                .unwrap_or_else(|| usage(&format!("{a} needs a value")))
        };
        match a.as_str() {
            "--iface" => iface = Some(val()),
            "--config" => config = val(),
            "--for" => run_for = Some(val().parse().unwrap_or_else(|_| usage("bad --for"))),
            "--fault" => {
                let v = val();
                let (spec, at) = v.split_once('@').unwrap_or((v.as_str(), "0"));
                let (node, kind) = spec.split_once(':').unwrap_or_else(|| usage("bad --fault"));
                let node: u8 = node.parse().unwrap_or_else(|_| usage("bad --fault node"));
                let kind: FaultKind = kind.parse().unwrap_or_else(|e| usage(&format!("{e}")));
                let at: f64 = at.parse().unwrap_or_else(|_| usage("bad --fault time"));
                faults.push((node, kind, at));
            }
            _ => usage(&format!("unknown argument {a}")),
        }
    }
    let iface = iface.unwrap_or_else(|| usage("--iface is required"));
    let cfg = MachineConfig::load(&config).unwrap_or_else(|e| usage(&e.to_string()));
    let mut bus = SocketCanBus::open(&iface).unwrap_or_else(|e| {
        eprintln!("simpeer: {e}");
        std::process::exit(6);
    });
    let period = Duration::from_micros(cfg.bus.period_us as u64);
    let mut drives: Vec<SimDrive> = cfg
        .axes
        .iter()
        .filter_map(|a| {
            let node = NodeId::new(a.node?).ok()?;
            Some(SimDrive::new(a, node, period))
        })
        .collect();
    eprintln!(
        "simpeer: {} drive(s) on {iface}: nodes {:?}",
        drives.len(),
        drives.iter().map(|d| d.node().get()).collect::<Vec<_>>()
    );
    let end = run_for.map(|s| bus.now() + Duration::from_secs_f64(s));
    loop {
        let now = bus.now();
        if end.is_some_and(|e| now >= e) {
            break;
        }
        for (node, kind, at) in faults.iter_mut() {
            if *at >= 0.0 && now.nanos() as f64 * 1e-9 >= *at {
                if let Some(d) = drives.iter_mut().find(|d| d.node().get() == *node) {
                    d.inject(*kind, now);
                    eprintln!("simpeer: injected {kind:?} into node {node} at {now}");
                }
                *at = -1.0;
            }
        }
        match bus.recv_timeout(Duration::from_micros(200)) {
            Ok(Some(frame)) => {
                let now = bus.now();
                for d in drives.iter_mut() {
                    d.on_frame(&frame, now, &mut bus);
                }
            }
            Ok(None) => {}
            Err(e) => {
                eprintln!("simpeer: receive failed: {e}");
                std::process::exit(6);
            }
        }
        let now = bus.now();
        for d in drives.iter_mut() {
            d.poll(now, &mut bus);
        }
    }
    let c = bus.counters();
    eprintln!(
        "simpeer: done: rx {} tx {} frames, error frames {}",
        c.rx_frames,
        c.tx_frames,
        bus.error_frames()
    );
}
