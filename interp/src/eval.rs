//! Evaluation of address values: literal numbers and bracketed expressions (`X[1+2*3]`,
//! `F=100*2`) with Fanuc Custom Macro B semantics (degrees, FIX/FUP/ROUND, MOD, bitwise
//! AND/OR/XOR, comparisons giving 1 or 0). Variables come with the Macro B issue.

use cnc402_lang::ast::{BinaryOp, Expr, ExprKind, Func, UnaryOp, Value};
use cnc402_lang::{NcError, SourceFile};

/// The number a word's value stands for. Errors (division by zero, SQRT of a negative, …)
/// point at the sub-expression that failed.
pub fn value(src: &SourceFile, v: &Value) -> Result<f64, NcError> {
    match v {
        Value::Number(n) => Ok(n.value),
        Value::Expr(e) => expr(src, e),
    }
}

/// Evaluates `e` with Fanuc semantics: angles in degrees, `ATAN[a]/[b]` in 0..360,
/// `FIX` truncates toward zero, `FUP` rounds away from zero, `ROUND` rounds half away from zero.
///
/// ```
/// use cnc402_lang::{SourceFile, parse_expr};
/// let src = SourceFile::new("e", "[FUP[-1.2]+ATAN[1]/[-1]]");
/// let e = parse_expr(&src).unwrap();
/// assert_eq!(cnc402_interp::eval::expr(&src, &e).unwrap(), -2.0 + 135.0);
/// ```
pub fn expr(src: &SourceFile, e: &Expr) -> Result<f64, NcError> {
    let err = |m: String| NcError::new(src, e.span, m);
    let r = match &e.kind {
        ExprKind::Number(v) => *v,
        ExprKind::Unary(op, a) => {
            let a = expr(src, a)?;
            match op {
                UnaryOp::Neg => -a,
                UnaryOp::Plus => a,
            }
        }
        ExprKind::Binary(op, a, b) => {
            let x = expr(src, a)?;
            let y = expr(src, b)?;
            let int = |v: f64| v.round() as i64;
            match op {
                BinaryOp::Add => x + y,
                BinaryOp::Sub => x - y,
                BinaryOp::Mul => x * y,
                BinaryOp::Div => {
                    if y == 0.0 {
                        return Err(err("division by zero".into()));
                    }
                    x / y
                }
                BinaryOp::Mod => {
                    let (xi, yi) = (int(x), int(y));
                    if yi == 0 {
                        return Err(err("MOD by zero".into()));
                    }
                    // Fanuc: operands rounded to integers, the remainder has the dividend's sign.
                    (xi % yi) as f64
                }
                BinaryOp::Or => (int(x) | int(y)) as f64,
                BinaryOp::Xor => (int(x) ^ int(y)) as f64,
                BinaryOp::And => (int(x) & int(y)) as f64,
                BinaryOp::Eq => bool01(x == y),
                BinaryOp::Ne => bool01(x != y),
                BinaryOp::Gt => bool01(x > y),
                BinaryOp::Ge => bool01(x >= y),
                BinaryOp::Lt => bool01(x < y),
                BinaryOp::Le => bool01(x <= y),
            }
        }
        ExprKind::Call(f, args) => {
            let want = if matches!(f, Func::Pow) { 2 } else { 1 };
            let ok_count = args.len() == want || (matches!(f, Func::Atan) && args.len() == 2);
            if !ok_count {
                return Err(err(format!(
                    "{f:?} takes {want} argument(s), {} given",
                    args.len()
                )));
            }
            let mut v = [0.0f64; 2];
            for (slot, a) in v.iter_mut().zip(args) {
                *slot = expr(src, a)?;
            }
            let a = v[0];
            match f {
                Func::Sin => a.to_radians().sin(),
                Func::Cos => a.to_radians().cos(),
                Func::Tan => a.to_radians().tan(),
                Func::Asin | Func::Acos => {
                    if !(-1.0..=1.0).contains(&a) {
                        return Err(err(format!("{f:?} of {a}: outside -1..1")));
                    }
                    if matches!(f, Func::Asin) {
                        a.asin().to_degrees()
                    } else {
                        a.acos().to_degrees()
                    }
                }
                Func::Atan if args.len() == 2 => {
                    let d = v[0].atan2(v[1]).to_degrees();
                    if d < 0.0 { d + 360.0 } else { d }
                }
                Func::Atan => a.atan().to_degrees(),
                Func::Sqrt => {
                    if a < 0.0 {
                        return Err(err(format!("SQRT of a negative number ({a})")));
                    }
                    a.sqrt()
                }
                Func::Abs => a.abs(),
                Func::Round => a.round(),
                Func::Fix => a.trunc(),
                Func::Fup => {
                    let t = a.trunc();
                    if t == a { t } else { t + a.signum() }
                }
                Func::Ln => {
                    if a <= 0.0 {
                        return Err(err(format!("LN of {a}: needs a positive number")));
                    }
                    a.ln()
                }
                Func::Exp => a.exp(),
                Func::Pow => a.powf(v[1]),
                Func::Bin => bcd_to_bin(a).ok_or_else(|| err(format!("BIN of {a}: not BCD")))?,
                Func::Bcd => bin_to_bcd(a)
                    .ok_or_else(|| err(format!("BCD of {a}: not a whole number >= 0")))?,
            }
        }
        ExprKind::Var(_) | ExprKind::IndirectVar(_) => {
            return Err(err(
                "macro variables are not supported yet (they come with Custom Macro B)".into(),
            ));
        }
        #[allow(unreachable_patterns)]
        _ => {
            return Err(err(
                "this expression is not supported yet (it belongs to the C-like language)".into(),
            ));
        }
    };
    if r.is_finite() {
        Ok(r)
    } else {
        Err(err("the result is not a finite number".into()))
    }
}

