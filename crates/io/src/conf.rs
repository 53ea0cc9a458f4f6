//! Stanford `.conf` scan sets (being written: see the module table in the crate docs).

use std::path::Path;

use crate::{Error, Location, Mesh, ReadOptions, Result};

pub(crate) fn read(_path: &Path, _data: &[u8], _opts: &ReadOptions) -> Result<Mesh> {
    Err(Error::unsupported(Location::Unknown, ".conf reading is not implemented yet"))
}
