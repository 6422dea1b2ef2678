//! The wgpu renderer: one pipeline for the static scene, one instanced draw for every vehicle,
//! multisampled, on screen (a window's surface) or off screen (to an image).

use crate::camera::Camera;
use crate::scene::{COM_HEIGHT_SHARE, CarVertex, StaticScene, VehicleInstance, Vertex, car_mesh};
use glam::Vec3;
use std::path::Path;
use wgpu::util::DeviceExt;

/// Why rendering could not start or finish.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// No GPU adapter, not even a software one.
    #[error(
        "no graphics adapter found: install a Vulkan or OpenGL driver (on Debian: \
         `apt install mesa-vulkan-drivers libvulkan1`, which renders in software), \
         or run the level headless with `flockway run`"
    )]
    NoAdapter(#[source] wgpu::RequestAdapterError),
    /// The adapter refused a device.
    #[error("the graphics adapter refused a device: {0}")]
    Device(#[from] wgpu::RequestDeviceError),
    /// Reading the rendered image back failed.
    #[error("reading the rendered image back failed: {0}")]
    Readback(String),
    /// Writing the PNG failed.
    #[error("{}: {source}", path.display())]
    Png {
        /// The file.
        path: std::path::PathBuf,
        /// The cause.
        source: png::EncodingError,
    },
}

/// A GPU device and its queue.
pub struct Gpu {
    /// The instance it came from (a window's surface is made from it).
    pub instance: wgpu::Instance,
    /// The adapter.
    pub adapter: wgpu::Adapter,
    /// The device.
    pub device: wgpu::Device,
    /// Its queue.
    pub queue: wgpu::Queue,
}

impl Gpu {
    /// A device without a window, for off-screen rendering: Vulkan (lavapipe in CI) or GL.
    pub fn headless() -> Result<Gpu, RenderError> {
        // Vulkan first; GL only without it (its EGL probing is noisy on machines without a
        // display, and lavapipe renders the same picture).
        let instance = |backends| {
            wgpu::Instance::new(wgpu::InstanceDescriptor {
                backends,
                ..wgpu::InstanceDescriptor::new_without_display_handle()
            })
        };
        match Gpu::with_instance(instance(wgpu::Backends::VULKAN), None) {
            Err(RenderError::NoAdapter(_)) => {
                Gpu::with_instance(instance(wgpu::Backends::GL), None)
            }
            other => other,
        }
    }

    /// A device for `instance` (compatible with `surface`, if given).
    pub fn with_instance(
        instance: wgpu::Instance,
        surface: Option<&wgpu::Surface<'_>>,
    ) -> Result<Gpu, RenderError> {
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            force_fallback_adapter: false,
            compatible_surface: surface,
            ..Default::default()
        }))
        .map_err(RenderError::NoAdapter)?;
        let (device, queue) =
            pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
                label: Some("flockway"),
                required_limits:
                    wgpu::Limits::downlevel_webgl2_defaults().using_resolution(adapter.limits()),
                ..Default::default()
            }))?;
        Ok(Gpu {
            instance,
            adapter,
            device,
            queue,
        })
    }

    /// The adapter's name and backend, for logs and test messages.
    pub fn describe(&self) -> String {
        let info = self.adapter.get_info();
        format!("{} ({:?})", info.name, info.backend)
    }
}

/// Samples per pixel.
pub const MSAA_SAMPLES: u32 = 4;
/// Depth buffer format.
pub const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;
/// Sky colour behind the scene (linear).
pub const SKY: wgpu::Color = wgpu::Color {
    r: 0.38,
    g: 0.55,
    b: 0.78,
    a: 1.0,
};

#[repr(C)]
#[derive(Clone, Copy, bytemuck::Pod, bytemuck::Zeroable)]
struct CameraUniform {
    view_proj: [[f32; 4]; 4],
    sun: [f32; 4],
}

/// Draws a [`StaticScene`] and vehicle instances into a colour target of one format.
pub struct SceneRenderer {
    format: wgpu::TextureFormat,
    static_pipeline: wgpu::RenderPipeline,
    vehicle_pipeline: wgpu::RenderPipeline,
    camera_buffer: wgpu::Buffer,
    camera_group: wgpu::BindGroup,
    car_vertices: wgpu::Buffer,
    car_indices: wgpu::Buffer,
    car_index_count: u32,
    static_vertices: Option<wgpu::Buffer>,
    static_indices: Option<wgpu::Buffer>,
    static_opaque: u32,
    static_total: u32,
    instances: Option<wgpu::Buffer>,
    instance_capacity: usize,
    instance_count: u32,
}

