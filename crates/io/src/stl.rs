//! STL reading and writing (being written: see the module table in the crate docs).

use std::io::Write;

use crate::{Error, Location, Mesh, ReadOptions, Result, WriteOptions};

pub(crate) fn read(_data: &[u8], _opts: &ReadOptions) -> Result<Mesh> {
    Err(Error::unsupported(Location::Unknown, "STL reading is not implemented yet"))
}

pub(crate) fn write(_w: &mut dyn Write, _mesh: &Mesh, _opts: &WriteOptions) -> Result<()> {
    Err(Error::unsupported(Location::Unknown, "STL writing is not implemented yet"))
}

/// Whether `data` is a binary STL: an 80-byte header, a triangle count, and exactly 50 bytes per
/// triangle after it. (An ASCII STL starts with `solid`, but so do some binary ones.)
pub(crate) fn looks_binary(data: &[u8]) -> bool {
    if data.len() < 84 {
        return false;
    }
    let n = u32::from_le_bytes([data[80], data[81], data[82], data[83]]) as u64;
    84 + 50 * n == data.len() as u64
}
