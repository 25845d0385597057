//! Where the operator's commands come from: the terminal, stdin as a pipe, or a command file
//! (`--commands FILE`, `-` for stdin), one command a line. A bad command from the terminal or
//! a pipe is refused and asked again; from a file it ends the run (exit 64 at its line).

use std::io::{BufRead, BufReader, Read as _};
use std::path::Path;
use std::sync::Mutex;

use super::Command;

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
    reader: Mutex<(Box<dyn BufRead + Send>, u32)>,
    /// The command file's name (`None`: stdin, terminal or pipe).
    file: Option<String>,
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
        Ok(CommandInput::from_reader(
            Box::new(BufReader::new(f)),
            Some(path.display().to_string()),
        ))
    }

    /// Commands from any reader; `file` names it in errors (and makes a bad line fatal).
    pub fn from_reader(reader: Box<dyn BufRead + Send>, file: Option<String>) -> CommandInput {
        CommandInput {
            reader: Mutex::new((reader, 0)),
            file,
        }
    }

    /// The next command. Lines starting with `#` are comments (in a command file).
    pub fn next(&self) -> Read {
        let mut guard = self.reader.lock().unwrap_or_else(|e| e.into_inner());
        let (reader, line_no) = &mut *guard;
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
                Ok(c) => Read::Command(c, *line_no),
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

    impl CommandInput {
        fn next_after(&self, skip: usize) -> Read {
            for _ in 0..skip {
                self.next();
            }
            self.next()
        }
    }
}
