//! The blocks whose ISO end point or centre the reader computes ([`super::contour`]): `CR`,
//! `CT`, and the `RND`/`CHF` an `L` sees ahead of it (the `L` ends where the corner starts,
//! the `RND`/`CHF` line is the arc or chamfer, the next `L` starts where it ends).

use super::contour::{self, Corner, Xy};
use super::words::Word;
use super::{Translator, axis_words, body, feed_words, fmt, m_words, number};

impl Translator {
    /// Where the tool is in the plane, if the program has said.
    pub(super) fn xy(&self) -> Option<Xy> {
        Some((self.at[0]?, self.at[1]?))
    }

    /// Where a block with `words` ends in the plane (the axes it leaves stay).
    pub(super) fn plane_end(&self, words: &[Word]) -> Option<Xy> {
        Some((
            axis(words, 'X').or(self.at[0])?,
            axis(words, 'Y').or(self.at[1])?,
        ))
    }

    /// The `RND`/`CHF` in `ahead` (the lines after an `L` from `start` with `words`), if the
    /// first line there that is not empty or a comment is one.
    pub(super) fn corner_ahead(
        &self,
        start: Option<Xy>,
        words: &[Word],
        ahead: &[String],
    ) -> Option<Result<Corner, String>> {
        let mut blocks = ahead
            .iter()
            .map(|l| body(l))
            .filter(|b| !b.is_empty() && !b.starts_with([';', '*']));
        let first = blocks.next()?;
        let (what, rest) = first.split_once(' ').unwrap_or((first, ""));
        if what != "RND" && what != "CHF" {
            return None;
        }
        Some(self.corner_to(what, rest, start, words, blocks.next()))
    }

    fn corner_to(
        &self,
        what: &str,
        rest: &str,
        start: Option<Xy>,
        words: &[Word],
        next: Option<&str>,
    ) -> Result<Corner, String> {
        let rest = rest.split(';').next().unwrap_or("");
        let (size, feed) = self.corner_words(what, &self.q.substitute(rest)?)?;
        let (Some(start), Some(corner)) = (start, self.plane_end(words)) else {
            return Err(format!(
                "{what} needs the L before it to start and end at a known X and Y (absolute \
                 X and Y before it)"
            ));
        };
        let in_plane = |words: &[Word]| {
            words.iter().all(|w| match w {
                Word::Axis('Z', z) => self.at[2] == Some(*z),
                Word::Axis(l, _) => *l == 'X' || *l == 'Y',
                _ => true,
            })
        };
        let after = next.map(|l| l.split(';').next().unwrap_or("").trim());
        let Some(next_rest) = after.and_then(|l| l.strip_prefix("L ")) else {
            return Err(format!(
                "{what} needs a straight L block after it (cnc402 reads RND and CHF between \
                 two L blocks in the XY plane), found {:?}",
                after.unwrap_or("nothing")
            ));
        };
        let next_words = self.path_words(&self.q.substitute(next_rest)?)?;
        if !in_plane(words) || !in_plane(&next_words) {
            return Err(format!(
                "{what} between blocks that move Z: cnc402 reads it in the XY plane only"
            ));
        }
        // The next L's end, from the corner (its own axes, else the corner's).
        let next_end = (
            axis(&next_words, 'X').unwrap_or(corner.0),
            axis(&next_words, 'Y').unwrap_or(corner.1),
        );
        contour::corner(start, corner, next_end, size, what == "RND", feed)
    }

    /// `RND R r [F f]` or `CHF c [F f]`: the size, and the feed of that block only.
    fn corner_words(&self, what: &str, rest: &str) -> Result<(f64, Option<f64>), String> {
        let (mut size, mut feed) = (None, None);
        for w in rest.split_whitespace() {
            let radius = w.strip_prefix('R').filter(|_| what == "RND");
            if let Some(f) = w.strip_prefix('F') {
                feed = Some(number(f)? * self.feed_scale());
            } else if let Some(r) = radius.or((what == "CHF").then_some(w)) {
                size = Some(number(r)?);
            } else {
                return Err(format!(
                    "{w} is not a word of {what} (expected {what} size F)"
                ));
            }
        }
        let expected = if what == "RND" { "RND R r" } else { "CHF c" };
        let size = size.ok_or_else(|| format!("{what} without its size: expected {expected}"))?;
        Ok((size, feed))
    }

