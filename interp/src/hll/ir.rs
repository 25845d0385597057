//! The checked form of a C-like program: names resolved to slots and functions, every
//! expression's static type known. [`crate::hll::compile`] builds it; the executor walks it.

use std::sync::Arc;

use cnc402_lang::SourceFile;
use cnc402_lang::ast::{AssignOp, BinaryOp, Line, Number, Span};

/// Index of a file in [`Prog::files`] (0 is the main program).
pub(crate) type FileId = usize;

/// Static types. `Dyn` is a `$` global, whose type is only known when the program runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Ty {
    Int,
    Double,
    Str,
    Bool,
    Void,
    Dyn,
}

impl Ty {
    pub(crate) fn name(self) -> &'static str {
        match self {
            Ty::Int => "int",
            Ty::Double => "double",
            Ty::Str => "string",
            Ty::Bool => "bool",
            Ty::Void => "void",
            Ty::Dyn => "a global",
        }
    }
    pub(crate) fn numeric(self) -> bool {
        matches!(self, Ty::Int | Ty::Double | Ty::Dyn)
    }
}

/// A run-time value.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum Val {
    Int(i64),
    Dbl(f64),
    Str(Arc<str>),
    Bool(bool),
    /// A local array (only ever in a slot, never the value of an expression).
    Arr(Vec<Val>),
    /// The array an array parameter stands for (in the parameter's slot, and the value of
    /// [`Ex::Array`]): C passes arrays by reference, so the callee works on the caller's.
    ArrRef(ArrPlace),
}

/// Where an array passed by reference lives.
#[derive(Clone, Debug, PartialEq)]
pub(crate) enum ArrPlace {
    /// A local array: its index in the executor's stack of locals (below the callee's frame,
    /// so it outlives the call).
    Stack(usize),
    /// The `$` global array of that name.
    Global(Arc<str>),
}

/// An array named where an array is expected (an argument of an array parameter, `len(a)`).
#[derive(Debug)]
pub(crate) enum ArrArg {
    /// A local array or an array parameter of the running function.
    Slot(u32),
    /// `$name`.
    Global(Arc<str>),
}

impl Val {
    pub(crate) fn ty(&self) -> Ty {
        match self {
            Val::Int(_) => Ty::Int,
            Val::Dbl(_) => Ty::Double,
            Val::Str(_) => Ty::Str,
            Val::Bool(_) => Ty::Bool,
            Val::Arr(_) | Val::ArrRef(_) => Ty::Void,
        }
    }
    /// The zero value a declaration without initialiser gets.
    pub(crate) fn zero(ty: Ty) -> Val {
        match ty {
            Ty::Int => Val::Int(0),
            Ty::Double => Val::Dbl(0.0),
            Ty::Str => Val::Str(Arc::from("")),
            Ty::Bool => Val::Bool(false),
            Ty::Void | Ty::Dyn => Val::Int(0),
        }
    }
    /// As text, for string concatenation and messages.
    pub(crate) fn text(&self) -> String {
        match self {
            Val::Int(i) => i.to_string(),
            Val::Dbl(d) => d.to_string(),
            Val::Str(s) => s.to_string(),
            Val::Bool(b) => b.to_string(),
            Val::Arr(_) | Val::ArrRef(_) => "<array>".to_string(),
        }
    }
}

/// Built-in functions.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Builtin {
    Terminate,
    Msg,
    Sleep,
    Fabs,
    Sqrt,
    Sin,
    Cos,
    Tan,
    Atan2,
    Floor,
    Ceil,
    Round,
    Pow,
    Min,
    Max,
    /// `len(a)`: the number of elements of an array.
    Len,
    /// `channel_load(ch, prog)` … `channel_reset(ch)`: see [`crate::host::channels`].
    ChannelLoad,
    ChannelRun,
    ChannelStart,
    ChannelWait,
    ChannelReset,
    /// `wait_mark(m)`, `wait_mark(m, mask)`: a wait for other channels.
    WaitMark,
}

impl Builtin {
    pub(crate) fn by_name(n: &str) -> Option<Builtin> {
        use Builtin::*;
        Some(match n {
            "terminate" => Terminate,
            "MSG" => Msg,
            "sleep" => Sleep,
            "fabs" => Fabs,
            "sqrt" => Sqrt,
            "sin" => Sin,
            "cos" => Cos,
            "tan" => Tan,
            "atan2" => Atan2,
            "floor" => Floor,
            "ceil" => Ceil,
            "round" => Round,
            "pow" => Pow,
            "min" => Min,
            "max" => Max,
            "len" => Len,
            "channel_load" => ChannelLoad,
            "channel_run" => ChannelRun,
            "channel_start" => ChannelStart,
            "channel_wait" => ChannelWait,
            "channel_reset" => ChannelReset,
            "wait_mark" => WaitMark,
            _ => return None,
        })
    }
}

