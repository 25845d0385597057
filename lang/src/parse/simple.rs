//! The fast path for the plain blocks CAM programs are made of (`N10 G1 X1.5 Y-2`): an
//! optional `N` number, then address letters with literal numbers, separated by spaces,
//! tabs and ASCII comments (`(…)`, nested, and `;…`). Such a line is read here without the
//! general parser's machinery; anything else (expressions, statements, flow, block delete,
//! odd characters, errors) returns `None`, and the caller parses the line in full, which
//! gives the same [`Line`] for lines read here (tests/fuzz compare the two).

use super::lex::scan_unsigned_at;
use crate::ast::{Block, Comment, Line, LineKind, Number, SeqNo, Span, Value, Word};

/// Longest sequence number taken here (9 digits always fit a `u32`).
const MAX_N_DIGITS: usize = 9;

fn skip_ws(b: &[u8], mut k: usize) -> usize {
    while k < b.len() && matches!(b[k], b' ' | b'\t') {
        k += 1;
    }
    k
}

/// Skips spaces, tabs and comments from `k` on, handing each comment's span to `comment`
/// (as the general parser's trivia reads them: `(` to its `)`, parentheses nesting, or `;`
/// to the end). `None` at a comment that does not close or holds a byte that is no ASCII
/// (or a `\r`): the general parser's. Inline: most calls see a space and a letter.
#[inline(always)]
fn skip_trivia(b: &[u8], k: usize, comment: &mut impl FnMut(Span)) -> Option<usize> {
    let k = skip_ws(b, k);
    match b.get(k) {
        Some(b'(' | b';') => skip_comments(b, k, comment),
        _ => Some(k),
    }
}

/// [`skip_trivia`] from a comment on. Each round takes 2 bytes or more, so it ends.
#[inline(never)]
fn skip_comments(b: &[u8], mut k: usize, comment: &mut impl FnMut(Span)) -> Option<usize> {
    loop {
        let end = match b.get(k) {
            Some(b'(') => k + 2 + close_paren(&b[k + 1..])?,
            Some(b';') if b[k + 1..].iter().all(|&c| c.is_ascii() && c != b'\r') => b.len(),
            _ => return Some(k),
        };
        comment(Span::new(k, end));
        k = skip_ws(b, end);
    }
}

/// Index of the `)` closing a comment whose body starts `body`, parentheses nesting; `None`
/// when there is none, or a byte before it is no ASCII.
fn close_paren(body: &[u8]) -> Option<usize> {
    let mut depth = 0u32;
    for (k, &c) in body.iter().enumerate() {
        match c {
            b'(' => depth += 1,
            b')' if depth == 0 => return Some(k),
            b')' => depth -= 1,
            0x80.. => return None,
            _ => {}
        }
    }
    None
}

