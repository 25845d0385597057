//! Object dictionary indices of the CiA 402 objects this project uses (and the CiA 301 ones a
//! drive must have). Sub-index 0 unless a `*_SUB` constant says otherwise.

/// Abort connection option code (INT16).
pub const ABORT_CONNECTION_OPTION: u16 = 0x6007;
/// Error code of the last fault (UINT16).
pub const ERROR_CODE: u16 = 0x603F;
/// Controlword (UINT16, RPDO-mappable).
pub const CONTROLWORD: u16 = 0x6040;
/// Statusword (UINT16, TPDO-mappable, read-only).
pub const STATUSWORD: u16 = 0x6041;
/// Quick stop option code (INT16).
pub const QUICK_STOP_OPTION: u16 = 0x605A;
/// Shutdown option code (INT16).
pub const SHUTDOWN_OPTION: u16 = 0x605B;
/// Disable operation option code (INT16).
pub const DISABLE_OPERATION_OPTION: u16 = 0x605C;
/// Fault reaction option code (INT16).
pub const FAULT_REACTION_OPTION: u16 = 0x605E;
/// Modes of operation (INT8).
pub const MODES_OF_OPERATION: u16 = 0x6060;
/// Modes of operation display (INT8, read-only).
pub const MODES_OF_OPERATION_DISPLAY: u16 = 0x6061;
/// Position demand value (INT32).
pub const POSITION_DEMAND: u16 = 0x6062;
/// Position actual value (INT32, counts, wraps).
pub const POSITION_ACTUAL: u16 = 0x6064;
/// Following error window (UINT32; 0 or 0xFFFF_FFFF = monitoring off).
pub const FOLLOWING_ERROR_WINDOW: u16 = 0x6065;
/// Following error time-out (UINT16, ms).
pub const FOLLOWING_ERROR_TIMEOUT: u16 = 0x6066;
/// Velocity actual value (INT32).
pub const VELOCITY_ACTUAL: u16 = 0x606C;
/// Target position (INT32, RPDO-mappable).
pub const TARGET_POSITION: u16 = 0x607A;
/// Quick stop deceleration (UINT32).
pub const QUICK_STOP_DECELERATION: u16 = 0x6085;
/// Interpolation time period (record: sub 1 UINT8 value, sub 2 INT8 exponent of 10 s).
pub const INTERPOLATION_TIME_PERIOD: u16 = 0x60C2;
/// 0x60C2 sub 1: the period's mantissa.
pub const INTERPOLATION_TIME_PERIOD_VALUE_SUB: u8 = 1;
/// 0x60C2 sub 2: the period's exponent (seconds = value · 10^exponent).
pub const INTERPOLATION_TIME_PERIOD_INDEX_SUB: u8 = 2;
/// Velocity offset (INT32).
pub const VELOCITY_OFFSET: u16 = 0x60B1;
/// Torque offset (INT16).
pub const TORQUE_OFFSET: u16 = 0x60B2;
/// Following error actual value (INT32).
pub const FOLLOWING_ERROR_ACTUAL: u16 = 0x60F4;
/// Home offset (INT32, position units): the position the home point reads after homing.
pub const HOME_OFFSET: u16 = 0x607C;
/// Polarity (UINT8): bit 7 inverts positions, bit 6 velocities.
pub const POLARITY: u16 = 0x607E;
/// 0x607E value inverting both position and velocity.
pub const POLARITY_INVERTED: u8 = 0xC0;
/// Gear ratio (record: sub 1 motor revolutions, sub 2 shaft revolutions, UINT32).
pub const GEAR_RATIO: u16 = 0x6091;
/// Feed constant (record: sub 1 feed in position units, sub 2 shaft revolutions, UINT32).
pub const FEED_CONSTANT: u16 = 0x6092;
/// Homing method (INT8).
pub const HOMING_METHOD: u16 = 0x6098;
/// Homing speeds (record: sub 1 during search for switch, sub 2 during search for zero,
/// UINT32, velocity units = position units/s).
pub const HOMING_SPEEDS: u16 = 0x6099;
/// Homing acceleration (UINT32, position units/s²).
pub const HOMING_ACCELERATION: u16 = 0x609A;
/// Digital inputs (UINT32): bit 0 negative limit switch, bit 1 positive limit switch, bit 2
/// home switch, bit 3 interlock; 16..=31 manufacturer specific.
pub const DIGITAL_INPUTS: u16 = 0x60FD;
/// Digital outputs (ARRAY): sub 1 physical outputs, sub 2 bit mask (an output follows sub 1
/// only where its mask bit is 1). Bits 16..31 are manufacturer-specific outputs.
pub const DIGITAL_OUTPUTS: u16 = 0x60FE;
/// 0x60FD bit 0.
pub const INPUT_NEGATIVE_LIMIT: u32 = 1 << 0;
/// 0x60FD bit 1.
pub const INPUT_POSITIVE_LIMIT: u32 = 1 << 1;
/// 0x60FD bit 2.
pub const INPUT_HOME_SWITCH: u32 = 1 << 2;
/// Supported drive modes (UINT32, bit `mode - 1`).
pub const SUPPORTED_DRIVE_MODES: u16 = 0x6502;

/// CiA 301 device type (UINT32); a CiA 402 drive reports 0x0192 in the low word.
pub const DEVICE_TYPE: u16 = 0x1000;
/// CiA 301 error register (UINT8).
pub const ERROR_REGISTER: u16 = 0x1001;
/// CiA 301 pre-defined error field (ARRAY of UINT32; sub 0 = number of errors).
pub const PREDEFINED_ERROR_FIELD: u16 = 0x1003;
/// CiA 301 manufacturer device name (VISIBLE_STRING).
pub const DEVICE_NAME: u16 = 0x1008;
/// CiA 301 SYNC COB-ID (UINT32).
pub const SYNC_COB_ID: u16 = 0x1005;
/// CiA 301 communication cycle period (UINT32, µs).
pub const COMMUNICATION_CYCLE_PERIOD: u16 = 0x1006;
/// CiA 301 consumer heartbeat time (ARRAY of UINT32 `(node << 16) | ms`).
pub const CONSUMER_HEARTBEAT_TIME: u16 = 0x1016;
/// CiA 301 producer heartbeat time (UINT16, ms; 0 = off).
pub const PRODUCER_HEARTBEAT_TIME: u16 = 0x1017;
/// CiA 301 identity object (RECORD: 1 vendor, 2 product, 3 revision, 4 serial).
pub const IDENTITY: u16 = 0x1018;
/// RPDO n communication parameter: `RPDO_COMMUNICATION + (n - 1)`.
pub const RPDO_COMMUNICATION: u16 = 0x1400;
/// RPDO n mapping parameter: `RPDO_MAPPING + (n - 1)`.
pub const RPDO_MAPPING: u16 = 0x1600;
/// TPDO n communication parameter: `TPDO_COMMUNICATION + (n - 1)`.
pub const TPDO_COMMUNICATION: u16 = 0x1800;
/// TPDO n mapping parameter: `TPDO_MAPPING + (n - 1)`.
pub const TPDO_MAPPING: u16 = 0x1A00;

/// The device type value of a CiA 402 servo drive (profile 402 = 0x0192, servo = 0x0002).
pub const DEVICE_TYPE_CIA402_SERVO: u32 = 0x0002_0192;
