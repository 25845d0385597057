//! The page description of a macro package (`pages.toml`, format in docs/pages.md): pages of
//! fields, each naming a non-volatile variable with its label, unit, type, allowed values,
//! default, help and the choices of other fields that show it. Loaded and validated whole;
//! every error names the file, line, column and key.

use std::collections::BTreeMap;
use std::ops::Range;
use std::path::{Path, PathBuf};

use cnc402_config::ConfigError;
use cnc402_interp::nvfile::{NV_FIRST, NV_LAST};
use serde::Deserialize;
use toml::Spanned;

/// At most this many pages: one soft key each (F1–F6; F7 and F8 are the field's default and
/// start).
pub const MAX_PAGES: usize = 6;
/// At most this many fields on one page (what a screen can list).
pub const MAX_FIELDS_PER_PAGE: usize = 40;
/// At most this many choices in a choice field.
pub const MAX_CHOICES: usize = 64;

/// A validated page description.
#[derive(Clone, Debug, PartialEq)]
pub struct Spec {
    /// The file it was read from.
    pub path: PathBuf,
    /// The package's name (title of the screen).
    pub name: String,
    /// The package's main program (resolved against the pages file's folder).
    pub main: PathBuf,
    pub pages: Vec<Page>,
    /// Every field of every page, in page order.
    pub fields: Vec<Field>,
    /// What the package's alarms mean, in the operator's words (`alarm 501` → text), shown
    /// after the package's own alarm text.
    pub alarms: BTreeMap<u32, String>,
}

/// One page: a title and its fields (indices into [`Spec::fields`]).
#[derive(Clone, Debug, PartialEq)]
pub struct Page {
    pub title: String,
    pub fields: Vec<usize>,
}

/// One field: a non-volatile variable as the operator sees it.
#[derive(Clone, Debug, PartialEq)]
pub struct Field {
    pub var: u32,
    /// The name scripts use (`--set pattern=circle`).
    pub name: String,
    pub label: String,
    pub unit: String,
    pub kind: Kind,
    pub default: Option<f64>,
    /// A vacant value is refused while the field is shown.
    pub required: bool,
    pub help: String,
    /// Shown only when each of these choice fields holds one of the listed values.
    pub when: Vec<Condition>,
    /// The page the field is on.
    pub page: usize,
}

/// `when`: the field `field` (an index) holds one of `values`.
#[derive(Clone, Debug, PartialEq)]
pub struct Condition {
    pub field: usize,
    pub values: Vec<f64>,
}

/// What values a field takes.
#[derive(Clone, Debug, PartialEq)]
pub enum Kind {
    Number(Limits),
    Integer(Limits),
    Choice(Vec<Choice>),
}

/// Bounds of a number: `min <= v <= max`, `above < v < below` (each optional).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Limits {
    pub min: Option<f64>,
    pub max: Option<f64>,
    pub above: Option<f64>,
    pub below: Option<f64>,
}

/// One value of a choice field.
#[derive(Clone, Debug, PartialEq)]
pub struct Choice {
    pub value: f64,
    pub name: String,
    pub label: String,
}

