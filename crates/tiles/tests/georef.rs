//! Georeferencing against an independent tool: a point of `autzen_trim.las` (NAD83(HARN) Lambert
//! conformal conic in international feet, declared as WKT) in Earth-centred coordinates, ours
//! against pyproj's for the same CRS and the same (null) datum transformation.

mod support;

use std::process::Command;

use octowrap_geom::DVec3;
use octowrap_tiles::georef::Georeference;

#[test]
fn autzen_point_lands_where_pyproj_puts_it() {
    let Some(file) = octowrap_testdata::file("lidar-las/autzen_trim.las") else {
        return octowrap_testdata::skip("lidar-las/autzen_trim.las");
    };
    let data = std::fs::read(&file).unwrap();
    let crs = octowrap_io::read_crs(&data, octowrap_io::Format::Las).unwrap().expect("autzen declares a CRS");
    let octowrap_io::Crs::Wkt(wkt) = &crs else { panic!("autzen's CRS is WKT: {crs:?}") };
    // A point inside the file's extent (feet): easting, northing, height.
    let p = DVec3::new(636_500.25, 849_200.75, 450.5);
    let ours = Georeference::from_crs(wkt, p).unwrap().to_ecef(p).unwrap();
    let script = r#"
import sys, pyproj
crs = pyproj.CRS.from_wkt(sys.argv[1])
x, y, z = map(float, sys.argv[2:5])
geo = pyproj.Transformer.from_crs(crs, crs.geodetic_crs, always_xy=True)
lon, lat = geo.transform(x, y)
unit = crs.axis_info[0].unit_conversion_factor
cart = pyproj.Transformer.from_pipeline("+proj=cart +ellps=GRS80")
X, Y, Z = cart.transform(lon, lat, z * unit)
print(X, Y, Z)
"#;
    let out = Command::new("python3")
        .args(["-c", script, wkt, &p.x.to_string(), &p.y.to_string(), &p.z.to_string()])
        .output();
    let out = match out {
        Ok(o) if o.status.success() => o,
        Ok(o) => {
            return support::skip_or_fail("pyproj comparison", &String::from_utf8_lossy(&o.stderr));
        }
        Err(e) => return support::skip_or_fail("pyproj comparison", &format!("python3 cannot run: {e}")),
    };
    let v: Vec<f64> = String::from_utf8_lossy(&out.stdout).split_whitespace().map(|s| s.parse().unwrap()).collect();
    let theirs = DVec3::new(v[0], v[1], v[2]);
    let d = ours.distance(theirs);
    assert!(d <= 0.05, "ours {ours:?}, pyproj {theirs:?}: {d} m apart");
}
