//! A scripted two-channel machine for the channel tests: channel 0 runs the program under
//! test, channel 1 (axes U, V, W) really runs the part programs it is given, through a second
//! interpreter, unless the script says the next load or run fails. Every call is logged.

use std::path::Path;
use std::sync::{Arc, Mutex};

use cnc402_config::MachineConfig;
use cnc402_interp::host::channels::no_such_channel;
use cnc402_interp::{ChannelMode, ChannelState, Channels};
use cnc402_lang::SourceFile;

pub const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/..");

/// The shipped machine with its axes X, Y, Z named U, V, W: channel 1's machine.
pub fn channel_1_config() -> MachineConfig {
    let text = std::fs::read_to_string(format!("{ROOT}/config/machine.toml")).unwrap();
    let mut text = text
        .replace("name = \"X\"", "name = \"U\"")
        .replace("name = \"Y\"", "name = \"V\"")
        .replace("name = \"Z\"", "name = \"W\"");
    for (a, b) in [("X = ", "U = "), ("Y = ", "V = "), ("Z = ", "W = ")] {
        text = text.replace(&format!("{{ {a}"), &format!("{{ {b}"));
        text = text.replace(&format!(", {a}"), &format!(", {b}"));
    }
    MachineConfig::parse(&text, Path::new(&format!("{ROOT}/config/channel1.toml"))).unwrap()
}

/// What the script makes channel 1 do.
pub struct Script {
    pub mode: ChannelMode,
    pub state: ChannelState,
    /// The next this many loads fail (then loads check the file for real).
    pub load_fails: usize,
    /// The next this many runs fail (then runs run the program for real).
    pub run_fails: usize,
}

impl Default for Script {
    fn default() -> Self {
        Script {
            mode: ChannelMode::Auto,
            state: ChannelState::Ready,
            load_fails: 0,
            run_fails: 0,
        }
    }
}

/// Two channels; this program runs on channel 0.
pub struct FakeChannels {
    pub script: Script,
    pub log: Arc<Mutex<Vec<String>>>,
    cfg1: MachineConfig,
    /// The outcome of the program started last, for `wait`.
    started: Option<bool>,
}

impl FakeChannels {
    pub fn new(script: Script) -> (Self, Arc<Mutex<Vec<String>>>) {
        let log = Arc::new(Mutex::new(Vec::new()));
        let f = FakeChannels {
            script,
            log: log.clone(),
            cfg1: channel_1_config(),
            started: None,
        };
        (f, log)
    }

    fn note(&self, s: String) {
        self.log.lock().unwrap().push(s);
    }

    fn check(&self, ch: usize) -> Result<(), String> {
        match ch {
            0 => Err("channel 0 is the calling channel".into()),
            1 => Ok(()),
            _ => Err(no_such_channel(ch, 2)),
        }
    }

    /// The part program `program` as channel 1 would read it (next to `main`).
    fn source(program: &str, main: &str) -> Option<SourceFile> {
        let path = Path::new(main).parent()?.join(program);
        let text = std::fs::read_to_string(&path).ok()?;
        Some(SourceFile::new(path.display().to_string(), text))
    }
}

impl Channels for FakeChannels {
    fn count(&self) -> usize {
        2
    }
    fn this(&self) -> usize {
        0
    }
    fn mode(&mut self, ch: usize) -> Result<ChannelMode, String> {
        self.note(format!("mode {ch}"));
        Ok(if ch == 0 {
            ChannelMode::Auto
        } else {
            self.script.mode
        })
    }
    fn state(&mut self, ch: usize) -> Result<ChannelState, String> {
        self.note(format!("state {ch}"));
        Ok(if ch == 0 {
            ChannelState::Running
        } else {
            self.script.state
        })
    }
    fn load(&mut self, ch: usize, program: &str, main: &str) -> Result<bool, String> {
        self.check(ch)?;
        self.note(format!("load {ch} {program}"));
        if self.script.load_fails > 0 {
            self.script.load_fails -= 1;
            return Ok(false);
        }
        Ok(Self::source(program, main)
            .is_some_and(|s| cnc402_interp::parse_program(&self.cfg1, &s, None).is_ok()))
    }
    fn start(&mut self, ch: usize, program: &str, main: &str) -> Result<bool, String> {
        self.check(ch)?;
        self.note(format!("start {ch} {program}"));
        let ok = if self.script.run_fails > 0 {
            self.script.run_fails -= 1;
            false
        } else {
            match Self::source(program, main) {
                None => return Ok(false),
                Some(s) => match cnc402_interp::run_program(&self.cfg1, &s) {
                    Ok(_) => true,
                    Err(e) => {
                        self.note(format!("error {}:{}", e.line, e.message));
                        false
                    }
                },
            }
        };
        self.started = Some(ok);
        Ok(true)
    }
    fn wait(&mut self, ch: usize) -> Result<bool, String> {
        self.check(ch)?;
        self.note(format!("wait {ch}"));
        Ok(self.started.take().unwrap_or(true))
    }
    fn reset(&mut self, ch: usize) -> Result<bool, String> {
        self.check(ch)?;
        self.note(format!("reset {ch}"));
        self.started = None;
        Ok(true)
    }
}
