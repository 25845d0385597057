//! LinuxCNC's block words that the Fanuc block layer reads otherwise, translated before the
//! block runs (the `linuxcnc` dialect only): polar `@`/`^` become X and Y, a canned cycle's
//! `P` seconds becomes milliseconds, `G8` (lathe radius mode) is dropped and `G7` refused,
//! and `G92.1`/`G92.2`/`G92.3` reset, suspend and restore the G92 shift (kept as LinuxCNC
//! keeps it in `#5211`…: the last G92 set).

use cnc402_lang::NcError;
use cnc402_lang::ast::{Block, Number, Span, Value, Word};

use super::Interpreter;
use super::units::Unit;
use crate::expr;

/// `G<whole>.<tenth>` as ten times its value, when `v` is one (92.1 → 921).
fn tenths(v: f64) -> Option<i64> {
    let t = (v * 10.0).round();
    ((v * 10.0 - t).abs() < 1e-6).then_some(t as i64)
}

fn number_word(letter: char, v: f64, span: Span) -> Word {
    Word {
        letter,
        value: Value::Number(Number {
            value: v,
            has_point: true,
            span,
        }),
        span,
    }
}

impl Interpreter {
    /// `block` as the Fanuc block layer is to run it, or `None` when it needs no change.
    pub(crate) fn linuxcnc_block(
        &mut self,
        unit: &Unit,
        block: &Block,
    ) -> Result<Option<Block>, NcError> {
        self.m.state.polar_step = None;
        let special = |w: &Word| matches!(w.letter, '@' | '^' | 'G');
        if !block.words.iter().any(special) {
            return Ok(None);
        }
        let mut g = Vec::new();
        for w in block.words.iter().filter(|w| w.letter == 'G') {
            if let Some(v) = expr::value_in(&unit.src, &w.value, self)? {
                g.push((tenths(v), w.span));
            }
        }
        let has = |code: i64| g.iter().any(|c| c.0 == Some(code));
        let mut out = block.clone();
        let mut changed = false;
        for (code, span) in &g {
            match code {
                Some(c @ 921..=923) => self.g92_dot(*c),
                // G8: lathe radius mode, what a mill's X already is (Fanuc's G08 is lookahead).
                Some(80) => {}
                Some(70) => {
                    return Err(NcError::new(
                        &unit.src,
                        *span,
                        "G7 (lathe diameter mode) is not supported: X is a radius on this machine"
                            .to_string(),
                    ));
                }
                _ => continue,
            }
            out.words.retain(|w| w.span != *span);
            changed = true;
        }
        let cycle = [730, 810, 820, 830, 840, 850, 860, 870, 880, 890]
            .into_iter()
            .any(has);
        if let Some(k) = out.words.iter().position(|w| w.letter == 'P')
            && cycle
            && !has(40)
            && let Some(p) = expr::value_in(&unit.src, &out.words[k].value, self)?
        {
            // The block layer reads a cycle's P as whole milliseconds.
            out.words[k] = number_word('P', (p * 1000.0).round(), out.words[k].span);
            changed = true;
        }
        if out.words.iter().any(|w| matches!(w.letter, '@' | '^')) {
            let distance = g.iter().rev().find_map(|c| match c.0 {
                Some(900) => Some(false),
                Some(910) => Some(true),
                _ => None,
            });
            self.polar(unit, &mut out, distance)?;
            changed = true;
        }
        Ok(changed.then_some(out))
    }

    /// `@` and `^` of `block` → X and Y (LinuxCNC): the radius and angle (degrees) of the end
    /// point about the work origin; in G91 they add to the current point's radius and angle.
    /// `incremental`: the block's own G90/G91, if it has one.
    fn polar(
        &mut self,
        unit: &Unit,
        block: &mut Block,
        incremental: Option<bool>,
    ) -> Result<(), NcError> {
        let err = |span: Span, m: &str| NcError::new(&unit.src, span, m.to_string());
        let at = |l: char| block.words.iter().find(|w| w.letter == l);
        let first = at('@').or(at('^')).map_or(Span::default(), |w| w.span);
        if let Some(w) = at('X').or(at('Y')) {
            return Err(err(w.span, "X or Y with polar @/^ in one block (LinuxCNC)"));
        }
        let mut value = |l: char| -> Result<Option<f64>, NcError> {
            match block.words.iter().find(|w| w.letter == l) {
                Some(w) => expr::value_in(&unit.src, &w.value, self),
                None => Ok(None),
            }
        };
        let (radius, angle) = (value('@')?, value('^')?);
        let rd = |m: Result<f64, String>| m.map_err(|m| err(first, &m));
        let cx = rd(self.axis_position('X'))?;
        let cy = rd(self.axis_position('Y'))?;
        let incremental = match incremental {
            Some(i) => i,
            None => self.read_var(4003).map_err(|m| err(first, &m))? == Some(91.0),
        };
        let (r0, a0) = (cx.hypot(cy), cy.atan2(cx).to_degrees());
        let (mut r, mut a) = (radius.unwrap_or(r0), angle.unwrap_or(a0));
        if incremental {
            if r0 == 0.0 && angle.is_some() {
                return Err(err(
                    first,
                    "incremental polar move from the origin: its angle is undefined",
                ));
            }
            r = radius.map_or(r0, |d| r0 + d);
            a = angle.map_or(a0, |d| a0 + d);
            self.m.state.polar_step = Some([radius.unwrap_or(0.0), angle.unwrap_or(0.0)]);
        }
        let (x, y) = (r * a.to_radians().cos(), r * a.to_radians().sin());
        // The block layer reads X/Y in the distance mode: give it what that needs.
        let (x, y) = if incremental {
            (x - cx, y - cy)
        } else {
            (x, y)
        };
        block.words.retain(|w| !matches!(w.letter, '@' | '^'));
        block.words.push(number_word('X', x, first));
        block.words.push(number_word('Y', y, first));
        Ok(())
    }

    /// G92.1 (shift and kept values to 0), G92.2 (shift to 0, kept values stay), G92.3 (the
    /// kept values back).
    fn g92_dot(&mut self, code: i64) {
        let shift = &mut self.m.state.shift;
        match code {
            921 => {
                *shift = Default::default();
                self.flow.g92_kept = Default::default();
            }
            922 => *shift = Default::default(),
            _ => *shift = self.flow.g92_kept,
        }
    }
}
