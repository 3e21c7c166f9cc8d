//! One frame of the native march: the texels it reads, the tables, and
//! what the frame asks for and took.

use crate::plan::Params;

/// The volume's texels as the GPU path's texture holds them (numpy axis
/// order, axis 2 fastest), kept on the CPU for the native march.
pub enum Texels {
    /// (value, unit normal or gradient) in float32.
    Rgba32Float(Vec<[f32; 4]>),
    /// (value code, unit normal codes) in 16-bit fixed point.
    Rgba16Snorm(Vec<[i16; 4]>),
    /// Values, and one more past the last so that every value can be read
    /// with the next along the last axis.
    R32Float(Vec<f32>),
    /// Value codes, and one more past the last so that every code can be
    /// read as the low half of a 32-bit word.
    R16Snorm(Vec<i16>),
    /// 8-bit codes, and three bytes past the last.
    R8Unorm(Vec<u8>),
    /// 16-bit codes, and one more past the last.
    R16Unorm(Vec<u16>),
    /// binary16 values, and one more past the last.
    R16Float(Vec<u16>),
    /// (value, unit normal) in binary16.
    Rgba16Float(Vec<[u16; 4]>),
}

impl Texels {
    /// The first `n` texels' bytes, as the GPU path's texture holds them.
    pub fn bytes(&self, n: usize) -> &[u8] {
        match self {
            Texels::Rgba32Float(t) => bytemuck::cast_slice(&t[..n]),
            Texels::Rgba16Snorm(t) => bytemuck::cast_slice(&t[..n]),
            Texels::R32Float(t) => bytemuck::cast_slice(&t[..n]),
            Texels::R16Snorm(t) => bytemuck::cast_slice(&t[..n]),
            Texels::R8Unorm(t) => &t[..n],
            Texels::R16Unorm(t) => bytemuck::cast_slice(&t[..n]),
            Texels::R16Float(t) => bytemuck::cast_slice(&t[..n]),
            Texels::Rgba16Float(t) => bytemuck::cast_slice(&t[..n]),
        }
    }

    /// Whether the storage holds the padding its reads need past `n` texels
    /// (a texel's read takes the next along the last axis with it).
    pub(super) fn padded(&self, n: usize) -> bool {
        match self {
            Texels::Rgba32Float(t) => t.len() >= n,
            Texels::Rgba16Snorm(t) => t.len() >= n,
            Texels::R32Float(t) => t.len() > n,
            Texels::R16Snorm(t) => t.len() > n,
            Texels::R8Unorm(t) => t.len() >= n + 3,
            Texels::R16Unorm(t) => t.len() > n,
            Texels::R16Float(t) => t.len() > n,
            Texels::Rgba16Float(t) => t.len() >= n,
        }
    }
}

pub struct CpuVolume {
    pub texels: Texels,
    /// The texture's size (the volume's, or larger by a border).
    pub dims: [usize; 3],
    /// Normals stored apart from values-only texels (8-, 16-bit codes or
    /// float32), one a texel, as the GPU path's Rgba8Snorm texture holds
    /// them: (x, y, z) codes of 1/127, and a fourth byte unused.
    pub normals: Option<Vec<[i8; 4]>>,
}

impl CpuVolume {
    /// Whether each texel has a normal (or gradient), in it or apart.
    pub fn has_normals(&self) -> bool {
        let apart = matches!(self.texels, Texels::R8Unorm(_) | Texels::R16Unorm(_) | Texels::R32Float(_));
        matches!(self.texels, Texels::Rgba32Float(_) | Texels::Rgba16Snorm(_) | Texels::Rgba16Float(_))
            || (apart && self.normals.as_ref().is_some_and(|n| n.len() >= self.dims.iter().product()))
    }
}

/// The pre-integration texture's texels (`renderer::resources::with_lut_row`):
/// `side` rows of the (front, back) table, each `side` entries (optical
/// depth in alpha, emitted colour), then `rows` rows as wide of the
/// running opacity sums and twice as many of the transfer function,
/// wrapped (`preintegrate::wrapped_rows`).
#[derive(Clone, Debug, Default)]
pub struct PreintTable {
    pub texels: Vec<[f32; 4]>,
    pub side: usize,
    pub rows: usize,
}

