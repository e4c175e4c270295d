//! The one GPU context: a headless wgpu instance, adapter, device and queue, chosen Vulkan first
//! (lavapipe on CPU-only nodes, any real GPU), with GL through EGL (Mesa's llvmpipe) as the
//! fallback. Capabilities that change how hdrvis renders — float32 filtering, f64 and f16 in
//! shaders, texture limits — are detected here, and every missing one has a working path.

pub(crate) mod filter_probe;
pub(crate) mod layout;
pub(crate) mod pipeline;
pub(crate) mod readback;
pub mod shader;
pub(crate) mod timestamps;
pub mod transfer;

use crate::error::{Error, Result};
use std::path::Path;
use std::sync::Arc;

/// Environment variable that selects the backend when `--backend` is not given.
pub(crate) const BACKEND_ENV: &str = "HDRVIS_BACKEND";
/// Environment variable listing capabilities to treat as missing (comma-separated), so the
/// fallback paths can be exercised on any machine: `float32_filterable`, `shader_f64`, `shader_f16`,
/// `mappable_primary_buffers`.
pub(crate) const DISABLE_ENV: &str = "HDRVIS_DISABLE_FEATURES";

#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum BackendChoice {
    Auto,
    Vulkan,
    Gl,
}

impl BackendChoice {
    pub fn parse(s: &str) -> Result<BackendChoice> {
        match s.to_ascii_lowercase().as_str() {
            "auto" | "" => Ok(BackendChoice::Auto),
            "vulkan" | "vk" => Ok(BackendChoice::Vulkan),
            "gl" | "gles" | "opengl" | "egl" => Ok(BackendChoice::Gl),
            _ => Err(Error::invalid(
                "backend",
                format!("expected auto, vulkan or gl, got {s:?}"),
            )),
        }
    }

    /// The explicit choice if given, else `HDRVIS_BACKEND`, else auto.
    pub fn resolve(explicit: Option<&str>) -> Result<BackendChoice> {
        match explicit {
            Some(s) => BackendChoice::parse(s),
            None => match std::env::var(BACKEND_ENV) {
                Ok(v) => BackendChoice::parse(&v).map_err(|_| {
                    Error::invalid(
                        BACKEND_ENV,
                        format!("expected auto, vulkan or gl, got {v:?}"),
                    )
                }),
                Err(_) => Ok(BackendChoice::Auto),
            },
        }
    }

    /// The name `--backend` takes for this choice.
    pub fn name(self) -> &'static str {
        match self {
            BackendChoice::Auto => "auto",
            BackendChoice::Vulkan => "vulkan",
            BackendChoice::Gl => "gl",
        }
    }
}

/// What the adapter can do that matters to hdrvis.
#[derive(Clone, Debug, PartialEq)]
pub struct Capabilities {
    /// Hardware trilinear filtering of R32Float textures; otherwise exact manual trilinear.
    pub float32_filterable: bool,
    pub shader_f64: bool,
    pub shader_f16: bool,
    pub max_texture_3d: u32,
    pub max_texture_2d: u32,
    pub max_buffer_size: u64,
    pub max_storage_buffer_binding_size: u64,
    /// Storage buffers may also be MAP_READ / MAP_WRITE (wgpu's MAPPABLE_PRIMARY_BUFFERS),
    /// requested only on CPU adapters, where device memory is host memory: uploads and
    /// readbacks then skip the staging copy (see [`transfer`]).
    pub mappable_primary_buffers: bool,
    /// Timestamp queries: benchmarks report the ray cast's own GPU time beside the wall clock.
    pub timestamp_query: bool,
}

pub struct GpuContext {
    pub instance: wgpu::Instance,
    pub adapter: wgpu::Adapter,
    pub device: wgpu::Device,
    pub queue: wgpu::Queue,
    pub info: wgpu::AdapterInfo,
    pub caps: Capabilities,
    /// The driver's compiled pipelines, loaded from and saved to disk where the backend supports
    /// it (Vulkan), so that a second run does not compile its shaders again.
    pipeline_cache: Option<PersistentPipelineCache>,
    /// The first GPU error no error scope caught (out of memory, a lost device), kept for
    /// [`GpuContext::wait`] to return: wgpu's default handler panics instead.
    uncaptured: Arc<std::sync::Mutex<Option<String>>>,
    /// The texture unit's trilinear error, measured on first use ([`filter_probe`]).
    filter_error: std::sync::OnceLock<Option<f64>>,
    /// Why this adapter is a slow path and what to do, when it is one ([`slow_path`]).
    slow_path: Option<String>,
}

