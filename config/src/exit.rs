//! The exit codes of every binary of the workspace (`cnc402`, `drivectl`, `simdrive`): one
//! table, so the same cause ends each with the same code. It lives here because all three
//! load a machine config and so already depend on this crate. docs/exit-codes.md documents the
//! table; `tests/exit_codes.rs` checks the document lists exactly [`TABLE`].

/// Success (also `--help` and `--version`).
pub const OK: u8 = 0;
/// The machine or a drive stopped or is in the wrong state: a drive fault, a safety reaction,
/// the operator's stop during a run; a drive in FAULT or in a CiA 402 state that refuses the
/// command (`drivectl`).
pub const FAULT: u8 = 1;
/// The NC program is wrong: parse, interpreter or planning error.
pub const PROGRAM: u8 = 2;
/// The machine config (or a file describing the machine: EDS/DCF, pages file) cannot be read
/// or is wrong.
pub const CONFIG: u8 = 3;
/// A file cannot be read or written, the terminal fails, or the CAN interface cannot be
/// opened or fails (missing interface, kernel without AF_CAN, bus-off, down).
pub const IO: u8 = 4;
/// `cnc402 which`: no path passes within `--within` of the point.
pub const FAR: u8 = 5;
/// A drive refused an object access: SDO abort (the abort code and its name are printed).
pub const SDO_ABORT: u8 = 6;
/// No answer in time: absent node, SDO timeout, no boot-up or heartbeat.
pub const TIMEOUT: u8 = 7;
/// A device broke the protocol: wrong data type or size, SDO protocol violation, not a CiA 402
/// device.
pub const PROTOCOL: u8 = 8;
/// `simdrive`: one of its checks failed (coupling, SYNC, protocol errors; see its report).
pub const CHECK_FAILED: u8 = 9;
/// Bad command-line usage (clap's own errors included) or a value out of its range.
pub const USAGE: u8 = 64;
/// An internal error: a state that should not happen (a bug to report).
pub const INTERNAL: u8 = 70;

/// Every code with its short name and a one-line summary (as docs/exit-codes.md and
/// `drivectl --help` show them).
pub const TABLE: [(u8, &str, &str); 12] = [
    (OK, "ok", "success; --help, --version"),
    (
        FAULT,
        "fault",
        "machine stopped, drive in FAULT or in a state that refuses the command",
    ),
    (PROGRAM, "program", "the NC program is wrong"),
    (
        CONFIG,
        "config",
        "machine config, EDS/DCF or pages file unreadable or wrong",
    ),
    (
        IO,
        "io",
        "file, terminal or CAN interface failed (no such interface, bus-off, down)",
    ),
    (FAR, "far", "cnc402 which: no path within --within"),
    (
        SDO_ABORT,
        "sdo abort",
        "the drive refused an SDO access (abort code and name printed)",
    ),
    (
        TIMEOUT,
        "timeout",
        "no answer in time: absent node, SDO timeout, no boot-up/heartbeat",
    ),
    (
        PROTOCOL,
        "protocol",
        "wrong data type or size, SDO protocol violation, not CiA 402",
    ),
    (
        CHECK_FAILED,
        "check failed",
        "simdrive: a check failed (see its report)",
    ),
    (
        USAGE,
        "usage",
        "bad command line or a value out of its range",
    ),
    (
        INTERNAL,
        "internal",
        "a state that should not happen (please report)",
    ),
];

/// The exit code for a command line clap refused or answered itself: 0 for `--help` and
/// `--version` (printed on stdout), [`USAGE`] for every error (printed on stderr). clap's own
/// default would be 2, which here means a program error.
pub fn for_clap(printed_on_stderr: bool) -> u8 {
    if printed_on_stderr { USAGE } else { OK }
}

/// The table as one line per code, for a binary's `--help`.
pub fn help_table() -> String {
    let mut s = String::from("Exit codes (docs/exit-codes.md):\n");
    for (code, name, summary) in TABLE {
        s.push_str(&format!("  {code:<3} {name:<13} {summary}\n"));
    }
    s.trim_end().to_string()
}
