//! The rule sets. Differences between the Fanuc models are the ones that change the text:
//! word lengths (0: 4-digit O and N numbers, S4; 16/18: N5, S5; 32i: 8-digit O numbers) and
//! the options assumed present (the 0 without the orienting boring cycles G76/G87, which it
//! gets as Custom Macro B programs). Arumatik is modelled as an ISO (Fanuc-like) milling control
//! without Custom Macro B, G10 or helical interpolation, and without the orienting boring
//! cycles G76/G87 (docs/post.md says why: the source names it and nothing more).

use super::{ArcForm, Numbering, Rules};

/// A target named on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Target {
    Fanuc0,
    Fanuc16,
    Fanuc18,
    Fanuc32,
    Arumatik,
    Itnc530,
}

/// Every Fanuc M-series canned cycle.
const FANUC_CYCLES: &[u32] = &[73, 74, 76, 81, 82, 83, 84, 85, 86, 87, 88, 89];
/// Series 0-MC: no orienting boring cycles (G76/G87; see docs/post.md): Macro B bodies instead.
const FANUC0_CYCLES: &[u32] = &[73, 74, 81, 82, 83, 84, 85, 86, 88, 89];
/// Arumatik: the drilling, tapping and boring cycles without spindle orientation.
const ARUMATIK_CYCLES: &[u32] = &[73, 74, 81, 82, 83, 84, 85, 86, 88, 89];

impl Target {
    pub const ALL: [Target; 6] = [
        Target::Fanuc0,
        Target::Fanuc16,
        Target::Fanuc18,
        Target::Fanuc32,
        Target::Arumatik,
        Target::Itnc530,
    ];

    /// The `--target` name.
    pub fn name(self) -> &'static str {
        match self {
            Target::Fanuc0 => "fanuc0",
            Target::Fanuc16 => "fanuc16",
            Target::Fanuc18 => "fanuc18",
            Target::Fanuc32 => "fanuc32",
            Target::Arumatik => "arumatik",
            Target::Itnc530 => "itnc530",
        }
    }

    /// The target of a `--target` name.
    pub fn from_name(name: &str) -> Option<Target> {
        Target::ALL.into_iter().find(|t| t.name() == name)
    }

    /// The target's rule set.
    pub fn rules(self) -> Rules {
        let fanuc16 = Rules {
            name: self.name(),
            title: "Fanuc Series 16i-MB",
            position_decimals: 3,
            feed_decimals: 3,
            max_position: 99_999.999,
            max_feed: 240_000.0,
            max_spindle: 99_999.0,
            max_tool: 99_999_999,
            max_program: 9999,
            main_program: 1000,
            first_subprogram: 8000,
            numbering: Some(Numbering {
                start: 10,
                step: 10,
                max: 99_999,
            }),
            max_line: 256,
            cycles: FANUC_CYCLES,
            arc_form: ArcForm::Ijk,
            helical: true,
            macros: true,
            data_input: true,
            comments: true,
        };
        match self {
            Target::Fanuc16 => fanuc16,
            Target::Fanuc18 => Rules {
                title: "Fanuc Series 18i-MB",
                ..fanuc16
            },
            Target::Fanuc32 => Rules {
                title: "Fanuc Series 32i-B (8-digit program numbers)",
                max_program: 99_999_999,
                ..fanuc16
            },
            Target::Fanuc0 => Rules {
                title: "Fanuc Series 0-MC",
                max_feed: 15_000.0,
                max_spindle: 9999.0,
                max_tool: 9999,
                numbering: Some(Numbering {
                    start: 10,
                    step: 10,
                    max: 9999,
                }),
                max_line: 128,
                cycles: FANUC0_CYCLES,
                ..fanuc16
            },
            Target::Arumatik => Rules {
                title: "Arumatik (ISO milling control, no Custom Macro B)",
                max_feed: 15_000.0,
                max_spindle: 9999.0,
                max_tool: 99,
                numbering: Some(Numbering {
                    start: 1,
                    step: 1,
                    max: 9999,
                }),
                max_line: 80,
                cycles: ARUMATIK_CYCLES,
                helical: false,
                macros: false,
                data_input: false,
                ..fanuc16
            },
            Target::Itnc530 => Rules {
                title: "Heidenhain iTNC 530",
                position_decimals: 4,
                numbering: None,
                max_line: 256,
                cycles: &[],
                ..fanuc16
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_target_has_its_name_back() {
        for t in Target::ALL {
            assert_eq!(Target::from_name(t.name()), Some(t));
            assert_eq!(t.rules().name, t.name());
        }
        assert_eq!(Target::from_name("fanuc15"), None);
    }

    #[test]
    fn models_differ_where_the_controls_do() {
        assert_eq!(Target::Fanuc0.rules().max_program, 9999);
        assert_eq!(Target::Fanuc32.rules().max_program, 99_999_999);
        assert_eq!(Target::Fanuc0.rules().numbering.unwrap().max, 9999);
        assert!(!Target::Arumatik.rules().macros);
        assert!(!Target::Arumatik.rules().has_cycle(76));
        assert!(Target::Fanuc18.rules().has_cycle(87));
        assert!(!Target::Fanuc0.rules().has_cycle(76) && Target::Fanuc0.rules().macros);
    }
}
