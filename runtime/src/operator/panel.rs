//! The operator's panel during motion: feed hold, resume (cycle start), feed override
//! 0–200 % and spindle override 50–120 %. Commands reach the 1 ms loop through atomics
//! ([`Panel`], set at once from the terminal) or through a fixed-size schedule of triggered
//! commands (`at 1.5s hold`, `at N40 feed 50` in a command file, [`Schedule`]), which keeps
//! runs in virtual time deterministic; the loop records what it applied ([`PanelLog`]).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};

/// Feed override range (%).
pub const FEED_RANGE: (u32, u32) = (0, 200);
/// Spindle override range (%).
pub const SPINDLE_RANGE: (u32, u32) = (50, 120);
/// Rapid override settings (%), Fanuc's panel steps (its F0, a configured slow rapid, is not
/// offered).
pub const RAPID_STEPS: [u32; 3] = [25, 50, 100];
/// Most triggered commands a command file may hold.
pub const MAX_SCHEDULED: usize = 64;
/// Most panel events a run's report keeps (later ones are counted, not kept).
pub const MAX_PANEL_EVENTS: usize = 256;
/// The longest trigger time accepted (s): a day of virtual or real time.
const MAX_AT_SECONDS: f64 = 86_400.0;

/// What the operator does on the panel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PanelAction {
    Hold,
    Resume,
    /// Feed override in %.
    Feed(u32),
    /// Spindle override in %.
    Spindle(u32),
    /// Rapid override in % (25, 50 or 100).
    Rapid(u32),
}

/// When a command from a command file acts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Trigger {
    /// At this time after the drives were enabled (µs of loop time, virtual or real).
    Time { micros: u64 },
    /// When the first move of the block with this N number starts.
    Block { n: u32 },
}

/// A panel command, with its trigger when it has one.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PanelCommand {
    pub action: PanelAction,
    pub at: Option<Trigger>,
}

/// The panel commands, for messages and `--help`.
pub const PANEL_COMMANDS: &str = "hold, resume (or start), feed 0–200, spindle 50–120, \
     rapid 25|50|100; in a command file also `at 1.5s <command>` or `at N40 <command>`";

impl PanelAction {
    /// The action's name in the report and on the terminal.
    pub fn name(self) -> &'static str {
        match self {
            PanelAction::Hold => "hold",
            PanelAction::Resume => "resume",
            PanelAction::Feed(_) => "feed",
            PanelAction::Spindle(_) => "spindle",
            PanelAction::Rapid(_) => "rapid",
        }
    }

    /// The override in %, for `feed` and `spindle`.
    pub fn percent(self) -> Option<u32> {
        match self {
            PanelAction::Feed(p) | PanelAction::Spindle(p) | PanelAction::Rapid(p) => Some(p),
            _ => None,
        }
    }
}

impl PanelCommand {
    /// Parses a panel command from a trimmed, lower-case line; `None` when the line is no
    /// panel command (another operator command, or unknown).
    pub fn parse(w: &str) -> Option<Result<PanelCommand, String>> {
        let mut words = w.split_whitespace();
        let first = words.next()?;
        if first == "at" {
            return Some(Self::parse_at(words));
        }
        let rest: Vec<&str> = words.collect();
        let action = PanelAction::parse(first, &rest)?;
        Some(action.map(|action| PanelCommand { action, at: None }))
    }

    fn parse_at<'a>(mut words: impl Iterator<Item = &'a str>) -> Result<PanelCommand, String> {
        let when = words.next().unwrap_or("");
        let at = parse_trigger(when)?;
        let first = words.next().unwrap_or("");
        let rest: Vec<&str> = words.collect();
        match PanelAction::parse(first, &rest) {
            Some(Ok(action)) => Ok(PanelCommand {
                action,
                at: Some(at),
            }),
            Some(Err(e)) => Err(e),
            None => Err(format!(
                "`at {when}` must be followed by a panel command ({PANEL_COMMANDS}), not {first:?}"
            )),
        }
    }
}

