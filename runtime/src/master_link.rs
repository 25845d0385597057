//! [`MasterLink`]: the CANopen [`Master`] on any bus with a clock, as the loop's [`DriveLink`].
//! Boot, configuration, enable and disable run outside the loop on the bus's clock
//! ([`TimedBus`]); cycles map the loop's deadlines onto that clock. A transport only says what
//! happens right before each cycle ([`CycleBus`]): the simulated bus advances its time there.

use cia402::State;
use cnc402_config::{MAX_AXES, MachineConfig};
use cnc402_drives::Instant;
use cnc402_drives::bus::BusCounters;
use cnc402_drives::master::{
    HomingError, HomingReport, Master, MasterConfigError, MasterOptions, Phase, SafetyStop,
    StopMode, StopReason, TimedBus,
};
use cnc402_drives::wire::NmtState;

use crate::link::{DriveFeedback, DriveLink, DriveStop, Startup, StopCause};

/// A bus the master can run its cycles on.
pub trait CycleBus: TimedBus {
    /// Called right before the master's cycle at bus time `t`, `since_start` after the first
    /// cyclic SYNC. Must not allocate, log or block.
    fn before_cycle(&mut self, t: Instant, since_start: core::time::Duration) {
        let _ = (t, since_start);
    }
    /// The bit rate, for bus load.
    fn bitrate(&self) -> u32;
    /// Called with `true` once boot succeeded (the cyclic phase begins: sends must not wait)
    /// and with `false` before the blocking shutdown.
    fn set_cyclic(&mut self, cyclic: bool) {
        let _ = cyclic;
    }
}

/// Implements [`CanBus`](cnc402_drives::bus::CanBus) and [`TimedBus`] for a machine type by
/// forwarding every call to its field `$field` (the machines wrap a bus and add only
/// [`CycleBus`] behaviour). A macro because a blanket impl of the drives crate's traits over
/// a local "wrapper" trait is not allowed by the orphan rule.
macro_rules! forward_timed_bus {
    ($machine:ty, $field:ident) => {
        impl cnc402_drives::bus::CanBus for $machine {
            fn send(
                &mut self,
                frame: &cnc402_drives::wire::CanFrame,
            ) -> Result<(), cnc402_drives::bus::BusError> {
                cnc402_drives::bus::CanBus::send(&mut self.$field, frame)
            }
            fn recv(
                &mut self,
            ) -> Result<Option<cnc402_drives::wire::CanFrame>, cnc402_drives::bus::BusError> {
                cnc402_drives::bus::CanBus::recv(&mut self.$field)
            }
            fn recv_timeout(
                &mut self,
                timeout: core::time::Duration,
            ) -> Result<Option<cnc402_drives::wire::CanFrame>, cnc402_drives::bus::BusError> {
                cnc402_drives::bus::CanBus::recv_timeout(&mut self.$field, timeout)
            }
            fn counters(&self) -> cnc402_drives::bus::BusCounters {
                cnc402_drives::bus::CanBus::counters(&self.$field)
            }
        }

        impl cnc402_drives::master::TimedBus for $machine {
            fn now(&self) -> cnc402_drives::Instant {
                cnc402_drives::master::TimedBus::now(&self.$field)
            }
            fn recv_until(
                &mut self,
                deadline: cnc402_drives::Instant,
            ) -> Result<Option<cnc402_drives::wire::CanFrame>, cnc402_drives::bus::BusError> {
                cnc402_drives::master::TimedBus::recv_until(&mut self.$field, deadline)
            }
        }
    };
}
pub(crate) use forward_timed_bus;

/// How long start-up may take on a [`MasterLink`]; see [`MasterLink::with_timeouts`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LinkTimeouts {
    /// Waiting for every drive's boot-up after NMT reset communication (a drive process that
    /// starts late, a slow emulated guest).
    pub boot: core::time::Duration,
    /// The enable sequence, fault reset included.
    pub enable: core::time::Duration,
}

impl Default for LinkTimeouts {
    /// The master's defaults (10 s boot, 3 s enable): right for the embedded simulator.
    fn default() -> Self {
        let m = MasterOptions::default();
        LinkTimeouts {
            boot: m.boot_timeout,
            enable: m.enable_timeout,
        }
    }
}

impl LinkTimeouts {
    /// Generous limits for a real bus: 30 s for boot-up, 10 s for enable. In the HIL's
    /// emulated guest a process starts in 0.1-0.7 s and a 1 ms loop misses deadlines by up to
    /// ~100 ms, so the enable sequence's cycles (each waited for on the socket's clock) can
    /// take far longer than on a real controller.
    pub fn real_bus() -> LinkTimeouts {
        LinkTimeouts {
            boot: core::time::Duration::from_secs(30),
            enable: core::time::Duration::from_secs(10),
        }
    }
}

