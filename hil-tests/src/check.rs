//! Assertions on JSON reports for the HIL scenarios (`hilcheck`): a path into the document,
//! an operator and a value, e.g. `stop.node == 3`, `checks.*.pass == true`,
//! `tapping.*.max_coupling_error_um_cmd <= @coupling_bound_um`, `error ~ line 12`, and
//! templates that print figures (`p99 {sync_period_us.p99:.0} µs`).

use serde_json::Value;

/// Selects values: segments separated by `.`: an object key, an array index, `*` (every
/// element or member), `#` (the length of an array/object/string), `?KEY~TEXT` (array
/// elements whose KEY is a string containing TEXT) or `?KEY=JSON` (whose KEY equals it).
///
/// ```
/// use cnc402_hil::check::select;
/// let v = serde_json::json!({"a": [{"n": "x1", "v": 1}, {"n": "y", "v": 2}]});
/// assert_eq!(select(&v, "a.*.v"), vec![serde_json::json!(1), serde_json::json!(2)]);
/// assert_eq!(select(&v, "a.?n~x.v"), vec![serde_json::json!(1)]);
/// assert_eq!(select(&v, "a.#"), vec![serde_json::json!(2)]);
/// ```
pub fn select(doc: &Value, path: &str) -> Vec<Value> {
    let mut cur: Vec<Value> = vec![doc.clone()];
    let path = path.trim();
    if path.is_empty() || path == "." {
        return cur;
    }
    for seg in path.split('.') {
        let mut next = Vec::new();
        for v in &cur {
            if seg == "*" {
                match v {
                    Value::Array(a) => next.extend(a.iter().cloned()),
                    Value::Object(o) => next.extend(o.values().cloned()),
                    _ => {}
                }
            } else if seg == "#" {
                let n = match v {
                    Value::Array(a) => a.len(),
                    Value::Object(o) => o.len(),
                    Value::String(s) => s.chars().count(),
                    _ => continue,
                };
                next.push(Value::from(n));
            } else if let Some(filter) = seg.strip_prefix('?') {
                let Value::Array(a) = v else { continue };
                let keep = |e: &Value| -> bool {
                    if let Some((k, text)) = filter.split_once('~') {
                        e.get(k)
                            .and_then(Value::as_str)
                            .is_some_and(|s| s.contains(text))
                    } else if let Some((k, lit)) = filter.split_once('=') {
                        e.get(k).is_some_and(|x| values_equal(x, &literal(lit)))
                    } else {
                        false
                    }
                };
                next.extend(a.iter().filter(|e| keep(e)).cloned());
            } else {
                match v {
                    Value::Object(o) => {
                        if let Some(x) = o.get(seg) {
                            next.push(x.clone());
                        }
                    }
                    Value::Array(a) => {
                        if let Some(x) = seg.parse::<usize>().ok().and_then(|i| a.get(i)) {
                            next.push(x.clone());
                        }
                    }
                    _ => {}
                }
            }
        }
        cur = next;
    }
    cur
}

/// A literal on the right of an assertion: JSON if it parses as JSON, else a bare string.
fn literal(s: &str) -> Value {
    let s = s.trim();
    serde_json::from_str(s).unwrap_or_else(|_| Value::String(s.to_string()))
}

fn values_equal(a: &Value, b: &Value) -> bool {
    match (a.as_f64(), b.as_f64()) {
        (Some(x), Some(y)) => x == y,
        _ => a == b,
    }
}

/// Comparison operators.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Op {
    Eq,
    Ne,
    Le,
    Ge,
    Lt,
    Gt,
    /// The value, as text, contains the string.
    Contains,
    /// It does not.
    NotContains,
}

/// One parsed assertion `PATH OP VALUE` (VALUE `@PATH` refers to the document's single
/// value at PATH).
#[derive(Clone, Debug, PartialEq)]
pub struct Assertion {
    pub path: String,
    pub op: Op,
    pub rhs: String,
}

