//! Pre-integrated transfer functions (Engel, Kraus and Ertl, "High-Quality
//! Pre-Integrated Volume Rendering Using Hardware-Accelerated Pixel
//! Shading", 2001). A segment's value is taken to run linearly from its
//! front value to its back value; its colour and optical depth are the
//! emission–absorption integral along that ramp, tabulated over (front,
//! back) for one segment length. A sharp transfer-function peak that falls
//! between two samples is then still integrated, which midpoint sampling
//! misses at large steps.

use crate::config::OpacityCorrection;
use crate::integrate::{extinction, one_minus_exp_neg};
use crate::transfer::eval_lut;

/// Largest table side: 512^2 entries of 16 bytes (4 MiB).
pub const MAX_TABLE: usize = 512;

/// With `RenderConfig::refine`, a full segment is refined where the table's
/// opacity changes by more than this (summed from entry to entry) over the
/// values the segment can reach: a 64th of the opacity per reference step.
pub const REFINE_OPACITY_CHANGE: f64 = 1.0 / 64.0;

/// The running sum of |opacity change| from entry to entry of `lut`: entry
/// i holds the change over entries 0..=i, so the change over entries i..=j
/// is `[j] - [i]`.
pub fn opacity_change_sums(lut: &[[f32; 4]]) -> Vec<f32> {
    let mut sum = 0.0f64;
    let mut out = Vec::with_capacity(lut.len());
    for (i, e) in lut.iter().enumerate() {
        if i > 0 {
            sum += (e[3] as f64 - lut[i - 1][3] as f64).abs();
        }
        out.push(sum as f32);
    }
    out
}

/// The integral along a ramp from `vf` to `vb` over `len_over_ref`
/// reference steps, by `substeps` pieces each treated as homogeneous
/// (exact Beer–Lambert within a piece): unlit premultiplied colour
/// `∫ T σ c ds / ref` in [0..3] and optical depth `∫ σ ds / ref` in [3].
pub fn segment(
    lut: &[[f32; 4]],
    vf: f64,
    vb: f64,
    len_over_ref: f64,
    form: OpacityCorrection,
    substeps: usize,
) -> [f64; 4] {
    let k = substeps.max(1);
    let piece = len_over_ref / k as f64;
    let mut out = [0.0f64; 4];
    // Transmittance to the piece's front as a running product: one
    // exponential a piece instead of two, and in f64 a product of even
    // thousands of factors stays exact to ~1e-12.
    let mut trans = 1.0f64;
    for s in 0..k {
        let v = vf + (vb - vf) * ((s as f64 + 0.5) / k as f64);
        let rgba = eval_lut(lut, v);
        let x = extinction(rgba[3], form) * piece;
        if x > 0.0 {
            // 1 - exp(-x) without cancellation, and exp(-x) from it.
            let absorbed = one_minus_exp_neg(x);
            let w = trans * absorbed;
            for c in 0..3 {
                out[c] += w * rgba[c];
            }
            out[3] += x;
            trans *= 1.0 - absorbed;
        }
    }
    out
}

/// Pieces that resolve the table between `vf` and `vb`: one per table
/// interval the ramp crosses, plus one.
pub fn substeps_for(lut_len: usize, vf: f64, vb: f64) -> usize {
    let span = (vb - vf).abs().min(1.0) * lut_len.saturating_sub(1) as f64;
    span.ceil() as usize + 1
}

/// Rows of `width` entries that hold a row of `n` wrapped: row r holds
/// entries r (width - 1) to r (width - 1) + width - 1, so the last entry of
/// a row is the first of the next and an entry and the one after it always
/// share a row (a lerp between them reads one row). One row when n <= width.
pub fn wrapped_rows(n: usize, width: usize) -> usize {
    if n <= width || width < 2 {
        1
    } else {
        (n - 2) / (width - 1) + 1
    }
}

/// Row and column of entry `i` in `rows` wrapped rows of `width`: the rule
/// the shader and the native march each write out, checked here.
#[cfg(test)]
fn wrapped_at(i: usize, width: usize, rows: usize) -> (usize, usize) {
    let row = (i / (width - 1).max(1)).min(rows - 1);
    (row, i - row * (width - 1))
}

