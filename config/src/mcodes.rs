//! `[mcodes]`: the machine's own M codes (what a machine builder adds to the control's M0–M99
//! set: M13 spindle and coolant, M17/M25 clamps, M66 wait for an input, M101 a macro …), each
//! mapped to an action. An M number the interpreter defines itself cannot be remapped.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Spanned;

use crate::check::{Invalid, Table};

/// The M codes the interpreter defines (program stops and ends, spindle, tool change,
/// coolant, orientation, rigid tapping, sub-program call and return): not remappable.
pub const BUILT_IN_M_CODES: [u32; 15] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 19, 29, 30, 98, 99];

/// The file extensions a sub-program file may have (any case).
pub const PROGRAM_EXTENSIONS: &[&str] = &["nc", "cnc", "ngc", "tap", "txt", "mpf", "spf"];

/// Longest dwell or wait an M code may ask for (s): an hour.
const MAX_SECONDS: f64 = 3600.0;

/// What a machine M code does.
#[derive(Clone, Debug, PartialEq)]
pub enum MAction {
    /// Nothing on this machine (a note once per run; `note` says why).
    Ignore { note: Option<String> },
    /// Sets output `name` to `value` (an event in the canon/segment stream until the I/O of
    /// the drives is wired).
    Output { name: String, value: bool },
    /// Waits until input `name` is `value`, at most `timeout_s` seconds.
    Wait {
        name: String,
        value: bool,
        timeout_s: f64,
    },
    /// A dwell of `seconds`.
    Dwell { seconds: f64 },
    /// Calls program `program`: like `M98 P…` (Fanuc's sub-program call by M code,
    /// parameters 6071–6079 → O9001–O9009), or with `args` like `G65 P…` with the block's
    /// other words as arguments (custom macro call by M code, parameters 6080–6089 →
    /// O9020–O9029).
    Macro { program: u32, args: bool },
    /// The same as these built-in M codes in one block (M13 = M3 M8 on many machines).
    Alias { codes: Vec<u32> },
}

/// `[mcodes]` as written: `13 = { action = "alias", codes = [3, 8] }`.
pub(crate) type RawMCodes = BTreeMap<String, Spanned<Table<RawMCode>>>;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawMCode {
    action: Spanned<String>,
    note: Option<Spanned<String>>,
    output: Option<Spanned<String>>,
    input: Option<Spanned<String>>,
    value: Option<Spanned<bool>>,
    timeout_s: Option<Spanned<f64>>,
    seconds: Option<Spanned<f64>>,
    program: Option<Spanned<i64>>,
    args: Option<Spanned<bool>>,
    codes: Option<Spanned<Vec<i64>>>,
}

/// The whole table by M number.
pub(crate) fn validate(raw: &RawMCodes) -> Result<BTreeMap<u32, MAction>, Invalid> {
    let mut out = BTreeMap::new();
    for (n, t) in raw {
        let key = format!("mcodes.{n}");
        let code = n
            .parse::<u32>()
            .ok()
            .filter(|k| *k <= 9999 && (n == "0" || !n.starts_with('0')))
            .ok_or_else(|| (t.span(), key.clone(), "expected an M number 0..9999".into()))?;
        if BUILT_IN_M_CODES.contains(&code) {
            return Err((
                t.span(),
                key,
                format!("M{code} is defined by the interpreter and cannot be remapped"),
            ));
        }
        out.insert(code, action(&t.get_ref().0, &key, t.span())?);
    }
    Ok(out)
}

