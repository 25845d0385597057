//! LinuxCNC's named parameters: `#<name>` local to the subroutine call that set it, and
//! `#<_name>` global. Predefined read-only ones (`#<_x>`, `#<_metric>` …) are answered by the
//! program flow; this table holds what programs assign. Both are bounded in size.

use std::collections::HashMap;

/// How many names one scope (and the globals) may hold: a program that makes up names in a
/// loop ends with an error instead of growing without bound.
pub const MAX_NAMES: usize = 10_000;

/// Named parameters as assigned: one scope of locals per call level, and the globals.
#[derive(Debug)]
pub struct NamedVars {
    /// `[0]` is the main program's; a subroutine call pushes one.
    locals: Vec<HashMap<String, f64>>,
    globals: HashMap<String, f64>,
}

impl Default for NamedVars {
    fn default() -> Self {
        NamedVars {
            locals: vec![HashMap::new()],
            globals: HashMap::new(),
        }
    }
}

/// A name is global when it starts with `_` (LinuxCNC).
pub fn is_global(name: &str) -> bool {
    name.starts_with('_')
}

impl NamedVars {
    pub fn reset(&mut self) {
        *self = NamedVars::default();
    }

    /// The value of `name` in the current scope (or global), `None` when never assigned.
    pub fn get(&self, name: &str) -> Option<f64> {
        if is_global(name) {
            self.globals.get(name).copied()
        } else {
            self.locals.last().and_then(|s| s.get(name)).copied()
        }
    }

    /// Assigns `name`; an error when a scope would pass [`MAX_NAMES`].
    pub fn set(&mut self, name: &str, v: f64) -> Result<(), String> {
        let scope = if is_global(name) {
            &mut self.globals
        } else {
            match self.locals.last_mut() {
                Some(s) => s,
                None => return Ok(()),
            }
        };
        if scope.len() >= MAX_NAMES && !scope.contains_key(name) {
            return Err(format!(
                "more than {MAX_NAMES} named parameters in one scope (#<{name}>)"
            ));
        }
        scope.insert(name.to_string(), v);
        Ok(())
    }

    /// A subroutine call: its own locals.
    pub fn push_scope(&mut self) {
        self.locals.push(HashMap::new());
    }

    /// The subroutine returned: its locals go.
    pub fn pop_scope(&mut self) {
        if self.locals.len() > 1 {
            self.locals.pop();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn locals_belong_to_their_call_and_globals_to_all() {
        let mut t = NamedVars::default();
        t.set("a", 1.0).unwrap();
        t.set("_g", 2.0).unwrap();
        t.push_scope();
        assert_eq!((t.get("a"), t.get("_g")), (None, Some(2.0)));
        t.set("a", 5.0).unwrap();
        t.set("_g", 3.0).unwrap();
        t.pop_scope();
        assert_eq!((t.get("a"), t.get("_g")), (Some(1.0), Some(3.0)));
    }

    #[test]
    fn a_scope_is_bounded() {
        let mut t = NamedVars::default();
        for i in 0..MAX_NAMES {
            t.set(&format!("n{i}"), 0.0).unwrap();
        }
        assert!(t.set("one_more", 0.0).is_err());
        assert!(t.set("n0", 1.0).is_ok());
    }
}
