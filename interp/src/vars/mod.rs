//! Macro variables: the one classification of variable numbers ([`VarClass`]) that reading
//! and writing share, the tables of local, common and non-volatile values ([`VarTable`]), and
//! the non-volatile table's file format ([`nv`]). System variables are answered by the layers
//! that own their state (block state, program flow); this layer only says which is which.

mod class;
pub mod named;
pub mod nv;

pub use class::{OffsetField, VarClass, tool_offset_var};
pub use named::NamedVars;
pub use nv::NvTable;

/// A macro value; `None` is vacant.
pub type MVal = Option<f64>;

/// Local, common and non-volatile variables.
#[derive(Debug)]
pub struct VarTable {
    /// One set of `#1–#33` per macro call level; `[0]` is the main program's.
    pub locals: Vec<[MVal; 33]>,
    pub common: [MVal; 100],
    /// `#500–#999`, kept across `load`s.
    pub nv: NvTable,
    /// Reads of `#500–#999` so far.
    pub nv_reads: u64,
}

impl Default for VarTable {
    fn default() -> Self {
        VarTable {
            locals: vec![[None; 33]],
            common: [None; 100],
            nv: NvTable::default(),
            nv_reads: 0,
        }
    }
}

impl VarTable {
    /// Reset: locals and common variables vacant; non-volatile ones kept.
    pub fn reset(&mut self) {
        self.locals = vec![[None; 33]];
        self.common = [None; 100];
    }

    /// `#n` of a class this table holds; `None` for the others.
    pub fn read(&mut self, class: VarClass) -> Option<MVal> {
        Some(match class {
            VarClass::Local(i) => self.locals.last().and_then(|l| l[i]),
            VarClass::Common(i) => self.common[i],
            VarClass::NonVolatile(n) => {
                self.nv_reads += 1;
                self.nv.get(n)
            }
            _ => return None,
        })
    }

    /// Writes `#n` of a class this table holds: `true` if it held it (a non-volatile write
    /// is then the caller's to make durable).
    pub fn write(&mut self, class: VarClass, v: MVal) -> bool {
        match class {
            VarClass::Local(i) => {
                if let Some(l) = self.locals.last_mut() {
                    l[i] = v;
                }
            }
            VarClass::Common(i) => self.common[i] = v,
            // In range by the classification: `set` cannot fail.
            VarClass::NonVolatile(n) => {
                let _ = self.nv.set(n, v);
            }
            _ => return false,
        }
        true
    }
}
