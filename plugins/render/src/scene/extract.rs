//! Main world to render world: the scene's change set becomes record writes, materials and lights are
//! compared with what was sent before. Runs on the main thread during extraction, so it never waits:
//! when the scene worker holds the tree, this frame uploads nothing and the next one catches up.

use crate::scene::gpu_scene::StreamTarget;
use crate::scene::pending::PendingUpload;
use crate::scene::staging::UploadRound;
use crate::scene::texture_layers::TextureLayers;
use crate::types::emitters::{EmitterList, placed_triangles};
use crate::types::map_transforms::MapUvTransforms;
use crate::types::records::{
    LayerTexture, SceneLight, SurfaceAlpha, SurfaceMaterial, light_bytes, object_bytes,
    outline_words, same_drawing, set_outline, with_identity,
};
use crate::types::upload::{BufferKind, Layouts, UploadPlan, Writes, runs};
use crate::types::vertex_pool::ShadingPool;
use crate::types::view::Outlined;
use bevy::camera::primitives::Aabb;
use bevy::camera::visibility::InheritedVisibility;
use bevy::light::{DirectionalLight, PointLight, SpotLight};
use bevy::math::Mat3;
use bevy::mesh::UvChannel;
use bevy::pbr::{MeshMaterial3d, StandardMaterial};
use bevy::prelude::*;
use bevy::render::{Extract, ExtractSchedule};
use treelight_bvh::{GroupId, PositionPool, WideRecords};
use treelight_scene::{SceneBvh, SceneChanges, SceneTree};

pub(crate) fn build(render_app: &mut SubApp) {
    render_app
        .init_resource::<SceneSync>()
        .init_resource::<PendingUpload>()
        .add_systems(ExtractSchedule, extract_scene);
}

/// The render world's memory of what it has sent, so only differences are uploaded.
#[derive(Resource, Default)]
pub(crate) struct SceneSync {
    /// Whether the first, complete change set has been taken.
    synced: bool,
    /// Object records as last written, by group slot.
    objects: Vec<Option<Vec<u8>>>,
    lights: Option<Vec<u8>>,
    /// The sets of per-map UV transforms the object records name.
    map_transforms: crate::types::map_transforms::MapTransformTable,
    /// The outline words as last sent.
    outlines: Vec<u32>,
    /// The slots the views know re-laid groups by.
    identities: crate::types::identity::SlotIdentities,
    /// The shading vertices' pool: a run per mesh, and the run each group's records name.
    pool: ShadingPool,
    /// The emissive triangles, by group.
    emitters: EmitterList,
    /// Whether the emitters' records changed since the lights buffer was last written.
    emitters_changed: bool,
    /// Which inner nodes own a node record, and where: kept in step with the tree's change sets.
    records: WideRecords,
    /// Where each group's positions lie in the position pool: kept in step the same way.
    positions: PositionPool,
}

/// The meshes to outline, with what their world-space boxes are made from.
type OutlinedQuery<'w, 's> = Query<
    'w,
    's,
    (
        Entity,
        &'static Outlined,
        Option<&'static Aabb>,
        Option<&'static GlobalTransform>,
    ),
>;

type MaterialQuery<'w, 's> = Query<'w, 's, &'static MeshMaterial3d<StandardMaterial>>;

/// Main-world assets a material is read from.
#[derive(Clone, Copy)]
struct MaterialAssets<'a> {
    materials: Option<&'a Assets<StandardMaterial>>,
    images: Option<&'a Assets<Image>>,
    map_transforms: Option<&'a MapUvTransforms>,
}

