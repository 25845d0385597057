//! Position to drive counts for the wire: CiA 402 positions are INT32 and wrap, while motion
//! keeps an unwrapped f64 (a spindle running for hours passes 2^31 counts).

/// Converts a position (mm or degrees) to INT32 counts, rounding to the nearest count as an
/// i64 and then wrapping modulo 2^32 — so consecutive setpoints differ by the true count
/// difference even across the wrap (the drive's position arithmetic is modulo 2^32 too).
/// Non-finite input gives 0; beyond ±2^63 counts the i64 saturates (never reached: 2^63
/// counts at 131072 counts/rev is 7·10^13 revolutions).
///
/// ```
/// use cnc402_motion::to_counts_wrapping;
/// assert_eq!(to_counts_wrapping(1.5, 10000.0), 15000);
/// // 2^31 counts is one past i32::MAX: it wraps to i32::MIN.
/// assert_eq!(to_counts_wrapping(2147483648.0, 1.0), i32::MIN);
/// ```
pub fn to_counts_wrapping(pos: f64, counts_per_unit: f64) -> i32 {
    let c = (pos * counts_per_unit).round();
    if !c.is_finite() {
        return 0;
    }
    (c as i64) as i32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rounds_to_nearest() {
        assert_eq!(to_counts_wrapping(0.00004, 10000.0), 0);
        assert_eq!(to_counts_wrapping(0.00006, 10000.0), 1);
        assert_eq!(to_counts_wrapping(-0.00006, 10000.0), -1);
        assert_eq!(to_counts_wrapping(f64::NAN, 10000.0), 0);
    }

    #[test]
    fn differences_survive_the_wrap() {
        let cpu = 131072.0 / 360.0;
        // Spindle at 6000 rpm = 36000 deg/s, 1 ms ticks: 13107.2 counts per tick.
        let start_deg = (i32::MAX as f64 - 50_000.0) / cpu;
        let mut prev = to_counts_wrapping(start_deg, cpu);
        let mut wrapped = false;
        for k in 1..20 {
            let deg = start_deg + 36.0 * k as f64;
            let c = to_counts_wrapping(deg, cpu);
            if c < prev {
                wrapped = true;
            }
            let ideal = ((deg * cpu).round() - ((deg - 36.0) * cpu).round()) as i64;
            assert_eq!(c.wrapping_sub(prev) as i64, ideal);
            assert!((13106..=13108).contains(&ideal));
            prev = c;
        }
        assert!(wrapped, "the run crossed i32::MAX");
        // And backwards (M4) across i32::MIN.
        let a = to_counts_wrapping(-(2f64.powi(31)) / cpu, cpu);
        let b = to_counts_wrapping(-(2f64.powi(31)) / cpu - 1.0, cpu);
        assert_eq!(a, i32::MIN);
        assert!(b > 0 && b.wrapping_sub(a) == -364);
    }
}
