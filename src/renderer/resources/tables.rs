//! The transfer-function table and the pre-integration tables derived
//! from it, kept for the last few segment lengths.

use super::*;
use crate::config::OpacityCorrection;
use crate::error::Error;
use crate::half::f32_to_f16;
use crate::preintegrate;
use crate::renderer::device::Device;

/// RGBA rows as a filterable texture: f32 when the device can filter it,
/// else f16 (`cap` caps values f16 cannot hold).
pub(super) fn float_table(dev: &Device, rows: &[[f32; 4]], cap: Option<f32>) -> (wgpu::TextureFormat, Vec<u8>) {
    if dev.caps.float32_filterable {
        (wgpu::TextureFormat::Rgba32Float, bytemuck::cast_slice(rows).to_vec())
    } else {
        let h: Vec<u16> = rows.iter().flatten().map(|&v| f32_to_f16(cap.map_or(v, |c| v.min(c)))).collect();
        (wgpu::TextureFormat::Rgba16Float, bytemuck::cast_slice(&h).to_vec())
    }
}

/// The pre-integration texture's texels, `side` wide: the `side` x `side`
/// table, then the running sums of the opacity change between `lut`'s
/// entries (`preintegrate::opacity_change_sums`, in every channel; read by
/// refined frames), then the transfer-function table `lut`, so that a
/// pre-integrated frame reads a shorter segment's midpoint entry from the
/// same texture as a full segment's, in one fetch chosen by select (a fetch
/// of its own, in a branch, cost 12-18% of such a frame on lavapipe). Both
/// are wrapped into rows of the table's width (`preintegrate::wrapped_rows`):
/// a longer transfer function made every row as wide as itself, 34 MB of
/// texels at 4096 entries instead of 4.4. Each row of `lut` comes twice, and
/// frames sample it between the two, where the sampler's filtering mixes
/// the row with nothing but itself. Rows short of the width repeat their
/// last entry.
pub(super) fn with_lut_row(key: &PreintKey, lut: &[[f32; 4]]) -> crate::cpu::PreintTable {
    let side = preintegrate::table_side(lut.len());
    let rows = preintegrate::wrapped_rows(lut.len(), side);
    let mut texels = Vec::with_capacity(side * (side + 3 * rows));
    preintegrate::append_table(lut, key.len_over_ref, key.form, key.reach, &mut texels);
    let wrapped = |texels: &mut Vec<[f32; 4]>, entries: &[[f32; 4]], copies: usize| {
        let last = entries.last().copied().unwrap_or([0.0; 4]);
        for r in 0..rows {
            for _ in 0..copies {
                texels.extend((0..side).map(|c| entries.get(r * (side - 1) + c).copied().unwrap_or(last)));
            }
        }
    };
    let sums: Vec<[f32; 4]> = preintegrate::opacity_change_sums(lut).into_iter().map(|c| [c; 4]).collect();
    wrapped(&mut texels, &sums, 1);
    wrapped(&mut texels, lut, 2);
    crate::cpu::PreintTable { texels, side, rows }
}

/// The transfer-function table and what is derived from it.
pub struct Tables {
    /// The table (entries at scalars m / (M - 1)) as an M x 1 texture the
    /// sampler interpolates, and M.
    pub lut: Option<(Option<wgpu::TextureView>, u32)>,
    /// The rows last uploaded, kept to recompute occupancy and pre-integration.
    pub rows: Vec<[f32; 4]>,
    /// A one-entry table as two equal entries: the native march reads a
    /// sample's pair of neighbouring entries (a texture of one entry is the
    /// same constant to the sampler).
    pair: [[f32; 4]; 2],
    /// Bumped by every upload, so derived tables know when to rebuild.
    pub version: u64,
    /// The pre-integration table and what it was built for; its texture
    /// is uploaded when a frame on the device first needs it (the native
    /// march reads only the texels).
    pub preint: Option<(Option<wgpu::TextureView>, PreintKey)>,
    /// The same texture's texels, for the native march.
    pub preint_texels: crate::cpu::PreintTable,
    /// Tables of this transfer function for other segment lengths, latest
    /// first: a session that switches steps (a coarse step while the view
    /// moves, a fine one at rest; pilots of a step search) swaps them back
    /// in instead of rebuilding.
    preint_spares: Vec<(Option<wgpu::TextureView>, PreintKey, crate::cpu::PreintTable)>,
}

/// Pre-integration tables kept besides the current one, and the most
/// their texels may take together: 1 MiB for 256 entries (and as much
/// again on the device), 4.2-5.2 MiB from 512 entries on (`with_lut_row`).
pub(super) const PREINT_SPARES: usize = 3;
pub(super) const PREINT_SPARE_BYTES: usize = 24 << 20;

