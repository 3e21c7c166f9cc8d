//! Reading buffers back from the device: map them all, wait once, copy out.

use super::context::GpuContext;
use crate::error::Error;

/// The contents of each (MAP_READ) buffer after the work submitted so far,
/// passed to `read` in order; the buffers are unmapped afterwards.
pub fn read_buffers<R>(
    ctx: &GpuContext,
    buffers: &[&wgpu::Buffer],
    what: &str,
    read: impl FnOnce(&[&[u8]]) -> R,
) -> Result<R, Error> {
    let (tx, rx) = std::sync::mpsc::channel();
    for b in buffers {
        let tx = tx.clone();
        b.slice(..).map_async(wgpu::MapMode::Read, move |r| {
            let _ = tx.send(r);
        });
    }
    ctx.device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| Error::Gpu(format!("waiting for the GPU failed: {e}")))?;
    for _ in buffers {
        rx.recv()
            .map_err(|_| Error::Gpu("the GPU dropped a readback".into()))?
            .map_err(|e| Error::Gpu(format!("reading {what} back failed: {e}")))?;
    }
    let result = {
        let mut views = Vec::with_capacity(buffers.len());
        for b in buffers {
            views.push(
                b.slice(..).get_mapped_range().map_err(|e| Error::Gpu(format!("reading {what} back failed: {e}")))?,
            );
        }
        let slices: Vec<&[u8]> = views.iter().map(|v| &v[..]).collect();
        read(&slices)
    };
    for b in buffers {
        b.unmap();
    }
    Ok(result)
}
