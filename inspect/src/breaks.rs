//! Breakpoints as the operator writes them (`N1700`, `file.nc:42`) resolved against a
//! program's toolpath: the blocks each one marks, or a warning naming the nearest blocks that
//! exist when it names none.

use crate::toolpath::Toolpath;

/// A breakpoint as written.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BreakSpec {
    /// `N1700`: every block numbered N1700 (in any file).
    N(u32),
    /// `file.nc:42`: the block on line 42 of the file whose path ends with `file.nc`.
    Line { file: String, line: u32 },
}

impl BreakSpec {
    /// Parses `N1700` (or `n1700`) or `FILE:LINE`.
    pub fn parse(s: &str) -> Result<BreakSpec, String> {
        let t = s.trim();
        let bad = || format!("--break {s:?}: expected N<number> (N1700) or FILE:LINE (part.nc:42)");
        if let Some(num) = t.strip_prefix(['N', 'n'])
            && !num.is_empty()
            && num.bytes().all(|b| b.is_ascii_digit())
        {
            return num.parse().map(BreakSpec::N).map_err(|_| bad());
        }
        let (file, line) = t.rsplit_once(':').ok_or_else(bad)?;
        let line: u32 = line.parse().map_err(|_| bad())?;
        if file.is_empty() || line == 0 {
            return Err(bad());
        }
        Ok(BreakSpec::Line {
            file: file.to_string(),
            line,
        })
    }
}

/// Where a breakpoint lands.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Resolved {
    /// As the operator wrote it.
    pub spec: String,
    /// The blocks (indices into [`Toolpath::blocks`]) it marks; empty with a warning.
    pub blocks: Vec<usize>,
    /// Why it marks nothing, or marks a later block than written.
    pub warning: Option<String>,
}

/// How many existing neighbours a warning lists.
const NEAREST_LISTED: usize = 4;

/// Resolves `spec` on `tp`. `numbered` are the (N, line) pairs of the main program's text
/// (`main_file`), so that an N whose block makes no segment still exists: it marks the next
/// block that does.
pub fn resolve(
    tp: &Toolpath,
    spec: &BreakSpec,
    written: &str,
    main_file: &str,
    numbered: &[(u32, u32)],
) -> Resolved {
    let mut r = Resolved {
        spec: written.to_string(),
        blocks: Vec::new(),
        warning: None,
    };
    match spec {
        BreakSpec::N(n) => {
            r.blocks = (0..tp.blocks.len())
                .filter(|&b| tp.blocks[b].n == Some(*n))
                .collect();
            if r.blocks.is_empty() {
                if let Some(&(_, line)) = numbered.iter().find(|(m, _)| m == n) {
                    mark_at_or_after(tp, main_file, line, &mut r);
                } else {
                    r.warning = Some(missing_n(tp, *n, numbered));
                }
            }
        }
        BreakSpec::Line { file, line } => {
            let Some(name) = tp.files.iter().find(|f| same_file(f, file)) else {
                let files: Vec<&str> = tp.files.iter().map(|f| &**f).collect();
                r.warning = Some(format!(
                    "breakpoint {written}: no block of {file} ran (files that ran: {})",
                    files.join(", ")
                ));
                return r;
            };
            mark_at_or_after(tp, &name.clone(), *line, &mut r);
        }
    }
    r
}

/// `name` (as the interpreter names a file) is the file the operator wrote as `written`.
fn same_file(name: &str, written: &str) -> bool {
    let (n, w) = (name.replace('\\', "/"), written.replace('\\', "/"));
    n == w
        || n.ends_with(&format!("/{}", w.trim_start_matches("./")))
        || std::fs::canonicalize(name)
            .ok()
            .zip(std::fs::canonicalize(written).ok())
            .is_some_and(|(a, b)| a == b)
}

/// Marks the block on `line` of `file`, or the first later block of that file with a
/// segment (with a note), or warns with the nearest lines that have one.
fn mark_at_or_after(tp: &Toolpath, file: &str, line: u32, r: &mut Resolved) {
    let in_file: Vec<usize> = (0..tp.blocks.len())
        .filter(|&b| &*tp.files[tp.blocks[b].file] == file)
        .collect();
    let exact: Vec<usize> = in_file
        .iter()
        .copied()
        .filter(|&b| tp.blocks[b].line == line)
        .collect();
    if !exact.is_empty() {
        r.blocks = exact;
        return;
    }
    let later = in_file
        .iter()
        .copied()
        .filter(|&b| tp.blocks[b].line > line)
        .min_by_key(|&b| tp.blocks[b].line);
    match later {
        Some(b) => {
            r.blocks = vec![b];
            r.warning = Some(format!(
                "breakpoint {}: {file}:{line} makes no motion; marked at the next block that \
                 does, {}",
                r.spec,
                tp.block_label(b)
            ));
        }
        None => {
            let mut lines: Vec<u32> = in_file.iter().map(|&b| tp.blocks[b].line).collect();
            lines.sort_by_key(|l| l.abs_diff(line));
            lines.dedup();
            lines.truncate(NEAREST_LISTED);
            let near: Vec<String> = lines.iter().map(|l| format!("{file}:{l}")).collect();
            r.warning = Some(format!(
                "breakpoint {}: no block at or after {file}:{line} makes motion; nearest: {}",
                r.spec,
                if near.is_empty() {
                    "none".into()
                } else {
                    near.join(", ")
                }
            ));
        }
    }
}

