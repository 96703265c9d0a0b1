//! The Assets panel: the built-in shapes, the built-in sample meshes and the scene files of every
//! folder the user added, each a tile (files with a ray-cast thumbnail). A click adds the item
//! where the view's centre meets the scene; a drag carries it over the viewport. A shape is shown
//! (and path traced) at the point under the pointer by the placement rule until it is dropped (one
//! step) or the drag is cancelled with Escape or ends outside the viewport; a file is imported
//! where it is dropped, by the same rule.

use crate::editor::assets::library::{AssetLibrary, THUMBNAIL, Thumbnail};
use crate::editor::core::file_requests::{FileAction, FileRequest};
use crate::editor::core::palette_payload::{PaletteFile, PaletteItem, paint_drag_label};
use crate::editor::core::place::{shape_at, view_ray};
use crate::editor::core::view::OrbitCamera;
use crate::editor::core::widget_rects::WidgetRects;
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use bevy_egui::egui;
use std::collections::HashMap;
use std::path::PathBuf;
use treelight_document::edit::history::EditRequests;
use treelight_document::import::parse::PendingImports;
use treelight_document::values::primitive::Primitive;
use treelight_scene::SceneBvh;

/// What the user asked of the panel this frame.
#[derive(Clone, Debug, PartialEq)]
pub enum PaletteClick {
    /// Add this shape at the view's centre.
    Shape(Primitive),
    /// Import this file at the view's centre.
    File(PathBuf),
    /// Choose a folder to add.
    AddFolder,
    /// Take this folder off the panel.
    RemoveFolder(PathBuf),
}

/// The thumbnails as egui textures, by file, with the version each was made from.
#[derive(Resource, Default)]
pub struct ThumbnailTextures(HashMap<PathBuf, (u32, egui::TextureHandle)>);

const TILE: egui::Vec2 = egui::vec2(84.0, 52.0);

fn drag_label(ui: &egui::Ui, response: &egui::Response, text: &str) {
    if response.dragged()
        && let Some(p) = ui.ctx().pointer_interact_pos()
    {
        paint_drag_label(ui.ctx(), p, text);
    }
}

/// Lays out the panel; returns what was clicked (not dragged). Each tile's rectangle goes to
/// `tiles`, named after its shape or file.
pub fn palette_ui(
    ui: &mut egui::Ui,
    tiles: &mut Vec<(String, egui::Rect)>,
    library: &AssetLibrary,
    textures: &mut ThumbnailTextures,
) -> Option<PaletteClick> {
    let mut clicked = None;
    ui.weak("Drag onto the viewport to place (Shift: along the surface's normal); click to add at the view's centre.");
    ui.add_space(4.0);
    egui::ScrollArea::vertical()
        .auto_shrink([false; 2])
        .show(ui, |ui| {
            ui.strong("Shapes");
            ui.horizontal_wrapped(|ui| {
                for shape in Primitive::ALL {
                    let tile = egui::Button::new(egui::RichText::new(shape.label()).size(13.0))
                        .min_size(TILE)
                        .sense(egui::Sense::click_and_drag());
                    let response = ui.add(tile);
                    tiles.push((shape.label().to_owned(), response.rect));
                    if response.drag_started() {
                        response.dnd_set_drag_payload(PaletteItem(shape));
                    } else if response.clicked() {
                        clicked = Some(PaletteClick::Shape(shape));
                    }
                    drag_label(ui, &response, shape.label());
                }
            });
            for folder in &library.folders {
                ui.add_space(6.0);
                ui.horizontal(|ui| {
                    let title = if folder.built_in {
                        "Samples".to_owned()
                    } else {
                        folder.path.file_name().map_or_else(
                            || folder.path.display().to_string(),
                            |n| n.to_string_lossy().into_owned(),
                        )
                    };
                    ui.strong(title)
                        .on_hover_text(folder.path.display().to_string());
                    if !folder.built_in
                        && ui
                            .small_button("✕")
                            .on_hover_text("Remove this folder from the panel (its files stay)")
                            .clicked()
                    {
                        clicked = Some(PaletteClick::RemoveFolder(folder.path.clone()));
                    }
                });
                if let Some(e) = &folder.error {
                    ui.colored_label(egui::Color32::from_rgb(255, 110, 100), e);
                }
                if folder.files.is_empty() && folder.error.is_none() {
                    ui.weak("No .gltf, .glb, .obj or .ply files here.");
                }
                ui.horizontal_wrapped(|ui| {
                    for file in &folder.files {
                        let name = file
                            .file_stem()
                            .map_or_else(String::new, |n| n.to_string_lossy().into_owned());
                        let response = file_tile(ui, file, &name, library, textures);
                        tiles.push((
                            file.file_name()
                                .map_or_else(String::new, |n| n.to_string_lossy().into_owned()),
                            response.rect,
                        ));
                        if response.drag_started() {
                            response.dnd_set_drag_payload(PaletteFile {
                                path: file.clone(),
                                read: library.read_ahead(file),
                            });
                        } else if response.clicked() {
                            clicked = Some(PaletteClick::File(file.clone()));
                        }
                        drag_label(ui, &response, &name);
                    }
                });
            }
            ui.add_space(8.0);
            if ui
                .button("Add folder…")
                .on_hover_text("List a folder's scene files here (kept between runs)")
                .clicked()
            {
                clicked = Some(PaletteClick::AddFolder);
            }
        });
    clicked
}

