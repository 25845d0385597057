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
    scan_unsigned_at(i.as_bytes(), 0)
}

/// [`scan_unsigned`] of the text from `at` on, `b` being the whole text: a number near its
/// end is read in one word with the bytes before it.
#[inline(always)]
pub(crate) fn scan_unsigned_at(b: &[u8], at: usize) -> Unsigned {
    let d = short_number(b, at).unwrap_or_else(|| long_number(b, at));
    let digits = d.int_digits + d.frac_digits;
    // Up to 15 digits fit an f64 exactly, and so does 10^k for k <= 22: one IEEE division
    // of two exact values is the correctly rounded result (Clinger's fast path). Longer
    // numbers go through the std parser, also correctly rounded.
    let value = if digits == 0 {
        None
    } else if digits <= 15 {
        Some(d.mantissa as f64 / POW10[d.frac_digits])
    } else {
        let text = b
            .get(at..at + d.len)
            .and_then(|t| std::str::from_utf8(t).ok());
        text.and_then(|t| t.parse::<f64>().ok())
    };
    Unsigned {
        len: d.len,
        digits,
        has_point: d.has_point,
        value,
    }
}

/// A number's digits as scanned: its length, digits each side of the point, and their
/// value as one integer (wrapping past 19 digits, when it is not used).
struct Digits {
    len: usize,
    int_digits: usize,
    frac_digits: usize,
    has_point: bool,
    mantissa: u64,
}

/// A number that ends within the 8 bytes at `at` (`10.0000`, `-2.5`, `3`, most of what
/// CAM writes): read from one word, with its point taken out. `None`: a longer one.
#[inline(always)]
fn short_number(b: &[u8], at: usize) -> Option<Digits> {
    let word = load8_at(b, at);
    let stops = non_digits(word);
    let p1 = (stops.trailing_zeros() / 8) as usize;
    if p1 == 8 {
        return None;
    }
    if (word >> (8 * p1)) as u8 != b'.' {
        return Some(Digits {
            len: p1,
            int_digits: p1,
            frac_digits: 0,
            has_point: false,
            mantissa: eight_digits(word, p1),
        });
    }
    let p2 = ((stops & (stops - 1)).trailing_zeros() / 8) as usize;
    if p2 == 8 {
        return None;
    }
    // The bytes after the point moved down one, over it.
    let below_point = (1u64 << (8 * p1)) - 1;
    let joined = (word & below_point) | ((word >> 8) & !below_point);
    Some(Digits {
        len: p2,
        int_digits: p1,
        frac_digits: p2 - p1 - 1,
        has_point: true,
        mantissa: eight_digits(joined, p2 - 1),
    })
}

/// Any number, one run of digits at a time.
#[inline(never)]
fn long_number(b: &[u8], at: usize) -> Digits {
    let (int, int_digits) = digit_run(b, at);
    let mut d = Digits {
        len: int_digits,
        int_digits,
        frac_digits: 0,
        has_point: false,
        mantissa: int,
    };
    if b.get(at + d.len) == Some(&b'.') {
        d.has_point = true;
        let (frac, n) = digit_run(b, at + d.len + 1);
        d.mantissa = d
            .mantissa
            .wrapping_mul(POW10_INT.get(n).copied().unwrap_or(0))
            .wrapping_add(frac);
        d.len += 1 + n;
        d.frac_digits = n;
    }
    d
}

/// 10^k as integers, for joining runs of digits (10^19 is the largest a `u64` holds).
const POW10_INT: [u64; 20] = {
    let mut t = [1u64; 20];
    let mut k = 1;
    while k < 20 {
        t[k] = t[k - 1] * 10;
        k += 1;
    }
    t
};

const LANES_01: u64 = 0x0101_0101_0101_0101;

/// The ASCII digits of `b` from `at` on: their value (wrapping past 19 digits) and how
/// many. Eight bytes at a time: a byte loop was ~13 instructions a digit, and every word of
/// every streamed line is scanned twice (load pass and run).
fn digit_run(b: &[u8], at: usize) -> (u64, usize) {
    let mut value = 0u64;
    let mut n = 0;
    // Each full round takes 8 digits, so this ends within b.len() / 8 + 1 rounds.
    loop {
        let word = load8_at(b, at + n);
        let len = (non_digits(word).trailing_zeros() / 8) as usize;
        value = value
            .wrapping_mul(POW10_INT[len])
            .wrapping_add(eight_digits(word, len));
        n += len;
        if len < 8 {
            return (value, n);
        }
    }
}

