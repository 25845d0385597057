//! Loading and checking a C-like program before it runs: `#use` files are found and parsed,
//! functions collected from every file, names resolved and types checked. Every error found
//! here is reported at `file:line:col` before any motion.

use std::collections::HashMap;
use std::sync::Arc;

use cnc402_config::MachineConfig;
use cnc402_lang::ast::{
    AssignOp, BinaryOp, Expr, ExprKind, Line, LineKind, LogicalOp, Program, Span, Stmt, StmtKind,
    Type, UnaryOp, Value,
};
use cnc402_lang::{NcError, SourceFile};

use super::ir::*;
use crate::host::{ProgramLibrary, UsedFile};

struct File {
    src: Arc<SourceFile>,
    prog: Program,
    /// `#use` statement span start → the file it names.
    uses: HashMap<u32, FileId>,
}

/// Finds, parses and checks `main` and the files it uses. `library` resolves `#use` (none:
/// every `#use` is a not-found error).
pub(crate) fn compile(
    cfg: &MachineConfig,
    main: SourceFile,
    program: Program,
    mut library: Option<&mut dyn ProgramLibrary>,
) -> Result<Prog, NcError> {
    let files = load(main, program, &mut library)?;
    let (sigs, defs) = collect_functions(&files)?;
    let sig_list = signatures(&defs);
    let mut funcs = Vec::new();
    for &(fid, fun) in &defs {
        let mut cx = Cx::new(
            cfg,
            &files[fid],
            fid,
            &sigs,
            &sig_list,
            ty_of(fun.ret),
            true,
        );
        funcs.push(cx.function(fun)?);
    }
    let mut bodies = Vec::new();
    for (fid, f) in files.iter().enumerate() {
        let mut cx = Cx::new(cfg, f, fid, &sigs, &sig_list, Ty::Void, false);
        let body = cx.top_level()?;
        bodies.push(funcs.len());
        funcs.push(body);
    }
    Ok(Prog {
        files: files.into_iter().map(|f| f.src).collect(),
        funcs,
        bodies,
    })
}

/// `main` and every file it uses, `main` first.
fn load(
    main: SourceFile,
    program: Program,
    library: &mut Option<&mut dyn ProgramLibrary>,
) -> Result<Vec<File>, NcError> {
    let mut files: Vec<File> = Vec::new();
    let mut keys: Vec<String> = Vec::new();
    let main = Arc::new(main);
    keys.push(match library.as_deref_mut() {
        Some(l) => l.key_of(&main.name),
        None => main.name.to_string(),
    });
    files.push(File {
        src: main,
        prog: program,
        uses: HashMap::new(),
    });
    let mut stack = vec![0usize];
    resolve_uses(0, &mut files, &mut keys, &mut stack, library)?;
    Ok(files)
}

/// A function definition and the file it is in.
type Def<'a> = (FileId, &'a cnc402_lang::ast::Function);

/// The functions of every file (in file order), and each one's index by name; a function
/// named like a built-in, or defined twice, is an error.
fn collect_functions(files: &[File]) -> Result<(HashMap<String, usize>, Vec<Def<'_>>), NcError> {
    let mut sigs: HashMap<String, usize> = HashMap::new();
    let mut defs: Vec<Def<'_>> = Vec::new();
    for (fid, f) in files.iter().enumerate() {
        for line in &f.prog.lines {
            let LineKind::Stmts(stmts) = &line.kind else {
                continue;
            };
            for s in stmts {
                if let StmtKind::Function(fun) = &s.kind {
                    let err = |m: String| Err(NcError::new(&f.src, fun.span, m));
                    if Builtin::by_name(&fun.name).is_some() {
                        return err(format!("`{}` is a built-in function", fun.name));
                    }
                    if let Some(&k) = sigs.get(&fun.name) {
                        let (of, odef) = defs[k];
                        let (l, _) = files[of].src.line_col(odef.span.start as usize);
                        return err(format!(
                            "function `{}` is already defined at {}:{l}",
                            fun.name, files[of].src.name
                        ));
                    }
                    sigs.insert(fun.name.clone(), defs.len());
                    defs.push((fid, fun));
                }
            }
        }
    }
    Ok((sigs, defs))
}