impl Assertion {
    /// Parses an assertion; the operator is the earliest of `== != <= >= !~ < > ~` standing
    /// between spaces.
    ///
    /// ```
    /// use cnc402_hil::check::{Assertion, Op};
    /// let a = Assertion::parse("stop.node == 3").unwrap();
    /// assert_eq!((a.path.as_str(), a.op, a.rhs.as_str()), ("stop.node", Op::Eq, "3"));
    /// assert!(Assertion::parse("no operator").is_err());
    /// ```
    pub fn parse(s: &str) -> Result<Assertion, String> {
        const OPS: [(&str, Op); 8] = [
            ("==", Op::Eq),
            ("!=", Op::Ne),
            ("<=", Op::Le),
            (">=", Op::Ge),
            ("!~", Op::NotContains),
            ("<", Op::Lt),
            (">", Op::Gt),
            ("~", Op::Contains),
        ];
        // The operator stands alone between spaces (paths may contain `~` and `=`).
        let mut best: Option<(usize, &str, Op)> = None;
        for (tok, op) in OPS {
            let padded = format!(" {tok} ");
            let found = s.find(&padded).or_else(|| {
                s.strip_suffix(tok)
                    .filter(|h| h.ends_with(' '))
                    .map(|h| h.len() - 1)
            });
            if let Some(i) = found
                && best.is_none_or(|(j, _, _)| i < j)
            {
                best = Some((i + 1, tok, op));
            }
        }
        let (i, tok, op) = best
            .ok_or_else(|| format!("`{s}`: no operator (== != <= >= < > ~ !~ between spaces)"))?;
        let path = s[..i].trim();
        if path.is_empty() {
            return Err(format!("`{s}`: no path before the operator"));
        }
        Ok(Assertion {
            path: path.to_string(),
            op,
            rhs: s[i + tok.len()..].trim().to_string(),
        })
    }

    /// Checks the assertion on `doc`: every selected value must satisfy it, and at least one
    /// must be selected. `Err` says why not, with the values seen.
    pub fn check(&self, doc: &Value) -> Result<(), String> {
        let rhs = match self.rhs.strip_prefix('@') {
            Some(p) => {
                let r = select(doc, p);
                if r.len() != 1 {
                    return Err(format!("`{p}` selects {} values, need 1", r.len()));
                }
                r[0].clone()
            }
            None => literal(&self.rhs),
        };
        let vals = select(doc, &self.path);
        if vals.is_empty() {
            return Err(format!("`{}` selects nothing", self.path));
        }
        for v in &vals {
            if !compare(v, self.op, &rhs) {
                let shown: Vec<String> = vals.iter().map(|v| v.to_string()).collect();
                return Err(format!("{} is [{}]", self.path, shown.join(", ")));
            }
        }
        Ok(())
    }
}

fn text(v: &Value) -> String {
    match v {
        Value::String(s) => s.clone(),
        v => v.to_string(),
    }
}

fn compare(v: &Value, op: Op, rhs: &Value) -> bool {
    match op {
        Op::Eq => values_equal(v, rhs),
        Op::Ne => !values_equal(v, rhs),
        Op::Contains => text(v).contains(&text(rhs)),
        Op::NotContains => !text(v).contains(&text(rhs)),
        Op::Le | Op::Ge | Op::Lt | Op::Gt => match (v.as_f64(), rhs.as_f64()) {
            (Some(a), Some(b)) => match op {
                Op::Le => a <= b,
                Op::Ge => a >= b,
                Op::Lt => a < b,
                _ => a > b,
            },
            _ => false,
        },
    }
}

/// Checks `expr`: one assertion, or several joined by ` || ` (passes if any passes).
///
/// ```
/// let v = serde_json::json!({"n": 3});
/// assert!(cnc402_hil::check::check_expr("n == 2 || n == 3", &v).unwrap().is_ok());
/// assert!(cnc402_hil::check::check_expr("n == 2 || n > 4", &v).unwrap().is_err());
/// assert!(cnc402_hil::check::check_expr("n", &v).is_err());
/// ```
pub fn check_expr(expr: &str, doc: &Value) -> Result<Result<(), String>, String> {
    let mut whys = Vec::new();
    for part in expr.split(" || ") {
        match Assertion::parse(part)?.check(doc) {
            Ok(()) => return Ok(Ok(())),
            Err(why) => whys.push(why),
        }
    }
    Ok(Err(whys.join("; ")))
}

