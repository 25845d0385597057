//! A block's words sorted for execution: G codes with their modal group, M codes, and one value
//! per other address letter. Every value that is read is marked used, so that a word the block
//! cannot use is reported instead of silently ignored.

use cnc402_lang::ast::{Block, Span, Value};
use cnc402_lang::{NcError, SourceFile};

use crate::expr as eval;

/// The value of one address in a block.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Arg {
    pub v: f64,
    pub span: Span,
    /// Written with a decimal point (literal numbers only; expressions count as having one).
    pub has_point: bool,
}

/// Fanuc modal groups of the G codes this interpreter knows (group numbers as Fanuc M series).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum GGroup {
    /// 00: G4, G10, G28, G29, G30, G53, G92 (one-shot).
    NonModal,
    /// 01: G0 G1 G2 G3.
    Motion,
    /// 02: G17 G18 G19.
    Plane,
    /// 03: G90 G91.
    Distance,
    /// G90.1 (I/J/K absolute) G91.1 (incremental, Fanuc's only mode): LinuxCNC's group 4.
    ArcDistance,
    /// 05: G94 G95.
    FeedMode,
    /// 06: G20 G21.
    Units,
    /// 09: G73 G74 G76 G80-G89.
    Cycle,
    /// 10: G98 G99.
    ReturnMode,
    /// 08: G43 G44 G49.
    ToolLength,
    /// 14: G54-G59.
    WorkOffset,
    /// 15: G61 G63 G64, and Fanuc's G08 (lookahead: P1 = G64, P0 = G61) and G05.1 (AI
    /// contour control: Q1 = G64, Q0 = G61).
    PathMode,
    /// 00: G9, exact stop at the end of this block's motion only.
    ExactStopOnce,
    /// 07: G40 G41 G42 (cutter radius compensation, `block/comp.rs`).
    CutterComp,
    /// 00/12: G65 (macro call), G66/G67 (modal macro call); the interpreter handles them.
    MacroCall,
    /// A cancel code of a group whose function cnc402 does not have, so it is never on:
    /// G50 (11), G69 (16), G15 (17). Accepted as no-ops so that programs
    /// restoring saved modal state (`G[FUP[#104]]`) run.
    Cancel(u8),
}

impl GGroup {
    /// The group's bit in a set of groups (every [`Cancel`](GGroup::Cancel) shares one).
    pub const fn bit(self) -> u32 {
        use GGroup::*;
        1 << match self {
            NonModal => 0,
            Motion => 1,
            Plane => 2,
            Distance => 3,
            ArcDistance => 4,
            FeedMode => 5,
            Units => 6,
            Cycle => 7,
            ReturnMode => 8,
            ToolLength => 9,
            WorkOffset => 10,
            PathMode => 11,
            ExactStopOnce => 12,
            CutterComp => 13,
            MacroCall => 14,
            Cancel(_) => 15,
        }
    }
}

/// G codes with one decimal (`G90.1`) are numbered `DECIMAL_G + 10·whole + tenth`: a code
/// stays one `u32` that `match` takes plainly, and never equals a whole code (those are at
/// most 9999). Write them with [`g_dec`]; print any code with [`g_name`].
pub const DECIMAL_G: u32 = 100_000;

/// The code of `G<whole>.<tenth>`.
///
/// ```
/// use cnc402_interp::words::{g_dec, g_name};
/// assert_eq!(g_name(g_dec(90, 1)), "G90.1");
/// assert_eq!(g_name(1), "G1");
/// ```
pub const fn g_dec(whole: u32, tenth: u32) -> u32 {
    DECIMAL_G + whole * 10 + tenth
}

/// `G1`, `G90.1`: a G code as written.
pub fn g_name(code: u32) -> String {
    if code >= DECIMAL_G {
        let d = code - DECIMAL_G;
        format!("G{}.{}", d / 10, d % 10)
    } else {
        format!("G{code}")
    }
}

/// The modal group of G code `code` (see [`DECIMAL_G`] for `G90.1` and the like), or the
/// reason it cannot be run.
#[inline]
pub fn g_group(code: u32) -> Result<GGroup, String> {
    // The motion codes, in nearly every block, answered inline (the other codes' answer is
    // returned through memory).
    match code {
        0..=3 => Ok(GGroup::Motion),
        _ => other_g_group(code),
    }
}