impl SceneRenderer {
    /// Pipelines for colour targets of `format`.
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat) -> SceneRenderer {
        let shader = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("scene"),
            source: wgpu::ShaderSource::Wgsl(include_str!("scene.wgsl").into()),
        });
        let camera_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("camera"),
            entries: &[wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            }],
        });
        let camera_buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("camera"),
            size: std::mem::size_of::<CameraUniform>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let camera_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("camera"),
            layout: &camera_layout,
            entries: &[wgpu::BindGroupEntry {
                binding: 0,
                resource: camera_buffer.as_entire_binding(),
            }],
        });
        let layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("scene"),
            bind_group_layouts: &[Some(&camera_layout)],
            immediate_size: 0,
        });
        let static_attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32x4];
        let car_attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x3, 2 => Float32];
        let instance_attrs = wgpu::vertex_attr_array![
            3 => Float32x3, 4 => Float32x4, 5 => Float32x3, 6 => Float32x4
        ];
        let pipeline = |entry: &str, buffers: &[Option<wgpu::VertexBufferLayout<'_>>]| {
            device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(entry),
                layout: Some(&layout),
                vertex: wgpu::VertexState {
                    module: &shader,
                    entry_point: Some(entry),
                    compilation_options: Default::default(),
                    buffers,
                },
                primitive: wgpu::PrimitiveState {
                    topology: wgpu::PrimitiveTopology::TriangleList,
                    front_face: wgpu::FrontFace::Ccw,
                    // Guardrails and markers are seen from both sides.
                    cull_mode: None,
                    ..Default::default()
                },
                depth_stencil: Some(wgpu::DepthStencilState {
                    format: DEPTH_FORMAT,
                    depth_write_enabled: Some(true),
                    depth_compare: Some(wgpu::CompareFunction::LessEqual),
                    stencil: Default::default(),
                    bias: Default::default(),
                }),
                multisample: wgpu::MultisampleState {
                    count: MSAA_SAMPLES,
                    ..Default::default()
                },
                fragment: Some(wgpu::FragmentState {
                    module: &shader,
                    entry_point: Some("fs_main"),
                    compilation_options: Default::default(),
                    targets: &[Some(wgpu::ColorTargetState {
                        format,
                        blend: Some(wgpu::BlendState::ALPHA_BLENDING),
                        write_mask: wgpu::ColorWrites::ALL,
                    })],
                }),
                multiview_mask: None,
                cache: None,
            })
        };
        let static_pipeline = pipeline(
            "vs_static",
            &[Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<Vertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &static_attrs,
            })],
        );
        let vehicle_pipeline = pipeline(
            "vs_vehicle",
            &[
                Some(wgpu::VertexBufferLayout {
                    array_stride: std::mem::size_of::<CarVertex>() as u64,
                    step_mode: wgpu::VertexStepMode::Vertex,
                    attributes: &car_attrs,
                }),
                Some(wgpu::VertexBufferLayout {
                    array_stride: std::mem::size_of::<VehicleInstance>() as u64,
                    step_mode: wgpu::VertexStepMode::Instance,
                    attributes: &instance_attrs,
                }),
            ],
        );
        let (car_v, car_i) = car_mesh(COM_HEIGHT_SHARE);
        let car_vertices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("car vertices"),
            contents: bytemuck::cast_slice(&car_v),
            usage: wgpu::BufferUsages::VERTEX,
        });
        let car_indices = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("car indices"),
            contents: bytemuck::cast_slice(&car_i),
            usage: wgpu::BufferUsages::INDEX,
        });
        SceneRenderer {
            format,
            static_pipeline,
            vehicle_pipeline,
            camera_buffer,
            camera_group,
            car_vertices,
            car_indices,
            car_index_count: car_i.len() as u32,
            static_vertices: None,
            static_indices: None,
            static_opaque: 0,
            static_total: 0,
            instances: None,
            instance_capacity: 0,
            instance_count: 0,
        }
    }

    /// The colour format it draws into.
    pub fn format(&self) -> wgpu::TextureFormat {
        self.format
    }

    /// Uploads the static scene (after an edit).
    pub fn set_static(&mut self, device: &wgpu::Device, scene: &StaticScene) {
        self.static_vertices = Some(
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("static vertices"),
                contents: bytemuck::cast_slice(&scene.vertices),
                usage: wgpu::BufferUsages::VERTEX,
            }),
        );
        self.static_indices = Some(
            device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some("static indices"),
                contents: bytemuck::cast_slice(&scene.indices),
                usage: wgpu::BufferUsages::INDEX,
            }),
        );
        self.static_opaque = scene.translucent_from;
        self.static_total = scene.indices.len() as u32;
    }

    /// Uploads this frame's vehicles (the buffer grows by doubling, never per frame).
    pub fn set_vehicles(
        &mut self,
        device: &wgpu::Device,
        queue: &wgpu::Queue,
        vehicles: &[VehicleInstance],
    ) {
        if vehicles.len() > self.instance_capacity || self.instances.is_none() {
            self.instance_capacity = vehicles.len().next_power_of_two().max(64);
            self.instances = Some(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("vehicle instances"),
                size: (self.instance_capacity * std::mem::size_of::<VehicleInstance>()) as u64,
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        if let Some(buf) = &self.instances
            && !vehicles.is_empty()
        {
            queue.write_buffer(buf, 0, bytemuck::cast_slice(vehicles));
        }
        self.instance_count = vehicles.len() as u32;
    }

    /// Sets the camera for the next draw.
    pub fn set_camera(&self, queue: &wgpu::Queue, camera: &Camera, aspect: f32) {
        let sun = Vec3::new(-0.4, -0.3, 0.85).normalize();
        let u = CameraUniform {
            view_proj: camera.view_proj(aspect).to_cols_array_2d(),
            sun: sun.extend(0.0).to_array(),
        };
        queue.write_buffer(&self.camera_buffer, 0, bytemuck::bytes_of(&u));
    }

    /// Records the scene into a pass: static opaque, vehicles (one instanced draw), translucent.
    pub fn draw<'a>(&'a self, pass: &mut wgpu::RenderPass<'a>) {
        pass.set_bind_group(0, &self.camera_group, &[]);
        if let (Some(v), Some(i)) = (&self.static_vertices, &self.static_indices) {
            pass.set_pipeline(&self.static_pipeline);
            pass.set_vertex_buffer(0, v.slice(..));
            pass.set_index_buffer(i.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(0..self.static_opaque, 0, 0..1);
        }
        if let Some(inst) = &self.instances
            && self.instance_count > 0
        {
            pass.set_pipeline(&self.vehicle_pipeline);
            pass.set_vertex_buffer(0, self.car_vertices.slice(..));
            pass.set_vertex_buffer(1, inst.slice(..));
            pass.set_index_buffer(self.car_indices.slice(..), wgpu::IndexFormat::Uint16);
            pass.draw_indexed(0..self.car_index_count, 0, 0..self.instance_count);
        }
        if let (Some(v), Some(i)) = (&self.static_vertices, &self.static_indices)
            && self.static_total > self.static_opaque
        {
            pass.set_pipeline(&self.static_pipeline);
            pass.set_vertex_buffer(0, v.slice(..));
            pass.set_index_buffer(i.slice(..), wgpu::IndexFormat::Uint32);
            pass.draw_indexed(self.static_opaque..self.static_total, 0, 0..1);
        }
    }
}

/// Multisampled colour and depth targets of one size, resolving into a single-sample view.
pub struct Targets {
    /// Size in pixels.
    pub size: (u32, u32),
    msaa: wgpu::TextureView,
    depth: wgpu::TextureView,
}

impl Targets {
    /// Targets of `size` for colour `format`.
    pub fn new(device: &wgpu::Device, format: wgpu::TextureFormat, size: (u32, u32)) -> Targets {
        let extent = wgpu::Extent3d {
            width: size.0.max(1),
            height: size.1.max(1),
            depth_or_array_layers: 1,
        };
        let texture = |label, format| {
            device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some(label),
                    size: extent,
                    mip_level_count: 1,
                    sample_count: MSAA_SAMPLES,
                    dimension: wgpu::TextureDimension::D2,
                    format,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                    view_formats: &[],
                })
                .create_view(&Default::default())
        };
        Targets {
            size,
            msaa: texture("msaa colour", format),
            depth: texture("depth", DEPTH_FORMAT),
        }
    }

    /// A pass that clears to the sky and resolves into `resolve`.
    pub fn begin<'e>(
        &'e self,
        encoder: &'e mut wgpu::CommandEncoder,
        resolve: &'e wgpu::TextureView,
    ) -> wgpu::RenderPass<'e> {
        encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("scene"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: &self.msaa,
                depth_slice: None,
                resolve_target: Some(resolve),
                ops: wgpu::Operations {
                    load: wgpu::LoadOp::Clear(SKY),
                    store: wgpu::StoreOp::Discard,
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &self.depth,
                depth_ops: Some(wgpu::Operations {
                    load: wgpu::LoadOp::Clear(1.0),
                    store: wgpu::StoreOp::Discard,
                }),
                stencil_ops: None,
            }),
            ..Default::default()
        })
    }
}

