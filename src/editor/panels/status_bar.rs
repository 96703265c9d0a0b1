//! The status bar: frame rate, object and entity counts, the BVH's size and cost, the path tracer's
//! progress, the scene threads' health, the selection, and every file being opened or traced with
//! its progress and a Cancel.

use crate::editor::core::resident::resident_bytes;
use crate::editor::core::selection::Selection;
use crate::editor::core::view::OrbitCamera;
use crate::editor::core::viewport_render::ViewportRender;
use crate::editor::panels::worker_watch::WorkerHealth;
use bevy::diagnostic::{DiagnosticsStore, FrameTimeDiagnosticsPlugin};
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use bevy_egui::egui;
use std::path::Path;
use treelight_document::import::jobs::{CancelImports, TracingImports};
use treelight_document::import::parse::PendingImports;
use treelight_document::project::open::OpeningProjects;
use treelight_document::values::object::SceneObject;
use treelight_render::PathTracerStats;
use treelight_scene::SceneBvh;

/// What the status bar shows of the scene and the renderer.
#[derive(SystemParam)]
pub struct SceneFigures<'w, 's> {
    diagnostics: Res<'w, DiagnosticsStore>,
    objects: Query<'w, 's, (), With<SceneObject>>,
    entities: Query<'w, 's, ()>,
    scene: Res<'w, SceneBvh>,
    render: Res<'w, ViewportRender>,
    camera: Query<'w, 's, Entity, With<OrbitCamera>>,
    tracer: Res<'w, PathTracerStats>,
    health: Res<'w, WorkerHealth>,
    selection: Res<'w, Selection>,
    names: Query<'w, 's, &'static Name>,
    /// The process's resident memory, bytes, and when it was last read.
    memory: Local<'s, Option<(std::time::Instant, Option<u64>)>>,
}

/// Files being opened and imports being traced, and their Cancel buttons.
#[derive(SystemParam)]
pub struct Loading<'w> {
    opening: ResMut<'w, OpeningProjects>,
    pending: Res<'w, PendingImports>,
    tracing: Res<'w, TracingImports>,
    cancel: ResMut<'w, CancelImports>,
}

/// Draws the status bar into `ui`.
pub fn status_bar(InMut(ui): InMut<egui::Ui>, mut figures: SceneFigures, loading: Loading) {
    // Read twice a second: the file system is asked each time.
    let stale = figures
        .memory
        .is_none_or(|(at, _)| at.elapsed().as_millis() >= 500);
    if stale {
        *figures.memory = Some((std::time::Instant::now(), resident_bytes()));
    }
    ui.horizontal(|ui| {
        scene_figures(ui, &figures);
        loading_files(ui, loading);
    });
}

