//! The operators and functions of Macro B expressions on plain numbers, with Fanuc's rules
//! (degrees, integer rounding for MOD and the bitwise operators). The expression evaluator and
//! the old `G65 H…` instructions both compute through these; vacant values are the caller's.

use std::fmt;

use cnc402_lang::ast::{BinaryOp, Func};

/// Why an operator has no result; [`Display`](fmt::Display) is the evaluator's message.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum OpError {
    DivisionByZero,
    ModByZero,
    /// ASIN/ACOS of a value outside -1..1.
    OutsideUnit(Func, f64),
    NegativeSqrt(f64),
    NonPositiveLn(f64),
    NotBcd(f64),
    NotWhole(f64),
}

impl fmt::Display for OpError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            OpError::DivisionByZero => write!(f, "division by zero"),
            OpError::ModByZero => write!(f, "MOD by zero"),
            OpError::OutsideUnit(func, a) => write!(f, "{func:?} of {a}: outside -1..1"),
            OpError::NegativeSqrt(a) => write!(f, "SQRT of a negative number ({a})"),
            OpError::NonPositiveLn(a) => write!(f, "LN of {a}: needs a positive number"),
            OpError::NotBcd(a) => write!(f, "BIN of {a}: not BCD"),
            OpError::NotWhole(a) => write!(f, "BCD of {a}: not a whole number >= 0"),
        }
    }
}

/// 1 for true, 0 for false.
pub fn bool01(b: bool) -> f64 {
    if b { 1.0 } else { 0.0 }
}

/// `x op y` on numbers (vacant operands already read as 0).
pub fn binary(op: BinaryOp, x: f64, y: f64) -> Result<f64, OpError> {
    let int = |v: f64| v.round() as i64;
    Ok(match op {
        BinaryOp::Add => x + y,
        BinaryOp::Sub => x - y,
        BinaryOp::Mul => x * y,
        BinaryOp::Div => {
            if y == 0.0 {
                return Err(OpError::DivisionByZero);
            }
            x / y
        }
        BinaryOp::Mod => {
            let (xi, yi) = (int(x), int(y));
            if yi == 0 {
                return Err(OpError::ModByZero);
            }
            // Fanuc: operands rounded to integers, the remainder has the dividend's sign.
            (xi % yi) as f64
        }
        BinaryOp::Or => (int(x) | int(y)) as f64,
        BinaryOp::Xor => (int(x) ^ int(y)) as f64,
        BinaryOp::And => (int(x) & int(y)) as f64,
        BinaryOp::Eq | BinaryOp::Ne => bool01((x == y) == matches!(op, BinaryOp::Eq)),
        BinaryOp::Gt => bool01(x > y),
        BinaryOp::Ge => bool01(x >= y),
        BinaryOp::Lt => bool01(x < y),
        BinaryOp::Le => bool01(x <= y),
    })
}

/// Function `f` of `a` (and `b`, the second argument of `POW` and of two-argument `ATAN`,
/// when `two`).
pub fn call(f: Func, a: f64, b: f64, two: bool) -> Result<f64, OpError> {
    Ok(match f {
        Func::Sin => a.to_radians().sin(),
        Func::Cos => a.to_radians().cos(),
        Func::Tan => a.to_radians().tan(),
        Func::Asin | Func::Acos => {
            if !(-1.0..=1.0).contains(&a) {
                return Err(OpError::OutsideUnit(f, a));
            }
            if matches!(f, Func::Asin) {
                a.asin().to_degrees()
            } else {
                a.acos().to_degrees()
            }
        }
        Func::Atan if two => {
            let d = a.atan2(b).to_degrees();
            if d < 0.0 { d + 360.0 } else { d }
        }
        Func::Atan => a.atan().to_degrees(),
        Func::Sqrt => {
            if a < 0.0 {
                return Err(OpError::NegativeSqrt(a));
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
                return Err(OpError::NonPositiveLn(a));
            }
            a.ln()
        }
        Func::Exp => a.exp(),
        Func::Pow => a.powf(b),
        Func::Bin => bcd_to_bin(a).ok_or(OpError::NotBcd(a))?,
        Func::Bcd => bin_to_bcd(a).ok_or(OpError::NotWhole(a))?,
    })
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
