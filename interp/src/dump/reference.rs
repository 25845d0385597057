//! The segment dump as it was written before it was made cheaper (session of 2026-11-25,
//! `format!` and [`fmt_num`] for every number, one `push` a character): kept for the tests
//! only, as the reference the fast writer must match byte for byte on any segment.

use std::fmt::Write;

use cnc402_config::MachineConfig;
use cnc402_motion::segment::{
    ArcDir, AxisPos, Plane, Segment, SegmentEnd, SegmentKind, Source, SpindleDir, StopKind,
    TapSegment,
};

use super::{json_str, kind_name};
use crate::words::fmt_num;

fn num(v: f64) -> String {
    if v.is_finite() {
        fmt_num(v)
    } else {
        "null".into()
    }
}

pub(super) fn axes_obj(o: &mut String, key: &str, end: &AxisPos, cfg: &MachineConfig) {
    let _ = write!(o, ",\"{key}\":{{");
    for (i, ax) in cfg.axes.iter().enumerate() {
        if i > 0 {
            o.push(',');
        }
        let _ = write!(o, "\"{}\":{}", ax.name, num(end[i]));
    }
    o.push('}');
}

pub(super) fn source_keys(o: &mut String, key: &str, name: &str, source: &Source) {
    let n = source.n.map_or("null".to_string(), |n| n.to_string());
    let _ = write!(
        o,
        "{{\"{key}\":\"{name}\",\"file\":{},\"line\":{},\"n\":{n}",
        json_str(&source.file),
        source.line
    );
}

fn spindle_number(o: &mut String, spindle: u8) {
    if spindle != 1 {
        let _ = write!(o, ",\"spindle\":{spindle}");
    }
}

pub(super) fn kind_keys(o: &mut String, kind: &SegmentKind, cfg: &MachineConfig) {
    match kind {
        SegmentKind::Rapid { end } => axes_obj(o, "end", end, cfg),
        SegmentKind::Linear { end, feed } => {
            axes_obj(o, "end", end, cfg);
            let _ = write!(o, ",\"feed\":{}", num(*feed));
        }
        SegmentKind::Tap(TapSegment {
            end,
            feed,
            tool,
            spindle,
            pitch,
        }) => {
            axes_obj(o, "end", end, cfg);
            let name = |i: u8| cfg.axes.get(usize::from(i)).map_or('?', |a| a.name);
            let _ = write!(
                o,
                ",\"feed\":{},\"tool\":\"{}\",\"spindle\":\"{}\",\"pitch\":{}",
                num(*feed),
                name(*tool),
                name(*spindle),
                num(*pitch)
            );
        }
        SegmentKind::Arc {
            end,
            center,
            plane,
            dir,
            turns,
            feed,
        } => {
            axes_obj(o, "end", end, cfg);
            let plane = match plane {
                Plane::XY => "XY",
                Plane::ZX => "ZX",
                Plane::YZ => "YZ",
            };
            let dir = match dir {
                ArcDir::Cw => "cw",
                ArcDir::Ccw => "ccw",
            };
            let _ = write!(
                o,
                ",\"center\":{{\"X\":{},\"Y\":{},\"Z\":{}}},\"plane\":\"{plane}\",\"dir\":\"{dir}\",\"turns\":{turns},\"feed\":{}",
                num(center[0]),
                num(center[1]),
                num(center[2]),
                num(*feed)
            );
        }
        SegmentKind::Dwell { seconds } => {
            let _ = write!(o, ",\"seconds\":{}", num(*seconds));
        }
        SegmentKind::Spindle { rpm, dir, spindle } => {
            let dir = match dir {
                SpindleDir::Cw => "cw",
                SpindleDir::Ccw => "ccw",
                SpindleDir::Stop => "stop",
            };
            let _ = write!(o, ",\"rpm\":{},\"dir\":\"{dir}\"", num(*rpm));
            spindle_number(o, *spindle);
        }
        SegmentKind::SpindleOrient {
            angle,
            program,
            spindle,
        } => {
            let _ = write!(o, ",\"angle\":{}", num(*angle));
            if let Some(c) = program {
                let _ = write!(o, ",\"program\":{}", num(*c));
            }
            spindle_number(o, *spindle);
        }
        SegmentKind::ToolChange { tool } => {
            let _ = write!(o, ",\"tool\":{tool}");
        }
        SegmentKind::Coolant { mist, flood } => {
            let _ = write!(o, ",\"mist\":{mist},\"flood\":{flood}");
        }
        SegmentKind::Stop { kind } => {
            let k = match kind {
                StopKind::Program => "program",
                StopKind::Optional => "optional",
                StopKind::End => "end",
                StopKind::EndRewind => "end_rewind",
                StopKind::WaitMark { mark, channels } => {
                    let _ = write!(
                        o,
                        ",\"stop\":\"wait_mark\",\"mark\":{mark},\"channels\":{channels}"
                    );
                    return;
                }
            };
            let _ = write!(o, ",\"stop\":\"{k}\"");
        }
        SegmentKind::Message { text } => {
            let _ = write!(o, ",\"text\":{}", json_str(text));
        }
    }
}

