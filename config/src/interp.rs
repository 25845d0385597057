//! `[interp]`: the interpreter's modal defaults at program start, canned cycle amounts, and
//! where sub-programs, libraries and the non-volatile variables live.

use std::path::PathBuf;

use cnc402_lang::Dialect;
use cnc402_lang::dialect::UnknownDialect;
use serde::Deserialize;
use toml::Spanned;

use crate::MachineConfig;
use crate::check::{Invalid, angle_in_turn, int_in, positive_at_most, sp};
use crate::cutter_comp::{CutterComp, RawCutterComp};

/// Ceiling of the interpreter's lengths (retracts, clearances, tolerances; mm): one metre,
/// beyond any cycle amount or tolerance.
const MAX_LENGTH: f64 = 1000.0;

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Units {
    Mm,
    Inch,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PlaneDefault {
    XY,
    ZX,
    YZ,
}

/// The path mode at program start (group 15).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PathModeDefault {
    /// G64: blend blocks within the path tolerance.
    Continuous,
    /// G61: stop exactly at every block end.
    ExactStop,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReturnPlane {
    /// G98
    Initial,
    /// G99
    R,
}

#[derive(Clone, Debug, PartialEq)]
pub struct InterpDefaults {
    /// The dialect programs are read in unless their header or the command line names
    /// another (`"fanuc"`, `"haas"`, `"linuxcnc"`; default `"fanuc"`).
    pub dialect: Dialect,
    pub units: Units,
    pub plane: PlaneDefault,
    pub return_plane: ReturnPlane,
    /// G73 retract d (mm).
    pub peck_retract: f64,
    /// G83 re-entry clearance d (mm).
    pub peck_clearance: f64,
    /// G84/G74 peck tapping: how far the tap backs out after each peck (mm; Fanuc parameter
    /// No. 5213, the return amount of peck tapping). Default: `peck_retract`'s value.
    pub tap_peck_retract: f64,
    /// An I/J/K arc is refused when its start and end radius differ by more than this
    /// (mm, in G21 programs) and by more than `arc_tolerance_relative` of the radius, or by
    /// more than 100 times this (LinuxCNC's rule and `CENTER_ARC_RADIUS_TOLERANCE_MM`).
    /// Also the planner's limit for an arc whose radius changes from start to end.
    pub arc_tolerance: f64,
    /// `arc_tolerance` for G20 programs, in inches (LinuxCNC's
    /// `CENTER_ARC_RADIUS_TOLERANCE_INCH`).
    pub arc_tolerance_inch: f64,
    /// The relative part of the arc rule: a fraction of the larger radius (LinuxCNC's
    /// `SPIRAL_RELATIVE_TOLERANCE`, 0.001); 0 turns it off (the absolute tolerance alone).
    pub arc_tolerance_relative: f64,
    /// G64 continuous-path mode's default corner tolerance (mm): how far the path may leave
    /// a corner between blocks when the program gives none (LinuxCNC's G64 P, Fanuc's default).
    pub path_tolerance: f64,
    /// The largest tolerance a program may ask for with `G64 P` / `Q` (mm).
    pub max_path_tolerance: f64,
    /// G64's collinearity tolerance when the program gives neither P nor Q (mm, LinuxCNC's
    /// `G64_DEFAULT_NAIVETOLERANCE`): feed lines whose corners lie within it of one straight
    /// line run as that line; 0 merges nothing. Also for `G64 P` without Q (LinuxCNC takes
    /// P there; README "Continuous path" says why cnc402 does not).
    pub collinear_tolerance: f64,
    /// G64 or G61 at program start.
    pub path_mode: PathModeDefault,
    /// The physical spindle angle (degrees, 0 ≤ angle < 360, in the spindle axis's machine
    /// coordinate) that spindle orientation (G76/G87) turns C to: where the boring bar's
    /// edge points away from the shift direction.
    pub spindle_orient_angle: f64,
    /// Where sub-programs (`O9001.nc`, …) are looked up; relative to the config file's folder's
    /// parent when relative (so `examples` means `<repo>/examples`).
    pub program_dir: PathBuf,
    /// Blocks executed without motion before a program is called runaway.
    pub block_limit: u64,
    /// The file of the non-volatile macro variables `#500–#999` (`None`: kept in memory for
    /// one run). Relative paths resolve like `program_dir`; see [`crate::MachineConfig::variables_file`].
    pub variables_file: Option<PathBuf>,
    /// Where `#use "file"` of the C-like language looks after the including file's folder
    /// (`None`: nowhere else). Relative paths resolve like `program_dir`.
    pub library_dir: Option<PathBuf>,
    /// Cutter radius compensation (`cutter_comp_*` keys).
    pub cutter_comp: CutterComp,
    /// The Fanuc multi-path waiting M codes (`M100`…`M199` by default, `[100, 199]`): `M<n>
    /// P12` waits until paths (channels) 1 and 2 reach `M<n>`. `None` (`wait_mcodes = []`):
    /// none. An M code in `[mcodes]` is that action, not a wait.
    pub wait_mcodes: Option<(u32, u32)>,
}

/// `[interp]` as written, with spans; every key has a default.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawInterp {
    #[serde(default)]
    dialect: Option<Spanned<String>>,
    #[serde(default = "default_units")]
    units: Spanned<String>,
    #[serde(default = "default_plane")]
    plane: Spanned<String>,
    #[serde(default = "default_return")]
    return_plane: Spanned<String>,
    #[serde(default = "default_half")]
    peck_retract: Spanned<f64>,
    #[serde(default = "default_half")]
    peck_clearance: Spanned<f64>,
    #[serde(default)]
    tap_peck_retract: Option<Spanned<f64>>,
    #[serde(default = "default_arc_tol")]
    arc_tolerance: Spanned<f64>,
    #[serde(default = "default_arc_tol_inch")]
    arc_tolerance_inch: Spanned<f64>,
    #[serde(default = "default_arc_tol_relative")]
    arc_tolerance_relative: Spanned<f64>,
    #[serde(default = "default_path_tol")]
    path_tolerance: Spanned<f64>,
    #[serde(default = "default_max_path_tol")]
    max_path_tolerance: Spanned<f64>,
    #[serde(default = "default_collinear_tol")]
    collinear_tolerance: Spanned<f64>,
    #[serde(default = "default_path_mode")]
    path_mode: Spanned<String>,
    #[serde(default = "default_orient_angle")]
    spindle_orient_angle: Spanned<f64>,
    #[serde(default = "default_program_dir")]
    program_dir: Spanned<String>,
    #[serde(default = "default_block_limit")]
    block_limit: Spanned<i64>,
    #[serde(default)]
    variables_file: Option<Spanned<String>>,
    #[serde(default)]
    library_dir: Option<Spanned<String>>,
    #[serde(default)]
    cutter_comp_corner: Option<Spanned<String>>,
    #[serde(default)]
    cutter_comp_startup: Option<Spanned<String>>,
    #[serde(default)]
    cutter_comp_gouge: Option<Spanned<String>>,
    #[serde(default)]
    cutter_comp_lookahead: Option<Spanned<i64>>,
    #[serde(default)]
    cutter_comp_chamfer_angle: Option<Spanned<f64>>,
    #[serde(default)]
    wait_mcodes: Option<Spanned<Vec<i64>>>,
}

