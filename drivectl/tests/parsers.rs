//! The parsers that take user input never panic: EDS text, `INDEX[:SUB]`, typed values, hex
//! bytes; and what `encode` accepts, `decode` gives back.

use drivectl::eds::Eds;
use drivectl::values::{DataType, decode, encode, parse_hex_bytes, parse_object, parse_type};
use proptest::prelude::*;

const TYPES: [&str; 13] = [
    "bool", "u8", "u16", "u32", "u64", "i8", "i16", "i32", "i64", "f32", "f64", "string", "bytes",
];

proptest! {
    #[test]
    fn eds_parse_never_panics(text in "(\\[[0-9A-Fa-fsub]{0,8}\\]\n|[A-Za-z]{0,12}=[0-9a-zA-Zx ;]{0,10}\n|;.*\n|\n){0,30}") {
        let _ = Eds::parse(&text);
    }

    #[test]
    fn compact_eds_and_nodeid_values_never_panic(
        n in "[0-9x]{0,5}",
        value in "(\\$NODEID|\\$nodeid|0x[0-9A-F]{0,18}|[0-9]{0,22}|-|\\+| ){0,6}",
        node in proptest::option::of(any::<u8>()),
    ) {
        let text = format!(
            "[1600]\nParameterName=m\nDataType=0x0007\nAccessType=rw\nCompactSubObj={n}\nDefaultValue={value}\n[1600Value]\n1={value}\n"
        );
        if let Ok(eds) = Eds::parse(&text) {
            for a in eds.objects.keys() {
                let _ = eds.encoded_value(*a, node);
            }
        }
        for t in TYPES {
            let _ = parse_type(t).map(|ty| ty.encode_text(&value, node));
        }
        let names = Eds::parse(&text).map(|e| e.lookup_names()).unwrap_or_default();
        let _ = drivectl::eds::find_object(&names, &value);
    }

    #[test]
    fn object_and_hex_parsers_never_panic(s in ".{0,20}") {
        let _ = parse_object(&s);
        let _ = parse_hex_bytes(&s);
        for t in TYPES {
            let _ = parse_type(t).map(|ty| encode(ty, &s));
        }
    }

    #[test]
    fn integers_round_trip(v in any::<i32>(), u in any::<u16>()) {
        let t = DataType::Integer32;
        let bytes = encode(t, &v.to_string()).unwrap();
        prop_assert_eq!(decode(t, &bytes).unwrap().1, serde_json::json!(v));
        let t = DataType::Unsigned16;
        let bytes = encode(t, &format!("{u:#x}")).unwrap();
        prop_assert_eq!(decode(t, &bytes).unwrap().1, serde_json::json!(u));
    }
}

#[test]
fn sub_index_is_hex_like_the_index() {
    use drivectl::values::ObjectAddr;
    for (text, sub) in [
        ("0x1018:10", 0x10),
        ("1018:ff", 0xff),
        ("1018:FF", 0xff),
        ("1018:0x0a", 0x0a),
        ("1018:a", 0x0a),
        ("1018:4", 4),
    ] {
        assert_eq!(
            parse_object(text).unwrap(),
            ObjectAddr { index: 0x1018, sub },
            "{text}"
        );
    }
    for bad in ["1018:100", "1018:-1", "1018:g", "1018:"] {
        assert!(parse_object(bad).is_err(), "{bad}");
    }
}
