//! Decoding bus traffic for `monitor` and `emcy`: every frame classified by the pre-defined
//! connection set and turned into text and JSON (NMT, SYNC, PDOs by the mapping cnc402 sets,
//! SDO with object names, EMCY with its text, heartbeats), with node names from the config.

use std::collections::BTreeMap;

use cia402::Statusword;
use cnc402_config::MachineConfig;
use cnc402_drives::master::emcy_text;
use cnc402_drives::wire::{
    CanFrame, EmcyRepr, Function, HeartbeatRepr, InitiateKind, NmtCommand, NmtRepr, NmtState,
    NmtTarget, PdoMap, SdoRequest, SdoResponse, SyncRepr,
};
use serde_json::{Value as Json, json};

use crate::dict::Dictionary;
use crate::values::{ObjectAddr, hex};

/// Node names (`X`, `Y` ...) from the machine config.
#[derive(Clone, Debug, Default)]
pub struct NodeNames(BTreeMap<u8, String>);

impl NodeNames {
    /// Axis letters by node id.
    pub fn from_config(cfg: &MachineConfig) -> NodeNames {
        NodeNames(
            cfg.axes
                .iter()
                .filter_map(|a| a.node.map(|n| (n, a.name.to_string())))
                .collect(),
        )
    }
    /// `node 3 (Z)` or `node 9`.
    pub fn label(&self, node: u8) -> String {
        match self.0.get(&node) {
            Some(n) => format!("node {node} ({n})"),
            None => format!("node {node}"),
        }
    }
    /// The axis name of a node.
    pub fn get(&self, node: u8) -> Option<&str> {
        self.0.get(&node).map(String::as_str)
    }
}

/// The NMT state's name.
pub fn nmt_state_name(s: NmtState) -> &'static str {
    match s {
        NmtState::BootUp => "BOOT-UP",
        NmtState::Stopped => "STOPPED",
        NmtState::Operational => "OPERATIONAL",
        NmtState::PreOperational => "PRE-OPERATIONAL",
    }
}

fn nmt_command_name(c: NmtCommand) -> &'static str {
    match c {
        NmtCommand::Start => "start",
        NmtCommand::Stop => "stop",
        NmtCommand::EnterPreOperational => "enter pre-operational",
        NmtCommand::ResetNode => "reset node",
        NmtCommand::ResetCommunication => "reset communication",
    }
}

/// A decoded frame.
#[derive(Clone, Debug, PartialEq)]
pub struct Decoded {
    /// `nmt`, `sync`, `emcy`, `tpdo1`, `rpdo1`, `sdo_req`, `sdo_resp`, `heartbeat`, `boot_up`,
    /// `time`, `other`.
    pub kind: &'static str,
    /// The node the frame is from / for.
    pub node: Option<u8>,
    /// Human text (without the node label).
    pub text: String,
    /// Fields for `--json`.
    pub fields: Json,
}

