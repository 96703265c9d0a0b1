//! The dock's layout: which panels there are and where they stand, kept between frames (and, by
//! the settings, between runs) so the user's rearrangements persist.

use bevy::prelude::*;
use egui_dock::{DockState, NodeIndex};

/// The panels that can be docked.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
pub enum EditorTab {
    /// The 3D view.
    Viewport,
    /// The list of scene entities.
    Outliner,
    /// The selected entity's properties.
    Inspector,
    /// The edit history: every step, and a click goes back or forward to it.
    History,
    /// The built-in shapes, to drag onto the viewport.
    Assets,
}

impl EditorTab {
    /// Every panel.
    pub const ALL: [EditorTab; 5] = [
        EditorTab::Viewport,
        EditorTab::Outliner,
        EditorTab::Inspector,
        EditorTab::History,
        EditorTab::Assets,
    ];

    /// The panel's title on its tab.
    pub fn title(self) -> &'static str {
        match self {
            EditorTab::Viewport => "Viewport",
            EditorTab::Outliner => "Outliner",
            EditorTab::Inspector => "Inspector",
            EditorTab::History => "History",
            EditorTab::Assets => "Assets",
        }
    }
}

/// The dock layout.
#[derive(Resource)]
pub struct EditorDock(pub DockState<EditorTab>);

impl Default for EditorDock {
    fn default() -> Self {
        let mut state = DockState::new(vec![EditorTab::Viewport]);
        let tree = state.main_surface_mut();
        let [viewport, outliner] =
            tree.split_left(NodeIndex::root(), 0.2, vec![EditorTab::Outliner]);
        let [_, inspector] = tree.split_right(viewport, 0.75, vec![EditorTab::Inspector]);
        tree.split_below(inspector, 0.6, vec![EditorTab::History]);
        tree.split_below(outliner, 0.7, vec![EditorTab::Assets]);
        Self(state)
    }
}

/// The arrangement of one part of the dock, as read from a settings file.
enum Shape {
    /// Tabs side by side, and the one shown.
    Leaf(Vec<EditorTab>, usize),
    /// Two parts, left and right (`horizontal`) or top and bottom, the first taking `fraction`.
    Split {
        horizontal: bool,
        fraction: f32,
        parts: Box<[Shape; 2]>,
    },
}

/// How deep a layout may nest: five panels need at most four splits.
const MAX_LAYOUT_DEPTH: usize = 8;

impl Shape {
    /// The part at `at` of `tree`, checked: every split has both parts, fractions are within
    /// 0..=1, leaves hold tabs, nothing nests deeper than [`MAX_LAYOUT_DEPTH`].
    fn read(tree: &egui_dock::Tree<EditorTab>, at: usize, depth: usize) -> Result<Self, String> {
        use egui_dock::Node;
        if depth > MAX_LAYOUT_DEPTH {
            return Err("the layout nests deeper than five panels can".into());
        }
        if at >= tree.len() {
            return Err("a split of the layout lacks a part".into());
        }
        let split = |s: &egui_dock::SplitNode, horizontal: bool| {
            if !(0.0..=1.0).contains(&s.fraction) {
                return Err(format!(
                    "a split's fraction {} is not within 0 to 1",
                    s.fraction
                ));
            }
            Ok(Shape::Split {
                horizontal,
                fraction: s.fraction,
                parts: Box::new([
                    Self::read(tree, 2 * at + 1, depth + 1)?,
                    Self::read(tree, 2 * at + 2, depth + 1)?,
                ]),
            })
        };
        match &tree[NodeIndex(at)] {
            Node::Empty => Err("a part of the layout is empty".into()),
            Node::Leaf(leaf) if leaf.tabs.is_empty() => Err("a panel group has no tabs".into()),
            Node::Leaf(leaf) => Ok(Shape::Leaf(
                leaf.tabs.clone(),
                leaf.active.0.min(leaf.tabs.len() - 1),
            )),
            Node::Horizontal(s) => split(s, true),
            Node::Vertical(s) => split(s, false),
        }
    }

    /// A tab of this part (the first leaf's first), to hold its place while it is built.
    fn first_tab(&self) -> EditorTab {
        match self {
            Shape::Leaf(tabs, _) => tabs[0],
            Shape::Split { parts, .. } => parts[0].first_tab(),
        }
    }

