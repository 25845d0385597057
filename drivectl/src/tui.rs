//! `monitor --tui`: a full-screen view (ratatui) with one panel per drive — NMT state from
//! heartbeats, CiA 402 state and position from TPDO1, controlword and target from RPDO1, the
//! last EMCY — plus bus load, SYNC period statistics and a log of non-cyclic events. The
//! state ([`TuiState`]) is plain data fed with frames, so it is tested without a terminal.

use std::collections::{BTreeMap, VecDeque};

use cia402::{State, Statusword};
use cnc402_drives::Instant;
use cnc402_drives::wire::CanFrame;
use ratatui::Frame;
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::Line;
use ratatui::widgets::{Block, Paragraph};

use crate::decode::{Decoded, NodeNames, PdoMaps, decode};
use crate::dict::Dictionary;
use crate::period::PeriodStats;

/// What is known about one drive.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct DriveView {
    /// Node id.
    pub node: u8,
    /// Axis name from the config.
    pub axis: Option<String>,
    /// NMT state from the last heartbeat / boot-up.
    pub nmt: Option<String>,
    /// When the last heartbeat came.
    pub heartbeat_at: Option<Instant>,
    /// Statusword from TPDO1 (or an SDO read of 0x6041 seen on the bus).
    pub statusword: Option<u16>,
    /// Position actual from TPDO1.
    pub position: Option<i32>,
    /// Controlword from RPDO1.
    pub controlword: Option<u16>,
    /// Target position from RPDO1.
    pub target: Option<i32>,
    /// The last EMCY: code and text.
    pub last_emcy: Option<(u16, String)>,
    /// EMCY messages seen.
    pub emcys: u64,
    /// SDO aborts sent by this drive.
    pub sdo_aborts: u64,
    /// Frames from or to this node.
    pub frames: u64,
}

/// Everything the TUI shows.
#[derive(Clone, Debug)]
pub struct TuiState {
    /// Interface name.
    pub iface: String,
    /// Per node.
    pub drives: BTreeMap<u8, DriveView>,
    names: NodeNames,
    start: Instant,
    now: Instant,
    frames: u64,
    window_bits: u64,
    window_start: Instant,
    /// Bus load over the last tick window, percent.
    pub load_percent: f64,
    bitrate: u32,
    sync: PeriodStats,
    /// The latest events that are not cyclic (NMT, SDO, EMCY, boot-ups), newest last.
    pub events: VecDeque<String>,
}

impl TuiState {
    /// Events kept for the log panel.
    pub const EVENTS: usize = 200;

    /// A state with a panel for every configured drive.
    pub fn new(iface: &str, names: NodeNames, nodes: &[u8], bitrate: u32, start: Instant) -> Self {
        let drives = nodes
            .iter()
            .map(|&n| {
                (
                    n,
                    DriveView {
                        node: n,
                        axis: names.get(n).map(str::to_string),
                        ..DriveView::default()
                    },
                )
            })
            .collect();
        TuiState {
            iface: iface.to_string(),
            drives,
            names,
            start,
            now: start,
            frames: 0,
            window_bits: 0,
            window_start: start,
            load_percent: 0.0,
            bitrate: bitrate.max(1),
            sync: PeriodStats::default(),
            events: VecDeque::with_capacity(Self::EVENTS),
        }
    }

    fn drive(&mut self, n: u8) -> &mut DriveView {
        let axis = self.names.get(n).map(str::to_string);
        self.drives.entry(n).or_insert_with(|| DriveView {
            node: n,
            axis,
            ..DriveView::default()
        })
    }