/// The optical models: the core's own (`crate::model`), which the march
/// runs all of (compositing.wgsl's rules).
pub use crate::model::Model;

/// One frame of the native march.
pub struct Frame<'a> {
    /// The uniform block the shader would read (one pass, not bricked).
    pub params: &'a Params,
    /// Per pixel (row 0 at the bottom), the ray parameter in the block's
    /// units where an opaque surface stops the ray (infinity: none).
    pub depth_in: Option<&'a [f32]>,
    pub volume: &'a CpuVolume,
    /// The transfer function's table (entries at scalars m / (M - 1)).
    pub lut: &'a [[f32; 4]],
    /// Each occupancy cell's code (its empty radius, 0 where it is not
    /// empty, or UNIFORM_FLAG + its uniform radius), cells of `BLOCK`
    /// voxels in numpy axis order, and the grid's size; needed by
    /// `skip_empty` and `uniform_runs`.
    pub cells: Option<(&'a [u8], [usize; 3])>,
    /// Leap over empty cells, and march only the window of occupied ones.
    pub skip_empty: bool,
    /// The texels' normals light the samples (else ambient light only).
    pub lit: bool,
    /// With `lit`: the field's gradient, from central differences of the
    /// interpolated values, stands for the normal (texels of values alone).
    pub gradient: bool,
    /// With `lit`: the light is a point light at `params.light_pos` (else
    /// directional, along `params.light_dir`).
    pub point_light: bool,
    pub early_termination: bool,
    pub jitter: bool,
    /// Composite a run of segments through a cube of uniform cells as one
    /// (the cells' codes from UNIFORM_FLAG up).
    pub uniform_runs: bool,
    pub model: Model,
    /// Full segments take their (front, back) entry of this table (an
    /// emission-absorption frame's); None: the midpoint rule.
    pub preint: Option<&'a PreintTable>,
    /// With `preint`: segments whose values may reach an opacity change
    /// their ramp misses are taken as this many midpoint samples (0: none).
    pub refine: u32,
    /// Opacity correction's power form: a sample's extinction is
    /// -ln(1 - a) for its table opacity a (else a itself). A
    /// pre-integration table holds extinctions already.
    pub power: bool,
    /// Single scattering's samples take the light a shadow ray to the
    /// light lets through, by the phase function (else ambient light only).
    pub scatter: bool,
    /// Ratio tracking (an unbiased frame of emission-absorption, absorption
    /// or emission): Poisson points instead of midpoints.
    pub unbiased: bool,
    /// With `unbiased`: the points are drawn and composited from the far
    /// end, as the shader's are (other frames marched back to front are
    /// marched front to back here, the same segments and sum).
    pub back_to_front: bool,
    /// With `unbiased`: each cell's majorant code (`occupancy::majorant_code`,
    /// 0 where empty), cells as `cells` and followed by three readable
    /// bytes, where segments take their cells' rates; None: the frame's
    /// rate everywhere.
    pub majorants: Option<&'a [u8]>,
    /// Maximum (minimum) intensity projections: the cells' bounds on their
    /// values. A ray whose maximum (minimum) already reaches a bound leaps
    /// out of the cell, or of the cube.
    pub bounds: Option<CellBounds>,
}

/// Each cell's largest (smallest) value a sample in it can read
/// (`MinMaxGrid::value_bounds`), cells as `Frame::cells`; the same over the
/// cube of cells of radius `reach` (`Cells::exit`'s `cube`) around each;
/// and the grid's size. Shared: the volume keeps them across frames.
#[derive(Clone)]
pub struct CellBounds {
    pub cell: std::sync::Arc<[f32]>,
    pub wide: std::sync::Arc<[f32]>,
    pub reach: i32,
    pub grid: [usize; 3],
}

/// What a native frame took.
#[derive(Clone, Copy, Debug, Default)]
pub struct Stats {
    pub samples: u64,
    /// The largest step count a ray cut short by max_steps needed (0: none).
    pub truncated_needed: u32,
}