/// Fills `{PATH}` / `{PATH:.N}` (N decimals) placeholders from `doc`; several values are
/// joined with `/`, none is `-`. `{max:PATH}` / `{min:PATH}` take the largest / smallest of
/// the numbers selected.
///
/// ```
/// use cnc402_hil::check::render;
/// let v = serde_json::json!({"s": {"p50": 1000.25}, "n": "x", "a": [3, 1.5, 2]});
/// assert_eq!(render(&v, "p50 {s.p50:.1} µs {n} {nope}"), "p50 1000.2 µs x -");
/// assert_eq!(render(&v, "{a.*} {max:a.*:.1} {min:a.*}"), "3/1.5/2 3.0 1.5");
/// ```
pub fn render(doc: &Value, template: &str) -> String {
    let mut out = String::new();
    let mut rest = template;
    while let Some(i) = rest.find('{') {
        out.push_str(&rest[..i]);
        let Some(j) = rest[i..].find('}') else {
            out.push_str(&rest[i..]);
            return out;
        };
        let inner = &rest[i + 1..i + j];
        let (path, prec) = match inner.rsplit_once(":.") {
            Some((p, n)) => (p, n.parse::<usize>().ok()),
            None => (inner, None),
        };
        let (agg, path) = match path.split_once(':') {
            Some((a @ ("max" | "min"), p)) => (Some(a), p),
            _ => (None, path),
        };
        let mut vals = select(doc, path);
        if let Some(a) = agg {
            let nums = vals.iter().filter_map(Value::as_f64);
            let pick = if a == "max" {
                nums.reduce(f64::max)
            } else {
                nums.reduce(f64::min)
            };
            vals = pick
                .and_then(serde_json::Number::from_f64)
                .map(Value::Number)
                .into_iter()
                .collect();
        }
        if vals.is_empty() {
            out.push('-');
        } else {
            let parts: Vec<String> = vals
                .iter()
                .map(|v| match (v.as_f64(), prec) {
                    (Some(x), Some(n)) if !v.is_string() => format!("{x:.n$}"),
                    _ => text(v),
                })
                .collect();
            out.push_str(&parts.join("/"));
        }
        rest = &rest[i + j + 1..];
    }
    out.push_str(rest);
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn doc() -> Value {
        json!({
            "ok": false,
            "stop": {"node": 3, "emcy": "0x7300", "location": "examples/x.nc:12"},
            "bound": 0.1,
            "checks": [
                {"name": "tap coupling window 1 (setpoints)", "value_um": 0.05, "pass": true},
                {"name": "tap coupling window 1 (actual)", "value_um": 7.0, "pass": true},
                {"name": "no unexpected frames", "value": 0, "pass": true}
            ],
            "drives": {"1": {"state": "OperationEnabled"}, "2": {"state": "Fault"}}
        })
    }

    fn ok(s: &str) -> bool {
        Assertion::parse(s).unwrap().check(&doc()).is_ok()
    }

    #[test]
    fn assertions_pass_and_fail() {
        assert!(ok("ok == false"));
        assert!(!ok("ok == true"));
        assert!(ok("stop.node == 3"));
        assert!(ok("stop.node >= 3"));
        assert!(!ok("stop.node > 3"));
        assert!(ok("stop.emcy == \"0x7300\""));
        assert!(ok("stop.emcy == 0x7300"));
        assert!(ok("stop.location ~ :12"));
        assert!(ok("stop.location !~ :13"));
        assert!(ok("checks.*.pass == true"));
        assert!(ok("checks.?name~setpoints.value_um <= @bound"));
        assert!(!ok("checks.?name~actual.value_um <= @bound"));
        assert!(ok("checks.# == 3"));
        assert!(ok("drives.1.state == OperationEnabled"));
        assert!(!ok("drives.*.state == OperationEnabled"));
        // Nothing selected fails, as does a number compared with text.
        assert!(!ok("tapping.*.line == 1"));
        assert!(!ok("stop.emcy < 3"));
        assert!(Assertion::parse("x").is_err());
        assert!(Assertion::parse("== 3").is_err());
        assert!(Assertion::parse("a==3").is_err());
        assert!(ok("stop.location ~ x.nc:12"));
        assert_eq!(Assertion::parse("a.b ~").unwrap().rhs, "");
        let e = Assertion::parse("drives.*.state == Fault")
            .unwrap()
            .check(&doc())
            .unwrap_err();
        assert!(e.contains("OperationEnabled"), "{e}");
    }

    #[test]
    fn templates_render_figures() {
        let d = doc();
        assert_eq!(render(&d, "{checks.*.value_um:.2}"), "0.05/7.00");
        assert_eq!(
            render(&d, "node {stop.node} {stop.emcy:.1}"),
            "node 3 0x7300"
        );
        assert_eq!(render(&d, "open {x"), "open {x");
    }
}
