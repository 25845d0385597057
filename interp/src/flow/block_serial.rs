//! Block identity for the operator's breakpoints and single block: a serial that grows by one
//! for every block (or C-like statement acting on the machine) the interpreter executes, so
//! that two passes of one line in a loop tell apart although their `Source` is the same.

use super::Interpreter;

impl Interpreter {
    /// Blocks executed so far since [`load`](Self::load). Read right after
    /// [`next_segment`](Self::next_segment) refilled its operations, it names the block whose
    /// operation came out (without cutter compensation holding operations back, exactly;
    /// with it, the serial may run a few blocks ahead, the line still tells the block).
    pub fn block_serial(&self) -> u64 {
        self.flow.runaway.total + self.hll.requests()
    }
}

#[cfg(test)]
mod tests {
    use cnc402_config::MachineConfig;
    use cnc402_lang::SourceFile;

    use crate::Interpreter;

    /// (line, serial) of each segment of `text`.
    fn serials(text: &str) -> Vec<(u32, u64)> {
        let cfg = MachineConfig::default_machine();
        let src = SourceFile::new("s.nc", text);
        let program = cnc402_lang::parse(&src).expect("parses");
        let mut it = Interpreter::new(&cfg);
        it.load(src, program);
        let mut out = Vec::new();
        while let Some(seg) = it.next_segment().expect("runs") {
            out.push((seg.source.line, it.block_serial()));
        }
        out
    }

    #[test]
    fn each_pass_of_a_loop_line_is_a_new_block() {
        let s = serials("#1=0\nWHILE [#1 LT 3] DO1\nG91 G1 X1 F100\n#1=#1+1\nEND1\nM30\n");
        let lines: Vec<u32> = s.iter().map(|x| x.0).collect();
        assert_eq!(lines, [3, 3, 3, 6]);
        assert!(s.windows(2).all(|w| w[0].1 < w[1].1), "{s:?}");
    }

    #[test]
    fn the_operations_of_one_block_share_its_serial() {
        // One block: a spindle start and a move.
        let s = serials("G0 X1 S1000 M3\nG0 X2\n");
        assert_eq!(s.len(), 3, "{s:?}");
        assert_eq!(s[0].1, s[1].1);
        assert!(s[2].1 > s[1].1);
    }

    #[test]
    fn c_like_statements_count() {
        let s = serials("int nI = 0;\nwhile (nI < 2) {\n  MSG(\"a\");\n  nI = nI + 1;\n}\n");
        assert_eq!(s.len(), 2, "{s:?}");
        assert!(s[0].1 < s[1].1, "{s:?}");
    }
}
