//! The Heidenhain conversational (Klartext) subset cnc402 reads: each line of a program that
//! starts with `BEGIN PGM` (or is named `*.h`) is translated, as it is read, into the ISO
//! block the interpreter already executes, line for line (errors keep the line number):
//! `L`, `LP`, `CC` + `C`, `CP IPA IZ` (helices), `CR`, `CT`, `RND`, `CHF` ([`arcs`]), Q
//! parameters as values ([`qparams`]), `TOOL CALL`, `CYCL DEF 7/9/200/201/205/207` with
//! their calls, labels ([`labels`]), M functions, comments, `BLK FORM`.
//! What is outside the subset is an error at its line, never a block read another way.

mod arcs;
mod contour;
mod labels;
mod qparams;
mod words;

use std::io::BufRead;

use contour::Xy;
use words::{Word, split_words};

/// Most lines a contour block looks ahead for an `RND`/`CHF` and the block after it
/// (comments and empty lines between them count).
pub const AHEAD_LINES: usize = 8;

/// Whether a program is Heidenhain conversational: named `*.h`, or its first line (after
/// the block number) is `BEGIN PGM`.
pub fn is_heidenhain(name: &str, first_line: &str) -> bool {
    let lower = name.to_ascii_lowercase();
    lower.ends_with(".h") || body(first_line).starts_with("BEGIN PGM")
}

/// A line without its block number.
fn body(line: &str) -> &str {
    let t = line.trim_start();
    let digits = t.len() - t.trim_start_matches(|c: char| c.is_ascii_digit()).len();
    if digits > 0 && t[digits..].starts_with([' ', '\t']) {
        t[digits..].trim()
    } else {
        t.trim()
    }
}

/// The translation state: what one line leaves for the next (the circle centre `CC`, the
/// tool called, the tool length still to be switched on, the units of `BEGIN PGM`).
#[derive(Clone, Debug, Default)]
pub struct Translator {
    centre: Option<(f64, f64)>,
    tool: Option<u32>,
    /// `TOOL CALL` switched the tool's length on: the next move along the tool axis takes it
    /// (G43 H, as the iTNC applies it from that move).
    length_pending: bool,
    /// Modal words for the first block after `BEGIN PGM` (units, absolute centres).
    preamble: Option<String>,
    /// Where the tool is as far as the program has said (absolute X, Y, Z words).
    at: [Option<f64>; 3],
    /// The last F of a path block, and whether the next must write it again (a cycle's
    /// feed took the ISO F over).
    feed: Option<f64>,
    refeed: bool,
    /// The cycle defined (200 or 207) and its Q parameters so far; whether a G81/G82/G84/G74
    /// is active in the ISO translation (the next block cancels it).
    defined: u32,
    drilling: Option<Vec<(u32, f64)>>,
    /// The S of the last `TOOL CALL` (cycle 207 taps at it).
    speed: Option<f64>,
    cycle_active: bool,
    labels: labels::Labels,
    /// The machine's G83 re-entry clearance (`interp.peck_clearance`): cycle 205 is read
    /// as a G83 only with its advanced stop distances equal to it.
    peck_clearance: Option<f64>,
    /// `BEGIN PGM … INCH`: lengths in inches, feeds in 1/10 inch/min.
    inch: bool,
    /// The datum shift of cycle 7 (X, Y, Z, program units) the G54 entry holds on top of
    /// its own.
    shift: [f64; 3],
    /// The Q parameters' values so far, and whether the lines read are a cycle's
    /// definition (its `Q2xx=` lines after `CYCL DEF`).
    q: qparams::QTable,
    defining: bool,
    /// The direction the last contour element in the plane ended in (for `CT`).
    tangent: Option<Xy>,
    /// The `RND`/`CHF` the last `L` saw ahead of it: computed there (the `L` ends where the
    /// corner starts), emitted at its own line; or why it cannot be.
    corner: Option<Result<contour::Corner, String>>,
}

impl Translator {
    /// A translator for a machine whose G83 re-entry clearance is `peck_clearance` (the
    /// clearance cnc402 runs a G83 with; `None`: cycle 205 is not read).
    pub fn for_machine(peck_clearance: Option<f64>) -> Translator {
        Translator {
            peck_clearance,
            ..Translator::default()
        }
    }

    /// The ISO text of one line (`index` 0 is the first: it starts the program afresh), or
    /// what is wrong with it.
    pub fn line(&mut self, index: usize, line: &str) -> Result<String, String> {
        self.line_ahead(index, line, &[])
    }

