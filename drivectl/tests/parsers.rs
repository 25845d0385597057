//! The parsers that take user input never panic: EDS text, `INDEX[:SUB]`, typed values, hex
//! bytes; and what `encode` accepts, `decode` gives back.

use drivectl::eds::Eds;
use drivectl::values::{DataType, parse_hex_bytes, parse_object};
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
    fn object_and_hex_parsers_never_panic(s in ".{0,20}") {
        let _ = parse_object(&s);
        let _ = parse_hex_bytes(&s);
        for t in TYPES {
            let _ = DataType::parse(t).map(|ty| ty.encode(&s));
        }
    }

    #[test]
    fn integers_round_trip(v in any::<i32>(), u in any::<u16>()) {
        let t = DataType::I32;
        let bytes = t.encode(&v.to_string()).unwrap();
        prop_assert_eq!(t.decode(&bytes).unwrap().1, serde_json::json!(v));
        let t = DataType::U16;
        let bytes = t.encode(&format!("{u:#x}")).unwrap();
        prop_assert_eq!(t.decode(&bytes).unwrap().1, serde_json::json!(u));
    }
}