/// Smallest table side: frames read the table bilinearly between its
/// entries, and a ramp's integral is far from bilinear across a coarse
/// grid. Under a narrow opacity tent at step 0.05, tables as long as
/// lookup tables of 2, 8, 32 and 64 entries put frames 76, 8.9, 23 and 7.8
/// levels from the f64 integrator; at 256 a side, 0.005, 0.05, 0.42 and
/// 0.54 (a 256-entry lookup table's: 0.41).
pub const MIN_TABLE: usize = 256;

/// Side of the table for a lookup table of `lut_len` entries: its own
/// length between MIN_TABLE and MAX_TABLE (`table_windowed` cuts the table's
/// intervals at the lookup table's entries either way).
pub fn table_side(lut_len: usize) -> usize {
    lut_len.clamp(MIN_TABLE, MAX_TABLE)
}

/// `side x side` entries, row `b` (back value `b / (side - 1)`) after row
/// `b - 1`, column `f` the front value: RGB premultiplied colour and the
/// optical depth (clamped to 1e30, which is opaque) of one segment of
/// `len_over_ref` reference steps. Only entries whose front and back lie at
/// most `reach` entries apart are integrated (segments whose values cannot
/// change more read no others: `table_reach`); each of the others repeats
/// the entry `reach` apart in its row.
pub fn table(lut: &[[f32; 4]], len_over_ref: f64, form: OpacityCorrection, reach: usize) -> Vec<[f32; 4]> {
    let mut out = Vec::new();
    append_table(lut, len_over_ref, form, reach, &mut out);
    out
}

/// `table`, appended to `out` (whose capacity the caller may have sized
/// for what follows the table): each entry is written once, row by row,
/// from the band of entries integrated (a zeroed table filled in place
/// spent more time writing 1 MiB twice than integrating a narrow band).
pub fn append_table(
    lut: &[[f32; 4]],
    len_over_ref: f64,
    form: OpacityCorrection,
    reach: usize,
    out: &mut Vec<[f32; 4]>,
) {
    let m = table_side(lut.len());
    out.reserve(m * m);
    if lut.len() < 2 {
        // One entry: every ramp is one homogeneous stretch.
        let e = entry(segment(lut, 0.0, 0.0, len_over_ref, form, 1));
        out.extend(std::iter::repeat_n(e, m * m));
        return;
    }
    let reach = reach.clamp(1, m - 1);
    let band = table_windowed(lut, len_over_ref, form, m, reach);
    let width = band_width(m, reach);
    for b in 0..m {
        // Row b's fronts within the reach, the rest repeating the nearest.
        let row = &band[b * width..(b + 1) * width];
        let (lo, hi) = (b.saturating_sub(reach), (b + reach).min(m - 1));
        let (first, last) = (lo - band_start(m, reach, b), hi - band_start(m, reach, b));
        out.resize(out.len() + lo, row[first]);
        out.extend_from_slice(&row[first..=last]);
        out.resize(out.len() + (m - 1 - hi), row[last]);
    }
}

/// Entries a row of the band holds: every front within `reach` of the
/// row's back value, as many as the table's side at most.
fn band_width(m: usize, reach: usize) -> usize {
    (2 * reach + 1).min(m)
}

/// The first front value row `b` of the band holds: `reach` below `b`,
/// kept inside the table.
fn band_start(m: usize, reach: usize, b: usize) -> usize {
    b.saturating_sub(reach).min(m - band_width(m, reach))
}

/// Table entries between a segment's front and back values, at most:
/// values that change by at most `change` (in the transfer function's
/// [0, 1]) over a segment, in a table of `side` entries, with one entry
/// more for the sampler's neighbours and one for rounding.
pub fn table_reach(change: f64, side: usize) -> usize {
    let d = change * (side - 1) as f64 * (1.0 + 1e-3);
    if d.is_finite() && d < side as f64 {
        d.ceil() as usize + 2
    } else {
        side - 1
    }
}

fn entry(r: [f64; 4]) -> [f32; 4] {
    [r[0] as f32, r[1] as f32, r[2] as f32, r[3].min(1e30) as f32]
}

/// Largest optical depth of one homogeneous piece of the windowed table
/// (`table_windowed`), and the fewest and most pieces per stretch.
const PIECE_DEPTH: f64 = 0.05;
const MIN_PIECES: usize = 4;
const MAX_PIECES: usize = 64;

