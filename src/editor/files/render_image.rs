//! File → Render image… (F12): the viewport's view path traced off screen at a size and sample count
//! the user picks, while the editor stays usable (the render has its own camera and frame budget;
//! an edit meanwhile restarts its samples), with progress and Cancel; the image is saved as a PNG
//! (written atomically, an existing file replaced only when the user says so) and shown.

use crate::editor::core::view::OrbitCamera;
use crate::editor::core::viewport_render::ViewportRender;
use crate::editor::core::widget_rects::WidgetRects;
use crate::editor::files::ask_yes_or_cancel;
use crate::render_file::{CaptureGate, ImageWrite, PipelinesReady, check_image_path, save_png};
use bevy::camera::{Exposure, RenderTarget};
use bevy::core_pipeline::tonemapping::Tonemapping;
use bevy::prelude::*;
use bevy::render::render_resource::TextureFormat;
use bevy::render::view::screenshot::{Screenshot, ScreenshotCaptured};
use bevy_egui::{EguiContexts, EguiTextureHandle, egui};
use std::path::PathBuf;
use treelight_document::project::format::ProjectState;
use treelight_document::scene::notice::Notices;
use treelight_render::{DebugView, OutlineStyle, PathTraced, PathTracerStats};

/// The render window and the render in progress.
#[derive(Resource)]
pub struct RenderImageUi {
    /// Whether the window is shown.
    pub open: bool,
    /// Image width in pixels.
    pub width: u32,
    /// Image height in pixels.
    pub height: u32,
    /// Samples per pixel.
    pub spp: u32,
    /// Where the image goes (a .png).
    pub path: String,
    /// The name the editor proposed (the project's, beside it), never written through a link.
    proposed: String,
    /// The file exists: the user is asked whether to replace it.
    asking: Option<PathBuf>,
    /// The render in progress.
    pub job: Option<RenderJob>,
    /// The last image rendered: shown in the window.
    pub result: Option<RenderResult>,
    /// Why the last render was not saved.
    pub error: Option<String>,
}

impl Default for RenderImageUi {
    fn default() -> Self {
        Self {
            open: false,
            width: 640,
            height: 400,
            spp: 64,
            path: String::new(),
            proposed: String::new(),
            asking: None,
            job: None,
            result: None,
            error: None,
        }
    }
}

/// A render in progress.
pub struct RenderJob {
    camera: Entity,
    target: Handle<Image>,
    path: PathBuf,
    how: ImageWrite,
    spp: u32,
    /// When the image may be captured.
    gate: CaptureGate,
    captured: bool,
}

/// A finished render.
pub struct RenderResult {
    image: Handle<Image>,
    size: UVec2,
    /// Where it was saved.
    pub path: PathBuf,
}

/// Marks the render's camera.
#[derive(Component)]
pub struct OffscreenRender;

impl RenderImageUi {
    /// Opens the window, its file named after the project (in its folder) the first time.
    pub fn open(&mut self, project: &ProjectState) {
        self.open = true;
        if self.path.is_empty() {
            let (dir, stem) = match &project.path {
                Some(p) => (
                    p.parent().map(PathBuf::from).unwrap_or_default(),
                    p.file_stem()
                        .map_or("render".into(), |s| s.to_string_lossy().into_owned()),
                ),
                None => (
                    std::env::current_dir().unwrap_or_default(),
                    "render".to_owned(),
                ),
            };
            self.path = dir.join(format!("{stem}.png")).display().to_string();
            self.proposed = self.path.clone();
        }
    }

    /// Whether the file is still the one the editor proposed (not one the user named).
    fn own_name(&self) -> bool {
        self.path.trim() == self.proposed.trim()
    }

    /// The file to write, or why the field does not name one.
    fn target(&self) -> Result<PathBuf, String> {
        let mut path = PathBuf::from(self.path.trim());
        if path.as_os_str().is_empty() {
            return Err("Name the file the image goes to.".into());
        }
        if path.extension().is_none() {
            path.set_extension("png");
        }
        check_image_path(&path, &["png"])?;
        Ok(path)
    }
}

