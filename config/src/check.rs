//! The checks every section applies to its values, and the form a failed check takes: the
//! span of the offending text, the dotted key and the message (`ConfigError` adds file, line
//! and column).

use toml::Spanned;

/// A failed check: span of the value, key path, message.
pub(crate) type Invalid = (std::ops::Range<usize>, String, String);

/// A default value: spans nothing (an error about it is reported at no position).
pub(crate) fn sp<T>(v: T) -> Spanned<T> {
    Spanned::new(0..0, v)
}

/// A finite number above 0.
pub(crate) fn positive(v: &Spanned<f64>, key: &str) -> Result<f64, Invalid> {
    let x = *v.get_ref();
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err((
            v.span(),
            key.to_string(),
            format!("must be a positive number, got {x}"),
        ))
    }
}

/// An angle within one turn: 0 ≤ x < 360.
pub(crate) fn angle_in_turn(v: &Spanned<f64>, key: &str) -> Result<f64, Invalid> {
    let x = *v.get_ref();
    if x.is_finite() && (0.0..360.0).contains(&x) {
        Ok(x)
    } else {
        Err((
            v.span(),
            key.to_string(),
            format!("must be an angle in degrees with 0 <= angle < 360, got {x}"),
        ))
    }
}

/// An integer in `lo..=hi`.
pub(crate) fn int_in(v: &Spanned<i64>, key: &str, lo: i64, hi: i64) -> Result<i64, Invalid> {
    let x = *v.get_ref();
    if (lo..=hi).contains(&x) {
        Ok(x)
    } else {
        Err((
            v.span(),
            key.to_string(),
            format!("must be in {lo}..={hi}, got {x}"),
        ))
    }
}
