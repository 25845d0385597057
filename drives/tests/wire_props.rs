//! Every frame parser on arbitrary frames: never panics, and whatever parses re-emits to a
//! frame that parses to the same value.

use cnc402_drives::wire::{
    CanFrame, EmcyRepr, Function, HeartbeatRepr, MappingEntry, NmtRepr, PdoMap, SdoRequest,
    SdoResponse, SyncRepr,
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
}