/// Optical depth of a piece past which nothing behind it shows (exp(-40)
/// is 4e-18): a stretch whose every piece is that deep is composed from
/// its first piece one way and its last the other, which bounds the work
/// for dense tables (the power form's opacity 1 is infinitely deep).
const OPAQUE_PIECE: f64 = 40.0;

/// A stretch of a segment: premultiplied colour, optical depth and
/// transmittance (kept as a product: composing then needs no exponential).
#[derive(Clone, Copy)]
struct Piece {
    c: [f64; 3],
    x: f64,
    t: f64,
}

impl Piece {
    const EMPTY: Piece = Piece { c: [0.0; 3], x: 0.0, t: 1.0 };

    /// This stretch, then `b` behind it.
    fn then(self, b: Piece) -> Piece {
        let c = std::array::from_fn(|k| self.c[k] + self.t * b.c[k]);
        Piece { c, x: self.x + b.x, t: self.t * b.t }
    }

    /// A homogeneous piece of colour `rgba` (alpha as extinction) and
    /// optical depth `x`.
    fn homogeneous(rgba: [f64; 4], x: f64) -> Piece {
        if !(x > 0.0) {
            return Piece::EMPTY;
        }
        let absorbed = absorbed_by(x);
        Piece { c: [rgba[0] * absorbed, rgba[1] * absorbed, rgba[2] * absorbed], x, t: 1.0 - absorbed }
    }
}

/// The parts of the lookup table within table interval `k` of a side-`m`
/// table over `n` entries (values k / (m - 1) to (k + 1) / (m - 1)): for
/// each lookup-table interval it meets, the interval, the fractions of it
/// where the part starts and ends, and the part's share of interval `k`.
/// When the table sits on the entries (m = n) that is interval k whole.
fn stretches(n: usize, m: usize, k: usize) -> impl Iterator<Item = (usize, f64, f64, f64)> {
    let scale = (n - 1) as f64 / (m - 1) as f64;
    let (x0, x1) = (k as f64 * scale, (k + 1) as f64 * scale);
    let first = (x0.floor() as usize).min(n - 2);
    let last = (x1.ceil() as usize).clamp(first + 1, n - 1);
    (first..last).filter_map(move |i| {
        let (u, w) = (x0.max(i as f64), x1.min((i + 1) as f64));
        (w > u).then(|| (i, u - i as f64, w - i as f64, (w - u) / (x1 - x0)))
    })
}

/// The lookup table at fraction `f` of its interval `i` (its entries
/// themselves at 0 and 1).
fn lerp_entry(lut: &[[f32; 4]], i: usize, f: f64) -> [f64; 4] {
    let (a, b) = (lut[i].map(f64::from), lut[i + 1].map(f64::from));
    if f == 0.0 {
        a
    } else if f == 1.0 {
        b
    } else {
        std::array::from_fn(|c| a[c] + (b[c] - a[c]) * f)
    }
}