fn material_of(
    e: Entity,
    handles: &MaterialQuery,
    assets: MaterialAssets,
    layers: &mut TextureLayers,
) -> SurfaceMaterial {
    let Some((id, m)) = handles
        .get(e)
        .ok()
        .and_then(|h| Some((h.0.id(), assets.materials?.get(&h.0)?)))
    else {
        return SurfaceMaterial::default();
    };
    let c = m.base_color.to_linear();
    let mut layer = |h: &Option<Handle<Image>>, channel: &UvChannel| match (h, assets.images) {
        (Some(h), Some(images)) => layers.layer_for(h.id(), images).map(|t| LayerTexture {
            second_uv_set: *channel == UvChannel::Uv1,
            ..t
        }),
        _ => None,
    };
    let tint = m.specular_tint.to_linear();
    SurfaceMaterial {
        base_color: [c.red, c.green, c.blue, c.alpha],
        emissive: [m.emissive.red, m.emissive.green, m.emissive.blue],
        metallic: m.metallic,
        perceptual_roughness: m.perceptual_roughness,
        reflectance: m.reflectance,
        specular_tint: [tint.red, tint.green, tint.blue],
        transmission: m.specular_transmission,
        clearcoat: m.clearcoat,
        clearcoat_roughness: m.clearcoat_perceptual_roughness,
        alpha: match m.alpha_mode {
            AlphaMode::Opaque => SurfaceAlpha::Opaque,
            AlphaMode::Mask(cutoff) => SurfaceAlpha::Mask(cutoff),
            AlphaMode::AlphaToCoverage => SurfaceAlpha::Mask(0.5),
            AlphaMode::Blend | AlphaMode::Premultiplied | AlphaMode::Add | AlphaMode::Multiply => {
                SurfaceAlpha::Blend
            }
        },
        base_color_texture: layer(&m.base_color_texture, &m.base_color_channel),
        metallic_roughness_texture: layer(
            &m.metallic_roughness_texture,
            &m.metallic_roughness_channel,
        ),
        normal_texture: layer(&m.normal_map_texture, &m.normal_map_channel),
        normal_y: if m.flip_normal_map_y { -1.0 } else { 1.0 },
        occlusion_texture: layer(&m.occlusion_texture, &m.occlusion_channel),
        emissive_texture: layer(&m.emissive_texture, &m.emissive_channel),
        uv_transform: m.uv_transform,
        map_uv_transforms: assets.map_transforms.and_then(|t| t.0.get(&id).copied()),
    }
}

