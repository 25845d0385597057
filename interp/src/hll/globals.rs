//! The `$` globals as the C-like executor reads and writes them: the table is the host's
//! ([`crate::host::channels::SharedGlobals`] shares one between the channels of a run), its
//! values converted to and from the executor's.

use std::sync::Arc;

use crate::host::channels::SharedValue;
pub(crate) use crate::host::channels::{Global, Globals, lock};

use super::ir::Val;

/// A value as a `$` global holds it (an array is not a value a global can hold).
pub(crate) fn to_shared(v: Val) -> Result<SharedValue, String> {
    Ok(match v {
        Val::Int(i) => SharedValue::Int(i),
        Val::Dbl(d) => SharedValue::Double(d),
        Val::Str(s) => SharedValue::Str(s.to_string()),
        Val::Bool(b) => SharedValue::Bool(b),
        Val::Arr(_) | Val::ArrRef(_) => {
            return Err("a $ global holds a number, a string or a bool, not an array".into());
        }
    })
}

/// A `$` global's value as the executor computes with it.
pub(crate) fn from_shared(v: &SharedValue) -> Val {
    match v {
        SharedValue::Int(i) => Val::Int(*i),
        SharedValue::Double(d) => Val::Dbl(*d),
        SharedValue::Str(s) => Val::Str(Arc::from(s.as_str())),
        SharedValue::Bool(b) => Val::Bool(*b),
    }
}
