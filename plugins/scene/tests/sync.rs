//! Headless (no GPU): after random spawns, despawns and moves over many frames, the published tree's
//! hits equal brute force over the world's current meshes, and nothing remains of despawned entities.

mod support;

use bevy::math::{Affine3A, Ray3d};
use bevy::mesh::{Mesh, MeshBuilder, Meshable};
use bevy::prelude::*;
use std::time::{Duration, Instant};
use support::headless_app;
use treelight_bvh::RayData;
use treelight_scene::{NotTraced, SceneBvh, SceneBvhConfig, mesh_triangles};
use treelight_test_support::Xorshift;

fn app(bake_after: Duration) -> App {
    headless_app(SceneBvhConfig {
        bake_after,
        ..default()
    })
}

/// Runs frames until the worker has applied everything.
fn settle(app: &mut App) {
    let start = Instant::now();
    // Asset edits reach `Changed<Mesh3d>` a frame later; give them time to become commands.
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
            start.elapsed() < Duration::from_secs(30),
            "the worker did not catch up"
        );
        std::thread::sleep(Duration::from_millis(2));
    }
}

/// Closest hit by brute force over every mesh entity in the world, from the ECS directly.
fn brute_force(world: &mut World, ray: Ray3d) -> Option<(Entity, f32)> {
    let mut q = world.query::<(Entity, &Mesh3d, &GlobalTransform)>();
    let meshes = world.resource::<Assets<Mesh>>();
    closest_hit(
        q.iter(world)
            .filter_map(|(e, m, gt)| Some((e, meshes.get(&m.0)?, gt.affine()))),
        ray,
    )
}

/// Closest hit by brute force over meshes placed by entities.
fn closest_hit<'a>(
    placed: impl Iterator<Item = (Entity, &'a Mesh, Affine3A)>,
    ray: Ray3d,
) -> Option<(Entity, f32)> {
    let rd = RayData::new(&treelight_bvh::Ray::new(ray.origin, ray.direction.into()));
    let mut best: Option<(Entity, f32)> = None;
    for (e, mesh, xf) in placed {
        for t in mesh_triangles(mesh).unwrap() {
            let w = t.transformed(&xf);
            if let Some((t, _, _)) = rd.hit_triangle(&w, 0.0, best.map_or(f32::INFINITY, |b| b.1)) {
                best = Some((e, t));
            }
        }
    }
    best
}

/// Triangles in the published tree.
fn tree_triangles(app: &App) -> u32 {
    app.world()
        .resource::<SceneBvh>()
        .read_blocking()
        .bvh
        .triangle_count()
}

fn cast(app: &App, ray: Ray3d) -> Option<treelight_scene::SceneHit> {
    treelight_scene::cast_on(&app.world().resource::<SceneBvh>().read_blocking(), ray)
}

fn rays(n: usize, seed: u64) -> Vec<Ray3d> {
    let mut r = Xorshift(seed);
    (0..n)
        .map(|_| {
            let o = Vec3::new(r.range(-30.0, 30.0), r.range(-30.0, 30.0), 40.0);
            let target = Vec3::new(
                r.range(-15.0, 15.0),
                r.range(-15.0, 15.0),
                r.range(-15.0, 15.0),
            );
            Ray3d::new(o, Dir3::new(target - o).unwrap())
        })
        .collect()
}

fn check(app: &mut App, rays: &[Ray3d]) {
    check_against(app, rays, brute_force);
}

/// The tree's closest hit for each ray against `expected`'s.
fn check_against(
    app: &mut App,
    rays: &[Ray3d],
    mut expected: impl FnMut(&mut World, Ray3d) -> Option<(Entity, f32)>,
) {
    for ray in rays {
        let expected = expected(app.world_mut(), *ray);
        let scene = app.world().resource::<SceneBvh>();
        let got =
            treelight_scene::cast_on(&scene.read_blocking(), *ray).map(|h| (h.entity, h.distance));
        match (got, expected) {
            (None, None) => {}
            (Some((ge, gt)), Some((ee, et))) => {
                assert!(
                    (gt - et).abs() < 1e-3 * et.max(1.0),
                    "distance {gt} vs {et}"
                );
                if (gt - et).abs() > 1e-5 {
                    assert_eq!(ge, ee);
                }
            }
            (g, e) => panic!("scene hit {g:?} vs brute force {e:?} for {ray:?}"),
        }
    }
}

#[test]
fn random_spawns_despawns_and_moves_match_brute_force() {
    let most_groups = random_edits(app(Duration::from_millis(30)), 0x9e3779b97f4a7c15);
    assert_eq!(
        most_groups, 1,
        "no mesh is big enough to be cut into chunks"
    );
}

#[test]
fn random_edits_of_meshes_inserted_in_chunks_match_brute_force() {
    // Spheres (320 triangles) and tori enter the tree in chunks of at most 100, cubes whole: each
    // chunk a group of the same entity, moved, shared, baked and removed with it.
    let app = headless_app(SceneBvhConfig {
        bake_after: Duration::from_millis(30),
        chunks: treelight_bvh::PieceRule {
            cut_above: 100,
            piece: 100,
        },
        ..default()
    });
    let most_groups = random_edits(app, 0x2545f4914f6cdd1d);
    assert!(
        most_groups >= 4,
        "spheres come in at least 4 chunks: {most_groups}"
    );
}

