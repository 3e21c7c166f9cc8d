//! `pyvr._core.Renderer`: the GPU engine behind `pyvr.VolumeRenderer`, and
//! the f64 oracle. Arguments arrive already normalised by the Python layer
//! (C-contiguous arrays of a supported dtype, plain tuples), but everything
//! is checked again here: bad input is a ValueError/TypeError, never a panic.

use super::args::integer;
use super::config::PyRenderConfig;
use super::errors::{guarded, run_released, to_py, to_py_in};
use crate::config::RenderConfig;
use crate::error::{try_collect, try_zeroed};
use crate::integrate::{self, Frame};
use crate::output::{Format, Image, Pixels};
use crate::renderer::Renderer;
use crate::scene::{Bounds, Camera, ClipPlane, Light, LightKind};
use crate::transfer::ValueMap;
use crate::volume::{Precision, VolumeView, Voxels};
use glam::DVec3;
use numpy::{
    PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray2, PyReadonlyArray3, PyReadonlyArray4,
    PyReadwriteArray3, PyUntypedArrayMethods,
};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;

pub type Vec3 = (f64, f64, f64);

fn clip_planes(planes: Option<Vec<(Vec3, Vec3)>>) -> PyResult<Vec<ClipPlane>> {
    planes
        .unwrap_or_default()
        .into_iter()
        .map(|(point, normal)| ClipPlane::new(DVec3::from(point), DVec3::from(normal)).map_err(to_py))
        .collect()
}

fn clip_bounds((lo, hi): (Vec3, Vec3)) -> PyResult<Bounds> {
    Bounds::new(DVec3::from(lo), DVec3::from(hi)).map_err(|e| to_py_in("crop box", e))
}
/// (position, target, up, vertical fov in radians)
/// (position, target, up, fov), and for an orthographic camera its view
/// height as a fifth number (0: perspective).
#[derive(FromPyObject)]
pub enum CameraArgs {
    Orthographic((Vec3, Vec3, Vec3, f64, f64)),
    Perspective((Vec3, Vec3, Vec3, f64)),
}
/// (position, target, ambient, diffuse, "directional" | "point")
pub type LightArgs = (Vec3, Vec3, f64, f64, String);

fn dv(v: Vec3) -> DVec3 {
    DVec3::new(v.0, v.1, v.2)
}

pub fn camera_from(c: &CameraArgs) -> Camera {
    let ((position, target, up, fov), height) = match *c {
        CameraArgs::Orthographic((p, t, u, f, h)) => ((p, t, u, f), h),
        CameraArgs::Perspective(args) => (args, 0.0),
    };
    let view_height = (height != 0.0).then_some(height);
    Camera { position: dv(position), target: dv(target), up: dv(up), fov_y: fov, view_height }
}

pub fn light_from(l: &LightArgs) -> PyResult<Light> {
    let (position, target, ambient, diffuse, ref kind) = *l;
    let kind = match kind.as_str() {
        "directional" => LightKind::Directional,
        "point" => LightKind::Point,
        other => {
            return Err(PyValueError::new_err(format!("light kind must be 'directional' or 'point', got '{other}'")))
        }
    };
    for (n, v) in [("ambient_intensity", ambient), ("diffuse_intensity", diffuse)] {
        if !v.is_finite() {
            return Err(PyValueError::new_err(format!("{n} must be finite, got {v}")));
        }
    }
    Ok(Light { position: dv(position), target: dv(target), ambient, diffuse, kind })
}

