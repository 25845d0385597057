//! A canned cycle the target lacks, re-created as a Custom Macro B program (source 003): the
//! cycle's body written once, as a sub-program after the main program, with every value a
//! local variable, and each hole a `G65 P… X Y Z R Q …` call filling them. Used where the
//! rule set has macros; elsewhere, and for what a body here does not cover, plain blocks.

use cnc402_interp::canon::{CannedCycle, CanonOp, CanonState, FeedMode};
use cnc402_motion::segment::{Plane, SpindleDir};

use super::Emitter;
use super::format::{decimal, feed, speed};
use crate::PostError;
use crate::assemble::{Block, SubProgram, Word};

/// What makes two macro bodies differ: the cycle, and the steps a body either has or not
/// (a Macro B body has no branches, so that its block numbers stay the assembler's).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MacroKey {
    code: u32,
    /// A dwell at the bottom (`G4 X#20`).
    dwell: bool,
    /// M19 (spindle oriented) or M5 (the machine has no orientation angle).
    orient: bool,
    /// The spindle turned on again after the cycle, in this direction.
    restore: Option<SpindleDir>,
}

/// The cycles a macro body is written for: the orienting boring cycles, which a control
/// without a programmable oriented stop in its cycles lacks.
const MACRO_CYCLES: [u32; 2] = [76, 87];

impl Emitter<'_> {
    /// Posts `cc` as macro calls, or returns `false` (nothing written) when a body here does
    /// not cover it: another cycle, another plane than G17, LinuxCNC's cycle semantics, feed
    /// per revolution, an orientation other than the machine's M19, or a block that would
    /// have to change the tool length or compensation too.
    pub(crate) fn cycle_as_macro(
        &mut self,
        op: &CanonOp,
        cc: &CannedCycle,
    ) -> Result<bool, PostError> {
        let Some(key) = self.macro_key(op, cc) else {
            return Ok(false);
        };
        self.end_cycle(op);
        let exact = CanonOp {
            kind: op.kind.clone(),
            source: op.source.clone(),
            state: std::sync::Arc::new(CanonState {
                path_mode: Self::exact_stop(),
                ..(*op.state).clone()
            }),
        };
        if !self.state_before_call(&exact)? {
            return Ok(false);
        }
        let sub = self.macro_sub(key);
        let data = self.macro_data(op, cc, key)?;
        for &[a, b] in &cc.holes {
            let mut block = Block::new(Vec::new(), Some(op.source.clone()));
            block.words = vec![Word::Text("G65".into()), Word::Sub(sub)];
            for w in [
                self.axis_word(cc.axes[0], a, op)?,
                self.axis_word(cc.axes[1], b, op)?,
            ]
            .into_iter()
            .chain(data.iter().cloned())
            {
                block.words.push(Word::Text(w));
            }
            self.program.main.push(block);
        }
        // What the body leaves the control holding.
        self.modal.motion = Some(0);
        self.modal.feed = None;
        self.modal.spindle = None;
        self.modal.offset = op.state.offset;
        Ok(true)
    }

    /// Brings the control to the state `op` runs under in a block of its own before a `G65`
    /// (which takes no other words): `false`, with nothing written, where that block would
    /// set the tool length or the compensation (G40–G49) and so move where the job does not.
    pub(crate) fn state_before_call(&mut self, op: &CanonOp) -> Result<bool, PostError> {
        let (modal, blocks) = (self.modal.clone(), self.program.main.len());
        let words = self.modal_words(op)?;
        if self.length_written || words.iter().any(|w| w.starts_with("G4")) {
            self.modal = modal;
            self.program.main.truncate(blocks);
            return Ok(false);
        }
        if !words.is_empty() {
            self.push(words, Some(op));
        }
        Ok(true)
    }

    /// The body `cc` needs, if one here covers it.
    fn macro_key(&self, op: &CanonOp, cc: &CannedCycle) -> Option<MacroKey> {
        let st = &op.state;
        let xyz = ['X', 'Y', 'Z'].map(|l| self.cfg.axis_index(l));
        let orient = match cc.plan.orient_angle {
            None => false,
            Some(a) if (a - self.cfg.interp.spindle_orient_angle).abs() <= 1e-9 => true,
            Some(_) => return None,
        };
        let covered = MACRO_CYCLES.contains(&cc.code)
            && st.plane == Plane::XY
            && st.feed_mode == FeedMode::PerMinute
            && cc.plan.linuxcnc.is_none()
            && cc.tap.is_none()
            && xyz.map(Some) == cc.axes.map(|i| Some(Some(i)));
        let restore = if cc.code == 87 || cc.plan.spindle_turning {
            Some(cc.plan.spindle_dir)
        } else {
            None
        };
        covered.then_some(MacroKey {
            code: cc.code,
            dwell: cc.words.p.is_some_and(|p| p > 0.0),
            orient,
            restore,
        })
    }

    /// The index of `key`'s sub-program, written on first use.
    fn macro_sub(&mut self, key: MacroKey) -> usize {
        if let Some(&(_, i)) = self.macro_subs.iter().find(|(k, _)| *k == key) {
            return i;
        }
        let blocks = macro_body(key)
            .into_iter()
            .map(|line| Block::new(line.split(' ').map(String::from).collect(), None))
            .collect();
        let name = match key.code {
            76 => "G76 FINE BORING: X Y HOLE, Z BOTTOM, R, Q SHIFT, T DWELL S, W RETURN, F, S",
            _ => "G87 BACK BORING: X Y HOLE, Z TOP, R BOTTOM, Q SHIFT, T DWELL S, W RETURN, F, S",
        };
        self.program.subs.push(SubProgram {
            name: name.into(),
            blocks,
        });
        let i = self.program.subs.len() - 1;
        self.macro_subs.push((key, i));
        i
    }

    /// The call's words after X Y: `Z R Q [T] W F [S]` (#26 #18 #17 #20 #23 #9 #19).
    fn macro_data(
        &self,
        op: &CanonOp,
        cc: &CannedCycle,
        key: MacroKey,
    ) -> Result<Vec<String>, PostError> {
        let mut data = vec![
            self.axis_word(cc.axes[2], cc.bottom, op)?,
            self.length_word('R', cc.r_level, op)?,
            self.length_word('Q', cc.words.q.unwrap_or(0.0), op)?,
        ];
        if key.dwell {
            data.push(format!("T{}", decimal(cc.words.p.unwrap_or(0.0), 3)));
        }
        data.push(self.length_word('W', cc.return_level, op)?);
        data.push(feed(self.rules, cc.feed, self.length_unit(), &op.source)?);
        if key.restore.is_some() {
            data.push(speed(self.rules, cc.plan.speed, &op.source)?);
        }
        Ok(data)
    }
}

