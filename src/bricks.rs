//! A volume cut into bricks: a regular grid of core boxes that tile the
//! voxels, each stored with `ghost` extra voxels on every side (clamped to
//! the volume) so that trilinear samples, gradients, pre-integrated
//! segments and isosurface brackets near a face read the same voxels as in
//! the whole volume. Which brick marches which segment of a ray is decided
//! in the shader (shaders/main.wgsl, `brick_window`); here is the layout and
//! the order bricks are composited in.

use crate::error::Error;
use glam::DVec3;

/// Voxel index ranges [lo, hi) along the three numpy axes.
pub type Ranges = [[usize; 2]; 3];

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct BrickGrid {
    /// The whole volume's shape.
    pub dims: [usize; 3],
    /// A brick's core shape (the last brick along an axis may be smaller).
    pub core: [usize; 3],
    /// Ghost voxels on each side of a core.
    pub ghost: usize,
}

impl BrickGrid {
    pub fn new(dims: [usize; 3], core: [usize; 3], ghost: usize) -> Result<BrickGrid, Error> {
        if dims.contains(&0) || core.contains(&0) {
            return Err(Error::InvalidInput(format!(
                "bricks need a non-empty volume and brick shape, got volume {dims:?} and bricks {core:?}"
            )));
        }
        let grid = BrickGrid { dims, core: [0, 1, 2].map(|a| core[a].min(dims[a])), ghost };
        // Checked: shapes come from the caller, and a wrapped product would pass the limit.
        let count = grid.counts().iter().try_fold(1usize, |n, &c| n.checked_mul(c));
        if count.is_none_or(|n| n > 1 << 20) {
            return Err(Error::InvalidInput(format!(
                "volume {dims:?} in bricks of {core:?} makes {} bricks, over the limit of 2^20: use larger bricks",
                count.map_or("more than 2^64".to_string(), |n| n.to_string())
            )));
        }
        Ok(grid)
    }

    /// Bricks along each axis.
    pub fn counts(&self) -> [usize; 3] {
        [0, 1, 2].map(|a| self.dims[a].div_ceil(self.core[a]))
    }

