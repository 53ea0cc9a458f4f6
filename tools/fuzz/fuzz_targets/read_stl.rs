//! Any bytes read as STL through `octowrap_io::read_from` (the CLI's entry point): never panics,
//! never allocates past the 256 MiB ceiling, and a successful read keeps its promises.
#![no_main]

use libfuzzer_sys::fuzz_target;
use octowrap_fuzz::read_as;
use octowrap_io::Format;

fuzz_target!(|data: &[u8]| {
    let _ = read_as(data, Format::Stl, "fuzz.stl");
});