#[allow(clippy::too_many_arguments)]
fn extract_scene(
    mut sync: ResMut<SceneSync>,
    mut pending: ResMut<PendingUpload>,
    mut target: StreamTarget,
    mut layers: ResMut<TextureLayers>,
    scene: Extract<Option<Res<SceneBvh>>>,
    round: Extract<Option<Res<UploadRound>>>,
    handles: Extract<MaterialQuery>,
    materials: Extract<Option<Res<Assets<StandardMaterial>>>>,
    images: Extract<Option<Res<Assets<Image>>>>,
    map_transforms: Extract<Option<Res<MapUvTransforms>>>,
    outlined: Extract<OutlinedQuery>,
    points: Extract<Query<(&PointLight, &GlobalTransform, Option<&InheritedVisibility>)>>,
    spots: Extract<Query<(&SpotLight, &GlobalTransform, Option<&InheritedVisibility>)>>,
    suns: Extract<
        Query<(
            &DirectionalLight,
            &GlobalTransform,
            Option<&InheritedVisibility>,
        )>,
    >,
) {
    let sync = &mut *sync;
    let pending = &mut *pending;
    let Some(scene) = scene.as_deref() else {
        return;
    };
    let everything = !sync.synced;
    if everything {
        sync.records = WideRecords::default();
        sync.positions = PositionPool::default();
        sync.pool = ShadingPool::default();
    }
    pending.filling = scene.is_filling();
    let assets = MaterialAssets {
        materials: materials.as_deref(),
        images: images.as_deref(),
        map_transforms: map_transforms.as_deref(),
    };
    let incoming = scene.incoming_triangles() as u64;
    let taken = scene.try_take_changes(everything, |tree, changes| {
        // Each new triangle brings a record of its own, its shading's and about one inner node.
        let triangles = u64::from(tree.bvh.triangle_count()) + incoming;
        pending.expect(BufferKind::Triangles, triangles);
        pending.expect(BufferKind::Attributes, triangles);
        // Positions: as many a new triangle as the pool holds a triangle now (one before there
        // is a pool to go by).
        let positions = match tree.bvh.triangle_count() {
            0..1024 => 1.0,
            n => sync.positions.live_records() as f64 / f64::from(n),
        };
        pending.expect(
            BufferKind::Positions,
            u64::from(sync.positions.end()) + (incoming as f64 * positions.min(3.0)) as u64,
        );
        // Shading vertices: as many a new triangle as the pool holds a triangle now (one before
        // there is a pool to go by).
        let per_triangle = match tree.bvh.triangle_count() {
            0..1024 => 1.0,
            n => sync.pool.live_records() as f64 / f64::from(n),
        };
        pending.expect(
            BufferKind::ShadingVertices,
            u64::from(sync.pool.end()) + (incoming as f64 * per_triangle.min(3.0)) as u64,
        );
        // Node records: as many a new triangle as the tree has now (at most one an inner node,
        // half of them once laid out afresh).
        let per_inner = match tree.bvh.inner_count() {
            0..1024 => 0.5,
            n => f64::from(sync.records.live()) / f64::from(n),
        };
        pending.expect(
            BufferKind::Nodes,
            u64::from(sync.records.capacity()) + (incoming as f64 * per_inner.min(1.0)) as u64,
        );
        let frame = FrameUpload {
            tree,
            changes,
            handles: &handles,
            assets,
            round: round.as_deref().copied().unwrap_or_default().0,
        };
        scene_writes(sync, pending, &mut target, frame, &mut layers);
        changes.version
    });
    if let Some(version) = taken {
        sync.synced = true;
        pending.version = Some(version);
    }
    // The outlined meshes' group slots (when the worker holds the tree, the next frame looks).
    if let Some(tree) = scene.try_read() {
        let slots = tree.bvh.group_slots();
        let mut words = vec![0u32; outline_words(slots as usize)];
        for (e, o, ..) in &outlined {
            for g in tree.groups_of(e) {
                set_outline(&mut words, sync.identities.of(g.index()), o.shader_value());
            }
        }
        if words != sync.outlines {
            let covered = if words.iter().any(|&w| w != 0) {
                slots
            } else {
                0
            };
            pending.outlines = Some((words.clone(), covered));
            sync.outlines = words;
        }
    }
    pending.outline_bounds = outlined_bounds(&outlined);
    let mut lights: Vec<SceneLight> = Vec::new();
    for (l, gt, vis) in &points {
        if vis.is_none_or(|v| v.get()) {
            let c = l.color.to_linear();
            lights.push(SceneLight::Point {
                position: gt.translation(),
                power: Vec3::new(c.red, c.green, c.blue) * l.intensity,
                radius: l.radius,
                range: Some(l.range),
            });
        }
    }
    for (l, gt, vis) in &spots {
        if vis.is_none_or(|v| v.get()) {
            let c = l.color.to_linear();
            lights.push(SceneLight::Spot {
                position: gt.translation(),
                direction: gt.forward().into(),
                power: Vec3::new(c.red, c.green, c.blue) * l.intensity,
                radius: l.radius,
                range: Some(l.range),
                inner_angle: l.inner_angle,
                outer_angle: l.outer_angle,
            });
        }
    }
    for (l, gt, vis) in &suns {
        if vis.is_none_or(|v| v.get()) {
            let c = l.color.to_linear();
            lights.push(SceneLight::Directional {
                direction: gt.forward().into(),
                illuminance: Vec3::new(c.red, c.green, c.blue) * l.illuminance,
            });
        }
    }
    sync.write_lights(&lights, pending);
}