/// One file's tile: its thumbnail (once made) over its name.
fn file_tile(
    ui: &mut egui::Ui,
    file: &PathBuf,
    name: &str,
    library: &AssetLibrary,
    textures: &mut ThumbnailTextures,
) -> egui::Response {
    let side = THUMBNAIL as f32;
    let (rect, response) = ui.allocate_exact_size(
        egui::vec2(side + 12.0, side + 28.0),
        egui::Sense::click_and_drag(),
    );
    let visuals = ui.style().interact(&response);
    ui.painter().rect_filled(rect, 4.0, visuals.weak_bg_fill);
    let image_rect =
        egui::Rect::from_min_size(rect.min + egui::vec2(6.0, 4.0), egui::vec2(side, side));
    match library.thumbnails.get(file) {
        Some(Thumbnail::Ready { image, version }) => {
            let stale = textures.0.get(file).is_none_or(|(v, _)| v != version);
            if stale {
                let pixels = egui::ColorImage::from_rgba_unmultiplied(
                    [THUMBNAIL as usize, THUMBNAIL as usize],
                    &image.rgba,
                );
                let handle = ui.ctx().load_texture(
                    format!("thumbnail {}", file.display()),
                    pixels,
                    egui::TextureOptions::LINEAR,
                );
                textures.0.insert(file.clone(), (*version, handle));
            }
            if let Some((_, handle)) = textures.0.get(file) {
                ui.painter().image(
                    handle.id(),
                    image_rect,
                    egui::Rect::from_min_max(egui::pos2(0.0, 0.0), egui::pos2(1.0, 1.0)),
                    egui::Color32::WHITE,
                );
            }
        }
        Some(Thumbnail::Failed(e)) => {
            ui.painter().text(
                image_rect.center(),
                egui::Align2::CENTER_CENTER,
                "unreadable",
                egui::FontId::proportional(11.0),
                egui::Color32::from_rgb(255, 110, 100),
            );
            response.clone().on_hover_text(e.clone());
        }
        _ => {
            ui.painter().text(
                image_rect.center(),
                egui::Align2::CENTER_CENTER,
                "…",
                egui::FontId::proportional(16.0),
                visuals.text_color(),
            );
        }
    }
    let mut label = name.to_owned();
    if label.chars().count() > 12 {
        label = label.chars().take(11).collect::<String>() + "…";
    }
    ui.painter().text(
        egui::pos2(rect.center().x, rect.max.y - 12.0),
        egui::Align2::CENTER_CENTER,
        label,
        egui::FontId::proportional(12.0),
        visuals.text_color(),
    );
    let triangles = match library.thumbnails.get(file) {
        Some(Thumbnail::Ready { image, .. }) => format!("\n{} triangles", image.triangles),
        _ => String::new(),
    };
    response.on_hover_text(format!("{}{triangles}", file.display()))
}

/// What a click in the Assets tab changes.
#[derive(SystemParam)]
pub struct PaletteTargets<'w, 's> {
    requests: ResMut<'w, EditRequests>,
    pending: ResMut<'w, PendingImports>,
    scene: Res<'w, SceneBvh>,
    cameras: Query<'w, 's, (&'static Camera, &'static GlobalTransform), With<OrbitCamera>>,
    files: MessageWriter<'w, FileRequest>,
}

/// Draws the Assets tab into `ui` and does what a click asked: a shape or a file goes where the
/// view's centre meets the scene; folders are added or removed.
pub fn assets_tab(
    InMut(ui): InMut<egui::Ui>,
    mut library: ResMut<AssetLibrary>,
    mut textures: ResMut<ThumbnailTextures>,
    mut widgets: ResMut<WidgetRects>,
    mut t: PaletteTargets,
) {
    let mut tiles = Vec::new();
    let click = palette_ui(ui, &mut tiles, &library, &mut textures);
    widgets.extend(tiles);
    let centre = t
        .cameras
        .single()
        .ok()
        .and_then(|(c, g)| view_ray(c, g, None));
    match click {
        Some(PaletteClick::Shape(shape)) => {
            if let Some(ray) = centre {
                t.requests.apply(shape_at(&t.scene, ray, shape));
            }
        }
        Some(PaletteClick::File(file)) => t.pending.start_at(file, centre),
        Some(PaletteClick::AddFolder) => {
            t.files.write(FileRequest(FileAction::AddAssetFolder));
        }
        Some(PaletteClick::RemoveFolder(dir)) => library.remove_folder(&dir),
        None => {}
    }
}