/// The 8 bytes of `b` from `at` on as a little-endian word, zero bytes past its end (a 0
/// byte is no digit, so the padding ends a run).
#[inline(always)]
fn load8_at(b: &[u8], at: usize) -> u64 {
    if let Some(w) = b.get(at..).and_then(<[u8]>::first_chunk::<8>) {
        return u64::from_le_bytes(*w);
    }
    // Near the end: the text's last 8 bytes, those before `at` shifted out.
    if let Some(w) = b.last_chunk::<8>() {
        let before = (at + 8).saturating_sub(b.len());
        return u64::from_le_bytes(*w)
            .checked_shr(8 * before as u32)
            .unwrap_or(0);
    }
    let mut word = 0u64;
    for (k, &c) in b.iter().skip(at).enumerate() {
        word |= u64::from(c) << (8 * k);
    }
    word
}

/// The high bit of each byte of `word` that is no ASCII digit. Exact up to and including
/// the first such byte (all that is read of it).
#[inline(always)]
fn non_digits(word: u64) -> u64 {
    const HIGH_NIBBLES: u64 = 0xF0 * LANES_01;
    // Zero bytes where the high nibble is 3 (0x30..=0x3F), and where adding 6 keeps it 3
    // (0x30..=0x39). A carry out of a byte comes only from a byte >= 0xFA, itself no digit,
    // and reaches only the bytes after it.
    let not_3x = (word & HIGH_NIBBLES) ^ (0x30 * LANES_01);
    let above_9 = (word.wrapping_add(0x06 * LANES_01) & HIGH_NIBBLES) ^ (0x30 * LANES_01);
    let x = not_3x | above_9;
    // The high bit of each byte of x that is not zero (no carries between bytes).
    (((x & (0x7F * LANES_01)) + 0x7F * LANES_01) | x) & (0x80 * LANES_01)
}

