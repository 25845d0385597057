//! The words of a Heidenhain positioning block: signed axis values (`X+10`, `Z-2.5`),
//! `R0/RL/RR`, `F`/`FMAX`, `DR+/-`, `M`.

use super::number;

#[derive(Clone, Debug, PartialEq)]
pub enum Word {
    Axis(char, f64),
    R0,
    Rl,
    Rr,
    Feed(f64),
    Fmax,
    /// `DR+` (true) or `DR-`.
    Dr(bool),
    M(u32),
}

/// The words of `text`, or what is not one (incremental `IX` is outside the subset; Q
/// parameters are values by now, polar `LP` words X and Y).
pub fn split_words(text: &str) -> Result<Vec<Word>, String> {
    let mut out = Vec::new();
    for w in text.split_whitespace() {
        out.push(match w {
            "R0" => Word::R0,
            "RL" => Word::Rl,
            "RR" => Word::Rr,
            "FMAX" => Word::Fmax,
            "DR+" => Word::Dr(true),
            "DR-" => Word::Dr(false),
            _ => one(w)?,
        });
    }
    Ok(out)
}

fn one(w: &str) -> Result<Word, String> {
    let mut chars = w.chars();
    let letter = chars.next().unwrap_or(' ');
    let rest = chars.as_str();
    match letter {
        'X' | 'Y' | 'Z' | 'A' | 'B' | 'C' if rest.starts_with(['+', '-']) => {
            Ok(Word::Axis(letter, number(rest)?))
        }
        'F' => Ok(Word::Feed(number(rest)?)),
        'M' => rest
            .parse::<u32>()
            .map(Word::M)
            .map_err(|_| format!("{w} is not an M function")),
        _ => Err(format!(
            "{w} is not a word cnc402 reads here (absolute signed axes X+/-, R0/RL/RR, F, \
             FMAX, DR+/-, M, a Q parameter as X+Qn; no IX)"
        )),
    }
}