/// Each function's return type and parameters, as declared (in `defs` order).
fn signatures(defs: &[Def<'_>]) -> Vec<(Ty, Vec<ParamTy>)> {
    defs.iter()
        .map(|(_, f)| {
            let ps = f.params.iter().map(|p| ParamTy {
                ty: ty_of(p.ty),
                array: p.array,
                konst: p.konst,
            });
            (ty_of(f.ret), ps.collect())
        })
        .collect()
}

/// Loads the files `files[id]` names with `#use` (depth first, in order), each once.
fn resolve_uses(
    id: FileId,
    files: &mut Vec<File>,
    keys: &mut Vec<String>,
    stack: &mut Vec<FileId>,
    library: &mut Option<&mut dyn ProgramLibrary>,
) -> Result<(), NcError> {
    let mut found = Vec::new();
    for line in &files[id].prog.lines {
        if let LineKind::Stmts(stmts) = &line.kind {
            for s in stmts {
                if let StmtKind::Use { path } = &s.kind {
                    found.push((s.span, path.clone()));
                }
            }
        }
    }
    for (span, path) in found {
        let src = files[id].src.clone();
        let used = match library.as_deref_mut() {
            Some(l) => {
                let u = l
                    .resolve_use(&path, &src.name)
                    .map_err(|e| NcError::new(&src, span, e))?;
                u.ok_or_else(|| {
                    format!(
                        "#use \"{path}\": no such file next to this program ({})",
                        l.describe()
                    )
                })
            }
            None => Err(format!(
                "#use \"{path}\": no such file (no program library is configured)"
            )),
        };
        let UsedFile { key, file: sf } = used.map_err(|m| NcError::new(&src, span, m))?;
        if let Some(k) = keys.iter().position(|x| *x == key) {
            if let Some(pos) = stack.iter().position(|&s| s == k) {
                let chain: Vec<String> = stack[pos..]
                    .iter()
                    .map(|&s| files[s].src.name.to_string())
                    .chain(std::iter::once(sf.name.to_string()))
                    .collect();
                return Err(NcError::new(
                    &src,
                    span,
                    format!("#use cycle: {}", chain.join(" uses ")),
                ));
            }
            files[id].uses.insert(span.start, k);
            continue;
        }
        let prog = cnc402_lang::parse(&sf)?;
        let nid = files.len();
        files.push(File {
            src: Arc::new(sf),
            prog,
            uses: HashMap::new(),
        });
        keys.push(key);
        files[id].uses.insert(span.start, nid);
        stack.push(nid);
        resolve_uses(nid, files, keys, stack, library)?;
        stack.pop();
    }
    Ok(())
}

fn ty_of(t: Type) -> Ty {
    match t {
        Type::Int => Ty::Int,
        Type::Double => Ty::Double,
        Type::String => Ty::Str,
        Type::Bool => Ty::Bool,
        Type::Void => Ty::Void,
    }
}

#[derive(Clone, Copy)]
struct Var {
    slot: u32,
    ty: Ty,
    array: bool,
    /// A `const` parameter: not assignable (nor its elements).
    konst: bool,
}

/// The checker of one function (or one file's top level).
struct Cx<'a> {
    cfg: &'a MachineConfig,
    file: &'a File,
    fid: FileId,
    sigs: &'a HashMap<String, usize>,
    sig_list: &'a [(Ty, Vec<ParamTy>)],
    ret: Ty,
    in_function: bool,
    scopes: Vec<HashMap<String, Var>>,
    next_slot: u32,
    loops: u32,
}

impl<'a> Cx<'a> {
    fn new(
        cfg: &'a MachineConfig,
        file: &'a File,
        fid: FileId,
        sigs: &'a HashMap<String, usize>,
        sig_list: &'a [(Ty, Vec<ParamTy>)],
        ret: Ty,
        in_function: bool,
    ) -> Self {
        Cx {
            cfg,
            file,
            fid,
            sigs,
            sig_list,
            ret,
            in_function,
            scopes: Vec::new(),
            next_slot: 0,
            loops: 0,
        }
    }

    fn err(&self, span: Span, m: impl Into<String>) -> NcError {
        NcError::new(&self.file.src, span, m)
    }

    fn declare(&mut self, name: &str, ty: Ty, array: bool, span: Span) -> Result<u32, NcError> {
        let scope = self.scopes.last_mut().expect("a scope is open");
        if scope.contains_key(name) {
            return Err(NcError::new(
                &self.file.src,
                span,
                format!("`{name}` is already declared in this scope"),
            ));
        }
        let slot = self.next_slot;
        self.next_slot += 1;
        scope.insert(
            name.to_string(),
            Var {
                slot,
                ty,
                array,
                konst: false,
            },
        );
        Ok(slot)
    }

    /// Marks `name`, just declared in the innermost scope, as `const`.
    fn make_const(&mut self, name: &str) {
        if let Some(v) = self.scopes.last_mut().and_then(|s| s.get_mut(name)) {
            v.konst = true;
        }
    }

    /// The local array `e` names, if `e` is the bare name of one (`a`, not `a[i]`).
    fn array_named(&self, e: &Expr) -> Option<(String, Var)> {
        match &e.kind {
            ExprKind::Ident(n) => self.lookup(n).filter(|v| v.array).map(|v| (n.clone(), v)),
            _ => None,
        }
    }

    /// An array passed where an array is expected: the bare name of a local array, of an array
    /// parameter or of a `$` global. `want` is the parameter (`None` for `len`), `what` names
    /// it in messages.
    fn array_arg(&self, e: &Expr, want: Option<ParamTy>, what: &str) -> Result<Ex, NcError> {
        let sp = e.span;
        let expected = want.map_or("an array".to_string(), |p| p.text());
        match &e.kind {
            ExprKind::Ident(n) => {
                let v = self.lookup(n).ok_or_else(|| {
                    self.err(sp, format!("undefined name `{n}`"))
                })?;
                if !v.array {
                    return Err(self.err(
                        sp,
                        format!(
                            "{what} is an array ({expected}): `{n}` is a {}, pass an array",
                            v.ty.name()
                        ),
                    ));
                }
                if let Some(p) = want {
                    if p.ty != v.ty {
                        // C passes the array itself: its elements cannot change type.
                        return Err(self.err(
                            sp,
                            format!(
                                "cannot pass `{n}` ({}[]) to {what} ({expected}): the element \
                                 types must be the same",
                                v.ty.name()
                            ),
                        ));
                    }
                    if v.konst && !p.konst {
                        return Err(self.err(
                            sp,
                            format!(
                                "`{n}` is const: it cannot be passed to {what} ({expected}), \
                                 which could change it"
                            ),
                        ));
                    }
                }
                Ok(Ex::Array(ArrArg::Slot(v.slot), sp))
            }
            ExprKind::Global(n) => Ok(Ex::Array(ArrArg::Global(n.as_str().into()), sp)),
            _ => Err(self.err(
                sp,
                format!("{what} is an array ({expected}): pass an array's name (`a` or `$g`), not a value"),
            )),
        }
    }

