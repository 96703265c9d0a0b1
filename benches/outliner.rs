//! What the outliner costs a frame as the scene grows: flattening the objects into rows
//! (`outliner::rows`) and laying out the panel (egui, only the rows in sight), for scenes of 100 to
//! 10,000 objects in assemblies of 100 parts (all expanded), the panel 600 points tall.
//!
//! Run: `cargo bench -p treelight --bench outliner` (release). Prints a markdown table.

use bevy::prelude::*;
use bevy_egui::egui;
use std::time::{Duration, Instant};
use treelight::editor::core::selection::Selection;
use treelight::editor::panels::outliner::OutlinerItem;
use treelight::editor::panels::outliner::OutlinerPanel;
use treelight::editor::panels::outliner::OutlinerState;
use treelight::editor::panels::outliner::rows;
use treelight_document::edit::command::EditCommand;
use treelight_document::values::object::SceneId;

fn items(world: &mut World, n: usize) -> Vec<OutlinerItem> {
    let mut out = Vec::with_capacity(n);
    let mut root = None;
    for k in 0..n {
        let entity = world.spawn_empty().id();
        // Every 100th object an assembly root, the others its parts.
        let parent = if k % 100 == 0 {
            root = Some(entity);
            None
        } else {
            root
        };
        out.push(OutlinerItem {
            entity,
            id: SceneId(k as u64 + 1),
            parent,
            name: format!("part {k}"),
            kind: "▣",
            visible: true,
        });
    }
    out
}

fn median(mut v: Vec<Duration>) -> f64 {
    v.sort();
    v[v.len() / 2].as_secs_f64() * 1e3
}

fn main() {
    println!("| objects | rows() median (ms) | panel layout median (ms) | rows laid out |");
    println!("|---|---|---|---|");
    for n in [100usize, 1_000, 10_000] {
        let mut world = World::new();
        let items = items(&mut world, n);
        let mut state = OutlinerState::default();
        let mut selection = Selection::default();
        let ctx = egui::Context::default();
        let input = || egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(
                egui::Pos2::ZERO,
                egui::vec2(260.0, 600.0),
            )),
            ..Default::default()
        };
        let (mut flatten, mut layout) = (Vec::new(), Vec::new());
        let mut laid_out = 0;
        for _ in 0..60 {
            let t = Instant::now();
            let rows = rows(&items, &state);
            flatten.push(t.elapsed());
            let mut commands: Vec<EditCommand> = Vec::new();
            let mut rects = Vec::new();
            let t = Instant::now();
            let _ = ctx.run_ui(input(), |ui| {
                OutlinerPanel {
                    items: &items,
                    rows: &rows,
                    selection: &mut selection,
                    state: &mut state,
                    commands: &mut commands,
                    f2: false,
                    row_rects: &mut rects,
                }
                .ui(ui);
            });
            layout.push(t.elapsed());
            laid_out = rects.len();
        }
        println!(
            "| {n} | {:.3} | {:.3} | {laid_out} |",
            median(flatten),
            median(layout)
        );
    }
}
