//! `cnc402 segments` and `cnc402 canon`: a program's segments or canonical operations as JSON
//! Lines, on two threads. This one interprets (and lowers); a writer thread formats and
//! writes. Items go over in batches through bounded channels and the emptied batches come
//! back, so memory stays bounded and the steady state allocates nothing per block.

use std::io::Write;
use std::sync::mpsc::{Receiver, SyncSender, sync_channel};

use crate::CliError;

/// Items handed to the writer at a time: large enough that the channel and the writer's
/// wake-ups cost little per block (on 200,000 blocks, 256 took 2,760 context switches; 1,024
/// took 198 and ran 0.050 s, best of 25; 2,048 took 98 and ran 0.042 s; 4,096 49 and 0.043 s:
/// each wake-up costs tens of µs on a VM), small enough that the writer starts early and
/// three batches stay small (about 1 MiB of segments).
const BATCH: usize = 2048;
/// Batches in circulation: one being filled, one being written, one waiting between.
const BATCHES: usize = 3;
/// The writer's text buffer: lines are gathered and written in pieces of about this size.
const TEXT: usize = 1 << 16;

/// What `segments` and `canon` print.
#[derive(Clone, Copy)]
pub(crate) enum Dump {
    Segments,
    Canon,
}

/// How the interpreting side stopped.
enum Ended {
    /// The program ended.
    Done,
    /// `DRY_RUN_MOVES` items were printed and the program goes on.
    Capped,
}

/// Prints a program's segments or canonical operations as JSON Lines.
pub(crate) fn dump(
    cfg: &cnc402_config::MachineConfig,
    program: &std::path::Path,
    dialect: Option<cnc402_lang::Dialect>,
    what: Dump,
) -> Result<(), CliError> {
    // Read line by line: memory stays bounded whatever the program's length.
    let file = crate::open_program(program)?;
    // The interpreter does no I/O: sub-programs, `#use` files and the variables file come
    // from the file system through host_fs. A dump never writes the variables file.
    let mut interp = cnc402_interp::host_fs::interpreter(
        cfg,
        cnc402_interp::Options::default(),
        cnc402_interp::host_fs::VarsAccess::ReadOnly,
    );
    let name = program.display().to_string();
    interp
        .load_stream(name, Box::new(file), dialect)
        .map_err(CliError::Program)?;
    // An endless program with motion never ends: print what `run`'s dry run checks.
    let cap = cnc402_runtime::feeder::DRY_RUN_MOVES;
    let stdout = std::io::stdout();
    let ended = match what {
        Dump::Segments => {
            let mut writer = cnc402_interp::dump::SegmentWriter::default();
            pipeline(
                // The segment goes from the interpreter's queue into the batch, not through
                // its return values: one move instead of several.
                |batch: &mut Vec<_>| interp.with_next_segment(|s| batch.push(s)),
                move |text: &mut String, s| writer.write_line(text, s, cfg),
                stdout,
                cap,
            )
        }
        Dump::Canon => pipeline(
            |batch: &mut Vec<_>| interp.next_canon().map(|op| op.map(|op| batch.push(op))),
            |text: &mut String, op| {
                text.push_str(&cnc402_interp::dump::canon::canon_to_json(op, cfg));
                text.push('\n');
            },
            stdout,
            cap,
        ),
    }
    .map_err(|e| CliError::Io(e.to_string()))?
    .map_err(CliError::Program)?;
    match ended {
        Ended::Capped => eprintln!(
            "note: printed the first {cap} lines, as many as `cnc402 run` checks before \
             motion; the program goes on past them"
        ),
        Ended::Done => {
            if let Some(line) = interp.main_m99_line() {
                eprintln!(
                    "note: M99 at line {line} ends the main program: `cnc402 run` (like a \
                     Fanuc control) starts it over there, endlessly; this is one pass"
                );
            }
        }
    }
    Ok(())
}

