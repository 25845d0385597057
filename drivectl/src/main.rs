//! drivectl: a thin binary over the drivectl library (see `drivectl --help`).

use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};

use clap::Parser;
use cnc402_config::exit;
use drivectl::cli::Cli;

fn main() -> ExitCode {
    // RUST_LOG as in cnc402 (default: warnings only).
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("warn")).init();
    let cli = match Cli::try_parse() {
        Ok(c) => c,
        Err(e) => {
            let _ = e.print();
            return ExitCode::from(exit::for_clap(e.use_stderr()));
        }
    };
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
                    serde_json::json!({ "error": { "kind": e.kind(), "message": e.message, "exit": e.exit.code() } })
                );
            }
            eprintln!("drivectl: error: {e}");
            ExitCode::from(e.exit.code())
        }
    }
}