/// The window: size, samples, file; Render, Cancel and Close; progress; the last image. Its
/// controls are named in `widgets` ("Render width", "Render samples", "Render file", "Render",
/// "Cancel render").
#[allow(clippy::too_many_arguments)]
pub fn render_image_window(
    mut contexts: EguiContexts,
    mut ui_state: ResMut<RenderImageUi>,
    mut widgets: ResMut<WidgetRects>,
    stats: Res<PathTracerStats>,
    mut commands: Commands,
    mut images: ResMut<Assets<Image>>,
    viewport: Query<(&GlobalTransform, &Projection, &Exposure, &Tonemapping), With<OrbitCamera>>,
    render: Res<ViewportRender>,
) -> Result {
    // The last image, registered with egui before the window borrows the context.
    let shown = ui_state.result.as_ref().map(|r| {
        (
            contexts.add_image(EguiTextureHandle::Weak(r.image.id())),
            r.size,
            r.path.clone(),
        )
    });
    let ctx = contexts.ctx_mut()?.clone();
    let s = &mut *ui_state;
    if let Some(path) = s.asking.clone() {
        let name = path.display().to_string();
        let (answer, buttons) = ask_yes_or_cancel(
            &ctx,
            "Replace the image?",
            &format!("{name} exists. Replace it with the new render?"),
            "Replace",
        );
        widgets.extend(buttons);
        match answer {
            Some(true) => {
                s.asking = None;
                let how = if s.own_name() {
                    ImageWrite::ReplaceOwnName
                } else {
                    ImageWrite::Replace
                };
                start(
                    s,
                    (path, how),
                    &mut commands,
                    &mut images,
                    &viewport,
                    &render,
                );
            }
            Some(false) => s.asking = None,
            None => {}
        }
    }
    if !s.open {
        return Ok(());
    }
    let mut open = true;
    let mut go = false;
    let mut cancel = false;
    egui::Window::new("Render image")
        .open(&mut open)
        .collapsible(false)
        .resizable(false)
        .show(&ctx, |ui| {
            let busy = s.job.is_some();
            ui.add_enabled_ui(!busy, |ui| {
                settings_grid(ui, s, &mut widgets);
            });
            ui.horizontal(|ui| {
                if let Some(job) = &s.job {
                    let done = stats.samples(job.camera).min(job.spp);
                    ui.add(
                        egui::ProgressBar::new(done as f32 / job.spp as f32)
                            .text(format!("{done} / {} samples per pixel", job.spp))
                            .desired_width(260.0),
                    );
                    let c = ui.button("Cancel");
                    widgets.push("Cancel render", c.rect);
                    cancel = c.clicked();
                } else {
                    let r = ui.button("Render");
                    widgets.push("Render", r.rect);
                    go = r.clicked();
                }
            });
            if let Some(e) = &s.error {
                ui.colored_label(egui::Color32::from_rgb(255, 110, 100), e);
            }
            if let Some((id, size, path)) = &shown {
                ui.separator();
                ui.label(format!("Saved to {}", path.display()));
                let w = 320.0f32.min(size.x as f32);
                let h = w * size.y as f32 / size.x.max(1) as f32;
                ui.add(egui::Image::new((*id, egui::vec2(w, h))));
            }
        });
    if cancel && let Some(job) = s.job.take() {
        commands.entity(job.camera).despawn();
    }
    if go {
        s.error = None;
        match (s.target(), s.own_name()) {
            (Ok(path), true) if is_link(&path) => {
                s.error = Some(format!(
                    "{} is a link; the editor does not write through a link under a name it \
                     chose. Name the file.",
                    path.display()
                ));
            }
            (Ok(path), _) if std::fs::symlink_metadata(&path).is_ok() => s.asking = Some(path),
            (Ok(path), _) => {
                let job = (path, ImageWrite::New);
                start(s, job, &mut commands, &mut images, &viewport, &render);
            }
            (Err(e), _) => s.error = Some(e),
        }
    }
    if !open {
        s.open = false;
    }
    Ok(())
}

