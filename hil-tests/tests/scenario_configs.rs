//! The HIL scenarios' machine configs (`hil-tests/scenarios/machine-vcan*.toml`) are generated
//! from `config/machine.toml` by `gen_configs.py`: a change to the shipped machine that was not
//! carried over makes the vcan suite test another machine than the one shipped. This fails on
//! that drift (the suite itself only warns), with the command that fixes it.

use std::process::Command;

#[test]
fn scenario_configs_match_the_shipped_machine() {
    let root = concat!(env!("CARGO_MANIFEST_DIR"), "/..");
    let out = match Command::new("python3")
        .args(["hil-tests/scenarios/gen_configs.py", "--check"])
        .current_dir(root)
        .output()
    {
        Ok(o) => o,
        Err(e) => {
            // The generator needs python3; a machine without it cannot check (CI has it).
            eprintln!("skipped: python3 cannot be run ({e})");
            return;
        }
    };
    assert!(
        out.status.success(),
        "hil-tests/scenarios/machine-vcan*.toml differ from what config/machine.toml gives; \
         run: python3 hil-tests/scenarios/gen_configs.py\n{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
}
