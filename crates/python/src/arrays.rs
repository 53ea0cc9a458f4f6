//! numpy arrays in and out: one checked copy in, no copy (or one) out.
//!
//! Input rules, each broken rule a `ValueError` that names the argument: a numpy array (not a list:
//! the caller converts, so no hidden conversion copies or per-element loops happen here), of the
//! stated dtype, shape and C-contiguous layout.

use numpy::ndarray::{Array1, Array2};
use numpy::{
    Element, IntoPyArray, PyArray1, PyArray2, PyArrayDyn, PyArrayMethods, PyUntypedArray, PyUntypedArrayMethods,
};
use octowrap_mesh::{DVec3, FaceList, Rgb, Vec3};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyTuple;

fn bad(message: String) -> PyErr {
    PyValueError::new_err(message)
}

/// A shape as numpy prints it: `(3,)`, `(10, 3)`.
fn shape_text(shape: &[usize]) -> String {
    match shape {
        [n] => format!("({n},)"),
        _ => format!("({})", shape.iter().map(ToString::to_string).collect::<Vec<_>>().join(", ")),
    }
}

/// `obj` as a C-contiguous numpy array with `ndim` dimensions whose trailing dimension is
/// `width` (when given); `expect` describes the whole requirement for messages.
fn checked<'py>(
    obj: &Bound<'py, PyAny>,
    name: &str,
    expect: &str,
    ndim: usize,
    width: Option<usize>,
) -> PyResult<Bound<'py, PyUntypedArray>> {
    let Ok(arr) = obj.cast::<PyUntypedArray>() else {
        let ty = obj.get_type().name().map_or_else(|_| "?".to_owned(), |n| n.to_string());
        return Err(bad(format!("{name} must be a numpy array {expect}, not {ty} (use numpy.asarray)")));
    };
    let shape = shape_text(arr.shape());
    let dtype = arr.dtype();
    if arr.ndim() != ndim || width.is_some_and(|w| arr.shape()[ndim - 1] != w) {
        return Err(bad(format!("{name} must be an array {expect}, found shape {shape} of {dtype}")));
    }
    if !arr.is_c_contiguous() {
        return Err(bad(format!(
            "{name} must be C-contiguous, found a strided view of shape {shape}; pass numpy.ascontiguousarray({name})"
        )));
    }
    Ok(arr.clone())
}

/// The data of an array of element type `T`, when that is its dtype.
fn slice_of<T: Element, R>(arr: &Bound<'_, PyUntypedArray>, f: impl FnOnce(&[T]) -> R) -> Option<PyResult<R>> {
    let typed = arr.cast::<PyArrayDyn<T>>().ok()?;
    Some(match typed.try_readonly() {
        Ok(ro) => ro.as_slice().map(f).map_err(|e| bad(e.to_string())),
        Err(e) => Err(bad(e.to_string())),
    })
}

