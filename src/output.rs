//! A frame as `render` returns it. The renderer makes premultiplied float
//! RGBA, row 0 at the bottom; a frame is returned as 8-bit codes or floats,
//! straight or premultiplied, transparent or over a background, with row 0
//! at the bottom or the top. The native march writes each pixel in the
//! returned format as it goes, and the GPU path converts its image as it
//! copies it out of the readback buffer, so a frame is never converted in
//! a pass of its own (at 2048x2048 that pass read 64 MiB and wrote 16).

use std::marker::PhantomData;

use crate::error::{try_zeroed, Error};

/// How a frame's pixels are returned.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Format {
    /// 8-bit codes (rounded half up, clamped to [0, 255]); else float32.
    pub codes: bool,
    /// Colour divided by alpha; else premultiplied.
    pub straight: bool,
    /// An opaque colour the frame is composited over; the result is opaque.
    pub background: Option<[f32; 3]>,
    /// Row 0 at the top; else at the bottom (the renderer's own order).
    pub top_down: bool,
}

impl Format {
    /// The renderer's own format: premultiplied floats, transparent, row 0
    /// at the bottom.
    pub const PREMULTIPLIED: Format = Format { codes: false, straight: false, background: None, top_down: false };

    /// Whether a pixel no ray colours is all zero bytes in this format: a
    /// zeroed image then needs no pass writing the pixels rays miss.
    pub fn blank_is_zero(&self) -> bool {
        self.background.is_none()
    }

    /// `src`'s pixels in this format as floats (`codes` is not asked).
    pub fn floats(&self, src: &[[f32; 4]], dst: &mut [[f32; 4]]) {
        match (self.background, self.straight) {
            (None, false) => dst.copy_from_slice(src),
            (None, true) => convert(src, dst, straight),
            (Some(b), false) => convert(src, dst, |c| over(c, b)),
            (Some(b), true) => convert(src, dst, |c| straight(over(c, b))),
        }
    }

    /// `src`'s pixels in this format as 8-bit codes.
    pub fn codes(&self, src: &[[f32; 4]], dst: &mut [[u8; 4]]) {
        // Each case is its own loop without branches, so that it is vectorised.
        match (self.background, self.straight) {
            (None, false) => convert(src, dst, |c| to_codes(c, false)),
            (None, true) => convert(src, dst, |c| to_codes(c, true)),
            // Over a background alpha is 1: straight colour is premultiplied.
            (Some(b), _) => convert(src, dst, |c| to_codes(over(c, b), false)),
        }
    }
}

#[inline(always)]
fn convert<T>(src: &[[f32; 4]], dst: &mut [T], f: impl Fn([f32; 4]) -> T) {
    assert_eq!(src.len(), dst.len(), "pixels");
    for (c, o) in src.iter().zip(dst) {
        *o = f(*c);
    }
}

/// Premultiplied colour over an opaque background: C + (1 - A) B, as
/// numpy's float32 `img[..., :3] += (1.0 - img[..., 3:4]) * bg` makes it.
#[inline(always)]
fn over(c: [f32; 4], b: [f32; 3]) -> [f32; 4] {
    let t = 1.0 - c[3];
    [c[0] + t * b[0], c[1] + t * b[1], c[2] + t * b[2], 1.0]
}

/// Straight colour as numpy's `clip(where(a > 0, c / a, c), 0, 1)` gives
/// it bit for bit: colour over alpha where alpha is above 0, kept where not
/// (nothing there, or the emission model's additive glow), then clamped
/// (clamp, as numpy's clip, keeps NaN and -0). Alpha is left as it is.
#[inline(always)]
fn straight(c: [f32; 4]) -> [f32; 4] {
    let a = c[3];
    let s = |v: f32| (if a > 0.0 { v / a } else { v }).clamp(0.0, 1.0);
    [s(c[0]), s(c[1]), s(c[2]), a]
}

/// 8-bit codes of premultiplied RGBA; `straight` divides colour by alpha
/// first (by its reciprocal). Rounded half up and clamped after scaling,
/// which gives the codes of clamping to [0, 1] first; max(NaN, 0) is 0.
#[inline(always)]
#[allow(clippy::manual_clamp)] // clamp would keep NaN
fn to_codes(c: [f32; 4], straight: bool) -> [u8; 4] {
    let q = |v: f32| -> u8 {
        let x = (v * 255.0 + 0.5).max(0.0).min(255.0);
        // SAFETY: x lies in [0, 255] (max(NaN, 0) is 0), where the
        // conversion is `as u8`'s; unchecked, it is one vector instruction
        // (the checked one kept the loop scalar).
        unsafe { x.to_int_unchecked::<i32>() as u8 }
    };
    let a = c[3];
    let s = if straight && a > 0.0 { 1.0 / a } else { 1.0 };
    [q(c[0] * s), q(c[1] * s), q(c[2] * s), q(a)]
}

