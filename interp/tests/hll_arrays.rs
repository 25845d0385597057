//! Arrays as function parameters in the C-like language: `type name[]` passed by reference
//! (local arrays and `$` global arrays), `len(a)`, `const` parameters, and the errors of each
//! with their `file:line:col`, checked before running or at run time.

// NcError is large; these helpers only run in tests.
#![allow(clippy::result_large_err)]

mod hll_common;
use hll_common::{cfg, msgs, run};

use cnc402_interp::{Interpreter, hll};
use cnc402_lang::SourceFile;
use cnc402_motion::segment::SegmentKind;

fn ok(text: &str) -> Vec<String> {
    msgs(&run(text).unwrap_or_else(|e| panic!("{text}\n{e}")))
}

/// Each case must fail with a message containing `want` at (line, col).
fn refused(cases: &[(&str, (u32, u32), &str)]) {
    for (text, (l, c), want) in cases {
        let e = match run(text) {
            Ok(_) => panic!("{text:?} ran without an error"),
            Err(e) => e,
        };
        assert!(e.message.contains(want), "{text:?}: {e}");
        assert_eq!((e.line, e.col), (*l, *c), "{text:?}: {e}");
    }
}

#[test]
fn writes_in_the_callee_are_seen_by_the_caller() {
    let out = ok(r#"void Fill(double dA[], int nN)
{
    for (int i = 0; i < nN; i++)
        dA[i] = i * 1.5;
}
double Sum(double dV[], int nN)
{
    double dS = 0;
    for (int i = 0; i < nN; i++)
        dS += dV[i];
    return dS;
}
void Bump(int nA[])
{
    nA[1]++;
    nA[2] += 10;
}
double dVals[4];
Fill(dVals, 4);
MSG("" + Sum(dVals, 4) + " " + dVals[0] + " " + dVals[3]);
int nC[3];
Bump(nC);
Bump(nC);
MSG("" + nC[0] + " " + nC[1] + " " + nC[2]);
"#);
    assert_eq!(out, vec!["9 0 4.5", "0 2 20"]);
}

#[test]
fn an_array_parameter_passed_on_is_still_the_callers_array() {
    // Three levels: Outer's parameter goes to Inner, which writes the main program's array.
    let out = ok(
        r#"void Inner(string sA[], int nI, string sV) { sA[nI] = sV; }
void Outer(string sA[]) { Inner(sA, 0, "a"); Inner(sA, len(sA) - 1, "z"); }
string sNames[3];
Outer(sNames);
MSG(sNames[0] + sNames[1] + "|" + sNames[2]);
"#,
    );
    assert_eq!(out, vec!["a|z"]);
}

#[test]
fn recursion_with_array_parameters_sorts_in_place() {
    // Quicksort: every level partitions the caller's array, not a copy.
    let out = ok(r#"void Swap(int nA[], int nI, int nJ)
{
    int nT = nA[nI];
    nA[nI] = nA[nJ];
    nA[nJ] = nT;
}
void Sort(int nA[], int nLo, int nHi)
{
    if (nLo >= nHi)
        return;
    int nP = nA[nHi];
    int nK = nLo;
    for (int i = nLo; i < nHi; i++)
    {
        if (nA[i] < nP)
        {
            Swap(nA, i, nK);
            nK++;
        }
    }
    Swap(nA, nK, nHi);
    Sort(nA, nLo, nK - 1);
    Sort(nA, nK + 1, nHi);
}
int nV[9];
for (int i = 0; i < 9; i++)
    nV[i] = (i * 7 + 3) % 9 - 4;
Sort(nV, 0, len(nV) - 1);
string sOut = "";
for (int i = 0; i < len(nV); i++)
    sOut = sOut + nV[i] + " ";
MSG(sOut);
"#);
    assert_eq!(out, vec!["-4 -3 -2 -1 0 1 2 3 4 "]);
}

#[test]
fn the_same_array_twice_is_one_array() {
    // By reference, as in C: a write through one parameter is read through the other.
    let out = ok(
        r#"int Alias(int nA[], int nB[]) { nA[0] = 7; return nB[0]; }
int nX[1];
MSG("" + Alias(nX, nX));
"#,
    );
    assert_eq!(out, vec!["7"]);
}

#[test]
fn a_call_inside_an_argument_leaves_the_callers_locals_alone() {
    // Arguments are evaluated onto the stack of locals while other calls run above them.
    let out = ok(r#"int Deep(int nN)
{
    int nL1 = nN * 2;
    int nArr[5];
    nArr[4] = nL1;
    if (nN > 0)
        return Deep(nN - 1) + nArr[4];
    return 0;
}
int Mix(int nA[], int nP, int nQ, int nB[]) { return nA[0] * 1000 + nP * 100 + nQ + nB[1]; }
int nU[2];
int nW[2];
nU[0] = 3;
nW[1] = 4;
int nBefore = 11;
MSG("" + Mix(nU, Deep(3), Deep(2), nW) + " " + nBefore + " " + nU[0] + " " + nW[1]);
"#);
    // Deep(3) = 6 + 4 + 2 = 12, Deep(2) = 4 + 2 = 6.
    assert_eq!(out, vec!["4210 11 3 4"]);
}

#[test]
fn len_gives_the_size_of_local_arrays_parameters_and_globals() {
    let out = ok(r#"int Count(double dA[]) { return len(dA); }
int nN = 6;
double dA[nN];
int nZ[0];
$dG[0] = 1;
$dG[4] = 2;
MSG("" + len(dA) + " " + Count(dA) + " " + len(nZ) + " " + len($dG) + " " + Count($dG)
    + " " + len($dNone));
"#);
    assert_eq!(out, vec!["6 6 0 5 5 0"]);
}

#[test]
fn global_arrays_are_passed_by_reference_and_created_by_their_first_element() {
    let c = cfg();
    let mut it = Interpreter::new(&c);
    let src = SourceFile::new(
        "g.nc",
        r#"void Fill(double dA[], int nN) { for (int i = 0; i < nN; i++) dA[i] = i + 0.5; }
double Mean(double dA[])
{
    double dS = 0;
    for (int i = 0; i < len(dA); i++) dS += dA[i];
    return dS / len(dA);
}
void Twice(int nA[]) { nA[1] = nA[1] * 2; $nSeen = $nA[1]; }
Fill($dTab, 3);
$nA[1] = 21;
Twice($nA);
MSG("" + $dTab[2] + " " + Mean($dTab) + " " + $nA[1] + " " + $nSeen);
"#,
    );
    it.load(src.clone(), cnc402_lang::parse(&src).unwrap());
    let mut out = Vec::new();
    while let Some(s) = it.next_segment().unwrap() {
        out.push(s);
    }
    // Inside Twice, `$nA[1]` read directly sees the write through the parameter.
    assert_eq!(msgs(&out), vec!["2.5 1.5 42 42"]);
    assert_eq!(hll::global_number(&it, "dTab", Some(0)), Some(0.5));
    assert_eq!(hll::global_number(&it, "nA", Some(1)), Some(42.0));
}

#[test]
fn global_elements_are_converted_to_the_parameters_type() {
    // An int element read through double[] is a double (7 / 2 is then 3.5); a double
    // written through int[] is truncated, as an assignment does.
    let out = ok(r#"double Half(double dA[]) { return dA[0] / 2; }
void Put(int nA[]) { nA[1] = 2.9; }
$gV[0] = 7;
Put($gV);
MSG("" + Half($gV) + " " + $gV[1]);
"#);
    assert_eq!(out, vec!["3.5 2"]);
}

#[test]
fn const_parameters_are_read_only() {
    let out = ok(
        r#"double Scale(const double dK, const double dA[], double dOut[])
{
    for (int i = 0; i < len(dA); i++)
        dOut[i] = dA[i] * dK;
    return dK;
}
double dIn[2];
double dRes[2];
dIn[0] = 1;
dIn[1] = 2;
Scale(3, dIn, dRes);
MSG("" + dRes[0] + " " + dRes[1]);
"#,
    );
    assert_eq!(out, vec!["3 6"]);
}

#[test]
fn wrong_array_arguments_are_refused_before_running() {
    const SUM: &str = "double Sum(double dV[]) { return dV[0]; }\n";
    let with = |rest: &str| format!("{SUM}{rest}");
    let cases = [
        (
            with("int nA[2];\nG0 X1\ndouble dS = Sum(nA);\n"),
            (4, 17),
            "cannot pass `nA` (int[]) to parameter 1 of `Sum` (double[]): the element types \
             must be the same",
        ),
        (
            with("double dX = 1;\ndouble dS = Sum(dX);\n"),
            (3, 17),
            "parameter 1 of `Sum` is an array (double[]): `dX` is a double, pass an array",
        ),
        (
            with("double dS = Sum(2.5);\n"),
            (2, 17),
            "parameter 1 of `Sum` is an array (double[]): pass an array's name",
        ),
        (
            with("double dA[2];\ndouble dS = Sum(dA[0]);\n"),
            (3, 17),
            "pass an array's name (`a` or `$g`), not a value",
        ),
        (
            with("double dS = Sum($dG[1]);\n"),
            (2, 17),
            "pass an array's name",
        ),
        (
            with("double dS = Sum(dNope);\n"),
            (2, 17),
            "undefined name `dNope`",
        ),
        (
            "double Sq(double dX) { return dX * dX; }\ndouble dA[2];\ndouble dS = Sq(dA);\n"
                .to_string(),
            (3, 16),
            "`dA` is an array (double[]), but parameter 1 of `Sq` is a double: pass an \
             element, `dA[i]`",
        ),
        (
            with("double dA[2];\ndouble dS = Sum(dA, 2);\n"),
            (3, 13),
            "`Sum` takes 1 argument(s), not 2",
        ),
        (
            "double Get(double dA[]) { return dA; }\n".to_string(),
            (1, 34),
            "a function cannot return an array (C cannot either)",
        ),
        (
            "void Set(double dA[], double dB[]) { dA = dB; }\n".to_string(),
            (1, 38),
            "`dA` is an array: assign an element (C cannot assign arrays)",
        ),
        (
            "double dA[2];\nint nL = len(dA[0]);\n".to_string(),
            (2, 14),
            "the argument of `len` is an array (an array): pass an array's name",
        ),
        (
            "int nX = 2;\nint nL = len(nX);\n".to_string(),
            (2, 14),
            "the argument of `len` is an array (an array): `nX` is a int, pass an array",
        ),
        (
            "double dA[2];\nint nL = len(dA, 1);\n".to_string(),
            (2, 10),
            "`len` takes 1 argument(s), not 2",
        ),
        (
            "double dA[2];\nstring sL = len(dA);\n".to_string(),
            (2, 13),
            "cannot assign int to sL (string)",
        ),
        (
            "int len(int nA[]) { return 0; }\n".to_string(),
            (1, 1),
            "`len` is a built-in function",
        ),
        (
            "void Put(const double dA[]) { dA[0] = 1; }\n".to_string(),
            (1, 31),
            "`dA` is a const array parameter: its elements cannot be assigned",
        ),
        (
            "void Inc(const int nN) { nN++; }\n".to_string(),
            (1, 26),
            "`nN` is a const parameter: it cannot be assigned",
        ),
        (
            "void Put(double dA[]) { dA[0] = 1; }\nvoid Pass(const double dA[]) { Put(dA); }\n"
                .to_string(),
            (2, 36),
            "`dA` is const: it cannot be passed to parameter 1 of `Put` (double[])",
        ),
    ];
    for (text, at, want) in &cases {
        refused(&[(text.as_str(), *at, want)]);
    }
}

#[test]
fn array_syntax_errors_name_the_rule() {
    let cases: &[(&str, (u32, u32), &str)] = &[
        (
            "double[] Get(double dA[]) { return 0; }\n",
            (1, 7),
            "a function cannot return an array",
        ),
        (
            "double Get(double dA[3]) { return 0; }\n",
            (1, 22),
            "an array parameter is written `name[]`",
        ),
    ];
    for (text, (l, c), want) in cases {
        let src = SourceFile::new("t.nc", *text);
        let e = cnc402_lang::parse(&src).unwrap_err();
        assert!(e.message.contains(want), "{text:?}: {e}");
        assert_eq!((e.line, e.col), (*l, *c), "{text:?}: {e}");
    }
}

#[test]
fn run_time_errors_in_the_callee_point_into_the_callee() {
    refused(&[
        (
            "G0 X1\nvoid Put(int nA[], int nI)\n{\n    nA[nI] = 1;\n}\nint nB[2];\nPut(nB, 2);\n",
            (4, 5),
            "index 2 is out of range (the array has 2 elements)",
        ),
        (
            "int Get(int nA[], int nI) { return nA[nI]; }\nint nB[3];\nint nX = Get(nB, -1);\n",
            (1, 36),
            "index -1 is out of range (the array has 3 elements)",
        ),
        (
            // A global array through a parameter: an element never assigned, a negative index,
            // a string where a double is declared, a scalar global passed as an array.
            "double Get(double dA[], int nI) { return dA[nI]; }\n$dG[0] = 1;\ndouble dX = Get($dG, 3);\n",
            (1, 42),
            "$dG[3] has no value (never assigned)",
        ),
        (
            "void Put(double dA[]) { dA[-1] = 1; }\n$dG[0] = 1;\nPut($dG);\n",
            (1, 25),
            "index -1 of $dG is negative",
        ),
        (
            "double Get(double dA[]) { return dA[0]; }\n$dG[0] = \"x\";\ndouble dX = Get($dG);\n",
            (1, 34),
            "$dG[0] holds a string, not a double",
        ),
        (
            "double Get(double dA[]) { return dA[0]; }\n$dS = 1;\ndouble dX = Get($dS);\n",
            (3, 17),
            "$dS is not an array",
        ),
        (
            "$dS = 1;\nint nL = len($dS);\n",
            (2, 14),
            "$dS is not an array",
        ),
    ]);
}

#[test]
fn run_time_errors_in_a_used_file_name_that_file() {
    let d = std::env::temp_dir().join(format!("cnc402-hll-arrays-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    std::fs::write(
        d.join("lib.c"),
        "// helpers\nvoid Clear(double dA[], int nN)\n{\n    for (int i = 0; i <= nN; i++)\n        dA[i] = 0;\n}\n",
    )
    .unwrap();
    let main = d.join("main.nc");
    let text = "#use \"lib.c\"\ndouble dBuf[3];\nClear(dBuf, len(dBuf));\n";
    std::fs::write(&main, text).unwrap();
    let e = cnc402_interp::host_fs::run_program(
        &cfg(),
        &SourceFile::new(main.display().to_string(), text),
    )
    .unwrap_err();
    assert!(e.file.ends_with("lib.c"), "{e}");
    assert_eq!((e.line, e.col), (5, 9), "{e}");
    assert!(e.message.contains("index 3 is out of range"), "{e}");
}

#[test]
fn deep_recursion_with_an_array_is_the_usual_error() {
    refused(&[(
        "int Down(int nA[], int nN) { nA[0] = nN; return Down(nA, nN + 1); }\nint nB[1];\nint nX = Down(nB, 0);\n",
        (1, 49),
        "recursion too deep",
    )]);
    // 150 levels deep, each writing its own element of the one array.
    let out = ok(
        r#"void Mark(int nA[], int nN) { if (nN < len(nA)) { nA[nN] = nN; Mark(nA, nN + 1); } }
int nB[150];
Mark(nB, 0);
MSG("" + nB[0] + " " + nB[149]);
"#,
    );
    assert_eq!(out, vec!["0 149"]);
}

#[test]
fn memory_a_program_asks_for_is_bounded_by_an_error() {
    refused(&[
        (
            // Each level keeps a million elements alive: the fifth would pass 4 million.
            "void Deep(int nN)\n{\n    int nBig[1000000];\n    nBig[0] = nN;\n    Deep(nN + 1);\n}\nDeep(0);\n",
            (3, 9),
            "arrays too large: 5000000 elements would be alive at once (at most 4000000",
        ),
        (
            "string sS = \"ab\";\nwhile (true)\n    sS = sS + sS;\n",
            (3, 10),
            "string too long: 2097152 bytes (at most 1048576)",
        ),
    ]);
    // Arrays of functions that returned, and of a declaration run again in a loop, are freed.
    let out = ok(
        r#"int Use(int nN) { int nBig[1000000]; nBig[nN] = nN; return nBig[nN]; }
int nSum = 0;
for (int i = 0; i < 20; i++)
{
    int nLoop[1000000];
    nSum += Use(i);
}
MSG("" + nSum);
"#,
    );
    assert_eq!(out, vec!["190"]);
}

#[test]
fn array_parameters_give_g_code_lines_their_values() {
    // A hole pattern in two arrays, drilled by a function that gets the arrays and the axis
    // names (a string array) as parameters.
    let segs = run(
        r#"void Drill(const double dX[], const double dY[], const string sAx[], double dF)
{
    for (int i = 0; i < len(dX); i++)
    {
        G1 AXSTR(sAx[0])=dX[i] AXSTR(sAx[1])=dY[i] F=dF
    }
}
double dPx[3];
double dPy[3];
string sAxes[2];
sAxes[0] = "X";
sAxes[1] = "Y";
for (int i = 0; i < 3; i++)
{
    dPx[i] = 10 * (i + 1);
    dPy[i] = -5 * i;
}
G90
Drill(dPx, dPy, sAxes, 400);
M02
"#,
    )
    .unwrap();
    let moves: Vec<(f64, f64, f64, u32)> = segs
        .iter()
        .filter_map(|s| match &s.kind {
            SegmentKind::Linear { end, feed } => Some((end[0], end[1], *feed, s.source.line)),
            _ => None,
        })
        .collect();
    assert_eq!(
        moves,
        vec![
            (10.0, 0.0, 400.0, 5),
            (20.0, -5.0, 400.0, 5),
            (30.0, -10.0, 400.0, 5)
        ]
    );
}