fn other_g_group(code: u32) -> Result<GGroup, String> {
    use GGroup::*;
    if code >= DECIMAL_G {
        return decimal_g_group(code);
    }
    Ok(match code {
        4 | 10 | 28..=30 | 53 | 92 => NonModal,
        17..=19 => Plane,
        90 | 91 => Distance,
        94 | 95 => FeedMode,
        20 | 21 => Units,
        73 | 74 | 76 | 80..=89 => Cycle,
        98 | 99 => ReturnMode,
        54..=59 => WorkOffset,
        11 => {
            return Err(
                "G11 (programmable data input mode cancel) is not supported: G10 here is one block"
                    .into(),
            );
        }
        27 => {
            return Err("G27 (reference position return check) is not supported yet".into());
        }
        43 | 44 | 49 => ToolLength,
        8 | 61 | 63 | 64 => PathMode,
        9 => ExactStopOnce,
        62 => return Err("G62 (automatic corner override) is not supported yet".into()),
        40..=42 => CutterComp,
        50 => Cancel(11),
        69 => Cancel(16),
        15 => Cancel(17),
        65..=67 => MacroCall,
        _ => return Err(format!("unknown G code G{code}")),
    })
}

/// [`g_group`] of the codes with a decimal.
fn decimal_g_group(code: u32) -> Result<GGroup, String> {
    let name = g_name(code);
    if code == g_dec(90, 1) || code == g_dec(91, 1) {
        return Ok(GGroup::ArcDistance);
    }
    if code == g_dec(5, 1) {
        return Ok(GGroup::PathMode);
    }
    let what = match code {
        c if (g_dec(92, 1)..=g_dec(92, 3)).contains(&c) => "G92 offset reset and restore",
        c if (g_dec(38, 2)..=g_dec(38, 5)).contains(&c) => "probing",
        c if c == g_dec(43, 1) => "dynamic tool length offset",
        c if c == g_dec(33, 1) => "LinuxCNC rigid tapping",
        _ => return Err(format!("unknown G code {name}")),
    };
    Err(format!("{name} ({what}) is not supported yet"))
}

/// The words of one block.
#[derive(Debug)]
pub struct Words {
    /// G codes in source order, with their group (read with [`g`](Self::g), added with
    /// [`push_g`](Self::push_g), which keeps `groups` with them).
    g: Vec<(u32, GGroup, Span)>,
    /// Bit [`GGroup::bit`] of each group of `g`: a block asks for a dozen groups and has
    /// one or two, so most questions are answered without looking at `g`.
    groups: u32,
    /// The corner word `,R` (`'R'`) or `,C` (`'C'`) of Fanuc's corner rounding and
    /// chamfer, if the block has one; taken (set to `None`) by the code that uses it.
    pub corner: Option<(char, Arg)>,
    /// LinuxCNC's spindle selection `$n` (spindles from 0), if the block has one; taken by
    /// the block's spindle selection (the lexer gives `$` words in that dialect only).
    pub dollar: Option<Arg>,
    /// M codes in source order.
    pub m: Vec<(u32, Span)>,
    args: [Option<Arg>; 26],
    /// Bit `i`: letter `A + i` has a value in `args` (so that a block whose words were all
    /// used is known without looking at the 26 slots).
    given: u32,
    used: u32,
    /// The span of the whole block (all its words), for errors not at one word.
    pub span: Span,
}

impl Words {
    /// Sorts `block`'s words; errors on a G/M value that is not a known code, a letter given
    /// twice, an `N` inside the block, and on expressions that fail to evaluate.
    pub fn collect(src: &SourceFile, block: &Block) -> Result<Words, NcError> {
        Self::collect_with(src, block, &mut eval::NoVars)
    }

    /// [`collect`](Self::collect) reading macro variables from `vars`. A word whose value is
    /// vacant (`X#1` with `#1` vacant) is left out, as on Fanuc.
    pub fn collect_with(
        src: &SourceFile,
        block: &Block,
        vars: &mut dyn eval::VarSource,
    ) -> Result<Words, NcError> {
        let mut w = Words {
            g: Vec::new(),
            groups: 0,
            corner: None,
            dollar: None,
            m: Vec::new(),
            args: [None; 26],
            given: 0,
            used: 0,
            span: Span::default(),
        };
        w.collect_again(src, block, vars)?;
        Ok(w)
    }

