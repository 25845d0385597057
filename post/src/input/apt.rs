//! APT/CL input (ISO 4343, the cutter-location data CAM systems write for post-processors):
//! `GOTO/`, `GODLTA/`, `CIRCLE/` (+ the `GOTO/` that ends the arc), `RAPID`, `FEDRAT/`
//! (`MMPM`, `MMPR`, `MMPT`, `IPM`…: per tooth, from the tool table), `SPINDL/` (`RPM`, `SMM`,
//! `SFM`: cutting speed, from the tool table; `CLW`, `CCLW`, `OFF`), `LOADTL/`, `COOLNT/`,
//! `CYCLE/DRILL|DEEP|BORE|TAP … CYCLE/OFF`, `UNITS/MM|INCHES`, `STOP`, `OPSTOP`, `PPRINT`,
//! `END`, `FINI`, read straight into canonical operations (XY plane, G54, the loaded tool's
//! length from the config as `G43 H`). A statement outside that set (`CUTCOM` among them)
//! is an error at its line.

use std::sync::Arc;

use cnc402_config::MachineConfig;
use cnc402_interp::canon::{
    CannedCycle, CanonKind, CanonOp, CanonState, CyclePlan, CycleWords, FeedMode, PathMode,
    ProgramUnits, TapPlan,
};
use cnc402_motion::segment::{ArcDir, AxisPos, Plane, SegmentKind, Source, SpindleDir, StopKind};

use super::tools::{ToolTable, feed_from_fz, rpm_from_vc};
use crate::PostError;

/// Whether a job is CL data: named `*.cl`, `*.cls` or `*.apt`, or its first statement is an
/// APT one (`PARTNO`, `LOADTL/`, `GOTO/` …).
pub fn is_cl(name: &str, text: &str) -> bool {
    let lower = name.to_ascii_lowercase();
    if [".cl", ".cls", ".apt"].iter().any(|e| lower.ends_with(e)) {
        return true;
    }
    let first = text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with("$$"));
    first.is_some_and(|l| {
        let word = l.split(['/', ' ', ',']).next().unwrap_or("");
        [
            "PARTNO", "LOADTL", "GOTO", "MULTAX", "UNITS", "CUTTER", "SPINDL", "FEDRAT", "PPRINT",
        ]
        .contains(&word)
    })
}

/// A cycle as `CYCLE/` set it up: code, depth, peck, feed, clearance, initial level.
#[derive(Clone, Copy, Debug)]
struct ClCycle {
    code: u32,
    depth: f64,
    step: Option<f64>,
    /// A tap's pitch (mm per revolution): a rigid tap, G84 (G74 with the spindle CCLW).
    pitch: Option<f64>,
    feed: f64,
    clearance: f64,
    initial: Option<f64>,
}

/// The reader's state.
struct Cl<'a> {
    cfg: &'a MachineConfig,
    tools: &'a ToolTable,
    file: Arc<str>,
    line: u32,
    state: Arc<CanonState>,
    pos: AxisPos,
    rapid: bool,
    feed: Option<f64>,
    rpm: f64,
    dir: SpindleDir,
    circle: Option<([f64; 3], ArcDir)>,
    cycle: Option<ClCycle>,
    coolant: (bool, bool),
    ops: Vec<CanonOp>,
    /// mm per length unit of the data (`UNITS/INCHES`: 25.4), and whether anything moved
    /// yet (units change only before).
    unit: f64,
    moved: bool,
}

