//! The machine description (`config/machine.toml`): axes, bus, interpreter defaults and work
//! offsets. Text is parsed into a raw, span-carrying form, then validated into
//! [`MachineConfig`], the plain plan every other crate reads. Every error, syntactic or
//! semantic, names the file, line, column and key path.

use std::fmt;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Spanned;

/// Most axes a machine may configure; keeps per-axis arrays fixed-size and `Copy`.
pub const MAX_AXES: usize = 8;

/// Default config path, relative to the working directory.
pub const DEFAULT_PATH: &str = "config/machine.toml";

#[derive(Clone, Debug, PartialEq)]
pub struct MachineConfig {
    /// The file it was read from (for resolving relative paths and for messages).
    pub path: PathBuf,
    pub axes: Vec<AxisConfig>,
    pub bus: BusConfig,
    pub interp: InterpDefaults,
    /// G54..G59: machine position of the work zero, indexed like `axes`.
    pub work_offsets: [[f64; MAX_AXES]; 6],
    /// Tool offsets 1..=[`TOOL_OFFSETS`] (Fanuc memory C): `tool_offsets[n - 1]` is number n.
    /// Programs change their copy (G10, `#11001…`) for one run; the file is never written.
    pub tool_offsets: Vec<ToolOffset>,
}

/// How many tool offset numbers there are (H1..H400, D1..D400), as Fanuc's 400-offset option.
pub const TOOL_OFFSETS: usize = 400;

/// One tool offset number (Fanuc memory C): tool length (H) and radius (D), geometry and wear,
/// in mm. The length used by G43/G44 is `length + length_wear`.
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct ToolOffset {
    pub length: f64,
    pub length_wear: f64,
    pub radius: f64,
    pub radius_wear: f64,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AxisKind {
    /// mm
    Linear,
    /// degrees, a positioning axis
    Rotary,
    /// degrees, the spindle: position-controlled for rigid tapping, speed mode for M3/M4
    Spindle,
}

impl AxisKind {
    pub fn is_rotary(self) -> bool {
        !matches!(self, AxisKind::Linear)
    }
}

#[derive(Clone, Debug, PartialEq)]
pub struct AxisConfig {
    /// Address letter: X, Y, Z, A, B, C, U, V, W.
    pub name: char,
    pub kind: AxisKind,
    /// CANopen node id 1..=127, or `None` for a virtual axis with no drive on the bus.
    pub node: Option<u8>,
    /// Drive position counts per mm (linear) or per degree (rotary).
    pub counts_per_unit: f64,
    /// units/s
    pub max_velocity: f64,
    /// units/s²
    pub max_acceleration: f64,
    /// units/s³
    pub max_jerk: f64,
    /// Soft limits in machine coordinates (linear axes; rotary axes have none).
    pub soft_limits: Option<(f64, f64)>,
    /// Largest allowed |commanded − actual|, in units.
    pub following_error_window: f64,
    pub following_error_timeout_ms: u32,
    /// Spindle only.
    pub max_rpm: Option<f64>,
    /// The drive's dead time (cycles) between taking a setpoint and its position loop acting
    /// on it; the master's following error rule does not count it as error. Default 1.
    pub feedback_delay_cycles: u32,
    /// Reference positions in machine coordinates: `[0]` the first (G28; key `reference`,
    /// default 0), `[1..4]` the second to fourth (G30 P2..P4; `second_reference`,
    /// `third_reference`, `fourth_reference`; `None` when not configured).
    pub references: [Option<f64>; 4],
    pub sim: SimDynamics,
}

/// How the simulated drive of an axis follows its CSP setpoints.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimDynamics {
    /// Pure delay between a setpoint taking effect and the position loop seeing it.
    pub delay_cycles: u32,
    /// First-order tracking bandwidth of the position loop (Hz); 0 = ideal (actual = target).
    pub bandwidth_hz: f64,
}

#[derive(Clone, Debug, PartialEq)]
pub struct BusConfig {
    /// `"sim"` or a SocketCAN interface name.
    pub interface: String,
    pub bitrate: u32,
    pub period_us: u32,
    pub heartbeat_ms: u16,
    pub heartbeat_timeout_ms: u32,
    pub tpdo_timeout_cycles: u32,
    pub sdo_timeout_ms: u32,
    /// The master's own node id: it produces its heartbeat on 0x700 + id and the drives
    /// consume it (0x1016). No axis may use it. Default 127.
    pub master_node_id: u8,
}

impl BusConfig {
    pub fn is_sim(&self) -> bool {
        self.interface == "sim"
    }
    pub fn period_s(&self) -> f64 {
        self.period_us as f64 * 1e-6
    }
}

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

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ReturnPlane {
    /// G98
    Initial,
    /// G99
    R,
}

#[derive(Clone, Debug, PartialEq)]
pub struct InterpDefaults {
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
    /// Largest allowed difference between an arc's start and end radius (mm).
    pub arc_tolerance: f64,
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
    /// one run). Relative paths resolve like `program_dir`; see [`MachineConfig::variables_file`].
    pub variables_file: Option<PathBuf>,
    /// Where `#use "file"` of the C-like language looks after the including file's folder
    /// (`None`: nowhere else). Relative paths resolve like `program_dir`.
    pub library_dir: Option<PathBuf>,
}