/// Borrowed voxels of any supported dtype.
enum VoxelArray<'py> {
    F32(PyReadonlyArray3<'py, f32>),
    U8(PyReadonlyArray3<'py, u8>),
    U16(PyReadonlyArray3<'py, u16>),
}

impl<'py> VoxelArray<'py> {
    fn extract(data: &Bound<'py, PyAny>) -> PyResult<Self> {
        if let Ok(a) = data.extract::<PyReadonlyArray3<'py, f32>>() {
            return Ok(VoxelArray::F32(a));
        }
        if let Ok(a) = data.extract::<PyReadonlyArray3<'py, u8>>() {
            return Ok(VoxelArray::U8(a));
        }
        if let Ok(a) = data.extract::<PyReadonlyArray3<'py, u16>>() {
            return Ok(VoxelArray::U16(a));
        }
        Err(PyTypeError::new_err(
            "volume data must be a 3-D numpy array of float32, uint8 or uint16 (pyvr.volume converts other dtypes)",
        ))
    }

    fn view(&self) -> PyResult<([usize; 3], Voxels<'_>)> {
        let noncontig = |_| PyValueError::new_err("volume data must be C-contiguous");
        let (shape, vox) = match self {
            VoxelArray::F32(a) => (a.shape().to_vec(), Voxels::F32(a.as_slice().map_err(noncontig)?)),
            VoxelArray::U8(a) => (a.shape().to_vec(), Voxels::U8(a.as_slice().map_err(noncontig)?)),
            VoxelArray::U16(a) => (a.shape().to_vec(), Voxels::U16(a.as_slice().map_err(noncontig)?)),
        };
        Ok(([shape[0], shape[1], shape[2]], vox))
    }
}

/// Checks and borrows a volume from numpy arrays for the duration of `f`.
pub(super) fn with_volume<R>(
    data: &Bound<'_, PyAny>,
    normals: &Option<PyReadonlyArray4<'_, f32>>,
    min_bounds: Vec3,
    max_bounds: Vec3,
    f: impl FnOnce(VolumeView<'_>) -> PyResult<R>,
) -> PyResult<R> {
    let arr = VoxelArray::extract(data)?;
    let (dims, voxels) = arr.view()?;
    let n = normals_slice(normals, dims)?;
    let b = bounds_from(min_bounds, max_bounds)?;
    f(VolumeView::new(dims, voxels, n, b).map_err(to_py)?)
}

fn bounds_from(min: Vec3, max: Vec3) -> PyResult<Bounds> {
    Bounds::new(dv(min), dv(max)).map_err(to_py)
}

fn normals_slice<'a>(n: &'a Option<PyReadonlyArray4<'_, f32>>, dims: [usize; 3]) -> PyResult<Option<&'a [f32]>> {
    match n {
        None => Ok(None),
        Some(a) => {
            let s = a.shape();
            if s != [dims[0], dims[1], dims[2], 3] {
                return Err(PyValueError::new_err(format!(
                    "Normal volume must have shape {:?}, got {:?}",
                    (dims[0], dims[1], dims[2], 3),
                    s
                )));
            }
            Ok(Some(a.as_slice().map_err(|_| PyValueError::new_err("normals must be C-contiguous"))?))
        }
    }
}

fn lut_rows(lut: &PyReadonlyArray2<'_, f32>) -> PyResult<Vec<[f32; 4]>> {
    let s = lut.shape();
    if s.len() != 2 || s[1] != 4 || s[0] == 0 {
        return Err(PyValueError::new_err(format!("lookup table must have shape (M, 4) with M >= 1, got {s:?}")));
    }
    let flat = lut.as_slice().map_err(|_| PyValueError::new_err("lookup table must be C-contiguous"))?;
    if flat.iter().any(|v| !v.is_finite()) {
        return Err(PyValueError::new_err("lookup table values must be finite"));
    }
    Ok(flat.chunks_exact(4).map(|c| [c[0], c[1], c[2], c[3]]).collect())
}

fn stats_dict<'py>(py: Python<'py>, stats: &crate::renderer::FrameStats) -> PyResult<Bound<'py, PyDict>> {
    let d = PyDict::new(py);
    d.set_item("truncated_needed", stats.truncated_needed)?;
    d.set_item("uploaded_bytes", stats.uploaded_bytes)?;
    d.set_item("passes", stats.passes)?;
    d.set_item("samples", stats.samples)?;
    d.set_item("engine", if stats.native { "native" } else { "gpu" })?;
    Ok(d)
}

