//! Drive commissioning in the config: per axis a DCF/EDS (`dcf = "drives/x.dcf"`, relative to
//! the config's folder) whose `ParameterValue`s boot writes, and a list of SDO writes
//! (`sdo = [ { index = 0x6065, sub = 0, value = 2000, type = "u32" }, { object = "Quick stop
//! option code", value = 2 } ]`) written after them in order. Everything is resolved to bytes
//! here, at config load, so a bad value is a config error with key and line, not a boot abort.

use std::ops::Range;
use std::path::{Path, PathBuf};

use serde::Deserialize;
use toml::Spanned;

use crate::check::{Invalid, Table};
use crate::eds::{DataType, Eds, ObjectAddr, find_object};

/// One `sdo = [ … ]` entry as written.
#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
pub(crate) struct RawSdoWrite {
    index: Option<Spanned<i64>>,
    sub: Option<Spanned<i64>>,
    object: Option<Spanned<String>>,
    value: Spanned<toml::Value>,
    #[serde(rename = "type")]
    data_type: Option<Spanned<String>>,
}

/// One SDO download boot makes after its own set-up.
#[derive(Clone, Debug, PartialEq)]
pub struct SdoWrite {
    /// Object index.
    pub index: u16,
    /// Sub-index.
    pub sub: u8,
    /// The object's type (the value was checked against it).
    pub data_type: DataType,
    /// The little-endian bytes written.
    pub data: Vec<u8>,
    /// The object's name, when the EDS/DCF or the entry gives one.
    pub name: Option<String>,
    /// Where it was asked for: `config/machine.toml:42` or `drives/x.dcf:120`.
    pub origin: String,
}

/// A DCF parameter value boot does not write, and why.
#[derive(Clone, Debug, PartialEq)]
pub struct SkippedParameter {
    /// Object index.
    pub index: u16,
    /// Sub-index.
    pub sub: u8,
    /// `ParameterName`.
    pub name: String,
    /// Why it is not written.
    pub reason: &'static str,
    /// `drives/x.dcf:LINE`.
    pub origin: String,
}

/// An axis's commissioning: what boot writes after its built-in set-up.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Commissioning {
    /// The DCF/EDS file (resolved), if one is given.
    pub dcf: Option<PathBuf>,
    /// Its contents (names and types for `object = …` and for drivectl).
    pub eds: Option<Eds>,
    /// The writes in order: the DCF's parameter values, then the `sdo` list.
    pub writes: Vec<SdoWrite>,
    /// The DCF's parameter values that are not written.
    pub skipped: Vec<SkippedParameter>,
}

/// Objects the master itself sets at boot (or that are commands, not parameters): a DCF's
/// values for them are skipped; an explicit `sdo` entry may still override them.
pub fn master_owned(index: u16) -> Option<&'static str> {
    Some(match index {
        0x1005 | 0x1006 => "SYNC: set by the master from bus.period_us",
        0x1010 | 0x1011 => "a store/restore command, not a parameter (drivectl store)",
        0x1016 | 0x1017 => "heartbeats: set by the master from bus.heartbeat_ms",
        0x1400..=0x1BFF => "PDO parameters: the master maps the PDOs itself",
        0x6007 => "abort connection option: set by the master (quick stop)",
        0x6040 | 0x607A => "process data: driven by the master",
        0x6060 => "mode of operation: the master sets CSP",
        0x6065 | 0x6066 => "following error window/time-out: from the axis config",
        0x60C2 => "interpolation period: from bus.period_us",
        _ => return None,
    })
}

/// 1-based line of byte `offset` in `text`.
fn line_of(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())].matches('\n').count() + 1
}

/// One axis's commissioning keys as written: `dcf` and `sdo`.
pub(crate) type RawKeys<'a> = (
    Option<&'a Spanned<String>>,
    &'a [Spanned<Table<RawSdoWrite>>],
);

