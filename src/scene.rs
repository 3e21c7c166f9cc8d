//! What a frame needs besides the volume: camera rays, light, bounds, and the
//! box intersection, in f64. The GPU path packs these into its uniforms; the
//! f64 integrator uses them directly, so both march the same rays.

use crate::error::Error;
use glam::DVec3;

/// A half-space rays march in: the points x with `normal · (x - point) >= 0`
/// (the normal points into the part that is kept). Rays and shadow rays
/// march only where every plane and the (cropped) box agree.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClipPlane {
    pub point: DVec3,
    /// Unit length.
    pub normal: DVec3,
}

impl ClipPlane {
    pub fn new(point: DVec3, normal: DVec3) -> Result<Self, Error> {
        if !point.is_finite() || !normal.is_finite() {
            return Err(Error::InvalidInput("a clip plane's point and normal must be finite".into()));
        }
        // Scaled by its largest component first: a normal of 1e-300 or 1e300
        // has a direction even where its squared length does not.
        let largest = normal.abs().max_element();
        if largest == 0.0 {
            return Err(Error::InvalidInput("a clip plane's normal must not be zero".into()));
        }
        Ok(ClipPlane { point, normal: (normal / largest).normalize() })
    }

    /// Signed distance of `p` from the plane, positive on the kept side.
    pub fn side(&self, p: DVec3) -> f64 {
        self.normal.dot(p - self.point)
    }

    /// The part of `[t0, t1]` of the ray `origin + t dir` on the kept side,
    /// or None where no part of it is (a ray along the plane is kept whole
    /// when it starts on the kept side or in the plane).
    pub fn cut(&self, origin: DVec3, dir: DVec3, (t0, t1): (f64, f64)) -> Option<(f64, f64)> {
        let (f0, slope) = (self.side(origin), self.normal.dot(dir));
        let (t0, t1) = if slope > 0.0 {
            (t0.max(-f0 / slope), t1)
        } else if slope < 0.0 {
            (t0, t1.min(-f0 / slope))
        } else if f0 < 0.0 {
            return None;
        } else {
            (t0, t1)
        };
        (t0 <= t1).then_some((t0, t1))
    }
}

/// The axis-aligned box the volume fills.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bounds {
    pub min: DVec3,
    pub max: DVec3,
}

impl Default for Bounds {
    fn default() -> Self {
        Bounds { min: DVec3::splat(-0.5), max: DVec3::splat(0.5) }
    }
}

impl Bounds {
    pub fn new(min: DVec3, max: DVec3) -> Result<Self, Error> {
        if !min.is_finite() || !max.is_finite() {
            return Err(Error::InvalidInput("bounds must be finite".into()));
        }
        if !(max.cmpgt(min).all()) {
            return Err(Error::InvalidInput("max_bounds must be greater than min_bounds".into()));
        }
        Ok(Bounds { min, max })
    }

    pub fn extent(&self) -> DVec3 {
        self.max - self.min
    }

    /// The part of this box inside `other`, or None when they do not overlap.
    pub fn intersection(&self, other: &Bounds) -> Option<Bounds> {
        let (min, max) = (self.min.max(other.min), self.max.min(other.max));
        max.cmpgt(min).all().then_some(Bounds { min, max })
    }

    /// World position to texture coordinates in [0, 1]^3 (axis 0 = x).
    pub fn to_unit(&self, p: DVec3) -> DVec3 {
        (p - self.min) / self.extent()
    }

    /// Ray parameter interval `[t_near, t_far]` inside the box, clipped to
    /// `t >= 0`; `None` on a miss. Zero direction components are handled
    /// explicitly (no reliance on 1/0 = inf).
    pub fn intersect(&self, origin: DVec3, dir: DVec3) -> Option<(f64, f64)> {
        let mut t0 = f64::NEG_INFINITY;
        let mut t1 = f64::INFINITY;
        for a in 0..3 {
            let (o, d, lo, hi) = (origin[a], dir[a], self.min[a], self.max[a]);
            if d == 0.0 {
                if o < lo || o > hi {
                    return None;
                }
                continue;
            }
            let inv = 1.0 / d;
            let (mut ta, mut tb) = ((lo - o) * inv, (hi - o) * inv);
            if ta > tb {
                std::mem::swap(&mut ta, &mut tb);
            }
            t0 = t0.max(ta);
            t1 = t1.min(tb);
        }
        if t0 > t1 || t1 <= 0.0 {
            return None;
        }
        Some((t0.max(0.0), t1))
    }

