//! The PLY body: vertex and face records in ascii or binary, every other element skipped.

use octowrap_geom::{DVec3, Vec3};
use octowrap_mesh::{FaceList, PointCloud};

use super::header::{Element, Encoding, Header, Property, Scalar};
use crate::budget::{Budget, Corners, point_bytes};
use crate::text::{Tokens, parse_i64, truncated};
use crate::{Error, Limits, Location, Result, justify};

/// What a vertex property means to us.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Role {
    X,
    Y,
    Z,
    Nx,
    Ny,
    Nz,
    R,
    G,
    B,
    Intensity,
    Skip,
}

impl Role {
    fn of(name: &str) -> Self {
        match name {
            "x" => Self::X,
            "y" => Self::Y,
            "z" => Self::Z,
            "nx" | "normal_x" => Self::Nx,
            "ny" | "normal_y" => Self::Ny,
            "nz" | "normal_z" => Self::Nz,
            "red" | "diffuse_red" => Self::R,
            "green" | "diffuse_green" => Self::G,
            "blue" | "diffuse_blue" => Self::B,
            "intensity" | "scalar_intensity" => Self::Intensity,
            _ => Self::Skip,
        }
    }

    fn slot(self) -> usize {
        self as usize
    }
}

/// The vertex element's layout: one role per property (first occurrence wins), and which
/// attributes are complete.
struct VertexLayout {
    roles: Vec<Role>,
    normals: bool,
    colors: bool,
    intensity: bool,
    /// The colour component type (all three must share it to be scaled the same way; the red one
    /// is used).
    color_ty: [Scalar; 3],
}

impl VertexLayout {
    fn new(el: &Element) -> Result<Self> {
        let mut seen = [false; 10];
        let mut color_ty = [Scalar::U8; 3];
        let roles: Vec<Role> = el
            .props
            .iter()
            .map(|p| match p {
                Property::List { .. } => Role::Skip,
                Property::Scalar { ty, name } => {
                    let r = Role::of(name);
                    if r == Role::Skip || seen[r.slot()] {
                        return Role::Skip;
                    }
                    seen[r.slot()] = true;
                    if let Some(k) = [Role::R, Role::G, Role::B].iter().position(|&c| c == r) {
                        color_ty[k] = *ty;
                    }
                    r
                }
            })
            .collect();
        if !(seen[0] && seen[1] && seen[2]) {
            return Err(Error::invalid(
                Location::Line(el.line),
                "the vertex element needs scalar properties x, y and z".to_owned(),
            ));
        }
        Ok(Self {
            roles,
            normals: seen[3] && seen[4] && seen[5],
            colors: seen[6] && seen[7] && seen[8],
            intensity: seen[9],
            color_ty,
        })
    }

    fn point_bytes(&self) -> usize {
        point_bytes(self.normals, self.colors, self.intensity)
    }

    fn cloud(&self, n: usize) -> PointCloud {
        PointCloud {
            positions: Vec::with_capacity(n),
            normals: self.normals.then(|| Vec::with_capacity(n)),
            colors: self.colors.then(|| Vec::with_capacity(n)),
            intensities: self.intensity.then(|| Vec::with_capacity(n)),
        }
    }

    /// Appends one vertex from its role slots.
    #[inline]
    fn push(&self, cloud: &mut PointCloud, v: &[f64; 11]) {
        cloud.positions.push(DVec3::new(v[0], v[1], v[2]));
        if let Some(n) = cloud.normals.as_mut() {
            n.push(Vec3::new(v[3] as f32, v[4] as f32, v[5] as f32));
        }
        if let Some(c) = cloud.colors.as_mut() {
            c.push([
                color_u8(v[6], self.color_ty[0]),
                color_u8(v[7], self.color_ty[1]),
                color_u8(v[8], self.color_ty[2]),
            ]);
        }
        if let Some(i) = cloud.intensities.as_mut() {
            i.push(v[9] as f32);
        }
    }
}

/// Converts a colour component of PLY type `ty` to 8 bits: 8-bit types as they are, 16-bit
/// ones scaled (65535 → 255), floats taken as 0.0-1.0, other integers clamped to 0-255.
fn color_u8(v: f64, ty: Scalar) -> u8 {
    match ty {
        Scalar::U16 | Scalar::I16 => (v / 257.0).round().clamp(0.0, 255.0) as u8,
        Scalar::F32 | Scalar::F64 => crate::text::unit_to_u8(v),
        _ => v.clamp(0.0, 255.0) as u8,
    }
}

