//! The channels of a multi-channel machine as one channel's program sees them: the C-like
//! built-ins `channel_load/run/start/wait/reset`, `@CH[n].MODE/.STATE`, and the `$` globals
//! all channels of one run share. The runtime implements [`Channels`]; a one-channel machine
//! (and every pure use of the interpreter) gets [`SingleChannel`], a dry run [`DryChannels`].

use std::collections::{BTreeMap, HashMap};
use std::sync::{Arc, Mutex, MutexGuard};

/// `@CH[n].MODE`: the seed's 1 = Auto. A channel in manual mode refuses programs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChannelMode {
    Manual = 0,
    Auto = 1,
}

/// `@CH[n].STATE` (the numbers are what the program reads; the seed's 2 = ready).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ChannelState {
    /// Being reset (its motion stopping, its program unloaded).
    Reset = 1,
    /// Idle, no error: a program may be loaded and run.
    Ready = 2,
    /// Running a program (a channel reading its own state while it runs reads this).
    Running = 3,
    /// Its last program ended in an error; `channel_reset` makes it ready again.
    Error = 4,
    /// Running, and at rest waiting for other channels (a wait mark).
    Waiting = 5,
}

/// What a channel's program may do to the machine's channels. Every call names a channel
/// by number (0-based, config order). `Err` is a program error at the calling line (a
/// channel that does not exist, a channel driving itself); `Ok(false)` is the seed's
/// "failed", which the program may handle (retry after `channel_reset`).
pub trait Channels: Send {
    /// The number of channels of this machine (≥ 1).
    fn count(&self) -> usize;
    /// The channel this program runs on.
    fn this(&self) -> usize;
    fn mode(&mut self, ch: usize) -> Result<ChannelMode, String>;
    fn state(&mut self, ch: usize) -> Result<ChannelState, String>;
    /// Reads and checks `program` (a file name, found like `M98`'s programs, relative to the
    /// calling program `main`) into channel `ch`, ready to run. False: the file is missing or
    /// does not parse, the channel is busy, in error or in manual mode.
    fn load(&mut self, ch: usize, program: &str, main: &str) -> Result<bool, String>;
    /// Starts `program` on `ch` (loading it unless it is the one loaded) and returns at once.
    fn start(&mut self, ch: usize, program: &str, main: &str) -> Result<bool, String>;
    /// Blocks until channel `ch` is no longer running; false when its program ended in an
    /// error (or was reset). A wait that can never end (deadlock) is an `Err` naming both
    /// channels' lines.
    fn wait(&mut self, ch: usize) -> Result<bool, String>;
    /// `start` then `wait`: true only when the program ran to its end without an error.
    fn run(&mut self, ch: usize, program: &str, main: &str) -> Result<bool, String> {
        Ok(self.start(ch, program, main)? && self.wait(ch)?)
    }
    /// Stops channel `ch`'s motion along its path, unloads its program and clears its
    /// error; true when it is ready afterwards.
    fn reset(&mut self, ch: usize) -> Result<bool, String>;
}

/// The channels of a one-channel machine: channel 0 is the caller, in Auto, running.
#[derive(Clone, Copy, Debug, Default)]
pub struct SingleChannel;

/// The error for a channel number past the machine's channels.
pub fn no_such_channel(ch: usize, count: usize) -> String {
    if count == 1 {
        format!("@CH[{ch}]: this machine has one channel (0); [[channel]] in the config adds more")
    } else {
        format!(
            "@CH[{ch}]: this machine has {count} channels (0..={})",
            count - 1
        )
    }
}

impl SingleChannel {
    fn check(ch: usize) -> Result<(), String> {
        if ch == 0 {
            Err(
                "channel 0 is the channel running this program: a program cannot load, run, \
                 wait for or reset its own channel"
                    .into(),
            )
        } else {
            Err(no_such_channel(ch, 1))
        }
    }
}

impl Channels for SingleChannel {
    fn count(&self) -> usize {
        1
    }
    fn this(&self) -> usize {
        0
    }
    fn mode(&mut self, ch: usize) -> Result<ChannelMode, String> {
        if ch == 0 {
            Ok(ChannelMode::Auto)
        } else {
            Err(no_such_channel(ch, 1))
        }
    }
    fn state(&mut self, ch: usize) -> Result<ChannelState, String> {
        if ch == 0 {
            Ok(ChannelState::Running)
        } else {
            Err(no_such_channel(ch, 1))
        }
    }
    fn load(&mut self, ch: usize, _: &str, _: &str) -> Result<bool, String> {
        Self::check(ch).map(|_| false)
    }
    fn start(&mut self, ch: usize, _: &str, _: &str) -> Result<bool, String> {
        Self::check(ch).map(|_| false)
    }
    fn wait(&mut self, ch: usize) -> Result<bool, String> {
        Self::check(ch).map(|_| false)
    }
    fn reset(&mut self, ch: usize) -> Result<bool, String> {
        Self::check(ch).map(|_| false)
    }
}

