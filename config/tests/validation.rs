//! Values that passed validation and failed at run time with a misleading message (issue
//! 18): each is now refused at load, with its key and the line it is on.

use std::path::Path;

use cnc402_config::{ConfigError, MachineConfig};

const SHIPPED: &str = include_str!("../machine.toml");
/// The first axis's `sim` line (since issue 17 it also places the simulated switches).
const X_SIM: &str = "sim = { delay_cycles = 1, bandwidth_hz = 150.0, home_switch = 0.0, limit_switches = [-305.0, 305.0] }";

fn parse(text: &str) -> Result<MachineConfig, ConfigError> {
    MachineConfig::parse(text, Path::new("m.toml"))
}

/// `SHIPPED` with the first `from` replaced by `to` (which must be there).
fn with(from: &str, to: &str) -> String {
    assert!(SHIPPED.contains(from), "{from}");
    SHIPPED.replacen(from, to, 1)
}

/// The error of `text`, checked to name `key` on the line that holds `line_text`.
fn refused(text: &str, key: &str, line_text: &str) -> ConfigError {
    let e = parse(text).unwrap_err();
    assert_eq!(e.key, key, "{e}");
    let line = text
        .lines()
        .position(|l| l.contains(line_text))
        .expect("line_text is in the text")
        + 1;
    assert_eq!(e.line, line, "{e}");
    e
}

#[test]
fn period_us_999_is_not_representable_in_0x60c2() {
    for bad in [999, 1001, 2560, 25_550, 99_999] {
        let text = with("period_us = 1000", &format!("period_us = {bad}"));
        let e = refused(&text, "bus.period_us", "period_us =");
        assert!(e.message.contains("0x60C2"), "{e}");
    }
    // Virtual axes: no drive traffic, so the bus-load plan (busload.rs) accepts every period
    // down to 100 µs and only 0x60C2 decides here.
    let all_virtual = (1..=4).fold(SHIPPED.to_string(), |t, n| {
        t.replacen(&format!("node = {n}\n"), "virtual = true\n", 1)
    });
    for good in [
        100, 125, 250, 255, 500, 1000, 2000, 2500, 4000, 25_500, 100_000,
    ] {
        let text = all_virtual.replacen("period_us = 1000", &format!("period_us = {good}"), 1);
        assert_eq!(parse(&text).unwrap().bus.period_us, good, "{good}");
    }
    // The range message is unchanged.
    let e = parse(&with("period_us = 1000", "period_us = 0")).unwrap_err();
    assert_eq!(e.message, "must be in 100..=100000, got 0");
}

#[test]
fn counts_per_unit_1e300_is_beyond_the_32_bit_position() {
    let text = with(
        "counts_per_unit = 10000      # 0.1 µm",
        "counts_per_unit = 1e300",
    );
    let e = refused(&text, "axis[0].counts_per_unit", "counts_per_unit = 1e300");
    assert!(e.message.contains("32-bit position"), "{e}");
    // ±300 mm at 7 158 278 counts/mm is 2 147 483 400 counts: still fits.
    let text = with(
        "counts_per_unit = 10000      # 0.1 µm",
        "counts_per_unit = 7158278",
    );
    // (its window and velocity still fit too)
    assert!(parse(&text).is_ok(), "{:?}", parse(&text).err());
    let text = with(
        "counts_per_unit = 10000      # 0.1 µm",
        "counts_per_unit = 7158279",
    );
    refused(
        &text,
        "axis[0].counts_per_unit",
        "counts_per_unit = 7158279",
    );
    // A rotary axis: one turn must fit.
    let text = with("counts_per_rev = 131072", "counts_per_unit = 6e6");
    refused(&text, "axis[3].counts_per_unit", "counts_per_unit = 6e6");
}

