//! Imports without a window: each request is its own job, named by its root's id from the request
//! to the tree, so imports opened in the same frame (two of one file, one of another) are all made
//! and all followed into the tree; files without lights get one default sun, and a notice says so.

use bevy::prelude::*;
use std::path::Path;
use treelight_document::import::jobs::TracingImports;
use treelight_document::import::parse::PendingImports;
use treelight_document::scene::notice::Notices;

#[test]
fn imports_opened_in_one_frame_are_all_made_and_traced() {
    let scenes = treelight_test_support::shared_scene("gltf");
    let file = scenes.join("BoxTextured-glTF/BoxTextured.gltf");
    let other = scenes.join("Box_Draco.glb");
    let mut app = treelight_document::app::headless_app(treelight_scene::SceneBvhConfig::default());
    {
        let mut pending = app.world_mut().resource_mut::<PendingImports>();
        pending.start(file.clone());
        pending.start(file.clone());
        pending.start(other.clone());
    }
    let start = std::time::Instant::now();
    let traced = |app: &App| {
        app.world()
            .resource::<Notices>()
            .0
            .iter()
            .filter(|n| n.text.contains("is in the tree"))
            .count()
    };
    while traced(&app) < 3 {
        assert!(
            start.elapsed().as_secs() < 60,
            "imports traced: {}; following: {}",
            traced(&app),
            app.world().resource::<TracingImports>().jobs.len()
        );
        app.update();
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
    let roots: Vec<String> = app
        .world_mut()
        .query::<(&Name, &treelight_document::values::object::SceneId)>()
        .iter(app.world())
        .filter(|(n, _)| n.as_str() == "BoxTextured.gltf")
        .map(|(_, id)| id.to_string())
        .collect();
    assert_eq!(roots.len(), 2, "{roots:?}");
    assert_eq!(app.world().resource::<TracingImports>().jobs.len(), 0);
    // The files bring no light: the first import added the default sun and said so; the others
    // found it there.
    let suns = app
        .world_mut()
        .query::<(&Name, &DirectionalLight)>()
        .iter(app.world())
        .filter(|(n, l)| {
            n.as_str() == "Sun"
                && l.illuminance == treelight_document::scene::spawn::DEFAULT_SUN_LUX
        })
        .count();
    assert_eq!(suns, 1);
    let said = app
        .world()
        .resource::<Notices>()
        .0
        .iter()
        .filter(|n| n.text.contains("has no lights: added a Sun of 8000 lux"))
        .count();
    assert_eq!(said, 1);
    // The parse made the tree's copy of each new mesh with its asset: the main thread copied
    // none (the second import of the file shares the first one's mesh).
    assert_eq!(
        app.world()
            .resource::<treelight_scene::SceneBvh>()
            .meshes_handed_over(),
        2
    );
    // The two imports of one file show one mesh and one texture, each under a material of its
    // own: the tree holds the box once and the path tracer's array one layer.
    let world = app.world_mut();
    let mut q = world.query::<(
        &treelight_document::scene::spawn::MeshSource,
        &Mesh3d,
        &MeshMaterial3d<StandardMaterial>,
    )>();
    let shown: Vec<_> = q
        .iter(world)
        .filter(|(s, ..)| *s.0.file == *file)
        .map(|(s, m, mat)| (s.0.import, m.0.id(), mat.0.clone()))
        .collect();
    assert_eq!(shown.len(), 2, "{shown:?}");
    assert_ne!(shown[0].0, shown[1].0);
    assert_eq!(shown[0].1, shown[1].1, "the mesh is not shared");
    assert_ne!(shown[0].2.id(), shown[1].2.id(), "the material is shared");
    let materials = world.resource::<Assets<StandardMaterial>>();
    let texture = |m: &Handle<StandardMaterial>| {
        materials
            .get(m)
            .and_then(|m| m.base_color_texture.as_ref())
            .map(Handle::id)
    };
    assert!(texture(&shown[0].2).is_some());
    assert_eq!(
        texture(&shown[0].2),
        texture(&shown[1].2),
        "the texture is not shared"
    );
}

#[test]
fn an_import_past_the_free_memory_waits_for_an_answer_where_the_app_asks() {
    use treelight_document::import::ask::ImportQuestions;
    let helmet = treelight_test_support::shared_scene("gltf/FlightHelmet/FlightHelmet.gltf");
    let mut app = treelight_document::app::headless_app(treelight_scene::SceneBvhConfig::default());
    // 94,722 triangles need tens of MiB once traced; the app says 1 MiB is free.
    app.insert_resource(ImportQuestions {
        ask: true,
        free_memory: Some(1 << 20),
        ..default()
    });
    let meshes = |app: &mut App| {
        app.world_mut()
            .query_filtered::<(), With<Mesh3d>>()
            .iter(app.world())
            .count()
    };
    let wait_for_question = |app: &mut App| {
        let start = std::time::Instant::now();
        while app.world().resource::<ImportQuestions>().waiting.is_empty() {
            assert!(start.elapsed().as_secs() < 60, "never asked");
            app.update();
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        let q = app.world().resource::<ImportQuestions>();
        let held = &q.waiting[0];
        assert_eq!(held.triangles, 94_722);
        assert!(held.needed > held.free, "{} <= {}", held.needed, held.free);
    };
    app.world_mut()
        .resource_mut::<PendingImports>()
        .start(helmet.clone());
    wait_for_question(&mut app);
    // Nothing is imported while it waits, however many frames pass.
    for _ in 0..10 {
        app.update();
    }
    assert_eq!(meshes(&mut app), 0);
    // Cancelled: nothing, and the question is gone.
    app.world_mut()
        .resource_mut::<ImportQuestions>()
        .answers
        .push((helmet.clone(), false));
    for _ in 0..5 {
        app.update();
    }
    assert!(app.world().resource::<ImportQuestions>().waiting.is_empty());
    assert_eq!(meshes(&mut app), 0);
    assert!(
        app.world()
            .resource::<Notices>()
            .0
            .iter()
            .any(|n| n.text.contains("cancelled")),
    );
    // Asked again and answered yes: imported.
    app.world_mut()
        .resource_mut::<PendingImports>()
        .start(helmet.clone());
    wait_for_question(&mut app);
    app.world_mut()
        .resource_mut::<ImportQuestions>()
        .answers
        .push((helmet.clone(), true));
    for _ in 0..5 {
        app.update();
    }
    assert_eq!(meshes(&mut app), 6);
    // An app that does not ask imports it at once.
    let mut quiet =
        treelight_document::app::headless_app(treelight_scene::SceneBvhConfig::default());
    quiet.insert_resource(ImportQuestions {
        free_memory: Some(1 << 20),
        ..default()
    });
    quiet
        .world_mut()
        .resource_mut::<PendingImports>()
        .start(helmet);
    let start = std::time::Instant::now();
    while meshes(&mut quiet) == 0 {
        assert!(start.elapsed().as_secs() < 60, "never imported");
        quiet.update();
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
}

/// The raster view draws normal maps with Bevy's shader, which needs tangents: FlightHelmet's
/// meshes (every material normal-mapped) get the file's own (`TANGENT`), unit length, nearly
/// perpendicular to their normals, with a sign; BoxTextured (no normal map) keeps its vertices as
/// they were.
#[test]
fn normal_mapped_meshes_get_tangents_and_others_do_not() {
    use bevy::mesh::VertexAttributeValues;
    let scenes = treelight_test_support::shared_scene("gltf");
    let import = |file: &Path| {
        let mut app =
            treelight_document::app::headless_app(treelight_scene::SceneBvhConfig::default());
        app.world_mut()
            .resource_mut::<PendingImports>()
            .start(file.to_owned());
        let start = std::time::Instant::now();
        loop {
            app.update();
            let made = app
                .world()
                .resource::<Notices>()
                .0
                .iter()
                .any(|n| n.text.contains("opened"));
            if made {
                break;
            }
            assert!(
                start.elapsed().as_secs() < 60,
                "{} never opened",
                file.display()
            );
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
        app
    };
    let mut helmet = import(&scenes.join("FlightHelmet/FlightHelmet.gltf"));
    let handles: Vec<Handle<Mesh>> = helmet
        .world_mut()
        .query::<&Mesh3d>()
        .iter(helmet.world())
        .map(|m| m.0.clone())
        .collect();
    assert!(!handles.is_empty());
    let file =
        treelight_import::load_scene(&scenes.join("FlightHelmet/FlightHelmet.gltf")).unwrap();
    let assets = helmet.world().resource::<Assets<Mesh>>();
    for h in &handles {
        let mesh = assets.get(h).expect("the mesh asset");
        let Some(VertexAttributeValues::Float32x4(tangents)) =
            mesh.attribute(Mesh::ATTRIBUTE_TANGENT)
        else {
            panic!("a normal-mapped mesh without tangents");
        };
        let Some(VertexAttributeValues::Float32x3(normals)) =
            mesh.attribute(Mesh::ATTRIBUTE_NORMAL)
        else {
            panic!("no normals");
        };
        assert_eq!(tangents.len(), normals.len());
        let Some(VertexAttributeValues::Float32x3(positions)) =
            mesh.attribute(Mesh::ATTRIBUTE_POSITION)
        else {
            panic!("no positions");
        };
        let source = file
            .meshes
            .iter()
            .find(|m| m.geometry.positions == *positions)
            .expect("the file's mesh");
        assert_eq!(
            Some(tangents),
            source.geometry.tangents.as_ref(),
            "not the file's tangents"
        );
        for (t, n) in tangents.iter().zip(normals) {
            let (t3, n3) = (Vec3::new(t[0], t[1], t[2]), Vec3::from(*n).normalize());
            assert!(
                (t3.length() - 1.0).abs() < 1e-4 && t3.dot(n3).abs() < 0.1,
                "{t:?} against the normal {n3}"
            );
            assert!(t[3] == 1.0 || t[3] == -1.0);
        }
    }
    let mut boxed = import(&scenes.join("BoxTextured-glTF/BoxTextured.gltf"));
    let handles: Vec<Handle<Mesh>> = boxed
        .world_mut()
        .query::<&Mesh3d>()
        .iter(boxed.world())
        .map(|m| m.0.clone())
        .collect();
    let assets = boxed.world().resource::<Assets<Mesh>>();
    assert!(!handles.is_empty());
    assert!(handles.iter().all(|h| {
        assets
            .get(h)
            .is_some_and(|m| m.attribute(Mesh::ATTRIBUTE_TANGENT).is_none())
    }));
}

/// A map that reads the second UV set (`TEXCOORD_1`) is drawn through it in the raster view: the
/// Bevy mesh carries the set as `ATTRIBUTE_UV_1` and the material reads the map (here an occlusion
/// map beside a base colour map on set 0) on that channel.
#[test]
fn a_map_on_the_second_uv_set_reads_it_in_the_raster_view() {
    use bevy::mesh::{UvChannel, VertexAttributeValues};
    let (dir, scene, mut app) = spawned_box_textured("uv1", |text| {
        text.replace("\"TEXCOORD_0\": 3", "\"TEXCOORD_0\": 3, \"TEXCOORD_1\": 3")
            .replace(
                "\"name\": \"Texture\"",
                "\"occlusionTexture\": {\"index\": 0, \"texCoord\": 1}, \"name\": \"Texture\"",
            )
    });
    let world = app.world_mut();
    let (mesh, material) = world
        .query::<(&Mesh3d, &MeshMaterial3d<StandardMaterial>)>()
        .iter(world)
        .map(|(m, mat)| (m.0.clone(), mat.0.clone()))
        .next()
        .unwrap();
    let mesh = world.resource::<Assets<Mesh>>().get(&mesh).unwrap();
    let Some(VertexAttributeValues::Float32x2(set1)) = mesh.attribute(Mesh::ATTRIBUTE_UV_1) else {
        panic!("no second UV set");
    };
    assert_eq!(Some(set1), scene.meshes[0].geometry.uvs1.as_ref());
    let material = world
        .resource::<Assets<StandardMaterial>>()
        .get(&material)
        .unwrap();
    assert!(material.base_color_texture.is_some() && material.occlusion_texture.is_some());
    assert_eq!(material.base_color_channel, UvChannel::Uv0);
    assert_eq!(material.occlusion_channel, UvChannel::Uv1);
    std::fs::remove_dir_all(&dir).ok();
}

/// A material whose maps have different `KHR_texture_transform`s keeps each map's for the path
/// tracer (Bevy's material holds the first map's), and a copy made to edit one object's material
/// alone keeps them too.
#[test]
fn maps_with_their_own_texture_transforms_keep_them() {
    use bevy::math::{Affine2, Vec2};
    use treelight_document::edit::command::EditCommand;
    use treelight_document::edit::history::{EditRequest, apply_request};
    use treelight_document::values::map_transforms::MaterialMapTransforms;
    let (dir, scene, mut app) = spawned_box_textured("map-transforms", |text| {
        text.replacen("{", "{\"extensionsUsed\": [\"KHR_texture_transform\"],", 1)
            .replace(
                "\"name\": \"Texture\"",
                "\"occlusionTexture\": {\"index\": 0, \"extensions\": {\"KHR_texture_transform\": \
                 {\"offset\": [0.5, 0.25], \"scale\": [2, 4]}}}, \"name\": \"Texture\"",
            )
    });
    assert!(
        scene
            .warnings
            .iter()
            .any(|w| w.contains("different KHR_texture_transforms")),
        "{:?}",
        scene.warnings
    );
    let world = app.world_mut();
    let (id, material) = world
        .query::<(
            &treelight_document::values::object::SceneId,
            &MeshMaterial3d<StandardMaterial>,
        )>()
        .iter(world)
        .map(|(id, m)| (*id, m.0.id()))
        .next()
        .unwrap();
    let occlusion =
        Affine2::from_scale_angle_translation(Vec2::new(2.0, 4.0), 0.0, Vec2::new(0.5, 0.25));
    let each = world.resource::<MaterialMapTransforms>().0[&material];
    assert_eq!((each[0], each[3]), (Affine2::IDENTITY, occlusion));
    apply_request(
        app.world_mut(),
        EditRequest::Apply {
            command: EditCommand::MakeMaterialUnique { id },
            continuing: false,
        },
    )
    .unwrap();
    app.update();
    let world = app.world_mut();
    let copy = world
        .query::<(
            &treelight_document::values::object::SceneId,
            &MeshMaterial3d<StandardMaterial>,
        )>()
        .iter(world)
        .find(|(i, _)| **i == id)
        .map(|(_, m)| m.0.id())
        .unwrap();
    assert_ne!(copy, material);
    assert_eq!(world.resource::<MaterialMapTransforms>().0[&copy], each);
    std::fs::remove_dir_all(&dir).ok();
}

/// A copy of BoxTextured in a fresh folder (named after `name`), its glTF's text changed by `edit`
/// (which must change it), read and spawned in a headless app: the folder, the scene as read and
/// the app.
fn spawned_box_textured(
    name: &str,
    edit: impl Fn(&str) -> String,
) -> (std::path::PathBuf, treelight_import::ImportedScene, App) {
    let from = treelight_test_support::shared_scene("gltf/BoxTextured-glTF");
    let dir = std::env::temp_dir().join(format!("treelight-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for f in std::fs::read_dir(&from).unwrap() {
        let f = f.unwrap().path();
        std::fs::copy(&f, dir.join(f.file_name().unwrap())).unwrap();
    }
    let file = dir.join("BoxTextured.gltf");
    let text = std::fs::read_to_string(&file).unwrap();
    let edited = edit(&text);
    assert_ne!(edited, text);
    std::fs::write(&file, edited).unwrap();
    let scene = treelight_import::load_scene(&file).unwrap();
    let mut app = treelight_document::app::headless_app(treelight_scene::SceneBvhConfig::default());
    treelight_document::scene::spawn::spawn_scene_in_world(
        app.world_mut(),
        &file,
        &scene,
        &mut Default::default(),
        false,
        &[],
    )
    .unwrap();
    (dir, scene, app)
}