/// Random spawns (some sharing a mesh), despawns and drags, each round checked against brute force
/// over the ECS; ends with everything despawned. Returns the most groups one entity had.
fn random_edits(mut app: App, seed: u64) -> usize {
    let mut r = Xorshift(seed);
    let mut most_groups = 0;
    let shapes: Vec<Handle<Mesh>> = {
        let mut meshes = app.world_mut().resource_mut::<Assets<Mesh>>();
        vec![
            meshes.add(Cuboid::new(2.0, 1.0, 3.0).mesh().build()),
            meshes.add(Sphere::new(1.5).mesh().ico(2).unwrap()),
            meshes.add(Torus::new(0.5, 1.5).mesh().build()),
        ]
    };
    let mut live: Vec<Entity> = Vec::new();
    let test_rays = rays(150, 7);
    for round in 0..25 {
        // Spawns, including some that despawn in the same frame.
        for _ in 0..(r.next_u64() % 6) {
            let t = Transform::from_xyz(
                r.range(-12.0, 12.0),
                r.range(-12.0, 12.0),
                r.range(-12.0, 12.0),
            )
            .with_rotation(Quat::from_rotation_y(r.range(0.0, 6.0)))
            .with_scale(Vec3::splat(r.range(0.5, 2.0)));
            let shape = shapes[(r.next_u64() % 3) as usize].clone();
            let e = app.world_mut().spawn((Mesh3d(shape), t)).id();
            if r.next_u64().is_multiple_of(7) {
                app.world_mut().despawn(e);
            } else {
                live.push(e);
            }
        }
        if !live.is_empty() && r.next_u64().is_multiple_of(2) {
            let e = live.swap_remove((r.next_u64() % live.len() as u64) as usize);
            app.world_mut().despawn(e);
        }
        // Moves over a few frames, as a drag would.
        for _ in 0..3 {
            app.update();
            for &e in live.iter().take(3) {
                let mut t = app.world_mut().get_mut::<Transform>(e).unwrap();
                t.translation.x += 0.7;
                t.rotate_x(0.2);
            }
        }
        if round % 5 == 4 {
            // Let some groups be baked, others not.
            std::thread::sleep(Duration::from_millis(40));
        }
        settle(&mut app);
        check(&mut app, &test_rays);
        // Entities of one mesh share its triangles: the tree holds each used shape once.
        let mut used: Vec<AssetId<Mesh>> = live
            .iter()
            .map(|&e| app.world().get::<Mesh3d>(e).unwrap().0.id())
            .collect();
        used.sort_unstable();
        used.dedup();
        let meshes = app.world().resource::<Assets<Mesh>>();
        let expected: usize = used
            .iter()
            .map(|&m| mesh_triangles(meshes.get(m).unwrap()).unwrap().len())
            .sum();
        assert_eq!(tree_triangles(&app) as usize, expected);
        let scene = app.world().resource::<SceneBvh>();
        let tree = scene.read_blocking();
        tree.bvh.validate().unwrap();
        // Every group belongs to a live entity, and each entity's groups are its own.
        for (e, groups) in &tree.entity_groups {
            assert!(live.contains(e));
            most_groups = most_groups.max(groups.len());
            for g in groups {
                assert_eq!(tree.group_entity.get(g), Some(e));
            }
        }
        assert_eq!(
            tree.group_entity.len(),
            tree.entity_groups.values().map(Vec::len).sum::<usize>()
        );
    }

    // Despawn everything: nothing may remain.
    for e in live.drain(..) {
        app.world_mut().despawn(e);
    }
    settle(&mut app);
    let scene = app.world().resource::<SceneBvh>();
    let tree = scene.read_blocking();
    assert_eq!(tree.bvh.triangle_count(), 0);
    assert!(tree.entity_groups.is_empty());
    tree.bvh.validate().unwrap();
    most_groups
}

#[test]
fn meshes_loaded_later_and_edited_meshes_are_traced() {
    let mut app = app(Duration::from_millis(20));
    // A handle whose asset appears only a few frames later, like a glTF still loading.
    let handle: Handle<Mesh> = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .reserve_handle();
    let e = app
        .world_mut()
        .spawn((Mesh3d(handle.clone()), Transform::default()))
        .id();
    settle(&mut app);
    assert_eq!(tree_triangles(&app), 0);
    app.world_mut()
        .resource_mut::<Assets<Mesh>>()
        .insert(handle.id(), Cuboid::new(1.0, 1.0, 1.0).mesh().build())
        .unwrap();
    settle(&mut app);
    let down = Ray3d::new(Vec3::new(0.0, 10.0, 0.0), Dir3::NEG_Y);
    let hit = cast(&app, down).expect("the loaded mesh is hit");
    assert_eq!(hit.entity, e);
    assert!((hit.point.y - 0.5).abs() < 1e-4 && hit.normal.y > 0.99);
    // Editing the asset replaces the triangles.
    app.world_mut()
        .resource_mut::<Assets<Mesh>>()
        .insert(handle.id(), Cuboid::new(1.0, 4.0, 1.0).mesh().build())
        .unwrap();
    settle(&mut app);
    let hit = cast(&app, down).unwrap();
    assert!((hit.point.y - 2.0).abs() < 1e-4, "{hit:?}");
    // One asset shared by two entities appears twice, its triangles stored once.
    let second = app
        .world_mut()
        .spawn((Mesh3d(handle.clone()), Transform::from_xyz(5.0, 0.0, 0.0)))
        .id();
    settle(&mut app);
    assert_eq!(tree_triangles(&app), 12);
    let stats = app.world().resource::<SceneBvh>().stats();
    assert_eq!(stats.triangles, 12);
    assert!(stats.sah_cost > 0.0);
    let over_second = Ray3d::new(Vec3::new(5.0, 10.0, 0.0), Dir3::NEG_Y);
    assert_eq!(cast(&app, over_second).unwrap().entity, second);
    assert_eq!(cast(&app, down).unwrap().entity, e);
    // An edit of the shared asset reaches both.
    app.world_mut()
        .resource_mut::<Assets<Mesh>>()
        .insert(handle.id(), Cuboid::new(1.0, 6.0, 1.0).mesh().build())
        .unwrap();
    settle(&mut app);
    for (ray, who) in [(down, e), (over_second, second)] {
        let hit = cast(&app, ray).unwrap();
        assert_eq!(hit.entity, who);
        assert!((hit.point.y - 3.0).abs() < 1e-4, "{hit:?}");
    }
    assert_eq!(tree_triangles(&app), 12);
    // The first entity goes; the second keeps the triangles, then takes them along.
    app.world_mut().despawn(e);
    settle(&mut app);
    assert!(cast(&app, down).is_none());
    assert_eq!(cast(&app, over_second).unwrap().entity, second);
    assert_eq!(tree_triangles(&app), 12);
    app.world_mut().despawn(second);
    settle(&mut app);
    assert_eq!(tree_triangles(&app), 0);
    app.world()
        .resource::<SceneBvh>()
        .read_blocking()
        .bvh
        .validate()
        .unwrap();
}

#[test]
fn big_meshes_are_copied_over_several_frames() {
    // No main-thread budget: one chunk of triangles per frame.
    let mut app = headless_app(SceneBvhConfig {
        main_thread_budget: Duration::ZERO,
        main_thread_share: 0.0,
        ..default()
    });
    let sphere = Sphere::new(1.0).mesh().uv(200, 100);
    let triangles = mesh_triangles(&sphere).unwrap().len() as u32;
    assert!(triangles > 30_000, "{triangles}");
    let handle = app.world_mut().resource_mut::<Assets<Mesh>>().add(sphere);
    let kept = app
        .world_mut()
        .spawn((Mesh3d(handle.clone()), Transform::default()))
        .id();
    let dropped = app
        .world_mut()
        .spawn((Mesh3d(handle), Transform::from_xyz(0.0, 0.0, 5.0)))
        .id();
    app.update();
    app.update();
    let scene = app.world().resource::<SceneBvh>();
    assert!(!scene.is_idle() && scene.stats().pending >= 1);
    assert!(scene.is_filling(), "a mesh being copied is on its way");
    assert_eq!(tree_triangles(&app), 0, "still copying after two frames");
    // Moved and despawned while their triangles are still being copied.
    app.world_mut()
        .get_mut::<Transform>(kept)
        .unwrap()
        .translation = Vec3::new(5.0, 0.0, 0.0);
    app.world_mut().despawn(dropped);
    settle(&mut app);
    assert!(!app.world().resource::<SceneBvh>().is_filling());
    assert_eq!(tree_triangles(&app), triangles, "only the kept sphere");
    // A move brings no geometry: not filling, while it is still on its way or after.
    app.world_mut()
        .get_mut::<Transform>(kept)
        .unwrap()
        .translation = Vec3::new(6.0, 0.0, 0.0);
    for _ in 0..3 {
        app.update();
        assert!(!app.world().resource::<SceneBvh>().is_filling());
    }
    settle(&mut app);
    app.world_mut()
        .get_mut::<Transform>(kept)
        .unwrap()
        .translation = Vec3::new(5.0, 0.0, 0.0);
    settle(&mut app);
    let down = |x: f32, z: f32| Ray3d::new(Vec3::new(x, 10.0, z), Dir3::NEG_Y);
    let hit = cast(&app, down(5.0, 0.0)).expect("the sphere where it was moved to");
    assert_eq!(hit.entity, kept);
    assert!((hit.point.y - 1.0).abs() < 1e-3);
    assert!(
        cast(&app, down(0.0, 0.0)).is_none(),
        "nothing where it started"
    );
    assert!(
        cast(&app, down(0.0, 5.0)).is_none(),
        "nothing of the despawned one"
    );
}

