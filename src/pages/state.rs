//! The operator screen as plain data: which page and field is selected, the key-in buffer,
//! the values, what is shown, and what a key does (move, type, INPUT a value, refuse it with
//! the reason, start). No terminal and no file here: saving goes through [`Store`], so the
//! model is tested without either.

use super::spec::{Field, Spec};

/// Where an accepted value goes (the variables file; a table in tests). `Err` keeps the old
/// value on the screen and shows the reason.
pub trait Store {
    fn save(&mut self, var: u32, value: Option<f64>) -> Result<(), String>;
}

/// The keys the screen acts on (the terminal's keys mapped in `screen.rs`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Key {
    Up,
    Down,
    /// Previous / next page.
    Left,
    Right,
    /// Soft key: page `n` (0-based).
    Page(usize),
    /// A character for the key-in buffer.
    Char(char),
    Backspace,
    /// INPUT: the key-in buffer becomes the field's value.
    Enter,
    /// Make the field vacant.
    Delete,
    /// Soft key: put the field's default in.
    Default,
    /// Soft key: cycle start.
    Start,
    /// Cancel the key-in buffer, or leave when it is empty.
    Escape,
    Quit,
}

/// What the screen does after a key.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    Stay,
    /// A value was saved: the preview is out of date.
    Saved,
    Quit,
    /// Every shown field holds a valid value: run the package.
    Start,
}

/// The line under the fields: what the last key did.
#[derive(Clone, Debug, PartialEq)]
pub enum Note {
    None,
    Info(String),
    /// A value refused at the field, with the reason.
    Refused(String),
}

/// Longest key-in buffer (a number or a choice name).
pub const MAX_INPUT: usize = 32;

/// The pages, their values and the selection.
#[derive(Clone, Debug)]
pub struct PagesState {
    pub spec: Spec,
    /// Per field of `spec.fields`.
    pub values: Vec<Option<f64>>,
    pub page: usize,
    /// The selected field (an index into `spec.fields`), on `page`.
    pub field: usize,
    pub input: String,
    pub note: Note,
}

impl PagesState {
    /// The pages with the values of `var` (the variables file), first page, first field.
    pub fn new(spec: Spec, var: impl Fn(u32) -> Option<f64>) -> Self {
        let values = spec.fields.iter().map(|f| var(f.var)).collect();
        let mut s = PagesState {
            spec,
            values,
            page: 0,
            field: 0,
            input: String::new(),
            note: Note::None,
        };
        s.field = s.shown_on(0).first().copied().unwrap_or(0);
        s
    }

    /// Whether field `i` is shown with the current values (its `when` holds).
    pub fn shown(&self, i: usize) -> bool {
        self.spec.fields[i]
            .when
            .iter()
            .all(|c| self.values[c.field].is_some_and(|v| c.values.contains(&v)))
    }

    /// The shown fields of page `p`, in order.
    pub fn shown_on(&self, p: usize) -> Vec<usize> {
        self.spec.pages[p]
            .fields
            .iter()
            .copied()
            .filter(|&i| self.shown(i))
            .collect()
    }

    pub fn current(&self) -> &Field {
        &self.spec.fields[self.field]
    }

    /// Why the value of field `i` is not usable, if it is shown and is not.
    pub fn problem(&self, i: usize) -> Option<String> {
        if !self.shown(i) {
            return None;
        }
        self.spec.fields[i].check(self.values[i]).err()
    }

    /// The first shown field whose value is not usable, with the reason.
    pub fn first_problem(&self) -> Option<(usize, String)> {
        (0..self.spec.fields.len()).find_map(|i| self.problem(i).map(|p| (i, p)))
    }