#[test]
fn counts_per_rev_1_5_is_not_a_whole_number() {
    let text = with("counts_per_rev = 131072", "counts_per_rev = 1.5");
    let e = refused(&text, "axis[3].counts_per_rev", "counts_per_rev = 1.5");
    assert!(e.message.contains("whole number"), "{e}");
    let text = with("counts_per_rev = 131072", "counts_per_rev = 4294967296");
    refused(
        &text,
        "axis[3].counts_per_rev",
        "counts_per_rev = 4294967296",
    );
    let text = with("counts_per_rev = 131072", "counts_per_rev = 131072.0");
    assert!(parse(&text).is_ok());
}

#[test]
fn following_error_window_below_one_count_is_not_supervision_off() {
    // 0.00001 mm at 10 000 counts/mm rounds to 0 counts, which turned the drive's
    // supervision off (0xFFFFFFFF).
    let text = with(
        "following_error_window = 0.5 # mm",
        "following_error_window = 0.00001",
    );
    refused(
        &text,
        "axis[0].following_error_window",
        "following_error_window = 0.00001",
    );
    // 2 counts/rev: a count is 180°, so a 90° window is half a count.
    let text = with("counts_per_rev = 131072", "counts_per_rev = 2");
    refused(
        &text,
        "axis[3].following_error_window",
        "following_error_window = 90.0",
    );
    let text = with(
        "following_error_window = 0.5 # mm",
        "following_error_window = 300000.0",
    );
    refused(
        &text,
        "axis[0].following_error_window",
        "following_error_window = 300000.0",
    );
}

#[test]
fn max_acceleration_1e200_is_above_the_ceiling() {
    let text = with(
        "max_acceleration = 2000.0    # mm/s²",
        "max_acceleration = 1e200",
    );
    let e = refused(
        &text,
        "axis[0].max_acceleration",
        "max_acceleration = 1e200",
    );
    assert!(e.message.contains("at most"), "{e}");
    // Negative: the old message.
    let text = with(
        "max_acceleration = 2000.0    # mm/s²",
        "max_acceleration = -1.0",
    );
    let e = refused(&text, "axis[0].max_acceleration", "max_acceleration = -1.0");
    assert_eq!(e.message, "must be a positive number, got -1");
}

#[test]
fn max_jerk_1e_300_never_reaches_max_velocity() {
    let text = with("max_jerk = 50000.0           # mm/s³", "max_jerk = 1e-300");
    let e = refused(&text, "axis[0].max_jerk", "max_jerk = 1e-300");
    assert!(e.message.contains("to reach from rest"), "{e}");
    // A tiny acceleration is blamed on the acceleration.
    let text = with(
        "max_acceleration = 2000.0    # mm/s²",
        "max_acceleration = 1e-6",
    );
    refused(&text, "axis[0].max_acceleration", "max_acceleration = 1e-6");
    let text = with("max_jerk = 50000.0           # mm/s³", "max_jerk = 1e13");
    refused(&text, "axis[0].max_jerk", "max_jerk = 1e13");
    // 250 mm/s in 2 × sqrt(250 / 1) = 31.6 s: slow, but allowed.
    let text = with("max_jerk = 50000.0           # mm/s³", "max_jerk = 1.0");
    assert!(parse(&text).is_ok());
}

#[test]
fn max_velocity_beyond_a_cycles_32_bit_step_is_refused() {
    for bad in ["1e300", "1e8", "0.00001"] {
        let text = with(
            "max_velocity = 250.0         # mm/s (15 m/min)",
            &format!("max_velocity = {bad}"),
        );
        refused(&text, "axis[0].max_velocity", "max_velocity = ");
    }
}

#[test]
fn max_rpm_above_max_velocity_is_refused_at_load_not_at_the_s_word() {
    let text = with("max_rpm = 6000.0", "max_rpm = 6001.0");
    let e = refused(&text, "axis[3].max_rpm", "max_rpm = 6001.0");
    assert!(e.message.contains("max_velocity / 6"), "{e}");
}