/// A fill grows the tree's arrays by doubling; once the worker has nothing left to do it gives the
/// room back, and the published figures say so.
#[test]
fn a_tree_at_rest_after_a_fill_gives_back_its_spare_room() {
    let mut app = app(Duration::from_millis(50));
    for k in 0..24 {
        let sphere = Sphere::new(1.0).mesh().uv(200, 100);
        let handle = app.world_mut().resource_mut::<Assets<Mesh>>().add(sphere);
        app.world_mut().spawn((
            Mesh3d(handle),
            Transform::from_xyz(3.0 * k as f32, 0.0, 0.0),
        ));
        // Meshes arriving frame by frame, as an import's do.
        app.update();
    }
    settle(&mut app);
    let start = Instant::now();
    while !app.world().resource::<SceneBvh>().is_resting() {
        assert!(start.elapsed() < Duration::from_secs(60), "never at rest");
        app.update();
        std::thread::sleep(Duration::from_millis(5));
    }
    // The main world copies the worker's figures in its frame.
    app.update();
    let scene = app.world().resource::<SceneBvh>();
    assert!(scene.is_resting());
    let tree = scene.try_read().expect("the worker sleeps");
    let (spare, held) = (tree.bvh.spare_bytes(), tree.bvh.memory_bytes().total());
    assert!(tree.bvh.triangle_count() > 900_000);
    assert!(spare * 8 < held, "{spare} spare bytes of {held}");
    assert_eq!(
        scene.stats().tree_bytes,
        held,
        "the figures say what it holds"
    );
}

#[test]
fn geometry_handed_over_goes_to_the_worker_at_once_and_only_for_its_own_asset() {
    // No main-thread budget: a copied mesh would take many frames.
    let mut app = headless_app(SceneBvhConfig {
        main_thread_budget: Duration::ZERO,
        main_thread_share: 0.0,
        ..default()
    });
    let add = |app: &mut App, mesh: Mesh| app.world_mut().resource_mut::<Assets<Mesh>>().add(mesh);
    let sphere = Sphere::new(1.0).mesh().uv(200, 100);
    let made = || treelight_scene::GeometryCopy::whole(&sphere).unwrap();
    let triangles = mesh_triangles(&sphere).unwrap().len() as u32;
    let handle = add(&mut app, sphere.clone());
    let prepare = |app: &mut App, mesh: &Handle<Mesh>, geometry| {
        app.world_mut()
            .resource_mut::<SceneBvh>()
            .prepare(mesh.id(), geometry)
    };
    prepare(&mut app, &handle, made());
    for x in [0.0, 3.0] {
        app.world_mut()
            .spawn((Mesh3d(handle.clone()), Transform::from_xyz(x, 0.0, 0.0)));
    }
    app.update();
    assert_eq!(
        app.world().resource::<SceneBvh>().meshes_handed_over(),
        1,
        "sent in the first frame, with no copy; the second entity shares it"
    );
    settle(&mut app);
    assert_eq!(tree_triangles(&app), triangles, "one copy, two instances");
    check(&mut app, &rays(300, 11));

    // Geometry that is not the asset's (another triangle count) is ignored: the asset is copied.
    let cube = add(&mut app, Cuboid::new(1.0, 2.0, 1.0).mesh().build());
    prepare(&mut app, &cube, made());
    app.world_mut()
        .spawn((Mesh3d(cube), Transform::from_xyz(-3.0, 0.0, 0.0)));
    settle(&mut app);
    assert_eq!(tree_triangles(&app), triangles + 12);
    // Geometry handed over before its asset was modified is of the old version: dropped.
    let ring = Torus::new(0.5, 1.0).mesh().build();
    let ring_triangles = mesh_triangles(&ring).unwrap().len() as u32;
    let old = treelight_scene::GeometryCopy::whole(&ring).unwrap();
    let torus = add(&mut app, ring.clone());
    prepare(&mut app, &torus, old);
    app.update();
    // The same triangle count, elsewhere: only rays can tell the versions apart.
    *app.world_mut()
        .resource_mut::<Assets<Mesh>>()
        .get_mut(&torus)
        .unwrap() = ring.translated_by(Vec3::new(0.0, 0.0, 6.0));
    app.world_mut()
        .spawn((Mesh3d(torus), Transform::from_xyz(0.0, -6.0, 0.0)));
    settle(&mut app);
    assert_eq!(tree_triangles(&app), triangles + 12 + ring_triangles);
    assert_eq!(app.world().resource::<SceneBvh>().meshes_handed_over(), 1);
    check(&mut app, &rays(300, 12));
}

