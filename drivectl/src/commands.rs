//! The one-shot commands: scan, info, sdo, nmt, the CiA 402 state machine commands, mode,
//! eds and completions. Each prints text (or one JSON document with `--json`) and returns a
//! [`CliError`] in protocol terms when it fails.

use core::time::Duration;
use std::collections::BTreeMap;
use std::path::Path;

use cia402::{Goal, OperationMode, State, Statusword, objects as obj};
use cnc402_drives::bus::CanBus;
use cnc402_drives::master::{
    BlockingSdo, SdoError, SdoErrorKind, TimedBus, emcy_text, send_nmt, sequence_over_sdo,
};
use cnc402_drives::wire::{
    CanFrame, Function, HeartbeatRepr, NmtCommand, NmtState, NmtTarget, NodeId, SdoRequest,
    SdoResponse,
};
use serde_json::{Value as Json, json};

use crate::cli::{Command, ModeArg, NmtCmd, NodeOrAll, SdoCmd, SeqArgs, ShellArg};
use crate::decode::nmt_state_name;
use crate::error::{CliError, Exit, Result};
use crate::link::Link;
use crate::values;
use crate::values::{DataType, ObjectAddr, decode_untyped, hex};
use crate::{Ctx, node_id};

/// Runs one bus command.
pub fn dispatch(ctx: &mut Ctx, cmd: Command) -> Result<()> {
    match cmd {
        Command::Scan { listen_ms, nodes } => scan(ctx, Duration::from_millis(listen_ms), &nodes),
        Command::Info { node } => info(ctx, node),
        Command::Sdo(SdoCmd::Read {
            node,
            object,
            r#type,
        }) => {
            let a = resolve_object(ctx, node, &object)?;
            sdo_read(ctx, node, a, r#type.as_deref())
        }
        Command::Sdo(SdoCmd::Write {
            node,
            object,
            type_and_value,
        }) => {
            let a = resolve_object(ctx, node, &object)?;
            match type_and_value.as_slice() {
                [t, value] => sdo_write(ctx, node, a, Some(t), value),
                [value] => sdo_write(ctx, node, a, None, value),
                _ => Err(CliError::usage("give [TYPE] VALUE")),
            }
        }
        Command::Store { node, yes, restore } => crate::store::store(ctx, node, yes, restore),
        Command::Nmt { command, target } => nmt(ctx, command, target),
        Command::State { node } => state(ctx, node),
        Command::Enable {
            node,
            fault_reset,
            seq,
        } => enable(ctx, node, fault_reset, seq),
        Command::Disable { node, seq } => sequence(ctx, node, Goal::SwitchOnDisabled, seq),
        Command::QuickStop { node, seq } => sequence(ctx, node, Goal::QuickStop, seq),
        Command::FaultReset { node, seq } => fault_reset(ctx, node, seq),
        Command::Mode { node, mode, force } => set_mode(ctx, node, mode, force),
        Command::Jog {
            node,
            velocity,
            duration,
            interrupt_after,
        } => crate::motion::jog(ctx, node, velocity, duration, interrupt_after),
        Command::Move {
            node,
            position,
            interrupt_after,
        } => crate::motion::move_to(ctx, node, position, interrupt_after),
        Command::Identify {
            node,
            amplitude,
            duration,
        } => crate::identify::identify(
            ctx,
            crate::identify::Request {
                node,
                amplitude,
                duration_s: duration,
            },
        ),
        Command::Monitor {
            log,
            duration,
            stats_every,
            quiet,
            read_mapping,
            tui,
        } => {
            if read_mapping {
                crate::monitor::read_mappings(ctx)?;
            }
            if tui {
                crate::monitor::monitor_tui(ctx, log.as_deref(), duration)
            } else {
                crate::monitor::monitor(ctx, log.as_deref(), duration, stats_every, quiet)
            }
        }
        Command::Emcy { duration } => crate::monitor::emcy(ctx, duration),
        Command::Eds { file } => eds_list(&file, ctx.json),
        Command::Completions { shell } => completions(shell),
    }
}

// ---- helpers ---------------------------------------------------------------------------

/// An optional read: an abort becomes `Err(text)` for the printout, a timeout or bus error
/// is a real error (the node went away).
fn optional<T>(r: core::result::Result<T, SdoError>) -> Result<core::result::Result<T, String>> {
    match r {
        Ok(v) => Ok(Ok(v)),
        Err(e) => match e.kind {
            SdoErrorKind::Aborted(code) => Ok(Err(format!("{code}"))),
            SdoErrorKind::WrongSize { expected, got } => {
                Ok(Err(format!("wrong size: {got} bytes, expected {expected}")))
            }
            _ => Err(e.into()),
        },
    }
}

fn opt_json<T: Clone + Into<Json>>(r: &core::result::Result<T, String>) -> Json {
    match r {
        Ok(v) => v.clone().into(),
        Err(e) => json!({ "error": e }),
    }
}

fn opt_text<T>(r: &core::result::Result<T, String>, f: impl Fn(&T) -> String) -> String {
    match r {
        Ok(v) => f(v),
        Err(e) => format!("— ({e})"),
    }
}

/// The named bits of a statusword that are set.
pub fn statusword_bits(sw: Statusword) -> Vec<&'static str> {
    const NAMES: [(u16, &str); 14] = [
        (0, "ready to switch on"),
        (1, "switched on"),
        (2, "operation enabled"),
        (3, "fault"),
        (4, "voltage enabled"),
        (5, "quick stop"),
        (6, "switch on disabled"),
        (7, "warning"),
        (8, "manufacturer specific"),
        (9, "remote"),
        (10, "target reached"),
        (11, "internal limit active"),
        (12, "op-mode specific 12 (CSP: follows command)"),
        (13, "op-mode specific 13 (CSP: following error)"),
    ];
    NAMES
        .iter()
        .filter(|(b, _)| sw.0 & (1 << b) != 0)
        .map(|(_, n)| *n)
        .collect()
}