#[test]
fn work_offsets_differing_in_case_are_one_offset_given_twice() {
    let text = with(
        "G59 = { X = 0.0, Y = 0.0, Z = 0.0 }",
        "G59 = { X = 0.0, Y = 0.0, Z = 0.0 }\ng54 = { X = 7.0 }",
    );
    let e = refused(&text, "work_offsets.g54", "g54 = { X = 7.0 }");
    assert!(e.message.contains("same work offset"), "{e}");
    // The lower-case one comes first in the file: the error is still at the later one.
    let text = with("G54 = { X = 0.0,", "g54 = { X = 7.0 }\nG54 = { X = 0.0,");
    refused(&text, "work_offsets.G54", "G54 = { X = 0.0,");
    // Axis letters too.
    let text = with("G55 = { X = 100.0,", "G55 = { x = 1.0, X = 100.0,");
    let e = refused(&text, "work_offsets.G55.X", "G55 = {");
    assert!(e.message.contains("same axis"), "{e}");
    // One spelling alone stays fine.
    let text = with("G55 = { X = 100.0,", "g55 = { x = 100.0,");
    assert_eq!(parse(&text).unwrap().work_offsets[1][0], 100.0);
}

#[test]
fn keys_differing_in_case_are_unknown_keys() {
    let text = with("max_jerk = 40000.0", "Max_jerk = 40000.0");
    let e = refused(&text, "axis[2].Max_jerk", "Max_jerk");
    assert!(e.message.contains("unknown field `Max_jerk`"), "{e}");
    let text = with("[bus]", "[Bus]");
    assert!(parse(&text).is_err());
    let text = with(
        "block_limit = 1000000",
        "block_limit = 1000000\nBlock_limit = 5",
    );
    assert!(parse(&text).unwrap_err().message.contains("unknown field"));
}

#[test]
fn work_offset_1e300_is_beyond_the_32_bit_position() {
    let text = with("G55 = { X = 100.0,", "G55 = { X = 1e300,");
    refused(&text, "work_offsets.G55.X", "G55 = { X = 1e300,");
    let text = with("G55 = { X = 100.0,", "G55 = { X = nan,");
    let e = refused(&text, "work_offsets.G55.X", "G55 = { X = nan,");
    assert_eq!(e.message, "must be finite");
}

#[test]
fn tool_offset_1e300_is_refused() {
    let text = with("length = -180.0", "length = -1e300");
    let e = refused(&text, "tool_offsets.1.length", "length = -1e300");
    assert!(e.message.contains("10000"), "{e}");
}

#[test]
fn sim_as_an_empty_array_is_not_a_table_of_defaults() {
    let text = with(X_SIM, "sim = []");
    let e = refused(&text, "axis[0].sim", "sim = []");
    assert!(e.message.contains("expected a table"), "{e}");
    // An array filled the fields by position.
    let text = with(X_SIM, "sim = [5, 10.0]");
    refused(&text, "axis[0].sim", "sim = [5, 10.0]");
    let text = with("1 = { length = -180.0, radius = 5.0 }", "1 = [-180.0]");
    refused(&text, "tool_offsets.1", "1 = [-180.0]");
    let text = with(X_SIM, "sim = { bandwidth_hz = 1e7 }");
    refused(
        &text,
        "axis[0].sim.bandwidth_hz",
        "sim = { bandwidth_hz = 1e7 }",
    );
}

#[test]
fn variables_file_naming_a_folder_is_refused_at_its_key() {
    let dir = std::env::temp_dir().join(format!("cnc402-config-vf-{}", std::process::id()));
    std::fs::create_dir_all(dir.join("cfg")).unwrap();
    std::fs::create_dir_all(dir.join("var")).unwrap();
    let path = dir.join("cfg/machine.toml");
    std::fs::write(
        &path,
        with(
            "variables_file = \"../var/macro_variables.txt\"",
            "variables_file = \"../var\"",
        ),
    )
    .unwrap();
    let e = MachineConfig::load(&path).unwrap_err();
    assert_eq!(e.key, "interp.variables_file", "{e}");
    assert!(e.message.contains("is a folder"), "{e}");
    assert!(e.line > 0, "{e}");
    // A library_dir that is a file.
    std::fs::write(dir.join("lib.nc"), "").unwrap();
    std::fs::write(
        &path,
        with(
            "library_dir = \"../examples/axioma\"",
            "library_dir = \"../lib.nc\"",
        ),
    )
    .unwrap();
    let e = MachineConfig::load(&path).unwrap_err();
    assert_eq!(e.key, "interp.library_dir", "{e}");
    // Missing files and folders are fine at load.
    std::fs::write(&path, SHIPPED).unwrap();
    assert!(MachineConfig::load(&path).is_ok());
    std::fs::remove_dir_all(&dir).unwrap();
}

