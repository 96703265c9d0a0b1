//! What the user did in the viewport, acted on after the UI drew: clicks and boxes select through
//! the scene BVH; a palette item or file over the viewport is placed by the placement rule, as a
//! live preview (a ghost, traced like any object) while it moves and one step when it is dropped.

use crate::editor::core::object_item::{Objects, parent_of};
use crate::editor::core::palette_payload::{PaletteFile, PaletteItem};
use crate::editor::core::place::view_ray;
use crate::editor::core::selection::{ClickModifiers, Selection};
use crate::editor::core::view::OrbitCamera;
use crate::editor::viewport::gizmo::ActiveDrag;
use crate::editor::viewport::selection::click;
use bevy::camera::primitives::Aabb;
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use std::sync::Arc;
use treelight_document::edit::command::EditCommand;
use treelight_document::edit::history::{EditHistory, EditRequest, EditRequests};
use treelight_document::import::finish::drop_transform;
use treelight_document::import::parse::{ParsedImports, PendingImports};
use treelight_document::scene::placement::{box_corners, place_transform, surface_under_excluding};
use treelight_document::values::object::SceneIndex;
use treelight_scene::{SceneBvh, cast_on};

/// What the user did in the viewport this frame, acted on after the UI (the systems below).
#[derive(Resource, Default)]
pub struct ViewportActions {
    /// A click on the image (not an icon): where, with its modifiers and whether it repeats the
    /// last click on the same spot.
    pub click: Option<(Vec2, ClickModifiers, bool)>,
    /// A click on an icon: its entity and the modifiers.
    pub icon_click: Option<(Entity, ClickModifiers)>,
    /// A finished selection box (window coordinates) and its modifiers.
    pub box_select: Option<(Rect, ClickModifiers)>,
    /// Edit requests: a drag's previews, its commit or its cancel.
    pub requests: Vec<EditRequest>,
    /// A palette item over the viewport: the item, the pointer, whether Shift aligns it to the
    /// surface, and whether it was dropped this frame.
    pub palette: Option<(PaletteItem, Vec2, bool, bool)>,
    /// A scene file from the Assets panel over the viewport: the file (with what the panel read
    /// of it), the pointer, whether Shift aligns it to the surface, and whether it was dropped
    /// this frame.
    pub palette_file: Option<(Arc<PaletteFile>, Vec2, bool, bool)>,
    /// The sky menu's Choose… was clicked: the file dialog opens for a panorama.
    pub choose_panorama: bool,
}

/// What picking reads.
#[derive(SystemParam)]
pub struct Picking<'w, 's> {
    selection: ResMut<'w, Selection>,
    objects: Objects<'w, 's>,
    boxes: Query<'w, 's, (&'static Aabb, &'static GlobalTransform)>,
    cameras: Query<'w, 's, (&'static Camera, &'static GlobalTransform), With<OrbitCamera>>,
    scene: Res<'w, SceneBvh>,
}

/// What placing from the Assets panel reads and asks for.
#[derive(SystemParam)]
pub struct Placing<'w> {
    history: Res<'w, EditHistory>,
    requests: ResMut<'w, EditRequests>,
    index: ResMut<'w, SceneIndex>,
    pending: ResMut<'w, PendingImports>,
    parsed: ResMut<'w, ParsedImports>,
    drag: Res<'w, ActiveDrag>,
}

/// Acts on the frame's viewport actions.
pub fn apply_viewport_actions(
    mut actions: ResMut<ViewportActions>,
    mut picking: Picking,
    mut placing: Placing,
) {
    let actions = std::mem::take(&mut *actions);
    select(&actions, &mut picking);
    place(actions, &picking, &mut placing);
}

/// Clicks and boxes select through the scene BVH (waiting for the worker if it holds the tree: a
/// click must not miss).
fn select(actions: &ViewportActions, p: &mut Picking) {
    let objects = &p.objects;
    if let Some((e, modifiers)) = actions.icon_click {
        click(&mut p.selection, Some(e), modifiers, false, |e| {
            parent_of(objects, e)
        });
    }
    let Ok((camera, cam_gt)) = p.cameras.single() else {
        return;
    };
    if let Some((at, modifiers, same_spot)) = actions.click
        && let Ok(ray) = camera.viewport_to_world(cam_gt, at)
    {
        let hit = p
            .scene
            .read_waiting()
            .and_then(|tree| cast_on(&tree, ray))
            .map(|h| h.entity)
            .filter(|e| objects.contains(*e));
        click(&mut p.selection, hit, modifiers, same_spot, |e| {
            parent_of(objects, e)
        });
    }
    if let Some((rect, modifiers)) = actions.box_select {
        let inside = box_select(&p.scene, camera, cam_gt, rect, objects, &p.boxes);
        let ClickModifiers { toggle, .. } = modifiers;
        if !toggle {
            p.selection.clear();
        }
        for e in inside {
            p.selection.add(e);
        }
    }
}

