//! What every compute fill shares: its pipeline (entry point `cs_main`, its own bind group
//! and the detail's) and its per-dispatch parameter blocks. On its own so the fills and the
//! detail's resources can use it without importing each other.

/// The compute pipeline of a fill: entry point `cs_main`, its own bind group and the detail's
/// (group 1).
pub(super) fn compute_pipeline(
    device: &wgpu::Device,
    label: &str,
    module: &wgpu::ShaderModule,
    layout: &wgpu::BindGroupLayout,
    detail: &wgpu::BindGroupLayout,
) -> wgpu::ComputePipeline {
    let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some(label),
        bind_group_layouts: &[Some(layout), Some(detail)],
        immediate_size: 0,
    });
    device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some(label),
        layout: Some(&pipeline_layout),
        module,
        entry_point: Some("cs_main"),
        compilation_options: Default::default(),
        cache: None,
    })
}

/// Per-dispatch parameter blocks of a compute fill: one uniform buffer bound with a dynamic
/// offset, one block per dispatch at the device's offset alignment (both fills use it).
pub(super) struct DispatchParams {
    buffer: wgpu::Buffer,
    size: u64,
    stride: u64,
    capacity: u32,
}

impl DispatchParams {
    /// Room for `capacity` blocks of `T`.
    pub(super) fn new<T: bytemuck::Pod>(device: &wgpu::Device, label: &str, capacity: u32) -> Self {
        let size = std::mem::size_of::<T>() as u64;
        let align = device.limits().min_uniform_buffer_offset_alignment as u64;
        let stride = size.div_ceil(align) * align;
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: stride * capacity as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            buffer,
            size,
            stride,
            capacity,
        }
    }

    /// The compute stage's layout entry for the blocks at `binding` (one block, moved by the
    /// dynamic offset).
    pub(super) fn layout_entry(&self, binding: u32) -> wgpu::BindGroupLayoutEntry {
        wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
                has_dynamic_offset: true,
                min_binding_size: wgpu::BufferSize::new(self.size),
            },
            count: None,
        }
    }

    /// The binding: one block, moved by the dynamic offset.
    pub(super) fn binding(&self) -> wgpu::BindingResource<'_> {
        wgpu::BindingResource::Buffer(wgpu::BufferBinding {
            buffer: &self.buffer,
            offset: 0,
            size: wgpu::BufferSize::new(self.size),
        })
    }

    pub(super) fn capacity(&self) -> u32 {
        self.capacity
    }

    /// Writes the blocks (at most `capacity`; the rest are the caller's to split over frames).
    pub(super) fn write<T: bytemuck::Pod>(&self, queue: &wgpu::Queue, blocks: &[T]) {
        let mut bytes = vec![0u8; (self.stride * blocks.len() as u64) as usize];
        for (i, b) in blocks.iter().enumerate() {
            let at = i * self.stride as usize;
            bytes[at..at + self.size as usize].copy_from_slice(bytemuck::bytes_of(b));
        }
        queue.write_buffer(&self.buffer, 0, &bytes);
    }

    /// The dynamic offset of block `i`.
    pub(super) fn offset(&self, i: usize) -> u32 {
        (i as u64 * self.stride) as u32
    }
}
