//! The command path on a real scene (FlightHelmet from `../shared/scenes`), headless: random command
//! sequences applied through the history, then all undone, give back the world as it was (objects
//! compared by stable id: names, transforms, parents, visibility, meshes, materials); redoing all
//! reaches the same world again; and the scene BVH's ray casts agree with brute force over the
//! world's meshes along the way. Also imports (a 1M-triangle assembly streams in front to back; a
//! cancel leaves nothing) and the placement rule's fallbacks.

use bevy::math::Ray3d;
use bevy::prelude::*;
use proptest::prelude::*;
use std::collections::BTreeMap;
use std::time::{Duration, Instant};
use treelight_bvh::RayData;
use treelight_document::edit::command::EditCommand;
use treelight_document::edit::command::LightKind;
use treelight_document::edit::command::MaterialValue;
use treelight_document::edit::command::TransformValue;
use treelight_document::edit::history::EditHistory;
use treelight_document::edit::history::EditRequest;
use treelight_document::edit::history::apply_request;
use treelight_document::scene::convert::to_bevy_mesh;
use treelight_document::scene::outbox::DocumentEvent;
use treelight_document::values::light::LightValue;
use treelight_document::values::object::SceneId;
use treelight_document::values::object::SceneIndex;
use treelight_document::values::object::SceneObject;
use treelight_document::values::primitive::Primitive;
use treelight_scene::{SceneBvh, cast_on, mesh_triangles};

#[path = "support/assembly.rs"]
mod assembly;

/// The editor's headless app (the one `--save` runs): assets, transforms, ids, the history, the
/// selection, imports, projects and the scene BVH.
fn editing_app() -> App {
    treelight_document::app::headless_app(treelight_scene::SceneBvhConfig::default())
}

/// The headless app at another pace: copying one chunk of a mesh per frame, as a slow machine does
/// (edits land while meshes are half copied), and baking moved meshes back into the tree at once
/// (bakes land between edits).
fn paced_app(slow_copies: bool, quick_bakes: bool) -> App {
    let mut config = treelight_scene::SceneBvhConfig::default();
    if slow_copies {
        config.main_thread_budget = Duration::ZERO;
        config.main_thread_share = 0.0;
    }
    if quick_bakes {
        config.bake_after = Duration::ZERO;
        config.idle_tick = Duration::from_millis(1);
    }
    treelight_document::app::headless_app(config)
}

fn app_with_flight_helmet() -> App {
    flight_helmet_in(editing_app())
}

fn flight_helmet_in(mut app: App) -> App {
    let path = treelight_test_support::shared_scene("gltf/FlightHelmet/FlightHelmet.gltf");
    let scene = treelight_import::load_scene(&path).expect("FlightHelmet loads");
    let world = app.world_mut();
    let material = world
        .resource_mut::<Assets<StandardMaterial>>()
        .add(StandardMaterial::default());
    // One assembly root with the file's meshes under it, as an import makes.
    let root = world
        .spawn((
            Name::new("FlightHelmet"),
            SceneObject,
            Transform::default(),
            Visibility::default(),
        ))
        .id();
    for m in &scene.meshes {
        let mesh = world
            .resource_mut::<Assets<Mesh>>()
            .add(to_bevy_mesh(m, false));
        world.spawn((
            Name::new(m.name.clone()),
            SceneObject,
            Mesh3d(mesh),
            MeshMaterial3d(material.clone()),
            Transform::from_matrix(m.transform),
            ChildOf(root),
        ));
    }
    settle(&mut app);
    app
}