impl Default for RawInterp {
    fn default() -> Self {
        RawInterp {
            dialect: None,
            units: default_units(),
            plane: default_plane(),
            return_plane: default_return(),
            peck_retract: default_half(),
            peck_clearance: default_half(),
            tap_peck_retract: None,
            arc_tolerance: default_arc_tol(),
            arc_tolerance_inch: default_arc_tol_inch(),
            arc_tolerance_relative: default_arc_tol_relative(),
            path_tolerance: default_path_tol(),
            max_path_tolerance: default_max_path_tol(),
            collinear_tolerance: default_collinear_tol(),
            path_mode: default_path_mode(),
            spindle_orient_angle: default_orient_angle(),
            program_dir: default_program_dir(),
            block_limit: default_block_limit(),
            variables_file: None,
            library_dir: None,
            cutter_comp_corner: None,
            cutter_comp_startup: None,
            cutter_comp_gouge: None,
            cutter_comp_lookahead: None,
            cutter_comp_chamfer_angle: None,
            wait_mcodes: None,
        }
    }
}

fn default_units() -> Spanned<String> {
    sp("mm".into())
}
fn default_plane() -> Spanned<String> {
    sp("XY".into())
}
fn default_return() -> Spanned<String> {
    sp("initial".into())
}
fn default_half() -> Spanned<f64> {
    sp(0.5)
}
/// LinuxCNC's `CENTER_ARC_RADIUS_TOLERANCE_MM`, 2 · 0.01 · √2 mm (interp_internal.hh).
fn default_arc_tol() -> Spanned<f64> {
    sp(2.0 * 0.01 * std::f64::consts::SQRT_2)
}
/// LinuxCNC's `CENTER_ARC_RADIUS_TOLERANCE_INCH`, 2 · 0.001 · √2 inch.
fn default_arc_tol_inch() -> Spanned<f64> {
    sp(2.0 * 0.001 * std::f64::consts::SQRT_2)
}
/// LinuxCNC's `SPIRAL_RELATIVE_TOLERANCE`.
fn default_arc_tol_relative() -> Spanned<f64> {
    sp(0.001)
}
fn default_path_tol() -> Spanned<f64> {
    sp(0.01)
}
fn default_max_path_tol() -> Spanned<f64> {
    sp(1.0)
}
fn default_collinear_tol() -> Spanned<f64> {
    sp(0.0)
}
fn default_path_mode() -> Spanned<String> {
    sp("continuous".into())
}
fn default_orient_angle() -> Spanned<f64> {
    sp(0.0)
}
fn default_program_dir() -> Spanned<String> {
    sp("examples".into())
}
fn default_block_limit() -> Spanned<i64> {
    sp(1_000_000)
}

