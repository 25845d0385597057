//! The syntax tree of an NC program: what the parser produces and the interpreter executes.
//! Every node keeps the byte span of its source text so that any later error (interpreter,
//! motion, drive fault) can point at `file:line:col`. The tree is shaped for growth: Fanuc
//! Custom Macro B statements and the C-like statement language become new [`LineKind`]s and
//! new [`ExprKind`]s; blocks and words stay as they are.

/// A half-open byte range `start..end` into the program text.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Default)]
pub struct Span {
    pub start: u32,
    pub end: u32,
}

impl Span {
    pub fn new(start: usize, end: usize) -> Self {
        Span {
            start: start as u32,
            end: end as u32,
        }
    }
    pub fn range(self) -> std::ops::Range<usize> {
        self.start as usize..self.end as usize
    }
    /// The smallest span covering both.
    pub fn join(self, other: Span) -> Span {
        Span {
            start: self.start.min(other.start),
            end: self.end.max(other.end),
        }
    }
}

/// A parsed program: one [`Line`] per physical line of the text (blank lines included, so that
/// `lines[i]` is line `i + 1`).
#[derive(Clone, Debug, PartialEq)]
pub struct Program {
    pub lines: Vec<Line>,
}

/// One physical line of NC text.
#[derive(Clone, Debug, PartialEq)]
pub struct Line {
    /// 1-based line number in the file.
    pub line_no: u32,
    /// The whole line, without its line terminator.
    pub span: Span,
    /// `/` at the start of the block: skipped when block delete is switched on.
    pub block_delete: bool,
    /// The `N` sequence number, if any.
    pub n: Option<SeqNo>,
    pub kind: LineKind,
    /// Comments on the line, in order: `( … )` and `; …`.
    pub comments: Vec<Comment>,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SeqNo {
    pub value: u32,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum LineKind {
    /// Nothing but whitespace, comments and perhaps an N number.
    Empty,
    /// `%`: tape start/end marker.
    Percent,
    /// `O1234` (or `:1234`): program number; what follows it on the line is its title comment.
    ProgramNumber { number: u32, span: Span },
    /// An ordinary block of words.
    Block(Block),
    // Later issues add: macro assignment `#1=…`, `IF[…]GOTO n`, `IF[…]THEN …`, `WHILE[…]DO m`,
    // `END m`, `GOTO n`, and C-like statements. They are new variants here.
}

/// A block: the words of one line, in source order. Several G words may appear.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Block {
    pub words: Vec<Word>,
}

/// A word: an address letter and its value, e.g. `X-12.5`, `G01`, `F=100*2`, `Z[1+2]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Word {
    /// Upper-case address letter (`a`..`z` in the text are accepted and folded).
    pub letter: char,
    pub value: Value,
    /// The whole word, letter through value.
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// A literal number as written: `10`, `-2.5`, `.5`, `007`.
    Number(Number),
    /// A bracketed expression `X[1+2*3]`, or one given with `=`: `F=100*2`.
    Expr(Expr),
}

/// A literal number. `has_point` matters to Fanuc controls, which read `X10` as 10 least
/// input increments unless calculator-type input is on; the interpreter decides.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Number {
    pub value: f64,
    pub has_point: bool,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Comment {
    /// The text between `(` and `)`, or after `;`, not trimmed.
    pub text: String,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Expr {
    pub kind: ExprKind,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum ExprKind {
    Number(f64),
    Unary(UnaryOp, Box<Expr>),
    Binary(BinaryOp, Box<Expr>, Box<Expr>),
    /// A built-in function applied to its arguments: `SIN[30]`, `ATAN[1]/[2]` (two args).
    Call(Func, Vec<Expr>),
    // Later issues add: `#n` and `#[expr]` variables, `@SYSVAR`, `$global`, C identifiers,
    // string literals, array indexing, function calls by name.
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum UnaryOp {
    Neg,
    Plus,
}

/// Binary operators, Fanuc spellings; the C-like language maps its own tokens onto these.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinaryOp {
    Add,
    Sub,
    Mul,
    Div,
    Mod,
    Or,
    Xor,
    And,
    Eq,
    Ne,
    Gt,
    Ge,
    Lt,
    Le,
}

/// Built-in functions (Fanuc Custom Macro B names).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Func {
    Sin,
    Cos,
    Tan,
    Asin,
    Acos,
    Atan,
    Sqrt,
    Abs,
    Round,
    Fix,
    Fup,
    Ln,
    Exp,
    Pow,
    Bin,
    Bcd,
}