    fn lookup(&self, name: &str) -> Option<Var> {
        self.scopes.iter().rev().find_map(|s| s.get(name).copied())
    }

    /// The declared array `name` (used at `span`), or an error: undefined, or not an array.
    fn lookup_array(&self, name: &str, span: Span) -> Result<Var, NcError> {
        let v = self
            .lookup(name)
            .ok_or_else(|| self.err(span, format!("undefined name `{name}`")))?;
        if !v.array {
            return Err(self.err(span, format!("`{name}` is not an array")));
        }
        Ok(v)
    }

    /// An index expression (at `span`) of type `ty` must be a number: int, double or dynamic.
    fn check_index(&self, span: Span, ty: Ty) -> Result<(), NcError> {
        if matches!(ty, Ty::Int | Ty::Dyn | Ty::Double) {
            Ok(())
        } else {
            Err(self.err(span, format!("an index must be an int, not {}", ty.name())))
        }
    }

    /// Checks the function `fun` (this checker's file and return type are its own).
    fn function(&mut self, fun: &cnc402_lang::ast::Function) -> Result<Func, NcError> {
        self.scopes.push(HashMap::new());
        let mut params = Vec::new();
        for p in &fun.params {
            let ty = ty_of(p.ty);
            if ty == Ty::Void {
                return Err(self.err(p.span, format!("parameter `{}` cannot be void", p.name)));
            }
            // Parameters take slots 0..n, in order: the executor stores the arguments there.
            self.declare(&p.name, ty, p.array, p.span)?;
            if p.konst {
                self.make_const(&p.name);
            }
            params.push(ParamTy {
                ty,
                array: p.array,
                konst: p.konst,
            });
        }
        let body = self.stmts(&fun.body)?;
        Ok(Func {
            name: fun.name.clone(),
            file: self.fid,
            ret: ty_of(fun.ret),
            params,
            slots: self.next_slot,
            body,
            span: fun.span,
        })
    }

    /// Checks this checker's file's top level, as the function the file runs as.
    fn top_level(&mut self) -> Result<Func, NcError> {
        self.scopes.push(HashMap::new());
        let file = self.file;
        let mut body = Vec::new();
        for line in &file.prog.lines {
            self.top_line(line, &mut body)?;
        }
        Ok(Func {
            name: file.src.name.to_string(),
            file: self.fid,
            ret: Ty::Void,
            params: Vec::new(),
            slots: self.next_slot,
            body,
            span: Span::default(),
        })
    }

    /// One line of a file's top level.
    fn top_line(&mut self, line: &Line, out: &mut Vec<St>) -> Result<(), NcError> {
        match &line.kind {
            LineKind::Empty | LineKind::Percent | LineKind::Continued => Ok(()),
            LineKind::ProgramNumber { .. } => Ok(()),
            // Only in the LinuxCNC dialect, which is never C-like.
            LineKind::OWord(o) => Err(self.err(o.label_span, "O-words are LinuxCNC's")),
            LineKind::Block(_) => {
                out.push(self.gcode(line)?);
                Ok(())
            }
            LineKind::Stmts(stmts) => {
                for s in stmts {
                    match &s.kind {
                        StmtKind::Function(_) => {}
                        StmtKind::Use { .. } => {
                            let id =
                                self.file.uses.get(&s.span.start).copied().ok_or_else(|| {
                                    self.err(s.span, "#use: the file was not loaded")
                                })?;
                            out.push(St::Use(id));
                        }
                        _ => out.push(self.stmt(s)?),
                    }
                }
                Ok(())
            }
            _ => Err(self.err(
                line.span,
                "Macro B statements (#n=, GOTO, IF, WHILE, END) cannot be mixed with the C-like \
                 language",
            )),
        }
    }

    fn stmts(&mut self, ss: &[Stmt]) -> Result<Vec<St>, NcError> {
        ss.iter().map(|s| self.stmt(s)).collect()
    }

    /// A statement in its own scope (the body of `if`/`while`/`for`).
    fn scoped(&mut self, s: &Stmt) -> Result<Vec<St>, NcError> {
        self.scopes.push(HashMap::new());
        let r = match &s.kind {
            StmtKind::Block(b) => self.stmts(b),
            _ => self.stmt(s).map(|x| vec![x]),
        };
        self.scopes.pop();
        r
    }

    fn stmt(&mut self, s: &Stmt) -> Result<St, NcError> {
        Ok(match &s.kind {
            StmtKind::Use { .. } => {
                return Err(self.err(s.span, "#use belongs at the top level of a file"));
            }
            StmtKind::Function(f) => {
                return Err(self.err(
                    f.span,
                    "functions are defined at the top level of a file, not inside a statement",
                ));
            }
            StmtKind::Decl { ty, vars } => self.decl(*ty, vars, s.span)?,
            StmtKind::Assign { target, op, value } => self.assign(target, *op, value, s.span)?,
            StmtKind::Call(e) => St::Eval(self.expr(e)?.0),
            StmtKind::If {
                cond,
                then,
                otherwise,
            } => {
                let c = self.cond(cond)?;
                let t = self.scoped(then)?;
                let o = match otherwise {
                    Some(o) => self.scoped(o)?,
                    None => Vec::new(),
                };
                St::If(c, t, o)
            }
            StmtKind::While { cond, body } => {
                let c = self.cond(cond)?;
                self.loops += 1;
                let b = self.scoped(body);
                self.loops -= 1;
                St::While(c, b?, s.span)
            }
            StmtKind::For {
                init,
                cond,
                step,
                body,
            } => {
                self.scopes.push(HashMap::new());
                let r = self.for_loop(
                    init.as_deref(),
                    cond.as_ref(),
                    step.as_deref(),
                    body,
                    s.span,
                );
                self.scopes.pop();
                r?
            }
            StmtKind::Block(b) => {
                self.scopes.push(HashMap::new());
                let r = self.stmts(b);
                self.scopes.pop();
                St::If(Ex::Lit(Val::Bool(true)), r?, Vec::new())
            }
            StmtKind::Break | StmtKind::Continue => {
                if self.loops == 0 {
                    return Err(self.err(s.span, "break/continue outside a loop"));
                }
                if s.kind == StmtKind::Break {
                    St::Break
                } else {
                    St::Continue
                }
            }
            StmtKind::Return(e) => self.return_stmt(e.as_ref(), s.span)?,
            StmtKind::Gcode(line) => self.gcode(line)?,
        })
    }