/// The table by windows: a ramp between table entries f and b crosses
/// d = |b - f| whole table intervals, spending len / d in each. Each
/// interval is integrated once per d (`Span::pieces`: pieces cut at the
/// lookup table's entries, where the integrand has its kinks) and the
/// entries of each d are windows of d consecutive intervals, composed in
/// the ramp's direction in O(1) each from running compositions within
/// blocks of d intervals. O(side^2) pieces where integrating every entry
/// on its own takes O(side^3), and closer to the exact integral (the tests
/// below). A lookup
/// table longer than the table's side (MAX_TABLE) puts several of its
/// intervals in each table interval; integrating each entry on its own
/// took 0.55 s at 1024 entries and grew with their number.
fn table_windowed(
    lut: &[[f32; 4]],
    len_over_ref: f64,
    form: OpacityCorrection,
    m: usize,
    reach: usize,
) -> Vec<[f32; 4]> {
    let n = lut.len();
    let width = band_width(m, reach);
    // Entry (front f, back b) at band[b * width + f - band_start(b)].
    let at = |f: usize, b: usize| b * width + f - band_start(m, reach, b);
    let mut band = vec![[0.0f32; 4]; m * width];
    let spans: Vec<Span> = (0..m - 1).map(|k| Span::new(lut, form, n, m, k)).collect();
    let spans = &spans;
    // The diagonal: a constant value, one homogeneous piece of full length.
    for f in 0..m {
        let v = f as f64 / (m - 1) as f64;
        band[at(f, f)] = entry(segment(lut, v, v, len_over_ref, form, 1));
    }
    // Windows of every length d up to the reach, both ways, each written
    // straight into its entry of the band.
    let out = BandWriter(band.as_mut_ptr(), band.len());
    let out = &out;
    let windows_of = |d: usize, scratch: &mut Scratch| {
        let len = len_over_ref / d as f64;
        let Scratch { up, down, to_end, from_start } = scratch;
        up.clear();
        down.clear();
        for span in spans {
            let (u, w) = span.pieces(lut, form, n, m, len);
            up.push(u);
            down.push(w);
        }
        down.reverse();
        // SAFETY (both writes): `at` lies in the band, and entry (f, b) is
        // written only by the window of length d = |f - b|, which only one
        // thread composes.
        windows(up, d, to_end, from_start, |s0, w| unsafe { out.write(at(s0, s0 + d), w) });
        // down[j] is interval m - 2 - j: window j runs from entry m - 1 - j down to m - 1 - j - d.
        windows(down, d, to_end, from_start, |j, w| unsafe { out.write(at(m - 1 - j, m - 1 - j - d), w) });
    };
    // A thread each only where there is work enough: a thread for fewer
    // lengths costs more to start than its share of the work.
    let threads = crate::cores::cores().min(reach / THREAD_LENGTHS).max(1);
    if threads == 1 {
        let mut scratch = Scratch::default();
        (1..=reach).for_each(|d| windows_of(d, &mut scratch));
    } else {
        std::thread::scope(|s| {
            for t in 0..threads {
                s.spawn(move || {
                    let mut scratch = Scratch::default();
                    // Every threads-th d, so that each thread gets long and short windows alike.
                    (1 + t..=reach).step_by(threads).for_each(|d| windows_of(d, &mut scratch));
                });
            }
        });
    }
    band
}

/// Window lengths per thread below which `table_windowed` stays on one.
const THREAD_LENGTHS: usize = 16;

/// One table interval, for composing it at any length: its thin series
/// both ways (`Thin`), and the largest of its stretches' extinction times
/// their share of it (times the length crossing it: the densest piece
/// count's numerator).
struct Span {
    k: usize,
    thin: [Thin; 2],
    steep: f64,
}

impl Span {
    fn new(lut: &[[f32; 4]], form: OpacityCorrection, n: usize, m: usize, k: usize) -> Span {
        // MIN_PIECES pieces per stretch: colour and extinction per unit length crossing the interval.
        let mut pieces = Vec::new();
        let mut steep = 0.0f64;
        for (i, u0, u1, share) in stretches(n, m, k) {
            let ends = [lerp_entry(lut, i, u0), lerp_entry(lut, i, u1)];
            steep = steep.max(extinction(ends[0][3], form).max(extinction(ends[1][3], form)) * share);
            for p in 0..MIN_PIECES {
                let f = (p as f64 + 0.5) / MIN_PIECES as f64;
                let e: [f64; 4] = std::array::from_fn(|c| ends[0][c] + (ends[1][c] - ends[0][c]) * f);
                pieces.push([e[0], e[1], e[2], extinction(e[3], form) * share / MIN_PIECES as f64]);
            }
        }
        Span { k, thin: [Thin::along(pieces.iter()), Thin::along(pieces.iter().rev())], steep }
    }