impl MachineConfig {
    /// Reads and validates a config file.
    pub fn load(path: impl AsRef<Path>) -> Result<MachineConfig, ConfigError> {
        let path = path.as_ref();
        let text = std::fs::read_to_string(path).map_err(|e| ConfigError {
            file: path.display().to_string(),
            line: 0,
            col: 0,
            key: String::new(),
            message: format!("cannot read: {e}"),
            located: None,
        })?;
        Self::parse(&text, path)
    }

    /// Parses and validates config text; `path` is used in messages and to resolve
    /// `program_dir`.
    pub fn parse(text: &str, path: &Path) -> Result<MachineConfig, ConfigError> {
        let err = |span: Option<std::ops::Range<usize>>, key: String, message: String| {
            let (line, col) = span
                .as_ref()
                .map(|s| line_col(text, s.start))
                .unwrap_or((0, 0));
            ConfigError {
                file: path.display().to_string(),
                line,
                col,
                key,
                message,
                located: span.map(|span| Box::new((text.to_string(), span))),
            }
        };
        let de = toml::Deserializer::parse(text)
            .map_err(|e| err(e.span(), String::new(), e.message().to_string()))?;
        let raw: RawConfig = serde_path_to_error::deserialize(de).map_err(|e| {
            // Spanned<T> shows up in the path as a private field; it is not a key the user wrote.
            let key = e
                .path()
                .to_string()
                .replace(".$__serde_spanned_private_value", "");
            let inner = e.into_inner();
            err(
                inner.span(),
                if key == "." { String::new() } else { key },
                inner.message().to_string(),
            )
        })?;
        validate(raw, path).map_err(|(span, key, message)| err(Some(span), key, message))
    }

    /// Index of the axis named `letter` (upper case).
    pub fn axis_index(&self, letter: char) -> Option<usize> {
        self.axes.iter().position(|a| a.name == letter)
    }

    /// The spindle axis, if one is configured.
    pub fn spindle_index(&self) -> Option<usize> {
        self.axes.iter().position(|a| a.kind == AxisKind::Spindle)
    }

    /// `program_dir` resolved against the config's base folder (see [`Self::resolve`]).
    pub fn program_dir(&self) -> PathBuf {
        self.resolve(&self.interp.program_dir)
    }

    /// `variables_file` resolved as `program_dir` is.
    pub fn variables_file(&self) -> Option<PathBuf> {
        self.interp
            .variables_file
            .as_deref()
            .map(|f| self.resolve(f))
    }

    /// `library_dir` resolved as `program_dir` is.
    pub fn library_dir(&self) -> Option<PathBuf> {
        self.interp.library_dir.as_deref().map(|f| self.resolve(f))
    }

    /// A path from the config, made usable: absolute paths stay; relative ones are taken from
    /// the parent of the config file's folder, so that `config/machine.toml`'s `examples`
    /// means `<repository>/examples` whatever the working directory.
    pub fn resolve(&self, p: &Path) -> PathBuf {
        if p.is_absolute() {
            return p.to_path_buf();
        }
        let base = self
            .path
            .parent()
            .and_then(Path::parent)
            .unwrap_or(Path::new(""));
        base.join(p)
    }

    /// The built-in default machine (the shipped `config/machine.toml`).
    pub fn default_machine() -> MachineConfig {
        Self::parse(include_str!("../machine.toml"), Path::new(DEFAULT_PATH))
            .expect("the shipped config/machine.toml is valid")
    }
}

/// A config error: where, which key, what is wrong. Renders as
/// `config/machine.toml:12:3: axis[2].max_velocity: must be > 0`.
#[derive(Clone, Debug, PartialEq)]
pub struct ConfigError {
    pub file: String,
    /// 1-based; 0 when unknown.
    pub line: usize,
    pub col: usize,
    /// Dotted key path, e.g. `axis[2].max_velocity`; empty when the error is not at a key.
    pub key: String,
    pub message: String,
    /// The config text and the span of the offending text, for the caret rendering (boxed:
    /// errors travel through every `Result` of the loaders and should stay small).
    located: Option<Box<(String, std::ops::Range<usize>)>>,
}

impl fmt::Display for ConfigError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.file)?;
        if self.line > 0 {
            write!(f, ":{}:{}", self.line, self.col)?;
        }
        if !self.key.is_empty() {
            write!(f, ": {}", self.key)?;
        }
        write!(f, ": {}", self.message)
    }
}

impl std::error::Error for ConfigError {}

impl miette::Diagnostic for ConfigError {
    fn code<'a>(&'a self) -> Option<Box<dyn fmt::Display + 'a>> {
        Some(Box::new("cnc402::config"))
    }
    fn source_code(&self) -> Option<&dyn miette::SourceCode> {
        self.located
            .as_ref()
            .map(|l| &l.0 as &dyn miette::SourceCode)
    }
    fn labels(&self) -> Option<Box<dyn Iterator<Item = miette::LabeledSpan> + '_>> {
        let span = self.located.as_ref()?.1.clone();
        let label = if self.key.is_empty() {
            self.message.clone()
        } else {
            self.key.clone()
        };
        Some(Box::new(std::iter::once(
            miette::LabeledSpan::new_with_span(Some(label), span),
        )))
    }
}

fn line_col(text: &str, offset: usize) -> (usize, usize) {
    let offset = offset.min(text.len());
    let before = &text[..offset];
    let line = before.matches('\n').count() + 1;
    let col = before
        .rfind('\n')
        .map(|i| before[i + 1..].chars().count())
        .unwrap_or(before.chars().count())
        + 1;
    (line, col)
}