#[pyclass(name = "Renderer", module = "pyvr._core")]
pub struct PyRenderer {
    /// Dropped only in the process that made it (see Drop).
    inner: std::mem::ManuallyDrop<Renderer>,
}

impl Drop for PyRenderer {
    fn drop(&mut self) {
        // In a child made by fork() the GPU objects are the parent's: freeing
        // them would call a driver whose threads stayed in the parent. Leak.
        if !self.inner.is_foreign() {
            // SAFETY: `inner` is never used after this.
            unsafe { std::mem::ManuallyDrop::drop(&mut self.inner) }
        }
    }
}

/// An image side: an integer from 1 to 2^32 - 1 (the device's own limit is
/// checked when the buffers are made).
fn side(name: &str, v: &Bound<'_, PyAny>) -> PyResult<u32> {
    integer(name, v, 1, u32::MAX as i128).map(|n| n as u32)
}

#[pymethods]
impl PyRenderer {
    #[new]
    fn new(py: Python<'_>, width: &Bound<'_, PyAny>, height: &Bound<'_, PyAny>) -> PyResult<Self> {
        let (width, height) = (side("width", width)?, side("height", height)?);
        let inner = run_released(py, |_| Renderer::new(width, height))?;
        Ok(PyRenderer { inner: std::mem::ManuallyDrop::new(inner) })
    }

    fn resize(&mut self, width: &Bound<'_, PyAny>, height: &Bound<'_, PyAny>) -> PyResult<()> {
        let (width, height) = (side("width", width)?, side("height", height)?);
        guarded(|| self.inner.resize(width, height).map_err(to_py))
    }

    #[getter]
    fn width(&self) -> u32 {
        self.inner.size().0
    }

    #[getter]
    fn height(&self) -> u32 {
        self.inner.size().1
    }

    /// Uploads a volume; data is float32, uint8 or uint16, C-contiguous;
    /// precision is 'float32' or 'float16' (float data only) or 'fixed16'.
    #[pyo3(signature = (data, normals, min_bounds, max_bounds, precision = "float32"))]
    fn set_volume(
        &mut self,
        py: Python<'_>,
        data: &Bound<'_, PyAny>,
        normals: Option<PyReadonlyArray4<'_, f32>>,
        min_bounds: Vec3,
        max_bounds: Vec3,
        precision: &str,
    ) -> PyResult<()> {
        let precision = Precision::parse(precision).map_err(to_py)?;
        let inner = &mut *self.inner;
        with_volume(data, &normals, min_bounds, max_bounds, |view| {
            run_released(py, |_| inner.set_volume_with_precision(&view, precision))
        })
    }

    /// Stores the loaded float32 volume (`data` and bounds as loaded, no
    /// normals) with its gradients, so that gradient-shaded frames fetch
    /// once a sample; returns whether it did (false: left as it was).
    fn pack_gradients(
        &mut self,
        py: Python<'_>,
        data: &Bound<'_, PyAny>,
        min_bounds: Vec3,
        max_bounds: Vec3,
    ) -> PyResult<bool> {
        let inner = &mut *self.inner;
        let normals: Option<PyReadonlyArray4<'_, f32>> = None;
        with_volume(data, &normals, min_bounds, max_bounds, |view| run_released(py, |_| inner.pack_gradients(&view)))
    }

    /// Uploads an (M, 4) float32 RGBA table, entries at scalars m / (M - 1).
    fn set_lut(&mut self, lut: PyReadonlyArray2<'_, f32>) -> PyResult<()> {
        let rows = lut_rows(&lut)?;
        guarded(|| self.inner.set_lut(&rows).map_err(to_py))
    }

    /// Sampled value -> table domain: `tf = sample * scale + offset`.
    fn set_value_map(&mut self, scale: f64, offset: f64) -> PyResult<()> {
        let map = ValueMap::new(scale, offset).map_err(PyValueError::new_err)?;
        self.inner.set_value_map(map).map_err(to_py)
    }