struct PersistentPipelineCache {
    cache: wgpu::PipelineCache,
    path: std::path::PathBuf,
    /// Size of the data loaded from disk; the cache is written back only when it changed.
    loaded_len: usize,
}

/// Environment variable that turns the on-disk pipeline cache off (`0`).
pub(crate) const PIPELINE_CACHE_ENV: &str = "HDRVIS_PIPELINE_CACHE";

impl std::fmt::Debug for GpuContext {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "GpuContext({})", self.describe())
    }
}

fn disabled_features() -> Vec<String> {
    std::env::var(DISABLE_ENV)
        .map(|v| {
            v.split(',')
                .map(|s| s.trim().to_ascii_lowercase())
                .filter(|s| !s.is_empty())
                .collect()
        })
        .unwrap_or_default()
}

impl PersistentPipelineCache {
    fn open(device: &wgpu::Device, info: &wgpu::AdapterInfo) -> Option<Self> {
        if std::env::var(PIPELINE_CACHE_ENV).is_ok_and(|v| v.trim() == "0") {
            return None;
        }
        let key = wgpu::util::pipeline_cache_key(info)?;
        // The driver version is part of the file name: an updated driver starts a fresh cache.
        let driver: String = format!("{}_{}", info.driver, info.driver_info)
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
            .collect();
        let path = crate::io::cache_dir()
            .join("pipelines")
            .join(format!("{key}_{driver}.bin"));
        let data = read_pipeline_cache(&path);
        // SAFETY: the data is either absent or what `get_data` of a cache for this adapter
        // (same vendor, device and driver in the file name) returned; with `fallback` the
        // driver validates the header and starts empty when it does not match.
        let cache = unsafe {
            device.create_pipeline_cache(&wgpu::PipelineCacheDescriptor {
                label: Some("hdrvis pipelines"),
                data: data.as_deref(),
                fallback: true,
            })
        };
        Some(PersistentPipelineCache {
            cache,
            path,
            loaded_len: data.map_or(0, |d| d.len()),
        })
    }

    fn save(&self) {
        let Some(data) = self.cache.get_data() else {
            return;
        };
        if data.len() == self.loaded_len {
            return;
        }
        if let Some(dir) = self.path.parent() {
            let _ = std::fs::create_dir_all(dir);
        }
        let sealed = crate::io::checked::seal(&data);
        let _ = crate::io::write_atomic(&self.path, |f| {
            use std::io::Write;
            f.write_all(&sealed).map_err(|e| Error::io(&self.path, e))
        });
    }
}

/// The pipeline data saved at `path`, checked against the checksum it was sealed with: a file
/// cut short or changed is set aside (`hdrvis cache du` lists it as failed) and the pipelines
/// are compiled afresh, so the driver is never handed damaged bytes.
fn read_pipeline_cache(path: &std::path::Path) -> Option<Vec<u8>> {
    let blob = std::fs::read(path).ok()?;
    match crate::io::checked::unseal(&blob) {
        Ok(data) => Some(data.to_vec()),
        Err(why) => {
            let cache = crate::io::cache_dir();
            let aside = crate::io::checked::set_aside(&cache, path);
            let fate = match &aside {
                Ok(to) => format!("set aside as {}", to.display()),
                Err(_) => "left in place (the folder cannot be written)".to_string(),
            };
            crate::io::notice(&format!(
                "cache: {} {why}; {fate}, pipelines are compiled afresh",
                path.display()
            ));
            None
        }
    }
}

impl Drop for GpuContext {
    fn drop(&mut self) {
        self.save_pipeline_cache();
    }
}

fn type_rank(t: wgpu::DeviceType) -> u32 {
    match t {
        wgpu::DeviceType::DiscreteGpu => 0,
        wgpu::DeviceType::IntegratedGpu => 1,
        wgpu::DeviceType::VirtualGpu => 2,
        wgpu::DeviceType::Cpu => 3,
        wgpu::DeviceType::Other => 4,
    }
}

