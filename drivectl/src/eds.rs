//! CiA 306 EDS/DCF files: an INI parser for the sections drivectl uses (FileInfo,
//! DeviceInfo, DeviceComissioning, and the objects `[IIII]` / `[IIIIsubS]` with their names,
//! data types, access and default/parameter values). canopen-rs 0.6.1 has no EDS parser.

use std::collections::BTreeMap;
use std::path::Path;

use crate::error::{CliError, Exit, Result};
use crate::values::{DataType, ObjectAddr, parse_uint};

/// One object or sub-object of an EDS.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct EdsEntry {
    /// `ParameterName`.
    pub name: String,
    /// `ObjectType` (7 VAR, 8 ARRAY, 9 RECORD).
    pub object_type: u8,
    /// `DataType` as a code (0x0007 = UNSIGNED32 ...).
    pub data_type_code: Option<u16>,
    /// `AccessType` (ro, wo, rw, rww, rwr, const).
    pub access: Option<String>,
    /// `DefaultValue`.
    pub default: Option<String>,
    /// `ParameterValue` (DCF).
    pub value: Option<String>,
    /// `PDOMapping=1`.
    pub pdo_mapping: bool,
    /// The line of the section header.
    pub line: usize,
}

impl EdsEntry {
    /// The data type, if the code is one drivectl knows.
    pub fn data_type(&self) -> Option<DataType> {
        self.data_type_code.and_then(DataType::from_code)
    }
}

/// A parsed EDS/DCF.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct Eds {
    /// `[FileInfo]` keys (lower-case) and values.
    pub file_info: BTreeMap<String, String>,
    /// `[DeviceInfo]` keys (lower-case) and values.
    pub device_info: BTreeMap<String, String>,
    /// `[DeviceComissioning]` (DCF) keys (lower-case) and values.
    pub commissioning: BTreeMap<String, String>,
    /// Objects by address; a VAR is at sub 0, the header of an ARRAY/RECORD at sub 0 too,
    /// unless its `[IIIIsub0]` section exists (that one wins for sub 0).
    pub objects: BTreeMap<ObjectAddr, EdsEntry>,
    /// Names of ARRAY/RECORD headers, by index.
    pub object_names: BTreeMap<u16, String>,
}

impl Eds {
    /// Reads and parses a file; errors name the file and line.
    pub fn load(path: &Path) -> Result<Eds> {
        let bytes = std::fs::read(path).map_err(|e| {
            CliError::new(
                Exit::Config,
                format!("cannot read EDS {}: {e}", path.display()),
            )
        })?;
        // EDS files are often Latin-1: decode lossily rather than refuse them.
        let text = String::from_utf8_lossy(&bytes);
        Eds::parse(&text).map_err(|(line, m)| {
            CliError::new(Exit::Config, format!("{}:{line}: {m}", path.display()))
        })
    }

    /// Parses EDS/DCF text. Errors are `(line, message)`.
    ///
    /// ```
    /// let eds = drivectl::eds::Eds::parse(
    ///     "[6041]\nParameterName=Statusword\nObjectType=0x7\nDataType=0x0006\nAccessType=ro\n",
    /// ).unwrap();
    /// let e = &eds.objects[&drivectl::values::ObjectAddr { index: 0x6041, sub: 0 }];
    /// assert_eq!(e.name, "Statusword");
    /// assert_eq!(e.data_type(), Some(drivectl::values::DataType::Unsigned16));
    /// ```
    pub fn parse(text: &str) -> core::result::Result<Eds, (usize, String)> {
        let mut eds = Eds::default();
        // Section name → (header line, key/values).
        let mut sections: Vec<(String, usize, BTreeMap<String, String>)> = Vec::new();
        for (n, raw) in text.lines().enumerate() {
            let line = raw.trim();
            if line.is_empty() || line.starts_with(';') || line.starts_with('#') {
                continue;
            }
            if let Some(rest) = line.strip_prefix('[') {
                let Some(name) = rest.strip_suffix(']') else {
                    return Err((n + 1, format!("section header `{line}` lacks `]`")));
                };
                sections.push((name.trim().to_ascii_lowercase(), n + 1, BTreeMap::new()));
                continue;
            }
            let Some((k, v)) = line.split_once('=') else {
                return Err((n + 1, format!("expected KEY=VALUE, found `{line}`")));
            };
            let Some(sec) = sections.last_mut() else {
                return Err((n + 1, "key before the first [section]".to_string()));
            };
            // Inline comments after values are common in hand-edited files.
            let v = v.split(';').next().unwrap_or("").trim();
            sec.2.insert(k.trim().to_ascii_lowercase(), v.to_string());
        }
        let mut headers: Vec<(u16, usize, BTreeMap<String, String>)> = Vec::new();
        for (name, line, kv) in sections {
            match name.as_str() {
                "fileinfo" => eds.file_info = kv,
                "deviceinfo" => eds.device_info = kv,
                "devicecomissioning" | "devicecommissioning" => eds.commissioning = kv,
                _ => {
                    let (idx, sub) = match name.split_once("sub") {
                        Some((i, s)) => (i, Some(s)),
                        None => (name.as_str(), None),
                    };
                    if idx.len() != 4 || !idx.chars().all(|c| c.is_ascii_hexdigit()) {
                        continue; // MandatoryObjects, Comments, vendor sections ...
                    }
                    let index = u16::from_str_radix(idx, 16)
                        .map_err(|_| (line, format!("bad object index in [{name}]")))?;
                    match sub {
                        Some(s) => {
                            let sub = u8::from_str_radix(s, 16).map_err(|_| {
                                (line, format!("bad sub-index in [{name}] (hex expected)"))
                            })?;
                            let e = entry(&kv, line)?;
                            eds.objects.insert(ObjectAddr { index, sub }, e);
                        }
                        None => headers.push((index, line, kv)),
                    }
                }
            }
        }
        for (index, line, kv) in headers {
            let e = entry(&kv, line)?;
            eds.object_names.insert(index, e.name.clone());
            eds.objects.entry(ObjectAddr { index, sub: 0 }).or_insert(e);
        }
        Ok(eds)
    }

