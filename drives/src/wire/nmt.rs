//! NMT node control (COB-ID 0x000, 2 bytes) and heartbeat / boot-up (0x700 + node, 1 byte).
//! The byte codecs are canopen-rs's (`nmt::decode_command`, `NmtState::from_wire`), wrapped
//! so the rest of the crate does not depend on its types.

use canopen_rs::nmt as co;

use super::{CanFrame, NodeId, WireError};

/// Zero-copy view of an NMT node control frame's data bytes.
#[derive(Clone, Copy, Debug)]
pub struct NmtPacket<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> NmtPacket<T> {
    /// Checks the length (exactly 2).
    pub fn new_checked(buffer: T) -> Result<Self, WireError> {
        if buffer.as_ref().len() != 2 {
            return Err(WireError::BadLength);
        }
        Ok(NmtPacket { buffer })
    }
    /// Byte 0: command specifier.
    pub fn command_byte(&self) -> u8 {
        self.buffer.as_ref()[0]
    }
    /// Byte 1: target node id (0 = all).
    pub fn node_byte(&self) -> u8 {
        self.buffer.as_ref()[1]
    }
}

/// Zero-copy view of a heartbeat / boot-up frame's data byte.
#[derive(Clone, Copy, Debug)]
pub struct HeartbeatPacket<T: AsRef<[u8]>> {
    buffer: T,
}

impl<T: AsRef<[u8]>> HeartbeatPacket<T> {
    /// Checks the length (exactly 1).
    pub fn new_checked(buffer: T) -> Result<Self, WireError> {
        if buffer.as_ref().len() != 1 {
            return Err(WireError::BadLength);
        }
        Ok(HeartbeatPacket { buffer })
    }
    /// Bits 6..0: the NMT state byte.
    pub fn state_byte(&self) -> u8 {
        self.buffer.as_ref()[0] & 0x7F
    }
    /// Bit 7: the node-guarding toggle (0 in heartbeats).
    pub fn toggle(&self) -> bool {
        self.buffer.as_ref()[0] & 0x80 != 0
    }
}

/// An NMT node control command.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NmtCommand {
    /// 0x01 → OPERATIONAL.
    Start,
    /// 0x02 → STOPPED.
    Stop,
    /// 0x80 → PRE-OPERATIONAL.
    EnterPreOperational,
    /// 0x81: reset application and communication.
    ResetNode,
    /// 0x82: reset communication.
    ResetCommunication,
}

impl NmtCommand {
    fn to_co(self) -> co::NmtCommand {
        match self {
            NmtCommand::Start => co::NmtCommand::StartRemoteNode,
            NmtCommand::Stop => co::NmtCommand::StopRemoteNode,
            NmtCommand::EnterPreOperational => co::NmtCommand::EnterPreOperational,
            NmtCommand::ResetNode => co::NmtCommand::ResetNode,
            NmtCommand::ResetCommunication => co::NmtCommand::ResetCommunication,
        }
    }
    fn from_co(c: co::NmtCommand) -> NmtCommand {
        match c {
            co::NmtCommand::StartRemoteNode => NmtCommand::Start,
            co::NmtCommand::StopRemoteNode => NmtCommand::Stop,
            co::NmtCommand::EnterPreOperational => NmtCommand::EnterPreOperational,
            co::NmtCommand::ResetNode => NmtCommand::ResetNode,
            co::NmtCommand::ResetCommunication => NmtCommand::ResetCommunication,
        }
    }
}

/// Whom an NMT command addresses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NmtTarget {
    /// Node id 0: every node.
    All,
    /// One node.
    Node(NodeId),
}

impl NmtTarget {
    /// Whether `node` must act on a command with this target.
    pub fn includes(self, node: NodeId) -> bool {
        match self {
            NmtTarget::All => true,
            NmtTarget::Node(n) => n == node,
        }
    }
}

