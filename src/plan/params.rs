//! The uniform block every frame writes (the shader's `Params`, in
//! shaders/bindings.wgsl) and how a frame's inputs fill it. Positions are
//! relative to the volume's min corner and lengths are in units of the box's
//! longest side (`world_unit`), so the shader's box is [0, extent] with
//! extent <= 1 whatever the scene's scale: f32 neither overflows for a scene
//! measured in light years nor underflows for one in femtometres.

use crate::bricks::BrickGrid;
use crate::config::RenderConfig;
use crate::occupancy::BLOCK;
use crate::preintegrate;
use crate::scene::{Bounds, ClipPlane, Light, LightKind, RayBasis};
use crate::transfer::ValueMap;
use bytemuck::{Pod, Zeroable};
use glam::DVec3;

/// Declares the block and the list of its fields with their byte offsets,
/// which a test compares with the WGSL struct's layout.
macro_rules! uniform_block {
    ($(#[$m:meta])* pub struct $name:ident { $($(#[$fm:meta])* pub $field:ident : $ty:ty,)* }) => {
        $(#[$m])* pub struct $name { $($(#[$fm])* pub $field: $ty,)* }
        impl $name {
            /// (name, byte offset) of every field, in order.
            pub const FIELDS: &'static [(&'static str, usize)] =
                &[$((stringify!($field), std::mem::offset_of!($name, $field)),)*];
        }
    };
}

uniform_block! {
    #[repr(C)]
    #[derive(Clone, Copy, Pod, Zeroable, Debug, Default)]
    pub struct Params {
        pub cam_pos: [f32; 4],
        pub cam_fwd: [f32; 4],
        /// Scaled by aspect * tan(fov / 2).
        pub cam_right: [f32; 4],
        /// Scaled by tan(fov / 2).
        pub cam_up: [f32; 4],
        pub extent: [f32; 4],
        pub inv_extent: [f32; 4],
        /// 1 / (2 * voxel spacing) along the world axes.
        pub inv_two_spacing: [f32; 4],
        pub light_pos: [f32; 4],
        /// A directional light's unit direction of travel.
        pub light_dir: [f32; 4],
        pub step_size: f32,
        pub inv_ref: f32,
        pub ambient: f32,
        pub diffuse: f32,
        pub threshold: f32,
        pub max_steps: u32,
        pub width: u32,
        pub height: u32,
        pub lut_size: u32,
        /// A directional light with a defined direction.
        pub light_valid: u32,
        pub pass_start: u32,
        pub pass_steps: u32,
        pub first_pass: u32,
        pub last_pass: u32,
        /// Voxels of border around the volume's texels (1 for gradient
        /// texels, `gradients::bordered_texels`), taken off a sample's
        /// voxel coordinates before finding its occupancy cell.
        pub border: u32,
        pub jitter_seed: u32,
        pub iso_value: f32,
        /// Henyey–Greenstein g.
        pub anisotropy: f32,
        pub shadow_step: f32,
        /// Side of the pre-integration table.
        pub preint_side: f32,
        /// Sampled value -> transfer-function domain: v * scale + offset.
        pub value_scale: f32,
        pub value_offset: f32,
        /// Points per unit length of unbiased frames' Poisson process.
        pub track_rate: f32,
        /// Rows the pre-integration texture wraps its opacity sums and its
        /// transfer function into (`preintegrate::wrapped_rows`).
        pub preint_rows: f32,
        /// The box rays march in (a crop, or the whole volume).
        pub clip_lo: [f32; 4],
        pub clip_hi: [f32; 4],
        /// World position -> coordinates in the bound texture (p * scale + offset).
        pub tex_scale: [f32; 4],
        pub tex_offset: [f32; 4],
        /// A brick's core box (when `bricked`).
        pub core_lo: [f32; 4],
        pub core_hi: [f32; 4],
        /// The box of occupancy cells that are not empty, in voxel units
        /// and texture axis order (faces on the grid's boundary pushed out
        /// far); w is 1 where it is known (`with_occupied`).
        pub occupied_lo: [f32; 4],
        pub occupied_hi: [f32; 4],
        /// Transfer-function units a trilinear value can change by per
        /// voxel moved along each texture axis (`MinMaxGrid::slopes` times
        /// the value map's scale; `with_slopes`).
        pub slopes: [f32; 4],
        pub bricked: u32,
        /// Finished rays write their raw state: a partial image.
        pub keep_state: u32,
        /// The frame is one dispatch.
        pub only_dispatch: u32,
        /// Finish the rays still open, sampling nothing.
        pub resolve: u32,
        /// The dispatch's first pixel.
        pub tile_x: u32,
        pub tile_y: u32,
        /// The value map's scale is `value_prescale * value_scale`: a power
        /// of two apart where the scale alone would be subnormal or overflow
        /// in f32 (GPUs flush subnormals to zero; `split_scale`).
        pub value_prescale: f32,
        /// Planes in use, the first `clip_count` of `clip_planes`.
        pub clip_count: u32,
        /// 1: parallel rays, pixel (x, y)'s from `cam_pos + X cam_right + Y
        /// cam_up` along `cam_fwd`; 0: every ray from `cam_pos`.
        pub orthographic: u32,
        /// 1: each pixel's ray stops at its texel of the depth texture (an
        /// opaque scene's surface, ray parameter in the block's units).
        pub depth_in: u32,
        pub plan_pad1: u32,
        pub plan_pad2: u32,
        /// Clip planes as (n, c): rays march where `n · p + c >= 0` (p in
        /// this block's frame, n unit).
        pub clip_planes: [[f32; 4]; MAX_CLIP_PLANES],
    }
}

