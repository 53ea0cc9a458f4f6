//! XYZ reading and writing (being written: see the module table in the crate docs).

use std::io::Write;

use crate::{Error, Location, Mesh, ReadOptions, Result, WriteOptions};

pub(crate) fn read(_data: &[u8], _opts: &ReadOptions) -> Result<Mesh> {
    Err(Error::unsupported(Location::Unknown, "XYZ reading is not implemented yet"))
}

pub(crate) fn write(_w: &mut dyn Write, _mesh: &Mesh, _opts: &WriteOptions) -> Result<()> {
    Err(Error::unsupported(Location::Unknown, "XYZ writing is not implemented yet"))
}