impl PanelAction {
    /// `word` and its arguments as an action; `None` when `word` is no panel command.
    fn parse(word: &str, args: &[&str]) -> Option<Result<PanelAction, String>> {
        let pct = |what: &str, (lo, hi): (u32, u32)| -> Result<u32, String> {
            let [arg] = args else {
                return Err(format!(
                    "{what} takes one value in % ({lo}–{hi}), e.g. `{what} {hi}`"
                ));
            };
            let num = arg.trim_end_matches('%');
            match num.parse::<f64>() {
                Ok(v) if v.is_finite() && v >= lo as f64 && v <= hi as f64 && v.fract() == 0.0 => {
                    Ok(v as u32)
                }
                Ok(v) if v.is_finite() && v >= lo as f64 && v <= hi as f64 => Err(format!(
                    "{what} override {arg}: whole percent only ({lo}–{hi})"
                )),
                _ => Err(format!(
                    "{what} override {arg} % out of range: {lo}–{hi} % (nothing changed)"
                )),
            }
        };
        let no_args = |a: PanelAction| {
            if args.is_empty() {
                Ok(a)
            } else {
                Err(format!("{} takes no value", a.name()))
            }
        };
        Some(match word {
            "hold" | "feed-hold" => no_args(PanelAction::Hold),
            "resume" | "start" | "cycle-start" => no_args(PanelAction::Resume),
            "feed" => pct("feed", FEED_RANGE).map(PanelAction::Feed),
            "spindle" => pct("spindle", SPINDLE_RANGE).map(PanelAction::Spindle),
            "rapid" => match pct("rapid", (0, 100)) {
                Ok(p) if RAPID_STEPS.contains(&p) => Ok(PanelAction::Rapid(p)),
                Ok(p) => Err(format!("rapid override {p} %: one of 25, 50, 100")),
                Err(e) => Err(e),
            },
            _ => return None,
        })
    }
}

/// `1.5s`, `1500ms` or `N40`.
fn parse_trigger(when: &str) -> Result<Trigger, String> {
    let bad =
        || format!("`at {when}`: expected a time (`at 1.5s`, `at 200ms`) or a block (`at N40`)");
    if let Some(n) = when.strip_prefix('n') {
        return n
            .parse::<u32>()
            .map(|n| Trigger::Block { n })
            .map_err(|_| bad());
    }
    let (num, scale) = if let Some(ms) = when.strip_suffix("ms") {
        (ms, 1e-3)
    } else if let Some(s) = when.strip_suffix('s') {
        (s, 1.0)
    } else {
        return Err(bad());
    };
    let secs = num.parse::<f64>().map_err(|_| bad())? * scale;
    if !(secs.is_finite() && (0.0..=MAX_AT_SECONDS).contains(&secs)) {
        return Err(format!(
            "`at {when}`: the time must be 0–{MAX_AT_SECONDS} s"
        ));
    }
    Ok(Trigger::Time {
        micros: (secs * 1e6).round() as u64,
    })
}

/// Applies the commands of `schedule` that act from the start (no trigger) to `panel` and
/// leaves the triggered ones.
pub fn apply_at_start(schedule: &mut Schedule, panel: &Panel) {
    for slot in schedule.slots.iter_mut() {
        if let Some(s) = slot
            && s.command.at.is_none()
        {
            panel.apply(s.command.action, s.input_line);
            *slot = None;
            schedule.pending -= 1;
        }
    }
}

/// The panel's state as the terminal sets it and the loop reads it (atomics only).
#[derive(Debug)]
pub struct Panel {
    hold: AtomicBool,
    /// Shared with the lookahead, which plans feed override above 100 %.
    feed: Arc<AtomicU32>,
    spindle: AtomicU32,
    rapid: AtomicU32,
    /// Line of the command input that set the panel last (0: the run's start).
    input_line: AtomicU32,
    /// No command will come any more (the listener met the end of stdin): a feed hold at
    /// rest with nothing scheduled to end it ends the program instead of waiting for ever.
    closed: AtomicBool,
}

impl Default for Panel {
    fn default() -> Self {
        Panel {
            hold: AtomicBool::new(false),
            feed: Arc::new(AtomicU32::new(100)),
            spindle: AtomicU32::new(100),
            rapid: AtomicU32::new(100),
            input_line: AtomicU32::new(0),
            closed: AtomicBool::new(false),
        }
    }
}

/// The panel's settings at one moment.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PanelState {
    pub hold: bool,
    pub feed: u32,
    pub spindle: u32,
    pub rapid: u32,
}

