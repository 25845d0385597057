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
        "variables_file = \"var/macro_variables.txt\"",
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
