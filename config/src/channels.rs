//! `[[channel]]`: the machine's axes split into channels, each with its own program,
//! interpreter, planner and interpolator, all on the one bus and 1 ms loop. No `[[channel]]`
//! is one channel holding every axis. [`MachineConfig::channel`] gives a channel as a smaller
//! machine (its axes only) plus the map back to the machine's axis indices.

use serde::Deserialize;
use toml::Spanned;

use crate::axes::AxisConfig;
use crate::check::Invalid;
use crate::{MAX_AXES, MachineConfig, MachineOutputs, OutputBit};

/// Most channels a machine may configure (fixed-size per-channel tables in the loop).
pub const MAX_CHANNELS: usize = 4;

/// `mode`: a channel in manual mode refuses programs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ChannelMode {
    #[default]
    Auto,
    Manual,
}

/// `on_error`: what an error (fault, motion error) in this channel stops.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum OnError {
    /// Every channel (as a safety chain would): the default.
    #[default]
    All,
    /// Only this channel; the others run on.
    Channel,
}

/// One validated `[[channel]]`.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelConfig {
    pub name: String,
    /// Machine axis indices, in the channel's order (the order of its `axes` key).
    pub axes: Vec<usize>,
    pub mode: ChannelMode,
    pub on_error: OnError,
}

/// A channel as a machine of its own: `config` holds only the channel's axes (and the work
/// offsets, matched axes and outputs that live on them); `axes[i]` is the machine axis index
/// of the channel's axis `i`. Never build a drive link from `config`: the bus is the
/// machine's.
#[derive(Clone, Debug, PartialEq)]
pub struct ChannelView {
    pub index: usize,
    pub name: String,
    pub config: MachineConfig,
    pub axes: Vec<usize>,
    pub mode: ChannelMode,
    pub on_error: OnError,
}

/// `[[channel]]` as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawChannel {
    name: Option<Spanned<String>>,
    axes: Spanned<Vec<Spanned<String>>>,
    mode: Option<Spanned<String>>,
    on_error: Option<Spanned<String>>,
}

/// The one channel of a config without `[[channel]]`: every axis.
fn whole_machine(axes: &[AxisConfig]) -> ChannelConfig {
    ChannelConfig {
        name: "main".into(),
        axes: (0..axes.len()).collect(),
        mode: ChannelMode::Auto,
        on_error: OnError::All,
    }
}

/// Validates the `[[channel]]` entries against the axes: each axis in exactly one channel,
/// every channel with at least one axis, at most [`MAX_CHANNELS`].
pub(crate) fn validate(
    raw: &[crate::check::Table<RawChannel>],
    axes: &[AxisConfig],
) -> Result<Vec<ChannelConfig>, Invalid> {
    if raw.is_empty() {
        return Ok(vec![whole_machine(axes)]);
    }
    let mut owner: [Option<usize>; MAX_AXES] = [None; MAX_AXES];
    let mut out = Vec::with_capacity(raw.len());
    for (k, c) in raw.iter().map(|t| &t.0).enumerate() {
        if k >= MAX_CHANNELS {
            return Err((
                c.axes.span(),
                format!("channel[{k}]"),
                format!("at most {MAX_CHANNELS} channels are supported"),
            ));
        }
        out.push(c.validate(k, axes, &mut owner, &out)?);
    }
    if let Some(i) = (0..axes.len().min(MAX_AXES)).find(|&i| owner[i].is_none()) {
        let last = &raw[raw.len() - 1].0;
        return Err((
            last.axes.span(),
            "channel".into(),
            format!(
                "axis {} is in no channel: with [[channel]] every axis belongs to exactly one",
                axes[i].name
            ),
        ));
    }
    Ok(out)
}

