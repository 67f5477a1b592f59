//! The wgpu instance, adapter, device and queue, shared by the window and the headless paths.

use super::RenderError;

/// Keeps a headless process off the windowing system.
///
/// Mesa's device-selection layer (`VK_LAYER_MESA_device_select`, an implicit Vulkan layer)
/// connects to the Wayland and X11 displays to find "the display's GPU" as soon as an instance
/// enables the surface extensions, which wgpu always does; on a machine without a display it
/// prints `error: XDG_RUNTIME_DIR is invalid or not set in the environment.`. A headless
/// command has no display to match, so this switches the layer off with its documented variable
/// `NODEVICE_SELECT=1`, unless the user chose a device (`MESA_VK_DEVICE_SELECT`) or set the
/// variable themselves. Adapters are still ordered by wgpu's own preference.
///
/// # Safety
///
/// It changes the process environment: call it before any other thread starts (first thing in
/// `main`), as [`std::env::set_var`] requires.
pub unsafe fn leave_the_display_alone() {
    if std::env::var_os("NODEVICE_SELECT").is_none()
        && std::env::var_os("MESA_VK_DEVICE_SELECT").is_none()
    {
        // SAFETY: the caller guarantees no other thread runs yet.
        unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
    }
}

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
            // The adapter's texture sizes and array layers: the GPU tile cache is one array
            // (`--gpu-tiles`, 512 by default; wgpu's default limit is 256 layers).
            // Its buffer sizes: the vertex pre-pass holds one placed vertex per mesh vertex
            // (render::placement: 160 MB at n = 1024, m = 64).
            required_limits: wgpu::Limits {
                max_texture_array_layers: adapter.limits().max_texture_array_layers,
                max_buffer_size: adapter.limits().max_buffer_size,
                max_storage_buffer_binding_size: adapter.limits().max_storage_buffer_binding_size,
                ..wgpu::Limits::default().using_resolution(adapter.limits())
            },
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