    /// The `RND`/`CHF` line: the arc or chamfer its `L` computed, at that block's feed only.
    pub(super) fn rounding(
        &mut self,
        what: &str,
        corner: Option<Result<Corner, String>>,
    ) -> Result<String, String> {
        let Some(corner) = corner else {
            return Err(format!(
                "{what} after a block that is not a straight L: cnc402 reads RND R and CHF \
                 between two L blocks in the XY plane (expected an L before and after it)"
            ));
        };
        let c = corner?;
        let mut out = match c.arc {
            Some(a) => vec![
                if a.ccw { "G3" } else { "G2" }.to_string(),
                format!("X{} Y{}", fmt(c.end.0), fmt(c.end.1)),
                format!("I{} J{}", fmt(a.centre.0), fmt(a.centre.1)),
            ],
            None => vec![
                "G1".to_string(),
                format!("X{} Y{}", fmt(c.end.0), fmt(c.end.1)),
            ],
        };
        if let Some(f) = c.feed {
            // The RND/CHF block's F is its own: the block after it has the feed before.
            out.push(format!("F{}", fmt(f)));
            self.refeed = true;
        } else if let Some(f) = self.feed_again(&[], false) {
            out.push(f);
        }
        self.tangent = match c.arc {
            Some(a) => Some(a.end_tangent()),
            None => contour::unit(contour::sub(c.end, c.leg_end)),
        };
        self.at[0] = Some(c.end.0);
        self.at[1] = Some(c.end.1);
        Ok(out.join(" "))
    }

    /// `CR X Y R±r DR± [R0|RL|RR] [F] [M]`: the arc of radius r to the end point (R+ the
    /// short one, R- the long one).
    pub(super) fn radius_arc(&mut self, rest: &str) -> Result<String, String> {
        let (mut radius, mut others) = (None, Vec::new());
        for w in rest.split_whitespace() {
            let value = w.strip_prefix('R').filter(|v| {
                w != "R0" && v.starts_with(|c: char| c == '+' || c == '-' || c.is_ascii_digit())
            });
            match value {
                Some(v) => radius = Some(number(v)?),
                None => others.push(w),
            }
        }
        let words = self.path_words(&others.join(" "))?;
        let Some(r) = radius.filter(|r| *r != 0.0) else {
            return Err("CR needs its radius R+r (short arc) or R-r (long arc)".into());
        };
        let Some(ccw) = direction(&words) else {
            return Err("CR needs DR+ or DR-".into());
        };
        plane_only("CR", &words)?;
        let (Some(start), Some(end)) = (self.xy(), self.plane_end(&words)) else {
            return Err("CR needs the tool's X and Y known (an absolute L before it)".into());
        };
        let arc = contour::by_radius(start, end, r, ccw)?;
        self.plane_arc(&words, arc)
    }

    /// `CT X Y [R0|RL|RR] [F] [M]`: the arc tangent to the element before it.
    pub(super) fn tangent_arc(&mut self, rest: &str) -> Result<String, String> {
        let words = self.path_words(rest)?;
        if direction(&words).is_some() {
            return Err("CT takes no DR (its direction follows from the tangent)".into());
        }
        plane_only("CT", &words)?;
        let Some(tangent) = self.tangent else {
            return Err(
                "CT with no previous contour direction: expected a contour block (L, C, CR, \
                 CT, CP, RND, CHF) moving in the XY plane before it"
                    .into(),
            );
        };
        let (Some(start), Some(end)) = (self.xy(), self.plane_end(&words)) else {
            return Err("CT needs the tool's X and Y known (an absolute L before it)".into());
        };
        let arc = contour::tangential(start, tangent, end)?;
        self.plane_arc(&words, arc)
    }