/// The channels as a dry run (a check of a program without motion) sees them: `count`
/// channels, every other one in Auto and ready, every load, run, wait and reset succeeding
/// at once without doing anything; the caller's own channel is running. The calls are
/// checked as the real ones are (a channel the machine lacks, a program driving its own
/// channel), so a dry run finds those errors and follows the program's success path.
#[derive(Clone, Copy, Debug)]
pub struct DryChannels {
    pub count: usize,
    pub this: usize,
}

impl DryChannels {
    fn check(&self, ch: usize) -> Result<(), String> {
        if ch >= self.count {
            Err(no_such_channel(ch, self.count))
        } else if ch == self.this {
            Err(format!(
                "channel {ch} is the channel running this program: a program cannot load, \
                 run, wait for or reset its own channel"
            ))
        } else {
            Ok(())
        }
    }
}

impl Channels for DryChannels {
    fn count(&self) -> usize {
        self.count.max(1)
    }
    fn this(&self) -> usize {
        self.this
    }
    fn mode(&mut self, ch: usize) -> Result<ChannelMode, String> {
        if ch >= self.count {
            return Err(no_such_channel(ch, self.count));
        }
        Ok(ChannelMode::Auto)
    }
    fn state(&mut self, ch: usize) -> Result<ChannelState, String> {
        if ch >= self.count {
            return Err(no_such_channel(ch, self.count));
        }
        Ok(if ch == self.this {
            ChannelState::Running
        } else {
            ChannelState::Ready
        })
    }
    fn load(&mut self, ch: usize, _: &str, _: &str) -> Result<bool, String> {
        self.check(ch).map(|_| true)
    }
    fn start(&mut self, ch: usize, _: &str, _: &str) -> Result<bool, String> {
        self.check(ch).map(|_| true)
    }
    fn wait(&mut self, ch: usize) -> Result<bool, String> {
        self.check(ch).map(|_| true)
    }
    fn reset(&mut self, ch: usize) -> Result<bool, String> {
        self.check(ch).map(|_| true)
    }
}

/// Where a program runs: the machine's number of channels and the channel running it.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Seat {
    pub count: usize,
    pub this: usize,
}

impl Seat {
    pub(crate) fn of(channels: &dyn Channels) -> Seat {
        Seat {
            count: channels.count(),
            this: channels.this(),
        }
    }
}

/// A wait's channel mask (a bit per channel, 0 = all) checked against the machine: the
/// bits name channels it has, the calling channel among them. The message on an error.
pub(crate) fn check_mask(mask: i64, seat: Seat) -> Result<u16, String> {
    if mask == 0 {
        return Ok(0);
    }
    let bits = u16::try_from(mask).map_err(|_| format!("channel mask {mask} is not 0..65535"))?;
    if let Some(c) = (seat.count..16).find(|c| bits & (1 << c) != 0) {
        let why = no_such_channel(c, seat.count);
        let why = why.split_once(": ").map_or("", |(_, w)| w);
        return Err(format!("channel mask {mask} names channel {c}; {why}"));
    }
    if !mask_has(bits, seat.this) {
        return Err(format!(
            "channel mask {mask} leaves out channel {}, the one waiting",
            seat.this
        ));
    }
    Ok(bits)
}

/// Whether the mask `bits` holds channel `ch`.
pub(crate) fn mask_has(bits: u16, ch: usize) -> bool {
    ch < 16 && bits & (1 << ch) != 0
}

/// A value of a shared `$` global.
#[derive(Clone, Debug, PartialEq)]
pub enum SharedValue {
    Int(i64),
    Double(f64),
    Str(String),
    /// A comparison's result stored in a global (`$bDone = nA > 2;`).
    Bool(bool),
}

/// The `$` globals every channel of one run reads and writes (a flag set by one channel is
/// seen by the others). Cloning shares the table. Keyed by name and element index (0 for a
/// scalar). The interpreter threads of the channels use it; the 1 ms loop never does.
/// [`Interpreter::set_shared_globals`](crate::Interpreter::set_shared_globals) makes an
/// interpreter's C-like programs use it for every `$name` and `$name[i]`.
#[derive(Clone, Debug, Default)]
pub struct SharedGlobals {
    pub(crate) table: Globals,
}

/// The most values (scalars and array elements) all `$` globals may hold together (a
/// runaway writer ends in an error, not in memory exhaustion).
pub const SHARED_GLOBALS_LIMIT: usize = 1 << 20;

impl SharedGlobals {
    /// `$name` (`index` 0, when `$name` is a scalar) or `$name[index]`.
    pub fn get(&self, name: &str, index: usize) -> Option<SharedValue> {
        let t = lock(&self.table);
        match t.get(name)? {
            Global::Scalar(v) if index == 0 => Some(v.clone()),
            Global::Scalar(_) => None,
            Global::Array(a) => a.get(&i64::try_from(index).ok()?).cloned(),
        }
    }

