//! `LBL n` / `CALL LBL n [REP m]` / `LBL 0` translated to the ISO flow cnc402 already runs:
//! a label after the main program's end (`M2`/`M30`) starts a sub-program (`O n`, `LBL 0`
//! is its `M99`, `CALL LBL n` is `M98 Pn`); a label inside a program starts a program section
//! that `CALL LBL n REP m` repeats m times (`WHILE … DOk` … `ENDk`: jumps to positions the
//! load pass knows, so no line is translated out of the order it runs in).

/// Most program sections open inside each other (Fanuc's WHILE levels DO1–DO3).
pub const MAX_SECTIONS: usize = 3;

/// The repeats one `REP` may ask for, and the label numbers (the TNC's input formats: REP
/// 1 to 65 534, labels 0 to 999).
pub const MAX_REPEATS: u32 = 65_534;
pub const MAX_LABEL: u32 = 999;

/// What the label lines so far leave for the next.
#[derive(Clone, Debug, Default)]
pub struct Labels {
    /// `M2`/`M30` seen in file order: a label from here on starts a sub-program.
    ended: bool,
    /// Sub-program bodies entered and not yet left by `LBL 0`.
    depth: u32,
    /// The label a `CALL LBL` (no REP) just called: its `LBL` line is the body's start.
    called: Option<u32>,
    /// The program sections open, innermost last (their WHILE level is the index + 1).
    sections: Vec<u32>,
    /// Sections being repeated: label and repeats still to run (at most one per level).
    repeats: Vec<(u32, u32)>,
}

impl Labels {
    /// Notes a block that ends the main program (`M2`, `M30`).
    pub fn note_end(&mut self, iso: &str) {
        if iso.split_whitespace().any(|w| w == "M2" || w == "M30") {
            self.ended = true;
        }
    }

    /// `LBL n` (`rest` is what follows `LBL`): a sub-program's `O n`, `LBL 0`'s `M99`, or a
    /// program section's `WHILE`.
    pub fn label(&mut self, rest: &str) -> Result<String, String> {
        let n = label_number(rest)?;
        if n == 0 {
            if self.depth == 0 {
                return Err(
                    "LBL 0 outside a sub-program (it ends a label body after the main \
                            program's M2/M30)"
                        .into(),
                );
            }
            self.depth -= 1;
            return Ok("M99".into());
        }
        if self.called == Some(n) || (self.ended && self.depth == 0) {
            self.called = None;
            self.depth += 1;
            return Ok(format!("O{n}"));
        }
        let level = self.sections.len() + 1;
        let again = self.repeats.iter().position(|(l, _)| *l == n);
        if let Some(i) = again {
            if self.repeats[i].1 == 0 {
                // The last pass ran: the WHILE is false and the flow goes past its END.
                self.repeats.remove(i);
                return Ok(format!("WHILE [1 EQ 0] DO{level}"));
            }
            self.repeats[i].1 -= 1;
        }
        if level > MAX_SECTIONS {
            return Err(format!(
                "more than {MAX_SECTIONS} program sections (LBL … CALL LBL REP) inside each other"
            ));
        }
        self.sections.push(n);
        Ok(format!("WHILE [1 EQ 1] DO{level}"))
    }

    /// `CALL LBL n [REP m]` (`rest` is what follows `CALL`): `M98 Pn`, or the `END` of the
    /// open section `n` repeated m times.
    pub fn call(&mut self, rest: &str) -> Result<String, String> {
        let rest = rest.trim_start().strip_prefix("LBL").unwrap_or("").trim();
        let (label, rep) = match rest.split_once("REP") {
            Some((l, r)) => (l.trim(), Some(r.trim())),
            None => (rest, None),
        };
        let n = label_number(label)?;
        let Some(rep) = rep else {
            if n == 0 {
                return Err("CALL LBL 0 calls nothing".into());
            }
            self.called = Some(n);
            return Ok(format!("M98 P{n}"));
        };
        if self.sections.last() != Some(&n) {
            return Err(format!(
                "CALL LBL {n} REP repeats the program section that LBL {n} opened before it \
                 (the innermost one open); a sub-program is called without REP"
            ));
        }
        // `REP 2/2`: the count as typed, then what is left (the iTNC shows it): the count.
        let count = rep.split('/').next().unwrap_or("").trim();
        let m: u32 = count
            .parse()
            .ok()
            .filter(|m| (1..=MAX_REPEATS).contains(m))
            .ok_or_else(|| format!("REP {count}: expected a count from 1 to {MAX_REPEATS}"))?;
        let level = self.sections.len();
        self.sections.pop();
        if !self.repeats.iter().any(|(l, _)| *l == n) {
            if self.repeats.len() >= MAX_SECTIONS {
                self.repeats.remove(0);
            }
            self.repeats.push((n, m));
        }
        Ok(format!("END{level}"))
    }
}

/// Whether an ISO line is one of the flow lines above (no modal words go before it).
pub fn is_flow(iso: &str) -> bool {
    iso.starts_with(['O', 'W', 'E']) || iso.starts_with("M98") || iso == "M99"
}

fn label_number(text: &str) -> Result<u32, String> {
    text.trim()
        .parse::<u32>()
        .ok()
        .filter(|n| *n <= MAX_LABEL)
        .ok_or_else(|| {
            format!(
                "LBL {}: cnc402 reads numbered labels (0 to {MAX_LABEL}), not named ones",
                text.trim()
            )
        })
}