    /// As [`Self::line`], with the lines after it (`ahead`, as many as [`looks_ahead`]
    /// asks for: an `L` needs them to end where an `RND` or `CHF` after it begins).
    pub fn line_ahead(
        &mut self,
        index: usize,
        line: &str,
        ahead: &[String],
    ) -> Result<String, String> {
        if index == 0 {
            *self = Translator::for_machine(self.peck_clearance);
        }
        let text = body(line);
        let was_active = self.cycle_active;
        let mut out = self.translate(text, ahead)?;
        // A flow line (a label's O, WHILE, END, M98, M99) or a datum shift's incremental
        // G10 takes no modal words: they wait for the next block (after a shift: G90).
        if out.is_empty() || out.starts_with('(') || labels::is_flow(&out) {
            return Ok(out);
        }
        self.labels.note_end(&out);
        if was_active && self.cycle_active && !(out.contains(" G8") || out.contains(" G74")) {
            out = format!("G80 {out}");
            self.cycle_active = false;
        }
        if out.contains("G91 G10") {
            let p = self.preamble.take().unwrap_or_else(|| "G90".into());
            self.preamble = Some(if p.contains("G90") {
                p
            } else {
                format!("{p} G90")
            });
            return Ok(out);
        }
        Ok(match self.preamble.take() {
            Some(p) => format!("{p} {out}"),
            None => out,
        })
    }

    fn translate(&mut self, text: &str, ahead: &[String]) -> Result<String, String> {
        if text.is_empty() {
            return Ok(String::new());
        }
        if let Some(c) = text.strip_prefix(';').or_else(|| text.strip_prefix('*')) {
            return Ok(comment(c));
        }
        // A comment after the block.
        let (text, tail) = match text.split_once(';') {
            Some((t, c)) => (t.trim(), comment(c)),
            None => (text, String::new()),
        };
        let mut out = self
            .block(text, ahead)
            .or_else(|m| qparams::alarm_if_unset(&m))?;
        if !tail.is_empty() {
            out = if out.is_empty() {
                tail
            } else {
                format!("{out} {tail}")
            };
        }
        Ok(out)
    }

    fn block(&mut self, text: &str, ahead: &[String]) -> Result<String, String> {
        let head = text.split_once(' ').map_or(text, |(h, _)| h);
        if head.starts_with('Q') || head == "FN" {
            return self.q_parameter(text);
        }
        self.defining = false;
        let corner = self.corner.take();
        if !matches!(head, "L" | "C" | "CC" | "CR" | "CT" | "CP" | "RND" | "CHF")
            && !head.starts_with('M')
        {
            self.tangent = None;
        }
        let text = self.q.substitute(text)?;
        let (head, rest) = text.split_once(' ').unwrap_or((&text, ""));
        match head {
            "RND" | "CHF" => self.rounding(head, corner),
            "CR" => self.radius_arc(rest),
            "CT" => self.tangent_arc(rest),
            "BEGIN" => self.begin(rest),
            "END" if rest.starts_with("PGM") => Ok(String::new()),
            "BLK" if rest.starts_with("FORM") => Ok(String::new()),
            "TOOL" if rest.starts_with("CALL") => self.tool_call(&rest[4..]),
            "L" => self.line_move(rest, ahead),
            "LP" => {
                let cartesian = self.polar_line(rest)?;
                self.line_move(&cartesian, ahead)
            }
            "CC" => self.centre(rest),
            "C" => self.arc(rest),
            "CP" => self.polar_arc(rest),
            "CYCL"
                if ["DEF 200", "DEF 201", "DEF 205", "DEF 207"]
                    .iter()
                    .any(|d| rest.starts_with(d)) =>
            {
                self.defined = rest[4..7].parse().unwrap_or(0);
                self.drilling = Some(Vec::new());
                self.defining = true;
                Ok(String::new())
            }
            "CYCL" if rest.trim() == "CALL" => {
                let [x, y, _] = self.at;
                match (x, y) {
                    (Some(x), Some(y)) => {
                        self.drill(&[format!("X{}", fmt(x)), format!("Y{}", fmt(y))])
                    }
                    _ => Err("CYCL CALL before X and Y are known".into()),
                }
            }
            "CYCL" if rest.starts_with("DEF 7.") => self.datum_shift(rest),
            "CYCL" => cycle(rest),
            "LBL" => self.labels.label(rest),
            "CALL" if rest.trim_start().starts_with("LBL") => self.labels.call(rest),
            "STOP" => {
                let m = if rest.trim().is_empty() {
                    "M0"
                } else {
                    rest.trim()
                };
                Ok(m.to_string())
            }
            _ if head.starts_with('M') => Ok(m_words(&split_words(&text)?)?.join(" ")),
            _ => Err(format!(
                "{head} is not in the Heidenhain subset cnc402 reads (expected L, CC, C, CR, CT, \
                 CP, RND, CHF, Qn =, FN 0-4, TOOL CALL, CYCL DEF 7/9/200/201/205/207, LBL, CALL \
                 LBL, M, STOP, BLK FORM, a comment)"
            )),
        }
    }