/// The warning for an N that no block has, naming the nearest Ns that exist.
fn missing_n(tp: &Toolpath, n: u32, numbered: &[(u32, u32)]) -> String {
    let mut known: Vec<u32> = tp
        .blocks
        .iter()
        .filter_map(|b| b.n)
        .chain(numbered.iter().map(|&(m, _)| m))
        .collect();
    known.sort_unstable();
    known.dedup();
    known.sort_by_key(|m| (m.abs_diff(n), *m));
    known.truncate(NEAREST_LISTED);
    known.sort_unstable();
    if known.is_empty() {
        return format!("breakpoint N{n}: the program has no N numbers");
    }
    let near: Vec<String> = known
        .iter()
        .map(|m| {
            let at = tp
                .blocks
                .iter()
                .position(|b| b.n == Some(*m))
                .map(|b| format!(" ({})", tp.block_label(b)))
                .unwrap_or_default();
            format!("N{m}{at}")
        })
        .collect();
    format!(
        "breakpoint N{n}: no block N{n} in the program; nearest: {}",
        near.join(", ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::toolpath::Block;

    fn program() -> Toolpath {
        Toolpath {
            files: vec!["dir/a.nc".into()],
            blocks: [(3, 1690), (4, 1700), (6, 1720)]
                .into_iter()
                .map(|(line, n)| Block {
                    file: 0,
                    line,
                    n: Some(n),
                })
                .collect(),
            ..Toolpath::default()
        }
    }

    #[test]
    fn specs_parse_and_bad_ones_say_what_is_expected() {
        assert_eq!(BreakSpec::parse("N1700"), Ok(BreakSpec::N(1700)));
        assert_eq!(
            BreakSpec::parse("part.nc:42"),
            Ok(BreakSpec::Line {
                file: "part.nc".into(),
                line: 42
            })
        );
        for bad in ["N", "N17x", "part.nc", "part.nc:0", ":4", "X12"] {
            assert!(
                BreakSpec::parse(bad)
                    .unwrap_err()
                    .contains("expected N<number>")
            );
        }
    }

    #[test]
    fn a_missing_n_lists_the_nearest_that_exist() {
        let tp = program();
        let numbered = [(1690, 3), (1700, 4), (1710, 5), (1720, 6)];
        let r = resolve(&tp, &BreakSpec::N(1705), "N1705", "dir/a.nc", &numbered);
        assert!(r.blocks.is_empty());
        let w = r.warning.unwrap();
        assert!(
            w.contains("N1700 (dir/a.nc:4 N1700)") && w.contains("N1710"),
            "{w}"
        );
        // N1710 is in the text but makes no motion: marked at the next block that does.
        let r = resolve(&tp, &BreakSpec::N(1710), "N1710", "dir/a.nc", &numbered);
        assert_eq!(r.blocks, vec![2]);
        let r = resolve(&tp, &BreakSpec::N(1700), "N1700", "dir/a.nc", &numbered);
        assert_eq!((r.blocks, r.warning), (vec![1], None));
    }

    #[test]
    fn a_file_line_matches_the_end_of_the_path() {
        let tp = program();
        let spec = BreakSpec::parse("a.nc:4").unwrap();
        assert_eq!(
            resolve(&tp, &spec, "a.nc:4", "dir/a.nc", &[]).blocks,
            vec![1]
        );
        let spec = BreakSpec::parse("b.nc:4").unwrap();
        let r = resolve(&tp, &spec, "b.nc:4", "dir/a.nc", &[]);
        assert!(r.warning.unwrap().contains("no block of b.nc ran"));
        let spec = BreakSpec::parse("a.nc:9").unwrap();
        let w = resolve(&tp, &spec, "a.nc:9", "dir/a.nc", &[])
            .warning
            .unwrap();
        assert!(w.contains("nearest: dir/a.nc:6"), "{w}");
    }
}
