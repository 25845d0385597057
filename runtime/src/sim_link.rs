//! The embedded simulated machine: the CANopen [`Master`] on an in-process [`SimBus`] with one
//! [`SimDrive`] per configured drive node — the same frames a real bus carries, in the time the
//! loop passes in. Boot runs in the bus's virtual time; the cyclic phase maps the loop's time
//! onto the bus clock from there.

use core::time::Duration;

use cia402::State;
use cnc402_config::{MAX_AXES, MachineConfig};
use cnc402_drives::Instant;
use cnc402_drives::bus::{BusCounters, CanBus, SimBus};
use cnc402_drives::master::{Master, MasterOptions, SafetyStop, StopMode, StopReason};
use cnc402_drives::sim::{FaultKind, SimDrive, SimDriveOptions};
use cnc402_drives::wire::NodeId;

use crate::link::{DriveFeedback, DriveLink, DriveStop, FaultPlan, Startup, StopCause};

/// See the module doc.
pub struct SimLink {
    bus: SimBus<SimDrive>,
    master: Master,
    n_axes: usize,
    /// Device number on the bus of each axis's drive.
    device_of_axis: [Option<usize>; MAX_AXES],
    fault: Option<(FaultPlan, Option<usize>)>,
    fault_done: bool,
    /// Bus time when the cyclic phase began, and the loop time it corresponds to.
    bus_base: Instant,
    loop_base: Option<Instant>,
    last: [f64; MAX_AXES],
    quick_stop_sent: bool,
    prev_actual: [f64; MAX_AXES],
    counts_per_unit: [f64; MAX_AXES],
}

/// Why the simulated machine could not be built.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SimLinkError(pub String);

impl SimLink {
    /// Builds the bus and its drives from `cfg`; `initial` are the drives' positions at power-on
    /// (counts, config axis order; `None` = 0).
    pub fn new(
        cfg: &MachineConfig,
        initial: Option<[i32; MAX_AXES]>,
    ) -> Result<SimLink, SimLinkError> {
        let options = MasterOptions {
            stop_mode: StopMode::FollowPath,
            ..MasterOptions::default()
        };
        let master = Master::with_options(cfg, options).map_err(|e| SimLinkError(e.to_string()))?;
        let period = Duration::from_micros(cfg.bus.period_us as u64);
        let mut bus: SimBus<SimDrive> = SimBus::new(cfg.bus.bitrate);
        let mut device_of_axis = [None; MAX_AXES];
        for (i, a) in cfg.axes.iter().enumerate().take(MAX_AXES) {
            let Some(node) = a.node else { continue };
            let node = NodeId::new(node)
                .map_err(|e| SimLinkError(format!("axis {}: node {node}: {e:?}", a.name)))?;
            let opts = SimDriveOptions {
                initial_position: initial.map_or(0, |p| p[i]),
                ..SimDriveOptions::default()
            };
            device_of_axis[i] = Some(bus.attach(SimDrive::with_options(a, node, period, opts)));
        }
        Ok(SimLink {
            bus,
            master,
            n_axes: cfg.axes.len().min(MAX_AXES),
            device_of_axis,
            fault: None,
            fault_done: false,
            bus_base: Instant::ZERO,
            loop_base: None,
            last: [0.0; MAX_AXES],
            quick_stop_sent: false,
            prev_actual: [f64::NAN; MAX_AXES],
            counts_per_unit: core::array::from_fn(|i| {
                cfg.axes.get(i).map_or(1.0, |a| a.counts_per_unit)
            }),
        })
    }

    /// Arms a fault: drive `plan.node` goes to FAULT with EMCY `plan.emcy` at `plan.at` after
    /// the cyclic phase began.
    pub fn with_fault(mut self, plan: FaultPlan) -> SimLink {
        let axis = (0..self.n_axes).find(|&i| self.master.axis_of_node(plan.node) == Some(i));
        self.fault = Some((plan, axis.and_then(|i| self.device_of_axis[i])));
        self
    }

    /// The simulated bus (drives' state, counters).
    pub fn bus(&self) -> &SimBus<SimDrive> {
        &self.bus
    }

