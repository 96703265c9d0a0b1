//! What kind of file a path names, by its name.

/// Whether `path` names a project (`.treelight`) rather than a scene file to import.
pub fn is_project_file(path: &std::path::Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("treelight"))
}