    fn begin(&mut self, rest: &str) -> Result<String, String> {
        let mut parts = rest.split_whitespace();
        if parts.next() != Some("PGM") {
            return Err("expected BEGIN PGM NAME MM|INCH".into());
        }
        let name = parts.next().unwrap_or("");
        let units = match parts.next() {
            Some("MM") => "G21",
            Some("INCH") => "G20",
            _ => return Err("expected BEGIN PGM NAME MM|INCH".into()),
        };
        self.inch = units == "G20";
        self.preamble = Some(format!("{units} G90 G90.1 G17"));
        Ok(format!("(dialect: fanuc) (BEGIN PGM {name})"))
    }

    /// `TOOL CALL n Z S.. F..`: a tool change (with `n`), a speed; the length follows.
    fn tool_call(&mut self, rest: &str) -> Result<String, String> {
        let mut out = Vec::new();
        let mut parts = rest.split_whitespace().peekable();
        if let Some(n) = parts.peek().and_then(|p| p.parse::<u32>().ok()) {
            parts.next();
            out.push(format!("T{n} M6"));
            self.tool = Some(n);
            self.length_pending = n != 0;
        }
        if parts.next() != Some("Z") {
            return Err("TOOL CALL needs the tool axis Z (the only one cnc402 reads)".into());
        }
        for p in parts {
            if let Some(s) = p.strip_prefix('S') {
                let s = number(s)?;
                self.speed = Some(s);
                out.push(format!("S{s}"));
            } else if p.starts_with("DL") || p.starts_with("DR") {
                return Err(format!("{p}: tool deltas are not in the subset"));
            } else if !p.starts_with('F') {
                return Err(format!("{p} is not a TOOL CALL word cnc402 reads"));
            }
        }
        Ok(out.join(" "))
    }

    /// `Qn = …` or `FN k: Qn = …`: the parameter's new value; inside a cycle's definition
    /// (the lines after `CYCL DEF`) also one of the cycle's parameters.
    fn q_parameter(&mut self, text: &str) -> Result<String, String> {
        let (n, v) = self.q.assign(text)?;
        if self.defining {
            let params = self.drilling.get_or_insert_with(Vec::new);
            if params.len() >= 24 {
                return Err("more Q parameters than CYCL DEF 200, 205 or 207 has".into());
            }
            params.push((n, v));
        }
        Ok(String::new())
    }

    /// A call of `CYCL DEF 200` or `207` at `xy` (the `X Y` words): the G81/G82 (200) or
    /// G84/G74 with M29 (207) block that does what the iTNC does. Read: a negative depth in
    /// one plunge (200: Q202 at least the depth, no dwell at the top); it returns to the 2nd
    /// set-up clearance (G98: the tool must be there at the call, the initial level) or,
    /// with Q204 not above Q200, to the set-up clearance (G99).
    fn drill(&mut self, xy: &[String]) -> Result<String, String> {
        let Some(params) = self.drilling.as_ref() else {
            return Err("a cycle call without a CYCL DEF 200, 205 or 207 before it".into());
        };
        let cycle = self.defined;
        let q = |n: u32| {
            params
                .iter()
                .rev()
                .find(|(k, _)| *k == n)
                .map(|(_, v)| *v)
                .ok_or_else(|| format!("CYCL DEF {cycle} without Q{n}"))
        };
        let (clear, depth, surface, clear2) = (q(200)?, q(201)?, q(203)?, q(204)?);
        if depth >= 0.0 {
            return Err(format!(
                "CYCL DEF {cycle} is read with a negative depth (Q201)"
            ));
        }
        let (code, tail) = match cycle {
            207 => rigid_tap(q(239)?, self.speed)?,
            205 => {
                let stops = [q(258)?, q(259)?];
                let rest = [q(212)?, q(257)?, q(211)?, q(379)?];
                // The machine's clearance (mm) in the program's length unit.
                let clearance = self
                    .peck_clearance
                    .map(|d| if self.inch { d / 25.4 } else { d });
                pecking(
                    q(206)? * self.feed_scale(),
                    q(202)?,
                    stops,
                    rest,
                    depth,
                    clearance,
                )?
            }
            201 => {
                let scale = self.feed_scale();
                reaming(q(206)? * scale, q(208)? * scale, q(211)?)?
            }
            _ => drilling(
                q(206)? * self.feed_scale(),
                q(202)?,
                q(210)?,
                q(211)?,
                depth,
            )?,
        };
        let r = surface + clear;
        let mode = if clear2 > clear {
            let level = surface + clear2;
            if self.at[2].is_none_or(|z| (z - level).abs() > 1e-6) {
                return Err(format!(
                    "the tool is not at the 2nd set-up clearance (Z{}) at the cycle call",
                    fmt(level)
                ));
            }
            "G98"
        } else {
            self.at[2] = Some(r);
            "G99"
        };
        let mut out = vec![mode.to_string(), code];
        out.extend(xy.iter().cloned());
        out.push(format!("Z{} R{}", fmt(surface + depth), fmt(r)));
        out.extend(tail);
        self.cycle_active = true;
        self.refeed = true;
        Ok(out.join(" "))
    }