    /// Rays march only inside the box (min, max) in world coordinates; None
    /// marches the whole volume.
    fn set_clip(&mut self, clip: Option<(Vec3, Vec3)>) -> PyResult<()> {
        self.inner.set_clip(clip.map(clip_bounds).transpose()?);
        Ok(())
    }

    /// Rays march only where `normal . (x - point) >= 0` for every
    /// (point, normal) given, world coordinates; an empty list removes them.
    fn set_clip_planes(&mut self, planes: Vec<(Vec3, Vec3)>) -> PyResult<()> {
        self.inner.set_clip_planes(&clip_planes(Some(planes))?).map_err(to_py)
    }

    /// An opaque scene's depth for the next frames: float32 (height, width),
    /// row 0 at the bottom, the world distance along each pixel's ray to its
    /// surface (inf where none); None removes it.
    fn set_depth_in(&mut self, depth: Option<PyReadonlyArray2<'_, f32>>) -> PyResult<()> {
        let flat = depth.map(|d| d.as_array().iter().copied().collect::<Vec<f32>>());
        self.inner.set_depth_in(flat).map_err(to_py)
    }

    /// Renders one frame as a (H, W, 4) array and a dict of frame
    /// statistics. `output`: (codes, straight, background, top_down) for
    /// uint8 codes (else float32), straight colour (else premultiplied),
    /// over an RGB background (None: transparent), row 0 at the top (else
    /// the bottom); None is float32 premultiplied, transparent, row 0 at
    /// the bottom.
    #[pyo3(signature = (camera, light, config, output=None))]
    fn render<'py>(
        &mut self,
        py: Python<'py>,
        camera: CameraArgs,
        light: LightArgs,
        config: PyRef<'_, PyRenderConfig>,
        output: Option<OutputArgs>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyDict>)> {
        let camera = camera_from(&camera);
        let light = light_from(&light)?;
        let cfg = config.inner;
        let format = output.map_or(Format::PREMULTIPLIED, format_from);
        let inner = &mut *self.inner;
        let (image, stats) = run_released(py, |stop| inner.render_image(&camera, &light, &cfg, format, stop))?;
        Ok((image_array(py, image)?, stats_dict(py, &stats)?))
    }

    /// Renders one frame and adds its premultiplied RGBA to `sums`, a
    /// C-contiguous float64 (H, W, 4) array of the renderer's size (row 0
    /// at the bottom), instead of returning it; returns the frame
    /// statistics. For frames averaged by pyvr itself: the array must not
    /// be used elsewhere while the frame renders (the GIL is released).
    #[pyo3(signature = (camera, light, config, sums))]
    fn accumulate<'py>(
        &mut self,
        py: Python<'py>,
        camera: CameraArgs,
        light: LightArgs,
        config: PyRef<'_, PyRenderConfig>,
        mut sums: PyReadwriteArray3<'py, f64>,
    ) -> PyResult<Bound<'py, PyDict>> {
        let camera = camera_from(&camera);
        let light = light_from(&light)?;
        let cfg = config.inner;
        let (w, h) = self.inner.size();
        let shape = sums.shape().to_vec();
        if shape != [h as usize, w as usize, 4] {
            return Err(PyValueError::new_err(format!("sums must have shape ({h}, {w}, 4), got {shape:?}")));
        }
        let sums = sums.as_slice_mut().map_err(|_| PyValueError::new_err("sums must be C-contiguous"))?;
        let inner = &mut *self.inner;
        let stats = run_released(py, |stop| inner.accumulate_interruptible(&camera, &light, &cfg, sums, stop))?;
        stats_dict(py, &stats)
    }

    /// Replaces the volume by an empty bricked one of shape `dims` in the
    /// box (min_bounds, max_bounds), in bricks of `core` voxels with `ghost`
    /// voxels around each; bricks are then uploaded with `set_brick`.
    fn set_brick_layout(
        &mut self,
        dims: (usize, usize, usize),
        min_bounds: Vec3,
        max_bounds: Vec3,
        core: (usize, usize, usize),
        ghost: usize,
    ) -> PyResult<()> {
        let b = bounds_from(min_bounds, max_bounds)?;
        guarded(|| self.inner.set_brick_layout(dims.into(), b, core.into(), ghost).map_err(to_py))
    }

    /// Brick count, and each brick's padded voxel ranges ((lo, hi) per axis).
    fn brick_ranges(&self) -> PyResult<Vec<[[usize; 2]; 3]>> {
        let g = self.inner.brick_grid().ok_or_else(|| PyValueError::new_err("no bricked volume is loaded"))?;
        Ok((0..g.len()).map(|i| g.padded_range(i)).collect())
    }

    /// Uploads brick `index` from its padded voxels (float32, uint8 or uint16).
    #[pyo3(signature = (index, data, normals, precision = "float32"))]
    fn set_brick(
        &mut self,
        py: Python<'_>,
        index: usize,
        data: &Bound<'_, PyAny>,
        normals: Option<PyReadonlyArray4<'_, f32>>,
        precision: &str,
    ) -> PyResult<()> {
        let precision = Precision::parse(precision).map_err(to_py)?;
        let inner = &mut *self.inner;
        with_volume(data, &normals, (0.0, 0.0, 0.0), (1.0, 1.0, 1.0), |view| {
            run_released(py, |_| inner.set_brick(index, &view, precision))
        })
    }

    fn evict_brick(&mut self, index: usize) -> PyResult<()> {
        self.inner.evict_brick(index).map_err(to_py)
    }

    fn brick_resident(&self, index: usize) -> bool {
        self.inner.brick_resident(index)
    }

    /// Waits until the device has finished the work submitted so far (and
    /// freed what it no longer uses): streamed bricks must not pile up.
    fn wait_idle(&mut self, py: Python<'_>) -> PyResult<()> {
        let inner = &mut *self.inner;
        run_released(py, |_| inner.wait_idle())
    }

    /// Starts a bricked frame; returns the bricks to render, in order.
    #[pyo3(signature = (camera, light, config, keep_state = false))]
    fn begin_bricks(
        &mut self,
        camera: CameraArgs,
        light: LightArgs,
        config: PyRef<'_, PyRenderConfig>,
        keep_state: bool,
    ) -> PyResult<Vec<usize>> {
        let camera = camera_from(&camera);
        let light = light_from(&light)?;
        let cfg = config.inner;
        guarded(|| self.inner.begin_bricks(&camera, &light, &cfg, keep_state).map_err(to_py))
    }

    /// Marches the current bricked frame's segments in brick `index`.
    fn render_brick(&mut self, py: Python<'_>, index: usize) -> PyResult<()> {
        let inner = &mut *self.inner;
        run_released(py, |stop| inner.render_brick(index, stop))
    }

    /// Ends the bricked frame: float32 (H, W, 4) (premultiplied RGBA, or
    /// the rays' states with keep_state) and the frame statistics.
    fn end_bricks<'py>(&mut self, py: Python<'py>) -> PyResult<(Bound<'py, PyArray3<f32>>, Bound<'py, PyDict>)> {
        let (w, h) = self.inner.size();
        let inner = &mut *self.inner;
        let (img, stats) = run_released(py, |_| {
            let mut out = try_zeroed::<f32>(w as usize * h as usize * 4, "the image")?;
            let stats = inner.end_bricks(&mut out)?;
            Ok((out, stats))
        })?;
        let arr = PyArray1::from_vec(py, img).reshape([h as usize, w as usize, 4])?;
        Ok((arr, stats_dict(py, &stats)?))
    }

    /// Life-time counters: frames, volume_uploads, lut_uploads, uploaded_bytes
    /// (counted by the frame that uploads them: a texture that waits for a
    /// frame on the shader, by that frame), volume_bytes (resident),
    /// volume_storage (texel format), volume_texture (made yet),
    /// pipeline_variants (compiled so far).
    fn counters<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let c = self.inner.counters;
        let d = PyDict::new(py);
        d.set_item("frames", c.frames)?;
        d.set_item("volume_uploads", c.volume_uploads)?;
        d.set_item("lut_uploads", c.lut_uploads)?;
        d.set_item("uploaded_bytes", c.uploaded_bytes)?;
        d.set_item("volume_bytes", self.inner.volume_bytes())?;
        d.set_item("volume_storage", self.inner.volume_storage())?;
        d.set_item("volume_texture", self.inner.volume_texture())?;
        d.set_item("pipeline_variants", self.inner.cached_variants())?;
        Ok(d)
    }

    /// Leap over cells the transfer function leaves empty, and in maximum
    /// and minimum projections over cells that cannot change the pixel (default on).
    #[getter]
    fn get_skip_empty(&self) -> bool {
        self.inner.skip_empty
    }
    #[setter]
    fn set_skip_empty(&mut self, on: bool) {
        self.inner.skip_empty = on;
    }

    /// With skip_empty: composite runs through uniform cells as one segment (default on).
    #[getter]
    fn get_uniform_runs(&self) -> bool {
        self.inner.uniform_runs
    }
    #[setter]
    fn set_uniform_runs(&mut self, on: bool) {
        self.inner.uniform_runs = on;
    }

    /// Frames the native CPU march covers are rendered by it where the adapter is a CPU (default on).
    #[getter]
    fn get_native_march(&self) -> bool {
        self.inner.native_march
    }
    #[setter]
    fn set_native_march(&mut self, on: bool) {
        self.inner.native_march = on;
    }

    /// Fraction of the volume's 8^3-voxel cells the current transfer function leaves empty.
    fn empty_fraction(&self) -> f64 {
        self.inner.empty_fraction()
    }

    /// Fraction of the cells the table can show that are uniform: every
    /// sample in them takes one colour and opacity (0 where the last grid
    /// built has none, or the volume holds NaN).
    fn uniform_fraction(&self) -> f64 {
        self.inner.uniform_fraction()
    }

    /// The last frame's isosurface hit distances as float32 (H, W), row 0 at
    /// the bottom, inf where no surface was hit; None unless the last frame
    /// used the isosurface model.
    fn depth<'py>(&mut self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray2<f32>>>> {
        let (w, h) = self.inner.size();
        let inner = &mut *self.inner;
        match run_released(py, |_| inner.depth())? {
            None => Ok(None),
            Some(d) => Ok(Some(PyArray1::from_vec(py, d).reshape([h as usize, w as usize])?)),
        }
    }

    #[getter]
    fn device(&self) -> String {
        self.inner.device().describe()
    }
}