/// Whether a list property holds the face corners.
fn is_face_list(p: &Property) -> bool {
    matches!(p, Property::List { name, .. } if name == "vertex_indices" || name == "vertex_index")
}

/// The body, read into a cloud and a face list. Anything after the records the header declares
/// is trailing data and refused (blanks excepted).
pub(crate) fn read(
    data: &[u8],
    header: &Header,
    limits: &Limits,
    budget: &mut Budget,
) -> Result<(PointCloud, FaceList)> {
    let mut vertices = None;
    let mut faces = None;
    match header.encoding {
        Encoding::Ascii => {
            let mut t = Tokens::new(data, header.body_start, header.body_line);
            for el in &header.elements {
                if el.name == "vertex" && vertices.is_none() {
                    vertices = Some(ascii_vertices(&mut t, el, limits, budget)?);
                } else if el.name == "face" && faces.is_none() && el.props.iter().any(is_face_list) {
                    faces = Some(ascii_faces(&mut t, el, limits, budget)?);
                } else {
                    ascii_skip(&mut t, el)?;
                }
            }
            if let Some(tok) = t.next_token() {
                return Err(Error::invalid(
                    t.location(),
                    format!(
                        "trailing data: '{}' follows the last record the header declares",
                        String::from_utf8_lossy(truncated(tok))
                    ),
                ));
            }
        }
        Encoding::BinaryLe | Encoding::BinaryBe => {
            let mut b = Binary { data, pos: header.body_start, be: header.encoding == Encoding::BinaryBe };
            for el in &header.elements {
                if el.name == "vertex" && vertices.is_none() {
                    vertices = Some(b.vertices(el, limits, budget)?);
                } else if el.name == "face" && faces.is_none() && el.props.iter().any(is_face_list) {
                    faces = Some(b.faces(el, limits, budget)?);
                } else {
                    b.skip(el)?;
                }
            }
            let rest = data.get(b.pos..).unwrap_or_default();
            if !rest.trim_ascii().is_empty() {
                return Err(Error::invalid(
                    b.at(),
                    format!(
                        "trailing data: {} bytes follow the last record the header declares, which ends at byte {}",
                        rest.len(),
                        b.pos
                    ),
                ));
            }
        }
    }
    let vertices = vertices
        .ok_or_else(|| Error::invalid(Location::Line(1), "the header declares no 'vertex' element".to_owned()))?;
    Ok((vertices, faces.unwrap_or_default()))
}

fn index_u32(v: i64, at: Location) -> Result<u32> {
    u32::try_from(v).map_err(|_| Error::invalid(at, format!("expected a vertex index from 0 to 2^32-1, found {v}")))
}

// ---------------------------------------------------------------------------------------------
// ascii: a token stream; each value takes at least 2 bytes (a digit and a separator, the last
// one excepted), which is what `justify` checks counts against.

fn ascii_vertices(t: &mut Tokens<'_>, el: &Element, limits: &Limits, budget: &mut Budget) -> Result<PointCloud> {
    let layout = VertexLayout::new(el)?;
    let n =
        justify(el.count, 2 * el.props.len() as u64, t.remaining() + 1, limits.max_points, "vertices", t.location())?;
    budget.charge_n(n, layout.point_bytes(), "vertices", t.location())?;
    let mut cloud = layout.cloud(n);
    let mut v = [0.0f64; 11];
    let props: Vec<(Role, &Property)> = layout.roles.iter().copied().zip(&el.props).collect();
    for _ in 0..n {
        for &(role, prop) in &props {
            match prop {
                Property::Scalar { ty, name } => {
                    if role == Role::Skip {
                        if t.next_token().is_none() {
                            return Err(Error::invalid(
                                t.location(),
                                format!("expected a value for vertex property '{name}', found the end of the input"),
                            ));
                        }
                    } else if *ty == Scalar::F32 {
                        v[role.slot()] = f64::from(t.f32(name)?);
                    } else {
                        v[role.slot()] = t.f64(name)?;
                    }
                }
                Property::List { name, .. } => ascii_skip_list(t, name)?,
            }
        }
        layout.push(&mut cloud, &v);
    }
    Ok(cloud)
}

fn ascii_count(t: &mut Tokens<'_>, name: &str) -> Result<usize> {
    let tok = t.next_token();
    match tok.and_then(parse_i64).map(usize::try_from) {
        Some(Ok(c)) => Ok(c),
        _ => Err(Error::invalid(
            t.location(),
            format!(
                "expected the length of list '{name}', found {}",
                tok.map_or("the end of the input".to_owned(), |w| format!(
                    "'{}'",
                    String::from_utf8_lossy(truncated(w))
                ))
            ),
        )),
    }
}

