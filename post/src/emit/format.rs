//! Words in a target's number format: decimal-point input everywhere (`X10.`, `X-0.5`), so
//! that every Fanuc model reads millimetres whatever its calculator-input parameter says,
//! rounded to the control's least input increment and checked against its range.

use cnc402_motion::segment::Source;

use crate::PostError;
use crate::rules::Rules;

/// `value` rounded to `decimals`, trailing zeros dropped, a whole number ending in `.`.
pub fn decimal(value: f64, decimals: u32) -> String {
    let scale = 10f64.powi(decimals as i32);
    let rounded = (value * scale).round() / scale;
    // -0 prints as 0.
    let rounded = if rounded == 0.0 { 0.0 } else { rounded };
    let text = format!("{rounded:.*}", decimals as usize);
    let text = text.trim_end_matches('0');
    text.to_string()
}

/// A position word (`X-2.5`) within the control's range.
pub fn position(
    rules: &Rules,
    letter: char,
    value: f64,
    at: &Source,
) -> Result<String, PostError> {
    if !value.is_finite() || value.abs() > rules.max_position {
        return Err(PostError::target(
            rules,
            Some(at),
            format!(
                "{letter}{value} is outside the control's range (±{})",
                rules.max_position
            ),
        ));
    }
    Ok(format!("{letter}{}", decimal(value, rules.position_decimals)))
}

/// An F word in mm/min.
pub fn feed(rules: &Rules, value: f64, at: &Source) -> Result<String, PostError> {
    if !(value > 0.0 && value <= rules.max_feed) {
        return Err(PostError::target(
            rules,
            Some(at),
            format!(
                "feed F{value} is outside the control's range (0 < F <= {})",
                rules.max_feed
            ),
        ));
    }
    Ok(format!("F{}", decimal(value, rules.feed_decimals)))
}

/// An S word: whole rpm within the control's range (S has no decimals on these controls; a
/// fractional speed would turn the spindle at another speed than the job's).
pub fn speed(rules: &Rules, rpm: f64, at: &Source) -> Result<String, PostError> {
    if !(rpm >= 0.0 && rpm <= rules.max_spindle) || (rpm - rpm.round()).abs() > 1e-9 {
        return Err(PostError::target(
            rules,
            Some(at),
            format!(
                "spindle speed S{rpm} is not a whole number of rpm up to {}",
                rules.max_spindle
            ),
        ));
    }
    Ok(format!("S{}", rpm.round() as u64))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn decimals_have_a_point_and_no_trailing_zeros() {
        assert_eq!(decimal(10.0, 3), "10.");
        assert_eq!(decimal(-0.5, 3), "-0.5");
        assert_eq!(decimal(1.23456, 3), "1.235");
        assert_eq!(decimal(-0.0001, 3), "0.");
        assert_eq!(decimal(0.0, 4), "0.");
    }

    #[test]
    fn ranges_are_checked() {
        let rules = crate::Target::Fanuc0.rules();
        let at = Source {
            file: "j.nc".into(),
            line: 3,
            n: Some(30),
        };
        let e = speed(&rules, 12000.0, &at).unwrap_err().to_string();
        assert_eq!(
            e,
            "j.nc:3: block N30: spindle speed S12000 is not a whole number of rpm up to 9999 \
             (target fanuc0)"
        );
        assert!(speed(&rules, 1000.5, &at).is_err());
        assert_eq!(speed(&rules, 1000.0, &at).unwrap(), "S1000");
        assert!(position(&rules, 'X', 1e6, &at).is_err());
        assert!(feed(&rules, 0.0, &at).is_err());
    }
}