    /// Takes in one frame received at `t`.
    pub fn on_frame(&mut self, t: Instant, f: &CanFrame, dict: &Dictionary, maps: &PdoMaps) {
        self.now = t;
        self.frames += 1;
        self.window_bits += f.bits() as u64;
        let d: Decoded = decode(f, dict, maps);
        if d.kind == "sync" {
            self.sync.on_sync(t);
            return;
        }
        if let Some(n) = d.node {
            let v = self.drive(n);
            v.frames += 1;
            match d.kind {
                "tpdo1" => {
                    v.statusword = d.fields["statusword"].as_u64().map(|x| x as u16);
                    // cnc402's TPDO1, or a mapping read from the drive (object names).
                    v.position = d.fields["position_actual"]
                        .as_i64()
                        .or_else(|| d.fields["position actual value"].as_i64())
                        .map(|x| x as i32);
                }
                "rpdo1" => {
                    v.controlword = d.fields["controlword"].as_u64().map(|x| x as u16);
                    v.target = d.fields["target_position"].as_i64().map(|x| x as i32);
                }
                "heartbeat" | "boot_up" => {
                    v.nmt = Some(
                        if d.kind == "boot_up" {
                            "PRE-OPERATIONAL (boot-up)"
                        } else {
                            d.fields["state"].as_str().unwrap_or("?")
                        }
                        .to_string(),
                    );
                    v.heartbeat_at = Some(t);
                }
                "emcy" => {
                    v.emcys += 1;
                    let code = d.fields["code"].as_u64().unwrap_or(0) as u16;
                    let text = d.fields["text"].as_str().unwrap_or("").to_string();
                    v.last_emcy = Some((code, text));
                }
                "sdo_resp" if d.text.starts_with("SDO abort") => v.sdo_aborts += 1,
                "sdo_resp" if d.text.starts_with("SDO read 0x6041:00") => {
                    // An expedited statusword read: "… data 3702" → 0x0237.
                    if let Some(h) = d.text.rsplit(' ').next()
                        && h.len() == 4
                        && let Ok(v16) = u16::from_str_radix(h, 16)
                    {
                        v.statusword = Some(v16.swap_bytes());
                    }
                }
                _ => {}
            }
        }
        if !matches!(d.kind, "tpdo1" | "rpdo1" | "heartbeat") {
            let rel = t.saturating_since(self.start).as_secs_f64();
            let who = d.node.map(|n| self.names.label(n)).unwrap_or_default();
            if self.events.len() == Self::EVENTS {
                self.events.pop_front();
            }
            self.events
                .push_back(format!("{rel:9.3}  {who:<12} {}", d.text));
        }
    }

    /// Closes a statistics window at `t` (bus load).
    pub fn on_tick(&mut self, t: Instant) {
        let span = t.saturating_since(self.window_start);
        if !span.is_zero() {
            self.load_percent =
                100.0 * self.window_bits as f64 / (self.bitrate as f64 * span.as_secs_f64());
        }
        self.window_bits = 0;
        self.window_start = t;
        self.now = self.now.max(t);
    }

    /// Draws the whole screen.
    pub fn render(&self, f: &mut Frame) {
        let area = f.area();
        let [head, grid, log] = Layout::vertical([
            Constraint::Length(1),
            Constraint::Min(8),
            Constraint::Length(9),
        ])
        .areas(area);
        let sync = match self.sync.summary() {
            Some((n, mean, p50, p99, max)) => {
                format!("SYNC mean {mean:.0} µs p50 {p50:.0} p99 {p99:.0} max {max:.0} (n={n})")
            }
            None => "no SYNC".to_string(),
        };
        f.render_widget(
            Paragraph::new(format!(
                " drivectl monitor {}  t {:.1} s  {} frames  load {:.1} %  {sync}  — q quits",
                self.iface,
                self.now.saturating_since(self.start).as_secs_f64(),
                self.frames,
                self.load_percent
            ))
            .style(Style::new().add_modifier(Modifier::REVERSED)),
            head,
        );
        self.render_drives(f, grid);
        let lines: Vec<Line> = self
            .events
            .iter()
            .rev()
            .take(log.height.saturating_sub(2) as usize)
            .rev()
            .map(|s| Line::from(s.as_str()))
            .collect();
        f.render_widget(
            Paragraph::new(lines).block(Block::bordered().title(" events ")),
            log,
        );
    }

