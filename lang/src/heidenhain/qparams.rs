//! Q parameters as values: `Qn = expr`, `FN 0..4: Qn = …` and `X+Qn` / `X-Qn` in a block.
//! The reader evaluates them itself as it translates the lines, which happens in the order
//! they run (label repeats and calls re-read their lines), so a block's ISO words carry
//! numbers and the contour geometry (CR, CT, RND, CHF, cycles) sees the values.

use super::number;

/// The Q parameters an iTNC 530 program may use (Q0 to Q1999).
pub const MAX_Q: u32 = 1999;

/// Most nested parentheses in a formula (an expression's recursion ends here).
const MAX_DEPTH: u32 = 16;

/// The tail of the message of a Q parameter read before it has a value.
const UNSET: &str = " has no value (no Q = before it in the run)";

/// A block that reads a Q parameter with no value yet: an alarm (`#3000`) at that block
/// when it runs, not an error when it is read — the load pass reads the lines in file
/// order, so a value a label body called earlier sets is not there yet; in the run it is,
/// and where it is not the run stops at the block with the message. Other errors stay.
pub fn alarm_if_unset(message: &str) -> Result<String, String> {
    match message.strip_suffix(UNSET) {
        Some(q) if q.starts_with('Q') && !q.contains(' ') => Ok(format!(
            "#3000=1 ({q} HAS NO VALUE: NO {q} = BEFORE THIS BLOCK)"
        )),
        _ => Err(message.to_string()),
    }
}

/// The values assigned so far (at most `MAX_Q + 1` of them).
#[derive(Clone, Debug, Default)]
pub struct QTable {
    values: std::collections::BTreeMap<u32, f64>,
}

impl QTable {
    pub fn get(&self, n: u32) -> Result<f64, String> {
        self.values
            .get(&n)
            .copied()
            .ok_or_else(|| format!("Q{n}{UNSET}"))
    }

    /// `Qn = expr` or `FN k: Qn = …` (`text` without a comment): the parameter set and its
    /// number and value.
    pub fn assign(&mut self, text: &str) -> Result<(u32, f64), String> {
        let (fnk, text) = match text.strip_prefix("FN") {
            Some(rest) => {
                let (k, rest) = rest
                    .split_once(':')
                    .ok_or_else(|| format!("FN{rest}: expected FN k: Qn = …"))?;
                (Some(k.trim().to_string()), rest.trim())
            }
            None => (None, text),
        };
        if let Some(k) = fnk
            .as_deref()
            .filter(|k| !["0", "1", "2", "3", "4"].contains(k))
        {
            return Err(format!(
                "FN {k} is not read (cnc402 reads FN 0 to FN 4 and Q formulas with + - * / \
                 and parentheses)"
            ));
        }
        let (q, expr) = text
            .split_once('=')
            .ok_or_else(|| format!("{text}: expected Qn = value"))?;
        let n = q_number(q.trim())?;
        let value = match fnk.as_deref() {
            Some(k @ ("1" | "2" | "3" | "4")) => self.fn_arithmetic(k, expr)?,
            _ => self.formula(expr)?,
        };
        if !value.is_finite() {
            return Err(format!("Q{n} = {expr}: the result is not a finite number"));
        }
        self.values.insert(n, value);
        Ok((n, value))
    }

    /// `FN 1: a + b`, `FN 2: a - b`, `FN 3: a * b`, `FN 4: a DIV b`.
    fn fn_arithmetic(&self, k: &str, expr: &str) -> Result<f64, String> {
        let op = ["+", "-", "*", "DIV"][k.parse::<usize>().unwrap_or(1) - 1];
        let expected = || format!("FN {k}: expected Qn = a {op} b (a and b numbers or Q)");
        // The operator stands between spaces (`+Q2 + -5`): a sign is glued to its operand.
        let (a, b) = expr.split_once(&format!(" {op} ")).ok_or_else(expected)?;
        let (a, b) = (self.operand(a.trim())?, self.operand(b.trim())?);
        Ok(match op {
            "+" => a + b,
            "-" => a - b,
            "*" => a * b,
            _ if b == 0.0 => return Err(format!("FN 4: division by zero ({expr})")),
            _ => a / b,
        })
    }

    /// `±number` or `±Qn`.
    fn operand(&self, text: &str) -> Result<f64, String> {
        let (sign, rest) = match text.strip_prefix('-') {
            Some(r) => (-1.0, r),
            None => (1.0, text.strip_prefix('+').unwrap_or(text)),
        };
        let value = if rest.starts_with('Q') {
            self.get(q_number(rest)?)?
        } else {
            number(rest)?
        };
        Ok(sign * value)
    }

    /// A formula of numbers, `Qn`, `+ - * /`, unary signs and parentheses.
    fn formula(&self, expr: &str) -> Result<f64, String> {
        let tokens = tokens(expr)?;
        let mut at = 0;
        let v = self.sum(&tokens, &mut at, 0)?;
        if at != tokens.len() {
            return Err(format!(
                "{expr}: expected a formula of numbers, Qn, + - * / and ( )"
            ));
        }
        Ok(v)
    }

    fn sum(&self, t: &[Token], at: &mut usize, depth: u32) -> Result<f64, String> {
        let mut v = self.product(t, at, depth)?;
        while let Some(Token::Op(op @ ('+' | '-'))) = t.get(*at) {
            *at += 1;
            let w = self.product(t, at, depth)?;
            v = if *op == '+' { v + w } else { v - w };
        }
        Ok(v)
    }