impl RawChannel {
    fn validate(
        &self,
        k: usize,
        axes: &[AxisConfig],
        owner: &mut [Option<usize>; MAX_AXES],
        earlier: &[ChannelConfig],
    ) -> Result<ChannelConfig, Invalid> {
        let key = |f: &str| format!("channel[{k}].{f}");
        let name = match &self.name {
            Some(n) if n.get_ref().trim().is_empty() => {
                return Err((n.span(), key("name"), "must not be empty".into()));
            }
            Some(n) if earlier.iter().any(|c| &c.name == n.get_ref()) => {
                return Err((
                    n.span(),
                    key("name"),
                    format!("{:?} names an earlier channel too", n.get_ref()),
                ));
            }
            Some(n) => n.get_ref().clone(),
            None => format!("ch{k}"),
        };
        if self.axes.get_ref().is_empty() {
            return Err((
                self.axes.span(),
                key("axes"),
                "a channel needs at least one axis".into(),
            ));
        }
        let mut mine = Vec::with_capacity(self.axes.get_ref().len());
        for a in self.axes.get_ref() {
            let i = axis_of(a, axes).ok_or_else(|| {
                let names: String = axes.iter().map(|a| a.name).collect();
                (
                    a.span(),
                    key("axes"),
                    format!("{:?} is not a configured axis (axes: {names})", a.get_ref()),
                )
            })?;
            if let Some(other) = owner[i] {
                let whom = if other == k {
                    "this channel already".to_string()
                } else {
                    format!("channel[{other}] already")
                };
                return Err((
                    a.span(),
                    key("axes"),
                    format!(
                        "axis {} is in {whom}: an axis belongs to one channel",
                        axes[i].name
                    ),
                ));
            }
            owner[i] = Some(k);
            mine.push(i);
        }
        Ok(ChannelConfig {
            name,
            axes: mine,
            mode: pick(
                &self.mode,
                &key("mode"),
                &[("auto", ChannelMode::Auto), ("manual", ChannelMode::Manual)],
            )?,
            on_error: pick(
                &self.on_error,
                &key("on_error"),
                &[("all", OnError::All), ("channel", OnError::Channel)],
            )?,
        })
    }
}

/// The axis named by `a` (one letter, either case).
fn axis_of(a: &Spanned<String>, axes: &[AxisConfig]) -> Option<usize> {
    let mut chars = a.get_ref().chars();
    let (Some(c), None) = (chars.next(), chars.next()) else {
        return None;
    };
    axes.iter().position(|x| x.name == c.to_ascii_uppercase())
}

/// One of `choices` by its name (the first when the key is absent).
fn pick<T: Copy>(
    v: &Option<Spanned<String>>,
    key: &str,
    choices: &[(&str, T)],
) -> Result<T, Invalid> {
    let Some(v) = v else {
        return Ok(choices[0].1);
    };
    match choices.iter().find(|(n, _)| *n == v.get_ref()) {
        Some((_, t)) => Ok(*t),
        None => {
            let names: Vec<String> = choices.iter().map(|(n, _)| format!("{n:?}")).collect();
            Err((
                v.span(),
                key.to_string(),
                format!("expected {}, got {:?}", names.join(" or "), v.get_ref()),
            ))
        }
    }
}

impl MachineConfig {
    /// The number of channels (1 without `[[channel]]`).
    pub fn channel_count(&self) -> usize {
        self.channels.len().max(1)
    }

    /// Channel `i` as a machine of its own (see [`ChannelView`]); `None` past the channels.
    /// A one-channel machine's channel 0 is the machine itself.
    pub fn channel(&self, i: usize) -> Option<ChannelView> {
        let whole;
        let c = match self.channels.get(i) {
            Some(c) => c,
            None if i == 0 && self.channels.is_empty() => {
                whole = whole_machine(&self.axes);
                &whole
            }
            None => return None,
        };
        let identity =
            c.axes.len() == self.axes.len() && c.axes.iter().enumerate().all(|(k, &a)| k == a);
        let config = if identity {
            MachineConfig {
                channels: vec![c.clone()],
                ..self.clone()
            }
        } else {
            self.restricted_to(c)
        };
        Some(ChannelView {
            index: i,
            name: c.name.clone(),
            config,
            axes: c.axes.clone(),
            mode: c.mode,
            on_error: c.on_error,
        })
    }

