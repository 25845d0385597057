//! LinuxCNC's O-word statements (`o100 sub`, `o<name> call [1]`, `o1 if [c]` … `o1 endif`)
//! and named parameters (`#<name>`), read only in the LinuxCNC dialect: in the others `O`
//! starts a program number and `#<` is an error.

use super::lex::{char_len, ws};
use super::{Cx, PResult, fail, fail_exp};
use crate::ast::{Comment, Expr, ExprKind, LineKind, OLabel, OWord, OWordKind};

/// The O-word keywords, as LinuxCNC spells them (any case).
const KEYWORDS: &str = "sub, endsub, return, call, if, elseif, else, endif, do, while, endwhile, repeat, endrepeat, break or continue";

/// Longest `<name>` (LinuxCNC's limit on names is of this order): bounds what a name costs.
const MAX_NAME: usize = 64;

impl<'a> Cx<'a> {
    /// An O-word line after its comments and block delete: `i` starts with `O`/`o`.
    pub(crate) fn oword(&self, i: &'a str, comments: &mut Vec<Comment>) -> PResult<'a, LineKind> {
        let start = i;
        let after = ws(&i[1..]);
        let (r, label) = match after.as_bytes().first() {
            Some(b'<') => {
                let (r, name) = self.angle_name(after, "subroutine name")?;
                (r, OLabel::Name(name))
            }
            _ => {
                let (r, n) = self.whole(after, "O-word number or <name>")?;
                (r, OLabel::Number(n))
            }
        };
        let label_span = self.span(start, r);
        let kw_at = ws(r);
        let kw_len = kw_at.bytes().take_while(u8::is_ascii_alphabetic).count();
        if kw_len == 0 {
            return fail_exp(
                kw_at,
                char_len(kw_at),
                format!("an O-word needs a keyword after {label} (LinuxCNC dialect)"),
                KEYWORDS,
            );
        }
        let mut kw = kw_at[..kw_len].to_ascii_lowercase();
        let mut r = &kw_at[kw_len..];
        // LinuxCNC reads a line without its spaces: `else if` is `elseif`, `end if` `endif`.
        let next_at = ws(r);
        let next_len = next_at.bytes().take_while(u8::is_ascii_alphabetic).count();
        if next_len > 0 && next_at.len() < r.len() {
            let joined = format!("{kw}{}", next_at[..next_len].to_ascii_lowercase());
            let known = ["elseif", "endif", "endsub", "endwhile", "endrepeat"];
            if known.contains(&joined.as_str()) {
                kw = joined;
                r = &next_at[next_len..];
            }
        }
        let (r, kind) = match kw.as_str() {
            "sub" => (r, OWordKind::Sub),
            "else" => (r, OWordKind::Else),
            "endif" => (r, OWordKind::EndIf),
            "do" => (r, OWordKind::Do),
            "endwhile" => (r, OWordKind::EndWhile),
            "endrepeat" => (r, OWordKind::EndRepeat),
            "break" => (r, OWordKind::Break),
            "continue" => (r, OWordKind::Continue),
            "endsub" | "return" => {
                let (r, v) = self.optional_bracket(r)?;
                let k = if kw == "endsub" {
                    OWordKind::EndSub(v)
                } else {
                    OWordKind::Return(v)
                };
                (r, k)
            }
            "if" | "elseif" | "while" | "repeat" => {
                let (r, v) = self.optional_bracket(r)?;
                let Some(v) = v else {
                    let at = ws(r);
                    return fail_exp(
                        at,
                        char_len(at),
                        format!("{kw} needs a condition in brackets"),
                        format!("{label} {kw} [expression]"),
                    );
                };
                let k = match kw.as_str() {
                    "if" => OWordKind::If(v),
                    "elseif" => OWordKind::ElseIf(v),
                    "while" => OWordKind::While(v),
                    _ => OWordKind::Repeat(v),
                };
                (r, k)
            }
            "call" => {
                let mut args = Vec::new();
                let mut r = r;
                while let (rest, Some(e)) = self.optional_bracket(r)? {
                    if args.len() == 30 {
                        return fail(r, char_len(ws(r)), "a call takes at most 30 arguments");
                    }
                    args.push(e);
                    r = rest;
                }
                (r, OWordKind::Call(args))
            }
            _ => {
                return fail_exp(
                    kw_at,
                    kw_len,
                    format!("unknown O-word keyword `{}`", &kw_at[..kw_len]),
                    KEYWORDS,
                );
            }
        };
        let (rest, ()) = self.trivia(r, comments)?;
        if !rest.is_empty() {
            return fail_exp(
                rest,
                char_len(rest),
                "unexpected text after the O-word",
                "a comment or the end of the line",
            );
        }
        Ok((
            rest,
            LineKind::OWord(Box::new(OWord {
                label,
                label_span,
                kind,
            })),
        ))
    }

    /// `[expr]` after optional whitespace, or nothing.
    fn optional_bracket(&self, i: &'a str) -> PResult<'a, Option<Expr>> {
        let at = ws(i);
        if !at.starts_with('[') {
            return Ok((i, None));
        }
        let (r, mut e) = self.bracketed(at, 1)?;
        e.span = self.span(at, r);
        Ok((r, Some(e)))
    }

    /// `<name>` at `i` (which starts with `<`): the name folded to lower case, spaces removed.
    fn angle_name(&self, i: &'a str, what: &str) -> PResult<'a, String> {
        let Some(close) = i.find('>') else {
            return fail_exp(
                i,
                char_len(i),
                format!("unclosed `<` in a {what}"),
                "`>` after the name",
            );
        };
        let name: String = i[1..close]
            .chars()
            .filter(|c| !c.is_whitespace())
            .map(|c| c.to_ascii_lowercase())
            .collect();
        if name.is_empty() {
            return fail_exp(
                i,
                close + 1,
                format!("empty {what}"),
                "a name between < and >",
            );
        }
        if name.len() > MAX_NAME {
            return fail(
                i,
                close + 1,
                format!("{what} longer than {MAX_NAME} characters"),
            );
        }
        Ok((&i[close + 1..], name))
    }

    /// A named parameter `#<name>` at `i` (which starts with `#`, then `<` after spaces).
    pub(crate) fn named_param(&self, i: &'a str) -> PResult<'a, Expr> {
        let after = ws(&i[1..]);
        let (rest, name) = self.angle_name(after, "parameter name")?;
        Ok((
            rest,
            Expr {
                kind: ExprKind::Named(name),
                span: self.span(i, rest),
            },
        ))
    }
}

#[cfg(test)]
mod tests {
    use crate::ast::{ExprKind, LineKind, OLabel, OWordKind};
    use crate::dialect::Dialect;
    use crate::{SourceFile, parse_in};

    fn kinds(text: &str) -> Vec<LineKind> {
        let src = SourceFile::new("t.ngc", text);
        parse_in(&src, Dialect::LinuxCnc)
            .unwrap()
            .lines
            .into_iter()
            .map(|l| l.kind)
            .collect()
    }

    fn err(text: &str) -> (u32, u32, String) {
        let e = parse_in(&SourceFile::new("t.ngc", text), Dialect::LinuxCnc).unwrap_err();
        (e.line, e.col, e.message.clone())
    }

    fn oword(k: &LineKind) -> (&OLabel, &OWordKind) {
        let LineKind::OWord(o) = k else {
            panic!("{k:?}")
        };
        (&o.label, &o.kind)
    }

    #[test]
    fn owords_parse_with_labels_and_brackets() {
        let k = kinds("o100 sub\nO<My Sub> call [1] [#2+1]\no1 if [#1 GT 0] (c)\no1 endsub [3]\n");
        assert_eq!(oword(&k[0]), (&OLabel::Number(100), &OWordKind::Sub));
        let (l, OWordKind::Call(args)) = oword(&k[1]) else {
            panic!()
        };
        assert_eq!((l, args.len()), (&OLabel::Name("mysub".into()), 2));
        assert!(matches!(oword(&k[2]).1, OWordKind::If(_)));
        assert!(matches!(oword(&k[3]).1, OWordKind::EndSub(Some(_))));
    }

    #[test]
    fn named_parameters_fold_case_and_spaces() {
        let k = kinds("#<Tool Dia> = 3\nG0 X#<tooldia>\n");
        let LineKind::Assign { target, .. } = &k[0] else {
            panic!()
        };
        assert_eq!(target.kind, ExprKind::Named("tooldia".into()));
    }

    #[test]
    fn o_words_and_names_are_linuxcnc_only() {
        let src = SourceFile::new("t.nc", "O100\n");
        let p = parse_in(&src, Dialect::Fanuc).unwrap();
        assert!(matches!(
            p.lines[0].kind,
            LineKind::ProgramNumber { number: 100, .. }
        ));
        assert!(parse_in(&SourceFile::new("t.nc", "#<a>=1\n"), Dialect::Fanuc).is_err());
    }

    #[test]
    fn o_word_errors_point_at_the_text() {
        assert_eq!(err("o100\n").1, 5);
        assert!(err("o100\n").2.contains("needs a keyword"));
        let (l, c, m) = err("G0\no1 frob\n");
        assert_eq!((l, c), (2, 4), "{m}");
        assert!(err("o1 if\n").2.contains("needs a condition"));
        assert!(err("#<abc = 1\n").2.contains("unclosed"));
        assert!(err("o<> sub\n").2.contains("empty"));
    }
}
