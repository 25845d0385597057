//! The machine-reference keys (issue 17): `homing`, `polarity`, `gear_ratio`,
//! `feed_constant`, the simulated machine under `sim`, and `[machine] require_homing`; each
//! bad value is refused with its key and line.

use std::path::Path;

use cnc402_config::{ConfigError, Homing, MachineConfig};

const SHIPPED: &str = include_str!("../machine.toml");
/// The first axis's `homing` line, which the tests replace with their keys.
const X_HOMING: &str = "homing = { method = 19, speed_switch = 20.0, speed_zero = 2.0, acceleration = 200.0, offset = 0.0 }";
/// The first axis's `sim` line.
const X_SIM: &str = "sim = { delay_cycles = 1, bandwidth_hz = 150.0, home_switch = 0.0, limit_switches = [-305.0, 305.0] }";

fn parse(text: &str) -> Result<MachineConfig, ConfigError> {
    MachineConfig::parse(text, Path::new("m.toml"))
}

/// The shipped config with the first axis's `homing` line replaced by `extra`.
fn x_with(extra: &str) -> String {
    assert!(SHIPPED.contains(X_HOMING));
    SHIPPED.replacen(X_HOMING, extra, 1)
}

fn refused(text: &str, key: &str, line_text: &str) -> ConfigError {
    let e = parse(text).unwrap_err();
    assert_eq!(e.key, key, "{e}");
    // The first line that holds `line_text` outside a comment.
    let line = text
        .lines()
        .position(|l| !l.starts_with('#') && l.contains(line_text))
        .unwrap()
        + 1;
    assert_eq!(e.line, line, "{e}");
    e
}

const GOOD: &str = "homing = { method = 19, speed_switch = 20.0, speed_zero = 2.0, acceleration = 200.0, offset = -1.5 }";

#[test]
fn a_drive_homing_method_is_read_in_axis_units() {
    let c = parse(&x_with(GOOD)).unwrap();
    let Some(Homing::Drive(h)) = c.axes[0].homing else {
        panic!("{:?}", c.axes[0].homing)
    };
    assert_eq!(h.method.number(), 19);
    assert_eq!(
        (h.speed_switch, h.speed_zero, h.acceleration, h.offset),
        (20.0, 2.0, 200.0, -1.5)
    );
    assert_eq!(h.timeout_s, cnc402_config::DEFAULT_TIMEOUT_S);
    let c = parse(&x_with("homing = { method = 37, offset = 3.0 }")).unwrap();
    assert!(matches!(c.axes[0].homing, Some(Homing::Drive(h)) if h.offset == 3.0));
    let c = parse(&x_with("homing = { absolute = true, offset = 12.25 }")).unwrap();
    assert_eq!(c.axes[0].homing, Some(Homing::Absolute { offset: 12.25 }));
}

#[test]
fn an_unsupported_method_names_the_supported_ones() {
    for bad in [0, 3, 36, 38, -1, 300] {
        let text = x_with(&GOOD.replace("method = 19", &format!("method = {bad}")));
        let e = refused(&text, "axis[0].homing.method", "homing = {");
        assert!(
            e.message
                .contains("supported: 1, 2, 17, 18, 19, 20, 21, 22, 33, 34, 35, 37"),
            "{e}"
        );
    }
}

#[test]
fn homing_values_out_of_range_are_refused_with_their_key() {
    for (from, to, key) in [
        ("speed_switch = 20.0", "speed_switch = 0.0", "speed_switch"),
        (
            "speed_switch = 20.0",
            "speed_switch = 1000.0",
            "speed_switch",
        ),
        ("speed_zero = 2.0", "speed_zero = 30.0", "speed_zero"),
        (
            "acceleration = 200.0",
            "acceleration = -1.0",
            "acceleration",
        ),
        ("offset = -1.5", "offset = 1e300", "offset"),
        (
            "offset = -1.5",
            "offset = -1.5, timeout_s = 0.0",
            "timeout_s",
        ),
        ("offset = -1.5", "offset = -1.5, colour = 1", ""),
    ] {
        let text = x_with(&GOOD.replace(from, to));
        let e = parse(&text).unwrap_err();
        assert!(e.key.ends_with(key), "{to}: {e}");
        assert!(e.key.starts_with("axis[0].homing") || key.is_empty(), "{e}");
        let line = text
            .lines()
            .position(|l| l.starts_with("homing = {"))
            .unwrap()
            + 1;
        assert_eq!(e.line, line, "{e}");
    }
    let e = refused(
        &x_with("homing = { method = 19, speed_zero = 2.0, acceleration = 200.0 }"),
        "axis[0].homing.speed_switch",
        "homing = {",
    );
    assert!(e.message.contains("missing"), "{e}");
    refused(
        &x_with("homing = { absolute = true, method = 19 }"),
        "axis[0].homing.method",
        "homing = {",
    );
    refused(
        &x_with("homing = { offset = 1.0 }"),
        "axis[0].homing.method",
        "homing = {",
    );
    // On a virtual axis the key is checked and unused (no drive to home).
    let virtual_x =
        x_with("homing = { method = 35 }").replacen("node = 1\n", "virtual = true\n", 1);
    assert_eq!(parse(&virtual_x).unwrap().axes[0].homing, None);
    let bad = virtual_x.replacen("method = 35", "method = 36", 1);
    refused(&bad, "axis[0].homing.method", "homing = {");
}

