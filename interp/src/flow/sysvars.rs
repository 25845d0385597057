//! Macro variables as the program reads and writes them: one classification ([`VarClass`])
//! sends `#n` to the variable tables, to the program flow (`#4113–#4115`, `#4012`) or to the
//! block layer ([`Machine`](crate::block::Machine): modal state, positions, offsets).

use crate::expr::VarSource;
use crate::vars::nv::{NV_FIRST, NV_LAST};
use crate::vars::{MVal, VarClass};

use super::Interpreter;

/// LinuxCNC's global parameters; those Fanuc gives no writable meaning are kept apart.
pub(crate) const LC_GLOBALS: std::ops::RangeInclusive<i64> = 31..=5000;

impl VarSource for Interpreter {
    fn get(&mut self, n: i64) -> Result<Option<f64>, String> {
        if self.m.dialect == cnc402_lang::Dialect::LinuxCnc {
            return super::oword::linuxcnc_read(self, n);
        }
        self.read_var(n)
    }
    fn get_named(&mut self, name: &str) -> Result<Option<f64>, String> {
        self.read_named(name)
    }
    fn named_exists(&mut self, name: &str) -> bool {
        self.read_named(name).is_ok()
    }
}

impl Interpreter {
    /// Reads `#n` (system variables included). A position read (`#5021…`, `#5041…`) first
    /// waits for motion through the [`MotionSync`](crate::host::MotionSync).
    pub(crate) fn read_var(&mut self, n: i64) -> Result<MVal, String> {
        let class = VarClass::of(n, self.m.cfg.axes.len())?;
        if let Some(v) = self.vars.table.read(class) {
            return Ok(v);
        }
        Ok(match class {
            VarClass::ModalInfo(13) => self.flow.last_m,
            VarClass::ModalInfo(14) => self.flow.last_n,
            VarClass::ModalInfo(15) => self
                .flow
                .frames
                .last()
                .and_then(|f| f.unit.number)
                .map(f64::from),
            _ => {
                let modal_call = self.flow.modal_call.is_some();
                return self.m.read_class(n, class, modal_call);
            }
        })
    }

    /// Writes `#n`; system variables with side effects (`#3000`, `#3006`) are handled by the
    /// assignment itself.
    pub(crate) fn write_var(&mut self, n: i64, v: MVal) -> Result<(), String> {
        if self.m.dialect == cnc402_lang::Dialect::LinuxCnc {
            if n == super::oword::LC_DEBUG_SWITCH {
                self.flow.lc_debug_switch = v.unwrap_or(0.0);
                return Ok(());
            }
            if LC_GLOBALS.contains(&n)
                && (self.flow.lc_globals.contains_key(&n) || !self.fanuc_writable(n))
            {
                self.flow.lc_globals.insert(n, v.unwrap_or(0.0));
                return Ok(());
            }
        }
        let class = VarClass::of(n, self.m.cfg.axes.len())?;
        if class == VarClass::Null {
            return Err("#0 is always vacant and cannot be written".into());
        }
        if self.vars.table.write(class, v) {
            if let (VarClass::NonVolatile(nv), Some(s)) = (class, self.vars.store.as_mut()) {
                s.store_write(nv, self.vars.table.nv.as_slice())
                    .map_err(|e| format!("#{n} could not be stored (non-volatile): {e}"))?;
            }
            return Ok(());
        }
        if self.m.write_class(class, v)? {
            return Ok(());
        }
        Err(format!(
            "#{n} cannot be written (locals #1-#33, common #100-#199, non-volatile #{NV_FIRST}-#{NV_LAST}, work offsets #5221-#5326, tool offsets #2001-#2400 and #10001-#13400, #3000, #3006)"
        ))
    }

    /// `#n` has a writable meaning in the Fanuc variable map (what the linuxcnc dialect keeps
    /// there rather than among its own globals).
    fn fanuc_writable(&self, n: i64) -> bool {
        matches!(n, 3000 | 3006)
            || matches!(
                VarClass::of(n, self.m.cfg.axes.len()),
                Ok(VarClass::Local(_)
                    | VarClass::Common(_)
                    | VarClass::NonVolatile(_)
                    | VarClass::WorkOffset { .. }
                    | VarClass::ToolOffset { .. })
            )
    }
}
