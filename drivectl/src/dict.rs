//! Object names and data types for printouts: from the vendor EDS/DCF given with `--eds`
//! first, else from the standard CiA 301 / CiA 402 objects (the simulated drive's dictionary,
//! which implements the objects cnc402 uses with their standard names and types). Objects
//! are also found by name here (`drivectl sdo read 3 controlword`).

use core::time::Duration;

use cnc402_config::MachineConfig;
use cnc402_drives::od::ObjectDictionary;
use cnc402_drives::sim::SimDrive;
use cnc402_drives::wire::NodeId;

use crate::eds::{Eds, NameError, find_object};
use crate::error::CliError;
use crate::values::{DataType, ObjectAddr};

/// Names and types by object address.
#[derive(Clone, Debug)]
pub struct Dictionary {
    /// The EDS, if one was given.
    pub eds: Option<Eds>,
    builtin: ObjectDictionary,
}

impl Dictionary {
    /// The dictionary with an optional EDS on top of the standard objects.
    pub fn new(eds: Option<Eds>) -> Dictionary {
        let cfg = MachineConfig::default_machine();
        let builtin = match (cfg.axes.first(), NodeId::new(1)) {
            (Some(axis), Ok(node)) => SimDrive::new(axis, node, Duration::from_millis(1))
                .od()
                .clone(),
            _ => ObjectDictionary::new(),
        };
        Dictionary { eds, builtin }
    }

    /// The object's name.
    pub fn name(&self, a: ObjectAddr) -> Option<String> {
        if let Some(n) = self.eds.as_ref().and_then(|e| e.name(a)) {
            return Some(n);
        }
        self.builtin
            .entry(a.index, a.sub)
            .ok()
            .map(|e| e.name.to_string())
    }

    /// The object's data type.
    pub fn data_type(&self, a: ObjectAddr) -> Option<DataType> {
        if let Some(t) = self
            .eds
            .as_ref()
            .and_then(|e| e.get(a))
            .and_then(|e| e.data_type())
        {
            return Some(t);
        }
        self.builtin
            .entry(a.index, a.sub)
            .ok()
            .map(|e| e.value.data_type())
    }

    /// Where the name/type come from: `eds`, `standard` or `unknown`.
    pub fn source(&self, a: ObjectAddr) -> &'static str {
        if self.eds.as_ref().and_then(|e| e.get(a)).is_some() {
            "eds"
        } else if self.builtin.entry(a.index, a.sub).is_ok() {
            "standard"
        } else {
            "unknown"
        }
    }
}

/// CiA 301/402 names of the records and arrays among the standard objects (the simulated
/// drive's dictionary names the sub-objects only): `(first index, last index, name)`; a
/// range is numbered (`RPDO1 mapping parameter` …).
const RECORD_NAMES: &[(u16, u16, &str)] = &[
    (0x1003, 0x1003, "Pre-defined error field"),
    (0x1010, 0x1010, "Store parameters"),
    (0x1011, 0x1011, "Restore default parameters"),
    (0x1016, 0x1016, "Consumer heartbeat time"),
    (0x1018, 0x1018, "Identity object"),
    (0x1400, 0x15FF, "RPDO# communication parameter"),
    (0x1600, 0x17FF, "RPDO# mapping parameter"),
    (0x1800, 0x19FF, "TPDO# communication parameter"),
    (0x1A00, 0x1BFF, "TPDO# mapping parameter"),
    (0x60C2, 0x60C2, "Interpolation time period"),
];

/// The record/array name of standard object `index`, if it is one.
fn record_name(index: u16) -> Option<String> {
    let (first, _, name) = RECORD_NAMES
        .iter()
        .find(|(first, last, _)| (*first..=*last).contains(&index))?;
    Some(name.replace('#', &(index - first + 1).to_string()))
}

impl Dictionary {
    /// The names of the standard objects: a VAR's own name; a record's sub-object as
    /// `Record.Sub` (python-canopen's form) and by its own name.
    fn builtin_names(&self) -> Vec<(ObjectAddr, String)> {
        let mut out = Vec::new();
        for index in self.builtin.indices() {
            let record = record_name(index);
            for sub in self.builtin.subs(index) {
                let Ok(e) = self.builtin.entry(index, sub) else {
                    continue;
                };
                let a = ObjectAddr { index, sub };
                if let Some(r) = &record {
                    out.push((a, format!("{r}.{}", e.name)));
                }
                out.push((a, e.name.to_string()));
            }
        }
        out
    }