/// Reads `b` (one line, without its terminator) when it is a plain block, handing each
/// word to `word` and each comment's span to `comment` in order; returns the sequence
/// number (if any) and the number of words. `None` when the line is anything else; then
/// `word` and `comment` may have seen some of it.
pub(crate) fn scan(
    b: &[u8],
    mut word: impl FnMut(Word),
    mut comment: impl FnMut(Span),
) -> Option<(Option<SeqNo>, usize)> {
    let mut k = skip_trivia(b, 0, &mut comment)?;
    let mut n = None;
    if matches!(b.get(k), Some(b'N' | b'n')) {
        let start = k;
        let d0 = skip_ws(b, k + 1);
        let mut d = d0;
        while d < b.len() && b[d].is_ascii_digit() {
            d += 1;
        }
        if d == d0 || d - d0 > MAX_N_DIGITS || b.get(d) == Some(&b'.') {
            return None;
        }
        // At most 9 digits: no overflow.
        let value = b[d0..d]
            .iter()
            .fold(0u32, |v, &c| v * 10 + u32::from(c - b'0'));
        n = Some(SeqNo {
            value,
            span: Span::new(start, d),
        });
        k = skip_trivia(b, d, &mut comment)?;
    }
    let mut count = 0;
    while k < b.len() {
        let letter = b[k].to_ascii_uppercase();
        // `N` and `O` inside a block, and two letters in a row (keywords: IF, WHILE, GOTO,
        // END, DO), are the general parser's.
        if !letter.is_ascii_uppercase() || matches!(letter, b'N' | b'O') {
            return None;
        }
        let v = skip_ws(b, k + 1);
        let (neg, digits_at) = match b.get(v) {
            Some(b'-') => (true, v + 1),
            Some(b'+') => (false, v + 1),
            _ => (false, v),
        };
        if !matches!(b.get(digits_at), Some(b'0'..=b'9' | b'.')) {
            return None;
        }
        let u = scan_unsigned_at(b, digits_at);
        let end = digits_at + u.len;
        let value = u.value?;
        // A second point, or a number running into anything but a space or the next
        // letter, is an error (or an expression) for the general parser to describe.
        match b.get(end) {
            None | Some(b' ' | b'\t' | b'(' | b';') => {}
            Some(c) if c.is_ascii_alphabetic() => {}
            _ => return None,
        }
        word(Word {
            letter: char::from(letter),
            value: Value::Number(Number {
                value: if neg { -value } else { value },
                has_point: u.has_point,
                span: Span::new(v, end),
            }),
            span: Span::new(k, end),
        });
        count += 1;
        k = skip_trivia(b, end, &mut comment)?;
    }
    Some((n, count))
}

/// What [`scan`] says of `b` (`Some(true)`: a plain block with an `N` number or a word,
/// `Some(false)`: an empty one, `None`: no plain block), read through a state table for the
/// lines CAM writes most (an `N` number, words and spaces, no comment); a line the table
/// cannot tell is read by [`scan`]. The load pass asks it of every line of a program.
pub(crate) fn classify(b: &[u8]) -> Option<bool> {
    // No early exit: `ASK` keeps itself, and a line that reaches it is read again anyway.
    // Four bytes a round (fewer loop tests); a state is kept as its row's first index.
    let step = |row: u16, c: u8| STEP[(usize::from(row) | usize::from(c)) & (STEP.len() - 1)];
    let (quads, rest) = b.as_chunks::<4>();
    let mut row = u16::from(START) << 8;
    for &[c0, c1, c2, c3] in quads {
        row = step(step(step(step(row, c0), c1), c2), c3);
    }
    for &c in rest {
        row = step(row, c);
    }
    match (row >> 8) as u8 {
        START => Some(false),
        BETWEEN | INT | FRAC | N_DIGIT..=N_LAST_DIGIT => Some(true),
        _ => classify_by_scan(b),
    }
}

/// [`classify`] by the full [`scan`] (also what [`classify`] is tested against).
pub(crate) fn classify_by_scan(b: &[u8]) -> Option<bool> {
    let (n, words) = scan(b, |_| {}, |_| {})?;
    Some(n.is_some() || words > 0)
}

// The states of [`classify`]: only spaces read yet; between words; after an address letter;
// after its sign; after a point with no digit yet; in the integer digits; in the fraction;
// `ASK`: the table cannot tell, [`scan`] reads the line; after the `N`; after its k-th digit
// (`N_DIGIT + k - 1`, at most MAX_N_DIGITS).
const START: u8 = 0;
const BETWEEN: u8 = 1;
const LETTER: u8 = 2;
const SIGN: u8 = 3;
const POINT: u8 = 4;
const INT: u8 = 5;
const FRAC: u8 = 6;
const ASK: u8 = 7;
const N_LETTER: u8 = 8;
const N_DIGIT: u8 = 9;
const N_LAST_DIGIT: u8 = N_DIGIT + MAX_N_DIGITS as u8 - 1;

