//! GPU time per pass from timestamp queries, where the adapter has them
//! (`wgpu::Features::TIMESTAMP_QUERY`): queries 0–1 bracket the terrain's work after the fill
//! (the sky-view table, the water cull and the vertex pre-pass, written by
//! `TerrainRenderer::prepare`, then the terrain pass; the pass-through's pass alone), 2–3 the
//! frame's compute fill (when it has one). The wall clock is never passed off as GPU time.

use super::{GpuContext, RenderError};

pub struct GpuTimer {
    queries: wgpu::QuerySet,
    resolve: wgpu::Buffer,
    readback: wgpu::Buffer,
    period_ns: f64,
}

impl GpuTimer {
    /// None when the device was opened without timestamp queries.
    pub fn new(ctx: &GpuContext) -> Option<Self> {
        if !ctx
            .device
            .features()
            .contains(wgpu::Features::TIMESTAMP_QUERY)
        {
            return None;
        }
        let queries = ctx.device.create_query_set(&wgpu::QuerySetDescriptor {
            label: Some("pass timestamps"),
            ty: wgpu::QueryType::Timestamp,
            count: 4,
        });
        let buffer = |label, usage| {
            ctx.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some(label),
                size: 32,
                usage,
                mapped_at_creation: false,
            })
        };
        Some(Self {
            queries,
            resolve: buffer(
                "timestamp resolve",
                wgpu::BufferUsages::QUERY_RESOLVE | wgpu::BufferUsages::COPY_SRC,
            ),
            readback: buffer(
                "timestamp readback",
                wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            ),
            period_ns: ctx.queue.get_timestamp_period() as f64,
        })
    }

    /// The writes to hand to the timed pass.
    pub fn pass_writes(&self) -> wgpu::RenderPassTimestampWrites<'_> {
        wgpu::RenderPassTimestampWrites {
            query_set: &self.queries,
            beginning_of_pass_write_index: Some(0),
            end_of_pass_write_index: Some(1),
        }
    }

    /// The query set, for the renderer to time its compute fill with (queries 2–3).
    pub fn query_set(&self) -> &wgpu::QuerySet {
        &self.queries
    }

    /// Records the copy of the timestamps (after the timed passes, in the same encoder).
    pub fn resolve(&self, encoder: &mut wgpu::CommandEncoder) {
        encoder.resolve_query_set(&self.queries, 0..4, &self.resolve, 0);
        encoder.copy_buffer_to_buffer(&self.resolve, 0, &self.readback, 0, 32);
    }

    /// The terrain pass's and the fill's durations in milliseconds, once the submission has
    /// finished (the fill's is meaningful only in a frame that had one).
    pub fn read_ms(&self, ctx: &GpuContext) -> Result<(f64, f64), RenderError> {
        let (tx, rx) = std::sync::mpsc::channel();
        self.readback.map_async(wgpu::MapMode::Read, .., move |r| {
            let _ = tx.send(r);
        });
        ctx.wait_idle()?;
        rx.recv()
            .map_err(|e| RenderError::Readback(e.to_string()))?
            .map_err(|e| RenderError::Readback(e.to_string()))?;
        let ticks = {
            let data = self
                .readback
                .get_mapped_range(..)
                .map_err(|e| RenderError::Readback(e.to_string()))?;
            let t: &[u64] = bytemuck::cast_slice(&data[..32]);
            (t[1].wrapping_sub(t[0]), t[3].wrapping_sub(t[2]))
        };
        self.readback.unmap();
        let ms = |ticks: u64| ticks as f64 * self.period_ns * 1e-6;
        Ok((ms(ticks.0), ms(ticks.1)))
    }
}
