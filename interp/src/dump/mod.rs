//! The segment dump: one JSON object per segment (JSON Lines), the interpreter's stable contract
//! that `cnc402 segments` prints and the golden tests compare byte for byte. Numbers are rounded
//! to 1e-6 and printed in their shortest form (`10`, `-2.5`, `0.000001`); keys come in a fixed
//! order. It is written by hand rather than through serde_json (a dev-dependency here, used by
//! the tests to parse it back) because the key order and number format are the contract.
//!
//! Keys: `kind` (`rapid` `linear` `tap` `arc` `dwell` `spindle` `spindle_orient` `tool_change`
//! `coolant` `stop` `message`),
//! `file`, `line`, `n` (N number or null); motion kinds add `end` (axis name → absolute machine
//! position of every configured axis, mm or degrees); `linear`, `tap` and `arc` add `feed`
//! (mm/min); `tap` adds `tool` and `spindle` (the coupled axes' names) and `pitch` (mm per
//! spindle turn, signed: pitch / 360 = Δtool / Δspindle);
//! `arc` adds `center` (`X` `Y` `Z`, machine coordinates; the normal axis holds the start's
//! value), `plane` (`XY` `ZX` `YZ`), `dir` (`cw` `ccw`) and `turns` (1 = full circle);
//! `dwell` adds `seconds`; `spindle` adds `rpm` and `dir` (`cw` `ccw` `stop`);
//! `spindle_orient` adds `angle` (the physical spindle angle in degrees) and, for G28/G30 C,
//! `program` (the spindle axis's program position from then on: its reference); `tool_change`
//! adds `tool`; `coolant` adds `mist` and `flood` (booleans: the state from here on); `stop` adds `stop` (`program` `optional` `end` `end_rewind`); `message` adds
//! `text`. Every segment ends with `ends`: `exact_stop`, or `continuous` followed by
//! `tolerance` (mm, G64).
//!
//! The spindle axis C is the program's view: it starts at 0 and moves only with rigid taps,
//! C words and G28/G30 C (which set it to the reference); speed-mode runs (M3/M4) and
//! orientation do not otherwise change it, because the motion layer keeps their turn in the
//! spindle offset (machine C − program C).

use std::fmt::Write;

use cnc402_config::MachineConfig;

use crate::words::fmt_num;

pub mod canon;
#[cfg(test)]
mod reference;
use cnc402_motion::segment::{
    ArcDir, AxisPos, Plane, Segment, SegmentEnd, SegmentKind, Source, SpindleDir, StopKind,
    TapSegment,
};

/// `v` rounded to 1e-6 in its shortest decimal form ([`fmt_num`], the interpreter's one number
/// format); `-0` prints as `0`. The block layer refuses any non-finite number at its word,
/// so none comes from the interpreter; a hand-made segment's prints as `null`, never as
/// invalid JSON.
///
/// ```
/// use cnc402_interp::dump::num;
/// assert_eq!(num(10.0), "10");
/// assert_eq!(num(-2.50000004), "-2.5");
/// assert_eq!(num(-0.0000001), "0");
/// assert_eq!(num(1.0 / 3.0), "0.333333");
/// ```
pub fn num(v: f64) -> String {
    let mut o = String::new();
    write_num(&mut o, v);
    o
}

