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
    let code = cell_code(tc);
    let flagged = code >= UNIFORM_FLAG;
    let radius = select(select(0u, code, !flagged), select(0u, code - UNIFORM_FLAG, flagged), uniform);
    return exit_of_cube(tc, d, radius);
}

// The occupancy code of the cell holding texture coordinate `tc`.
fn cell_code(tc: vec3<f32>) -> u32 {
    return textureLoad(occupancy, cell_of(voxel_coords(tc)), 0).g;
}

// Ray parameter at which the ray through `tc` along `d` leaves the cube of
// 2 radius - 1 cells a side centred on tc's cell, measured from tc, or -1
// for radius 0.
fn exit_of_cube(tc: vec3<f32>, d: vec3<f32>, radius_code: u32) -> f32 {
    let radius = i32(radius_code);
    if (radius == 0) {
        return -1.0;
    }
    let dims = vec3<f32>(textureDimensions(volume));
    let u = voxel_coords(tc);
    let c0 = cell_of(u);
    let lo = vec3<f32>(c0 - (radius - 1)) * CELL;
    let hi = vec3<f32>(c0 + radius) * CELL;
    // Voxel units per unit of t along the ray, in texture axis order (the
    // scale maps the box to the texels inside any border).
    // Branch-free: lavapipe runs every side of a branch some lane takes.
    let du = (d * P.tex_scale.xyz).zyx * dims;
    let moving = du != vec3<f32>(0.0);
    let t = (select(lo, hi, du > vec3<f32>(0.0)) - u) * (1.0 / select(vec3<f32>(1.0), du, moving));
    let ta = select(vec3<f32>(3.0e38), t, moving);
    return max(min(ta.x, min(ta.y, ta.z)), 0.0);
}

// March indices [a, b) outside which every segment is empty: those of the
// ray's segments whose points up to `reach` steps from their midpoints (0:
// the midpoint; 0.5: any point, as pre-integrated segments and unbiased
// frames' Poisson points need) may lie in the box of cells that are not
// empty (Params.occupied_*). A ray
// marches from a and is done at b. (0, r.n) where the box is not known;
// (0, 0) where the ray misses it. Nominal segments, from (k + shift) to
// (k + shift + 1) steps past the entry, are compared a thousandth of a step
// generously, as leaps do; the chord's first and last segments, which may
// be shorter, stay in whenever their neighbours are.
fn occupied_window(r: Ray, reach: f32) -> vec2<u32> {
    if (!SKIP_EMPTY || P.bricked == 1u || P.occupied_hi.w != 1.0) {
        return vec2<u32>(0u, r.n);
    }
    let dims = vec3<f32>(textureDimensions(volume));
    let u0 = voxel_coords(tex_of(point_at(r, 0.0)));
    let du = (r.d * P.tex_scale.xyz).zyx * dims;
    var a = 0.0;
    var b = r.chord;
    for (var k = 0; k < 3; k++) {
        if (du[k] == 0.0) {
            if (u0[k] < P.occupied_lo[k] || u0[k] > P.occupied_hi[k]) {
                return vec2<u32>(0u);
            }
        } else {
            let ta = (P.occupied_lo[k] - u0[k]) / du[k];
            let tb = (P.occupied_hi[k] - u0[k]) / du[k];
            a = max(a, min(ta, tb));
            b = min(b, max(ta, tb));
        }
    }
    if (!(b >= a)) {
        return vec2<u32>(0u);
    }
    let h = P.step_size;
    var lo = u32(clamp(ceil(a / h - 0.5 - reach - r.shift - 1e-3), 0.0, f32(r.n)));
    var hi = u32(clamp(floor(b / h - 0.5 + reach - r.shift + 1e-3) + 1.0, 0.0, f32(r.n)));
    if (lo <= 1u) {
        lo = 0u;
    }
    if (hi + 1u >= r.n) {
        hi = r.n;
    }
    if (BACK_TO_FRONT) {
        return vec2<u32>(r.n - hi, r.n - lo);
    }
    return vec2<u32>(lo, hi);
}
