//! A run's trace (`cnc402 run --trace`: `t,line,<A>_cmd,<A>_act,…` per tick, machine
//! coordinates) read for the toolpath page's overlay: X Y Z commanded and actual, thinned to
//! a bounded number of rows however long the run was, and moved into the page's frame.

use std::collections::HashMap;
use std::io::BufRead;

use crate::geom::P3;
use crate::toolpath::{Frame, Toolpath};

/// One kept tick: program line, commanded and actual X Y Z.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TraceRow {
    pub line: u32,
    pub cmd: P3,
    pub act: P3,
}

/// Reads a trace, keeping at most `cap` (≥ 2) rows evenly spread over the run: when the kept
/// rows reach the cap, every other one is dropped and the stride doubles.
pub fn read(input: impl BufRead, cap: usize) -> Result<Vec<TraceRow>, String> {
    let cap = cap.max(2);
    let mut lines = input.lines();
    let header = match lines.next() {
        Some(h) => h.map_err(|e| e.to_string())?,
        None => return Err("empty trace: expected the header t,line,X_cmd,X_act,…".into()),
    };
    let cols: Vec<&str> = header.trim().split(',').collect();
    let col = |name: &str| cols.iter().position(|c| *c == name);
    let line_col = col("line").ok_or("the trace header has no `line` column")?;
    let mut axis_cols = [(None, None); 3];
    for (k, a) in ['X', 'Y', 'Z'].into_iter().enumerate() {
        axis_cols[k] = (col(&format!("{a}_cmd")), col(&format!("{a}_act")));
    }
    if axis_cols.iter().all(|c| c.0.is_none()) {
        return Err("the trace has no X_cmd, Y_cmd or Z_cmd column".into());
    }
    let (mut rows, mut stride, mut seen) = (Vec::new(), 1u64, 0u64);
    for (i, l) in lines.enumerate() {
        let l = l.map_err(|e| e.to_string())?;
        seen += 1;
        if (seen - 1) % stride != 0 {
            continue;
        }
        let f: Vec<&str> = l.trim().split(',').collect();
        let num = |c: Option<usize>| -> Result<f64, String> {
            match c {
                None => Ok(0.0),
                Some(c) => f
                    .get(c)
                    .and_then(|v| v.parse::<f64>().ok())
                    .filter(|v| v.is_finite())
                    .ok_or_else(|| {
                        format!("trace line {}: column {} is not a number", i + 2, c + 1)
                    }),
            }
        };
        let line = f
            .get(line_col)
            .and_then(|v| v.parse().ok())
            .ok_or_else(|| format!("trace line {}: no program line", i + 2))?;
        let mut row = TraceRow {
            line,
            cmd: [0.0; 3],
            act: [0.0; 3],
        };
        for (k, (c, a)) in axis_cols.iter().enumerate() {
            row.cmd[k] = num(*c)?;
            row.act[k] = num(a.or(*c))?;
        }
        rows.push(row);
        if rows.len() >= cap {
            rows = rows.into_iter().step_by(2).collect();
            stride *= 2;
        }
    }
    Ok(rows)
}

/// Moves machine-coordinate rows into `tp`'s frame: in work coordinates each row takes the
/// offset of the blocks on its line in `main_file` (the trace names lines, not files), or the
/// last known one.
pub fn to_frame(rows: &mut [TraceRow], tp: &Toolpath, main_file: &str) {
    if tp.frame != Some(Frame::Work) {
        return;
    }
    let mut by_line: HashMap<u32, P3> = HashMap::new();
    for p in &tp.pieces {
        let b = &tp.blocks[p.block];
        if &*tp.files[b.file] == main_file {
            by_line.entry(b.line).or_insert(p.offset);
        }
    }
    let mut offset = tp.pieces.first().map_or([0.0; 3], |p| p.offset);
    for r in rows {
        if let Some(o) = by_line.get(&r.line) {
            offset = *o;
        }
        for (k, o) in offset.iter().enumerate() {
            r.cmd[k] -= o;
            r.act[k] -= o;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_long_trace_is_thinned_to_the_cap() {
        let mut csv = String::from("t,line,X_cmd,X_act,Z_cmd,Z_act,C_cmd,C_act,X_sw\n");
        for i in 0..1000 {
            csv.push_str(&format!(
                "{}.0,{},{i},{},-1,-1.5,0,0,0x1237\n",
                i,
                i / 100,
                i as f64 - 0.5
            ));
        }
        let rows = read(csv.as_bytes(), 100).unwrap();
        assert!(rows.len() < 100 && rows.len() >= 50, "{}", rows.len());
        assert_eq!(rows[0].cmd, [0.0, 0.0, -1.0]);
        assert_eq!(rows[1].act[0], rows[1].cmd[0] - 0.5);
        assert_eq!(rows[0].act[2], -1.5);
    }

    #[test]
    fn a_bad_trace_says_what_is_wrong() {
        assert!(read("".as_bytes(), 10).unwrap_err().contains("empty trace"));
        assert!(
            read("t,X_cmd\n".as_bytes(), 10)
                .unwrap_err()
                .contains("`line`")
        );
        let e = read("t,line,X_cmd\n0,1,abc\n".as_bytes(), 10).unwrap_err();
        assert!(e.contains("trace line 2: column 3"), "{e}");
    }
}
