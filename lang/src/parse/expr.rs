//! The Fanuc expression grammar, loosest binding first:
//! `cmp := add ((EQ|NE|GT|GE|LT|LE) add)*`, `add := mul ((+|-|OR|XOR) mul)*`,
//! `mul := unary ((*|/|AND|MOD) unary)*`, `unary := (-|+) unary | primary`,
//! `primary := number | #n | #[cmp] | [cmp] | FUNC[cmp] | ATAN[cmp]/[cmp] | ATAN[cmp,cmp]
//! | POW[cmp,cmp]`.
//! Keywords are case-insensitive and need no surrounding spaces (`#1OR#2`).

use super::lex::{char_len, starts_with_kw, ws};
use super::{Cx, PResult, fail, fail_exp};
use crate::ast::{BinaryOp, Expr, ExprKind, Func, UnaryOp};

/// Deepest nesting of brackets, unary signs and calls; deeper input is an error, not a stack
/// overflow. (Fanuc allows five levels of brackets.)
pub(crate) const MAX_DEPTH: u32 = 32;

/// Most operators on any path from an expression's root to an operand (`1+1+…+1` with
/// `MAX_HEIGHT + 1` terms is an error). Everything that walks an expression — evaluation,
/// the C-like compiler and executor, `Drop` — recurses once per level, so this bound, not
/// the length of the line, is what their stacks must hold (`interp/tests/expr_stack.rs`
/// runs the deepest expressions on the smallest stack the product gives them).
pub const MAX_HEIGHT: u32 = 64;

/// Operator levels below `e`'s root (an operand is 0). The recursion is bounded: every
/// expression the parser returns is at most [`MAX_HEIGHT`] (plus its brackets) high.
pub(crate) fn height(e: &Expr) -> u32 {
    let sub = |x: &Expr| height(x) + 1;
    match &e.kind {
        ExprKind::Unary(_, a) | ExprKind::IndirectVar(a) | ExprKind::Not(a) => sub(a),
        ExprKind::Field(a, _) => sub(a),
        ExprKind::Binary(_, a, b) | ExprKind::Logical(_, a, b) | ExprKind::Index(a, b) => {
            sub(a).max(sub(b))
        }
        ExprKind::Call(_, args) | ExprKind::CallNamed(_, args) => {
            args.iter().map(sub).max().unwrap_or(0)
        }
        _ => 0,
    }
}

/// Sets `lhs_height` (`lhs`'s height, if known) to the height of a node joining `lhs` to an
/// operand `rhs_height` high, or gives the error at `at` (the operator) when it would pass
/// [`MAX_HEIGHT`]. Chains are folded in loops, so this check is what bounds them.
pub(crate) fn join_height<'a>(
    at: &'a str,
    lhs_height: &mut Option<u32>,
    lhs: &Expr,
    rhs_height: u32,
) -> Result<(), nom::Err<super::PErr<'a>>> {
    let h = lhs_height.unwrap_or_else(|| height(lhs)).max(rhs_height) + 1;
    if h > MAX_HEIGHT {
        return fail::<()>(
            at,
            char_len(at),
            format!("expression nested too deeply (more than {MAX_HEIGHT} levels of operators)"),
        )
        .map(|_| ());
    }
    *lhs_height = Some(h);
    Ok(())
}

pub(crate) const CMP_OPS: [(&str, BinaryOp); 6] = [
    ("EQ", BinaryOp::Eq),
    ("NE", BinaryOp::Ne),
    ("GT", BinaryOp::Gt),
    ("GE", BinaryOp::Ge),
    ("LT", BinaryOp::Lt),
    ("LE", BinaryOp::Le),
];
pub(crate) const ADD_OPS: [(&str, BinaryOp); 4] = [
    ("+", BinaryOp::Add),
    ("-", BinaryOp::Sub),
    ("OR", BinaryOp::Or),
    ("XOR", BinaryOp::Xor),
];
const MUL_OPS: [(&str, BinaryOp); 4] = [
    ("*", BinaryOp::Mul),
    ("/", BinaryOp::Div),
    ("AND", BinaryOp::And),
    ("MOD", BinaryOp::Mod),
];