/// [`num`] written onto `o` without allocating: a segment dump prints millions of numbers.
/// Below 1e9 the rounded value is k·1e-6 with |k| < 1e15; a decimal of at most 15
/// significant digits is the shortest form of the nearest double (which is what `fmt_num`
/// prints), so printing k's digits with the point put back gives the same text.
///
/// ```
/// use cnc402_interp::dump::{num, write_num};
/// for v in [0.0, -0.0, 1.5, -2.50000004, 1e-7, 123456.0000004, 999999999.9999996, 1e300] {
///     let mut o = String::new();
///     write_num(&mut o, v);
///     assert_eq!(o, cnc402_interp::words::fmt_num(v), "{v}");
/// }
/// ```
pub fn write_num(o: &mut String, v: f64) {
    if !v.is_finite() {
        o.push_str("null");
        return;
    }
    if v.abs() >= 1e9 {
        o.push_str(&fmt_num(v));
        return;
    }
    // `(v * 1e6).round()` as an integer, without the call `round` is on x86-64: below 1e15
    // (< 2^52) the truncation and the rest `x - t` are exact, so rounding half away from zero
    // comes out the same.
    let x = v * 1e6;
    let t = x as i64;
    let rest = x - t as f64;
    let k = t + i64::from(rest >= 0.5) - i64::from(rest <= -0.5);
    if k == 0 {
        o.push('0');
        return;
    }
    let neg = k < 0;
    let k = k.unsigned_abs();
    let (whole, frac) = (k / 1_000_000, (k % 1_000_000) as usize);
    // Sign, whole part, point and fraction without its trailing zeros, written straight
    // into `o`'s spare room: below 1e9 (1e9 itself after rounding) that is at most
    // 1 + 10 + 7 bytes.
    let mut text = [0u8; WINDOW];
    let mut at = usize::from(neg);
    text[0] = b'-';
    let whole_digits = whole.checked_ilog10().unwrap_or(0) as usize + 1;
    at += whole_digits;
    digits_before(&mut text, at, whole);
    if frac != 0 {
        let (a, b, c) = (frac / 10_000, frac / 100 % 100, frac % 100);
        text[at] = b'.';
        put_pair(&mut text, at + 1, a);
        put_pair(&mut text, at + 3, b);
        put_pair(&mut text, at + 5, c);
        // The text ends after the last digit that is not 0.
        let zeros = match (b, c) {
            (_, c) if c != 0 => usize::from(c % 10 == 0),
            (b, _) if b != 0 => 2 + usize::from(b % 10 == 0),
            _ => 4 + usize::from(a % 10 == 0),
        };
        at += 7 - zeros;
    }
    push_window(o, &text, 0, at);
}

/// How many bytes [`push_window`] copies at a time: more than any number it is given.
const WINDOW: usize = 24;

/// Appends `buf[at..at + len]` (`len` ≤ [`WINDOW`]) to `o` by copying the [`WINDOW`] bytes
/// from `at` and cutting off the rest: a copy of a size known when compiling is a few
/// moves, where one of a few bytes of a size known only at run time is a call to `memcpy`,
/// and the window's ASCII check is a few word tests, not a loop. Callers fill `buf` with
/// ASCII only (digits, sign, point, quotes, ASCII axis names) and leave a window after `at`.
#[inline(always)]
fn push_window(o: &mut String, buf: &[u8], at: usize, len: usize) {
    let window = buf.get(at..).and_then(|b| b.first_chunk::<WINDOW>());
    match window {
        Some(window) if window.is_ascii() && len <= WINDOW => {
            // SAFETY: the window is ASCII (checked just above), so `o` is valid UTF-8 after
            // the copy and after the cut, which falls on one of the copied ASCII bytes.
            let v = unsafe { o.as_mut_vec() };
            let keep = v.len() + len;
            v.extend_from_slice(window);
            v.truncate(keep);
        }
        // Not reached with this module's callers; still right (and checked) if it were.
        _ => push_ascii(o, buf.get(at..at + len).unwrap_or_default()),
    }
}

/// Appends the ASCII bytes `a` (a piece of known size: no call to `memcpy`, and the ASCII
/// check is a word test); anything else is left out, as [`push_ascii`] does.
#[inline(always)]
fn push_array<const N: usize>(o: &mut String, a: &[u8; N]) {
    if a.is_ascii() {
        // SAFETY: ASCII bytes (checked just above) are valid UTF-8 on their own.
        unsafe { o.as_mut_vec() }.extend_from_slice(a);
    }
}

/// Writes `v` (< 100) as two digits at `buf[at..at + 2]`.
#[inline(always)]
fn put_pair(buf: &mut [u8], at: usize, v: usize) {
    buf[at..at + 2].copy_from_slice(&PAIRS[2 * v..2 * v + 2]);
}

/// "00" to "99": two decimal digits at a time.
const PAIRS: &[u8; 200] = b"\
0001020304050607080910111213141516171819\
2021222324252627282930313233343536373839\
4041424344454647484950515253545556575859\
6061626364656667686970717273747576777879\
8081828384858687888990919293949596979899";

/// Writes `v`'s decimal digits into `buf` ending before `at`; returns where they start.
fn digits_before(buf: &mut [u8], mut at: usize, mut v: u64) -> usize {
    while v >= 100 {
        at -= 2;
        put_pair(buf, at, (v % 100) as usize);
        v /= 100;
    }
    if v >= 10 {
        at -= 2;
        put_pair(buf, at, v as usize);
    } else {
        at -= 1;
        buf[at] = b'0' + v as u8;
    }
    at
}