/// See the module doc.
pub struct MasterLink<B: CycleBus> {
    pub(crate) bus: B,
    master: Master,
    n_axes: usize,
    has_drive: [bool; MAX_AXES],
    /// Bus time of the first cyclic SYNC, and the loop time it corresponds to.
    bus_base: Instant,
    loop_base: Option<Instant>,
    last: [f64; MAX_AXES],
    quick_stop_sent: bool,
    /// Actual counts at the previous quick-stop cycle (`None` before the first).
    prev_counts: [Option<i64>; MAX_AXES],
    /// `[machine] require_homing`: start-up homes every axis with a `homing` key after boot.
    home_at_startup: bool,
}

impl<B: CycleBus> MasterLink<B> {
    /// A master for `cfg`'s drives on `bus`. Its stop reaction follows the path: healthy drives
    /// keep taking the interpolator's (decelerating) setpoints so that a tap stays coupled,
    /// and quick stop goes to every drive once the path is at rest.
    pub fn new(cfg: &MachineConfig, bus: B) -> Result<MasterLink<B>, MasterConfigError> {
        MasterLink::with_timeouts(cfg, bus, LinkTimeouts::default())
    }

    /// As [`new`](Self::new), with the boot and enable limits given.
    pub fn with_timeouts(
        cfg: &MachineConfig,
        bus: B,
        timeouts: LinkTimeouts,
    ) -> Result<MasterLink<B>, MasterConfigError> {
        let options = MasterOptions {
            stop_mode: StopMode::FollowPath,
            boot_timeout: timeouts.boot,
            enable_timeout: timeouts.enable,
            ..MasterOptions::default()
        };
        let master = Master::with_options(cfg, options)?;
        Ok(MasterLink {
            bus,
            master,
            n_axes: cfg.axes.len().min(MAX_AXES),
            has_drive: core::array::from_fn(|i| cfg.axes.get(i).is_some_and(|a| a.node.is_some())),
            bus_base: Instant::ZERO,
            loop_base: None,
            last: [0.0; MAX_AXES],
            quick_stop_sent: false,
            prev_counts: [None; MAX_AXES],
            home_at_startup: cfg.machine.require_homing,
        })
    }

    /// Homes `axes` (config indices) after start-up, blocking on the bus's clock (see
    /// [`Master::home`]); the cyclic phase then starts where homing left the drives.
    pub fn home(&mut self, axes: &[usize]) -> Result<HomingReport, HomingError> {
        let r = self.master.home(&mut self.bus, axes)?;
        self.bus_base = r.last_cycle + self.master.period();
        self.last = self.master.positions();
        Ok(r)
    }

    /// Whether each axis has its machine reference (homed since boot, or absolute).
    pub fn homed(&self) -> [bool; MAX_AXES] {
        core::array::from_fn(|i| self.master.is_homed(i))
    }

    /// Start-up homing when the config requires it: every axis with a `homing` key.
    fn home_required(&mut self) -> Result<(), String> {
        if !self.home_at_startup {
            return Ok(());
        }
        let axes = self.master.homing_axes();
        let r = match self.home(&axes) {
            Ok(r) => r,
            Err(e) => {
                // No run follows: the drives go to rest rather than wait for the master's
                // heartbeat to stop.
                if let Err(d) = self.master.disable(&mut self.bus) {
                    log::warn!("after the failed homing: {d}");
                }
                return Err(format!("{e}"));
            }
        };
        for a in &r.axes {
            log::info!(
                "axis {} homed at {} in {:.3} s",
                a.axis,
                a.position,
                a.took.as_secs_f64()
            );
        }
        Ok(())
    }

    /// The master.
    pub fn master(&self) -> &Master {
        &self.master
    }

    fn bus_time(&mut self, now: Instant) -> Instant {
        if self.loop_base.is_none() {
            // A bus on the wall clock (SocketCAN) has gone on since the last enable cycle
            // while the loop got ready: its first cycle is now, not in the past. (The
            // simulated bus stands at the last enable cycle: it keeps enabled_at + period.)
            self.bus_base = self.bus_base.max(self.bus.now());
            self.loop_base = Some(now);
        }
        let base = self.loop_base.unwrap_or(now);
        self.bus_base + now.saturating_since(base)
    }

    /// The bus.
    pub fn bus(&self) -> &B {
        &self.bus
    }