    /// [`collect_with`](Self::collect_with) into these words, which are emptied first: a long
    /// program reuses one `Words` (and its vectors) for all its blocks.
    pub(crate) fn collect_again(
        &mut self,
        src: &SourceFile,
        block: &Block,
        vars: &mut dyn eval::VarSource,
    ) -> Result<(), NcError> {
        let w = self;
        w.g.clear();
        w.groups = 0;
        w.corner = None;
        w.dollar = None;
        w.m.clear();
        // Only the given letters hold a value (`given` is set with each one).
        let mut given = w.given;
        while given != 0 {
            w.args[given.trailing_zeros() as usize] = None;
            given &= given - 1;
        }
        w.given = 0;
        w.used = 0;
        w.span = block
            .words
            .iter()
            .map(|w| w.span)
            .reduce(Span::join)
            .unwrap_or_default();
        for word in &block.words {
            let Some(v) = eval::value_in(src, &word.value, vars)? else {
                continue;
            };
            if !v.is_finite() {
                // A literal of more than 308 digits: nothing after this may see `inf`.
                return Err(NcError::new(
                    src,
                    word.span,
                    format!("{} is not a finite number", word.letter),
                )
                .with_expected("a number within ±1.8e308"));
            }
            let has_point = match &word.value {
                Value::Number(n) => n.has_point,
                Value::Expr(_) => true,
            };
            let here = |m: String| NcError::new(src, word.span, m);
            match word.letter {
                'G' if decimal_g_code(v).is_some() => {
                    let code = decimal_g_code(v).unwrap_or_default();
                    let grp = g_group(code).map_err(here)?;
                    w.push_g(code, grp, word.span);
                }
                'G' | 'M' => {
                    let l = word.letter;
                    let code = whole_code(v).ok_or_else(|| {
                        here(format!(
                            "{l}{} is not a {l} code: {l} codes here are whole numbers",
                            fmt_num(v)
                        ))
                        .with_expected(format!("a whole {l} number such as {l}1"))
                    })?;
                    if l == 'G' {
                        let grp = g_group(code).map_err(here)?;
                        w.push_g(code, grp, word.span);
                    } else {
                        w.m.push((code, word.span));
                    }
                }
                'N' | 'O' => {
                    return Err(here(format!(
                        "address {} is only allowed at the start of a line",
                        word.letter
                    )));
                }
                'r' | 'c' => {
                    if w.corner.is_some() {
                        return Err(here("a block takes one corner word, `,R` or `,C`".into()));
                    }
                    let a = Arg {
                        v,
                        span: word.span,
                        has_point,
                    };
                    w.corner = Some((word.letter.to_ascii_uppercase(), a));
                }
                '$' => {
                    if w.dollar.is_some() {
                        return Err(here("a block takes one spindle selection `$`".into()));
                    }
                    w.dollar = Some(Arg {
                        v,
                        span: word.span,
                        has_point,
                    });
                }
                c if c.is_ascii_uppercase() => {
                    let i = (c as u8 - b'A') as usize;
                    if let Some(prev) = w.args[i] {
                        let (l, c0) = src.line_col(prev.span.start as usize);
                        return Err(here(format!(
                            "address {c} given twice in one block (first at {l}:{c0})"
                        )));
                    }
                    w.args[i] = Some(Arg {
                        v,
                        span: word.span,
                        has_point,
                    });
                    w.given |= 1 << i;
                }
                c => return Err(here(format!("address {c:?} is not an address letter"))),
            }
        }
        Ok(())
    }

    /// The value of `letter`, marking it used.
    pub fn take(&mut self, letter: char) -> Option<Arg> {
        let i = (letter as u8).wrapping_sub(b'A') as usize;
        let a = *self.args.get(i)?;
        if a.is_some() {
            self.used |= 1 << i;
        }
        a
    }

    /// The value of `letter` without marking it used.
    pub fn peek(&self, letter: char) -> Option<Arg> {
        let i = (letter as u8).wrapping_sub(b'A') as usize;
        *self.args.get(i)?
    }

    pub fn has(&self, letter: char) -> bool {
        self.peek(letter).is_some()
    }

    /// Marks `letter` used without reading it (a word whose meaning is "ignored, as Fanuc").
    pub fn consume(&mut self, letter: char) {
        let _ = self.take(letter);
    }

    /// Gives `letter` the value `a` (a word the interpreter adds: the `P` of an M code that
    /// calls a program); `false` if the block has that letter already.
    pub fn put(&mut self, letter: char, a: Arg) -> bool {
        let i = (letter as u8).wrapping_sub(b'A') as usize;
        match self.args.get_mut(i) {
            Some(slot @ None) => {
                *slot = Some(a);
                self.given |= 1 << i;
                true
            }
            _ => false,
        }
    }

