//! Where the operator's commands come from: the terminal, stdin as a pipe, or a command file
//! (`--commands FILE`, `-` for stdin), one command a line. A bad command from the terminal or
//! a pipe is refused and asked again; from a file it ends the run (exit 64 at its line).
//! Panel commands (hold, resume, overrides) from stdin act as soon as they are read (a
//! listener thread reads stdin throughout the run); in a command file, `at …` commands and
//! those before the first answer to a hold are scheduled before the run starts.

use std::collections::VecDeque;
use std::io::{BufRead, BufReader, Read as _};
use std::path::{Path, PathBuf};
use std::sync::{Arc, Condvar, Mutex, OnceLock};

use super::Command;
use super::panel::{Panel, PanelAction, PanelCommand, Schedule, Scheduled};

/// Longest command line read (a longer one is a bad command, never a growing buffer).
const MAX_LINE: u64 = 4096;

/// The result of reading one command.
#[derive(Debug, PartialEq)]
pub enum Read {
    /// A command, with the input's line number.
    Command(Command, u32),
    /// End of input.
    Eof,
    /// A line that is no command; `fatal` when it came from a command file.
    Bad { message: String, fatal: bool },
}

/// The operator's command stream.
pub struct CommandInput {
    reader: Mutex<Reader>,
    /// The command file's name (`None`: stdin, terminal or pipe).
    file: Option<String>,
    /// The command file, for scheduling its triggered commands before the run.
    path: Option<PathBuf>,
    /// Stdin read by a listener thread: what it read for the holds, in order.
    heard: OnceLock<Heard>,
}

/// What a listener read for the holds, and the signal that it read more.
type Heard = Arc<(Mutex<VecDeque<Read>>, Condvar)>;

/// The input and how far it was read.
struct Reader {
    input: Box<dyn BufRead + Send>,
    line: u32,
    /// A command answered a hold: panel commands read from here on act when read (before,
    /// a command file's were scheduled at the start).
    answered: bool,
}

impl std::fmt::Debug for CommandInput {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("CommandInput")
            .field("file", &self.file)
            .finish()
    }
}

impl CommandInput {
    /// Commands from stdin (the terminal, or a pipe).
    pub fn stdin() -> CommandInput {
        CommandInput::from_reader(Box::new(BufReader::new(std::io::stdin())), None)
    }

    /// Commands from `path` (`-`: stdin).
    pub fn open(path: &Path) -> std::io::Result<CommandInput> {
        if path.as_os_str() == "-" {
            return Ok(CommandInput::stdin());
        }
        let f = std::fs::File::open(path)?;
        let mut input = CommandInput::from_reader(
            Box::new(BufReader::new(f)),
            Some(path.display().to_string()),
        );
        input.path = Some(path.to_path_buf());
        Ok(input)
    }

    /// Commands from any reader; `file` names it in errors (and makes a bad line fatal).
    pub fn from_reader(reader: Box<dyn BufRead + Send>, file: Option<String>) -> CommandInput {
        CommandInput {
            reader: Mutex::new(Reader {
                input: reader,
                line: 0,
                answered: false,
            }),
            file,
            path: None,
            heard: OnceLock::new(),
        }
    }