/// PDO mappings read from the drives, by COB-ID (`monitor --read-mapping`).
#[derive(Clone, Debug, Default)]
pub struct PdoMaps(BTreeMap<u16, (&'static str, PdoMap)>);

impl PdoMaps {
    /// Adds the mapping of the PDO on `cob_id` (`kind`: `tpdo1` … `rpdo4`).
    pub fn insert(&mut self, cob_id: u16, kind: &'static str, map: PdoMap) {
        self.0.insert(cob_id, (kind, map));
    }
    /// The mappings cnc402 sets with `bus.pdo_layout = "compact"` (RPDO1 target, RPDO2
    /// controlword, TPDO1 position, TPDO2 statusword) for each configured drive; empty for
    /// the standard layout, which [`decode`] knows without a map.
    pub fn of_config(cfg: &MachineConfig) -> PdoMaps {
        use cnc402_config::busload::PdoLayout;
        use cnc402_drives::master::boot::MappedPdos;
        let mut maps = PdoMaps::default();
        if cfg.bus.pdo_layout != PdoLayout::Compact {
            return maps;
        }
        let pdos = MappedPdos::of(PdoLayout::Compact);
        for node in cfg.axes.iter().filter_map(|a| a.node) {
            let id = u16::from(node);
            maps.insert(0x200 + id, "rpdo1", pdos.rx[0].map());
            maps.insert(0x300 + id, "rpdo2", pdos.rx[1].map());
            maps.insert(0x180 + id, "tpdo1", pdos.tx[0].map());
            maps.insert(0x280 + id, "tpdo2", pdos.tx[1].map());
        }
        maps
    }
    /// Number of mappings.
    pub fn len(&self) -> usize {
        self.0.len()
    }
    /// No mappings.
    pub fn is_empty(&self) -> bool {
        self.0.is_empty()
    }
}

/// Decodes a PDO by a mapping read from the drive: each entry with its object name and its
/// value, sign-extended where the dictionary says the object is signed.
fn decode_mapped(frame: &CanFrame, kind: &'static str, map: &PdoMap, dict: &Dictionary) -> Decoded {
    let node = Some((frame.id() & 0x7F) as u8);
    let mut parts = Vec::new();
    let mut fields = serde_json::Map::new();
    let r = map.unpack(frame.data(), |e, raw| {
        let a = ObjectAddr {
            index: e.index,
            sub: e.sub,
        };
        let signed = dict.data_type(a).is_some_and(|t| t.is_signed());
        let v: Json = if signed && e.bits > 0 && e.bits < 64 {
            let shift = 64 - e.bits as u32;
            json!(((raw << shift) as i64) >> shift)
        } else {
            json!(raw)
        };
        let name = dict.name(a).unwrap_or_else(|| a.to_string());
        parts.push(format!("{name} {v}"));
        fields.insert(name, v);
    });
    let upper = kind.to_ascii_uppercase();
    match r {
        Ok(()) => Decoded {
            kind,
            node,
            text: format!("{upper} {}", parts.join(", ")),
            fields: Json::Object(fields),
        },
        Err(e) => Decoded {
            kind,
            node,
            text: format!(
                "{upper} does not fit its mapping ({e:?}): {}",
                hex(frame.data())
            ),
            fields: json!({ "data": hex(frame.data()), "error": format!("{e:?}") }),
        },
    }
}

/// Decodes one frame. PDOs whose mapping was read from the drive (`maps`) are decoded by it;
/// otherwise PDO1s are decoded with cnc402's mapping (RPDO1 = controlword + target
/// position, TPDO1 = statusword + position actual) and other PDOs are shown as bytes.
pub fn decode(frame: &CanFrame, dict: &Dictionary, maps: &PdoMaps) -> Decoded {
    let data = frame.data();
    if matches!(
        Function::classify(frame.id()),
        Function::Tpdo(..) | Function::Rpdo(..)
    ) && let Some((kind, map)) = maps.0.get(&frame.id())
    {
        return decode_mapped(frame, kind, map, dict);
    }
    let raw = |kind: &'static str, node: Option<u8>, what: String| Decoded {
        kind,
        node,
        text: what,
        fields: json!({ "data": hex(data) }),
    };
    match Function::classify(frame.id()) {
        Function::Nmt => match NmtRepr::parse(frame) {
            Ok(r) => {
                let (target, node) = match r.target {
                    NmtTarget::All => ("all nodes".to_string(), None),
                    NmtTarget::Node(n) => (format!("node {}", n.get()), Some(n.get())),
                };
                Decoded {
                    kind: "nmt",
                    node,
                    text: format!("NMT {} → {target}", nmt_command_name(r.command)),
                    fields: json!({ "command": nmt_command_name(r.command) }),
                }
            }
            Err(e) => raw("nmt", None, format!("NMT malformed ({e}): {}", hex(data))),
        },
        Function::Sync => match SyncRepr::parse(frame) {
            Ok(s) => Decoded {
                kind: "sync",
                node: None,
                text: match s.counter {
                    Some(c) => format!("SYNC counter {c}"),
                    None => "SYNC".to_string(),
                },
                fields: json!({ "counter": s.counter }),
            },
            Err(e) => raw("sync", None, format!("SYNC malformed ({e})")),
        },
        Function::Time => raw("time", None, format!("TIME {}", hex(data))),
        Function::Emcy(n) => match EmcyRepr::parse(frame) {
            Ok(e) => Decoded {
                kind: "emcy",
                node: Some(n.get()),
                text: format!(
                    "EMCY {:#06x} {} (error register {:#04x}, manufacturer {})",
                    e.code,
                    emcy_text(e.code),
                    e.register,
                    hex(&e.manufacturer)
                ),
                fields: json!({
                    "code": e.code, "text": emcy_text(e.code), "register": e.register,
                    "manufacturer": hex(&e.manufacturer)
                }),
            },
            Err(err) => raw("emcy", Some(n.get()), format!("EMCY malformed ({err})")),
        },
        Function::Tpdo(p, n) => match tpdo1(p, n.get(), data) {
            Some(d) => d,
            None => raw(
                pdo_kind(true, p),
                Some(n.get()),
                format!("TPDO{p} {}", hex(data)),
            ),
        },
        Function::Rpdo(p, n) => match rpdo1(p, n.get(), data) {
            Some(d) => d,
            None => raw(
                pdo_kind(false, p),
                Some(n.get()),
                format!("RPDO{p} {}", hex(data)),
            ),
        },
        Function::SdoRx(n) => raw(
            "sdo_req",
            Some(n.get()),
            match SdoRequest::parse_bytes(data) {
                Ok(r) => sdo_request_text(r, dict),
                Err(e) => format!("SDO request malformed ({e})"),
            },
        ),
        Function::SdoTx(n) => raw(
            "sdo_resp",
            Some(n.get()),
            match SdoResponse::parse_bytes(data) {
                Ok(r) => sdo_response_text(r, dict),
                Err(e) => format!("SDO response malformed ({e})"),
            },
        ),
        Function::Heartbeat(n) => heartbeat(frame, n.get()),
        Function::Other(id) => raw("other", None, format!("{id:03X}#{}", hex(data))),
    }
}

/// TPDO1 in cnc402's mapping (statusword + position actual), if the frame is one.
fn tpdo1(pdo: u8, node: u8, data: &[u8]) -> Option<Decoded> {
    if pdo != 1 || data.len() != 6 {
        return None;
    }
    let sw = Statusword(u16::from_le_bytes([data[0], data[1]]));
    let pos = i32::from_le_bytes([data[2], data[3], data[4], data[5]]);
    Some(Decoded {
        kind: "tpdo1",
        node: Some(node),
        text: format!("TPDO1 statusword {sw} position actual {pos}"),
        fields: json!({ "statusword": sw.0, "state": sw.state().map(|s| s.name()), "position_actual": pos }),
    })
}

/// RPDO1 in cnc402's mapping (controlword + target position), if the frame is one.
fn rpdo1(pdo: u8, node: u8, data: &[u8]) -> Option<Decoded> {
    if pdo != 1 || data.len() != 6 {
        return None;
    }
    let cw = u16::from_le_bytes([data[0], data[1]]);
    let pos = i32::from_le_bytes([data[2], data[3], data[4], data[5]]);
    Some(Decoded {
        kind: "rpdo1",
        node: Some(node),
        text: format!("RPDO1 controlword {cw:#06x} target position {pos}"),
        fields: json!({ "controlword": cw, "target_position": pos }),
    })
}

/// The text of a parsed SDO request (client to server).
fn sdo_request_text(r: SdoRequest, dict: &Dictionary) -> String {
    match r {
        SdoRequest::InitiateUpload { index, sub } => {
            format!("SDO read {}", obj(dict, index, sub))
        }
        SdoRequest::InitiateDownload { index, sub, kind } => {
            format!("SDO write {} {}", obj(dict, index, sub), initiate(&kind))
        }
        SdoRequest::DownloadSegment(s) => {
            format!(
                "SDO download segment t={} {}",
                s.toggle as u8,
                hex(s.data())
            )
        }
        SdoRequest::UploadSegment { toggle } => {
            format!("SDO upload segment request t={}", toggle as u8)
        }
        SdoRequest::Abort { index, sub, code } => {
            format!("SDO abort by client {}: {code}", obj(dict, index, sub))
        }
    }
}

/// The text of a parsed SDO response (server to client).
fn sdo_response_text(r: SdoResponse, dict: &Dictionary) -> String {
    match r {
        SdoResponse::InitiateUpload { index, sub, kind } => {
            format!("SDO read {} → {}", obj(dict, index, sub), initiate(&kind))
        }
        SdoResponse::InitiateDownload { index, sub } => {
            format!("SDO write {} confirmed", obj(dict, index, sub))
        }
        SdoResponse::UploadSegment(s) => {
            format!("SDO upload segment t={} {}", s.toggle as u8, hex(s.data()))
        }
        SdoResponse::DownloadSegment { toggle } => {
            format!("SDO download segment confirmed t={}", toggle as u8)
        }
        SdoResponse::Abort { index, sub, code } => {
            format!("SDO abort by server {}: {code}", obj(dict, index, sub))
        }
    }
}

/// A heartbeat (boot-up or NMT state) or a node-guarding request (a remote frame).
fn heartbeat(frame: &CanFrame, node: u8) -> Decoded {
    let raw = |kind: &'static str, text: String| Decoded {
        kind,
        node: Some(node),
        text,
        fields: json!({ "data": hex(frame.data()) }),
    };
    if frame.is_remote() {
        return raw("guard", "node guarding request".into());
    }
    match HeartbeatRepr::parse(frame) {
        Ok(h) if h.state == NmtState::BootUp => Decoded {
            kind: "boot_up",
            node: Some(node),
            text: "boot-up".into(),
            fields: json!({ "state": "BOOT-UP" }),
        },
        Ok(h) => Decoded {
            kind: "heartbeat",
            node: Some(node),
            text: format!("heartbeat {}", nmt_state_name(h.state)),
            fields: json!({ "state": nmt_state_name(h.state) }),
        },
        Err(e) => raw("heartbeat", format!("heartbeat malformed ({e})")),
    }
}