/// The operations of CL text `text`.
pub fn read_cl(
    cfg: &MachineConfig,
    name: &str,
    text: &str,
    tools: &ToolTable,
) -> Result<Vec<CanonOp>, PostError> {
    let path_mode = match cfg.interp.path_mode {
        cnc402_config::PathModeDefault::ExactStop => PathMode::ExactStop,
        _ => PathMode::Continuous {
            tolerance: cfg.interp.path_tolerance,
            collinear: cfg.interp.collinear_tolerance,
        },
    };
    let mut cl = Cl {
        cfg,
        tools,
        file: name.into(),
        line: 0,
        state: Arc::new(CanonState {
            plane: Plane::XY,
            units: ProgramUnits::Mm,
            feed_mode: FeedMode::PerMinute,
            path_mode,
            work_offset: 0,
            offset: AxisPos(cfg.work_offsets[0]),
            tool: None,
            tool_length_mode: 49,
            h: 0,
            tool_length: 0.0,
            tool_axis: cfg.axis_index('Z'),
            comp: None,
        }),
        pos: AxisPos::default(),
        rapid: false,
        feed: None,
        rpm: 0.0,
        dir: SpindleDir::Stop,
        circle: None,
        cycle: None,
        coolant: (false, false),
        ops: Vec::new(),
        unit: 1.0,
        moved: false,
    };
    // Machine 0 is where a run starts; in work coordinates that is −offset.
    cl.pos = cl.state.to_work(&AxisPos::default());
    let mut statement = String::new();
    let mut first_line = 1;
    for (i, raw) in text.lines().enumerate() {
        let l = raw.trim();
        if statement.is_empty() {
            first_line = i as u32 + 1;
        }
        if l.starts_with("$$") || l.is_empty() {
            continue;
        }
        // A `$` at the end continues the statement on the next line.
        if let Some(part) = l.strip_suffix('$') {
            statement.push_str(part);
            continue;
        }
        statement.push_str(l);
        cl.line = first_line;
        cl.statement(&std::mem::take(&mut statement))?;
        if cl.ops.len() > crate::input::MAX_OPERATIONS {
            return Err(cl.error("the CL data has too many operations".into()));
        }
    }
    Ok(cl.ops)
}