impl RawInterp {
    /// Checks each key; a left-out `tap_peck_retract` takes `peck_retract`'s value.
    pub(crate) fn validate(&self) -> Result<InterpDefaults, Invalid> {
        let d = self.validate_keys()?;
        if d.collinear_tolerance > d.max_path_tolerance {
            return Err((
                self.collinear_tolerance.span(),
                "interp.collinear_tolerance".into(),
                format!(
                    "must be at most interp.max_path_tolerance ({}), got {}",
                    d.max_path_tolerance, d.collinear_tolerance
                ),
            ));
        }
        if d.path_tolerance > d.max_path_tolerance {
            return Err((
                self.path_tolerance.span(),
                "interp.path_tolerance".into(),
                format!(
                    "must be at most interp.max_path_tolerance ({}), got {}",
                    d.max_path_tolerance, d.path_tolerance
                ),
            ));
        }
        Ok(d)
    }

    fn validate_keys(&self) -> Result<InterpDefaults, Invalid> {
        let i = self;
        Ok(InterpDefaults {
            dialect: match &i.dialect {
                None => Dialect::default(),
                Some(d) => d.get_ref().parse().map_err(|e: UnknownDialect| {
                    (d.span(), "interp.dialect".into(), e.to_string())
                })?,
            },
            units: match i.units.get_ref().as_str() {
                "mm" => Units::Mm,
                "inch" => Units::Inch,
                o => {
                    return Err((
                        i.units.span(),
                        "interp.units".into(),
                        format!("expected \"mm\" or \"inch\", got {o:?}"),
                    ));
                }
            },
            plane: match i.plane.get_ref().to_ascii_uppercase().as_str() {
                "XY" | "G17" => PlaneDefault::XY,
                "ZX" | "XZ" | "G18" => PlaneDefault::ZX,
                "YZ" | "G19" => PlaneDefault::YZ,
                o => {
                    return Err((
                        i.plane.span(),
                        "interp.plane".into(),
                        format!("expected \"XY\", \"ZX\" or \"YZ\", got {o:?}"),
                    ));
                }
            },
            return_plane: match i.return_plane.get_ref().to_ascii_lowercase().as_str() {
                "initial" | "g98" => ReturnPlane::Initial,
                "r" | "g99" => ReturnPlane::R,
                o => {
                    return Err((
                        i.return_plane.span(),
                        "interp.return_plane".into(),
                        format!("expected \"initial\" (G98) or \"r\" (G99), got {o:?}"),
                    ));
                }
            },
            peck_retract: positive_at_most(&i.peck_retract, "interp.peck_retract", MAX_LENGTH)?,
            peck_clearance: positive_at_most(
                &i.peck_clearance,
                "interp.peck_clearance",
                MAX_LENGTH,
            )?,
            tap_peck_retract: match &i.tap_peck_retract {
                Some(v) => positive_at_most(v, "interp.tap_peck_retract", MAX_LENGTH)?,
                None => positive_at_most(&i.peck_retract, "interp.peck_retract", MAX_LENGTH)?,
            },
            arc_tolerance: positive_at_most(&i.arc_tolerance, "interp.arc_tolerance", MAX_LENGTH)?,
            arc_tolerance_inch: positive_at_most(
                &i.arc_tolerance_inch,
                "interp.arc_tolerance_inch",
                MAX_LENGTH / 25.4,
            )?,
            arc_tolerance_relative: fraction(
                &i.arc_tolerance_relative,
                "interp.arc_tolerance_relative",
            )?,
            path_tolerance: positive_at_most(
                &i.path_tolerance,
                "interp.path_tolerance",
                MAX_LENGTH,
            )?,
            max_path_tolerance: positive_at_most(
                &i.max_path_tolerance,
                "interp.max_path_tolerance",
                MAX_LENGTH,
            )?,
            collinear_tolerance: if *i.collinear_tolerance.get_ref() == 0.0 {
                0.0
            } else {
                positive_at_most(
                    &i.collinear_tolerance,
                    "interp.collinear_tolerance",
                    MAX_LENGTH,
                )?
            },
            path_mode: match i.path_mode.get_ref().to_ascii_lowercase().as_str() {
                "continuous" | "g64" => PathModeDefault::Continuous,
                "exact" | "g61" => PathModeDefault::ExactStop,
                o => {
                    return Err((
                        i.path_mode.span(),
                        "interp.path_mode".into(),
                        format!("expected \"continuous\" (G64) or \"exact\" (G61), got {o:?}"),
                    ));
                }
            },
            spindle_orient_angle: angle_in_turn(
                &i.spindle_orient_angle,
                "interp.spindle_orient_angle",
            )?,
            program_dir: optional_path(
                &Some(i.program_dir.clone()),
                "interp.program_dir",
                "leave the key out for \"examples\"",
            )?
            .unwrap_or_default(),
            block_limit: int_in(&i.block_limit, "interp.block_limit", 1, i64::MAX)? as u64,
            variables_file: optional_path(
                &i.variables_file,
                "interp.variables_file",
                "leave the key out to keep the variables in memory",
            )?,
            library_dir: optional_path(
                &i.library_dir,
                "interp.library_dir",
                "leave the key out to search only next to the program",
            )?,
            cutter_comp: RawCutterComp {
                corner: &i.cutter_comp_corner,
                startup: &i.cutter_comp_startup,
                gouge: &i.cutter_comp_gouge,
                lookahead: &i.cutter_comp_lookahead,
                chamfer_angle: &i.cutter_comp_chamfer_angle,
            }
            .validate()?,
            wait_mcodes: wait_mcodes(&i.wait_mcodes)?,
        })
    }
}