    /// The interval crossed in `len` reference steps, upwards and
    /// downwards: homogeneous pieces of optical depth at most PIECE_DEPTH
    /// under each stretch's densest end (MIN_PIECES to MAX_PIECES of them),
    /// or, where all are MIN_PIECES thin ones, its series.
    fn pieces(&self, lut: &[[f32; 4]], form: OpacityCorrection, n: usize, m: usize, len: f64) -> (Piece, Piece) {
        if self.steep * len <= MIN_PIECES as f64 * PIECE_DEPTH && self.thin[0].depth * len < THIN_DEPTH {
            return (self.thin[0].piece(len), self.thin[1].piece(len));
        }
        let (mut up, mut down) = (Piece::EMPTY, Piece::EMPTY);
        let mut buf = [Piece::EMPTY; MAX_PIECES];
        for (i, u0, u1, share) in stretches(n, m, self.k) {
            let ends = [lerp_entry(lut, i, u0), lerp_entry(lut, i, u1)];
            let stretch_len = len * share;
            let densest = extinction(ends[0][3], form).max(extinction(ends[1][3], form)) * stretch_len;
            let want = (densest / PIECE_DEPTH).ceil();
            let q =
                if want.is_nan() || want > MAX_PIECES as f64 { MAX_PIECES } else { (want as usize).max(MIN_PIECES) };
            let piece_len = stretch_len / q as f64;
            let at = |p: usize| {
                let rgba = lerp_entry(lut, i, u0 + (u1 - u0) * ((p as f64 + 0.5) / q as f64));
                Piece::homogeneous(rgba, extinction(rgba[3], form) * piece_len)
            };
            let lightest = extinction(ends[0][3], form).min(extinction(ends[1][3], form)) * piece_len;
            let (s_up, s_down) = if lightest > OPAQUE_PIECE {
                // Every piece opaque: only the first shows one way and the last the other.
                let (first, last) = (at(0), at(q - 1));
                let x = first.x.max(last.x) * q as f64;
                (Piece { x, ..first }, Piece { x, ..last })
            } else {
                for (p, piece) in buf[..q].iter_mut().enumerate() {
                    *piece = at(p);
                }
                (
                    buf[..q].iter().fold(Piece::EMPTY, |acc, &b| acc.then(b)),
                    buf[..q].iter().rev().fold(Piece::EMPTY, |acc, &b| acc.then(b)),
                )
            };
            up = up.then(s_up);
            down = s_down.then(down);
        }
        (up, down)
    }
}

/// Optical depth under which a table interval's thin pieces are composed
/// from their moments (`Thin`): the series' first omitted term is then
/// about depth^4 / 120 = 1.3e-9 of the colour.
const THIN_DEPTH: f64 = 0.02;

/// A sequence of pieces, composed in order, as a power series in the
/// length l that crosses them all. With S_p the extinction of the pieces
/// before piece p (per unit l), piece p adds c_p (exp(-S_p l) -
/// exp(-S_{p+1} l)), so the colour is sum_k (-1)^(k+1) l^k A_k with
/// A_k = sum_p c_p (S_{p+1}^k - S_p^k) / k!. Long ramps cross many short
/// intervals, and four terms then give each in a few multiplications,
/// where the pieces take an exponential each.
#[derive(Clone, Copy)]
struct Thin {
    moments: [[f64; 3]; 4],
    /// Extinction of all the pieces together (per unit l).
    depth: f64,
}

impl Thin {
    /// `pieces`: colour and extinction per unit l of each, in order.
    fn along<'a>(pieces: impl Iterator<Item = &'a [f64; 4]>) -> Thin {
        let mut moments = [[0.0; 3]; 4];
        let mut before = 0.0f64;
        for e in pieces {
            let after = before + e[3];
            let mut fact = 1.0;
            let (mut pa, mut pb) = (after, before);
            for (k, m) in moments.iter_mut().enumerate() {
                fact *= (k + 1) as f64;
                let w = (pa - pb) / fact;
                for c in 0..3 {
                    m[c] += e[c] * w;
                }
                pa *= after;
                pb *= before;
            }
            before = after;
        }
        Thin { moments, depth: before }
    }

    fn piece(&self, l: f64) -> Piece {
        let m = &self.moments;
        let c = std::array::from_fn(|k| l * (m[0][k] - l * (m[1][k] - l * (m[2][k] - l * m[3][k]))));
        let x = self.depth * l;
        Piece { c, x, t: 1.0 - absorbed_by(x) }
    }
}

/// `1 - exp(-x)`: a piece's absorption. Most pieces of long ramps are thin
/// (x well under 1e-3), where four terms of the series are exact to f64
/// rounding (the next is x^5 / 120 < 1e-17) at a fraction of `exp_m1`'s cost.
#[inline]
fn absorbed_by(x: f64) -> f64 {
    if x < 1e-3 {
        x * (1.0 - x * 0.5 * (1.0 - x / 3.0 * (1.0 - x * 0.25)))
    } else {
        one_minus_exp_neg(x)
    }
}