    /// Acts on one key.
    pub fn key(&mut self, key: Key, store: &mut dyn Store) -> Outcome {
        match key {
            Key::Up => self.step(-1),
            Key::Down => self.step(1),
            Key::Left => {
                self.goto_page((self.page + self.spec.pages.len() - 1) % self.spec.pages.len())
            }
            Key::Right => self.goto_page((self.page + 1) % self.spec.pages.len()),
            Key::Page(p) if p < self.spec.pages.len() => self.goto_page(p),
            Key::Page(_) => {}
            Key::Char(c) if self.input.chars().count() < MAX_INPUT && !c.is_control() => {
                self.input.push(c);
                self.note = Note::None;
            }
            Key::Char(_) => {}
            Key::Backspace => {
                self.input.pop();
            }
            Key::Enter if self.input.is_empty() => {
                self.note = Note::Info("type a value, then Enter (Del makes it vacant)".into());
            }
            Key::Enter => {
                let text = std::mem::take(&mut self.input);
                return self.input_text(&text, store);
            }
            Key::Delete => return self.input_text("", store),
            Key::Default => match self.current().default {
                Some(d) => return self.set(self.field, Some(d), store),
                None => {
                    self.note = Note::Refused(format!("{} has no default", self.current().label))
                }
            },
            Key::Start => return self.start(),
            Key::Escape if !self.input.is_empty() => self.input.clear(),
            Key::Escape | Key::Quit => return Outcome::Quit,
        }
        Outcome::Stay
    }

    /// The key-in text as the selected field's value: refused with the reason, or saved.
    fn input_text(&mut self, text: &str, store: &mut dyn Store) -> Outcome {
        let f = self.current();
        match f.parse(text) {
            Ok(v) => self.set(self.field, v, store),
            Err(why) => {
                self.note = Note::Refused(format!("{} (#{}): {why}", f.label, f.var));
                Outcome::Stay
            }
        }
    }

    /// Saves a checked value of field `i`; on a store error the old value stays.
    fn set(&mut self, i: usize, v: Option<f64>, store: &mut dyn Store) -> Outcome {
        let f = &self.spec.fields[i];
        if let Err(why) = store.save(f.var, v) {
            self.note = Note::Refused(format!("#{} not saved: {why}", f.var));
            return Outcome::Stay;
        }
        let shown = if v.is_some() {
            f.show(v)
        } else {
            "vacant".into()
        };
        self.note = Note::Info(format!("saved #{} {} = {shown}", f.var, f.name));
        self.values[i] = v;
        // A choice may hide the selected field's neighbours, never the field itself (a
        // controlling field has no `when`); keep the selection on a shown field anyway.
        if !self.shown(self.field) {
            self.field = self
                .shown_on(self.page)
                .first()
                .copied()
                .unwrap_or(self.field);
        }
        Outcome::Saved
    }

    fn start(&mut self) -> Outcome {
        match self.first_problem() {
            None => Outcome::Start,
            Some((i, why)) => {
                let f = &self.spec.fields[i];
                self.note = Note::Refused(format!("cannot start: {} (#{}): {why}", f.label, f.var));
                self.page = f.page;
                self.field = i;
                Outcome::Stay
            }
        }
    }

    fn goto_page(&mut self, p: usize) {
        self.page = p;
        self.input.clear();
        self.field = self
            .shown_on(p)
            .first()
            .copied()
            .unwrap_or(self.spec.pages[p].fields[0]);
    }

    /// Moves the selection among the shown fields of the page (wrapping), dropping the
    /// key-in buffer.
    fn step(&mut self, by: isize) {
        let rows = self.shown_on(self.page);
        if rows.is_empty() {
            return;
        }
        self.input.clear();
        let at = rows.iter().position(|&i| i == self.field).unwrap_or(0) as isize;
        let n = rows.len() as isize;
        self.field = rows[((at + by) % n + n) as usize % rows.len()];
    }

