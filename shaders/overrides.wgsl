// Override constants: each scene feature that changes the inner loop is
// fixed when a pipeline variant is built (src/gpu/pipeline.rs), so a frame
// runs only the code its scene needs. MODEL takes a MODEL_* code and SHADING
// a SHADING_* code from the generated prelude.

override MODEL: u32 = 0u;
override BACK_TO_FRONT: bool = false;
override JITTER: bool = false;
// Emission–absorption from the (front, back) table instead of the midpoint.
override PRE_INTEGRATED: bool = false;
// Pre-integrated segments whose values may reach an opacity change their
// ramp misses are taken as this many midpoint samples (0: never).
override REFINE: u32 = 0u;
// Points of a Poisson process instead of one midpoint a segment (tracking.wgsl).
override UNBIASED: bool = false;
// Unbiased segments take their cell's rate (where any can be below the frame's).
override CELL_RATES: bool = false;

// SHADING_AMBIENT_ONLY (no normals read), SHADING_NORMALS (supplied) or
// SHADING_GRADIENT (on the fly). Single scattering reads no normals: there
// SHADING_AMBIENT_ONLY means no diffuse term, anything else lit.
override SHADING: u32 = 0u;
override POINT_LIGHT: bool = false;
override EARLY_TERMINATION: bool = true;
override POWER_CORRECTION: bool = false;
// true: the volume's format is filterable and the sampler interpolates;
// false: trilinear by hand from textureLoad (R32Float without FLOAT32_FILTERABLE,
// or exact_filtering: texture units weigh texels in 8-bit fixed point).
override HW_FILTER: bool = true;
// The transfer function's and the pre-integration table's lookups
// interpolated by hand with f32 weights (exact_filtering).
override EXACT_TABLES: bool = false;
// true: each volume texel is (value, normal x, y, z) (Rgba16Float), so a lit
// sample fetches once; `normals` is then a placeholder.
override NORMALS_IN_VOLUME: bool = false;

// Skip cells of the occupancy grid that the transfer function leaves empty.
override SKIP_EMPTY: bool = true;
// Composite the segments in a cube of uniform cells as one segment.
override UNIFORM_CELLS: bool = false;
// Empty cubes a pre-integrated leap crosses at most (compositing.wgsl `whole_segments`).
const CHAIN: u32 = 4u;

// The side, in workgroups, of the tiles a dispatch runs in (main.wgsl).
override GROUP_TILE: u32 = 8u;
