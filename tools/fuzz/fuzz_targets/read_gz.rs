//! The gzip path: the first byte picks a format; with its high bit clear the rest is gzipped here
//! (so the fuzzer mutates the decompressed content), with it set the rest is fed as it is (so it
//! mutates the gzip framing itself). Same properties as the per-format targets.
#![no_main]

use std::io::Write;

use libfuzzer_sys::fuzz_target;
use octowrap_fuzz::read_as;
use octowrap_io::Format;

const FORMATS: [Format; 9] = [
    Format::Ply,
    Format::Obj,
    Format::Off,
    Format::Stl,
    Format::Xyz,
    Format::Pcd,
    Format::Las,
    Format::E57,
    Format::Exr,
];

fuzz_target!(|data: &[u8]| {
    let Some((&pick, rest)) = data.split_first() else { return };
    let format = FORMATS[usize::from(pick & 0x7f) % FORMATS.len()];
    let name = format!("fuzz.{}.gz", format.name());
    if pick & 0x80 != 0 {
        let _ = read_as(rest, format, &name);
    } else {
        let mut e = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::fast());
        e.write_all(rest).expect("writing to memory");
        let gz = e.finish().expect("writing to memory");
        let _ = read_as(&gz, format, &name);
    }
});
