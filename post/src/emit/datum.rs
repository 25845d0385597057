//! Direct blocks translated with buffering (issue 16: "one block on one control can be three
//! on another"): the datum the job moves in — its own `G10 L2` work-offset writes, `G92`, or
//! another work system than G54 — becomes, on the iTNC, one `CYCL DEF 7` datum shift of
//! four blocks (`7.0 DATUM SHIFT`, `7.1 X`, `7.2 Y`, `7.3 Z`), collected whole before any is
//! written and written where the first block of the new datum runs.

use cnc402_interp::canon::CanonOp;

use super::Emitter;

/// Closer than this, two shifts are the same.
const SAME: f64 = 1e-9;

/// A datum shift relative to the machine's G54 along X, Y and Z (mm), as cycle 7 holds it.
pub type Shift = [f64; 3];

/// The shift `op` runs under (its work zero less the machine's G54 and less the tool length
/// along the tool axis), or why cycle 7 cannot give it (a shift along another axis).
pub fn shift_of(e: &Emitter<'_>, op: &CanonOp) -> Result<Shift, String> {
    let st = &op.state;
    let mut zero = st.offset;
    if let Some(t) = st.tool_axis {
        zero[t] -= e.effective_length(op);
    }
    let g54 = &e.cfg.work_offsets[0];
    let xyz = e.xyz;
    let other = e
        .axes()
        .filter(|i| !xyz.contains(&Some(*i)))
        .any(|i| (zero[i] - g54[i]).abs() > SAME);
    if other {
        return Err(
            "a datum shift along another axis than X, Y, Z (cycle 7 is written for \
                    X, Y, Z only)"
                .into(),
        );
    }
    Ok(xyz.map(|i| i.map_or(0.0, |i| zero[i] - g54[i])))
}

/// The blocks of the cycle-7 shift to `want` when the control holds `held` (none when the
/// same): all three axes, so that no axis keeps an earlier shift. `len` writes a length.
pub fn shift_blocks(held: &Shift, want: &Shift, len: impl Fn(f64) -> String) -> Vec<String> {
    if held.iter().zip(want).all(|(a, b)| (a - b).abs() <= SAME) {
        return Vec::new();
    }
    let mut blocks = vec!["CYCL DEF 7.0 DATUM SHIFT".to_string()];
    blocks.extend(
        ['X', 'Y', 'Z']
            .iter()
            .zip(want)
            .enumerate()
            .map(|(k, (l, v))| format!("CYCL DEF 7.{} {l}{}", k + 1, len(*v))),
    );
    blocks
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn one_shift_is_four_blocks_and_the_same_shift_none() {
        let len = |v: f64| format!("{v:+}");
        assert!(shift_blocks(&[1.0, 2.0, 0.0], &[1.0, 2.0, 0.0], len).is_empty());
        assert_eq!(
            shift_blocks(&[0.0; 3], &[10.0, -5.0, 0.0], len),
            [
                "CYCL DEF 7.0 DATUM SHIFT",
                "CYCL DEF 7.1 X+10",
                "CYCL DEF 7.2 Y-5",
                "CYCL DEF 7.3 Z+0"
            ]
        );
    }
}
