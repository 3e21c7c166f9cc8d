//! The pixels whose rays can meet the box: a rectangle around the box's
//! corners as the camera sees them.
//!
//! A frame builds a ray for every pixel, and one whose ray misses the box
//! costs that ray's set-up all the same: at 2048² a small box in the middle
//! of the image took tens of milliseconds of set-ups of rays that found
//! nothing. The tiles outside this rectangle are written transparent
//! without building their rays, as the rays would leave them.

use crate::plan::params::Params;

/// Pixel columns `cols.0..cols.1` and rows `rows.0..rows.1` (row 0 at the
/// bottom, as the march counts them) hold every pixel whose ray meets the box.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Footprint {
    pub cols: (usize, usize),
    pub rows: (usize, usize),
}

impl Footprint {
    /// Whether pixel rows `rows` and columns `cols` (half-open) miss it.
    pub fn misses(&self, cols: (usize, usize), rows: (usize, usize)) -> bool {
        cols.1 <= self.cols.0 || cols.0 >= self.cols.1 || rows.1 <= self.rows.0 || rows.0 >= self.rows.1
    }
}

/// The footprint of the (cropped) box, or None where it cannot be bounded
/// so (a corner on or behind the camera's plane, a degenerate camera, a
/// value that is not finite): every pixel is then marched.
///
/// Pixel (x, y)'s ray runs along fwd + X right + Y up with
/// X = (2x + 1 - W) / W and Y = (2y + 1 - H) / H (main.wgsl). A point at
/// q = a fwd + b right + c up from the camera, a > 0, lies on the ray of
/// (X, Y) = (b / a, c / a). With every corner in front (a > 0) the whole box
/// is, and its image is the convex hull of its corners' images: the rays
/// meeting it have (X, Y) inside the corners' bounding rectangle. The
/// rectangle is widened by 10^-4 of its extent and two pixels, far more
/// than the rays' f32 rounding moves a hit (about 10^-7 of the view).
/// Parallel rays (orthographic) start at pos + X right + Y up: a point
/// lies on the ray of (X, Y) = (b, c), in front of the camera or not.
pub fn footprint(p: &Params) -> Option<Footprint> {
    let v = |x: [f32; 4]| glam::DVec3::new(x[0] as f64, x[1] as f64, x[2] as f64);
    let (pos, fwd, right, up) = (v(p.cam_pos), v(p.cam_fwd), v(p.cam_right), v(p.cam_up));
    let (lo, hi) = (v(p.clip_lo), v(p.clip_hi));
    // Cramer's rule: a, b and c are q's dot products with these over the determinant.
    let (ra, rb, rc) = (right.cross(up), up.cross(fwd), fwd.cross(right));
    let det = fwd.dot(ra);
    let scale = fwd.length() * right.length() * up.length();
    if !(det.abs() > 1e-9 * scale) || !(pos.is_finite() && lo.is_finite() && hi.is_finite()) {
        return None;
    }
    let (mut x, mut y) = ((f64::INFINITY, f64::NEG_INFINITY), (f64::INFINITY, f64::NEG_INFINITY));
    for k in 0..8 {
        let corner = glam::DVec3::select(glam::BVec3::new(k & 1 != 0, k & 2 != 0, k & 4 != 0), hi, lo);
        let q = corner - pos;
        let a = q.dot(ra) / det;
        let (bx, cy) = if p.orthographic == 1 {
            // Parallel rays: the ray of (X, Y) = (b, c) passes q (at t = a;
            // corners behind the camera's plane only widen the rectangle).
            (q.dot(rb) / det, q.dot(rc) / det)
        } else {
            // (A corner on the camera's plane, or within rounding of it, gives up.)
            if !(a > 1e-9 * q.length() / fwd.length()) {
                return None;
            }
            (q.dot(rb) / det / a, q.dot(rc) / det / a)
        };
        x = (x.0.min(bx), x.1.max(bx));
        y = (y.0.min(cy), y.1.max(cy));
    }
    // Pixels whose centre's X lies in [lo, hi], widened: x = (X W + W - 1) / 2.
    let span = |(lo, hi): (f64, f64), n: u32| -> (usize, usize) {
        let n = n as f64;
        let pad = 1e-4 * lo.abs().max(hi.abs()).max(1.0) + 4.0 / n;
        let first = (((lo - pad) * n + n - 1.0) / 2.0).floor().clamp(0.0, n);
        let last = (((hi + pad) * n + n - 1.0) / 2.0).ceil().clamp(-1.0, n - 1.0);
        // (Inverted bounds, as from NaN, leave nothing out.)
        if first > last + 1.0 || first.is_nan() || last.is_nan() {
            return (0, n as usize);
        }
        (first as usize, (last + 1.0) as usize)
    };
    Some(Footprint { cols: span(x, p.width), rows: span(y, p.height) })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cpu::test_rays::{frame, pick};
    use crate::cpu::{CpuVolume, Ray, Texels};

    /// Every pixel whose ray (the scalar rule's) meets the box lies in the
    /// footprint, over cameras near and far, inside the box and grazing it,
    /// parallel projections, crops and image shapes; and from outside most
    /// footprints leave pixels out.
    #[test]
    fn every_ray_that_meets_the_box_lies_inside() {
        let volume = CpuVolume { texels: Texels::R32Float(vec![0.0; 8]), dims: [2, 2, 2], normals: None };
        let mut k = 0u32;
        let (mut hits, mut culled, mut unbounded, mut bounded) = (0u64, 0u64, 0, 0);
        for case in 0..300u32 {
            let v4 = |x: [f32; 3]| [x[0], x[1], x[2], 0.0];
            let ext = [1.0, 0.6, 0.8];
            let far = [1.5, 4.0, 40.0, 4000.0][case as usize % 4];
            let pos: [f32; 3] = match case % 5 {
                // Inside the box.
                0 => std::array::from_fn(|a| pick(&mut k, 0.1, ext[a] - 0.1)),
                // On a face's plane, looking along it.
                1 => [pick(&mut k, -2.0, 3.0), 0.6, pick(&mut k, -2.0, 3.0)],
                _ => std::array::from_fn(|a| 0.5 * ext[a] + far * pick(&mut k, -1.0, 1.0)),
            };
            let target: [f32; 3] = std::array::from_fn(|a| pick(&mut k, -0.2, 1.2) * ext[a]);
            let f = (glam::Vec3::from(target) - glam::Vec3::from(pos)).normalize();
            let right = f.cross(if f.z.abs() > 0.9 { glam::Vec3::Y } else { glam::Vec3::Z }).normalize();
            let up = right.cross(f);
            let fov = pick(&mut k, 0.05, 1.5);
            let (width, height) = (1 + (case * 7) % 61, 1 + (case * 13) % 47);
            let crop = case % 3 == 0;
            let p = Params {
                width,
                height,
                cam_pos: v4(pos),
                cam_fwd: v4(f.into()),
                cam_right: v4((right * fov * width as f32 / height as f32).into()),
                cam_up: v4((up * fov).into()),
                clip_lo: v4(std::array::from_fn(|a| if crop { 0.3 * ext[a] } else { 0.0 })),
                clip_hi: v4(std::array::from_fn(|a| if crop { 0.7 * ext[a] } else { ext[a] })),
                step_size: 0.01,
                max_steps: 1000,
                // Parallel rays every seventh case, fov read as the view's half height.
                orthographic: (case % 7 == 2) as u32,
                ..Default::default()
            };
            let frame = frame(&p, &volume);
            let Some(fp) = footprint(&p) else {
                unbounded += 1;
                continue;
            };
            bounded += 1;
            assert!(fp.cols.0 <= fp.cols.1 && fp.cols.1 <= width as usize, "case {case}: {fp:?}");
            assert!(fp.rows.0 <= fp.rows.1 && fp.rows.1 <= height as usize, "case {case}: {fp:?}");
            for row in 0..height {
                for col in 0..width {
                    let inside = !fp.misses((col as usize, col as usize + 1), (row as usize, row as usize + 1));
                    if Ray::new(&frame, col, row).is_some() {
                        assert!(inside, "case {case}: pixel ({col}, {row}) meets the box outside {fp:?}");
                        hits += 1;
                    } else if !inside {
                        culled += 1;
                    }
                }
            }
        }
        // Cameras inside the box give up; most others bound, and leave out pixels.
        let counts = format!("hits {hits}, culled {culled}, unbounded {unbounded}, bounded {bounded}");
        assert!(hits > 10_000 && culled > 50_000 && unbounded >= 50 && bounded > 150, "{counts}");
    }

    #[test]
    fn a_camera_in_the_box_or_degenerate_is_not_bounded() {
        let base = Params {
            width: 10,
            height: 10,
            cam_fwd: [0.0, 0.0, -1.0, 0.0],
            cam_right: [1.0, 0.0, 0.0, 0.0],
            cam_up: [0.0, 1.0, 0.0, 0.0],
            clip_lo: [0.0; 4],
            clip_hi: [1.0, 1.0, 1.0, 0.0],
            ..Default::default()
        };
        let inside = Params { cam_pos: [0.5, 0.5, 0.5, 0.0], ..base };
        assert_eq!(footprint(&inside), None);
        let flat = Params { cam_pos: [0.5, 0.5, 3.0, 0.0], cam_up: [1.0, 0.0, 0.0, 0.0], ..base };
        assert_eq!(footprint(&flat), None);
        let nan = Params { cam_pos: [f32::NAN, 0.5, 3.0, 0.0], ..base };
        assert_eq!(footprint(&nan), None);
        // Straight on from z = 3 the near face spans X and Y in [-1/4, 1/4]:
        // pixels 4 and 5 (centres at -0.1 and 0.1), two more each side, and
        // one more for rounding outwards.
        let front = Params { cam_pos: [0.5, 0.5, 3.0, 0.0], ..base };
        let fp = footprint(&front).expect("in front");
        assert_eq!(fp, Footprint { cols: (1, 9), rows: (1, 9) });
    }
}