/// Premultiplied float RGBA to 8-bit codes; `straight` un-premultiplies.
pub fn to_u8(rgba: &[f32], straight: bool, out: &mut [u8]) {
    let format = Format { codes: true, straight, ..Format::PREMULTIPLIED };
    format.codes(bytemuck::cast_slice(rgba), bytemuck::cast_slice_mut(out));
}

/// The pixels in each core's run, or None where one core does it all
/// (small frames): quantizing a large frame on one core takes longer than
/// a GPU takes to render it.
fn run_pixels(pixels: usize) -> Option<usize> {
    const MIN_PIXELS: usize = 1 << 16;
    let threads = crate::cores::cores().min(pixels / MIN_PIXELS);
    (threads > 1).then(|| pixels.div_ceil(threads))
}

/// A frame's pixels in their format.
pub enum Pixels {
    Floats(Vec<f32>),
    Codes(Vec<u8>),
}

/// A frame being returned: its pixels, size and format.
pub struct Image {
    pub pixels: Pixels,
    pub width: usize,
    pub height: usize,
    pub format: Format,
}

impl Image {
    /// An image of zero bytes (allocated zeroed: fresh pages the kernel
    /// zeroes as they are first written). Its pixels are transparent
    /// unless the format is over a background.
    pub fn zeroed(width: usize, height: usize, format: Format) -> Result<Image, Error> {
        let n = width * height * 4;
        let pixels = if format.codes {
            Pixels::Codes(try_zeroed(n, "the image")?)
        } else {
            Pixels::Floats(try_zeroed(n, "the image")?)
        };
        Ok(Image { pixels, width, height, format })
    }

    /// The image as a target the workers write.
    pub fn target(&mut self) -> Target<'_> {
        // (The kind follows the pixels, whatever the format says.)
        let (ptr, len, kind) = match &mut self.pixels {
            Pixels::Floats(v) => (v.as_mut_ptr() as *mut u8, v.len(), Kind::Floats),
            Pixels::Codes(v) => (v.as_mut_ptr(), v.len(), Kind::Codes),
        };
        assert_eq!(len, self.width * self.height * 4, "an image of width x height pixels");
        Target { ptr, width: self.width, height: self.height, format: self.format, kind, _image: PhantomData }
    }
}

/// What a target's memory holds.
#[derive(Clone, Copy, PartialEq)]
enum Kind {
    Floats,
    Codes,
    /// float64 sums of premultiplied frames, row 0 at the bottom.
    Sums,
}

/// An image written by several threads, each writing its own pixels: the
/// pixels are given in the renderer's order and format, and written in the
/// image's (or added to its sums).
pub struct Target<'a> {
    ptr: *mut u8,
    width: usize,
    height: usize,
    format: Format,
    kind: Kind,
    _image: PhantomData<&'a mut [u8]>,
}

// SAFETY: the workers write disjoint pixels (`put`'s contract).
unsafe impl Sync for Target<'_> {}