/// A system variable (`@…`).
#[derive(Debug)]
pub(crate) enum Sys {
    /// `@ITPPATH`: path length produced by the interpolator since the program started.
    ItpPath,
    /// `@X`, `@Z`, …: actual position of a configured axis, work coordinates.
    Axis(usize),
    /// `@POS[name]`: the same, axis named by a string at run time.
    AxisByName(Box<Ex>),
    /// `@CH[n].MODE`
    ChMode(Box<Ex>),
    /// `@CH[n].STATE`
    ChState(Box<Ex>),
}

/// A checked expression. Spans point into the file of the function it belongs to.
#[derive(Debug)]
pub(crate) enum Ex {
    Lit(Val),
    Local(u32),
    /// Element of a local array or array parameter: slot, element type, index.
    Elem(u32, Ty, Box<Ex>, Span),
    /// An array passed to an array parameter or to `len`: its value is a [`Val::ArrRef`].
    Array(ArrArg, Span),
    /// `$name` or `$name[i]`.
    Global(Arc<str>, Option<Box<Ex>>, Span),
    Sys(Sys, Span),
    Neg(Box<Ex>, Span),
    Bin(BinaryOp, Box<Ex>, Box<Ex>, Span),
    And(Box<Ex>, Box<Ex>),
    Or(Box<Ex>, Box<Ex>),
    Not(Box<Ex>, Span),
    /// A user function by index into [`Prog::funcs`].
    Call(usize, Vec<Ex>, Span),
    Builtin(Builtin, Vec<Ex>, Span),
}

/// Where an assignment stores.
#[derive(Debug)]
pub(crate) enum Target {
    Local(u32, Ty),
    Elem(u32, Ty, Ex),
    Global(Arc<str>),
    GlobalElem(Arc<str>, Ex),
}

/// A word value of a G-code line.
#[derive(Debug)]
pub(crate) enum WordVal {
    Num(Number),
    Ex(Ex),
}

/// A G-code line inside a C-like program, its values still to be computed.
#[derive(Debug)]
pub(crate) struct GLine {
    /// The line as parsed (number, N, comments, span); its block is replaced at run time.
    pub line: Line,
    pub words: Vec<(char, WordVal, Span)>,
    /// `AXSTR(name)=value`: name, value, span of the word.
    pub named: Vec<(Ex, Ex, Span)>,
}

/// A checked statement.
#[derive(Debug)]
pub(crate) enum St {
    Decl {
        slot: u32,
        ty: Ty,
        size: Option<Ex>,
        init: Option<Ex>,
        span: Span,
    },
    Set {
        target: Target,
        op: AssignOp,
        value: Ex,
        span: Span,
    },
    Eval(Ex),
    If(Ex, Vec<St>, Vec<St>),
    While(Ex, Vec<St>, Span),
    For(Vec<St>, Option<Ex>, Vec<St>, Vec<St>, Span),
    Break,
    Continue,
    Return(Option<Ex>),
    Gcode(Box<GLine>),
    /// `#use`: run that file's top-level statements (the first time only).
    Use(FileId),
}

/// A parameter's type: `ty name`, or `ty name[]` (an array, by reference); `const` if the
/// function may not assign it (or its elements).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) struct ParamTy {
    pub ty: Ty,
    pub array: bool,
    pub konst: bool,
}

impl ParamTy {
    /// As written in C: `double`, `const int[]`.
    pub(crate) fn text(self) -> String {
        format!(
            "{}{}{}",
            if self.konst { "const " } else { "" },
            self.ty.name(),
            if self.array { "[]" } else { "" }
        )
    }
}

/// A function, or the top-level statements of a file (`name` is then the file name).
#[derive(Debug)]
pub(crate) struct Func {
    pub name: String,
    pub file: FileId,
    pub ret: Ty,
    pub params: Vec<ParamTy>,
    pub slots: u32,
    pub body: Vec<St>,
    pub span: Span,
}

/// A whole checked program with everything it `#use`s.
#[derive(Debug)]
pub(crate) struct Prog {
    pub files: Vec<Arc<SourceFile>>,
    pub funcs: Vec<Func>,
    /// `bodies[f]`: the top-level statements of file `f` (index into `funcs`).
    pub bodies: Vec<usize>,
}