    /// Longest chord a ray from `eye` can have inside the box: the distance
    /// to the farthest corner bounds it from above.
    pub fn max_chord_from(&self, eye: DVec3) -> f64 {
        let mut best: f64 = 0.0;
        for i in 0..8 {
            let c = DVec3::new(
                if i & 1 == 0 { self.min.x } else { self.max.x },
                if i & 2 == 0 { self.min.y } else { self.max.y },
                if i & 4 == 0 { self.min.z } else { self.max.z },
            );
            best = best.max((c - eye).length());
        }
        best.min(self.extent().length())
    }
}

/// A pinhole camera in pyvr's convention: +Z up by default, vertical fov.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Camera {
    pub position: DVec3,
    pub target: DVec3,
    pub up: DVec3,
    /// Vertical field of view in radians, in (0, pi).
    pub fov_y: f64,
    /// Orthographic: the world height the image spans, its rays parallel to
    /// the view direction and starting on the camera's plane; None:
    /// perspective, every ray from `position`.
    pub view_height: Option<f64>,
}

/// Per-frame ray basis. Perspective: every ray starts at `origin`, along
/// `normalize(forward + ndc.x*right + ndc.y*up)`. Orthographic: rays start
/// at `origin + ndc.x*right + ndc.y*up`, all along `forward`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RayBasis {
    pub origin: DVec3,
    pub forward: DVec3,
    /// Screen right, scaled by `aspect * tan(fov/2)` (orthographic: by
    /// `aspect * view_height / 2`).
    pub right: DVec3,
    /// Screen up, scaled by `tan(fov/2)` (orthographic: `view_height / 2`).
    pub up: DVec3,
    pub orthographic: bool,
}

impl Camera {
    /// pyvr 2.3: `f = normalize(target - pos)`, `r = normalize(f x up)`, `u = r x f`.
    /// An up vector parallel to the view falls back to the world axis least
    /// aligned with it, so such cameras still render instead of giving NaN.
    pub fn basis(&self, width: u32, height: u32) -> Result<RayBasis, Error> {
        if width == 0 || height == 0 {
            return Err(Error::InvalidInput(format!("width and height must be positive, got {width}x{height}")));
        }
        for (name, v) in [("position", self.position), ("target", self.target), ("up", self.up)] {
            if !v.is_finite() {
                return Err(Error::InvalidInput(format!("camera {name} must be finite, got {v:?}")));
            }
        }
        if !(self.fov_y > 0.0 && self.fov_y < std::f64::consts::PI) {
            return Err(Error::InvalidInput(format!("fov must be between 0 and π radians, got {}", self.fov_y)));
        }
        let to_target = self.target - self.position;
        let len = to_target.length();
        if !(len > 0.0) {
            return Err(Error::InvalidInput("camera position must differ from its target".into()));
        }
        let f = to_target / len;
        let mut r = f.cross(self.up);
        if r.length() <= 1e-12 * self.up.length().max(1e-300) {
            let a = f.abs();
            let alt = if a.x <= a.y && a.x <= a.z {
                DVec3::X
            } else if a.y <= a.z {
                DVec3::Y
            } else {
                DVec3::Z
            };
            r = f.cross(alt);
        }
        let r = r.normalize();
        let u = r.cross(f);
        let aspect = width as f64 / height as f64;
        let (half, orthographic) = match self.view_height {
            None => ((self.fov_y * 0.5).tan(), false),
            Some(h) if h > 0.0 && h.is_finite() => (0.5 * h, true),
            Some(h) => {
                return Err(Error::InvalidInput(format!(
                    "an orthographic camera's view height must be a finite number > 0, got {h}"
                )))
            }
        };
        Ok(RayBasis { origin: self.position, forward: f, right: r * (aspect * half), up: u * half, orthographic })
    }

