//! Any bytes: the decoder must return an error or a hierarchy, never panic, and allocate only
//! within `Limits::strict()`. A successful decode must re-encode and decode to the same topology.
#![no_main]

use libfuzzer_sys::fuzz_target;
use octowrap_format::{DecodeOptions, EncodeOptions, Limits, Quantization, decode, encode};

fuzz_target!(|data: &[u8]| {
    let mut opts = DecodeOptions::default();
    opts.limits = Limits::strict();
    if let Ok(file) = decode(data, &opts) {
        // Round-trip property: exact re-encoding keeps every face and link.
        let again = encode(&file.hierarchy, &EncodeOptions::with_quantization(Quantization::Exact));
        if let Ok(bytes) = again {
            let back = decode(&bytes[..], &DecodeOptions::default()).expect("re-encoded file decodes");
            assert_eq!(back.hierarchy.levels.len(), file.hierarchy.levels.len());
        }
    }
});
