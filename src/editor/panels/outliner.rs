//! The outliner: the scene as a tree. Rows fold, show and hide their object, rename it
//! (double-click or F2), select (Ctrl toggles, Shift selects a range), and move objects under
//! another when dragged onto its row (or to the top level when dropped below the rows). A filter
//! keeps the rows whose names match, with their parents. Only the rows in sight are laid out.

use crate::editor::core::key_chords::KeyChords;
use crate::editor::core::keymap::Action;
use crate::editor::core::object_item::{Objects, kind_of, parent_of};
use crate::editor::core::selection::Selection;
use crate::editor::core::widget_rects::WidgetRects;
use bevy::ecs::system::SystemParam;
use bevy::prelude::*;
use bevy_egui::egui;
use std::collections::{HashMap, HashSet};
use treelight_document::edit::command::EditCommand;
use treelight_document::edit::history::EditRequests;
use treelight_document::values::object::SceneId;

/// One object as the outliner lists it.
pub struct OutlinerItem {
    /// The entity.
    pub entity: Entity,
    /// Its stable id.
    pub id: SceneId,
    /// Its parent, when that is a scene object.
    pub parent: Option<Entity>,
    /// Its name.
    pub name: String,
    /// A glyph for what it is.
    pub kind: &'static str,
    /// Whether the object itself is shown (its parent may still hide it).
    pub visible: bool,
}

/// One row: an item at a depth, with whether it folds.
pub struct OutlinerRow {
    /// Index into the items.
    item: usize,
    /// Levels below the top.
    depth: usize,
    /// `Some(expanded)` for a row with children.
    expandable: Option<bool>,
}

/// What the outliner keeps between frames.
#[derive(Resource, Default)]
pub struct OutlinerState {
    /// Rows the user folded.
    pub collapsed: HashSet<Entity>,
    /// Names must contain this (any case) to be listed, with their parents.
    pub filter: String,
    /// The row being renamed and the text typed so far.
    renaming: Option<(Entity, String)>,
    /// Whether the rename field still has to take the keyboard.
    focus_rename: bool,
}

impl OutlinerState {
    /// Starts renaming `entity`, whose name is `name`.
    pub fn start_rename(&mut self, entity: Entity, name: &str) {
        self.renaming = Some((entity, name.to_owned()));
        self.focus_rename = true;
    }
}

/// The outliner's objects and rows as last made, kept between frames: they are made again only
/// when a scene object was added, removed, renamed, reparented or shown/hidden
/// ([`invalidate_outliner`]), or the filter or the folding changed.
#[derive(Resource, Default)]
pub struct OutlinerCache {
    /// The objects, as [`rows`] takes them.
    pub items: Vec<OutlinerItem>,
    /// Their rows.
    pub rows: Vec<OutlinerRow>,
    /// Whether `items` and `rows` still describe the scene.
    pub valid: bool,
    /// The filter and the folded rows they were made with.
    made_with: (String, HashSet<Entity>),
}

impl OutlinerCache {
    /// Whether the rows must be made again for `state`'s filter and folding.
    pub fn stale_for(&self, state: &OutlinerState) -> bool {
        !self.valid || self.made_with.0 != state.filter || self.made_with.1 != state.collapsed
    }

    /// Keeps `items` and the rows made from them under `state`.
    pub fn remake(&mut self, items: Vec<OutlinerItem>, state: &OutlinerState) {
        self.rows = rows(&items, state);
        self.items = items;
        self.valid = true;
        self.made_with = (state.filter.clone(), state.collapsed.clone());
    }
}

/// What the outliner lists changed: a scene object came or went, or its name, parent, visibility
/// or kind changed.
type OutlinerChanges = Or<(
    Added<treelight_document::values::object::SceneObject>,
    Changed<Name>,
    Changed<ChildOf>,
    Changed<Visibility>,
    Changed<Mesh3d>,
    Changed<SceneId>,
)>;