fn settle(app: &mut App) {
    let start = Instant::now();
    for _ in 0..3 {
        app.update();
    }
    loop {
        app.update();
        if app.world().resource::<SceneBvh>().is_idle() {
            app.update();
            return;
        }
        assert!(
            start.elapsed() < Duration::from_secs(60),
            "the BVH did not settle"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// What is compared of each object.
#[derive(Debug, PartialEq)]
struct ObjectState {
    name: Option<String>,
    transform: [f32; 10],
    parent: Option<SceneId>,
    visibility: Option<Visibility>,
    mesh: Option<AssetId<Mesh>>,
    material: Option<AssetId<StandardMaterial>>,
    material_values: Option<MaterialValue>,
    /// The light's values, for a light.
    light: Option<LightValue>,
}

fn world_state(world: &mut World) -> BTreeMap<SceneId, ObjectState> {
    let mut q = world.query::<(
        &SceneId,
        Option<&Name>,
        &Transform,
        Option<&ChildOf>,
        Option<&Visibility>,
        Option<&Mesh3d>,
        Option<&MeshMaterial3d<StandardMaterial>>,
        EntityRef,
    )>();
    let values: BTreeMap<AssetId<StandardMaterial>, MaterialValue> = world
        .resource::<Assets<StandardMaterial>>()
        .iter()
        .map(|(id, m)| (id, MaterialValue::of(m)))
        .collect();
    let parents: BTreeMap<Entity, SceneId> = world
        .query::<(Entity, &SceneId)>()
        .iter(world)
        .map(|(e, id)| (e, *id))
        .collect();
    q.iter(world)
        .map(|(id, name, t, parent, vis, mesh, mat, entity)| {
            let mut transform = [0.0; 10];
            transform[..3].copy_from_slice(&t.translation.to_array());
            transform[3..7].copy_from_slice(&t.rotation.to_array());
            transform[7..].copy_from_slice(&t.scale.to_array());
            (
                *id,
                ObjectState {
                    name: name.map(|n| n.as_str().to_owned()),
                    transform,
                    parent: parent.and_then(|p| parents.get(&p.parent()).copied()),
                    visibility: vis.copied(),
                    mesh: mesh.map(|m| m.0.id()),
                    material: mat.map(|m| m.0.id()),
                    material_values: mat.and_then(|m| values.get(&m.0.id()).copied()),
                    light: LightValue::of(&entity),
                },
            )
        })
        .collect()
}

/// Closest hits of a fan of rays through the helmet, by the scene BVH and by brute force over the
/// visible meshes in the world; they must name the same entity at the same distance. A ray that
/// grazes the edge of the triangle brute force finds (within a ten-thousandth of its barycentric range)
/// is not judged: the tree holds the triangle as its group's transform made it, brute force as the
/// entity's global transform does, and the two roundings may fall on either side of the edge.
fn check_rays(app: &mut App) {
    settle(app);
    let world = app.world_mut();
    let mut q = world.query::<(
        Entity,
        &Mesh3d,
        &GlobalTransform,
        &InheritedVisibility,
        Option<&Name>,
    )>();
    let meshes = world.resource::<Assets<Mesh>>();
    let mut tris = Vec::new();
    let mut names: BTreeMap<Entity, String> = BTreeMap::new();
    for (e, m, gt, vis, name) in q.iter(world) {
        if !vis.get() {
            continue;
        }
        names.insert(e, name.map_or_else(String::new, |n| n.as_str().to_owned()));
        let xf = gt.affine();
        for t in mesh_triangles(meshes.get(&m.0).unwrap()).unwrap() {
            tris.push((e, t.transformed(&xf)));
        }
    }
    let scene = world.resource::<SceneBvh>();
    let tree = scene.read_blocking();
    for i in 0..12 {
        let a = i as f32 * 0.52;
        let origin = Vec3::new(a.cos() * 2.0, 0.2 + 0.05 * i as f32, a.sin() * 2.0);
        let target = Vec3::new(0.0, 0.3, 0.0);
        let ray = Ray3d::new(origin, Dir3::new(target - origin).unwrap());
        let rd = RayData::new(&treelight_bvh::Ray::new(ray.origin, ray.direction.into()));
        // Entity, distance, and the smallest barycentric coordinate of the hit.
        let mut best: Option<(Entity, f32, f32)> = None;
        for (e, t) in &tris {
            if let Some((d, v, w)) = rd.hit_triangle(t, 0.0, best.map_or(f32::INFINITY, |b| b.1)) {
                best = Some((*e, d, v.min(w).min(1.0 - v - w)));
            }
        }
        let hit = cast_on(&tree, ray).map(|h| (h.entity, h.distance));
        let grazing = best.is_some_and(|b| b.2 < 1e-4);
        match (hit, best) {
            (None, None) => {}
            (Some((e1, d1)), Some((_, d2, _))) => {
                // Coplanar duplicates may tie: the distance decides.
                assert!(
                    (d1 - d2).abs() < 1e-4 || grazing,
                    "ray {i}: {d1} vs {d2} ({e1})"
                );
            }
            (None, Some((e, d, edge))) if !grazing => panic!(
                "ray {i}: brute force hits {e} ('{}') at {d} ({edge} from an edge), the BVH \
                 nothing; the tree {} it: {:?} ({} triangles in all)",
                names[&e],
                if tree.is_traced(e) { "holds" } else { "lacks" },
                tree.groups_of(e),
                tree.bvh.triangle_count(),
            ),
            (Some((e, d)), None) => panic!(
                "ray {i}: the BVH hits {e} ('{}') at {d}, brute force nothing",
                names.get(&e).map_or("not visible", String::as_str)
            ),
            _ => {}
        }
    }
    exact_against_the_trees_own_triangles(&tree.bvh);
}

/// The tree's traversal against brute force over its own triangles, each met in the space the
/// traversal meets it in: the same distance to the last bit, and the same triangle unless another
/// lies at exactly that distance. No tolerance, near edges or anywhere (the world-space check
/// above compares two spaces, which round apart on a grazing ray).
fn exact_against_the_trees_own_triangles(bvh: &treelight_bvh::Bvh) {
    for i in 0..200 {
        let a = i as f32 * 0.131;
        let origin = Vec3::new(a.cos() * 2.0, 0.1 + 0.004 * i as f32, a.sin() * 2.0);
        let target = Vec3::new((a * 3.0).sin() * 0.2, 0.3, (a * 5.0).cos() * 0.2);
        let ray = treelight_bvh::Ray::new(origin, target - origin);
        let (got, want) = (bvh.closest_hit(&ray), bvh.brute_force_closest_hit(&ray));
        match (got, want) {
            (None, None) => {}
            (Some(g), Some(w)) => {
                assert_eq!(g.t, w.t, "ray {i}: tree {g:?}, brute force {w:?}");
                if (g.triangle, g.instance) != (w.triangle, w.instance) {
                    assert_eq!(
                        bvh.hit_at(&ray, g.triangle, g.instance),
                        Some(w.t),
                        "ray {i}"
                    );
                }
            }
            _ => panic!("ray {i}: tree {got:?}, brute force {want:?}"),
        }
    }
}

#[derive(Clone, Debug)]
enum Op {
    Move(usize, [f32; 3]),
    Rename(usize),
    Hide(usize, bool),
    Delete(usize),
    Duplicate(usize),
    Add(u8, [f32; 3]),
    Reparent(usize, Option<usize>),
    MoveMany(usize, usize, [f32; 3]),
    /// A drag shown live then cancelled (no step) or committed (one step).
    Drag(usize, [f32; 3], bool),
    Material(usize, f32),
    MakeUnique(usize),
    Group(usize, usize),
    /// A light of the kind with this index, added at a point.
    Light(usize, [f32; 3]),
    /// An object's light given another kind (by index), intensity and cone (when it is a light).
    EditLight(usize, usize, f32, f32),
    Undo,
    Redo,
}

fn op() -> impl Strategy<Value = Op> {
    let v = || prop::array::uniform3(-0.5f32..0.5);
    prop_oneof![
        3 => (any::<usize>(), v()).prop_map(|(i, d)| Op::Move(i, d)),
        1 => any::<usize>().prop_map(Op::Rename),
        1 => (any::<usize>(), any::<bool>()).prop_map(|(i, b)| Op::Hide(i, b)),
        2 => any::<usize>().prop_map(Op::Delete),
        2 => any::<usize>().prop_map(Op::Duplicate),
        1 => (0u8..5, v()).prop_map(|(k, p)| Op::Add(k, p)),
        2 => (any::<usize>(), any::<Option<usize>>()).prop_map(|(i, p)| Op::Reparent(i, p)),
        1 => (any::<usize>(), any::<usize>(), v()).prop_map(|(i, j, d)| Op::MoveMany(i, j, d)),
        2 => (any::<usize>(), v(), any::<bool>()).prop_map(|(i, d, c)| Op::Drag(i, d, c)),
        1 => (any::<usize>(), 0f32..1.0).prop_map(|(i, r)| Op::Material(i, r)),
        1 => any::<usize>().prop_map(Op::MakeUnique),
        1 => (any::<usize>(), any::<usize>()).prop_map(|(i, j)| Op::Group(i, j)),
        1 => (any::<usize>(), v()).prop_map(|(k, at)| Op::Light(k, at)),
        1 => (any::<usize>(), any::<usize>(), 0f32..1e6, 0f32..1.5)
            .prop_map(|(i, k, w, a)| Op::EditLight(i, k, w, a)),
        1 => Just(Op::Undo),
        1 => Just(Op::Redo),
    ]
}

fn request(world: &mut World, op: &Op, step: usize) -> Option<EditRequest> {
    let ids: Vec<SceneId> = {
        let mut q = world.query::<&SceneId>();
        let mut v: Vec<SceneId> = q.iter(world).copied().collect();
        v.sort();
        v
    };
    let pick = |i: usize| ids.get(i % ids.len().max(1)).copied();
    let apply = |command| {
        Some(EditRequest::Apply {
            command,
            continuing: false,
        })
    };
    match *op {
        Op::Move(i, d) => {
            let id = pick(i)?;
            let e = world.resource::<SceneIndex>().entity(id)?;
            let t = *world.get::<Transform>(e)?;
            let mut moved = t;
            moved.translation += Vec3::from_array(d);
            moved.rotation *= Quat::from_rotation_y(d[0]);
            apply(EditCommand::SetTransform {
                id,
                transform: moved.into(),
            })
        }
        Op::Rename(i) => apply(EditCommand::Rename {
            id: pick(i)?,
            name: format!("renamed {step}"),
        }),
        Op::Hide(i, visible) => apply(EditCommand::SetVisible {
            id: pick(i)?,
            visible,
        }),
        Op::Delete(i) => apply(EditCommand::Delete {
            ids: vec![pick(i)?],
        }),
        Op::Duplicate(i) => apply(EditCommand::Duplicate {
            ids: vec![pick(i)?],
            copies: Vec::new(),
        }),
        Op::Add(k, p) => apply(EditCommand::AddPrimitive {
            shape: Primitive::ALL[k as usize % Primitive::ALL.len()],
            transform: TransformValue {
                translation: p,
                rotation: [0.0, 0.0, 0.0, 1.0],
                scale: [0.2; 3],
            },
            id: None,
        }),
        Op::Reparent(i, p) => {
            let command = EditCommand::Reparent {
                ids: vec![pick(i)?],
                parent: match p {
                    Some(p) => Some(pick(p)?),
                    None => None,
                },
            };
            // A parent under the object itself is refused; the generator skips those.
            command.check(world).ok()?;
            apply(command)
        }
        Op::MoveMany(i, j, d) => {
            let (a, b) = (pick(i)?, pick(j)?);
            if a == b {
                return None;
            }
            let moved = |id: SceneId| {
                let e = world.resource::<SceneIndex>().entity(id)?;
                let mut t = *world.get::<Transform>(e)?;
                t.translation += Vec3::from_array(d);
                Some((id, TransformValue::from(t)))
            };
            apply(EditCommand::SetTransforms {
                transforms: vec![moved(a)?, moved(b)?],
            })
        }
        Op::Drag(i, d, commit) => drag(world, pick(i)?, d, commit),
        Op::Material(i, r) => apply(material_edit(world, pick(i)?, r)?),
        Op::MakeUnique(i) => {
            let id = pick(i)?;
            let e = world.resource::<SceneIndex>().entity(id)?;
            world.get::<MeshMaterial3d<StandardMaterial>>(e)?;
            apply(EditCommand::MakeMaterialUnique { id })
        }
        Op::Group(i, j) => {
            let mut ids = vec![pick(i)?, pick(j)?];
            ids.dedup();
            apply(EditCommand::Group {
                ids,
                name: format!("Group {step}"),
                group: None,
            })
        }
        Op::Light(kind, at) => apply(EditCommand::AddLight {
            kind: LightKind::ALL[kind % LightKind::ALL.len()],
            transform: Transform::from_translation(Vec3::from_array(at)).into(),
            id: None,
        }),
        Op::EditLight(i, kind, intensity, angle) => {
            let id = pick(i)?;
            let e = world.resource::<SceneIndex>().entity(id)?;
            let light = LightValue::of(&world.entity(e))?;
            apply(EditCommand::SetLight {
                id,
                light: LightValue {
                    kind: LightKind::ALL[kind % LightKind::ALL.len()],
                    intensity,
                    outer_angle: angle,
                    inner_angle: angle * 0.5,
                    color: [1.0, 0.5, 0.25],
                    ..light
                },
            })
        }
        Op::Undo => Some(EditRequest::Undo),
        Op::Redo => Some(EditRequest::Redo),
    }
}

/// A drag of `id` by `d`: three previews applied now, then the commit (or the cancel) returned.
fn drag(world: &mut World, id: SceneId, d: [f32; 3], commit: bool) -> Option<EditRequest> {
    let e = world.resource::<SceneIndex>().entity(id)?;
    let t = *world.get::<Transform>(e)?;
    for k in 1..=3 {
        let mut moved = t;
        moved.translation += Vec3::from_array(d) * k as f32 / 3.0;
        apply_request(
            world,
            EditRequest::Preview(EditCommand::SetTransform {
                id,
                transform: moved.into(),
            }),
        )
        .expect("a preview applies");
    }
    if !commit {
        return Some(EditRequest::CancelPreview);
    }
    let mut moved = t;
    moved.translation += Vec3::from_array(d);
    Some(EditRequest::Apply {
        command: EditCommand::SetTransform {
            id,
            transform: moved.into(),
        },
        continuing: false,
    })
}

/// `id`'s material with roughness `r` and colour and emission following it.
fn material_edit(world: &World, id: SceneId, r: f32) -> Option<EditCommand> {
    let e = world.resource::<SceneIndex>().entity(id)?;
    let handle = world.get::<MeshMaterial3d<StandardMaterial>>(e)?.0.clone();
    let mut value = MaterialValue::of(world.resource::<Assets<StandardMaterial>>().get(&handle)?);
    value.perceptual_roughness = r;
    value.base_color[0] = 1.0 - r;
    value.emissive = [r, 0.0, 0.0];
    Some(EditCommand::SetMaterial {
        id,
        material: value,
    })
}

fn head(app: &App) -> usize {
    app.world().resource::<EditHistory>().head()
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 12, .. ProptestConfig::default() })]

    #[test]
    fn undo_all_restores_the_world_and_redo_all_reaches_it_again(
        ops in prop::collection::vec(op(), 1..24),
        slow_copies in any::<bool>(),
        quick_bakes in any::<bool>(),
    ) {
        let mut app = flight_helmet_in(paced_app(slow_copies, quick_bakes));
        let before = world_state(app.world_mut());
        for (step, op) in ops.iter().enumerate() {
            let Some(r) = request(app.world_mut(), op, step) else { continue };
            apply_request(app.world_mut(), r).expect("valid commands apply");
            app.update();
            if step % 6 == 5 {
                check_rays(&mut app);
            }
        }
        let head_after = head(&app);
        let after = world_state(app.world_mut());
        check_rays(&mut app);
        while head(&app) > 0 {
            apply_request(app.world_mut(), EditRequest::Undo).unwrap();
        }
        app.update();
        prop_assert_eq!(&world_state(app.world_mut()), &before);
        check_rays(&mut app);
        // Redo all, as far as the history went before the undos.
        apply_request(app.world_mut(), EditRequest::GoTo(head_after)).unwrap();
        app.update();
        prop_assert_eq!(&world_state(app.world_mut()), &after);
        check_rays(&mut app);
    }
}