/// `wait_mcodes`: `[first, last]` M numbers (default `[100, 199]`), none of them built in;
/// `[]` for none.
fn wait_mcodes(v: &Option<Spanned<Vec<i64>>>) -> Result<Option<(u32, u32)>, Invalid> {
    let Some(v) = v else {
        return Ok(Some((100, 199)));
    };
    let bad = |m: String| Err((v.span(), "interp.wait_mcodes".to_string(), m));
    let (first, last) = match v.get_ref()[..] {
        [] => return Ok(None),
        [a, b] => (a, b),
        _ => return bad("expected [first, last] M numbers, e.g. [100, 199], or []".into()),
    };
    if !(0..=9999).contains(&first) || !(first..=9999).contains(&last) {
        return bad(format!(
            "expected M numbers 0 <= first <= last <= 9999, got [{first}, {last}]"
        ));
    }
    let (first, last) = (first as u32, last as u32);
    if let Some(b) = crate::BUILT_IN_M_CODES
        .iter()
        .find(|c| (first..=last).contains(c))
    {
        return bad(format!(
            "[{first}, {last}] holds M{b}, which the interpreter defines"
        ));
    }
    Ok(Some((first, last)))
}

/// A finite fraction 0 ≤ x ≤ 1.
fn fraction(v: &Spanned<f64>, key: &str) -> Result<f64, Invalid> {
    let x = *v.get_ref();
    if x.is_finite() && (0.0..=1.0).contains(&x) {
        Ok(x)
    } else {
        Err((
            v.span(),
            key.to_string(),
            format!("expected a fraction 0 <= x <= 1, got {x}"),
        ))
    }
}