/// The state after `state` reads byte `c`, as [`scan`] reads a line: an optional `N` with
/// 1 to [`MAX_N_DIGITS`] digits and no point, then words — a letter (not `N`/`O`), spaces,
/// a sign, digits with one point and at least one digit — each ended by a space, the next
/// letter or the end. Everything else asks.
const fn next_state(state: u8, c: u8) -> u8 {
    let letter = c.is_ascii_alphabetic() && !matches!(c, b'N' | b'n' | b'O' | b'o');
    let ws = matches!(c, b' ' | b'\t');
    match (state, c) {
        (START, _) if ws => START,
        (START, b'N' | b'n') => N_LETTER,
        (N_LETTER | LETTER, _) if ws => state,
        (N_LETTER, b'0'..=b'9') => N_DIGIT,
        (N_DIGIT..N_LAST_DIGIT, b'0'..=b'9') => state + 1,
        (START | BETWEEN | INT | FRAC | N_DIGIT..=N_LAST_DIGIT, _) if letter => LETTER,
        (BETWEEN | INT | FRAC | N_DIGIT..=N_LAST_DIGIT, _) if ws => BETWEEN,
        (LETTER | SIGN | INT, b'0'..=b'9') => INT,
        (LETTER | SIGN, b'.') => POINT,
        (LETTER, b'+' | b'-') => SIGN,
        (POINT | FRAC, b'0'..=b'9') | (INT, b'.') => FRAC,
        _ => ASK,
    }
}

/// [`next_state`] of every state and byte, one row of 256 a state (32 rows, a power of two:
/// every index masked to the table is in it), each as the index of its row's first entry.
static STEP: [u16; 32 * 256] = {
    let mut t = [(ASK as u16) << 8; 32 * 256];
    let mut i = 0;
    while i < t.len() {
        let state = (i >> 8) as u8;
        if state <= N_LAST_DIGIT {
            t[i] = (next_state(state, i as u8) as u16) << 8;
        }
        i += 1;
    }
    t
};

/// The [`Line`] of `text` (line `line_no`) when it is a plain block, as the general parser
/// makes it.
pub(crate) fn line(text: &str, line_no: u32) -> Option<Line> {
    let mut line = Line {
        line_no,
        span: Span::new(0, 0),
        block_delete: false,
        n: None,
        kind: LineKind::Empty,
        comments: Vec::new(),
    };
    line_into(text, line_no, &mut line).then_some(line)
}

/// Makes `line` the [`Line`] of `text` (line `line_no`) when it is a plain block, keeping
/// the vectors it had (a streamed program reads every block into one line); `false`, and
/// `line` is to be overwritten, when `text` is no plain block.
pub(crate) fn line_into(text: &str, line_no: u32, line: &mut Line) -> bool {
    let mut block = match std::mem::replace(&mut line.kind, LineKind::Empty) {
        LineKind::Block(b) => b,
        // One allocation, as the general parser makes: words are rarely shorter than 4 bytes.
        _ => Block {
            words: Vec::with_capacity((text.len() / 4 + 1).min(16)),
            named_axes: Vec::new(),
        },
    };
    block.words.clear();
    block.named_axes.clear();
    line.comments.clear();
    let comments = &mut line.comments;
    let scanned = scan(
        text.as_bytes(),
        |w| block.words.push(w),
        |span| {
            // The text between `(` and `)`, or after `;`.
            let end = span.end as usize - usize::from(text.as_bytes()[span.start as usize] == b'(');
            comments.push(Comment {
                text: text[span.start as usize + 1..end].to_string(),
                span,
            });
        },
    );
    let Some((n, count)) = scanned else {
        line.kind = LineKind::Block(block);
        return false;
    };
    line.line_no = line_no;
    line.span = Span::new(0, text.len());
    line.block_delete = false;
    line.n = n;
    if count > 0 {
        line.kind = LineKind::Block(block);
    }
    true
}