    fn exchange(
        &mut self,
        t: Instant,
        commands: &[f64; MAX_AXES],
        fb: &mut [DriveFeedback; MAX_AXES],
    ) -> Result<(), SafetyStop> {
        self.bus.before_cycle(t, t.saturating_since(self.bus_base));
        let r = self
            .master
            .cycle(&mut self.bus, t, &commands[..self.n_axes]);
        // Every cycle, the tripping one included, leaves its whole feedback (statuswords,
        // following errors, ages) in `last_feedback`: one conversion for both outcomes.
        let f = self.master.last_feedback();
        for (i, fb) in fb.iter_mut().enumerate().take(self.n_axes) {
            *fb = DriveFeedback {
                actual: f.actual[i],
                statusword: f.statusword[i].map_or(0, |s| s.0),
                following_error: f.following_error[i],
                age: f.age[i],
                actual_counts: f.actual_counts[i],
                target: f.target[i],
            };
        }
        r.map(|_| ())
    }
}

/// The loop's view of a master safety stop.
pub fn drive_stop(s: &SafetyStop) -> DriveStop {
    let cause = match s.reason {
        StopReason::DriveFault => StopCause::DriveFault,
        StopReason::Emergency => StopCause::Emergency,
        StopReason::NmtState(NmtState::BootUp) => StopCause::DriveRebooted,
        StopReason::NotEnabled | StopReason::NmtState(_) => StopCause::NotEnabled,
        StopReason::HeartbeatLost { .. } => StopCause::HeartbeatLost,
        StopReason::TpdoMissing { .. } | StopReason::StatuswordStale { .. } => {
            StopCause::TpdoMissing
        }
        StopReason::FollowingError { .. } => StopCause::FollowingError,
        StopReason::BadSetpoint => StopCause::BadSetpoint,
        StopReason::Bus(_) => StopCause::Bus,
        StopReason::LimitSwitch { .. } => StopCause::LimitSwitch,
        StopReason::EstopOpen { .. } => StopCause::EstopOpen,
    };
    DriveStop {
        cause,
        node: s.node.unwrap_or(0),
        statusword: s.statusword.map_or(0, |w| w.0),
        emcy: s.emcy.map(|e| e.code),
        bus: match s.reason {
            StopReason::Bus(e) => Some(e),
            _ => None,
        },
    }
}

impl<B: CycleBus> DriveLink for MasterLink<B> {
    fn startup(&mut self, _now: Instant) -> Startup {
        if self.master.phase() == Phase::Running {
            // Already started (a caller that asks twice): the drives hold where they are.
            return Startup::Ready(self.master.positions());
        }
        // Boot blocks on the bus's clock (SDO configuration, enable).
        match self.master.boot(&mut self.bus) {
            Ok(report) => {
                log::info!(
                    "drives enabled: {} drive(s), enable took {} cycles, bus time {}",
                    report.drives.len(),
                    report.enable_cycles,
                    self.bus.now()
                );
                for d in &report.drives {
                    for s in &d.skipped_parameters {
                        log::info!(
                            "axis {} (node {}): DCF value {:#06x}:{:02x} \"{}\" ({}) not written: {}",
                            d.axis,
                            d.node,
                            s.index,
                            s.sub,
                            s.name,
                            s.origin,
                            s.reason
                        );
                    }
                }
                // The first cyclic SYNC follows the last enable cycle by one period.
                self.bus_base = report.enabled_at + self.master.period();
                self.last = self.master.positions();
                if let Some(e) = self.master.estop_open(&mut self.bus) {
                    let _ = self.master.disable(&mut self.bus);
                    return Startup::Failed(e);
                }
                if let Err(e) = self.home_required() {
                    return Startup::Failed(e);
                }
                self.bus.set_cyclic(true);
                Startup::Ready(self.last)
            }
            Err(e) => Startup::Failed(format!("{e}")),
        }
    }

    fn cycle(
        &mut self,
        now: Instant,
        commands: &[f64; MAX_AXES],
        fb: &mut [DriveFeedback; MAX_AXES],
    ) -> Result<(), DriveStop> {
        let t = self.bus_time(now);
        self.last = *commands;
        self.exchange(t, commands, fb).map_err(|s| drive_stop(&s))
    }

    fn quick_stop(&mut self, now: Instant, fb: &mut [DriveFeedback; MAX_AXES]) -> bool {
        if !self.quick_stop_sent {
            self.master.quick_stop();
            self.quick_stop_sent = true;
        }
        let t = self.bus_time(now);
        let hold = self.last;
        let _ = self.exchange(t, &hold, fb);
        // Stopped: every drive out of OPERATION ENABLED and no axis moved by a count since
        // the last cycle (quick stop ramps take their time). The first quick-stop cycle has
        // no previous position and counts as moving.
        let mut stopped = true;
        for (i, fb) in fb.iter().enumerate().take(self.n_axes) {
            if self.has_drive[i] {
                let state = cia402::Statusword(fb.statusword).state();
                let moved = self.prev_counts[i].is_none_or(|p| fb.actual_counts.abs_diff(p) >= 1);
                stopped &= state != Some(State::OperationEnabled) && !moved;
            }
            self.prev_counts[i] = Some(fb.actual_counts);
        }
        stopped
    }

