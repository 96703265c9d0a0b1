//! `--commands EDITS.ron`: a list of edit commands applied after loading, once the scene's BVH is
//! idle, through the same path (and into the same history) as the editor's own edits.

use crate::edit::command::EditCommand;
use crate::edit::history::{EditRequest, apply_request};
use crate::import::parse::PendingImports;
use crate::values::object::SceneIndex;
use bevy::prelude::*;
use std::path::{Path, PathBuf};
use treelight_scene::SceneBvh;

/// The largest script read: far above any list of edits a person or a test writes.
const MAX_SCRIPT_BYTES: u64 = 16 << 20;

/// Why a script cannot be read; each names the file.
#[derive(Debug, thiserror::Error)]
pub enum ScriptError {
    /// The file cannot be read.
    #[error("{0}: {1}")]
    Read(PathBuf, std::io::Error),
    /// The file is too large to be a script.
    #[error(
        "{0}: {1} bytes is too large for a list of commands (at most {MAX_SCRIPT_BYTES}, and its \
         parse within the memory budget)"
    )]
    TooLarge(PathBuf, u64),
    /// The file is not a RON list of commands.
    #[error("{0}: not a list of edit commands: {1}")]
    Parse(PathBuf, Box<ron::error::SpannedError>),
}

/// Memory parsing a script may take for each byte of its text, at most (a list of ids: 8 bytes
/// for each two of text, doubled while the list grows).
const PARSE_BYTES_PER_BYTE: u64 = 12;

/// Reads a RON list of [`EditCommand`]s: a regular file (a pipe or device is refused at once), no
/// larger than a script can be nor than its parse fits in the import's memory budget.
pub fn read_commands(path: &Path) -> Result<Vec<EditCommand>, ScriptError> {
    let (_, len) = crate::files::own_file::open_regular(path)
        .map_err(|e| ScriptError::Read(path.into(), e))?;
    if len > MAX_SCRIPT_BYTES
        || len.saturating_mul(PARSE_BYTES_PER_BYTE) > treelight_import::default_memory_budget()
    {
        return Err(ScriptError::TooLarge(path.into(), len));
    }
    let text = crate::files::own_file::read_text_bounded(path, len.max(1))
        .map_err(|e| ScriptError::Read(path.into(), e))?;
    ron::from_str(&text).map_err(|e| ScriptError::Parse(path.into(), Box::new(e)))
}

/// Commands waiting for the scene to settle.
#[derive(Resource, Debug)]
pub struct ScriptedEdits {
    /// Where they came from.
    pub path: PathBuf,
    /// The commands; taken when applied.
    pub commands: Option<Vec<EditCommand>>,
    /// Frames in a row the scene has been settled.
    settled: u32,
    /// Why the commands were not applied, when they could not be.
    pub failed: Option<String>,
}

impl ScriptedEdits {
    /// Commands from `path`, to apply once the scene settles.
    pub fn new(path: PathBuf, commands: Vec<EditCommand>) -> Self {
        Self {
            path,
            commands: Some(commands),
            settled: 0,
            failed: None,
        }
    }
}

/// Frames the scene must stay settled (no import, BVH idle) before the script runs.
const SETTLED_FRAMES: u32 = 3;

/// Applies the script once nothing is loading and the BVH is idle; reports what it did.
pub fn run_scripted_edits(world: &mut World) {
    let loading = !world.resource::<PendingImports>().0.is_empty()
        || !world
            .resource::<crate::import::parse::ParsedImports>()
            .0
            .is_empty()
        || world
            .resource::<crate::project::open::OpeningProjects>()
            .busy();
    let idle = world.resource::<SceneBvh>().is_idle();
    let failure = world.resource::<SceneBvh>().worker_failure();
    let mut script = world.resource_mut::<ScriptedEdits>();
    if script.commands.is_none() {
        return;
    }
    if let Some(why) = failure {
        // The tree will never settle: the script is not applied, and says so.
        let path = script.path.clone();
        script.commands = None;
        script.failed = Some(format!(
            "{}: not applied: the scene BVH worker crashed ({why})",
            path.display()
        ));
        error!("{}", script.failed.as_deref().unwrap_or_default());
        return;
    }
    script.settled = if idle && !loading {
        script.settled + 1
    } else {
        0
    };
    if script.settled < SETTLED_FRAMES {
        return;
    }
    let path = script.path.clone();
    let commands = script.commands.take().unwrap_or_default();
    let total = commands.len();
    let mut applied = 0;
    for (i, command) in commands.into_iter().enumerate() {
        let request = EditRequest::Apply {
            command,
            continuing: false,
        };
        match apply_request(world, request) {
            Ok(()) => applied += 1,
            Err(e) => error!("{}: command {}: {e}", path.display(), i + 1),
        }
    }
    let objects = world.resource::<SceneIndex>().len();
    info!(
        "{}: applied {applied} of {total} commands; the scene has {objects} objects",
        path.display()
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::values::object::SceneId;

    #[test]
    fn the_readme_example_parses() {
        let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../docs/edits-example.ron");
        let commands = read_commands(&path).unwrap();
        assert_eq!(commands.len(), 5);
        assert!(matches!(
            &commands[2],
            EditCommand::Rename { id: SceneId(8), name } if name == "Golden sphere"
        ));
    }

    #[test]
    fn bad_scripts_name_the_file_and_the_problem() {
        let dir = std::env::temp_dir().join(format!("treelight-script-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let bad = dir.join("bad.ron");
        std::fs::write(&bad, "[Delete(ids: [(1)]), Explode(id: (2))]").unwrap();
        let e = read_commands(&bad).unwrap_err().to_string();
        assert!(e.contains("bad.ron") && e.contains("Explode"), "{e}");
        let missing = dir.join("missing.ron");
        let e = read_commands(&missing).unwrap_err().to_string();
        assert!(e.contains("missing.ron"), "{e}");
        let e = read_commands(&dir).unwrap_err().to_string();
        assert!(e.contains("not a regular file"), "{e}");
        std::fs::remove_dir_all(&dir).ok();
    }
}