/// Appends ASCII bytes (digits, sign, point) to `o`.
fn push_ascii(o: &mut String, bytes: &[u8]) {
    // Checking a few digits as UTF-8 (`push_str(from_utf8(..))`) or pushing them one `char`
    // at a time costs as much as making them; every caller passes ASCII only.
    debug_assert!(bytes.is_ascii());
    if !bytes.is_ascii() {
        return;
    }
    // SAFETY: ASCII bytes (checked just above) are valid UTF-8 on their own, so `o` stays
    // valid UTF-8.
    unsafe { o.as_mut_vec() }.extend_from_slice(bytes);
}

/// `s` as a JSON string literal: `"` `\` and control characters (U+0000 to U+001F) escaped,
/// everything else (non-ASCII too) as UTF-8, which JSON allows.
pub fn json_str(s: &str) -> String {
    let mut o = String::with_capacity(s.len() + 2);
    write_json_str(&mut o, s);
    o
}

/// `v`'s decimal digits written onto `o` (what `{v}` prints, without the formatter).
fn push_u64(o: &mut String, v: u64) {
    // u64::MAX has 20 digits.
    let mut buf = [b'0'; 20 + WINDOW];
    let at = digits_before(&mut buf, 20, v);
    push_window(o, &buf, at, 20 - at);
}

/// [`json_str`] written onto `o`.
pub fn write_json_str(o: &mut String, s: &str) {
    o.push('"');
    for c in s.chars() {
        match c {
            '"' => o.push_str("\\\""),
            '\\' => o.push_str("\\\\"),
            '\n' => o.push_str("\\n"),
            '\r' => o.push_str("\\r"),
            '\t' => o.push_str("\\t"),
            c if (c as u32) < 0x20 => {
                let _ = write!(o, "\\u{:04x}", c as u32);
            }
            c => o.push(c),
        }
    }
    o.push('"');
}

/// `,"<key>":{"X":…}` with every configured axis.
pub(crate) fn axes_obj(o: &mut String, key: &str, end: &AxisPos, cfg: &MachineConfig) {
    o.push_str(",\"");
    o.push_str(key);
    o.push_str("\":{");
    for (i, ax) in cfg.axes.iter().enumerate() {
        if ax.name.is_ascii() {
            // `,"X":` (the first axis without its comma) as a piece of known size.
            let name = ax.name as u8;
            if i > 0 {
                push_array(o, &[b',', b'"', name, b'"', b':']);
            } else {
                push_array(o, &[b'"', name, b'"', b':']);
            }
        } else {
            if i > 0 {
                o.push(',');
            }
            o.push('"');
            o.push(ax.name);
            o.push_str("\":");
        }
        write_num(o, end[i]);
    }
    o.push('}');
}

/// The `kind` a segment prints as.
pub fn kind_name(kind: &SegmentKind) -> &'static str {
    match kind {
        SegmentKind::Rapid { .. } => "rapid",
        SegmentKind::Linear { .. } => "linear",
        SegmentKind::Tap(_) => "tap",
        SegmentKind::Arc { .. } => "arc",
        SegmentKind::Dwell { .. } => "dwell",
        SegmentKind::Spindle { .. } => "spindle",
        SegmentKind::SpindleOrient { .. } => "spindle_orient",
        SegmentKind::ToolChange { .. } => "tool_change",
        SegmentKind::Coolant { .. } => "coolant",
        SegmentKind::Stop { .. } => "stop",
        SegmentKind::Message { .. } => "message",
    }
}

/// `{"<key>":"<name>","file":…,"line":…,"n":…` (the object stays open).
pub(crate) fn source_keys(o: &mut String, key: &str, name: &str, source: &Source) {
    source_keys_with(o, key, name, source, None);
}

/// [`source_keys`] with the file name already escaped (`file_json`, when known).
fn source_keys_with(
    o: &mut String,
    key: &str,
    name: &str,
    source: &Source,
    file_json: Option<&str>,
) {
    o.push_str("{\"");
    o.push_str(key);
    o.push_str("\":\"");
    o.push_str(name);
    o.push_str("\",\"file\":");
    match file_json {
        Some(f) => o.push_str(f),
        None => write_json_str(o, &source.file),
    }
    o.push_str(",\"line\":");
    push_u64(o, u64::from(source.line));
    o.push_str(",\"n\":");
    match source.n {
        Some(n) => push_u64(o, u64::from(n)),
        None => o.push_str("null"),
    }
}