/// Marks the outliner's cache stale when what it lists changed (runs before the UI).
pub fn invalidate_outliner(
    mut cache: ResMut<OutlinerCache>,
    changed: Query<
        (),
        (
            With<treelight_document::values::object::SceneObject>,
            OutlinerChanges,
        ),
    >,
    mut removed: RemovedComponents<treelight_document::values::object::SceneObject>,
    mut unparented: RemovedComponents<ChildOf>,
) {
    let gone = removed.read().count() + unparented.read().count() > 0;
    if gone || !changed.is_empty() {
        cache.valid = false;
    }
}

/// The objects dragged onto another row.
#[derive(Clone, Debug)]
struct DraggedObjects(Vec<SceneId>);

/// Flattens `items` into rows: each after its parent, indented, nothing under a folded row, and
/// with a filter only matching names and their ancestors (unfolded).
pub fn rows(items: &[OutlinerItem], state: &OutlinerState) -> Vec<OutlinerRow> {
    let index: HashMap<Entity, usize> = items
        .iter()
        .enumerate()
        .map(|(i, it)| (it.entity, i))
        .collect();
    let mut children: HashMap<Option<Entity>, Vec<usize>> = HashMap::new();
    for (i, it) in items.iter().enumerate() {
        let parent = it.parent.filter(|p| index.contains_key(p));
        children.entry(parent).or_default().push(i);
    }
    for list in children.values_mut() {
        // By id: the order things were made in, kept when an undo brings an object back.
        list.sort_by_key(|i| items[*i].id);
    }
    let filter = state.filter.trim().to_lowercase();
    let shown: Option<HashSet<usize>> = (!filter.is_empty()).then(|| {
        let mut shown = HashSet::new();
        for (i, it) in items.iter().enumerate() {
            if it.name.to_lowercase().contains(&filter) {
                let mut at = Some(i);
                while let Some(k) = at {
                    if !shown.insert(k) {
                        break;
                    }
                    at = items[k].parent.and_then(|p| index.get(&p).copied());
                }
            }
        }
        shown
    });
    let mut out = Vec::new();
    let mut stack: Vec<(usize, usize)> = children
        .get(&None)
        .map(|r| r.iter().rev().map(|i| (*i, 0)).collect())
        .unwrap_or_default();
    while let Some((i, depth)) = stack.pop() {
        if shown.as_ref().is_some_and(|s| !s.contains(&i)) {
            continue;
        }
        let kids = children.get(&Some(items[i].entity));
        let collapsed = shown.is_none() && state.collapsed.contains(&items[i].entity);
        out.push(OutlinerRow {
            item: i,
            depth,
            expandable: kids.is_some_and(|k| !k.is_empty()).then_some(!collapsed),
        });
        if !collapsed && let Some(kids) = kids {
            stack.extend(kids.iter().rev().map(|k| (*k, depth + 1)));
        }
    }
    out
}

/// The outliner panel.
pub struct OutlinerPanel<'a> {
    /// The scene's objects.
    pub items: &'a [OutlinerItem],
    /// Its rows, from [`rows`].
    pub rows: &'a [OutlinerRow],
    /// The shared selection.
    pub selection: &'a mut Selection,
    /// Folding, filter and renaming.
    pub state: &'a mut OutlinerState,
    /// Commands the panel asks for.
    pub commands: &'a mut Vec<EditCommand>,
    /// Whether F2 was pressed with the keyboard free.
    pub f2: bool,
    /// Each laid-out row's label rectangle, named `row <id>`.
    pub row_rects: &'a mut Vec<(String, egui::Rect)>,
}

/// Height of a row, points.
const ROW_HEIGHT: f32 = 20.0;