/// A validated NMT node control message.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct NmtRepr {
    /// The command.
    pub command: NmtCommand,
    /// Its target.
    pub target: NmtTarget,
}

impl NmtRepr {
    /// Parses a frame on COB-ID 0x000 with exactly 2 data bytes.
    ///
    /// ```
    /// use cnc402_drives::wire::{CanFrame, NmtCommand, NmtRepr, NmtTarget};
    /// let r = NmtRepr::parse(&CanFrame::new(0x000, &[0x01, 0x00]).unwrap()).unwrap();
    /// assert_eq!((r.command, r.target), (NmtCommand::Start, NmtTarget::All));
    /// assert!(NmtRepr::parse(&CanFrame::new(0x000, &[0x07, 0x00]).unwrap()).is_err());
    /// ```
    pub fn parse(frame: &CanFrame) -> Result<NmtRepr, WireError> {
        if frame.id() != 0x000 {
            return Err(WireError::WrongCobId(frame.id()));
        }
        let p = NmtPacket::new_checked(frame.data())?;
        let data = [p.command_byte(), p.node_byte()];
        let (command, target) = co::decode_command(&data).map_err(|e| match e {
            canopen_rs::Error::InvalidNodeId => WireError::BadNodeId(data[1]),
            _ => WireError::UnknownCommand(data[0]),
        })?;
        let target = match target.raw() {
            0 => NmtTarget::All,
            n => NmtTarget::Node(NodeId::new(n)?),
        };
        Ok(NmtRepr {
            command: NmtCommand::from_co(command),
            target,
        })
    }

    /// The frame.
    pub fn emit(&self) -> CanFrame {
        let target = match self.target {
            NmtTarget::All => 0,
            NmtTarget::Node(n) => n.get(),
        };
        let mut d = [0u8; 8];
        d[0] = self.command.to_co() as u8;
        d[1] = target;
        CanFrame::from_parts(0x000, d, 2)
    }
}

/// An NMT state as reported in a heartbeat.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NmtState {
    /// 0x00: the boot-up message.
    BootUp,
    /// 0x04.
    Stopped,
    /// 0x05.
    Operational,
    /// 0x7F.
    PreOperational,
}

impl NmtState {
    /// The heartbeat byte.
    pub const fn to_byte(self) -> u8 {
        match self {
            NmtState::BootUp => 0x00,
            NmtState::Stopped => 0x04,
            NmtState::Operational => 0x05,
            NmtState::PreOperational => 0x7F,
        }
    }
}

/// A heartbeat or boot-up message.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct HeartbeatRepr {
    /// The producer.
    pub node: NodeId,
    /// Its state ([`NmtState::BootUp`] = boot-up message).
    pub state: NmtState,
}

impl HeartbeatRepr {
    /// Parses a frame on 0x701..=0x77F with exactly one data byte (bit 7, the node-guarding
    /// toggle, is ignored). Remote frames (node guarding requests) are rejected.
    ///
    /// ```
    /// use cnc402_drives::wire::{CanFrame, HeartbeatRepr, NmtState};
    /// let r = HeartbeatRepr::parse(&CanFrame::new(0x705, &[0x00]).unwrap()).unwrap();
    /// assert_eq!((r.node.get(), r.state), (5, NmtState::BootUp));
    /// ```
    pub fn parse(frame: &CanFrame) -> Result<HeartbeatRepr, WireError> {
        let id = frame.id();
        if id & 0x780 != 0x700 || frame.is_remote() {
            return Err(WireError::WrongCobId(id));
        }
        let node = NodeId::new((id & 0x7F) as u8).map_err(|_| WireError::WrongCobId(id))?;
        let p = HeartbeatPacket::new_checked(frame.data())?;
        let byte = p.state_byte();
        let state = match co::NmtState::from_wire(byte) {
            Ok(co::NmtState::Initialising) => NmtState::BootUp,
            Ok(co::NmtState::Stopped) => NmtState::Stopped,
            Ok(co::NmtState::Operational) => NmtState::Operational,
            Ok(co::NmtState::PreOperational) => NmtState::PreOperational,
            Err(_) => return Err(WireError::UnknownCommand(byte)),
        };
        Ok(HeartbeatRepr { node, state })
    }