/// The body of a macro, one block a line. Arguments: X #24, Y #25 (the hole), Z #26, R #18,
/// Q #17 (the shift along +X), T #20 (dwell, s), W #23 (the level to return to), F #9, S #19;
/// the tool starts at the initial level. Each step is the one cnc402's own expansion of the
/// cycle makes (`interp::lower::cycle`), so the proof compares like with like.
pub fn macro_body(key: MacroKey) -> Vec<String> {
    let stop = if key.orient { "M19" } else { "M5" };
    let on = key.restore.map(|d| match d {
        SpindleDir::Cw => "S#19 M3",
        SpindleDir::Ccw => "S#19 M4",
        SpindleDir::Stop => "M5",
    });
    let dwell = key.dwell.then_some("G4 X#20");
    // Out of the hole: oriented, shifted off the wall, up, back, spindle on.
    let out = [
        Some(stop),
        Some("G0 X[#24+#17]"),
        Some("Z#23"),
        Some("X#24"),
        on,
    ];
    let into: Vec<Option<&str>> = match key.code {
        76 => vec![
            Some("G0 X#24 Y#25"),
            Some("Z#18"),
            Some("G1 Z#26 F#9"),
            dwell,
        ],
        // G87 goes down shifted, beside the bore, and cuts upwards.
        _ => vec![
            Some("G0 X#24 Y#25"),
            Some(stop),
            Some("X[#24+#17]"),
            Some("Z#18"),
            Some("X#24"),
            on,
            Some("G1 Z#26 F#9"),
            dwell,
        ],
    };
    let lines = into.into_iter().chain(out);
    lines.into_iter().flatten().map(String::from).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_body_has_only_the_steps_its_cycle_takes() {
        let key = MacroKey {
            code: 76,
            dwell: false,
            orient: true,
            restore: Some(SpindleDir::Cw),
        };
        assert_eq!(
            macro_body(key),
            [
                "G0 X#24 Y#25",
                "Z#18",
                "G1 Z#26 F#9",
                "M19",
                "G0 X[#24+#17]",
                "Z#23",
                "X#24",
                "S#19 M3"
            ]
        );
        let back = macro_body(MacroKey {
            code: 87,
            dwell: true,
            ..key
        });
        assert_eq!(back.iter().filter(|l| *l == "M19").count(), 2);
        assert!(back.contains(&"G4 X#20".to_string()));
    }
}
