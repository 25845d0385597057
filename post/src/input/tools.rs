//! The post's tool table (`cnc402 post --tools FILE.toml`) and source 003's cutting data:
//! spindle speed from cutting speed, n = 1000·Vc / (π·D), and feed from feed per tooth,
//! F = fz·z·n. A CL job's `SPINDL/ vc, SMM` and `FEDRAT/ fz, MMPT` are recomputed with the
//! diameter and teeth of the tool it loaded; `SPINDL/CLW` without a speed and
//! `FEDRAT/MMPT` without a feed take the tool's own Vc and fz. Without `--tools` the table
//! is the config's `[tool_offsets]` entries that carry cutting data.
//!
//! ```toml
//! [tool.1]
//! diameter = 10.0   # mm
//! teeth = 4
//! vc = 150.0        # m/min (optional)
//! fz = 0.05         # mm per tooth (optional)
//! ```

use std::collections::BTreeMap;

/// One tool: diameter (mm), number of teeth, cutting speed Vc (m/min), feed per tooth fz
/// (mm); what a table leaves out is `None` (an error where it is needed).
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Tool {
    pub diameter: Option<f64>,
    pub teeth: Option<u32>,
    pub vc: Option<f64>,
    pub fz: Option<f64>,
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
            let values = [
                ("diameter", tool.diameter),
                ("vc", tool.vc),
                ("fz", tool.fz),
                ("teeth", tool.teeth.map(f64::from)),
            ];
            for (key, v) in values {
                if v.is_some_and(|v| !(v > 0.0 && v.is_finite())) {
                    return Err(format!("tool.{n}: {key} must be > 0"));
                }
            }
        }
        Ok(t)
    }

    /// The table of the config's `[tool_offsets]` entries that carry cutting data (keys
    /// `diameter`, `teeth`, `vc`, `fz`), numbered as the offsets.
    pub fn from_config(cfg: &cnc402_config::MachineConfig) -> ToolTable {
        let tool = (1u32..)
            .zip(&cfg.tool_offsets)
            .filter(|(_, t)| t.cutting != cnc402_config::CuttingData::default())
            .map(|(n, t)| {
                let c = t.cutting;
                let tool = Tool {
                    diameter: c.diameter,
                    teeth: c.teeth,
                    vc: c.vc,
                    fz: c.fz,
                };
                (n, tool)
            })
            .collect();
        ToolTable { tool }
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
                diameter: Some(8.0),
                teeth: Some(3),
                ..Tool::default()
            }
        );
        assert!(ToolTable::parse("[tool.3]\nvc = -1.0\n").is_err());
        assert!(ToolTable::parse("[tool.3]\ndiameter = 0.0\nteeth = 3\n").is_err());
        assert!(ToolTable::parse("[tool.3]\ndiamter = 8.0\nteeth = 3\n").is_err());
    }
}