    /// The entry at `addr`.
    pub fn get(&self, addr: ObjectAddr) -> Option<&EdsEntry> {
        self.objects.get(&addr)
    }

    /// A display name: the sub-object's name, prefixed with its array/record name.
    pub fn name(&self, addr: ObjectAddr) -> Option<String> {
        let sub = self.objects.get(&addr).map(|e| e.name.clone());
        let parent = self.object_names.get(&addr.index);
        match (parent, sub) {
            (Some(p), Some(s)) if addr.sub > 0 && *p != s => Some(format!("{p} / {s}")),
            (_, Some(s)) => Some(s),
            (Some(p), None) => Some(p.clone()),
            (None, None) => None,
        }
    }
}

fn entry(
    kv: &BTreeMap<String, String>,
    line: usize,
) -> core::result::Result<EdsEntry, (usize, String)> {
    // Keys are stored lower-case; errors use CiA 306's spelling.
    let num = |k: &str, shown: &str| -> core::result::Result<Option<u64>, (usize, String)> {
        match kv.get(k) {
            None => Ok(None),
            Some(v) if v.is_empty() => Ok(None),
            Some(v) => parse_uint(v)
                .map(Some)
                .ok_or((line, format!("{shown}={v} is not a number"))),
        }
    };
    Ok(EdsEntry {
        name: kv.get("parametername").cloned().unwrap_or_default(),
        object_type: num("objecttype", "ObjectType")?.unwrap_or(7) as u8,
        data_type_code: num("datatype", "DataType")?.map(|v| v as u16),
        access: kv.get("accesstype").map(|s| s.to_ascii_lowercase()),
        default: kv.get("defaultvalue").cloned().filter(|s| !s.is_empty()),
        value: kv.get("parametervalue").cloned().filter(|s| !s.is_empty()),
        pdo_mapping: num("pdomapping", "PDOMapping")?.unwrap_or(0) != 0,
        line,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const SAMPLE: &str = "\
[FileInfo]
FileName=drive.eds
[DeviceInfo]
VendorName=ACME ; a comment
ProductName=Servo 9
[1018]
ParameterName=Identity Object
ObjectType=0x9
SubNumber=2
[1018sub0]
ParameterName=Number of entries
ObjectType=0x7
DataType=0x0005
AccessType=ro
DefaultValue=1
[1018sub1]
ParameterName=Vendor-ID
ObjectType=0x7
DataType=0x0007
AccessType=ro
DefaultValue=0x1234
[6060]
ParameterName=Modes of operation
DataType=0x0002
AccessType=rw
PDOMapping=1
";

    #[test]
    fn parses_objects_names_and_types() {
        let eds = Eds::parse(SAMPLE).unwrap();
        assert_eq!(eds.device_info["vendorname"], "ACME");
        let v = ObjectAddr {
            index: 0x1018,
            sub: 1,
        };
        assert_eq!(eds.name(v).unwrap(), "Identity Object / Vendor-ID");
        assert_eq!(eds.get(v).unwrap().data_type(), Some(DataType::Unsigned32));
        let m = eds
            .get(ObjectAddr {
                index: 0x6060,
                sub: 0,
            })
            .unwrap();
        assert_eq!(m.data_type(), Some(DataType::Integer8));
        assert!(m.pdo_mapping);
        // [1018sub0] wins over the record header for sub 0.
        assert_eq!(
            eds.get(ObjectAddr {
                index: 0x1018,
                sub: 0
            })
            .unwrap()
            .name,
            "Number of entries"
        );
    }

    #[test]
    fn errors_name_the_line() {
        let e = Eds::parse("[6041]\nParameterName=x\nDataType=zz\n").unwrap_err();
        assert_eq!(e.0, 1);
        assert!(e.1.contains("DataType=zz"));
        assert_eq!(Eds::parse("junk\n").unwrap_err().0, 1);
        assert_eq!(Eds::parse("[x]\nnot a pair\n").unwrap_err().0, 2);
    }
}