    /// A command file's panel commands that act by trigger: every `at …` line, and the plain
    /// ones before the first command that answers a hold (they act from the start). Read
    /// before the run (a second pass over the file), so that a run in virtual time is
    /// deterministic; a bad panel command is an error naming its line (the run does not
    /// start). Stdin has none.
    pub fn schedule(&self) -> Result<Schedule, String> {
        let mut out = Schedule::default();
        let Some(path) = &self.path else {
            return Ok(out);
        };
        let name = self.name();
        let f = std::fs::File::open(path).map_err(|e| format!("{name}: {e}"))?;
        let mut reader = BufReader::new(f);
        let mut answered = false;
        // The last hold (or feed 0) not released later in the file: it would hold forever.
        let mut unreleased = None;
        // Each turn reads one more line: bounded by the file.
        for line_no in 1u32.. {
            let mut buf = String::new();
            match reader.by_ref().take(MAX_LINE).read_line(&mut buf) {
                Ok(0) => break,
                Ok(_) => {}
                Err(e) => return Err(format!("{name}: {e}")),
            }
            if buf.trim_start().starts_with('#') {
                continue;
            }
            if let Ok(Command::Panel(p)) = Command::parse(&buf) {
                match p.action {
                    PanelAction::Hold | PanelAction::Feed(0) => unreleased = Some(line_no),
                    PanelAction::Resume | PanelAction::Feed(_) => unreleased = None,
                    PanelAction::Spindle(_) | PanelAction::Rapid(_) => {}
                }
            }
            match Command::parse(&buf) {
                Ok(Command::Panel(command)) if command.at.is_some() || !answered => {
                    out.push(Scheduled {
                        command,
                        input_line: line_no,
                    })
                    .map_err(|e| format!("{name}:{line_no}: {e}"))?;
                }
                Ok(Command::Panel(_)) => {}
                Ok(_) => answered = true,
                Err(m) if PanelCommand::parse(&buf.trim().to_ascii_lowercase()).is_some() => {
                    return Err(format!("{name}:{line_no}: {m}"));
                }
                // Checked when a hold reads it, as before.
                Err(_) => answered = true,
            }
        }
        if let Some(line) = unreleased {
            return Err(format!(
                "{name}:{line}: a feed hold (or feed 0) that no later line resumes: the run \
                 would hold there for ever (add e.g. `at 5s resume`)"
            ));
        }
        Ok(out)
    }

    /// Stdin only: reads it on a thread of its own from now on, so that panel commands act
    /// as soon as they are typed (applied to `panel`, acknowledged on stderr); the other
    /// commands wait, in order, for the holds that [`next`](Self::next) answers.
    pub fn listen(self: &Arc<Self>, panel: Arc<Panel>) -> std::io::Result<()> {
        let heard = Heard::default();
        if self.file.is_some() || self.heard.set(heard.clone()).is_err() {
            return Ok(());
        }
        let input = Arc::clone(self);
        std::thread::Builder::new()
            .name("cnc402-commands".into())
            .spawn(move || {
                // Each turn reads one more line: it ends with the input.
                loop {
                    let r = input.read_next();
                    match r {
                        Read::Command(Command::Panel(p), line) => {
                            panel.apply(p.action, line);
                            eprintln!("{}: {}", p.action.name(), describe(&panel));
                            continue;
                        }
                        // Said at once (a hold would say it only when reached).
                        Read::Bad { message, .. } => {
                            eprintln!("{message} (nothing changed)");
                            continue;
                        }
                        _ => {}
                    }
                    let end = r == Read::Eof;
                    if end {
                        panel.close();
                        if panel.state().hold {
                            eprintln!(
                                "no operator input (end of input) in a feed hold: the program \
                                 ends there (controlled stop)"
                            );
                        }
                    }
                    let (queue, ready) = &*heard;
                    lock(queue).push_back(r);
                    ready.notify_all();
                    if end {
                        return;
                    }
                }
            })?;
        Ok(())
    }

    /// The next command. Lines starting with `#` are comments (in a command file).
    pub fn next(&self) -> Read {
        let Some(heard) = self.heard.get() else {
            return self.read_next();
        };
        let (queue, ready) = &**heard;
        let mut q = lock(queue);
        // Waits for the listener, which ends with the input (its last entry is `Eof`).
        loop {
            match q.front() {
                Some(Read::Eof) => return Read::Eof,
                Some(_) => return q.pop_front().unwrap_or(Read::Eof),
                None => q = ready.wait(q).unwrap_or_else(|e| e.into_inner()),
            }
        }
    }

