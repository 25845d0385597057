//! A helix on the iTNC: `CC` then `CP IPA±a IZ±dz DR±` — the iTNC interpolates a helix only
//! in polar coordinates, by the angle swept (incremental, signed as the direction) and the
//! travel along the tool axis. Up to one full turn (a closed XY circle: ±360°).

/// The words of the helix from `start` to `end` (work X Y Z) about `center` (X Y), `ccw`
/// the direction, `full` a whole turn; `len` writes a length, `angle` an angle.
pub fn polar_words(
    start: [f64; 3],
    end: [f64; 3],
    center: [f64; 2],
    ccw: bool,
    full: bool,
    len: impl Fn(f64) -> String,
    angle: impl Fn(f64) -> String,
) -> Vec<String> {
    let a0 = (start[1] - center[1]).atan2(start[0] - center[0]);
    let a1 = (end[1] - center[1]).atan2(end[0] - center[0]);
    let mut sweep = (a1 - a0).to_degrees();
    if full {
        sweep = 360.0;
    } else {
        // Into (0, 360): the arc's own way round.
        let sign = if ccw { 1.0 } else { -1.0 };
        sweep = (sweep * sign).rem_euclid(360.0);
        if sweep == 0.0 {
            sweep = 360.0;
        }
    }
    let signed_sweep = if ccw { sweep } else { -sweep };
    vec![
        "CP".to_string(),
        format!("IPA{}", angle(signed_sweep)),
        format!("IZ{}", len(end[2] - start[2])),
        if ccw { "DR+" } else { "DR-" }.to_string(),
    ]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn words(start: [f64; 3], end: [f64; 3], ccw: bool, full: bool) -> Vec<String> {
        polar_words(
            start,
            end,
            [0.0, 0.0],
            ccw,
            full,
            |v| format!("{v:+}"),
            |v| format!("{v:+.4}"),
        )
    }

    #[test]
    fn the_angle_is_swept_the_arcs_way_round() {
        assert_eq!(
            words([10.0, 0.0, 0.0], [0.0, 10.0, -1.0], true, false),
            ["CP", "IPA+90.0000", "IZ-1", "DR+"]
        );
        assert_eq!(
            words([10.0, 0.0, 0.0], [0.0, 10.0, -1.0], false, false),
            ["CP", "IPA-270.0000", "IZ-1", "DR-"]
        );
        assert_eq!(
            words([10.0, 0.0, 0.0], [10.0, 0.0, -2.0], false, true),
            ["CP", "IPA-360.0000", "IZ-2", "DR-"]
        );
    }
}
