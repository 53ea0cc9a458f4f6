//! E57 reading (being written: see the module table in the crate docs).

use crate::{Error, Location, Mesh, ReadOptions, Result};

pub(crate) fn read(_data: &[u8], _opts: &ReadOptions) -> Result<Mesh> {
    Err(Error::unsupported(Location::Unknown, "E57 reading is not implemented yet"))
}
