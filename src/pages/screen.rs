//! The pages on a terminal (ratatui with its crossterm backend, as `drivectl monitor --tui`):
//! page tabs, the fields with their values, the help of the selected field, the key-in line,
//! the preview drawn on a canvas, and the soft-key labels. Keys are mapped to
//! [`state::Key`]s; everything they do is in the state model.

use cnc402_config::MachineConfig;
use cnc402_interp::NvTable;
use ratatui::Frame;
use ratatui::crossterm::event::{self, Event, KeyCode, KeyEvent, KeyEventKind, KeyModifiers};
use ratatui::layout::{Constraint, Layout, Rect};
use ratatui::style::{Color, Modifier, Style};
use ratatui::text::{Line, Span};
use ratatui::widgets::canvas::{Canvas, Circle, Line as CanvasLine};
use ratatui::widgets::{Block, Paragraph, Wrap};

use super::preview::{self, Preview};
use super::spec::fmt_num;
use super::state::{Key, Note, Outcome, PagesState, Store};
use crate::cli_error::CliError;

/// Shows the pages until the operator leaves (`Ok(false)`) or starts with every shown field
/// valid and a preview without alarm (`Ok(true)`). The terminal is restored either way.
pub fn run_screen(
    cfg: &MachineConfig,
    state: &mut PagesState,
    store: &mut dyn Store,
    file: &NvTable,
) -> Result<bool, CliError> {
    let ui = |e: std::io::Error| CliError::Io(format!("terminal: {e}"));
    let mut preview = preview::of_pages(cfg, state, file)?;
    let mut terminal = ratatui::try_init().map_err(ui)?;
    let result = (|| loop {
        terminal.draw(|f| render(f, state, &preview)).map_err(ui)?;
        let Event::Key(k) = event::read().map_err(ui)? else {
            continue;
        };
        let Some(key) = map_key(k) else { continue };
        match state.key(key, store) {
            Outcome::Stay => {}
            Outcome::Saved => {
                preview = preview::of_pages(cfg, state, file)?;
            }
            Outcome::Quit => return Ok(false),
            Outcome::Start => match &preview.alarm {
                None => return Ok(true),
                Some(a) => state.note = Note::Refused(format!("cannot start: {a}")),
            },
        }
    })();
    ratatui::restore();
    result
}

/// The terminal's key as a pages key: F1–F6 pages, F7 default, F8 start (or Alt+1…8 where
/// a terminal has no function keys), arrows, Enter = INPUT, Del = vacant, Esc, Ctrl-C.
fn map_key(k: KeyEvent) -> Option<Key> {
    if k.kind != KeyEventKind::Press {
        return None;
    }
    let soft = |n: u8| match n {
        1..=6 => Some(Key::Page(usize::from(n - 1))),
        7 => Some(Key::Default),
        8 => Some(Key::Start),
        _ => None,
    };
    Some(match k.code {
        KeyCode::F(n) => return soft(n),
        KeyCode::Char('c') if k.modifiers.contains(KeyModifiers::CONTROL) => Key::Quit,
        KeyCode::Char(c) if k.modifiers.contains(KeyModifiers::ALT) => {
            return c.to_digit(10).and_then(|d| soft(d as u8));
        }
        KeyCode::Char(c) => Key::Char(c),
        KeyCode::Up => Key::Up,
        KeyCode::Down | KeyCode::Tab => Key::Down,
        KeyCode::Left | KeyCode::PageUp => Key::Left,
        KeyCode::Right | KeyCode::PageDown => Key::Right,
        KeyCode::Enter => Key::Enter,
        KeyCode::Backspace => Key::Backspace,
        KeyCode::Delete => Key::Delete,
        KeyCode::Esc => Key::Escape,
        _ => return None,
    })
}

/// The soft-key labels, F1…F8.
pub fn soft_keys(state: &PagesState) -> Vec<(String, String)> {
    let mut keys: Vec<(String, String)> = state
        .spec
        .pages
        .iter()
        .enumerate()
        .map(|(i, p)| (format!("F{}", i + 1), p.title.clone()))
        .collect();
    keys.push(("F7".into(), "Default".into()));
    keys.push(("F8".into(), "Start".into()));
    keys.push(("Esc".into(), "Quit".into()));
    keys
}