impl Default for PanelState {
    fn default() -> Self {
        PanelState {
            hold: false,
            feed: 100,
            spindle: 100,
            rapid: 100,
        }
    }
}

impl Panel {
    /// Applies `action` (from input line `input_line`). Allocation- and lock-free.
    pub fn apply(&self, action: PanelAction, input_line: u32) {
        self.input_line.store(input_line, Ordering::Relaxed);
        match action {
            PanelAction::Hold => self.hold.store(true, Ordering::Release),
            PanelAction::Resume => self.hold.store(false, Ordering::Release),
            PanelAction::Feed(p) => self.feed.store(p, Ordering::Release),
            PanelAction::Spindle(p) => self.spindle.store(p, Ordering::Release),
            PanelAction::Rapid(p) => self.rapid.store(p, Ordering::Release),
        }
    }

    /// The current settings.
    pub fn state(&self) -> PanelState {
        PanelState {
            hold: self.hold.load(Ordering::Acquire),
            feed: self.feed.load(Ordering::Acquire),
            spindle: self.spindle.load(Ordering::Acquire),
            rapid: self.rapid.load(Ordering::Acquire),
        }
    }

    /// The feed override (%) as the lookahead reads it
    /// (`Lookahead::set_feed_override_source`).
    pub fn feed_source(&self) -> Arc<AtomicU32> {
        self.feed.clone()
    }

    /// No command will come any more (see the field).
    pub fn close(&self) {
        self.closed.store(true, Ordering::Release);
    }

    /// Whether [`close`](Self::close) was called.
    pub fn is_closed(&self) -> bool {
        self.closed.load(Ordering::Acquire)
    }

    /// The input line of the last command applied.
    pub fn input_line(&self) -> u32 {
        self.input_line.load(Ordering::Relaxed)
    }
}

/// A triggered command waiting in the loop.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Scheduled {
    pub command: PanelCommand,
    pub input_line: u32,
}

/// The triggered commands of a command file, in a fixed-size table the loop scans.
#[derive(Clone, Copy, Debug)]
pub struct Schedule {
    slots: [Option<Scheduled>; MAX_SCHEDULED],
    pending: usize,
}

impl Default for Schedule {
    fn default() -> Self {
        Schedule {
            slots: [None; MAX_SCHEDULED],
            pending: 0,
        }
    }
}

impl Schedule {
    /// Adds `s`; an error when the table is full.
    pub fn push(&mut self, s: Scheduled) -> Result<(), String> {
        let Some(slot) = self.slots.iter_mut().find(|s| s.is_none()) else {
            return Err(format!(
                "more than {MAX_SCHEDULED} triggered (`at …`) commands"
            ));
        };
        *slot = Some(s);
        self.pending += 1;
        Ok(())
    }

    /// Commands still waiting for their trigger.
    pub fn pending(&self) -> usize {
        self.pending
    }

    /// Hands the commands due at `micros` of loop time with block `n` running to `fire`, in
    /// table order (allocation-free); returns how many.
    pub fn take_due(
        &mut self,
        micros: u64,
        n: Option<u32>,
        mut fire_one: impl FnMut(Scheduled),
    ) -> usize {
        if self.pending == 0 {
            return 0;
        }
        let mut k = 0;
        for slot in self.slots.iter_mut() {
            let Some(s) = slot else { continue };
            let fire = match s.command.at {
                Some(Trigger::Time { micros: at }) => micros >= at,
                Some(Trigger::Block { n: want }) => n == Some(want),
                None => true,
            };
            if fire {
                fire_one(*s);
                k += 1;
                *slot = None;
                self.pending -= 1;
            }
        }
        k
    }
}

/// One panel change the loop applied.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PanelEvent {
    pub action: PanelAction,
    /// The loop's tick (time = tick × period) and the program line and N running then.
    pub tick: u64,
    pub line: u32,
    pub n: Option<u32>,
    /// Line of the command file or stdin that asked for it (0: none).
    pub input_line: u32,
}

/// The panel changes of a run, fixed-size (kept in the loop).
#[derive(Clone, Copy, Debug)]
pub struct PanelLog {
    events: [Option<PanelEvent>; MAX_PANEL_EVENTS],
    len: usize,
    /// Events past [`MAX_PANEL_EVENTS`], counted only.
    pub lost: u64,
}