    pub fn len(&self) -> usize {
        self.counts().iter().product()
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Brick coordinates of `index` (axis 2 fastest, like numpy).
    pub fn coords(&self, index: usize) -> [usize; 3] {
        let [_, c1, c2] = self.counts();
        [index / (c1 * c2), index / c2 % c1, index % c2]
    }

    /// The voxels brick `index` is responsible for.
    pub fn core_range(&self, index: usize) -> Ranges {
        let c = self.coords(index);
        [0, 1, 2].map(|a| [c[a] * self.core[a], ((c[a] + 1) * self.core[a]).min(self.dims[a])])
    }

    /// The voxels brick `index` stores: its core and ghosts, within the volume.
    pub fn padded_range(&self, index: usize) -> Ranges {
        let core = self.core_range(index);
        [0, 1, 2]
            .map(|a| [core[a][0].saturating_sub(self.ghost), core[a][1].saturating_add(self.ghost).min(self.dims[a])])
    }

    /// Every brick in an order that is front to back along every ray from
    /// `eye` (continuous voxel coordinates, voxel i centred at i + 0.5):
    /// along any such ray each axis's distance in bricks from the eye's slab
    /// never decreases, so sorting by the sum of those distances puts every
    /// brick after those in front of it on every ray.
    pub fn front_to_back(&self, eye: DVec3) -> Vec<usize> {
        let e = [eye.x, eye.y, eye.z];
        let slab = |a: usize| (e[a] / self.core[a] as f64).floor().clamp(-1e15, 1e15) as i64;
        let eye_slab = [slab(0), slab(1), slab(2)];
        let mut order: Vec<(i64, usize)> = (0..self.len())
            .map(|i| {
                let c = self.coords(i);
                let d: i64 = (0..3).map(|a| (c[a] as i64 - eye_slab[a]).abs()).sum();
                (d, i)
            })
            .collect();
        order.sort_unstable();
        order.into_iter().map(|(_, i)| i).collect()
    }

    /// Ghost voxels a brick needs for segments of world length `step` on a
    /// grid of world `spacing`: half a step for a segment's samples or a
    /// pre-integrated segment's ends, a whole one for the isosurface's
    /// bracket, and two voxels for the trilinear footprint and the
    /// gradient's central differences.
    pub fn ghost_for(step: f64, spacing: DVec3) -> usize {
        let h = step / spacing.min_element();
        if !h.is_finite() {
            return usize::MAX / 4;
        }
        // Saturating: an absurd step asks for more ghosts than any device holds.
        (h.ceil() as usize).saturating_add(2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cores_tile_the_volume_and_ghosts_stay_inside() {
        let g = BrickGrid::new([10, 7, 5], [4, 4, 5], 2).unwrap();
        assert_eq!(g.counts(), [3, 2, 1]);
        let mut hits = vec![0u8; 10 * 7 * 5];
        for b in 0..g.len() {
            let c = g.core_range(b);
            for i in c[0][0]..c[0][1] {
                for j in c[1][0]..c[1][1] {
                    for k in c[2][0]..c[2][1] {
                        hits[(i * 7 + j) * 5 + k] += 1;
                    }
                }
            }
            let p = g.padded_range(b);
            for a in 0..3 {
                assert!(p[a][0] <= c[a][0] && c[a][1] <= p[a][1] && p[a][1] <= g.dims[a]);
                assert_eq!(c[a][0] - p[a][0], c[a][0].min(2));
            }
        }
        assert!(hits.iter().all(|&h| h == 1));
    }

    #[test]
    fn order_puts_nearer_bricks_first_on_every_ray() {
        let g = BrickGrid::new([16, 16, 16], [4, 4, 4], 0).unwrap();
        for eye in [DVec3::new(-30.0, 5.0, 40.0), DVec3::new(6.0, 9.5, 1.0), DVec3::new(8.0, 8.0, 8.0)] {
            let order = g.front_to_back(eye);
            let rank: Vec<usize> = {
                let mut r = vec![0; g.len()];
                for (k, &b) in order.iter().enumerate() {
                    r[b] = k;
                }
                r
            };
            // March many rays from the eye through the grid: the bricks met
            // must appear in increasing rank.
            for n in 0..500 {
                let t = n as f64 * 0.7;
                let d = DVec3::new(t.sin() * 0.9 + 0.05, (t * 1.3).cos(), (t * 0.37).sin() - 0.1).normalize();
                let mut last = None;
                let mut s = 0.0;
                while s < 100.0 {
                    let p = eye + d * s;
                    s += 0.01;
                    if p.min_element() < 0.0 || p.max_element() >= 16.0 {
                        continue;
                    }
                    let c = [p.x, p.y, p.z].map(|v| (v / 4.0) as usize);
                    let b = (c[0] * 4 + c[1]) * 4 + c[2];
                    if let Some(l) = last {
                        assert!(rank[b] >= rank[l], "eye {eye} ray {d}: brick {b} after {l}");
                    }
                    last = Some(b);
                }
            }
        }
    }

    #[test]
    fn bad_layouts_are_errors() {
        assert!(BrickGrid::new([0, 4, 4], [2, 2, 2], 1).is_err());
        assert!(BrickGrid::new([4, 4, 4], [0, 2, 2], 1).is_err());
        assert!(BrickGrid::new([4096, 4096, 4096], [2, 2, 2], 1).is_err());
        // A product of counts that would wrap is refused, not wrapped.
        assert!(BrickGrid::new([usize::MAX / 2, usize::MAX / 2, 4], [1, 1, 1], 0).is_err());
        let g = BrickGrid::new([8, 8, 8], [4, 4, 4], usize::MAX).unwrap();
        assert_eq!(g.padded_range(7), [[0, 8]; 3]);
        assert_eq!(BrickGrid::ghost_for(1e300, DVec3::splat(1e-300)), usize::MAX / 4);
        assert_eq!(BrickGrid::ghost_for(1e18, DVec3::splat(1e-2)), usize::MAX);
        assert_eq!(BrickGrid::ghost_for(0.05, DVec3::splat(0.01)), 7);
    }
}