/// `,"spindle":N` for a spindle other than the first (dumps of one-spindle programs stay as
/// they were).
pub(crate) fn spindle_number(o: &mut String, spindle: u8) {
    if spindle != 1 {
        let _ = write!(o, ",\"spindle\":{spindle}");
    }
}

/// The keys of `kind` after the source keys: positions, feed, arc, event data.
pub(crate) fn kind_keys(o: &mut String, kind: &SegmentKind, cfg: &MachineConfig) {
    match kind {
        SegmentKind::Rapid { end } => axes_obj(o, "end", end, cfg),
        SegmentKind::Linear { end, feed } => {
            axes_obj(o, "end", end, cfg);
            o.push_str(",\"feed\":");
            write_num(o, *feed);
        }
        SegmentKind::Tap(TapSegment {
            end,
            feed,
            tool,
            spindle,
            pitch,
        }) => {
            axes_obj(o, "end", end, cfg);
            let name = |i: u8| cfg.axes.get(usize::from(i)).map_or('?', |a| a.name);
            o.push_str(",\"feed\":");
            write_num(o, *feed);
            o.push_str(",\"tool\":\"");
            o.push(name(*tool));
            o.push_str("\",\"spindle\":\"");
            o.push(name(*spindle));
            o.push_str("\",\"pitch\":");
            write_num(o, *pitch);
        }
        SegmentKind::Arc {
            end,
            center,
            plane,
            dir,
            turns,
            feed,
        } => {
            axes_obj(o, "end", end, cfg);
            o.push_str(",\"center\":{\"X\":");
            write_num(o, center[0]);
            o.push_str(",\"Y\":");
            write_num(o, center[1]);
            o.push_str(",\"Z\":");
            write_num(o, center[2]);
            o.push_str(match plane {
                Plane::XY => "},\"plane\":\"XY\"",
                Plane::ZX => "},\"plane\":\"ZX\"",
                Plane::YZ => "},\"plane\":\"YZ\"",
            });
            o.push_str(match dir {
                ArcDir::Cw => ",\"dir\":\"cw\",\"turns\":",
                ArcDir::Ccw => ",\"dir\":\"ccw\",\"turns\":",
            });
            push_u64(o, u64::from(*turns));
            o.push_str(",\"feed\":");
            write_num(o, *feed);
        }
        SegmentKind::Dwell { seconds } => {
            let _ = write!(o, ",\"seconds\":{}", num(*seconds));
        }
        SegmentKind::Spindle { rpm, dir, spindle } => {
            let dir = match dir {
                SpindleDir::Cw => "cw",
                SpindleDir::Ccw => "ccw",
                SpindleDir::Stop => "stop",
            };
            let _ = write!(o, ",\"rpm\":{},\"dir\":\"{dir}\"", num(*rpm));
            spindle_number(o, *spindle);
        }
        SegmentKind::SpindleOrient {
            angle,
            program,
            spindle,
        } => {
            let _ = write!(o, ",\"angle\":{}", num(*angle));
            if let Some(c) = program {
                let _ = write!(o, ",\"program\":{}", num(*c));
            }
            spindle_number(o, *spindle);
        }
        SegmentKind::ToolChange { tool } => {
            let _ = write!(o, ",\"tool\":{tool}");
        }
        SegmentKind::Coolant { mist, flood } => {
            let _ = write!(o, ",\"mist\":{mist},\"flood\":{flood}");
        }
        SegmentKind::Stop { kind } => {
            let k = match kind {
                StopKind::Program => "program",
                StopKind::Optional => "optional",
                StopKind::End => "end",
                StopKind::EndRewind => "end_rewind",
                StopKind::WaitMark { mark, channels } => {
                    let _ = write!(
                        o,
                        ",\"stop\":\"wait_mark\",\"mark\":{mark},\"channels\":{channels}"
                    );
                    return;
                }
            };
            let _ = write!(o, ",\"stop\":\"{k}\"");
        }
        SegmentKind::Message { text } => {
            let _ = write!(o, ",\"text\":{}", json_str(text));
        }
    }
}