impl SceneSync {
    /// The lights buffer's writes for this frame's punctual `lights` and the emitters' list as
    /// the last pass left it: the lights' records first, then the emitters' table and triangles.
    /// Only what changed is written, except that a change in the lights' number moves (and
    /// rewrites) every emitter record.
    fn write_lights(&mut self, lights: &[SceneLight], p: &mut PendingUpload) {
        let bytes: Vec<u8> = lights.iter().flat_map(light_bytes).collect();
        let lights_changed = self.lights.as_ref() != Some(&bytes);
        if !lights_changed && !self.emitters_changed {
            return;
        }
        let moved = self.lights.as_ref().map(Vec::len) != Some(bytes.len());
        let emitters = &mut self.emitters;
        let writes = emitters.take_writes(moved);
        p.need(
            BufferKind::Lights,
            lights.len() as u64 + u64::from(emitters.record_count()),
        );
        p.light_count = Some(lights.len() as u32);
        p.emitters = Some((emitters.group_count(), emitters.total()));
        p.geometry_changed = true;
        if lights_changed && !bytes.is_empty() {
            p.writes.push(BufferKind::Lights, 0, &bytes);
        }
        for (at, records) in writes {
            p.writes
                .push(BufferKind::Lights, bytes.len() as u64 + at, &records);
        }
        self.lights = Some(bytes);
        self.emitters_changed = false;
    }
}

/// The union of the outlined meshes' world-space boxes; `None` when one has no box or transform.
fn outlined_bounds(outlined: &OutlinedQuery) -> Option<[Vec3; 2]> {
    let mut out = [Vec3::INFINITY, Vec3::NEG_INFINITY];
    for (_, _, aabb, gt) in outlined {
        let (aabb, affine) = (aabb?, gt?.affine());
        // The transformed box's bounds: its centre moved, its half extents through |M|.
        let centre = Vec3::from(affine.transform_point3a(aabb.center));
        let half = Vec3::from(affine.matrix3.abs() * aabb.half_extents);
        out = [out[0].min(centre - half), out[1].max(centre + half)];
    }
    out[0].is_finite().then_some(out)
}

/// What one frame's scene writes are made from: the tree and its changes under the worker's lock,
/// and the main world's materials.
struct FrameUpload<'a, 'w, 's> {
    tree: &'a SceneTree,
    changes: &'a SceneChanges,
    handles: &'a MaterialQuery<'w, 's>,
    assets: MaterialAssets<'a>,
    /// Bytes of writes handed over at a time ([`UploadRound`]).
    round: u64,
}