impl Cl<'_> {
    fn error(&self, message: String) -> PostError {
        PostError::Target {
            target: "any",
            source: Some(self.source()),
            message,
        }
    }

    fn source(&self) -> Source {
        Source {
            file: self.file.clone(),
            line: self.line,
            n: None,
        }
    }

    fn push(&mut self, kind: CanonKind) {
        self.ops.push(CanonOp {
            kind,
            source: self.source(),
            state: self.state.clone(),
        });
    }

    fn statement(&mut self, s: &str) -> Result<(), PostError> {
        let (word, args) = match s.split_once('/') {
            Some((w, a)) => (w.trim(), a.trim()),
            None => (s.trim(), ""),
        };
        let list: Vec<&str> = args
            .split(',')
            .map(str::trim)
            .filter(|a| !a.is_empty())
            .collect();
        match word {
            "PARTNO" | "MULTAX" | "CUTTER" | "END" | "TPRINT" => Ok(()),
            "UNITS" => self.units(&list),
            "CUTCOM" => Err(self.error(
                "CUTCOM is not read: the CL points would be the part contour, and the proof of \
                 a CL job compares the posted program with the CL points as tool-centre moves \
                 (post the CAM's tool-centre output, CUTCOM/OFF throughout)"
                    .into(),
            )),
            "PPRINT" => {
                self.push(CanonKind::Single(SegmentKind::Message {
                    text: args.to_string(),
                }));
                Ok(())
            }
            "FINI" => self.stop(StopKind::EndRewind),
            "STOP" => self.stop(StopKind::Program),
            "OPSTOP" => self.stop(StopKind::Optional),
            "RAPID" => {
                self.rapid = true;
                Ok(())
            }
            "LOADTL" => self.load_tool(&list),
            "SPINDL" => self.spindle(&list),
            "FEDRAT" => self.feedrate(&list),
            "COOLNT" => self.coolant_statement(&list),
            "CIRCLE" => self.circle(&list),
            "CYCLE" => self.cycle_statement(&list),
            "GOTO" | "GODLTA" => {
                let v: Vec<f64> = self
                    .numbers(&list, 3)?
                    .iter()
                    .map(|v| v * self.unit)
                    .collect();
                self.moved = true;
                let mut end = self.pos;
                for (k, axis) in ['X', 'Y', 'Z'].into_iter().enumerate() {
                    if let Some(i) = self.cfg.axis_index(axis) {
                        end[i] = if word == "GOTO" {
                            v[k]
                        } else {
                            self.pos[i] + v[k]
                        };
                    }
                }
                self.goto(end)
            }
            _ => Err(self.error(format!(
                "{word} is not an APT/CL statement cnc402 reads (GOTO, GODLTA, CIRCLE, RAPID, \
                 FEDRAT, SPINDL, LOADTL, COOLNT, CYCLE, STOP, OPSTOP, PPRINT, PARTNO, END, FINI)"
            ))),
        }
    }

    fn numbers(&self, list: &[&str], at_least: usize) -> Result<Vec<f64>, PostError> {
        let v: Vec<f64> = list
            .iter()
            .map(|a| a.parse::<f64>().ok().filter(|v| v.is_finite()))
            .collect::<Option<_>>()
            .ok_or_else(|| self.error(format!("expected numbers, got {}", list.join(","))))?;
        if v.len() < at_least {
            return Err(self.error(format!("expected at least {at_least} numbers")));
        }
        Ok(v)
    }

    fn stop(&mut self, kind: StopKind) -> Result<(), PostError> {
        self.push(CanonKind::Single(SegmentKind::Stop { kind }));
        Ok(())
    }

    /// `LOADTL/n`: the tool, with its length from the config switched on (G43 Hn).
    fn load_tool(&mut self, list: &[&str]) -> Result<(), PostError> {
        let n = list
            .first()
            .and_then(|a| a.parse::<u32>().ok())
            .filter(|n| (1..=cnc402_config::TOOL_OFFSETS as u32).contains(n))
            .ok_or_else(|| self.error("LOADTL needs a tool number 1-400".into()))?;
        self.push(CanonKind::Single(SegmentKind::ToolChange { tool: n }));
        let t = self.cfg.tool_offsets[n as usize - 1];
        let mut st = (*self.state).clone();
        st.tool = Some(n);
        st.tool_length_mode = 43;
        st.h = n;
        st.tool_length = t.length + t.length_wear;
        st.offset = AxisPos(self.cfg.work_offsets[0]);
        if let Some(z) = st.tool_axis {
            st.offset[z] += st.tool_length;
        }
        // The tool stays where it is; its work coordinates change with the length.
        let machine = self.state.to_machine(&self.pos);
        self.pos = st.to_work(&machine);
        self.state = Arc::new(st);
        Ok(())
    }

    fn tool(&self) -> Result<super::tools::Tool, PostError> {
        let n = self
            .state
            .tool
            .ok_or_else(|| self.error("cutting data before a LOADTL".into()))?;
        self.tools.tool.get(&n).copied().ok_or_else(|| {
            self.error(format!(
                "tool {n} is not in the tool table (--tools: [tool.{n}] diameter, teeth; or \
                 the config's [tool_offsets] {n} = {{ diameter, teeth, vc, fz }})"
            ))
        })
    }

    /// A value of the loaded tool's cutting data, or which key it lacks.
    fn tool_value<T>(
        &self,
        key: &str,
        get: impl Fn(&super::tools::Tool) -> Option<T>,
    ) -> Result<T, PostError> {
        let tool = self.tool()?;
        get(&tool).ok_or_else(|| {
            let n = self.state.tool.unwrap_or(0);
            self.error(format!("tool {n} has no {key} in the tool table"))
        })
    }

    /// The number at the head of `list`, if it starts with one (a statement's own value).
    fn leading_number(&self, list: &[&str]) -> Result<Option<f64>, PostError> {
        match list.first() {
            Some(a)
                if a.starts_with(|c: char| c.is_ascii_digit() || matches!(c, '.' | '-' | '+')) =>
            {
                Ok(Some(self.numbers(&list[..1], 1)?[0]))
            }
            _ => Ok(None),
        }
    }

    /// `SPINDL/ n, RPM|SMM, CLW|CCLW` or `SPINDL/OFF`; without `n` (`SPINDL/CLW`), the
    /// loaded tool's Vc from the tool table.
    fn spindle(&mut self, list: &[&str]) -> Result<(), PostError> {
        if list.first() == Some(&"OFF") {
            self.dir = SpindleDir::Stop;
            self.push(CanonKind::Single(SegmentKind::Spindle {
                rpm: 0.0,
                dir: SpindleDir::Stop,
                spindle: 1,
            }));
            return Ok(());
        }
        let diameter = || self.tool_value("diameter", |t| t.diameter);
        self.rpm = match self.leading_number(list)? {
            Some(vc) if list.contains(&"SMM") => rpm_from_vc(vc, diameter()?),
            // Surface feet per minute: 0.3048 m each.
            Some(sfm) if list.contains(&"SFM") => rpm_from_vc(sfm * 0.3048, diameter()?),
            Some(rpm) => rpm,
            None => rpm_from_vc(self.tool_value("vc", |t| t.vc)?, diameter()?),
        };
        self.dir = if list.contains(&"CCLW") {
            SpindleDir::Ccw
        } else {
            SpindleDir::Cw
        };
        self.push(CanonKind::Single(SegmentKind::Spindle {
            rpm: self.rpm,
            dir: self.dir,
            spindle: 1,
        }));
        Ok(())
    }

    /// `FEDRAT/ f, MMPM|MMPR|MMPT` (mm/min, per revolution, per tooth); `FEDRAT/MMPT`
    /// without `f`: the loaded tool's fz from the tool table.
    fn feedrate(&mut self, list: &[&str]) -> Result<(), PostError> {
        let f = match self.leading_number(list)? {
            Some(f) => f,
            // The table's fz is mm per tooth whatever the data's units.
            None if list.first() == Some(&"MMPT") => {
                self.tool_value("fz", |t| t.fz)? / self.length_unit(list)
            }
            None => self.numbers(&list[..1.min(list.len())], 1)?[0],
        };
        let per_rev = || {
            if self.rpm > 0.0 {
                Ok(self.rpm)
            } else {
                Err(self.error("a feed per revolution or tooth with the spindle at 0 rpm".into()))
            }
        };
        let f = f * self.length_unit(list);
        let feed = if list.iter().any(|w| matches!(*w, "MMPR" | "IPR")) {
            f * per_rev()?
        } else if list.iter().any(|w| matches!(*w, "MMPT" | "IPT")) {
            feed_from_fz(f, self.tool_value("teeth", |t| t.teeth)?, per_rev()?)
        } else {
            f
        };
        if feed <= 0.0 {
            return Err(self.error("a feed must be > 0".into()));
        }
        self.feed = Some(feed);
        Ok(())
    }

    fn coolant_statement(&mut self, list: &[&str]) -> Result<(), PostError> {
        let (mist, flood) = match list.first().copied() {
            Some("ON") | Some("FLOOD") => (self.coolant.0, true),
            Some("MIST") => (true, self.coolant.1),
            Some("OFF") => (false, false),
            _ => return Err(self.error("COOLNT/ ON, FLOOD, MIST or OFF".into())),
        };
        self.coolant = (mist, flood);
        self.push(CanonKind::Single(SegmentKind::Coolant { mist, flood }));
        Ok(())
    }

    /// `UNITS/MM` or `UNITS/INCHES` (every length and feed of the data after it in inches;
    /// the posted program is then an inch program), before anything moves.
    fn units(&mut self, list: &[&str]) -> Result<(), PostError> {
        let (unit, units) = match list.first().copied() {
            Some("MM") => (1.0, ProgramUnits::Mm),
            Some("INCHES") | Some("INCH") => (25.4, ProgramUnits::Inch),
            _ => return Err(self.error("UNITS/ MM or INCHES".into())),
        };
        if self.moved && unit != self.unit {
            return Err(self.error("UNITS/ changes the units after the data moved".into()));
        }
        self.unit = unit;
        let mut st = (*self.state).clone();
        st.units = units;
        self.state = Arc::new(st);
        Ok(())
    }

    /// mm per unit of a value whose statement names its unit (`MMPM`, `MMPR`, `MMPT`: mm;
    /// `IPM`, `IPR`, `IPT`: inches), else the data's units.
    fn length_unit(&self, list: &[&str]) -> f64 {
        if list.iter().any(|w| matches!(*w, "MMPM" | "MMPR" | "MMPT")) {
            1.0
        } else if list.iter().any(|w| matches!(*w, "IPM" | "IPR" | "IPT")) {
            25.4
        } else {
            self.unit
        }
    }

    /// `CIRCLE/ xc, yc, zc, i, j, k, r`: the next `GOTO/` runs along it (axis +Z: CCW).
    fn circle(&mut self, list: &[&str]) -> Result<(), PostError> {
        let v = self.numbers(list, 7)?;
        if v[3].abs() > 1e-9 || v[4].abs() > 1e-9 || v[5].abs() < 1e-9 {
            return Err(
                self.error("CIRCLE with an axis other than ±Z (only XY arcs are read)".into())
            );
        }
        let dir = if v[5] > 0.0 { ArcDir::Ccw } else { ArcDir::Cw };
        let u = self.unit;
        self.circle = Some(([v[0] * u, v[1] * u, v[2] * u], dir));
        Ok(())
    }

    /// `CYCLE/DRILL, depth, MMPM|MMPR, f, clearance`, `CYCLE/DEEP, depth, STEP, q, MMPM, f,
    /// clearance`, `CYCLE/BORE, …`, `CYCLE/TAP, depth, MMPR, pitch, clearance` (or MMPM f:
    /// pitch f/n) (G81, G83, G85, G84 rigid at every GOTO), `CYCLE/OFF`; IPM/IPR in inches.
    fn cycle_statement(&mut self, list: &[&str]) -> Result<(), PostError> {
        let code = match list.first().copied() {
            Some("OFF") => {
                self.cycle = None;
                return Ok(());
            }
            Some("DRILL") => 81,
            Some("DEEP") => 83,
            Some("BORE") => 85,
            Some("TAP") => 84,
            other => {
                return Err(self.error(format!(
                    "CYCLE/{} is not read (DRILL, DEEP, BORE, TAP, OFF are)",
                    other.unwrap_or("")
                )));
            }
        };
        let rest = &list[1..];
        let u = self.unit;
        let nums: Vec<f64> = rest.iter().filter_map(|a| a.parse::<f64>().ok()).collect();
        let step = if code == 83 {
            nums.get(1).copied()
        } else {
            None
        };
        let k = if code == 83 { 2 } else { 1 };
        let (Some(depth), Some(f), Some(clearance)) = (nums.first(), nums.get(k), nums.get(k + 1))
        else {
            return Err(
                self.error("CYCLE/ needs depth, (STEP q,) MMPM|MMPR feed, clearance".into())
            );
        };
        let f = f * self.length_unit(rest);
        let per_rev = rest.iter().any(|w| matches!(*w, "MMPR" | "IPR"));
        let feed = if per_rev { f * self.rpm } else { f };
        let (code, pitch) = if code == 84 {
            self.tap_of(feed)?
        } else {
            (code, None)
        };
        if feed <= 0.0 || *depth <= 0.0 || step.is_some_and(|q| q <= 0.0) {
            return Err(self.error("CYCLE/ depth, step and feed must be > 0".into()));
        }
        self.cycle = Some(ClCycle {
            code,
            depth: depth * u,
            step: step.map(|q| q * u),
            pitch,
            feed,
            clearance: clearance * u,
            initial: None,
        });
        Ok(())
    }

    /// A rigid tap at `feed` (mm/min): G84 with the spindle CLW, G74 CCLW; the pitch is the
    /// feed per revolution. The spindle must turn (the tap is coupled to it) and the machine
    /// have a spindle axis.
    fn tap_of(&self, feed: f64) -> Result<(u32, Option<f64>), PostError> {
        if self.dir == SpindleDir::Stop || self.rpm <= 0.0 {
            return Err(self.error("CYCLE/TAP with the spindle stopped (SPINDL/ first)".into()));
        }
        if self.cfg.spindle_index().is_none() {
            return Err(self.error(
                "CYCLE/TAP is a rigid tap: the machine has no spindle axis to couple it to".into(),
            ));
        }
        let code = if self.dir == SpindleDir::Ccw { 74 } else { 84 };
        Ok((code, Some(feed / self.rpm)))
    }

    fn goto(&mut self, end: AxisPos) -> Result<(), PostError> {
        if let Some(c) = self.cycle {
            return self.hole(c, end);
        }
        let kind = if std::mem::take(&mut self.rapid) {
            SegmentKind::Rapid { end }
        } else {
            let feed = self
                .feed
                .ok_or_else(|| self.error("a feed move before any FEDRAT".into()))?;
            match self.circle.take() {
                Some((center, dir)) => SegmentKind::Arc {
                    end,
                    center,
                    plane: Plane::XY,
                    dir,
                    turns: 0,
                    feed,
                },
                None => SegmentKind::Linear { end, feed },
            }
        };
        self.pos = end;
        self.push(CanonKind::Single(kind));
        Ok(())
    }

    /// One hole of the active cycle at `at` (its top), returning to the level it began at.
    fn hole(&mut self, mut c: ClCycle, at: AxisPos) -> Result<(), PostError> {
        let (Some(x), Some(y), Some(z)) = (
            self.cfg.axis_index('X'),
            self.cfg.axis_index('Y'),
            self.cfg.axis_index('Z'),
        ) else {
            return Err(self.error("a cycle needs X, Y and Z".into()));
        };
        let initial = *c.initial.get_or_insert(self.pos[z]);
        self.cycle = Some(c);
        let r_level = at[z] + c.clearance;
        if r_level > initial {
            return Err(self.error("the cycle's clearance is above where the tool starts".into()));
        }
        let cc = CannedCycle {
            code: c.code,
            words: CycleWords {
                r: Some(r_level),
                z: Some(at[z] - c.depth),
                q: c.step,
                p: None,
                f: c.feed,
                repeats: 1,
                incremental: false,
                return_to_r: false,
            },
            axes: [x, y, z],
            start: self.pos,
            holes: vec![[at[x], at[y]]],
            initial_level: initial,
            r_level,
            bottom: at[z] - c.depth,
            return_level: initial,
            feed: c.feed,
            tap: c
                .pitch
                .zip(self.cfg.spindle_index())
                .map(|(pitch, spindle)| TapPlan {
                    spindle,
                    pitch,
                    dir: self.dir,
                    peck: None,
                    peck_retract: self.cfg.interp.tap_peck_retract,
                }),
            plan: CyclePlan {
                peck_retract: self.cfg.interp.peck_retract,
                peck_clearance: self.cfg.interp.peck_clearance,
                orient_angle: None,
                spindle: 1,
                spindle_turning: self.dir != SpindleDir::Stop && self.rpm > 0.0,
                speed: self.rpm,
                spindle_dir: self.dir,
                linuxcnc: None,
            },
        };
        self.push(CanonKind::CannedCycle(Box::new(cc)));
        self.pos[x] = at[x];
        self.pos[y] = at[y];
        self.pos[z] = initial;
        Ok(())
    }
}
