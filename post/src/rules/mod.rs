//! One rule set per target control: data (word formats, numbering, ranges, the cycles and
//! features it has) plus a few small hooks where a control's syntax is not a table entry
//! (tool call, program frame). A new target is a new `Rules` value in [`targets`]
//! (docs/post.md, "Adding a target").

pub mod targets;

pub use targets::Target;

/// How a circular arc is written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArcForm {
    /// Centre as I/J/K, incremental from the start (every Fanuc; works for full circles).
    Ijk,
    /// Radius R (negative for more than 180°); full circles fall back to I/J/K.
    Radius,
}

/// Sequence numbers: `N start`, `start + step`, …; past `max` they wrap to `step` again (a
/// number is a search label on Fanuc, not a unique key; `GOTO` targets are placed apart).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Numbering {
    pub start: u32,
    pub step: u32,
    pub max: u32,
}

/// What a target control is, as the post needs to know it.
#[derive(Clone, Debug)]
pub struct Rules {
    /// The `--target` name.
    pub name: &'static str,
    /// What it is, for the program header comment and the docs.
    pub title: &'static str,
    /// Decimals of positions (mm) and of feeds (mm/min): the control's least input increment.
    pub position_decimals: u32,
    pub feed_decimals: u32,
    /// Largest |position| the control's word format takes (mm).
    pub max_position: f64,
    /// Largest F (mm/min) and S (rpm); S is always a whole number.
    pub max_feed: f64,
    pub max_spindle: f64,
    /// Largest T and program number O (sub-programs too).
    pub max_tool: u32,
    pub max_program: u32,
    /// The main program's number and the first sub-program's.
    pub main_program: u32,
    pub first_subprogram: u32,
    /// `None`: no sequence numbers.
    pub numbering: Option<Numbering>,
    /// Longest block, characters (sequence number and comment included).
    pub max_line: usize,
    /// The canned cycles it has (G73…G89).
    pub cycles: &'static [u32],
    pub arc_form: ArcForm,
    /// G2/G3 with a move along the plane's normal.
    pub helical: bool,
    /// Custom Macro B (G65, #variables): a cycle the control lacks becomes a macro
    /// program; without it, plain blocks.
    pub macros: bool,
    /// G10 programmable data input (work and tool offsets set by the program).
    pub data_input: bool,
    /// Comments in parentheses are kept (else dropped).
    pub comments: bool,
}

impl Rules {
    /// Whether the control has canned cycle `code`.
    pub fn has_cycle(&self, code: u32) -> bool {
        self.cycles.contains(&code)
    }
}