/// A pages file that cannot be used: `file:line:col: key: message`, the error type of the
/// machine config (exit 3, a caret under the offending text).
pub type SpecError = ConfigError;

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawFile {
    package: RawPackage,
    page: Vec<RawPage>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPackage {
    name: String,
    main: Spanned<String>,
    #[serde(default)]
    alarms: BTreeMap<Spanned<String>, String>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawPage {
    title: Spanned<String>,
    field: Vec<RawField>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawField {
    var: Spanned<i64>,
    name: Spanned<String>,
    label: String,
    #[serde(default)]
    unit: String,
    #[serde(rename = "type")]
    kind: Spanned<String>,
    min: Option<Spanned<f64>>,
    max: Option<Spanned<f64>>,
    above: Option<Spanned<f64>>,
    below: Option<Spanned<f64>>,
    choices: Option<Spanned<Vec<RawChoice>>>,
    default: Option<Spanned<f64>>,
    #[serde(default)]
    required: bool,
    #[serde(default)]
    help: String,
    when: Option<Spanned<BTreeMap<String, Vec<String>>>>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct RawChoice {
    value: f64,
    name: String,
    #[serde(default)]
    label: String,
}

/// An error at a span with its key path (`page[1].field[3].var`).
type At = (Option<Range<usize>>, String, String);

fn at<T>(s: &Spanned<T>, key: String, message: String) -> At {
    (Some(s.span()), key, message)
}

impl Spec {
    /// Reads and validates `path`.
    pub fn load(path: &Path) -> Result<Spec, SpecError> {
        let text = std::fs::read_to_string(path).map_err(|e| {
            ConfigError::at("", path, None, String::new(), format!("cannot read: {e}"))
        })?;
        Spec::parse(&text, path)
    }

    /// Parses and validates pages text read from `path` (used in messages and to find the
    /// main program). The main program must exist.
    pub fn parse(text: &str, path: &Path) -> Result<Spec, SpecError> {
        let err = |(span, key, message): At| ConfigError::at(text, path, span, key, message);
        let de = toml::Deserializer::parse(text)
            .map_err(|e| err((e.span(), String::new(), e.message().to_string())))?;
        let raw: RawFile = serde_path_to_error::deserialize(de).map_err(|e| {
            let key = e
                .path()
                .to_string()
                .replace(".$__serde_spanned_private_value", "");
            let inner = e.into_inner();
            let key = if key == "." { String::new() } else { key };
            err((inner.span(), key, inner.message().to_string()))
        })?;
        let folder = path.parent().unwrap_or(Path::new(""));
        validate(raw, folder).map_err(err).map(|mut s| {
            s.path = path.to_path_buf();
            s
        })
    }

    /// `alarm` (`…: alarm 501: <the package's text>`) with the pages' words for that alarm
    /// number appended, if they have some.
    pub fn explain(&self, alarm: &str) -> String {
        let number = alarm.split("alarm ").skip(1).find_map(|rest| {
            let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
            digits.parse::<u32>().ok()
        });
        match number.and_then(|n| self.alarms.get(&n)) {
            Some(words) => format!("{alarm} — {words}"),
            None => alarm.to_string(),
        }
    }

    /// The field named `name`, or whose variable is `name` (`530`, `#530`).
    pub fn field_by_name(&self, name: &str) -> Option<usize> {
        let name = name.trim();
        if let Some(i) = self.fields.iter().position(|f| f.name == name) {
            return Some(i);
        }
        let n: u32 = name.strip_prefix('#').unwrap_or(name).parse().ok()?;
        self.fields.iter().position(|f| f.var == n)
    }
}

fn validate(raw: RawFile, folder: &Path) -> Result<Spec, At> {
    let main = folder.join(raw.package.main.get_ref());
    if !main.is_file() {
        return Err(at(
            &raw.package.main,
            "package.main".into(),
            format!("no such file: {}", main.display()),
        ));
    }
    let mut alarms = BTreeMap::new();
    for (k, text) in &raw.package.alarms {
        let n: u32 = k.get_ref().parse().map_err(|_| {
            at(
                k,
                format!("package.alarms.{}", k.get_ref()),
                "expected an alarm number".into(),
            )
        })?;
        alarms.insert(n, text.clone());
    }
    if raw.page.is_empty() || raw.page.len() > MAX_PAGES {
        return Err((
            None,
            "page".into(),
            format!(
                "expected 1 to {MAX_PAGES} pages (one soft key each), found {}",
                raw.page.len()
            ),
        ));
    }
    let mut pages = Vec::new();
    let mut fields: Vec<Field> = Vec::new();
    let mut whens = Vec::new();
    for (p, page) in raw.page.into_iter().enumerate() {
        let key = format!("page[{p}]");
        if page.field.is_empty() || page.field.len() > MAX_FIELDS_PER_PAGE {
            return Err(at(
                &page.title,
                format!("{key}.field"),
                format!(
                    "expected 1 to {MAX_FIELDS_PER_PAGE} fields, found {}",
                    page.field.len()
                ),
            ));
        }
        let mut on_page = Vec::new();
        for (i, f) in page.field.into_iter().enumerate() {
            let key = format!("{key}.field[{i}]");
            let field = field(&f, &key, p)?;
            if let Some(other) = fields.iter().find(|o| o.var == field.var) {
                return Err(at(
                    &f.var,
                    format!("{key}.var"),
                    format!("#{} is already field `{}`", field.var, other.name),
                ));
            }
            if fields.iter().any(|o| o.name == field.name) {
                return Err(at(
                    &f.name,
                    format!("{key}.name"),
                    format!("`{}` names another field already", field.name),
                ));
            }
            on_page.push(fields.len());
            fields.push(field);
            whens.push((key, f.when));
        }
        pages.push(Page {
            title: page.title.into_inner(),
            fields: on_page,
        });
    }
    let has_when: Vec<bool> = whens.iter().map(|(_, w)| w.is_some()).collect();
    for (i, (key, when)) in whens.into_iter().enumerate() {
        if let Some(w) = when {
            fields[i].when = conditions(&fields, &has_when, i, &w, &format!("{key}.when"))?;
        }
    }
    Ok(Spec {
        path: PathBuf::new(),
        name: raw.package.name,
        main,
        pages,
        fields,
        alarms,
    })
}

/// One field, checked on its own (what no other field decides).
fn field(f: &RawField, key: &str, page: usize) -> Result<Field, At> {
    let var = *f.var.get_ref();
    if !(i64::from(NV_FIRST)..=i64::from(NV_LAST)).contains(&var) {
        return Err(at(
            &f.var,
            format!("{key}.var"),
            format!("#{var} is not a non-volatile variable (#{NV_FIRST}..#{NV_LAST})"),
        ));
    }
    let name = f.name.get_ref();
    if !valid_name(name) {
        return Err(at(
            &f.name,
            format!("{key}.name"),
            format!(
                "{name:?}: expected lower-case letters, digits, `_` or `-`, starting with a letter"
            ),
        ));
    }
    let bounds = [
        ("min", &f.min),
        ("max", &f.max),
        ("above", &f.above),
        ("below", &f.below),
    ];
    let kind = match f.kind.get_ref().as_str() {
        "number" | "integer" => {
            if let Some(c) = &f.choices {
                return Err(at(
                    c,
                    format!("{key}.choices"),
                    "only a choice field has choices".into(),
                ));
            }
            let l = limits(&bounds, key)?;
            if f.kind.get_ref() == "number" {
                Kind::Number(l)
            } else {
                Kind::Integer(l)
            }
        }
        "choice" => {
            if let Some((b, Some(s))) = bounds.iter().find(|(_, s)| s.is_some()) {
                return Err(at(
                    s,
                    format!("{key}.{b}"),
                    "a choice field has choices, not bounds".into(),
                ));
            }
            Kind::Choice(choices(f, key)?)
        }
        other => {
            return Err(at(
                &f.kind,
                format!("{key}.type"),
                format!("{other:?}: expected \"number\", \"integer\" or \"choice\""),
            ));
        }
    };
    let mut field = Field {
        var: var as u32,
        name: name.clone(),
        label: f.label.clone(),
        unit: f.unit.clone(),
        kind,
        default: None,
        required: f.required,
        help: f.help.clone(),
        when: Vec::new(),
        page,
    };
    if let Some(d) = &f.default {
        field
            .check(Some(*d.get_ref()))
            .map_err(|why| at(d, format!("{key}.default"), why))?;
        field.default = Some(*d.get_ref());
    }
    Ok(field)
}

fn valid_name(name: &str) -> bool {
    name.len() <= 32
        && name.starts_with(|c: char| c.is_ascii_lowercase())
        && name
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_' || c == '-')
}

fn limits(bounds: &[(&str, &Option<Spanned<f64>>); 4], key: &str) -> Result<Limits, At> {
    for (b, s) in bounds {
        if let Some(s) = s
            && !s.get_ref().is_finite()
        {
            return Err(at(
                s,
                format!("{key}.{b}"),
                "must be a finite number".into(),
            ));
        }
    }
    let get = |i: usize| bounds[i].1.as_ref().map(|s| *s.get_ref());
    let l = Limits {
        min: get(0),
        max: get(1),
        above: get(2),
        below: get(3),
    };
    let low = [(0, l.min), (2, l.above)];
    let high = [(1, l.max), (3, l.below)];
    for (li, lo) in low {
        for (hi, h) in high {
            if let (Some(lo), Some(h)) = (lo, h)
                && lo >= h
                && !(li == 0 && hi == 1 && lo == h)
            {
                let s = bounds[hi].1.as_ref().map_or(0..0, |s| s.span());
                return Err((
                    Some(s),
                    format!("{key}.{}", bounds[hi].0),
                    format!(
                        "leaves no value: {} = {lo}, {} = {h}",
                        bounds[li].0, bounds[hi].0
                    ),
                ));
            }
        }
    }
    Ok(l)
}

fn choices(f: &RawField, key: &str) -> Result<Vec<Choice>, At> {
    let key = format!("{key}.choices");
    let Some(raw) = &f.choices else {
        return Err(at(&f.kind, key, "a choice field needs `choices`".into()));
    };
    let list = raw.get_ref();
    if list.is_empty() || list.len() > MAX_CHOICES {
        return Err(at(raw, key, format!("expected 1 to {MAX_CHOICES} choices")));
    }
    let mut out: Vec<Choice> = Vec::new();
    for (i, c) in list.iter().enumerate() {
        let bad = |m: String| at(raw, format!("{key}[{i}]"), m);
        if !c.value.is_finite() {
            return Err(bad("value must be a finite number".into()));
        }
        if !valid_name(&c.name) {
            return Err(bad(format!(
                "name {:?}: expected lower-case letters, digits, `_` or `-`, starting with a letter",
                c.name
            )));
        }
        if out.iter().any(|o| o.value == c.value || o.name == c.name) {
            return Err(bad(format!(
                "value {} or name {:?} is given twice",
                c.value, c.name
            )));
        }
        out.push(Choice {
            value: c.value,
            name: c.name.clone(),
            label: if c.label.is_empty() {
                c.name.clone()
            } else {
                c.label.clone()
            },
        });
    }
    Ok(out)
}

/// `when = { pattern = ["arc", "circle"] }`: each key a choice field without a `when` of its
/// own (one level: what shows a field never hides behind another field), each value one of
/// its choices.
fn conditions(
    fields: &[Field],
    has_when: &[bool],
    me: usize,
    when: &Spanned<BTreeMap<String, Vec<String>>>,
    key: &str,
) -> Result<Vec<Condition>, At> {
    let mut out = Vec::new();
    for (name, values) in when.get_ref() {
        let bad = |m: String| at(when, format!("{key}.{name}"), m);
        let Some(i) = fields.iter().position(|f| &f.name == name) else {
            return Err(bad(format!("no field is named `{name}`")));
        };
        let Kind::Choice(choices) = &fields[i].kind else {
            return Err(bad(format!("`{name}` is not a choice field")));
        };
        if i == me || has_when[i] {
            return Err(bad(format!(
                "`{name}` is this field or is itself shown by a `when`"
            )));
        }
        if values.is_empty() {
            return Err(bad("expected at least one choice".into()));
        }
        let mut vals = Vec::new();
        for v in values {
            let Some(c) = choices.iter().find(|c| &c.name == v) else {
                let names: Vec<&str> = choices.iter().map(|c| c.name.as_str()).collect();
                return Err(bad(format!(
                    "{v:?} is not one of its choices ({})",
                    names.join(", ")
                )));
            };
            vals.push(c.value);
        }
        out.push(Condition {
            field: i,
            values: vals,
        });
    }
    Ok(out)
}

impl Field {
    /// Checks a value for this field (`None`: vacant). The error is the reason, for the
    /// operator.
    pub fn check(&self, v: Option<f64>) -> Result<(), String> {
        let Some(v) = v else {
            return if self.required {
                Err("a value is required".into())
            } else {
                Ok(())
            };
        };
        if !v.is_finite() {
            return Err("not a finite number".into());
        }
        match &self.kind {
            Kind::Number(l) => l.check(v),
            Kind::Integer(l) => {
                if v.fract() != 0.0 {
                    return Err(format!("{v} is not a whole number"));
                }
                l.check(v)
            }
            Kind::Choice(cs) => {
                if cs.iter().any(|c| c.value == v) {
                    Ok(())
                } else {
                    Err(format!("{} is not one of {}", fmt_num(v), self.allowed()))
                }
            }
        }
    }

    /// Reads what the operator typed: a number, a choice's name or number, or nothing
    /// (vacant), and checks it.
    pub fn parse(&self, text: &str) -> Result<Option<f64>, String> {
        let t = text.trim();
        let v = if t.is_empty() {
            None
        } else if let Kind::Choice(cs) = &self.kind
            && let Some(c) = cs.iter().find(|c| c.name.eq_ignore_ascii_case(t))
        {
            Some(c.value)
        } else {
            match t.parse::<f64>() {
                Ok(v) if v.is_finite() => Some(v),
                _ => return Err(format!("{t:?} is not {}", self.expects())),
            }
        };
        self.check(v)?;
        Ok(v)
    }

    /// What the field takes, in words: `a number (mm)`, `a whole number`, `a choice`.
    fn expects(&self) -> String {
        match &self.kind {
            Kind::Number(_) => "a number".into(),
            Kind::Integer(_) => "a whole number".into(),
            Kind::Choice(_) => format!("one of {}", self.allowed()),
        }
    }

    /// The allowed values, for the help line: `1 .. 999`, `> 0`, `linear (1), arc (2)`.
    pub fn allowed(&self) -> String {
        match &self.kind {
            Kind::Number(l) | Kind::Integer(l) => l.describe(),
            Kind::Choice(cs) => cs
                .iter()
                .map(|c| format!("{} ({})", c.name, fmt_num(c.value)))
                .collect::<Vec<_>>()
                .join(", "),
        }
    }

    /// A value as the page shows it: a choice's name, or the number.
    pub fn show(&self, v: Option<f64>) -> String {
        let Some(v) = v else { return String::new() };
        if let Kind::Choice(cs) = &self.kind
            && let Some(c) = cs.iter().find(|c| c.value == v)
        {
            return c.name.clone();
        }
        fmt_num(v)
    }

    /// The label of the chosen value (`circle (ring) holes`), if a choice field holds one.
    pub fn choice_label(&self, v: Option<f64>) -> Option<&str> {
        let Kind::Choice(cs) = &self.kind else {
            return None;
        };
        cs.iter()
            .find(|c| Some(c.value) == v)
            .map(|c| c.label.as_str())
    }
}

impl Limits {
    fn check(&self, v: f64) -> Result<(), String> {
        let ok = self.min.is_none_or(|m| v >= m)
            && self.max.is_none_or(|m| v <= m)
            && self.above.is_none_or(|m| v > m)
            && self.below.is_none_or(|m| v < m);
        if ok {
            Ok(())
        } else {
            Err(format!(
                "{} is out of range: {}",
                fmt_num(v),
                self.describe()
            ))
        }
    }

    fn describe(&self) -> String {
        let mut parts = Vec::new();
        if let Some(m) = self.min {
            parts.push(format!(">= {}", fmt_num(m)));
        }
        if let Some(m) = self.above {
            parts.push(format!("> {}", fmt_num(m)));
        }
        if let Some(m) = self.max {
            parts.push(format!("<= {}", fmt_num(m)));
        }
        if let Some(m) = self.below {
            parts.push(format!("< {}", fmt_num(m)));
        }
        if parts.is_empty() {
            "any number".into()
        } else {
            parts.join(" and ")
        }
    }
}

/// A number as an operator writes it: `3`, `-45`, `12.5` (shortest text that reads back).
pub fn fmt_num(v: f64) -> String {
    if v.fract() == 0.0 && v.abs() < 1e15 {
        format!("{}", v as i64)
    } else {
        format!("{v}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A folder with an empty main program for pages texts to name.
    fn folder(tag: &str) -> PathBuf {
        let d =
            std::env::temp_dir().join(format!("cnc402-pages-spec-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(d.join("O0001.nc"), "M30\n").unwrap();
        d
    }

    const HEAD: &str = "[package]\nname = \"t\"\nmain = \"O0001.nc\"\n\n[[page]]\ntitle = \"P\"\n";

    fn field(var: &str, name: &str, extra: &str) -> String {
        format!(
            "\n[[page.field]]\nvar = {var}\nname = \"{name}\"\nlabel = \"L\"\ntype = \"number\"\n{extra}"
        )
    }

    fn parse(tag: &str, text: &str) -> Result<Spec, SpecError> {
        let d = folder(tag);
        let p = d.join("pages.toml");
        let r = Spec::parse(text, &p);
        std::fs::remove_dir_all(&d).unwrap();
        r
    }

    /// `file:line: key` of an error, the file name cut to its last part.
    fn place(e: &SpecError) -> (usize, &str) {
        (e.line, e.key.as_str())
    }

    #[test]
    fn the_shipped_mlt980_pages_cover_every_variable_its_programs_read() {
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("examples/mlt980");
        let spec = Spec::load(&dir.join("pages.toml")).unwrap();
        let mut read = std::collections::BTreeSet::new();
        for e in std::fs::read_dir(&dir).unwrap() {
            let p = e.unwrap().path();
            if p.extension().is_some_and(|x| x == "CNC") {
                let text = std::fs::read_to_string(&p).unwrap();
                for (i, _) in text.match_indices('#') {
                    let digits: String = text[i + 1..]
                        .chars()
                        .take_while(char::is_ascii_digit)
                        .collect();
                    if let Ok(n) = digits.parse::<u32>()
                        && (NV_FIRST..=NV_LAST).contains(&n)
                    {
                        read.insert(n);
                    }
                }
            }
        }
        let on_pages: std::collections::BTreeSet<u32> = spec.fields.iter().map(|f| f.var).collect();
        assert_eq!(read.len(), 26, "{read:?}");
        assert_eq!(read, on_pages);
        assert_eq!(spec.main, dir.join("O0001.CNC"));
    }

    #[test]
    fn a_valid_file_parses_with_conditions_limits_and_choices() {
        let text = format!(
            "{HEAD}{}{}",
            "\n[[page.field]]\nvar = 530\nname = \"pattern\"\nlabel = \"P\"\ntype = \"choice\"\nchoices = [{ value = 1, name = \"a\" }, { value = 2, name = \"b\", label = \"B!\" }]\ndefault = 2\n",
            field(
                "507",
                "holes",
                "min = 1\nmax = 9\nwhen = { pattern = [\"b\"] }\n"
            )
            .replace("number", "integer")
        );
        let s = parse("ok", &text).unwrap();
        assert_eq!(s.fields.len(), 2);
        assert_eq!(s.fields[0].default, Some(2.0));
        assert_eq!(s.fields[0].choice_label(Some(2.0)), Some("B!"));
        assert_eq!(
            s.fields[1].when,
            [Condition {
                field: 0,
                values: vec![2.0]
            }]
        );
        assert_eq!(
            s.fields[1].kind,
            Kind::Integer(Limits {
                min: Some(1.0),
                max: Some(9.0),
                ..Limits::default()
            })
        );
        assert_eq!(s.field_by_name("#507"), Some(1));
        assert_eq!(s.field_by_name("530"), Some(0));
        assert_eq!(s.field_by_name("nope"), None);
    }

    #[test]
    fn errors_name_the_line_and_the_key() {
        let cases: Vec<(String, usize, &str, &str)> = vec![
            (
                format!("{HEAD}{}", field("507", "holes", "colour = 3\n")),
                13,
                "page[0].field[0].colour",
                "unknown field `colour`",
            ),
            (
                format!("{HEAD}{}{}", field("507", "a", ""), field("507", "b", "")),
                15,
                "page[0].field[1].var",
                "#507 is already field `a`",
            ),
            (
                format!("{HEAD}{}", field("1000", "a", "")),
                9,
                "page[0].field[0].var",
                "#1000 is not a non-volatile variable",
            ),
            (
                format!("{HEAD}{}", field("499", "a", "")),
                9,
                "page[0].field[0].var",
                "#499 is not",
            ),
            (
                format!("{HEAD}{}{}", field("500", "a", ""), field("501", "a", "")),
                16,
                "page[0].field[1].name",
                "names another field",
            ),
            (
                format!("{HEAD}{}", field("500", "a", "min = 5\nmax = 1\n")),
                14,
                "page[0].field[0].max",
                "leaves no value",
            ),
            (
                format!("{HEAD}{}", field("500", "a", "default = 7\nmax = 1\n")),
                13,
                "page[0].field[0].default",
                "7 is out of range",
            ),
            (
                format!("{HEAD}{}", field("500", "a", "when = { b = [\"x\"] }\n")),
                13,
                "page[0].field[0].when.b",
                "no field is named `b`",
            ),
            (
                format!("{HEAD}{}", field("500", "a", "").replace("number", "text")),
                12,
                "page[0].field[0].type",
                "expected \"number\"",
            ),
            (
                format!("{HEAD}{}", field("500", "Bad Name", "")),
                10,
                "page[0].field[0].name",
                "expected lower-case",
            ),
            (
                HEAD.replace("O0001.nc", "O0002.nc") + &field("500", "a", ""),
                3,
                "package.main",
                "no such file",
            ),
        ];
        for (i, (text, line, key, msg)) in cases.iter().enumerate() {
            let e = parse(&format!("e{i}"), text).expect_err(text);
            assert_eq!(place(&e), (*line, *key), "{e}");
            assert!(e.message.contains(msg), "{e}");
            assert!(
                e.to_string().contains(&format!("pages.toml:{line}:")),
                "{e}"
            );
        }
    }

    #[test]
    fn alarms_get_the_pages_words_and_their_keys_are_numbers() {
        let with = |alarms: &str| {
            let head = HEAD.replace(
                "\n\n[[page]]",
                &format!("\n[package.alarms]\n{alarms}\n\n[[page]]"),
            );
            parse("alarms", &format!("{head}{}", field("500", "a", "")))
        };
        let s = with("507 = \"radius <= 0\"").unwrap();
        assert_eq!(
            s.explain("O9003.CNC:31:1: alarm 507: ∕x"),
            "O9003.CNC:31:1: alarm 507: ∕x — radius <= 0"
        );
        assert_eq!(
            s.explain("O1.nc:3:1: alarm 3001: y"),
            "O1.nc:3:1: alarm 3001: y"
        );
        let e = with("seven = \"x\"").unwrap_err();
        assert_eq!((e.line, e.key.as_str()), (5, "package.alarms.seven"), "{e}");
    }

    #[test]
    fn a_condition_on_a_number_field_or_a_shown_by_field_is_refused() {
        let choice = "\n[[page.field]]\nvar = 530\nname = \"p\"\nlabel = \"P\"\ntype = \"choice\"\nchoices = [{ value = 1, name = \"a\" }]\n";
        let on_number = format!(
            "{HEAD}{}{}",
            field("500", "n", ""),
            field("501", "m", "when = { n = [\"a\"] }\n")
        );
        let e = parse("c1", &on_number).unwrap_err();
        assert!(e.message.contains("not a choice field"), "{e}");
        let chained = format!(
            "{HEAD}{choice}{}{}",
            choice
                .replace("530", "531")
                .replace("\"p\"", "\"q\"")
                .trim_end()
                .to_string()
                + "\nwhen = { p = [\"a\"] }\n",
            field("501", "m", "when = { q = [\"a\"] }\n")
        );
        let e = parse("c2", &chained).unwrap_err();
        assert!(e.message.contains("itself shown by a `when`"), "{e}");
        let bad_choice = format!(
            "{HEAD}{choice}{}",
            field("501", "m", "when = { p = [\"z\"] }\n")
        );
        let e = parse("c3", &bad_choice).unwrap_err();
        assert!(
            e.message.contains("\"z\" is not one of its choices (a)"),
            "{e}"
        );
    }
}