/// The value of the `len` (0..=8) digits in the low bytes of `word`, the first digit in the
/// lowest byte: the other bytes are shifted out, and zeros (leading zeros) come in.
#[inline(always)]
fn eight_digits(word: u64, len: usize) -> u64 {
    let Some(mut v) = (word & (0x0F * LANES_01)).checked_shl(8 * (8 - len as u32)) else {
        return 0;
    };
    // Pairs, then fours, then eight digits, each step within its lanes.
    v = (v.wrapping_mul(10) + (v >> 8)) & 0x00FF_00FF_00FF_00FF;
    v = (v.wrapping_mul(100) + (v >> 16)) & 0x0000_FFFF_0000_FFFF;
    (v.wrapping_mul(10_000) + (v >> 32)) & 0xFFFF_FFFF
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
    use proptest::prelude::{TestCaseError, prop_assert_eq};

    fn num(s: &str) -> Result<(f64, bool, usize), String> {
        let cx = Cx::new(s);
        match cx.number(s) {
            Ok((rest, n)) => Ok((n.value, n.has_point, s.len() - rest.len())),
            Err(nom::Err::Failure(e) | nom::Err::Error(e)) => Err(e.msg.to_string()),
            Err(_) => Err("incomplete".into()),
        }
    }

    /// The byte-at-a-time scan `scan_unsigned` replaced, with the std parser's value: the
    /// reference the word-at-a-time scan must equal.
    fn reference_unsigned(i: &str) -> (usize, usize, bool, Option<f64>) {
        let b = i.as_bytes();
        let int = b.iter().take_while(|c| c.is_ascii_digit()).count();
        let mut len = int;
        let mut frac = 0;
        let has_point = b.get(int) == Some(&b'.');
        if has_point {
            frac = b[int + 1..]
                .iter()
                .take_while(|c| c.is_ascii_digit())
                .count();
            len = int + 1 + frac;
        }
        let digits = int + frac;
        let value = if digits == 0 {
            None
        } else {
            i[..len].parse::<f64>().ok()
        };
        (len, digits, has_point, value)
    }

    fn same_as_reference(text: &str) -> Result<(), TestCaseError> {
        let (len, digits, has_point, value) = reference_unsigned(text);
        // Alone, and after text before it (a word's number read within its line).
        for before in ["", "X", "G1 X10.0000 Y", "N1234567 G01 Z"] {
            let line = format!("{before}{text}");
            let u = scan_unsigned_at(line.as_bytes(), before.len());
            prop_assert_eq!(
                (u.len, u.digits, u.has_point),
                (len, digits, has_point),
                "{:?}",
                line
            );
            prop_assert_eq!(
                u.value.map(f64::to_bits),
                value.map(f64::to_bits),
                "{:?}",
                line
            );
        }
        // With a sign, as a word's value is read: the std parser's bits too.
        for sign in ["-", "+"] {
            let signed = format!("{sign}{text}");
            if let (Ok((v, _, n)), Some(_)) = (num(&signed), value) {
                let want: f64 = signed[..n].parse().unwrap();
                prop_assert_eq!(v.to_bits(), want.to_bits(), "{:?}", signed);
            }
        }
        Ok(())
    }

    #[test]
    fn digit_runs_of_every_length_and_alignment() {
        for text in [
            "",
            ".",
            "5.",
            ".5",
            "0",
            "00000000",
            "000000001",
            "12345678",
            "123456789",
            "1234567890123456",
            "999999999999999",
            "9999999999999999",
            "0.000000000000001",
            "18446744073709551615",
            "18446744073709551616",
            "99999999999999999999999",
            "1.2.3",
            "7:",
            "7/",
            "7\u{ff}",
            "12345678\u{fa}9",
            "0.1",
            "9007199254740993",
            "X10.0000",
            "10.0000 Y0.0100",
            ".123456",
            ".1234567",
            "1.23456",
            "123456.7",
            "-5",
            "1e5",
            "12345678.12345678",
        ] {
            same_as_reference(text).unwrap();
        }
    }

    /// Every byte value at every place of a word of digits (and after any byte before it):
    /// the run ends exactly at the first non-digit, whatever carries the test makes.
    #[test]
    fn digit_run_ends_at_the_first_non_digit_byte() {
        for c in 0..=255u8 {
            for before in [b'0', b'9', 0xFF, 0xFA, b'/', b':'] {
                for p in 0..10 {
                    let mut b = b"123456789012".to_vec();
                    b[p] = c;
                    if p > 0 {
                        b[p - 1] = before;
                    }
                    let want = b.iter().take_while(|d| d.is_ascii_digit()).count();
                    let (value, n) = digit_run(&b, 0);
                    assert_eq!(n, want, "{b:?}");
                    let digits: String = b[..n].iter().map(|&d| char::from(d)).collect();
                    assert_eq!(value, digits.parse::<u64>().unwrap_or(0), "{b:?}");
                }
            }
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(20_000))]

        /// Digit strings of any length, points, and the bytes around digits that a SWAR
        /// test could take for one ('/', ':', 0xFA.., 0x30 + 16 ...): length, digit count and
        /// value to the bit as the std parser reads them.
        #[test]
        fn scan_unsigned_reads_as_the_std_parser(
            parts in proptest::collection::vec(proptest::sample::select(vec![
                "0", "1", "5", "9", "00", "0000000", "12345678", "999999999", ".", "/", ":",
                "?", "@", " ", "X", "\u{fa}", "\u{ff}", "\u{c0}", "-", "e",
            ]), 0..12)
        ) {
            same_as_reference(&parts.concat())?;
        }

        /// Every split of up to 10 + 10 digits around a point, with what may follow.
        #[test]
        fn digits_around_a_point_read_as_the_std_parser(
            text in "[0-9]{0,10}(\\.[0-9]{0,10})?[ XY.;]?"
        ) {
            same_as_reference(&text)?;
        }

        /// Numbers as CAM systems print them, with up to 22 decimals.
        #[test]
        fn printed_numbers_read_as_the_std_parser(
            v in -1.0e9f64..1.0e9, decimals in 0usize..22, tail in "[ XY;(.]?"
        ) {
            let text = format!("{:.decimals$}{tail}", v.abs());
            same_as_reference(&text)?;
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