#[test]
fn blank_program_dir_is_refused() {
    let text = with("program_dir = \"../examples\"", "program_dir = \"  \"");
    refused(&text, "interp.program_dir", "program_dir = ");
}

#[test]
fn interface_that_is_no_interface_name_is_refused() {
    for bad in ["can0/x", "a very long name1", "can 0"] {
        let text = with("interface = \"sim\"", &format!("interface = \"{bad}\""));
        refused(&text, "bus.interface", "interface = ");
    }
    let text = with("interface = \"sim\"", "interface = \"vcan0\"");
    assert_eq!(parse(&text).unwrap().bus.interface, "vcan0");
}

#[test]
fn interp_lengths_above_a_metre_are_refused() {
    for key in [
        "peck_retract = 0.5",
        "peck_clearance = 0.5",
        "tap_peck_retract = 0.5",
        "arc_tolerance = 0.028284",
        "path_tolerance = 0.01",
    ] {
        let name = key.split(' ').next().unwrap();
        let text = SHIPPED.replace(key, &format!("{name} = 1e300"));
        refused(&text, &format!("interp.{name}"), &format!("{name} = 1e300"));
    }
}

#[test]
fn arc_tolerances_out_of_range_are_refused() {
    let text = SHIPPED.replace(
        "arc_tolerance_relative = 0.001",
        "arc_tolerance_relative = 1.5",
    );
    refused(
        &text,
        "interp.arc_tolerance_relative",
        "arc_tolerance_relative = 1.5",
    );
    let text = SHIPPED.replace("arc_tolerance_inch = 0.0028284", "arc_tolerance_inch = 0");
    refused(&text, "interp.arc_tolerance_inch", "arc_tolerance_inch = 0");
    let cfg = parse(SHIPPED).unwrap();
    assert_eq!(cfg.interp.arc_tolerance_relative, 0.001);
    assert_eq!(cfg.interp.arc_tolerance_inch, 0.0028284);
}

#[test]
fn rotary_reference_beyond_the_32_bit_position_is_refused() {
    let text = with("max_rpm = 6000.0", "max_rpm = 6000.0\nreference = 1e300");
    refused(&text, "axis[3].reference", "reference = 1e300");
}

#[test]
fn hil_and_example_configs_still_load() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    for f in [
        "hil-tests/scenarios/machine-vcan.toml",
        "hil-tests/scenarios/machine-vcan-wrap.toml",
        "hil-tests/scenarios/machine-vcan-tight-fe.toml",
        "examples/axioma/machine.toml",
    ] {
        MachineConfig::load(root.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
    }
}

#[test]
fn interp_dialect_names_a_known_dialect() {
    use cnc402_lang::Dialect;
    assert_eq!(parse(SHIPPED).unwrap().interp.dialect, Dialect::Fanuc);
    for (name, d) in [("haas", Dialect::Haas), ("LinuxCNC", Dialect::LinuxCnc)] {
        let text = with("dialect = \"fanuc\"", &format!("dialect = \"{name}\""));
        assert_eq!(parse(&text).unwrap().interp.dialect, d);
    }
    let text = with("dialect = \"fanuc\"", "dialect = \"sinumerik\"");
    let e = refused(&text, "interp.dialect", "dialect = \"sinumerik\"");
    assert!(e.message.contains("fanuc, haas or linuxcnc"), "{e}");
}

