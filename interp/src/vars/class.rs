//! The one classification of macro variable numbers ([`VarClass::of`]), used by both reading
//! and writing: which table or piece of state `#n` addresses, or why it addresses none.

use cnc402_config::TOOL_OFFSETS;

/// What a variable number addresses. Numbers of one range that name nothing on this machine
/// (an axis it lacks, offset 401) are errors of [`VarClass::of`], the same for read and write.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VarClass {
    /// `#0`: always vacant.
    Null,
    /// `#1–#33` of the current call level (index 0..33).
    Local(usize),
    /// `#100–#199` (index 0..100).
    Common(usize),
    /// `#500–#999` (the number).
    NonVolatile(u32),
    /// `#3000` (alarm) and `#3006` (message + stop): the assignment acts; a read is vacant.
    Alarm,
    /// `#4001–#4022`: the code of modal group g.
    GroupCode(u32),
    /// `#4102–#4120`: modal information, `k` = n − 4100 (not every k is one).
    ModalInfo(u32),
    /// `#5001+i`: programmed block end (work coordinates, no tool length offset).
    Programmed(usize),
    /// `#5021+i`: machine position (a sync point).
    MachinePos(usize),
    /// `#5041+i`: work position with the tool length offset (a sync point).
    WorkPos(usize),
    /// `#5081+i`: the tool length offset vector.
    ToolLengthVector(usize),
    /// `#5221+20k+i`: work offset G54+k, axis i.
    WorkOffset { k: usize, axis: usize },
    /// `#2001–#2400`, `#10001–#13400`: a field of tool offset k (1-based).
    ToolOffset { k: usize, field: OffsetField },
    /// No variable of this control.
    Unknown,
}

impl VarClass {
    /// Classifies `#n` on a machine with `naxes` axes.
    pub fn of(n: i64, naxes: usize) -> Result<VarClass, String> {
        let naxes = naxes as i64;
        Ok(match n {
            0 => VarClass::Null,
            1..=33 => VarClass::Local((n - 1) as usize),
            100..=199 => VarClass::Common((n - 100) as usize),
            500..=999 => VarClass::NonVolatile(n as u32),
            3000 | 3006 => VarClass::Alarm,
            4001..=4022 => VarClass::GroupCode((n - 4000) as u32),
            4102..=4120 => VarClass::ModalInfo((n - 4100) as u32),
            5001..=5008 if n - 5001 < naxes => VarClass::Programmed((n - 5001) as usize),
            5081..=5088 if n - 5081 < naxes => VarClass::ToolLengthVector((n - 5081) as usize),
            5021..=5028 if (n - 1) % 20 < naxes => VarClass::MachinePos(((n - 1) % 20) as usize),
            5041..=5048 if (n - 1) % 20 < naxes => VarClass::WorkPos(((n - 1) % 20) as usize),
            5221..=5328 => {
                let (k, axis) = work_offset_var(n, naxes)?;
                VarClass::WorkOffset { k, axis }
            }
            2001..=2400 | 10001..=13999 => match tool_offset_var(n) {
                Some((k, field)) => VarClass::ToolOffset { k, field },
                None => {
                    return Err(format!(
                        "#{n} is not a tool offset of this control (1..400)"
                    ));
                }
            },
            2401..=2800 => return Err(old_d_offset_var(n)),
            _ => VarClass::Unknown,
        })
    }
}

/// `#2401–#2800`: controls differ in whether and how they number the D values (cutter
/// radius) of offsets 1–200 there, so cnc402 maps only `#12001…`/`#13001…` for D; a guessed
/// mapping could write the wrong field. The error says where the D values are.
fn old_d_offset_var(n: i64) -> String {
    format!(
        "#{n} is not a variable of this control: the D (radius) offsets are #13001-#13400 (geometry) and #12001-#12400 (wear); the older #2xxx numbers are H only (#2001-#2200 wear, #2201-#2400 geometry)"
    )
}