    /// `ty a, b[n], c = e;`: one `St::Decl` per declarator, each declared after its own
    /// size and initialiser are checked.
    fn decl(
        &mut self,
        ty: Type,
        vars: &[cnc402_lang::ast::Declarator],
        span: Span,
    ) -> Result<St, NcError> {
        let ty = ty_of(ty);
        if ty == Ty::Void {
            return Err(self.err(span, "a variable cannot be void"));
        }
        let mut out = Vec::new();
        for d in vars {
            let size = match &d.size {
                Some(e) => {
                    let (x, t) = self.expr(e)?;
                    if !matches!(t, Ty::Int | Ty::Dyn) {
                        return Err(self.err(
                            e.span,
                            format!("an array size must be an int, not {}", t.name()),
                        ));
                    }
                    if d.init.is_some() {
                        return Err(self.err(d.span, "an array cannot have an initialiser"));
                    }
                    Some(x)
                }
                None => None,
            };
            let init = match &d.init {
                Some(e) => {
                    let (x, t) = self.expr(e)?;
                    self.assignable(ty, t, e.span, &d.name)?;
                    Some(x)
                }
                None => None,
            };
            // Declared after its initialiser is checked: `int a = a;` is an error.
            let slot = self.declare(&d.name, ty, size.is_some(), d.span)?;
            out.push(St::Decl {
                slot,
                ty,
                size,
                init,
                span: d.span,
            });
        }
        Ok(if out.len() == 1 {
            out.pop().expect("one")
        } else {
            // Several declarators: keep them in the enclosing scope, in order.
            St::If(Ex::Lit(Val::Bool(true)), out, Vec::new())
        })
    }

    /// `target op value;` (the statement at `span`).
    fn assign(
        &mut self,
        target: &Expr,
        op: AssignOp,
        value: &Expr,
        span: Span,
    ) -> Result<St, NcError> {
        if let Some((n, _)) = self.array_named(target) {
            return Err(self.err(
                target.span,
                format!("`{n}` is an array: assign an element (C cannot assign arrays)"),
            ));
        }
        let (v, vt) = self.expr(value)?;
        let (tg, tt, name) = self.target(target)?;
        if op == AssignOp::Set {
            self.assignable(tt, vt, value.span, &name)?;
        } else {
            let bop = match op {
                AssignOp::Add => BinaryOp::Add,
                AssignOp::Sub => BinaryOp::Sub,
                AssignOp::Mul => BinaryOp::Mul,
                AssignOp::Div => BinaryOp::Div,
                _ => BinaryOp::Mod,
            };
            let rt = self.bin_type(bop, tt, vt, span)?;
            self.assignable(tt, rt, value.span, &name)?;
        }
        Ok(St::Set {
            target: tg,
            op,
            value: v,
            span,
        })
    }

    /// `for (init; cond; step) body`, inside the scope the caller opened for `init`.
    fn for_loop(
        &mut self,
        init: Option<&Stmt>,
        cond: Option<&Expr>,
        step: Option<&Stmt>,
        body: &Stmt,
        span: Span,
    ) -> Result<St, NcError> {
        let i = match init {
            Some(i) => vec![self.stmt(i)?],
            None => Vec::new(),
        };
        let c = match cond {
            Some(c) => Some(self.cond(c)?),
            None => None,
        };
        let st = match step {
            Some(s) => vec![self.stmt(s)?],
            None => Vec::new(),
        };
        self.loops += 1;
        let b = self.scoped(body);
        self.loops -= 1;
        Ok(St::For(i, c, st, b?, span))
    }

    /// `return;` or `return e;` (at `span`), checked against the function's return type.
    fn return_stmt(&mut self, e: Option<&Expr>, span: Span) -> Result<St, NcError> {
        if !self.in_function {
            return Err(self.err(
                span,
                "return outside a function (end the program with M02 or terminate())",
            ));
        }
        match (e, self.ret) {
            (None, Ty::Void) => Ok(St::Return(None)),
            (None, t) => Err(self.err(
                span,
                format!("this function returns {}: `return` needs a value", t.name()),
            )),
            (Some(e), Ty::Void) => Err(self.err(e.span, "a void function returns no value")),
            (Some(e), t) => {
                if let Some((n, _)) = self.array_named(e) {
                    return Err(self.err(
                        e.span,
                        format!(
                            "a function cannot return an array (C cannot either): \
                             `{n}` is an array; pass one as a parameter to fill, \
                             `void f(double a[])`"
                        ),
                    ));
                }
                let (x, xt) = self.expr(e)?;
                self.assignable(t, xt, e.span, "the return value")?;
                Ok(St::Return(Some(x)))
            }
        }
    }

