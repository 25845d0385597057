//! Commissioning at boot against simulated drives: a DCF's parameter values and the config's
//! `sdo` list written after the master's set-up (in order, overriding it), skipped DCF values
//! reported, and a refused write stopping boot with node, object, abort code and config line.

mod master_common;

use std::path::{Path, PathBuf};

use cia402::objects as obj;
use cnc402_config::MachineConfig;
use cnc402_drives::master::{BootError, Phase};
use cnc402_drives::wire::AbortCode;
use master_common::Rig;

const SHIPPED: &str = include_str!("../../config/machine.toml");

const DCF: &str = "\
[DeviceComissioning]
NodeID=1
[1017]
ParameterName=Producer heartbeat time
DataType=0x0006
AccessType=rw
ParameterValue=20
[605A]
ParameterName=Quick stop option code
DataType=0x0003
AccessType=rw
ParameterValue=1
[6085]
ParameterName=Quick stop deceleration
DataType=0x0007
AccessType=rw
ParameterValue=123456
";

/// The shipped config with `extra` after the first axis's `node = 1`, in a fresh folder
/// holding `drives/x.dcf` = `dcf`.
fn config(tag: &str, extra: &str, dcf: &str) -> (MachineConfig, PathBuf) {
    let dir = std::env::temp_dir().join(format!("cnc402-mc-{}-{tag}", std::process::id()));
    std::fs::create_dir_all(dir.join("drives")).unwrap();
    std::fs::write(dir.join("drives/x.dcf"), dcf).unwrap();
    let text = SHIPPED.replacen("node = 1\n", &format!("node = 1\n{extra}\n"), 1);
    let path = dir.join("machine.toml");
    std::fs::write(&path, &text).unwrap();
    (MachineConfig::load(&path).unwrap(), path)
}

fn line_of(path: &Path, needle: &str) -> usize {
    std::fs::read_to_string(path)
        .unwrap()
        .lines()
        .position(|l| l.contains(needle))
        .unwrap()
        + 1
}

#[test]
fn dcf_values_then_the_sdo_list_are_written_after_the_masters_set_up() {
    let (cfg, _) = config(
        "ok",
        "dcf = \"drives/x.dcf\"\nsdo = [ { index = 0x6065, value = 2000, type = \"u32\" }, \
         { object = \"Quick stop option code\", value = 6 } ]",
        DCF,
    );
    let mut rig = Rig::for_machine(cfg);
    let report = rig.boot();
    assert_eq!(rig.master.phase(), Phase::Running);
    let od = rig.drive(0).od();
    // The explicit entry overrides the window the master wrote from the axis config.
    assert_eq!(od.get_u64(obj::FOLLOWING_ERROR_WINDOW, 0), Some(2000));
    // The DCF wrote 1, the list 6 after it.
    assert_eq!(od.get_i64(obj::QUICK_STOP_OPTION, 0), Some(6));
    assert_eq!(od.get_u64(obj::QUICK_STOP_DECELERATION, 0), Some(123456));
    // 0x1017 is the master's: the DCF's 20 ms is skipped, the config's 50 ms stays.
    assert_eq!(od.get_u64(obj::PRODUCER_HEARTBEAT_TIME, 0), Some(50));
    let x = &report.drives[0];
    assert_eq!(x.commissioning_writes, 4);
    assert_eq!(x.skipped_parameters.len(), 1);
    assert_eq!(x.skipped_parameters[0].index, 0x1017);
    assert!(x.skipped_parameters[0].origin.contains("x.dcf:3"));
    // The other drives are untouched.
    let y = rig.drive(1).od();
    assert_ne!(y.get_u64(obj::QUICK_STOP_DECELERATION, 0), Some(123456));
    assert_eq!(report.drives[1].commissioning_writes, 0);
}

#[test]
fn a_refused_write_stops_boot_naming_node_object_abort_and_config_line() {
    // 0x6064 is read-only in the drive; the config does not know (no DCF).
    let (cfg, path) = config(
        "refused",
        "sdo = [ { index = 0x6085, value = 1000, type = \"u32\" },\n  \
         { index = 0x6064, value = 5, type = \"i32\" } ]",
        DCF,
    );
    let mut rig = Rig::for_machine(cfg);
    let e = rig.master.boot(&mut rig.bus).unwrap_err();
    let line = line_of(&path, "index = 0x6064");
    match &e {
        BootError::Commissioning { axis, write, error } => {
            assert_eq!(*axis, 'X');
            assert_eq!((write.index, write.sub), (0x6064, 0));
            assert!(write.origin.ends_with(&format!("machine.toml:{line}")));
            assert_eq!(error.node, 1);
            assert_eq!(error.abort_code(), Some(AbortCode::WriteReadOnly));
        }
        other => panic!("{other}"),
    }
    let text = e.to_string();
    assert!(text.contains(&format!("machine.toml:{line}")), "{text}");
    assert!(
        text.contains("node 1") && text.contains("0x6064:00"),
        "{text}"
    );
    assert!(text.contains("0x06010002"), "{text}");
    // The write before it was made.
    assert_eq!(
        rig.drive(0).od().get_u64(obj::QUICK_STOP_DECELERATION, 0),
        Some(1000)
    );
}

#[test]
fn an_unknown_object_is_refused_with_its_abort_code() {
    let (cfg, _) = config(
        "unknown",
        "sdo = [ { index = 0x2000, sub = 3, value = 1, type = \"u8\" } ]",
        DCF,
    );
    let mut rig = Rig::for_machine(cfg);
    let e = rig.master.boot(&mut rig.bus).unwrap_err();
    assert!(
        matches!(&e, BootError::Commissioning { error, .. } if error.abort_code() == Some(AbortCode::NoObject)),
        "{e}"
    );
}