/// `#n` in 5221..=5328 as (work offset G54.. index, axis index): `#5221 + 20·k + i`, for
/// k < 6 and i < `naxes`; anything else in the range is an error naming `#n`.
fn work_offset_var(n: i64, naxes: i64) -> Result<(usize, usize), String> {
    let (k, i) = ((n - 5221) / 20, (n - 5221) % 20);
    if !(0..=5).contains(&k) || !(0..naxes).contains(&i) {
        return Err(format!(
            "#{n} is not a work offset variable of this machine"
        ));
    }
    Ok((k as usize, i as usize))
}

/// Which value of a tool offset number `G10 L10–L13` and the `#1xxxx` variables address.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum OffsetField {
    LengthGeometry,
    LengthWear,
    RadiusGeometry,
    RadiusWear,
}

impl OffsetField {
    pub fn get(self, t: &cnc402_config::ToolOffset) -> f64 {
        match self {
            OffsetField::LengthGeometry => t.length,
            OffsetField::LengthWear => t.length_wear,
            OffsetField::RadiusGeometry => t.radius,
            OffsetField::RadiusWear => t.radius_wear,
        }
    }
    pub fn set(self, t: &mut cnc402_config::ToolOffset, v: f64) {
        match self {
            OffsetField::LengthGeometry => t.length = v,
            OffsetField::LengthWear => t.length_wear = v,
            OffsetField::RadiusGeometry => t.radius = v,
            OffsetField::RadiusWear => t.radius_wear = v,
        }
    }
}

/// `#n` as a tool offset variable (Fanuc memory C): `#10001+` H wear, `#11001+` H geometry,
/// `#12001+` D wear, `#13001+` D geometry (offsets 1..400), and the older numbers of a
/// memory C control with up to 200 offsets: `#2001+` H wear, `#2201+` H geometry. `None`:
/// not a tool offset variable.
///
/// ```
/// use cnc402_interp::offsets::{OffsetField, tool_offset_var};
/// assert_eq!(tool_offset_var(11001), Some((1, OffsetField::LengthGeometry)));
/// assert_eq!(tool_offset_var(12400), Some((400, OffsetField::RadiusWear)));
/// assert_eq!(tool_offset_var(2201), Some((1, OffsetField::LengthGeometry)));
/// assert_eq!(tool_offset_var(2200), Some((200, OffsetField::LengthWear)));
/// assert_eq!(tool_offset_var(10401), None);
/// ```
pub fn tool_offset_var(n: i64) -> Option<(usize, OffsetField)> {
    let max = TOOL_OFFSETS as i64;
    let (base, field) = match n {
        2001..=2200 => (2000, OffsetField::LengthWear),
        2201..=2400 => (2200, OffsetField::LengthGeometry),
        _ => match n / 1000 {
            10 => (10000, OffsetField::LengthWear),
            11 => (11000, OffsetField::LengthGeometry),
            12 => (12000, OffsetField::RadiusWear),
            13 => (13000, OffsetField::RadiusGeometry),
            _ => return None,
        },
    };
    let k = n - base;
    (1..=max).contains(&k).then_some((k as usize, field))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn work_offset_vars_name_offset_and_axis() {
        assert_eq!(work_offset_var(5221, 4), Ok((0, 0)));
        assert_eq!(work_offset_var(5243, 4), Ok((1, 2)));
        assert_eq!(work_offset_var(5328, 8), Ok((5, 7)));
        assert!(work_offset_var(5225, 4).unwrap_err().contains("#5225"));
        assert!(work_offset_var(5341, 8).is_err(), "k = 6 is not G54-G59");
    }

    #[test]
    fn read_and_write_share_one_classification() {
        assert_eq!(VarClass::of(1, 4), Ok(VarClass::Local(0)));
        assert_eq!(VarClass::of(5041, 4), Ok(VarClass::WorkPos(0)));
        assert_eq!(VarClass::of(5008, 4), Ok(VarClass::Unknown));
        assert!(VarClass::of(2401, 4).unwrap_err().contains("#13001"));
    }
}