    /// Whether a value of type `src` may be stored where `dst` is declared.
    fn assignable(&self, dst: Ty, src: Ty, span: Span, what: &str) -> Result<(), NcError> {
        let ok = dst == src || dst == Ty::Dyn || src == Ty::Dyn || (dst.numeric() && src.numeric());
        if ok {
            Ok(())
        } else {
            Err(self.err(
                span,
                format!("cannot assign {} to {what} ({})", src.name(), dst.name()),
            ))
        }
    }

    fn cond(&mut self, e: &Expr) -> Result<Ex, NcError> {
        let (x, t) = self.expr(e)?;
        if matches!(t, Ty::Str | Ty::Void) {
            return Err(self.err(e.span, format!("a condition cannot be {}", t.name())));
        }
        Ok(x)
    }

    fn target(&mut self, e: &Expr) -> Result<(Target, Ty, String), NcError> {
        match &e.kind {
            ExprKind::Ident(n) => {
                let v = self
                    .lookup(n)
                    .ok_or_else(|| self.err(e.span, format!("undefined name `{n}`")))?;
                if v.array {
                    return Err(self.err(e.span, format!("`{n}` is an array: assign an element")));
                }
                if v.konst {
                    return Err(self.err(
                        e.span,
                        format!("`{n}` is a const parameter: it cannot be assigned"),
                    ));
                }
                Ok((Target::Local(v.slot, v.ty), v.ty, format!("`{n}`")))
            }
            ExprKind::Global(n) => {
                Ok((Target::Global(n.as_str().into()), Ty::Dyn, format!("${n}")))
            }
            ExprKind::Index(a, i) => {
                let (ix, it) = self.expr(i)?;
                self.check_index(i.span, it)?;
                match &a.kind {
                    ExprKind::Ident(n) => {
                        let v = self.lookup_array(n, a.span)?;
                        if v.konst {
                            return Err(self.err(
                                a.span,
                                format!(
                                    "`{n}` is a const array parameter: its elements cannot be \
                                     assigned"
                                ),
                            ));
                        }
                        Ok((Target::Elem(v.slot, v.ty, ix), v.ty, format!("`{n}[]`")))
                    }
                    ExprKind::Global(n) => Ok((
                        Target::GlobalElem(n.as_str().into(), ix),
                        Ty::Dyn,
                        format!("${n}[]"),
                    )),
                    _ => Err(self.err(e.span, "only variables and their elements can be assigned")),
                }
            }
            ExprKind::SysVar(n) => Err(self.err(e.span, format!("@{n} is read-only"))),
            _ => Err(self.err(e.span, "only variables and their elements can be assigned")),
        }
    }

    /// The type of `a op b`, or the type error.
    fn bin_type(&self, op: BinaryOp, a: Ty, b: Ty, span: Span) -> Result<Ty, NcError> {
        use BinaryOp::*;
        let bad = || {
            Err(self.err(
                span,
                format!(
                    "{} {} {}: wrong operand types",
                    a.name(),
                    op_text(op),
                    b.name()
                ),
            ))
        };
        if a == Ty::Void || b == Ty::Void {
            return Err(self.err(span, "a void function call has no value"));
        }
        match op {
            Add if a == Ty::Str || b == Ty::Str => Ok(Ty::Str),
            Add | Sub | Mul | Div | Mod => {
                if a == Ty::Dyn || b == Ty::Dyn {
                    if a == Ty::Bool || b == Ty::Bool {
                        return bad();
                    }
                    Ok(Ty::Dyn)
                } else if !a.numeric() || !b.numeric() {
                    bad()
                } else if a == Ty::Int && b == Ty::Int {
                    Ok(Ty::Int)
                } else {
                    Ok(Ty::Double)
                }
            }
            Or | Xor | And => {
                if matches!(a, Ty::Int | Ty::Dyn) && matches!(b, Ty::Int | Ty::Dyn) {
                    Ok(Ty::Int)
                } else {
                    bad()
                }
            }
            Eq | Ne | Gt | Ge | Lt | Le => {
                let num = |t: Ty| matches!(t, Ty::Int | Ty::Double | Ty::Bool);
                let ok = a == Ty::Dyn
                    || b == Ty::Dyn
                    || (a == Ty::Str && b == Ty::Str)
                    || (num(a) && num(b));
                if ok { Ok(Ty::Bool) } else { bad() }
            }
        }
    }