#[test]
fn an_undone_delete_restores_the_same_object_with_its_children() {
    let mut app = app_with_flight_helmet();
    let before = world_state(app.world_mut());
    let root = *before
        .iter()
        .find(|(_, s)| s.name.as_deref() == Some("FlightHelmet"))
        .unwrap()
        .0;
    let children = before.values().filter(|s| s.parent == Some(root)).count();
    assert!(children >= 5, "{children} parts");
    apply_request(
        app.world_mut(),
        EditRequest::Apply {
            command: EditCommand::Delete { ids: vec![root] },
            continuing: false,
        },
    )
    .unwrap();
    app.update();
    assert!(world_state(app.world_mut()).is_empty());
    settle(&mut app);
    assert_eq!(app.world().resource::<SceneBvh>().stats().triangles, 0);
    apply_request(app.world_mut(), EditRequest::Undo).unwrap();
    app.update();
    assert_eq!(world_state(app.world_mut()), before);
    check_rays(&mut app);
    assert!(app.world().resource::<SceneBvh>().stats().triangles > 0);
}

#[test]
fn a_duplicate_is_selected_and_a_refused_command_changes_nothing() {
    let mut app = app_with_flight_helmet();
    let before = world_state(app.world_mut());
    let part = *before.keys().nth(1).unwrap();
    apply_request(
        app.world_mut(),
        EditRequest::Apply {
            command: EditCommand::Duplicate {
                ids: vec![part],
                copies: Vec::new(),
            },
            continuing: false,
        },
    )
    .unwrap();
    let after = world_state(app.world_mut());
    assert_eq!(after.len(), before.len() + 1);
    let copy = *after.keys().max().unwrap();
    // The document announces what it made, for an editor to select.
    let made: Vec<DocumentEvent> = app
        .world_mut()
        .resource_mut::<Messages<DocumentEvent>>()
        .drain()
        .collect();
    assert_eq!(made, vec![DocumentEvent::Made(vec![copy])]);
    // Same mesh and material (shared, not copied), same parent and transform.
    let (a, b) = (&after[&part], &after[&copy]);
    assert_eq!(
        (a.mesh, a.material, a.parent, a.transform),
        (b.mesh, b.material, b.parent, b.transform)
    );
    // The tree holds the mesh's triangles once: the copy is a second instance of them, traced
    // and picked as itself once moved away.
    let triangles = |app: &App| {
        app.world()
            .resource::<SceneBvh>()
            .read_blocking()
            .bvh
            .triangle_count()
    };
    let before_triangles = triangles(&app);
    settle(&mut app);
    assert_eq!(triangles(&app), before_triangles);
    let copy_entity = app.world().resource::<SceneIndex>().entity(copy).unwrap();
    let moved = Transform::from_xyz(0.0, 0.0, 50.0);
    apply_request(
        app.world_mut(),
        EditRequest::Apply {
            command: EditCommand::SetTransform {
                id: copy,
                transform: moved.into(),
            },
            continuing: false,
        },
    )
    .unwrap();
    settle(&mut app);
    assert_eq!(triangles(&app), before_triangles);
    let mesh = app.world().get::<Mesh3d>(copy_entity).unwrap().0.id();
    let centre = app
        .world()
        .resource::<Assets<Mesh>>()
        .get(mesh)
        .and_then(bevy::camera::primitives::MeshAabb::compute_aabb)
        .map(|b| moved.transform_point(Vec3::from(b.center)))
        .unwrap();
    // Rays at the copy's centre from all sides, until one meets it.
    let hit = [
        Vec3::X,
        Vec3::NEG_X,
        Vec3::Y,
        Vec3::NEG_Y,
        Vec3::Z,
        Vec3::NEG_Z,
    ]
    .into_iter()
    .find_map(|d| {
        cast_on(
            &app.world().resource::<SceneBvh>().read_blocking(),
            Ray3d::new(centre + d * 20.0, Dir3::new(-d).unwrap()),
        )
    })
    .expect("the moved copy is traced");
    assert_eq!(hit.entity, copy_entity);
    check_rays(&mut app);
    let after = world_state(app.world_mut());
    // A command naming no object is refused and leaves no step.
    let steps = head(&app);
    let refused = apply_request(
        app.world_mut(),
        EditRequest::Apply {
            command: EditCommand::Delete {
                ids: vec![SceneId(999_999)],
            },
            continuing: false,
        },
    );
    assert!(refused.is_err());
    assert_eq!(head(&app), steps);
    assert_eq!(world_state(app.world_mut()), after);
}

