//! The loop's dynamic matching of axes that must move together: the contouring axes
//! `[planner] match_axes` names, shaped all the time, and a rigid tap's tool axis and
//! spindle, shaped from the start of a tap move until they have caught up at rest. Each set
//! goes to the drives through [`AxisShaper`]s, so that every axis lags like the slowest drive
//! of its set by the master's models (`dynamics`) and the actual positions stay together.

use cnc402_config::{DriveModel, MAX_AXES, MachineConfig};
use cnc402_motion::TapCoupling;
use cnc402_motion::matching::{AxisShaper, settling_cycles, slowest};

/// A shaped setpoint this close to the path's (in counts) is left without a visible step.
const SETTLED_COUNTS: f64 = 0.01;

/// Axes shaped to one target model. Fixed size: a slot per axis of the set.
#[derive(Clone, Copy, Debug)]
struct ShapedSet {
    axes: [usize; MAX_AXES],
    n: usize,
    own: [DriveModel; MAX_AXES],
    target: DriveModel,
    shapers: [AxisShaper; MAX_AXES],
    /// A slot that passes its input through (a tap's follower meets the leader by itself).
    released: [bool; MAX_AXES],
    period_s: f64,
    /// Cycles the input has not changed, and after how many the set is caught up at the
    /// latest ([`settling_cycles`]).
    resting: u32,
    settle_cycles: u32,
    last_input: [f64; MAX_AXES],
}

impl ShapedSet {
    /// `axes` with models `own` shaped to the slowest of them, standing at `pos`.
    fn new(axes: &[usize], own: &[DriveModel], period_s: f64, pos: &[f64; MAX_AXES]) -> Self {
        let n = axes.len().min(own.len()).min(MAX_AXES);
        let target = slowest(&own[..n]).unwrap_or(DriveModel {
            delay_cycles: 0,
            bandwidth_hz: 0.0,
        });
        let mut set = ShapedSet {
            axes: [0; MAX_AXES],
            n,
            own: [target; MAX_AXES],
            target,
            shapers: [AxisShaper::new(target, target, period_s, 0.0); MAX_AXES],
            released: [false; MAX_AXES],
            period_s,
            resting: 0,
            settle_cycles: settling_cycles(target, period_s),
            last_input: [0.0; MAX_AXES],
        };
        set.axes[..n].copy_from_slice(&axes[..n]);
        set.own[..n].copy_from_slice(&own[..n]);
        set.anchor(pos);
        set
    }

    /// Fresh shapers standing at `pos`: nothing lags behind it.
    fn anchor(&mut self, pos: &[f64; MAX_AXES]) {
        for k in 0..self.n {
            let i = self.axes[k];
            self.shapers[k] = AxisShaper::new(self.own[k], self.target, self.period_s, pos[i]);
            self.last_input[k] = pos[i];
        }
        self.resting = 0;
    }

    /// Whether every axis's drive already lags like the target (nothing to shape).
    fn is_identity(&self) -> bool {
        self.shapers[..self.n].iter().all(AxisShaper::is_identity)
    }

    /// Shapes the set's axes of `cmds` in place. When `may_end` and every axis has caught up
    /// with its input (within `tolerance`, or the input has rested for the settling time),
    /// `cmds` keep the inputs exactly, the shapers start afresh there, and it returns true.
    fn shape(
        &mut self,
        cmds: &mut [f64; MAX_AXES],
        tolerance: &[f64; MAX_AXES],
        may_end: bool,
    ) -> bool {
        let input = *cmds;
        let mut caught_up = true;
        let mut rested = true;
        for k in 0..self.n {
            let i = self.axes[k];
            rested &= input[i] == self.last_input[k];
            self.last_input[k] = input[i];
            if self.released[k] {
                continue;
            }
            cmds[i] = self.shapers[k].shape(input[i]);
            caught_up &= self.shapers[k].settled_at(input[i], tolerance[i]);
        }
        self.resting = if rested {
            self.resting.saturating_add(1)
        } else {
            0
        };
        if may_end && (caught_up || self.resting >= self.settle_cycles) {
            for &i in &self.axes[..self.n] {
                cmds[i] = input[i];
            }
            self.anchor(&input);
            return true;
        }
        false
    }