/// Runs `next` on this thread (each call pushes the next item onto the batch it is given,
/// `Ok(None)` at the end) and `format` on a writer thread that writes the text to `out`, until
/// the program ends, errs or `cap` items are out. Returns once everything before that is
/// written: a write error first (it came first, as with one thread), then the program's end.
fn pipeline<T: Send, E>(
    next: impl FnMut(&mut Vec<T>) -> Result<Option<()>, E>,
    format: impl FnMut(&mut String, &T) + Send,
    out: impl Write + Send,
    cap: u64,
) -> std::io::Result<Result<Ended, E>> {
    std::thread::scope(|scope| {
        let (full_tx, full_rx) = sync_channel::<Vec<T>>(BATCHES);
        let (empty_tx, empty_rx) = sync_channel::<Vec<T>>(BATCHES);
        for _ in 0..BATCHES {
            // Cannot fail: the receiver is here and the channel holds BATCHES.
            let _ = empty_tx.send(Vec::with_capacity(BATCH));
        }
        let writer = std::thread::Builder::new()
            .name("dump-writer".into())
            .spawn_scoped(scope, move || write_batches(full_rx, empty_tx, format, out))?;
        let produced = produce(next, &full_tx, &empty_rx, cap);
        // The writer ends once it has written every batch sent before this.
        drop(full_tx);
        writer
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic))?;
        Ok(produced)
    })
}

/// Fills batches with `next` and sends them to the writer until the program ends, errs or
/// `cap` items are out. A writer that stopped (a write error) stops this too: its error is
/// what the run reports.
fn produce<T, E>(
    mut next: impl FnMut(&mut Vec<T>) -> Result<Option<()>, E>,
    full: &SyncSender<Vec<T>>,
    empty: &Receiver<Vec<T>>,
    cap: u64,
) -> Result<Ended, E> {
    let mut printed = 0;
    loop {
        let Ok(mut batch) = empty.recv() else {
            return Ok(Ended::Done);
        };
        // The items of a written batch are dropped here, where they were made.
        batch.clear();
        let mut ended = None;
        while batch.len() < BATCH {
            if printed == cap {
                ended = Some(Ok(Ended::Capped));
                break;
            }
            printed += 1;
            match next(&mut batch) {
                Ok(Some(())) => {}
                Ok(None) => {
                    ended = Some(Ok(Ended::Done));
                    break;
                }
                // What came before the error is printed, as it always was.
                Err(e) => {
                    ended = Some(Err(e));
                    break;
                }
            }
        }
        let sent = full.send(batch);
        match ended {
            Some(ended) => return ended,
            None if sent.is_err() => return Ok(Ended::Done),
            None => {}
        }
    }
}

