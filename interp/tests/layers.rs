//! The interpreter's layers stay one-way: every `crate::…` path in a source file (in `use`
//! lines and in code, comments left out) must name a module of the file's own layer or a lower
//! one. The order, lowest first: host traits, expressions, variables, the canonical operations,
//! cutter radius compensation (canonical → canonical),
//! lowering (canonical → segments), block execution, output (segment and canonical dumps), the
//! C-like language, program flow, the file-system host. `lib.rs` is the crate's
//! face and may name anything. Inside a layer, the files must not use each other in a circle
//! either (`super::x`, `crate::layer::x`, a `mod.rs` naming its child `x::`).

use std::collections::{BTreeMap, BTreeSet};
use std::fs;
use std::path::Path;

const SRC: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/src");

/// The layer of a source file, by its path under `src/`; `None` for `lib.rs`.
fn layer_of_file(rel: &str) -> Option<u32> {
    if rel == "lib.rs" {
        return None;
    }
    let top = rel.split('/').next().unwrap_or(rel).trim_end_matches(".rs");
    Some(layer_of_name(top).unwrap_or_else(|| panic!("src/{rel}: no layer for `{top}`")))
}

/// The layer of a name at the crate root: a layer module, an old public path re-exported by
/// `lib.rs`, or an item `lib.rs` re-exports.
fn layer_of_name(name: &str) -> Option<u32> {
    Some(match name {
        "host" | "ExactStop" | "MotionSync" | "PersistentVars" | "ProgramLibrary" | "UsedFile" => 0,
        "expr" | "eval" => 10,
        "vars" | "nvfile" | "NvTable" | "VarFileError" => 20,
        "canon" => 24,
        "comp" => 25,
        "lower" => 27,
        "block" | "arc" | "cycles" | "offsets" | "state" | "words" | "ModalState" => 30,
        "dump" | "segment_to_json" => 40,
        "hll" => 50,
        "flow" | "macros" | "Interpreter" | "MainM99" | "Options" | "run_program"
        | "run_program_with" => 60,
        "host_fs" => 70,
        _ => return None,
    })
}

