//! The editor's own files and jobs, above the values: atomic writes, the one opener for its own
//! files, its folders, and jobs contained so a panic ends one job, not the editor.

pub mod atomic_file;
pub mod contain;
pub mod file_kind;
pub mod folders;
pub mod job;
pub mod own_file;