/// One entry's action, every key it gives belonging to it.
fn action(m: &RawMCode, key: &str, at: std::ops::Range<usize>) -> Result<MAction, Invalid> {
    let given: [(&str, Option<std::ops::Range<usize>>); 9] = [
        ("note", m.note.as_ref().map(Spanned::span)),
        ("output", m.output.as_ref().map(Spanned::span)),
        ("input", m.input.as_ref().map(Spanned::span)),
        ("value", m.value.as_ref().map(Spanned::span)),
        ("timeout_s", m.timeout_s.as_ref().map(Spanned::span)),
        ("seconds", m.seconds.as_ref().map(Spanned::span)),
        ("program", m.program.as_ref().map(Spanned::span)),
        ("args", m.args.as_ref().map(Spanned::span)),
        ("codes", m.codes.as_ref().map(Spanned::span)),
    ];
    let a = m.action.get_ref().as_str();
    let allowed: &[&str] = match a {
        "ignore" => &["note"],
        "output" => &["output", "value"],
        "wait" => &["input", "value", "timeout_s"],
        "dwell" => &["seconds"],
        "macro" => &["program", "args"],
        "alias" => &["codes"],
        _ => {
            return Err((
                m.action.span(),
                format!("{key}.action"),
                format!(
                    "expected \"ignore\", \"output\", \"wait\", \"dwell\", \"macro\" or \"alias\", got {a:?}"
                ),
            ));
        }
    };
    if let Some((k, Some(span))) = given
        .iter()
        .find(|(k, s)| s.is_some() && !allowed.contains(k))
    {
        return Err((
            span.clone(),
            format!("{key}.{k}"),
            format!(
                "not a key of action \"{a}\" (its keys: {})",
                allowed.join(", ")
            ),
        ));
    }
    let need = |k: &str| {
        (
            at.clone(),
            key.to_string(),
            format!("action \"{a}\" needs `{k}`"),
        )
    };
    let name = |v: &Option<Spanned<String>>, k: &str| -> Result<String, Invalid> {
        let v = v.as_ref().ok_or_else(|| need(k))?;
        let s = v.get_ref().trim();
        if s.is_empty() {
            return Err((v.span(), format!("{key}.{k}"), "must not be blank".into()));
        }
        Ok(s.to_string())
    };
    let seconds = |v: &Option<Spanned<f64>>, k: &str| -> Result<f64, Invalid> {
        let v = v.as_ref().ok_or_else(|| need(k))?;
        let x = *v.get_ref();
        if x.is_finite() && (0.0..=MAX_SECONDS).contains(&x) {
            Ok(x)
        } else {
            Err((
                v.span(),
                format!("{key}.{k}"),
                format!("must be 0..={MAX_SECONDS} seconds, got {x}"),
            ))
        }
    };
    let value = m.value.as_ref().is_none_or(|v| *v.get_ref());
    Ok(match a {
        "ignore" => MAction::Ignore {
            note: m.note.as_ref().map(|n| n.get_ref().clone()),
        },
        "output" => MAction::Output {
            name: name(&m.output, "output")?,
            value,
        },
        "wait" => MAction::Wait {
            name: name(&m.input, "input")?,
            value,
            timeout_s: seconds(&m.timeout_s, "timeout_s")?,
        },
        "dwell" => MAction::Dwell {
            seconds: seconds(&m.seconds, "seconds")?,
        },
        "macro" => {
            let p = m.program.as_ref().ok_or_else(|| need("program"))?;
            let program = u32::try_from(*p.get_ref())
                .ok()
                .filter(|n| (1..=9999).contains(n))
                .ok_or_else(|| {
                    (
                        p.span(),
                        format!("{key}.program"),
                        format!("expected a program number 1..9999, got {}", p.get_ref()),
                    )
                })?;
            MAction::Macro {
                program,
                args: m.args.as_ref().is_some_and(|v| *v.get_ref()),
            }
        }
        _ => {
            let c = m.codes.as_ref().ok_or_else(|| need("codes"))?;
            let codes = c
                .get_ref()
                .iter()
                .map(|&x| {
                    u32::try_from(x)
                        .ok()
                        .filter(|x| BUILT_IN_M_CODES.contains(x) && !matches!(x, 98 | 99))
                })
                .collect::<Option<Vec<u32>>>()
                .filter(|v| !v.is_empty())
                .ok_or_else(|| {
                    (
                        c.span(),
                        format!("{key}.codes"),
                        "expected built-in M codes other than M98/M99 (e.g. [3, 8])".into(),
                    )
                })?;
            MAction::Alias { codes }
        }
    })
}

/// The file of program `number` in `dir` (`O9001.nc`, `o9001.CNC`, `O12.txt` …: the stem
/// `O` and the number with or without leading zeros to four digits, any case, one of
/// [`PROGRAM_EXTENSIONS`]); the first by name if several. `Ok(None)`: none, or no folder.
pub fn program_file(dir: &Path, number: u32) -> Result<Option<PathBuf>, String> {
    let names = [format!("o{number:04}"), format!("o{number}")];
    let rd = match std::fs::read_dir(dir) {
        Ok(rd) => rd,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
        Err(e) => return Err(format!("program directory {}: {e}", dir.display())),
    };
    let mut found: Vec<PathBuf> = rd
        .flatten()
        .map(|ent| ent.path())
        .filter(|p| is_program_file(p, &names))
        .collect();
    found.sort();
    Ok(found.into_iter().next())
}

fn is_program_file(p: &Path, names: &[String]) -> bool {
    let (Some(stem), Some(ext)) = (
        p.file_stem().and_then(|s| s.to_str()),
        p.extension().and_then(|s| s.to_str()),
    ) else {
        return false;
    };
    names.iter().any(|n| stem.eq_ignore_ascii_case(n))
        && PROGRAM_EXTENSIONS
            .iter()
            .any(|e| ext.eq_ignore_ascii_case(e))
}

/// Each `macro` target exists in `program_dir` when that folder exists (a missing folder is
/// checked at run time, at the block).
pub(crate) fn check_targets(
    raw: &RawMCodes,
    mcodes: &BTreeMap<u32, MAction>,
    program_dir: &Path,
) -> Result<(), Invalid> {
    if !program_dir.is_dir() {
        return Ok(());
    }
    for (n, t) in raw {
        let Ok(code) = n.parse::<u32>() else { continue };
        if let Some(MAction::Macro { program, .. }) = mcodes.get(&code) {
            let found = program_file(program_dir, *program)
                .map_err(|e| (t.span(), format!("mcodes.{n}.program"), e))?;
            if found.is_none() {
                let span = t
                    .get_ref()
                    .0
                    .program
                    .as_ref()
                    .map_or(t.span(), Spanned::span);
                return Err((
                    span,
                    format!("mcodes.{n}.program"),
                    format!(
                        "M{code} calls O{program:04}, which is not in {}",
                        program_dir.display()
                    ),
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn program_files_match_case_insensitively() {
        let n = |s: &str| is_program_file(Path::new(s), &["o9001".into(), "o9001".into()]);
        assert!(n("/x/O9001.CNC"));
        assert!(n("/x/o9001.nc"));
        assert!(n("O9001.Nc"));
        assert!(!n("O9001"));
        assert!(!n("O9001.bak"));
        assert!(!n("O90011.nc"));
    }
}