/// Resolves every axis's `dcf` and `sdo` keys (`raw`, with the axes' node ids `nodes`) into
/// [`Commissioning`], one per axis; `path` is the config file (relative DCF paths start at
/// its folder), `text` its contents (for line numbers).
pub(crate) fn validate(
    raw: &[RawKeys<'_>],
    nodes: &[Option<u8>],
    path: &Path,
    text: &str,
) -> Result<Vec<Commissioning>, Invalid> {
    let mut out = Vec::with_capacity(raw.len());
    for (k, (&(dcf, sdo), node)) in raw.iter().zip(nodes).enumerate() {
        let mut c = Commissioning::default();
        if dcf.is_none() && sdo.is_empty() {
            out.push(c);
            continue;
        }
        let Some(node) = *node else {
            let span = dcf.map(Spanned::span).unwrap_or_else(|| sdo[0].span());
            return Err((
                span,
                format!("axis[{k}].{}", if dcf.is_some() { "dcf" } else { "sdo" }),
                "a virtual axis has no drive to commission".into(),
            ));
        };
        if let Some(d) = dcf {
            load_dcf(&mut c, d, k, node, path)?;
        }
        for (i, w) in sdo.iter().enumerate() {
            let key = format!("axis[{k}].sdo[{i}]");
            let origin = format!("{}:{}", path.display(), line_of(text, w.span().start));
            let write = w.get_ref().0.resolve(&key, c.eds.as_ref(), node, origin)?;
            c.writes.push(write);
        }
        out.push(c);
    }
    Ok(out)
}

/// Reads the DCF/EDS of axis `k` into `c`: its file, and its parameter values as writes
/// (or skipped, with the reason).
fn load_dcf(
    c: &mut Commissioning,
    d: &Spanned<String>,
    k: usize,
    node: u8,
    config: &Path,
) -> Result<(), Invalid> {
    let key = format!("axis[{k}].dcf");
    let err = |m: String| (d.span(), key.clone(), m);
    let rel = Path::new(d.get_ref().as_str());
    if d.get_ref().trim().is_empty() {
        return Err(err("must name a DCF or EDS file".into()));
    }
    let file = if rel.is_absolute() {
        rel.to_path_buf()
    } else {
        config.parent().unwrap_or(Path::new("")).join(rel)
    };
    let bytes =
        std::fs::read(&file).map_err(|e| err(format!("cannot read {}: {e}", file.display())))?;
    // EDS files are often Latin-1: decode lossily rather than refuse them.
    let eds = Eds::parse(&String::from_utf8_lossy(&bytes))
        .map_err(|(line, m)| err(format!("{}:{line}: {m}", file.display())))?;
    for (a, e) in &eds.objects {
        let Some(text) = e.value.as_deref() else {
            continue; // an EDS default: the drive has it already
        };
        let origin = format!("{}:{}", file.display(), e.line);
        let reason = if !e.writable() {
            Some("read-only (AccessType)")
        } else if matches!(e.data_type(), Some(DataType::Domain)) {
            Some("DOMAIN (no value to write)")
        } else {
            master_owned(a.index)
        };
        if let Some(reason) = reason {
            c.skipped.push(SkippedParameter {
                index: a.index,
                sub: a.sub,
                name: e.name.clone(),
                reason,
                origin,
            });
            continue;
        }
        let t = e
            .data_type()
            .ok_or_else(|| err(format!("{origin}: {a} has no basic DataType")))?;
        let data = t
            .encode_text(text, Some(node))
            .map_err(|m| err(format!("{origin}: {a} ParameterValue: {m}")))?;
        c.writes.push(SdoWrite {
            index: a.index,
            sub: a.sub,
            data_type: t,
            data,
            name: eds.name(*a),
            origin,
        });
    }
    c.dcf = Some(file);
    c.eds = Some(eds);
    Ok(())
}

impl RawSdoWrite {
    /// The write this entry asks for: its object (by index/sub or by name in `eds`), type
    /// (given, or the EDS's) and value (checked against the type).
    fn resolve(
        &self,
        key: &str,
        eds: Option<&Eds>,
        node: u8,
        origin: String,
    ) -> Result<SdoWrite, Invalid> {
        let at = |span: Range<usize>, field: &str, m: String| (span, format!("{key}.{field}"), m);
        let addr = self.object_addr(key, eds)?;
        if matches!(addr.index, 0x1010 | 0x1011) {
            // A store at every boot would wear the drive's flash and keep whatever a
            // half-finished commissioning left: it is done once, confirmed, by hand.
            return Err(at(
                self.value.span(),
                "value",
                format!(
                    "{addr} stores or restores the drive's parameters: not a boot write; use \
                     `drivectl store NODE` once the values are right"
                ),
            ));
        }
        let entry = eds.and_then(|e| e.get(addr));
        let data_type = match (&self.data_type, entry.and_then(|e| e.data_type())) {
            (Some(t), known) => {
                let given = DataType::from_name(t.get_ref()).ok_or_else(|| {
                    at(
                        t.span(),
                        "type",
                        format!(
                            "unknown type `{}` (u8, u16, u32, u64, i8, i16, i32, i64, f32, \
                             f64, bool, string, bytes or the CiA 301 names)",
                            t.get_ref()
                        ),
                    )
                })?;
                if let Some(k) = known.filter(|k| *k != given) {
                    return Err(at(
                        t.span(),
                        "type",
                        format!("{addr} is {k} in the DCF/EDS, not {given}"),
                    ));
                }
                given
            }
            (None, Some(known)) => known,
            (None, None) => {
                return Err(at(
                    self.value.span(),
                    "type",
                    format!("missing: {addr} has no type in a DCF/EDS; give type = \"u32\" …"),
                ));
            }
        };
        if let Some(e) = entry.filter(|e| e.access.is_some() && !e.writable()) {
            return Err(at(
                self.value.span(),
                "value",
                format!(
                    "{addr} \"{}\" is {} in the DCF/EDS: the drive refuses writes",
                    e.name,
                    e.access.as_deref().unwrap_or("")
                ),
            ));
        }
        let data = encode_value(self.value.get_ref(), data_type, node)
            .map_err(|m| at(self.value.span(), "value", m))?;
        Ok(SdoWrite {
            index: addr.index,
            sub: addr.sub,
            data_type,
            data,
            name: eds.and_then(|e| e.name(addr)),
            origin,
        })
    }

    /// `index`/`sub` or `object` (a name in the EDS/DCF), exactly one of the two.
    fn object_addr(&self, key: &str, eds: Option<&Eds>) -> Result<ObjectAddr, Invalid> {
        match (&self.index, &self.object) {
            (Some(i), None) => {
                let index = crate::check::int_in(i, &format!("{key}.index"), 0x1000, 0xFFFF)?;
                let sub = match &self.sub {
                    Some(s) => crate::check::int_in(s, &format!("{key}.sub"), 0, 255)?,
                    None => 0,
                };
                Ok(ObjectAddr {
                    index: index as u16,
                    sub: sub as u8,
                })
            }
            (None, Some(o)) => {
                let err = |m: String| (o.span(), format!("{key}.object"), m);
                if let Some(s) = &self.sub {
                    return Err((
                        s.span(),
                        format!("{key}.sub"),
                        "not with `object`: name the sub-object (\"Parent.Sub\")".into(),
                    ));
                }
                let eds = eds.ok_or_else(|| {
                    err(
                        "object names come from the drive's DCF/EDS: give `dcf = …` on this \
                         axis, or index and sub"
                            .into(),
                    )
                })?;
                find_object(&eds.lookup_names(), o.get_ref())
                    .map_err(|e| err(format!("\"{}\": {e}", o.get_ref())))
            }
            (Some(i), Some(_)) => Err((
                i.span(),
                format!("{key}.index"),
                "give either index (and sub) or object, not both".into(),
            )),
            (None, None) => Err((
                self.value.span(),
                format!("{key}.index"),
                "missing: give index (and sub) or object".into(),
            )),
        }
    }
}

/// A TOML value as bytes of type `t`: integers and booleans as integers, floats as reals,
/// strings as an EDS value (`"0x1234"`, `"$NODEID+0x180"`, text for VISIBLE_STRING).
fn encode_value(v: &toml::Value, t: DataType, node: u8) -> Result<Vec<u8>, String> {
    match v {
        toml::Value::Integer(i) => t.encode_int(i128::from(*i)),
        toml::Value::Boolean(b) => t.encode_int(i128::from(*b)),
        toml::Value::Float(f) => t.encode_real(*f),
        toml::Value::String(s) => t.encode_text(s, Some(node)),
        other => Err(format!("a {} cannot be written", other.type_str())),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::MachineConfig;

    const SHIPPED: &str = include_str!("../machine.toml");

    const DCF: &str = "\
[DeviceComissioning]
NodeID=1
[1017]
ParameterName=Producer heartbeat time
DataType=0x0006
AccessType=rw
ParameterValue=50
[1018sub1]
ParameterName=Vendor-ID
DataType=0x0007
AccessType=ro
ParameterValue=0x1234
[1014]
ParameterName=COB-ID EMCY
DataType=0x0007
AccessType=rw
ParameterValue=$NODEID+0x80
[605A]
ParameterName=Quick stop option code
DataType=0x0003
AccessType=rw
ParameterValue=2
[6085]
ParameterName=Quick stop deceleration
DataType=0x0007
AccessType=rw
DefaultValue=100000
[6091]
ParameterName=Gear ratio
ObjectType=0x9
[6091sub1]
ParameterName=Motor revolutions
DataType=0x0007
AccessType=rw
ParameterValue=3
";

    /// The shipped config with `extra` lines added to the first axis (after `node = 1`), in
    /// a fresh folder holding `drives/x.dcf`.
    fn with_axis_lines(
        extra: &str,
        dcf: &str,
    ) -> (Result<MachineConfig, crate::ConfigError>, PathBuf) {
        let dir = std::env::temp_dir().join(format!(
            "cnc402-commissioning-{}-{:x}",
            std::process::id(),
            extra.len() * 31 + dcf.len()
        ));
        std::fs::create_dir_all(dir.join("drives")).unwrap();
        std::fs::write(dir.join("drives/x.dcf"), dcf).unwrap();
        let text = SHIPPED.replacen("node = 1\n", &format!("node = 1\n{extra}\n"), 1);
        let path = dir.join("machine.toml");
        (MachineConfig::parse(&text, &path), dir)
    }

    #[test]
    fn sdo_list_by_index_and_by_name_in_order() {
        let (c, dir) = with_axis_lines(
            "dcf = \"drives/x.dcf\"\nsdo = [ { index = 0x6065, sub = 0, value = 2000, type = \"u32\" },\n  { object = \"quick stop option code\", value = 6 },\n  { object = \"Gear ratio.Motor revolutions\", value = \"0x10\" } ]",
            DCF,
        );
        let c = c.unwrap();
        let com = &c.axes[0].commissioning;
        assert_eq!(com.dcf.as_deref(), Some(dir.join("drives/x.dcf").as_path()));
        let listed: Vec<(u16, u8, Vec<u8>)> = com
            .writes
            .iter()
            .map(|w| (w.index, w.sub, w.data.clone()))
            .collect();
        assert_eq!(
            listed,
            vec![
                (0x1014, 0, vec![0x81, 0, 0, 0]),
                (0x605A, 0, vec![2, 0]),
                (0x6091, 1, vec![3, 0, 0, 0]),
                (0x6065, 0, vec![0xD0, 0x07, 0, 0]),
                (0x605A, 0, vec![6, 0]),
                (0x6091, 1, vec![0x10, 0, 0, 0]),
            ],
            "DCF values first (no DefaultValue-only entry), then the sdo list in order"
        );
        assert!(com.writes[3].origin.ends_with(&format!(
            ":{}",
            SHIPPED.lines().position(|l| l == "node = 1").unwrap() + 3
        )));
        assert!(
            com.writes[0].origin.contains("x.dcf:"),
            "{}",
            com.writes[0].origin
        );
        let skipped: Vec<(u16, &str)> = com.skipped.iter().map(|s| (s.index, s.reason)).collect();
        assert_eq!(skipped.len(), 2, "{skipped:?}");
        assert!(skipped.contains(&(0x1017, master_owned(0x1017).unwrap())));
        assert!(
            skipped
                .iter()
                .any(|(i, r)| *i == 0x1018 && r.contains("read-only"))
        );
        assert!(c.axes[1].commissioning.writes.is_empty());
    }

    #[test]
    fn bad_entries_are_config_errors_with_key_and_line() {
        let line = SHIPPED.lines().position(|l| l == "node = 1").unwrap() + 2;
        for (entry, key, says) in [
            (
                "{ index = 0x6065, value = 2000 }",
                "axis[0].sdo[0].type",
                "no type",
            ),
            (
                "{ index = 0x6065, value = -1, type = \"u32\" }",
                "axis[0].sdo[0].value",
                "outside",
            ),
            (
                "{ index = 0x6065, value = 1, type = \"u33\" }",
                "axis[0].sdo[0].type",
                "unknown type",
            ),
            (
                "{ object = \"quick stop optoin code\", value = 1 }",
                "axis[0].sdo[0].object",
                "nearest: \"Quick stop option code\"",
            ),
            (
                "{ object = \"Vendor-ID\", value = 1 }",
                "axis[0].sdo[0].value",
                "refuses writes",
            ),
            (
                "{ index = 0x605A, value = 1, type = \"u8\" }",
                "axis[0].sdo[0].type",
                "INTEGER16",
            ),
            (
                "{ index = 0x605A, object = \"x\", value = 1 }",
                "axis[0].sdo[0].index",
                "not both",
            ),
            (
                "{ index = 0x10, value = 1, type = \"u8\" }",
                "axis[0].sdo[0].index",
                "4096",
            ),
            (
                "{ index = 0x6065, value = [1], type = \"u32\" }",
                "axis[0].sdo[0].value",
                "array",
            ),
            (
                "{ index = 0x1010, sub = 1, value = 0x65766173, type = \"u32\" }",
                "axis[0].sdo[0].value",
                "drivectl store",
            ),
        ] {
            let (r, _) =
                with_axis_lines(&format!("dcf = \"drives/x.dcf\"\nsdo = [ {entry} ]"), DCF);
            let e = r.unwrap_err();
            assert_eq!((e.key.as_str(), e.line), (key, line + 1), "{entry}: {e}");
            assert!(e.message.contains(says), "{entry}: {e}");
        }
        // Names need an EDS/DCF.
        let (r, _) = with_axis_lines("sdo = [ { object = \"Controlword\", value = 1 } ]", DCF);
        let e = r.unwrap_err();
        assert_eq!(e.key, "axis[0].sdo[0].object");
        assert!(e.message.contains("dcf"), "{e}");
    }

    #[test]
    fn dcf_errors_name_the_file_and_its_line() {
        let (r, dir) = with_axis_lines("dcf = \"drives/missing.dcf\"", DCF);
        let e = r.unwrap_err();
        assert_eq!(e.key, "axis[0].dcf");
        assert!(
            e.message
                .contains(&dir.join("drives/missing.dcf").display().to_string()),
            "{e}"
        );
        let bad = DCF.replace("ParameterValue=2\n", "ParameterValue=70000\n");
        let (r, _) = with_axis_lines("dcf = \"drives/x.dcf\"", &bad);
        let e = r.unwrap_err();
        let dcf_line = DCF.lines().position(|l| l == "[605A]").unwrap() + 1;
        assert!(
            e.message.contains(&format!("x.dcf:{dcf_line}: 0x605a:00")),
            "{e}"
        );
        let (r, _) = with_axis_lines("dcf = \"drives/x.dcf\"", "[6041\n");
        assert!(r.unwrap_err().message.contains("x.dcf:1:"));
    }

    #[test]
    fn a_virtual_axis_cannot_be_commissioned() {
        let text = SHIPPED.replacen(
            "node = 1\n",
            "virtual = true\nsdo = [ { index = 0x6065, value = 1, type = \"u32\" } ]\n",
            1,
        );
        let e = MachineConfig::parse(&text, Path::new("m.toml")).unwrap_err();
        assert_eq!(e.key, "axis[0].sdo");
    }
}
