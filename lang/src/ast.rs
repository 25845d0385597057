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
    /// The dialect the program was read in (its header's, or the one the caller chose).
    pub dialect: crate::dialect::Dialect,
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
    Assign { target: Box<Expr>, value: Box<Expr> },
    /// LinuxCNC dialect: several assignments on one line (`#41=0 #42=#41`): every right-hand
    /// side is evaluated first, then the parameters are set in order. (target, value) pairs.
    Assigns(Vec<(Expr, Expr)>),
    /// `GOTO 100`, `GOTO #10`, `GOTO [#1+10]`: jump to the block with that N number.
    Goto { target: Box<Expr> },
    /// `IF [#1 EQ 2] GOTO 100`: conditional jump.
    IfGoto { cond: Box<Expr>, target: Box<Expr> },
    /// `IF [#520 EQ 3] THEN #113=1`: conditional statement. `then` is an
    /// [`LineKind::Assign`] or a [`LineKind::Block`] (`IF[#1 GT 0]THEN G0 X#1`).
    IfThen {
        cond: Box<Expr>,
        then: Box<LineKind>,
    },
    /// `WHILE [#1 LT 10] DO 1`: loop head; `id` (1, 2 or 3) pairs it with its `END`.
    While { cond: Box<Expr>, id: u8 },
    /// `END 1`: loop end, paired with `WHILE … DO 1`.
    End { id: u8 },
    /// Statements of the C-like language starting on this line: `int n = 2;`,
    /// `Tapping("Z", "C", 200);`, `if (a > 1) { … } else { … }`. A statement may run over
    /// several lines; those lines are [`LineKind::Continued`], and G-code lines inside it are
    /// [`StmtKind::Gcode`]. Which lines are statements: see `parse::clike`.
    Stmts(Vec<Stmt>),
    /// A line that belongs to a statement begun on an earlier line (it is executed there).
    Continued,
    /// LinuxCNC dialect: an O-word of a subroutine or of control flow, `o100 sub`,
    /// `o<probe> call [1] [2]`, `o1 if [#1 GT 0]`, `o2 endwhile`.
    OWord(Box<OWord>),
}

/// A LinuxCNC O-word statement: a label and what it does. Lines with the same label pair up
/// (`o1 if` … `o1 else` … `o1 endif`).
#[derive(Clone, Debug, PartialEq)]
pub struct OWord {
    pub label: OLabel,
    /// `o100` or `o<name>`.
    pub label_span: Span,
    pub kind: OWordKind,
}

/// An O-word label: `o100` or `o<name>` (names folded to lower case, spaces removed, as
/// LinuxCNC reads them).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum OLabel {
    Number(u32),
    Name(String),
}

impl std::fmt::Display for OLabel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            OLabel::Number(n) => write!(f, "o{n}"),
            OLabel::Name(s) => write!(f, "o<{s}>"),
        }
    }
}

/// What an O-word does; expressions are bracketed in the text (`o1 while [#1 LT 3]`).
#[derive(Clone, Debug, PartialEq)]
pub enum OWordKind {
    Sub,
    /// `endsub [value]`.
    EndSub(Option<Expr>),
    /// `return [value]`.
    Return(Option<Expr>),
    /// `call [a] [b] …`: the arguments become `#1`, `#2`, … of the subroutine.
    Call(Vec<Expr>),
    If(Expr),
    ElseIf(Expr),
    Else,
    EndIf,
    Do,
    /// `while [c]`: a loop head, or the end of a `do` loop with the same label.
    While(Expr),
    EndWhile,
    Repeat(Expr),
    EndRepeat,
    Break,
    Continue,
}

/// A block: the words of one line, in source order. Several G words may appear.
#[derive(Clone, Debug, PartialEq, Default)]
pub struct Block {
    pub words: Vec<Word>,
    /// Axis words whose axis is named at run time (C-like language):
    /// `AXSTR(strToolAx)=-(dStep1 + dSafeDist)`. Empty in ISO/Fanuc programs.
    pub named_axes: Vec<NamedAxisWord>,
}

/// `AXSTR(name)=value`: a word for the axis whose name (a string expression) is `axis`.
#[derive(Clone, Debug, PartialEq)]
pub struct NamedAxisWord {
    pub axis: Expr,
    pub value: Expr,
    /// The whole word, `AXSTR` through the value.
    pub span: Span,
}

/// A word: an address letter and its value, e.g. `X-12.5`, `G01`, `F=100*2`, `Z[1+2]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Word {
    /// Upper-case address letter (`a`..`z` in the text are accepted and folded). The
    /// comma addresses of Fanuc's corner rounding and chamfer, `,R` and `,C`, are the lower
    /// case `r` and `c` (see [`Word::comma_letter`]).
    pub letter: char,
    pub value: Value,
    /// The whole word, letter through value.
    pub span: Span,
}