#[test]
fn released_meshes_are_traced_from_the_tree_alone() {
    let mut app = headless_app(SceneBvhConfig {
        release_traced_meshes: true,
        ..default()
    });
    let sphere = Sphere::new(1.0).mesh().uv(40, 20);
    let ring = Torus::new(0.5, 1.0).mesh().build();
    let add = |app: &mut App, mesh: &Mesh| {
        app.world_mut()
            .resource_mut::<Assets<Mesh>>()
            .add(mesh.clone())
    };
    let (ball, torus) = (add(&mut app, &sphere), add(&mut app, &ring));
    // What each entity shows, kept here: the world's assets lose their vertices.
    fn place(app: &mut App, handle: &Handle<Mesh>, at: Vec3) -> (Entity, Affine3A) {
        let e = app
            .world_mut()
            .spawn((Mesh3d(handle.clone()), Transform::from_translation(at)))
            .id();
        (e, Affine3A::from_translation(at))
    }
    let mut placed: Vec<(Entity, &Mesh, Affine3A)> = Vec::new();
    for (handle, mesh, at) in [
        (&ball, &sphere, Vec3::ZERO),
        (&ball, &sphere, Vec3::new(3.0, 0.0, 0.0)),
        (&torus, &ring, Vec3::new(-3.0, 1.0, 0.0)),
    ] {
        let (e, xf) = place(&mut app, handle, at);
        placed.push((e, mesh, xf));
    }
    settle(&mut app);
    assert_eq!(
        app.world().resource::<SceneBvh>().meshes_released(),
        2,
        "each mesh freed once, after its one copy"
    );
    for handle in [&ball, &torus] {
        let meshes = app.world().resource::<Assets<Mesh>>();
        let mesh = meshes.get(handle).unwrap();
        assert!(
            mesh.try_indices().is_err() && mesh.try_attribute(Mesh::ATTRIBUTE_POSITION).is_err(),
            "the asset's vertex data is freed"
        );
        assert!(mesh.final_aabb.is_some(), "the asset keeps its bounds");
    }
    let sphere_triangles = mesh_triangles(&sphere).unwrap().len() as u32;
    let ring_triangles = mesh_triangles(&ring).unwrap().len() as u32;
    assert_eq!(tree_triangles(&app), sphere_triangles + ring_triangles);
    check_against(&mut app, &rays(300, 21), |_, ray| {
        closest_hit(placed.iter().copied(), ray)
    });
    // A later entity of a freed mesh shares the triangles already in the tree.
    let (e, xf) = place(&mut app, &ball, Vec3::new(0.0, -3.0, 2.0));
    placed.push((e, &sphere, xf));
    settle(&mut app);
    assert_eq!(tree_triangles(&app), sphere_triangles + ring_triangles);
    check_against(&mut app, &rays(300, 22), |_, ray| {
        closest_hit(placed.iter().copied(), ray)
    });

    // Without the setting, the assets keep their data.
    let mut kept = headless_app(SceneBvhConfig::default());
    let handle = add(&mut kept, &sphere);
    kept.world_mut()
        .spawn((Mesh3d(handle.clone()), Transform::default()));
    settle(&mut kept);
    assert_eq!(tree_triangles(&kept), sphere_triangles);
    let meshes = kept.world().resource::<Assets<Mesh>>();
    assert!(meshes.get(&handle).unwrap().try_indices().is_ok());
    assert_eq!(kept.world().resource::<SceneBvh>().meshes_released(), 0);
}

#[test]
fn a_mesh_component_marked_changed_with_nothing_new_is_not_sent_again() {
    // Bevy marks `Mesh3d` changed when the entity's material changes (or its material asset
    // loads): the geometry is what the worker holds. Sent again, a released mesh could not be
    // traced (its vertices are gone); a move in the same frame still goes as a move.
    let mut app = headless_app(SceneBvhConfig {
        release_traced_meshes: true,
        ..default()
    });
    let sphere = Sphere::new(1.0).mesh().uv(16, 8);
    let handle = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(sphere.clone());
    let e = app
        .world_mut()
        .spawn((Mesh3d(handle), Transform::default()))
        .id();
    settle(&mut app);
    let triangles = mesh_triangles(&sphere).unwrap().len() as u32;
    assert_eq!(tree_triangles(&app), triangles);
    for round in 0..3 {
        let mut entity = app.world_mut().entity_mut(e);
        entity.get_mut::<Mesh3d>().unwrap().set_changed();
        if round == 1 {
            entity.get_mut::<Transform>().unwrap().translation = Vec3::new(4.0, 0.0, 0.0);
        }
        settle(&mut app);
        assert_eq!(tree_triangles(&app), triangles, "round {round}");
    }
    let placed = [(
        e,
        &sphere,
        Affine3A::from_translation(Vec3::new(4.0, 0.0, 0.0)),
    )];
    check_against(&mut app, &rays(200, 41), |_, ray| {
        closest_hit(placed.iter().copied(), ray)
    });
}

/// Every attribute's bytes and the indices of `mesh`, to compare meshes exactly.
fn mesh_bytes(mesh: &Mesh) -> (Vec<Vec<u8>>, Option<Vec<usize>>) {
    let attributes = mesh
        .try_attributes()
        .map(|a| a.map(|(_, v)| v.get_bytes().to_vec()).collect())
        .unwrap_or_default();
    let indices = mesh.try_indices().ok().map(|i| i.iter().collect());
    (attributes, indices)
}

#[test]
fn parked_meshes_come_back_whole_whenever_they_are_read_again() {
    let mut app = headless_app(SceneBvhConfig {
        park_meshes: true,
        ..default()
    });
    // Only the main world keeps the sphere (as the path tracer leaves a mesh while every camera
    // traces); the torus is the render world's too, so it is never parked.
    let mut sphere = Sphere::new(1.0).mesh().uv(40, 20);
    sphere.asset_usage = bevy::asset::RenderAssetUsages::MAIN_WORLD;
    let ring = Torus::new(0.5, 1.0).mesh().build();
    let ball = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(sphere.clone());
    let torus = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(ring.clone());
    let mut placed: Vec<(Entity, &Mesh, Affine3A)> = Vec::new();
    for (handle, mesh, at) in [
        (&ball, &sphere, Vec3::ZERO),
        (&ball, &sphere, Vec3::new(3.0, 0.0, 0.0)),
        (&torus, &ring, Vec3::new(-3.0, 1.0, 0.0)),
    ] {
        let e = app
            .world_mut()
            .spawn((Mesh3d(handle.clone()), Transform::from_translation(at)))
            .id();
        placed.push((e, mesh, Affine3A::from_translation(at)));
    }
    settle(&mut app);
    let parked = |app: &App, h: &Handle<Mesh>| app.world().resource::<SceneBvh>().is_parked(h.id());
    assert!(parked(&app, &ball) && !parked(&app, &torus));
    let (count, bytes) = app.world().resource::<SceneBvh>().parked_figures();
    let full = mesh_bytes(&sphere).0.iter().map(Vec::len).sum::<usize>();
    assert!(count == 1 && bytes > 0 && bytes < full, "{bytes} of {full}");
    {
        let meshes = app.world().resource::<Assets<Mesh>>();
        let asset = meshes.get(&ball).unwrap();
        assert!(
            asset.try_indices().is_err(),
            "the vertices are out of the asset"
        );
        assert!(asset.final_aabb.is_some(), "the asset keeps its bounds");
        assert_eq!(mesh_bytes(meshes.get(&torus).unwrap()), mesh_bytes(&ring));
    }
    let sphere_triangles = mesh_triangles(&sphere).unwrap().len() as u32;
    let ring_triangles = mesh_triangles(&ring).unwrap().len() as u32;
    assert_eq!(tree_triangles(&app), sphere_triangles + ring_triangles);
    check_against(&mut app, &rays(300, 31), |_, ray| {
        closest_hit(placed.iter().copied(), ray)
    });

    // Both balls out of the tree, then one back: its vertices are read again, and parked again.
    let balls = [placed[0].0, placed[1].0];
    for e in balls {
        app.world_mut().entity_mut(e).insert(NotTraced);
    }
    settle(&mut app);
    assert_eq!(tree_triangles(&app), ring_triangles);
    app.world_mut().entity_mut(balls[1]).remove::<NotTraced>();
    settle(&mut app);
    assert!(parked(&app, &ball));
    assert_eq!(tree_triangles(&app), sphere_triangles + ring_triangles);
    let shown: Vec<_> = placed.iter().copied().filter(|p| p.0 != balls[0]).collect();
    check_against(&mut app, &rays(300, 32), |_, ray| {
        closest_hit(shown.iter().copied(), ray)
    });

    // Put back for a reader: exactly the mesh that was added.
    app.world_mut()
        .resource_scope(|world, mut meshes: Mut<Assets<Mesh>>| {
            world
                .resource_mut::<SceneBvh>()
                .restore_parked_mesh(ball.id(), &mut meshes);
        });
    assert!(!parked(&app, &ball));
    let meshes = app.world().resource::<Assets<Mesh>>();
    assert_eq!(mesh_bytes(meshes.get(&ball).unwrap()), mesh_bytes(&sphere));
    assert_eq!(meshes.get(&ball).unwrap().final_aabb, sphere.final_aabb);

    // Parked again once looked at; then replaced by new geometry, which wins.
    app.world_mut()
        .resource_mut::<SceneBvh>()
        .park_mesh_later(ball.id());
    app.update();
    assert!(parked(&app, &ball));
    let mut cube = Cuboid::new(1.0, 2.0, 3.0).mesh().build();
    cube.asset_usage = bevy::asset::RenderAssetUsages::MAIN_WORLD;
    app.world_mut()
        .resource_mut::<Assets<Mesh>>()
        .insert(ball.id(), cube.clone())
        .unwrap();
    settle(&mut app);
    for p in &mut placed[..2] {
        p.1 = &cube;
    }
    let shown: Vec<_> = placed.iter().copied().filter(|p| p.0 != balls[0]).collect();
    check_against(&mut app, &rays(300, 33), |_, ray| {
        closest_hit(shown.iter().copied(), ray)
    });
    let cube_triangles = mesh_triangles(&cube).unwrap().len() as u32;
    assert_eq!(tree_triangles(&app), cube_triangles + ring_triangles);
    app.world_mut()
        .resource_scope(|world, mut meshes: Mut<Assets<Mesh>>| {
            world
                .resource_mut::<SceneBvh>()
                .restore_parked_mesh(ball.id(), &mut meshes);
        });
    let meshes = app.world().resource::<Assets<Mesh>>();
    assert_eq!(mesh_bytes(meshes.get(&ball).unwrap()), mesh_bytes(&cube));
}

