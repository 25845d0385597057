//! The interpreter's defaults do no I/O (DEVELOPERS.md: interp is a pure core): no program
//! files are read, no `#use` files, no variables file is read or written. The file system comes
//! in only when a caller injects `host_fs` (checked here too, against the same programs).

use std::path::Path;

use cnc402_config::MachineConfig;
use cnc402_interp::host_fs::{self, FsLibrary, VarsAccess};
use cnc402_interp::{Interpreter, NvTable};
use cnc402_lang::SourceFile;

const ROOT: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/..");

fn run(it: &mut Interpreter, name: &str, text: &str) -> Result<usize, String> {
    let src = SourceFile::new(name, text);
    let p = cnc402_lang::parse(&src).map_err(|e| e.to_string())?;
    it.load(src, p);
    let mut n = 0;
    loop {
        match it.next_segment() {
            Ok(Some(_)) => n += 1,
            Ok(None) => return Ok(n),
            Err(e) => return Err(e.to_string()),
        }
    }
}

fn tmp(tag: &str) -> std::path::PathBuf {
    let d = std::env::temp_dir().join(format!("cnc402-pure-{}-{tag}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

#[test]
fn default_interpreter_reads_no_program_files() {
    // O9001.CNC exists next to the "main program" (relative to cwd and absolute), and the
    // shipped program_dir is `examples`: a default interpreter must still not find it.
    for dir in ["../examples/mlt980", &format!("{ROOT}/examples/mlt980")] {
        assert!(Path::new(dir).join("O9001.CNC").is_file());
        let cfg = MachineConfig::default_machine();
        let mut it = Interpreter::new(&cfg);
        let e = run(&mut it, &format!("{dir}/main.nc"), "M98 P9001\nM30\n").unwrap_err();
        assert!(
            e.contains(
                "program O9001 not found: not in this file, and no program directory is configured"
            ),
            "{e}"
        );
        // set_program_library(None) is the default: the main file's folder is not searched.
        it.set_program_library(None);
        let e = run(&mut it, &format!("{dir}/main.nc"), "G65 P9001 A1\nM30\n").unwrap_err();
        assert!(e.contains("program O9001 not found"), "{e}");
    }
}

#[test]
fn injected_file_library_finds_the_program_next_to_the_main_file() {
    let cfg = MachineConfig::default_machine();
    let mut it = Interpreter::new(&cfg);
    it.set_program_library(Some(Box::new(FsLibrary::default())));
    // O9001 runs (its own alarms need parameters: any error must not be "not found").
    let r = run(
        &mut it,
        &format!("{ROOT}/examples/mlt980/main.nc"),
        "M98 P9001\nM30\n",
    );
    if let Err(e) = r {
        assert!(!e.contains("not found"), "{e}");
    }
}

#[test]
fn default_interpreter_resolves_no_use_files() {
    // metch_cycles.c stands next to the program and in the shipped library_dir.
    let name = format!("{ROOT}/examples/axioma/t.nc");
    assert!(Path::new(&format!("{ROOT}/examples/axioma/metch_cycles.c")).is_file());
    let text = "#use \"metch_cycles.c\"\nMSG(\"x\");\n";
    let cfg = MachineConfig::default_machine();
    let e = run(&mut Interpreter::new(&cfg), &name, text).unwrap_err();
    assert!(
        e.contains("#use \"metch_cycles.c\": no such file (no program library is configured)"),
        "{e}"
    );
    let mut it = Interpreter::new(&cfg);
    it.set_program_library(Some(Box::new(FsLibrary::from_config(&cfg))));
    assert_eq!(run(&mut it, &name, text), Ok(1));
}

#[test]
fn default_interpreter_neither_reads_nor_writes_the_variables_file() {
    let d = tmp("nv");
    let path = d.join("vars.txt");
    let mut t = NvTable::default();
    t.set(500, Some(41.0)).unwrap();
    t.save(&path).unwrap();
    let before = std::fs::read(&path).unwrap();
    let mut cfg = MachineConfig::default_machine();
    cfg.interp.variables_file = Some(path.clone());
    let prog = "#501 = [#500 + 1]\n#500 = #501\nG0 X#501\nM30\n";

    // Default: #500 starts vacant (reads 0) and lives in memory across loads.
    let mut it = Interpreter::new(&cfg);
    run(&mut it, "p.nc", prog).unwrap();
    run(&mut it, "p.nc", prog).unwrap();
    assert_eq!(it.var(500), Some(2.0));
    assert_eq!(std::fs::read(&path).unwrap(), before, "file untouched");

    // Read-only injection: reads 41, never writes; repeatable.
    for _ in 0..2 {
        let mut it = Interpreter::new(&cfg);
        host_fs::attach_variables_file(&mut it, &cfg, VarsAccess::ReadOnly);
        run(&mut it, "p.nc", prog).unwrap();
        assert_eq!(it.var(500), Some(42.0));
        assert_eq!(std::fs::read(&path).unwrap(), before, "file untouched");
    }

    // Writable injection: the write is durable.
    let mut it = Interpreter::new(&cfg);
    host_fs::attach_variables_file(&mut it, &cfg, VarsAccess::Write);
    run(&mut it, "p.nc", prog).unwrap();
    assert_eq!(NvTable::load(&path).unwrap().get(500), Some(42.0));
    let _ = std::fs::remove_dir_all(&d);
}
