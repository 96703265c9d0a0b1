//! Treelight's document core: the edited scene without a window, egui or a renderer. Its layers,
//! each a folder naming only those before it: [`values`] (ids, transforms, materials, lights,
//! shapes, the look), [`files`] (the editor's own files, jobs), [`scene`] (notices and events, the
//! hierarchy, placement, the sky, imported scenes spawned as objects), [`edit`] (commands and
//! their history), [`import`] (files parsed and handed to the history), [`project`] (projects,
//! autosave, recovery, scripts, `info`), then [`app`] and [`default_scene`]. What an editor must
//! answer (select what an edit made, frame an import, restore a project's view) leaves as
//! [`scene::outbox::DocumentEvent`] messages; the core never reaches into whoever shows it.

#![warn(missing_docs)]

pub mod app;
pub mod default_scene;
pub mod edit;
pub mod files;
pub mod import;
pub mod project;
pub mod scene;
pub mod values;

pub use app::DocumentPlugin;
pub use files::file_kind::is_project_file;