// ---------------------------------------------------------------------------------------------
// Raw form: what serde reads, with spans kept for the semantic checks.

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawConfig {
    bus: RawBus,
    #[serde(default)]
    interp: RawInterp,
    #[serde(default)]
    work_offsets: std::collections::BTreeMap<
        Spanned<String>,
        std::collections::BTreeMap<Spanned<String>, Spanned<f64>>,
    >,
    #[serde(default)]
    // Plain keys, so that an error inside an entry names it (`tool_offsets.1.length`); a bad
    // number is reported at the entry's value.
    tool_offsets: std::collections::BTreeMap<String, Spanned<RawToolOffset>>,
    axis: Vec<RawAxis>,
}

/// `[tool_offsets]` entry: `1 = { length = 120.0, radius = 5.0 }`; keys left out are 0.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawToolOffset {
    length: Option<Spanned<f64>>,
    length_wear: Option<Spanned<f64>>,
    radius: Option<Spanned<f64>>,
    radius_wear: Option<Spanned<f64>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawBus {
    interface: Spanned<String>,
    #[serde(default = "default_bitrate")]
    bitrate: Spanned<i64>,
    #[serde(default = "default_period")]
    period_us: Spanned<i64>,
    #[serde(default = "default_heartbeat")]
    heartbeat_ms: Spanned<i64>,
    #[serde(default = "default_heartbeat_timeout")]
    heartbeat_timeout_ms: Spanned<i64>,
    #[serde(default = "default_tpdo_timeout")]
    tpdo_timeout_cycles: Spanned<i64>,
    #[serde(default = "default_sdo_timeout")]
    sdo_timeout_ms: Spanned<i64>,
    #[serde(default = "default_master_node_id")]
    master_node_id: Spanned<i64>,
}