/// An RGBA8 (sRGB) image read back from the GPU, rows top to bottom.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width, pixels.
    pub width: u32,
    /// Height, pixels.
    pub height: u32,
    /// `width × height × 4` bytes.
    pub rgba: Vec<u8>,
}

impl Image {
    /// Writes the image as a PNG.
    pub fn save_png(&self, path: &Path) -> Result<(), RenderError> {
        let err = |source| RenderError::Png {
            path: path.to_owned(),
            source,
        };
        let file = std::fs::File::create(path).map_err(|e| err(png::EncodingError::IoError(e)))?;
        let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), self.width, self.height);
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(png::BitDepth::Eight);
        let mut writer = encoder.write_header().map_err(err)?;
        writer.write_image_data(&self.rgba).map_err(err)?;
        writer.finish().map_err(err)
    }
}

/// Off-screen format: sRGB, so the image matches what a window shows.
pub const OFFSCREEN_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Rgba8UnormSrgb;

/// Renders one frame off screen and reads it back.
pub fn render_image(
    gpu: &Gpu,
    renderer: &SceneRenderer,
    camera: &Camera,
    size: (u32, u32),
) -> Result<Image, RenderError> {
    let (w, h) = (size.0.max(1), size.1.max(1));
    let device = &gpu.device;
    let targets = Targets::new(device, renderer.format(), (w, h));
    let resolved = device.create_texture(&wgpu::TextureDescriptor {
        label: Some("resolved"),
        size: wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
        mip_level_count: 1,
        sample_count: 1,
        dimension: wgpu::TextureDimension::D2,
        format: renderer.format(),
        usage: wgpu::TextureUsages::RENDER_ATTACHMENT | wgpu::TextureUsages::COPY_SRC,
        view_formats: &[],
    });
    let view = resolved.create_view(&Default::default());
    renderer.set_camera(&gpu.queue, camera, w as f32 / h as f32);
    // Rows of a texture copy are padded to 256 bytes.
    let row = w * 4;
    let padded =
        row.div_ceil(wgpu::COPY_BYTES_PER_ROW_ALIGNMENT) * wgpu::COPY_BYTES_PER_ROW_ALIGNMENT;
    let readback = device.create_buffer(&wgpu::BufferDescriptor {
        label: Some("readback"),
        size: u64::from(padded) * u64::from(h),
        usage: wgpu::BufferUsages::COPY_DST | wgpu::BufferUsages::MAP_READ,
        mapped_at_creation: false,
    });
    let mut encoder = device.create_command_encoder(&Default::default());
    {
        let mut pass = targets.begin(&mut encoder, &view);
        renderer.draw(&mut pass);
    }
    encoder.copy_texture_to_buffer(
        wgpu::TexelCopyTextureInfo {
            texture: &resolved,
            mip_level: 0,
            origin: wgpu::Origin3d::ZERO,
            aspect: wgpu::TextureAspect::All,
        },
        wgpu::TexelCopyBufferInfo {
            buffer: &readback,
            layout: wgpu::TexelCopyBufferLayout {
                offset: 0,
                bytes_per_row: Some(padded),
                rows_per_image: Some(h),
            },
        },
        wgpu::Extent3d {
            width: w,
            height: h,
            depth_or_array_layers: 1,
        },
    );
    gpu.queue.submit([encoder.finish()]);
    let slice = readback.slice(..);
    let (tx, rx) = std::sync::mpsc::channel();
    slice.map_async(wgpu::MapMode::Read, move |r| {
        let _ = tx.send(r);
    });
    device
        .poll(wgpu::PollType::wait_indefinitely())
        .map_err(|e| RenderError::Readback(e.to_string()))?;
    rx.recv()
        .map_err(|e| RenderError::Readback(e.to_string()))?
        .map_err(|e| RenderError::Readback(e.to_string()))?;
    let data = slice
        .get_mapped_range()
        .map_err(|e| RenderError::Readback(e.to_string()))?;
    let mut rgba = Vec::with_capacity((row * h) as usize);
    for y in 0..h as usize {
        let start = y * padded as usize;
        rgba.extend_from_slice(&data[start..start + row as usize]);
    }
    drop(data);
    readback.unmap();
    Ok(Image {
        width: w,
        height: h,
        rgba,
    })
}
