//! The channels of a multi-channel machine as one channel's program sees them: the C-like
//! built-ins `channel_load/run/start/wait/reset`, `@CH[n].MODE/.STATE`, and the `$` globals
//! all channels of one run share. The runtime implements [`Channels`]; a one-channel machine
//! (and every pure use of the interpreter) gets [`SingleChannel`].

use std::collections::HashMap;
use std::sync::{Arc, Mutex};

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

/// A value of a shared `$` global.
#[derive(Clone, Debug, PartialEq)]
pub enum SharedValue {
    Int(i64),
    Double(f64),
    Str(String),
}

/// The `$` globals every channel of one run reads and writes (a flag set by one channel is
/// seen by the others). Cloning shares the table. Keyed by name and element index (0 for a
/// scalar). The interpreter threads of the channels use it; the 1 ms loop never does.
#[derive(Clone, Debug, Default)]
pub struct SharedGlobals {
    table: Arc<Mutex<HashMap<(String, usize), SharedValue>>>,
}

/// The most elements all shared globals may hold together (a runaway writer ends in an
/// error, not in memory exhaustion).
pub const SHARED_GLOBALS_LIMIT: usize = 1 << 20;

impl SharedGlobals {
    pub fn get(&self, name: &str, index: usize) -> Option<SharedValue> {
        let t = self.table.lock().unwrap_or_else(|p| p.into_inner());
        t.get(&(name.to_string(), index)).cloned()
    }

    pub fn set(&self, name: &str, index: usize, value: SharedValue) -> Result<(), String> {
        let mut t = self.table.lock().unwrap_or_else(|p| p.into_inner());
        let key = (name.to_string(), index);
        if t.len() >= SHARED_GLOBALS_LIMIT && !t.contains_key(&key) {
            return Err(format!(
                "${name}[{index}]: the shared globals hold {SHARED_GLOBALS_LIMIT} elements already"
            ));
        }
        t.insert(key, value);
        Ok(())
    }
}