/// Ghost voxels a brick needs around its core for segments of world length
/// `step` on a grid of world `spacing` (x, y, z).
#[pyfunction]
pub fn brick_ghost(step: f64, spacing: Vec3) -> PyResult<usize> {
    if !(step > 0.0 && step.is_finite()) || ![spacing.0, spacing.1, spacing.2].iter().all(|s| *s > 0.0 && s.is_finite())
    {
        return Err(PyValueError::new_err(format!(
            "step and spacing must be positive and finite, got {step} and {spacing:?}"
        )));
    }
    Ok(crate::bricks::BrickGrid::ghost_for(step, dv(spacing)))
}

/// The padded voxel ranges ((lo, hi) per axis) of the bricks of a volume of
/// shape `dims` in cores of `core` voxels with `ghost` voxels around each,
/// and their front-to-back order along every ray from `eye` (continuous
/// voxel coordinates).
#[pyfunction]
pub fn brick_layout(
    dims: (usize, usize, usize),
    core: (usize, usize, usize),
    ghost: usize,
    eye: Vec3,
) -> PyResult<(Vec<[[usize; 2]; 3]>, Vec<usize>)> {
    let g = crate::bricks::BrickGrid::new(dims.into(), core.into(), ghost).map_err(to_py)?;
    Ok(((0..g.len()).map(|i| g.padded_range(i)).collect(), g.front_to_back(dv(eye))))
}