    /// The object `text` names: hex `INDEX[:SUB]` (`6041`, `0x1018:1`), else a name from
    /// `node_eds` (the `--eds` file first, else the node's DCF from the config) and the
    /// standard objects, compared case-insensitively, python-canopen's `"Parent.Sub"` too.
    /// An unknown or ambiguous name is a usage error listing the nearest or all matches.
    pub fn resolve(&self, node_eds: Option<&Eds>, text: &str) -> Result<ObjectAddr, CliError> {
        let hex_error = match crate::values::parse_object(text) {
            Ok(a) => return Ok(a),
            Err(e) => e,
        };
        let looks_hex = text
            .trim()
            .trim_start_matches("0x")
            .chars()
            .all(|c| c.is_ascii_hexdigit() || c == ':' || c == 'x');
        if looks_hex {
            return Err(CliError::usage(hex_error));
        }
        let mut names = match self.eds.as_ref().or(node_eds) {
            Some(e) => e.lookup_names(),
            None => Vec::new(),
        };
        names.extend(self.builtin_names());
        find_object(&names, text).map_err(|e| match e {
            NameError::Unknown(_) => CliError::usage(format!(
                "`{text}` is neither INDEX[:SUB] (hex, e.g. 6041 or 0x1018:1) nor an object \
                 name: {e}"
            )),
            NameError::Ambiguous(_) => CliError::usage(format!(
                "`{text}`: {e}; give INDEX:SUB or the \"Parent.Sub\" name"
            )),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn a(index: u16, sub: u8) -> ObjectAddr {
        ObjectAddr { index, sub }
    }

    #[test]
    fn objects_by_hex_address_or_standard_name() {
        let d = Dictionary::new(None);
        assert_eq!(d.resolve(None, "0x6041").unwrap(), a(0x6041, 0));
        assert_eq!(d.resolve(None, "1018:1").unwrap(), a(0x1018, 1));
        assert_eq!(d.resolve(None, "controlword").unwrap(), a(0x6040, 0));
        assert_eq!(d.resolve(None, "Controlword").unwrap(), a(0x6040, 0));
        assert_eq!(d.resolve(None, "STATUSWORD").unwrap(), a(0x6041, 0));
        assert_eq!(
            d.resolve(None, "Store parameters.Save all parameters")
                .unwrap(),
            a(0x1010, 1)
        );
        assert_eq!(
            d.resolve(None, "identity object.vendor id").unwrap(),
            a(0x1018, 1)
        );
        assert_eq!(
            d.resolve(None, "TPDO2 mapping parameter.number of mapped objects")
                .unwrap(),
            a(0x1A01, 0)
        );
    }

    #[test]
    fn unknown_and_ambiguous_names_list_the_candidates() {
        let d = Dictionary::new(None);
        let e = d.resolve(None, "controlwrod").unwrap_err();
        assert_eq!(e.exit, crate::error::Exit::Usage);
        assert!(
            e.message.contains("\"controlword\" (0x6040:00)"),
            "{}",
            e.message
        );
        let e = d.resolve(None, "number of mapped objects").unwrap_err();
        assert!(e.message.contains("several objects"), "{}", e.message);
        assert!(e.message.contains("0x1600:00") && e.message.contains("0x1a03:00"));
        let e = d.resolve(None, "0x6041:300").unwrap_err();
        assert!(e.message.contains("sub-index"), "{}", e.message);
    }

    #[test]
    fn the_eds_names_come_first_and_vendor_objects_are_found() {
        let eds = Eds::parse(
            "[2010]\nParameterName=Motor temperature limit\nDataType=0x0006\nAccessType=rw\n",
        )
        .unwrap();
        let d = Dictionary::new(None);
        assert_eq!(
            d.resolve(Some(&eds), "motor temperature limit").unwrap(),
            a(0x2010, 0)
        );
        assert!(d.resolve(None, "motor temperature limit").is_err());
        assert_eq!(d.resolve(Some(&eds), "controlword").unwrap(), a(0x6040, 0));
    }
}