    /// The frame.
    pub fn emit(&self) -> CanFrame {
        let mut d = [0u8; 8];
        d[0] = self.state.to_byte();
        CanFrame::from_parts(0x700 + self.node.get() as u16, d, 1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nmt_round_trip_and_bytes() {
        let n3 = NodeId::new(3).unwrap();
        for command in [
            NmtCommand::Start,
            NmtCommand::Stop,
            NmtCommand::EnterPreOperational,
            NmtCommand::ResetNode,
            NmtCommand::ResetCommunication,
        ] {
            for target in [NmtTarget::All, NmtTarget::Node(n3)] {
                let r = NmtRepr { command, target };
                assert_eq!(NmtRepr::parse(&r.emit()), Ok(r));
            }
        }
        let f = NmtRepr {
            command: NmtCommand::Start,
            target: NmtTarget::Node(n3),
        }
        .emit();
        assert_eq!(f.to_string(), "000#0103");
        assert!(
            NmtTarget::All.includes(n3) && !NmtTarget::Node(n3).includes(NodeId::new(4).unwrap())
        );
    }

    #[test]
    fn nmt_malformed() {
        let p = |id, d: &[u8]| NmtRepr::parse(&CanFrame::new(id, d).unwrap());
        assert_eq!(p(0x001, &[1, 0]), Err(WireError::WrongCobId(1)));
        assert_eq!(p(0, &[1]), Err(WireError::BadLength));
        assert_eq!(p(0, &[1, 0, 0]), Err(WireError::BadLength));
        assert_eq!(p(0, &[0x03, 0]), Err(WireError::UnknownCommand(3)));
        assert_eq!(p(0, &[0x01, 0x80]), Err(WireError::BadNodeId(0x80)));
    }

    #[test]
    fn heartbeat_round_trip_and_malformed() {
        let n = NodeId::new(127).unwrap();
        for state in [
            NmtState::BootUp,
            NmtState::Stopped,
            NmtState::Operational,
            NmtState::PreOperational,
        ] {
            let r = HeartbeatRepr { node: n, state };
            assert_eq!(HeartbeatRepr::parse(&r.emit()), Ok(r));
        }
        let boot = HeartbeatRepr {
            node: NodeId::new(1).unwrap(),
            state: NmtState::BootUp,
        }
        .emit();
        assert_eq!(boot.to_string(), "701#00");
        // Toggle bit ignored.
        let f = CanFrame::new(0x705, &[0x85]).unwrap();
        assert_eq!(
            HeartbeatRepr::parse(&f).unwrap().state,
            NmtState::Operational
        );
        let p = |id, d: &[u8]| HeartbeatRepr::parse(&CanFrame::new(id, d).unwrap());
        assert_eq!(p(0x700, &[0]), Err(WireError::WrongCobId(0x700)));
        assert_eq!(p(0x685, &[0]), Err(WireError::WrongCobId(0x685)));
        assert_eq!(p(0x705, &[]), Err(WireError::BadLength));
        assert_eq!(p(0x705, &[5, 0]), Err(WireError::BadLength));
        assert_eq!(p(0x705, &[0x06]), Err(WireError::UnknownCommand(6)));
        let v = HeartbeatPacket::new_checked(&[0x85u8][..]).unwrap();
        assert!(v.toggle() && v.state_byte() == 5);
        let v = NmtPacket::new_checked(&[0x81u8, 7][..]).unwrap();
        assert_eq!((v.command_byte(), v.node_byte()), (0x81, 7));
        assert!(NmtPacket::new_checked(&[1u8][..]).is_err());
        assert!(HeartbeatRepr::parse(&CanFrame::new_remote(0x705, 1).unwrap()).is_err());
    }
}
