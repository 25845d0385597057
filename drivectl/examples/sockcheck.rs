//! sockcheck: checks the SocketCAN transport on a real interface (run by drivectl/hil.sh in
//! the HIL guest). 1. Order and completeness: one socket sends a burst of mixed PDO, EMCY,
//! heartbeat and SDO frames, another receives them all in order through `recv_timeout`.
//! 2. SDO does not eat PDOs: while a thread streams TPDO-like frames, blocking SDO uploads
//! (to a drive hosted by simpeer, node 3) run on the receiving socket; every streamed frame
//! must reach the SDO helper's "other frames" sink or the receive after it. 3. `recv_timeout`
//! never returns empty before its timeout (lateness reported).
//!
//!   sockcheck --iface vcan0 [--frames N] [--sdo N]

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant as WallInstant};

use cnc402_drives::bus::CanBus;
use cnc402_drives::master::BlockingSdo;
use cnc402_drives::socketcan::SocketCanBus;
use cnc402_drives::wire::{CanFrame, NodeId};

fn fail(msg: String) -> ! {
    println!("FAIL: {msg}");
    std::process::exit(1);
}

/// Frame `i` of the burst: the id cycles through TPDO1, EMCY, heartbeat and SDO response
/// COB-IDs of node 0x21 (no simulated drive uses it); the data carry `i`.
fn burst_frame(i: u32) -> CanFrame {
    let id = [0x1A1u16, 0x0A1, 0x721, 0x5A1][(i % 4) as usize];
    let b = i.to_le_bytes();
    let data: &[u8] = match i % 4 {
        2 => &b[..1],
        _ => &[b[0], b[1], b[2], b[3], 0xA5, 0x5A, 0, 8],
    };
    CanFrame::new(id, data).unwrap_or_else(|e| fail(format!("frame {i}: {e}")))
}

/// Check 1: a burst, received complete and in order. Receiving runs on a thread so the kernel's
/// socket buffer never has to hold the whole burst. Gives the receiving socket back.
fn check_burst(tx: &mut SocketCanBus, mut rx: SocketCanBus, frames: u32) -> SocketCanBus {
    let t0 = WallInstant::now();
    let receiver = std::thread::spawn(move || {
        let mut got: Vec<CanFrame> = Vec::with_capacity(frames as usize);
        while (got.len() as u32) < frames {
            match rx.recv_timeout(Duration::from_secs(2)) {
                Ok(Some(f)) => {
                    if f.id() & 0x7F == 0x21 {
                        got.push(f);
                    }
                }
                Ok(None) => break,
                Err(e) => fail(format!("receive: {e}")),
            }
        }
        (rx, got)
    });
    std::thread::sleep(Duration::from_millis(50));
    // At the pace of a full 1 Mbit/s bus (~7400 frames/s): vcan itself has no bit rate,
    // and a burst faster than any real bus only measures the kernel's socket buffers.
    let pace = WallInstant::now();
    for i in 0..frames {
        if let Err(e) = tx.send(&burst_frame(i)) {
            fail(format!("send of frame {i}: {e}"));
        }
        if i % 8 == 7 {
            let due = Duration::from_micros(135 * (i as u64 + 1));
            if let Some(wait) = due.checked_sub(pace.elapsed()) {
                std::thread::sleep(wait);
            }
        }
    }
    let (rx, got) = receiver
        .join()
        .unwrap_or_else(|_| fail("receiver panicked".into()));
    if got.len() as u32 != frames {
        fail(format!("burst: sent {frames}, received {}", got.len()));
    }
    for (i, f) in got.iter().enumerate() {
        if *f != burst_frame(i as u32) {
            fail(format!(
                "burst: frame {i} is {f}, expected {}",
                burst_frame(i as u32)
            ));
        }
    }
    println!(
        "ok: burst of {frames} mixed frames (TPDO/EMCY/heartbeat/SDO ids) received complete and in order in {:.1} ms; tx retries {}",
        t0.elapsed().as_secs_f64() * 1e3,
        tx.tx_retries()
    );
    rx
}

