//! hilcheck: assertions on JSON reports for the HIL scenarios, in one process (process start
//! is slow in the emulated guest).
//!
//!   hilcheck -f drive.json 'checks.*.pass == true' -p 'SYNC p99 {sync_period_us.p99:.0} µs' \
//!            -f run.json 'ok == false' 'stop.node == 3'
//!
//! `-f FILE` selects the document the following assertions and `-p TEMPLATE` lines apply to;
//! every other argument is an assertion `PATH OP VALUE`, or several joined by ` || ` (see
//! `cnc402_hil::check`). Prints
//! `FAIL FILE: ASSERTION (why)` for each failed one. Exit 0 all passed, 1 one failed, 2 bad
//! arguments or an unreadable file.

use std::process::ExitCode;

use cnc402_hil::check::{check_expr, render};
use serde_json::Value;

fn main() -> ExitCode {
    let mut doc: Option<(String, Value)> = None;
    let mut failed = 0usize;
    let mut args = std::env::args().skip(1);
    if std::env::args().len() < 2 {
        eprintln!("usage: hilcheck -f FILE.json [ASSERTION | -p TEMPLATE]... [-f FILE ...]");
        return ExitCode::from(2);
    }
    while let Some(a) = args.next() {
        match a.as_str() {
            "-f" | "--file" => {
                let Some(path) = args.next() else {
                    eprintln!("hilcheck: -f needs a file");
                    return ExitCode::from(2);
                };
                let text = match std::fs::read_to_string(&path) {
                    Ok(t) => t,
                    Err(e) => {
                        eprintln!("hilcheck: {path}: {e}");
                        return ExitCode::from(2);
                    }
                };
                match serde_json::from_str(&text) {
                    Ok(v) => doc = Some((path, v)),
                    Err(e) => {
                        eprintln!("hilcheck: {path}: not JSON: {e}");
                        return ExitCode::from(2);
                    }
                }
            }
            "-p" | "--print" => {
                let (Some(t), Some((_, v))) = (args.next(), doc.as_ref()) else {
                    eprintln!("hilcheck: -p needs a template after -f FILE");
                    return ExitCode::from(2);
                };
                println!("{}", render(v, &t));
            }
            _ => {
                let Some((path, v)) = doc.as_ref() else {
                    eprintln!("hilcheck: `{a}` before any -f FILE");
                    return ExitCode::from(2);
                };
                match check_expr(&a, v) {
                    Err(e) => {
                        eprintln!("hilcheck: {e}");
                        return ExitCode::from(2);
                    }
                    Ok(Err(why)) => {
                        println!("FAIL {path}: {a} ({why})");
                        failed += 1;
                    }
                    Ok(Ok(())) => {}
                }
            }
        }
    }
    if failed > 0 {
        ExitCode::from(1)
    } else {
        ExitCode::SUCCESS
    }
}