/// The compositions of every `d` consecutive pieces, in order, each
/// passed to `emit` with its first piece's index: within blocks of `d`,
/// each piece's composition to its block's end and from its block's start
/// (in `to_end` and `from_start`, reused between calls); a window is the
/// first of one and the second of the next.
fn windows(
    a: &[Piece],
    d: usize,
    to_end: &mut Vec<Piece>,
    from_start: &mut Vec<Piece>,
    mut emit: impl FnMut(usize, Piece),
) {
    let len = a.len();
    to_end.clear();
    to_end.extend_from_slice(a);
    from_start.clear();
    from_start.extend_from_slice(a);
    for start in (0..len).step_by(d) {
        let end = (start + d).min(len);
        for i in (start..end - 1).rev() {
            to_end[i] = a[i].then(to_end[i + 1]);
        }
        for i in start + 1..end {
            from_start[i] = from_start[i - 1].then(a[i]);
        }
    }
    for s in 0..=len - d {
        emit(s, if s % d == 0 { to_end[s] } else { to_end[s].then(from_start[s + d - 1]) });
    }
}

/// A thread's buffers for `table_windowed`: one window length's pieces
/// both ways, and `windows`' running compositions.
#[derive(Default)]
struct Scratch {
    up: Vec<Piece>,
    down: Vec<Piece>,
    to_end: Vec<Piece>,
    from_start: Vec<Piece>,
}

/// The band's entries (and how many), written by `table_windowed`'s
/// threads, each its own.
struct BandWriter(*mut [f32; 4], usize);

// SAFETY: the threads write disjoint entries (`table_windowed`) and nothing
// reads the band until they have all finished.
unsafe impl Sync for BandWriter {}