    fn render_drives(&self, f: &mut Frame, area: Rect) {
        let n = self.drives.len().max(1);
        let cols = n.min(4);
        let rows = n.div_ceil(cols);
        let row_areas = Layout::vertical(vec![Constraint::Ratio(1, rows as u32); rows]).split(area);
        for (i, v) in self.drives.values().enumerate() {
            let (r, c) = (i / cols, i % cols);
            let Some(row) = row_areas.get(r) else { break };
            let cells =
                Layout::horizontal(vec![Constraint::Ratio(1, cols as u32); cols]).split(*row);
            let Some(cell) = cells.get(c) else { break };
            let sw = v.statusword.map(Statusword);
            let state = sw.and_then(|s| s.state());
            let colour = match state {
                Some(s) if s.is_fault() => Color::Red,
                Some(State::OperationEnabled) => Color::Green,
                Some(State::QuickStopActive) => Color::Yellow,
                _ => Color::Reset,
            };
            let age = v
                .heartbeat_at
                .map(|t| format!(" ({:.1} s ago)", self.now.saturating_since(t).as_secs_f64()))
                .unwrap_or_default();
            let lines = vec![
                Line::from(format!("NMT  {}{age}", v.nmt.as_deref().unwrap_or("—"))),
                Line::styled(
                    format!(
                        "402  {}",
                        match sw {
                            Some(s) => s.to_string(),
                            None => "— (no TPDO1 / 0x6041 seen)".into(),
                        }
                    ),
                    Style::new().fg(colour),
                ),
                Line::from(format!(
                    "pos  {}   target {}",
                    v.position.map(|p| p.to_string()).unwrap_or("—".into()),
                    v.target.map(|p| p.to_string()).unwrap_or("—".into())
                )),
                Line::from(format!(
                    "cw   {}",
                    v.controlword
                        .map(|c| format!("{c:#06x}"))
                        .unwrap_or("—".into())
                )),
                Line::styled(
                    format!(
                        "EMCY {}",
                        match &v.last_emcy {
                            Some((c, t)) => format!("{c:#06x} {t} ({} total)", v.emcys),
                            None => "none".into(),
                        }
                    ),
                    Style::new().fg(if v.last_emcy.is_some() {
                        Color::Red
                    } else {
                        Color::Reset
                    }),
                ),
                Line::from(format!("{} frames, {} SDO aborts", v.frames, v.sdo_aborts)),
            ];
            let title = format!(" {} ", self.names.label(v.node));
            f.render_widget(
                Paragraph::new(lines).block(Block::bordered().title(title)),
                *cell,
            );
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use ratatui::Terminal;
    use ratatui::backend::TestBackend;

    fn screen(s: &TuiState) -> String {
        let mut t = Terminal::new(TestBackend::new(140, 30)).unwrap();
        t.draw(|f| s.render(f)).unwrap();
        let buf = t.backend().buffer().clone();
        let mut out = String::new();
        for y in 0..buf.area.height {
            for x in 0..buf.area.width {
                out.push_str(buf[(x, y)].symbol());
            }
            out.push('\n');
        }
        out
    }

    #[test]
    fn panels_show_pdo_state_heartbeat_and_emcy() {
        let cfg = cnc402_config::MachineConfig::default_machine();
        let names = NodeNames::from_config(&cfg);
        let dict = Dictionary::new(None);
        let maps = PdoMaps::default();
        let mut s = TuiState::new("vcan0", names, &[1, 2], 1_000_000, Instant::ZERO);
        let t = |ms| Instant::from_millis(ms);
        s.on_frame(t(1), &CanFrame::new(0x702, &[0x05]).unwrap(), &dict, &maps);
        s.on_frame(t(2), &CanFrame::new(0x080, &[]).unwrap(), &dict, &maps);
        s.on_frame(
            t(3),
            &CanFrame::new(0x181, &[0x37, 0x12, 0x10, 0x27, 0, 0]).unwrap(),
            &dict,
            &maps,
        );
        s.on_frame(t(3), &CanFrame::new(0x080, &[]).unwrap(), &dict, &maps);
        s.on_frame(
            t(4),
            &CanFrame::new(0x082, &[0x10, 0x23, 0x03, 0, 0, 0, 0, 0]).unwrap(),
            &dict,
            &maps,
        );
        s.on_tick(t(10));
        assert_eq!(s.drives[&1].position, Some(10000));
        assert_eq!(s.drives[&2].emcys, 1);
        let text = screen(&s);
        assert!(text.contains("node 1 (X)"), "{text}");
        assert!(text.contains("0x1237 (OPERATION ENABLED)"), "{text}");
        assert!(text.contains("pos  10000"), "{text}");
        assert!(text.contains("NMT  OPERATIONAL"), "{text}");
        assert!(text.contains("EMCY 0x2310 current"), "{text}");
        assert!(text.contains("SYNC mean 1000 µs"), "{text}");
        assert!(
            text.contains("EMCY 0x2310 current (error register"),
            "event log: {text}"
        );
    }
}