    /// The first (in source order) address that was given but not used.
    pub fn first_unused(&self) -> Option<(char, Arg)> {
        let unused = self.given & !self.used;
        if unused == 0 {
            // Every block that runs ends here: most have used all their words.
            return None;
        }
        (0..26)
            .filter(|i| unused & (1 << i) != 0)
            .filter_map(|i| self.args[i].map(|a| ((b'A' + i as u8) as char, a)))
            .min_by_key(|(_, a)| a.span.start)
    }

    /// The block's G codes in source order, with their group.
    pub fn g(&self) -> &[(u32, GGroup, Span)] {
        &self.g
    }

    /// Adds G code `code` of `group` at `span` to the block's G codes.
    pub fn push_g(&mut self, code: u32, group: GGroup, span: Span) {
        self.g.push((code, group, span));
        self.groups |= group.bit();
    }

    /// The G code of `group` in this block, if any (the caller has checked there is at most one).
    pub fn g_of(&self, group: GGroup) -> Option<(u32, Span)> {
        if self.groups & group.bit() == 0 {
            return None;
        }
        self.g
            .iter()
            .find(|(_, g, _)| *g == group)
            .map(|&(c, _, s)| (c, s))
    }
}

/// `v` as a G code with one decimal (`90.1`), if it is one (and not whole): see [`DECIMAL_G`].
fn decimal_g_code(v: f64) -> Option<u32> {
    let tenths = v * 10.0;
    let rounded = tenths.round();
    if v.fract() == 0.0 || !(0.0..=99_999.0).contains(&rounded) || (tenths - rounded).abs() > 1e-6 {
        return None;
    }
    let t = rounded as u32;
    Some(g_dec(t / 10, t % 10))
}

/// `v` as a whole code number, if it is one.
fn whole_code(v: f64) -> Option<u32> {
    if (0.0..=9999.0).contains(&v) && v.fract() == 0.0 {
        Some(v as u32)
    } else {
        None
    }
}

/// A number for a message or the segment dump: rounded to 1e-6, shortest decimal form, no
/// trailing zeros, `-0` as `0` (`10`, `-2.5`, `0.333333`). Numbers of 1e15 and more are not
/// rounded (scaling them by 1e6 could overflow to `inf`): they print in full. Non-finite
/// values print as Rust does (`NaN`, `inf`); none reaches a segment (see `dump::num`).
///
/// ```
/// use cnc402_interp::words::fmt_num;
/// assert_eq!(fmt_num(-2.50000004), "-2.5");
/// assert_eq!(fmt_num(-0.0000001), "0");
/// assert_eq!(fmt_num(f64::NAN), "NaN");
/// assert_eq!(fmt_num(f64::MAX), format!("{}", f64::MAX));
/// ```
pub fn fmt_num(v: f64) -> String {
    if v.is_nan() || v.abs() >= 1e15 {
        return format!("{v}");
    }
    let r = (v * 1e6).round() / 1e6;
    if r == 0.0 { "0".into() } else { format!("{r}") }
}

#[cfg(test)]
mod tests {
    use super::*;
    use cnc402_lang::ast::LineKind;

    fn words(t: &str) -> Result<Words, NcError> {
        let src = SourceFile::new("w", t);
        let p = cnc402_lang::parse(&src).expect("parses");
        match &p.lines[0].kind {
            LineKind::Block(b) => Words::collect(&src, b),
            k => panic!("not a block: {k:?}"),
        }
    }