fn ascii_skip_list(t: &mut Tokens<'_>, name: &str) -> Result<()> {
    let c = ascii_count(t, name)?;
    for _ in 0..c {
        if t.next_token().is_none() {
            return Err(Error::invalid(
                t.location(),
                format!("expected {c} values in list '{name}', found the end of the input"),
            ));
        }
    }
    Ok(())
}

fn ascii_faces(t: &mut Tokens<'_>, el: &Element, limits: &Limits, budget: &mut Budget) -> Result<FaceList> {
    let n = justify(el.count, 2 * el.props.len() as u64, t.remaining() + 1, limits.max_faces, "faces", t.location())?;
    let mut meter = Corners::default();
    let mut faces = FaceList::default();
    let mut buf = Vec::with_capacity(16);
    if let [Property::List { name, .. }] = &el.props[..] {
        // The common layout: the corner list alone.
        for _ in 0..n {
            let c = match t.plain_uint() {
                Some(c) => usize::try_from(c).unwrap_or(usize::MAX),
                None => ascii_count(t, name)?,
            };
            buf.clear();
            for _ in 0..c {
                let i = match t.plain_uint() {
                    Some(i) => i64::try_from(i).unwrap_or(i64::MAX),
                    None => t.int("a vertex index")?,
                };
                buf.push(index_u32(i, t.location())?);
            }
            meter.room(budget, &faces, c, t.location())?;
            faces.push(&buf);
        }
        return Ok(faces);
    }
    let mut done = false;
    for _ in 0..n {
        for p in &el.props {
            match p {
                Property::List { name, .. } if !done && is_face_list(p) => {
                    let c = ascii_count(t, name)?;
                    buf.clear();
                    for _ in 0..c {
                        let i = t.int("a vertex index")?;
                        buf.push(index_u32(i, t.location())?);
                    }
                    meter.room(budget, &faces, c, t.location())?;
                    faces.push(&buf);
                    done = true;
                }
                Property::List { name, .. } => ascii_skip_list(t, name)?,
                Property::Scalar { name, .. } => {
                    if t.next_token().is_none() {
                        return Err(Error::invalid(
                            t.location(),
                            format!("expected a value for face property '{name}', found the end of the input"),
                        ));
                    }
                }
            }
        }
        done = false;
    }
    Ok(faces)
}

