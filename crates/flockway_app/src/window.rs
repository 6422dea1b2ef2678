//! The window: winit events, a wgpu surface showing the scene with egui on top, and the
//! keyboard and mouse controls of the editor and play mode.

use crate::app::AppState;
use flockway_render::VehicleInstance;
use flockway_render::{Gpu, RenderError, SceneRenderer, Targets};
use std::sync::Arc;
use std::time::Instant;
use winit::application::ApplicationHandler;
use winit::event::WindowEvent;
use winit::event_loop::{ActiveEventLoop, EventLoop};
use winit::window::{Window, WindowId};

/// Why the window could not open.
#[derive(Debug, thiserror::Error)]
pub enum WindowError {
    /// No display to open a window on.
    #[error(
        "cannot open a window ({0}): there is no display. Run the level headless with \
         `flockway run LEVEL`, or render a picture with `flockway render LEVEL -o FILE.png`"
    )]
    NoDisplay(String),
    /// The GPU could not be set up.
    #[error(transparent)]
    Render(#[from] RenderError),
}

struct Graphics {
    window: Arc<Window>,
    gpu: Gpu,
    surface: wgpu::Surface<'static>,
    config: wgpu::SurfaceConfiguration,
    scene: SceneRenderer,
    targets: Targets,
    egui_state: egui_winit::State,
    egui_renderer: egui_wgpu::Renderer,
    scene_version: u64,
}

struct WindowApp {
    app: AppState,
    graphics: Option<Graphics>,
    error: Option<WindowError>,
    last_frame: Instant,
    last_autosave: Instant,
    interpolated: Vec<VehicleInstance>,
    /// Takes the keyboard focus where no window manager gives it.
    focus: Option<crate::focus::FocusKeeper>,
}

/// Opens the window on `app` and runs until it is closed.
pub fn run(app: AppState) -> Result<(), WindowError> {
    let event_loop = EventLoop::new().map_err(|e| WindowError::NoDisplay(e.to_string()))?;
    let mut w = WindowApp {
        app,
        graphics: None,
        error: None,
        last_frame: Instant::now(),
        last_autosave: Instant::now(),
        interpolated: Vec::new(),
        focus: None,
    };
    event_loop
        .run_app(&mut w)
        .map_err(|e| WindowError::NoDisplay(e.to_string()))?;
    match w.error {
        Some(e) => Err(e),
        None => Ok(()),
    }
}

impl Graphics {
    fn new(event_loop: &ActiveEventLoop, title: &str) -> Result<Graphics, WindowError> {
        let attrs = Window::default_attributes()
            .with_title(title)
            .with_inner_size(winit::dpi::LogicalSize::new(1400.0, 860.0));
        let window = Arc::new(
            event_loop
                .create_window(attrs)
                .map_err(|e| WindowError::NoDisplay(e.to_string()))?,
        );
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_with_display_handle(
            Box::new(event_loop.owned_display_handle()),
        ));
        let surface = instance
            .create_surface(window.clone())
            .map_err(|e| WindowError::NoDisplay(e.to_string()))?;
        let gpu = Gpu::with_instance(instance, Some(&surface))?;
        let size = window.inner_size();
        let caps = surface.get_capabilities(&gpu.adapter);
        let format = caps
            .formats
            .iter()
            .copied()
            .find(wgpu::TextureFormat::is_srgb)
            .unwrap_or(caps.formats[0]);
        let config = wgpu::SurfaceConfiguration {
            usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
            format,
            width: size.width.max(1),
            height: size.height.max(1),
            present_mode: wgpu::PresentMode::AutoVsync,
            desired_maximum_frame_latency: 2,
            alpha_mode: caps.alpha_modes[0],
            view_formats: vec![],
            color_space: wgpu::SurfaceColorSpace::Auto,
        };
        surface.configure(&gpu.device, &config);
        let scene = SceneRenderer::new(&gpu.device, format);
        let targets = Targets::new(&gpu.device, format, (config.width, config.height));
        let egui_ctx = egui::Context::default();
        let egui_state = egui_winit::State::new(
            egui_ctx,
            egui::ViewportId::ROOT,
            &window,
            Some(window.scale_factor() as f32),
            None,
            Some(gpu.device.limits().max_texture_dimension_2d as usize),
        );
        let egui_renderer =
            egui_wgpu::Renderer::new(&gpu.device, format, egui_wgpu::RendererOptions::default());
        Ok(Graphics {
            window,
            gpu,
            surface,
            config,
            scene,
            targets,
            egui_state,
            egui_renderer,
            scene_version: u64::MAX,
        })
    }

    fn resize(&mut self, w: u32, h: u32) {
        self.config.width = w.max(1);
        self.config.height = h.max(1);
        self.surface.configure(&self.gpu.device, &self.config);
        self.targets = Targets::new(
            &self.gpu.device,
            self.config.format,
            (self.config.width, self.config.height),
        );
    }
}