impl OutlinerPanel<'_> {
    /// Lays out the panel.
    pub fn ui(&mut self, ui: &mut egui::Ui) {
        ui.horizontal(|ui| {
            ui.label("🔍");
            ui.add(
                egui::TextEdit::singleline(&mut self.state.filter)
                    .hint_text("Filter by name")
                    .desired_width(f32::INFINITY),
            );
        });
        if self.f2
            && let Some(active) = self.selection.active()
            && let Some(item) = self.items.iter().find(|i| i.entity == active)
        {
            self.state.start_rename(active, &item.name);
        }
        let dragging = egui::DragAndDrop::has_payload_of_type::<DraggedObjects>(ui.ctx());
        let bottom_zone = if dragging { 26.0 } else { 0.0 };
        let scroll_height = (ui.available_height() - bottom_zone).max(ROW_HEIGHT);
        let mut clicked: Option<(usize, egui::Modifiers)> = None;
        egui::ScrollArea::vertical()
            .id_salt("outliner-rows")
            .auto_shrink([false; 2])
            .max_height(scroll_height)
            .show_rows(ui, ROW_HEIGHT, self.rows.len(), |ui, range| {
                for r in range {
                    if let Some(m) = self.row_ui(ui, r) {
                        clicked = Some((r, m));
                    }
                }
            });
        if self.rows.is_empty() {
            ui.weak(if self.state.filter.trim().is_empty() {
                "The scene is empty."
            } else {
                "No name matches the filter."
            });
        }
        if dragging {
            let (rect, response) = ui.allocate_exact_size(
                egui::vec2(ui.available_width(), bottom_zone - 4.0),
                egui::Sense::hover(),
            );
            let hovered = response.dnd_hover_payload::<DraggedObjects>().is_some();
            ui.painter().rect(
                rect,
                3.0,
                egui::Color32::from_white_alpha(if hovered { 30 } else { 10 }),
                egui::Stroke::new(1.0, egui::Color32::from_gray(120)),
                egui::StrokeKind::Inside,
            );
            ui.painter().text(
                rect.center(),
                egui::Align2::CENTER_CENTER,
                "Drop here for the top level",
                egui::FontId::proportional(12.0),
                egui::Color32::from_gray(200),
            );
            if let Some(payload) = response.dnd_release_payload::<DraggedObjects>() {
                self.commands.push(EditCommand::Reparent {
                    ids: payload.0.clone(),
                    parent: None,
                });
            }
        }
        if let Some((r, modifiers)) = clicked {
            self.select_row(r, modifiers);
        }
    }

    /// One row; returns the modifiers of a click on its label.
    fn row_ui(&mut self, ui: &mut egui::Ui, r: usize) -> Option<egui::Modifiers> {
        let row = &self.rows[r];
        let item = &self.items[row.item];
        let selected = self.selection.contains(item.entity);
        let mut clicked = None;
        ui.horizontal(|ui| {
            ui.set_height(ROW_HEIGHT);
            ui.add_space(row.depth as f32 * 14.0);
            match row.expandable {
                Some(expanded) => {
                    let arrow = if expanded { "⏷" } else { "⏵" };
                    if ui.small_button(arrow).clicked() {
                        if expanded {
                            self.state.collapsed.insert(item.entity);
                        } else {
                            self.state.collapsed.remove(&item.entity);
                        }
                    }
                }
                None => ui.add_space(18.0),
            }
            // Show or hide: a hidden mesh leaves the traced scene too.
            let eye = if item.visible { "👁" } else { "—" };
            let tip = if item.visible { "Hide" } else { "Show" };
            if ui.small_button(eye).on_hover_text(tip).clicked() {
                self.commands.push(EditCommand::SetVisible {
                    id: item.id,
                    visible: !item.visible,
                });
            }
            if let Some((e, text)) = self.state.renaming.as_mut()
                && *e == item.entity
            {
                let edit = ui.add(egui::TextEdit::singleline(text).desired_width(f32::INFINITY));
                if std::mem::take(&mut self.state.focus_rename) {
                    edit.request_focus();
                }
                let cancel = ui.input(|i| i.key_pressed(egui::Key::Escape));
                if edit.lost_focus() {
                    let name = text.trim().to_owned();
                    if !cancel && !name.is_empty() && name != item.name {
                        self.commands
                            .push(EditCommand::Rename { id: item.id, name });
                    }
                    self.state.renaming = None;
                }
                return;
            }
            let label = egui::Button::selectable(selected, format!("{}  {}", item.kind, item.name))
                .sense(egui::Sense::click_and_drag());
            let response = ui.add(label);
            self.row_rects
                .push((format!("row {}", item.id.0), response.rect));
            if response.double_clicked() {
                self.state.start_rename(item.entity, &item.name);
            } else if response.clicked() {
                clicked = Some(ui.input(|i| i.modifiers));
            }
            if response.drag_started() {
                // Dragging a selected row moves the whole selection.
                let ids: Vec<SceneId> = if selected {
                    self.items
                        .iter()
                        .filter(|i| self.selection.contains(i.entity))
                        .map(|i| i.id)
                        .collect()
                } else {
                    vec![item.id]
                };
                response.dnd_set_drag_payload(DraggedObjects(ids));
            }
            if let Some(payload) = response.dnd_hover_payload::<DraggedObjects>()
                && !payload.0.contains(&item.id)
            {
                ui.painter().rect_stroke(
                    response.rect,
                    2.0,
                    egui::Stroke::new(1.5, egui::Color32::from_rgb(120, 170, 255)),
                    egui::StrokeKind::Outside,
                );
            }
            if let Some(payload) = response.dnd_release_payload::<DraggedObjects>()
                && !payload.0.contains(&item.id)
            {
                self.commands.push(EditCommand::Reparent {
                    ids: payload.0.clone(),
                    parent: Some(item.id),
                });
            }
            if response.dragged()
                && let Some(payload) = egui::DragAndDrop::payload::<DraggedObjects>(ui.ctx())
                && let Some(p) = ui.ctx().pointer_interact_pos()
            {
                let text = match payload.0.len() {
                    1 => format!("Move {}", item.name),
                    n => format!("Move {n} objects"),
                };
                crate::editor::core::palette_payload::paint_drag_label(ui.ctx(), p, &text);
            }
        });
        clicked
    }

    /// A click on row `r`: select it alone, toggle it (Ctrl), or select the rows from the active
    /// one to it (Shift).
    fn select_row(&mut self, r: usize, modifiers: egui::Modifiers) {
        let entity = self.items[self.rows[r].item].entity;
        if modifiers.shift
            && let Some(active) = self.selection.active()
            && let Some(from) = self
                .rows
                .iter()
                .position(|row| self.items[row.item].entity == active)
        {
            let (a, b) = (from.min(r), from.max(r));
            let mut range: Vec<Entity> = (a..=b)
                .map(|k| self.items[self.rows[k].item].entity)
                .collect();
            // The clicked row becomes the active one.
            range.retain(|e| *e != entity);
            range.push(entity);
            self.selection.set_all(range);
        } else if modifiers.ctrl || modifiers.command {
            self.selection.toggle(entity);
        } else {
            self.selection.set(Some(entity));
        }
    }
}

