//! Mesh assets parked while nothing in the main world reads them
//! ([`SceneBvhConfig::park_meshes`](crate::types::config::SceneBvhConfig::park_meshes)): their
//! vertex data compressed beside the asset once the worker has their triangles and no camera
//! rasterises them, and put back before anything reads it again.

use crate::types::parked::ParkedMesh;
use bevy::asset::RenderAssetUsages;
use bevy::prelude::*;
use std::collections::{HashMap, HashSet};
use std::time::Instant;

/// The parked meshes, and the meshes to look at for parking.
#[derive(Default)]
pub(crate) struct Parking {
    enabled: bool,
    parked: HashMap<AssetId<Mesh>, ParkedMesh>,
    /// Meshes that may have become parkable: copied to the worker, or held back from the render
    /// world.
    candidates: HashSet<AssetId<Mesh>>,
    bytes: usize,
}

impl Parking {
    /// Parking on or off.
    pub(crate) fn new(enabled: bool) -> Self {
        Self {
            enabled,
            ..Self::default()
        }
    }

    /// Looks at `mesh` for parking at the end of the frame.
    pub(crate) fn consider(&mut self, mesh: AssetId<Mesh>) {
        if self.enabled && !self.parked.contains_key(&mesh) {
            self.candidates.insert(mesh);
        }
    }

    /// Whether any mesh waits to be looked at.
    pub(crate) fn has_candidates(&self) -> bool {
        !self.candidates.is_empty()
    }

    /// Parks the candidates that only the main world keeps and `in_use` does not name, until
    /// `deadline` (at least one). A candidate in use or drawn by the render world is dropped: it
    /// is looked at again when that ends.
    pub(crate) fn park(
        &mut self,
        meshes: &mut Assets<Mesh>,
        in_use: impl Fn(AssetId<Mesh>) -> bool,
        deadline: Instant,
    ) {
        let ids: Vec<AssetId<Mesh>> = self.candidates.iter().copied().collect();
        for id in ids {
            self.candidates.remove(&id);
            if in_use(id) {
                continue;
            }
            let Some(mesh) = meshes.get_mut_untracked(id) else {
                continue;
            };
            if mesh.asset_usage.contains(RenderAssetUsages::RENDER_WORLD) {
                continue;
            }
            if let Some(p) = ParkedMesh::park(mesh) {
                self.bytes += p.bytes();
                self.parked.insert(id, p);
            }
            if Instant::now() >= deadline {
                break;
            }
        }
    }

    /// Puts `mesh`'s parked data back into its asset, if it is parked. Untracked: the asset's
    /// content is what it was, so nothing takes it for changed.
    pub(crate) fn restore(&mut self, id: AssetId<Mesh>, meshes: &mut Assets<Mesh>) {
        let Some(p) = self.parked.remove(&id) else {
            return;
        };
        self.bytes -= p.bytes();
        if let Some(mesh) = meshes.get_mut_untracked(id)
            && !p.restore(mesh)
        {
            warn!("mesh {id}: its parked vertex data did not decode whole");
        }
    }

    /// Puts every parked mesh back (a camera rasterises them again).
    pub(crate) fn restore_all(&mut self, meshes: &mut Assets<Mesh>) {
        let ids: Vec<AssetId<Mesh>> = self.parked.keys().copied().collect();
        for id in ids {
            self.restore(id, meshes);
        }
    }

    /// The asset `id` was modified: its own data, if it has any now, replaces what was parked;
    /// else (a change that left its geometry alone) the parked data is put back.
    pub(crate) fn modified(&mut self, id: AssetId<Mesh>, meshes: &mut Assets<Mesh>) {
        let has_data = meshes.get(id).is_some_and(|m| {
            m.try_contains_attribute(Mesh::ATTRIBUTE_POSITION)
                .unwrap_or(true)
        });
        if !has_data {
            self.restore(id, meshes);
        } else if let Some(p) = self.parked.remove(&id) {
            self.bytes -= p.bytes();
            if let Some(mesh) = meshes.get_mut_untracked(id) {
                p.forget(mesh);
            }
        }
    }

    /// The asset `id` is gone: so is its parked data.
    pub(crate) fn removed(&mut self, id: AssetId<Mesh>) {
        self.candidates.remove(&id);
        if let Some(p) = self.parked.remove(&id) {
            self.bytes -= p.bytes();
        }
    }

    /// Whether `id` is parked.
    pub(crate) fn is_parked(&self, id: AssetId<Mesh>) -> bool {
        self.parked.contains_key(&id)
    }

    /// Triangles of a parked mesh.
    pub(crate) fn triangles(&self, id: AssetId<Mesh>) -> Option<usize> {
        self.parked.get(&id).map(ParkedMesh::triangles)
    }

    /// How many meshes are parked, and the bytes they hold.
    pub(crate) fn figures(&self) -> (usize, usize) {
        (self.parked.len(), self.bytes)
    }
}