fn render(f: &mut Frame, state: &PagesState, preview: &Preview) {
    let [title, tabs, body, help, input, keys] = Layout::vertical([
        Constraint::Length(1),
        Constraint::Length(1),
        Constraint::Min(6),
        Constraint::Length(4),
        Constraint::Length(1),
        Constraint::Length(1),
    ])
    .areas(f.area());
    let bold = Style::default().add_modifier(Modifier::BOLD);
    f.render_widget(
        Paragraph::new(Line::styled(state.spec.name.clone(), bold)),
        title,
    );
    f.render_widget(Paragraph::new(tab_line(state)), tabs);
    let [fields, pic] =
        Layout::horizontal([Constraint::Percentage(58), Constraint::Percentage(42)]).areas(body);
    render_fields(f, state, fields);
    render_preview(f, preview, pic);
    render_help(f, state, help);
    let note = match &state.note {
        Note::None => Span::raw(""),
        Note::Info(m) => Span::styled(m.clone(), Style::default().fg(Color::Green)),
        Note::Refused(m) => Span::styled(
            m.clone(),
            Style::default().fg(Color::Red).add_modifier(Modifier::BOLD),
        ),
    };
    let line = Line::from(vec![
        Span::styled(format!("INPUT> {}_ ", state.input), bold),
        note,
    ]);
    f.render_widget(Paragraph::new(line), input);
    let mut spans = Vec::new();
    for (k, label) in soft_keys(state) {
        spans.push(Span::styled(
            format!(" {k} "),
            Style::default().add_modifier(Modifier::REVERSED),
        ));
        spans.push(Span::raw(format!("{label} ")));
    }
    f.render_widget(Paragraph::new(Line::from(spans)), keys);
}

fn tab_line(state: &PagesState) -> Line<'static> {
    let spans = state.spec.pages.iter().enumerate().flat_map(|(i, p)| {
        let style = if i == state.page {
            Style::default().add_modifier(Modifier::REVERSED | Modifier::BOLD)
        } else {
            Style::default()
        };
        [
            Span::styled(format!(" {} ", p.title), style),
            Span::raw("│"),
        ]
    });
    Line::from(spans.collect::<Vec<_>>())
}

fn render_fields(f: &mut Frame, state: &PagesState, area: Rect) {
    let mut lines = Vec::new();
    for i in state.shown_on(state.page) {
        let field = &state.spec.fields[i];
        let value = match state.values[i] {
            Some(_) => format!("{} {}", field.show(state.values[i]), field.unit),
            None => match field.default {
                Some(d) => format!("— (default {})", field.show(Some(d))),
                None => "—".into(),
            },
        };
        let mark = if i == state.field { "▶" } else { " " };
        let mut style = Style::default();
        if i == state.field {
            style = style.add_modifier(Modifier::REVERSED);
        }
        let mut spans = vec![Span::styled(
            format!(
                "{mark} {:<30.30} #{:<4} {:<14}",
                field.label,
                field.var,
                value.trim_end()
            ),
            style,
        )];
        if let Some(why) = state.problem(i) {
            spans.push(Span::styled(
                format!(" ! {why}"),
                Style::default().fg(Color::Red),
            ));
        } else if let Some(l) = field.choice_label(state.values[i]) {
            spans.push(Span::styled(
                format!(" {l}"),
                Style::default().fg(Color::DarkGray),
            ));
        }
        lines.push(Line::from(spans));
    }
    let title = format!(" {} ", state.spec.pages[state.page].title);
    f.render_widget(
        Paragraph::new(lines).block(Block::bordered().title(title)),
        area,
    );
}

fn render_help(f: &mut Frame, state: &PagesState, area: Rect) {
    let field = state.current();
    let mut head = format!("{} (#{}, `{}`)", field.label, field.var, field.name);
    if !field.unit.is_empty() {
        head += &format!(" [{}]", field.unit);
    }
    head += &format!("  allowed: {}", field.allowed());
    if let Some(d) = field.default {
        head += &format!("  default: {}", field.show(Some(d)));
    }
    if field.required {
        head += "  required";
    }
    let text = vec![
        Line::styled(head, Style::default().add_modifier(Modifier::BOLD)),
        Line::raw(field.help.clone()),
    ];
    f.render_widget(
        Paragraph::new(text)
            .wrap(Wrap { trim: true })
            .block(Block::bordered().title(" help ")),
        area,
    );
}