    /// Every group of the block is found by `g_of` as a search of the codes finds it, also
    /// a group added after collecting and after the words are collected again (the group
    /// set is a filter in front of the search: a bit not set or not cleared shows here).
    #[test]
    fn group_set_answers_as_searching_the_codes() {
        use GGroup::*;
        let all = [
            NonModal,
            Motion,
            Plane,
            Distance,
            ArcDistance,
            FeedMode,
            Units,
            Cycle,
            ReturnMode,
            ToolLength,
            WorkOffset,
            PathMode,
            ExactStopOnce,
            CutterComp,
            MacroCall,
            Cancel(11),
            Cancel(16),
            Cancel(17),
        ];
        let search =
            |w: &Words, grp: GGroup| w.g().iter().find(|g| g.1 == grp).map(|&(c, _, s)| (c, s));
        let blocks = [
            "G0 G90 X1",
            "G17 G21 G40 G49 G54 G64 G80 G94 G98 G91.1",
            "G4 P1",
            "G50 G69 G15 G9 G43 H1",
            "G18 G20 G61 G95 G99 G83 Z-1 R1 Q1",
            "X1",
        ];
        let mut w = words(blocks[0]).unwrap();
        for t in blocks {
            let s2 = SourceFile::new("w", t);
            let p = cnc402_lang::parse(&s2).expect("parses");
            let LineKind::Block(b) = &p.lines[0].kind else {
                panic!("not a block")
            };
            w.collect_again(&s2, b, &mut eval::NoVars).unwrap();
            for grp in all {
                assert_eq!(w.g_of(grp), search(&w, grp), "{t}: {grp:?}");
            }
            w.push_g(65, MacroCall, Span::default());
            assert_eq!(w.g_of(MacroCall), search(&w, MacroCall), "{t} + G65");
        }
    }

    #[test]
    fn sorts_codes_and_marks_use() {
        let mut w = words("G0 G90 X1 Y[2*3] M3 S100").unwrap();
        assert_eq!(w.g.len(), 2);
        assert_eq!(w.g_of(GGroup::Distance).map(|g| g.0), Some(90));
        assert_eq!(w.m[0].0, 3);
        assert_eq!(w.take('Y').unwrap().v, 6.0);
        assert_eq!(w.first_unused().unwrap().0, 'X');
        w.consume('X');
        w.consume('S');
        assert!(w.first_unused().is_none());
        // A word the interpreter adds counts as given until it is used.
        let p = Arg {
            v: 1.0,
            span: Span::default(),
            has_point: false,
        };
        assert!(w.put('P', p));
        assert_eq!(w.first_unused().map(|(c, _)| c), Some('P'));
        w.consume('P');
        assert!(w.first_unused().is_none());
    }

    #[test]
    fn offset_reference_and_path_mode_codes_have_their_groups() {
        for c in [4, 10, 28, 29, 30, 53, 92] {
            assert_eq!(g_group(c), Ok(GGroup::NonModal), "G{c}");
        }
        for c in [43, 44, 49] {
            assert_eq!(g_group(c), Ok(GGroup::ToolLength), "G{c}");
        }
        for c in [61, 63, 64] {
            assert_eq!(g_group(c), Ok(GGroup::PathMode), "G{c}");
        }
        for c in [11, 27, 62] {
            assert!(g_group(c).unwrap_err().contains("not supported"), "G{c}");
        }
    }

    #[test]
    fn rejects_fractional_codes_duplicates_and_unknown_g() {
        let e = words("G1.25 X1").unwrap_err();
        assert!(e.message.contains("G1.25 is not a G code"), "{e}");
        // One decimal names a code of its own (G90.1), known or not.
        let e = words("G1.5 X1").unwrap_err();
        assert_eq!((e.col, e.message.as_str()), (1, "unknown G code G1.5"));
        let e = words("G43.1 X1").unwrap_err();
        assert!(
            e.message.contains("G43.1 (dynamic tool length offset)"),
            "{e}"
        );
        // G5.1 (Fanuc's AI contour control) is a path-mode switch, like G08.
        let w = words("G5.1 Q1").unwrap();
        assert_eq!(w.g_of(GGroup::PathMode).map(|g| g.0), Some(g_dec(5, 1)));
        let w = words("G90.1 X1").unwrap();
        assert_eq!(w.g_of(GGroup::ArcDistance).map(|g| g.0), Some(g_dec(90, 1)));
        let e = words("G[92+0.1]").unwrap_err();
        assert!(e.message.starts_with("G92.1 "), "{e}");
        let e = words("M3.5").unwrap_err();
        assert!(e.message.contains("M3.5 is not a M code"), "{e}");
        let e = words("G1 X1 X2").unwrap_err();
        assert_eq!(
            (e.col, e.message.as_str()),
            (7, "address X given twice in one block (first at 1:4)")
        );
        assert!(
            words("G7")
                .unwrap_err()
                .message
                .contains("unknown G code G7")
        );
        assert!(
            words("G27 X1")
                .unwrap_err()
                .message
                .contains("not supported yet")
        );
        assert!(words("G41 D1").is_ok(), "G41 is cutter compensation now");
    }
}