fn pdo_kind(tx: bool, p: u8) -> &'static str {
    match (tx, p) {
        (true, 1) => "tpdo1",
        (true, 2) => "tpdo2",
        (true, 3) => "tpdo3",
        (true, _) => "tpdo4",
        (false, 1) => "rpdo1",
        (false, 2) => "rpdo2",
        (false, 3) => "rpdo3",
        (false, _) => "rpdo4",
    }
}

fn obj(dict: &Dictionary, index: u16, sub: u8) -> String {
    let a = ObjectAddr { index, sub };
    match dict.name(a) {
        Some(n) => format!("{a} {n}"),
        None => a.to_string(),
    }
}

fn initiate(k: &InitiateKind) -> String {
    match k {
        InitiateKind::Expedited(d) => format!("data {}", hex(d.bytes())),
        InitiateKind::Segmented { size: Some(s) } => format!("segmented, {s} bytes"),
        InitiateKind::Segmented { size: None } => "segmented".to_string(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use cnc402_drives::wire::MappingEntry;

    #[test]
    fn the_compact_layout_is_decoded_from_the_config() {
        let mut cfg = MachineConfig::default_machine();
        let dict = Dictionary::new(None);
        assert!(PdoMaps::of_config(&cfg).is_empty());
        cfg.bus.pdo_layout = cnc402_config::busload::PdoLayout::Compact;
        let maps = PdoMaps::of_config(&cfg);
        assert_eq!(maps.len(), 16);
        // TPDO2 of node 3: the statusword alone; TPDO1: the position alone.
        let sw = CanFrame::new(0x283, &[0x37, 0x06]).unwrap();
        let d = decode(&sw, &dict, &maps);
        assert_eq!((d.kind, d.node), ("tpdo2", Some(3)));
        assert!(d.text.contains("statusword"), "{}", d.text);
        let pos = CanFrame::new(0x183, &(-5i32).to_le_bytes()).unwrap();
        let d = decode(&pos, &dict, &maps);
        assert!(d.text.contains("-5"), "{}", d.text);
        let cw = CanFrame::new(0x303, &[0x0F, 0x00]).unwrap();
        assert!(decode(&cw, &dict, &maps).text.contains("controlword"));
    }

    #[test]
    fn pdos_decode_by_the_mapping_read_from_the_drive() {
        let dict = Dictionary::new(None);
        let mut maps = PdoMaps::default();
        let m = PdoMap::from_entries(&[
            MappingEntry::new(0x6041, 0, 16),
            MappingEntry::new(0x6064, 0, 32),
        ])
        .unwrap();
        maps.insert(0x182, "tpdo1", m);
        let f = CanFrame::new(0x182, &[0x37, 0x12, 0xfe, 0xff, 0xff, 0xff]).unwrap();
        let d = decode(&f, &dict, &maps);
        assert_eq!(d.kind, "tpdo1");
        assert_eq!(d.node, Some(2));
        // 0x6064 is INTEGER32: sign-extended.
        assert_eq!(d.text, "TPDO1 statusword 4663, position actual value -2");
        // A frame of the wrong length is said to be so, not misread.
        let short = CanFrame::new(0x182, &[0x37, 0x12]).unwrap();
        assert!(
            decode(&short, &dict, &maps)
                .text
                .contains("does not fit its mapping")
        );
        // Without a mapping, cnc402's PDO1 layout applies.
        let d = decode(&f, &dict, &PdoMaps::default());
        assert!(d.text.contains("position actual -2"), "{}", d.text);
        // EMCY and SDO with names.
        let e = CanFrame::new(0x083, &[0x11, 0x86, 0x80, 0, 0, 0, 0, 0]).unwrap();
        assert!(
            decode(&e, &dict, &maps)
                .text
                .contains("EMCY 0x8611 following error")
        );
        let r = CanFrame::new(0x603, &[0x40, 0x41, 0x60, 0, 0, 0, 0, 0]).unwrap();
        assert_eq!(
            decode(&r, &dict, &maps).text,
            "SDO read 0x6041:00 statusword"
        );
    }
}
