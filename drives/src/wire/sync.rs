//! SYNC (COB-ID 0x080): empty, or one counter byte (CiA 301 counter 1..=240). The length check
//! is canopen-rs's `sync::decode`.

use super::{CanFrame, WireError};

/// A validated SYNC message.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct SyncRepr {
    /// The SYNC counter, if the producer sends one.
    pub counter: Option<u8>,
}

impl SyncRepr {
    /// The SYNC COB-ID.
    pub const COB_ID: u16 = 0x080;

    /// Parses a frame on 0x080 with 0 or 1 data byte (a counter of 0 or above 240 is
    /// rejected as invalid).
    ///
    /// ```
    /// use cnc402_drives::wire::{CanFrame, SyncRepr};
    /// assert_eq!(SyncRepr::parse(&CanFrame::new(0x080, &[]).unwrap()).unwrap().counter, None);
    /// assert_eq!(SyncRepr::parse(&CanFrame::new(0x080, &[7]).unwrap()).unwrap().counter, Some(7));
    /// ```
    pub fn parse(frame: &CanFrame) -> Result<SyncRepr, WireError> {
        if frame.id() != Self::COB_ID {
            return Err(WireError::WrongCobId(frame.id()));
        }
        let counter = canopen_rs::sync::decode(frame.data()).map_err(|_| WireError::BadLength)?;
        if let Some(0 | 241..) = counter {
            return Err(WireError::Invalid("SYNC counter outside 1..=240"));
        }
        Ok(SyncRepr { counter })
    }

    /// The frame.
    pub fn emit(&self) -> CanFrame {
        let mut d = [0u8; 8];
        match self.counter {
            Some(c) => {
                d[0] = c;
                CanFrame::from_parts(Self::COB_ID, d, 1)
            }
            None => CanFrame::from_parts(Self::COB_ID, d, 0),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sync_round_trip_and_malformed() {
        for r in [
            SyncRepr { counter: None },
            SyncRepr { counter: Some(1) },
            SyncRepr { counter: Some(240) },
        ] {
            assert_eq!(SyncRepr::parse(&r.emit()), Ok(r));
        }
        assert_eq!(SyncRepr { counter: None }.emit().bits(), 55);
        let p = |id, d: &[u8]| SyncRepr::parse(&CanFrame::new(id, d).unwrap());
        assert_eq!(p(0x081, &[]), Err(WireError::WrongCobId(0x81)));
        assert_eq!(p(0x080, &[1, 2]), Err(WireError::BadLength));
        assert!(p(0x080, &[0]).is_err());
        assert!(p(0x080, &[241]).is_err());
    }
}