fn bool01(b: bool) -> f64 {
    if b { 1.0 } else { 0.0 }
}

fn bcd_to_bin(a: f64) -> Option<f64> {
    if a < 0.0 || a.fract() != 0.0 || a > u32::MAX as f64 {
        return None;
    }
    let (mut x, mut r, mut m) = (a as u64, 0u64, 1u64);
    while x > 0 {
        let d = x & 0xF;
        if d > 9 {
            return None;
        }
        r += d * m;
        m *= 10;
        x >>= 4;
    }
    Some(r as f64)
}

fn bin_to_bcd(a: f64) -> Option<f64> {
    if a < 0.0 || a.fract() != 0.0 || a > 99_999_999.0 {
        return None;
    }
    let (mut x, mut r, mut sh) = (a as u64, 0u64, 0u32);
    while x > 0 {
        r |= (x % 10) << sh;
        sh += 4;
        x /= 10;
    }
    Some(r as f64)
}

#[cfg(test)]
mod tests {
    use super::*;
    use cnc402_lang::parse_expr;

    fn ev(t: &str) -> Result<f64, NcError> {
        let src = SourceFile::new("e", t);
        let e = parse_expr(&src).expect("parses");
        expr(&src, &e)
    }

    #[test]
    fn fanuc_rounding_functions_of_negative_numbers() {
        assert_eq!(ev("FIX[-1.2]").unwrap(), -1.0);
        assert_eq!(ev("FUP[-1.2]").unwrap(), -2.0);
        assert_eq!(ev("FUP[1.2]").unwrap(), 2.0);
        assert_eq!(ev("FUP[3]").unwrap(), 3.0);
        assert_eq!(ev("ROUND[-1.5]").unwrap(), -2.0);
        assert_eq!(ev("ROUND[2.5]").unwrap(), 3.0);
    }

    #[test]
    fn trig_in_degrees_and_atan_quadrants() {
        assert!((ev("SIN[30]").unwrap() - 0.5).abs() < 1e-12);
        assert!((ev("ATAN[1]/[-1]").unwrap() - 135.0).abs() < 1e-12);
        assert!((ev("ATAN[-1]/[-1]").unwrap() - 225.0).abs() < 1e-12);
        assert!((ev("ATAN[-1]/[1]").unwrap() - 315.0).abs() < 1e-12);
    }

    #[test]
    fn operators_mod_bitwise_comparisons() {
        assert_eq!(ev("[10 MOD 3]").unwrap(), 1.0);
        assert_eq!(ev("[-10 MOD 3]").unwrap(), -1.0);
        assert_eq!(ev("[6 AND 3]").unwrap(), 2.0);
        assert_eq!(ev("[6 OR 3]").unwrap(), 7.0);
        assert_eq!(ev("[6 XOR 3]").unwrap(), 5.0);
        assert_eq!(ev("[2 GT 1]").unwrap(), 1.0);
        assert_eq!(ev("[2 LE 1]").unwrap(), 0.0);
        assert_eq!(ev("BIN[18]").unwrap(), 12.0); // 0x12 is BCD for 12
        assert_eq!(ev("BCD[12]").unwrap(), 18.0);
    }

    #[test]
    fn errors_point_at_the_failing_subexpression() {
        let e = ev("[1+[2/0]]").unwrap_err();
        assert_eq!(e.message, "division by zero");
        assert_eq!(e.col, 4);
        assert!(ev("SQRT[-1]").unwrap_err().message.contains("SQRT"));
        assert!(ev("LN[0]").is_err());
        assert!(ev("[5 MOD 0]").is_err());
    }
}
