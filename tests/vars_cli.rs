//! `cnc402 vars`: set, list, clear on a variables file; usage errors exit 64, a damaged file
//! exits 4 naming the damage; `segments` of O0001 then reads what `vars set` wrote.

use std::process::Command;

fn cnc402(args: &[&str]) -> (i32, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(args)
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .output()
        .unwrap();
    (
        out.status.code().unwrap_or(-1),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn set_list_clear_and_errors() {
    let dir = std::env::temp_dir().join(format!("cnc402-vars-cli-{}", std::process::id()));
    let f = dir.join("sub").join("v.txt");
    let f = f.to_str().unwrap();
    let (code, out, _) = cnc402(&["vars", "--file", f, "set", "520=3", "#521=800", "530=1"]);
    assert_eq!(
        (code, out.as_str()),
        (0, "#520 = 3\n#521 = 800\n#530 = 1\n")
    );
    let (code, out, _) = cnc402(&["vars", "--file", f, "clear", "521..530"]);
    assert_eq!((code, out.as_str()), (0, "#520 = 3\n"));
    let (code, out, _) = cnc402(&["vars", "--file", f]);
    assert_eq!((code, out.as_str()), (0, "#520 = 3\n"));
    let (code, _, err) = cnc402(&["vars", "--file", f, "set", "100=1"]);
    assert_eq!(code, 64, "{err}");
    let (code, _, err) = cnc402(&["vars", "--file", f, "clear", "530..520"]);
    assert_eq!(code, 64, "{err}");
    std::fs::write(f, "cnc402-vars 1\n520 4.0\ncrc32 00000000\n").unwrap();
    let (code, _, err) = cnc402(&["vars", "--file", f]);
    assert_eq!(code, 4);
    assert!(err.contains("damaged") && err.contains("checksum"), "{err}");
    // A damaged file can still be cleared whole.
    let (code, out, _) = cnc402(&["vars", "--file", f, "clear"]);
    assert_eq!((code, out.as_str()), (0, ""));
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn segments_of_o0001_read_the_variables_set_by_vars() {
    let dir = std::env::temp_dir().join(format!("cnc402-vars-seg-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let vars = dir.join("v.txt");
    let shipped = std::fs::read_to_string("config/machine.toml").unwrap();
    let cfg_text = shipped.replace(
        "variables_file = \"../var/macro_variables.txt\"",
        &format!("variables_file = {:?}", vars.to_str().unwrap()),
    );
    assert_ne!(cfg_text, shipped);
    let cfg = dir.join("machine.toml");
    std::fs::write(&cfg, cfg_text).unwrap();
    let cfg = cfg.to_str().unwrap();
    let (code, _, err) = cnc402(&[
        "vars", "--config", cfg, "set", "530=1", "519=81", "520=3", "521=800", "522=150", "524=98",
        "512=50", "503=-45", "502=-20", "500=10", "501=20", "509=15", "510=5", "511=4",
    ]);
    assert_eq!(code, 0, "{err}");
    let (code, out, err) = cnc402(&["segments", "--config", cfg, "examples/mlt980/O0001.CNC"]);
    assert_eq!(code, 0, "{err}");
    let bottoms = out.lines().filter(|l| l.contains("\"Z\":-15")).count();
    assert_eq!(bottoms, 4, "{out}");
    let (code, _, _) = cnc402(&["vars", "--config", cfg, "set", "524=97"]);
    assert_eq!(code, 0);
    let (code, _, err) = cnc402(&["segments", "--config", cfg, "examples/mlt980/O0001.CNC"]);
    assert_eq!(code, 2);
    assert!(err.contains("alarm 502"), "{err}");
    std::fs::remove_dir_all(&dir).unwrap();
}

fn fresh_dir(tag: &str) -> std::path::PathBuf {
    let dir = std::env::temp_dir().join(format!("cnc402-vars-{tag}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    dir
}

/// `#n` as the file at `f` holds it now (`vars list`).
fn file_var(f: &str, n: u32) -> Option<f64> {
    let (code, out, err) = cnc402(&["vars", "--file", f]);
    assert_eq!(code, 0, "{err}");
    listed(&out, n)
}

/// `#n` in a `vars` listing.
fn listed(out: &str, n: u32) -> Option<f64> {
    let head = format!("#{n} = ");
    out.lines()
        .find_map(|l| l.strip_prefix(head.as_str()))
        .map(|v| v.parse().unwrap())
}

#[test]
fn concurrent_vars_set_of_different_variables_lose_none() {
    // Several `cnc402 vars set` processes at once, each setting its own variable many times.
    const WRITERS: u32 = 4;
    const SETS: u32 = 15;
    let dir = fresh_dir("concurrent");
    let f = dir.join("v.txt");
    let f = f.to_str().unwrap();
    std::thread::scope(|s| {
        for w in 0..WRITERS {
            s.spawn(move || {
                for i in 1..=SETS {
                    let (code, _, err) =
                        cnc402(&["vars", "--file", f, "set", &format!("{}={i}", 500 + w)]);
                    assert_eq!(code, 0, "{err}");
                }
            });
        }
    });
    for w in 0..WRITERS {
        assert_eq!(file_var(f, 500 + w), Some(f64::from(SETS)), "#{}", 500 + w);
    }
    let left: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .filter(|n| n.contains(".tmp"))
        .collect();
    assert!(left.is_empty(), "temporary files left: {left:?}");
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn vars_set_during_a_run_is_not_overwritten_by_the_run() {
    // `cnc402 run` on the embedded simulator of a program that writes #500 = 1, 2, … with a
    // dwell between; while it runs the operator sets #501. Synchronised on the file, not on
    // time: the set is made once the run has written, and the run must write again after it.
    const WRITES: u32 = 600;
    let dir = fresh_dir("during-run");
    let vars = dir.join("v.txt");
    let f = vars.to_str().unwrap();
    let shipped = std::fs::read_to_string("config/machine.toml").unwrap();
    let cfg_text = shipped.replace(
        "variables_file = \"../var/macro_variables.txt\"",
        &format!("variables_file = {f:?}"),
    );
    assert_ne!(cfg_text, shipped);
    let cfg = dir.join("machine.toml");
    std::fs::write(&cfg, cfg_text).unwrap();
    let prog = dir.join("writes.nc");
    std::fs::write(
        &prog,
        format!("#500=0\nWHILE[#500 LT {WRITES}]DO1\n#500=#500+1\nG4 P10\nEND1\nM30\n"),
    )
    .unwrap();
    let mut run = Command::new(env!("CARGO_BIN_EXE_cnc402"))
        .args(["run", "--at-stop", "continue", "--config"])
        .args([&cfg, &prog])
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Wait for the run's first write (or its end, which fails below).
    while std::fs::read(&vars).is_err() && run.try_wait().unwrap().is_none() {
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let (code, out, err) = cnc402(&["vars", "--file", f, "set", "501=7"]);
    assert_eq!(code, 0, "{err}");
    let at_set = listed(&out, 500).unwrap_or(0.0);
    let status = run.wait().unwrap();
    let mut err = String::new();
    std::io::Read::read_to_string(&mut run.stderr.take().unwrap(), &mut err).unwrap();
    assert!(status.success(), "{err}");
    assert!(
        at_set < f64::from(WRITES),
        "the run had written everything before the set (#500 = {at_set}): nothing was tested"
    );
    assert_eq!(file_var(f, 500), Some(f64::from(WRITES)));
    assert_eq!(file_var(f, 501), Some(7.0), "the run overwrote #501");
    std::fs::remove_dir_all(&dir).unwrap();
}
