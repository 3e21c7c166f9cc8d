// The uniform block (src/plan/params.rs mirrors it field for field; a test
// compares the two layouts) and the frame's resources, at the binding
// indices the prelude takes from src/gpu/bindings.rs.

struct Params {
    // Positions are relative to the box's min corner: the box is [0, extent].
    cam_pos: vec4<f32>,
    cam_fwd: vec4<f32>,
    cam_right: vec4<f32>,   // scaled by aspect * tan(fov / 2) (orthographic: aspect * height / 2)
    cam_up: vec4<f32>,      // scaled by tan(fov / 2) (orthographic: height / 2)
    extent: vec4<f32>,
    inv_extent: vec4<f32>,
    inv_two_spacing: vec4<f32>,  // 1 / (2 * voxel spacing), world axes
    light_pos: vec4<f32>,
    light_dir: vec4<f32>,   // directional: unit direction the light travels
    step_size: f32,
    inv_ref: f32,
    ambient: f32,
    diffuse: f32,
    threshold: f32,
    max_steps: u32,
    width: u32,
    height: u32,
    lut_size: u32,
    light_valid: u32,       // directional light with a defined direction
    // Long rays are marched over several dispatches of at most pass_steps
    // steps each (drivers cap loop trip counts and dispatch durations);
    // between passes each ray's state waits in `ray_state`.
    pass_start: u32,
    pass_steps: u32,
    first_pass: u32,
    last_pass: u32,
    // Voxels of border around the volume's texels (gradient texels have 1),
    // taken off a sample's voxel coordinates before finding its cell.
    border: u32,
    jitter_seed: u32,
    // The model's options: isosurface value, Henyey–Greenstein g, shadow
    // step, and the side of the pre-integration table.
    iso_value: f32,
    anisotropy: f32,
    shadow_step: f32,
    preint_side: f32,
    // Sampled value -> transfer-function domain, v * scale + offset (a value
    // range in data units; identity by default).
    value_scale: f32,
    value_offset: f32,
    // Points per unit length of unbiased frames' Poisson process.
    track_rate: f32,
    // Rows the pre-integration texture wraps its opacity sums and its
    // transfer function into (src/preintegrate.rs `wrapped_rows`).
    preint_rows: f32,
    // The box rays march in (a crop, or [0, extent]), same frame as positions.
    clip_lo: vec4<f32>,
    clip_hi: vec4<f32>,
    // World position -> coordinates in the bound texture: p * scale + offset
    // (a brick's texture covers only its voxels and their ghosts).
    tex_scale: vec4<f32>,
    tex_offset: vec4<f32>,
    // A brick's core box, whose segments it marches (when bricked == 1).
    core_lo: vec4<f32>,
    core_hi: vec4<f32>,
    // Occupancy cells that are not empty: their box in voxel units
    // (texture axis order); w = 1 where known.
    occupied_lo: vec4<f32>,
    occupied_hi: vec4<f32>,
    // Transfer-function units a value can change by per voxel moved along
    // each texture axis (refined pre-integration, compositing.wgsl).
    slopes: vec4<f32>,
    bricked: u32,
    // Finished rays write their raw state (partial images for compositing).
    keep_state: u32,
    // The frame is this one dispatch (no ray needs `ray_done`).
    only_dispatch: u32,
    // Finish every ray that is still open from its state, sampling nothing.
    resolve: u32,
    // The dispatch's first pixel (a brick's screen rectangle).
    tile_x: u32,
    tile_y: u32,
    // The value map's scale is value_prescale * value_scale, each normal in
    // f32 where it can be (GPUs flush subnormals; src/plan/params.rs split_scale).
    value_prescale: f32,
    // Rays march where n . p + c >= 0 for the first clip_count planes
    // (n, c) (src/plan/params.rs plane_in_block).
    clip_count: u32,
    // 1: parallel rays from cam_pos + X cam_right + Y cam_up along cam_fwd.
    orthographic: u32,
    // 1: each ray stops at its pixel's texel of depth_in.
    depth_in: u32,
    plan_pad1: u32,
    plan_pad2: u32,
    clip_planes: array<vec4<f32>, MAX_CLIP_PLANES>,
};

@group(0) @binding(BINDING_PARAMS) var<uniform> P: Params;
@group(0) @binding(BINDING_VOLUME) var volume: texture_3d<f32>;
@group(0) @binding(BINDING_NORMALS) var normals: texture_3d<f32>;
@group(0) @binding(BINDING_LUT) var lut: texture_2d<f32>;
@group(0) @binding(BINDING_IMAGE) var<storage, read_write> out_rgba: array<vec4<f32>>;
// [0]: largest step count a ray needed when max_steps cut it short;
// [1], [2]: samples taken (low and high words).
@group(0) @binding(BINDING_STATS) var<storage, read_write> stats: array<atomic<u32>, 3>;
// Filtering when HW_FILTER, non-filtering otherwise (then never sampled).
@group(0) @binding(BINDING_VOLUME_SAMPLER) var volume_sampler: sampler;
// Always filtering: normals are stored as Rgba8Snorm.
@group(0) @binding(BINDING_LINEAR_SAMPLER) var linear_sampler: sampler;
// Per pixel, between passes: (colour, tau).
@group(0) @binding(BINDING_RAY_STATE) var<storage, read_write> ray_state: array<vec4<f32>>;
// Per pixel: 1 once the ray is finished (written by every ray in the first pass).
@group(0) @binding(BINDING_RAY_DONE) var<storage, read_write> ray_done: array<u32>;
// Per cell of CELL^3 voxels: r is 0 where the current transfer function
// leaves the cell empty (else its majorant code); g is its empty radius, the
// Chebyshev distance in cells to the nearest cell that is not empty.
@group(0) @binding(BINDING_OCCUPANCY) var occupancy: texture_3d<u32>;
// Pre-integrated segments (src/preintegrate.rs): x = front value, y = back
// value; rgb = premultiplied colour, a = optical depth of one full step. Its
// last row is the transfer-function table (compositing.wgsl, preint_lut_uv).
@group(0) @binding(BINDING_PREINT) var preint: texture_2d<f32>;
// Per pixel (row 0 at the bottom): where an opaque scene stops the ray, as
// a ray parameter (read when P.depth_in == 1).
@group(0) @binding(BINDING_DEPTH_IN) var opaque_depth: texture_2d<f32>;