    /// `CYCL DEF 7.0 DATUM SHIFT` (nothing yet) and `7.1`–`7.3 X|Y|Z±v` (`IX`: added):
    /// the G54 entry moved by the change of the shift (`G91 G10 L2 P1`), so that the
    /// program's zero is the machine's G54 plus the shift, as on the iTNC (whose shifts are
    /// from its preset, cnc402's G54).
    fn datum_shift(&mut self, rest: &str) -> Result<String, String> {
        let mut parts = rest.split_whitespace().skip(1);
        let step = parts.next().unwrap_or("");
        if step == "7.0" {
            return Ok(String::new());
        }
        let word = parts.next().unwrap_or("");
        let (incremental, word) = match word.strip_prefix('I') {
            Some(w) => (true, w),
            None => (false, word),
        };
        let axis = "XYZ".find(word.chars().next().unwrap_or(' '));
        let (Some(axis), Some(value), None) = (axis, word.get(1..), parts.next()) else {
            return Err(format!(
                "CYCL DEF {step} {word}: cnc402 reads datum shifts along X, Y or Z by a value \
                 (no datum table numbers)"
            ));
        };
        let value = number(value)?;
        let new = if incremental {
            self.shift[axis] + value
        } else {
            value
        };
        let change = new - self.shift[axis];
        self.shift[axis] = new;
        // Where the tool is in the shifted coordinates is no longer known.
        self.at = [None; 3];
        let letter = &"XYZ"[axis..=axis];
        Ok(format!("G91 G10 L2 P1 {letter}{}", fmt(change)))
    }

    /// The words of a path block, its F in the ISO program's unit (an INCH program's F is
    /// in 1/10 inch/min, G20's in inch/min).
    fn path_words(&self, text: &str) -> Result<Vec<Word>, String> {
        let mut words = split_words(text)?;
        for w in &mut words {
            if let Word::Feed(f) = w {
                *f *= self.feed_scale();
            }
        }
        Ok(words)
    }

    fn feed_scale(&self) -> f64 {
        if self.inch { 0.1 } else { 1.0 }
    }

    /// Keeps where the tool is and the feed from a path block's words.
    fn follow(&mut self, words: &[Word]) {
        for w in words {
            match w {
                Word::Axis(l, v) => {
                    if let Some(i) = "XYZ".find(*l) {
                        self.at[i] = Some(*v);
                    }
                }
                Word::Feed(f) => {
                    self.feed = Some(*f);
                    self.refeed = false;
                }
                _ => {}
            }
        }
    }

    /// The F a feed block must write again after a cycle took the ISO F over.
    fn feed_again(&mut self, words: &[Word], rapid: bool) -> Option<String> {
        if rapid || !self.refeed || words.iter().any(|w| matches!(w, Word::Feed(_))) {
            return None;
        }
        self.refeed = false;
        self.feed.map(|f| format!("F{}", fmt(f)))
    }