/// One segment as a single-line JSON object (no trailing newline).
///
/// ```
/// use cnc402_config::MachineConfig;
/// use cnc402_interp::dump::segment_to_json;
/// use cnc402_motion::segment::{AxisPos, Segment, SegmentEnd, SegmentKind, Source};
/// let cfg = MachineConfig::default_machine();
/// let mut end = AxisPos::default();
/// end[0] = 12.5;
/// let seg = Segment {
///     kind: SegmentKind::Linear { end, feed: 300.0 },
///     source: Source { file: "a.nc".into(), line: 3, n: Some(30) },
///     ends: SegmentEnd::Continuous { tolerance: 0.01, collinear: 0.0 },
/// };
/// assert_eq!(segment_to_json(&seg, &cfg),
///     r#"{"kind":"linear","file":"a.nc","line":3,"n":30,"end":{"X":12.5,"Y":0,"Z":0,"C":0},"feed":300,"ends":"continuous","tolerance":0.01}"#);
/// ```
pub fn segment_to_json(seg: &Segment, cfg: &MachineConfig) -> String {
    let mut o = String::with_capacity(160);
    write_segment(&mut o, seg, cfg, None, None);
    o
}

/// [`segment_to_json`] appended to `o`; `file_json`: the source file's name already escaped;
/// `last`: the text of the numbers that repeat from one segment to the next, when kept.
fn write_segment(
    o: &mut String,
    seg: &Segment,
    cfg: &MachineConfig,
    file_json: Option<&str>,
    mut last: Option<&mut Repeated>,
) {
    source_keys_with(o, "kind", kind_name(&seg.kind), &seg.source, file_json);
    match (&seg.kind, last.as_deref_mut()) {
        (SegmentKind::Linear { end, feed }, Some(last)) => {
            axes_obj(o, "end", end, cfg);
            o.push_str(",\"feed\":");
            last.feed.write(o, *feed);
        }
        (kind, _) => kind_keys(o, kind, cfg),
    }
    match seg.ends {
        SegmentEnd::ExactStop => o.push_str(",\"ends\":\"exact_stop\""),
        SegmentEnd::Continuous {
            tolerance,
            collinear,
        } => {
            o.push_str(",\"ends\":\"continuous\",\"tolerance\":");
            match last {
                Some(last) => last.tolerance.write(o, tolerance),
                None => write_num(o, tolerance),
            }
            if collinear > 0.0 {
                o.push_str(",\"collinear\":");
                write_num(o, collinear);
            }
        }
    }
    o.push('}');
}

/// The numbers most segments of a program share with the one before (the feed of a run of
/// moves, the path tolerance), kept as text.
#[derive(Default)]
struct Repeated {
    feed: NumText,
    tolerance: NumText,
}

/// A number's [`write_num`] text, kept for as long as the same number comes again.
#[derive(Default)]
struct NumText {
    /// The number's bits (-0 and 0 apart: their texts are the same anyway).
    bits: u64,
    text: String,
}

impl NumText {
    /// Appends `v`'s text to `o`, made again only when `v` is not the last number.
    fn write(&mut self, o: &mut String, v: f64) {
        if self.text.is_empty() || v.to_bits() != self.bits {
            self.text.clear();
            write_num(&mut self.text, v);
            self.bits = v.to_bits();
        }
        o.push_str(&self.text);
    }
}

/// Writes segments as JSON Lines, as [`segment_to_json`] does, for a long dump: it remembers
/// the last source file's escaped name (a program's segments share it), and the last feed's
/// and tolerance's text, so each line costs no allocation and no second pass over them.
///
/// ```
/// use cnc402_config::MachineConfig;
/// use cnc402_interp::dump::{SegmentWriter, segment_to_json};
/// use cnc402_motion::segment::{Segment, SegmentEnd, SegmentKind, Source};
/// let cfg = MachineConfig::default_machine();
/// let seg = Segment {
///     kind: SegmentKind::Dwell { seconds: 0.5 },
///     source: Source { file: "a \"b\".nc".into(), line: 3, n: None },
///     ends: SegmentEnd::ExactStop,
/// };
/// let mut o = String::new();
/// let mut w = SegmentWriter::default();
/// w.write_line(&mut o, &seg, &cfg);
/// w.write_line(&mut o, &seg, &cfg);
/// let one = segment_to_json(&seg, &cfg) + "\n";
/// assert_eq!(o, one.repeat(2));
/// ```
#[derive(Default)]
pub struct SegmentWriter {
    /// The last source file and its name as a JSON string literal.
    file: Option<(std::sync::Arc<str>, String)>,
    /// The last feed and tolerance and their text.
    last: Repeated,
}