    fn counters(&self) -> BusCounters {
        self.bus.counters()
    }

    fn bitrate(&self) -> u32 {
        self.bus.bitrate()
    }

    fn homed(&self) -> [bool; MAX_AXES] {
        MasterLink::homed(self)
    }

    fn set_output(&mut self, which: cnc402_drives::master::Output, on: bool) {
        self.master.set_output(which, on);
    }

    fn shutdown(&mut self) -> Result<(), String> {
        self.bus.set_cyclic(false);
        // Coolant and spindle enable off before the power stage (the clamp holds the tool).
        let rest = self.master.outputs_to_rest(&mut self.bus);
        self.master
            .disable(&mut self.bus)
            .map_err(|e| e.to_string())?;
        rest.map_err(|e| format!("machine outputs not switched off: {e}"))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim_machine::SimMachine;

    /// The simulated machine, recording the `set_cyclic` calls.
    struct Recording {
        bus: SimMachine,
        calls: Vec<bool>,
    }

    forward_timed_bus!(Recording, bus);

    impl CycleBus for Recording {
        fn before_cycle(&mut self, t: Instant, since_start: core::time::Duration) {
            self.bus.before_cycle(t, since_start);
        }
        fn bitrate(&self) -> u32 {
            self.bus.bitrate()
        }
        fn set_cyclic(&mut self, cyclic: bool) {
            self.calls.push(cyclic);
        }
    }

    #[test]
    fn blocking_sends_inside_the_loop_cyclic_phase_is_announced_after_boot_only() {
        let cfg = MachineConfig::default_machine();
        let bus = Recording {
            bus: SimMachine::new(&cfg, None).expect("sim machine"),
            calls: Vec::new(),
        };
        let mut link = MasterLink::new(&cfg, bus).expect("master");
        assert!(link.bus().calls.is_empty(), "nothing before boot");
        let start = match link.startup(Instant::ZERO) {
            Startup::Ready(p) => p,
            other => panic!("start-up: {other:?}"),
        };
        // Boot's blocking SDO ran with the boot budget; the cyclic phase starts now.
        assert_eq!(link.bus().calls, [true]);
        let mut fb = [DriveFeedback::default(); MAX_AXES];
        let period = link.master().period();
        link.cycle(Instant::ZERO + period, &start, &mut fb)
            .expect("a healthy cycle");
        assert_eq!(link.bus().calls, [true], "cycles do not switch the budget");
        link.shutdown().expect("disable");
        assert_eq!(link.bus().calls, [true, false], "shutdown may wait again");
    }
}

#[cfg(test)]
mod count_tests {
    use super::*;
    use cnc402_motion::to_counts_wrapping;

    #[test]
    fn positions_scaled_to_counts_twice_feedback_carries_the_masters_counts() {
        let cfg = MachineConfig::default_machine();
        let mut link = MasterLink::simulated(&cfg, None).expect("sim");
        let start = match link.startup(Instant::ZERO) {
            Startup::Ready(p) => p,
            other => panic!("start-up: {other:?}"),
        };
        let period = link.master().period();
        let mut cmd = start;
        cmd[0] += 0.12345; // X, a fraction of a count off the grid
        let mut fb = [DriveFeedback::default(); MAX_AXES];
        let mut t = Instant::ZERO;
        for _ in 0..400 {
            t += period;
            link.cycle(t, &cmd, &mut fb).expect("healthy");
        }
        let n = cfg.axes.len();
        let master = link.master().last_feedback();
        for i in 0..n {
            let cpu = cfg.axes[i].counts_per_unit;
            // The setpoint is the one the master sent, scaled once.
            assert_eq!(fb[i].target, to_counts_wrapping(cmd[i], cpu), "axis {i}");
            assert_eq!(fb[i].target, master.target[i], "axis {i}");
            // The actual count is the master's exact unwrapped count, not re-derived.
            assert_eq!(fb[i].actual_counts, master.actual_counts[i], "axis {i}");
            assert_eq!(fb[i].actual, fb[i].actual_counts as f64 / cpu, "axis {i}");
        }
        // X came to rest on its setpoint.
        assert_eq!(fb[0].actual_counts as i32, fb[0].target);
    }
}