/// Function names as written in programs.
pub(crate) const FUNCS: [(&str, Func); 16] = [
    ("SIN", Func::Sin),
    ("COS", Func::Cos),
    ("TAN", Func::Tan),
    ("ASIN", Func::Asin),
    ("ACOS", Func::Acos),
    ("ATAN", Func::Atan),
    ("SQRT", Func::Sqrt),
    ("ABS", Func::Abs),
    ("ROUND", Func::Round),
    ("FIX", Func::Fix),
    ("FUP", Func::Fup),
    ("LN", Func::Ln),
    ("EXP", Func::Exp),
    ("POW", Func::Pow),
    ("BIN", Func::Bin),
    ("BCD", Func::Bcd),
];

pub(crate) fn match_op(i: &str, ops: &[(&'static str, BinaryOp)]) -> Option<(usize, BinaryOp)> {
    ops.iter()
        .find(|(kw, _)| starts_with_kw(i, kw))
        .map(|&(kw, op)| (kw.len(), op))
}

impl<'a> Cx<'a> {
    /// A whole expression (comparison level), leading whitespace allowed.
    pub(crate) fn expr(&self, i: &'a str, depth: u32) -> PResult<'a, Expr> {
        if self.dialect == crate::dialect::Dialect::LinuxCnc {
            return self.lc_expr(i, depth);
        }
        self.binary_level(i, depth, 0)
    }

    /// One precedence level (0 = comparisons, 1 = additive, 2 = multiplicative), folding
    /// left-associatively.
    fn binary_level(&self, i: &'a str, depth: u32, level: u8) -> PResult<'a, Expr> {
        let ops: &[(&'static str, BinaryOp)] = match level {
            0 => &CMP_OPS,
            1 => &ADD_OPS,
            _ => &MUL_OPS,
        };
        let operand = |i: &'a str| {
            if level < 2 {
                self.binary_level(i, depth, level + 1)
            } else {
                self.unary(i, depth)
            }
        };
        let (mut i, mut lhs) = operand(i)?;
        let mut lhs_height = None;
        loop {
            let j = ws(i);
            let Some((len, op)) = match_op(j, ops) else {
                return Ok((i, lhs));
            };
            let after = &j[len..];
            let (rest, rhs) = match operand(after) {
                Err(nom::Err::Error(_)) => {
                    let at = ws(after);
                    return fail_exp(
                        at,
                        char_len(at),
                        format!("missing operand after `{}`", &j[..len]),
                        "an expression",
                    );
                }
                r => r?,
            };
            join_height(j, &mut lhs_height, &lhs, height(&rhs))?;
            let span = lhs.span.join(rhs.span);
            lhs = Expr {
                kind: ExprKind::Binary(op, Box::new(lhs), Box::new(rhs)),
                span,
            };
            i = rest;
        }
    }

    /// `-x`, `+x`, or a primary.
    pub(crate) fn unary(&self, i: &'a str, depth: u32) -> PResult<'a, Expr> {
        let i = ws(i);
        let op = match i.as_bytes().first() {
            Some(b'-') => UnaryOp::Neg,
            Some(b'+') => UnaryOp::Plus,
            _ => return self.primary(i, depth),
        };
        if depth >= MAX_DEPTH {
            return self.too_deep(i);
        }
        let after = &i[1..];
        let (rest, e) = match self.unary(after, depth + 1) {
            Err(nom::Err::Error(_)) => {
                let at = ws(after);
                return fail_exp(
                    at,
                    char_len(at),
                    format!("missing operand after `{}`", &i[..1]),
                    "an expression",
                );
            }
            r => r?,
        };
        let span = self.span_at(i, 0).join(e.span);
        Ok((
            rest,
            Expr {
                kind: ExprKind::Unary(op, Box::new(e)),
                span,
            },
        ))
    }

    fn too_deep<T>(&self, i: &'a str) -> PResult<'a, T> {
        fail(
            i,
            char_len(i),
            format!("expression nested too deeply (more than {MAX_DEPTH} levels)"),
        )
    }

    /// A number, a bracketed expression or a function call. A recoverable error when `i`
    /// starts none of them, so callers can say what they expected.
    pub(crate) fn primary(&self, i: &'a str, depth: u32) -> PResult<'a, Expr> {
        let i = ws(i);
        match i.as_bytes().first() {
            Some(b'[') => {
                if depth >= MAX_DEPTH {
                    return self.too_deep(i);
                }
                let (rest, mut e) = self.bracketed(i, depth + 1)?;
                e.span = self.span(i, rest);
                Ok((rest, e))
            }
            Some(c) if c.is_ascii_digit() || *c == b'.' => {
                let (rest, (v, _)) = self.unsigned(i)?;
                Ok((
                    rest,
                    Expr {
                        kind: ExprKind::Number(v),
                        span: self.span(i, rest),
                    },
                ))
            }
            Some(c) if c.is_ascii_alphabetic() => self.call(i, depth),
            Some(b'#') => self.var(i, depth),
            _ => Err(nom::Err::Error(nom::error::ParseError::from_error_kind(
                i,
                nom::error::ErrorKind::Alt,
            ))),
        }
    }

    /// A macro variable at `i` (which starts with `#`): `#100` or `#[expr]`; whitespace may
    /// follow the `#`.
    pub(crate) fn var(&self, i: &'a str, depth: u32) -> PResult<'a, Expr> {
        let after = ws(&i[1..]);
        match after.as_bytes().first() {
            Some(b'<') if self.dialect == crate::dialect::Dialect::LinuxCnc => self.named_param(i),
            Some(b'0'..=b'9') => {
                let (rest, n) = self.whole(after, "variable number")?;
                Ok((
                    rest,
                    Expr {
                        kind: ExprKind::Var(n),
                        span: self.span(i, rest),
                    },
                ))
            }
            Some(b'[') => {
                if depth >= MAX_DEPTH {
                    return self.too_deep(after);
                }
                let (rest, e) = self.bracketed(after, depth + 1)?;
                Ok((
                    rest,
                    Expr {
                        kind: ExprKind::IndirectVar(Box::new(e)),
                        span: self.span(i, rest),
                    },
                ))
            }
            _ => fail_exp(
                i,
                1,
                "missing variable number after `#`",
                "a variable number or `[expression]` after #",
            ),
        }
    }

    /// `[ expr ]` at `i` (which starts with `[`); returns the inner expression.
    pub(crate) fn bracketed(&self, i: &'a str, depth: u32) -> PResult<'a, Expr> {
        let open = i;
        let inner = &i[1..];
        let (rest, e) = match self.expr(inner, depth) {
            Err(nom::Err::Error(_)) => {
                let at = ws(inner);
                if at.starts_with(']') {
                    return fail_exp(at, 1, "empty brackets", "an expression");
                }
                return self.expected_expr(at);
            }
            r => r?,
        };
        let rest = ws(rest);
        match rest.as_bytes().first() {
            Some(b']') => Ok((&rest[1..], e)),
            None => fail_exp(
                open,
                1,
                "unbalanced bracket: `[` is not closed",
                "`]` before the end of the line",
            ),
            Some(_) => fail_exp(
                rest,
                char_len(rest),
                "unexpected text in expression",
                "an operator or `]`",
            ),
        }
    }

    /// The error for "an expression was expected here".
    pub(crate) fn expected_expr<T>(&self, at: &'a str) -> PResult<'a, T> {
        match at.chars().next() {
            None => fail_exp(at, 0, "missing expression", "an expression"),
            Some(']') => fail_exp(
                at,
                1,
                "unbalanced bracket: `]` without `[`",
                "an expression",
            ),
            Some('(') => fail_exp(
                at,
                1,
                "`(` starts a comment, not a group; group with `[ ]`",
                "an expression",
            ),
            Some(c) if c.is_ascii_alphabetic() => {
                let n = at.bytes().take_while(u8::is_ascii_alphabetic).count();
                fail_exp(
                    at,
                    n,
                    format!("unexpected `{}` in expression", &at[..n]),
                    "an expression",
                )
            }
            Some(c) => fail_exp(
                at,
                c.len_utf8(),
                format!("unexpected `{c}` in expression"),
                "an expression",
            ),
        }
    }

    /// `NAME[e]`, `ATAN[e]/[e]`, `ATAN[e,e]`, `POW[e,e]`; `i` starts with a letter.
    fn call(&self, i: &'a str, depth: u32) -> PResult<'a, Expr> {
        let name_len = i.bytes().take_while(u8::is_ascii_alphabetic).count();
        if self.dialect == crate::dialect::Dialect::LinuxCnc
            && i[..name_len].eq_ignore_ascii_case("EXISTS")
        {
            return self.exists(i, name_len);
        }
        let Some(&(kw, func)) = FUNCS
            .iter()
            .filter(|(kw, _)| starts_with_kw(i, kw))
            .max_by_key(|(kw, _)| kw.len())
        else {
            // A name used like a function is an unknown function; any other letters are
            // not an operand at all (e.g. the next word after `F=100`): let the caller say.
            if ws(&i[name_len..]).starts_with('[') {
                return fail_exp(
                    i,
                    name_len,
                    format!("unknown function `{}`", &i[..name_len]),
                    "a function name: SIN COS TAN ASIN ACOS ATAN SQRT ABS ROUND FIX FUP LN EXP POW BIN BCD",
                );
            }
            return Err(nom::Err::Error(nom::error::ParseError::from_error_kind(
                i,
                nom::error::ErrorKind::Alpha,
            )));
        };
        if depth >= MAX_DEPTH {
            return self.too_deep(i);
        }
        let after = ws(&i[kw.len()..]);
        if !after.starts_with('[') {
            return fail_exp(
                after,
                char_len(after),
                format!("missing `[` after function {kw}"),
                format!("`[` after {kw}"),
            );
        }
        let (mut rest, args) = self.call_args(after, depth + 1, kw)?;
        let mut args = args;
        if func == Func::Atan && args.len() == 1 {
            // Fanuc's two-argument form `ATAN[a]/[b]`.
            let j = ws(rest);
            if let Some(k) = j.strip_prefix('/') {
                let k = ws(k);
                if k.starts_with('[') {
                    let (r, b) = self.bracketed(k, depth + 1)?;
                    args.push(b);
                    rest = r;
                }
            }
        }
        let want = match func {
            Func::Pow => 2..=2,
            Func::Atan => 1..=2,
            _ => 1..=1,
        };
        if !want.contains(&args.len()) {
            let n = *want.start();
            return fail(
                i,
                self.off(rest) - self.off(i),
                format!(
                    "{kw} takes {n} argument{}, found {}",
                    if n == 1 { "" } else { "s" },
                    args.len()
                ),
            );
        }
        Ok((
            rest,
            Expr {
                kind: ExprKind::Call(func, args),
                span: self.span(i, rest),
            },
        ))
    }

    /// `[e]` or `[e, e]` after a function name.
    fn call_args(&self, open: &'a str, depth: u32, kw: &str) -> PResult<'a, Vec<Expr>> {
        let mut args = Vec::with_capacity(1);
        let mut i = &open[1..];
        loop {
            let (rest, e) = match self.expr(i, depth) {
                Err(nom::Err::Error(_)) => {
                    let at = ws(i);
                    if at.starts_with(']') && args.is_empty() {
                        return fail_exp(
                            at,
                            1,
                            format!("missing argument of {kw}"),
                            "an expression",
                        );
                    }
                    return self.expected_expr(at);
                }
                r => r?,
            };
            args.push(e);
            let rest = ws(rest);
            match rest.as_bytes().first() {
                Some(b']') => return Ok((&rest[1..], args)),
                Some(b',') => i = &rest[1..],
                None => {
                    return fail_exp(
                        open,
                        1,
                        "unbalanced bracket: `[` is not closed",
                        "`]` before the end of the line",
                    );
                }
                Some(_) => {
                    return fail_exp(
                        rest,
                        char_len(rest),
                        "unexpected text in expression",
                        "an operator, `,` or `]`",
                    );
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Renders an expression fully bracketed, to check precedence and associativity.
    fn show(e: &Expr) -> String {
        match &e.kind {
            ExprKind::Number(v) => format!("{v}"),
            ExprKind::Unary(UnaryOp::Neg, a) => format!("-{}", show(a)),
            ExprKind::Unary(UnaryOp::Plus, a) => format!("+{}", show(a)),
            ExprKind::Binary(op, a, b) => format!("({} {op:?} {})", show(a), show(b)),
            ExprKind::Call(f, args) => {
                let a: Vec<String> = args.iter().map(show).collect();
                format!("{f:?}({})", a.join(","))
            }
            ExprKind::Var(n) => format!("#{n}"),
            ExprKind::IndirectVar(e) => format!("#[{}]", show(e)),
            other => format!("{other:?}"),
        }
    }

    fn p(s: &str) -> String {
        let cx = Cx::new(s);
        match cx.expr(s, 0) {
            Ok((rest, e)) => {
                assert_eq!(rest.trim(), "", "unparsed rest in {s:?}");
                show(&e)
            }
            Err(nom::Err::Failure(e) | nom::Err::Error(e)) => format!("ERR {}", e.msg),
            Err(nom::Err::Incomplete(_)) => "INCOMPLETE".into(),
        }
    }

    #[test]
    fn fanuc_precedence() {
        assert_eq!(p("1+2*3"), "(1 Add (2 Mul 3))");
        assert_eq!(p("1-2-3"), "((1 Sub 2) Sub 3)");
        assert_eq!(p("8/4/2"), "((8 Div 4) Div 2)");
        assert_eq!(p("1 OR 2 AND 3"), "(1 Or (2 And 3))");
        assert_eq!(p("1 XOR 2 MOD 3"), "(1 Xor (2 Mod 3))");
        assert_eq!(p("1+2 EQ 3"), "((1 Add 2) Eq 3)");
        assert_eq!(p("1 OR 2 NE 3"), "((1 Or 2) Ne 3)");
        assert_eq!(p("[1+2]*3"), "((1 Add 2) Mul 3)");
        assert_eq!(p("-2*3"), "(-2 Mul 3)");
        assert_eq!(p("2*-3"), "(2 Mul -3)");
        assert_eq!(p("--1"), "--1");
        assert_eq!(p("+.5"), "+0.5");
    }

    #[test]
    fn comparison_operators_and_case() {
        for (kw, op) in CMP_OPS {
            assert_eq!(p(&format!("1 {kw} 2")), format!("(1 {op:?} 2)"));
            assert_eq!(
                p(&format!("1{}2", kw.to_lowercase())),
                format!("(1 {op:?} 2)")
            );
        }
    }

    #[test]
    fn functions() {
        for (kw, f) in FUNCS {
            if f == Func::Pow {
                continue;
            }
            assert_eq!(p(&format!("{kw}[1]")), format!("{f:?}(1)"));
            assert_eq!(
                p(&format!("{} [ 1 ]", kw.to_lowercase())),
                format!("{f:?}(1)")
            );
        }
        assert_eq!(p("ATAN[1]/[2]"), "Atan(1,2)");
        assert_eq!(p("ATAN[1] / [2]"), "Atan(1,2)");
        assert_eq!(p("ATAN[1,2]"), "Atan(1,2)");
        assert_eq!(p("POW[2,3]"), "Pow(2,3)");
        assert_eq!(p("SIN[30]/2"), "(Sin(30) Div 2)");
        assert_eq!(p("FUP[SQRT[4]+1]"), "Fup((Sqrt(4) Add 1))");
    }

    #[test]
    fn variables() {
        assert_eq!(p("#1+#2*#3"), "(#1 Add (#2 Mul #3))");
        assert_eq!(p("[#113 OR#114]NE 1"), "((#113 Or #114) Ne 1)");
        assert_eq!(p("# 100"), "#100");
        assert_eq!(p("#[#1+2]"), "#[(#1 Add 2)]");
        assert_eq!(p("#[#[1]]"), "#[#[1]]");
        assert_eq!(p("-#0"), "-#0");
        assert_eq!(p("FUP[#100]"), "Fup(#100)");
        assert_eq!(p("#"), "ERR missing variable number after `#`");
        assert_eq!(p("#1.5"), "ERR a variable number must be a whole number");
        assert_eq!(p("#-1"), "ERR missing variable number after `#`");
        assert_eq!(p("#[1"), "ERR unbalanced bracket: `[` is not closed");
    }

    #[test]
    fn errors() {
        assert_eq!(p("1+"), "ERR missing operand after `+`");
        assert_eq!(p("[1+2"), "ERR unbalanced bracket: `[` is not closed");
        assert_eq!(p("[]"), "ERR empty brackets");
        assert_eq!(p("FOO[1]"), "ERR unknown function `FOO`");
        assert_eq!(p("SIN 1"), "ERR missing `[` after function SIN");
        assert_eq!(p("POW[1]"), "ERR POW takes 2 arguments, found 1");
        assert_eq!(p("SIN[1,2]"), "ERR SIN takes 1 argument, found 2");
        assert_eq!(p("[1 2]"), "ERR unexpected text in expression");
        assert_eq!(p("SIN[]"), "ERR missing argument of SIN");
        let deep = format!("{}1{}", "[".repeat(100), "]".repeat(100));
        assert!(p(&deep).starts_with("ERR expression nested too deeply"));
        let neg = format!("{}1", "-".repeat(100));
        assert!(p(&neg).starts_with("ERR expression nested too deeply"));
    }

    #[test]
    fn spans_cover_brackets_and_operands() {
        let s = "[1 + 2]*SIN[3]";
        let cx = Cx::new(s);
        let (_, e) = cx.expr(s, 0).unwrap();
        assert_eq!(e.span.range(), 0..s.len());
        let ExprKind::Binary(_, a, b) = &e.kind else {
            panic!()
        };
        assert_eq!(a.span.range(), 0..7);
        assert_eq!(b.span.range(), 8..14);
    }
}