impl BandWriter {
    /// # Safety
    /// `idx` lies in the band, and no other thread writes it.
    unsafe fn write(&self, idx: usize, w: Piece) {
        debug_assert!(idx < self.1, "entry {idx} outside a band of {}", self.1);
        // SAFETY: the caller's contract.
        unsafe { *self.0.add(idx) = entry([w.c[0], w.c[1], w.c[2], w.x]) };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every entry of a wrapped row lies in its rows, and so does the one
    /// after it, in the same row: a lerp between them reads one row.
    #[test]
    fn wrapped_rows_keep_each_entry_with_the_next() {
        for (n, width) in [(1, 2), (2, 2), (7, 2), (256, 256), (512, 512), (513, 512), (1024, 512), (16384, 512)] {
            let rows = wrapped_rows(n, width);
            assert_eq!(rows == 1, n <= width, "{n} {width}");
            for i in 0..n {
                let (r, c) = wrapped_at(i, width, rows);
                assert!(r < rows && c < width && r * (width - 1) + c == i, "{n} {width} {i}");
                if i + 1 < n {
                    assert!(c + 1 < width, "{n} {width} {i}: the next entry is past the row");
                }
            }
        }
    }

    #[test]
    fn constant_ramp_is_beer_lambert() {
        let lut = [[0.8f32, 0.4, 0.2, 0.3]; 4];
        let r = segment(&lut, 0.5, 0.5, 7.0, OpacityCorrection::Exponential, 1);
        let a = 1.0 - (-(0.3f32 as f64) * 7.0).exp();
        assert!((r[0] - 0.8f32 as f64 * a).abs() < 1e-12);
        assert!((r[3] - 0.3f32 as f64 * 7.0).abs() < 1e-12);
    }

    /// The largest colour difference, and optical-depth difference relative
    /// to the depth (or 1e-3), of table `t` from the (front, back) entries
    /// `at` integrated on their own with 256 pieces per interval crossed.
    fn worst_against_fine(
        lut: &[[f32; 4]],
        t: &[[f32; 4]],
        len: f64,
        form: OpacityCorrection,
        at: &[(usize, usize)],
    ) -> [f64; 2] {
        let m = table_side(lut.len());
        let mut worst = [0.0f64; 2];
        for &(f, b) in at {
            let (vf, vb) = (f as f64 / (m - 1) as f64, b as f64 / (m - 1) as f64);
            let r = segment(lut, vf, vb, len, form, 256 * substeps_for(lut.len(), vf, vb));
            let e = t[b * m + f];
            for c in 0..3 {
                worst[0] = worst[0].max((e[c] as f64 - r[c]).abs());
            }
            let x = r[3].min(1e30);
            worst[1] = worst[1].max((e[3] as f64 - x).abs() / x.max(1e-3));
        }
        worst
    }

    /// `n` entries of random colour and opacity up to `opacity`
    /// (neighbouring entries far apart), from `seed`.
    fn rough_lut(seed: u64, n: usize, opacity: f32) -> Vec<[f32; 4]> {
        let mut seed = seed;
        let mut rand = || {
            seed = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (seed >> 40) as f32 / (1u64 << 24) as f32
        };
        (0..n).map(|_| [rand(), rand(), rand(), opacity * rand() * rand()]).collect()
    }

    /// In both correction forms at two lengths, the table's entries `at`
    /// within 2.5e-3 in colour and 1% in optical depth (`worst_against_fine`).
    fn assert_table_near_fine(lut: &[[f32; 4]], at: &[(usize, usize)]) {
        for form in [OpacityCorrection::Exponential, OpacityCorrection::Power] {
            for len in [0.3, 4.0] {
                let worst = worst_against_fine(lut, &table(lut, len, form, usize::MAX), len, form, at);
                assert!(worst[0] < 2.5e-3 && worst[1] < 1e-2, "{form:?} len {len}: {worst:?}");
            }
        }
    }

    /// The windowed table against each entry integrated on its own, finely,
    /// for a rough table in both correction forms, with an opaque entry.
    /// Measured: colour within 7.5e-4 (under a fifth of an 8-bit level),
    /// optical depth within 1.4e-3 relative (the power form's log
    /// singularity at the opaque entry); a reference of 64 pieces per
    /// interval was itself 2.7e-3 off once the table's entries fell between
    /// the lookup table's. One piece per interval crossed, plus one, not cut
    /// at the entries, was off by 0.05-0.67 and 0.1-1e30.
    #[test]
    fn the_table_matches_each_segment_integrated_finely() {
        let mut lut = rough_lut(12345, 37, 1.0);
        lut[20][3] = 1.0;
        // Every 5th entry of the 256 a side, and those beside the 37 entries' first interval.
        let picks = |k: usize| (0..table_side(lut.len())).step_by(k).chain([6, 7, 8]);
        let at: Vec<(usize, usize)> = picks(5).flat_map(|b| picks(5).map(move |f| (f, b))).collect();
        assert_table_near_fine(&lut, &at);
    }

    /// A lookup table longer than the table's side: table intervals span
    /// several of its intervals (cut at its entries), against entries
    /// integrated on their own, finely, for a rough table with a narrow
    /// peak between table entries and an opaque entry, in both forms.
    /// Measured: colour within 1.3e-3, optical depth within 8.3e-3 relative
    /// (the power form's opaque entry, as on the entries).
    #[test]
    fn a_longer_lookup_table_is_integrated_across_its_entries() {
        let n = MAX_TABLE + 190;
        let mut lut = rough_lut(777, n, 0.2);
        lut[300][3] = 0.9; // one entry: narrower than a table interval (1.37 entries)
        lut[501][3] = 1.0;
        let m = table_side(n);
        assert_eq!(m, MAX_TABLE);
        let picks = |k: usize| (0..m).step_by(k).chain([219, 220, 221]);
        let at: Vec<(usize, usize)> = picks(41).flat_map(|b| picks(37).map(move |f| (f, b))).collect();
        assert_table_near_fine(&lut, &at);
    }

    #[test]
    fn a_peak_between_samples_is_integrated() {
        // Opacity only in a narrow band around 0.5; a ramp from 0 to 1
        // crosses it, while its midpoint sample (0.5) would not see the
        // band's true width. The table's optical depth must equal the band's
        // integral over value times the length: ∫σ dv * len.
        let m = 256;
        let lut: Vec<[f32; 4]> = (0..m)
            .map(|i| {
                let v = i as f64 / (m - 1) as f64;
                [1.0, 1.0, 1.0, if (v - 0.5).abs() < 0.02 { 1.0 } else { 0.0 }]
            })
            .collect();
        let t = table(&lut, 3.0, OpacityCorrection::Exponential, usize::MAX);
        let n = table_side(m);
        let e = t[(n - 1) * n]; // front 0, back 1
        let band: f64 = (0..100_000).map(|i| eval_lut(&lut, (i as f64 + 0.5) / 100_000.0)[3]).sum::<f64>() / 100_000.0;
        assert!((e[3] as f64 - band * 3.0).abs() < 1e-4, "{} vs {}", e[3], band * 3.0);
        // Symmetric in the optical depth, not in colour order (only one colour here).
        let back = t[n - 1];
        assert!((back[3] - e[3]).abs() < 1e-6);
    }

    /// A thin table interval's series against its pieces composed one by
    /// one, both ways, over depths up to THIN_DEPTH, for colour and opacity
    /// changing across it: on the lookup table's entries (one stretch) and
    /// over three of its intervals (a longer lookup table than the table).
    #[test]
    fn thin_intervals_compose_as_their_pieces() {
        let lut = [[0.9f32, 0.1, 0.4, 0.02], [0.2, 0.7, 0.5, 0.9], [0.0, 0.0, 1.0, 0.0], [0.5, 0.5, 0.5, 0.3]];
        for form in [OpacityCorrection::Exponential, OpacityCorrection::Power] {
            for (m, k) in [(4, 0), (4, 1), (2, 0)] {
                let span = Span::new(&lut, form, lut.len(), m, k);
                for depth in [1e-6, 1e-3, THIN_DEPTH] {
                    let len = depth / span.thin[0].depth;
                    let mut pieces = Vec::new();
                    for (i, u0, u1, share) in stretches(lut.len(), m, k) {
                        for p in 0..MIN_PIECES {
                            let f = u0 + (u1 - u0) * (p as f64 + 0.5) / MIN_PIECES as f64;
                            let e = lerp_entry(&lut, i, f);
                            let x = extinction(e[3], form) * len * share / MIN_PIECES as f64;
                            pieces.push(Piece::homogeneous(e, x));
                        }
                    }
                    assert_eq!(pieces.len(), if m == 2 { 3 * MIN_PIECES } else { MIN_PIECES });
                    let up = pieces.iter().fold(Piece::EMPTY, |a, &b| a.then(b));
                    let down = pieces.iter().rev().fold(Piece::EMPTY, |a, &b| a.then(b));
                    for (want, got) in [(up, span.thin[0].piece(len)), (down, span.thin[1].piece(len))] {
                        let bound = depth.powi(4) / 60.0 * want.c.iter().fold(0.0f64, |m, v| m.max(v.abs())) + 1e-16;
                        for c in 0..3 {
                            let off = (want.c[c] - got.c[c]).abs();
                            assert!(off <= bound, "{form:?} {m} {k} {depth}: {:?} {:?}", want.c, got.c);
                        }
                        assert!((want.x - got.x).abs() <= 1e-14 * want.x && (want.t - got.t).abs() <= 1e-15);
                    }
                }
            }
        }
    }

    #[test]
    fn a_table_within_a_reach_holds_the_whole_tables_entries_there() {
        let lut = rough_lut(7, 256, 0.9);
        let full = table(&lut, 2.0, OpacityCorrection::Exponential, usize::MAX);
        let m = table_side(lut.len());
        for reach in [1, 3, 40, 200] {
            let part = table(&lut, 2.0, OpacityCorrection::Exponential, reach);
            for b in 0..m {
                for f in 0..m {
                    // Outside the reach, the entry `reach` apart in the same row.
                    let g = f.clamp(b.saturating_sub(reach), (b + reach).min(m - 1));
                    assert_eq!(part[b * m + f], full[b * m + g], "reach {reach}: entry ({f}, {b})");
                }
            }
        }
        // Values that change by 0.01 over a segment reach 3 entries of 256 (2.55), and one each side more.
        assert_eq!(table_reach(0.01, 256), 5);
        assert_eq!(table_reach(2.0, 256), 255);
        assert_eq!(table_reach(f64::NAN, 256), 255);
    }
}