/// The most clip planes a frame takes. Each camera ray and each shadow ray
/// tests every plane once, never per sample.
pub const MAX_CLIP_PLANES: usize = 16;

fn v4(v: DVec3) -> [f32; 4] {
    [finite_f32(v.x), finite_f32(v.y), finite_f32(v.z), 0.0]
}

/// What a frame's block is made of besides the camera, light and config.
pub struct FrameInputs<'a> {
    pub bounds: Bounds,
    pub dims: [usize; 3],
    pub width: u32,
    pub height: u32,
    pub lut_size: u32,
    pub value_map: ValueMap,
    /// Crop box in world coordinates (None: the whole volume).
    pub clip: Option<Bounds>,
    /// Clip planes in world coordinates (at most `MAX_CLIP_PLANES`; the
    /// renderer refuses more).
    pub planes: &'a [ClipPlane],
    /// The transfer function's largest extinction per reference step.
    pub max_extinction: f64,
}

/// A world plane in the block's frame (positions `(x - b.min) s`): since
/// `n · (x - point) = (n · p + s n · (b.min - point)) / s`, the normal stays
/// and the offset is `s n · (b.min - point)`.
fn plane_in_block(q: &ClipPlane, b: &Bounds, s: f64) -> [f32; 4] {
    let n = q.normal;
    [n.x as f32, n.y as f32, n.z as f32, finite_f32(s * n.dot(b.min - q.point))]
}

/// World length of one shader length unit for a volume in `bounds`: its
/// longest side. Distances the shader reports (isosurface depth) are
/// multiplied by it.
pub fn world_unit(bounds: &Bounds) -> f64 {
    bounds.extent().max_element()
}

/// An f64 as the nearest finite f32 (a reciprocal of a tiny length must not
/// become infinity, whose product with a zero opacity is NaN).
fn finite_f32(v: f64) -> f32 {
    v.clamp(-(f32::MAX as f64), f32::MAX as f64) as f32
}

/// A positive length as an f32 no smaller than the least normal one: GPUs
/// flush subnormals to 0, and a step of 0 would march nowhere (a 0.01 step
/// in a box 6e37 across is 1.7e-40 of it). Such a step is lengthened.
fn normal_f32(v: f64) -> f32 {
    finite_f32(v.max(f32::MIN_POSITIVE as f64))
}