impl SegmentWriter {
    /// Appends `seg` as one JSON line (with its `\n`) to `o`.
    pub fn write_line(&mut self, o: &mut String, seg: &Segment, cfg: &MachineConfig) {
        let file = &seg.source.file;
        let cached = self
            .file
            .as_ref()
            .is_some_and(|(f, _)| std::sync::Arc::ptr_eq(f, file) || **f == **file);
        if !cached {
            self.file = Some((file.clone(), json_str(file)));
        }
        let file_json = self.file.as_ref().map(|(_, j)| j.as_str());
        write_segment(o, seg, cfg, file_json, Some(&mut self.last));
        o.push('\n');
    }
}

/// Every segment as JSON Lines (each line ends in `\n`).
pub fn segments_to_jsonl(segs: &[Segment], cfg: &MachineConfig) -> String {
    let mut o = String::with_capacity(segs.len() * 120);
    for s in segs {
        o.push_str(&segment_to_json(s, cfg));
        o.push('\n');
    }
    o
}

#[cfg(test)]
mod tests {
    use super::*;
    use cnc402_motion::segment::Source;

    fn seg(kind: SegmentKind) -> Segment {
        Segment {
            kind,
            source: Source {
                file: "q\"x.nc".into(),
                line: 7,
                n: None,
            },
            ends: SegmentEnd::ExactStop,
        }
    }

    /// Strings (file names, MSG texts) come from users: every control character, quote,
    /// backslash and non-ASCII character must survive a JSON parser unchanged.
    #[test]
    fn json_str_escapes_every_string_so_a_parser_reads_it_back() {
        assert_eq!(
            json_str("a\"b\\c\n\r\t\u{1}\u{1f}"),
            r#""a\"b\\c\n\r\t\u0001\u001f""#
        );
        assert_eq!(json_str("Ø ✓ 𝄞"), "\"Ø ✓ 𝄞\"");
        let mut all: String = (0u32..0x80).filter_map(char::from_u32).collect();
        all.push_str("\u{7f}\u{80}\u{a0}é\u{2028}\u{2029}\u{fffd}\u{10ffff}/");
        let j = json_str(&all);
        assert!(
            !j.chars().any(|c| (c as u32) < 0x20),
            "raw control char in {j:?}"
        );
        let back: String = serde_json::from_str(&j).unwrap_or_else(|e| panic!("{j}: {e}"));
        assert_eq!(back, all);
    }

    #[test]
    fn every_kind_is_valid_json_with_its_keys() {
        let cfg = MachineConfig::default_machine();
        let kinds = [
            SegmentKind::Rapid {
                end: AxisPos::default(),
            },
            SegmentKind::Arc {
                end: AxisPos::default(),
                center: [1.0, 2.0, 3.0],
                plane: Plane::ZX,
                dir: ArcDir::Ccw,
                turns: 1,
                feed: 100.0,
            },
            SegmentKind::Tap(TapSegment {
                end: AxisPos::default(),
                feed: 600.0,
                tool: 2,
                spindle: 3,
                pitch: -1.25,
            }),
            SegmentKind::Dwell { seconds: 0.5 },
            SegmentKind::Spindle {
                rpm: 800.0,
                dir: SpindleDir::Ccw,
                spindle: 1,
            },
            SegmentKind::SpindleOrient {
                angle: 271.5,
                program: None,
                spindle: 1,
            },
            SegmentKind::ToolChange { tool: 4 },
            SegmentKind::Coolant {
                mist: false,
                flood: true,
            },
            SegmentKind::Stop {
                kind: StopKind::EndRewind,
            },
            SegmentKind::Message {
                text: "a\tb \"c\"\u{1}".into(),
            },
        ];
        let want = [
            ("rapid", "end"),
            ("arc", "center"),
            ("tap", "pitch"),
            ("dwell", "seconds"),
            ("spindle", "rpm"),
            ("spindle_orient", "angle"),
            ("tool_change", "tool"),
            ("coolant", "flood"),
            ("stop", "stop"),
            ("message", "text"),
        ];
        for (k, (name, key)) in kinds.into_iter().zip(want) {
            let j = segment_to_json(&seg(k), &cfg);
            let v: serde_json::Value =
                serde_json::from_str(&j).unwrap_or_else(|e| panic!("{j}: {e}"));
            assert_eq!(v["kind"], name);
            assert_eq!(v["file"], "q\"x.nc");
            assert_eq!(v["line"], 7);
            assert!(v["n"].is_null());
            assert!(!v[key].is_null(), "{j}");
            assert_eq!(v["ends"], "exact_stop", "{j}");
        }
    }