/// (codes, straight, background, top_down): how a frame is returned (`Format`).
type OutputArgs = (bool, bool, Option<(f32, f32, f32)>, bool);

fn format_from((codes, straight, background, top_down): OutputArgs) -> Format {
    Format { codes, straight, background: background.map(|(r, g, b)| [r, g, b]), top_down }
}

/// An image as a (H, W, 4) array of its own (no copy).
fn image_array<'py>(py: Python<'py>, image: Image) -> PyResult<Bound<'py, PyAny>> {
    let shape = [image.height, image.width, 4];
    Ok(match image.pixels {
        Pixels::Floats(v) => PyArray1::from_vec(py, v).reshape(shape)?.into_any(),
        Pixels::Codes(v) => PyArray1::from_vec(py, v).reshape(shape)?.into_any(),
    })
}

/// Premultiplied float RGBA (H, W, 4), row 0 at the bottom, C-contiguous,
/// as a new (H, W, 4) array in the format `output` names (see
/// `Renderer.render`), on every core.
#[pyfunction]
pub fn convert<'py>(
    py: Python<'py>,
    rgba: PyReadonlyArray3<'py, f32>,
    output: OutputArgs,
) -> PyResult<Bound<'py, PyAny>> {
    let s = rgba.shape().to_vec();
    if s[2] != 4 {
        return Err(PyValueError::new_err(format!("expected shape (H, W, 4), got {s:?}")));
    }
    let src = rgba.as_slice().map_err(|_| PyValueError::new_err("image must be C-contiguous"))?;
    let mut image = Image::zeroed(s[1], s[0], format_from(output)).map_err(to_py)?;
    // The GIL stays held: the array is borrowed, and Python may write it.
    image.target().put_image(src);
    image_array(py, image)
}