    fn expr(&mut self, e: &Expr) -> Result<(Ex, Ty), NcError> {
        let sp = e.span;
        Ok(match &e.kind {
            ExprKind::Number(v) => self.number(*v, sp),
            ExprKind::Str(s) => (Ex::Lit(Val::Str(Arc::from(s.as_str()))), Ty::Str),
            ExprKind::Bool(b) => (Ex::Lit(Val::Bool(*b)), Ty::Bool),
            ExprKind::Ident(n) => self.ident(n, sp)?,
            ExprKind::Global(n) => (Ex::Global(n.as_str().into(), None, sp), Ty::Dyn),
            ExprKind::SysVar(n) => self.sys_var(n, sp)?,
            ExprKind::Index(a, i) => self.index(a, i, sp)?,
            ExprKind::Field(base, field) => self.channel_field(base, field, sp)?,
            ExprKind::Unary(op, x) => {
                let (v, t) = self.expr(x)?;
                if !t.numeric() {
                    return Err(
                        self.err(sp, format!("a sign applies to numbers, not {}", t.name()))
                    );
                }
                match op {
                    UnaryOp::Plus => (v, t),
                    UnaryOp::Neg => (Ex::Neg(Box::new(v), sp), t),
                }
            }
            ExprKind::Binary(op, a, b) => {
                let (x, xt) = self.expr(a)?;
                let (y, yt) = self.expr(b)?;
                let t = self.bin_type(*op, xt, yt, sp)?;
                (Ex::Bin(*op, Box::new(x), Box::new(y), sp), t)
            }
            ExprKind::Logical(op, a, b) => {
                let x = self.cond(a)?;
                let y = self.cond(b)?;
                match op {
                    LogicalOp::And => (Ex::And(Box::new(x), Box::new(y)), Ty::Bool),
                    LogicalOp::Or => (Ex::Or(Box::new(x), Box::new(y)), Ty::Bool),
                }
            }
            ExprKind::Not(x) => (Ex::Not(Box::new(self.cond(x)?), sp), Ty::Bool),
            ExprKind::CallNamed(name, args) => self.call(name, args, sp)?,
            ExprKind::Var(_) | ExprKind::IndirectVar(_) | ExprKind::Named(_) => {
                return Err(self.err(
                    sp,
                    "macro variables (#n) are not available in C-like programs: use a variable",
                ));
            }
            ExprKind::Call(..) => {
                return Err(self.err(
                    sp,
                    "Fanuc functions (SIN[…]) are not available in C-like programs: use sin(…)",
                ));
            }
        })
    }

    /// A number literal (parsed as `v`, written at `sp`): an int if written as a whole number.
    fn number(&self, v: f64, sp: Span) -> (Ex, Ty) {
        let text = self.file.src.text.get(sp.range()).unwrap_or("");
        // Whole-number literals are ints from their digits (the parsed f64 loses
        // precision above 2^53); beyond i64 they stay doubles.
        let digits = text.trim();
        let exact = (!digits.is_empty() && digits.bytes().all(|b| b.is_ascii_digit()))
            .then(|| digits.parse::<i64>().ok())
            .flatten();
        let is_int = !text.contains(['.', 'e', 'E']) && v.fract() == 0.0 && v.abs() < 9e15;
        match exact {
            Some(i) => (Ex::Lit(Val::Int(i)), Ty::Int),
            None if is_int => (Ex::Lit(Val::Int(v as i64)), Ty::Int),
            None => (Ex::Lit(Val::Dbl(v)), Ty::Double),
        }
    }

    /// A name read as a value: a local (not a whole array) or `M_PI`.
    fn ident(&self, n: &str, sp: Span) -> Result<(Ex, Ty), NcError> {
        match self.lookup(n) {
            Some(v) if v.array => {
                Err(self.err(sp, format!("`{n}` is an array: use an element, `{n}[i]`")))
            }
            Some(v) => Ok((Ex::Local(v.slot), v.ty)),
            None if n == "M_PI" => Ok((Ex::Lit(Val::Dbl(std::f64::consts::PI)), Ty::Double)),
            None => {
                let hint = if self.in_function {
                    " (functions see only their parameters, their locals and $globals)"
                } else {
                    ""
                };
                Err(self.err(sp, format!("undefined name `{n}`{hint}")))
            }
        }
    }

    /// `@n` without an index: `@ITPPATH` or an axis (`@X`).
    fn sys_var(&self, n: &str, sp: Span) -> Result<(Ex, Ty), NcError> {
        let u = n.to_ascii_uppercase();
        if u == "ITPPATH" {
            Ok((Ex::Sys(Sys::ItpPath, sp), Ty::Double))
        } else if let Some(i) = (u.len() == 1)
            .then(|| u.chars().next().and_then(|c| self.cfg.axis_index(c)))
            .flatten()
        {
            Ok((Ex::Sys(Sys::Axis(i), sp), Ty::Double))
        } else {
            Err(self.err(
                sp,
                format!(
                    "unknown system variable @{n} (known: @ITPPATH, @<axis> such as @{}, \
                     @POS[name], @CH[n].MODE, @CH[n].STATE)",
                    self.cfg.axes.first().map_or('X', |a| a.name)
                ),
            ))
        }
    }

    /// `a[i]` read as a value: an element of a local or `$` array, or `@POS[name]`.
    fn index(&mut self, a: &Expr, i: &Expr, sp: Span) -> Result<(Ex, Ty), NcError> {
        let (ix, it) = self.expr(i)?;
        match &a.kind {
            ExprKind::SysVar(n) if n.eq_ignore_ascii_case("POS") => {
                if !matches!(it, Ty::Str | Ty::Dyn) {
                    return Err(self.err(i.span, "@POS[…] takes an axis name (a string)"));
                }
                Ok((Ex::Sys(Sys::AxisByName(Box::new(ix)), sp), Ty::Double))
            }
            ExprKind::SysVar(n) if n.eq_ignore_ascii_case("CH") => {
                Err(self.err(sp, "@CH[n] needs a field: @CH[n].MODE or @CH[n].STATE"))
            }
            _ => {
                self.check_index(i.span, it)?;
                match &a.kind {
                    ExprKind::Ident(n) => {
                        let v = self.lookup_array(n, a.span)?;
                        Ok((Ex::Elem(v.slot, v.ty, Box::new(ix), sp), v.ty))
                    }
                    ExprKind::Global(n) => Ok((
                        Ex::Global(n.as_str().into(), Some(Box::new(ix)), sp),
                        Ty::Dyn,
                    )),
                    _ => Err(self.err(sp, "only arrays can be indexed")),
                }
            }
        }
    }

