//! The loop's dynamic matching of a rigid tap: from the start of a tap move the tool axis's
//! and the spindle's setpoints go to the drives through [`AxisShaper`]s, so that both lag
//! like the slower drive of the master's models (`dynamics`) and their actual positions stay
//! coupled; after the tap it stays on until the shaped setpoints have caught up at rest.

use cnc402_config::{DriveModel, MAX_AXES, MachineConfig};
use cnc402_motion::TapCoupling;
use cnc402_motion::matching::{AxisShaper, slowest};

/// A shaped setpoint this close to the path's (in counts) is left without a visible step.
const SETTLED_COUNTS: f64 = 0.01;

/// See the module doc.
#[derive(Clone, Copy, Debug)]
pub struct TapMatch {
    models: [Option<DriveModel>; MAX_AXES],
    tolerance: [f64; MAX_AXES],
    period_s: f64,
    /// (tool axis, spindle axis, their shapers) while shaping.
    active: Option<(usize, usize, [AxisShaper; 2])>,
}

impl TapMatch {
    /// The models of `cfg`'s axes; nothing is shaped yet.
    pub fn new(cfg: &MachineConfig) -> TapMatch {
        let mut models = [None; MAX_AXES];
        let mut tolerance = [0.0; MAX_AXES];
        for (i, a) in cfg.axes.iter().take(MAX_AXES).enumerate() {
            models[i] = a.dynamics;
            tolerance[i] = SETTLED_COUNTS / a.counts_per_unit;
        }
        TapMatch {
            models,
            tolerance,
            period_s: cfg.bus.period_s(),
            active: None,
        }
    }

    /// A tap move of coupling `c` starts with the axes standing at `pos`: shaping begins
    /// (unless it runs already, the tap's moves follow each other) when both axes have a
    /// model and the models differ.
    pub fn start(&mut self, c: TapCoupling, pos: &[f64; MAX_AXES]) {
        let (t, s) = (usize::from(c.tool), usize::from(c.spindle));
        if self.active.is_some() || t >= MAX_AXES || s >= MAX_AXES {
            return;
        }
        let (Some(mt), Some(ms)) = (self.models[t], self.models[s]) else {
            return;
        };
        let Some(target) = slowest(&[mt, ms]) else {
            return;
        };
        let shapers = [
            AxisShaper::new(mt, target, self.period_s, pos[t]),
            AxisShaper::new(ms, target, self.period_s, pos[s]),
        ];
        if !shapers.iter().all(AxisShaper::is_identity) {
            self.active = Some((t, s, shapers));
        }
    }

    /// Shapes `cmds` in place (the setpoints the drives get). `tapping`: a tap move runs, so
    /// shaping may not end yet.
    pub fn apply(&mut self, cmds: &mut [f64; MAX_AXES], tapping: bool) {
        let Some((t, s, sh)) = &mut self.active else {
            return;
        };
        let (t, s) = (*t, *s);
        let (xt, xs) = (cmds[t], cmds[s]);
        cmds[t] = sh[0].shape(xt);
        cmds[s] = sh[1].shape(xs);
        if !tapping
            && sh[0].settled_at(xt, self.tolerance[t])
            && sh[1].settled_at(xs, self.tolerance[s])
        {
            cmds[t] = xt;
            cmds[s] = xs;
            self.active = None;
        }
    }

    /// Stops shaping at once (a drive of the pair stopped following: the other follows its
    /// actual position instead).
    pub fn cancel(&mut self) {
        self.active = None;
    }

    /// Whether setpoints are being shaped.
    pub fn is_active(&self) -> bool {
        self.active.is_some()
    }
}