    fn product(&self, t: &[Token], at: &mut usize, depth: u32) -> Result<f64, String> {
        let mut v = self.unary(t, at, depth)?;
        while let Some(Token::Op(op @ ('*' | '/'))) = t.get(*at) {
            *at += 1;
            let w = self.unary(t, at, depth)?;
            if *op == '/' && w == 0.0 {
                return Err("division by zero in a Q formula".into());
            }
            v = if *op == '*' { v * w } else { v / w };
        }
        Ok(v)
    }

    fn unary(&self, t: &[Token], at: &mut usize, depth: u32) -> Result<f64, String> {
        if depth > MAX_DEPTH {
            return Err(format!("a Q formula nested deeper than {MAX_DEPTH}"));
        }
        let token = t.get(*at).cloned();
        *at += 1;
        match token {
            Some(Token::Op('-')) => Ok(-self.unary(t, at, depth + 1)?),
            Some(Token::Op('+')) => self.unary(t, at, depth + 1),
            Some(Token::Num(v)) => Ok(v),
            Some(Token::Q(n)) => self.get(n),
            Some(Token::Op('(')) => {
                let v = self.sum(t, at, depth + 1)?;
                if t.get(*at) != Some(&Token::Op(')')) {
                    return Err("a Q formula without its closing )".into());
                }
                *at += 1;
                Ok(v)
            }
            _ => Err("expected a number, Qn or ( in a Q formula".into()),
        }
    }

    /// `text` with each `Qn` reference after a word's letters (`X+Q1`, `X-Q1`, `R+Q3`,
    /// `FQ5`, `Q201=-Q5`) replaced by its value.
    pub fn substitute(&self, text: &str) -> Result<String, String> {
        if !text.contains('Q') {
            return Ok(text.to_string());
        }
        let mut out = Vec::new();
        for word in text.split_whitespace() {
            out.push(self.substitute_word(word)?);
        }
        Ok(out.join(" "))
    }

    fn substitute_word(&self, word: &str) -> Result<String, String> {
        // The last `Q` followed by digits to the word's end, after at least one character.
        let Some(i) = word.rfind('Q').filter(|i| *i > 0) else {
            return Ok(word.to_string());
        };
        let digits = &word[i + 1..];
        if digits.is_empty() || !digits.bytes().all(|b| b.is_ascii_digit()) {
            return Ok(word.to_string());
        }
        let value = self.get(q_number(&word[i..])?)?;
        let (head, sign) = match word[..i].strip_suffix('-') {
            Some(h) => (h, -1.0),
            None => (word[..i].strip_suffix('+').unwrap_or(&word[..i]), 1.0),
        };
        let v = sign * value;
        Ok(format!("{head}{}{v}", if v < 0.0 { "" } else { "+" }))
    }
}

#[derive(Clone, Debug, PartialEq)]
enum Token {
    Num(f64),
    Q(u32),
    Op(char),
}

/// The tokens of a formula (at most one per character: bounded by the line).
fn tokens(expr: &str) -> Result<Vec<Token>, String> {
    let mut out = Vec::new();
    let mut rest = expr.trim();
    while let Some(c) = rest.chars().next() {
        if c.is_whitespace() {
            rest = rest.trim_start();
            continue;
        }
        if "+-*/()".contains(c) {
            out.push(Token::Op(c));
            rest = &rest[1..];
            continue;
        }
        // At least the whole first character: a sign like `±` (a Latin-1 byte read as a
        // character) is one token, a number that does not parse, not half a character.
        let len = rest
            .find(|ch: char| !(ch.is_ascii_alphanumeric() || ch == '.' || ch == ','))
            .unwrap_or(rest.len())
            .max(c.len_utf8());
        let word = &rest[..len];
        out.push(if word.starts_with('Q') {
            Token::Q(q_number(word)?)
        } else {
            Token::Num(number(word)?)
        });
        rest = &rest[len..];
    }
    Ok(out)
}

/// `Qn` → n (0 to [`MAX_Q`]).
pub fn q_number(text: &str) -> Result<u32, String> {
    text.strip_prefix('Q')
        .and_then(|d| d.trim().parse::<u32>().ok())
        .filter(|n| *n <= MAX_Q)
        .ok_or_else(|| format!("{text} is not a Q parameter (Q0 to Q{MAX_Q})"))
}

#[cfg(test)]
mod tests {
    use super::QTable;

    /// Found by the differential fuzzer: `Q1 = -2.92±` (a Latin-1 byte 0xB1 at the end of
    /// the line) cut the `±` in half and panicked.
    #[test]
    fn a_formula_with_a_multibyte_character_used_to_panic_and_is_an_error() {
        for text in ["Q1 = -2.92±", "Q1 = ±2", "Q1 = 2 * é", "Q2 = Q1 €"] {
            let e = QTable::default().assign(text).unwrap_err();
            assert!(!e.is_empty(), "{text}");
        }
        assert_eq!(QTable::default().assign("Q1 = -2.92"), Ok((1, -2.92)));
    }

    proptest::proptest! {
        /// No assignment text panics: any characters (ASCII, Latin-1 read as characters,
        /// multibyte) after `Qn =` or `FN k:` are a value or an error.
        #[test]
        fn no_assignment_text_panics(
            head in proptest::sample::select(vec!["Q1 = ", "FN 0: Q2 = ", "Q3=", "FN 4: Q1 = "]),
            body in "[0-9Q.,+*/() \\-±éµ€a-z]{0,24}",
        ) {
            let mut t = QTable::default();
            let _ = t.assign("Q5 = 3");
            let _ = t.assign(&format!("{head}{body}"));
        }
    }
}
