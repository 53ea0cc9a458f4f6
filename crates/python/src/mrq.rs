//! `open_mrq`: an MRQ file read lazily, the preamble first and then a prefix of levels.

use std::path::PathBuf;

use octowrap_format::{DecodeOptions, FileInfo, Limits};
use pyo3::exceptions::PyIndexError;
use pyo3::prelude::*;

use crate::errors;
use crate::hierarchy::{FilePlan, LevelTuple, RawHierarchy, level_tuple};

/// An MRQ file whose preamble has been read and checked.
#[pyclass(frozen, module = "octowrap._octowrap")]
pub struct RawMrq {
    path: PathBuf,
    info: FileInfo,
}

impl RawMrq {
    /// The file's path.
    pub fn path(&self) -> &std::path::Path {
        &self.path
    }

    /// Its format version.
    pub fn version(&self) -> u16 {
        self.info.version
    }

    /// Decodes levels `0..=k` only (the decoder stops reading there), GIL released.
    fn prefix(&self, py: Python<'_>, k: usize) -> PyResult<octowrap_mesh::Hierarchy> {
        let n = self.info.levels.len();
        if k >= n {
            return Err(PyIndexError::new_err(format!("level {k} requested, but the file holds {n} levels")));
        }
        let opts = DecodeOptions::up_to(k as u32);
        let file = py.detach(|| octowrap_format::read_path(&self.path, &opts));
        Ok(file.map_err(|e| errors::decode_error(&e, &self.path))?.hierarchy)
    }

    /// Every level, decoded (GIL released).
    pub fn decode_all(&self, py: Python<'_>) -> PyResult<octowrap_mesh::Hierarchy> {
        self.prefix(py, self.info.levels.len().saturating_sub(1))
    }

    /// What `octowrap export FILE.mrq -o DIR/tileset.json` takes from the file: its units, source
    /// and generator (those not empty) for the tileset's `extras`, and its CRS, if any.
    pub fn tiles_metadata(&self) -> (Vec<(String, String)>, Option<String>) {
        let m = &self.info.metadata;
        let pairs = [("units", &m.units), ("source", &m.source), ("generator", &m.generator)]
            .into_iter()
            .filter(|(_, v)| !v.is_empty())
            .map(|(k, v)| (k.to_owned(), v.clone()))
            .collect();
        let crs = m.entries.iter().find(|(k, _)| k == octowrap_format::CRS_KEY).map(|(_, v)| v.clone());
        (pairs, crs)
    }
}

/// Opens `path`, reading its preamble only (the level table, quantization and metadata).
#[pyfunction]
pub fn open_mrq(py: Python<'_>, path: PathBuf) -> PyResult<RawMrq> {
    let info = py.detach(|| {
        let f = std::fs::File::open(&path)?;
        octowrap_format::read_info(std::io::BufReader::new(f), &Limits::default())
    });
    let info = info.map_err(|e| errors::decode_error(&e, &path))?;
    Ok(RawMrq { path, info })
}

#[pymethods]
impl RawMrq {
    fn __len__(&self) -> usize {
        self.info.levels.len()
    }

    /// The preamble's description as JSON (the `octowrap info --format json` fields).
    fn info_json(&self) -> String {
        serde_json::to_string(&self.info).expect("the file description serializes")
    }

    /// The key-value pairs `octowrap export` records in a glTF file made from this file: its
    /// units, source and generator (those not empty), its further entries, the number of levels,
    /// and the file's name as `source` when it records none.
    fn export_metadata(&self) -> Vec<(String, String)> {
        let m = &self.info.metadata;
        let mut out: Vec<(String, String)> = [("units", &m.units), ("source", &m.source), ("generator", &m.generator)]
            .into_iter()
            .filter(|(_, v)| !v.is_empty())
            .map(|(k, v)| (k.to_owned(), v.clone()))
            .collect();
        out.extend(m.entries.iter().cloned());
        out.push(("levels".to_owned(), self.info.levels.len().to_string()));
        if !out.iter().any(|(k, _)| k == "source") {
            if let Some(name) = self.path.file_name() {
                out.push(("source".to_owned(), name.to_string_lossy().into_owned()));
            }
        }
        out
    }

    /// Level `k`'s arrays, decoding levels `0..=k` only.
    fn level<'py>(&self, py: Python<'py>, k: usize) -> PyResult<LevelTuple<'py>> {
        let h = self.prefix(py, k)?;
        Ok(level_tuple(py, &h.levels[k], None))
    }

    /// Levels `0..=k` (all when `None`) as a hierarchy.
    #[pyo3(signature = (k=None))]
    fn hierarchy(&self, py: Python<'_>, k: Option<usize>) -> PyResult<RawHierarchy> {
        let k = k.unwrap_or_else(|| self.info.levels.len().saturating_sub(1));
        let hierarchy = self.prefix(py, k)?;
        let kinds = vec![None; hierarchy.levels.len()];
        Ok(RawHierarchy { hierarchy, kinds, file: FilePlan::default() })
    }
}