#[test]
fn meshes_that_are_not_triangle_lists_are_skipped() {
    let mut app = app(Duration::from_millis(20));
    let lines = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Mesh::new(
            bevy::mesh::PrimitiveTopology::LineList,
            Default::default(),
        ));
    app.world_mut()
        .spawn((Mesh3d(lines), Transform::default(), Name::new("wireframe")));
    settle(&mut app);
    assert_eq!(tree_triangles(&app), 0);
}

#[test]
fn filtered_rays_see_through_rejected_entities() {
    let mut app = app(Duration::from_millis(20));
    let cube = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::new(1.0, 1.0, 1.0).mesh().build());
    let front = app
        .world_mut()
        .spawn((Mesh3d(cube.clone()), Transform::from_xyz(0.0, 0.0, -3.0)))
        .id();
    let back = app
        .world_mut()
        .spawn((Mesh3d(cube), Transform::from_xyz(0.0, 0.0, -6.0)))
        .id();
    settle(&mut app);
    let scene = app.world().resource::<SceneBvh>();
    let ray = Ray3d::new(Vec3::ZERO, Dir3::NEG_Z);
    let hit = scene.cast_ray(ray).expect("the front cube is hit");
    assert_eq!(hit.entity, front);
    assert!((hit.distance - 2.5).abs() < 1e-4, "{}", hit.distance);
    let hit = scene
        .cast_ray_filtered(ray, |e| e != front)
        .expect("the back cube is hit through the front one");
    assert_eq!(hit.entity, back);
    assert!((hit.distance - 5.5).abs() < 1e-3, "{}", hit.distance);
    assert!((hit.point - Vec3::new(0.0, 0.0, -5.5)).length() < 1e-3);
    assert!(scene.cast_ray_filtered(ray, |_| false).is_none());
}

#[test]
fn filtered_rays_find_a_surface_that_touches_a_rejected_one() {
    // A box resting on a floor: the box's bottom face and the floor's top lie in one plane. Seeing
    // through the box must find the floor's top there, not its underside (the placement of an object
    // dragged over the floor depends on it), whichever of the two the tree reaches first.
    let mut app = app(Duration::from_millis(20));
    let (floor, resting) = {
        let mut meshes = app.world_mut().resource_mut::<Assets<Mesh>>();
        (
            meshes.add(Cuboid::new(10.0, 0.1, 10.0).mesh().build()),
            meshes.add(Cuboid::new(1.0, 1.0, 1.0).mesh().build()),
        )
    };
    let floor = app
        .world_mut()
        .spawn((Mesh3d(floor), Transform::from_xyz(0.0, -0.05, 0.0)))
        .id();
    let resting = app
        .world_mut()
        .spawn((Mesh3d(resting), Transform::from_xyz(0.0, 0.5, 0.0)))
        .id();
    settle(&mut app);
    assert_eq!(tree_triangles(&app), 24, "both traced");
    let scene = app.world().resource::<SceneBvh>();
    for k in 0..25 {
        let at = Vec3::new(-0.65 + 0.0325 * k as f32, 3.0, 0.3);
        let ray = Ray3d::new(at, Dir3::new(Vec3::new(0.1, -1.0, -0.05)).unwrap());
        let hit = scene.cast_ray(ray).expect("the box");
        assert_eq!(hit.entity, resting, "{hit:?} {ray:?}");
        let hit = scene
            .cast_ray_filtered(ray, |e| e != resting)
            .expect("the floor under the box");
        assert_eq!(hit.entity, floor);
        assert!(
            hit.point.y.abs() < 1e-4,
            "the floor's top, not {}",
            hit.point
        );
    }
}

#[test]
fn not_traced_meshes_stay_out_of_the_tree_until_the_marker_goes() {
    let mut app = app(Duration::from_millis(20));
    let cube = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::new(1.0, 1.0, 1.0).mesh().build());
    let ray = Ray3d::new(Vec3::ZERO, Dir3::NEG_Z);
    // A helper in front of a scene mesh: rays pass through it.
    let helper = app
        .world_mut()
        .spawn((
            Mesh3d(cube.clone()),
            Transform::from_xyz(0.0, 0.0, -3.0),
            NotTraced,
        ))
        .id();
    let scene_mesh = app
        .world_mut()
        .spawn((Mesh3d(cube), Transform::from_xyz(0.0, 0.0, -6.0)))
        .id();
    settle(&mut app);
    assert_eq!(tree_triangles(&app), 12);
    assert_eq!(cast(&app, ray).map(|h| h.entity), Some(scene_mesh));
    // Moving the helper sends nothing.
    app.world_mut()
        .entity_mut(helper)
        .insert(Transform::from_xyz(0.0, 0.0, -2.0));
    settle(&mut app);
    assert_eq!(tree_triangles(&app), 12);
    // Without the marker it is traced where it now stands.
    app.world_mut().entity_mut(helper).remove::<NotTraced>();
    settle(&mut app);
    // Traced as a second placement of the same cube mesh.
    assert_eq!(tree_triangles(&app), 12);
    let traced = |app: &App| {
        app.world()
            .resource::<SceneBvh>()
            .read_blocking()
            .entity_groups
            .len()
    };
    assert_eq!(traced(&app), 2);
    let hit = cast(&app, ray).expect("the helper is hit");
    assert_eq!(hit.entity, helper);
    assert!((hit.distance - 1.5).abs() < 1e-4, "{}", hit.distance);
    // With it again, it leaves the tree.
    app.world_mut().entity_mut(helper).insert(NotTraced);
    settle(&mut app);
    assert_eq!(tree_triangles(&app), 12);
    assert_eq!(traced(&app), 1);
    assert_eq!(cast(&app, ray).map(|h| h.entity), Some(scene_mesh));
}