    /// The next command from the input itself (see [`next`](Self::next)); a command file's
    /// scheduled panel commands are passed over.
    fn read_next(&self) -> Read {
        let mut guard = self.reader.lock().unwrap_or_else(|e| e.into_inner());
        let Reader {
            input: reader,
            line: line_no,
            answered,
        } = &mut *guard;
        loop {
            let mut buf = String::new();
            let n = match reader.by_ref().take(MAX_LINE).read_line(&mut buf) {
                Ok(n) => n,
                Err(e) => {
                    return Read::Bad {
                        message: format!("{}: {e}", self.name()),
                        fatal: true,
                    };
                }
            };
            if n == 0 {
                return Read::Eof;
            }
            *line_no += 1;
            if buf.trim_start().starts_with('#') {
                continue;
            }
            return match Command::parse(&buf) {
                Ok(Command::Panel(p)) if self.file.is_some() && (p.at.is_some() || !*answered) => {
                    // Scheduled before the run (see `schedule`).
                    continue;
                }
                Ok(Command::Panel(p)) if p.at.is_some() => Read::Bad {
                    message: format!(
                        "{}:{line_no}: `at …` triggers belong in a command file (--commands \
                         FILE); from the terminal a command acts at once",
                        self.name()
                    ),
                    fatal: false,
                },
                Ok(c) => {
                    *answered |= !matches!(c, Command::Panel(_));
                    Read::Command(c, *line_no)
                }
                Err(m) => Read::Bad {
                    message: format!("{}:{line_no}: {m}", self.name()),
                    fatal: self.file.is_some(),
                },
            };
        }
    }

    fn name(&self) -> &str {
        self.file.as_deref().unwrap_or("stdin")
    }
}

fn lock<T>(m: &Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    m.lock().unwrap_or_else(|e| e.into_inner())
}

/// The panel's settings in words, for the operator's acknowledgement.
pub fn describe(panel: &Panel) -> String {
    let st = panel.state();
    format!(
        "feed {}{} %, spindle {} %, rapid {} %",
        if st.hold { "HOLD, override " } else { "" },
        st.feed,
        st.spindle,
        st.rapid
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn input(text: &'static str, file: bool) -> CommandInput {
        CommandInput::from_reader(
            Box::new(std::io::Cursor::new(text)),
            file.then(|| "cmds.txt".to_string()),
        )
    }

    #[test]
    fn commands_come_line_by_line_with_their_line() {
        let i = input("# a comment\nstep\n\nstop\n", true);
        assert_eq!(i.next(), Read::Command(Command::Step, 2));
        assert_eq!(i.next(), Read::Command(Command::Continue, 3));
        assert_eq!(i.next(), Read::Command(Command::Stop, 4));
        assert_eq!(i.next(), Read::Eof);
    }

    #[test]
    fn a_bad_command_is_fatal_only_from_a_file() {
        match input("step\nfly\n", true).next_after(1) {
            Read::Bad { message, fatal } => {
                assert!(fatal);
                assert!(
                    message.starts_with("cmds.txt:2: unknown command"),
                    "{message}"
                );
            }
            r => panic!("{r:?}"),
        }
        let piped = input("fly\nstep\n", false);
        assert!(matches!(piped.next(), Read::Bad { fatal: false, .. }));
        assert_eq!(piped.next(), Read::Command(Command::Step, 2));
    }

    /// A command file: `at` lines and the panel commands before the first answer are
    /// scheduled before the run and passed over at the holds; later plain panel commands
    /// come to the hold that reads them.
    #[test]
    fn a_command_files_triggered_panel_commands_are_scheduled_and_passed_over() {
        use crate::operator::{PanelAction, PanelCommand};
        let dir = std::env::temp_dir().join(format!("cnc402-input-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("cmds.txt");
        std::fs::write(
            &path,
            "feed 150\nat 1s hold\nstep\nat N40 resume\nspindle 110\nstop\n",
        )
        .unwrap();
        let input = CommandInput::open(&path).unwrap();
        let schedule = input.schedule().unwrap();
        assert_eq!(schedule.pending(), 3, "feed 150, at 1s hold, at N40 resume");
        assert_eq!(input.next(), Read::Command(Command::Step, 3));
        let spindle = PanelCommand {
            action: PanelAction::Spindle(110),
            at: None,
        };
        assert_eq!(input.next(), Read::Command(Command::Panel(spindle), 5));
        assert_eq!(input.next(), Read::Command(Command::Stop, 6));
        std::fs::write(&path, "at 1s hold\n").unwrap();
        let e = CommandInput::open(&path).unwrap().schedule().unwrap_err();
        assert!(e.contains("cmds.txt:1: a feed hold"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    impl CommandInput {
        fn next_after(&self, skip: usize) -> Read {
            for _ in 0..skip {
                self.next();
            }
            self.next()
        }
    }
}