    /// The machine with only `c`'s axes.
    fn restricted_to(&self, c: &ChannelConfig) -> MachineConfig {
        let local = |machine: usize| c.axes.iter().position(|&a| a == machine);
        let mut work_offsets = [[0.0; MAX_AXES]; 6];
        for (w, m) in work_offsets.iter_mut().zip(&self.work_offsets) {
            for (k, &a) in c.axes.iter().enumerate() {
                w[k] = m[a];
            }
        }
        let bit = |b: Option<OutputBit>| {
            b.and_then(|b| local(b.axis).map(|axis| OutputBit { axis, bit: b.bit }))
        };
        let o = &self.machine.outputs;
        let mut cfg = MachineConfig {
            // A channel's spindles are its spindles 1 and 2 in config order, whatever their
            // machine numbers: S, M3 and P address the channel's own (as each Fanuc path
            // has its own spindle).
            axes: {
                let mut spindles = 0u8;
                c.axes
                    .iter()
                    .map(|&a| {
                        let axis = &self.axes[a];
                        let spindle = axis.spindle.map(|_| {
                            spindles += 1;
                            spindles
                        });
                        AxisConfig {
                            spindle,
                            ..axis.clone()
                        }
                    })
                    .collect()
            },
            work_offsets,
            channels: vec![ChannelConfig {
                axes: (0..c.axes.len()).collect(),
                ..c.clone()
            }],
            ..self.clone()
        };
        cfg.planner.match_axes = self
            .planner
            .match_axes
            .iter()
            .filter_map(|&a| local(a))
            .collect();
        cfg.machine.estop_input = self
            .machine
            .estop_input
            .and_then(|(a, b)| local(a).map(|a| (a, b)));
        cfg.machine.outputs = MachineOutputs {
            coolant_flood: bit(o.coolant_flood),
            coolant_mist: bit(o.coolant_mist),
            spindle_enable: bit(o.spindle_enable),
            tool_clamp: bit(o.tool_clamp),
        };
        cfg
    }
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use super::*;

    const SHIPPED: &str = include_str!("../machine.toml");
    const TWO: &str = include_str!("../../examples/axioma/two-channel.toml");

    fn parse(text: &str) -> Result<MachineConfig, crate::ConfigError> {
        MachineConfig::parse(text, Path::new("m.toml"))
    }

    fn with_channels(channels: &str) -> String {
        let base = TWO.split("[[channel]]").next().unwrap().to_string();
        format!("{base}{channels}")
    }

    #[test]
    fn no_channel_is_one_channel_with_every_axis_and_the_same_machine() {
        let c = parse(SHIPPED).unwrap();
        assert_eq!(c.channel_count(), 1);
        let v = c.channel(0).unwrap();
        assert_eq!(v.axes, vec![0, 1, 2, 3]);
        assert_eq!(v.config, c);
        assert_eq!((v.mode, v.on_error), (ChannelMode::Auto, OnError::All));
        assert!(c.channel(1).is_none());
    }

    #[test]
    fn the_two_channel_example_splits_the_axes() {
        let c = parse(TWO).unwrap();
        assert_eq!(c.channel_count(), 2);
        let v0 = c.channel(0).unwrap();
        let v1 = c.channel(1).unwrap();
        let names = |v: &ChannelView| v.config.axes.iter().map(|a| a.name).collect::<String>();
        assert_eq!(names(&v0), "XYZC");
        assert_eq!(names(&v1), "UVW");
        assert_eq!(
            v1.axes,
            vec![
                c.axis_index('U').unwrap(),
                c.axis_index('V').unwrap(),
                c.axis_index('W').unwrap()
            ]
        );
        assert_eq!(v1.config.spindle_index(), None);
        assert_eq!(v0.config.spindle_index(), Some(3));
        // Work offsets follow their axes.
        let u = c.axis_index('U').unwrap();
        assert_eq!(v1.config.work_offsets[1][0], c.work_offsets[1][u]);
        assert_eq!(v1.on_error, OnError::All);
    }