    /// A point from which bricks seen by this camera are ordered front to
    /// back: its position, or for parallel rays a point far behind it along
    /// the view, whatever the scene's size.
    pub fn ordering_eye(&self, bounds: &Bounds) -> DVec3 {
        if self.view_height.is_none() {
            return self.position;
        }
        let f = (self.target - self.position).normalize_or_zero();
        let far = 1.0e6 * (bounds.extent().length() + (self.position - bounds.min).length());
        self.position - f * far
    }
}

impl RayBasis {
    /// Direction of the ray through the centre of pixel (col, row), row 0 at
    /// the bottom of the image (pyvr's order).
    pub fn direction(&self, col: u32, row: u32, width: u32, height: u32) -> DVec3 {
        self.ray(col, row, width, height).1
    }

    /// Origin and unit direction of the ray through the centre of pixel
    /// (col, row), row 0 at the bottom.
    pub fn ray(&self, col: u32, row: u32, width: u32, height: u32) -> (DVec3, DVec3) {
        let nx = 2.0 * (col as f64 + 0.5) / width as f64 - 1.0;
        let ny = 2.0 * (row as f64 + 0.5) / height as f64 - 1.0;
        if self.orthographic {
            (self.origin + self.right * nx + self.up * ny, self.forward)
        } else {
            (self.origin, (self.forward + self.right * nx + self.up * ny).normalize())
        }
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum LightKind {
    /// One direction for the whole scene: from `position` toward `target`.
    Directional,
    /// Light travels from `position` to each sample.
    Point,
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Light {
    pub position: DVec3,
    pub target: DVec3,
    pub ambient: f64,
    pub diffuse: f64,
    pub kind: LightKind,
}

impl Default for Light {
    fn default() -> Self {
        Light { position: DVec3::ONE, target: DVec3::ZERO, ambient: 0.2, diffuse: 0.8, kind: LightKind::Directional }
    }
}

impl Light {
    /// Unit direction the light travels at `p`, or `None` where it is
    /// undefined (zero length): such samples get no diffuse term.
    pub fn direction_at(&self, p: DVec3) -> Option<DVec3> {
        let v = match self.kind {
            LightKind::Directional => self.target - self.position,
            LightKind::Point => p - self.position,
        };
        let l = v.length();
        (l > 0.0 && l.is_finite()).then(|| v / l)
    }

    /// `ambient + diffuse * max(n . L, 0)`, pyvr's model; a zero normal or an
    /// undefined light direction leaves only the ambient term.
    pub fn intensity(&self, normal: Option<DVec3>, p: DVec3) -> f64 {
        if self.diffuse == 0.0 {
            return self.ambient;
        }
        match (normal, self.direction_at(p)) {
            (Some(n), Some(l)) => self.ambient + self.diffuse * n.dot(l).max(0.0),
            _ => self.ambient,
        }
    }
}

/// How a sample's normal is obtained.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Shading {
    /// No diffuse term: colour times ambient, no normals or gradients read.
    AmbientOnly,
    /// Normals supplied with the volume (pyvr's `compute_normal_volume`).
    Normals,
    /// Central differences of the sampled field, world-space, spacing-aware.
    Gradient,
}

impl Shading {
    /// The shader's `SHADING` override constant.
    pub fn code(self) -> u32 {
        match self {
            Shading::AmbientOnly => 0,
            Shading::Normals => 1,
            Shading::Gradient => 2,
        }
    }

    pub fn choose(light: &Light, has_normals: bool) -> Shading {
        if light.diffuse == 0.0 {
            Shading::AmbientOnly
        } else if has_normals {
            Shading::Normals
        } else {
            Shading::Gradient
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clip_planes_cut_rays_to_their_kept_side() {
        let plane = ClipPlane::new(DVec3::new(0.25, 0.0, 0.0), DVec3::new(-2.0, 0.0, 0.0)).unwrap();
        assert_eq!(plane.normal, DVec3::new(-1.0, 0.0, 0.0));
        // Along +x from x = -1: kept up to x = 0.25; along -x kept from there on.
        let (o, x) = (DVec3::new(-1.0, 0.0, 0.0), DVec3::X);
        assert_eq!(plane.cut(o, x, (0.5, 3.0)), Some((0.5, 1.25)));
        assert_eq!(plane.cut(DVec3::new(1.0, 0.0, 0.0), -x, (0.0, 3.0)), Some((0.75, 3.0)));
        // Beyond the span, and rays along the plane: on its kept side, on it, past it.
        assert_eq!(plane.cut(o, x, (1.5, 3.0)), None);
        assert_eq!(plane.cut(o, DVec3::Y, (0.0, 2.0)), Some((0.0, 2.0)));
        assert_eq!(plane.cut(DVec3::new(0.25, 0.0, 0.0), DVec3::Y, (0.0, 2.0)), Some((0.0, 2.0)));
        assert_eq!(plane.cut(DVec3::new(0.5, 0.0, 0.0), DVec3::Y, (0.0, 2.0)), None);
        // Normals of any magnitude have their direction; zero and NaN have none.
        for scale in [1e-300, 1e300] {
            let n = ClipPlane::new(DVec3::ZERO, DVec3::new(3.0, 0.0, 4.0) * scale).unwrap().normal;
            assert!((n - DVec3::new(0.6, 0.0, 0.8)).length() < 1e-15, "{scale}: {n}");
        }
        assert!(ClipPlane::new(DVec3::ZERO, DVec3::ZERO).is_err());
        assert!(ClipPlane::new(DVec3::new(f64::NAN, 0.0, 0.0), DVec3::X).is_err());
    }

    #[test]
    fn front_view_basis() {
        let cam = Camera {
            position: DVec3::new(3.0, 0.0, 0.0),
            target: DVec3::ZERO,
            up: DVec3::Z,
            fov_y: std::f64::consts::FRAC_PI_2,
            view_height: None,
        };
        let b = cam.basis(2, 1).unwrap();
        assert!((b.forward - DVec3::new(-1.0, 0.0, 0.0)).length() < 1e-12);
        // Screen right is +Y, up is +Z; aspect 2 and tan(45 deg) = 1.
        assert!((b.right - DVec3::new(0.0, 2.0, 0.0)).length() < 1e-12);
        assert!((b.up - DVec3::Z).length() < 1e-12);
    }

    #[test]
    fn up_parallel_to_view_falls_back() {
        let cam = Camera {
            position: DVec3::new(0.0, 0.0, 3.0),
            target: DVec3::ZERO,
            up: DVec3::Z,
            fov_y: 0.8,
            view_height: None,
        };
        let b = cam.basis(4, 4).unwrap();
        assert!(b.right.is_finite() && b.up.is_finite() && b.right.length() > 0.1);
    }

    #[test]
    fn box_intersection_with_zero_components() {
        let b = Bounds::default();
        let (t0, t1) = b.intersect(DVec3::new(-2.0, 0.0, 0.0), DVec3::X).unwrap();
        assert!((t0 - 1.5).abs() < 1e-12 && (t1 - 2.5).abs() < 1e-12);
        assert!(b.intersect(DVec3::new(-2.0, 0.7, 0.0), DVec3::X).is_none());
        // Inside: starts at the eye.
        let (t0, t1) = b.intersect(DVec3::ZERO, DVec3::Y).unwrap();
        assert_eq!(t0, 0.0);
        assert!((t1 - 0.5).abs() < 1e-12);
        // Box behind the eye.
        assert!(b.intersect(DVec3::new(2.0, 0.0, 0.0), DVec3::X).is_none());
    }

    #[test]
    fn light_without_direction_is_ambient() {
        let l = Light {
            position: DVec3::ZERO,
            target: DVec3::ZERO,
            ambient: 0.5,
            diffuse: 0.5,
            kind: LightKind::Directional,
        };
        assert_eq!(l.intensity(Some(DVec3::X), DVec3::ZERO), 0.5);
        let l = Light { kind: LightKind::Point, position: DVec3::new(2.0, 0.0, 0.0), ..l };
        // At the origin the light travels along -X; a normal along -X is fully lit.
        assert!((l.intensity(Some(-DVec3::X), DVec3::ZERO) - 1.0).abs() < 1e-12);
        assert_eq!(l.intensity(None, DVec3::ZERO), 0.5);
    }
}
