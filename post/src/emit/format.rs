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

/// How a length is written: in the program's units (G20 inches take one decimal more, the
/// control's 0.0001" increment); angles always in degrees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Unit {
    Mm,
    Inch,
    Degree,
}

impl Unit {
    /// `value` (mm or degrees) in this unit, and its decimals on a control of `rules`.
    fn convert(self, value: f64, rules: &Rules, decimals: u32) -> (f64, u32) {
        let _ = rules;
        match self {
            Unit::Inch => (value / 25.4, decimals + 1),
            Unit::Mm | Unit::Degree => (value, decimals),
        }
    }
}

/// A position word (`X-2.5`; `value` in mm or degrees) within the control's range.
pub fn position(
    rules: &Rules,
    letter: char,
    value: f64,
    unit: Unit,
    at: &Source,
) -> Result<String, PostError> {
    let (v, decimals) = unit.convert(value, rules, rules.position_decimals);
    if !v.is_finite() || v.abs() > rules.max_position {
        return Err(PostError::target(
            rules,
            Some(at),
            format!(
                "{letter}{v} is outside the control's range (±{})",
                rules.max_position
            ),
        ));
    }
    Ok(format!("{letter}{}", decimal(v, decimals)))
}

/// An F word (`value` in mm/min, written per minute in the program's units).
pub fn feed(rules: &Rules, value: f64, unit: Unit, at: &Source) -> Result<String, PostError> {
    let (v, decimals) = unit.convert(value, rules, rules.feed_decimals);
    if !(v > 0.0 && v <= rules.max_feed) {
        return Err(PostError::target(
            rules,
            Some(at),
            format!(
                "feed F{v} is outside the control's range (0 < F <= {})",
                rules.max_feed
            ),
        ));
    }
    Ok(format!("F{}", decimal(v, decimals)))
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
        assert!(position(&rules, 'X', 1e6, Unit::Mm, &at).is_err());
        assert!(feed(&rules, 0.0, Unit::Mm, &at).is_err());
        assert_eq!(position(&rules, 'X', 25.4, Unit::Inch, &at).unwrap(), "X1.");
        assert_eq!(
            position(&rules, 'Z', -0.0762, Unit::Inch, &at).unwrap(),
            "Z-0.003"
        );
        assert_eq!(feed(&rules, 119.99976, Unit::Inch, &at).unwrap(), "F4.7244");
    }
}