    /// Axis `i`, if in the set, passes its input through from now on.
    fn release(&mut self, i: usize) {
        if let Some(k) = self.axes[..self.n].iter().position(|&a| a == i) {
            self.released[k] = true;
        }
    }
}

/// See the module doc.
#[derive(Clone, Copy, Debug)]
pub struct Matching {
    models: [Option<DriveModel>; MAX_AXES],
    tolerance: [f64; MAX_AXES],
    period_s: f64,
    /// The contouring set (`None`: not asked for, or every model equal), and whether its
    /// shaped setpoints differ from the path's.
    contour: Option<ShapedSet>,
    contour_lagging: bool,
    /// What a contouring axis's drive lags like once shaped: a tap matches it as this.
    contour_target: Option<DriveModel>,
    /// (tool axis, spindle axis) of the tap being shaped.
    tap: Option<ShapedSet>,
}

impl Matching {
    /// The models of `cfg`'s axes and its contouring set, standing at `pos`.
    pub fn new(cfg: &MachineConfig, pos: &[f64; MAX_AXES]) -> Matching {
        let mut models = [None; MAX_AXES];
        let mut tolerance = [0.0; MAX_AXES];
        for (i, a) in cfg.axes.iter().take(MAX_AXES).enumerate() {
            models[i] = a.dynamics;
            tolerance[i] = SETTLED_COUNTS / a.counts_per_unit;
        }
        let period_s = cfg.bus.period_s();
        let mut axes = [0; MAX_AXES];
        let mut own = [DriveModel {
            delay_cycles: 0,
            bandwidth_hz: 0.0,
        }; MAX_AXES];
        let mut n = 0;
        for &i in cfg.planner.match_axes.iter().filter(|&&i| i < MAX_AXES) {
            // The config gives every matched axis a model; one without is left alone.
            if let Some(m) = models[i]
                && n < MAX_AXES
            {
                (axes[n], own[n]) = (i, m);
                n += 1;
            }
        }
        let set = (n >= 2).then(|| ShapedSet::new(&axes[..n], &own[..n], period_s, pos));
        Matching {
            models,
            tolerance,
            period_s,
            contour_target: set.map(|s| s.target),
            contour: set.filter(|s| !s.is_identity()),
            contour_lagging: false,
            tap: None,
        }
    }

    /// What axis `i`'s drive lags like as the loop sends its setpoints: the contouring
    /// target if the axis contours matched, else its own model.
    fn effective_model(&self, i: usize) -> Option<DriveModel> {
        let in_contour = self
            .contour
            .as_ref()
            .is_some_and(|s| s.axes[..s.n].contains(&i));
        if in_contour {
            self.contour_target
        } else {
            self.models[i]
        }
    }

    /// A tap move of coupling `c` starts with the axes commanded at `pos`: shaping begins
    /// (unless it runs already, the tap's moves follow each other) when both axes have a
    /// model and they lag differently. A contouring tool axis already lags like the
    /// contouring target; the tap's shaping comes on top of that.
    pub fn start(&mut self, c: TapCoupling, pos: &[f64; MAX_AXES]) {
        let (t, s) = (usize::from(c.tool), usize::from(c.spindle));
        if self.tap.is_some() || t >= MAX_AXES || s >= MAX_AXES {
            return;
        }
        let (Some(mt), Some(ms)) = (self.effective_model(t), self.models[s]) else {
            return;
        };
        let set = ShapedSet::new(&[t, s], &[mt, ms], self.period_s, pos);
        if !set.is_identity() {
            self.tap = Some(set);
        }
    }

    /// Shapes `cmds` in place (the setpoints the drives get): a tap's pair first, then the
    /// contouring set (a contouring tool axis goes through both). `tapping`: a tap move runs,
    /// so its shaping may not end yet.
    pub fn apply(&mut self, cmds: &mut [f64; MAX_AXES], tapping: bool) {
        if let Some(set) = &mut self.tap
            && set.shape(cmds, &self.tolerance, !tapping)
        {
            self.tap = None;
        }
        if let Some(set) = &mut self.contour {
            self.contour_lagging = !set.shape(cmds, &self.tolerance, true);
        }
    }