/// The writes for one change set, plus every object record whose transform or material changed.
/// Each round's worth goes to `target` as it is made ([`StreamTarget::flush`]), the buffers grown
/// first to what the change set needs; what is left is in `p`'s writes.
fn scene_writes(
    sync: &mut SceneSync,
    p: &mut PendingUpload,
    target: &mut StreamTarget,
    frame: FrameUpload,
    layers: &mut TextureLayers,
) {
    let FrameUpload {
        tree,
        changes,
        handles,
        assets,
        round,
    } = frame;
    let bvh = &tree.bvh;
    let c = &changes.bvh;
    let moved = sync.records.update(bvh, c);
    let pooled = sync.positions.update(bvh, c);
    target
        .set_record_layout_bytes((sync.records.heap_bytes() + sync.positions.heap_bytes()) as u64);
    p.need(BufferKind::Nodes, u64::from(sync.records.capacity()));
    p.need(BufferKind::Triangles, c.triangle_capacity as u64);
    p.need(BufferKind::Positions, u64::from(sync.positions.end()));
    p.need(BufferKind::Instances, c.instance_capacity as u64);
    p.need(BufferKind::Attributes, c.triangle_capacity as u64);
    p.need(BufferKind::Objects, bvh.group_slots() as u64);
    let (needed, expected) = (p.needed, p.expected);
    let mut flush = |w: &mut Writes| target.flush(w, &needed, &expected);
    // Capacities are settled by the render world when it applies the writes.
    let plan = UploadPlan::streamed(
        bvh,
        Layouts {
            records: (&sync.records, &moved),
            positions: (&sync.positions, &pooled),
        },
        c,
        [u64::MAX; 4],
        std::mem::take(&mut p.writes),
        round,
        &mut flush,
    );
    p.writes = plan.writes;
    p.root = Some(plan.root);
    let restart = c.geometry_changed() || !changes.fresh_groups.is_empty();
    p.geometry_changed |= restart;
    // The views restart, or keep what they traced and know each re-laid group as the one it
    // replaced.
    if restart {
        sync.identities.restart();
    } else {
        for &(new, old) in &changes.relaid_groups {
            sync.identities.relaid(new.index(), old.index());
        }
    }

    // Object records: compared with what was sent, so a material edit or a move uploads one record.
    // A re-laid group's record is compared with the one of the group it replaced: the same one
    // in a new slot changes no pixel.
    sync.objects.resize(bvh.group_slots() as usize, None);
    let replaced: std::collections::HashMap<GroupId, GroupId> =
        changes.relaid_groups.iter().copied().collect();
    let mut relay: Vec<GroupId> = changes.fresh_groups.clone();
    relay.extend(changes.relaid_groups.iter().map(|r| r.0));
    layers.begin_pass();
    sync.emitters.begin_pass();
    sync.pool.begin_pass(bvh.group_slots());
    let sets = sync.map_transforms.len();
    let relaid: std::collections::HashSet<GroupId> = relay.iter().copied().collect();
    for (&g, &e) in &tree.group_entity {
        let Ok(transform) = bvh.group_transform(g) else {
            continue;
        };
        let material = material_of(e, handles, assets, layers);
        sync.emitters.group(
            g.index(),
            transform,
            Vec3::from(material.emissive),
            relaid.contains(&g),
            || placed_triangles(bvh, g),
        );
        // Its shading vertices hold its second UV set where its material reads it. New vertices,
        // or a material that began or stopped reading the second set: the group's records again.
        let shading = tree.shading.get(&g).map(|s| &**s);
        if sync
            .pool
            .group(g.index(), shading, material.reads_second_uv_set())
        {
            relay.push(g);
        }
        let rec = with_identity(
            object_bytes(
                Mat3::from(transform.matrix3),
                &material,
                &mut sync.map_transforms,
            ),
            sync.identities.borrowed(g.index()),
        );
        let before = replaced
            .get(&g)
            .and_then(|old| sync.objects.get(old.index() as usize).cloned().flatten());
        let slot = &mut sync.objects[g.index() as usize];
        if slot.as_ref() != Some(&rec) {
            p.geometry_changed |= !before.is_some_and(|b| same_drawing(&b, &rec));
            p.writes.push(
                BufferKind::Objects,
                g.index() as u64 * crate::types::records::OBJECT_BYTES,
                &rec,
            );
            *slot = Some(rec);
        }
    }
    layers.end_pass();
    sync.pool.end_pass();
    sync.emitters_changed |= sync.emitters.end_pass();
    if sync.map_transforms.len() != sets {
        p.map_transforms = Some(sync.map_transforms.bytes());
    }

    // The vertices of meshes new to the pool, then the shading records of new and re-laid
    // groups (triangles that only moved keep theirs) and of groups whose vertices moved in the
    // pool or whose material changed the UV sets it reads: which group and which of its
    // triangles each id is, sorted by id, then written run by run.
    p.need(BufferKind::ShadingVertices, u64::from(sync.pool.end()));
    let (needed, expected) = (p.needed, p.expected);
    let mut flush = |w: &mut Writes| target.flush(w, &needed, &expected);
    sync.pool
        .write_new_vertices(&mut p.writes, round, &mut flush);
    let mut records: Vec<(u32, GroupId, u32)> = Vec::new();
    for g in relay {
        let (Ok(ids), true) = (bvh.group_triangles(g), tree.shading.contains_key(&g)) else {
            continue;
        };
        records.extend(ids.iter().enumerate().map(|(k, t)| (t, g, k as u32)));
    }
    records.sort_unstable_by_key(|r| r.0);
    records.dedup_by_key(|r| r.0);
    let runs = runs(records.iter().map(|r| r.0), 0);
    let pool = &sync.pool;
    p.writes.push_records_in_rounds(
        BufferKind::Attributes,
        runs,
        |j, _| {
            let (_, g, k) = records[j];
            pool.record(g.index(), tree.shading.get(&g).map(|s| &**s), k as usize)
        },
        round,
        &mut flush,
    );
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::math::Affine3A;
    use std::collections::{HashMap, HashSet};

    /// `size` squares of two triangles from `at` along z, as ids and world-space corners.
    fn squares(at: Vec3, size: u32) -> Vec<(u32, [Vec3; 3])> {
        (0..size)
            .flat_map(|k| {
                let a = at + Vec3::Z * k as f32;
                let (x, z) = (Vec3::X, Vec3::Z);
                [
                    (2 * k, [a, a + x, a + x + z]),
                    (2 * k + 1, [a, a + x + z, a + z]),
                ]
            })
            .collect()
    }

    proptest::proptest! {
        /// Frame after frame of punctual lights coming and going and emissive groups changing,
        /// a copy of the lights buffer that only this frame's writes touch (grown as the render
        /// world grows it, keeping its bytes) holds the lights' records and then the emitters'
        /// list, and the counts the kernel reads with it say where each part ends.
        #[test]
        fn the_lights_buffer_kept_by_the_writes_is_the_lights_then_the_emitters(
            frames in proptest::collection::vec(
                (
                    proptest::collection::vec(1u32..5, 0..4),
                    proptest::collection::vec(
                        (0u32..5, 0u32..3, 1u32..4, proptest::bool::ANY),
                        0..4,
                    ),
                ),
                1..14,
            )
        ) {
            let mut sync = SceneSync::default();
            let mut copy: Vec<u8> = Vec::new();
            let (mut light_count, mut emitters) = (0u32, (0u32, 0.0f32));
            // Per slot: place, brightness (0: dark), squares.
            let mut scene: HashMap<u32, (u32, u32, u32)> = HashMap::new();
            for (powers, edits) in frames {
                let mut edited = HashSet::new();
                for (slot, place, size, dark) in edits {
                    scene.insert(slot, (place, if dark { 0 } else { size }, size));
                    edited.insert(slot);
                }
                sync.emitters.begin_pass();
                for (&slot, &(place, bright, size)) in &scene {
                    let at = Vec3::new(slot as f32 * 3.0, place as f32, 0.0);
                    sync.emitters.group(
                        slot,
                        Affine3A::from_translation(at),
                        Vec3::splat(bright as f32),
                        edited.contains(&slot),
                        || squares(at, size),
                    );
                }
                // As `scene_writes` ends its pass.
                sync.emitters_changed |= sync.emitters.end_pass();
                let lights: Vec<SceneLight> = powers
                    .iter()
                    .enumerate()
                    .map(|(i, &w)| SceneLight::Point {
                        position: Vec3::new(i as f32, 5.0, 0.0),
                        power: Vec3::splat(w as f32 * 100.0),
                        radius: 0.0,
                        range: None,
                    })
                    .collect();
                let mut p = PendingUpload::default();
                sync.write_lights(&lights, &mut p);
                // The render world takes the frame's upload: grows the buffer to what it needs
                // (the old bytes kept), then writes.
                let need = p.needed[BufferKind::Lights.index()] * BufferKind::Lights.record_bytes();
                if copy.len() < need as usize {
                    copy.resize(need as usize, 0);
                }
                for w in p.writes.iter() {
                    proptest::prop_assert_eq!(w.buffer, BufferKind::Lights);
                    let at = w.offset as usize;
                    proptest::prop_assert!(at + w.bytes.len() <= copy.len(), "a write past the buffer");
                    copy[at..at + w.bytes.len()].copy_from_slice(w.bytes);
                }
                light_count = p.light_count.unwrap_or(light_count);
                emitters = p.emitters.unwrap_or(emitters);
                let mut want: Vec<u8> = lights.iter().flat_map(light_bytes).collect();
                want.extend(sync.emitters.bytes());
                proptest::prop_assert_eq!(&copy[..want.len()], &want[..]);
                proptest::prop_assert_eq!(light_count as usize, lights.len());
                proptest::prop_assert_eq!(
                    emitters,
                    (sync.emitters.group_count(), sync.emitters.total())
                );
            }
        }
    }
}