impl<'a> Target<'a> {
    /// `out` (width * height * 4 floats) in the float format `format`.
    pub fn floats(out: &'a mut [f32], width: usize, height: usize, format: Format) -> Target<'a> {
        assert!(!format.codes && out.len() == width * height * 4, "a float image of width x height");
        Target { ptr: out.as_mut_ptr() as *mut u8, width, height, format, kind: Kind::Floats, _image: PhantomData }
    }

    /// `out` (width * height * 4 float64 sums of premultiplied RGBA, row 0
    /// at the bottom), to which each frame written adds its pixels: frames
    /// are accumulated without an image of their own, and pixels no ray
    /// colours add nothing, so they need not be written.
    pub fn sums(out: &'a mut [f64], width: usize, height: usize) -> Target<'a> {
        assert_eq!(out.len(), width * height * 4, "sums of width x height pixels");
        let (ptr, format) = (out.as_mut_ptr() as *mut u8, Format::PREMULTIPLIED);
        Target { ptr, width, height, format, kind: Kind::Sums, _image: PhantomData }
    }

    /// Whether the target already holds what a pixel no ray colours would
    /// leave, for a target whose memory was zeroed (an image) or that sums.
    pub fn blank_when_zeroed(&self) -> bool {
        self.kind == Kind::Sums || self.format.blank_is_zero()
    }

    pub fn size(&self) -> (usize, usize) {
        (self.width, self.height)
    }

    pub fn format(&self) -> Format {
        self.format
    }

    /// Writes `src`, premultiplied float pixels, at columns `col0..` of row
    /// `row` (counted from the bottom), in the image's format.
    ///
    /// # Safety
    /// No other thread may write or read those pixels meanwhile.
    pub unsafe fn put(&self, row: usize, col0: usize, src: &[[f32; 4]]) {
        assert!(row < self.height && col0 + src.len() <= self.width, "pixels inside the image");
        let row = if self.format.top_down { self.height - 1 - row } else { row };
        let at = row * self.width + col0;
        // SAFETY: the pixels lie in the image (asserted), which outlives
        // 'a, and no other thread touches them (the caller's contract).
        unsafe {
            match self.kind {
                Kind::Codes => {
                    let dst = std::slice::from_raw_parts_mut((self.ptr as *mut [u8; 4]).add(at), src.len());
                    self.format.codes(src, dst);
                }
                Kind::Floats => {
                    let dst = std::slice::from_raw_parts_mut((self.ptr as *mut [f32; 4]).add(at), src.len());
                    self.format.floats(src, dst);
                }
                Kind::Sums => {
                    let dst = std::slice::from_raw_parts_mut((self.ptr as *mut [f64; 4]).add(at), src.len());
                    for (d, c) in dst.iter_mut().zip(src) {
                        *d = std::array::from_fn(|k| d[k] + c[k] as f64);
                    }
                }
            }
        }
    }

    /// Every pixel as no ray colours it: zeros, or the background (sums
    /// are left as they are: such a pixel adds zero).
    pub fn clear(&mut self) {
        if self.kind == Kind::Sums {
            return;
        }
        let zeros = [[0.0f32; 4]; 64];
        for row in 0..self.height {
            for col in (0..self.width).step_by(zeros.len()) {
                let n = zeros.len().min(self.width - col);
                // SAFETY: `&mut self`: no other thread holds the target.
                unsafe { self.put(row, col, &zeros[..n]) };
            }
        }
    }

    /// Writes `src`, a whole premultiplied float image (row 0 at the
    /// bottom), on every core in runs of rows.
    pub fn put_image(&mut self, src: &[f32]) {
        assert_eq!(src.len(), self.width * self.height * 4, "a whole image");
        let rows: &[[f32; 4]] = bytemuck::cast_slice(src);
        let w = self.width.max(1);
        let run = run_pixels(self.width * self.height).map_or(self.height, |p| p.div_ceil(w)).max(1);
        let this = &*self;
        let put_rows = |first: usize, part: &[[f32; 4]]| {
            for (k, row) in part.chunks(w).enumerate() {
                // SAFETY: each run writes only its own rows.
                unsafe { this.put(first + k, 0, row) };
            }
        };
        if run >= self.height {
            return put_rows(0, rows);
        }
        std::thread::scope(|s| {
            for (k, part) in rows.chunks(run * w).enumerate() {
                s.spawn(move || put_rows(k * run, part));
            }
        });
    }
}

#[cfg(test)]
mod tests {
    use super::{to_u8, Format, Image, Pixels, Target};

    /// Every format from a whole image on every core: the pixels of one
    /// core's rule, rows in the asked order, in runs that do not divide evenly.
    #[test]
    fn every_core_writes_the_pixels_of_one() {
        let (w, h) = (301, (1 << 18) / 301 + 3);
        let rgba: Vec<f32> = (0..4 * w * h).map(|i| ((i * 7919) % 1021) as f32 / 1000.0 - 0.01).collect();
        let px: &[[f32; 4]] = bytemuck::cast_slice(&rgba);
        for codes in [false, true] {
            for straight in [false, true] {
                for background in [None, Some([0.2, 0.9, 0.5])] {
                    for top_down in [false, true] {
                        let format = Format { codes, straight, background, top_down };
                        let mut image = Image::zeroed(w, h, format).unwrap();
                        image.target().put_image(&rgba);
                        for row in [0, 1, h / 2, h - 1] {
                            let src = &px[row * w..][..w];
                            let at = if top_down { h - 1 - row } else { row } * w * 4;
                            match &image.pixels {
                                Pixels::Codes(got) => {
                                    let mut want = vec![[0u8; 4]; w];
                                    format.codes(src, &mut want);
                                    assert!(got[at..at + 4 * w] == *want.as_flattened(), "{format:?} row {row}");
                                }
                                Pixels::Floats(got) => {
                                    let mut want = vec![[0f32; 4]; w];
                                    format.floats(src, &mut want);
                                    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                                    assert!(bits(&got[at..at + 4 * w]) == bits(want.as_flattened()), "{format:?}");
                                }
                            }
                        }
                    }
                }
            }
        }
    }

    /// Sums add each frame's pixels in float64, on every core, and a
    /// cleared frame adds nothing.
    #[test]
    fn sums_add_frames_in_float64() {
        let (w, h) = (257, 300);
        let a: Vec<f32> = (0..4 * w * h).map(|i| ((i * 7919) % 1021) as f32 / 1000.0 + 1e-9).collect();
        let b: Vec<f32> = a.iter().map(|v| 0.3 - v / 3.0).collect();
        let mut sums = vec![0.5f64; 4 * w * h];
        let mut target = Target::sums(&mut sums, w, h);
        assert!(target.blank_when_zeroed());
        target.put_image(&a);
        target.clear();
        target.put_image(&b);
        for (i, s) in sums.iter().enumerate() {
            assert_eq!(*s, 0.5 + a[i] as f64 + b[i] as f64, "{i}");
        }
    }

    /// Over a background: numpy's float32 rule, then opaque; the codes
    /// those of the composited floats; a cleared image is the background.
    #[test]
    fn composites_over_a_background() {
        let b = [0.25f32, 1.0, 0.0];
        let src = [[0.1f32, 0.2, 0.3, 0.4], [0.0, 0.0, 0.0, 0.0], [0.9, 0.1, 0.5, 1.0]];
        let format = Format { codes: false, straight: true, background: Some(b), top_down: false };
        let mut got = [[0f32; 4]; 3];
        format.floats(&src, &mut got);
        for (c, g) in src.iter().zip(got) {
            let t = 1.0f32 - c[3];
            let want: [f32; 3] = std::array::from_fn(|k| (c[k] + t * b[k]).clamp(0.0, 1.0));
            assert_eq!(g, [want[0], want[1], want[2], 1.0]);
        }
        let mut codes = [[0u8; 4]; 3];
        Format { codes: true, ..format }.codes(&src, &mut codes);
        assert_eq!(codes[1], [64, 255, 0, 255]);
        let mut float_codes = [0u8; 12];
        to_u8(got.as_flattened(), false, &mut float_codes);
        assert_eq!(codes.as_flattened(), float_codes);
        let mut image = Image::zeroed(3, 2, Format { codes: true, ..format }).unwrap();
        image.target().clear();
        let Pixels::Codes(px) = &image.pixels else { unreachable!() };
        assert!(px.chunks(4).all(|p| p == [64, 255, 0, 255]));
    }

    #[test]
    fn straightens_clamps_and_keeps_what_has_no_alpha() {
        let nan = f32::NAN;
        let px = [[0.25, 0.5, 2.0, 0.5], [0.3, -0.2, -0.0, 0.0], [nan, 0.2, 0.1, 0.4], [0.1, 0.2, 0.3, nan]];
        let mut got = [[0f32; 4]; 4];
        Format { straight: true, ..Format::PREMULTIPLIED }.floats(&px, &mut got);
        let want = [[0.5, 1.0, 1.0, 0.5], [0.3, 0.0, -0.0, 0.0], [nan, 0.5, 0.25, 0.4], [0.1, 0.2, 0.3, nan]];
        let bits = |x: &[[f32; 4]]| x.as_flattened().iter().map(|v| v.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&got), bits(&want));
    }

    #[test]
    fn rounds_clamps_and_unassociates() {
        let mut out = [0u8; 8];
        to_u8(&[0.25, 0.5, f32::NAN, 0.5, 2.0, -1.0, 0.0, 1.0], true, &mut out);
        assert_eq!(out, [128, 255, 0, 128, 255, 0, 0, 255]);
        to_u8(&[0.25, 0.5, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0], false, &mut out);
        assert_eq!(out, [64, 128, 0, 128, 0, 0, 0, 0]);
    }

    /// Clamping after scaling gives the codes of clamping to [0, 1] first,
    /// at every code's half-way point and around it.
    #[test]
    fn codes_are_those_of_clamping_first() {
        let first = |v: f32| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8;
        let mut values: Vec<f32> = (0..=120_000).map(|k| -0.1 + 1.2 * k as f32 / 120_000.0).collect();
        for c in 0..=256 {
            let mid = (c as f32 - 0.5) / 255.0;
            values.extend([mid, f32::from_bits(mid.to_bits() + 1), f32::from_bits(mid.to_bits().wrapping_sub(1))]);
        }
        values.extend([f32::INFINITY, f32::NEG_INFINITY, f32::MAX, -f32::MAX, 1e-45, -1e-45]);
        let rgba: Vec<f32> = values.iter().flat_map(|&v| [v, v, v, v]).collect();
        let mut out = vec![0u8; rgba.len()];
        to_u8(&rgba, false, &mut out);
        for (v, px) in values.iter().zip(out.chunks_exact(4)) {
            assert_eq!(px, [first(*v); 4], "{v}");
        }
    }
}