    /// A drive of a tap stopped following: the other axis of the pair, `follower`, is sent
    /// the leader's actual position as it is from now on (it meets it by its own model).
    pub fn cancel(&mut self, follower: usize) {
        self.tap = None;
        if let Some(set) = &mut self.contour {
            set.release(follower);
        }
    }

    /// Whether shaped setpoints still differ from the path's (the loop must run on until
    /// they have caught up, so that the last setpoint is the commanded one exactly).
    pub fn is_active(&self) -> bool {
        self.tap.is_some() || self.contour_lagging
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mismatched_xy(match_axes: Vec<usize>) -> MachineConfig {
        let mut cfg = MachineConfig::default_machine();
        cfg.axes[0].dynamics = Some(DriveModel {
            delay_cycles: 2,
            bandwidth_hz: 40.0,
        });
        cfg.planner.match_axes = match_axes;
        cfg
    }

    #[test]
    fn the_contouring_set_catches_up_and_ends_on_the_path_exactly() {
        let cfg = mismatched_xy(vec![0, 1, 2]);
        let start = [1.0, 2.0, 3.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        let mut m = Matching::new(&cfg, &start);
        let mut cmd = start;
        let mut sent = cmd;
        m.apply(&mut sent, false);
        assert_eq!(sent, cmd, "at rest nothing is shaped");
        assert!(!m.is_active());
        // A ramp on Y: Y (the fast drive) is held back, X is not shaped at all.
        for k in 1..=100 {
            cmd[1] = 2.0 + 0.01 * k as f64;
            sent = cmd;
            m.apply(&mut sent, false);
            assert!(m.is_active());
            assert!(sent[1] < cmd[1], "{k}: {sent:?}");
            assert_eq!(sent[0], cmd[0]);
        }
        let mut ticks = 0;
        while m.is_active() {
            sent = cmd;
            m.apply(&mut sent, false);
            ticks += 1;
            assert!(ticks < 1000, "caught up");
        }
        assert_eq!(sent, cmd, "the last setpoint is the commanded one exactly");
    }

    #[test]
    fn no_set_and_equal_models_shape_nothing() {
        for cfg in [
            mismatched_xy(vec![]),
            MachineConfig {
                planner: cnc402_config::PlannerConfig {
                    match_axes: vec![0, 1],
                    ..Default::default()
                },
                ..MachineConfig::default_machine()
            },
        ] {
            let mut m = Matching::new(&cfg, &[0.0; MAX_AXES]);
            for k in 0..50 {
                let cmd = [k as f64 * 0.1; MAX_AXES];
                let mut sent = cmd;
                m.apply(&mut sent, false);
                assert_eq!(sent, cmd);
                assert!(!m.is_active());
            }
        }
    }

    #[test]
    fn a_contouring_tool_axis_is_matched_to_the_spindle_as_the_contouring_target() {
        // X slow (2 cycles, 40 Hz) makes Z contour like it; the spindle at 150 Hz / 1 cycle
        // must then be shaped to that in a tap, and Z gets nothing more.
        let cfg = mismatched_xy(vec![0, 1, 2]);
        let mut m = Matching::new(&cfg, &[0.0; MAX_AXES]);
        let c = TapCoupling {
            tool: 2,
            spindle: 3,
            ratio: 1.5 / 360.0,
        };
        m.start(c, &[0.0; MAX_AXES]);
        let tap = m.tap.expect("the spindle lags differently: shaped");
        assert!(
            tap.shapers[0].is_identity(),
            "Z already lags like the target"
        );
        assert!(!tap.shapers[1].is_identity());
        // Following a stopped spindle, Z leaves both sets.
        m.cancel(2);
        assert!(m.tap.is_none());
        let mut sent = [0.0, 0.0, 5.0, 0.0, 0.0, 0.0, 0.0, 0.0];
        m.apply(&mut sent, false);
        assert_eq!(sent[2], 5.0);
    }
}