/// Check 2: SDO uploads while a PDO stream runs: every streamed frame reaches the SDO helper's
/// "other frames" sink or the receive after it. Gives the receiving socket back.
fn check_sdo_under_pdo_stream(
    mut tx: SocketCanBus,
    mut rx: SocketCanBus,
    sdo_count: u32,
) -> SocketCanBus {
    let stop = Arc::new(AtomicBool::new(false));
    let stop2 = stop.clone();
    let streamer = std::thread::spawn(move || {
        let mut sent = 0u32;
        while !stop2.load(Ordering::SeqCst) {
            let b = sent.to_le_bytes();
            let f = CanFrame::new(0x1A2, &[b[0], b[1], b[2], b[3], 0, 0])
                .unwrap_or_else(|e| fail(format!("{e}")));
            if tx.send(&f).is_ok() {
                sent += 1;
            }
            std::thread::sleep(Duration::from_micros(200));
        }
        sent
    });
    let mut pdos: Vec<u32> = Vec::new();
    let mut record = |f: &CanFrame| {
        if f.id() == 0x1A2 {
            let d = f.data();
            pdos.push(u32::from_le_bytes([d[0], d[1], d[2], d[3]]));
        }
    };
    let node = NodeId::new(3).unwrap_or_else(|e| fail(format!("{e}")));
    let t1 = WallInstant::now();
    {
        let mut sdo = BlockingSdo::new(&mut rx, Duration::from_millis(500), &mut record);
        for k in 0..sdo_count {
            match sdo.read_string(node, 0x1008, 0) {
                Ok(s) if s.contains("simdrive") => {}
                Ok(s) => fail(format!("SDO {k}: unexpected name {s:?}")),
                Err(e) => fail(format!("SDO {k}: {e} (is simpeer running?)")),
            }
        }
    }
    let sdo_ms = t1.elapsed().as_secs_f64() * 1e3;
    stop.store(true, Ordering::SeqCst);
    let sent = streamer
        .join()
        .unwrap_or_else(|_| fail("streamer panicked".into()));
    // What arrived after the last transfer.
    while let Ok(Some(f)) = rx.recv_timeout(Duration::from_millis(200)) {
        record(&f);
    }
    let in_order = pdos.windows(2).all(|w| w[1] == w[0] + 1);
    if pdos.len() as u32 != sent || !in_order || pdos.first().is_some_and(|&x| x != 0) {
        fail(format!(
            "PDO stream during SDO: sent {sent}, seen {} (in order: {in_order})",
            pdos.len()
        ));
    }
    println!(
        "ok: {sdo_count} segmented SDO uploads ({:.2} ms each) while {sent} PDOs streamed: all {sent} PDOs handed on, in order",
        sdo_ms / sdo_count.max(1) as f64
    );
    rx
}

/// Check 3: `recv_timeout` on a quiet bus: never returns empty before the timeout; how late it is
/// is reported (timing in an emulated guest is loose).
fn check_recv_timeout(rx: &mut SocketCanBus) {
    let mut late_us = Vec::new();
    for want_us in [300u64, 800, 2500] {
        for _ in 0..20 {
            let t = WallInstant::now();
            match rx.recv_timeout(Duration::from_micros(want_us)) {
                Ok(Some(_)) => continue, // a frame came (heartbeats): not a timeout sample
                Ok(None) => {
                    let took = t.elapsed();
                    if took < Duration::from_micros(want_us) {
                        fail(format!(
                            "recv_timeout({want_us} µs) returned empty after {took:?}"
                        ));
                    }
                    late_us.push(took.as_secs_f64() * 1e6 - want_us as f64);
                }
                Err(e) => fail(format!("recv_timeout: {e}")),
            }
        }
    }
    late_us.sort_by(|a, b| a.total_cmp(b));
    if let (Some(first), Some(last)) = (late_us.first(), late_us.last()) {
        println!(
            "ok: recv_timeout never early ({} samples of 0.3/0.8/2.5 ms); lateness min {first:.0} µs, p50 {:.0} µs, max {last:.0} µs",
            late_us.len(),
            late_us[late_us.len() / 2]
        );
    }
}

fn main() {
    let mut iface = String::from("vcan0");
    let mut frames: u32 = 5000;
    let mut sdo_count: u32 = 50;
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let v = args.next().unwrap_or_default();
        match a.as_str() {
            "--iface" => iface = v,
            "--frames" => frames = v.parse().unwrap_or(frames),
            "--sdo" => sdo_count = v.parse().unwrap_or(sdo_count),
            _ => fail(format!("unknown argument {a}")),
        }
    }
    let open =
        |what: &str| SocketCanBus::open(&iface).unwrap_or_else(|e| fail(format!("{what}: {e}")));
    let mut tx = open("sender");
    let rx = open("receiver");

    let rx = check_burst(&mut tx, rx, frames);
    let mut rx = check_sdo_under_pdo_stream(tx, rx, sdo_count);
    check_recv_timeout(&mut rx);
    let c = rx.counters();
    println!(
        "receiver counters: rx {} frames, {} bits; error frames {}",
        c.rx_frames,
        c.bus_bits,
        rx.error_frames()
    );
}
