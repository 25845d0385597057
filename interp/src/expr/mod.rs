//! Evaluation of address values: literal numbers and bracketed expressions (`X[1+2*3]`,
//! `F=100*2`) with Fanuc Custom Macro B semantics (degrees, FIX/FUP/ROUND, MOD, bitwise
//! AND/OR/XOR, comparisons giving 1 or 0). Variables are read through [`VarSource`]; a
//! value is `Option<f64>` where `None` is Fanuc's vacant (`#0`, never-set variables).

use cnc402_lang::ast::{BinaryOp, Expr, ExprKind, Func, UnaryOp, Value};
use cnc402_lang::{NcError, SourceFile};

use ops::bool01;

pub mod ops;

/// Where the C-like language runs: a Macro B sub-program may be a C-like file, but the
/// Macro B executor does not run C-like code (a C-like main program runs in `hll`).
pub(crate) const C_LIKE_ONLY: &str = "only in a C-like main program and the files it #uses, not in a sub-program that a Macro B program calls (M98, G65, G66)";

/// Where expressions read macro variables from. `n` is the variable number as computed
/// (indirect `#[…]` already evaluated and rounded); `Ok(None)` is vacant; `Err` is a message
/// for the variable's place in the program (no such variable, a failed motion sync, …).
pub trait VarSource {
    fn get(&mut self, n: i64) -> Result<Option<f64>, String>;
    /// A LinuxCNC named parameter `#<name>` (name folded to lower case).
    fn get_named(&mut self, name: &str) -> Result<Option<f64>, String> {
        Err(format!("#<{name}>: named parameters need the interpreter"))
    }
    /// LinuxCNC's `EXISTS[#<name>]`.
    fn named_exists(&mut self, _name: &str) -> bool {
        false
    }
}

/// No variables at all: every read is an error (plain expression evaluation).
pub struct NoVars;

impl VarSource for NoVars {
    fn get(&mut self, _n: i64) -> Result<Option<f64>, String> {
        Err("macro variables need the interpreter (no variables here)".into())
    }
}

/// The number a word's value stands for. Errors (division by zero, SQRT of a negative, …)
/// point at the sub-expression that failed.
pub fn value(src: &SourceFile, v: &Value) -> Result<f64, NcError> {
    Ok(value_in(src, v, &mut NoVars)?.unwrap_or(0.0))
}

/// A word's value with variables; `None` when it is vacant (`X#1` with `#1` vacant: Fanuc
/// then ignores the whole word).
pub fn value_in(
    src: &SourceFile,
    v: &Value,
    vars: &mut dyn VarSource,
) -> Result<Option<f64>, NcError> {
    match v {
        Value::Number(n) => Ok(Some(n.value)),
        Value::Expr(e) => eval(src, e, vars),
    }
}

/// A variable number from a computed value: rounded to the nearest whole number (Fanuc).
pub fn var_number(v: f64) -> i64 {
    v.round() as i64
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
    Ok(eval(src, e, &mut NoVars)?.unwrap_or(0.0))
}

/// Evaluates `e` reading variables from `vars`, with Fanuc's vacant rules: a lone variable
/// (or its negation) stays vacant; in arithmetic and functions vacant counts as 0; `EQ`/`NE`
/// compare vacant as its own value (`#0 EQ 0` is false, `#0 EQ #0` true); `GT GE LT LE`
/// count vacant as 0.
///
/// ```
/// use cnc402_interp::eval::{eval, VarSource};
/// use cnc402_lang::{SourceFile, parse_expr};
/// struct One;
/// impl VarSource for One {
///     fn get(&mut self, n: i64) -> Result<Option<f64>, String> {
///         Ok(if n == 1 { Some(2.0) } else { None })
///     }
/// }
/// let src = SourceFile::new("e", "[#1*3+#2]");
/// let e = parse_expr(&src).unwrap();
/// assert_eq!(eval(&src, &e, &mut One).unwrap(), Some(6.0));
/// ```
pub fn eval(src: &SourceFile, e: &Expr, vars: &mut dyn VarSource) -> Result<Option<f64>, NcError> {
    let err = |m: String| NcError::new(src, e.span, m);
    let r = match &e.kind {
        ExprKind::Number(v) => *v,
        ExprKind::Var(n) => return vars.get(i64::from(*n)).map_err(err),
        ExprKind::Named(name) => return vars.get_named(name).map_err(err),
        ExprKind::CallNamed(f, args) if f == "EXISTS" => match args.first().map(|a| &a.kind) {
            Some(ExprKind::Named(name)) => bool01(vars.named_exists(name)),
            _ => return Err(err("EXISTS takes a named parameter".into())),
        },
        ExprKind::IndirectVar(i) => {
            let n = eval(src, i, vars)?.unwrap_or(0.0);
            return vars.get(var_number(n)).map_err(err);
        }
        ExprKind::Unary(op, a) => {
            let Some(a) = eval(src, a, vars)? else {
                return Ok(None);
            };
            match op {
                UnaryOp::Neg => -a,
                UnaryOp::Plus => a,
            }
        }
        ExprKind::Binary(op, a, b) => {
            let xa = eval(src, a, vars)?;
            let yb = eval(src, b, vars)?;
            match op {
                BinaryOp::Eq => return Ok(Some(bool01(xa == yb))),
                BinaryOp::Ne => return Ok(Some(bool01(xa != yb))),
                _ => {}
            }
            let (x, y) = (xa.unwrap_or(0.0), yb.unwrap_or(0.0));
            ops::binary(*op, x, y).map_err(|e| err(e.to_string()))?
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
                *slot = eval(src, a, vars)?.unwrap_or(0.0);
            }
            ops::call(*f, v[0], v[1], args.len() == 2).map_err(|e| err(e.to_string()))?
        }
        #[allow(unreachable_patterns)]
        _ => {
            return Err(err(format!(
                "C-like expressions are allowed {}",
                C_LIKE_ONLY
            )));
        }
    };
    if r.is_finite() {
        Ok(Some(r))
    } else {
        Err(err("the result is not a finite number".into()))
    }
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
