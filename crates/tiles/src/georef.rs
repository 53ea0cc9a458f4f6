//! Georeferencing: from a CRS's coordinates to Earth-centred, Earth-fixed (EPSG:4978) and to a
//! local east-north-up frame.
//!
//! A CRS comes as OGC WKT (WKT1, as LAS files and GeoTIFF-derived tools write it, or WKT2);
//! `proj4wkt` turns it into a PROJ string and `proj4rs` runs the inverse projection and the
//! geocentric conversion, both pure Rust ports of PROJ's own formulas (no C library to build or
//! install, and the same results on every platform; the `proj` crate's bindings would need
//! libproj and its database at build and run time).
//!
//! What the conversion assumes, as PROJ does without its database:
//! * A datum without `TOWGS84` parameters is taken as WGS 84 (a null transformation: NAD83 and
//!   its realisations differ from WGS 84 by about a metre, which a transformation grid or a
//!   Helmert set would correct).
//! * Heights are ellipsoidal, in the CRS's linear unit unless the CRS names a vertical unit
//!   (LAS files in US feet store heights in feet).
//!
//! The tileset's local frame is east-north-up at the data's centre, in metres: tile coordinates
//! stay small (no `f32` jitter), and the root tile's transform carries them to ECEF.

use octowrap_geom::DVec3;
use proj4rs::proj::Proj;

use crate::Error;

/// How a hierarchy's coordinates are placed in the world.
#[derive(Clone, Debug, PartialEq)]
pub enum Frame {
    /// No CRS: the input's own coordinates, in its units, around a local origin.
    Local,
    /// A CRS given as OGC WKT or `EPSG:N`: the tileset is placed on the globe.
    Crs(String),
}

/// A CRS with its local east-north-up frame.
pub struct Georeference {
    src: Proj,
    ecef: Proj,
    z_to_meter: f64,
    origin_ecef: DVec3,
    /// Rows: east, north, up unit vectors in ECEF.
    enu: [DVec3; 3],
    /// The PROJ string the WKT became.
    pub proj_string: String,
}

impl std::fmt::Debug for Georeference {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Georeference")
            .field("proj_string", &self.proj_string)
            .field("origin_ecef", &self.origin_ecef)
            .finish_non_exhaustive()
    }
}

fn crs_error(e: impl std::fmt::Display) -> Error {
    Error::Crs(e.to_string())
}

impl Georeference {
    /// Reads `crs` (OGC WKT, or `EPSG:N`) and sets the local frame's origin at `origin` (a point
    /// in the CRS's coordinates).
    pub fn from_crs(crs: &str, origin: DVec3) -> Result<Self, Error> {
        let crs = crs.trim();
        let (src, proj_string) = if crs.get(..5).is_some_and(|p| p.eq_ignore_ascii_case("EPSG:")) {
            let src = Proj::from_user_string(crs).map_err(|e| crs_error(format!("{crs}: {e}")))?;
            (src, crs.to_owned())
        } else {
            let proj_string =
                proj4wkt::wkt_to_projstring(crs).map_err(|e| crs_error(format!("cannot read the WKT: {e:?}")))?;
            let src = Proj::from_proj_string(&proj_string)
                .map_err(|e| crs_error(format!("PROJ string '{proj_string}': {e}")))?;
            (src, proj_string)
        };
        let ecef = Proj::from_proj_string("+proj=geocent +datum=WGS84 +units=m +no_defs").map_err(crs_error)?;
        let z_to_meter =
            if (src.vto_meter() - 1.0).abs() < f64::EPSILON && !src.is_latlong() { src.to_meter() } else { 1.0 };
        let mut g =
            Self { src, ecef, z_to_meter, origin_ecef: DVec3::ZERO, enu: [DVec3::X, DVec3::Y, DVec3::Z], proj_string };
        let o = g.to_ecef(origin)?;
        let (lon, lat) = (o.y.atan2(o.x), geodetic_latitude(o));
        let east = DVec3::new(-lon.sin(), lon.cos(), 0.0);
        let up = DVec3::new(lat.cos() * lon.cos(), lat.cos() * lon.sin(), lat.sin());
        let north = up.cross(east);
        g.origin_ecef = o;
        g.enu = [east, north, up];
        Ok(g)
    }

    /// ECEF (EPSG:4978, metres) of a point in the CRS's coordinates.
    pub fn to_ecef(&self, p: DVec3) -> Result<DVec3, Error> {
        let (x, y) = if self.src.is_latlong() { (p.x.to_radians(), p.y.to_radians()) } else { (p.x, p.y) };
        let mut q = (x, y, p.z * self.z_to_meter);
        proj4rs::transform::transform(&self.src, &self.ecef, &mut q)
            .map_err(|e| crs_error(format!("cannot convert ({}, {}, {}): {e}", p.x, p.y, p.z)))?;
        let out = DVec3::new(q.0, q.1, q.2);
        if out.is_finite() {
            Ok(out)
        } else {
            Err(crs_error(format!("({}, {}, {}) has no ECEF position", p.x, p.y, p.z)))
        }
    }