/// The writer thread: formats each batch's items onto one text buffer, writes it to `out` in
/// large pieces and hands the batch back, until the interpreting side hangs up.
fn write_batches<T>(
    full: Receiver<Vec<T>>,
    empty: SyncSender<Vec<T>>,
    mut format: impl FnMut(&mut String, &T),
    out: impl Write,
) -> std::io::Result<()> {
    let mut out = std::io::BufWriter::new(out);
    let mut text = String::with_capacity(TEXT);
    for batch in full {
        for item in &batch {
            format(&mut text, item);
            if text.len() >= TEXT - 1024 {
                out.write_all(text.as_bytes())?;
                text.clear();
            }
        }
        // The other side may have stopped already; then the batch is dropped here.
        let _ = empty.send(batch);
    }
    out.write_all(text.as_bytes())?;
    out.flush()
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::{Arc, Mutex};

    /// A `Write` into shared bytes that fails once `limit` bytes are in.
    #[derive(Clone)]
    struct Sink {
        bytes: Arc<Mutex<Vec<u8>>>,
        limit: usize,
    }

    impl Sink {
        fn new(limit: usize) -> Self {
            Sink {
                bytes: Arc::default(),
                limit,
            }
        }
        fn text(&self) -> String {
            String::from_utf8(self.bytes.lock().unwrap().clone()).unwrap()
        }
    }

    impl Write for Sink {
        fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
            let mut b = self.bytes.lock().unwrap();
            if b.len() + buf.len() > self.limit {
                return Err(std::io::ErrorKind::BrokenPipe.into());
            }
            b.extend_from_slice(buf);
            Ok(buf.len())
        }
        fn flush(&mut self) -> std::io::Result<()> {
            Ok(())
        }
    }

    /// The pipeline over items 1, 2, … : the program has `items` of them (`None`: endless)
    /// and then ends, or errs with "bad" when `err`. Returns what it returned, the text
    /// written and how many items were asked for.
    fn run(
        items: Option<u64>,
        err: bool,
        cap: u64,
        sink: &Sink,
    ) -> (std::io::Result<Result<Ended, &'static str>>, String, u64) {
        let mut asked = 0u64;
        let r = pipeline(
            |batch: &mut Vec<u64>| {
                asked += 1;
                match items {
                    Some(n) if asked > n && err => Err("bad"),
                    Some(n) if asked > n => Ok(None),
                    _ => {
                        batch.push(asked);
                        Ok(Some(()))
                    }
                }
            },
            |text: &mut String, i: &u64| {
                text.push_str(&format!("{{\"i\":{i}}}\n"));
            },
            sink.clone(),
            cap,
        );
        (r, sink.text(), asked)
    }

    fn lines(n: u64) -> String {
        (1..=n).map(|i| format!("{{\"i\":{i}}}\n")).collect()
    }

    #[test]
    fn every_item_is_written_in_order_across_batches_and_text_pieces() {
        // 10,000 lines of ~10 bytes: many batches and several 64 KiB pieces.
        let sink = Sink::new(usize::MAX);
        let (r, text, asked) = run(Some(10_000), false, u64::MAX, &sink);
        assert!(matches!(r, Ok(Ok(Ended::Done))));
        assert_eq!(text, lines(10_000));
        assert_eq!(asked, 10_001);
    }

    #[test]
    fn the_cap_stops_after_exactly_cap_items_whatever_the_batch_boundary() {
        for cap in [
            1,
            BATCH as u64 - 1,
            BATCH as u64,
            2 * BATCH as u64 + 1,
            5_000,
        ] {
            let sink = Sink::new(usize::MAX);
            let (r, text, asked) = run(None, false, cap, &sink);
            assert!(matches!(r, Ok(Ok(Ended::Capped))), "cap {cap}");
            assert_eq!(text, lines(cap), "cap {cap}");
            // The next item is not asked for: the run stops at the cap, not past it.
            assert_eq!(asked, cap, "cap {cap}");
        }
    }

    #[test]
    fn a_program_of_exactly_cap_items_is_capped_and_one_item_fewer_is_not() {
        // As with one thread: the cap is reached before the end is seen.
        let cap = BATCH as u64 * 2;
        let (r, text, _) = run(Some(cap), false, cap, &Sink::new(usize::MAX));
        assert!(matches!(r, Ok(Ok(Ended::Capped))));
        assert_eq!(text, lines(cap));
        let (r, text, _) = run(Some(cap - 1), false, cap, &Sink::new(usize::MAX));
        assert!(matches!(r, Ok(Ok(Ended::Done))));
        assert_eq!(text, lines(cap - 1));
    }

    #[test]
    fn a_program_error_comes_after_everything_before_it_is_written() {
        for n in [0, 1, BATCH as u64, 7_777] {
            let sink = Sink::new(usize::MAX);
            let (r, text, _) = run(Some(n), true, u64::MAX, &sink);
            assert!(matches!(r, Ok(Err("bad"))), "{n}");
            assert_eq!(text, lines(n), "{n}");
        }
    }

    #[test]
    fn a_write_error_ends_the_run_and_wins_over_a_later_program_error() {
        // The reader goes away after 1,000 bytes of an endless program: the run ends with
        // the write error, having asked for a bounded number of items more.
        let sink = Sink::new(1_000);
        let (r, _, asked) = run(None, false, u64::MAX, &sink);
        assert_eq!(
            r.err().map(|e| e.kind()),
            Some(std::io::ErrorKind::BrokenPipe)
        );
        assert!(asked < 100_000, "went on interpreting: {asked}");
        // Everything fits in the writer's pieces until the end: the error is at the last write.
        let sink = Sink::new(1_000);
        let (r, _, _) = run(Some(500), true, u64::MAX, &sink);
        assert_eq!(
            r.err().map(|e| e.kind()),
            Some(std::io::ErrorKind::BrokenPipe)
        );
    }
}