    /// Sets `$name[index]`, or the scalar `$name` when `index` is 0 and `$name` is not an
    /// array.
    pub fn set(&self, name: &str, index: usize, value: SharedValue) -> Result<(), String> {
        let mut t = lock(&self.table);
        let i = i64::try_from(index).map_err(|_| format!("${name}[{index}]: index too large"))?;
        match t.get(name) {
            Some(Global::Array(_)) => t.set_elem(name, i, value),
            _ if index == 0 => t.set_scalar(name, value),
            _ => t.set_elem(name, i, value),
        }
    }
}

/// A `$` global: a scalar or a sparse array (`$dPerm[1]`).
#[derive(Clone, Debug)]
pub(crate) enum Global {
    Scalar(SharedValue),
    Array(BTreeMap<i64, SharedValue>),
}

/// Every `$` global by name, and how many values (scalars and array elements) they hold.
#[derive(Debug, Default)]
pub(crate) struct GlobalTable {
    vars: HashMap<String, Global>,
    values: usize,
}

/// The `$` globals as the executors (of one interpreter, or of every channel) share them.
pub(crate) type Globals = Arc<Mutex<GlobalTable>>;

/// The table, even if a thread panicked while holding it (its values are still whole).
pub(crate) fn lock(g: &Globals) -> MutexGuard<'_, GlobalTable> {
    g.lock().unwrap_or_else(|p| p.into_inner())
}

fn full(what: String) -> String {
    format!("{what}: the $ globals hold {SHARED_GLOBALS_LIMIT} values already")
}

impl GlobalTable {
    pub(crate) fn get(&self, name: &str) -> Option<&Global> {
        self.vars.get(name)
    }

    /// `$name = v`; an error (the message) if `$name` is an array or the table is full.
    pub(crate) fn set_scalar(&mut self, name: &str, v: SharedValue) -> Result<(), String> {
        match self.vars.get_mut(name) {
            Some(Global::Array(_)) => Err(format!("${name} is an array: assign an element")),
            Some(Global::Scalar(s)) => {
                *s = v;
                Ok(())
            }
            None if self.values >= SHARED_GLOBALS_LIMIT => Err(full(format!("${name}"))),
            None => {
                self.values += 1;
                self.vars.insert(name.to_string(), Global::Scalar(v));
                Ok(())
            }
        }
    }

    /// `$name[i] = v` (creating the array at its first element); `i` ≥ 0.
    pub(crate) fn set_elem(&mut self, name: &str, i: i64, v: SharedValue) -> Result<(), String> {
        if i < 0 {
            return Err(format!("index {i} of ${name} is negative"));
        }
        let at_limit = self.values >= SHARED_GLOBALS_LIMIT;
        let entry = self
            .vars
            .entry(name.to_string())
            .or_insert_with(|| Global::Array(BTreeMap::new()));
        let Global::Array(a) = entry else {
            return Err(format!("${name} is not an array"));
        };
        match a.get_mut(&i) {
            Some(e) => *e = v,
            None if at_limit => return Err(full(format!("${name}[{i}]"))),
            None => {
                a.insert(i, v);
                self.values += 1;
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_mask_names_channels_the_machine_has_and_the_waiting_one() {
        let seat = Seat { count: 3, this: 1 };
        assert_eq!(check_mask(0, seat), Ok(0));
        assert_eq!(check_mask(0b110, seat), Ok(0b110));
        let past = check_mask(0b1010, seat).unwrap_err();
        assert_eq!(
            past,
            "channel mask 10 names channel 3; this machine has 3 channels (0..=2)"
        );
        let without = check_mask(0b101, seat).unwrap_err();
        assert_eq!(
            without,
            "channel mask 5 leaves out channel 1, the one waiting"
        );
        assert!(check_mask(-1, seat).unwrap_err().contains("not 0..65535"));
        assert!(
            check_mask(1 << 16, seat)
                .unwrap_err()
                .contains("not 0..65535")
        );
        assert!(!mask_has(u16::MAX, 16));
    }

    #[test]
    fn shared_globals_index_0_is_the_scalar_unless_the_name_is_an_array() {
        let g = SharedGlobals::default();
        g.set("nFlag", 0, SharedValue::Int(1)).unwrap();
        assert_eq!(g.get("nFlag", 0), Some(SharedValue::Int(1)));
        assert_eq!(g.get("nFlag", 1), None);
        assert!(g.set("nFlag", 2, SharedValue::Int(1)).is_err());
        g.set("dPerm", 1, SharedValue::Double(2.5)).unwrap();
        g.set("dPerm", 0, SharedValue::Double(0.5)).unwrap();
        assert_eq!(g.get("dPerm", 0), Some(SharedValue::Double(0.5)));
        assert_eq!(g.get("dPerm", 1), Some(SharedValue::Double(2.5)));
        assert_eq!(g.get("nNever", 0), None);
        // Clones share the table.
        let h = g.clone();
        h.set("sName", 0, SharedValue::Str("01.nc".into())).unwrap();
        assert_eq!(g.get("sName", 0), Some(SharedValue::Str("01.nc".into())));
    }
}