#[test]
fn meshes_nearest_the_camera_are_traced_first() {
    // The order must hold in every run. That the parts arrive over several frames (not in one
    // batch) depends on the worker keeping up, which a loaded machine (other tests sharing the
    // rayon pool) can prevent: such a run says nothing, and is tried again.
    for attempt in 1..=3 {
        if traced_in_distance_order() {
            return;
        }
        eprintln!("attempt {attempt}: every part arrived in one batch");
    }
    panic!("every part arrived at once in three runs");
}

/// Traces an assembly's parts, asserting that none is traced before a nearer one; returns whether
/// the nearest came strictly before the farthest.
fn traced_in_distance_order() -> bool {
    // One chunk of array elements copied per frame, so the order of the copies shows.
    let mut app = headless_app(SceneBvhConfig {
        main_thread_budget: Duration::ZERO,
        main_thread_share: 0.0,
        ..default()
    });
    app.world_mut()
        .spawn((Camera3d::default(), Transform::from_xyz(0.0, 0.0, 5.0)));
    // Sixteen parts of an assembly (each its own mesh, so nothing is shared), spawned in a
    // scrambled order at distances 7 to 37 from the camera.
    let mut parts: Vec<(Entity, f32)> = Vec::new();
    let mut r = Xorshift(0x51ed);
    let mut slots: Vec<u32> = (0..16).collect();
    for i in (1..slots.len()).rev() {
        slots.swap(i, (r.next_u64() % (i as u64 + 1)) as usize);
    }
    for k in slots {
        let mesh = app
            .world_mut()
            .resource_mut::<Assets<Mesh>>()
            .add(Sphere::new(0.5 + k as f32 * 0.001).mesh().uv(64, 32));
        let z = -2.0 - 2.0 * k as f32;
        let e = app
            .world_mut()
            .spawn((Mesh3d(mesh), Transform::from_xyz(0.0, 0.0, z)))
            .id();
        parts.push((e, 5.0 - z));
    }
    let mut traced_at: Vec<Option<usize>> = vec![None; parts.len()];
    let start = Instant::now();
    for frame in 0.. {
        app.update();
        let scene = app.world().resource::<SceneBvh>();
        let tree = scene.read_blocking();
        for (k, (e, _)) in parts.iter().enumerate() {
            if traced_at[k].is_none() && tree.is_traced(*e) {
                traced_at[k] = Some(frame);
            }
        }
        if traced_at.iter().all(Option::is_some) {
            break;
        }
        assert!(start.elapsed() < Duration::from_secs(60), "never traced");
        // Frames take time in an app: a loop that only spins starves the worker of a core on a
        // two-core machine running other tests, and it then takes in every part at once.
        std::thread::sleep(Duration::from_millis(2));
    }
    let mut by_distance: Vec<(f32, usize)> = parts
        .iter()
        .zip(&traced_at)
        .map(|((_, d), f)| (*d, f.unwrap()))
        .collect();
    by_distance.sort_by(|a, b| a.0.total_cmp(&b.0));
    for w in by_distance.windows(2) {
        assert!(
            w[0].1 <= w[1].1,
            "a part {} away was traced at frame {}, after one {} away at frame {}: {by_distance:?}",
            w[0].0,
            w[0].1,
            w[1].0,
            w[1].1
        );
    }
    // And the nearest really came first, not all at once.
    by_distance[0].1 < by_distance[15].1
}

#[test]
fn an_entity_sent_again_beside_a_new_copy_of_its_mesh_stays_traced() {
    // In one frame a copy of a mesh appears and the original is sent again (its mesh handle set
    // anew): both become instances of the original's triangles, which never lapse in between (the
    // worker's order of the two is covered by the crate's own test of `SceneTree::share`).
    let mut app = app(Duration::from_millis(20));
    let cube = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::new(1.0, 1.0, 1.0).mesh().build());
    let original = app
        .world_mut()
        .spawn((Mesh3d(cube.clone()), Transform::default()))
        .id();
    settle(&mut app);
    let copy = app
        .world_mut()
        .spawn((Mesh3d(cube.clone()), Transform::from_xyz(3.0, 0.0, 0.0)))
        .id();
    app.world_mut()
        .entity_mut(original)
        .insert(Mesh3d(cube.clone()));
    settle(&mut app);
    assert_eq!(tree_triangles(&app), 12);
    let down = |x: f32| Ray3d::new(Vec3::new(x, 10.0, 0.0), Dir3::NEG_Y);
    assert_eq!(cast(&app, down(0.0)).map(|h| h.entity), Some(original));
    assert_eq!(cast(&app, down(3.0)).map(|h| h.entity), Some(copy));
    app.world()
        .resource::<SceneBvh>()
        .read_blocking()
        .bvh
        .validate()
        .unwrap();
}