    /// Builds this part at `at` of `tree` (a leaf there now) through egui_dock's own splits,
    /// which keep its invariants.
    fn build(&self, tree: &mut egui_dock::Tree<EditorTab>, at: NodeIndex) {
        match self {
            Shape::Leaf(tabs, active) => {
                let mut leaf = egui_dock::LeafNode::new(tabs.clone());
                leaf.active = egui_dock::TabIndex(*active);
                tree[at] = egui_dock::Node::Leaf(leaf);
            }
            Shape::Split {
                horizontal,
                fraction,
                parts,
            } => {
                let way = if *horizontal {
                    egui_dock::Split::Right
                } else {
                    egui_dock::Split::Below
                };
                let holder = egui_dock::Node::leaf_with(vec![parts[1].first_tab()]);
                let [first, second] = tree.split(at, way, *fraction, holder);
                parts[0].build(tree, first);
                parts[1].build(tree, second);
            }
        }
    }
}

/// A dock layout read from a settings file, made again through egui_dock's own operations so
/// that nothing a file holds can break its invariants (egui_dock indexes and asserts on them
/// while drawing: a bad layout would stop the editor at every start). The main surface is kept;
/// panels in floating windows return to the first panel group. Errors name what is wrong.
pub fn rebuild_layout(file: &DockState<EditorTab>) -> Result<DockState<EditorTab>, String> {
    use egui_dock::Surface;
    let main = match file.iter_surfaces().next() {
        Some(Surface::Main(tree)) => tree,
        _ => return Err("the layout has no main panel area".into()),
    };
    let shape = Shape::read(main, 0, 0)?;
    let mut state = DockState::new(vec![shape.first_tab()]);
    shape.build(state.main_surface_mut(), NodeIndex::root());
    let mut seen = Vec::new();
    for (_, tab) in state.iter_all_tabs() {
        if seen.contains(tab) {
            return Err(format!("the layout holds the {tab:?} panel more than once"));
        }
        seen.push(*tab);
    }
    for tab in EditorTab::ALL {
        if !seen.contains(&tab) {
            state.push_to_first_leaf(tab);
        }
    }
    Ok(state)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tabs_of(state: &DockState<EditorTab>) -> Vec<EditorTab> {
        state.iter_all_tabs().map(|(_, t)| *t).collect()
    }

    #[test]
    fn the_default_layout_is_rebuilt_as_it_was() {
        let default = EditorDock::default().0;
        let rebuilt = rebuild_layout(&default).unwrap();
        assert_eq!(tabs_of(&rebuilt), tabs_of(&default));
        // Node by node (the trailing empty slots are the vector's growth, not the layout).
        let fractions = |s: &DockState<EditorTab>| -> Vec<String> {
            let mut nodes: Vec<String> = s
                .main_surface()
                .iter()
                .map(|n| match n {
                    egui_dock::Node::Horizontal(x) => format!("h{}", x.fraction),
                    egui_dock::Node::Vertical(x) => format!("v{}", x.fraction),
                    egui_dock::Node::Leaf(l) => format!("{:?}", l.tabs),
                    egui_dock::Node::Empty => "-".into(),
                })
                .collect();
            while nodes.last().is_some_and(|n| n == "-") {
                nodes.pop();
            }
            nodes
        };
        assert_eq!(fractions(&rebuilt), fractions(&default));
    }

    #[test]
    fn broken_layouts_are_refused_with_the_reason() {
        for (ron, why) in [
            ("(surfaces: [], focused_surface: None)", "main"),
            (
                "(surfaces: [Main((nodes: [Horizontal((fraction: 0.5))]))], focused_surface: None)",
                "lacks a part",
            ),
            (
                "(surfaces: [Main((nodes: [Horizontal((fraction: 7.0)), Leaf((tabs: [Viewport])), \
                 Leaf((tabs: [Outliner]))]))], focused_surface: None)",
                "fraction",
            ),
            (
                "(surfaces: [Main((nodes: [Leaf((tabs: []))]))], focused_surface: None)",
                "no tabs",
            ),
            (
                "(surfaces: [Main((nodes: [Empty]))], focused_surface: None)",
                "empty",
            ),
            (
                "(surfaces: [Window((nodes: [Leaf((tabs: [Viewport]))]), ())], focused_surface: None)",
                "main",
            ),
        ] {
            let state: DockState<EditorTab> =
                ron::from_str(ron).unwrap_or_else(|e| panic!("{ron}: {e}"));
            let e = rebuild_layout(&state).err().unwrap_or_default();
            assert!(e.contains(why), "{ron}: {e}");
        }
        // A leaf's shown tab past its tabs is brought into range, not refused.
        let ron = "(surfaces: [Main((nodes: [Leaf((tabs: [Viewport], active: (9)))]))], \
                   focused_surface: Some((5)))";
        let state: DockState<EditorTab> = ron::from_str(ron).unwrap();
        assert_eq!(
            tabs_of(&rebuild_layout(&state).unwrap()).len(),
            EditorTab::ALL.len()
        );
    }
}
