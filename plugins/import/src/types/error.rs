//! What every reader reports a failure with, and the checks every mesh reader makes.

use std::path::{Path, PathBuf};
use thiserror::Error;

/// Most vertices or indices accepted in one file, so a hostile header cannot exhaust memory.
pub const MAX_ELEMENTS: usize = 1 << 28;

/// A file that could not be imported.
#[derive(Debug, Error, PartialEq)]
#[error("{}: {problem}", file.display())]
pub struct ImportError {
    /// The file opened.
    pub file: PathBuf,
    /// What is wrong with it.
    pub problem: String,
}

impl ImportError {
    pub(crate) fn new(file: &Path, problem: impl Into<String>) -> Self {
        Self {
            file: file.to_owned(),
            problem: problem.into(),
        }
    }
}

/// Rejects non-finite positions, naming the mesh.
pub(crate) fn check_positions(
    file: &Path,
    mesh: &str,
    positions: &[[f32; 3]],
) -> Result<(), ImportError> {
    if let Some(i) = positions
        .iter()
        .position(|p| p.iter().any(|c| !c.is_finite()))
    {
        return Err(ImportError::new(
            file,
            format!("mesh '{mesh}' has a NaN or infinite position at vertex {i}"),
        ));
    }
    Ok(())
}

/// Rejects indices past the vertex arrays, naming the mesh.
pub(crate) fn check_indices(
    file: &Path,
    mesh: &str,
    indices: &[u32],
    vertices: usize,
) -> Result<(), ImportError> {
    if let Some(&i) = indices.iter().find(|&&i| i as usize >= vertices) {
        return Err(ImportError::new(
            file,
            format!("mesh '{mesh}' has index {i}, past its {vertices} vertices"),
        ));
    }
    Ok(())
}