#[test]
fn axis_identity_is_read_and_its_values_are_checked_with_key_and_line() {
    let y = "node = 2\n";
    let text = with(
        y,
        "node = 2\nidentity = { vendor = 0x00C40402, product = 0x1, revision_min = 0x00010000 }\n",
    );
    let cfg = parse(&text).unwrap();
    let id = cfg.axes[1].identity.unwrap();
    assert_eq!(
        (id.vendor, id.product, id.revision_min),
        (0x00C4_0402, Some(1), Some(0x0001_0000))
    );
    assert_eq!(cfg.axes[0].identity, None);
    // Vendor alone is an expectation too.
    let text = with(y, "node = 2\nidentity = { vendor = 154 }\n");
    let id = parse(&text).unwrap().axes[1].identity.unwrap();
    assert_eq!((id.vendor, id.product, id.revision_min), (154, None, None));
    // Values are UNSIGNED32.
    for (bad, key) in [
        ("vendor = 0x100000000", "axis[1].identity.vendor"),
        ("vendor = 1, product = -1", "axis[1].identity.product"),
        (
            "vendor = 1, revision_min = 4294967296",
            "axis[1].identity.revision_min",
        ),
    ] {
        let text = with(y, &format!("node = 2\nidentity = {{ {bad} }}\n"));
        let e = refused(&text, key, "identity =");
        assert!(e.message.contains("0..=4294967295"), "{e}");
    }
    // Unknown keys and a missing vendor are refused on the identity's line.
    for bad in ["vendor = 1, serial_no = 2", "product = 1"] {
        let text = with(y, &format!("node = 2\nidentity = {{ {bad} }}\n"));
        let e = parse(&text).unwrap_err();
        let line = text.lines().position(|l| l.contains("identity =")).unwrap() + 1;
        assert_eq!(e.line, line, "{e}");
    }
}

#[test]
fn identity_on_a_virtual_axis_is_refused() {
    let text = with("node = 2\n", "virtual = true\nidentity = { vendor = 1 }\n");
    let e = refused(&text, "axis[1].identity", "identity =");
    assert!(e.message.contains("virtual"), "{e}");
}

#[test]
fn the_richer_sim_keys_are_read_and_checked_at_their_key() {
    let x = X_SIM;
    let text = with(
        x,
        "sim = { delay_cycles = 2, kv = 150.0, velocity_feedforward = 0.5, max_velocity = 300.0, \
         max_acceleration = 5000.0, encoder_resolution = 0.001 }",
    );
    let s = parse(&text).unwrap().axes[0].sim;
    assert_eq!(s.delay_cycles, 2);
    assert!((s.kv() - 150.0).abs() < 1e-9, "{s:?}");
    assert_eq!(
        (s.velocity_feedforward, s.max_velocity, s.max_acceleration),
        (0.5, 300.0, 5000.0)
    );
    assert_eq!(s.encoder_resolution, 0.001);
    // The master's equivalent: half the ramp lag, twice the bandwidth.
    let m = s.equivalent_model();
    assert_eq!(m.delay_cycles, 2);
    assert!((m.bandwidth_hz - 2.0 * 150.0 / (2.0 * std::f64::consts::PI)).abs() < 1e-9);
    // Absent keys: the first-order model of old (C's `sim` line has no others; X's places
    // the simulated switches since issue 17).
    let plain = parse(SHIPPED).unwrap().axes[3].sim;
    assert_eq!(plain, cnc402_config::SimDynamics::default());
    for (bad, key) in [
        (
            "sim = { bandwidth_hz = 40.0, kv = 250.0 }",
            "axis[0].sim.kv",
        ),
        (
            "sim = { velocity_feedforward = 1.5 }",
            "axis[0].sim.velocity_feedforward",
        ),
        ("sim = { max_velocity = -1.0 }", "axis[0].sim.max_velocity"),
        (
            "sim = { max_acceleration = nan }",
            "axis[0].sim.max_acceleration",
        ),
        // 0.00001 mm at 10000 counts/mm is a tenth of a count: finer than the drive counts.
        (
            "sim = { encoder_resolution = 0.00001 }",
            "axis[0].sim.encoder_resolution",
        ),
        ("sim = { kv = -3.0 }", "axis[0].sim.kv"),
    ] {
        let e = refused(&with(x, bad), key, bad);
        assert!(
            e.message.contains("must") || e.message.contains("not both"),
            "{e}"
        );
    }
}