/// Why the chosen adapter is a slow path and what to do about it, in one line; `None` on the
/// fast path. Two cases: OpenGL on Mesa's llvmpipe (the fallback when no Vulkan driver is
/// installed, or `--backend gl`), which runs hdrvis's shaders 2–2.7× slower than Vulkan's
/// lavapipe on the same CPU (`hdrvis bench volume --quick` with each backend, side by side,
/// docs/performance.md); and a CPU rasterizer while the machine has a GPU that another backend
/// reaches (a container without NVIDIA's Vulkan driver file, or `--backend gl` beside one).
fn slow_path(choice: BackendChoice, chosen: &wgpu::AdapterInfo) -> Option<String> {
    if chosen.device_type != wgpu::DeviceType::Cpu {
        return None;
    }
    if let Some((gpu, backend)) = unused_gpu() {
        return Some(format!(
            "rendering on {} (a CPU rasterizer) although {gpu} is present through {backend}: a GPU renders a 513³ → 1024² frame in about 14 ms where lavapipe on 2 cores takes 2.3 s (docs/performance.md); run with --backend {}",
            chosen.name,
            backend.to_lowercase()
        ));
    }
    if chosen.backend != wgpu::Backend::Gl {
        return None;
    }
    let how = if choice == BackendChoice::Gl && has_adapter(wgpu::Backends::VULKAN) {
        "Vulkan is installed here: leave out --backend gl (or HDRVIS_BACKEND=gl)".to_string()
    } else {
        "install Vulkan's lavapipe: apt-get install mesa-vulkan-drivers (Debian, Ubuntu) or dnf install mesa-vulkan-drivers (Fedora)".to_string()
    };
    Some(format!(
        "rendering with OpenGL on {} (the GL fallback), 2–2.7× slower than Vulkan's lavapipe on the same CPU; {how}",
        chosen.name
    ))
}

/// Whether this process is the first (or only) MPI rank: the slow-path line is said once per
/// job, not once per rank.
fn first_rank() -> bool {
    ["OMPI_COMM_WORLD_RANK", "PMI_RANK"]
        .iter()
        .filter_map(|k| std::env::var(k).ok())
        .all(|r| r.trim() == "0")
}

/// A headless instance of `backends` and the adapters it finds.
fn adapters(backends: wgpu::Backends) -> (wgpu::Instance, Vec<wgpu::Adapter>) {
    let mut desc = wgpu::InstanceDescriptor::new_without_display_handle();
    desc.backends = backends;
    let instance = wgpu::Instance::new(desc);
    let found = pollster::block_on(instance.enumerate_adapters(backends));
    (instance, found)
}

fn has_adapter(backends: wgpu::Backends) -> bool {
    !adapters(backends).1.is_empty()
}

/// A GPU (its name and backend) that Vulkan or GL can reach, looked for only where the machine
/// has a GPU's device file (`/dev/nvidia0`, `/dev/kfd`, a DRI render node): on CPU-only nodes
/// no second driver is started.
fn unused_gpu() -> Option<(String, &'static str)> {
    let render_node = std::fs::read_dir("/dev/dri").is_ok_and(|d| {
        d.flatten()
            .any(|e| e.file_name().to_string_lossy().starts_with("renderD"))
    });
    if !(render_node || Path::new("/dev/nvidia0").exists() || Path::new("/dev/kfd").exists()) {
        return None;
    }
    for (backends, name) in [
        (wgpu::Backends::VULKAN, "Vulkan"),
        (wgpu::Backends::GL, "GL"),
    ] {
        let (_, found) = adapters(backends);
        if let Some(gpu) = found.iter().map(|a| a.get_info()).find(|i| {
            matches!(
                i.device_type,
                wgpu::DeviceType::DiscreteGpu | wgpu::DeviceType::IntegratedGpu
            )
        }) {
            return Some((gpu.name, name));
        }
    }
    None
}

impl GpuContext {
    /// Opens the best adapter for the choice: on auto, Vulkan adapters first (real GPUs before
    /// CPU rasterizers), then GL.
    pub fn new(choice: BackendChoice) -> Result<Arc<GpuContext>> {
        let tries: &[wgpu::Backends] = match choice {
            BackendChoice::Auto => &[wgpu::Backends::VULKAN, wgpu::Backends::GL],
            BackendChoice::Vulkan => &[wgpu::Backends::VULKAN],
            BackendChoice::Gl => &[wgpu::Backends::GL],
        };
        for &backends in tries {
            let (instance, mut found) = adapters(backends);
            found.sort_by_key(|a| type_rank(a.get_info().device_type));
            if let Some(adapter) = found.into_iter().next() {
                let ctx = GpuContext::open(instance, adapter, choice)?;
                if let (Some(line), true) = (&ctx.slow_path, first_rank()) {
                    crate::io::notice(line);
                }
                return Ok(ctx);
            }
        }
        let hint = match choice {
            BackendChoice::Gl => "install Mesa's EGL/GL drivers (Debian: apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri)",
            _ => "install a Vulkan driver (Debian: apt-get install mesa-vulkan-drivers, which provides lavapipe on CPU-only machines) or use --backend gl with Mesa's EGL",
        };
        Err(Error::Gpu(format!(
            "no GPU adapter found for backend {}: {hint}",
            choice.name()
        )))
    }

