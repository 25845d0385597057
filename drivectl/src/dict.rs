//! Object names and data types for printouts: from the vendor EDS/DCF given with `--eds`
//! first, else from the standard CiA 301 / CiA 402 objects (the simulated drive's dictionary,
//! which implements the objects cnc402 uses with their standard names and types).

use core::time::Duration;

use cnc402_config::MachineConfig;
use cnc402_drives::od::ObjectDictionary;
use cnc402_drives::sim::SimDrive;
use cnc402_drives::wire::NodeId;

use crate::eds::Eds;
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