fn sp<T>(v: T) -> Spanned<T> {
    Spanned::new(0..0, v)
}
fn default_bitrate() -> Spanned<i64> {
    sp(1_000_000)
}
fn default_period() -> Spanned<i64> {
    sp(1000)
}
fn default_heartbeat() -> Spanned<i64> {
    sp(50)
}
fn default_heartbeat_timeout() -> Spanned<i64> {
    sp(200)
}
fn default_tpdo_timeout() -> Spanned<i64> {
    sp(5)
}
fn default_sdo_timeout() -> Spanned<i64> {
    sp(100)
}
fn default_master_node_id() -> Spanned<i64> {
    sp(127)
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawInterp {
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
}

impl Default for RawInterp {
    fn default() -> Self {
        RawInterp {
            units: default_units(),
            plane: default_plane(),
            return_plane: default_return(),
            peck_retract: default_half(),
            peck_clearance: default_half(),
            tap_peck_retract: None,
            arc_tolerance: default_arc_tol(),
            spindle_orient_angle: default_orient_angle(),
            program_dir: default_program_dir(),
            block_limit: default_block_limit(),
            variables_file: None,
            library_dir: None,
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
fn default_arc_tol() -> Spanned<f64> {
    sp(0.002)
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

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawAxis {
    name: Spanned<String>,
    kind: Spanned<String>,
    node: Option<Spanned<i64>>,
    #[serde(rename = "virtual")]
    is_virtual: Option<Spanned<bool>>,
    counts_per_unit: Option<Spanned<f64>>,
    counts_per_rev: Option<Spanned<f64>>,
    max_velocity: Spanned<f64>,
    max_acceleration: Spanned<f64>,
    max_jerk: Spanned<f64>,
    min: Option<Spanned<f64>>,
    max: Option<Spanned<f64>>,
    following_error_window: Spanned<f64>,
    #[serde(default = "default_fe_timeout")]
    following_error_timeout_ms: Spanned<i64>,
    max_rpm: Option<Spanned<f64>>,
    #[serde(default = "default_feedback_delay")]
    feedback_delay_cycles: Spanned<i64>,
    reference: Option<Spanned<f64>>,
    second_reference: Option<Spanned<f64>>,
    third_reference: Option<Spanned<f64>>,
    fourth_reference: Option<Spanned<f64>>,
    #[serde(default)]
    sim: RawSim,
}

fn default_fe_timeout() -> Spanned<i64> {
    sp(10)
}
fn default_feedback_delay() -> Spanned<i64> {
    sp(1)
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawSim {
    #[serde(default = "default_delay")]
    delay_cycles: Spanned<i64>,
    #[serde(default = "default_bandwidth")]
    bandwidth_hz: Spanned<f64>,
}

impl Default for RawSim {
    fn default() -> Self {
        RawSim {
            delay_cycles: default_delay(),
            bandwidth_hz: default_bandwidth(),
        }
    }
}
fn default_delay() -> Spanned<i64> {
    sp(1)
}
fn default_bandwidth() -> Spanned<f64> {
    sp(150.0)
}

type Invalid = (std::ops::Range<usize>, String, String);

fn positive(v: &Spanned<f64>, key: &str) -> Result<f64, Invalid> {
    let x = *v.get_ref();
    if x.is_finite() && x > 0.0 {
        Ok(x)
    } else {
        Err((
            v.span(),
            key.to_string(),
            format!("must be a positive number, got {x}"),
        ))
    }
}

/// An angle within one turn: 0 ≤ x < 360.
fn angle_in_turn(v: &Spanned<f64>, key: &str) -> Result<f64, Invalid> {
    let x = *v.get_ref();
    if x.is_finite() && (0.0..360.0).contains(&x) {
        Ok(x)
    } else {
        Err((
            v.span(),
            key.to_string(),
            format!("must be an angle in degrees with 0 <= angle < 360, got {x}"),
        ))
    }
}

fn int_in(v: &Spanned<i64>, key: &str, lo: i64, hi: i64) -> Result<i64, Invalid> {
    let x = *v.get_ref();
    if (lo..=hi).contains(&x) {
        Ok(x)
    } else {
        Err((
            v.span(),
            key.to_string(),
            format!("must be in {lo}..={hi}, got {x}"),
        ))
    }
}

fn validate(raw: RawConfig, path: &Path) -> Result<MachineConfig, Invalid> {
    let b = &raw.bus;
    let interface = b.interface.get_ref().trim().to_string();
    if interface.is_empty() {
        return Err((
            b.interface.span(),
            "bus.interface".into(),
            "must name \"sim\" or a CAN interface".into(),
        ));
    }
    let bus = BusConfig {
        interface,
        bitrate: int_in(&b.bitrate, "bus.bitrate", 10_000, 1_000_000)? as u32,
        period_us: int_in(&b.period_us, "bus.period_us", 100, 100_000)? as u32,
        heartbeat_ms: int_in(&b.heartbeat_ms, "bus.heartbeat_ms", 0, 65535)? as u16,
        heartbeat_timeout_ms: int_in(
            &b.heartbeat_timeout_ms,
            "bus.heartbeat_timeout_ms",
            1,
            60_000,
        )? as u32,
        tpdo_timeout_cycles: int_in(&b.tpdo_timeout_cycles, "bus.tpdo_timeout_cycles", 1, 10_000)?
            as u32,
        sdo_timeout_ms: int_in(&b.sdo_timeout_ms, "bus.sdo_timeout_ms", 1, 60_000)? as u32,
        master_node_id: int_in(&b.master_node_id, "bus.master_node_id", 1, 127)? as u8,
    };
    if bus.heartbeat_ms > 0 && bus.heartbeat_timeout_ms <= bus.heartbeat_ms as u32 {
        return Err((
            b.heartbeat_timeout_ms.span(),
            "bus.heartbeat_timeout_ms".into(),
            format!(
                "must be longer than bus.heartbeat_ms ({})",
                bus.heartbeat_ms
            ),
        ));
    }

    let i = &raw.interp;
    let interp = InterpDefaults {
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
        peck_retract: positive(&i.peck_retract, "interp.peck_retract")?,
        peck_clearance: positive(&i.peck_clearance, "interp.peck_clearance")?,
        tap_peck_retract: match &i.tap_peck_retract {
            Some(v) => positive(v, "interp.tap_peck_retract")?,
            None => positive(&i.peck_retract, "interp.peck_retract")?,
        },
        arc_tolerance: positive(&i.arc_tolerance, "interp.arc_tolerance")?,
        spindle_orient_angle: angle_in_turn(
            &i.spindle_orient_angle,
            "interp.spindle_orient_angle",
        )?,
        program_dir: PathBuf::from(i.program_dir.get_ref()),
        block_limit: int_in(&i.block_limit, "interp.block_limit", 1, i64::MAX)? as u64,
        variables_file: match &i.variables_file {
            None => None,
            Some(f) if f.get_ref().trim().is_empty() => {
                return Err((
                    f.span(),
                    "interp.variables_file".to_string(),
                    "must not be empty (leave the key out to keep the variables in memory)"
                        .to_string(),
                ));
            }
            Some(f) => Some(PathBuf::from(f.get_ref())),
        },
        library_dir: match &i.library_dir {
            None => None,
            Some(f) if f.get_ref().trim().is_empty() => {
                return Err((
                    f.span(),
                    "interp.library_dir".to_string(),
                    "must not be empty (leave the key out to search only next to the program)"
                        .to_string(),
                ));
            }
            Some(f) => Some(PathBuf::from(f.get_ref())),
        },
    };

    if raw.axis.is_empty() {
        return Err((
            0..0,
            "axis".into(),
            "at least one [[axis]] is required".into(),
        ));
    }
    if raw.axis.len() > MAX_AXES {
        return Err((
            raw.axis[MAX_AXES].name.span(),
            format!("axis[{MAX_AXES}]"),
            format!("at most {MAX_AXES} axes"),
        ));
    }
    let mut axes: Vec<AxisConfig> = Vec::new();
    for (k, a) in raw.axis.iter().enumerate() {
        let key = |f: &str| format!("axis[{k}].{f}");
        let name = {
            let s = a.name.get_ref();
            let mut cs = s.chars();
            match (cs.next(), cs.next()) {
                (Some(c), None) if "XYZABCUVW".contains(c.to_ascii_uppercase()) => {
                    c.to_ascii_uppercase()
                }
                _ => {
                    return Err((
                        a.name.span(),
                        key("name"),
                        format!("expected one of X Y Z A B C U V W, got {s:?}"),
                    ));
                }
            }
        };
        if let Some(prev) = axes.iter().find(|p| p.name == name) {
            return Err((
                a.name.span(),
                key("name"),
                format!("axis {} is configured twice", prev.name),
            ));
        }
        let kind = match a.kind.get_ref().as_str() {
            "linear" => AxisKind::Linear,
            "rotary" => AxisKind::Rotary,
            "spindle" => AxisKind::Spindle,
            o => {
                return Err((
                    a.kind.span(),
                    key("kind"),
                    format!("expected \"linear\", \"rotary\" or \"spindle\", got {o:?}"),
                ));
            }
        };
        if kind == AxisKind::Spindle && axes.iter().any(|p| p.kind == AxisKind::Spindle) {
            return Err((
                a.kind.span(),
                key("kind"),
                "only one spindle axis is supported".into(),
            ));
        }
        let is_virtual = a.is_virtual.as_ref().map(|v| *v.get_ref()).unwrap_or(false);
        let node = match (&a.node, is_virtual) {
            (Some(n), false) => {
                let id = int_in(n, &key("node"), 1, 127)? as u8;
                if id == bus.master_node_id {
                    return Err((
                        n.span(),
                        key("node"),
                        format!("node id {id} is the master's (bus.master_node_id)"),
                    ));
                }
                if let Some(p) = axes.iter().find(|p| p.node == Some(id)) {
                    return Err((
                        n.span(),
                        key("node"),
                        format!("node id {id} is already used by axis {}", p.name),
                    ));
                }
                Some(id)
            }
            (Some(n), true) => {
                return Err((
                    n.span(),
                    key("node"),
                    "a virtual axis has no node id".into(),
                ));
            }
            (None, true) => None,
            (None, false) => {
                return Err((
                    a.name.span(),
                    key("node"),
                    "missing: give a CANopen node id 1..127, or virtual = true".into(),
                ));
            }
        };
        let counts_per_unit = match (&a.counts_per_unit, &a.counts_per_rev) {
            (Some(c), None) => positive(c, &key("counts_per_unit"))?,
            (None, Some(c)) if kind.is_rotary() => positive(c, &key("counts_per_rev"))? / 360.0,
            (None, Some(c)) => {
                return Err((
                    c.span(),
                    key("counts_per_rev"),
                    "only rotary axes take counts_per_rev".into(),
                ));
            }
            (Some(c), Some(_)) => {
                return Err((
                    c.span(),
                    key("counts_per_unit"),
                    "give counts_per_unit or counts_per_rev, not both".into(),
                ));
            }
            (None, None) => return Err((a.name.span(), key("counts_per_unit"), "missing".into())),
        };
        let soft_limits = match (&a.min, &a.max, kind) {
            (Some(lo), Some(hi), AxisKind::Linear) => {
                if !(lo.get_ref().is_finite()
                    && hi.get_ref().is_finite()
                    && lo.get_ref() < hi.get_ref())
                {
                    return Err((
                        hi.span(),
                        key("max"),
                        format!("must be greater than min ({})", lo.get_ref()),
                    ));
                }
                Some((*lo.get_ref(), *hi.get_ref()))
            }
            (None, None, AxisKind::Linear) => {
                return Err((
                    a.name.span(),
                    key("min"),
                    "a linear axis needs soft limits min and max".into(),
                ));
            }
            (Some(l), None, AxisKind::Linear) => {
                return Err((l.span(), key("max"), "missing (min is given)".into()));
            }
            (None, Some(h), AxisKind::Linear) => {
                return Err((h.span(), key("min"), "missing (max is given)".into()));
            }
            (None, None, _) => None,
            (Some(l), _, _) | (_, Some(l), _) => {
                return Err((
                    l.span(),
                    key("min"),
                    "rotary axes have no soft limits".into(),
                ));
            }
        };
        let max_rpm = match (&a.max_rpm, kind) {
            (Some(r), AxisKind::Spindle) => Some(positive(r, &key("max_rpm"))?),
            (None, AxisKind::Spindle) => {
                return Err((
                    a.kind.span(),
                    key("max_rpm"),
                    "a spindle needs max_rpm".into(),
                ));
            }
            (Some(r), _) => {
                return Err((
                    r.span(),
                    key("max_rpm"),
                    "only the spindle has max_rpm".into(),
                ));
            }
            (None, _) => None,
        };
        let mut references = [Some(0.0), None, None, None];
        for (slot, (v, name)) in [
            (&a.reference, "reference"),
            (&a.second_reference, "second_reference"),
            (&a.third_reference, "third_reference"),
            (&a.fourth_reference, "fourth_reference"),
        ]
        .into_iter()
        .enumerate()
        {
            let Some(v) = v else { continue };
            let x = *v.get_ref();
            let bad = if !x.is_finite() {
                Some("must be a finite number".to_string())
            } else {
                soft_limits
                    .filter(|&(lo, hi)| x < lo || x > hi)
                    .map(|(lo, hi)| format!("{x} is outside the axis's soft limits {lo}..{hi}"))
            };
            if let Some(m) = bad {
                return Err((v.span(), key(name), m));
            }
            references[slot] = Some(x);
        }
        let bw = *a.sim.bandwidth_hz.get_ref();
        if !(bw.is_finite() && bw >= 0.0) {
            return Err((
                a.sim.bandwidth_hz.span(),
                key("sim.bandwidth_hz"),
                format!("must be ≥ 0, got {bw}"),
            ));
        }
        axes.push(AxisConfig {
            name,
            kind,
            node,
            counts_per_unit,
            max_velocity: positive(&a.max_velocity, &key("max_velocity"))?,
            max_acceleration: positive(&a.max_acceleration, &key("max_acceleration"))?,
            max_jerk: positive(&a.max_jerk, &key("max_jerk"))?,
            soft_limits,
            following_error_window: positive(
                &a.following_error_window,
                &key("following_error_window"),
            )?,
            following_error_timeout_ms: int_in(
                &a.following_error_timeout_ms,
                &key("following_error_timeout_ms"),
                0,
                65535,
            )? as u32,
            max_rpm,
            feedback_delay_cycles: int_in(
                &a.feedback_delay_cycles,
                &key("feedback_delay_cycles"),
                0,
                16,
            )? as u32,
            references,
            sim: SimDynamics {
                delay_cycles: int_in(&a.sim.delay_cycles, &key("sim.delay_cycles"), 0, 100)? as u32,
                bandwidth_hz: bw,
            },
        });
    }

    let mut work_offsets = [[0.0; MAX_AXES]; 6];
    for (g, offs) in &raw.work_offsets {
        let idx = match g.get_ref().to_ascii_uppercase().as_str() {
            "G54" => 0,
            "G55" => 1,
            "G56" => 2,
            "G57" => 3,
            "G58" => 4,
            "G59" => 5,
            o => {
                return Err((
                    g.span(),
                    format!("work_offsets.{o}"),
                    "expected G54..G59".into(),
                ));
            }
        };
        for (axis, v) in offs {
            let letter = axis.get_ref().to_ascii_uppercase();
            let Some(ai) = axes
                .iter()
                .position(|a| letter.len() == 1 && a.name.to_string() == letter)
            else {
                return Err((
                    axis.span(),
                    format!("work_offsets.{}.{}", g.get_ref(), axis.get_ref()),
                    "no such axis".into(),
                ));
            };
            if !v.get_ref().is_finite() {
                return Err((
                    v.span(),
                    format!("work_offsets.{}.{}", g.get_ref(), axis.get_ref()),
                    "must be finite".into(),
                ));
            }
            work_offsets[idx][ai] = *v.get_ref();
        }
    }

    let mut tool_offsets = vec![ToolOffset::default(); TOOL_OFFSETS];
    for (n, t) in &raw.tool_offsets {
        let slot = n
            .parse::<usize>()
            .ok()
            .filter(|k| (1..=TOOL_OFFSETS).contains(k) && !n.starts_with('0'))
            .ok_or_else(|| {
                (
                    t.span(),
                    format!("tool_offsets.{n}"),
                    format!("expected an offset number 1..{TOOL_OFFSETS}"),
                )
            })?;
        let value = |v: &Option<Spanned<f64>>, field: &str| -> Result<f64, Invalid> {
            match v {
                None => Ok(0.0),
                Some(v) if v.get_ref().is_finite() => Ok(*v.get_ref()),
                Some(v) => Err((
                    v.span(),
                    format!("tool_offsets.{n}.{field}"),
                    "must be a finite number".into(),
                )),
            }
        };
        let t = t.get_ref();
        tool_offsets[slot - 1] = ToolOffset {
            length: value(&t.length, "length")?,
            length_wear: value(&t.length_wear, "length_wear")?,
            radius: value(&t.radius, "radius")?,
            radius_wear: value(&t.radius_wear, "radius_wear")?,
        };
    }

    Ok(MachineConfig {
        path: path.to_path_buf(),
        axes,
        bus,
        interp,
        work_offsets,
        tool_offsets,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(text: &str) -> Result<MachineConfig, ConfigError> {
        MachineConfig::parse(text, Path::new("m.toml"))
    }

    const SHIPPED: &str = include_str!("../machine.toml");

    #[test]
    fn shipped_config_is_valid() {
        let c = parse(SHIPPED).unwrap();
        let names: String = c.axes.iter().map(|a| a.name).collect();
        assert_eq!(names, "XYZC");
        let z = &c.axes[2];
        assert_eq!(z.counts_per_unit, 10000.0);
        let cax = &c.axes[3];
        assert_eq!(cax.kind, AxisKind::Spindle);
        assert!((cax.counts_per_unit * 360.0 - 131072.0).abs() < 1e-9);
        assert_eq!(c.bus.period_us, 1000);
        assert_eq!(c.work_offsets[1][0], 100.0);
        assert_eq!(c.spindle_index(), Some(3));
    }

    #[test]
    fn variables_file_key() {
        let c = parse(SHIPPED).unwrap();
        assert_eq!(
            c.interp.variables_file.as_deref(),
            Some(Path::new("var/macro_variables.txt"))
        );
        let text = SHIPPED.replace("variables_file = \"var/macro_variables.txt\"", "");
        let c = parse(&text).unwrap();
        assert_eq!(c.variables_file(), None);
        let text = SHIPPED.replace(
            "variables_file = \"var/macro_variables.txt\"",
            "variables_file = \"/tmp/v.txt\"",
        );
        assert_eq!(
            parse(&text).unwrap().variables_file(),
            Some(PathBuf::from("/tmp/v.txt"))
        );
        let text = SHIPPED.replace(
            "variables_file = \"var/macro_variables.txt\"",
            "variables_file = \" \"",
        );
        let e = parse(&text).unwrap_err();
        assert_eq!(e.key, "interp.variables_file");
    }

    #[test]
    fn tap_peck_retract_key() {
        let c = parse(SHIPPED).unwrap();
        assert_eq!(c.interp.tap_peck_retract, 0.5);
        let text = SHIPPED.replace("tap_peck_retract = 0.5", "");
        assert_ne!(text, SHIPPED, "the shipped config sets the key");
        // Left out: G73's peck_retract.
        let c = parse(&text.replace("peck_retract = 0.5", "peck_retract = 0.3")).unwrap();
        assert_eq!(
            (c.interp.peck_retract, c.interp.tap_peck_retract),
            (0.3, 0.3)
        );
        let text = SHIPPED.replace("tap_peck_retract = 0.5", "tap_peck_retract = 2.5");
        assert_eq!(parse(&text).unwrap().interp.tap_peck_retract, 2.5);
        for bad in ["0.0", "-1.0", "nan"] {
            let text = SHIPPED.replace(
                "tap_peck_retract = 0.5",
                &format!("tap_peck_retract = {bad}"),
            );
            let e = parse(&text).unwrap_err();
            assert_eq!(e.key, "interp.tap_peck_retract", "{bad}");
        }
    }

    #[test]
    fn spindle_orient_angle_key() {
        assert_eq!(parse(SHIPPED).unwrap().interp.spindle_orient_angle, 0.0);
        let text = SHIPPED.replace("spindle_orient_angle = 0.0", "");
        assert_ne!(text, SHIPPED, "the shipped config sets the key");
        assert_eq!(parse(&text).unwrap().interp.spindle_orient_angle, 0.0);
        let text = SHIPPED.replace("spindle_orient_angle = 0.0", "spindle_orient_angle = 271.5");
        assert_eq!(parse(&text).unwrap().interp.spindle_orient_angle, 271.5);
        for bad in ["360.0", "-0.5", "nan", "inf"] {
            let text = SHIPPED.replace(
                "spindle_orient_angle = 0.0",
                &format!("spindle_orient_angle = {bad}"),
            );
            let e = parse(&text).unwrap_err();
            assert_eq!(e.key, "interp.spindle_orient_angle", "{bad}");
        }
    }

    #[test]
    fn library_dir_key() {
        let c = parse(SHIPPED).unwrap();
        assert_eq!(
            c.interp.library_dir.as_deref(),
            Some(Path::new("examples/axioma"))
        );
        let text = SHIPPED.replace("library_dir = \"examples/axioma\"", "");
        assert_eq!(parse(&text).unwrap().library_dir(), None);
        let text = SHIPPED.replace(
            "library_dir = \"examples/axioma\"",
            "library_dir = \"/opt/cycles\"",
        );
        assert_eq!(
            parse(&text).unwrap().library_dir(),
            Some(PathBuf::from("/opt/cycles"))
        );
        let text = SHIPPED.replace("library_dir = \"examples/axioma\"", "library_dir = \"\"");
        assert_eq!(parse(&text).unwrap_err().key, "interp.library_dir");
    }

    #[test]
    fn unknown_key_names_line_col_and_key_path() {
        let text = SHIPPED.replace("max_jerk = 40000.0", "max_jerk = 40000.0\nmax_jerkk = 1.0");
        let e = parse(&text).unwrap_err();
        let line = text
            .lines()
            .position(|l| l.starts_with("max_jerkk"))
            .unwrap()
            + 1;
        assert_eq!(e.line, line, "{e}");
        assert_eq!(e.col, 1, "{e}");
        assert!(e.key.starts_with("axis[2]"), "{e}");
        assert!(e.message.contains("unknown field `max_jerkk`"), "{e}");
    }

    #[test]
    fn negative_velocity_is_reported_at_its_value() {
        let text = SHIPPED.replacen("max_velocity = 200.0", "max_velocity = -200.0", 1);
        let e = parse(&text).unwrap_err();
        let line = text
            .lines()
            .position(|l| l.starts_with("max_velocity = -200.0"))
            .unwrap()
            + 1;
        assert_eq!((e.line, e.col), (line, 16), "{e}");
        assert_eq!(e.key, "axis[2].max_velocity");
        assert!(
            e.to_string().starts_with(&format!(
                "m.toml:{line}:16: axis[2].max_velocity: must be a positive"
            )),
            "{e}"
        );
    }

    #[test]
    fn duplicate_node_id_is_an_error() {
        let text = SHIPPED.replacen("node = 2", "node = 1", 1);
        let e = parse(&text).unwrap_err();
        assert_eq!(e.key, "axis[1].node");
        assert!(e.message.contains("already used by axis X"), "{e}");
    }

    #[test]
    fn master_node_id_defaults_to_127_and_no_drive_may_use_it() {
        let c = parse(SHIPPED).unwrap();
        assert_eq!(c.bus.master_node_id, 127);
        let e = parse(&SHIPPED.replacen("node = 3", "node = 127", 1)).unwrap_err();
        assert_eq!(e.key, "axis[2].node");
        assert!(e.message.contains("master"), "{e}");
        let text = SHIPPED.replacen("master_node_id = 127", "master_node_id = 3", 1);
        assert_eq!(parse(&text).unwrap_err().key, "axis[2].node");
        let text = SHIPPED.replacen("master_node_id = 127", "master_node_id = 100", 1);
        assert_eq!(parse(&text).unwrap().bus.master_node_id, 100);
        let text = SHIPPED.replacen("master_node_id = 127", "master_node_id = 0", 1);
        assert_eq!(parse(&text).unwrap_err().key, "bus.master_node_id");
    }

    #[test]
    fn feedback_delay_is_per_axis_and_independent_of_the_sim() {
        let c = parse(SHIPPED).unwrap();
        assert!(c.axes.iter().all(|a| a.feedback_delay_cycles == 1));
        let text = SHIPPED.replacen("feedback_delay_cycles = 1", "feedback_delay_cycles = 3", 1);
        let c = parse(&text).unwrap();
        assert_eq!(c.axes[0].feedback_delay_cycles, 3);
        assert_eq!(c.axes[0].sim.delay_cycles, 1);
        assert_eq!(c.axes[1].feedback_delay_cycles, 1);
        // Left out: 1.
        let text = SHIPPED.replacen("feedback_delay_cycles = 1\n", "", 1);
        assert_eq!(parse(&text).unwrap().axes[0].feedback_delay_cycles, 1);
        let text = SHIPPED.replacen("feedback_delay_cycles = 1", "feedback_delay_cycles = 17", 1);
        assert_eq!(
            parse(&text).unwrap_err().key,
            "axis[0].feedback_delay_cycles"
        );
    }

    #[test]
    fn node_id_out_of_range() {
        let e = parse(&SHIPPED.replacen("node = 4", "node = 128", 1)).unwrap_err();
        assert_eq!(e.key, "axis[3].node");
        assert!(e.message.contains("1..=127"));
    }

    #[test]
    fn zero_period_is_an_error() {
        let e = parse(&SHIPPED.replacen("period_us = 1000", "period_us = 0", 1)).unwrap_err();
        assert_eq!(e.key, "bus.period_us");
        assert!(e.line > 0);
    }

    #[test]
    fn virtual_axis_has_no_node() {
        let c = parse(&SHIPPED.replacen("node = 2", "virtual = true", 1)).unwrap();
        assert_eq!(c.axes[1].node, None);
        let e = parse(&SHIPPED.replacen("node = 2", "node = 2\nvirtual = true", 1)).unwrap_err();
        assert_eq!(e.key, "axis[1].node");
    }

    #[test]
    fn soft_limits_must_be_ordered() {
        let e = parse(&SHIPPED.replacen("max = 300.0", "max = -400.0", 1)).unwrap_err();
        assert_eq!(e.key, "axis[0].max");
    }

    #[test]
    fn wrong_type_names_key() {
        let e = parse(&SHIPPED.replacen("bitrate = 1000000", "bitrate = \"fast\"", 1)).unwrap_err();
        assert_eq!(e.key, "bus.bitrate");
        assert!(e.line > 0);
    }

    #[test]
    fn work_offset_for_unknown_axis() {
        let e = parse(&SHIPPED.replacen("G57 = { X = 0.0,", "G57 = { Q = 0.0,", 1)).unwrap_err();
        assert_eq!(e.key, "work_offsets.G57.Q");
    }

    #[test]
    fn tool_offsets_table() {
        let c = parse(SHIPPED).unwrap();
        assert_eq!(c.tool_offsets.len(), TOOL_OFFSETS);
        assert_eq!(c.tool_offsets[0].length, -180.0);
        assert_eq!(
            c.tool_offsets[1],
            ToolOffset {
                length: -165.5,
                length_wear: -0.02,
                radius: 3.3,
                radius_wear: 0.0
            }
        );
        assert_eq!(c.tool_offsets[399], ToolOffset::default());
        let text = SHIPPED.replace("1 = { length = -180.0,", "400 = { length = 1.5,");
        assert_eq!(parse(&text).unwrap().tool_offsets[399].length, 1.5);
        // Unknown field: line, column and key path.
        let text = SHIPPED.replace("1 = { length = -180.0,", "1 = { lenght = -180.0,");
        let e = parse(&text).unwrap_err();
        let line = text.lines().position(|l| l.contains("lenght")).unwrap() + 1;
        assert_eq!((e.line, e.col), (line, 7), "{e}");
        assert_eq!(e.key, "tool_offsets.1.lenght", "{e}");
        assert!(e.message.contains("unknown field `lenght`"), "{e}");
        for bad in ["0", "401", "01", "H1", "-1"] {
            let text = SHIPPED.replace(
                "1 = { length = -180.0,",
                &format!("\"{bad}\" = {{ length = -180.0,"),
            );
            let e = parse(&text).unwrap_err();
            assert_eq!(e.key, format!("tool_offsets.{bad}"), "{bad}: {e}");
            assert!(e.message.contains("1..400"), "{e}");
            assert_eq!(e.line, line, "{e}");
        }
        let text = SHIPPED.replace("length = -180.0", "length = nan");
        assert_eq!(parse(&text).unwrap_err().key, "tool_offsets.1.length");
        let text = SHIPPED.replace("length = -180.0", "length = \"long\"");
        assert_eq!(parse(&text).unwrap_err().key, "tool_offsets.1.length");
    }

    #[test]
    fn reference_positions() {
        let c = parse(SHIPPED).unwrap();
        assert_eq!(c.axes[2].references, [Some(0.0), Some(40.0), None, None]);
        assert_eq!(c.axes[0].references, [Some(0.0), None, None, None]);
        assert_eq!(
            c.axes[3].references[0],
            Some(0.0),
            "default on the spindle too"
        );
        let text = SHIPPED.replace("second_reference = 40.0", "third_reference = -10.0");
        assert_eq!(
            parse(&text).unwrap().axes[2].references,
            [Some(0.0), None, Some(-10.0), None]
        );
        let text = SHIPPED.replace("second_reference = 40.0", "second_reference = 60.0");
        let e = parse(&text).unwrap_err();
        assert_eq!(e.key, "axis[2].second_reference");
        assert!(
            e.message
                .contains("outside the axis's soft limits -250..50"),
            "{e}"
        );
        let line = text
            .lines()
            .position(|l| l.starts_with("second_reference"))
            .unwrap()
            + 1;
        assert_eq!((e.line, e.col), (line, 20));
        let text = SHIPPED.replace("reference = 0.0\n", "reference = inf\n");
        assert_eq!(parse(&text).unwrap_err().key, "axis[2].reference");
    }

    #[test]
    fn syntax_error_has_position() {
        let e = parse("[bus\ninterface = 1").unwrap_err();
        assert_eq!(e.line, 1);
    }
}