/// What an f64 reference frame takes from its Python arguments besides the
/// volume, checked.
pub(super) struct ReferenceScene {
    rows: Vec<[f32; 4]>,
    value_map: ValueMap,
    clip: Option<Bounds>,
    planes: Vec<ClipPlane>,
    config: RenderConfig,
    camera: Camera,
    light: Light,
    depth_in: Option<Vec<f64>>,
}

impl ReferenceScene {
    #[allow(clippy::too_many_arguments)]
    pub(super) fn new(
        lut: &PyReadonlyArray2<'_, f32>,
        camera: &CameraArgs,
        light: &LightArgs,
        config: &PyRenderConfig,
        order: Option<&str>,
        value_map: (f64, f64),
        clip: Option<(Vec3, Vec3)>,
        planes: Option<Vec<(Vec3, Vec3)>>,
    ) -> PyResult<Self> {
        let mut cfg = config.inner;
        if let Some(o) = order {
            cfg.order = crate::model::Order::parse(o).map_err(to_py)?;
        }
        cfg.validate().map_err(to_py)?;
        Ok(ReferenceScene {
            rows: lut_rows(lut)?,
            value_map: ValueMap::new(value_map.0, value_map.1).map_err(PyValueError::new_err)?,
            clip: clip.map(clip_bounds).transpose()?,
            planes: clip_planes(planes)?,
            config: cfg,
            camera: camera_from(camera),
            light: light_from(light)?,
            depth_in: None,
        })
    }