/// What a pre-integration table depends on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PreintKey {
    pub lut_version: u64,
    pub len_over_ref: f64,
    pub form: OpacityCorrection,
    /// Entries apart that a segment's front and back can lie
    /// (`preintegrate::table_reach`): only those are integrated.
    pub reach: usize,
}

impl Tables {
    pub fn new() -> Tables {
        Tables {
            lut: None,
            rows: Vec::new(),
            pair: [[0.0; 4]; 2],
            version: 0,
            preint: None,
            preint_texels: Default::default(),
            preint_spares: Vec::new(),
        }
    }

    /// Uploads the table: a texture fetch is far cheaper than an indexed
    /// storage-buffer read on CPU drivers; f16 (where f32 cannot be filtered)
    /// is within 0.13 of an 8-bit level. Returns the bytes written.
    pub fn upload_lut(&mut self, dev: &Device, lut: &[[f32; 4]]) -> Result<u64, Error> {
        if lut.is_empty() {
            return Err(Error::InvalidInput("the transfer-function table must have at least one entry".into()));
        }
        let max = dev.caps.max_texture_2d;
        if lut.len() > max {
            return Err(Error::DeviceLimit(format!(
                "transfer-function table of {} entries exceeds this device's limit of {max} entries",
                lut.len()
            )));
        }
        let (format, bytes) = float_table(dev, lut, None);
        let size = wgpu::Extent3d { width: lut.len() as u32, height: 1, depth_or_array_layers: 1 };
        let view = dev.texture("uploading the transfer function", "lut", size, D2, format, &bytes)?;
        // (Without a device nothing is uploaded.)
        let uploaded = if view.is_some() { bytes.len() as u64 } else { 0 };
        self.lut = Some((view, lut.len() as u32));
        self.rows = lut.to_vec();
        self.pair = [lut[0]; 2];
        self.version += 1;
        self.preint_spares.clear();
        Ok(uploaded)
    }

    /// The table as the native march reads it: at least two entries.
    pub fn march_rows(&self) -> &[[f32; 4]] {
        if self.rows.len() >= 2 {
            &self.rows
        } else {
            &self.pair
        }
    }

    /// Makes the pre-integration table for `key` current: the current one
    /// if it was built for `key`, else a kept one, else a new one (its
    /// texture not yet uploaded: `upload_preint`). Returns whether the table
    /// changed.
    pub fn ensure_preint(&mut self, key: PreintKey) -> bool {
        if self.preint.as_ref().is_some_and(|(_, k)| *k == key) {
            return false;
        }
        if let Some(i) = self.preint_spares.iter().position(|(_, k, _)| *k == key) {
            let (view, key, texels) = self.preint_spares.remove(i);
            self.keep_current_preint();
            self.preint = Some((view, key));
            self.preint_texels = texels;
            return true;
        }
        let texels = with_lut_row(&key, &self.rows);
        self.keep_current_preint();
        self.preint = Some((None, key));
        self.preint_texels = texels;
        true
    }

    /// Uploads the current pre-integration table's texture if it is not
    /// yet (`preint`); returns the bytes that took.
    pub fn upload_preint(&mut self, dev: &Device) -> Result<u64, Error> {
        let Some((view @ None, _)) = self.preint.as_mut() else {
            return Ok(0);
        };
        let t = &self.preint_texels;
        // f16 tops out at 65504: deeper segments are opaque anyway.
        let (format, bytes) = float_table(dev, &t.texels, Some(6.0e4));
        let height = (t.side + 3 * t.rows) as u32;
        let size = wgpu::Extent3d { width: t.side as u32, height, depth_or_array_layers: 1 };
        let uploaded = dev.ctx().texture_with_data(
            "uploading the pre-integration table",
            "preint",
            size,
            D2,
            format,
            1,
            &bytes,
        )?;
        *view = Some(uploaded);
        Ok(bytes.len() as u64)
    }

    /// Moves the current table to the front of the spares if it is for the
    /// current transfer function.
    fn keep_current_preint(&mut self) {
        if let Some((view, key)) = self.preint.take() {
            let texels = std::mem::take(&mut self.preint_texels);
            if key.lut_version == self.version {
                self.preint_spares.insert(0, (view, key, texels));
                self.preint_spares.truncate(PREINT_SPARES);
                let bytes = |t: &crate::cpu::PreintTable| std::mem::size_of_val(t.texels.as_slice());
                while self.preint_spares.iter().map(|(_, _, t)| bytes(t)).sum::<usize>() > PREINT_SPARE_BYTES {
                    self.preint_spares.pop();
                }
            }
        }
    }
}