/// The named bits of the error register 0x1001.
pub fn error_register_bits(r: u8) -> Vec<&'static str> {
    const NAMES: [(u8, &str); 7] = [
        (0, "generic"),
        (1, "current"),
        (2, "voltage"),
        (3, "temperature"),
        (4, "communication"),
        (5, "device profile specific"),
        (7, "manufacturer specific"),
    ];
    NAMES
        .iter()
        .filter(|(b, _)| r & (1 << b) != 0)
        .map(|(_, n)| *n)
        .collect()
}

fn state_json(sw: Statusword) -> Json {
    json!({
        "statusword": sw.0,
        "state": sw.state().map(|s| s.name()),
        "bits": statusword_bits(sw),
    })
}

fn state_text(sw: Statusword) -> String {
    format!("{sw} bits: {}", statusword_bits(sw).join(", "))
}

fn device_type_text(dt: u32) -> String {
    let profile = dt & 0xFFFF;
    if profile == 402 {
        format!(
            "{dt:#010x} (CiA 402 drive, additional info {:#06x})",
            dt >> 16
        )
    } else {
        format!("{dt:#010x} (profile {profile}, not CiA 402)")
    }
}

fn modes_text(m: u32) -> Vec<String> {
    OperationMode::ALL
        .iter()
        .filter(|mode| mode.is_supported_by(m))
        .map(|mode| mode.to_string())
        .collect()
}

fn mode_name(v: i8) -> String {
    match OperationMode::from_i8(v) {
        Some(m) => m.to_string(),
        None if v == 0 => "no mode (0)".to_string(),
        None => format!("manufacturer / unknown ({v})"),
    }
}

// ---- scan ------------------------------------------------------------------------------

fn heartbeat_of(f: &CanFrame) -> Option<(u8, NmtState)> {
    match Function::classify(f.id()) {
        Function::Heartbeat(_) if !f.is_remote() => HeartbeatRepr::parse(f)
            .ok()
            .map(|h| (h.node.get(), h.state)),
        _ => None,
    }
}

fn scan(ctx: &mut Ctx, listen: Duration, only: &[u8]) -> Result<()> {
    let mut heard: BTreeMap<u8, NmtState> = BTreeMap::new();
    let note = |heard: &mut BTreeMap<u8, NmtState>, f: &CanFrame| {
        if let Some((n, s)) = heartbeat_of(f) {
            // A boot-up means the node is now PRE-OPERATIONAL.
            let s = if s == NmtState::BootUp {
                NmtState::PreOperational
            } else {
                s
            };
            heard.insert(n, s);
        }
    };
    // 1. Listen.
    let until = ctx.now() + listen;
    while let Some(f) = ctx.link.recv_until(until)? {
        note(&mut heard, &f);
    }
    // 2. Probe every node at once (0x1000:0 upload), collect answers for the timeout.
    let nodes: Vec<u8> = if only.is_empty() {
        (1..=127).collect()
    } else {
        only.to_vec()
    };
    let answered = probe(ctx, &nodes, &mut heard, &note)?;
    // 3. Identity of every node that answered.
    let mut rows = Vec::new();
    let mut json_nodes = Vec::new();
    for (&n, &dt) in &answered {
        let node = node_id(n)?;
        let (vendor, product, revision, serial, name) = ctx.with_sdo(|sdo| -> Result<_> {
            Ok((
                optional(sdo.read_u32(node, obj::IDENTITY, 1))?,
                optional(sdo.read_u32(node, obj::IDENTITY, 2))?,
                optional(sdo.read_u32(node, obj::IDENTITY, 3))?,
                optional(sdo.read_u32(node, obj::IDENTITY, 4))?,
                optional(sdo.read_string(node, obj::DEVICE_NAME, 0))?,
            ))
        })?;
        for f in std::mem::take(&mut ctx.other) {
            note(&mut heard, &f);
        }
        let nmt = match heard.get(&n) {
            Some(s) => nmt_state_name(*s).to_string(),
            None => "PRE-OPERATIONAL or OPERATIONAL (answers SDO; no heartbeat heard)".into(),
        };
        let dt_text = dt
            .map(device_type_text)
            .unwrap_or_else(|| "— (read aborted)".into());
        rows.push(format!(
            "{:<14} type {}  vendor {}  product {}  rev {}  serial {}  name {}  NMT {}",
            ctx.label(n),
            dt_text,
            opt_text(&vendor, |v| format!("{v:#010x}")),
            opt_text(&product, |v| format!("{v:#010x}")),
            opt_text(&revision, |v| format!("{v:#010x}")),
            opt_text(&serial, |v| format!("{v}")),
            opt_text(&name, |v| format!("\"{v}\"")),
            nmt
        ));
        json_nodes.push(json!({
            "node": n,
            "axis": ctx.names.get(n),
            "device_type": dt,
            "cia402": dt.map(|d| d & 0xFFFF == 402),
            "vendor": opt_json(&vendor),
            "product": opt_json(&product),
            "revision": opt_json(&revision),
            "serial": opt_json(&serial),
            "name": opt_json(&name),
            "nmt": heard.get(&n).map(|s| nmt_state_name(*s)),
        }));
    }
    // Nodes heard but silent on SDO (STOPPED nodes answer no SDO).
    let silent: Vec<u8> = heard
        .keys()
        .copied()
        .filter(|n| !answered.contains_key(n) && (only.is_empty() || only.contains(n)))
        .collect();
    for &n in &silent {
        let s = heard.get(&n).copied().map(nmt_state_name).unwrap_or("?");
        rows.push(format!(
            "{:<14} heartbeat {s}, no SDO answer (STOPPED nodes do not answer SDO)",
            ctx.label(n)
        ));
        json_nodes.push(json!({ "node": n, "axis": ctx.names.get(n), "nmt": s, "sdo": false }));
    }
    if ctx.json {
        ctx.emit_json(&json!({ "iface": ctx.link.name(), "nodes": json_nodes }));
    } else {
        ctx.say(format!(
            "scan on {}: {} node(s) answered SDO, {} more heard only",
            ctx.link.name(),
            answered.len(),
            silent.len()
        ));
        for r in rows {
            ctx.say(r);
        }
    }
    if answered.is_empty() && silent.is_empty() {
        return Err(CliError::timeout(format!(
            "no node answered on {} (probed {} node id(s) by SDO 0x1000, waited {} ms)",
            ctx.link.name(),
            nodes.len(),
            ctx.timeout.as_millis()
        )));
    }
    Ok(())
}