impl WindowApp {
    fn redraw(&mut self) {
        let now = Instant::now();
        let dt = (now - self.last_frame).as_secs_f64();
        self.last_frame = now;
        self.app.frame(dt);
        if now.duration_since(self.last_autosave).as_secs() >= 30 {
            self.last_autosave = now;
            if let Err(e) = self.app.editor.autosave() {
                self.app.status = format!("autosave failed: {e}");
            }
        }
        let Some(g) = &mut self.graphics else { return };
        if g.scene_version != self.app.scene_version() || self.app.play.is_some() {
            // In play mode the scene is cheap to keep: rebuild only when the version moves.
            if g.scene_version != self.app.scene_version() {
                g.scene.set_static(&g.gpu.device, &self.app.static_scene());
                g.scene_version = self.app.scene_version();
            }
        }
        match &self.app.play {
            Some(p) => {
                p.next
                    .interpolate(&p.prev, p.alpha(), &mut self.interpolated);
                g.scene
                    .set_vehicles(&g.gpu.device, &g.gpu.queue, &self.interpolated);
            }
            None => g.scene.set_vehicles(&g.gpu.device, &g.gpu.queue, &[]),
        }
        let raw = g.egui_state.take_egui_input(&g.window);
        let ctx = g.egui_state.egui_ctx().clone();
        let app = &mut self.app;
        let mut output = ctx.run_ui(raw, |ui| crate::ui::ui(ui, app));
        g.egui_state
            .handle_platform_output(&g.window, std::mem::take(&mut output.platform_output));
        g.window.set_title(&self.app.title());
        // egui's texture changes are applied every frame, drawn or not.
        for (id, deltas) in &output.textures_delta.set {
            for delta in deltas {
                g.egui_renderer
                    .update_texture(&g.gpu.device, &g.gpu.queue, *id, delta);
            }
        }
        let frees = std::mem::take(&mut output.textures_delta.free);
        output.textures_delta.clear();
        let frame = match g.surface.get_current_texture() {
            wgpu::CurrentSurfaceTexture::Success(f)
            | wgpu::CurrentSurfaceTexture::Suboptimal(f) => f,
            _ => {
                g.surface.configure(&g.gpu.device, &g.config);
                for id in &frees {
                    g.egui_renderer.free_texture(id);
                }
                g.window.request_redraw();
                return;
            }
        };
        let view = frame.texture.create_view(&Default::default());
        let size = (g.config.width, g.config.height);
        g.scene.set_camera(
            &g.gpu.queue,
            &self.app.camera,
            size.0 as f32 / size.1 as f32,
        );
        let ppp = output.pixels_per_point;
        let jobs = ctx.tessellate(output.shapes, ppp);
        let screen = egui_wgpu::ScreenDescriptor {
            size_in_pixels: [size.0, size.1],
            pixels_per_point: ppp,
        };
        let mut encoder = g.gpu.device.create_command_encoder(&Default::default());
        let extra = g.egui_renderer.update_buffers(
            &g.gpu.device,
            &g.gpu.queue,
            &mut encoder,
            &jobs,
            &screen,
        );
        {
            let mut pass = g.targets.begin(&mut encoder, &view);
            g.scene.draw(&mut pass);
        }
        {
            let pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("egui"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: &view,
                    depth_slice: None,
                    resolve_target: None,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Load,
                        store: wgpu::StoreOp::Store,
                    },
                })],
                ..Default::default()
            });
            g.egui_renderer
                .render(&mut pass.forget_lifetime(), &jobs, &screen);
        }
        g.gpu
            .queue
            .submit(extra.into_iter().chain([encoder.finish()]));
        g.gpu.queue.present(frame);
        let focus = self
            .focus
            .get_or_insert_with(|| crate::focus::FocusKeeper::new(&g.window));
        focus.frame();
        for id in &frees {
            g.egui_renderer.free_texture(id);
        }
        g.window.request_redraw();
    }
}

impl ApplicationHandler for WindowApp {
    fn resumed(&mut self, event_loop: &ActiveEventLoop) {
        if self.graphics.is_some() {
            return;
        }
        match Graphics::new(event_loop, &self.app.title()) {
            Ok(g) => {
                let aspect = g.config.width as f32 / g.config.height.max(1) as f32;
                self.app.fit_view(aspect);
                g.window.request_redraw();
                self.graphics = Some(g);
            }
            Err(e) => {
                self.error = Some(e);
                event_loop.exit();
            }
        }
    }

    fn window_event(&mut self, event_loop: &ActiveEventLoop, _: WindowId, event: WindowEvent) {
        // Mouse and keyboard go to egui, which hands the scene what no panel takes (`ui`).
        if let Some(g) = &mut self.graphics {
            let _ = g.egui_state.on_window_event(&g.window, &event);
        }
        match event {
            WindowEvent::CloseRequested => {
                self.app.request(crate::app::Pending::Quit);
            }
            WindowEvent::Resized(s) => {
                if let Some(g) = &mut self.graphics {
                    g.resize(s.width, s.height);
                }
            }
            WindowEvent::RedrawRequested => self.redraw(),
            WindowEvent::CursorEntered { .. } | WindowEvent::MouseInput { .. } => {
                if let Some(f) = &mut self.focus {
                    f.take_if_unmanaged();
                }
            }
            _ => {}
        }
        if self.app.quit {
            event_loop.exit();
        }
    }
}
