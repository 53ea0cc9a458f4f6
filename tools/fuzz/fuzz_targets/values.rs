//! The range coder of value blocks (spec §6.9) alone: the input's first two bytes are a value
//! count and the rest coded bytes, which must decode or fail cleanly; then the same bytes read as
//! values of varied magnitude must round-trip through the encoder and decoder. Must never panic.
#![no_main]

use libfuzzer_sys::fuzz_target;
use octowrap_format::fuzzing::{range_code, range_decode};

fuzz_target!(|data: &[u8]| {
    let [a, b, rest @ ..] = data else { return };
    let _ = range_decode(rest, usize::from(u16::from_le_bytes([*a, *b])));
    let values: Vec<u32> = rest
        .chunks(4)
        .map(|c| {
            let mut w = [0u8; 4];
            w[..c.len()].copy_from_slice(c);
            u32::from_le_bytes(w) >> (w[0] % 32)
        })
        .collect();
    let coded = range_code(&values);
    assert_eq!(range_decode(&coded, values.len()).as_deref(), Some(&values[..]), "round trip");
});
