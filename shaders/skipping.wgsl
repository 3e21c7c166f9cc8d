// Empty-space skipping: leaps over occupancy cells the transfer function
// leaves empty (src/occupancy.rs builds the grid, CELL voxels a side, and
// each cell's empty radius).

// Texture coordinates -> the volume's voxel coordinates (voxel units, the
// texels' border taken off), in texture axis order.
fn voxel_coords(tc: vec3<f32>) -> vec3<f32> {
    return tc * vec3<f32>(textureDimensions(volume)) - f32(P.border);
}

// The occupancy cell holding voxel coordinates u (voxel units).
fn cell_of(u: vec3<f32>) -> vec3<i32> {
    let last = vec3<i32>(textureDimensions(occupancy)) - 1;
    return clamp(vec3<i32>(floor(u / CELL)), vec3<i32>(0), last);
}

// Ray parameter at which the ray leaves the empty cube around the cell
// holding texture coordinate `tc`, measured from that point, or -1 if the
// cell is occupied. A cell of empty radius r is the centre of an empty cube
// of 2r - 1 cells a side (cells past the grid's faces hold no voxels, so the
// cube may reach past them).
fn empty_cell_exit(tc: vec3<f32>, d: vec3<f32>) -> f32 {
    return cube_exit(tc, d, false);
}

// The same for the empty cube (`uniform` false) or for the cube of cells of
// one colour and opacity around a uniform cell (g = UNIFORM_FLAG + its
// radius; -1 if the cell is not uniform).
fn cube_exit(tc: vec3<f32>, d: vec3<f32>, uniform: bool) -> f32 {
    let dims = vec3<f32>(textureDimensions(volume));
    let u = voxel_coords(tc);
    let c0 = cell_of(u);
    let code = textureLoad(occupancy, c0, 0).g;
    let flagged = code >= UNIFORM_FLAG;
    let radius = i32(select(select(0u, code, !flagged), select(0u, code - UNIFORM_FLAG, flagged), uniform));
    if (radius == 0) {
        return -1.0;
    }
    let lo = vec3<f32>(c0 - (radius - 1)) * CELL;
    let hi = vec3<f32>(c0 + radius) * CELL;
    // Voxel units per unit of t along the ray, in texture axis order (the
    // scale maps the box to the texels inside any border).
    // Branch-free: lavapipe runs every side of a branch some lane takes.
    let du = (d * P.tex_scale.xyz).zyx * dims;
    let moving = du != vec3<f32>(0.0);
    let t = (select(lo, hi, du > vec3<f32>(0.0)) - u) / select(vec3<f32>(1.0), du, moving);
    let ta = select(vec3<f32>(3.0e38), t, moving);
    return max(min(ta.x, min(ta.y, ta.z)), 0.0);
}
