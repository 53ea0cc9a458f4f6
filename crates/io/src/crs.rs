//! The coordinate reference system a point-cloud file declares, for georeferenced output.
//!
//! * LAS/LAZ/COPC (ASPRS LAS 1.4 R15, §2.5-2.6 and §2.8-2.9): the `LASF_Projection` records, in
//!   VLRs or EVLRs: OGC WKT (record 2112) first; otherwise the `GeoTIFF` key directory (record
//!   34735), whose `ProjectedCSTypeGeoKey` (3072) or else `GeographicTypeGeoKey` (2048) names an
//!   EPSG code (32767, user-defined, names none).
//! * E57 (ASTM E2807, §8.4.3): the root's `coordinateMetadata` string, as the file gives it (WKT,
//!   or an `EPSG:` code).
//!
//! Records are walked from the header's own counts and offsets, each checked against the file's
//! length before it is read: a hostile header gives an error naming the offset, never a panic.

use std::io::Cursor;

use crate::{Error, Format, Location, Result};

/// A declared CRS.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Crs {
    /// OGC WKT (WKT1 or WKT2), as stored.
    Wkt(String),
    /// An EPSG code.
    Epsg(u16),
}

impl Crs {
    /// The text stored in MRQ metadata and given to projection libraries: the WKT, or `EPSG:N`.
    pub fn to_text(&self) -> String {
        match self {
            Self::Wkt(w) => w.clone(),
            Self::Epsg(c) => format!("EPSG:{c}"),
        }
    }
}

const USER_ID: &[u8] = b"LASF_Projection";
const WKT_RECORD: u16 = 2112;
const GEOKEYS_RECORD: u16 = 34735;

fn le16(d: &[u8], at: usize) -> Option<u16> {
    d.get(at..at + 2).map(|b| u16::from_le_bytes([b[0], b[1]]))
}

fn le32(d: &[u8], at: usize) -> Option<u32> {
    d.get(at..at + 4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
}

fn le64(d: &[u8], at: usize) -> Option<u64> {
    d.get(at..at + 8).map(|b| u64::from_le_bytes(b.try_into().expect("8 bytes")))
}

fn short(at: usize, what: &str) -> Error {
    Error::invalid(Location::Byte(at as u64), format!("{what} runs past the end of the file"))
}

/// The CRS a file of `format` declares (`None` for formats that carry none, or files without one).
pub fn read_crs(data: &[u8], format: Format) -> Result<Option<Crs>> {
    match format {
        Format::Las => las_crs(data),
        Format::E57 => {
            let reader = ::e57::E57Reader::new(Cursor::new(data))
                .map_err(|e| Error::invalid(Location::Unknown, format!("cannot read the E57 header and XML: {e}")))?;
            Ok(reader.coordinate_metadata().map(str::trim).filter(|s| !s.is_empty()).map(|s| Crs::Wkt(s.to_owned())))
        }
        _ => Ok(None),
    }
}

/// A record: user id, record id, payload.
struct Record<'a> {
    user: &'a [u8],
    id: u16,
    data: &'a [u8],
}

fn las_crs(d: &[u8]) -> Result<Option<Crs>> {
    if d.get(..4) != Some(b"LASF") {
        return Err(Error::invalid(Location::Byte(0), "not a LAS file (no LASF signature)"));
    }
    let header = le16(d, 94).ok_or_else(|| short(94, "the public header block"))? as usize;
    let count = le32(d, 100).ok_or_else(|| short(100, "the public header block"))?;
    let mut records = Vec::new();
    let mut at = header;
    for _ in 0..count {
        let len = le16(d, at + 20).ok_or_else(|| short(at, "a VLR header"))? as usize;
        let data = d.get(at + 54..at + 54 + len).ok_or_else(|| short(at, "a VLR"))?;
        records.push(Record { user: &d[at + 2..at + 18], id: le16(d, at + 18).unwrap_or(0), data });
        at += 54 + len;
    }
    // LAS 1.4: extended VLRs after the points.
    if d.get(25) == Some(&4) && header >= 375 {
        let mut at = le64(d, 235).ok_or_else(|| short(235, "the public header block"))?;
        let count = le32(d, 243).ok_or_else(|| short(243, "the public header block"))?;
        for _ in 0..count {
            if at == 0 {
                break;
            }
            let start = usize::try_from(at).map_err(|_| short(235, "an EVLR"))?;
            let len = le64(d, start + 20).ok_or_else(|| short(start, "an EVLR header"))?;
            let end = usize::try_from(len)
                .ok()
                .and_then(|l| (start + 60).checked_add(l))
                .ok_or_else(|| short(start, "an EVLR"))?;
            let data = d.get(start + 60..end).ok_or_else(|| short(start, "an EVLR"))?;
            records.push(Record { user: &d[start + 2..start + 18], id: le16(d, start + 18).unwrap_or(0), data });
            at = end as u64;
        }
    }
    let projection = |r: &&Record| r.user.split(|&b| b == 0).next() == Some(USER_ID);
    if let Some(r) = records.iter().filter(projection).find(|r| r.id == WKT_RECORD) {
        let text = String::from_utf8_lossy(r.data.split(|&b| b == 0).next().unwrap_or_default()).trim().to_owned();
        if !text.is_empty() {
            return Ok(Some(Crs::Wkt(text)));
        }
    }
    if let Some(r) = records.iter().filter(projection).find(|r| r.id == GEOKEYS_RECORD) {
        return Ok(geokey_epsg(r.data).map(Crs::Epsg));
    }
    Ok(None)
}