/// What the outliner tab reads and changes.
#[derive(SystemParam)]
pub struct OutlinerAccess<'w, 's> {
    objects: Objects<'w, 's>,
    selection: ResMut<'w, Selection>,
    state: ResMut<'w, OutlinerState>,
    cache: ResMut<'w, OutlinerCache>,
    requests: ResMut<'w, EditRequests>,
    chords: Res<'w, KeyChords>,
    widgets: ResMut<'w, WidgetRects>,
}

/// Draws the outliner tab into `ui`: its rows made again only when the scene or the outliner's
/// state changed.
pub fn outliner_tab(InMut(ui): InMut<egui::Ui>, access: OutlinerAccess) {
    let OutlinerAccess {
        objects,
        mut selection,
        mut state,
        mut cache,
        mut requests,
        chords,
        mut widgets,
    } = access;
    state.collapsed.retain(|e| objects.contains(*e));
    if cache.stale_for(&state) {
        let items: Vec<OutlinerItem> = objects
            .iter()
            .map(|o| OutlinerItem {
                entity: o.entity,
                id: *o.id,
                parent: parent_of(&objects, o.entity),
                name: o.name.as_str().to_owned(),
                kind: kind_of(o.mesh.is_some(), o.light_kind()),
                visible: o.visibility != Some(&Visibility::Hidden),
            })
            .collect();
        cache.remake(items, &state);
    }
    let f2 = chords.triggered(Action::Rename) && !ui.ctx().egui_wants_keyboard_input();
    let mut commands = Vec::new();
    let mut row_rects = Vec::new();
    OutlinerPanel {
        items: &cache.items,
        rows: &cache.rows,
        selection: &mut selection,
        state: &mut state,
        commands: &mut commands,
        f2,
        row_rects: &mut row_rects,
    }
    .ui(ui);
    widgets.extend(row_rects);
    for command in commands {
        requests.apply(command);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn item(i: u32, parent: Option<u32>, name: &str) -> OutlinerItem {
        OutlinerItem {
            entity: Entity::from_raw_u32(i).unwrap(),
            id: SceneId(i as u64),
            parent: parent.map(|p| Entity::from_raw_u32(p).unwrap()),
            name: name.into(),
            kind: "",
            visible: true,
        }
    }

    fn names(items: &[OutlinerItem], rows: &[OutlinerRow]) -> Vec<(String, usize)> {
        rows.iter()
            .map(|r| (items[r.item].name.clone(), r.depth))
            .collect()
    }

    #[test]
    fn the_cache_goes_stale_exactly_when_what_it_lists_changes() {
        let mut app = App::new();
        app.init_resource::<OutlinerCache>()
            .add_systems(Update, invalidate_outliner);
        fn settle(app: &mut App) -> bool {
            app.update();
            let stale = !app.world().resource::<OutlinerCache>().valid;
            app.world_mut().resource_mut::<OutlinerCache>().valid = true;
            stale
        }
        fn world(app: &mut App) -> &mut World {
            app.world_mut()
        }
        let parent = world(&mut app)
            .spawn((
                treelight_document::values::object::SceneObject,
                Name::new("Parent"),
            ))
            .id();
        let child = world(&mut app)
            .spawn((
                treelight_document::values::object::SceneObject,
                Name::new("Child"),
                ChildOf(parent),
            ))
            .id();
        assert!(settle(&mut app), "objects added");
        assert!(!settle(&mut app), "nothing changed");
        world(&mut app)
            .entity_mut(child)
            .insert(Name::new("Renamed"));
        assert!(settle(&mut app), "a rename");
        world(&mut app).entity_mut(child).insert(Visibility::Hidden);
        assert!(settle(&mut app), "hidden");
        world(&mut app).entity_mut(child).remove::<ChildOf>();
        assert!(settle(&mut app), "moved to the top level");
        assert!(!settle(&mut app), "nothing changed");
        world(&mut app).entity_mut(parent).despawn();
        assert!(settle(&mut app), "an object removed");
        // Entities that are not scene objects (the editor's own) do not count.
        world(&mut app).spawn(Name::new("Camera"));
        assert!(!settle(&mut app), "not a scene object");
    }

    #[test]
    fn rows_nest_fold_and_filter() {
        let items = vec![
            item(1, None, "Helmet"),
            item(2, Some(1), "Visor"),
            item(3, Some(1), "Strap"),
            item(4, Some(3), "Buckle"),
            item(5, None, "Lamp"),
        ];
        let mut state = OutlinerState::default();
        let all = rows(&items, &state);
        assert_eq!(
            names(&items, &all),
            [
                ("Helmet", 0),
                ("Visor", 1),
                ("Strap", 1),
                ("Buckle", 2),
                ("Lamp", 0)
            ]
            .map(|(n, d)| (n.to_string(), d))
        );
        state.collapsed.insert(Entity::from_raw_u32(1).unwrap());
        assert_eq!(rows(&items, &state).len(), 2);
        // A filter lists matches with their parents, unfolded.
        state.filter = "BUCK".into();
        assert_eq!(
            names(&items, &rows(&items, &state)),
            [("Helmet", 0), ("Strap", 1), ("Buckle", 2)].map(|(n, d)| (n.to_string(), d))
        );
    }
}
