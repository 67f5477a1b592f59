//! The wgpu instance, adapter, device and queue, shared by the window and the headless paths.

use super::RenderError;

/// Everything needed to talk to one GPU (or a software rasteriser such as lavapipe).
pub struct GpuContext {
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
}

impl GpuContext {
    /// A context with no surface, for offscreen rendering. Honours `WGPU_BACKEND` and
    /// `WGPU_ADAPTER_NAME`; otherwise prefers a hardware adapter and falls back to a software
    /// one (lavapipe/llvmpipe), so tests run on machines without a GPU.
    pub fn headless() -> Result<Self, RenderError> {
        let instance =
            wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle_from_env());
        let adapter = pollster::block_on(Self::pick_adapter(&instance, None))?;
        Self::with_adapter(instance, adapter)
    }

    /// Picks an adapter able to present to `surface` when given.
    pub async fn pick_adapter(
        instance: &wgpu::Instance,
        surface: Option<&wgpu::Surface<'_>>,
    ) -> Result<wgpu::Adapter, RenderError> {
        if let Ok(name) = std::env::var("WGPU_ADAPTER_NAME") {
            let wanted = name.to_lowercase();
            for adapter in instance.enumerate_adapters(wgpu::Backends::all()).await {
                if adapter.get_info().name.to_lowercase().contains(&wanted) {
                    return Ok(adapter);
                }
            }
            return Err(RenderError::NoAdapter(format!(
                "no adapter name contains WGPU_ADAPTER_NAME={name}"
            )));
        }
        let mut last_error = String::new();
        for force_fallback_adapter in [false, true] {
            let options = wgpu::RequestAdapterOptions {
                power_preference: wgpu::PowerPreference::HighPerformance,
                force_fallback_adapter,
                compatible_surface: surface,
                apply_limit_buckets: false,
            };
            match instance.request_adapter(&options).await {
                Ok(adapter) => return Ok(adapter),
                Err(e) => last_error = e.to_string(),
            }
        }
        Err(RenderError::NoAdapter(last_error))
    }

    /// Opens the device on `adapter`, asking for timestamp queries where the adapter has them.
    pub fn with_adapter(
        instance: wgpu::Instance,
        adapter: wgpu::Adapter,
    ) -> Result<Self, RenderError> {
        let wanted = wgpu::Features::TIMESTAMP_QUERY;
        let desc = wgpu::DeviceDescriptor {
            label: Some("globe device"),
            required_features: adapter.features() & wanted,
            required_limits: wgpu::Limits::default().using_resolution(adapter.limits()),
            experimental_features: wgpu::ExperimentalFeatures::disabled(),
            memory_hints: wgpu::MemoryHints::Performance,
            trace: wgpu::Trace::Off,
        };
        let (device, queue) =
            pollster::block_on(adapter.request_device(&desc)).map_err(|source| {
                RenderError::Device {
                    adapter: adapter.get_info().name,
                    source,
                }
            })?;
        Ok(Self {
            instance,
            adapter,
            device,
            queue,
        })
    }

    /// "name (backend, device type)", printed beside every figure.
    pub fn adapter_description(&self) -> String {
        let info = self.adapter.get_info();
        format!(
            "{} ({:?}, {:?}, driver {} {})",
            info.name, info.backend, info.device_type, info.driver, info.driver_info
        )
    }

    /// Blocks until the GPU has finished all submitted work.
    pub fn wait_idle(&self) -> Result<(), RenderError> {
        self.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map(|_| ())
            .map_err(|e| RenderError::Gpu(e.to_string()))
    }
}
