// Empty-space skipping: leaps over occupancy cells the transfer function
// leaves empty (src/occupancy.rs builds the grid, CELL voxels a side).

// Ray parameter at which the ray leaves the largest empty occupancy cell
// holding texture coordinate `tc`, measured from that point, or -1 if its
// finest cell is occupied. Mip level l of `occupancy` has cells of CELL * 2^l
// voxels; the last cell along an axis may extend further, so exiting at its
// nominal size is early, never late.
// The level-l cell above level-0 cell c0 (the last one absorbs remainders).
// Mip levels are passed as i32: wgpu's GL backend writes a u32 level into
// GLSL's textureSize(sampler, int), which does not compile.
fn level_cell(c0: vec3<i32>, l: u32) -> vec3<i32> {
    return min(c0 >> vec3<u32>(l), vec3<i32>(textureDimensions(occupancy, i32(l))) - 1);
}

fn level_empty(c0: vec3<i32>, l: u32) -> bool {
    return textureLoad(occupancy, level_cell(c0, l), i32(l)).r == 0u;
}

fn empty_cell_exit(tc: vec3<f32>, d: vec3<f32>) -> f32 {
    let dims = vec3<f32>(textureDimensions(volume));
    let u = tc * dims;
    let c0 = max(vec3<i32>(floor(u / CELL)), vec3<i32>(0));
    let levels = i32(P.occ_levels);
    // Levels unrolled: a loop here is run wrongly by lavapipe (rays skipped
    // occupied cells), while straight-line code is right on every driver.
    var size = 0.0;
    var lo = vec3<f32>(0.0);
    if (level_empty(c0, 0u)) {
        size = CELL;
        lo = vec3<f32>(level_cell(c0, 0u)) * size;
        if (levels > 1 && level_empty(c0, 1u)) {
            size = 2.0 * CELL;
            lo = vec3<f32>(level_cell(c0, 1u)) * size;
            if (levels > 2 && level_empty(c0, 2u)) {
                size = 4.0 * CELL;
                lo = vec3<f32>(level_cell(c0, 2u)) * size;
                if (levels > 3 && level_empty(c0, 3u)) {
                    size = 8.0 * CELL;
                    lo = vec3<f32>(level_cell(c0, 3u)) * size;
                }
            }
        }
    }
    if (size == 0.0) {
        return -1.0;
    }
    // Voxel units per unit of t along the ray, in texture axis order.
    let du = (d * P.tex_scale.xyz).zyx * dims;
    var exit = 3.0e38;
    for (var a = 0; a < 3; a++) {
        if (du[a] > 0.0) {
            exit = min(exit, (lo[a] + size - u[a]) / du[a]);
        } else if (du[a] < 0.0) {
            exit = min(exit, (lo[a] - u[a]) / du[a]);
        }
    }
    return max(exit, 0.0);
}