#[test]
fn a_huge_mesh_enters_the_tree_in_chunks_nearest_the_camera_first() {
    // One mesh: a strip of 40,000 triangles running from just before the camera to 200 away, in
    // chunks of at most 1,000; the triangles are listed far end first, so index order would be the
    // wrong order.
    let mut app = headless_app(SceneBvhConfig {
        chunks: treelight_bvh::PieceRule {
            cut_above: 1_000,
            piece: 1_000,
        },
        ..default()
    });
    app.world_mut()
        .spawn((Camera3d::default(), Transform::from_xyz(0.0, 1.0, 5.0)));
    let quads = 20_000;
    let mut positions: Vec<[f32; 3]> = Vec::with_capacity(quads * 6);
    for k in (0..quads).rev() {
        let (z0, z1) = (-(k as f32) * 0.01, -(k as f32 + 1.0) * 0.01);
        let [a, b, c, d] = [
            [-1.0, 0.0, z0],
            [1.0, 0.0, z0],
            [1.0, 0.0, z1],
            [-1.0, 0.0, z1],
        ];
        positions.extend([a, b, c, a, c, d]);
    }
    let strip = Mesh::new(
        bevy::mesh::PrimitiveTopology::TriangleList,
        bevy::asset::RenderAssetUsages::default(),
    )
    .with_inserted_attribute(Mesh::ATTRIBUTE_POSITION, positions);
    let mesh = app.world_mut().resource_mut::<Assets<Mesh>>().add(strip);
    let e = app
        .world_mut()
        .spawn((Mesh3d(mesh), Transform::default()))
        .id();
    // Rays straight down onto the strip at increasing distances from the camera.
    let probes: Vec<(f32, Ray3d)> = [1.0f32, 40.0, 80.0, 120.0, 160.0, 199.0]
        .iter()
        .map(|&d| (d, Ray3d::new(Vec3::new(0.3, 2.0, -d), Dir3::NEG_Y)))
        .collect();
    let mut first_seen: Vec<Option<usize>> = vec![None; probes.len()];
    let mut look = 0usize;
    let start = Instant::now();
    while first_seen.iter().any(Option::is_none) {
        app.update();
        // Look many times between frames: the worker publishes each chunk as it goes in.
        for _ in 0..50 {
            look += 1;
            let scene = app.world().resource::<SceneBvh>();
            let tree = scene.read_blocking();
            for (k, (_, ray)) in probes.iter().enumerate() {
                if first_seen[k].is_none() && treelight_scene::cast_on(&tree, *ray).is_some() {
                    first_seen[k] = Some(look);
                }
            }
        }
        assert!(start.elapsed() < Duration::from_secs(60), "never traced");
    }
    let seen: Vec<usize> = first_seen.into_iter().map(Option::unwrap).collect();
    assert!(
        seen.windows(2).all(|w| w[0] <= w[1]),
        "a farther part of the strip was traced before a nearer one: {seen:?}"
    );
    assert!(seen[0] < seen[seen.len() - 1], "all at once: {seen:?}");
    settle(&mut app);
    let scene = app.world().resource::<SceneBvh>();
    let tree = scene.read_blocking();
    assert!(tree.groups_of(e).len() >= 40, "{}", tree.groups_of(e).len());
    assert_eq!(tree.bvh.triangle_count(), 40_000);
    tree.bvh.validate().unwrap();
    // Every chunk is the one entity.
    for (_, ray) in &probes {
        assert_eq!(treelight_scene::cast_on(&tree, *ray).unwrap().entity, e);
    }
}

#[test]
fn a_mesh_in_chunks_stays_instances_so_its_first_copy_is_one_node_per_chunk() {
    // A sphere of 960 triangles in chunks of at most 100, still long past `bake_after`, beside a
    // cube that is baked once still.
    let mut app = headless_app(SceneBvhConfig {
        bake_after: Duration::from_millis(20),
        chunks: treelight_bvh::PieceRule {
            cut_above: 100,
            piece: 100,
        },
        ..default()
    });
    let sphere = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Sphere::new(1.0).mesh().uv(24, 20));
    let cube = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::new(1.0, 1.0, 1.0).mesh().build());
    let big = app
        .world_mut()
        .spawn((Mesh3d(sphere.clone()), Transform::default()))
        .id();
    let small = app
        .world_mut()
        .spawn((Mesh3d(cube), Transform::from_xyz(4.0, 0.0, 0.0)))
        .id();
    settle(&mut app);
    // Moved, then still: the cube is baked, the sphere's chunks stay whole.
    for e in [big, small] {
        app.world_mut()
            .get_mut::<Transform>(e)
            .unwrap()
            .translation
            .y += 1.0;
    }
    settle(&mut app);
    std::thread::sleep(Duration::from_millis(200));
    settle(&mut app);
    {
        let scene = app.world().resource::<SceneBvh>();
        let tree = scene.read_blocking();
        let chunks = tree.groups_of(big);
        assert!(chunks.len() >= 4, "{} chunks", chunks.len());
        for &g in chunks {
            assert!(tree.bvh.is_group_whole(g).unwrap(), "a chunk was baked");
        }
        for &g in tree.groups_of(small) {
            assert!(
                !tree.bvh.is_group_whole(g).unwrap(),
                "the cube was not baked"
            );
        }
    }
    // A copy shares the chunks' triangles: the tree's triangle count does not change, and a ray
    // finds the copy where it stands.
    let before = app
        .world()
        .resource::<SceneBvh>()
        .read_blocking()
        .bvh
        .triangle_count();
    let copy = app
        .world_mut()
        .spawn((Mesh3d(sphere), Transform::from_xyz(0.0, 0.0, -6.0)))
        .id();
    settle(&mut app);
    let scene = app.world().resource::<SceneBvh>();
    let tree = scene.read_blocking();
    assert_eq!(tree.bvh.triangle_count(), before);
    tree.bvh.validate().unwrap();
    let down = Ray3d::new(Vec3::new(0.0, 5.0, -6.0), Dir3::NEG_Y);
    assert_eq!(treelight_scene::cast_on(&tree, down).unwrap().entity, copy);
}

#[test]
fn a_still_mesh_is_rebuilt_by_full_sweep_in_idle_time_and_traces_the_same() {
    let mut app = app(Duration::from_millis(20));
    // A sphere of about 4,500 triangles (worth a rebuild) beside a cube (too small for one).
    let (sphere, cube) = {
        let mut meshes = app.world_mut().resource_mut::<Assets<Mesh>>();
        (
            meshes.add(Sphere::new(4.0).mesh().uv(72, 32)),
            meshes.add(Cuboid::new(2.0, 2.0, 2.0).mesh().build()),
        )
    };
    let big = app
        .world_mut()
        .spawn((Mesh3d(sphere), Transform::from_xyz(1.0, 2.0, 0.0)))
        .id();
    let small = app
        .world_mut()
        .spawn((Mesh3d(cube), Transform::from_xyz(-8.0, 0.0, 0.0)))
        .id();
    settle(&mut app);
    let groups = |app: &App, e: Entity| {
        app.world()
            .resource::<SceneBvh>()
            .read_blocking()
            .groups_of(e)
            .to_vec()
    };
    let cube_group = groups(&app, small);
    let first = groups(&app, big);
    // What a renderer would take from here on: (whether a hit may have changed, re-laid groups).
    let take = |app: &App| {
        let scene = app.world().resource::<SceneBvh>();
        loop {
            let taken = scene.try_take_changes(false, |_, c| {
                (c.bvh.geometry_changed(), c.relaid_groups.clone())
            });
            if let Some(t) = taken {
                return t;
            }
            std::thread::sleep(Duration::from_millis(1));
        }
    };
    take(&app);
    let mut relaid = Vec::new();
    let refined = |app: &App| app.world().resource::<SceneBvh>().stats().meshes_refined;
    let start = Instant::now();
    while refined(&app) == 0 {
        app.update();
        let (changed, r) = take(&app);
        // The bakes and the rebuild lay the same triangles out anew: no hit changes, so a
        // renderer keeps its accumulated image.
        assert!(!changed, "a bake or a rebuild counted as an edit");
        relaid.extend(r);
        assert!(start.elapsed() < Duration::from_secs(30), "never rebuilt");
        std::thread::sleep(Duration::from_millis(5));
    }
    let rebuilt = groups(&app, big);
    settle(&mut app);
    let (changed, r) = take(&app);
    assert!(!changed);
    relaid.extend(r);
    assert_eq!(
        relaid,
        vec![(rebuilt[0], first[0])],
        "the rebuilt group, with the one it replaced"
    );
    assert_eq!(rebuilt.len(), 1, "still one group");
    assert_eq!(groups(&app, small), cube_group, "the cube is left as built");
    {
        let scene = app.world().resource::<SceneBvh>();
        let tree = scene.read_blocking();
        let g = rebuilt[0];
        assert_eq!(tree.bvh.is_group_whole(g), Ok(false), "baked");
        let n = tree.bvh.group_triangles(g).unwrap().len();
        assert!(n >= 4096, "{n} triangles");
        assert_eq!(tree.shading[&g].len(), n, "its shading came along");
        assert!(tree.shading[&g].normals(n - 1).is_some());
        tree.bvh.validate().unwrap();
    }
    check(&mut app, &rays(100, 0x5eed));
    // It still moves like any mesh; baked again once still, it is not rebuilt again.
    app.world_mut()
        .entity_mut(big)
        .insert(Transform::from_xyz(3.0, -1.0, 0.0).with_rotation(Quat::from_rotation_y(0.4)));
    settle(&mut app);
    assert!(take(&app).0, "a move is an edit");
    check(&mut app, &rays(100, 0x5eed));
    std::thread::sleep(Duration::from_millis(200));
    settle(&mut app);
    assert_eq!(groups(&app, big), rebuilt);
    assert_eq!(refined(&app), 1);
    check(&mut app, &rays(100, 0x5eed));
}