/// The EPSG code of a `GeoTIFF` key directory: projected first, then geographic.
fn geokey_epsg(d: &[u8]) -> Option<u16> {
    let keys = usize::from(le16(d, 6)?);
    let value = |wanted: u16| {
        (0..keys).find_map(|k| {
            let at = 8 + 8 * k;
            let (id, location, value) = (le16(d, at)?, le16(d, at + 2)?, le16(d, at + 6)?);
            (id == wanted && location == 0 && value != 0 && value != 32767).then_some(value)
        })
    };
    value(3072).or_else(|| value(2048))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A LAS 1.2 header with the given VLRs (user id, record id, payload).
    fn las(vlrs: &[(&[u8], u16, &[u8])]) -> Vec<u8> {
        let mut d = vec![0u8; 227];
        d[..4].copy_from_slice(b"LASF");
        d[24] = 1;
        d[25] = 2;
        d[94..96].copy_from_slice(&227u16.to_le_bytes());
        d[100..104].copy_from_slice(&(vlrs.len() as u32).to_le_bytes());
        for (user, id, data) in vlrs {
            let mut h = vec![0u8; 54];
            h[2..2 + user.len()].copy_from_slice(user);
            h[18..20].copy_from_slice(&id.to_le_bytes());
            h[20..22].copy_from_slice(&(data.len() as u16).to_le_bytes());
            d.extend_from_slice(&h);
            d.extend_from_slice(data);
        }
        d
    }

    fn geokeys(entries: &[[u16; 4]]) -> Vec<u8> {
        let mut v = vec![1u16, 1, 0, entries.len() as u16];
        for e in entries {
            v.extend_from_slice(e);
        }
        v.iter().flat_map(|x| x.to_le_bytes()).collect()
    }

    #[test]
    fn wkt_before_geokeys() {
        let keys = geokeys(&[[1024, 0, 1, 1], [3072, 0, 1, 32610]]);
        let d = las(&[(USER_ID, GEOKEYS_RECORD, &keys), (USER_ID, WKT_RECORD, b"PROJCS[\"x\"]\0\0")]);
        assert_eq!(read_crs(&d, Format::Las).unwrap(), Some(Crs::Wkt("PROJCS[\"x\"]".to_owned())));
        let d = las(&[(USER_ID, GEOKEYS_RECORD, &keys)]);
        assert_eq!(read_crs(&d, Format::Las).unwrap(), Some(Crs::Epsg(32610)));
        assert_eq!(Crs::Epsg(32610).to_text(), "EPSG:32610");
        // User-defined (32767) names no code; another user id is not a projection record.
        let d = las(&[(USER_ID, GEOKEYS_RECORD, &geokeys(&[[3072, 0, 1, 32767]]))]);
        assert_eq!(read_crs(&d, Format::Las).unwrap(), None);
        let d = las(&[(b"liblas", WKT_RECORD, b"PROJCS[\"y\"]")]);
        assert_eq!(read_crs(&d, Format::Las).unwrap(), None);
    }

    #[test]
    fn cut_records_are_errors() {
        let d = las(&[(USER_ID, WKT_RECORD, b"PROJCS[\"x\"]")]);
        for n in 0..d.len() {
            // Every prefix fails or finds nothing; none panics.
            let _ = read_crs(&d[..n], Format::Las);
        }
        let e = read_crs(&d[..d.len() - 3], Format::Las).unwrap_err();
        assert!(e.to_string().contains("past the end"), "{e}");
    }
}