    /// `base.field`: only `@CH[n].MODE` and `@CH[n].STATE` exist.
    fn channel_field(&mut self, base: &Expr, field: &str, sp: Span) -> Result<(Ex, Ty), NcError> {
        let ExprKind::Index(ch, n) = &base.kind else {
            return Err(self.err(sp, format!("unknown field .{field}")));
        };
        if !matches!(&ch.kind, ExprKind::SysVar(c) if c.eq_ignore_ascii_case("CH")) {
            return Err(self.err(sp, format!("unknown field .{field}")));
        }
        let (nx, nt) = self.expr(n)?;
        if !nt.numeric() {
            return Err(self.err(n.span, "a channel number is an int"));
        }
        let f = field.to_ascii_uppercase();
        let sys = match f.as_str() {
            "MODE" => Sys::ChMode(Box::new(nx)),
            "STATE" => Sys::ChState(Box::new(nx)),
            _ => {
                return Err(self.err(
                    sp,
                    format!("unknown channel field .{field} (known: .MODE, .STATE)"),
                ));
            }
        };
        Ok((Ex::Sys(sys, sp), Ty::Int))
    }

    fn call(&mut self, name: &str, args: &[Expr], sp: Span) -> Result<(Ex, Ty), NcError> {
        if let Some(&k) = self.sigs.get(name) {
            let (ret, params) = &self.sig_list[k];
            if params.len() != args.len() {
                return Err(self.err(
                    sp,
                    format!(
                        "`{name}` takes {} argument(s), not {}",
                        params.len(),
                        args.len()
                    ),
                ));
            }
            let mut xs = Vec::with_capacity(args.len());
            for (i, (p, a)) in params.iter().zip(args).enumerate() {
                let what = format!("parameter {} of `{name}`", i + 1);
                if p.array {
                    xs.push(self.array_arg(a, Some(*p), &what)?);
                    continue;
                }
                if let Some((n, v)) = self.array_named(a) {
                    return Err(self.err(
                        a.span,
                        format!(
                            "`{n}` is an array ({}[]), but {what} is a {}: pass an element, \
                             `{n}[i]`",
                            v.ty.name(),
                            p.ty.name()
                        ),
                    ));
                }
                let (x, t) = self.expr(a)?;
                if t == Ty::Void {
                    return Err(self.err(a.span, "a void function call has no value"));
                }
                self.assignable(p.ty, t, a.span, &what)?;
                xs.push(x);
            }
            return Ok((Ex::Call(k, xs, sp), *ret));
        }
        if name == "len" {
            let [a] = args else {
                return Err(self.err(sp, format!("`len` takes 1 argument(s), not {}", args.len())));
            };
            let x = self.array_arg(a, None, "the argument of `len`")?;
            return Ok((Ex::Builtin(Builtin::Len, vec![x], sp), Ty::Int));
        }
        let mut xs = Vec::with_capacity(args.len());
        let mut ts = Vec::with_capacity(args.len());
        for a in args {
            let (x, t) = self.expr(a)?;
            if t == Ty::Void {
                return Err(self.err(a.span, "a void function call has no value"));
            }
            xs.push(x);
            ts.push(t);
        }
        let Some(b) = Builtin::by_name(name) else {
            return Err(self.err(sp, format!("undefined function `{name}`")));
        };
        use Builtin::*;
        let (want, ret): (&[Ty], Ty) = match b {
            Terminate => (&[Ty::Int, Ty::Str], Ty::Void),
            Msg => (&[Ty::Str], Ty::Void),
            Sleep => (&[Ty::Double], Ty::Void),
            Fabs | Sqrt | Sin | Cos | Tan | Floor | Ceil | Round => (&[Ty::Double], Ty::Double),
            Atan2 | Pow => (&[Ty::Double, Ty::Double], Ty::Double),
            // `len` is checked above, before its argument could be read as a value.
            Len => return Err(self.err(sp, "`len` takes an array's name")),
            ChannelLoad | ChannelRun | ChannelStart => (&[Ty::Int, Ty::Str], Ty::Bool),
            ChannelWait | ChannelReset => (&[Ty::Int], Ty::Bool),
            // The mask is optional (0, every channel).
            WaitMark if args.len() == 2 => (&[Ty::Int, Ty::Int], Ty::Void),
            WaitMark => (&[Ty::Int], Ty::Void),
            Min | Max => {
                let r = if ts.iter().all(|t| *t == Ty::Int) {
                    Ty::Int
                } else {
                    Ty::Double
                };
                (&[Ty::Double, Ty::Double], r)
            }
        };
        if want.len() != args.len() {
            return Err(self.err(
                sp,
                format!(
                    "`{name}` takes {} argument(s), not {}",
                    want.len(),
                    args.len()
                ),
            ));
        }
        for (i, (w, t)) in want.iter().zip(&ts).enumerate() {
            let ok = match (b, w) {
                (Msg, _) => true, // MSG shows any value
                (_, Ty::Str) => matches!(t, Ty::Str | Ty::Dyn),
                _ => t.numeric(),
            };
            if !ok {
                return Err(self.err(
                    args[i].span,
                    format!(
                        "argument {} of `{name}` must be {}, not {}",
                        i + 1,
                        if *w == Ty::Str {
                            "a string"
                        } else {
                            "a number"
                        },
                        t.name()
                    ),
                ));
            }
        }
        Ok((Ex::Builtin(b, xs, sp), ret))
    }

