//! Lexical pieces: whitespace, comments, and our own number parser (nom's `double` reads
//! `1E2` as an exponent, but `E` is an address letter in G-code).

use nom::bytes::complete::take_while;

use super::{Cx, PResult, fail, fail_exp};
use crate::ast::{Comment, Number};

/// Exact powers of ten for the number fast path (15 digits at most after the point).
const POW10: [f64; 16] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
];

/// Whitespace inside a line: space, tab, and a stray carriage return.
#[inline]
pub(crate) fn is_ws(c: char) -> bool {
    c == ' ' || c == '\t' || c == '\r'
}

/// Skips whitespace.
#[inline]
pub(crate) fn ws(i: &str) -> &str {
    let r: PResult<'_, &str> = take_while(is_ws)(i);
    match r {
        Ok((rest, _)) => rest,
        Err(_) => i,
    }
}

/// Byte length of the first character of `i` (0 at the end): the span of an unexpected char.
#[inline]
pub(crate) fn char_len(i: &str) -> usize {
    i.chars().next().map_or(0, char::len_utf8)
}

/// Does `i` start with `kw` (ASCII, case-insensitive)?
#[inline]
pub(crate) fn starts_with_kw(i: &str, kw: &str) -> bool {
    i.len() >= kw.len() && i.as_bytes()[..kw.len()].eq_ignore_ascii_case(kw.as_bytes())
}

/// Byte index of the `)` that closes a comment whose body starts at `body`, counting nested
/// parentheses.
fn close_paren(body: &str) -> Option<usize> {
    let mut depth = 0u32;
    for (k, b) in body.bytes().enumerate() {
        match b {
            b'(' => depth += 1,
            b')' if depth == 0 => return Some(k),
            b')' => depth -= 1,
            _ => {}
        }
    }
    None
}

/// An unsigned literal's scan (see [`Cx::unsigned`]): shared with the plain-block fast
/// path (`super::simple`) so that both read every number to the same bits.
pub(crate) struct Unsigned {
    /// Bytes taken: digits and at most one point.
    pub len: usize,
    /// Digits before and after the point (0: not a number).
    pub digits: usize,
    pub has_point: bool,
    /// The value; `None` when there are no digits or the std parser refuses the text.
    pub value: Option<f64>,
}

/// Scans `digits [. digits]` or `. digits` at the start of `i`.
#[inline]
pub(crate) fn scan_unsigned(i: &str) -> Unsigned {
    let b = i.as_bytes();
    let mut k = 0;
    let mut int: u64 = 0;
    while k < b.len() && b[k].is_ascii_digit() {
        int = int.wrapping_mul(10).wrapping_add(u64::from(b[k] - b'0'));
        k += 1;
    }
    let int_digits = k;
    let mut has_point = false;
    let mut frac_digits = 0;
    if k < b.len() && b[k] == b'.' {
        has_point = true;
        k += 1;
        while k < b.len() && b[k].is_ascii_digit() {
            int = int.wrapping_mul(10).wrapping_add(u64::from(b[k] - b'0'));
            k += 1;
            frac_digits += 1;
        }
    }
    let digits = int_digits + frac_digits;
    // Up to 15 digits fit an f64 exactly, and so does 10^k for k <= 22: one IEEE division
    // of two exact values is the correctly rounded result (Clinger's fast path). Longer
    // numbers go through the std parser, also correctly rounded.
    let value = if digits == 0 {
        None
    } else if digits <= 15 {
        Some(int as f64 / POW10[frac_digits])
    } else {
        i[..k].parse::<f64>().ok()
    };
    Unsigned {
        len: k,
        digits,
        has_point,
        value,
    }
}