pub(super) fn segment_to_json(seg: &Segment, cfg: &MachineConfig) -> String {
    let mut o = String::new();
    source_keys(&mut o, "kind", kind_name(&seg.kind), &seg.source);
    kind_keys(&mut o, &seg.kind, cfg);
    match seg.ends {
        SegmentEnd::ExactStop => o.push_str(",\"ends\":\"exact_stop\""),
        SegmentEnd::Continuous {
            tolerance,
            collinear,
        } => {
            let _ = write!(
                o,
                ",\"ends\":\"continuous\",\"tolerance\":{}",
                num(tolerance)
            );
            if collinear > 0.0 {
                let _ = write!(o, ",\"collinear\":{}", num(collinear));
            }
        }
    }
    o.push('}');
    o
}

/// The fast writer against the reference on any segment, machine and file name.
mod differential {
    use super::*;
    use crate::dump::SegmentWriter;
    use proptest::prelude::*;

    /// Numbers as a program and a machine make them, and the ones the fast path treats
    /// apart: 4-decimal CAM values, halves of the last digit, ±1e9 and beyond, non-finite.
    fn number() -> impl Strategy<Value = f64> {
        prop_oneof![
            (-2_000_000_000i64..2_000_000_000).prop_map(|k| k as f64 / 1e4),
            (-1_000_000_000_000i64..1_000_000_000_000).prop_map(|k| (k as f64 + 0.5) / 1e6),
            any::<f64>(),
            (-3i32..12, any::<bool>())
                .prop_map(|(e, s)| if s { -1.0 } else { 1.0 } * 10f64.powi(e)),
            Just(-0.0),
            Just(999_999_999.999_999_6),
            Just(f64::NAN),
            Just(f64::NEG_INFINITY),
        ]
    }

    fn axes() -> impl Strategy<Value = AxisPos> {
        proptest::collection::vec(number(), cnc402_config::MAX_AXES).prop_map(|v| {
            let mut p = AxisPos::default();
            for (i, x) in v.into_iter().enumerate() {
                p[i] = x;
            }
            p
        })
    }

    fn text() -> impl Strategy<Value = String> {
        prop_oneof![
            Just("prog.nc".to_string()),
            "[a-z/._ -]{0,40}",
            ".{0,12}",
            proptest::collection::vec(any::<char>(), 0..10).prop_map(|c| c.into_iter().collect()),
        ]
    }

