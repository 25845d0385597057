//! A plain block's words straight from its bytes, for a reader that runs the commonest CAM
//! lines without building their [`Line`](crate::ast::Line): the same scan (and so the same
//! numbers, bit for bit) as the parser's fast path for plain blocks.

use crate::ast::Value;

/// The words of `body` (one line as read, without its terminator) when it is a plain block
/// without comments — an optional `N` number, then words of an address letter and a literal
/// number — each handed to `word` as (upper-case letter, value, whether it was written with a
/// point); returns the `N` number, if any, and how many words there were. `None` when the
/// line is anything else (a comment, an expression, a flow line, an error…): then `word` may
/// have seen some of it, and the line is the parser's.
///
/// ```
/// use cnc402_lang::plain::words;
/// let mut seen = Vec::new();
/// let r = words(b"N20 G1 x-1.5 Y2", |l, v, p| seen.push((l, v, p)));
/// assert_eq!(r, Some((Some(20), 3)));
/// assert_eq!(seen, [(b'G', 1.0, false), (b'X', -1.5, true), (b'Y', 2.0, false)]);
/// assert_eq!(words(b"G1 X1 (cut)", |_, _, _| {}), None);
/// assert_eq!(words(b"G1 X[1+2]", |_, _, _| {}), None);
/// ```
pub fn words(body: &[u8], mut word: impl FnMut(u8, f64, bool)) -> Option<(Option<u32>, usize)> {
    let mut comment = false;
    let (n, count) = crate::parse::simple::scan(
        body,
        |w| {
            if let Value::Number(v) = w.value {
                // `scan` folds the letter to upper case: it is ASCII.
                word(w.letter as u8, v.value, v.has_point);
            }
        },
        |_| comment = true,
    )?;
    (!comment).then_some((n.map(|n| n.value), count))
}
