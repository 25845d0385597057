//! Naming a block on the command line: `N1700` (a block number, in any file of the run) or
//! `file.nc:42` (a line). Checked against the program text before the run: a breakpoint that
//! names nothing is a warning listing the nearest blocks; a search bound that names nothing
//! is an error (exit 2), a range that runs backwards a usage error (exit 64).

use std::path::{Path, PathBuf};

use cnc402_lang::SourceFile;
use cnc402_motion::Source;

use super::search::SearchSpec;

/// A block named on the command line.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum BlockSpec {
    /// `N1700`: every block numbered 1700.
    N(u32),
    /// `file.nc:42`: the block on line 42 of `file.nc`.
    Line { file: String, line: u32 },
}

/// Most files next to the program scanned for block numbers, and their largest size.
const MAX_SIBLINGS: usize = 200;
const MAX_SIBLING_BYTES: u64 = 4 << 20;

impl BlockSpec {
    /// Parses `N1700` or `FILE:LINE`.
    pub fn parse(s: &str) -> Result<BlockSpec, String> {
        let t = s.trim();
        if let Some(d) = t.strip_prefix(['N', 'n'])
            && let Ok(n) = d.parse::<u32>()
        {
            return Ok(BlockSpec::N(n));
        }
        if let Some((file, line)) = t.rsplit_once(':')
            && let Ok(line) = line.parse::<u32>()
            && line > 0
            && !file.is_empty()
        {
            return Ok(BlockSpec::Line {
                file: file.to_string(),
                line,
            });
        }
        Err(format!(
            "{s:?}: expected a block number (N1700) or FILE:LINE (part.nc:42)"
        ))
    }

    /// Whether the block at `src` is the one named.
    pub fn matches(&self, src: &Source) -> bool {
        match self {
            BlockSpec::N(n) => src.n == Some(*n),
            BlockSpec::Line { file, line } => src.line == *line && file_matches(&src.file, file),
        }
    }
}

impl std::fmt::Display for BlockSpec {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            BlockSpec::N(n) => write!(f, "N{n}"),
            BlockSpec::Line { file, line } => write!(f, "{file}:{line}"),
        }
    }
}