    /// The master.
    pub fn master(&self) -> &Master {
        &self.master
    }

    fn bus_time(&mut self, now: Instant) -> Instant {
        let base = *self.loop_base.get_or_insert(now);
        self.bus_base + now.saturating_since(base)
    }

    fn exchange(
        &mut self,
        t: Instant,
        commands: &[f64; MAX_AXES],
        fb: &mut [DriveFeedback; MAX_AXES],
    ) -> Result<(), SafetyStop> {
        self.bus.advance(t);
        let r = self
            .master
            .cycle(&mut self.bus, t, &commands[..self.n_axes]);
        let f = match &r {
            Ok(f) => Some(*f),
            Err(_) => None,
        };
        if let Some(f) = f {
            for i in 0..self.n_axes {
                fb[i] = DriveFeedback {
                    actual: f.actual[i],
                    statusword: f.statusword[i].map_or(0, |s| s.0),
                    following_error: f.following_error[i],
                };
            }
        } else {
            // The tripping cycle gives no feedback: keep the last, with the latched positions.
            let pos = self.master.positions();
            for i in 0..self.n_axes {
                fb[i].actual = pos[i];
            }
        }
        r.map(|_| ())
    }
}

/// The loop's view of a master safety stop.
pub fn drive_stop(s: &SafetyStop) -> DriveStop {
    let cause = match s.reason {
        StopReason::DriveFault => StopCause::DriveFault,
        StopReason::Emergency => StopCause::Emergency,
        StopReason::NotEnabled | StopReason::NmtState(_) => StopCause::NotEnabled,
        StopReason::HeartbeatLost { .. } => StopCause::HeartbeatLost,
        StopReason::TpdoMissing { .. } => StopCause::TpdoMissing,
        StopReason::FollowingError { .. } => StopCause::FollowingError,
        StopReason::BadSetpoint => StopCause::BadSetpoint,
        StopReason::Bus(_) => StopCause::Bus,
    };
    DriveStop {
        cause,
        node: s.node.unwrap_or(0),
        statusword: s.statusword.map_or(0, |w| w.0),
        emcy: s.emcy.map(|e| e.code),
    }
}

impl DriveLink for SimLink {
    fn startup(&mut self, _now: Instant) -> Startup {
        if self.master.phase() == cnc402_drives::master::Phase::Running {
            // Already started (a caller that asks twice): the drives hold where they are.
            return Startup::Ready(self.master.positions());
        }
        // Boot blocks in the bus's virtual time (SDO configuration, enable).
        match self.master.boot(&mut self.bus) {
            Ok(report) => {
                log::info!(
                    "drives enabled: {} drive(s), enable took {} cycles, bus time {}",
                    report.drives.len(),
                    report.enable_cycles,
                    self.bus.now()
                );
                // The first cyclic SYNC follows the last enable cycle by one period.
                self.bus_base = report.enabled_at + self.master.period();
                self.last = self.master.positions();
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
        if let Some((plan, Some(dev))) = self.fault
            && !self.fault_done
            && t.saturating_since(self.bus_base) >= plan.at
        {
            self.fault_done = true;
            if let Some(d) = self.bus.device_mut(dev) {
                d.inject(FaultKind::Fault(plan.emcy), t);
            }
        }
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
        // the last cycle (quick stop ramps take their time).
        let mut stopped = true;
        for i in 0..self.n_axes {
            if self.device_of_axis[i].is_some() {
                let state = cia402::Statusword(fb[i].statusword).state();
                let moved =
                    (fb[i].actual - self.prev_actual[i]).abs() * self.counts_per_unit[i] >= 1.0;
                stopped &= state != Some(State::OperationEnabled) && !moved;
            }
            self.prev_actual[i] = fb[i].actual;
        }
        stopped
    }

    fn counters(&self) -> BusCounters {
        self.bus.counters()
    }

    fn bitrate(&self) -> u32 {
        self.bus.bitrate()
    }

    fn shutdown(&mut self) -> Result<(), String> {
        self.master
            .disable(&mut self.bus)
            .map_err(|e| e.to_string())
    }
}
