//! The post's tool table (`cnc402 post --tools FILE.toml`) and source 003's cutting data:
//! spindle speed from cutting speed, n = 1000·Vc / (π·D), and feed from feed per tooth,
//! F = fz·z·n. A CL job's `SPINDL/ vc, SMM` and `FEDRAT/ fz, MMPT` are recomputed with the
//! diameter and teeth of the tool it loaded.
//!
//! ```toml
//! [tool.1]
//! diameter = 10.0   # mm
//! teeth = 4
//! ```

use std::collections::BTreeMap;

/// One tool: diameter (mm) and number of teeth.
#[derive(Clone, Copy, Debug, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tool {
    pub diameter: f64,
    pub teeth: u32,
}

/// The table: tool number → tool.
#[derive(Clone, Debug, Default, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ToolTable {
    #[serde(default)]
    pub tool: BTreeMap<u32, Tool>,
}

impl ToolTable {
    /// The table in `text` (a TOML file), or what is wrong with it (key and line).
    pub fn parse(text: &str) -> Result<ToolTable, String> {
        let t: ToolTable = toml::from_str(text).map_err(|e| e.to_string())?;
        for (n, tool) in &t.tool {
            if !(tool.diameter > 0.0 && tool.diameter.is_finite()) || tool.teeth == 0 {
                return Err(format!("tool.{n}: diameter must be > 0 and teeth >= 1"));
            }
        }
        Ok(t)
    }
}

/// Spindle speed (rpm) for cutting speed `vc` (m/min) on diameter `d` (mm), rounded to a
/// whole rpm (the controls' S has no decimals).
pub fn rpm_from_vc(vc: f64, d: f64) -> f64 {
    (1000.0 * vc / (std::f64::consts::PI * d)).round()
}

/// Feed (mm/min) for `fz` mm per tooth, `teeth` teeth at `rpm`.
pub fn feed_from_fz(fz: f64, teeth: u32, rpm: f64) -> f64 {
    fz * f64::from(teeth) * rpm
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cutting_data_as_source_003_gives_it() {
        // Vc 200 m/min on a 10 mm cutter: 6366.2 rpm, written S6366.
        assert_eq!(rpm_from_vc(200.0, 10.0), 6366.0);
        assert_eq!(feed_from_fz(0.05, 4, 6366.0), 0.05 * 4.0 * 6366.0);
    }

    #[test]
    fn the_table_reads_and_refuses_nonsense() {
        let t = ToolTable::parse("[tool.3]\ndiameter = 8.0\nteeth = 3\n").unwrap();
        assert_eq!(
            t.tool[&3],
            Tool {
                diameter: 8.0,
                teeth: 3
            }
        );
        assert!(ToolTable::parse("[tool.3]\ndiameter = 0.0\nteeth = 3\n").is_err());
        assert!(ToolTable::parse("[tool.3]\ndiamter = 8.0\nteeth = 3\n").is_err());
    }
}