fn render_preview(f: &mut Frame, p: &Preview, area: Rect) {
    let [pic, status] = Layout::vertical([Constraint::Min(3), Constraint::Length(2)]).areas(area);
    let (x0, x1, y0, y1) = preview::bounds(p);
    let r = (x1 - x0).max(y1 - y0) / 60.0;
    let title = match p.holes.first() {
        Some(h) => format!(" preview: {} holes, {} ", p.holes.len(), h.cycle),
        None => " preview: no holes ".into(),
    };
    let canvas = Canvas::default()
        .block(Block::bordered().title(title))
        .x_bounds([x0, x1])
        .y_bounds([y0, y1])
        .paint(|ctx| {
            ctx.draw(&CanvasLine {
                x1: x0,
                y1: 0.0,
                x2: x1,
                y2: 0.0,
                color: Color::DarkGray,
            });
            ctx.draw(&CanvasLine {
                x1: 0.0,
                y1: y0,
                x2: 0.0,
                y2: y1,
                color: Color::DarkGray,
            });
            for w in p.holes.windows(2) {
                ctx.draw(&CanvasLine {
                    x1: w[0].x,
                    y1: w[0].y,
                    x2: w[1].x,
                    y2: w[1].y,
                    color: Color::Blue,
                });
            }
            ctx.layer();
            for (i, h) in p.holes.iter().enumerate() {
                ctx.draw(&Circle {
                    x: h.x,
                    y: h.y,
                    radius: r,
                    color: Color::Yellow,
                });
                if p.holes.len() <= 40 {
                    ctx.print(h.x + r, h.y + r, format!("{}", i + 1));
                }
            }
        });
    f.render_widget(canvas, pic);
    let line = match (&p.alarm, p.holes.first()) {
        (Some(a), _) => Line::styled(format!("alarm: {a}"), Style::default().fg(Color::Red)),
        (None, Some(h)) => Line::raw(format!(
            "{} R {}  bottom {}  return {}",
            h.cycle,
            h.r.map_or("-".into(), fmt_num),
            fmt_num(h.bottom),
            h.ret.map_or("-".into(), fmt_num)
        )),
        (None, None) => Line::raw("the values make no holes"),
    };
    f.render_widget(Paragraph::new(line).wrap(Wrap { trim: true }), status);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pages::preview::Hole;
    use crate::pages::spec::Spec;
    use ratatui::backend::TestBackend;

    struct Nowhere;
    impl Store for Nowhere {
        fn save(&mut self, _: u32, _: Option<f64>) -> Result<(), String> {
            Ok(())
        }
    }

    fn screen_text(state: &PagesState, preview: &Preview) -> String {
        let mut t = ratatui::Terminal::new(TestBackend::new(150, 40)).unwrap();
        t.draw(|f| render(f, state, preview)).unwrap();
        let buf = t.backend().buffer();
        (0..buf.area.height)
            .map(|y| {
                (0..buf.area.width)
                    .map(|x| buf[(x, y)].symbol())
                    .collect::<String>()
                    + "\n"
            })
            .collect()
    }

    #[test]
    fn soft_keys_arrows_and_alt_digits_map_to_pages_keys() {
        let k = |code, m| map_key(KeyEvent::new(code, m));
        let none = KeyModifiers::NONE;
        assert_eq!(k(KeyCode::F(1), none), Some(Key::Page(0)));
        assert_eq!(k(KeyCode::F(6), none), Some(Key::Page(5)));
        assert_eq!(k(KeyCode::F(7), none), Some(Key::Default));
        assert_eq!(k(KeyCode::F(8), none), Some(Key::Start));
        assert_eq!(k(KeyCode::F(9), none), None);
        assert_eq!(k(KeyCode::Char('3'), KeyModifiers::ALT), Some(Key::Page(2)));
        assert_eq!(k(KeyCode::Char('8'), KeyModifiers::ALT), Some(Key::Start));
        assert_eq!(k(KeyCode::Char('3'), none), Some(Key::Char('3')));
        assert_eq!(
            k(KeyCode::Char('c'), KeyModifiers::CONTROL),
            Some(Key::Quit)
        );
        assert_eq!(k(KeyCode::Delete, none), Some(Key::Delete));
        assert_eq!(k(KeyCode::PageDown, none), Some(Key::Right));
    }

    /// Without a terminal (the tmux test needs tmux): the frame shows the soft keys, the
    /// page's fields with values and problems, the help, a refusal and the preview.
    #[test]
    fn the_frame_shows_fields_help_refusal_soft_keys_and_preview() {
        let p = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/mlt980/pages.toml");
        let mut s = PagesState::new(Spec::load(&p).unwrap(), |n| (n == 530).then_some(3.0));
        s.key(Key::Page(1), &mut Nowhere);
        for _ in 0..4 {
            s.key(Key::Down, &mut Nowhere);
        }
        s.key(Key::Char('0'), &mut Nowhere);
        s.key(Key::Enter, &mut Nowhere);
        let hole = |x, y| Hole {
            x,
            y,
            cycle: "G81".into(),
            r: Some(5.0),
            bottom: -15.0,
            ret: Some(50.0),
        };
        let preview = Preview {
            holes: vec![hole(30.0, 0.0), hole(-30.0, 0.0)],
            axes: ['X', 'Y'],
            alarm: None,
            truncated: false,
        };
        let text = screen_text(&s, &preview);
        for want in [
            " F1 Pattern  F2 Hole data  F3 Process  F4 Other  F7 Default  F8 Start  Esc Quit",
            "▶ Number of holes                #507",
            "Radius                         #504  —              ! a value is required",
            "Number of holes (#507, `holes`)  allowed: >= 1 and <= 999  required",
            "INPUT> _ Number of holes (#507): 0 is out of range: >= 1 and <= 999",
            "preview: 2 holes, G81",
            "G81 R 5  bottom -15  return 50",
        ] {
            assert!(text.contains(want), "{want:?} not on\n{text}");
        }
        let alarm = Preview {
            alarm: Some("O0001.CNC:76:1: alarm 501: x".into()),
            ..preview
        };
        assert!(screen_text(&s, &alarm).contains("alarm: O0001.CNC:76:1: alarm 501: x"));
    }
}
