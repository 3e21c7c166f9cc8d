//! `pick_reference`: what pixels show, as points, from the f64 integrator.

use super::config::PyRenderConfig;
use super::errors::run_released;
use super::errors::to_py;
use super::renderer::{with_volume, CameraArgs, LightArgs, ReferenceScene, Vec3};
use crate::cores::cores;
use crate::error::try_collect;
use crate::integrate;
use numpy::{PyArray1, PyArray2, PyArrayMethods, PyReadonlyArray2, PyReadonlyArray4};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

/// Picks marched between two checks for Ctrl-C.
const BATCH: usize = 4096;

/// For each pixel (col, row) of `pixels` (N, 2), row 0 at the bottom:
/// the ray parameter and world position of what it shows by the config's
/// model (`integrate::pick`: the first crossing of `threshold` opacity,
/// the projection's extremum, the isosurface hit), as (N, 4) float64
/// (t, x, y, z), NaN where it shows nothing. Ctrl-C stops the work.
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (data, normals, min_bounds, max_bounds, lut, camera, light, config, width, height, pixels, threshold, value_map=(1.0, 0.0), clip=None, planes=None, depth=None))]
pub fn pick_reference<'py>(
    py: Python<'py>,
    data: &Bound<'py, PyAny>,
    normals: Option<PyReadonlyArray4<'py, f32>>,
    min_bounds: Vec3,
    max_bounds: Vec3,
    lut: PyReadonlyArray2<'py, f32>,
    camera: CameraArgs,
    light: LightArgs,
    config: PyRef<'py, PyRenderConfig>,
    width: u32,
    height: u32,
    pixels: PyReadonlyArray2<'py, u32>,
    threshold: f64,
    value_map: (f64, f64),
    clip: Option<(Vec3, Vec3)>,
    planes: Option<Vec<(Vec3, Vec3)>>,
    depth: Option<PyReadonlyArray2<'py, f64>>,
) -> PyResult<Bound<'py, PyArray2<f64>>> {
    if !(threshold > 0.0 && threshold <= 1.0) {
        return Err(PyValueError::new_err(format!("threshold must be in (0, 1], got {threshold}")));
    }
    let view = pixels.as_array();
    if view.ncols() != 2 {
        return Err(PyValueError::new_err(format!("pixels must have shape (N, 2), got {:?}", view.shape())));
    }
    let pixels = try_collect(view.nrows(), "the pixels to pick", view.rows().into_iter().map(|r| [r[0], r[1]]))
        .map_err(to_py)?;
    if let Some(p) = pixels.iter().find(|p| p[0] >= width || p[1] >= height) {
        return Err(PyValueError::new_err(format!("pixel {p:?} is outside the {width}x{height} image")));
    }
    let scene = ReferenceScene::new(&lut, &camera, &light, &config, None, value_map, clip, planes)?
        .with_depth(depth, width, height)?;
    let found = with_volume(data, &normals, min_bounds, max_bounds, |volume| {
        let frame = scene.frame(volume, width, height, 0.0);
        let basis = frame.camera.basis(width, height).map_err(to_py)?;
        run_released(py, |stop| {
            // Room for every pick, asked for up front (filled batch by batch).
            let mut out = try_collect(pixels.len(), "the picks", std::iter::empty::<[f64; 4]>())?;
            for batch in pixels.chunks(BATCH) {
                let per = batch.len().div_ceil(cores());
                let parts: Vec<Vec<[f64; 4]>> = std::thread::scope(|s| {
                    let jobs: Vec<_> = batch
                        .chunks(per)
                        .map(|part| {
                            s.spawn(|| {
                                part.iter()
                                    .map(|&[col, row]| {
                                        let (o, d) = basis.ray(col, row, width, height);
                                        let limit =
                                            frame.depth_in.map_or(f64::INFINITY, |z| z[(row * width + col) as usize]);
                                        match integrate::pick(&frame, o, d, threshold, limit) {
                                            Some(t) => {
                                                let p = o + d * t;
                                                [t, p.x, p.y, p.z]
                                            }
                                            None => [f64::NAN; 4],
                                        }
                                    })
                                    .collect()
                            })
                        })
                        .collect();
                    jobs.into_iter().map(|j| j.join().unwrap_or_default()).collect()
                });
                out.extend(parts.into_iter().flatten());
                if stop() {
                    return Err(crate::error::Error::Interrupted);
                }
            }
            Ok(out)
        })
    })?;
    let n = found.len();
    let flat = try_collect(4 * n, "the picks", found.into_iter().flatten()).map_err(to_py)?;
    PyArray1::from_vec(py, flat).reshape([n, 4])
}
