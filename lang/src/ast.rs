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
    /// Fanuc Custom Macro B assignment: `#100=#4001`, `#[#1+2]=SIN[30]`, `#3000=12(TEXT)`
    /// (the comment is in [`Line::comments`]). `target` is an [`ExprKind::Var`] or
    /// [`ExprKind::IndirectVar`].
    Assign { target: Expr, value: Expr },
    /// `GOTO 100`, `GOTO #10`, `GOTO [#1+10]`: jump to the block with that N number.
    Goto { target: Expr },
    /// `IF [#1 EQ 2] GOTO 100`: conditional jump.
    IfGoto { cond: Expr, target: Expr },
    /// `IF [#520 EQ 3] THEN #113=1`: conditional statement. `then` is an
    /// [`LineKind::Assign`] or a [`LineKind::Block`] (`IF[#1 GT 0]THEN G0 X#1`).
    IfThen { cond: Expr, then: Box<LineKind> },
    /// `WHILE [#1 LT 10] DO 1`: loop head; `id` (1, 2 or 3) pairs it with its `END`.
    While { cond: Expr, id: u8 },
    /// `END 1`: loop end, paired with `WHILE … DO 1`.
    End { id: u8 },
    // Later issues add C-like statements as new variants here.
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
    /// A bracketed expression `X[1+2*3]`, one given with `=`: `F=100*2`, or a macro variable,
    /// possibly negated: `X#500`, `Z-#1`.
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
    /// A macro variable by number: `#100` (`#0` is the vacant variable). As a word value:
    /// `X#500`, `G#524`.
    Var(u32),
    /// A macro variable whose number is computed: `#[#1+2]`.
    IndirectVar(Box<Expr>),
    // Later issues add: `@SYSVAR`, `$global`, C identifiers, string literals, array
    // indexing, function calls by name.
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