    /// The values as the non-volatile table the package reads (fields only; other variables
    /// come from `base`).
    pub fn table(&self, mut base: cnc402_interp::NvTable) -> cnc402_interp::NvTable {
        for (f, v) in self.spec.fields.iter().zip(&self.values) {
            // Numbers come from a validated spec: always in #500..#999.
            let _ = base.set(f.var, *v);
        }
        base
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::collections::BTreeMap;
    use std::path::Path;

    /// A store in memory that can be told to fail.
    #[derive(Default)]
    struct Memory {
        saved: BTreeMap<u32, Option<f64>>,
        saves: usize,
        fail: bool,
    }

    impl Store for Memory {
        fn save(&mut self, var: u32, value: Option<f64>) -> Result<(), String> {
            if self.fail {
                return Err("disk full".into());
            }
            self.saves += 1;
            self.saved.insert(var, value);
            Ok(())
        }
    }

    fn mlt980() -> PagesState {
        let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/mlt980/pages.toml");
        PagesState::new(Spec::load(&p).unwrap(), |_| None)
    }

    fn names(s: &PagesState, ids: &[usize]) -> Vec<String> {
        ids.iter().map(|&i| s.spec.fields[i].name.clone()).collect()
    }

    fn type_in(s: &mut PagesState, m: &mut Memory, text: &str) -> Outcome {
        for c in text.chars() {
            s.key(Key::Char(c), m);
        }
        s.key(Key::Enter, m)
    }

    fn select(s: &mut PagesState, name: &str) {
        let i = s.spec.field_by_name(name).unwrap();
        s.key(Key::Page(s.spec.fields[i].page), &mut Memory::default());
        for _ in 0..MAX_INPUT {
            if s.field == i {
                return;
            }
            s.key(Key::Down, &mut Memory::default());
        }
        panic!("{name} is not shown");
    }

    #[test]
    fn arrows_move_among_shown_fields_and_wrap_soft_keys_pick_pages() {
        let mut s = mlt980();
        let mut m = Memory::default();
        assert_eq!(s.current().name, "pattern");
        s.key(Key::Down, &mut m);
        assert_eq!(s.current().name, "cycle");
        s.key(Key::Up, &mut m);
        s.key(Key::Up, &mut m);
        assert_eq!(
            s.current().name,
            "return",
            "up from the first wraps to the last"
        );
        s.key(Key::Page(1), &mut m);
        assert_eq!((s.page, s.current().name.as_str()), (1, "x"));
        s.key(Key::Right, &mut m);
        assert_eq!(s.page, 2);
        s.key(Key::Left, &mut m);
        s.key(Key::Left, &mut m);
        assert_eq!(s.page, 0);
        s.key(Key::Left, &mut m);
        assert_eq!(s.page, 3, "left from the first page wraps");
        s.key(Key::Page(5), &mut m);
        assert_eq!(s.page, 3, "a soft key without a page does nothing");
        assert_eq!(m.saves, 0);
    }

    #[test]
    fn the_pattern_shows_its_fields_and_hides_the_others() {
        let mut s = mlt980();
        let mut m = Memory::default();
        // No pattern yet: only the fields every pattern has.
        assert_eq!(names(&s, &s.shown_on(1)), ["x", "y", "r", "z"]);
        assert_eq!(type_in(&mut s, &mut m, "circle"), Outcome::Saved);
        assert_eq!(m.saved[&530], Some(3.0));
        assert_eq!(
            names(&s, &s.shown_on(1)),
            ["x", "y", "radius", "start-angle", "holes", "r", "z"]
        );
        type_in(&mut s, &mut m, "arc");
        assert!(names(&s, &s.shown_on(1)).contains(&"angle-step".to_string()));
        type_in(&mut s, &mut m, "5");
        assert_eq!(
            names(&s, &s.shown_on(1)),
            [
                "x",
                "y",
                "count",
                "rows",
                "x-step",
                "y-step",
                "row-shift",
                "r",
                "z"
            ]
        );
        // The cycle picks the process fields.
        s.key(Key::Down, &mut m);
        type_in(&mut s, &mut m, "84");
        assert_eq!(
            names(&s, &s.shown_on(2)),
            ["spindle", "speed", "tap-feed", "peck"]
        );
        type_in(&mut s, &mut m, "g82");
        assert_eq!(
            names(&s, &s.shown_on(2)),
            ["spindle", "speed", "feed", "dwell"]
        );
    }

    #[test]
    fn a_bad_value_is_refused_at_the_field_with_the_reason_and_nothing_is_saved() {
        let mut s = mlt980();
        let mut m = Memory::default();
        type_in(&mut s, &mut m, "circle");
        select(&mut s, "holes");
        let before = m.saves;
        for (text, why) in [
            ("0", "0 is out of range: >= 1 and <= 999"),
            ("2.5", "2.5 is not a whole number"),
            ("six", "\"six\" is not a whole number"),
            ("", "a value is required"),
        ] {
            let out = if text.is_empty() {
                s.key(Key::Delete, &mut m)
            } else {
                type_in(&mut s, &mut m, text)
            };
            assert_eq!(out, Outcome::Stay, "{text}");
            assert_eq!(
                s.note,
                Note::Refused(format!("Number of holes (#507): {why}")),
                "{text}"
            );
        }
        assert_eq!((m.saves, s.values[s.field]), (before, None));
        assert_eq!(type_in(&mut s, &mut m, "6"), Outcome::Saved);
        assert_eq!(m.saved[&507], Some(6.0));
        select(&mut s, "radius");
        type_in(&mut s, &mut m, "0");
        assert!(
            matches!(&s.note, Note::Refused(r) if r.contains("> 0")),
            "{:?}",
            s.note
        );
        select(&mut s, "pattern");
        type_in(&mut s, &mut m, "7");
        assert!(
            matches!(&s.note, Note::Refused(r) if r.contains("7 is not one of linear (1)")),
            "{:?}",
            s.note
        );
    }

    #[test]
    fn an_optional_field_goes_vacant_with_delete_and_default_puts_the_default() {
        let mut s = mlt980();
        let mut m = Memory::default();
        select(&mut s, "tool");
        assert_eq!(type_in(&mut s, &mut m, "12"), Outcome::Saved);
        assert_eq!(s.key(Key::Delete, &mut m), Outcome::Saved);
        assert_eq!(m.saved[&527], None);
        assert_eq!(s.key(Key::Default, &mut m), Outcome::Stay, "no default");
        select(&mut s, "cycle");
        assert_eq!(s.key(Key::Default, &mut m), Outcome::Saved);
        assert_eq!(m.saved[&519], Some(81.0));
    }

    #[test]
    fn key_in_buffer_edits_escapes_and_is_bounded() {
        let mut s = mlt980();
        let mut m = Memory::default();
        for _ in 0..100 {
            s.key(Key::Char('9'), &mut m);
        }
        assert_eq!(s.input.len(), MAX_INPUT);
        s.key(Key::Backspace, &mut m);
        assert_eq!(s.input.len(), MAX_INPUT - 1);
        assert_eq!(s.key(Key::Escape, &mut m), Outcome::Stay);
        assert!(s.input.is_empty());
        assert_eq!(s.key(Key::Escape, &mut m), Outcome::Quit);
        assert_eq!(s.key(Key::Quit, &mut m), Outcome::Quit);
    }

    #[test]
    fn a_failed_save_keeps_the_old_value_and_says_why() {
        let mut s = mlt980();
        let mut m = Memory {
            fail: true,
            ..Memory::default()
        };
        assert_eq!(type_in(&mut s, &mut m, "grid"), Outcome::Stay);
        assert_eq!(s.values[s.field], None);
        assert_eq!(s.note, Note::Refused("#530 not saved: disk full".into()));
    }

    #[test]
    fn start_needs_every_shown_field_and_goes_to_the_first_missing_one() {
        let mut s = mlt980();
        let mut m = Memory::default();
        let fill = [
            ("pattern", "linear"),
            ("cycle", "81"),
            ("return", "99"),
            ("x", "10"),
            ("y", "20"),
            ("count", "4"),
            ("x-step", "15"),
            ("y-step", "5"),
            ("r", "-45"),
            ("spindle", "cw"),
            ("speed", "800"),
            ("feed", "150"),
            ("initial-z", "50"),
        ];
        for (name, v) in fill {
            select(&mut s, name);
            assert_eq!(type_in(&mut s, &mut m, v), Outcome::Saved, "{name}");
        }
        assert_eq!(s.key(Key::Start, &mut m), Outcome::Stay);
        assert_eq!((s.page, s.current().name.as_str()), (1, "z"));
        assert!(matches!(&s.note, Note::Refused(r) if r.starts_with("cannot start: Depth Z")));
        type_in(&mut s, &mut m, "-20");
        assert_eq!(s.key(Key::Start, &mut m), Outcome::Start);
        // A hidden field's value does not matter: a grid needs rows.
        select(&mut s, "pattern");
        type_in(&mut s, &mut m, "grid");
        assert_eq!(s.key(Key::Start, &mut m), Outcome::Stay);
        assert_eq!(s.current().name, "rows");
        let t = s.table(cnc402_interp::NvTable::default());
        assert_eq!(
            (t.get(530), t.get(502), t.get(508)),
            (Some(4.0), Some(-20.0), None)
        );
    }

    #[test]
    fn values_from_the_file_that_the_pages_refuse_are_marked() {
        let p = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/mlt980/pages.toml");
        let s = PagesState::new(Spec::load(&p).unwrap(), |n| (n == 524).then_some(97.0));
        let i = s.spec.field_by_name("return").unwrap();
        assert_eq!(
            s.problem(i).as_deref(),
            Some("97 is not one of initial (98), r-plane (99)")
        );
    }
}