    fn open(
        instance: wgpu::Instance,
        adapter: wgpu::Adapter,
        choice: BackendChoice,
    ) -> Result<Arc<GpuContext>> {
        let info = adapter.get_info();
        let features = adapter.features();
        let limits = adapter.limits();
        let disabled = disabled_features();
        let off = |name: &str| disabled.iter().any(|d| d == name);
        let mut wanted = wgpu::Features::empty();
        for (f, name) in [
            (wgpu::Features::FLOAT32_FILTERABLE, "float32_filterable"),
            (wgpu::Features::SHADER_F64, "shader_f64"),
            (wgpu::Features::SHADER_F16, "shader_f16"),
            (wgpu::Features::PIPELINE_CACHE, "pipeline_cache"),
            (wgpu::Features::TIMESTAMP_QUERY, "timestamp_query"),
        ] {
            if features.contains(f) && !off(name) {
                wanted |= f;
            }
        }
        // On a real GPU mapped storage buffers would live in slow host-visible memory; on a
        // CPU rasterizer every buffer is host memory, and mapping saves a full copy each way.
        let mappable = wgpu::Features::MAPPABLE_PRIMARY_BUFFERS;
        if info.device_type == wgpu::DeviceType::Cpu
            && features.contains(mappable)
            && !off("mappable_primary_buffers")
        {
            wanted |= mappable;
        }
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("hdrvis"),
            required_features: wanted,
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| Error::Gpu(format!("cannot open device on {}: {e}", info.name)))?;
        let caps = Capabilities {
            float32_filterable: wanted.contains(wgpu::Features::FLOAT32_FILTERABLE),
            shader_f64: wanted.contains(wgpu::Features::SHADER_F64),
            shader_f16: wanted.contains(wgpu::Features::SHADER_F16),
            max_texture_3d: limits.max_texture_dimension_3d,
            max_texture_2d: limits.max_texture_dimension_2d,
            max_buffer_size: limits.max_buffer_size,
            max_storage_buffer_binding_size: limits.max_storage_buffer_binding_size,
            mappable_primary_buffers: wanted.contains(wgpu::Features::MAPPABLE_PRIMARY_BUFFERS),
            timestamp_query: wanted.contains(wgpu::Features::TIMESTAMP_QUERY),
        };
        let uncaptured = Arc::new(std::sync::Mutex::new(None));
        let slot = uncaptured.clone();
        device.on_uncaptured_error(Arc::new(move |e: wgpu::Error| {
            let mut first = slot.lock().unwrap_or_else(|p| p.into_inner());
            if first.is_none() {
                // wgpu's messages run over several lines; the first says what happened.
                let text = e.to_string();
                *first = Some(
                    text.lines()
                        .next()
                        .unwrap_or("unknown error")
                        .trim()
                        .to_string(),
                );
            }
        }));
        let pipeline_cache = if wanted.contains(wgpu::Features::PIPELINE_CACHE) {
            PersistentPipelineCache::open(&device, &info)
        } else {
            None
        };
        Ok(Arc::new(GpuContext {
            slow_path: slow_path(choice, &info),
            instance,
            adapter,
            device,
            queue,
            info,
            caps,
            pipeline_cache,
            uncaptured,
            filter_error: std::sync::OnceLock::new(),
        }))
    }

    pub(crate) fn backend_name(&self) -> &'static str {
        match self.info.backend {
            wgpu::Backend::Vulkan => "Vulkan",
            wgpu::Backend::Gl => "GL",
            wgpu::Backend::Metal => "Metal",
            wgpu::Backend::Dx12 => "DX12",
            _ => "other",
        }
    }

    /// One line: adapter, backend and driver, for image metadata and benchmark headers.
    pub fn describe(&self) -> String {
        let driver = [self.info.driver.as_str(), self.info.driver_info.as_str()]
            .iter()
            .filter(|s| !s.is_empty())
            .cloned()
            .collect::<Vec<_>>()
            .join(" ");
        format!(
            "{} ({}, {})",
            self.info.name,
            self.backend_name(),
            if driver.is_empty() {
                "driver unknown"
            } else {
                &driver
            }
        )
    }

    /// The largest error of the texture unit's trilinear filter, in units of the step between
    /// two texels, measured once on first use; `None` where the adapter cannot filter float32
    /// textures (or the probe could not run).
    pub fn hardware_filter_error(&self) -> Option<f64> {
        *self.filter_error.get_or_init(|| {
            if self.caps.float32_filterable {
                filter_probe::measure_filter_error(self).ok()
            } else {
                None
            }
        })
    }

    /// Whether `filter: "auto"` takes the texture unit: only where it filters float32 textures
    /// with weights as exact as the shader's own (the one place this is decided).
    pub(crate) fn auto_filter_is_hardware(&self) -> bool {
        self.hardware_filter_error()
            .is_some_and(|e| e <= filter_probe::EXACT_FILTER_TOLERANCE)
    }

    /// The `hdrvis doctor` report.
    pub fn report(&self) -> String {
        let path = match &self.slow_path {
            Some(line) => format!("\npath:     slow: {line}"),
            None => "\npath:     fast".to_string(),
        };
        let yes = |b: bool| if b { "yes" } else { "no" };
        let c = &self.caps;
        format!(
            "adapter:  {}\nbackend:  {}\ntype:     {:?}\ndriver:   {} {}\nfloat32 filtering: {}{}\nshader f64: {}\nshader f16: {}\nmax 3-D texture: {}^3 voxels\nmax 2-D texture: {} px\nmax buffer: {} MiB\nmax storage binding: {} MiB\nmapped storage buffers: {}\ntimestamps: {}",
            self.info.name,
            self.backend_name(),
            self.info.device_type,
            self.info.driver,
            self.info.driver_info,
            yes(c.float32_filterable),
            self.filter_note(),
            yes(c.shader_f64),
            yes(c.shader_f16),
            c.max_texture_3d,
            c.max_texture_2d,
            c.max_buffer_size >> 20,
            c.max_storage_buffer_binding_size >> 20,
            yes(c.mappable_primary_buffers),
            yes(c.timestamp_query),
        ) + "\npipeline cache: "
            + match self.pipeline_cache_path() {
                Some(p) => format!("yes ({})", p.display()),
                None => "no (this backend compiles pipelines on every run)".to_string(),
            }
            .as_str()
            + path.as_str()
    }

    /// The pipeline cache to pass to pipeline creation (`None` where the backend has none).
    /// What `filter: "auto"` does here and why, for the doctor report.
    fn filter_note(&self) -> String {
        match self.hardware_filter_error() {
            Some(e) if e <= filter_probe::EXACT_FILTER_TOLERANCE => {
                format!(" (weights exact in f32, error {e:.1e}: auto uses the texture unit)")
            }
            Some(e) => format!(
                " (weights quantised, error {e:.1e} of a texel step: auto filters exactly in the shader)"
            ),
            None => " (auto filters exactly in the shader)".to_string(),
        }
    }

    pub(crate) fn pipeline_cache(&self) -> Option<&wgpu::PipelineCache> {
        self.pipeline_cache.as_ref().map(|p| &p.cache)
    }

    /// Where the pipeline cache lives on disk, if there is one.
    pub(crate) fn pipeline_cache_path(&self) -> Option<&std::path::Path> {
        self.pipeline_cache.as_ref().map(|p| p.path.as_path())
    }

    /// Writes the pipeline cache to disk if pipelines were added since it was loaded; also done
    /// when the context is dropped. Failures only cost the next run its head start.
    pub(crate) fn save_pipeline_cache(&self) {
        if let Some(p) = &self.pipeline_cache {
            p.save();
        }
    }

    /// A 3-D single-channel f32 texture of `size` texels (x, y, z) that shaders sample and the
    /// host writes: a volume or a brick atlas.
    pub(crate) fn r32f_texture_3d(&self, label: &str, size: [u32; 3]) -> wgpu::Texture {
        self.texture_3d(label, size, wgpu::TextureFormat::R32Float)
    }

    /// A 3-D texture of `size` texels (x, y, z) in `format` that shaders read and the host writes.
    pub(crate) fn texture_3d(
        &self,
        label: &str,
        size: [u32; 3],
        format: wgpu::TextureFormat,
    ) -> wgpu::Texture {
        self.device.create_texture(&wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: size[0],
                height: size[1],
                depth_or_array_layers: size[2],
            },
            mip_level_count: 1,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D3,
            format,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        })
    }

    /// Blocks until all submitted work is done.
    /// Waits for the submitted work; an error the device reported meanwhile that no error scope
    /// caught (out of memory above all) is returned here as one line.
    pub fn wait(&self) -> Result<()> {
        let polled = self
            .device
            .poll(wgpu::PollType::Wait {
                submission_index: None,
                timeout: None,
            })
            .map(|_| ())
            .map_err(|e| Error::Gpu(format!("waiting for the device failed: {e}")));
        let reported = self
            .uncaptured
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .take();
        match reported {
            Some(msg) => Err(Error::Gpu(format!(
                "{msg} (the device could not do the work asked; try a smaller image or volume, or --gpu-memory)"
            ))),
            None => polled,
        }
    }
}