impl Params {
    /// The block of a single-pass frame (passes set `pass_*` themselves).
    pub fn new(f: &FrameInputs, basis: &RayBasis, light: &Light, cfg: &RenderConfig) -> Params {
        let b = f.bounds;
        let s = 1.0 / world_unit(&b);
        let ext = b.extent() * s;
        let spacing = ext / DVec3::new(f.dims[0] as f64, f.dims[1] as f64, f.dims[2] as f64);
        let light_dir = (light.target - light.position).normalize_or_zero();
        let (value_prescale, value_scale) = split_scale(f.value_map.scale);
        // A crop that misses the volume leaves an empty box: no ray enters it.
        let clip = match f.clip {
            Some(c) => b.intersection(&c).unwrap_or(Bounds { min: b.min, max: b.min }),
            None => b,
        };
        Params {
            cam_pos: v4((basis.origin - b.min) * s),
            cam_fwd: v4(basis.forward),
            // Parallel rays' offsets are lengths, in the block's units too.
            cam_right: v4(basis.right * if basis.orthographic { s } else { 1.0 }),
            cam_up: v4(basis.up * if basis.orthographic { s } else { 1.0 }),
            extent: v4(ext),
            inv_extent: v4(1.0 / ext),
            inv_two_spacing: v4(0.5 / spacing),
            light_pos: v4((light.position - b.min) * s),
            light_dir: v4(light_dir),
            step_size: normal_f32(cfg.step_size * s),
            inv_ref: finite_f32(1.0 / (cfg.reference_step_size * s)),
            ambient: light.ambient as f32,
            diffuse: light.diffuse as f32,
            threshold: cfg.opacity_threshold as f32,
            max_steps: cfg.max_steps.clamp(0, u32::MAX as i64) as u32,
            width: f.width,
            height: f.height,
            lut_size: f.lut_size,
            light_valid: (light.kind == LightKind::Directional && light_dir != DVec3::ZERO) as u32,
            pass_start: 0,
            pass_steps: 0,
            first_pass: 1,
            last_pass: 1,
            border: 0,
            jitter_seed: cfg.jitter_seed,
            iso_value: cfg.iso_value as f32,
            anisotropy: cfg.anisotropy as f32,
            shadow_step: normal_f32(cfg.shadow_step() * s),
            preint_side: preintegrate::table_side(f.lut_size as usize) as f32,
            value_scale,
            value_offset: f.value_map.offset as f32,
            track_rate: finite_f32(cfg.tracking_rate(f.max_extinction / cfg.reference_step_size) / s),
            preint_rows: preintegrate::wrapped_rows(f.lut_size as usize, preintegrate::table_side(f.lut_size as usize))
                as f32,
            clip_lo: v4((clip.min - b.min) * s),
            clip_hi: v4((clip.max - b.min) * s),
            tex_scale: v4(1.0 / ext),
            tex_offset: [0.0; 4],
            core_lo: [0.0; 4],
            core_hi: [0.0; 4],
            occupied_lo: [0.0; 4],
            occupied_hi: [0.0; 4],
            slopes: [0.0; 4],
            bricked: 0,
            keep_state: 0,
            only_dispatch: 0,
            resolve: 0,
            tile_x: 0,
            tile_y: 0,
            value_prescale,
            clip_count: f.planes.len().min(MAX_CLIP_PLANES) as u32,
            orthographic: basis.orthographic as u32,
            depth_in: 0,
            plan_pad1: 0,
            plan_pad2: 0,
            clip_planes: std::array::from_fn(|k| f.planes.get(k).map_or([0.0; 4], |q| plane_in_block(q, &b, s))),
        }
    }

    /// The bytes of the block a frame uploads: all but the clip planes it
    /// does not use (the shader reads only the first `clip_count`).
    pub fn used_bytes(&self) -> &[u8] {
        let planes = std::mem::offset_of!(Params, clip_planes);
        let used = planes + self.clip_count as usize * std::mem::size_of::<[f32; 4]>();
        &bytemuck::bytes_of(self)[..used.min(std::mem::size_of::<Params>())]
    }

    /// The block with the box of occupied cells `cells` (inclusive cell
    /// indices per numpy axis) of a grid of `dims` cells, BLOCK voxels a
    /// side. A face on the grid's boundary moves out past any ray's reach
    /// (a sample there reads the boundary cell, whatever its coordinate).
    pub fn with_occupied(mut self, cells: [[usize; 2]; 3], dims: [usize; 3]) -> Params {
        const FAR: f32 = 1.0e7;
        for t in 0..3 {
            let a = 2 - t;
            let [lo, hi] = cells[a];
            self.occupied_lo[t] = if lo == 0 { -FAR } else { (lo * BLOCK) as f32 };
            self.occupied_hi[t] = if hi + 1 >= dims[a] { FAR } else { ((hi + 1) * BLOCK) as f32 };
        }
        self.occupied_hi[3] = 1.0;
        self
    }