/// Whether the source file `source` (as the interpreter names it) is `named` (as the operator
/// wrote it): the same path's tail, or the same file on disk.
pub fn file_matches(source: &str, named: &str) -> bool {
    let (s, n) = (Path::new(source), Path::new(named));
    if s.ends_with(n) || n.ends_with(s) {
        return true;
    }
    match (s.canonicalize(), n.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

/// `(N, line)` of every numbered block of `text` (`N1700…`, `/N1700…`).
fn numbered_blocks(text: &str) -> Vec<(u32, u32)> {
    text.lines()
        .enumerate()
        .filter_map(|(i, l)| {
            let l = l.trim_start().trim_start_matches('/').trim_start();
            let d = l.strip_prefix(['N', 'n'])?;
            let end = d.find(|c: char| !c.is_ascii_digit()).unwrap_or(d.len());
            Some((d[..end].parse().ok()?, i as u32 + 1))
        })
        .collect()
}

/// Whether line `line` (1-based) of `text` holds a block: anything but blanks, comments
/// (`(…)`, `;…`) and `%`.
fn has_block(text: &str, line: u32) -> bool {
    let Some(l) = text.lines().nth(line.saturating_sub(1) as usize) else {
        return false;
    };
    let mut depth = 0u32;
    for c in l.chars() {
        match c {
            ';' if depth == 0 => return false,
            '(' => depth += 1,
            ')' => depth = depth.saturating_sub(1),
            c if depth == 0 && !c.is_whitespace() && c != '%' => return true,
            _ => {}
        }
    }
    false
}

/// The nearest lines of `text` around `line` that hold a block (before, after).
fn nearest_block_lines(text: &str, line: u32) -> Vec<u32> {
    let count = text.lines().count() as u32;
    let before = (1..line.min(count + 1)).rev().find(|&l| has_block(text, l));
    let after = (line + 1..=count).find(|&l| has_block(text, l));
    before.into_iter().chain(after).collect()
}

/// The block numbers nearest `n` among `known` (at most three), as `N10, N20`.
fn nearest_ns(known: &[(u32, u32)], n: u32) -> String {
    let mut ns: Vec<u32> = known.iter().map(|k| k.0).collect();
    ns.sort_unstable();
    ns.dedup();
    ns.sort_by_key(|&k| (k.abs_diff(n), k));
    let near: Vec<String> = ns.iter().take(3).map(|k| format!("N{k}")).collect();
    if near.is_empty() {
        "the program has no numbered blocks".into()
    } else {
        format!("nearest: {}", near.join(", "))
    }
}

/// The text of the file a `FILE:LINE` names: the program itself, the path as given, or a
/// file of that name next to the program.
fn text_of(main: &SourceFile, file: &str) -> Option<(String, String)> {
    if file_matches(&main.name, file) {
        return Some((main.name.to_string(), main.text.to_string()));
    }
    let beside = Path::new(&*main.name)
        .parent()
        .map(|d| d.join(file))
        .unwrap_or_else(|| PathBuf::from(file));
    [PathBuf::from(file), beside].into_iter().find_map(|p| {
        let t = std::fs::read(&p).ok()?;
        Some((
            p.display().to_string(),
            String::from_utf8_lossy(&t).into_owned(),
        ))
    })
}

/// Block numbers of the program and of the programs next to it (same extension), which hold
/// its sub-programs.
fn all_numbered_blocks(main: &SourceFile) -> Vec<(u32, u32)> {
    let mut known = numbered_blocks(&main.text);
    let p = Path::new(&*main.name);
    let (Some(dir), ext) = (p.parent(), p.extension()) else {
        return known;
    };
    let dir = if dir.as_os_str().is_empty() {
        Path::new(".")
    } else {
        dir
    };
    let Ok(entries) = std::fs::read_dir(dir) else {
        return known;
    };
    for e in entries.flatten().take(MAX_SIBLINGS) {
        let path = e.path();
        let small = e.metadata().is_ok_and(|m| m.len() <= MAX_SIBLING_BYTES);
        if path.extension() == ext
            && small
            && path != p
            && let Ok(t) = std::fs::read(&path)
        {
            known.extend(numbered_blocks(&String::from_utf8_lossy(&t)));
        }
    }
    known
}

/// Why `spec` names no block of the program, if it names none.
fn names_nothing(spec: &BlockSpec, main: &SourceFile, known: &[(u32, u32)]) -> Option<String> {
    match spec {
        BlockSpec::N(n) => (!known.iter().any(|k| k.0 == *n)).then(|| {
            format!(
                "N{n} is no block of {} ({})",
                main.name,
                nearest_ns(known, *n)
            )
        }),
        BlockSpec::Line { file, line } => match text_of(main, file) {
            None => Some(format!("{file}: no such program file")),
            Some((name, text)) if !has_block(&text, *line) => {
                let near: Vec<String> = nearest_block_lines(&text, *line)
                    .iter()
                    .map(|l| format!("{name}:{l}"))
                    .collect();
                Some(format!(
                    "{name}:{line} holds no block (nearest blocks: {})",
                    if near.is_empty() {
                        "none".into()
                    } else {
                        near.join(", ")
                    }
                ))
            }
            Some(_) => None,
        },
    }
}

/// Warnings for breakpoints that name no block (the run still starts).
pub fn check_breaks(breaks: &[BlockSpec], main: &SourceFile) -> Vec<String> {
    let known = all_numbered_blocks(main);
    breaks
        .iter()
        .filter_map(|b| names_nothing(b, main, &known))
        .map(|w| format!("breakpoint {w}: it will not hold"))
        .collect()
}

/// Why a block search cannot run.
#[derive(Debug, PartialEq)]
pub enum SearchError {
    /// A bound names no block (exit 2).
    NotFound(String),
    /// `--to` comes before `--from` (exit 64).
    Backwards(String),
}

/// The main program's line of `spec`, when it names a block there.
fn main_line(spec: &BlockSpec, main: &SourceFile, known: &[(u32, u32)]) -> Option<u32> {
    match spec {
        BlockSpec::N(n) => known.iter().find(|k| k.0 == *n).map(|k| k.1),
        BlockSpec::Line { file, line } => file_matches(&main.name, file).then_some(*line),
    }
}

/// Checks a block search's bounds against the program.
pub fn resolve_search(
    from: BlockSpec,
    to: Option<BlockSpec>,
    main: &SourceFile,
) -> Result<SearchSpec, SearchError> {
    let known = all_numbered_blocks(main);
    for s in std::iter::once(&from).chain(to.as_ref()) {
        if let Some(why) = names_nothing(s, main, &known) {
            return Err(SearchError::NotFound(format!("block search: {why}")));
        }
    }
    let in_main = numbered_blocks(&main.text);
    if let Some(t) = &to
        && let (Some(a), Some(b)) = (
            main_line(&from, main, &in_main),
            main_line(t, main, &in_main),
        )
        && b < a
    {
        return Err(SearchError::Backwards(format!(
            "--to {t} (line {b}) comes before --from {from} (line {a})"
        )));
    }
    Ok(SearchSpec { from, to })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn specs_parse() {
        assert_eq!(BlockSpec::parse("N1700"), Ok(BlockSpec::N(1700)));
        assert_eq!(
            BlockSpec::parse("dir/p.nc:42"),
            Ok(BlockSpec::Line {
                file: "dir/p.nc".into(),
                line: 42
            })
        );
        assert!(BlockSpec::parse("N").is_err());
        assert!(BlockSpec::parse("p.nc:0").is_err());
        assert!(BlockSpec::parse("X12").is_err());
    }

    #[test]
    fn a_missing_n_names_the_nearest_and_an_empty_line_the_nearest_blocks() {
        let main = SourceFile::new(
            "/nonexistent/p.nc",
            "N10 G0 X0\n(only a comment)\nN20 G1 X1\nN40 X2\n",
        );
        let w = check_breaks(&[BlockSpec::N(30), BlockSpec::N(20)], &main);
        assert_eq!(w.len(), 1);
        assert!(
            w[0].contains("N30 is no block") && w[0].contains("N20, N40, N10"),
            "{}",
            w[0]
        );
        let w = check_breaks(
            &[BlockSpec::Line {
                file: "/nonexistent/p.nc".into(),
                line: 2,
            }],
            &main,
        );
        assert!(
            w[0].contains("p.nc:2 holds no block") && w[0].contains("p.nc:1, /nonexistent/p.nc:3"),
            "{}",
            w[0]
        );
    }

    #[test]
    fn a_search_that_runs_backwards_or_names_nothing_is_refused() {
        let main = SourceFile::new("/nonexistent/p.nc", "N10 G0 X0\nN20 G1 X1\nN30 X2\n");
        assert!(matches!(
            resolve_search(BlockSpec::N(30), Some(BlockSpec::N(10)), &main),
            Err(SearchError::Backwards(_))
        ));
        assert!(matches!(
            resolve_search(BlockSpec::N(25), None, &main),
            Err(SearchError::NotFound(m)) if m.contains("N20, N30")
        ));
        assert!(resolve_search(BlockSpec::N(10), Some(BlockSpec::N(30)), &main).is_ok());
    }
}