    /// `L X.. Y.. Z.. R0|RL|RR F..|FMAX M..`.
    fn line_move(&mut self, rest: &str, ahead: &[String]) -> Result<String, String> {
        let mut words = self.path_words(rest)?;
        if words.contains(&Word::M(99)) {
            self.tangent = None;
            let axes = axis_words(&words)?;
            if axes.iter().any(|a| !a.starts_with(['X', 'Y']))
                || words
                    .iter()
                    .any(|w| !matches!(w, Word::Axis(..) | Word::Fmax | Word::R0 | Word::M(99)))
            {
                return Err("a cycle call L … M99 is read with X, Y, R0 and FMAX only".into());
            }
            self.follow(&words);
            let out = self.drill(&axes)?;
            return Ok(out);
        }
        let (start, end) = (self.xy(), self.plane_end(&words));
        self.corner = self.corner_ahead(start, &words, ahead);
        if let Some(Ok(c)) = &self.corner {
            set_xy(&mut words, c.leg_end);
        }
        // A move along the tool axis only leaves no direction in the plane for a CT.
        let moved_z = words.iter().any(|w| matches!(w, Word::Axis('Z', _)));
        self.tangent = match (start, end) {
            (Some(s), Some(e)) => {
                contour::unit(contour::sub(e, s)).or(if moved_z { None } else { self.tangent })
            }
            _ => None,
        };
        let refeed = self.feed_again(&words, words.contains(&Word::Fmax));
        self.follow(&words);
        let rapid = words.iter().any(|w| matches!(w, Word::Fmax));
        let mut out = vec![if rapid { "G0" } else { "G1" }.to_string()];
        out.extend(self.compensation(&words)?);
        let axes = axis_words(&words)?;
        if self.length_pending && axes.iter().any(|a| a.starts_with('Z')) {
            out.push(format!("G43 H{}", self.tool.unwrap_or(0)));
            self.length_pending = false;
        }
        out.extend(axes);
        out.extend(feed_words(&words));
        out.extend(refeed);
        out.extend(m_words(&words)?);
        Ok(out.join(" "))
    }

    fn compensation(&self, words: &[Word]) -> Result<Option<String>, String> {
        let d = || self.tool.unwrap_or(0);
        Ok(words.iter().find_map(|w| match w {
            Word::R0 => Some("G40".to_string()),
            Word::Rl => Some(format!("G41 D{}", d())),
            Word::Rr => Some(format!("G42 D{}", d())),
            _ => None,
        }))
    }

    /// `CC X.. Y..`: the centre of the next `C`.
    fn centre(&mut self, rest: &str) -> Result<String, String> {
        let words = split_words(rest)?;
        let get = |l: char| {
            words.iter().find_map(|w| match w {
                Word::Axis(a, v) if *a == l => Some(*v),
                _ => None,
            })
        };
        match (get('X'), get('Y')) {
            (Some(x), Some(y)) if words.len() == 2 => {
                self.centre = Some((x, y));
                Ok(String::new())
            }
            _ => Err("CC needs X and Y (absolute), nothing else".into()),
        }
    }

    /// `C X.. Y.. DR+|DR- R0 F.. M..`: an arc about the last `CC`, to an absolute end.
    fn arc(&mut self, rest: &str) -> Result<String, String> {
        let words = self.path_words(rest)?;
        let Some((cx, cy)) = self.centre else {
            return Err("C without a CC before it".into());
        };
        let dir = words.iter().find_map(|w| match w {
            Word::Dr(ccw) => Some(if *ccw { "G3" } else { "G2" }),
            _ => None,
        });
        let Some(dir) = dir else {
            return Err("C needs DR+ or DR-".into());
        };
        let mut out = vec![dir.to_string()];
        out.extend(self.compensation(&words)?);
        let axes = axis_words(&words)?;
        if axes.iter().any(|a| !a.starts_with(['X', 'Y'])) {
            return Err("C moves X and Y only in the subset (no helix)".into());
        }
        let refeed = self.feed_again(&words, false);
        self.follow(&words);
        self.tangent = self.xy().map(|end| {
            let ccw = dir == "G3";
            contour::Arc {
                end,
                centre: (cx, cy),
                ccw,
            }
            .end_tangent()
        });
        out.extend(axes);
        out.push(format!("I{} J{}", fmt(cx), fmt(cy)));
        out.extend(feed_words(&words));
        out.extend(refeed);
        out.extend(m_words(&words)?);
        Ok(out.join(" "))
    }
}

/// The most a `CP` may sweep: one turn (cnc402's Fanuc arcs have no turn count).
const MAX_SWEEP: f64 = 360.0;