    /// The block with the slopes of a grid's voxels (numpy axis order,
    /// data units) under a value map of scale `scale`.
    pub fn with_slopes(mut self, slopes: [f32; 3], scale: f64) -> Params {
        for t in 0..3 {
            self.slopes[t] = finite_f32(slopes[2 - t] as f64 * scale);
        }
        self
    }

    /// This frame's block for the brick of `grid` numbered `index`, whose
    /// texture holds its padded voxels. The shared faces of neighbouring
    /// bricks come out as the same f32 planes (the same integer through the
    /// same arithmetic); faces on the volume's boundary move out to
    /// infinity, leaving the ray's own box as the limit there.
    pub fn for_brick(&self, bounds: &Bounds, grid: &BrickGrid, index: usize) -> Params {
        let s = 1.0 / world_unit(bounds);
        let ext = bounds.extent() * s;
        let ext = [ext.x, ext.y, ext.z];
        let (core, padded) = (grid.core_range(index), grid.padded_range(index));
        let mut p = *self;
        for a in 0..3 {
            let n = grid.dims[a] as f64;
            let stored = (padded[a][1] - padded[a][0]) as f64;
            p.tex_scale[a] = finite_f32(n / (ext[a] * stored));
            p.tex_offset[a] = (-(padded[a][0] as f64) / stored) as f32;
            let plane = |v: usize| (v as f64 / n * ext[a]) as f32;
            p.core_lo[a] = if core[a][0] == 0 { -f32::MAX } else { plane(core[a][0]) };
            p.core_hi[a] = if core[a][1] == grid.dims[a] { f32::MAX } else { plane(core[a][1]) };
        }
        p.bricked = 1;
        p
    }
}

/// (prescale, scale) with prescale * scale = `scale`, each a normal f32
/// where it can be: a value range 3e38 wide maps by 3.3e-39, which GPUs
/// flush to zero (every value would map to the offset). The prescale is 1,
/// 2^-64 or 2^64; values times 2^-64 that are themselves subnormal map to
/// under 1e-19 of the range anyway.
pub fn split_scale(scale: f64) -> (f32, f32) {
    let a = scale.abs();
    let prescale: f64 = if a != 0.0 && a < 2f64.powi(-100) {
        2f64.powi(-64)
    } else if a > 2f64.powi(100) {
        2f64.powi(64)
    } else {
        1.0
    };
    (prescale as f32, (scale / prescale) as f32)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn value_scales_split_into_normal_f32_factors() {
        // A range 3e38 wide, one 1e-39 wide, an ordinary one, and zero.
        for scale in [1.0 / 3e38, -1.0 / 3e38, 1e39, 2.5, 0.0] {
            let (pre, s) = split_scale(scale);
            for f in [pre, s] {
                assert!(f == 0.0 || f.is_normal(), "{scale}: {f}");
            }
            let product = pre as f64 * s as f64;
            assert!((product - scale).abs() <= scale.abs() * 1e-7, "{scale}: {product}");
        }
        assert_eq!(split_scale(2.5), (1.0, 2.5));
    }

    #[test]
    fn a_frame_uploads_only_the_planes_it_uses() {
        let mut p = Params::default();
        let head = std::mem::size_of::<Params>() - MAX_CLIP_PLANES * 16;
        assert_eq!(p.used_bytes().len(), head);
        p.clip_count = 3;
        assert_eq!(p.used_bytes().len(), head + 48);
        assert_eq!(head % 16, 0, "a prefix the queue can write (4-byte multiple) and the WGSL struct's layout");
    }

    #[test]
    fn occupied_box_is_in_voxels_and_texture_axis_order() {
        // Cells [1, 2] x [0, 3] x [4, 4] of a 5 x 4 x 8 grid (numpy order):
        // texture x is numpy axis 2; faces on the grid's boundary move far out.
        let p = Params::default().with_occupied([[1, 2], [0, 3], [4, 4]], [5, 4, 8]);
        assert_eq!(p.occupied_lo, [32.0, -1.0e7, 8.0, 0.0]);
        assert_eq!(p.occupied_hi, [40.0, 1.0e7, 24.0, 1.0]);
    }
}