    /// The point in the local east-north-up frame (metres from the origin).
    pub fn to_local(&self, p: DVec3) -> Result<DVec3, Error> {
        let d = self.to_ecef(p)? - self.origin_ecef;
        Ok(DVec3::new(self.enu[0].dot(d), self.enu[1].dot(d), self.enu[2].dot(d)))
    }

    /// The local frame's origin in ECEF.
    pub fn origin_ecef(&self) -> DVec3 {
        self.origin_ecef
    }

    /// The 4x4 matrix, column-major, taking local east-north-up coordinates to ECEF.
    pub fn world_from_local(&self) -> [f64; 16] {
        let [e, n, u] = self.enu;
        let o = self.origin_ecef;
        [e.x, e.y, e.z, 0.0, n.x, n.y, n.z, 0.0, u.x, u.y, u.z, 0.0, o.x, o.y, o.z, 1.0]
    }
}

/// Geodetic latitude on the WGS 84 ellipsoid of an ECEF point (Bowring's formula, iterated: well
/// under a millimetre near the surface).
fn geodetic_latitude(p: DVec3) -> f64 {
    const A: f64 = 6_378_137.0;
    const F: f64 = 1.0 / 298.257_223_563;
    let e2 = F * (2.0 - F);
    let r = p.x.hypot(p.y);
    let mut lat = p.z.atan2(r * (1.0 - e2));
    for _ in 0..5 {
        let n = A / (1.0 - e2 * lat.sin().powi(2)).sqrt();
        let h = r / lat.cos() - n;
        lat = p.z.atan2(r * (1.0 - e2 * n / (n + h)));
    }
    lat
}

#[cfg(test)]
mod tests {
    use super::*;

    const UTM10N: &str = r#"PROJCS["WGS 84 / UTM zone 10N",GEOGCS["WGS 84",DATUM["WGS_1984",SPHEROID["WGS 84",6378137,298.257223563]],PRIMEM["Greenwich",0],UNIT["degree",0.0174532925199433]],PROJECTION["Transverse_Mercator"],PARAMETER["latitude_of_origin",0],PARAMETER["central_meridian",-123],PARAMETER["scale_factor",0.9996],PARAMETER["false_easting",500000],PARAMETER["false_northing",0],UNIT["metre",1]]"#;

    #[test]
    fn central_meridian_on_the_equator() {
        // (500000, 0) of UTM 10N is (lon -123, lat 0): ECEF (a cos(-123), a sin(-123), 0).
        let g = Georeference::from_crs(UTM10N, DVec3::new(500_000.0, 0.0, 0.0)).unwrap();
        let a = 6_378_137.0;
        let lon = (-123.0f64).to_radians();
        let want = DVec3::new(a * lon.cos(), a * lon.sin(), 0.0);
        assert!(g.origin_ecef().distance(want) < 1e-3, "{:?} vs {want:?}", g.origin_ecef());
        // 100 m up and 100 m north are up and (about) north in the local frame.
        let up = g.to_local(DVec3::new(500_000.0, 0.0, 100.0)).unwrap();
        assert!(up.distance(DVec3::new(0.0, 0.0, 100.0)) < 1e-6, "{up:?}");
        let north = g.to_local(DVec3::new(500_000.0, 100.0, 0.0)).unwrap();
        assert!(north.x.abs() < 1e-6 && (north.y - 100.0 / 0.9996).abs() < 1e-3, "{north:?}");
        // The matrix takes the local point back to ECEF.
        let m = g.world_from_local();
        let back = DVec3::new(m[12], m[13], m[14]) + DVec3::new(m[8], m[9], m[10]) * 100.0;
        assert!(back.distance(g.to_ecef(DVec3::new(500_000.0, 0.0, 100.0)).unwrap()) < 1e-6);
    }

    #[test]
    fn epsg_codes_are_known() {
        let by_code = Georeference::from_crs("EPSG:32610", DVec3::new(500_000.0, 0.0, 0.0)).unwrap();
        let by_wkt = Georeference::from_crs(UTM10N, DVec3::new(500_000.0, 0.0, 0.0)).unwrap();
        let p = DVec3::new(512_345.0, 4_876_543.0, 80.0);
        assert!(by_code.to_ecef(p).unwrap().distance(by_wkt.to_ecef(p).unwrap()) < 1e-3);
        assert!(Georeference::from_crs("EPSG:1", DVec3::ZERO).is_err());
    }

    #[test]
    fn bad_wkt_is_an_error() {
        assert!(matches!(Georeference::from_crs("PROJCS[", DVec3::ZERO), Err(Error::Crs(_))));
        assert!(matches!(Georeference::from_crs("not a crs", DVec3::ZERO), Err(Error::Crs(_))));
    }
}