/// Sends an SDO upload of 0x1000:0 to every node at once and collects the answers (the
/// device type, or none where the read aborted) for the timeout; heartbeats go to `note`.
fn probe(
    ctx: &mut Ctx,
    nodes: &[u8],
    heard: &mut BTreeMap<u8, NmtState>,
    note: &impl Fn(&mut BTreeMap<u8, NmtState>, &CanFrame),
) -> Result<BTreeMap<u8, Option<u32>>> {
    let mut answered: BTreeMap<u8, Option<u32>> = BTreeMap::new();
    for &n in nodes {
        let req = SdoRequest::InitiateUpload {
            index: obj::DEVICE_TYPE,
            sub: 0,
        }
        .emit(node_id(n)?);
        ctx.link.send(&req)?;
        // Drain answers while sending so a slow bus does not overflow the receive side.
        while let Some(f) = ctx.link.recv()? {
            take_probe_answer(&f, &mut answered, heard, note);
        }
    }
    let until = ctx.now() + ctx.timeout;
    while let Some(f) = ctx.link.recv_until(until)? {
        take_probe_answer(&f, &mut answered, heard, note);
    }
    Ok(answered)
}

fn take_probe_answer(
    f: &CanFrame,
    answered: &mut BTreeMap<u8, Option<u32>>,
    heard: &mut BTreeMap<u8, NmtState>,
    note: &impl Fn(&mut BTreeMap<u8, NmtState>, &CanFrame),
) {
    if let Function::SdoTx(n) = Function::classify(f.id()) {
        let dt = match SdoResponse::parse_bytes(f.data()) {
            Ok(SdoResponse::InitiateUpload {
                index: obj::DEVICE_TYPE,
                sub: 0,
                kind: cnc402_drives::wire::InitiateKind::Expedited(d),
            }) if d.bytes().len() == 4 => {
                let b = d.bytes();
                Some(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
            }
            _ => None,
        };
        answered.insert(n.get(), dt);
    } else {
        note(heard, f);
    }
}

// ---- info ------------------------------------------------------------------------------

/// A PDO's COB-ID, transmission type and mapping entries, or why it could not be read.
type PdoInfo = core::result::Result<(u32, u8, Vec<u32>), String>;

fn read_pdo(sdo: &mut BlockingSdo<'_, Link>, node: NodeId, comm: u16, map: u16) -> Result<PdoInfo> {
    let cob = optional(sdo.read_u32(node, comm, 1))?;
    let cob = match cob {
        Ok(c) => c,
        Err(e) => return Ok(Err(e)),
    };
    let tt = optional(sdo.read_u8(node, comm, 2))?.unwrap_or(0);
    let n = optional(sdo.read_u8(node, map, 0))?.unwrap_or(0);
    let mut entries = Vec::new();
    for s in 1..=n.min(8) {
        if let Ok(e) = optional(sdo.read_u32(node, map, s))? {
            entries.push(e);
        }
    }
    Ok(Ok((cob, tt, entries)))
}

/// An optional object's value, or why it could not be read.
type Read<T> = core::result::Result<T, String>;

/// What `info` reads from one drive beside the (mandatory) device type.
struct DriveInfo {
    vendor: Read<u32>,
    product: Read<u32>,
    revision: Read<u32>,
    serial: Read<u32>,
    name: Read<String>,
    modes: Read<u32>,
    display: Read<i8>,
    sw: Read<u16>,
    pos: Read<i32>,
    fe: Read<i32>,
    err_reg: Read<u8>,
    err_code: Read<u16>,
    errors: Vec<u32>,
    hb: Read<u16>,
    consumers: Vec<u32>,
    pdos: Vec<(&'static str, u16, PdoInfo)>,
}

/// Sub-indices 1.. of an array object whose sub-index 0 says how many there are (at most 16
/// are read); entries that cannot be read are left out.
fn read_array(sdo: &mut BlockingSdo<'_, Link>, node: NodeId, index: u16) -> Result<Vec<u32>> {
    let mut values = Vec::new();
    if let Ok(k) = optional(sdo.read_u8(node, index, 0))? {
        for s in 1..=k.min(16) {
            if let Ok(v) = optional(sdo.read_u32(node, index, s))? {
                values.push(v);
            }
        }
    }
    Ok(values)
}

impl DriveInfo {
    fn read(sdo: &mut BlockingSdo<'_, Link>, node: NodeId) -> Result<DriveInfo> {
        let vendor = optional(sdo.read_u32(node, obj::IDENTITY, 1))?;
        let product = optional(sdo.read_u32(node, obj::IDENTITY, 2))?;
        let revision = optional(sdo.read_u32(node, obj::IDENTITY, 3))?;
        let serial = optional(sdo.read_u32(node, obj::IDENTITY, 4))?;
        let name = optional(sdo.read_string(node, obj::DEVICE_NAME, 0))?;
        let modes = optional(sdo.read_u32(node, obj::SUPPORTED_DRIVE_MODES, 0))?;
        let display = optional(sdo.read_i8(node, obj::MODES_OF_OPERATION_DISPLAY, 0))?;
        let sw = optional(sdo.read_u16(node, obj::STATUSWORD, 0))?;
        let pos = optional(sdo.read_i32(node, obj::POSITION_ACTUAL, 0))?;
        let fe = optional(sdo.read_i32(node, obj::FOLLOWING_ERROR_ACTUAL, 0))?;
        let err_reg = optional(sdo.read_u8(node, obj::ERROR_REGISTER, 0))?;
        let err_code = optional(sdo.read_u16(node, obj::ERROR_CODE, 0))?;
        let errors = read_array(sdo, node, obj::PREDEFINED_ERROR_FIELD)?;
        let hb = optional(sdo.read_u16(node, obj::PRODUCER_HEARTBEAT_TIME, 0))?;
        let consumers = read_array(sdo, node, obj::CONSUMER_HEARTBEAT_TIME)?;
        let mut pdos = Vec::new();
        for (kind, comm, map) in [
            ("RPDO", obj::RPDO_COMMUNICATION, obj::RPDO_MAPPING),
            ("TPDO", obj::TPDO_COMMUNICATION, obj::TPDO_MAPPING),
        ] {
            for i in 0..4u16 {
                pdos.push((kind, i + 1, read_pdo(sdo, node, comm + i, map + i)?));
            }
        }
        Ok(DriveInfo {
            vendor,
            product,
            revision,
            serial,
            name,
            modes,
            display,
            sw,
            pos,
            fe,
            err_reg,
            err_code,
            errors,
            hb,
            consumers,
            pdos,
        })
    }
}

/// The PDOs as text lines and as JSON values, mapping entries named from the dictionary.
fn pdo_report(
    pdos: &[(&'static str, u16, PdoInfo)],
    dict: &crate::dict::Dictionary,
) -> (Vec<String>, Vec<Json>) {
    let entry_text = |e: u32| {
        let a = ObjectAddr {
            index: (e >> 16) as u16,
            sub: (e >> 8) as u8,
        };
        let bits = e & 0xFF;
        match dict.name(a) {
            Some(nm) => format!("{a} {nm} ({bits} bits)"),
            None => format!("{a} ({bits} bits)"),
        }
    };
    let mut pdo_json = Vec::new();
    let mut pdo_text = Vec::new();
    for (kind, k, p) in pdos {
        match p {
            Ok((cob, tt, entries)) => {
                let valid = cob & 0x8000_0000 == 0;
                let tt_text = match tt {
                    0 => "synchronous acyclic".to_string(),
                    1..=240 => format!("synchronous every {tt} SYNC"),
                    254 | 255 => "event-driven".to_string(),
                    _ => format!("type {tt}"),
                };
                pdo_text.push(format!(
                    "  {kind}{k}: COB-ID {:#05x} {} {tt_text}: {}",
                    cob & 0x7FF,
                    if valid { "valid" } else { "invalid" },
                    if entries.is_empty() {
                        "(nothing mapped)".to_string()
                    } else {
                        entries
                            .iter()
                            .map(|e| entry_text(*e))
                            .collect::<Vec<_>>()
                            .join(", ")
                    }
                ));
                pdo_json.push(json!({
                    "pdo": format!("{kind}{k}"), "cob_id": cob & 0x7FF, "valid": valid,
                    "transmission_type": tt,
                    "mapping": entries.iter().map(|e| json!({
                        "index": e >> 16, "sub": (e >> 8) & 0xFF, "bits": e & 0xFF,
                        "name": dict.name(ObjectAddr { index: (e >> 16) as u16, sub: (e >> 8) as u8 }),
                    })).collect::<Vec<_>>(),
                }));
            }
            Err(e) => {
                pdo_text.push(format!("  {kind}{k}: — ({e})"));
                pdo_json.push(json!({ "pdo": format!("{kind}{k}"), "error": e }));
            }
        }
    }
    (pdo_text, pdo_json)
}

fn info(ctx: &mut Ctx, n: u8) -> Result<()> {
    let node = node_id(n)?;
    // The device type is mandatory: its failure (timeout: absent node) ends the command.
    let dt = ctx.with_sdo(|sdo| sdo.read_u32(node, obj::DEVICE_TYPE, 0))?;
    let info = ctx.with_sdo(|sdo| DriveInfo::read(sdo, node))?;
    // NMT state: from heartbeats that came in while the objects were read (drives with a
    // producer heartbeat), else from the fact that the drive answers SDO.
    let nmt = ctx
        .other
        .iter()
        .rev()
        .filter_map(heartbeat_of)
        .find(|(k, _)| *k == n)
        .map(|(_, s)| match s {
            NmtState::BootUp => "PRE-OPERATIONAL (boot-up seen)",
            s => nmt_state_name(s),
        });
    ctx.other.clear();
    let (pdo_text, pdo_json) = pdo_report(&info.pdos, &ctx.dict);
    if ctx.json {
        ctx.emit_json(&info_json(ctx, n, dt, &info, nmt, pdo_json));
        return Ok(());
    }
    say_info(ctx, n, dt, &info, nmt);
    for l in pdo_text {
        ctx.say(l);
    }
    Ok(())
}

/// `info --json`: one object with every value read (or why it could not be read).
fn info_json(
    ctx: &Ctx,
    n: u8,
    dt: u32,
    info: &DriveInfo,
    nmt: Option<&str>,
    pdo_json: Vec<Json>,
) -> Json {
    json!({
        "node": n,
        "axis": ctx.names.get(n),
        "device_type": dt,
        "cia402": dt & 0xFFFF == 402,
        "vendor": opt_json(&info.vendor),
        "product": opt_json(&info.product),
        "revision": opt_json(&info.revision),
        "serial": opt_json(&info.serial),
        "name": opt_json(&info.name),
        "supported_modes": match &info.modes { Ok(m) => json!({ "raw": m, "modes": modes_text(*m) }), Err(e) => json!({ "error": e }) },
        "mode_display": match &info.display { Ok(d) => json!({ "raw": d, "mode": mode_name(*d) }), Err(e) => json!({ "error": e }) },
        "statusword": match &info.sw { Ok(s) => state_json(Statusword(*s)), Err(e) => json!({ "error": e }) },
        "position_actual": opt_json(&info.pos),
        "following_error_actual": opt_json(&info.fe),
        "error_register": match &info.err_reg { Ok(r) => json!({ "raw": r, "bits": error_register_bits(*r) }), Err(e) => json!({ "error": e }) },
        "error_code": opt_json(&info.err_code),
        "error_history": info.errors.iter().map(|e| json!({ "raw": e, "code": e & 0xFFFF, "text": emcy_text((e & 0xFFFF) as u16), "info": e >> 16 })).collect::<Vec<_>>(),
        "producer_heartbeat_ms": opt_json(&info.hb),
        "nmt": nmt,
        "consumer_heartbeats": info.consumers.iter().map(|c| json!({ "node": (c >> 16) & 0x7F, "ms": c & 0xFFFF })).collect::<Vec<_>>(),
        "pdos": pdo_json,
    })
}

/// `info` as text, up to the "PDO mapping" heading.
fn say_info(ctx: &Ctx, n: u8, dt: u32, info: &DriveInfo, nmt: Option<&str>) {
    ctx.say(format!("{} on {}", ctx.label(n), ctx.link.name()));
    ctx.say(format!("  device type       {}", device_type_text(dt)));
    ctx.say(format!(
        "  identity          vendor {}  product {}  revision {}  serial {}",
        opt_text(&info.vendor, |v| format!("{v:#010x}")),
        opt_text(&info.product, |v| format!("{v:#010x}")),
        opt_text(&info.revision, |v| format!("{v:#010x}")),
        opt_text(&info.serial, |v| v.to_string())
    ));
    ctx.say(format!(
        "  name              {}",
        opt_text(&info.name, |v| format!("\"{v}\""))
    ));
    ctx.say(format!(
        "  supported modes   {}",
        opt_text(&info.modes, |m| format!(
            "{m:#010x}: {}",
            modes_text(*m).join(", ")
        ))
    ));
    ctx.say(format!(
        "  mode display      {}",
        opt_text(&info.display, |d| mode_name(*d))
    ));
    ctx.say(format!(
        "  statusword        {}",
        opt_text(&info.sw, |s| state_text(Statusword(*s)))
    ));
    ctx.say(format!(
        "  position actual   {}",
        opt_text(&info.pos, |p| format!("{p} counts"))
    ));
    ctx.say(format!(
        "  following error   {}",
        opt_text(&info.fe, |p| format!("{p} counts"))
    ));
    ctx.say(format!(
        "  error register    {}",
        opt_text(&info.err_reg, |r| format!(
            "{r:#04x}{}",
            if *r == 0 {
                " (no error)".to_string()
            } else {
                format!(" ({})", error_register_bits(*r).join(", "))
            }
        ))
    ));
    ctx.say(format!(
        "  error code 603F   {}",
        opt_text(&info.err_code, |c| format!("{c:#06x} ({})", emcy_text(*c)))
    ));
    if info.errors.is_empty() {
        ctx.say("  error history     (empty)");
    } else {
        for (i, e) in info.errors.iter().enumerate() {
            ctx.say(format!(
                "  error history [{}] {:#06x} {} (info {:#06x})",
                i + 1,
                e & 0xFFFF,
                emcy_text((e & 0xFFFF) as u16),
                e >> 16
            ));
        }
    }
    ctx.say(format!(
        "  heartbeat         producer {}; consumers {}",
        opt_text(&info.hb, |h| if *h == 0 {
            "off".to_string()
        } else {
            format!("{h} ms")
        }),
        if info.consumers.is_empty() {
            "none".to_string()
        } else {
            info.consumers
                .iter()
                .map(|c| format!("node {} {} ms", (c >> 16) & 0x7F, c & 0xFFFF))
                .collect::<Vec<_>>()
                .join(", ")
        }
    ));
    ctx.say(format!(
        "  NMT state         {}",
        nmt.unwrap_or("PRE-OPERATIONAL or OPERATIONAL (answers SDO; no heartbeat seen)")
    ));
    ctx.say("  PDO mapping");
}

// ---- sdo -------------------------------------------------------------------------------

fn type_for(ctx: &Ctx, a: ObjectAddr, given: Option<&str>) -> Result<Option<DataType>> {
    match given {
        Some(t) => values::parse_type(t).map(Some).ok_or_else(|| {
            CliError::usage(format!(
                "unknown data type `{t}`; expected one of {}",
                crate::values::TYPE_NAMES
            ))
        }),
        None => Ok(ctx.dict.data_type(a)),
    }
}

fn sdo_read(ctx: &mut Ctx, n: u8, a: ObjectAddr, ty: Option<&str>) -> Result<()> {
    let node = node_id(n)?;
    let ty = type_for(ctx, a, ty)?;
    let data = ctx.with_sdo(|sdo| sdo.upload(node, a.index, a.sub))?;
    let (text, val) = match ty {
        Some(t) => values::decode(t, &data)
            .map_err(|e| e.context(format!("{}: SDO read of {a}", ctx.label(n))))?,
        None => decode_untyped(&data),
    };
    let name = ctx.dict.name(a);
    let extra = if a.index == obj::STATUSWORD && data.len() == 2 {
        let sw = Statusword(u16::from_le_bytes([data[0], data[1]]));
        Some(sw)
    } else {
        None
    };
    if ctx.json {
        ctx.emit_json(&json!({
            "node": n, "index": a.index, "sub": a.sub, "name": name,
            "type": ty.map(|t| t.cia_name()), "value": val, "raw": hex(&data),
            "size": data.len(), "state": extra.and_then(|s| s.state()).map(|s| s.name()),
        }));
    } else {
        ctx.say(format!(
            "{} {a}{} = {text}{}{}",
            ctx.label(n),
            name.map(|s| format!(" {s}")).unwrap_or_default(),
            ty.map(|t| format!(" [{}]", t.cia_name()))
                .unwrap_or_else(|| format!(" [{} bytes, type unknown]", data.len())),
            extra
                .map(|s| format!(" — {}", state_text(s)))
                .unwrap_or_default()
        ));
    }
    Ok(())
}

/// The object a command line names for node `n` (hex or a name; see
/// [`Dictionary::resolve`](crate::dict::Dictionary::resolve)): the `--eds` file, else the
/// node's DCF from the config, else the standard objects.
fn resolve_object(ctx: &Ctx, n: u8, text: &str) -> Result<ObjectAddr> {
    let node_eds = ctx
        .cfg
        .axes
        .iter()
        .find(|a| a.node == Some(n))
        .and_then(|a| a.commissioning.eds.as_ref());
    ctx.dict.resolve(node_eds, text)
}

fn sdo_write(ctx: &mut Ctx, n: u8, a: ObjectAddr, ty: Option<&str>, value: &str) -> Result<()> {
    let node = node_id(n)?;
    let t = match type_for(ctx, a, ty)? {
        Some(t) => t,
        None => {
            return Err(CliError::usage(format!(
                "{a}: the type is unknown (not in the EDS/DCF or the standard objects); give \
                 it: drivectl sdo write {n} {a} TYPE {value}"
            )));
        }
    };
    let bytes = values::encode(t, value)?;
    if let Some(known) = ctx.dict.data_type(a)
        && known.size().is_some()
        && known.size() != t.size()
    {
        // Still sent (the drive decides), but said: a size mismatch aborts with 0x06070010.
        ctx.say(format!(
            "note: {a} is {} in the {} dictionary; writing {} bytes as {}",
            known.cia_name(),
            ctx.dict.source(a),
            bytes.len(),
            t.cia_name()
        ));
    }
    ctx.with_sdo(|sdo| sdo.download(node, a.index, a.sub, &bytes))?;
    let name = ctx.dict.name(a);
    if ctx.json {
        ctx.emit_json(&json!({
            "node": n, "index": a.index, "sub": a.sub, "name": name, "type": t.cia_name(),
            "written": hex(&bytes), "size": bytes.len(), "segmented": bytes.len() > 4,
        }));
    } else {
        ctx.say(format!(
            "{} {a}{} ← {value} [{}] ({} bytes, {})",
            ctx.label(n),
            name.map(|s| format!(" {s}")).unwrap_or_default(),
            t.cia_name(),
            bytes.len(),
            if bytes.len() > 4 {
                "segmented"
            } else {
                "expedited"
            }
        ));
    }
    Ok(())
}

// ---- nmt -------------------------------------------------------------------------------

fn nmt(ctx: &mut Ctx, cmd: NmtCmd, target: NodeOrAll) -> Result<()> {
    let command = match cmd {
        NmtCmd::Start => NmtCommand::Start,
        NmtCmd::Stop => NmtCommand::Stop,
        NmtCmd::Preop => NmtCommand::EnterPreOperational,
        NmtCmd::Reset => NmtCommand::ResetNode,
        NmtCmd::ResetComm => NmtCommand::ResetCommunication,
    };
    let t = match target {
        NodeOrAll::All => NmtTarget::All,
        NodeOrAll::Node(n) => NmtTarget::Node(node_id(n)?),
    };
    // Frames queued before the command (e.g. power-on boot-ups) would confirm nothing.
    while ctx.link.recv()?.is_some() {}
    send_nmt(&mut ctx.link, command, t)?;
    let cmd_name = clap::ValueEnum::to_possible_value(&cmd)
        .map(|v| v.get_name().to_string())
        .unwrap_or_default();
    let who = match target {
        NodeOrAll::All => "all nodes".to_string(),
        NodeOrAll::Node(n) => ctx.label(n),
    };
    let expect_boot = matches!(cmd, NmtCmd::Reset | NmtCmd::ResetComm);
    // Listen for boot-ups (resets) or heartbeats confirming the new state.
    let mut seen: BTreeMap<u8, NmtState> = BTreeMap::new();
    let until = ctx.now() + ctx.timeout.max(Duration::from_millis(200));
    while let Some(f) = ctx.link.recv_until(until)? {
        if let Some((n, s)) = heartbeat_of(&f)
            && (target == NodeOrAll::All || target == NodeOrAll::Node(n))
        {
            seen.insert(n, s);
            if let NodeOrAll::Node(_) = target
                && (!expect_boot || s == NmtState::BootUp)
            {
                break;
            }
        }
    }
    let confirmations: Vec<String> = seen
        .iter()
        .map(|(n, s)| format!("{}: {}", ctx.label(*n), nmt_state_name(*s)))
        .collect();
    if ctx.json {
        ctx.emit_json(&json!({
            "command": cmd_name,
            "target": match target { NodeOrAll::All => json!("all"), NodeOrAll::Node(n) => json!(n) },
            "seen": seen.iter().map(|(n, s)| json!({ "node": n, "state": nmt_state_name(*s) })).collect::<Vec<_>>(),
        }));
    } else {
        ctx.say(format!("NMT {cmd_name} sent to {who}"));
        if confirmations.is_empty() {
            ctx.say(
                "  no heartbeat seen to confirm it (drives with producer heartbeat 0 stay silent)",
            );
        }
        for c in confirmations {
            ctx.say(format!("  {c}"));
        }
    }
    if expect_boot
        && let NodeOrAll::Node(n) = target
        && seen.get(&n) != Some(&NmtState::BootUp)
    {
        return Err(CliError::timeout(format!(
            "{}: no boot-up within {} ms after NMT {cmd_name}",
            ctx.label(n),
            ctx.timeout.max(Duration::from_millis(200)).as_millis()
        )));
    }
    Ok(())
}

// ---- CiA 402 state machine -------------------------------------------------------------

fn read_sw(ctx: &mut Ctx, n: u8) -> Result<Statusword> {
    let node = node_id(n)?;
    Ok(Statusword(
        ctx.with_sdo(|sdo| sdo.read_u16(node, obj::STATUSWORD, 0))?,
    ))
}

fn fault_detail(ctx: &mut Ctx, n: u8) -> String {
    let Ok(node) = node_id(n) else {
        return String::new();
    };
    match ctx.with_sdo(|sdo| sdo.read_u16(node, obj::ERROR_CODE, 0)) {
        Ok(c) => format!("error code 0x603F = {c:#06x} ({})", emcy_text(c)),
        Err(e) => format!("error code unreadable: {e}"),
    }
}

fn state(ctx: &mut Ctx, n: u8) -> Result<()> {
    let sw = read_sw(ctx, n)?;
    let node = node_id(n)?;
    let display =
        optional(ctx.with_sdo(|sdo| sdo.read_i8(node, obj::MODES_OF_OPERATION_DISPLAY, 0)))?;
    let fault = if sw.state().is_some_and(State::is_fault) {
        Some(fault_detail(ctx, n))
    } else {
        None
    };
    if ctx.json {
        let mut v = state_json(sw);
        v["node"] = json!(n);
        v["mode_display"] = opt_json(&display);
        v["fault"] = json!(fault);
        ctx.emit_json(&v);
    } else {
        ctx.say(format!("{}: {}", ctx.label(n), state_text(sw)));
        ctx.say(format!(
            "  mode display {}",
            opt_text(&display, |d| mode_name(*d))
        ));
        if let Some(f) = fault {
            ctx.say(format!("  FAULT: {f}"));
        }
    }
    Ok(())
}

fn run_sequence(ctx: &mut Ctx, n: u8, goal: Goal, seq: SeqArgs) -> Result<Statusword> {
    let node = node_id(n)?;
    let label = ctx.label(n);
    let json = ctx.json;
    let mut steps: Vec<Json> = Vec::new();
    let mut last: Option<(u16, u16)> = None;
    let mut polls = 0u32;
    let r = ctx.with_sdo(|sdo| {
        let mut on_step = |sw: Statusword, cw: cia402::Controlword| {
            polls += 1;
            // Print transitions, not every repeated poll (fault reset edges alternate bit 7).
            let key = (sw.0, cw.0 & !0x0080);
            if last == Some(key) {
                return;
            }
            last = Some(key);
            if !json {
                let what = if cw.fault_reset() {
                    "fault reset".to_string()
                } else {
                    cw.command().name().to_string()
                };
                println!(
                    "  step {polls:>3}: {sw} → controlword {:#06x} ({what})",
                    cw.0
                );
            }
            steps.push(json!({
                "step": polls, "statusword": sw.0, "state": sw.state().map(|s| s.name()),
                "controlword": cw.0, "command": cw.command().name(),
            }));
        };
        sequence_over_sdo(
            sdo,
            node,
            goal,
            Duration::from_millis(seq.step_ms.max(1)),
            Duration::from_millis(seq.within_ms),
            &mut on_step,
        )
    });
    match r {
        Ok(sw) => {
            if ctx.json {
                ctx.emit_json(&json!({ "node": n, "goal": goal.to_string(), "reached": true, "statusword": sw.0, "state": sw.state().map(|s| s.name()), "steps": steps }));
            } else {
                ctx.say(format!("{label}: reached {sw}"));
            }
            Ok(sw)
        }
        Err(e) => {
            let mut err = CliError::from(e);
            if err.exit == Exit::DriveState {
                let detail =
                    if read_sw(ctx, n).is_ok_and(|s| s.state().is_some_and(State::is_fault)) {
                        format!("; {}", fault_detail(ctx, n))
                    } else {
                        String::new()
                    };
                err.message = format!("{}{detail}", err.message);
            }
            Err(err)
        }
    }
}

fn sequence(ctx: &mut Ctx, n: u8, goal: Goal, seq: SeqArgs) -> Result<()> {
    if !ctx.json {
        ctx.say(format!("{}: to {goal}", ctx.label(n)));
    }
    run_sequence(ctx, n, goal, seq).map(|_| ())
}

fn enable(ctx: &mut Ctx, n: u8, allow_reset: bool, seq: SeqArgs) -> Result<()> {
    let sw = read_sw(ctx, n)?;
    if sw.state().is_some_and(State::is_fault) && !allow_reset {
        let detail = fault_detail(ctx, n);
        return Err(CliError::state(format!(
            "{}: drive in {} ({detail}); run `drivectl fault-reset {n}` or `drivectl enable {n} --fault-reset`",
            ctx.label(n),
            sw
        )));
    }
    if !ctx.json {
        ctx.say(format!(
            "{}: to OPERATION ENABLED (0x607A set to 0x6064 before enabling operation)",
            ctx.label(n)
        ));
    }
    run_sequence(ctx, n, Goal::OperationEnabled, seq).map(|_| ())
}

fn fault_reset(ctx: &mut Ctx, n: u8, seq: SeqArgs) -> Result<()> {
    let node = node_id(n)?;
    let sw = read_sw(ctx, n)?;
    if !sw.state().is_some_and(State::is_fault) {
        if ctx.json {
            ctx.emit_json(&json!({ "node": n, "was_fault": false, "statusword": sw.0, "state": sw.state().map(|s| s.name()) }));
        } else {
            ctx.say(format!(
                "{}: not in FAULT ({sw}); nothing to reset",
                ctx.label(n)
            ));
        }
        return Ok(());
    }
    let detail = fault_detail(ctx, n);
    if !ctx.json {
        ctx.say(format!("{}: {sw}, {detail}", ctx.label(n)));
        ctx.say("  controlword 0x0000 then 0x0080 (fault reset edge)");
    }
    ctx.with_sdo(|sdo| -> core::result::Result<(), SdoError> {
        sdo.write_u16(node, obj::CONTROLWORD, 0, 0x0000)?;
        sdo.write_u16(node, obj::CONTROLWORD, 0, 0x0080)
    })?;
    let t0 = ctx.now();
    let within = Duration::from_millis(seq.within_ms);
    loop {
        let sw = read_sw(ctx, n)?;
        if !sw.state().is_some_and(State::is_fault) {
            ctx.with_sdo(|sdo| sdo.write_u16(node, obj::CONTROLWORD, 0, 0x0000))?;
            if ctx.json {
                ctx.emit_json(&json!({ "node": n, "was_fault": true, "fault": detail, "statusword": sw.0, "state": sw.state().map(|s| s.name()) }));
            } else {
                ctx.say(format!("{}: fault reset → {sw}", ctx.label(n)));
            }
            return Ok(());
        }
        if ctx.now().saturating_since(t0) > within {
            let now_detail = fault_detail(ctx, n);
            return Err(CliError::state(format!(
                "{}: stuck in FAULT: fault reset edge sent, the fault persists after {} ms ({now_detail}; statusword {:#06x})",
                ctx.label(n),
                within.as_millis(),
                sw.0
            )));
        }
        ctx.with_sdo(|sdo| sdo.wait(Duration::from_millis(seq.step_ms.max(1))))?;
    }
}

// ---- mode ------------------------------------------------------------------------------

fn set_mode(ctx: &mut Ctx, n: u8, m: ModeArg, force: bool) -> Result<()> {
    let node = node_id(n)?;
    let mode = match m {
        ModeArg::Csp => OperationMode::CyclicSyncPosition,
        ModeArg::Csv => OperationMode::CyclicSyncVelocity,
        ModeArg::Pp => OperationMode::ProfilePosition,
        ModeArg::Pv => OperationMode::ProfileVelocity,
        ModeArg::Homing => OperationMode::Homing,
    };
    let supported =
        optional(ctx.with_sdo(|sdo| sdo.read_u32(node, obj::SUPPORTED_DRIVE_MODES, 0)))?;
    if let Ok(s) = supported
        && !mode.is_supported_by(s)
        && !force
    {
        return Err(CliError::state(format!(
            "{}: the drive does not support {mode}: 0x6502 = {s:#010x} ({})",
            ctx.label(n),
            modes_text(s).join(", ")
        )));
    }
    let write = ctx.with_sdo(|sdo| sdo.write_i8(node, obj::MODES_OF_OPERATION, 0, mode.to_i8()));
    if let Err(e) = write {
        let mut err = CliError::from(e);
        if e.abort_code().is_some() {
            err.message = format!(
                "{}: the drive refused {mode}: {}",
                ctx.label(n),
                err.message
            );
        }
        return Err(err);
    }
    // 0x6061 follows when the drive has switched (it may take a few ms).
    let t0 = ctx.now();
    let mut shown;
    loop {
        shown = ctx.with_sdo(|sdo| sdo.read_i8(node, obj::MODES_OF_OPERATION_DISPLAY, 0))?;
        if shown == mode.to_i8() {
            break;
        }
        if ctx.now().saturating_since(t0) > ctx.timeout.max(Duration::from_millis(500)) {
            return Err(CliError::state(format!(
                "{}: 0x6060 = {} written but 0x6061 shows {} (not confirmed)",
                ctx.label(n),
                mode.to_i8(),
                mode_name(shown)
            )));
        }
        ctx.with_sdo(|sdo| sdo.wait(Duration::from_millis(5)))?;
    }
    if ctx.json {
        ctx.emit_json(&json!({ "node": n, "mode": mode.to_i8(), "name": mode.to_string(), "confirmed": true }));
    } else {
        ctx.say(format!(
            "{}: mode {mode} set, confirmed by 0x6061",
            ctx.label(n)
        ));
    }
    Ok(())
}

// ---- eds, completions ------------------------------------------------------------------

/// `drivectl eds FILE`: lists the objects.
pub fn eds_list(path: &Path, json_out: bool) -> Result<()> {
    let eds = crate::eds::load(path)?;
    if json_out {
        let objects: Vec<Json> = eds
            .objects
            .iter()
            .map(|(a, e)| {
                json!({
                    "index": a.index, "sub": a.sub, "name": eds.name(*a),
                    "type": e.data_type().map(|t| t.cia_name()), "type_code": e.data_type_code,
                    "access": e.access, "default": e.default, "value": e.value, "pdo_mapping": e.pdo_mapping,
                })
            })
            .collect();
        println!(
            "{}",
            json!({ "file": path.display().to_string(), "file_info": eds.file_info, "device_info": eds.device_info, "commissioning": eds.commissioning, "objects": objects })
        );
        return Ok(());
    }
    let di = |k: &str| {
        eds.device_info
            .get(k)
            .cloned()
            .unwrap_or_else(|| "?".into())
    };
    println!(
        "{}: {} {} (vendor {}, product {}), {} objects",
        path.display(),
        di("vendorname"),
        di("productname"),
        di("vendornumber"),
        di("productnumber"),
        eds.objects.len()
    );
    for (a, e) in &eds.objects {
        println!(
            "  {a}  {:<45} {:<15} {:<6} {}{}",
            eds.name(*a).unwrap_or_default(),
            e.data_type()
                .map(|t| t.cia_name().to_string())
                .or_else(|| e.data_type_code.map(|c| format!("type {c:#06x}")))
                .unwrap_or_default(),
            e.access.clone().unwrap_or_default(),
            e.value
                .as_ref()
                .map(|v| format!("value {v}"))
                .or_else(|| e.default.as_ref().map(|d| format!("default {d}")))
                .unwrap_or_default(),
            if e.pdo_mapping { "  (PDO)" } else { "" }
        );
    }
    Ok(())
}

/// `drivectl completions SHELL`.
pub fn completions(shell: ShellArg) -> Result<()> {
    use clap::CommandFactory;
    use clap_complete::Shell;
    let sh = match shell {
        ShellArg::Bash => Shell::Bash,
        ShellArg::Zsh => Shell::Zsh,
        ShellArg::Fish => Shell::Fish,
        ShellArg::Elvish => Shell::Elvish,
        ShellArg::Powershell => Shell::PowerShell,
    };
    let mut cmd = crate::cli::Cli::command();
    clap_complete::generate(sh, &mut cmd, "drivectl", &mut std::io::stdout());
    Ok(())
}