/// Positions: `float64`, shape `(N, 3)`.
pub fn positions(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<DVec3>> {
    let expect = "of float64 with shape (N, 3)";
    let arr = checked(obj, name, expect, 2, Some(3))?;
    slice_of::<f64, _>(&arr, |s| s.chunks_exact(3).map(|c| DVec3::new(c[0], c[1], c[2])).collect()).unwrap_or_else(
        || {
            Err(bad(format!(
                "{name} must be an array {expect}, found dtype {}; pass numpy.asarray({name}, dtype=numpy.float64)",
                arr.dtype()
            )))
        },
    )
}

/// Normals: `float32` or `float64`, shape `(N, 3)`.
pub fn normals(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<Vec3>> {
    let expect = "of float32 or float64 with shape (N, 3)";
    let arr = checked(obj, name, expect, 2, Some(3))?;
    slice_of::<f32, _>(&arr, |s| s.chunks_exact(3).map(|c| Vec3::new(c[0], c[1], c[2])).collect())
        .or_else(|| {
            slice_of::<f64, _>(&arr, |s| {
                s.chunks_exact(3).map(|c| Vec3::new(c[0] as f32, c[1] as f32, c[2] as f32)).collect()
            })
        })
        .unwrap_or_else(|| Err(bad(format!("{name} must be an array {expect}, found dtype {}", arr.dtype()))))
}

/// Colours: `uint8`, shape `(N, 3)`.
pub fn colors(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<Rgb>> {
    let expect = "of uint8 with shape (N, 3)";
    let arr = checked(obj, name, expect, 2, Some(3))?;
    slice_of::<u8, _>(&arr, |s| s.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
        .unwrap_or_else(|| Err(bad(format!("{name} must be an array {expect}, found dtype {}", arr.dtype()))))
}

/// Intensities: `float32` or `float64`, shape `(N,)`.
pub fn intensities(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<Vec<f32>> {
    let expect = "of float32 or float64 with shape (N,)";
    let arr = checked(obj, name, expect, 1, None)?;
    slice_of::<f32, _>(&arr, <[f32]>::to_vec)
        .or_else(|| slice_of::<f64, _>(&arr, |s| s.iter().map(|&v| v as f32).collect()))
        .unwrap_or_else(|| Err(bad(format!("{name} must be an array {expect}, found dtype {}", arr.dtype()))))
}

/// Integers of any of numpy's usual index dtypes as `u32`, refusing negative and too large values.
/// `each` receives every value once, in order (no intermediate vector).
fn for_each_index(arr: &Bound<'_, PyUntypedArray>, name: &str, each: &mut dyn FnMut(u32)) -> PyResult<()> {
    fn run<T: Copy + TryInto<u32> + std::fmt::Display>(s: &[T], name: &str, each: &mut dyn FnMut(u32)) -> PyResult<()> {
        if let Some((i, v)) = s.iter().enumerate().find(|(_, v)| TryInto::<u32>::try_into(**v).is_err()) {
            return Err(bad(format!("{name}[{i}] (flat) is {v}: indices must lie in 0..2**32")));
        }
        for &v in s {
            each(v.try_into().unwrap_or(u32::MAX));
        }
        Ok(())
    }
    slice_of::<i64, _>(arr, |s| run(s, name, each))
        .or_else(|| slice_of::<i32, _>(arr, |s| run(s, name, each)))
        .or_else(|| slice_of::<u32, _>(arr, |s| run(s, name, each)))
        .or_else(|| slice_of::<u64, _>(arr, |s| run(s, name, each)))
        .unwrap_or_else(|| {
            Err(bad(format!("{name} must hold integers (int32, int64, uint32 or uint64), found dtype {}", arr.dtype())))
        })?
}

/// Faces: `None` (none), an `(M, k)` integer array (`k` corners each), or a pair
/// `(offsets, indices)` of 1-D integer arrays (face `i` is `indices[offsets[i]:offsets[i + 1]]`).
/// Index values are not checked against the vertices here: the validator describes such faces,
/// and the writers refuse them.
pub fn faces(obj: &Bound<'_, PyAny>, name: &str) -> PyResult<FaceList> {
    if obj.is_none() {
        return Ok(FaceList::default());
    }
    if let Ok(pair) = obj.cast::<PyTuple>() {
        if pair.len() != 2 {
            return Err(bad(format!("{name} as a tuple must be (offsets, indices), found {} items", pair.len())));
        }
        return faces_csr(&pair.get_item(0)?, &pair.get_item(1)?, name);
    }
    let arr = checked(obj, name, "of integers with shape (M, k), or a tuple (offsets, indices)", 2, None)?;
    let (m, k) = (arr.shape()[0], arr.shape()[1]);
    if m > 0 && k == 0 {
        return Err(bad(format!("{name} has shape ({m}, 0): faces need corners")));
    }
    if m.checked_mul(k).is_none_or(|c| c > u32::MAX as usize) {
        return Err(bad(format!("{name} has {m} x {k} corners; at most 2**32 - 1 are supported")));
    }
    let mut out = FaceList::with_capacity(m, m * k);
    let mut row = Vec::with_capacity(k);
    for_each_index(&arr, name, &mut |v| {
        row.push(v);
        if row.len() == k {
            out.push(&row);
            row.clear();
        }
    })?;
    Ok(out)
}

fn faces_csr(offsets: &Bound<'_, PyAny>, indices: &Bound<'_, PyAny>, name: &str) -> PyResult<FaceList> {
    let offs_arr = checked(offsets, &format!("{name} offsets"), "of integers with shape (M + 1,)", 1, None)?;
    let idx_arr = checked(indices, &format!("{name} indices"), "of integers with shape (C,)", 1, None)?;
    let mut offs = Vec::with_capacity(offs_arr.len());
    for_each_index(&offs_arr, &format!("{name} offsets"), &mut |v| offs.push(v))?;
    let corners = idx_arr.len();
    if offs.first() != Some(&0)
        || offs.windows(2).any(|w| w[0] > w[1])
        || offs.last().map(|&l| l as usize) != Some(corners)
    {
        return Err(bad(format!(
            "{name} offsets must start at 0, never decrease and end at the number of indices ({corners})"
        )));
    }
    let mut out = FaceList::with_capacity(offs.len() - 1, corners);
    let mut next = 1;
    let mut face = Vec::new();
    // Empty faces (repeated offsets) come before the first index of the next face.
    let flush = |face: &mut Vec<u32>, next: &mut usize, out: &mut FaceList, upto: usize| {
        while *next < offs.len() && offs[*next] as usize == upto {
            out.push(face);
            face.clear();
            *next += 1;
        }
    };
    flush(&mut face, &mut next, &mut out, 0);
    let mut seen = 0usize;
    for_each_index(&idx_arr, &format!("{name} indices"), &mut |v| {
        face.push(v);
        seen += 1;
        flush(&mut face, &mut next, &mut out, seen);
    })?;
    Ok(out)
}

/// Positions out as a `float64 (N, 3)` array that takes over the vector (no copy).
pub fn positions_out(py: Python<'_>, v: Vec<DVec3>) -> Bound<'_, PyArray2<f64>> {
    let n = v.len();
    let flat: Vec<f64> = bytemuck::allocation::cast_vec(v);
    Array2::from_shape_vec((n, 3), flat).expect("3 coordinates per position").into_pyarray(py)
}

/// Normals out as `float32 (N, 3)` (no copy).
pub fn normals_out(py: Python<'_>, v: Vec<Vec3>) -> Bound<'_, PyArray2<f32>> {
    let n = v.len();
    let flat: Vec<f32> = bytemuck::allocation::cast_vec(v);
    Array2::from_shape_vec((n, 3), flat).expect("3 components per normal").into_pyarray(py)
}

/// Colours out as `uint8 (N, 3)` (no copy).
pub fn colors_out(py: Python<'_>, v: Vec<Rgb>) -> Bound<'_, PyArray2<u8>> {
    let n = v.len();
    let flat: Vec<u8> = bytemuck::allocation::cast_vec(v);
    Array2::from_shape_vec((n, 3), flat).expect("3 channels per colour").into_pyarray(py)
}

/// A face list out as `(offsets int64 (M + 1,), indices int64 (C,), k)`, `k` the common face size
/// when every face has the same (else `None`): one copy, widened to numpy's index type.
pub fn faces_out<'py>(
    py: Python<'py>,
    f: &FaceList,
) -> (Bound<'py, PyArray1<i64>>, Bound<'py, PyArray1<i64>>, Option<usize>) {
    let offsets: Vec<i64> = f.offsets().iter().map(|&o| i64::from(o)).collect();
    let indices: Vec<i64> = f.indices().iter().map(|&i| i64::from(i)).collect();
    let first = f.offsets().get(1).map(|&o| o as usize);
    let uniform = first.filter(|&k| k > 0 && f.offsets().windows(2).all(|w| (w[1] - w[0]) as usize == k));
    (Array1::from_vec(offsets).into_pyarray(py), Array1::from_vec(indices).into_pyarray(py), uniform)
}