impl Translator {
    /// `CP IPA±a [IZ±dz] DR± [R0|RL|RR] [F] [M]`: an arc (a helix with IZ) about the last
    /// `CC` by the incremental polar angle `a` (signed as DR), from where the tool is: the
    /// G2/G3 to the end that angle gives, Z by dz, the centre absolute. Up to one turn.
    fn polar_arc(&mut self, rest: &str) -> Result<String, String> {
        let (mut ipa, mut iz, mut others) = (None, 0.0, Vec::new());
        for w in rest.split_whitespace() {
            if let Some(v) = w.strip_prefix("IPA") {
                ipa = Some(number(v)?);
            } else if let Some(v) = w.strip_prefix("IZ") {
                iz = number(v)?;
            } else {
                others.push(w);
            }
        }
        let Some(ipa) = ipa else {
            return Err("CP is read with IPA (the incremental polar angle), not PA or PR".into());
        };
        let words = self.path_words(&others.join(" "))?;
        if words.iter().any(|w| matches!(w, Word::Axis(..))) {
            return Err("CP is read with IPA and IZ only (no absolute axis words)".into());
        }
        let ccw = words.iter().find_map(|w| match w {
            Word::Dr(ccw) => Some(*ccw),
            _ => None,
        });
        let Some(ccw) = ccw.filter(|ccw| *ccw == (ipa > 0.0)) else {
            return Err("CP needs DR+ with a positive IPA or DR- with a negative one".into());
        };
        if ipa.abs() > MAX_SWEEP + 1e-9 {
            return Err(format!("CP is read up to one turn (|IPA| <= {MAX_SWEEP})"));
        }
        let Some((cx, cy)) = self.centre else {
            return Err("CP without a CC before it".into());
        };
        let [Some(x), Some(y), Some(z)] = self.at else {
            return Err("CP needs the tool's X, Y and Z known (an absolute L before it)".into());
        };
        // A whole turn ends where it began (not a hair off it, which would be no turn).
        let (ex, ey) = if (ipa.abs() - MAX_SWEEP).abs() <= 1e-9 {
            (x, y)
        } else {
            let (s, c) = ipa.to_radians().sin_cos();
            (
                cx + (x - cx) * c - (y - cy) * s,
                cy + (x - cx) * s + (y - cy) * c,
            )
        };
        let mut out = vec![if ccw { "G3" } else { "G2" }.to_string()];
        out.extend(self.compensation(&words)?);
        if self.length_pending && iz != 0.0 {
            out.push(format!("G43 H{}", self.tool.unwrap_or(0)));
            self.length_pending = false;
        }
        let refeed = self.feed_again(&words, false);
        self.follow(&words);
        self.at = [Some(ex), Some(ey), Some(z + iz)];
        self.tangent = Some(
            contour::Arc {
                end: (ex, ey),
                centre: (cx, cy),
                ccw,
            }
            .end_tangent(),
        );
        out.push(format!("X{} Y{} Z{}", fmt(ex), fmt(ey), fmt(z + iz)));
        out.push(format!("I{} J{}", fmt(cx), fmt(cy)));
        out.extend(feed_words(&words));
        out.extend(refeed);
        out.extend(m_words(&words)?);
        Ok(out.join(" "))
    }
}

/// Whether a line is a straight `L` (it may end where an `RND`/`CHF` after it begins: the
/// reader hands it the [`AHEAD_LINES`] lines after it).
pub fn looks_ahead(line: &str) -> bool {
    let b = body(line);
    b.starts_with("L ") || b.starts_with("LP ")
}

/// Up to [`AHEAD_LINES`] lines of `input` from where it is (byte offset `at`), which is
/// where it is again afterwards: from the reader's buffer when they are there (no seek).
/// (`max_line`: the longest line the reader reads, so a line read ahead is as bounded.)
pub fn peek_lines<R: BufRead + std::io::Seek + ?Sized>(
    input: &mut R,
    at: u64,
    max_line: usize,
) -> std::io::Result<Vec<String>> {
    let lines_of = |bytes: &[u8]| -> Vec<String> {
        bytes
            .split(|b| *b == b'\n')
            .take(AHEAD_LINES)
            .map(|l| {
                String::from_utf8_lossy(l)
                    .trim_end_matches('\r')
                    .to_string()
            })
            .collect()
    };
    let buffered = input.fill_buf()?;
    // The end of the last line ahead, looking no further than those lines (not the whole
    // buffer: an L reads a few lines, whatever the buffer's size).
    let last_end = buffered
        .iter()
        .enumerate()
        .filter(|(_, b)| **b == b'\n')
        .nth(AHEAD_LINES - 1)
        .map(|(i, _)| i);
    if let Some(end) = last_end {
        return Ok(lines_of(&buffered[..end]));
    }
    if buffered.is_empty() {
        return Ok(Vec::new());
    }
    // The lines ahead run past the buffer: read them (each as long as a line may be) and
    // go back.
    let mut bytes = Vec::new();
    for _ in 0..AHEAD_LINES {
        let limit = max_line as u64 + 1;
        if std::io::Read::take(&mut *input, limit).read_until(b'\n', &mut bytes)? == 0 {
            break;
        }
    }
    std::io::Seek::seek(input, std::io::SeekFrom::Start(at))?;
    Ok(lines_of(bytes.strip_suffix(b"\n").unwrap_or(&bytes)))
}

