//! A plain block's words straight from its bytes, for a reader that runs the commonest CAM
//! lines without building their [`Line`](crate::ast::Line): the same scan (and so the same
//! numbers, bit for bit) as the parser's fast path for plain blocks.

use crate::ast::Value;

/// Where [`words`] hands a line's words.
pub trait WordSink {
    /// The next word: its upper-case letter, its value, and whether it was written with a
    /// point.
    fn word(&mut self, letter: u8, value: f64, point: bool);
    /// Forget the words handed so far: the line is read again from its start.
    fn restart(&mut self);
}

/// Collects the words in order (tests and examples).
impl WordSink for Vec<(u8, f64, bool)> {
    fn word(&mut self, letter: u8, value: f64, point: bool) {
        self.push((letter, value, point));
    }
    fn restart(&mut self) {
        self.clear();
    }
}

/// The words of `body` (one line as read, without its terminator) when it is a plain block
/// without comments — an optional `N` number, then words of an address letter and a literal
/// number — each handed to `sink`; returns the `N` number, if any, and how many words there
/// were. `None` when the line is anything else (a comment, an expression, a flow line, an
/// error…): then `sink` may have seen some of it, and the line is the parser's.
///
/// ```
/// use cnc402_lang::plain::words;
/// let mut seen = Vec::new();
/// let r = words(b"N20 G1 x-1.5 Y2", &mut seen);
/// assert_eq!(r, Some((Some(20), 3)));
/// assert_eq!(seen, [(b'G', 1.0, false), (b'X', -1.5, true), (b'Y', 2.0, false)]);
/// assert_eq!(words(b"G1 X1 (cut)", &mut seen), None);
/// assert_eq!(words(b"G1 X[1+2]", &mut seen), None);
/// ```
pub fn words(body: &[u8], sink: &mut impl WordSink) -> Option<(Option<u32>, usize)> {
    if let Some(read) = tight(body, sink) {
        return Some(read);
    }
    sink.restart();
    let mut comment = false;
    let (n, count) = crate::parse::simple::scan(
        body,
        |w| {
            if let Value::Number(v) = w.value {
                // `scan` folds the letter to upper case: it is ASCII.
                sink.word(w.letter as u8, v.value, v.has_point);
            }
        },
        |_| comment = true,
    )?;
    (!comment).then_some((n.map(|n| n.value), count))
}

/// [`words`] of the lines CAM writes most, read in one pass: an optional `N` number and words
/// of an upper-case letter directly followed by its number, separated by spaces; `None` (the
/// full scan decides) at anything else. What it reads, it reads as the full scan does: the
/// same number scanner, the same rules for what may follow a number.
fn tight(b: &[u8], sink: &mut impl WordSink) -> Option<(Option<u32>, usize)> {
    let mut k = 0;
    let mut n = None;
    if b.first() == Some(&b'N') {
        let mut v = 0u32;
        k = 1;
        while let Some(&c @ b'0'..=b'9') = b.get(k) {
            // At most 9 digits: no overflow.
            if k > 9 {
                return None;
            }
            v = v * 10 + u32::from(c - b'0');
            k += 1;
        }
        if k == 1 || b.get(k) == Some(&b'.') {
            return None;
        }
        n = Some(v);
    }
    let mut count = 0;
    loop {
        while b.get(k) == Some(&b' ') {
            k += 1;
        }
        let Some(&letter) = b.get(k) else {
            return Some((n, count));
        };
        if !letter.is_ascii_uppercase() || matches!(letter, b'N' | b'O') {
            return None;
        }
        // `G0`/`G1`, in nearly every CAM line: the value the scanner gives a lone digit.
        if letter == b'G'
            && let Some(&d @ (b'0' | b'1')) = b.get(k + 1)
            && b.get(k + 2)
                .is_none_or(|&c| c == b' ' || c.is_ascii_uppercase())
        {
            sink.word(letter, f64::from(d - b'0'), false);
            count += 1;
            k += 2;
            continue;
        }
        let (neg, at) = match b.get(k + 1) {
            Some(b'-') => (true, k + 2),
            Some(b'+') => (false, k + 2),
            _ => (false, k + 1),
        };
        if !matches!(b.get(at), Some(b'0'..=b'9' | b'.')) {
            return None;
        }
        let u = crate::parse::lex::scan_unsigned_at(b, at);
        let value = u.value?;
        k = at + u.len;
        match b.get(k) {
            None | Some(b' ') => {}
            Some(c) if c.is_ascii_uppercase() => {}
            _ => return None,
        }
        let value = if neg { -value } else { value };
        sink.word(letter, value, u.has_point);
        count += 1;
    }
}

#[cfg(test)]
mod tests {
    use proptest::prelude::*;

    /// A line's `N` number and words (letter, value's bits, written with a point).
    type Read = Option<(Option<u32>, Vec<(u8, u64, bool)>)>;

    /// [`super::words`] by the full scan alone.
    fn by_scan(b: &[u8]) -> Read {
        let mut seen = Vec::new();
        let mut comment = false;
        let (n, _) = crate::parse::simple::scan(
            b,
            |w| {
                if let crate::ast::Value::Number(v) = w.value {
                    seen.push((w.letter as u8, v.value.to_bits(), v.has_point));
                }
            },
            |_| comment = true,
        )?;
        (!comment).then_some((n.map(|n| n.value), seen))
    }

    fn by_words(b: &[u8]) -> Read {
        let mut words = Vec::new();
        let (n, count) = super::words(b, &mut words)?;
        assert_eq!(count, words.len());
        let seen = words
            .into_iter()
            .map(|(l, v, p)| (l, v.to_bits(), p))
            .collect();
        Some((n, seen))
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4096))]

        /// The one-pass reading gives what the full scan gives, bit for bit, on lines built
        /// from the bytes CAM lines are made of (and some that are not).
        #[test]
        fn the_tight_reading_is_the_full_scans(
            parts in prop::collection::vec(prop_oneof![
                4 => prop::sample::select(vec!["G", "X", "Y", "Z", "F", "N", "A", "x", "O"])
                    .prop_map(String::from),
                6 => "[0-9]{1,8}",
                2 => Just(".".to_string()),
                2 => Just(" ".to_string()),
                1 => prop::sample::select(vec!["-", "+", "\t", "(c)", ";", "  ", "#1", "[", "e"])
                    .prop_map(String::from),
                1 => Just("1".repeat(30)),
            ], 0..14),
        ) {
            let line = parts.concat();
            prop_assert_eq!(by_words(line.as_bytes()), by_scan(line.as_bytes()), "{:?}", line);
        }
    }

    #[test]
    fn cam_lines_are_read_tight() {
        for line in [
            "G1 X10.0000 Y0.0100",
            "N120 G01 X-1.5 Y+2. Z.5 F3000",
            "G0 X1",
            "G1",
            "G1X2",
            "G10 L2",
            "G1.5",
            "X1Y2",
            "N5",
            " G1 X1",
        ] {
            assert!(
                super::tight(line.as_bytes(), &mut Vec::new()).is_some(),
                "{line}"
            );
            assert_eq!(by_words(line.as_bytes()), by_scan(line.as_bytes()));
        }
        for line in ["g1 x1", "G1 X 1", "G1\tX1", "N1234567890 X1", "G1 X1 (c)"] {
            assert!(
                super::tight(line.as_bytes(), &mut Vec::new()).is_none(),
                "{line}"
            );
        }
    }
}
