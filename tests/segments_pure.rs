//! Regression: `cnc402 segments` wrote the operator's non-volatile variables (the interpreter
//! opened the config's variables file writable by default). The dump must be repeatable: it
//! reads `#500–#999` from the file and never writes it.

use std::process::Command;

#[test]
fn segments_does_not_write_nonvolatile_variables() {
    let dir = std::env::temp_dir().join(format!("cnc402-seg-pure-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    let vars = dir.join("v.txt");
    let shipped =
        std::fs::read_to_string(concat!(env!("CARGO_MANIFEST_DIR"), "/config/machine.toml"))
            .unwrap();
    let cfg_text = shipped.replace(
        "variables_file = \"../var/macro_variables.txt\"",
        &format!("variables_file = {:?}", vars.to_str().unwrap()),
    );
    assert_ne!(
        cfg_text, shipped,
        "the shipped config names a variables file"
    );
    let cfg = dir.join("machine.toml");
    std::fs::write(&cfg, cfg_text).unwrap();
    let prog = dir.join("count.nc");
    std::fs::write(&prog, "#500 = [#500 + 1]\nG0 X[#500]\nM30\n").unwrap();
    let segments = || {
        let o = Command::new(env!("CARGO_BIN_EXE_cnc402"))
            .args(["segments", prog.to_str().unwrap(), "--config"])
            .arg(&cfg)
            .current_dir(env!("CARGO_MANIFEST_DIR"))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert_eq!(o.status.code(), Some(0), "{err}");
        String::from_utf8_lossy(&o.stdout).into_owned()
    };

    // No file yet: #500 reads vacant (0), and no file is created.
    let first = segments();
    assert!(first.contains("\"X\":1,"), "{first}");
    assert!(!vars.exists(), "segments created the variables file");

    // A file with #500 = 7: read (X8) but never written, so two dumps are identical.
    let mut t = cnc402_interp::NvTable::default();
    t.set(500, Some(7.0)).unwrap();
    t.save(&vars).unwrap();
    let before = std::fs::read(&vars).unwrap();
    let a = segments();
    let b = segments();
    assert!(a.contains("\"X\":8,"), "{a}");
    assert_eq!(a, b, "the dump is repeatable");
    assert_eq!(
        std::fs::read(&vars).unwrap(),
        before,
        "variables file unchanged"
    );
    let _ = std::fs::remove_dir_all(&dir);
}