    /// A G-code line: its word values checked, to be computed when the line runs.
    fn gcode(&mut self, line: &Line) -> Result<St, NcError> {
        let LineKind::Block(b) = &line.kind else {
            return Err(self.err(line.span, "not a G-code block"));
        };
        let mut words = Vec::with_capacity(b.words.len());
        for w in &b.words {
            let v = match &w.value {
                Value::Number(n) => WordVal::Num(*n),
                Value::Expr(e) => {
                    let (x, t) = self.expr(e)?;
                    if !t.numeric() {
                        return Err(self.err(
                            e.span,
                            format!("address {} needs a number, not {}", w.letter, t.name()),
                        ));
                    }
                    WordVal::Ex(x)
                }
            };
            words.push((w.letter, v, w.span));
        }
        let mut named = Vec::with_capacity(b.named_axes.len());
        for n in &b.named_axes {
            let (ax, at) = self.expr(&n.axis)?;
            if !matches!(at, Ty::Str | Ty::Dyn) {
                return Err(self.err(
                    n.axis.span,
                    format!("AXSTR takes an axis name (a string), not {}", at.name()),
                ));
            }
            if let Ex::Lit(Val::Str(s)) = &ax {
                axis_of(self.cfg, s).map_err(|m| self.err(n.axis.span, m))?;
            }
            let (v, vt) = self.expr(&n.value)?;
            if !vt.numeric() {
                return Err(self.err(
                    n.value.span,
                    format!("an axis value is a number, not {}", vt.name()),
                ));
            }
            named.push((ax, v, n.span));
        }
        Ok(St::Gcode(Box::new(GLine {
            line: Line {
                kind: LineKind::Empty,
                ..line.clone()
            },
            words,
            named,
        })))
    }
}

/// The configured axis `name` names (one letter, any case).
pub(crate) fn axis_of(cfg: &MachineConfig, name: &str) -> Result<char, String> {
    let t = name.trim();
    let mut cs = t.chars();
    if let (Some(c), None) = (cs.next(), cs.next()) {
        let c = c.to_ascii_uppercase();
        if cfg.axis_index(c).is_some() {
            return Ok(c);
        }
    }
    let axes: Vec<String> = cfg.axes.iter().map(|a| a.name.to_string()).collect();
    Err(format!(
        "unknown axis name \"{name}\" (this machine has {})",
        axes.join(" ")
    ))
}

pub(crate) fn op_text(op: BinaryOp) -> &'static str {
    use BinaryOp::*;
    match op {
        Add => "+",
        Sub => "-",
        Mul => "*",
        Div => "/",
        Mod => "%",
        Or => "|",
        Xor => "^",
        And => "&",
        Eq => "==",
        Ne => "!=",
        Gt => ">",
        Ge => ">=",
        Lt => "<",
        Le => "<=",
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(text: &str) -> Result<Prog, NcError> {
        let cfg = MachineConfig::default_machine();
        let src = SourceFile::new("u.nc", text);
        let program = cnc402_lang::parse(&src)?;
        compile(&cfg, src, program, None)
    }

    #[test]
    fn array_parameters_are_typed_and_their_arguments_are_references() {
        let p = check(
            "double Sum(const double dV[], int nN, double dOut[]) { return dV[0]; }\n\
             double dA[2];\ndouble dS = Sum(dA, 2, $dG);\n",
        )
        .unwrap();
        let f = &p.funcs[0];
        assert_eq!(
            f.params.iter().map(|p| p.text()).collect::<Vec<_>>(),
            vec!["const double[]", "int", "double[]"]
        );
        // The call passes the slot of `dA` and the global's name, not their values.
        let main = &p.funcs[p.bodies[0]];
        let St::Decl {
            init: Some(Ex::Call(0, args, _)),
            ..
        } = &main.body[1]
        else {
            panic!("{:?}", main.body[1]);
        };
        assert!(matches!(args[0], Ex::Array(ArrArg::Slot(0), _)));
        assert!(matches!(args[1], Ex::Lit(Val::Int(2))));
        assert!(matches!(&args[2], Ex::Array(ArrArg::Global(n), _) if &**n == "dG"));
    }

    #[test]
    fn len_is_an_int_of_an_array_only() {
        let p = check("int nA[3];\nint nL = len(nA) + 1;\n").unwrap();
        let main = &p.funcs[p.bodies[0]];
        assert!(matches!(
            &main.body[1],
            St::Decl { init: Some(Ex::Bin(_, l, _, _)), .. }
                if matches!(**l, Ex::Builtin(Builtin::Len, _, _))
        ));
        let e = check("double dX;\nint nL = len(dX);\n").unwrap_err();
        assert!(e.message.contains("`dX` is a double, pass an array"), "{e}");
        let e = check("int nL = len(3);\n").unwrap_err();
        assert!(e.message.contains("pass an array's name"), "{e}");
    }

    #[test]
    fn array_and_scalar_parameters_do_not_mix() {
        let e = check("void Fn(int nA[]) { }\nint nA[2];\nFn(nA[0]);\n").unwrap_err();
        assert_eq!((e.line, e.col), (3, 4), "{e}");
        let e = check("void Fn(int nN) { }\nint nA[2];\nFn(nA);\n").unwrap_err();
        assert!(e.message.contains("pass an element, `nA[i]`"), "{e}");
        let e = check("void Fn(double dA[]) { }\nint nA[2];\nFn(nA);\n").unwrap_err();
        assert!(
            e.message.contains("the element types must be the same"),
            "{e}"
        );
        // The same element type through two levels is fine, `const` may be added, not dropped.
        check("void Gc(const int nA[]) { }\nvoid Fn(int nA[]) { Gc(nA); }\n").unwrap();
        let e = check("void Gc(int nA[]) { }\nvoid Fn(const int nA[]) { Gc(nA); }\n").unwrap_err();
        assert!(e.message.contains("`nA` is const"), "{e}");
    }
}
