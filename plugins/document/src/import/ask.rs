//! Imports that would not fit in the memory the machine has free once traced, held until the user
//! says whether to go on: an app that asks ([`ImportQuestions::ask`], the editor) shows the
//! question and answers through [`ImportQuestions::answers`]; one that does not (the headless
//! `--save`) imports them.

use crate::edit::command::TransformValue;
use crate::import::parse::ParsedScene;
use bevy::prelude::*;
use std::path::PathBuf;

/// The variable that stands in for the memory the machine has free, in MiB (to try the question
/// on a machine with plenty).
pub const AVAILABLE_VARIABLE: &str = "TREELIGHT_AVAILABLE_MEMORY_MIB";

/// What the editor holds per triangle once a scene is traced, by its records' sizes at half a
/// vertex a triangle (a mesh of tiles): the tree's inner node, corners, vertices, parent and group
/// (36 + 6 + 6 + 4 + 4 bytes), the shading source (8), the path tracer's node records with their
/// map, triangles with their positions, and shading records with their vertices (38 + 12 + 8 +
/// 12 + 8), and Bevy's mesh (18). A lower bound: the memory bench counts more in these owners at
/// 8M and 12M triangles (their room to grow), and the whole process holds more (the editor itself,
/// the peaks while it fills).
pub const TRACED_BYTES_PER_TRIANGLE: u64 = 160;

/// An import held for an answer.
pub struct HeldImport {
    /// The file.
    pub path: PathBuf,
    /// Bytes it would need once traced, at least.
    pub needed: u64,
    /// Bytes free when it was parsed.
    pub free: u64,
    /// Its triangles.
    pub triangles: u64,
    pub(crate) parsed: ParsedScene,
    pub(crate) transform: Option<TransformValue>,
}

/// Imports waiting for the user's answer, and the answers.
#[derive(Resource, Default)]
pub struct ImportQuestions {
    /// Whether an import past the free memory waits for an answer; otherwise it goes ahead.
    pub ask: bool,
    /// The bytes free to compare with; `None`: what the system says now ([`AVAILABLE_VARIABLE`]
    /// when set).
    pub free_memory: Option<u64>,
    /// The imports waiting, oldest first.
    pub waiting: Vec<HeldImport>,
    /// Answers to apply: the file, and whether to import it.
    pub answers: Vec<(PathBuf, bool)>,
}

impl ImportQuestions {
    /// The bytes free now, as the check sees them.
    pub fn free_now(&self) -> u64 {
        self.free_memory
            .or_else(|| {
                std::env::var(AVAILABLE_VARIABLE)
                    .ok()
                    .and_then(|v| v.trim().parse::<u64>().ok())
                    .map(|mib| mib.saturating_mul(1 << 20))
            })
            .or_else(treelight_import::available_memory)
            .unwrap_or(u64::MAX)
    }

    /// Whether an import of `triangles` must wait for an answer: the app asks, and it needs more
    /// than is free. Returns what it needs and what is free.
    pub fn must_ask(&self, triangles: u64) -> Option<(u64, u64)> {
        let needed = triangles.saturating_mul(TRACED_BYTES_PER_TRIANGLE);
        let free = self.free_now();
        (self.ask && needed > free).then_some((needed, free))
    }
}

/// A size for the question: GiB with one decimal from 1 GiB, else whole MiB.
pub fn size_text(bytes: u64) -> String {
    if bytes >= 1 << 30 {
        format!("{:.1} GiB", bytes as f64 / (1u64 << 30) as f64)
    } else {
        format!("{} MiB", bytes.div_ceil(1 << 20))
    }
}

/// A count with thousands separated by commas.
pub fn count_text(n: u64) -> String {
    let digits = n.to_string();
    let mut out = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            out.push(',');
        }
        out.push(c);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sizes_and_counts_read_as_a_person_writes_them() {
        assert_eq!(size_text(1), "1 MiB");
        assert_eq!(size_text(37 << 20), "37 MiB");
        assert_eq!(size_text(3 << 29), "1.5 GiB");
        assert_eq!(count_text(94_722), "94,722");
        assert_eq!(count_text(12_103_200), "12,103,200");
        assert_eq!(count_text(999), "999");
    }

    #[test]
    fn only_an_app_that_asks_holds_an_import_past_the_free_memory() {
        let mut q = ImportQuestions {
            ask: true,
            free_memory: Some(100 * TRACED_BYTES_PER_TRIANGLE),
            ..Default::default()
        };
        assert_eq!(q.must_ask(100), None);
        assert_eq!(
            q.must_ask(101),
            Some((
                101 * TRACED_BYTES_PER_TRIANGLE,
                100 * TRACED_BYTES_PER_TRIANGLE
            ))
        );
        q.ask = false;
        assert_eq!(q.must_ask(1_000_000), None);
    }
}