    /// `LP PR±r PA±a` (or `IPR`, `IPA`: added to where the tool is about the pole) and the
    /// block's other words: the same `L` words with the end point in X and Y. A radius or
    /// angle not given is the tool's, about the `CC` (the pole).
    pub(super) fn polar_line(&self, rest: &str) -> Result<String, String> {
        let Some(pole) = self.centre else {
            return Err("LP without a CC (its pole) before it".into());
        };
        let here = self.xy().map(|p| {
            let d = contour::sub(p, pole);
            (d.0.hypot(d.1), d.1.atan2(d.0).to_degrees())
        });
        let (mut radius, mut angle, mut others) = (None, None, Vec::new());
        for w in rest.split_whitespace() {
            let (incremental, word) = match w.strip_prefix('I') {
                Some(p) if p.starts_with("PR") || p.starts_with("PA") => (true, p),
                _ => (false, w),
            };
            let slot = if let Some(v) = word.strip_prefix("PR") {
                (&mut radius, 0, v)
            } else if let Some(v) = word.strip_prefix("PA") {
                (&mut angle, 1, v)
            } else {
                others.push(w);
                continue;
            };
            let value = number(slot.2)?;
            let base = match (incremental, here) {
                (false, _) => 0.0,
                (true, Some(h)) => [h.0, h.1][slot.1],
                (true, None) => {
                    return Err(format!("{w} needs the tool's X and Y known"));
                }
            };
            *slot.0 = Some(base + value);
        }
        let (Some(r), Some(a)) = (radius.or(here.map(|h| h.0)), angle.or(here.map(|h| h.1))) else {
            return Err("LP needs PR and PA (or the tool's X and Y known to keep one)".into());
        };
        if r < 0.0 {
            return Err(format!("LP with a negative polar radius PR {r}"));
        }
        let (s, c) = a.to_radians().sin_cos();
        // On a nanometre grid: the sine and cosine's last bits (cos 90°) are not a position.
        let clean = |v: f64| (v * 1e9).round() / 1e9 + 0.0;
        let (x, y) = (clean(pole.0 + r * c), clean(pole.1 + r * s));
        let signed = |v: f64| {
            if v < 0.0 {
                format!("{v}")
            } else {
                format!("+{v}")
            }
        };
        others.insert(0, "");
        Ok(format!("X{} Y{}{}", signed(x), signed(y), others.join(" ")))
    }

    /// The G2/G3 of `arc` with the block's other words.
    fn plane_arc(&mut self, words: &[Word], arc: contour::Arc) -> Result<String, String> {
        let mut out = vec![if arc.ccw { "G3" } else { "G2" }.to_string()];
        out.extend(self.compensation(words)?);
        let refeed = self.feed_again(words, false);
        self.follow(words);
        out.extend(axis_words(words)?);
        out.push(format!("I{} J{}", fmt(arc.centre.0), fmt(arc.centre.1)));
        out.extend(feed_words(words));
        out.extend(refeed);
        out.extend(m_words(words)?);
        self.tangent = Some(arc.end_tangent());
        Ok(out.join(" "))
    }
}

/// The value of the block's axis word `letter`, if it has one.
fn axis(words: &[Word], letter: char) -> Option<f64> {
    words.iter().find_map(|w| match w {
        Word::Axis(a, v) if *a == letter => Some(*v),
        _ => None,
    })
}

fn direction(words: &[Word]) -> Option<bool> {
    words.iter().find_map(|w| match w {
        Word::Dr(ccw) => Some(*ccw),
        _ => None,
    })
}

fn plane_only(what: &str, words: &[Word]) -> Result<(), String> {
    if words
        .iter()
        .any(|w| matches!(w, Word::Axis(l, _) if *l != 'X' && *l != 'Y'))
    {
        return Err(format!(
            "{what} moves X and Y only in the subset (no helix)"
        ));
    }
    Ok(())
}