    fn kind() -> impl Strategy<Value = SegmentKind> {
        prop_oneof![
            axes().prop_map(|end| SegmentKind::Rapid { end }),
            (axes(), number()).prop_map(|(end, feed)| SegmentKind::Linear { end, feed }),
            (axes(), number(), 0u8..10, 0u8..10, number()).prop_map(
                |(end, feed, tool, spindle, pitch)| SegmentKind::Tap(TapSegment {
                    end,
                    feed,
                    tool,
                    spindle,
                    pitch
                })
            ),
            (
                axes(),
                number(),
                number(),
                number(),
                0u8..3,
                any::<bool>(),
                any::<u32>(),
                number()
            )
                .prop_map(|(end, x, y, z, p, cw, turns, feed)| SegmentKind::Arc {
                    end,
                    center: [x, y, z],
                    plane: [Plane::XY, Plane::ZX, Plane::YZ][usize::from(p)],
                    dir: if cw { ArcDir::Cw } else { ArcDir::Ccw },
                    turns,
                    feed,
                }),
            number().prop_map(|seconds| SegmentKind::Dwell { seconds }),
            (number(), 0u8..3, 0u8..4).prop_map(|(rpm, d, spindle)| SegmentKind::Spindle {
                rpm,
                dir: [SpindleDir::Cw, SpindleDir::Ccw, SpindleDir::Stop][usize::from(d)],
                spindle,
            }),
            (number(), proptest::option::of(number()), 0u8..4).prop_map(
                |(angle, program, spindle)| SegmentKind::SpindleOrient {
                    angle,
                    program,
                    spindle
                }
            ),
            any::<u32>().prop_map(|tool| SegmentKind::ToolChange { tool }),
            (any::<bool>(), any::<bool>())
                .prop_map(|(mist, flood)| SegmentKind::Coolant { mist, flood }),
            (0u8..5, any::<u16>(), any::<u16>()).prop_map(|(k, mark, channels)| {
                let kind = match k {
                    0 => StopKind::Program,
                    1 => StopKind::Optional,
                    2 => StopKind::End,
                    3 => StopKind::EndRewind,
                    _ => StopKind::WaitMark { mark, channels },
                };
                SegmentKind::Stop { kind }
            }),
            text().prop_map(|text| SegmentKind::Message { text }),
        ]
    }

    fn segment(files: Vec<std::sync::Arc<str>>) -> impl Strategy<Value = Segment> {
        let ends = prop_oneof![
            Just(SegmentEnd::ExactStop),
            (number(), prop_oneof![Just(0.0), number()]).prop_map(|(tolerance, collinear)| {
                SegmentEnd::Continuous {
                    tolerance,
                    collinear,
                }
            }),
        ];
        (
            kind(),
            proptest::sample::select(files),
            any::<u32>(),
            proptest::option::of(any::<u32>()),
            ends,
        )
            .prop_map(|(kind, file, line, n, ends)| Segment {
                kind,
                source: Source { file, line, n },
                ends,
            })
    }

    /// A machine of 1 to MAX_AXES axes, some named by non-ASCII letters.
    fn machine() -> impl Strategy<Value = MachineConfig> {
        proptest::collection::vec(
            prop_oneof![4 => proptest::char::range('A', 'Z'), 1 => any::<char>()],
            1..=cnc402_config::MAX_AXES,
        )
        .prop_map(|names| {
            let mut cfg = MachineConfig::default_machine();
            let first = cfg.axes[0].clone();
            cfg.axes = names
                .into_iter()
                .map(|name| {
                    let mut a = first.clone();
                    a.name = name;
                    a
                })
                .collect();
            cfg
        })
    }

    fn program() -> impl Strategy<Value = (MachineConfig, Vec<Segment>)> {
        (machine(), proptest::collection::vec(text(), 1..4)).prop_flat_map(|(cfg, names)| {
            let files: Vec<std::sync::Arc<str>> = names.into_iter().map(Into::into).collect();
            (Just(cfg), proptest::collection::vec(segment(files), 1..20))
        })
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2_000))]

        /// Every segment, one at a time and as a long dump (the writer keeps the escaped
        /// file name, the feed's and the tolerance's text between segments: each segment is
        /// written twice, so the kept text is used as well as replaced), prints what the
        /// reference prints.
        #[test]
        fn the_fast_writer_prints_what_the_reference_prints((cfg, segs) in program()) {
            let mut dump = String::new();
            let mut want = String::new();
            let mut writer = SegmentWriter::default();
            for s in &segs {
                let one = segment_to_json(s, &cfg);
                prop_assert_eq!(crate::dump::segment_to_json(s, &cfg), one.clone());
                for _ in 0..2 {
                    writer.write_line(&mut dump, s, &cfg);
                    want.push_str(&one);
                    want.push('\n');
                }
                // The pieces `canon` shares: the kind's keys and an opening with "op".
                let (mut fast, mut slow) = (String::new(), String::new());
                crate::dump::kind_keys(&mut fast, &s.kind, &cfg);
                kind_keys(&mut slow, &s.kind, &cfg);
                prop_assert_eq!(&fast, &slow);
                crate::dump::source_keys(&mut fast, "op", "x", &s.source);
                source_keys(&mut slow, "op", "x", &s.source);
                prop_assert_eq!(fast, slow);
            }
            prop_assert_eq!(dump, want);
        }
    }
}