/// The words with the plane's end point `xy` (X and Y words set or added).
fn set_xy(words: &mut Vec<Word>, xy: Xy) {
    for (letter, v) in [('X', xy.0), ('Y', xy.1)] {
        match words
            .iter_mut()
            .find(|w| matches!(w, Word::Axis(l, _) if *l == letter))
        {
            Some(w) => *w = Word::Axis(letter, v),
            None => {
                let at = words
                    .iter()
                    .position(|w| !matches!(w, Word::Axis(..)))
                    .unwrap_or(words.len());
                words.insert(at, Word::Axis(letter, v));
            }
        }
    }
    // X before Y, as the ISO block writes them.
    let axes: Vec<usize> = (0..words.len())
        .filter(|i| matches!(words[*i], Word::Axis(..)))
        .collect();
    let mut sorted: Vec<Word> = axes.iter().map(|i| words[*i].clone()).collect();
    sorted.sort_by_key(|w| match w {
        Word::Axis(l, _) => "XYZABC".find(*l).unwrap_or(6),
        _ => 7,
    });
    for (i, w) in axes.into_iter().zip(sorted) {
        words[i] = w;
    }
}

/// Cycle 200's ISO code and words after Z R: one plunge (Q202 ≥ |Q201|), no dwell at the
/// top; G82 P with a dwell at the depth.
fn drilling(
    feed: f64,
    plunge: f64,
    top_dwell: f64,
    dwell: f64,
    depth: f64,
) -> Result<(String, Vec<String>), String> {
    if plunge < -depth - 1e-9 || top_dwell != 0.0 {
        return Err(
            "CYCL DEF 200 is read in one plunge (Q202 ≥ |Q201|) and with no dwell \
                    at the top (Q210=0)"
                .into(),
        );
    }
    Ok(dwelling(["G81", "G82"], dwell, feed))
}

/// `codes[0]` without a dwell, `codes[1]` with `P` (ms), then `F`: the words after Z R.
fn dwelling(codes: [&str; 2], dwell: f64, feed: f64) -> (String, Vec<String>) {
    let mut tail = Vec::new();
    if dwell > 0.0 {
        tail.push(format!("P{}", (dwell * 1000.0).round()));
    }
    tail.push(format!("F{}", fmt(feed)));
    (codes[usize::from(dwell > 0.0)].into(), tail)
}

/// Cycle 201's ISO code and words after Z R: Fanuc's G85 (G89 P with a dwell at the depth),
/// in and out at the feed — read only with the retraction feed Q208 the plunging feed Q206.
fn reaming(feed: f64, retract: f64, dwell: f64) -> Result<(String, Vec<String>), String> {
    if (retract - feed).abs() > 1e-9 * feed.abs().max(1.0) {
        return Err(
            "CYCL DEF 201 is read with the retraction feed Q208 equal to Q206 (G85/G89 feed \
             out as they feed in)"
                .into(),
        );
    }
    Ok(dwelling(["G85", "G89"], dwell, feed))
}