#[test]
fn polarity_gear_ratio_and_feed_constant() {
    let c = parse(&x_with(
        "polarity = \"inverted\"\ngear_ratio = [3, 1]\nfeed_constant = [5000, 1]",
    ))
    .unwrap();
    let x = &c.axes[0];
    assert!(x.polarity_inverted);
    assert_eq!(x.gear_ratio, Some((3, 1)));
    assert_eq!(x.feed_constant, Some((5000, 1)));
    assert!(!c.axes[1].polarity_inverted);
    assert_eq!(c.axes[1].gear_ratio, None);
    refused(
        &x_with("polarity = \"backwards\""),
        "axis[0].polarity",
        "polarity =",
    );
    refused(
        &x_with("gear_ratio = [0, 1]"),
        "axis[0].gear_ratio",
        "gear_ratio =",
    );
    refused(
        &x_with("feed_constant = [1, 4294967296]"),
        "axis[0].feed_constant",
        "feed_constant =",
    );
}

#[test]
fn the_simulated_machine_keys() {
    let text = SHIPPED.replacen(
        X_SIM,
        "sim = { delay_cycles = 1, bandwidth_hz = 150.0, power_on_position = 17.5, home_switch = 5.0, home_switch_active = \"below\", limit_switches = [-290.0, 290.0], index_pulse_counts = 4096 }",
        1,
    );
    let m = parse(&text).unwrap().axes[0].sim.machine;
    assert_eq!(m.power_on_position, 17.5);
    assert_eq!(m.home_switch, Some(5.0));
    assert!(!m.home_switch_above);
    assert_eq!(m.limit_switches, Some((-290.0, 290.0)));
    assert_eq!(m.index_pulse_counts, Some(4096));
    for (from, key) in [
        (
            "limit_switches = [-290.0, 290.0]",
            "limit_switches = [2.0, 1.0]",
        ),
        ("index_pulse_counts = 4096", "index_pulse_counts = 0"),
        (
            "home_switch_active = \"below\"",
            "home_switch_active = \"left\"",
        ),
    ] {
        let bad = text.replacen(from, key, 1);
        let e = parse(&bad).unwrap_err();
        let name = key.split(' ').next().unwrap();
        assert_eq!(e.key, format!("axis[0].sim.{name}"), "{e}");
    }
}

#[test]
fn require_homing_needs_an_axis_with_homing() {
    let text = format!("{SHIPPED}\n[machine]\nrequire_homing = true\n");
    let stripped = text
        .lines()
        .filter(|l| !l.starts_with("homing = {"))
        .collect::<Vec<_>>()
        .join("\n");
    let e = refused(&stripped, "machine.require_homing", "require_homing");
    assert!(e.message.contains("homing"), "{e}");
    let c = parse(&x_with(GOOD).replacen("[bus]", "[machine]\nrequire_homing = true\n\n[bus]", 1))
        .unwrap();
    assert!(c.machine.require_homing);
    assert!(!parse(SHIPPED).unwrap().machine.require_homing);
}

#[test]
fn machine_inputs_estop_and_limit_switches() {
    let text = SHIPPED
        .replacen(
            "[bus]",
            "[machine]\nestop_input = { axis = \"z\", bit = 16 }\n\n[bus]",
            1,
        )
        .replacen(X_HOMING, "limit_switch_inputs = true", 1)
        .replacen(
            X_SIM,
            "sim = { delay_cycles = 1, bandwidth_hz = 150.0, inputs = 0x10000 }",
            1,
        );
    // Two inputs TPDO3s (X's limit switches, Z's E-stop) on top of 4 standard axes at 1 ms
    // overload 1 Mbit/s: the load plan counts them.
    let e = parse(&text).unwrap_err();
    assert_eq!(e.key, "bus.period_us", "{e}");
    assert!(e.message.contains("inputs TPDO3 2×9.5"), "{e}");
    let text = text.replacen("pdo_layout = \"standard\"", "pdo_layout = \"compact\"", 1);
    let c = parse(&text).unwrap();
    assert_eq!(c.machine.estop_input, Some((2, 16)));
    assert!(c.axes[0].inputs_pdo && c.axes[2].inputs_pdo && !c.axes[1].inputs_pdo);
    assert!(c.axes[0].limit_switch_inputs);
    assert!(!c.axes[1].limit_switch_inputs);
    assert_eq!(c.axes[0].sim.machine.inputs, 0x10000);
    for (from, to, key) in [
        ("axis = \"z\"", "axis = \"q\"", "machine.estop_input.axis"),
        ("bit = 16", "bit = 32", "machine.estop_input.bit"),
        ("inputs = 0x10000", "inputs = -1", "axis[0].sim.inputs"),
    ] {
        let e = parse(&text.replacen(from, to, 1)).unwrap_err();
        assert_eq!(e.key, key, "{e}");
    }
    // A virtual axis has no drive to carry the E-stop input.
    let virtual_z = text.replacen("node = 3\n", "virtual = true\n", 1);
    assert_eq!(
        parse(&virtual_z).unwrap_err().key,
        "machine.estop_input.axis"
    );
}
