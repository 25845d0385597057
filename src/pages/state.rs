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
