//! Every frame parser on arbitrary frames: never panics, and whatever parses re-emits to a
//! frame that parses to the same value.

use cnc402_drives::master::boot::{RPDO1_LAYOUT, TPDO1_LAYOUT};
use cnc402_drives::wire::{
    CanFrame, EmcyRepr, Function, HeartbeatRepr, MappingEntry, NmtRepr, PdoDirection, PdoLayout,
    PdoMap, PdoObject, PdoValues, SdoRequest, SdoResponse, SyncRepr,
};
use proptest::prelude::*;

fn frame() -> impl Strategy<Value = CanFrame> {
    (0u16..=0x7FF, proptest::collection::vec(any::<u8>(), 0..=8))
        .prop_map(|(id, d)| CanFrame::new(id, &d).unwrap())
}

/// Frames on the ids the parsers look at, so that most of them get past the id check.
fn canopen_frame() -> impl Strategy<Value = CanFrame> {
    let ids = prop_oneof![
        Just(0x000u16),
        Just(0x080),
        0x081u16..=0x0FF,
        0x581u16..=0x5FF,
        0x601u16..=0x67F,
        0x701u16..=0x77F,
    ];
    (ids, proptest::collection::vec(any::<u8>(), 0..=8))
        .prop_map(|(id, d)| CanFrame::new(id, &d).unwrap())
}

fn check(f: &CanFrame) {
    let _ = Function::classify(f.id()).cob_id();
    if let Ok(r) = NmtRepr::parse(f) {
        assert_eq!(NmtRepr::parse(&r.emit()), Ok(r));
    }
    if let Ok(r) = SyncRepr::parse(f) {
        assert_eq!(SyncRepr::parse(&r.emit()), Ok(r));
    }
    if let Ok(r) = EmcyRepr::parse(f) {
        assert_eq!(r.emit(), *f);
    }
    if let Ok(r) = HeartbeatRepr::parse(f) {
        assert_eq!(HeartbeatRepr::parse(&r.emit()), Ok(r));
    }
    if let Ok((n, r)) = SdoRequest::parse(f) {
        assert_eq!(SdoRequest::parse(&r.emit(n)), Ok((n, r)));
    }
    if let Ok((n, r)) = SdoResponse::parse(f) {
        assert_eq!(SdoResponse::parse(&r.emit(n)), Ok((n, r)));
    }
}

proptest! {
    #[test]
    fn any_frame_parses_or_errs_and_round_trips(f in frame()) {
        check(&f);
    }

    #[test]
    fn canopen_ids_parse_or_err_and_round_trip(f in canopen_frame()) {
        check(&f);
    }

    #[test]
    fn pdo_pack_unpack_round_trip(
        bits in proptest::collection::vec(1u8..=32, 1..=8),
        values in proptest::collection::vec(any::<u64>(), 8),
    ) {
        let mut map = PdoMap::new();
        for (i, b) in bits.iter().enumerate() {
            if map.push(MappingEntry::new(0x2000, i as u8 + 1, *b)).is_err() {
                break;
            }
        }
        let mut out = [0u8; 8];
        let n = map.pack(&mut out, |e| values[(e.sub - 1) as usize]);
        prop_assert_eq!(n, map.byte_len());
        let mut k = 0;
        map.unpack(&out[..n], |e, raw| {
            let mask = if e.bits >= 64 { u64::MAX } else { (1u64 << e.bits) - 1 };
            assert_eq!(raw, values[(e.sub - 1) as usize] & mask);
            k += 1;
        }).unwrap();
        prop_assert_eq!(k, map.len());
    }

    /// The master's RPDO1 layout puts controlword then target on the wire exactly as the
    /// hand-packed codec it replaced did (u16 LE, then i32 LE, 6 bytes).
    #[test]
    fn rpdo1_layout_bytes_are_the_hand_packed_ones(cw in any::<u16>(), target in any::<i32>()) {
        let mut hand = [0u8; 6];
        hand[..2].copy_from_slice(&cw.to_le_bytes());
        hand[2..].copy_from_slice(&target.to_le_bytes());
        let v = PdoValues::new()
            .with(PdoObject::Controlword, cw as u64)
            .with(PdoObject::TargetPosition, target as u32 as u64);
        let (d, n) = RPDO1_LAYOUT.pack(&v);
        prop_assert_eq!(&d[..n], &hand[..]);
        prop_assert_eq!(RPDO1_LAYOUT.unpack(&hand), Ok(v));
    }

    /// TPDO1 unpacks any 6 bytes as statusword u16 LE then position i32 LE; other lengths
    /// are refused.
    #[test]
    fn tpdo1_layout_reads_the_hand_packed_fields(d in proptest::collection::vec(any::<u8>(), 0..=8)) {
        match TPDO1_LAYOUT.unpack(&d) {
            Ok(v) => {
                prop_assert_eq!(d.len(), 6);
                let sw = v.get(PdoObject::Statusword).map(|r| r as u16);
                let pos = v.get(PdoObject::PositionActual).map(|r| r as u32 as i32);
                prop_assert_eq!(sw, Some(u16::from_le_bytes([d[0], d[1]])));
                prop_assert_eq!(pos, Some(i32::from_le_bytes([d[2], d[3], d[4], d[5]])));
            }
            Err(_) => prop_assert_ne!(d.len(), 6),
        }
    }

    /// Any layout of known objects either is refused or round-trips, packs as the same
    /// mapping stored as a `PdoMap` does, and never panics on data of any length.
    #[test]
    fn layouts_round_trip_and_agree_with_the_map(
        picks in proptest::collection::vec(0usize..PdoObject::ALL.len(), 0..=9),
        tpdo in any::<bool>(),
        raw in proptest::collection::vec(any::<u64>(), PdoObject::ALL.len()),
        junk in proptest::collection::vec(any::<u8>(), 0..=8),
    ) {
        let entries: Vec<MappingEntry> = picks.iter().map(|&k| PdoObject::ALL[k].entry()).collect();
        let direction = if tpdo { PdoDirection::Tpdo } else { PdoDirection::Rpdo };
        let Ok(layout) = PdoLayout::new(direction, &entries) else {
            return Ok(());
        };
        let mut v = PdoValues::new();
        for f in layout.fields() {
            v = v.with(f.object, raw[PdoObject::ALL.iter().position(|&o| o == f.object).unwrap()]);
        }
        let (d, n) = layout.pack(&v);
        prop_assert_eq!(layout.unpack(&d[..n]), Ok(v));
        let mut via_map = [0u8; 8];
        let m = layout.map().pack(&mut via_map, |e| {
            v.get(PdoObject::at(e.index, e.sub).unwrap()).unwrap()
        });
        prop_assert_eq!((via_map, m), (d, n));
        let _ = layout.unpack(&junk);
    }
}
