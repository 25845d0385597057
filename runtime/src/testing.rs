//! Test and benchmark doubles, only with the `testing` feature (and in this crate's own
//! tests): [`ModelLink`], a bus-less machine whose drives follow after a pure delay. The
//! product has one drive model, the CANopen master's; this one exists to test the loop.

use cnc402_config::{MAX_AXES, MachineConfig};
use cnc402_drives::Instant;
use cnc402_drives::bus::BusCounters;
use cnc402_motion::to_counts_wrapping;

use crate::link::{
    DriveFeedback, DriveLink, DriveStop, FaultPlan, SW_FAULT, SW_OPERATION_ENABLED,
    SW_QUICK_STOP_ACTIVE, Startup, StopCause,
};

/// A machine without a bus: each drive follows its command after `delay` cycles, exactly.
/// For loop tests and the bus-less benchmark peer; a [`FaultPlan`] makes one drive fault.
#[derive(Clone, Debug)]
pub struct ModelLink {
    n_axes: usize,
    nodes: [u8; MAX_AXES],
    /// Delay line per axis, 8 deep (ring, index `head`).
    line: [[f64; 8]; MAX_AXES],
    delay: usize,
    head: usize,
    start: [f64; MAX_AXES],
    sw: [u16; MAX_AXES],
    fault: Option<FaultPlan>,
    t0: Option<Instant>,
    startup_cycles: u32,
    reported: bool,
    counts_per_unit: [f64; MAX_AXES],
    /// The last setpoints, in counts.
    target: [i32; MAX_AXES],
}

impl ModelLink {
    /// A model of `cfg`'s drives standing at `start` (axis units), following with a pure
    /// delay of `delay` cycles (0..=7), enabling after a few cycles.
    pub fn new(cfg: &MachineConfig, start: [f64; MAX_AXES], delay: usize) -> ModelLink {
        let n_axes = cfg.axes.len().min(MAX_AXES);
        let mut nodes = [0u8; MAX_AXES];
        for (n, a) in nodes.iter_mut().zip(&cfg.axes) {
            *n = a.node.unwrap_or(0);
        }
        let mut line = [[0.0; 8]; MAX_AXES];
        for (l, s) in line.iter_mut().zip(start) {
            *l = [s; 8];
        }
        ModelLink {
            n_axes,
            nodes,
            line,
            delay: delay.min(7),
            head: 0,
            start,
            sw: [0x0250; MAX_AXES],
            fault: None,
            t0: None,
            startup_cycles: 0,
            reported: false,
            counts_per_unit: core::array::from_fn(|i| {
                cfg.axes.get(i).map_or(1.0, |a| a.counts_per_unit)
            }),
            target: core::array::from_fn(|i| {
                let cpu = cfg.axes.get(i).map_or(1.0, |a| a.counts_per_unit);
                to_counts_wrapping(start[i], cpu)
            }),
        }
    }

    /// Arms a fault.
    pub fn with_fault(mut self, plan: FaultPlan) -> ModelLink {
        self.fault = Some(plan);
        self
    }

    // Several per-axis arrays are indexed together: an index reads clearer than a zip of five.
    #[allow(clippy::needless_range_loop)]
    fn feedback(&self, fb: &mut [DriveFeedback; MAX_AXES]) {
        let tail = (self.head + 8 - self.delay) % 8;
        for i in 0..self.n_axes {
            fb[i] = DriveFeedback {
                actual: self.line[i][tail],
                statusword: self.sw[i],
                following_error: 0.0,
                age: 0,
                actual_counts: (self.line[i][tail] * self.counts_per_unit[i]).round() as i64,
                target: self.target[i],
            };
        }
    }
}

impl DriveLink for ModelLink {
    fn startup(&mut self, now: Instant) -> Startup {
        self.startup_cycles += 1;
        if self.startup_cycles < 4 {
            return Startup::Pending;
        }
        self.sw = [SW_OPERATION_ENABLED; MAX_AXES];
        self.t0 = Some(now);
        Startup::Ready(self.start)
    }

    #[allow(clippy::needless_range_loop)]
    fn cycle(
        &mut self,
        now: Instant,
        commands: &[f64; MAX_AXES],
        fb: &mut [DriveFeedback; MAX_AXES],
    ) -> Result<(), DriveStop> {
        let head = (self.head + 1) % 8;
        let tail = (self.head + 8 - self.delay) % 8;
        for i in 0..self.n_axes {
            self.target[i] = to_counts_wrapping(commands[i], self.counts_per_unit[i]);
            // A faulted or stopped drive ignores commands and holds (no brake model here).
            self.line[i][head] = if self.sw[i] == SW_OPERATION_ENABLED {
                commands[i]
            } else {
                self.line[i][tail]
            };
        }
        self.head = head;
        let mut stop = None;
        if let (Some(plan), Some(t0)) = (self.fault, self.t0)
            && now.saturating_since(t0) >= plan.at
            && !self.reported
        {
            self.reported = true;
            if let Some(i) = self.nodes[..self.n_axes]
                .iter()
                .position(|&n| n == plan.node)
            {
                self.sw[i] = SW_FAULT;
                stop = Some(DriveStop {
                    cause: StopCause::DriveFault,
                    node: plan.node,
                    statusword: SW_FAULT,
                    emcy: Some(plan.emcy),
                    bus: None,
                });
            }
        }
        self.feedback(fb);
        match stop {
            Some(s) => Err(s),
            None => Ok(()),
        }
    }

    fn quick_stop(&mut self, _now: Instant, fb: &mut [DriveFeedback; MAX_AXES]) -> bool {
        for i in 0..self.n_axes {
            if self.sw[i] == SW_OPERATION_ENABLED {
                self.sw[i] = SW_QUICK_STOP_ACTIVE;
            }
        }
        self.feedback(fb);
        true
    }

    fn counters(&self) -> BusCounters {
        BusCounters::default()
    }

    fn bitrate(&self) -> u32 {
        0
    }

    fn shutdown(&mut self) -> Result<(), String> {
        self.sw = [0x0250; MAX_AXES];
        Ok(())
    }
}

/// The bus-less model for `cfg`: each drive follows after the largest configured delay.
pub fn model_link(cfg: &MachineConfig, fault: Option<FaultPlan>) -> ModelLink {
    let delay = cfg
        .axes
        .iter()
        .map(|a| a.sim.delay_cycles as usize)
        .max()
        .unwrap_or(1);
    let link = ModelLink::new(cfg, [0.0; MAX_AXES], delay);
    match fault {
        Some(f) => link.with_fault(f),
        None => link,
    }
}