    /// An opaque scene's depth per pixel ((height, width), row 0 at the
    /// bottom, world distances along the rays, inf where nothing is).
    pub(super) fn with_depth(
        mut self,
        depth: Option<PyReadonlyArray2<'_, f64>>,
        width: u32,
        height: u32,
    ) -> PyResult<Self> {
        if let Some(d) = depth {
            let view = d.as_array();
            if view.shape() != [height as usize, width as usize] {
                return Err(PyValueError::new_err(format!(
                    "depth must have shape ({height}, {width}), got {:?}",
                    view.shape()
                )));
            }
            let flat: Vec<f64> = view.iter().copied().collect();
            if let Some(bad) = flat.iter().find(|v| !(**v >= 0.0)) {
                return Err(PyValueError::new_err(format!("depths must be distances >= 0 or inf, got {bad}")));
            }
            self.depth_in = Some(flat);
        }
        Ok(self)
    }

    pub(super) fn frame<'a>(&'a self, volume: VolumeView<'a>, width: u32, height: u32, tolerance: f64) -> Frame<'a> {
        Frame {
            volume,
            lut: &self.rows,
            camera: self.camera,
            light: self.light,
            config: self.config,
            width,
            height,
            adaptive_tolerance: tolerance,
            value_map: self.value_map,
            clip: self.clip,
            planes: &self.planes,
            depth_in: self.depth_in.as_deref(),
            slopes: None,
        }
    }
}

/// The f64 integrator: the same frame as the GPU renders, in double
/// precision. Returns float64 (H, W, 4) premultiplied RGBA (row 0 at the
/// bottom), the largest step count a truncated ray needed, and float64
/// (H, W) isosurface hit distances (inf where none or another model).
/// `order` overrides the config's when given; `adaptive_tolerance` > 0
/// splits segments where the transfer function varies (see `Frame`).
/// `progress`, if given, is called with the rows finished about every 50
/// ms; Ctrl-C stops the work (KeyboardInterrupt).
#[pyfunction]
#[allow(clippy::too_many_arguments)]
#[pyo3(signature = (data, normals, min_bounds, max_bounds, lut, camera, light, config, width, height, order=None, adaptive_tolerance=0.0, value_map=(1.0, 0.0), clip=None, planes=None, depth=None, progress=None))]
pub fn integrate_reference<'py>(
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
    order: Option<&str>,
    adaptive_tolerance: f64,
    value_map: (f64, f64),
    clip: Option<(Vec3, Vec3)>,
    planes: Option<Vec<(Vec3, Vec3)>>,
    depth: Option<PyReadonlyArray2<'py, f64>>,
    progress: Option<Py<PyAny>>,
) -> PyResult<(Bound<'py, PyArray3<f64>>, u64, Bound<'py, PyArray2<f64>>)> {
    if !(adaptive_tolerance >= 0.0 && adaptive_tolerance.is_finite()) {
        return Err(PyValueError::new_err(format!(
            "adaptive_tolerance must be a finite number >= 0, got {adaptive_tolerance}"
        )));
    }
    let scene = ReferenceScene::new(&lut, &camera, &light, &config, order, value_map, clip, planes)?
        .with_depth(depth, width, height)?;
    // The progress callback runs Python code, where a Ctrl-C's
    // KeyboardInterrupt may surface: it stops the frame and is raised.
    let mut raised_in_progress: Option<PyErr> = None;
    let result = with_volume(data, &normals, min_bounds, max_bounds, |volume| {
        let frame = scene.frame(volume, width, height, adaptive_tolerance);
        run_released(py, |stop| {
            integrate::render_image_interruptible(&frame, &mut |rows| {
                if let Some(report) = &progress {
                    if let Err(e) = Python::attach(|py| report.call1(py, (rows,)).map(drop)) {
                        raised_in_progress = Some(e);
                        return true;
                    }
                }
                stop()
            })
        })
    });
    let img = result.map_err(|e| raised_in_progress.take().unwrap_or(e))?;
    let n = img.rgba.len() * 4;
    let flat = try_collect(n, "the float64 image", img.rgba.into_iter().flatten()).map_err(to_py)?;
    let shape = [height as usize, width as usize];
    Ok((
        PyArray1::from_vec(py, flat).reshape([shape[0], shape[1], 4])?,
        img.truncated_needed,
        PyArray1::from_vec(py, img.depth).reshape(shape)?,
    ))
}