/// A palette item or file over the viewport: its ghost follows the pointer; a drop makes it one
/// step; anything else removes the ghost. Then the drag's own requests.
fn place(mut actions: ViewportActions, p: &Picking, s: &mut Placing) {
    let camera = p.cameras.single().ok();
    let ghost = s.history.preview_made();
    // The ghost and everything under it, which placement sees through.
    let ghost_parts: Vec<Entity> =
        ghost
            .and_then(|g| s.index.entity(g))
            .map_or_else(Vec::new, |root| {
                p.objects
                    .iter()
                    .map(|o| o.entity)
                    .filter(|&e| {
                        let mut at = Some(e);
                        while let Some(x) = at {
                            if x == root {
                                return true;
                            }
                            at = parent_of(&p.objects, x);
                        }
                        false
                    })
                    .collect()
            });
    let file_dragged = actions.palette_file.is_some();
    if let (Some((file, at, _, dropped)), Some((camera, cam_gt))) =
        (actions.palette_file.take(), camera)
    {
        let ray = camera.viewport_to_world(cam_gt, at).ok();
        place_file(p, s, (file, ray, dropped), ghost, &ghost_parts, || {
            view_ray(camera, cam_gt, Some(at))
        });
    }
    match (actions.palette, camera) {
        (Some((item, at, aligned, dropped)), Some((camera, cam_gt))) => {
            if let Ok(ray) = camera.viewport_to_world(cam_gt, at) {
                place_shape(p, s, (item, ray, aligned, dropped), ghost, &ghost_parts);
            }
        }
        _ if ghost.is_some() && s.drag.0.is_none() && !file_dragged => {
            s.requests.0.push(EditRequest::CancelPreview)
        }
        _ => {}
    }
    s.requests.0.append(&mut actions.requests);
}

/// A scene file from the Assets panel at `ray`: stands where a dropped file would (its own
/// orientation kept), as the panel read it; one not read yet is imported where it lands, without
/// a ghost.
fn place_file(
    p: &Picking,
    s: &mut Placing,
    (file, ray, dropped): (Arc<PaletteFile>, Option<bevy::math::Ray3d>, bool),
    ghost: Option<treelight_document::values::object::SceneId>,
    ghost_parts: &[Entity],
    drop_ray: impl Fn() -> Option<bevy::math::Ray3d>,
) {
    match (ray, file.read.as_ref()) {
        (Some(ray), Some(read)) => {
            let surface = surface_under_excluding(&p.scene, ray, 5.0, ghost_parts);
            let transform = drop_transform(read.bounds, surface);
            match (dropped, ghost) {
                (false, Some(id)) => {
                    s.requests
                        .0
                        .push(EditRequest::Preview(EditCommand::SetTransform {
                            id,
                            transform: transform.into(),
                        }))
                }
                _ => {
                    // The import command takes the file as the panel read it, under the id its
                    // root will have.
                    let root = s.index.allocate();
                    s.parsed.0.insert(root, read.parsed());
                    let command = EditCommand::Import {
                        file: file.path.clone(),
                        root: Some(root),
                        transform: Some(transform.into()),
                    };
                    s.requests.0.push(drop_or_preview(command, dropped));
                }
            }
        }
        _ if dropped => s.pending.start_at(file.path.clone(), drop_ray()),
        _ => {}
    }
}

/// A built-in shape from the Assets panel at `ray`, on the surface there (along its normal with
/// `aligned`).
fn place_shape(
    p: &Picking,
    s: &mut Placing,
    (item, ray, aligned, dropped): (PaletteItem, bevy::math::Ray3d, bool, bool),
    ghost: Option<treelight_document::values::object::SceneId>,
    ghost_parts: &[Entity],
) {
    let surface = surface_under_excluding(&p.scene, ray, 5.0, ghost_parts);
    let (min, max) = item.0.bounds();
    let transform = place_transform(surface, min, max, aligned);
    let command = match (dropped, ghost) {
        (false, Some(id)) => EditCommand::SetTransform {
            id,
            transform: transform.into(),
        },
        _ => EditCommand::AddPrimitive {
            shape: item.0,
            transform: transform.into(),
            id: None,
        },
    };
    s.requests.0.push(drop_or_preview(command, dropped));
}

/// A drag from the Assets panel: a live preview while it moves, one step when it is dropped.
fn drop_or_preview(command: EditCommand, dropped: bool) -> EditRequest {
    if dropped {
        EditRequest::Apply {
            command,
            continuing: false,
        }
    } else {
        EditRequest::Preview(command)
    }
}

/// The meshes a selection box picks: those the image shows inside it (rays through a grid of its
/// pixels, the nearest hit of each) and those whose whole box projects inside it.
fn box_select(
    scene: &SceneBvh,
    camera: &Camera,
    cam_gt: &GlobalTransform,
    rect: Rect,
    objects: &Objects,
    boxes: &Query<(&Aabb, &GlobalTransform)>,
) -> Vec<Entity> {
    let mut found: Vec<Entity> = Vec::new();
    if rect.width() < 2.0 || rect.height() < 2.0 {
        return found;
    }
    // A ray every 4 pixels, at most 96 a side.
    let nx = ((rect.width() / 4.0).ceil() as usize).clamp(2, 96);
    let ny = ((rect.height() / 4.0).ceil() as usize).clamp(2, 96);
    // A stopped worker's tree is not read: only the boxes below pick.
    let tree = scene.read_waiting();
    for j in 0..ny {
        if tree.is_none() {
            break;
        }
        for i in 0..nx {
            let p = rect.min
                + Vec2::new(
                    rect.width() * (i as f32 + 0.5) / nx as f32,
                    rect.height() * (j as f32 + 0.5) / ny as f32,
                );
            if let Ok(ray) = camera.viewport_to_world(cam_gt, p)
                && let Some(hit) = tree.as_deref().and_then(|t| cast_on(t, ray))
                && objects.contains(hit.entity)
                && !found.contains(&hit.entity)
            {
                found.push(hit.entity);
            }
        }
    }
    drop(tree);
    for o in objects.iter() {
        let e = o.entity;
        if o.mesh.is_none() || found.contains(&e) {
            continue;
        }
        if let Ok((aabb, gt)) = boxes.get(e) {
            let (c, h) = (Vec3::from(aabb.center), Vec3::from(aabb.half_extents));
            let inside = box_corners(c - h, c + h).iter().all(|p| {
                camera
                    .world_to_viewport(cam_gt, gt.transform_point(*p))
                    .is_ok_and(|s| rect.contains(s))
            });
            if inside {
                found.push(e);
            }
        }
    }
    found
}