/// The render's size, samples and file.
fn settings_grid(ui: &mut egui::Ui, s: &mut RenderImageUi, widgets: &mut WidgetRects) {
    egui::Grid::new("render-settings")
        .num_columns(2)
        .show(ui, |ui| {
            ui.label("Size");
            ui.horizontal(|ui| {
                let w = ui.add(
                    egui::DragValue::new(&mut s.width)
                        .range(1..=16384)
                        .suffix(" px"),
                );
                widgets.push("Render width", w.rect);
                ui.label("×");
                ui.add(
                    egui::DragValue::new(&mut s.height)
                        .range(1..=16384)
                        .suffix(" px"),
                );
            });
            ui.end_row();
            ui.label("Samples");
            let spp = ui
                .add(egui::DragValue::new(&mut s.spp).range(1..=65536))
                .on_hover_text("Samples per pixel: more take longer and show less noise");
            widgets.push("Render samples", spp.rect);
            ui.end_row();
            ui.label("File");
            let file = ui.add(egui::TextEdit::singleline(&mut s.path).desired_width(320.0));
            widgets.push("Render file", file.rect);
            ui.end_row();
        });
}

fn is_link(path: &std::path::Path) -> bool {
    std::fs::symlink_metadata(path).is_ok_and(|m| m.file_type().is_symlink())
}

/// Starts a render into `path` (written as `how` says) from the viewport camera's view, with its look and the viewport's
/// path-tracer settings (full resolution, no selection outline).
fn start(
    s: &mut RenderImageUi,
    (path, how): (PathBuf, ImageWrite),
    commands: &mut Commands,
    images: &mut Assets<Image>,
    viewport: &Query<(&GlobalTransform, &Projection, &Exposure, &Tonemapping), With<OrbitCamera>>,
    render: &ViewportRender,
) {
    let Ok((gt, projection, exposure, tonemapping)) = viewport.single() else {
        s.error = Some("There is no view to render.".into());
        return;
    };
    let target = images.add(Image::new_target_texture(
        s.width,
        s.height,
        TextureFormat::Rgba8UnormSrgb,
        None,
    ));
    let camera = commands
        .spawn((
            Name::new("Render image camera"),
            OffscreenRender,
            Camera3d::default(),
            // Traced: multisampling would add a target of four samples a pixel and smooth nothing.
            Msaa::Off,
            // Before the viewport's and the UI's cameras.
            Camera {
                order: -1,
                ..default()
            },
            RenderTarget::Image(target.clone().into()),
            gt.compute_transform(),
            projection.clone(),
            *exposure,
            *tonemapping,
            PathTraced {
                view: DebugView::PathTraced,
                resolution_scale: 1.0,
                samples_per_frame: 1,
                max_samples: s.spp,
                // A still image: only its own samples.
                temporal: false,
                outline: OutlineStyle {
                    width: 0.0,
                    ..default()
                },
                ..render.settings
            },
        ))
        .id();
    s.job = Some(RenderJob {
        camera,
        target,
        path,
        how,
        spp: s.spp,
        gate: CaptureGate::default(),
        captured: false,
    });
}

/// Once every pixel has its samples and every pipeline is compiled, captures the image.
pub fn finish_render(
    mut commands: Commands,
    mut ui_state: ResMut<RenderImageUi>,
    stats: Res<PathTracerStats>,
    ready: Res<PipelinesReady>,
) {
    let Some(job) = ui_state.job.as_mut() else {
        return;
    };
    if job.captured {
        return;
    }
    if !job.gate.open(stats.finished(job.camera, job.spp), &ready) {
        return;
    }
    job.captured = true;
    commands
        .spawn(Screenshot::image(job.target.clone()))
        .observe(save_render);
}

/// Saves the captured image, shows it, and ends the render.
fn save_render(
    captured: On<ScreenshotCaptured>,
    mut commands: Commands,
    mut ui_state: ResMut<RenderImageUi>,
    mut images: ResMut<Assets<Image>>,
    mut notices: ResMut<Notices>,
) {
    let Some(job) = ui_state.job.take() else {
        return;
    };
    commands.entity(job.camera).despawn();
    let image = captured.image.clone();
    let size = image.size();
    match save_png(&image, &job.path, job.how) {
        Ok(()) => {
            notices.info(format!(
                "Rendered {} at {} samples per pixel",
                job.path.display(),
                job.spp
            ));
            ui_state.result = Some(RenderResult {
                image: images.add(image),
                size,
                path: job.path,
            });
        }
        Err(e) => {
            let text = format!("{}: cannot save the image: {e}", job.path.display());
            notices.error(text.clone());
            ui_state.error = Some(text);
        }
    }
}