    #[test]
    fn a_tap_names_its_axes_and_pitch_and_every_segment_how_it_ends() {
        let cfg = MachineConfig::default_machine();
        let mut s = seg(SegmentKind::Tap(TapSegment {
            end: AxisPos::default(),
            feed: 600.0,
            tool: 2,
            spindle: 3,
            pitch: -1.25,
        }));
        assert_eq!(
            segment_to_json(&s, &cfg),
            r#"{"kind":"tap","file":"q\"x.nc","line":7,"n":null,"end":{"X":0,"Y":0,"Z":0,"C":0},"feed":600,"tool":"Z","spindle":"C","pitch":-1.25,"ends":"exact_stop"}"#
        );
        s.kind = SegmentKind::Rapid {
            end: AxisPos::default(),
        };
        s.ends = SegmentEnd::Continuous {
            tolerance: 0.05,
            collinear: 0.0,
        };
        assert_eq!(
            segment_to_json(&s, &cfg),
            r#"{"kind":"rapid","file":"q\"x.nc","line":7,"n":null,"end":{"X":0,"Y":0,"Z":0,"C":0},"ends":"continuous","tolerance":0.05}"#
        );
    }

    #[test]
    fn numbers_are_rounded_and_minimal() {
        assert_eq!(num(0.1 + 0.2), "0.3");
        assert_eq!(num(-1e-7), "0");
        assert_eq!(num(123456.0000004), "123456");
        assert_eq!(num(f64::NAN), "null");
    }

    #[test]
    fn spindle_orient_has_its_angle() {
        let cfg = MachineConfig::default_machine();
        let j = segment_to_json(
            &seg(SegmentKind::SpindleOrient {
                angle: 90.25,
                program: None,
                spindle: 1,
            }),
            &cfg,
        );
        assert_eq!(
            j,
            r#"{"kind":"spindle_orient","file":"q\"x.nc","line":7,"n":null,"angle":90.25,"ends":"exact_stop"}"#
        );
        // G28/G30 C: program C reads the reference afterwards.
        let j = segment_to_json(
            &seg(SegmentKind::SpindleOrient {
                angle: 270.0,
                program: Some(-90.0),
                spindle: 1,
            }),
            &cfg,
        );
        assert_eq!(
            j,
            r#"{"kind":"spindle_orient","file":"q\"x.nc","line":7,"n":null,"angle":270,"program":-90,"ends":"exact_stop"}"#
        );
    }
}

#[cfg(test)]
mod num_tests {
    use super::*;

    /// `write_num` is the dump's fast path of `fmt_num`: the same text for every value.
    #[test]
    fn write_num_prints_what_fmt_num_prints() {
        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            x
        };
        // Halves of the last digit, which round away from zero, and the ends of the range.
        let halves = [
            0.5e-6,
            -0.5e-6,
            1.5e-6,
            -2.5e-6,
            0.1234565,
            -7.0000005,
            999_999_999.999_999_5,
            -999_999_999.999_999_5,
            999_999_999.999_999,
            1e9,
            -1e9,
        ];
        for v in halves {
            let mut o = String::new();
            write_num(&mut o, v);
            assert_eq!(o, fmt_num(v), "{v:e}");
        }
        for _ in 0..200_000 {
            let r = next();
            let mag = 10f64.powi((r % 20) as i32 - 8);
            let v = ((next() >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 2.0 * mag;
            for v in [v, (v * 1e4).round() / 1e4, v.trunc()] {
                let mut o = String::new();
                write_num(&mut o, v);
                assert_eq!(o, fmt_num(v), "{v:e}");
            }
        }
    }
}