/// Cycle 205's ISO code and words after Z R: Fanuc's G83 (Q the plunging depth), which
/// cnc402 runs as cycle 205 runs with no decrement (Q212=0), no chip breaking (Q257=0), no
/// dwell (Q211=0), no deepened start (Q379=0) and both advanced stop distances (Q258, Q259)
/// equal to the machine's G83 re-entry clearance: back to the set-up clearance after each
/// plunge, down at rapid to that distance above the last depth, on at the feed. A plunge
/// shorter than that distance re-enters differently (cnc402 stops at R): not read.
fn pecking(
    feed: f64,
    plunge: f64,
    stops: [f64; 2],
    rest: [f64; 4],
    depth: f64,
    clearance: Option<f64>,
) -> Result<(String, Vec<String>), String> {
    let Some(d) = clearance else {
        return Err(
            "CYCL DEF 205 is read only where the machine's G83 clearance is known \
                    (cnc402 segments, run)"
                .into(),
        );
    };
    // The distances as the program writes them (4 decimals) stand for the machine's.
    if stops.iter().any(|s| (s - d).abs() > 0.5e-4 + 1e-9) {
        return Err(format!(
            "CYCL DEF 205 is read with Q258 = Q259 = the machine's G83 clearance \
             (interp.peck_clearance = {d})"
        ));
    }
    if rest.iter().any(|v| *v != 0.0) {
        return Err("CYCL DEF 205 is read with Q212, Q257, Q211 and Q379 all 0".into());
    }
    if plunge <= 0.0 || (plunge < -depth - 1e-9 && plunge < d - 1e-9) {
        return Err(format!(
            "CYCL DEF 205 is read with a plunging depth Q202 of at least the clearance {d}"
        ));
    }
    let plunge = plunge.min(-depth);
    Ok((
        "G83".into(),
        vec![format!("Q{}", fmt(plunge)), format!("F{}", fmt(feed))],
    ))
}

/// Cycle 207's ISO code and words: a rigid tap (`M29`, so it runs coupled from a stopped
/// spindle as from a turning one) at the `TOOL CALL`'s S, the feed S × |pitch| (G94),
/// right-hand G84 for a positive pitch, left-hand G74 for a negative one.
fn rigid_tap(pitch: f64, speed: Option<f64>) -> Result<(String, Vec<String>), String> {
    let Some(s) = speed.filter(|s| *s > 0.0) else {
        return Err("CYCL DEF 207 called without a spindle speed (TOOL CALL … S)".into());
    };
    if pitch == 0.0 {
        return Err("CYCL DEF 207 with a pitch Q239 of 0".into());
    }
    let code = if pitch > 0.0 { "G84" } else { "G74" };
    Ok((
        format!("M29 {code}"),
        vec![format!("F{}", fmt(s * pitch.abs()))],
    ))
}

/// `CYCL DEF 9.0 DWELL TIME` (nothing yet) and `CYCL DEF 9.1 DWELL t` (the dwell).
fn cycle(rest: &str) -> Result<String, String> {
    let mut parts = rest.split_whitespace();
    if parts.next() != Some("DEF") {
        return Err("expected CYCL DEF".into());
    }
    match parts.next() {
        Some("9.0") => Ok(String::new()),
        Some("9.1") => {
            let t = parts.last().ok_or("CYCL DEF 9.1 needs the dwell time")?;
            Ok(format!("G4 X{}", number(t)?))
        }
        Some(n) => Err(format!(
            "cycle {n} is not in the subset cnc402 reads (cycles 7, datum shift, 9, dwell, 200, drilling, 201, reaming, 205, pecking, and 207, rigid tapping, are)"
        )),
        None => Err("expected the cycle number".into()),
    }
}

fn comment(text: &str) -> String {
    let clean: String = text.chars().filter(|c| !matches!(c, '(' | ')')).collect();
    let clean = clean.trim();
    if clean.is_empty() {
        String::new()
    } else {
        format!("({clean})")
    }
}

fn axis_words(words: &[Word]) -> Result<Vec<String>, String> {
    Ok(words
        .iter()
        .filter_map(|w| match w {
            Word::Axis(l, v) => Some(format!("{l}{}", fmt(*v))),
            _ => None,
        })
        .collect())
}

fn feed_words(words: &[Word]) -> Vec<String> {
    words
        .iter()
        .filter_map(|w| match w {
            Word::Feed(f) => Some(format!("F{}", fmt(*f))),
            _ => None,
        })
        .collect()
}

fn m_words(words: &[Word]) -> Result<Vec<String>, String> {
    Ok(words
        .iter()
        .filter_map(|w| match w {
            Word::M(m) => Some(format!("M{m}")),
            _ => None,
        })
        .collect())
}

fn number(s: &str) -> Result<f64, String> {
    s.replace(',', ".")
        .parse::<f64>()
        .ok()
        .filter(|v| v.is_finite())
        .ok_or_else(|| format!("{s:?} is not a number"))
}

/// A number as an ISO word takes it (decimal point always, so it reads as mm).
fn fmt(v: f64) -> String {
    let s = format!("{v}");
    if s.contains('.') || s.contains('e') {
        s
    } else {
        format!("{s}.")
    }
}

#[cfg(test)]
mod tests;
