//! `[interp] cutter_comp_*`: how cutter radius compensation (G41/G42) joins blocks, starts up
//! and reacts to a tool too big for the contour, and how many blocks it looks ahead.

use toml::Spanned;

use crate::check::{Invalid, int_in, positive_at_most};

/// What fills an outside corner between two compensated blocks.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CompCorner {
    /// An arc of the tool radius around the programmed corner (LinuxCNC's way; the default:
    /// the tool stays in contact with the corner point, so the corner is cut exactly and no
    /// path leaves the part farther than R).
    Arc,
    /// The two offset paths extended (by lines) to their intersection: a sharp corner.
    Intersection,
    /// Fanuc type C: corners sharper than [`CutterComp::chamfer_angle`] are cut short by three
    /// blocks (out by R along the first block, across, in along the second); blunter corners
    /// as `Intersection`.
    Chamfer,
}

/// How the start-up block (the first move in the plane after G41/G42) ends.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CompStartup {
    /// Fanuc type A: at the programmed end point offset by R perpendicular to the next block.
    A,
    /// Fanuc type B (the default, and what LinuxCNC does): at the end point offset by R
    /// perpendicular to the start-up block; the joint to the next block is then a corner like
    /// any other (intersection inside, the corner setting outside).
    B,
}

/// What a gouge (an element the tool cannot follow) does.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CompGouge {
    /// An error that names the block, before any motion (the default).
    Error,
    /// The element is left out and a warning names it.
    Suppress,
}

/// The cutter compensation settings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CutterComp {
    pub corner: CompCorner,
    pub startup: CompStartup,
    pub gouge: CompGouge,
    /// Blocks without motion in the plane (M codes, moves along the normal axis, dwells)
    /// that may come between two contour blocks without breaking the contour.
    pub lookahead: usize,
    /// `Chamfer`: corners whose direction turns by more than this (degrees) are cut short.
    pub chamfer_angle: f64,
}

impl Default for CutterComp {
    fn default() -> Self {
        CutterComp {
            corner: CompCorner::Arc,
            startup: CompStartup::B,
            gouge: CompGouge::Error,
            lookahead: 8,
            chamfer_angle: 90.0,
        }
    }
}

/// The keys as written.
pub(crate) struct RawCutterComp<'a> {
    pub corner: &'a Option<Spanned<String>>,
    pub startup: &'a Option<Spanned<String>>,
    pub gouge: &'a Option<Spanned<String>>,
    pub lookahead: &'a Option<Spanned<i64>>,
    pub chamfer_angle: &'a Option<Spanned<f64>>,
}

fn choice<T: Copy>(
    v: &Option<Spanned<String>>,
    key: &str,
    default: T,
    names: &[(&str, T)],
) -> Result<T, Invalid> {
    let Some(v) = v else { return Ok(default) };
    let got = v.get_ref().to_ascii_lowercase();
    names
        .iter()
        .find(|(n, _)| *n == got)
        .map(|(_, t)| *t)
        .ok_or_else(|| {
            let list: Vec<String> = names.iter().map(|(n, _)| format!("{n:?}")).collect();
            (
                v.span(),
                format!("interp.{key}"),
                format!("expected {}, got {:?}", list.join(" or "), v.get_ref()),
            )
        })
}

impl RawCutterComp<'_> {
    pub(crate) fn validate(&self) -> Result<CutterComp, Invalid> {
        let d = CutterComp::default();
        let angle = match self.chamfer_angle {
            Some(a) => {
                let v = positive_at_most(a, "interp.cutter_comp_chamfer_angle", 180.0)?;
                if v >= 180.0 {
                    return Err((
                        a.span(),
                        "interp.cutter_comp_chamfer_angle".into(),
                        "expected an angle in degrees, 0 < angle < 180".into(),
                    ));
                }
                v
            }
            None => d.chamfer_angle,
        };
        Ok(CutterComp {
            corner: choice(
                self.corner,
                "cutter_comp_corner",
                d.corner,
                &[
                    ("arc", CompCorner::Arc),
                    ("intersection", CompCorner::Intersection),
                    ("chamfer", CompCorner::Chamfer),
                ],
            )?,
            startup: choice(
                self.startup,
                "cutter_comp_startup",
                d.startup,
                &[("a", CompStartup::A), ("b", CompStartup::B)],
            )?,
            gouge: choice(
                self.gouge,
                "cutter_comp_gouge",
                d.gouge,
                &[
                    ("error", CompGouge::Error),
                    ("suppress", CompGouge::Suppress),
                ],
            )?,
            lookahead: match self.lookahead {
                Some(n) => int_in(n, "interp.cutter_comp_lookahead", 0, 1000)? as usize,
                None => d.lookahead,
            },
            chamfer_angle: angle,
        })
    }
}