impl<'a> Cx<'a> {
    /// Skips whitespace and comments, collecting the comments: `( … )` and `;` to the end of
    /// the line. Parentheses nest inside a comment (`(START(dòng) SPINDLE)` is one comment), as
    /// the macro programs of source 001 print annotations that way; a comment ends at the
    /// end of its line.
    pub(crate) fn trivia(&self, mut i: &'a str, comments: &mut Vec<Comment>) -> PResult<'a, ()> {
        loop {
            i = ws(i);
            match i.as_bytes().first() {
                Some(b'(') => {
                    let body = &i[1..];
                    match close_paren(body) {
                        Some(end) => {
                            comments.push(Comment {
                                text: body[..end].to_string(),
                                span: self.span_at(i, end + 2),
                            });
                            i = &body[end + 1..];
                        }
                        None => {
                            let len = i.trim_end_matches('\r').len();
                            return fail_exp(
                                i,
                                len,
                                "unclosed comment",
                                "`)` before the end of the line",
                            );
                        }
                    }
                }
                Some(b'/') if self.c_like && i.as_bytes().get(1) == Some(&b'/') => {
                    // A C comment at the end of a G-code line of a C-like program.
                    i = &i[i.len()..];
                }
                Some(b';') => {
                    let body = &i[1..];
                    let text = body.trim_end_matches('\r');
                    comments.push(Comment {
                        text: text.to_string(),
                        span: self.span_at(i, 1 + text.len()),
                    });
                    i = &body[body.len()..];
                }
                _ => return Ok((i, ())),
            }
        }
    }

    /// A signed literal number: `[+-]? digits [. digits]` or `[+-]? . digits`; at least one
    /// digit. No exponent: `1E2` is the number 1 followed by the word `E2`.
    pub(crate) fn number(&self, i: &'a str) -> PResult<'a, Number> {
        let b = i.as_bytes();
        let mut k = 0;
        let neg = match b.first() {
            Some(b'-') => {
                k = 1;
                true
            }
            Some(b'+') => {
                k = 1;
                false
            }
            _ => false,
        };
        let (rest, (value, has_point)) = match self.unsigned(&i[k..]) {
            Ok(ok) => ok,
            Err(nom::Err::Error(_)) if k == 1 => {
                let sign = if neg { '-' } else { '+' };
                return fail_exp(
                    &i[k..],
                    char_len(&i[k..]),
                    format!("no digits after `{sign}`"),
                    "a number",
                );
            }
            Err(e) => return Err(e),
        };
        let value = if neg { -value } else { value };
        Ok((
            rest,
            Number {
                value,
                has_point,
                span: self.span(i, rest),
            },
        ))
    }

    /// An unsigned literal: `digits [. digits]` or `. digits`. Returns (rest, value,
    /// has_point). A recoverable error (nothing consumed) when `i` does not start a number.
    pub(crate) fn unsigned(&self, i: &'a str) -> PResult<'a, (f64, bool)> {
        let u = scan_unsigned(i);
        if u.digits == 0 {
            if u.has_point {
                return fail_exp(i, 1, "a decimal point without digits", "a number");
            }
            return Err(nom::Err::Error(nom::error::ParseError::from_error_kind(
                i,
                nom::error::ErrorKind::Digit,
            )));
        }
        match u.value {
            Some(value) => Ok((&i[u.len..], (value, u.has_point))),
            None => fail(i, u.len, "not a valid number"),
        }
    }

    /// A whole number (for `N` and `O`): digits only, fitting a `u32`. `what` names it in
    /// errors ("sequence number", "program number").
    pub(crate) fn whole(&self, i: &'a str, what: &'static str) -> PResult<'a, u32> {
        let digits = i.bytes().take_while(u8::is_ascii_digit).count();
        if digits == 0 {
            return fail_exp(
                i,
                char_len(i),
                format!("missing {what}"),
                format!("the digits of the {what}"),
            );
        }
        let after = &i[digits..];
        if let Some(frac) = after.strip_prefix('.') {
            let frac = frac.bytes().take_while(u8::is_ascii_digit).count();
            return fail(
                i,
                digits + 1 + frac,
                format!("a {what} must be a whole number"),
            );
        }
        match i[..digits].parse::<u32>() {
            Ok(v) => Ok((after, v)),
            Err(_) => fail(i, digits, format!("{what} too large")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn num(s: &str) -> Result<(f64, bool, usize), String> {
        let cx = Cx::new(s);
        match cx.number(s) {
            Ok((rest, n)) => Ok((n.value, n.has_point, s.len() - rest.len())),
            Err(nom::Err::Failure(e) | nom::Err::Error(e)) => Err(e.msg.to_string()),
            Err(_) => Err("incomplete".into()),
        }
    }

    #[test]
    fn numbers_with_and_without_point() {
        assert_eq!(num("10"), Ok((10.0, false, 2)));
        assert_eq!(num("007"), Ok((7.0, false, 3)));
        assert_eq!(num("-2.5"), Ok((-2.5, true, 4)));
        assert_eq!(num("+3"), Ok((3.0, false, 2)));
        assert_eq!(num(".5"), Ok((0.5, true, 2)));
        assert_eq!(num("-.5"), Ok((-0.5, true, 3)));
        assert_eq!(num("1."), Ok((1.0, true, 2)));
        assert_eq!(num("0.1"), Ok((0.1, true, 3)));
        assert_eq!(
            num("123456789012345678901"),
            Ok((123456789012345678901.0, false, 21))
        );
    }

    #[test]
    fn fast_path_equals_std_parsing() {
        for t in [
            "0.1",
            "0.2",
            "0.3",
            "1.005",
            "123.456",
            "99999.99999",
            "0.000000000000001",
            "12345678901234.5",
            "1234567890123456.7",
            "3.141592653589793",
            ".333333333333333",
            "1000000.0000001",
            "7.",
            "0.0",
        ] {
            assert_eq!(num(t).unwrap().0, t.parse::<f64>().unwrap(), "{t}");
        }
    }

    #[test]
    fn e_is_not_an_exponent() {
        assert_eq!(num("1E2"), Ok((1.0, false, 1)));
        assert_eq!(num("10.E2Y3"), Ok((10.0, true, 3)));
        assert_eq!(num("1e-3"), Ok((1.0, false, 1)));
    }

    #[test]
    fn malformed_numbers() {
        assert_eq!(num("-"), Err("no digits after `-`".into()));
        assert_eq!(num("+X"), Err("no digits after `+`".into()));
        assert_eq!(num("."), Err("a decimal point without digits".into()));
        assert_eq!(num("-."), Err("a decimal point without digits".into()));
        assert_eq!(num("X"), Err("syntax error".into()));
    }

    #[test]
    fn comments_between_words() {
        let s = "  (a(b)) ;rest\r";
        let cx = Cx::new(s);
        let mut c = Vec::new();
        let (rest, ()) = cx.trivia(s, &mut c).unwrap();
        assert_eq!(rest, "");
        assert_eq!(c.len(), 2);
        assert_eq!(c[0].text, "a(b)");
        assert_eq!(c[0].span.range(), 2..8);
        assert_eq!(c[1].text, "rest");
        assert_eq!(c[1].span.range(), 9..14);
        let s = "(a(b)";
        let cx = Cx::new(s);
        assert!(cx.trivia(s, &mut c).is_err());
    }

    #[test]
    fn whole_numbers() {
        let cx = Cx::new("123 4.5 99999999999");
        assert_eq!(cx.whole(cx.text, "x").unwrap().1, 123);
        assert!(cx.whole(&cx.text[4..], "x").is_err());
        assert!(cx.whole(&cx.text[8..], "x").is_err());
    }
}
