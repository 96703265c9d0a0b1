//! Planning a project's opening before the scene changes: the id each read source's objects get
//! (their runs' and the listed objects'), and the check that the objects and the sources'
//! hierarchies together form a forest (a listed node moved under one of its own descendants in
//! the file closes a ring only the file shows).

use crate::project::format::{ObjectKind, ProjectFile, check_forest, keys_hash};
use crate::scene::spawn::{SourceTree, source_tree};
use crate::values::object::SceneId;
use std::collections::{HashMap, HashSet};
use treelight_import::ImportedScene;

/// What opening gives one read source's objects.
pub(crate) struct SourcePlan<'a> {
    /// The objects the source spawns, in key order, and their parents.
    pub tree: SourceTree<'a>,
    /// Each object's id in key order; [`SceneId::NEW`] where it gets a fresh one.
    pub ids: Vec<SceneId>,
    /// Key indices by key, for the sources the project names keys of.
    index: HashMap<std::borrow::Cow<'a, str>, usize>,
}

impl SourcePlan<'_> {
    /// The index of the object with `key`, if the source has one.
    pub fn index_of(&self, key: &str) -> Option<usize> {
        if key.is_empty() {
            Some(0)
        } else {
            self.index.get(key).copied()
        }
    }
}

/// The plan for all of a project's sources.
pub(crate) struct OpenPlan<'a> {
    /// By source; `None` for a source that was not read.
    pub sources: Vec<Option<SourcePlan<'a>>>,
    /// Sources whose keys changed since the save: their runs were not used.
    pub changed: Vec<usize>,
}

impl OpenPlan<'_> {
    /// The key index of `key` in source `source`, if it was read and has it.
    pub fn index_of(&self, source: usize, key: &str) -> Option<usize> {
        self.sources.get(source)?.as_ref()?.index_of(key)
    }
}

/// Plans the opening of `project` over its parsed sources, and checks the hierarchy it makes.
pub(crate) fn plan<'a>(
    project: &ProjectFile,
    parsed: &'a [Option<std::sync::Arc<ImportedScene>>],
) -> Result<OpenPlan<'a>, String> {
    // Sources whose keys the project names past the root: they need the index.
    let mut named: HashSet<usize> = HashSet::new();
    for o in &project.objects {
        if let ObjectKind::Node(n) | ObjectKind::MeshOf(n) = &o.kind
            && !n.key.is_empty()
        {
            named.insert(n.source);
        }
    }
    named.extend(project.deleted.iter().map(|d| d.source));
    let mut sources: Vec<Option<SourcePlan>> = parsed
        .iter()
        .enumerate()
        .map(|(s, scene)| {
            let tree = source_tree(scene.as_ref()?);
            let index = if named.contains(&s) {
                // The nodes' keys are borrowed from the scene; only a mesh's own key is copied.
                tree.keys
                    .iter()
                    .enumerate()
                    .map(|(i, k)| (k.clone(), i))
                    .collect()
            } else {
                HashMap::new()
            };
            Some(SourcePlan {
                ids: vec![SceneId::NEW; tree.keys.len()],
                tree,
                index,
            })
        })
        .collect();
    let mut changed = Vec::new();
    for s in &project.source_ids {
        let Some(Some(plan)) = sources.get_mut(s.source) else {
            continue;
        };
        if keys_hash(plan.tree.keys.iter().map(|k| k.as_ref())) != s.keys {
            changed.push(s.source);
            continue;
        }
        for run in &s.runs {
            let (start, first, count) = run.parts();
            for k in 0..count as usize {
                if let Some(slot) = plan.ids.get_mut(start + k) {
                    *slot = SceneId(first + k as u64);
                }
            }
        }
    }
    for o in &project.objects {
        if let ObjectKind::Node(n) = &o.kind
            && let Some(Some(plan)) = sources.get_mut(n.source)
            && let Some(i) = plan.index_of(&n.key)
        {
            plan.ids[i] = o.id;
        }
    }
    let plan = OpenPlan { sources, changed };
    check_hierarchy(project, &plan)?;
    Ok(plan)
}

/// Refuses objects and source hierarchies that together are not a forest: a parent that is the
/// object itself or that nothing holds, or a ring. Walks up from each listed object only: the
/// sources' own hierarchies are forests, so a ring passes through a listed object.
fn check_hierarchy(project: &ProjectFile, plan: &OpenPlan) -> Result<(), String> {
    let listed: HashMap<SceneId, Option<SceneId>> =
        project.objects.iter().map(|o| (o.id, o.parent)).collect();
    // (first id, count, source, first key index), by first id.
    let mut runs: Vec<(u64, u64, usize, usize)> = project
        .source_ids
        .iter()
        .flat_map(|s| {
            s.runs.iter().map(|r| {
                let (start, first, count) = r.parts();
                (first, count, s.source, start)
            })
        })
        .collect();
    runs.sort_unstable();
    let run_of = |id: SceneId| {
        let k = runs.partition_point(|r| r.0 <= id.0).checked_sub(1)?;
        let (first, count, source, start) = runs[k];
        (id.0 < first + count).then(|| (source, start + (id.0 - first) as usize))
    };
    let exists = |id: SceneId| listed.contains_key(&id) || run_of(id).is_some();
    let parent_of = |id: SceneId| -> Option<SceneId> {
        if let Some(p) = listed.get(&id) {
            return *p;
        }
        let (source, i) = run_of(id)?;
        let plan = plan.sources.get(source)?.as_ref()?;
        let p = (*plan.tree.parents.get(i)?)? as usize;
        Some(plan.ids[p]).filter(|p| *p != SceneId::NEW)
    };
    let listed_ids: Vec<SceneId> = project.objects.iter().map(|o| o.id).collect();
    check_forest(&listed_ids, parent_of, exists)
}