impl Word {
    /// `Some('R')` for a `,R` word, `Some('C')` for `,C`; `None` for a plain address.
    pub fn comma_letter(&self) -> Option<char> {
        self.letter
            .is_ascii_lowercase()
            .then(|| self.letter.to_ascii_uppercase())
    }
}

#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    /// A literal number as written: `10`, `-2.5`, `.5`, `007`.
    Number(Number),
    /// A bracketed expression `X[1+2*3]`, one given with `=`: `F=100*2`, or a macro variable,
    /// possibly negated: `X#500`, `Z-#1`.
    Expr(Box<Expr>),
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
    /// LinuxCNC dialect: a named parameter, `#<depth>` (local to its subroutine) or
    /// `#<_feed>` (global: the name starts with `_`). Folded to lower case, spaces removed.
    Named(String),
    /// C-like language: a local variable or parameter, `dDepth`.
    Ident(String),
    /// C-like language: a global shared by the programs of a run, `$dPerm` (name without `$`).
    Global(String),
    /// C-like language: a system variable, `@ITPPATH`, `@CH` (name without `@`).
    SysVar(String),
    /// C-like language: a string literal, escapes resolved: `"Z"`.
    Str(String),
    /// C-like language: `true` / `false`.
    Bool(bool),
    /// C-like language: indexing, `$dPerm[1]`, `chanProgs[i]`, `@CH[0]`.
    Index(Box<Expr>, Box<Expr>),
    /// C-like language: a field, `@CH[0].MODE`.
    Field(Box<Expr>, String),
    /// C-like language: a call by name, `fabs(x)`, `Tapping("Z", …)`.
    CallNamed(String, Vec<Expr>),
    /// C-like language: `&&` and `||`, which short-circuit (Fanuc `AND`/`OR` are bitwise
    /// [`BinaryOp`]s and do not).
    Logical(LogicalOp, Box<Expr>, Box<Expr>),
    /// C-like language: `!x`.
    Not(Box<Expr>),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LogicalOp {
    And,
    Or,
}

/// A statement of the C-like language (issue 6).
#[derive(Clone, Debug, PartialEq)]
pub struct Stmt {
    pub kind: StmtKind,
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub enum StmtKind {
    /// `#use "metch_cycles.c"`: include a file once.
    Use {
        path: String,
    },
    /// `int n = 1;`, `string progs[n];`, `double a = 1, b;`
    Decl {
        ty: Type,
        vars: Vec<Declarator>,
    },
    /// `x = e;`, `$d[1] += e;`, `i++;` (as `i += 1`), `--i;` (as `i -= 1`).
    Assign {
        target: Expr,
        op: AssignOp,
        value: Expr,
    },
    /// A call evaluated for its effect: `MSG("ok");`.
    Call(Expr),
    /// `if (c) s else s`.
    If {
        cond: Expr,
        then: Box<Stmt>,
        otherwise: Option<Box<Stmt>>,
    },
    /// `while (c) s`.
    While {
        cond: Expr,
        body: Box<Stmt>,
    },
    /// `for (init; cond; step) s`; each part may be empty.
    For {
        init: Option<Box<Stmt>>,
        cond: Option<Expr>,
        step: Option<Box<Stmt>>,
        body: Box<Stmt>,
    },
    /// `{ … }`.
    Block(Vec<Stmt>),
    Break,
    Continue,
    /// `return;`, `return e;`.
    Return(Option<Expr>),
    /// `double f(double a, string b) { … }` (top level only).
    Function(Box<Function>),
    /// A G-code line inside a statement (it has its own line number, N, comments).
    Gcode(Line),
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Type {
    Int,
    Double,
    String,
    Bool,
    Void,
}

/// One variable of a declaration: `name`, `name[size]`, `name = init`.
#[derive(Clone, Debug, PartialEq)]
pub struct Declarator {
    pub name: String,
    pub size: Option<Expr>,
    pub init: Option<Expr>,
    pub span: Span,
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum AssignOp {
    Set,
    Add,
    Sub,
    Mul,
    Div,
    Mod,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Function {
    pub ret: Type,
    pub name: String,
    pub params: Vec<Param>,
    pub body: Vec<Stmt>,
    /// The header, type through `)`.
    pub span: Span,
}

#[derive(Clone, Debug, PartialEq)]
pub struct Param {
    pub ty: Type,
    pub name: String,
    /// `type name[]`: an array passed by reference (C's array parameter).
    pub array: bool,
    /// `const type name`: the function cannot assign it (or, for an array, its elements).
    pub konst: bool,
    pub span: Span,
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