impl Default for PanelLog {
    fn default() -> Self {
        PanelLog {
            events: [None; MAX_PANEL_EVENTS],
            len: 0,
            lost: 0,
        }
    }
}

impl PanelLog {
    /// Records `e` (allocation-free).
    pub fn push(&mut self, e: PanelEvent) {
        if self.len < MAX_PANEL_EVENTS {
            self.events[self.len] = Some(e);
            self.len += 1;
        } else {
            self.lost += 1;
        }
    }

    /// The events kept, in order.
    pub fn events(&self) -> impl Iterator<Item = &PanelEvent> {
        self.events[..self.len].iter().flatten()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(s: &str) -> Option<Result<PanelCommand, String>> {
        PanelCommand::parse(&s.to_ascii_lowercase())
    }

    #[test]
    fn panel_commands_parse_with_and_without_triggers() {
        let cmd = |action, at| Some(Ok(PanelCommand { action, at }));
        assert_eq!(parse("hold"), cmd(PanelAction::Hold, None));
        assert_eq!(parse("start"), cmd(PanelAction::Resume, None));
        assert_eq!(parse("feed 150"), cmd(PanelAction::Feed(150), None));
        assert_eq!(parse("feed 0%"), cmd(PanelAction::Feed(0), None));
        assert_eq!(parse("spindle 110"), cmd(PanelAction::Spindle(110), None));
        assert_eq!(parse("rapid 25"), cmd(PanelAction::Rapid(25), None));
        let at = |micros| Some(Trigger::Time { micros });
        assert_eq!(parse("at 1.5s hold"), cmd(PanelAction::Hold, at(1_500_000)));
        assert_eq!(
            parse("at 250ms feed 50"),
            cmd(PanelAction::Feed(50), at(250_000))
        );
        let n40 = Some(Trigger::Block { n: 40 });
        assert_eq!(parse("at N40 resume"), cmd(PanelAction::Resume, n40));
        assert_eq!(parse("step"), None);
    }

    #[test]
    fn out_of_range_overrides_and_bad_triggers_say_what_is_allowed() {
        for (line, want) in [
            ("feed 250", "0–200"),
            ("feed -1", "0–200"),
            ("spindle 40", "50–120"),
            ("spindle 121", "50–120"),
            ("rapid 30", "one of 25, 50, 100"),
            ("rapid 150", "0–100"),
            ("feed", "one value"),
            ("feed 12.5", "whole percent"),
            ("hold 3", "no value"),
            ("at 2x hold", "expected a time"),
            ("at 1s jump", "panel command"),
            ("at -1s hold", "0–86400"),
            ("at 1e9s hold", "0–86400"),
        ] {
            let e = parse(line).expect("a panel command").unwrap_err();
            assert!(e.contains(want), "{line}: {e}");
        }
    }

    #[test]
    fn the_schedule_fires_each_command_once_at_its_trigger() {
        let mut s = Schedule::default();
        let at = |action, at, input_line| Scheduled {
            command: PanelCommand {
                action,
                at: Some(at),
            },
            input_line,
        };
        s.push(at(PanelAction::Hold, Trigger::Time { micros: 2000 }, 1))
            .unwrap();
        s.push(at(PanelAction::Feed(50), Trigger::Block { n: 40 }, 2))
            .unwrap();
        let mut fired = Vec::new();
        assert_eq!(s.take_due(1000, Some(30), |d| fired.push(d.input_line)), 0);
        assert_eq!(s.take_due(1000, Some(40), |d| fired.push(d.input_line)), 1);
        assert_eq!(s.take_due(2000, Some(40), |d| fired.push(d.input_line)), 1);
        assert_eq!(fired, [2, 1]);
        assert_eq!(s.pending(), 0);
        assert_eq!(s.take_due(9000, Some(40), |d| fired.push(d.input_line)), 0);
        for i in 0..MAX_SCHEDULED {
            s.push(at(PanelAction::Hold, Trigger::Block { n: 1 }, i as u32))
                .unwrap();
        }
        assert!(
            s.push(at(PanelAction::Hold, Trigger::Block { n: 1 }, 99))
                .is_err()
        );
    }
}