/// While meshes are still being copied to the worker (an import streaming in), its idle work
/// waits: a still mesh is neither baked nor rebuilt until the copies are done, so the builds of
/// the new meshes keep the cores.
#[test]
fn idle_rebuilds_wait_while_meshes_are_being_copied() {
    // No main-thread budget: a big mesh takes a frame per chunk to copy, and none without frames.
    let mut app = headless_app(SceneBvhConfig {
        bake_after: Duration::from_millis(300),
        main_thread_budget: Duration::ZERO,
        main_thread_share: 0.0,
        ..default()
    });
    let (sphere, big) = {
        let mut meshes = app.world_mut().resource_mut::<Assets<Mesh>>();
        (
            meshes.add(Sphere::new(4.0).mesh().uv(72, 32)),
            meshes.add(Sphere::new(1.0).mesh().uv(200, 100)),
        )
    };
    app.world_mut()
        .spawn((Mesh3d(sphere), Transform::from_xyz(1.0, 2.0, 0.0)));
    settle(&mut app);
    let refined = |app: &App| app.world().resource::<SceneBvh>().stats().meshes_refined;
    assert_eq!(refined(&app), 0, "too soon for a rebuild");
    // A big mesh starts copying; no frames run for a while, so its copy stays under way.
    app.world_mut()
        .spawn((Mesh3d(big), Transform::from_xyz(0.0, 0.0, 9.0)));
    app.update();
    app.update();
    assert!(app.world().resource::<SceneBvh>().is_filling());
    // Long enough for the sphere to be baked (0.3 s still), rebuilt (0.3 s after the last edit)
    // and swapped in several times over, were the worker idle.
    std::thread::sleep(Duration::from_millis(2000));
    app.update();
    assert_eq!(refined(&app), 0, "rebuilt while a mesh was being copied");
    // Once the copy is done, the idle work runs.
    settle(&mut app);
    let start = Instant::now();
    while refined(&app) == 0 {
        app.update();
        assert!(start.elapsed() < Duration::from_secs(30), "never rebuilt");
        std::thread::sleep(Duration::from_millis(5));
    }
}

#[test]
fn a_crashed_worker_is_reported_and_the_app_goes_on() {
    let mut app = app(Duration::from_millis(50));
    let mesh = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::new(1.0, 1.0, 1.0));
    app.world_mut()
        .spawn((Mesh3d(mesh.clone()), Transform::default()));
    settle(&mut app);
    assert_eq!(tree_triangles(&app), 12);
    assert_eq!(app.world().resource::<SceneBvh>().worker_failure(), None);
    app.world().resource::<SceneBvh>().crash_worker_for_tests();
    let start = Instant::now();
    let why = loop {
        app.update();
        if let Some(why) = app.world().resource::<SceneBvh>().worker_failure() {
            break why;
        }
        assert!(
            start.elapsed() < Duration::from_secs(30),
            "no failure reported"
        );
        std::thread::sleep(Duration::from_millis(2));
    };
    assert!(why.contains("asked to crash"), "{why}");
    // The app keeps running frames and taking edits; the tree it had still answers rays.
    app.world_mut()
        .spawn((Mesh3d(mesh), Transform::from_xyz(3.0, 0.0, 0.0)));
    for _ in 0..10 {
        app.update();
    }
    let down = Ray3d::new(Vec3::new(0.0, 5.0, 0.0), Dir3::NEG_Y);
    assert!(cast(&app, down).is_some());
    assert!(!app.world().resource::<SceneBvh>().is_idle());
}

/// A mesh placed at two entities, the first scaled to zero (how exporters hide a node): the
/// visible one is traced whichever comes first, and either is traced again once it can be.
#[test]
fn a_zero_scaled_entity_never_takes_its_mesh_from_the_others() {
    let mut app = app(Duration::from_secs(3600));
    let mesh = app
        .world_mut()
        .resource_mut::<Assets<Mesh>>()
        .add(Cuboid::default().mesh().build());
    let hidden = app
        .world_mut()
        .spawn((Mesh3d(mesh.clone()), Transform::from_scale(Vec3::ZERO)))
        .id();
    let shown = app
        .world_mut()
        .spawn((Mesh3d(mesh), Transform::from_xyz(3.0, 0.0, 0.0)))
        .id();
    settle(&mut app);
    let traced = |app: &App, e: Entity| {
        app.world()
            .resource::<SceneBvh>()
            .read_blocking()
            .is_traced(e)
    };
    assert!(traced(&app, shown), "the visible entity lost its mesh");
    assert!(!traced(&app, hidden));
    assert_eq!(tree_triangles(&app), 12);
    // Scaled up, the hidden one is traced too; the other scaled to zero leaves the tree.
    app.world_mut()
        .entity_mut(hidden)
        .insert(Transform::from_xyz(-3.0, 0.0, 0.0));
    settle(&mut app);
    assert!(traced(&app, hidden) && traced(&app, shown));
    app.world_mut()
        .entity_mut(shown)
        .insert(Transform::from_scale(Vec3::new(1.0, 0.0, 1.0)));
    settle(&mut app);
    assert!(traced(&app, hidden) && !traced(&app, shown));
    let ray = Ray3d::new(Vec3::new(-3.0, 0.0, 5.0), Dir3::NEG_Z);
    let hit = app.world().resource::<SceneBvh>().cast_ray(ray);
    assert_eq!(hit.map(|h| h.entity), Some(hidden));
}
