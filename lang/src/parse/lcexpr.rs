//! LinuxCNC's expression grammar (the `linuxcnc` dialect): its precedence, lowest first,
//! `AND OR XOR` (logical: 1 when …), comparisons, `+ -`, `* / MOD`, `**`. Fanuc's grammar
//! puts `OR XOR` with `+` and `AND` with `*`, bitwise. The tree uses Fanuc's nodes: a
//! logical operator compares its operands with 0 first, `MOD` is made non-negative as
//! LinuxCNC's, `**` is `POW`.

use super::expr::{ADD_OPS, CMP_OPS, MAX_HEIGHT, height, join_height, match_op};
use super::lex::{char_len, ws};
use super::{Cx, PResult, fail};
use crate::ast::{BinaryOp, Expr, ExprKind, Func};

const LOGIC_OPS: [(&str, BinaryOp); 3] = [
    ("AND", BinaryOp::And),
    ("OR", BinaryOp::Or),
    ("XOR", BinaryOp::Xor),
];
const MUL_OPS: [(&str, BinaryOp); 3] = [
    ("*", BinaryOp::Mul),
    ("/", BinaryOp::Div),
    ("MOD", BinaryOp::Mod),
];
/// `**` (its `BinaryOp` is not used: it becomes `POW`).
const POW_OPS: [(&str, BinaryOp); 1] = [("**", BinaryOp::Mul)];

fn node(kind: ExprKind, a: &Expr, b: &Expr) -> Expr {
    Expr {
        kind,
        span: a.span.join(b.span),
    }
}

fn bin(op: BinaryOp, a: Expr, b: Expr) -> Expr {
    let span = a.span.join(b.span);
    Expr {
        kind: ExprKind::Binary(op, Box::new(a), Box::new(b)),
        span,
    }
}

/// `x NE 0`.
fn truth(x: Expr) -> Expr {
    let zero = Expr {
        kind: ExprKind::Number(0.0),
        span: x.span,
    };
    bin(BinaryOp::Ne, x, zero)
}

/// The node for `a op b` at `level` (0 logical … 4 power).
fn join(level: u8, op: BinaryOp, a: Expr, b: Expr) -> Expr {
    match (level, op) {
        (0, _) => bin(op, truth(a), truth(b)),
        // LinuxCNC: a MOD b is in [0, |b|): (fmod(a, b) + |b|) fmod b.
        (_, BinaryOp::Mod) => {
            let abs_b = node(ExprKind::Call(Func::Abs, vec![b.clone()]), &b, &b);
            let r = bin(BinaryOp::Mod, a, b.clone());
            bin(BinaryOp::Mod, bin(BinaryOp::Add, r, abs_b), b)
        }
        (4, _) => node(
            ExprKind::Call(Func::Pow, vec![a.clone(), b.clone()]),
            &a,
            &b,
        ),
        _ => bin(op, a, b),
    }
}

impl<'a> Cx<'a> {
    /// `EXISTS[#<name>]` at `i` (`name_len` bytes of `EXISTS`): 1 when the named parameter
    /// is defined. As [`ExprKind::CallNamed`] `EXISTS` with the [`ExprKind::Named`].
    pub(crate) fn exists(&self, i: &'a str, name_len: usize) -> PResult<'a, Expr> {
        let open = ws(&i[name_len..]);
        let inner = open.strip_prefix('[').map(ws);
        let Some(inner) = inner.filter(|r| r.starts_with('#')) else {
            return fail(
                open,
                char_len(open),
                "EXISTS takes a named parameter: EXISTS[#<name>]",
            );
        };
        let (r, named) = self.named_param(inner)?;
        let r = ws(r);
        let Some(rest) = r.strip_prefix(']') else {
            return fail(r, char_len(r), "missing `]` after EXISTS[#<name>");
        };
        Ok((
            rest,
            Expr {
                kind: ExprKind::CallNamed("EXISTS".into(), vec![named]),
                span: self.span(i, rest),
            },
        ))
    }

    /// A whole expression in LinuxCNC's grammar.
    pub(crate) fn lc_expr(&self, i: &'a str, depth: u32) -> PResult<'a, Expr> {
        self.lc_level(i, depth, 0)
    }

    fn lc_level(&self, i: &'a str, depth: u32, level: u8) -> PResult<'a, Expr> {
        let ops: &[(&'static str, BinaryOp)] = match level {
            0 => &LOGIC_OPS,
            1 => &CMP_OPS,
            2 => &ADD_OPS[..2],
            3 => &MUL_OPS,
            _ => &POW_OPS,
        };
        let operand = |i: &'a str| {
            if level < 4 {
                self.lc_level(i, depth, level + 1)
            } else {
                self.unary(i, depth)
            }
        };
        let (mut i, mut lhs) = operand(i)?;
        let mut lhs_height = None;
        loop {
            let j = ws(i);
            // `**` is not two `*`.
            if level == 3 && j.starts_with("**") {
                return Ok((i, lhs));
            }
            let Some((len, op)) = match_op(j, ops) else {
                return Ok((i, lhs));
            };
            let after = &j[len..];
            let (rest, rhs) = match operand(after) {
                Err(nom::Err::Error(_)) => {
                    let at = ws(after);
                    return fail(
                        at,
                        char_len(at),
                        format!("missing operand after `{}`", &j[..len]),
                    );
                }
                r => r?,
            };
            join_height(j, &mut lhs_height, &lhs, height(&rhs))?;
            lhs = join(level, op, lhs, rhs);
            // The composed nodes are deeper than the operators written: bound those too.
            let h = height(&lhs);
            if h > MAX_HEIGHT {
                return fail(
                    j,
                    len,
                    format!(
                        "expression nested too deeply (more than {MAX_HEIGHT} levels of operators)"
                    ),
                );
            }
            lhs_height = Some(h);
            i = rest;
        }
    }
}