    /// Each Fanuc path has its own spindle: a channel that owns the machine's spindle 2
    /// addresses it as its spindle 1 (S, M3 and P in its programs).
    #[test]
    fn a_channel_owning_the_machines_second_spindle_sees_it_as_its_first() {
        let base = TWO.split("[[channel]]").next().unwrap();
        let second = "[[axis]]\nname = \"B\"\nkind = \"spindle\"\nnode = 8\n\
            counts_per_rev = 131072\nmax_velocity = 36000.0\nmax_acceleration = 36000.0\n\
            max_jerk = 720000.0\nmax_rpm = 6000.0\nfollowing_error_window = 90.0\n\
            following_error_timeout_ms = 10\n\
            [[channel]]\naxes = [\"X\",\"Y\",\"Z\",\"C\"]\n\
            [[channel]]\naxes = [\"U\",\"V\",\"W\",\"B\"]\n";
        let c = parse(&format!("{base}{second}")).unwrap();
        let b = c.axis_index('B').unwrap();
        assert_eq!(c.spindle_number(b), Some(2));
        let v1 = c.channel(1).unwrap();
        assert_eq!(v1.config.spindle_axis(1), Some(3));
        assert_eq!(v1.config.spindle_axis(2), None);
        assert_eq!(c.channel(0).unwrap().config.spindle_axis(1), Some(3));
    }

    #[test]
    fn channel_keys_are_checked_with_key_and_line() {
        let cases = [
            (
                "[[channel]]\naxes = []\n",
                "channel[0].axes",
                "at least one axis",
            ),
            (
                "[[channel]]\naxes = [\"X\",\"Y\",\"Z\",\"C\"]\n[[channel]]\naxes = [\"U\",\"V\",\"W\",\"X\"]\n",
                "channel[1].axes",
                "channel[0] already",
            ),
            (
                "[[channel]]\naxes = [\"X\",\"Y\",\"Z\",\"C\",\"U\",\"Q\"]\n",
                "channel[0].axes",
                "not a configured axis",
            ),
            (
                "[[channel]]\naxes = [\"X\",\"Y\",\"Z\",\"C\",\"U\",\"V\"]\n",
                "channel",
                "axis W is in no channel",
            ),
            (
                "[[channel]]\naxes = [\"X\",\"Y\",\"Z\",\"C\",\"U\",\"V\",\"W\"]\nmode = \"auto-ish\"\n",
                "channel[0].mode",
                "expected",
            ),
            (
                "[[channel]]\naxes = [\"X\",\"Y\",\"Z\",\"C\",\"U\",\"V\",\"W\"]\non_error = \"none\"\n",
                "channel[0].on_error",
                "expected",
            ),
            (
                "[[channel]]\naxes=[\"X\"]\n[[channel]]\naxes=[\"Y\"]\n[[channel]]\naxes=[\"Z\"]\n\
                 [[channel]]\naxes=[\"C\"]\n[[channel]]\naxes=[\"U\",\"V\",\"W\"]\n",
                "channel[4]",
                "at most 4 channels",
            ),
            (
                "[[channel]]\nname = \"a\"\naxes=[\"X\",\"Y\",\"Z\",\"C\"]\n[[channel]]\nname = \"a\"\naxes=[\"U\",\"V\",\"W\"]\n",
                "channel[1].name",
                "earlier channel",
            ),
        ];
        for (text, key, msg) in cases {
            let full = with_channels(text);
            let e = parse(&full).unwrap_err();
            assert_eq!(e.key, key, "{text}: {e}");
            assert!(e.message.contains(msg), "{text}: {e}");
            assert!(e.line > 0, "{text}: {e}");
        }
    }

    #[test]
    fn mode_and_on_error_are_read() {
        let full = with_channels(
            "[[channel]]\naxes = [\"X\",\"Y\",\"Z\",\"C\"]\non_error = \"channel\"\n\
             [[channel]]\naxes = [\"w\",\"u\",\"v\"]\nmode = \"manual\"\n",
        );
        let c = parse(&full).unwrap();
        let v1 = c.channel(1).unwrap();
        assert_eq!(v1.mode, ChannelMode::Manual);
        assert_eq!(c.channel(0).unwrap().on_error, OnError::Channel);
        let names: String = v1.config.axes.iter().map(|a| a.name).collect();
        assert_eq!(names, "WUV", "the channel's own axis order");
        assert_eq!(v1.name, "ch1");
    }
}