/// An optional path key: left out is `None`, given it must not be blank (`hint` says how
/// to get the `None` behaviour).
fn optional_path(
    v: &Option<Spanned<String>>,
    key: &str,
    hint: &str,
) -> Result<Option<PathBuf>, Invalid> {
    match v {
        None => Ok(None),
        Some(f) if f.get_ref().trim().is_empty() => Err((
            f.span(),
            key.to_string(),
            format!("must not be empty ({hint})"),
        )),
        Some(f) => Ok(Some(PathBuf::from(f.get_ref()))),
    }
}

impl RawInterp {
    /// What only the file system can tell: `variables_file` must not name a folder, nor
    /// `program_dir` and `library_dir` a file (where they exist; a missing one is created or
    /// reported when used). Checked at load, so that the error names the key and its line
    /// rather than the program's first line.
    pub(crate) fn check_paths(&self, cfg: &MachineConfig) -> Result<(), Invalid> {
        if let (Some(v), Some(f)) = (&self.variables_file, cfg.variables_file())
            && f.is_dir()
        {
            return Err((
                v.span(),
                "interp.variables_file".into(),
                format!("{} is a folder, not a file", f.display()),
            ));
        }
        let folders = [
            (
                Some(&self.program_dir),
                Some(cfg.program_dir()),
                "program_dir",
            ),
            (self.library_dir.as_ref(), cfg.library_dir(), "library_dir"),
        ];
        for (v, dir, key) in folders {
            if let (Some(v), Some(dir)) = (v, dir)
                && dir.exists()
                && !dir.is_dir()
            {
                return Err((
                    v.span(),
                    format!("interp.{key}"),
                    format!("{} is a file, not a folder", dir.display()),
                ));
            }
        }
        Ok(())
    }
}

#[cfg(test)]
mod wait_mcodes_key {
    use std::path::Path;

    use crate::MachineConfig;

    const SHIPPED: &str = include_str!("../machine.toml");

    fn with_key(line: &str) -> Result<MachineConfig, crate::ConfigError> {
        let text = SHIPPED.replacen("[interp]\n", &format!("[interp]\n{line}\n"), 1);
        MachineConfig::parse(&text, Path::new("m.toml"))
    }

    #[test]
    fn default_is_fanuc_m100_to_m199_and_empty_turns_it_off() {
        let c = MachineConfig::parse(SHIPPED, Path::new("m.toml")).unwrap();
        assert_eq!(c.interp.wait_mcodes, Some((100, 199)));
        let c = with_key("wait_mcodes = [300, 310]").unwrap();
        assert_eq!(c.interp.wait_mcodes, Some((300, 310)));
        assert_eq!(
            with_key("wait_mcodes = []").unwrap().interp.wait_mcodes,
            None
        );
    }

    #[test]
    fn a_bad_range_names_the_key_and_its_line() {
        let line = SHIPPED.lines().position(|l| l == "[interp]").unwrap() + 2;
        for (v, says) in [
            ("[100]", "expected [first, last]"),
            ("[199, 100]", "0 <= first <= last <= 9999"),
            ("[90, 120]", "holds M98"),
            ("[-1, 5]", "0 <= first"),
        ] {
            let e = with_key(&format!("wait_mcodes = {v}")).unwrap_err();
            assert_eq!(
                (e.key.as_str(), e.line),
                ("interp.wait_mcodes", line),
                "{e}"
            );
            assert!(e.to_string().contains(says), "{v}: {e}");
        }
    }
}
