//! drivectl: a thin binary over the drivectl library (see `drivectl --help`).

use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use clap::Parser;
use drivectl::cli::Cli;

fn main() -> ExitCode {
    let cli = Cli::parse();
    let json = cli.global.json;
    let interrupted = Arc::new(AtomicBool::new(false));
    let flag = interrupted.clone();
    // A second Ctrl-C while a ramp runs exits at once (the drive keeps its own quick stop).
    let _ = ctrlc::set_handler(move || {
        if flag.swap(true, Ordering::SeqCst) {
            std::process::exit(130);
        }
    });
    match drivectl::run(cli, interrupted) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            if json {
                println!(
                    "{}",
                    serde_json::json!({ "error": { "kind": e.kind(), "message": e.message, "exit": e.exit as u8 } })
                );
            }
            eprintln!("drivectl: error: {e}");
            ExitCode::from(e.exit as u8)
        }
    }
}