fn ascii_skip(t: &mut Tokens<'_>, el: &Element) -> Result<()> {
    if el.props.is_empty() {
        return Ok(());
    }
    let what = format!("'{}' records", el.name);
    let n = justify(el.count, 2 * el.props.len() as u64, t.remaining() + 1, u64::MAX, &what, t.location())?;
    for _ in 0..n {
        for p in &el.props {
            match p {
                Property::List { name, .. } => ascii_skip_list(t, name)?,
                Property::Scalar { name, .. } => {
                    if t.next_token().is_none() {
                        return Err(Error::invalid(
                            t.location(),
                            format!("expected a value for '{}' property '{name}', found the end of the input", el.name),
                        ));
                    }
                }
            }
        }
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------------
// binary

struct Binary<'a> {
    data: &'a [u8],
    pos: usize,
    be: bool,
}

impl<'a> Binary<'a> {
    fn at(&self) -> Location {
        Location::Byte(self.pos as u64)
    }

    fn remaining(&self) -> usize {
        self.data.len().saturating_sub(self.pos)
    }

    /// The next `n` bytes.
    #[inline]
    fn take(&mut self, n: usize, what: &dyn Fn() -> String) -> Result<&'a [u8]> {
        let end = self.pos.checked_add(n).filter(|&e| e <= self.data.len());
        match end.and_then(|e| self.data.get(self.pos..e)) {
            Some(s) => {
                self.pos += n;
                Ok(s)
            }
            None => Err(Error::invalid(
                self.at(),
                format!(
                    "expected {n} bytes for {}, found the end of the input ({} bytes left)",
                    what(),
                    self.remaining()
                ),
            )),
        }
    }

    #[inline]
    fn int(&mut self, ty: Scalar, what: &dyn Fn() -> String) -> Result<i64> {
        let at = self.at();
        let b = self.take(ty.size(), what)?;
        ty.read_int(b, self.be).ok_or_else(|| Error::invalid(at, format!("{} does not fit in 64 bits", what())))
    }

    fn list_len(&mut self, count: Scalar, name: &str) -> Result<usize> {
        let at = self.at();
        let c = self.int(count, &|| format!("the length of list '{name}'"))?;
        usize::try_from(c).map_err(|_| Error::invalid(at, format!("expected a list length, found {c}")))
    }

    fn skip_list(&mut self, count: Scalar, item: Scalar, name: &str) -> Result<()> {
        let c = self.list_len(count, name)?;
        let bytes = c.saturating_mul(item.size());
        self.take(bytes, &|| format!("the {c} values of list '{name}'"))?;
        Ok(())
    }

    fn vertices(&mut self, el: &Element, limits: &Limits, budget: &mut Budget) -> Result<PointCloud> {
        let layout = VertexLayout::new(el)?;
        let min = el.min_binary_size() as u64;
        let n = justify(el.count, min, self.remaining(), limits.max_points, "vertices", self.at())?;
        budget.charge_n(n, layout.point_bytes(), "vertices", self.at())?;
        let mut cloud = layout.cloud(n);
        if let Some(rs) = el.fixed_size() {
            // n * rs <= remaining, checked by `justify`.
            let body = self.take(n * rs, &|| "the vertices".to_owned())?;
            self.fixed_vertices(body, rs, el, &layout, &mut cloud);
            return Ok(cloud);
        }
        let mut v = [0.0f64; 11];
        for k in 0..n {
            for (role, p) in layout.roles.iter().zip(&el.props) {
                match p {
                    Property::Scalar { ty, name } => {
                        let b = self.take(ty.size(), &|| format!("property '{name}' of vertex {k}"))?;
                        if *role != Role::Skip {
                            v[role.slot()] = ty.read_f64(b, self.be);
                        }
                    }
                    Property::List { count, item, name } => self.skip_list(*count, *item, name)?,
                }
            }
            layout.push(&mut cloud, &v);
        }
        Ok(cloud)
    }

    /// Fixed-size records: each attribute in its own tight loop, with a dedicated loop for the
    /// common `float x, y, z` little-endian layout.
    fn fixed_vertices(&self, body: &[u8], rs: usize, el: &Element, layout: &VertexLayout, cloud: &mut PointCloud) {
        let mut field = [(0usize, Scalar::U8); 10];
        let mut off = 0;
        for (role, p) in layout.roles.iter().zip(&el.props) {
            if let Property::Scalar { ty, .. } = p {
                if *role != Role::Skip {
                    field[role.slot()] = (off, *ty);
                }
                off += ty.size();
            }
        }
        let be = self.be;
        let get = |rec: &[u8], (o, ty): (usize, Scalar)| rec.get(o..o + ty.size()).map_or(0.0, |b| ty.read_f64(b, be));
        let [x, y, z] = [field[0], field[1], field[2]];
        if !be && x.1 == Scalar::F32 && y.1 == Scalar::F32 && z.1 == Scalar::F32 {
            if rs == 12 && (x.0, y.0, z.0) == (0, 4, 8) {
                xyz_f32_le(body, 12, 0, 4, 8, &mut cloud.positions);
            } else {
                xyz_f32_le(body, rs, x.0, y.0, z.0, &mut cloud.positions);
            }
        } else {
            cloud.positions.extend(body.chunks_exact(rs).map(|r| DVec3::new(get(r, x), get(r, y), get(r, z))));
        }
        if let Some(n) = cloud.normals.as_mut() {
            let [a, b, c] = [field[3], field[4], field[5]];
            n.extend(body.chunks_exact(rs).map(|r| Vec3::new(get(r, a) as f32, get(r, b) as f32, get(r, c) as f32)));
        }
        if let Some(col) = cloud.colors.as_mut() {
            let [r, g, b] = [field[6], field[7], field[8]];
            col.extend(
                body.chunks_exact(rs)
                    .map(|rec| [color_u8(get(rec, r), r.1), color_u8(get(rec, g), g.1), color_u8(get(rec, b), b.1)]),
            );
        }
        if let Some(i) = cloud.intensities.as_mut() {
            let f = field[9];
            i.extend(body.chunks_exact(rs).map(|r| get(r, f) as f32));
        }
    }

    fn faces(&mut self, el: &Element, limits: &Limits, budget: &mut Budget) -> Result<FaceList> {
        let min = el.min_binary_size() as u64;
        let n = justify(el.count, min, self.remaining(), limits.max_faces, "faces", self.at())?;
        let faces = FaceList::default();
        let mut meter = Corners::default();
        if let [Property::List { count: Scalar::U8, item: item @ (Scalar::I32 | Scalar::U32), .. }] = el.props[..] {
            if !self.be {
                return self.faces_u8_i32_le(n, item, faces, budget);
            }
        }
        let mut faces = faces;
        let mut buf = Vec::with_capacity(16);
        for k in 0..n {
            let mut done = false;
            for p in &el.props {
                match p {
                    Property::List { count, item, name } if !done && is_face_list(p) => {
                        if !item.is_int() {
                            return Err(Error::invalid(
                                self.at(),
                                format!("face list '{name}' must hold integers, but its type is {item:?}"),
                            ));
                        }
                        let c = self.list_len(*count, name)?;
                        buf.clear();
                        for _ in 0..c {
                            let at = self.at();
                            let i = self.int(*item, &|| format!("a vertex index of face {k}"))?;
                            buf.push(index_u32(i, at)?);
                        }
                        meter.room(budget, &faces, c, self.at())?;
                        faces.push(&buf);
                        done = true;
                    }
                    Property::List { count, item, name } => self.skip_list(*count, *item, name)?,
                    Property::Scalar { ty, name } => {
                        self.take(ty.size(), &|| format!("property '{name}' of face {k}"))?;
                    }
                }
            }
        }
        Ok(faces)
    }

    /// The common `list uchar int vertex_indices` face layout, little-endian.
    fn faces_u8_i32_le(
        &mut self,
        n: usize,
        item: Scalar,
        mut faces: FaceList,
        budget: &mut Budget,
    ) -> Result<FaceList> {
        let mut meter = Corners::default();
        let data = self.data;
        let mut p = self.pos;
        for k in 0..n {
            let Some(&c) = data.get(p) else {
                self.pos = p;
                return Err(Error::invalid(
                    self.at(),
                    format!("expected the corner count of face {k}, found the end of the input"),
                ));
            };
            let c = usize::from(c);
            let Some(bytes) = data.get(p + 1..p + 1 + 4 * c) else {
                self.pos = p + 1;
                return Err(Error::invalid(
                    self.at(),
                    format!("expected {} bytes for the {c} indices of face {k}, found {}", 4 * c, self.remaining()),
                ));
            };
            if item == Scalar::I32 {
                if let Some(j) = bytes.chunks_exact(4).position(|b| b[3] & 0x80 != 0) {
                    let v = i32::from_le_bytes([bytes[4 * j], bytes[4 * j + 1], bytes[4 * j + 2], bytes[4 * j + 3]]);
                    return Err(Error::invalid(
                        Location::Byte((p + 1 + 4 * j) as u64),
                        format!("expected a vertex index from 0 to 2^31-1 in face {k}, found {v}"),
                    ));
                }
            }
            meter.room(budget, &faces, c, Location::Byte(p as u64))?;
            faces.push_iter(bytes.chunks_exact(4).map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]])));
            p += 1 + 4 * c;
        }
        self.pos = p;
        Ok(faces)
    }

    fn skip(&mut self, el: &Element) -> Result<()> {
        let what = format!("'{}' records", el.name);
        if let Some(rs) = el.fixed_size() {
            let n = justify(el.count, rs as u64, self.remaining(), u64::MAX, &what, self.at())?;
            self.take(n * rs, &|| what.clone())?;
            return Ok(());
        }
        let n = justify(el.count, el.min_binary_size() as u64, self.remaining(), u64::MAX, &what, self.at())?;
        for k in 0..n {
            for p in &el.props {
                match p {
                    Property::Scalar { ty, name } => {
                        self.take(ty.size(), &|| format!("property '{name}' of {} {k}", el.name))?;
                    }
                    Property::List { count, item, name } => self.skip_list(*count, *item, name)?,
                }
            }
        }
        Ok(())
    }
}

/// Positions from fixed-size little-endian records with `float` x, y, z at the given offsets.
#[inline]
fn xyz_f32_le(body: &[u8], rs: usize, ox: usize, oy: usize, oz: usize, out: &mut Vec<DVec3>) {
    let f = |r: &[u8], o: usize| r.get(o..o + 4).map_or(0.0, |b| f32::from_le_bytes([b[0], b[1], b[2], b[3]]));
    out.extend(
        body.chunks_exact(rs).map(|r| DVec3::new(f64::from(f(r, ox)), f64::from(f(r, oy)), f64::from(f(r, oz)))),
    );
}
