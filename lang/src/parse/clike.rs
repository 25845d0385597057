//! The C-like statement language (source 000, AxiOMA Control style) mixed with G-code lines.
//! Statements may span lines and hold G-code lines; expressions use C precedence. Which
//! lines are statements is decided by [`classify`] from the start of the line.

use super::expr::{FUNCS, MAX_DEPTH, height, join_height};
use super::lex::{char_len, starts_with_kw};
use super::{Cx, PResult, fail, fail_exp};
use crate::ast::{
    AssignOp, BinaryOp, Declarator, Expr, ExprKind, Function, LogicalOp, Param, Stmt, StmtKind,
    Type, UnaryOp,
};

/// What a line (or a statement position) holds, judged from its first characters.
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum Class {
    Gcode,
    Statement,
    /// Reads both ways; the message says why and how to write it unambiguously.
    Ambiguous(&'static str),
}

const KEYWORDS: [&str; 14] = [
    "if", "else", "while", "for", "return", "break", "continue", "int", "double", "string", "bool",
    "void", "true", "false",
];

fn is_ident_start(b: u8) -> bool {
    b.is_ascii_alphabetic() || b == b'_'
}
fn is_ident_char(b: u8) -> bool {
    b.is_ascii_alphanumeric() || b == b'_'
}
fn ident_len(i: &str) -> usize {
    match i.as_bytes().first() {
        Some(&b) if is_ident_start(b) => i.bytes().take_while(|&b| is_ident_char(b)).count(),
        _ => 0,
    }
}
fn hws(i: &str) -> &str {
    i.trim_start_matches([' ', '\t', '\r'])
}
/// `kw` as a whole word at the start of `i` (case-sensitive, as C keywords are).
fn word_is(i: &str, kw: &str) -> bool {
    i.starts_with(kw)
        && !i
            .as_bytes()
            .get(kw.len())
            .is_some_and(|&b| is_ident_char(b))
}

/// The rule that tells G-code from statements (documented on [`crate::parse`]), applied to
/// the text at the start of a line (after leading whitespace) or at the start of a statement
/// inside `{ }`.
pub(crate) fn classify(i: &str) -> Class {
    let b = i.as_bytes();
    let Some(&c0) = b.first() else {
        return Class::Gcode;
    };
    let c1 = b.get(1).copied().unwrap_or(0);
    match c0 {
        b'{' | b'}' | b'$' | b'@' | b'"' => Class::Statement,
        b'/' if c1 == b'/' || c1 == b'*' => Class::Statement,
        b'#' if word_is(&i[1..], "use") => Class::Statement,
        b'+' | b'-' if c1 == c0 => Class::Statement,
        _ if is_ident_start(c0) => {
            let n = ident_len(i);
            if c0 == b'_' || (n >= 2 && (c1.is_ascii_alphabetic() || c1 == b'_')) {
                let after = hws(&i[n..]);
                let digits_after = |k: usize| i[k..n].bytes().all(|b| b.is_ascii_digit());
                // Custom Macro B keywords and their two-letter abbreviations (WH, GO, EN).
                let fanuc = starts_with_kw(i, "GOTO")
                    || (starts_with_kw(i, "GO") && digits_after(2))
                    || ((n == 2 && (starts_with_kw(i, "IF") || starts_with_kw(i, "WH")))
                        || (n == 5 && starts_with_kw(i, "WHILE")))
                        && !after.starts_with('(')
                    || (starts_with_kw(i, "END") && digits_after(3))
                    || (starts_with_kw(i, "EN") && digits_after(2))
                    || (starts_with_kw(i, "DO") && i[2..n].bytes().all(|b| b.is_ascii_digit()))
                    || (starts_with_kw(i, "AXSTR") && n == 5 && after.starts_with('('));
                return if fanuc {
                    Class::Gcode
                } else {
                    Class::Statement
                };
            }
            if n >= 2 {
                // `x1 = 5;`, `x1++`: a name shaped like a word (letter, digits).
                let ab = hws(&i[n..]).as_bytes();
                let assign = (ab.first() == Some(&b'=') && ab.get(1) != Some(&b'='))
                    || (ab.len() >= 2
                        && matches!(ab[0], b'+' | b'-' | b'*' | b'/' | b'%')
                        && (ab[1] == b'=' || (ab[1] == ab[0] && matches!(ab[0], b'+' | b'-'))));
                if assign {
                    return Class::Ambiguous(
                        "ambiguous line: a name made of a letter and digits reads as a G-code \
                         word; start variable names with two letters",
                    );
                }
            }
            if n == 1 {
                let mut after = hws(&i[1..]);
                let mut indexed = false;
                if after.starts_with('[') {
                    let mut depth = 0;
                    let close = after.bytes().position(|b| {
                        match b {
                            b'[' => depth += 1,
                            b']' => depth -= 1,
                            _ => {}
                        }
                        depth == 0
                    });
                    if let Some(k) = close {
                        after = hws(&after[k + 1..]);
                        indexed = true;
                    }
                }
                let ab = after.as_bytes();
                let op_assign = ab.len() >= 2
                    && matches!(ab[0], b'+' | b'-' | b'*' | b'/' | b'%')
                    && (ab[1] == b'=' || (ab[1] == ab[0] && matches!(ab[0], b'+' | b'-')));
                let plain_assign = ab.first() == Some(&b'=') && ab.get(1) != Some(&b'=');
                if op_assign || (indexed && plain_assign) {
                    return Class::Ambiguous(
                        "ambiguous line: a single letter is an address in G-code, so it cannot \
                         start a statement; use a name of two or more characters",
                    );
                }
                if plain_assign {
                    let code = i.split('\n').next().unwrap_or("");
                    let code = code.split("//").next().unwrap_or("").trim_end();
                    if code.ends_with(';') {
                        return Class::Ambiguous(
                            "ambiguous line: `x = …;` reads as the address word X=… with a `;` \
                             comment and as an assignment to a variable; use a name of two or \
                             more characters, or drop the `;` for the G-code word",
                        );
                    }
                }
            }
            Class::Gcode
        }
        _ => Class::Gcode,
    }
}

/// Expression context: whether newlines are whitespace (inside `( )`/`[ ]`), and whether we
/// are in the value of a G-code word, where a name must not look like the next word and a
/// call or index follows its name without a space.
#[derive(Clone, Copy)]
pub(crate) struct ECx {
    pub nl: bool,
    pub in_block: bool,
}

const TOP: ECx = ECx {
    nl: false,
    in_block: false,
};
const NESTED: ECx = ECx {
    nl: true,
    in_block: false,
};

/// C binary operators by level, loosest first (level 0 `||`, 1 `&&` handled separately).
const C_LEVELS: [&[(&str, BinaryOp)]; 4] = [
    &[("==", BinaryOp::Eq), ("!=", BinaryOp::Ne)],
    &[
        ("<=", BinaryOp::Le),
        (">=", BinaryOp::Ge),
        ("<", BinaryOp::Lt),
        (">", BinaryOp::Gt),
    ],
    &[("+", BinaryOp::Add), ("-", BinaryOp::Sub)],
    &[
        ("*", BinaryOp::Mul),
        ("/", BinaryOp::Div),
        ("%", BinaryOp::Mod),
    ],
];

impl<'a> Cx<'a> {
    /// Skips spaces, tabs, `//` and `/* */` comments, and newlines if `nl`.
    pub(crate) fn c_ws(&self, mut i: &'a str, nl: bool) -> PResult<'a, ()> {
        loop {
            let j = if nl {
                i.trim_start_matches([' ', '\t', '\r', '\n'])
            } else {
                hws(i)
            };
            if j.starts_with("//") {
                let end = j.find('\n').unwrap_or(j.len());
                i = &j[end..];
            } else if let Some(body) = j.strip_prefix("/*") {
                match body.find("*/") {
                    Some(k) => i = &body[k + 2..],
                    None => {
                        return fail_exp(j, 2, "unclosed comment `/*`", "`*/`");
                    }
                }
            } else {
                return Ok((j, ()));
            }
        }
    }

    /// Is `i` preceded on its line only by whitespace?
    pub(crate) fn at_line_start(&self, i: &str) -> bool {
        let off = self.off(i);
        self.text.as_bytes()[..off]
            .iter()
            .rev()
            .take_while(|&&b| b != b'\n')
            .all(|&b| matches!(b, b' ' | b'\t' | b'\r'))
    }

    /// The statements that start on one line (at `i`, the line's start). Returns at the `\n`
    /// (or end of text) that ends the line where the last statement ended.
    pub(crate) fn c_line(&self, i: &'a str) -> PResult<'a, Vec<Stmt>> {
        let mut stmts = Vec::new();
        let (mut j, ()) = self.c_ws(i, false)?;
        loop {
            if j.is_empty() || j.starts_with('\n') {
                return Ok((j, stmts));
            }
            let (r, s) = self.c_item(j, 0, true)?;
            stmts.push(s);
            j = self.c_ws(r, false)?.0;
        }
    }

    /// A statement, or a G-code line where one may stand (inside `{ }`, as a body).
    fn c_item(&self, i: &'a str, depth: u32, top: bool) -> PResult<'a, Stmt> {
        if depth >= MAX_DEPTH {
            return fail(
                i,
                char_len(i),
                format!("statements nested too deeply (more than {MAX_DEPTH} levels)"),
            );
        }
        match classify(i) {
            Class::Statement => self.c_stmt(i, depth, top),
            Class::Ambiguous(msg) => {
                let n = i.find('\n').unwrap_or(i.len());
                fail_exp(i, n, msg, "a statement or a G-code block")
            }
            Class::Gcode => {
                if !self.at_line_start(i) {
                    return fail_exp(
                        i,
                        char_len(i),
                        "a G-code block must start its own line",
                        "a statement, or a line break before the G-code block",
                    );
                }
                let start = self.off(i) - {
                    // back to the start of the physical line (only whitespace lies between)
                    self.text.as_bytes()[..self.off(i)]
                        .iter()
                        .rev()
                        .take_while(|&&b| b != b'\n')
                        .count()
                };
                let line_text = &self.text[start..];
                let end = line_text.find('\n').unwrap_or(line_text.len());
                let line_no = self.line_no_at(start);
                let (_, line) = self.line(line_no, &line_text[..end])?;
                let span = line.span;
                Ok((
                    &line_text[end..],
                    Stmt {
                        kind: StmtKind::Gcode(line),
                        span,
                    },
                ))
            }
        }
    }

    /// A statement at `i` (classified as one).
    fn c_stmt(&self, i: &'a str, depth: u32, top: bool) -> PResult<'a, Stmt> {
        let stmt = |r: &'a str, kind| {
            Ok((
                r,
                Stmt {
                    kind,
                    span: self.span(i, r),
                },
            ))
        };
        if i.starts_with('{') {
            let (r, body) = self.c_block(i, depth)?;
            return stmt(r, StmtKind::Block(body));
        }
        if i.starts_with('}') {
            return fail_exp(i, 1, "unbalanced brace: `}` without `{`", "a statement");
        }
        if let Some(r) = i.strip_prefix("#use") {
            let (r, ()) = self.c_ws(r, false)?;
            if !r.starts_with('"') {
                return fail_exp(
                    r,
                    char_len(r),
                    "missing file name after #use",
                    "a file name in double quotes",
                );
            }
            let (r, path) = self.string_lit(r)?;
            let r = self.c_end(r)?.0;
            return stmt(r, StmtKind::Use { path });
        }
        if word_is(i, "if") {
            let (r, cond) = self.c_paren_cond(&i[2..], "if")?;
            let (r, then) = self.c_body(r, depth, "if")?;
            let (k, ()) = self.c_ws(r, true)?;
            if word_is(k, "else") {
                let (r, otherwise) = self.c_body(&k[4..], depth, "else")?;
                return stmt(
                    r,
                    StmtKind::If {
                        cond,
                        then: Box::new(then),
                        otherwise: Some(Box::new(otherwise)),
                    },
                );
            }
            return stmt(
                r,
                StmtKind::If {
                    cond,
                    then: Box::new(then),
                    otherwise: None,
                },
            );
        }
        if word_is(i, "else") {
            return fail(i, 4, "`else` without `if`");
        }
        if word_is(i, "while") {
            let (r, cond) = self.c_paren_cond(&i[5..], "while")?;
            let (r, body) = self.c_body(r, depth, "while")?;
            return stmt(
                r,
                StmtKind::While {
                    cond,
                    body: Box::new(body),
                },
            );
        }
        if word_is(i, "for") {
            return self.c_for(i, depth);
        }
        if word_is(i, "break") || word_is(i, "continue") {
            let brk = i.starts_with('b');
            let r = self.c_end(&i[if brk { 5 } else { 8 }..])?.0;
            return stmt(
                r,
                if brk {
                    StmtKind::Break
                } else {
                    StmtKind::Continue
                },
            );
        }
        if word_is(i, "return") {
            let (j, ()) = self.c_ws(&i[6..], false)?;
            if j.is_empty() || j.starts_with([';', '\n', '}']) {
                let r = self.c_end(j)?.0;
                return stmt(r, StmtKind::Return(None));
            }
            let (r, e) = self.c_expr_req(j, TOP, "after return")?;
            let r = self.c_end(r)?.0;
            return stmt(r, StmtKind::Return(Some(e)));
        }
        if let Some((ty, n)) = type_kw(i) {
            return self.c_decl_or_function(i, ty, n, depth, top);
        }
        let (r, s) = self.c_simple(i)?;
        let r = self.c_end(r)?.0;
        Ok((r, s))
    }

    /// `;`, or nothing before the end of the line, a `}` or the end of the text.
    fn c_end(&self, i: &'a str) -> PResult<'a, ()> {
        let (j, ()) = self.c_ws(i, false)?;
        if let Some(r) = j.strip_prefix(';') {
            return Ok((r, ()));
        }
        if j.is_empty() || j.starts_with(['\n', '}']) {
            return Ok((j, ()));
        }
        fail_exp(
            j,
            char_len(j),
            "missing `;` after the statement",
            "`;` or the end of the line",
        )
    }

    /// `{ items }` at `i`; returns the items.
    fn c_block(&self, i: &'a str, depth: u32) -> PResult<'a, Vec<Stmt>> {
        let open = i;
        let mut items = Vec::new();
        let mut j = &i[1..];
        loop {
            j = self.c_ws(j, true)?.0;
            if let Some(r) = j.strip_prefix('}') {
                return Ok((r, items));
            }
            if j.is_empty() {
                return fail_exp(
                    open,
                    1,
                    "unbalanced brace: `{` is not closed",
                    "`}` before the end of the program",
                );
            }
            if j.starts_with(';') {
                j = &j[1..];
                continue;
            }
            let (r, s) = self.c_item(j, depth + 1, false)?;
            items.push(s);
            j = r;
        }
    }

    /// The body of `if`/`else`/`while`/`for`: a statement or G-code line, possibly on the next
    /// line.
    fn c_body(&self, i: &'a str, depth: u32, after: &str) -> PResult<'a, Stmt> {
        let (j, ()) = self.c_ws(i, true)?;
        if j.is_empty() || j.starts_with('}') {
            return fail_exp(
                j,
                char_len(j),
                format!("missing statement after {after}"),
                "a statement or `{`",
            );
        }
        self.c_item(j, depth + 1, false)
    }

    /// `( cond )` after `if`/`while`.
    fn c_paren_cond(&self, i: &'a str, kw: &str) -> PResult<'a, Expr> {
        let (j, ()) = self.c_ws(i, false)?;
        if !j.starts_with('(') {
            return fail_exp(
                j,
                char_len(j),
                format!("missing `(` after {kw}"),
                "a condition in `( )`",
            );
        }
        let (r, e) = self.c_expr_req(&j[1..], NESTED, "in the condition")?;
        self.c_close(j, r, ')', e)
    }

    /// After an expression opened at `open` with `(`/`[`: expects `close`.
    fn c_close<T>(&self, open: &'a str, r: &'a str, close: char, v: T) -> PResult<'a, T> {
        let (k, ()) = self.c_ws(r, true)?;
        if let Some(r) = k.strip_prefix(close) {
            return Ok((r, v));
        }
        let open_c = open.chars().next().unwrap_or('(');
        if k.is_empty() {
            return fail_exp(
                open,
                1,
                format!("unbalanced bracket: `{open_c}` is not closed"),
                format!("`{close}`"),
            );
        }
        fail_exp(
            k,
            char_len(k),
            "unexpected text in expression",
            format!("an operator or `{close}`"),
        )
    }

    /// `for (init; cond; step) body`.
    fn c_for(&self, i: &'a str, depth: u32) -> PResult<'a, Stmt> {
        let (j, ()) = self.c_ws(&i[3..], false)?;
        if !j.starts_with('(') {
            return fail_exp(
                j,
                char_len(j),
                "missing `(` after for",
                "`(init; cond; step)`",
            );
        }
        let open = j;
        let (mut k, ()) = self.c_ws(&j[1..], true)?;
        let init = if k.starts_with(';') {
            None
        } else {
            let (r, s) = match type_kw(k) {
                Some((ty, n)) => {
                    let (r, vars) = self.c_declarators(&k[n..])?;
                    (
                        r,
                        Stmt {
                            kind: StmtKind::Decl { ty, vars },
                            span: self.span(k, r),
                        },
                    )
                }
                None => self.c_simple(k)?,
            };
            k = r;
            Some(Box::new(s))
        };
        k = self.c_semi(k, "after the for initialiser")?;
        let cond = if k.starts_with(';') {
            None
        } else {
            let (r, e) = self.c_expr_req(k, NESTED, "in the for condition")?;
            k = r;
            Some(e)
        };
        k = self.c_semi(k, "after the for condition")?;
        let step = if k.starts_with(')') {
            None
        } else {
            let (r, s) = self.c_simple(k)?;
            k = r;
            Some(Box::new(s))
        };
        let (r, ()) = self.c_close(open, k, ')', ())?;
        let (r, body) = self.c_body(r, depth, "for")?;
        Ok((
            r,
            Stmt {
                kind: StmtKind::For {
                    init,
                    cond,
                    step,
                    body: Box::new(body),
                },
                span: self.span(i, r),
            },
        ))
    }

    /// `;` (with whitespace and newlines around it) inside `for ( … )`.
    fn c_semi(&self, i: &'a str, what: &str) -> Result<&'a str, nom::Err<super::PErr<'a>>> {
        let (j, ()) = self.c_ws(i, true)?;
        match j.strip_prefix(';') {
            Some(r) => Ok(self.c_ws(r, true)?.0),
            None => fail_exp(j, char_len(j), format!("missing `;` {what}"), "`;`").map(|(r, ())| r),
        }
    }

    /// `type name …`: a declaration, or a function definition at the top level.
    fn c_decl_or_function(
        &self,
        i: &'a str,
        ty: Type,
        n: usize,
        depth: u32,
        top: bool,
    ) -> PResult<'a, Stmt> {
        let (j, ()) = self.c_ws(&i[n..], false)?;
        if j.starts_with('[') {
            return fail(
                j,
                1,
                "C declares arrays as `type name[size]`, and a function cannot return an array \
                 (pass one as a parameter, `void f(double a[])`)",
            );
        }
        let len = ident_len(j);
        if len > 0 {
            let (k, ()) = self.c_ws(&j[len..], false)?;
            if k.starts_with('(') {
                if !top || depth > 0 {
                    return fail(j, len, "functions must be defined at the top level");
                }
                return self.c_function(i, ty, &j[..len], k, depth);
            }
        }
        let (r, vars) = self.c_declarators(&i[n..])?;
        let r = self.c_end(r)?.0;
        Ok((
            r,
            Stmt {
                kind: StmtKind::Decl { ty, vars },
                span: self.span(i, r),
            },
        ))
    }

    /// `name [size]? (= init)? (, …)*` after a type.
    fn c_declarators(&self, i: &'a str) -> PResult<'a, Vec<Declarator>> {
        let mut vars = Vec::new();
        let mut j = i;
        loop {
            let (k, ()) = self.c_ws(j, false)?;
            let (k, name) = self.c_name(k, "a variable name")?;
            let name_at = self.off(k) - name.len();
            let (mut r, ()) = self.c_ws(k, false)?;
            let mut size = None;
            if r.starts_with('[') {
                let (q, e) = self.c_expr_req(&r[1..], NESTED, "as the array size")?;
                let (q, e) = self.c_close(r, q, ']', e)?;
                size = Some(e);
                r = self.c_ws(q, false)?.0;
            }
            let mut init = None;
            if r.starts_with('=') && !r.starts_with("==") {
                let (q, e) = self.c_expr_req(&r[1..], TOP, "after `=`")?;
                init = Some(e);
                r = q;
            }
            let span = crate::ast::Span::new(name_at, self.off(r));
            vars.push(Declarator {
                name: name.to_string(),
                size,
                init,
                span,
            });
            let (q, ()) = self.c_ws(r, false)?;
            match q.strip_prefix(',') {
                Some(q) => j = q,
                None => return Ok((r, vars)),
            }
        }
    }

    /// A name that is not a keyword.
    fn c_name(&self, i: &'a str, what: &'static str) -> PResult<'a, &'a str> {
        let n = ident_len(i);
        if n == 0 {
            return fail_exp(i, char_len(i), format!("missing {what}"), what);
        }
        let name = &i[..n];
        if KEYWORDS.contains(&name) {
            return fail_exp(i, n, format!("`{name}` is a keyword"), what);
        }
        Ok((&i[n..], name))
    }

    /// `type name(params) { body }`; `paren` is at the `(`.
    fn c_function(
        &self,
        i: &'a str,
        ret: Type,
        name: &str,
        paren: &'a str,
        depth: u32,
    ) -> PResult<'a, Stmt> {
        let mut params = Vec::new();
        let (mut j, ()) = self.c_ws(&paren[1..], true)?;
        if !j.starts_with(')') {
            loop {
                let p0 = j;
                // `const type name`: the function may not assign the parameter.
                let konst = word_is(j, "const");
                if konst {
                    j = self.c_ws(&j[5..], true)?.0;
                }
                let Some((ty, n)) = type_kw(j) else {
                    return fail_exp(
                        j,
                        ident_len(j).max(char_len(j)),
                        "missing parameter type",
                        "int, double, string or bool",
                    );
                };
                let (k, ()) = self.c_ws(&j[n..], true)?;
                let (k, pname) = self.c_name(k, "a parameter name")?;
                // `name[]`: an array parameter; its size is the argument's, so none is written.
                let mut end = k;
                let (k, ()) = self.c_ws(k, true)?;
                let array = k.starts_with('[');
                if array {
                    let (q, ()) = self.c_ws(&k[1..], true)?;
                    let Some(q) = q.strip_prefix(']') else {
                        return fail_exp(
                            q,
                            char_len(q),
                            "an array parameter is written `name[]`: its size is the array passed",
                            "`]`",
                        );
                    };
                    end = q;
                }
                params.push(Param {
                    ty,
                    name: pname.to_string(),
                    array,
                    konst,
                    span: self.span(p0, end),
                });
                let (k, ()) = self.c_ws(end, true)?;
                if let Some(k) = k.strip_prefix(',') {
                    j = self.c_ws(k, true)?.0;
                } else {
                    j = k;
                    break;
                }
            }
        }
        let (r, ()) = self.c_close(paren, j, ')', ())?;
        let header = self.span(i, r);
        let (b, ()) = self.c_ws(r, true)?;
        if !b.starts_with('{') {
            return fail_exp(
                b,
                char_len(b),
                format!("missing body of function {name}"),
                "`{`",
            );
        }
        let (r, body) = self.c_block(b, depth)?;
        Ok((
            r,
            Stmt {
                kind: StmtKind::Function(Box::new(Function {
                    ret,
                    name: name.to_string(),
                    params,
                    body,
                    span: header,
                })),
                span: self.span(i, r),
            },
        ))
    }

    /// An assignment, `++`/`--`, or a call, without the terminator.
    fn c_simple(&self, i: &'a str) -> PResult<'a, Stmt> {
        let mk = |r: &'a str, kind| {
            Ok((
                r,
                Stmt {
                    kind,
                    span: self.span(i, r),
                },
            ))
        };
        if i.starts_with("++") || i.starts_with("--") {
            let op = if i.starts_with('+') {
                AssignOp::Add
            } else {
                AssignOp::Sub
            };
            let (j, ()) = self.c_ws(&i[2..], false)?;
            let (r, target) = self.c_expr_req(j, TOP, "after the increment")?;
            self.check_lvalue(&target, j)?;
            let one = Expr {
                kind: ExprKind::Number(1.0),
                span: self.span_at(i, 2),
            };
            return mk(
                r,
                StmtKind::Assign {
                    target,
                    op,
                    value: one,
                },
            );
        }
        let (r, e) = self.c_expr_req(i, TOP, "")?;
        let (j, ()) = self.c_ws(r, false)?;
        let b = j.as_bytes();
        let op = match (b.first(), b.get(1)) {
            (Some(b'='), Some(b'=')) => None,
            (Some(b'='), _) => Some((AssignOp::Set, 1)),
            (Some(b'+'), Some(b'=')) => Some((AssignOp::Add, 2)),
            (Some(b'-'), Some(b'=')) => Some((AssignOp::Sub, 2)),
            (Some(b'*'), Some(b'=')) => Some((AssignOp::Mul, 2)),
            (Some(b'/'), Some(b'=')) => Some((AssignOp::Div, 2)),
            (Some(b'%'), Some(b'=')) => Some((AssignOp::Mod, 2)),
            _ => None,
        };
        if let Some((op, n)) = op {
            self.check_lvalue(&e, i)?;
            let (r, value) = self.c_expr_req(&j[n..], TOP, "after the assignment operator")?;
            return mk(
                r,
                StmtKind::Assign {
                    target: e,
                    op,
                    value,
                },
            );
        }
        if j.starts_with("++") || j.starts_with("--") {
            self.check_lvalue(&e, i)?;
            let op = if j.starts_with('+') {
                AssignOp::Add
            } else {
                AssignOp::Sub
            };
            let r = &j[2..];
            let one = Expr {
                kind: ExprKind::Number(1.0),
                span: self.span_at(j, 2),
            };
            return mk(
                r,
                StmtKind::Assign {
                    target: e,
                    op,
                    value: one,
                },
            );
        }
        if matches!(e.kind, ExprKind::CallNamed(..)) {
            return mk(r, StmtKind::Call(e));
        }
        fail_exp(
            i,
            e.span.range().len(),
            "a statement must be an assignment, a call or a declaration",
            "`=`, `++`, `--` or a call (as G-code: a value after every address letter)",
        )
    }

    fn check_lvalue(&self, e: &Expr, at: &'a str) -> PResult<'a, ()> {
        match e.kind {
            ExprKind::Ident(_)
            | ExprKind::Global(_)
            | ExprKind::SysVar(_)
            | ExprKind::Index(..)
            | ExprKind::Field(..)
            | ExprKind::Var(_)
            | ExprKind::IndirectVar(_) => Ok((at, ())),
            _ => fail(at, e.span.range().len(), "cannot assign to this expression"),
        }
    }

    /// An expression that must be there; `what` says where, for the error.
    pub(crate) fn c_expr_req(&self, i: &'a str, ecx: ECx, what: &str) -> PResult<'a, Expr> {
        self.c_expr_req_at(i, 0, ecx, what)
    }

    /// [`Self::c_expr_req`] at nesting `depth`.
    fn c_expr_req_at(&self, i: &'a str, depth: u32, ecx: ECx, what: &str) -> PResult<'a, Expr> {
        match self.c_expr(i, depth, ecx) {
            Err(nom::Err::Error(_)) => {
                let at = self.c_ws(i, ecx.nl)?.0;
                let msg = if what.is_empty() {
                    "missing expression".to_string()
                } else {
                    format!("missing expression {what}")
                };
                fail_exp(at, char_len(at), msg, "an expression")
            }
            r => r,
        }
    }

    /// A C expression (`||` level).
    pub(crate) fn c_expr(&self, i: &'a str, depth: u32, ecx: ECx) -> PResult<'a, Expr> {
        self.c_logical(i, depth, ecx, LogicalOp::Or)
    }

    fn c_logical(&self, i: &'a str, depth: u32, ecx: ECx, op: LogicalOp) -> PResult<'a, Expr> {
        let tok = if op == LogicalOp::Or { "||" } else { "&&" };
        let operand = |i| {
            if op == LogicalOp::Or {
                self.c_logical(i, depth, ecx, LogicalOp::And)
            } else {
                self.c_level(i, depth, ecx, 0)
            }
        };
        let (mut i, mut lhs) = operand(i)?;
        let mut lhs_height = None;
        loop {
            let (j, ()) = self.c_ws(i, ecx.nl)?;
            if !j.starts_with(tok) {
                return Ok((i, lhs));
            }
            let (r, rhs) = self.c_operand(&j[2..], ecx, tok, operand)?;
            join_height(j, &mut lhs_height, &lhs, height(&rhs))?;
            let span = lhs.span.join(rhs.span);
            lhs = Expr {
                kind: ExprKind::Logical(op, Box::new(lhs), Box::new(rhs)),
                span,
            };
            i = r;
        }
    }

    fn c_operand(
        &self,
        after: &'a str,
        ecx: ECx,
        tok: &str,
        mut f: impl FnMut(&'a str) -> PResult<'a, Expr>,
    ) -> PResult<'a, Expr> {
        match f(after) {
            Err(nom::Err::Error(_)) => {
                let at = self.c_ws(after, ecx.nl)?.0;
                fail_exp(
                    at,
                    char_len(at),
                    format!("missing operand after `{tok}`"),
                    "an expression",
                )
            }
            r => r,
        }
    }

    fn c_level(&self, i: &'a str, depth: u32, ecx: ECx, level: usize) -> PResult<'a, Expr> {
        let operand = |i| {
            if level + 1 < C_LEVELS.len() {
                self.c_level(i, depth, ecx, level + 1)
            } else {
                self.c_unary(i, depth, ecx)
            }
        };
        let (mut i, mut lhs) = operand(i)?;
        let mut lhs_height = None;
        loop {
            let (j, ()) = self.c_ws(i, ecx.nl)?;
            let b = j.as_bytes();
            let found = C_LEVELS[level].iter().find(|(tok, _)| {
                j.starts_with(tok) && {
                    let next = b.get(tok.len()).copied().unwrap_or(0);
                    // `+=`, `++`, `/=`, `//`, `<=` vs `<`: not this operator.
                    match *tok {
                        "+" | "-" => next != b'=' && next != b[0],
                        "*" | "%" => next != b'=',
                        "/" => next != b'=' && next != b'/' && next != b'*',
                        "<" | ">" => next != b'=',
                        _ => true,
                    }
                }
            });
            let Some(&(tok, op)) = found else {
                return Ok((i, lhs));
            };
            let (r, rhs) = self.c_operand(&j[tok.len()..], ecx, tok, operand)?;
            join_height(j, &mut lhs_height, &lhs, height(&rhs))?;
            let span = lhs.span.join(rhs.span);
            lhs = Expr {
                kind: ExprKind::Binary(op, Box::new(lhs), Box::new(rhs)),
                span,
            };
            i = r;
        }
    }

    fn c_unary(&self, i: &'a str, depth: u32, ecx: ECx) -> PResult<'a, Expr> {
        let (i, ()) = self.c_ws(i, ecx.nl)?;
        let b = i.as_bytes();
        let kind: Option<fn(Box<Expr>) -> ExprKind> = match (b.first(), b.get(1)) {
            (Some(b'-'), n) if n != Some(&b'-') => Some(|e| ExprKind::Unary(UnaryOp::Neg, e)),
            (Some(b'+'), n) if n != Some(&b'+') => Some(|e| ExprKind::Unary(UnaryOp::Plus, e)),
            (Some(b'!'), n) if n != Some(&b'=') => Some(ExprKind::Not),
            _ => None,
        };
        let Some(kind) = kind else {
            return self.c_postfix(i, depth, ecx);
        };
        if depth >= MAX_DEPTH {
            return fail(
                i,
                1,
                format!("expression nested too deeply (more than {MAX_DEPTH} levels)"),
            );
        }
        let (r, e) = self.c_operand(&i[1..], ecx, &i[..1], |j| self.c_unary(j, depth + 1, ecx))?;
        let span = self.span_at(i, 0).join(e.span);
        Ok((
            r,
            Expr {
                kind: kind(Box::new(e)),
                span,
            },
        ))
    }

    fn c_postfix(&self, i: &'a str, depth: u32, ecx: ECx) -> PResult<'a, Expr> {
        let (mut r, mut e) = self.c_primary(i, depth, ecx)?;
        let mut e_height = None;
        loop {
            let (j, ()) = if ecx.in_block {
                (r, ())
            } else {
                self.c_ws(r, ecx.nl)?
            };
            if depth >= MAX_DEPTH && j.starts_with(['[', '(']) {
                return fail(
                    j,
                    1,
                    format!("expression nested too deeply (more than {MAX_DEPTH} levels)"),
                );
            }
            if let Some(inner) = j.strip_prefix('[') {
                let (q, idx) = self
                    .c_expr_req_at(inner, depth + 1, NESTED, "as the index")
                    .and_then(|(q, x)| self.c_close(j, q, ']', x))?;
                join_height(j, &mut e_height, &e, height(&idx))?;
                let span = self.span(i, q);
                e = Expr {
                    kind: ExprKind::Index(Box::new(e), Box::new(idx)),
                    span,
                };
                r = q;
            } else if let Some(k) = j.strip_prefix('.') {
                let n = ident_len(k);
                if n == 0 {
                    return fail_exp(k, char_len(k), "missing field name after `.`", "a name");
                }
                let q = &k[n..];
                join_height(j, &mut e_height, &e, 0)?;
                e = Expr {
                    kind: ExprKind::Field(Box::new(e), k[..n].to_string()),
                    span: self.span(i, q),
                };
                r = q;
            } else if j.starts_with('(') {
                let ExprKind::Ident(name) = &e.kind else {
                    return Ok((r, e));
                };
                let name = name.clone();
                let (q, args) = self.c_args(j, depth + 1)?;
                e = Expr {
                    kind: ExprKind::CallNamed(name, args),
                    span: self.span(i, q),
                };
                r = q;
            } else {
                return Ok((r, e));
            }
        }
    }

    /// `( a, b, … )` at `open`.
    fn c_args(&self, open: &'a str, depth: u32) -> PResult<'a, Vec<Expr>> {
        let mut args = Vec::new();
        let (mut j, ()) = self.c_ws(&open[1..], true)?;
        if let Some(r) = j.strip_prefix(')') {
            return Ok((r, args));
        }
        loop {
            let (r, e) = match self.c_expr(j, depth, NESTED) {
                Err(nom::Err::Error(_)) => {
                    return fail_exp(j, char_len(j), "missing argument", "an expression");
                }
                r => r?,
            };
            args.push(e);
            let (k, ()) = self.c_ws(r, true)?;
            if let Some(k) = k.strip_prefix(',') {
                j = self.c_ws(k, true)?.0;
                continue;
            }
            return self.c_close(open, k, ')', args);
        }
    }

    /// A number literal; statements take C exponents (`1e-6`), G-code values do not (`E` is an
    /// address there).
    fn c_number(&self, i: &'a str, ecx: ECx) -> PResult<'a, Expr> {
        let number = |r: &'a str, v| {
            Ok((
                r,
                Expr {
                    kind: ExprKind::Number(v),
                    span: self.span(i, r),
                },
            ))
        };
        let (r, (v, _)) = self.unsigned(i)?;
        let rb = r.as_bytes();
        if !ecx.in_block && matches!(rb.first(), Some(b'e' | b'E')) {
            let k = 1 + usize::from(matches!(rb.get(1), Some(b'+' | b'-')));
            let digits = rb[k.min(rb.len())..]
                .iter()
                .take_while(|b| b.is_ascii_digit())
                .count();
            if digits > 0 {
                let end = self.off(r) + k + digits;
                let text = &self.text[self.off(i)..end];
                return match text.parse::<f64>() {
                    Ok(v) => number(&self.text[end..], v),
                    Err(_) => fail(i, text.len(), "not a valid number"),
                };
            }
        }
        number(r, v)
    }

    fn c_primary(&self, i: &'a str, depth: u32, ecx: ECx) -> PResult<'a, Expr> {
        let mk = |r: &'a str, kind| {
            Ok((
                r,
                Expr {
                    kind,
                    span: self.span(i, r),
                },
            ))
        };
        let b = i.as_bytes();
        match b.first() {
            Some(c) if c.is_ascii_digit() || *c == b'.' => self.c_number(i, ecx),
            Some(b'"') => {
                let (r, s) = self.string_lit(i)?;
                mk(r, ExprKind::Str(s))
            }
            Some(b'(') => {
                if depth >= MAX_DEPTH {
                    return fail(
                        i,
                        1,
                        format!("expression nested too deeply (more than {MAX_DEPTH} levels)"),
                    );
                }
                let (r, mut e) = match self.c_expr(&i[1..], depth + 1, NESTED) {
                    Err(nom::Err::Error(_)) => {
                        let at = self.c_ws(&i[1..], true)?.0;
                        if at.starts_with(')') {
                            return fail_exp(at, 1, "empty parentheses", "an expression");
                        }
                        return fail_exp(at, char_len(at), "missing expression", "an expression");
                    }
                    r => r?,
                };
                let (r, ()) = self.c_close(i, r, ')', ())?;
                e.span = self.span(i, r);
                Ok((r, e))
            }
            Some(b'[') => {
                if depth >= MAX_DEPTH {
                    return fail(
                        i,
                        1,
                        format!("expression nested too deeply (more than {MAX_DEPTH} levels)"),
                    );
                }
                let (r, mut e) = self.bracketed(i, depth + 1)?;
                e.span = self.span(i, r);
                Ok((r, e))
            }
            Some(b'#') => self.var(i, depth),
            Some(b'$') | Some(b'@') => {
                let n = ident_len(&i[1..]);
                if n == 0 {
                    return fail_exp(
                        i,
                        1,
                        format!("missing name after `{}`", b[0] as char),
                        "a name",
                    );
                }
                let name = i[1..1 + n].to_string();
                let kind = if b[0] == b'$' {
                    ExprKind::Global(name)
                } else {
                    ExprKind::SysVar(name)
                };
                mk(&i[1 + n..], kind)
            }
            Some(&c) if is_ident_start(c) => {
                let n = ident_len(i);
                let name = &i[..n];
                if ecx.in_block && n == 1 {
                    // `F= X1`: the next word, not a variable named X.
                    let next = hws(&i[1..]).as_bytes().first().copied().unwrap_or(0);
                    if next.is_ascii_digit()
                        || matches!(next, b'.' | b'+' | b'-' | b'#' | b'[' | b'=')
                    {
                        return Err(nom::Err::Error(nom::error::ParseError::from_error_kind(
                            i,
                            nom::error::ErrorKind::Alpha,
                        )));
                    }
                }
                if FUNCS.iter().any(|(f, _)| f.eq_ignore_ascii_case(name))
                    && hws(&i[n..]).starts_with('[')
                {
                    return self.primary(i, depth);
                }
                match name {
                    "true" => mk(&i[n..], ExprKind::Bool(true)),
                    "false" => mk(&i[n..], ExprKind::Bool(false)),
                    _ if KEYWORDS.contains(&name) => fail_exp(
                        i,
                        n,
                        format!("`{name}` is a keyword, not a value"),
                        "an expression",
                    ),
                    _ => mk(&i[n..], ExprKind::Ident(name.to_string())),
                }
            }
            _ => Err(nom::Err::Error(nom::error::ParseError::from_error_kind(
                i,
                nom::error::ErrorKind::Alt,
            ))),
        }
    }

    /// `"…"` with escapes `\"`, `\\`, `\n`, `\t`; on one line.
    fn string_lit(&self, i: &'a str) -> PResult<'a, String> {
        let mut out = String::new();
        let mut chars = i[1..].char_indices();
        while let Some((k, c)) = chars.next() {
            match c {
                '"' => return Ok((&i[k + 2..], out)),
                '\n' => break,
                '\\' => match chars.next() {
                    Some((_, 'n')) => out.push('\n'),
                    Some((_, 't')) => out.push('\t'),
                    Some((_, c @ ('"' | '\\'))) => out.push(c),
                    Some((k2, c)) => {
                        return fail(
                            &i[k + 1..],
                            1 + (k2 - k) + c.len_utf8() - 1,
                            format!("unknown escape `\\{c}` in string"),
                        );
                    }
                    None => break,
                },
                c => out.push(c),
            }
        }
        let line = i.split('\n').next().unwrap_or(i);
        fail_exp(
            i,
            line.trim_end_matches('\r').len(),
            "unterminated string",
            "`\"` before the end of the line",
        )
    }
}

/// A type keyword at the start of `i`, and its length.
fn type_kw(i: &str) -> Option<(Type, usize)> {
    [
        ("int", Type::Int),
        ("double", Type::Double),
        ("string", Type::String),
        ("bool", Type::Bool),
        ("void", Type::Void),
    ]
    .into_iter()
    .find(|(kw, _)| word_is(i, kw))
    .map(|(kw, t)| (t, kw.len()))
}
