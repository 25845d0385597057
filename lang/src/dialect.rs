//! Which control's habits a program is written for ([`Dialect`]). The dialect is chosen once
//! per program, in this order: the command line (`--dialect`), the program's own header
//! ([`crate::declared_dialect`]), the machine config (`interp.dialect`), else Fanuc.

use std::fmt;
use std::str::FromStr;

/// A control whose programs cnc402 reads as that control does where controls differ.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Dialect {
    /// Fanuc 0/16/18/21/30i M series with Custom Macro B (and the C-like language of
    /// source 000). The default.
    #[default]
    Fanuc,
    /// Haas mills: Fanuc plus Haas habits (a bare `G28` homes every axis, decimal `P` in
    /// seconds for cycle dwells, Haas M codes).
    Haas,
    /// LinuxCNC's rs274ngc: O-word subroutines and flow, named parameters, polar words,
    /// `G92.1`–`G92.3`, dwell `P` in seconds, LinuxCNC's canned-cycle retract.
    LinuxCnc,
}

impl Dialect {
    /// Every dialect, in the order the documentation lists them.
    pub const ALL: [Dialect; 3] = [Dialect::Fanuc, Dialect::Haas, Dialect::LinuxCnc];

    /// The name used in the config, on the command line and in program headers.
    pub fn name(self) -> &'static str {
        match self {
            Dialect::Fanuc => "fanuc",
            Dialect::Haas => "haas",
            Dialect::LinuxCnc => "linuxcnc",
        }
    }

    /// The valid names, for messages: `fanuc, haas or linuxcnc`.
    pub fn expected() -> String {
        let names: Vec<&str> = Self::ALL.iter().map(|d| d.name()).collect();
        format!(
            "{} or {}",
            names[..names.len() - 1].join(", "),
            names[names.len() - 1]
        )
    }
}

impl fmt::Display for Dialect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The name was none of [`Dialect::ALL`].
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct UnknownDialect(pub String);

impl fmt::Display for UnknownDialect {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "unknown dialect {:?} (expected {})",
            self.0,
            Dialect::expected()
        )
    }
}

impl std::error::Error for UnknownDialect {}

impl FromStr for Dialect {
    type Err = UnknownDialect;

    /// Case-insensitive: `LinuxCNC` is `linuxcnc`.
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|d| d.name().eq_ignore_ascii_case(s.trim()))
            .ok_or_else(|| UnknownDialect(s.trim().to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_in_any_case_and_print_lower_case() {
        for d in Dialect::ALL {
            assert_eq!(d.name().to_uppercase().parse::<Dialect>(), Ok(d));
            assert_eq!(d.to_string(), d.name());
        }
        assert_eq!("LinuxCNC".parse::<Dialect>(), Ok(Dialect::LinuxCnc));
        assert_eq!(
            "siemens".parse::<Dialect>().unwrap_err().to_string(),
            "unknown dialect \"siemens\" (expected fanuc, haas or linuxcnc)"
        );
    }
}