/// The source without `//` comments (doc links may point anywhere).
fn code_only(text: &str) -> String {
    text.lines()
        .map(|l| match l.find("//") {
            Some(i) => &l[..i],
            None => l,
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// Every crate-root name a `crate::` path in `code` starts with (`crate::a::b` → `a`,
/// `crate::{a, b::c}` → `a`, `b`), with `host::fs` reported as `host_fs`.
fn crate_names(code: &str) -> Vec<String> {
    let mut out = Vec::new();
    let mut rest = code;
    while let Some(i) = rest.find("crate::") {
        let before = rest[..i].chars().next_back();
        rest = &rest[i + "crate::".len()..];
        // `$crate::`, `some_crate::` are other crates.
        if before.is_some_and(|c| c.is_alphanumeric() || c == '_' || c == '$') {
            continue;
        }
        if let Some(group) = rest.strip_prefix('{') {
            let end = group.find('}').unwrap_or(group.len());
            for part in group[..end].split(',') {
                let path: String = part.split_whitespace().collect();
                if !path.is_empty() {
                    out.push(first_name(&path));
                }
            }
        } else {
            out.push(first_name(rest));
        }
    }
    out
}

fn first_name(path: &str) -> String {
    let ident = |s: &str| -> String {
        s.chars()
            .take_while(|c| c.is_alphanumeric() || *c == '_')
            .collect()
    };
    let first = ident(path);
    let after = &path[first.len()..];
    if first == "host"
        && after.starts_with("::fs")
        && !after[4..].starts_with(char::is_alphanumeric)
    {
        return "host_fs".into();
    }
    first
}

/// The layering errors of one file.
fn violations(rel: &str, text: &str) -> Vec<String> {
    let Some(own) = layer_of_file(rel) else {
        return Vec::new();
    };
    let mut out = Vec::new();
    for name in crate_names(&code_only(text)) {
        match layer_of_name(&name) {
            Some(l) if l <= own => {}
            Some(_) => out.push(format!("src/{rel} uses crate::{name}, a higher layer")),
            None => out.push(format!(
                "src/{rel} uses crate::{name}, which has no layer in tests/layers.rs"
            )),
        }
    }
    out
}

fn rust_files(dir: &Path, out: &mut Vec<std::path::PathBuf>) {
    for e in fs::read_dir(dir).expect("src is readable").flatten() {
        let p = e.path();
        if p.is_dir() {
            rust_files(&p, out);
        } else if p.extension().is_some_and(|x| x == "rs") {
            out.push(p);
        }
    }
}

/// The file a module path names: `dir/name.rs` or `dir/name/mod.rs`, if one of `files`.
fn module_file(dir: &str, name: &str, files: &BTreeSet<String>) -> Option<String> {
    let pre = if dir.is_empty() {
        String::new()
    } else {
        format!("{dir}/")
    };
    [format!("{pre}{name}.rs"), format!("{pre}{name}/mod.rs")]
        .into_iter()
        .find(|f| files.contains(f))
}

/// The files of its own folder that `rel` uses (test modules, at the file's end, left out).
fn sibling_uses(rel: &str, text: &str, files: &BTreeSet<String>) -> BTreeSet<String> {
    let code = code_only(text.split("#[cfg(test)]").next().unwrap_or(text));
    let (dir, file) = rel.rsplit_once('/').unwrap_or(("", rel));
    let is_mod = file == "mod.rs";
    let mut out = BTreeSet::new();
    let words: Vec<&str> = code
        .split(|c: char| !(c.is_alphanumeric() || c == '_' || c == ':'))
        .filter(|w| w.contains("::"))
        .collect();
    for w in words {
        let parts: Vec<&str> = w.split("::").collect();
        let target = match parts.as_slice() {
            // `super::x` from a file of the folder: its sibling x, else the folder's mod.rs.
            ["super", name, ..] if !is_mod => module_file(dir, name, files).or_else(|| {
                files
                    .contains(&format!("{dir}/mod.rs"))
                    .then(|| format!("{dir}/mod.rs"))
            }),
            ["crate", top, name, ..] if dir == *top => module_file(dir, name, files),
            [name, ..] if is_mod => module_file(dir, name, files),
            _ => None,
        };
        if let Some(t) = target.filter(|t| t != rel) {
            out.insert(t);
        }
    }
    out
}

/// A cycle in `edges`, as the files around it.
fn find_cycle(edges: &BTreeMap<String, BTreeSet<String>>) -> Option<Vec<String>> {
    fn visit(
        n: &str,
        edges: &BTreeMap<String, BTreeSet<String>>,
        state: &mut BTreeMap<String, u8>,
        path: &mut Vec<String>,
    ) -> Option<Vec<String>> {
        match state.get(n) {
            Some(2) => return None,
            Some(1) => {
                let at = path.iter().position(|p| p == n).unwrap_or(0);
                let mut c = path[at..].to_vec();
                c.push(n.to_string());
                return Some(c);
            }
            _ => {}
        }
        state.insert(n.to_string(), 1);
        path.push(n.to_string());
        for m in edges.get(n).into_iter().flatten() {
            if let Some(c) = visit(m, edges, state, path) {
                return Some(c);
            }
        }
        path.pop();
        state.insert(n.to_string(), 2);
        None
    }
    let mut state = BTreeMap::new();
    for n in edges.keys() {
        if let Some(c) = visit(n, edges, &mut state, &mut Vec::new()) {
            return Some(c);
        }
    }
    None
}

fn sources() -> Vec<(String, String)> {
    let mut files = Vec::new();
    rust_files(Path::new(SRC), &mut files);
    files.sort();
    files
        .iter()
        .map(|f| {
            let rel = f
                .strip_prefix(SRC)
                .expect("under src")
                .to_string_lossy()
                .trim_start_matches('/')
                .replace('\\', "/");
            (rel, fs::read_to_string(f).expect("readable"))
        })
        .collect()
}

#[test]
fn no_file_uses_itself_through_its_folder() {
    let srcs = sources();
    let files: BTreeSet<String> = srcs.iter().map(|(r, _)| r.clone()).collect();
    let edges: BTreeMap<String, BTreeSet<String>> = srcs
        .iter()
        .map(|(r, t)| (r.clone(), sibling_uses(r, t, &files)))
        .collect();
    assert!(
        edges["flow/macros.rs"].contains("flow/mod.rs"),
        "the check sees `super::Interpreter`: {edges:?}"
    );
    if let Some(c) = find_cycle(&edges) {
        panic!("module cycle: {}", c.join(" -> "));
    }
}

#[test]
fn the_cycle_check_sees_a_cycle() {
    let files: BTreeSet<String> = ["a/mod.rs", "a/x.rs", "a/y.rs"].map(String::from).into();
    let mut edges = BTreeMap::new();
    edges.insert(
        "a/mod.rs".to_string(),
        sibling_uses("a/mod.rs", "use x::T;", &files),
    );
    edges.insert(
        "a/x.rs".to_string(),
        sibling_uses("a/x.rs", "use super::y::U;", &files),
    );
    edges.insert(
        "a/y.rs".to_string(),
        sibling_uses("a/y.rs", "use crate::b::x::V;", &files),
    );
    assert_eq!(find_cycle(&edges), None);
    edges.insert(
        "a/y.rs".to_string(),
        sibling_uses("a/y.rs", "use super::T;", &files),
    );
    assert_eq!(
        find_cycle(&edges).map(|c| c.len()),
        Some(4),
        "mod -> x -> y -> mod"
    );
}

#[test]
fn lower_layers_never_use_higher_ones() {
    let srcs = sources();
    assert!(srcs.len() > 15, "the sources were found: {}", srcs.len());
    let errors: Vec<String> = srcs.iter().flat_map(|(r, t)| violations(r, t)).collect();
    assert!(errors.is_empty(), "{}", errors.join("\n"));
}

#[test]
fn the_check_sees_an_upward_use() {
    let bad = "use crate::flow::Interpreter;\nfn f() { crate::hll::x(); }\n";
    assert_eq!(violations("block/exec.rs", bad).len(), 2);
    assert_eq!(
        violations("vars/mod.rs", "use crate::{expr::ops, block::state};").len(),
        1
    );
    assert_eq!(
        violations("vars/mod.rs", "use crate::host::fs::X;").len(),
        1
    );
    assert!(violations("host_fs.rs", "use crate::flow::Interpreter;").is_empty());
    assert!(violations("expr/mod.rs", "// see crate::flow\n$crate::x").is_empty());
    assert_eq!(violations("expr/mod.rs", "crate::nowhere::x").len(), 1);
}
