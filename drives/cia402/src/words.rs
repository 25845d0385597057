//! Controlword (0x6040) and statusword (0x6041) as newtypes with named bits.

/// The controlword 0x6040 the master writes (bits 0..=3 and 7 drive the state machine).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Controlword(pub u16);

impl Controlword {
    /// Bit 0: switch on.
    pub const SWITCH_ON: u16 = 1 << 0;
    /// Bit 1: enable voltage.
    pub const ENABLE_VOLTAGE: u16 = 1 << 1;
    /// Bit 2: quick stop, active low (0 = quick stop requested).
    pub const QUICK_STOP: u16 = 1 << 2;
    /// Bit 3: enable operation.
    pub const ENABLE_OPERATION: u16 = 1 << 3;
    /// Bits 4..=6: operation-mode specific (unused in CSP).
    pub const MODE_SPECIFIC: u16 = 0x0070;
    /// Bit 7: fault reset, acts on its rising edge.
    pub const FAULT_RESET: u16 = 1 << 7;
    /// Bit 8: halt.
    pub const HALT: u16 = 1 << 8;

    /// Shutdown (0x06): → READY TO SWITCH ON.
    pub const SHUTDOWN: Controlword = Controlword(0x0006);
    /// Switch on (0x07): → SWITCHED ON. Same bits as disable operation.
    pub const SWITCH_ON_CMD: Controlword = Controlword(0x0007);
    /// Disable operation (0x07): OPERATION ENABLED → SWITCHED ON.
    pub const DISABLE_OPERATION: Controlword = Controlword(0x0007);
    /// Enable operation (0x0F): → OPERATION ENABLED.
    pub const ENABLE_OPERATION_CMD: Controlword = Controlword(0x000F);
    /// Disable voltage (0x00): → SWITCH ON DISABLED.
    pub const DISABLE_VOLTAGE: Controlword = Controlword(0x0000);
    /// Quick stop (0x02): OPERATION ENABLED → QUICK STOP ACTIVE, else → SWITCH ON DISABLED.
    pub const QUICK_STOP_CMD: Controlword = Controlword(0x0002);
    /// Fault reset (0x80): must follow a word with bit 7 low to be an edge.
    pub const FAULT_RESET_CMD: Controlword = Controlword(0x0080);

    /// The raw 16-bit value.
    pub const fn bits(self) -> u16 {
        self.0
    }
    /// Whether all of `mask` is set.
    pub const fn has(self, mask: u16) -> bool {
        self.0 & mask == mask
    }
    /// This word with `mask` set or cleared.
    pub const fn with(self, mask: u16, on: bool) -> Controlword {
        if on {
            Controlword(self.0 | mask)
        } else {
            Controlword(self.0 & !mask)
        }
    }
    /// Bit 0.
    pub const fn switch_on(self) -> bool {
        self.has(Self::SWITCH_ON)
    }
    /// Bit 1.
    pub const fn enable_voltage(self) -> bool {
        self.has(Self::ENABLE_VOLTAGE)
    }
    /// Bit 2 low = quick stop requested.
    pub const fn quick_stop_requested(self) -> bool {
        !self.has(Self::QUICK_STOP)
    }
    /// Bit 3.
    pub const fn enable_operation(self) -> bool {
        self.has(Self::ENABLE_OPERATION)
    }
    /// Bit 7 (the level; the device acts on its rising edge).
    pub const fn fault_reset(self) -> bool {
        self.has(Self::FAULT_RESET)
    }
    /// Bit 8.
    pub const fn halt(self) -> bool {
        self.has(Self::HALT)
    }
}

/// The statusword 0x6041 the drive reports.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Statusword(pub u16);

impl Statusword {
    /// Bit 0: ready to switch on.
    pub const READY_TO_SWITCH_ON: u16 = 1 << 0;
    /// Bit 1: switched on.
    pub const SWITCHED_ON: u16 = 1 << 1;
    /// Bit 2: operation enabled.
    pub const OPERATION_ENABLED: u16 = 1 << 2;
    /// Bit 3: fault.
    pub const FAULT: u16 = 1 << 3;
    /// Bit 4: voltage enabled.
    pub const VOLTAGE_ENABLED: u16 = 1 << 4;
    /// Bit 5: quick stop, active low (0 = quick stop in progress).
    pub const QUICK_STOP: u16 = 1 << 5;
    /// Bit 6: switch on disabled.
    pub const SWITCH_ON_DISABLED: u16 = 1 << 6;
    /// Bit 7: warning.
    pub const WARNING: u16 = 1 << 7;
    /// Bit 9: remote (the controlword is obeyed).
    pub const REMOTE: u16 = 1 << 9;
    /// Bit 10: target reached.
    pub const TARGET_REACHED: u16 = 1 << 10;
    /// Bit 11: internal limit active.
    pub const INTERNAL_LIMIT: u16 = 1 << 11;
    /// Bit 12 in CSP: drive follows the command value.
    pub const FOLLOWS_COMMAND: u16 = 1 << 12;
    /// Bit 13 in CSP: following error.
    pub const FOLLOWING_ERROR: u16 = 1 << 13;

    /// Mask of the state bits for states decoded with the short mask (0x4F).
    pub const STATE_MASK_SHORT: u16 = 0x004F;
    /// Mask of the state bits for states that also need bit 5 (0x6F).
    pub const STATE_MASK_LONG: u16 = 0x006F;

    /// The raw 16-bit value.
    pub const fn bits(self) -> u16 {
        self.0
    }
    /// Whether all of `mask` is set.
    pub const fn has(self, mask: u16) -> bool {
        self.0 & mask == mask
    }
    /// This word with `mask` set or cleared.
    pub const fn with(self, mask: u16, on: bool) -> Statusword {
        if on {
            Statusword(self.0 | mask)
        } else {
            Statusword(self.0 & !mask)
        }
    }
    /// Bit 3.
    pub const fn fault(self) -> bool {
        self.has(Self::FAULT)
    }
    /// Bit 7.
    pub const fn warning(self) -> bool {
        self.has(Self::WARNING)
    }
    /// Bit 9.
    pub const fn remote(self) -> bool {
        self.has(Self::REMOTE)
    }
    /// Bit 10.
    pub const fn target_reached(self) -> bool {
        self.has(Self::TARGET_REACHED)
    }
    /// Bit 11.
    pub const fn internal_limit(self) -> bool {
        self.has(Self::INTERNAL_LIMIT)
    }
    /// Bit 12 (CSP): the drive follows the command value.
    pub const fn follows_command(self) -> bool {
        self.has(Self::FOLLOWS_COMMAND)
    }
    /// Bit 13 (CSP): following error.
    pub const fn following_error(self) -> bool {
        self.has(Self::FOLLOWING_ERROR)
    }
}