fn scene_figures(ui: &mut egui::Ui, f: &SceneFigures) {
    let fps = f
        .diagnostics
        .get(&FrameTimeDiagnosticsPlugin::FPS)
        .and_then(|d| d.smoothed())
        .map_or("–".to_owned(), |f| format!("{f:.0}"));
    ui.label(format!("{fps} FPS"));
    ui.separator();
    ui.label(format!("{} scene objects", f.objects.iter().count()));
    ui.separator();
    ui.label(format!(
        "{} entities in the world",
        f.entities.iter().count()
    ));
    if let Some((_, Some(bytes))) = *f.memory {
        ui.separator();
        ui.label(format!("{} MiB", bytes >> 20)).on_hover_text(
            "The editor's resident memory (its GPU buffers too, on a software adapter)",
        );
    }
    let stats = f.scene.stats();
    ui.separator();
    ui.label(format!(
        "BVH: {} triangles, SAH cost {:.1}",
        stats.triangles, stats.sah_cost
    ))
    .on_hover_text(format!(
        "{} inner nodes; last insertion {:.2} MTris/s; last mesh ready {:.1} ms after it was sent",
        stats.inner_nodes,
        stats.insertion_mtris_per_s,
        stats.last_latency.as_secs_f64() * 1e3
    ));
    if let (Some(view), Ok(camera)) = (f.render.traced, f.camera.single()) {
        let figures = f.tracer.figures();
        ui.separator();
        let spp = figures.samples.get(&camera).copied().unwrap_or(0);
        let trace = figures.traces.get(&camera).copied().unwrap_or_default();
        let progress = if trace.previewing {
            "preview".to_string()
        } else {
            format!("{spp} spp")
        };
        let cost = trace
            .cost
            .map_or("not measured yet".to_string(), |(ns, source)| {
                let how = match source {
                    treelight_render::CostSource::Timestamps => "GPU timestamps",
                    treelight_render::CostSource::FrameTimes => "from frame times",
                };
                format!("{ns:.0} ns per pixel sample ({how})")
            });
        ui.label(format!("{}: {progress}", view.label())).on_hover_text(format!(
            "Samples every pixel has accumulated since the last change. This frame traced {} pixel samples; {cost}. Scene upload: {} bytes in the last upload, {} in all",
            trace.traced_per_frame, figures.last_upload_bytes, figures.total_upload_bytes
        ));
    }
    if let Some(kernel) = f.tracer.preparing_kernel().filter(|k| k.noticeable()) {
        ui.separator();
        ui.spinner();
        if kernel.split {
            ui.label("Preparing the path tracer for a large scene").on_hover_text(
                "The scene outgrew one GPU binding, and this software adapter compiles the kernel \
                 that reads split records once per machine (minutes the first time, moments \
                 after). The view is traced once it is ready; editing goes on meanwhile.",
            );
        } else {
            ui.label("Preparing the path tracer").on_hover_text(
                "This software adapter compiles the path tracer's kernel once per machine, and \
                 again for a texture of another kind (up to a minute the first time, moments \
                 after). The view is traced once it is ready; editing goes on meanwhile.",
            );
        }
    }
    if f.render.traced.is_none()
        && let Some(why) = f.tracer.trace_off()
    {
        ui.separator();
        ui.colored_label(egui::Color32::from_rgb(255, 110, 100), "Path tracing off")
            .on_hover_text(why);
    }
    if let Some(line) = f.health.status() {
        ui.separator();
        ui.colored_label(egui::Color32::from_rgb(255, 110, 100), line)
            .on_hover_text(
                [&f.health.worker, &f.health.refinement]
                    .into_iter()
                    .flatten()
                    .cloned()
                    .collect::<Vec<_>>()
                    .join("\n"),
            );
    } else if stats.pending > 0 {
        ui.spinner();
        ui.label(format!("{} changes pending", stats.pending));
    }
    match f.selection.entities() {
        [one] => {
            if let Ok(name) = f.names.get(*one) {
                ui.separator();
                ui.label(format!("Selected: {name}"));
            }
        }
        many if many.len() > 1 => {
            ui.separator();
            ui.label(format!("{} selected", many.len()));
        }
        _ => {}
    }
}

/// Each import until the tree holds it: parsing (no measure of its own), then the share of its
/// triangles traced; either can be cancelled. A project being opened, with its sources read.
fn loading_files(ui: &mut egui::Ui, mut l: Loading) {
    let name = |p: &Path| {
        p.file_name()
            .map_or_else(|| p.display().to_string(), |n| n.to_string_lossy().into())
    };
    if let (Some((done, total)), Some(o)) = (l.opening.progress(), l.opening.0.as_ref()) {
        ui.separator();
        ui.spinner();
        ui.label(format!(
            "Opening {}: {done} of {total} sources read",
            name(&o.path)
        ));
        if ui.small_button("Cancel").clicked() {
            l.opening.cancel();
        }
    }
    let mut cancel = Vec::new();
    for (k, job) in l.pending.0.iter().enumerate() {
        ui.separator();
        ui.spinner();
        ui.label(format!("Opening {}…", name(&job.path)));
        if ui
            .push_id(("cancel-import", k), |ui| ui.small_button("Cancel"))
            .inner
            .clicked()
        {
            cancel.push(job.path.clone());
        }
    }
    for job in &l.tracing.jobs {
        ui.separator();
        ui.add(
            egui::ProgressBar::new(job.fraction())
                .desired_width(160.0)
                .text(format!(
                    "{}: {:.0}% traced",
                    name(&job.file),
                    job.fraction() * 100.0
                )),
        )
        .on_hover_text(format!(
            "{} of {} triangles in the tree; nearest the camera first",
            job.traced,
            job.total()
        ));
        if ui.small_button("Cancel").clicked() {
            cancel.push(job.file.clone());
        }
    }
    if !cancel.is_empty() {
        l.cancel.0.extend(cancel);
    }
}