#[test]
fn a_drag_is_one_step() {
    let mut app = app_with_flight_helmet();
    let id = *world_state(app.world_mut()).keys().nth(2).unwrap();
    let e = app.world().resource::<SceneIndex>().entity(id).unwrap();
    let start = *app.world().get::<Transform>(e).unwrap();
    for k in 1..=10 {
        let mut t = start;
        t.translation.x += 0.01 * k as f32;
        apply_request(
            app.world_mut(),
            EditRequest::Apply {
                command: EditCommand::SetTransform {
                    id,
                    transform: t.into(),
                },
                continuing: k > 1,
            },
        )
        .unwrap();
    }
    assert_eq!(head(&app), 1);
    let moved = app.world().get::<Transform>(e).unwrap().translation.x;
    assert!((moved - start.translation.x - 0.1).abs() < 1e-5);
    apply_request(app.world_mut(), EditRequest::Undo).unwrap();
    assert_eq!(*app.world().get::<Transform>(e).unwrap(), start);
}

#[test]
fn an_import_keeps_the_file_s_hierarchy_and_undo_keeps_its_source_keys() {
    use treelight_document::scene::spawn::SourceKey;
    let mut app = editing_app();
    // A light already there: the import adds none of its own.
    app.world_mut()
        .spawn((PointLight::default(), Transform::default()));
    let sample = treelight_test_support::shared_scene("gltf/CesiumMan.glb");
    // A copy of its own, removed once imported: a redo must not need the file again.
    let dir = std::env::temp_dir().join(format!("treelight-test-redo-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("CesiumMan.glb");
    std::fs::copy(&sample, &path).unwrap();
    let scene = treelight_import::load_scene(&path).unwrap();
    // The import is a command: one step, undone and redone like any other.
    apply_request(
        app.world_mut(),
        EditRequest::Apply {
            command: EditCommand::Import {
                file: path.clone(),
                root: None,
                transform: None,
            },
            continuing: false,
        },
    )
    .unwrap();
    assert_eq!(head(&app), 1);
    app.update();
    let imported = world_state(app.world_mut());
    apply_request(app.world_mut(), EditRequest::Undo).unwrap();
    assert!(
        world_state(app.world_mut()).is_empty(),
        "undo removes the import"
    );
    // The redo takes back what the undo held (meshes, materials, ids): no second parse, so it
    // neither waits on a big file nor fails once the file is gone.
    std::fs::remove_dir_all(&dir).unwrap();
    apply_request(app.world_mut(), EditRequest::Redo).unwrap();
    app.update();
    assert_eq!(
        world_state(app.world_mut()),
        imported,
        "redo brings the same objects back"
    );
    let world = app.world_mut();
    // The root is named after the file; every node is an object under it, keyed by its path.
    let mut q = world.query::<(
        Entity,
        &Name,
        &SourceKey,
        Option<&ChildOf>,
        &GlobalTransform,
        Option<&Mesh3d>,
    )>();
    let rows: Vec<_> = q
        .iter(world)
        .map(|(e, n, k, p, g, m)| {
            (
                e,
                n.as_str().to_owned(),
                k.key.clone(),
                p.map(|p| p.parent()),
                *g,
                m.is_some(),
            )
        })
        .collect();
    assert_eq!(rows.len(), scene.nodes.len() + 1);
    let root = rows.iter().find(|r| r.3.is_none()).unwrap();
    assert_eq!(root.1, "CesiumMan.glb");
    for n in &scene.nodes {
        assert!(rows.iter().any(|r| *r.2 == *n.key), "{}", n.key);
    }
    // The mesh sits where the file puts it: its global transform is the mesh's world transform.
    let mesh_row = rows.iter().find(|r| r.5).unwrap();
    let expected = scene.meshes[0].transform;
    assert!(
        mesh_row.4.to_matrix().abs_diff_eq(expected, 1e-4),
        "{} vs {expected}",
        mesh_row.4.to_matrix()
    );
    // Deleting the assembly and undoing gives back every object with its key.
    let root_id = *world.get::<SceneId>(root.0).unwrap();
    let keys = |world: &mut World| {
        let mut q = world.query::<(&SceneId, &SourceKey)>();
        let mut v: Vec<(SceneId, String)> = q
            .iter(world)
            .map(|(i, k)| (*i, k.key.to_string()))
            .collect();
        v.sort();
        v
    };
    let before = keys(world);
    apply_request(
        world,
        EditRequest::Apply {
            command: EditCommand::Delete { ids: vec![root_id] },
            continuing: false,
        },
    )
    .unwrap();
    assert!(keys(world).is_empty());
    apply_request(world, EditRequest::Undo).unwrap();
    assert_eq!(keys(world), before);
}

/// The editor's import path without a window, the tree taking in one chunk of triangles per frame
/// (so an import takes many frames).
fn importing_app() -> App {
    treelight_document::app::headless_app(treelight_scene::SceneBvhConfig {
        main_thread_budget: Duration::ZERO,
        main_thread_share: 0.0,
        ..default()
    })
}

#[test]
fn a_cancelled_import_leaves_nothing_and_no_step() {
    use treelight_document::import::jobs::CancelImports;
    use treelight_document::import::jobs::TracingImports;
    use treelight_document::import::parse::PendingImports;
    let path = treelight_test_support::shared_scene("gltf/FlightHelmet/FlightHelmet.gltf");
    let mut app = importing_app();
    app.update();
    let before = world_state(app.world_mut());

    // Cancelled while parsing: nothing ever appears.
    app.world_mut()
        .resource_mut::<PendingImports>()
        .start(path.clone());
    app.world_mut()
        .resource_mut::<CancelImports>()
        .0
        .push(path.clone());
    for _ in 0..20 {
        app.update();
    }
    assert_eq!(world_state(app.world_mut()), before);
    assert_eq!(head(&app), 0);

    // Cancelled while the tree takes it in: its objects go, and no step is left to redo.
    app.world_mut()
        .resource_mut::<PendingImports>()
        .start(path.clone());
    let start = Instant::now();
    let fraction = loop {
        app.update();
        let jobs = app.world().resource::<TracingImports>();
        if let Some(job) = jobs.jobs.first() {
            break job.fraction();
        }
        assert!(start.elapsed() < Duration::from_secs(60), "never imported");
    };
    assert!(fraction < 1.0, "the tree took it all in one frame");
    assert_eq!(head(&app), 1);
    assert!(world_state(app.world_mut()).len() > before.len());
    app.world_mut()
        .resource_mut::<CancelImports>()
        .0
        .push(path.clone());
    app.update();
    assert_eq!(world_state(app.world_mut()), before);
    assert_eq!(head(&app), 0);
    let history = app.world().resource::<EditHistory>();
    assert!(history.labels().is_empty() && history.redo_label().is_none());
    apply_request(app.world_mut(), EditRequest::Redo).unwrap();
    assert_eq!(world_state(app.world_mut()), before, "nothing to redo");
    assert!(app.world().resource::<TracingImports>().jobs.is_empty());
    settle(&mut app);
    assert_eq!(
        app.world()
            .resource::<SceneBvh>()
            .read_blocking()
            .bvh
            .triangle_count(),
        0,
        "nothing of it stays in the tree"
    );

    // Left alone, an import is followed until the tree holds all of it, then forgotten.
    app.world_mut()
        .resource_mut::<PendingImports>()
        .start(path.clone());
    let start = Instant::now();
    let mut seen = false;
    loop {
        app.update();
        let jobs = app.world().resource::<TracingImports>();
        seen |= !jobs.jobs.is_empty();
        if seen && jobs.jobs.is_empty() {
            break;
        }
        assert!(start.elapsed() < Duration::from_secs(120), "never finished");
    }
    assert_eq!(head(&app), 1);
    assert!(
        app.world()
            .resource::<SceneBvh>()
            .read_blocking()
            .bvh
            .triangle_count()
            > 0
    );
}

/// The middle of a tile of the generated assembly, in the world.
fn tile_middle(world: &mut World, e: Entity) -> Option<Vec3> {
    let mut q = world.query::<&GlobalTransform>();
    q.get(world, e)
        .ok()
        .map(|t| t.transform_point(Vec3::new(0.5, 0.0, 0.5)))
}

/// The tiles among `tiles` that a primary ray from `eye` towards their middle hits first.
fn tiles_hit(world: &mut World, eye: Vec3, tiles: &[Entity]) -> Vec<Entity> {
    let middles: Vec<(Entity, Vec3)> = tiles
        .iter()
        .filter_map(|e| Some((*e, tile_middle(world, *e)?)))
        .collect();
    let tree = world.resource::<SceneBvh>().read_blocking();
    middles
        .into_iter()
        .filter(|(e, m)| {
            let ray = Ray3d::new(eye, Dir3::new(*m - eye).unwrap());
            cast_on(&tree, ray).is_some_and(|h| h.entity == *e)
        })
        .map(|(e, _)| e)
        .collect()
}

#[test]
fn a_big_assembly_streams_in_front_to_back() {
    use treelight_document::import::jobs::TracingImports;
    use treelight_document::import::parse::PendingImports;
    let dir = std::env::temp_dir().join(format!("treelight-test-stream-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    // 100 parts of 10,082 triangles on a grid: 1,008,200 triangles.
    let (file, triangles) = assembly::generated_assembly(&dir, 100, 71);
    assert!(triangles > 1_000_000);
    // The editor's settings, frames paced as a window's would be.
    let mut app = editing_app();
    // Beyond the grid's far corner, looking back: the file lists the parts farthest first.
    let eye = Vec3::new(15.0, 4.0, -15.0);
    app.world_mut().spawn((
        Camera3d::default(),
        Transform::from_translation(eye).looking_at(Vec3::new(6.0, 0.0, -6.0), Vec3::Y),
    ));
    app.update();
    app.world_mut()
        .resource_mut::<PendingImports>()
        .start(file.clone());
    // Each frame, a primary ray from the camera towards every part's middle: the frame of its
    // first hit on that part.
    let mut first_hit: BTreeMap<Entity, usize> = BTreeMap::new();
    let mut tiles: Vec<Entity> = Vec::new();
    let (start, mut seen) = (Instant::now(), false);
    for frame in 0.. {
        assert!(start.elapsed() < Duration::from_secs(120), "never imported");
        app.update();
        std::thread::sleep(Duration::from_millis(8));
        let world = app.world_mut();
        match world.resource::<TracingImports>().jobs.first() {
            Some(job) => {
                seen = true;
                tiles = job.meshes.iter().map(|(e, _)| *e).collect();
            }
            // The job ends in the frame its last part is traced; that frame is looked at too.
            None if !seen => continue,
            None => {}
        }
        for e in tiles_hit(world, eye, &tiles) {
            first_hit.entry(e).or_insert(frame);
        }
        if !world.resource::<TracingImports>().jobs.is_empty() {
            continue;
        }
        break;
    }
    std::fs::remove_dir_all(&dir).ok();
    let world = app.world_mut();
    let mut parts: Vec<(Entity, f32)> = tiles
        .iter()
        .map(|e| (*e, tile_middle(world, *e).unwrap().distance(eye)))
        .collect();
    assert_eq!(parts.len(), 100, "the assembly's parts");
    assert_eq!(first_hit.len(), 100, "every part is hit once imported");
    parts.sort_by(|a, b| a.1.total_cmp(&b.1));
    let frames: Vec<usize> = parts.iter().map(|(e, _)| first_hit[e]).collect();
    // Near parts come in earlier frames than far ones. How many parts share a frame depends on
    // how busy the machine is (the worker takes what has arrived, so most may share one), so the
    // order is judged over pairs: of the pairs first hit in different frames, far-before-near ones
    // are rare, and the nearest part comes before the farthest.
    let (mut in_order, mut reversed) = (0usize, 0usize);
    for i in 0..frames.len() {
        for j in i + 1..frames.len() {
            match frames[i].cmp(&frames[j]) {
                std::cmp::Ordering::Less => in_order += 1,
                std::cmp::Ordering::Greater => reversed += 1,
                std::cmp::Ordering::Equal => {}
            }
        }
    }
    assert!(
        frames[0] < frames[99] && reversed * 5 < in_order,
        "{in_order} pairs near first, {reversed} far first: {frames:?}"
    );
}

#[test]
fn placement_lands_on_a_surface_else_the_ground_else_a_plane_facing_the_camera() {
    use treelight_document::scene::placement::surface_under;
    let mut app = editing_app();
    let cube = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::new(2.0, 2.0, 2.0).mesh().build());
    app.world_mut()
        .spawn((Mesh3d(cube), Transform::from_xyz(0.0, 3.0, 0.0)));
    settle(&mut app);
    let scene = app.world().resource::<SceneBvh>();
    let eye = Vec3::new(0.0, 10.0, 0.0);
    // Straight down onto the cube's top (y = 4).
    let s = surface_under(scene, Ray3d::new(eye, Dir3::NEG_Y), 5.0);
    assert!(s.point.distance(Vec3::new(0.0, 4.0, 0.0)) < 1e-4, "{s:?}");
    assert!(s.normal.distance(Vec3::Y) < 1e-4);
    // Down past the cube: the ground plane.
    let d = Dir3::new(Vec3::new(1.0, -1.0, 0.0)).unwrap();
    let s = surface_under(scene, Ray3d::new(eye, d), 5.0);
    assert!(s.point.distance(Vec3::new(10.0, 0.0, 0.0)) < 1e-4, "{s:?}");
    assert_eq!(s.normal, Vec3::Y);
    // Up into the sky: a plane facing the camera, 5 along the ray.
    let d = Dir3::new(Vec3::new(1.0, 0.5, 0.0)).unwrap();
    let s = surface_under(scene, Ray3d::new(eye, d), 5.0);
    assert!(s.point.distance(eye + *d * 5.0) < 1e-4, "{s:?}");
    assert!(s.normal.distance(-*d) < 1e-6);
}
