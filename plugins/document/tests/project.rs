//! Projects on real files: a scene built from FlightHelmet (from `../shared/scenes`) with every kind
//! of edit is saved and opened again in a fresh editor world, which must then hold the same objects
//! (by stable id: names, transforms, parents, visibility, kinds, material values); a project never
//! copies geometry; broken or hostile projects are refused with the file named and the open scene
//! untouched; a missing source still opens and is kept by the next save.

#[path = "support/assembly.rs"]
mod assembly;
#[path = "support/world.rs"]
mod world;

use bevy::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use treelight_document::edit::command::EditCommand;
use treelight_document::edit::command::LightKind;
use treelight_document::edit::command::TransformValue;
use treelight_document::edit::command::{MaterialAlpha, MaterialValue};
use treelight_document::edit::history::EditHistory;
use treelight_document::edit::history::EditRequest;
use treelight_document::edit::history::apply_request;
use treelight_document::project::capture::save_project;
use treelight_document::project::format::PROJECT_VERSION;
use treelight_document::project::format::ProjectError;
use treelight_document::project::format::ProjectState;
use treelight_document::project::format::read_project;
use treelight_document::project::restore::open_project;
use treelight_document::values::light::LightValue;
use treelight_document::values::look::{SceneLook, ToneCurve};
use treelight_document::values::object::SceneId;
use treelight_document::values::primitive::Primitive;
use world::{editor_world, fresh_dir};

fn helmet() -> PathBuf {
    treelight_test_support::shared_scene("gltf/FlightHelmet/FlightHelmet.gltf")
}

fn temp(name: &str) -> PathBuf {
    fresh_dir("project", name)
}

fn apply(app: &mut App, command: EditCommand) {
    apply_request(
        app.world_mut(),
        EditRequest::Apply {
            command,
            continuing: false,
        },
    )
    .unwrap_or_else(|e| panic!("{e}"));
    app.update();
}

#[derive(Debug, PartialEq)]
struct Object {
    name: String,
    parent: Option<SceneId>,
    transform: [i64; 10],
    visible: bool,
    mesh: bool,
    light: Option<LightValue>,
    material: Option<[i64; 9]>,
}

/// Numbers rounded to 1e-4, so a RON round trip of floats compares equal.
fn q(v: f32) -> i64 {
    (v as f64 * 1e4).round() as i64
}

fn state(world: &mut World) -> BTreeMap<SceneId, Object> {
    let ids: BTreeMap<Entity, SceneId> = world
        .query::<(Entity, &SceneId)>()
        .iter(world)
        .map(|(e, i)| (e, *i))
        .collect();
    let materials: BTreeMap<AssetId<StandardMaterial>, MaterialValue> = world
        .resource::<Assets<StandardMaterial>>()
        .iter()
        .map(|(i, m)| (i, MaterialValue::of(m)))
        .collect();
    let mut query = world.query::<(
        &SceneId,
        Option<&Name>,
        &Transform,
        Option<&ChildOf>,
        Option<&Visibility>,
        Has<Mesh3d>,
        EntityRef,
        Option<&MeshMaterial3d<StandardMaterial>>,
    )>();
    query
        .iter(world)
        .map(|(id, name, t, parent, vis, mesh, entity, mat)| {
            let mut transform = [0; 10];
            for (k, v) in t
                .translation
                .to_array()
                .iter()
                .chain(&t.rotation.to_array())
                .chain(&t.scale.to_array())
                .enumerate()
            {
                transform[k] = q(*v);
            }
            let material = mat.and_then(|m| materials.get(&m.0.id())).map(|m| {
                let mut out = [0; 9];
                for (k, v) in m
                    .base_color
                    .iter()
                    .chain(&m.emissive)
                    .chain([&m.metallic, &m.perceptual_roughness])
                    .enumerate()
                {
                    out[k] = q(*v);
                }
                out
            });
            (
                *id,
                Object {
                    name: name.map_or(String::new(), |n| n.as_str().to_owned()),
                    parent: parent.and_then(|p| ids.get(&p.parent()).copied()),
                    transform,
                    visible: vis != Some(&Visibility::Hidden),
                    mesh,
                    light: LightValue::of(&entity),
                    material,
                },
            )
        })
        .collect()
}

fn ids_by_name(app: &mut App) -> BTreeMap<String, SceneId> {
    state(app.world_mut())
        .into_iter()
        .map(|(id, o)| (o.name, id))
        .collect()
}

/// FlightHelmet imported, then changed in every way a project keeps.
fn edited_scene() -> App {
    let mut app = editor_world();
    apply(
        &mut app,
        EditCommand::Import {
            file: helmet(),
            root: None,
            transform: None,
        },
    );
    let named = ids_by_name(&mut app);
    let part = |n: &str| {
        *named
            .iter()
            .find(|(k, _)| k.contains(n))
            .unwrap_or_else(|| panic!("no {n} in {named:?}"))
            .1
    };
    let (lenses, leather, root) = (part("Lenses"), part("Leather"), named["FlightHelmet.gltf"]);
    let t = |x: f32| {
        TransformValue::from(Transform::from_xyz(x, 0.25, -0.5).with_scale(Vec3::splat(0.5)))
    };
    apply(
        &mut app,
        EditCommand::SetTransform {
            id: lenses,
            transform: t(0.3),
        },
    );
    apply(
        &mut app,
        EditCommand::Rename {
            id: lenses,
            name: "Glass".into(),
        },
    );
    apply(
        &mut app,
        EditCommand::SetVisible {
            id: leather,
            visible: false,
        },
    );
    apply(
        &mut app,
        EditCommand::Delete {
            ids: vec![part("Hose")],
        },
    );
    apply(
        &mut app,
        EditCommand::Reparent {
            ids: vec![lenses],
            parent: None,
        },
    );
    let mut m = MaterialValue::of(&StandardMaterial::default());
    m.base_color = [0.1, 0.5, 0.9, 1.0];
    m.emissive = [2.0, 0.0, 0.0];
    m.transmission = Some(0.7);
    m.clearcoat = Some(0.4);
    m.clearcoat_roughness = Some(0.2);
    m.alpha = Some(MaterialAlpha::Mask(0.3));
    apply(&mut app, EditCommand::MakeMaterialUnique { id: lenses });
    apply(
        &mut app,
        EditCommand::SetMaterial {
            id: lenses,
            material: m,
        },
    );
    apply(
        &mut app,
        EditCommand::Duplicate {
            ids: vec![part("Wood")],
            copies: vec![],
        },
    );
    apply(
        &mut app,
        EditCommand::AddPrimitive {
            shape: Primitive::Cylinder,
            transform: t(1.0),
            id: None,
        },
    );
    apply(
        &mut app,
        EditCommand::AddLight {
            kind: LightKind::Point,
            transform: t(2.0),
            id: None,
        },
    );
    // The light made a spot with its own colour, intensity, range and cone.
    let light = ids_by_name(&mut app)["Point light"];
    apply(
        &mut app,
        EditCommand::SetLight {
            id: light,
            light: LightValue {
                kind: LightKind::Spot,
                color: [1.0, 0.5, 0.25],
                intensity: 1234.5,
                shadows: false,
                range: Some(6.5),
                inner_angle: 0.3,
                outer_angle: 0.7,
            },
        },
    );
    apply(
        &mut app,
        EditCommand::Group {
            ids: vec![root],
            name: "Helmet group".into(),
            group: None,
        },
    );
    apply(&mut app, EditCommand::SetLook { look: EDITED_LOOK });
    app
}

/// The look [`edited_scene`] sets.
const EDITED_LOOK: SceneLook = SceneLook {
    exposure: 1.5,
    tone: ToneCurve::Neutral,
    sky: [300.0, 120.0, 40.0],
};

#[test]
fn a_saved_project_opens_as_the_same_scene() {
    let dir = temp("round-trip");
    let path = dir.join("scene.treelight");
    let mut app = edited_scene();
    let before = state(app.world_mut());
    assert!(app.world().resource::<EditHistory>().is_dirty());
    let unsaved = save_project(app.world_mut(), &path).unwrap();
    assert!(unsaved.is_empty(), "{unsaved:?}");
    assert!(!app.world().resource::<EditHistory>().is_dirty(), "saved");
    // Nothing but the project beside it: the temporary file was renamed over it.
    let files: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(files.len(), 1, "{files:?}");
    // No geometry in the file: it is small next to the helmet's data.
    let size = std::fs::metadata(&path).unwrap().len();
    assert!(size < 64 * 1024, "{size} bytes");
    let project = read_project(&path).unwrap();
    assert_eq!(project.sources.len(), 1);
    assert!(!project.deleted.is_empty(), "the deleted hose is recorded");

    let mut fresh = editor_world();
    let report = open_project(fresh.world_mut(), &path).unwrap();
    assert_eq!(report.missing_sources, vec![]);
    assert_eq!(report.missing_nodes, 0);
    fresh.update();
    let after = state(fresh.world_mut());
    assert_eq!(after, before);
    // The open's job made the tree's copy of each of the file's meshes with its asset: the frame
    // copied none of those shown (the hidden one's waits until it is shown; the added primitive
    // is the editor's own).
    let meshes: std::collections::HashSet<_> = fresh
        .world_mut()
        .query_filtered::<(&Mesh3d, &InheritedVisibility), With<treelight_document::scene::spawn::MeshSource>>()
        .iter(fresh.world())
        .filter(|(_, v)| v.get())
        .map(|(m, _)| m.0.id())
        .collect();
    assert!(!meshes.is_empty());
    assert_eq!(
        fresh
            .world()
            .resource::<treelight_scene::SceneBvh>()
            .meshes_handed_over(),
        meshes.len() as u64
    );
    assert_eq!(*fresh.world().resource::<SceneLook>(), EDITED_LOOK);
    assert!(!fresh.world().resource::<EditHistory>().is_dirty());
    // Saving the opened project gives the same file.
    let again = dir.join("again.treelight");
    save_project(fresh.world_mut(), &again).unwrap();
    assert_eq!(read_project(&again).unwrap().objects, project.objects);
    // Byte for byte: the same sources, objects, deletions and camera in the same order.
    assert_eq!(
        std::fs::read_to_string(&again).unwrap(),
        std::fs::read_to_string(&path).unwrap()
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// The project text with the camera's radius made absurd.
fn absurd_radius(text: &str) -> String {
    let at = text.find("radius: ").expect("a camera") + "radius: ".len();
    let end = at + text[at..].find(',').unwrap();
    format!("{}1e38{}", &text[..at], &text[end..])
}

#[test]
fn broken_projects_are_refused_and_the_scene_is_untouched() {
    let dir = temp("broken");
    let mut app = edited_scene();
    let before = state(app.world_mut());
    let good = dir.join("good.treelight");
    save_project(app.world_mut(), &good).unwrap();
    let text = std::fs::read_to_string(&good).unwrap();
    let cases: Vec<(&str, String, &str)> = vec![
        (
            "garbage",
            "this is not RON (".into(),
            "not a Treelight project",
        ),
        (
            "version",
            text.replacen(&format!("version: {PROJECT_VERSION}"), "version: 99", 1),
            "version 99",
        ),
        ("absurd", absurd_radius(&text), "camera is out of range"),
        (
            "exposure",
            text.replacen("exposure: 1.5", "exposure: 1e30", 1),
            "exposure is not finite or beyond",
        ),
        // A folder and a device with a scene file's name: past the extension check, refused as
        // not regular files.
        (
            "dir-source",
            text.replace(
                &helmet().display().to_string(),
                &dir.join("folder.gltf").display().to_string(),
            ),
            "source 0 ('",
        ),
        (
            "device",
            text.replace(
                &helmet().display().to_string(),
                &dir.join("zero.glb").display().to_string(),
            ),
            "source 0 ('",
        ),
    ];
    std::fs::create_dir_all(dir.join("folder.gltf")).unwrap();
    std::os::unix::fs::symlink("/dev/zero", dir.join("zero.glb")).unwrap();
    for (name, body, expect) in cases {
        let path = dir.join(format!("{name}.treelight"));
        std::fs::write(&path, body).unwrap();
        let e = open_project(app.world_mut(), &path).expect_err(name);
        let text = e.to_string();
        assert!(text.contains(&path.display().to_string()), "{name}: {text}");
        assert!(text.contains(expect), "{name}: {text}");
        if name == "dir-source" || name == "device" {
            assert!(text.contains("is not a regular file"), "{name}: {text}");
        }
        assert_eq!(state(app.world_mut()), before, "{name} changed the scene");
    }
    // A directory in place of the project itself.
    let e = open_project(app.world_mut(), &dir).unwrap_err();
    assert!(matches!(e, ProjectError::Io(..)), "{e}");
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn objects_must_form_a_forest_and_ids_stay_in_range() {
    let dir = temp("forest");
    let mut app = edited_scene();
    let before = state(app.world_mut());
    let good = dir.join("good.treelight");
    save_project(app.world_mut(), &good).unwrap();
    let project = read_project(&good).unwrap();
    let ids: Vec<SceneId> = project.objects.iter().map(|o| o.id).collect();
    let (a, b, c) = (ids[0], ids[1], ids[2]);
    let with = |edit: &dyn Fn(&mut treelight_document::project::format::ProjectFile)| {
        let mut p = project.clone();
        edit(&mut p);
        p
    };
    let set_parent =
        |p: &mut treelight_document::project::format::ProjectFile, id: SceneId, parent: SceneId| {
            p.objects.iter_mut().find(|o| o.id == id).unwrap().parent = Some(parent);
        };
    let cases: Vec<(
        &str,
        treelight_document::project::format::ProjectFile,
        String,
    )> = vec![
        (
            "self-parent",
            with(&|p| set_parent(p, a, a)),
            format!("object {} is its own parent", a.0),
        ),
        (
            "missing-parent",
            with(&|p| set_parent(p, a, SceneId(9_999_999))),
            format!(
                "object {} names parent 9999999, which the project does not hold",
                a.0
            ),
        ),
        (
            "cycle",
            with(&|p| {
                set_parent(p, a, b);
                set_parent(p, b, c);
                set_parent(p, c, a);
            }),
            "form a cycle".into(),
        ),
        (
            "huge-id",
            with(&|p| {
                let leaf = p
                    .objects
                    .iter()
                    .position(|o| p.objects.iter().all(|c| c.parent != Some(o.id)))
                    .unwrap();
                p.objects[leaf].id = SceneId(u64::MAX - 1);
            }),
            format!("object id {} is outside the range of ids", u64::MAX - 1),
        ),
    ];
    for (name, body, expect) in cases {
        let path = dir.join(format!("{name}.treelight"));
        let text = ron::ser::to_string_pretty(&body, ron::ser::PrettyConfig::default()).unwrap();
        std::fs::write(&path, text).unwrap();
        let e = open_project(app.world_mut(), &path).expect_err(name);
        let text = e.to_string();
        assert!(text.contains(&path.display().to_string()), "{name}: {text}");
        assert!(text.contains(&expect), "{name}: {text}");
        assert_eq!(state(app.world_mut()), before, "{name} changed the scene");
    }
    // A command naming an id past the range makes nothing, so no project can come of it.
    let e = apply_request(
        app.world_mut(),
        EditRequest::Apply {
            command: EditCommand::AddPrimitive {
                shape: Primitive::Cube,
                transform: TransformValue::from(Transform::IDENTITY),
                id: Some(SceneId(u64::MAX)),
            },
            continuing: false,
        },
    )
    .unwrap_err();
    assert!(e.to_string().contains("outside the range of ids"), "{e}");
    // The largest id in range opens, and the ids given after it stay in range, taken by none.
    let leaf = project
        .objects
        .iter()
        .position(|o| project.objects.iter().all(|c| c.parent != Some(o.id)))
        .unwrap();
    let top = with(&|p| p.objects[leaf].id = SceneId::MAX);
    let path = dir.join("top.treelight");
    let text = ron::ser::to_string_pretty(&top, ron::ser::PrettyConfig::default()).unwrap();
    std::fs::write(&path, text).unwrap();
    let start = std::time::Instant::now();
    open_project(app.world_mut(), &path).unwrap();
    assert!(start.elapsed().as_secs() < 30);
    for _ in 0..3 {
        let fresh = app
            .world_mut()
            .resource_mut::<treelight_document::values::object::SceneIndex>()
            .allocate();
        assert!(fresh.is_valid(), "{fresh}");
        assert!(
            top.objects.iter().all(|o| o.id != fresh),
            "{fresh} is taken"
        );
    }
    // The same with its source gone: the objects it held are kept, not in the scene, and their ids
    // are still never given out.
    let mut kept = top.clone();
    kept.sources = vec![dir.join("gone.gltf")];
    let path = dir.join("kept.treelight");
    let text = ron::ser::to_string_pretty(&kept, ron::ser::PrettyConfig::default()).unwrap();
    std::fs::write(&path, text).unwrap();
    // In a fresh editor, where no earlier scene held those ids.
    let mut app = editor_world();
    let report = open_project(app.world_mut(), &path).unwrap();
    assert_eq!(report.missing_sources.len(), 1);
    for _ in 0..kept.objects.len() + 3 {
        let fresh = app
            .world_mut()
            .resource_mut::<treelight_document::values::object::SceneIndex>()
            .allocate();
        assert!(fresh.is_valid(), "{fresh}");
        assert!(
            kept.objects.iter().all(|o| o.id != fresh),
            "{fresh} is held by a kept object"
        );
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_missing_source_still_opens_and_a_save_keeps_it() {
    let dir = temp("missing");
    // The helmet's files copied next to the project, then removed after the save.
    let src = dir.join("helmet");
    std::fs::create_dir_all(&src).unwrap();
    let from = helmet().parent().unwrap().to_owned();
    for e in std::fs::read_dir(&from).unwrap() {
        let e = e.unwrap();
        if e.file_type().unwrap().is_file() {
            std::fs::copy(e.path(), src.join(e.file_name())).unwrap();
        }
    }
    let mut app = editor_world();
    apply(
        &mut app,
        EditCommand::Import {
            file: src.join("FlightHelmet.gltf"),
            root: None,
            transform: None,
        },
    );
    apply(
        &mut app,
        EditCommand::AddPrimitive {
            shape: Primitive::Cube,
            transform: Transform::from_xyz(0.0, 1.0, 0.0).into(),
            id: None,
        },
    );
    let path = dir.join("scene.treelight");
    let before = state(app.world_mut());
    save_project(app.world_mut(), &path).unwrap();
    let saved = read_project(&path).unwrap();
    // Inside the project's folder, the source is stored relative to it.
    assert_eq!(
        saved.sources,
        vec![PathBuf::from("helmet/FlightHelmet.gltf")]
    );
    std::fs::remove_dir_all(&src).unwrap();

    let mut fresh = editor_world();
    let report = open_project(fresh.world_mut(), &path).unwrap();
    assert_eq!(report.missing_sources.len(), 1, "{report:?}");
    fresh.update();
    // The import's sun and the cube are there; the helmet's objects are kept by the project, not
    // shown.
    let names: Vec<String> = state(fresh.world_mut())
        .into_values()
        .map(|o| o.name)
        .collect();
    assert_eq!(names, vec!["Sun".to_string(), "Cube".to_string()]);
    let again = dir.join("again.treelight");
    save_project(fresh.world_mut(), &again).unwrap();
    let resaved = read_project(&again).unwrap();
    // Relinked to the files in their new place, the helmet comes back, as unsaved changes.
    let moved = dir.join("moved");
    std::fs::create_dir_all(&moved).unwrap();
    for e in std::fs::read_dir(&from).unwrap() {
        let e = e.unwrap();
        if e.file_type().unwrap().is_file() {
            std::fs::copy(e.path(), moved.join(e.file_name())).unwrap();
        }
    }
    let lost = treelight_document::project::restore::missing_sources(
        fresh.world().resource::<ProjectState>(),
    );
    assert_eq!(lost, vec![src.join("FlightHelmet.gltf")]);
    let report = treelight_document::project::restore::relink_source(
        fresh.world_mut(),
        &lost[0],
        &moved.join("FlightHelmet.gltf"),
    )
    .unwrap();
    assert_eq!((report.missing_sources.len(), report.missing_nodes), (0, 0));
    fresh.update();
    // The same objects with the same ids as before the save.
    let relinked = state(fresh.world_mut());
    assert_eq!(relinked, before);
    assert!(fresh.world().resource::<EditHistory>().is_dirty());
    assert_eq!(
        fresh.world().resource::<ProjectState>().path.as_deref(),
        Some(again.as_path())
    );
    save_project(fresh.world_mut(), &again).unwrap();
    assert_eq!(
        read_project(&again).unwrap().sources,
        vec![PathBuf::from("moved/FlightHelmet.gltf")]
    );
    assert_eq!(
        (resaved.objects.len(), &resaved.source_ids),
        (saved.objects.len(), &saved.source_ids),
        "the missing objects or their ids were dropped"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// A command for a random step: `kind` picks the edit, `a` and `b` the objects (by position among
/// the current ids), `v` the numbers.
fn random_command(
    world: &mut World,
    kind: u8,
    a: usize,
    b: usize,
    v: [f32; 3],
) -> Option<EditCommand> {
    let ids: Vec<SceneId> = {
        let mut q = world.query::<&SceneId>();
        let mut ids: Vec<SceneId> = q.iter(world).copied().collect();
        ids.sort();
        ids
    };
    if ids.is_empty() {
        return None;
    }
    let (x, y) = (ids[a % ids.len()], ids[b % ids.len()]);
    let t = TransformValue::from(
        Transform::from_translation(Vec3::from_array(v))
            .with_rotation(Quat::from_rotation_y(v[0]))
            .with_scale(Vec3::splat(1.0 + v[1].abs())),
    );
    let command = match kind % 12 {
        0 => EditCommand::SetTransform {
            id: x,
            transform: t,
        },
        1 => EditCommand::Rename {
            id: x,
            name: format!("renamed {a}"),
        },
        2 => EditCommand::SetVisible {
            id: x,
            visible: v[2] > 0.0,
        },
        3 => EditCommand::Delete { ids: vec![x] },
        4 => EditCommand::Duplicate {
            ids: vec![x],
            copies: vec![],
        },
        5 => EditCommand::Reparent {
            ids: vec![x],
            parent: (v[2] > -0.2).then_some(y),
        },
        6 => EditCommand::Group {
            ids: vec![x, y],
            name: "g".into(),
            group: None,
        },
        7 => EditCommand::AddPrimitive {
            shape: Primitive::ALL[a % Primitive::ALL.len()],
            transform: t,
            id: None,
        },
        8 => EditCommand::AddLight {
            kind: if v[0] > 0.0 {
                LightKind::Point
            } else {
                LightKind::Directional
            },
            transform: t,
            id: None,
        },
        9 => {
            let mut m = MaterialValue::of(&StandardMaterial::default());
            m.base_color = [v[0].abs().min(1.0), 0.5, v[1].abs().min(1.0), 1.0];
            m.perceptual_roughness = v[2].abs().min(1.0);
            EditCommand::SetMaterial { id: x, material: m }
        }
        10 => EditCommand::MakeMaterialUnique { id: x },
        _ => EditCommand::SetTransforms {
            transforms: vec![(x, t)],
        },
    };
    command.check(world).ok()?;
    Some(command)
}

proptest::proptest! {
    #![proptest_config(proptest::prelude::ProptestConfig { cases: 10, .. Default::default() })]

    /// Whatever the edits, a saved project opens as the same scene.
    #[test]
    fn any_edited_scene_round_trips_through_a_project(
        steps in proptest::collection::vec(
            (0u8..12, 0usize..64, 0usize..64, proptest::array::uniform3(-1.0f32..1.0)),
            1..20,
        )
    ) {
        let mut app = editor_world();
        apply(&mut app, EditCommand::Import { file: helmet(), root: None, transform: None });
        for (kind, a, b, v) in steps {
            if let Some(c) = random_command(app.world_mut(), kind, a, b, v) {
                apply(&mut app, c);
            }
        }
        let before = state(app.world_mut());
        let dir = temp("random");
        let path = dir.join(format!("{}.treelight", before.len()));
        save_project(app.world_mut(), &path).unwrap();
        let mut fresh = editor_world();
        let report = open_project(fresh.world_mut(), &path).unwrap();
        proptest::prop_assert_eq!(report.missing_nodes, 0);
        fresh.update();
        proptest::prop_assert_eq!(state(fresh.world_mut()), before);
        std::fs::remove_file(&path).ok();
    }
}

#[test]
fn a_failed_autosave_is_shown_and_retried_and_a_save_leaves_no_copy() {
    use treelight_document::project::autosave::Autosave;
    use treelight_document::project::autosave::autosave;
    use treelight_document::project::recovery::recovery_beside;
    let dir = temp("autosave");
    let mut app = edited_scene();
    // The project's folder is a file for now, so the recovery copy cannot be written beside it.
    let folder = dir.join("work");
    std::fs::write(&folder, "not a folder").unwrap();
    let project = folder.join("house.treelight");
    let copy = recovery_beside(&project);
    let world = app.world_mut();
    world.resource_mut::<ProjectState>().path = Some(project.clone());
    let mut auto = Autosave::default();
    auto.interval = std::time::Duration::from_millis(20);
    world.insert_resource(auto);
    let run_until = |world: &mut World, what: &str, done: &dyn Fn(&World) -> bool| {
        let start = std::time::Instant::now();
        while !done(world) {
            assert!(start.elapsed().as_secs() < 30, "{what} never happened");
            autosave(world);
            std::thread::sleep(std::time::Duration::from_millis(5));
        }
    };
    run_until(world, "the failure", &|w| {
        w.resource::<Autosave>().failing.is_some()
    });
    let notices = world.resource::<treelight_document::scene::notice::Notices>();
    assert!(
        notices
            .0
            .iter()
            .any(|n| n.text.contains("autosave failed") && n.text.contains("work")),
        "{:?}",
        notices.0
    );
    assert!(!copy.exists());
    // Once the folder can hold it, the next try writes the copy.
    std::fs::remove_file(&folder).unwrap();
    std::fs::create_dir_all(&folder).unwrap();
    run_until(world, "the retry", &|w| {
        w.resource::<Autosave>().failing.is_none() && copy.exists()
    });
    // A save makes the copy stale: it is removed.
    world.resource_mut::<EditHistory>().mark_saved();
    autosave(world);
    assert!(!copy.exists(), "the stale copy was left");
    // Unsaved again, copied again; quitting with the changes discarded removes the copy too.
    world.resource_mut::<EditHistory>().mark_unsaved();
    run_until(world, "the second copy", &|_| copy.exists());
    world
        .resource_mut::<treelight_document::project::requests::ProjectRequests>()
        .0
        .push(treelight_document::project::requests::ProjectRequest::Quit);
    app.update();
    assert!(
        !copy.exists(),
        "a discarded scene's copy was left to be offered"
    );
    std::fs::remove_dir_all(&dir).ok();
}

/// Imports `file` into a fresh editor world.
fn imported(file: &Path) -> App {
    let mut app = editor_world();
    apply(
        &mut app,
        EditCommand::Import {
            file: file.to_owned(),
            root: None,
            transform: None,
        },
    );
    app
}

#[test]
fn a_project_grows_with_the_edits_not_the_sources() {
    let dir = temp("compact");
    // 300 parts under one root: 302 objects with the sun.
    let (file, _) = assembly::generated_assembly(&dir, 300, 2);
    let mut app = imported(&file);
    let before = state(app.world_mut());
    assert_eq!(before.len(), 302);
    let path = dir.join("unedited.treelight");
    save_project(app.world_mut(), &path).unwrap();
    let bytes = std::fs::metadata(&path).unwrap().len();
    assert!(bytes < 2048, "an unedited import saves as {bytes} bytes");
    let saved = read_project(&path).unwrap();
    // The root and the sun are listed; the parts are one run of ids.
    assert_eq!(saved.objects.len(), 2, "{:?}", saved.objects);
    assert_eq!(saved.source_ids[0].runs.len(), 1);
    let mut fresh = editor_world();
    open_project(fresh.world_mut(), &path).unwrap();
    fresh.update();
    assert_eq!(state(fresh.world_mut()), before);

    // Ten edits: seven parts moved, one renamed, one hidden, one deleted.
    let ids = ids_by_name(&mut app);
    for k in 0..7 {
        apply(
            &mut app,
            EditCommand::SetTransform {
                id: ids[&format!("part {}", 10 * k)],
                transform: Transform::from_xyz(k as f32, 2.0, 0.0).into(),
            },
        );
    }
    apply(
        &mut app,
        EditCommand::Rename {
            id: ids["part 3"],
            name: "renamed".into(),
        },
    );
    apply(
        &mut app,
        EditCommand::SetVisible {
            id: ids["part 4"],
            visible: false,
        },
    );
    apply(
        &mut app,
        EditCommand::Delete {
            ids: vec![ids["part 5"]],
        },
    );
    let edited = state(app.world_mut());
    let path = dir.join("edited.treelight");
    save_project(app.world_mut(), &path).unwrap();
    let saved = read_project(&path).unwrap();
    // The nine changed parts are listed, the deleted one named; the rest stay runs.
    assert_eq!(saved.objects.len(), 2 + 9);
    assert_eq!(saved.deleted.len(), 1);
    assert!(std::fs::metadata(&path).unwrap().len() < 12 * 1024);
    let mut fresh = editor_world();
    open_project(fresh.world_mut(), &path).unwrap();
    fresh.update();
    assert_eq!(state(fresh.world_mut()), edited);
    // Saved again unedited, it lists the same: opening did not make every node look edited.
    let again = dir.join("again.treelight");
    save_project(fresh.world_mut(), &again).unwrap();
    let resaved = read_project(&again).unwrap();
    assert_eq!(resaved.objects.len(), saved.objects.len());
    assert_eq!(resaved.source_ids, saved.source_ids);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_version_1_project_opens_and_saves_again_compact() {
    let dir = temp("version-1");
    let mut app = edited_scene();
    let before = state(app.world_mut());
    // Version 1 listed every object with its values and no runs.
    let path = dir.join("current.treelight");
    save_project(app.world_mut(), &path).unwrap();
    let current = read_project(&path).unwrap();
    let mut old = current.clone();
    old.version = 1;
    old.source_ids.clear();
    let mut q = app.world_mut().query::<(
        &SceneId,
        &Name,
        &Transform,
        Option<&ChildOf>,
        Option<&Visibility>,
        &treelight_document::scene::spawn::SourceKey,
    )>();
    let rows: Vec<_> = q
        .iter(app.world())
        .map(|(id, name, t, parent, vis, key)| {
            (
                *id,
                name.as_str().to_owned(),
                *t,
                parent.map(|p| p.parent()),
                vis.copied(),
                key.key.clone(),
            )
        })
        .collect();
    let index = app
        .world()
        .resource::<treelight_document::values::object::SceneIndex>();
    let id_of = |e: Entity| {
        rows.iter()
            .find(|r| index.entity(r.0) == Some(e))
            .map(|r| r.0)
    };
    for (id, name, t, parent, vis, key) in &rows {
        if old.objects.iter().any(|o| o.id == *id) {
            continue;
        }
        old.objects
            .push(treelight_document::project::format::ProjectObject {
                id: *id,
                name: name.clone(),
                parent: parent.and_then(id_of),
                transform: (*t).into(),
                visible: *vis != Some(Visibility::Hidden),
                kind: treelight_document::project::format::ObjectKind::Node(
                    treelight_document::project::format::SourceNode {
                        source: 0,
                        key: key.to_string(),
                    },
                ),
                material: None,
                light: None,
            });
    }
    assert!(old.objects.len() > current.objects.len());
    let v1 = dir.join("v1.treelight");
    let text = ron::ser::to_string_pretty(&old, ron::ser::PrettyConfig::default()).unwrap();
    assert!(text.contains("version: 1"));
    std::fs::write(&v1, text).unwrap();
    let mut fresh = editor_world();
    open_project(fresh.world_mut(), &v1).unwrap();
    fresh.update();
    assert_eq!(state(fresh.world_mut()), before);
    // Saved by this editor, it lists what the edits changed, as the current format does.
    let resaved_path = dir.join("resaved.treelight");
    save_project(fresh.world_mut(), &resaved_path).unwrap();
    let resaved = read_project(&resaved_path).unwrap();
    assert_eq!(resaved.version, PROJECT_VERSION);
    assert_eq!(resaved.objects.len(), current.objects.len());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_cycle_through_a_source_s_own_hierarchy_is_refused_once_it_is_read() {
    let dir = temp("source-cycle");
    let mut app = imported(&helmet());
    let path = dir.join("good.treelight");
    save_project(app.world_mut(), &path).unwrap();
    let good = read_project(&path).unwrap();
    let ids = ids_by_name(&mut app);
    // The file's root under one of its own children: each listed parent exists, so the file
    // reads, but the source's hierarchy closes the ring.
    let mut bad = good.clone();
    let root = bad
        .objects
        .iter_mut()
        .find(|o| o.name == "FlightHelmet.gltf")
        .unwrap();
    root.parent = Some(ids["Hose_low"]);
    let path = dir.join("cycle.treelight");
    let text = ron::ser::to_string_pretty(&bad, ron::ser::PrettyConfig::default()).unwrap();
    std::fs::write(&path, text).unwrap();
    assert!(read_project(&path).is_ok());
    let before = state(app.world_mut());
    let e = open_project(app.world_mut(), &path).unwrap_err();
    assert!(e.to_string().contains("form a cycle"), "{e}");
    assert_eq!(state(app.world_mut()), before);
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_re_exported_source_keeps_what_it_can_and_reports_the_rest_by_name() {
    let dir = temp("re-exported");
    let (file, _) = assembly::generated_assembly(&dir, 20, 2);
    let mut app = imported(&file);
    let ids = ids_by_name(&mut app);
    apply(
        &mut app,
        EditCommand::SetTransform {
            id: ids["part 1"],
            transform: Transform::from_xyz(0.0, 3.0, 0.0).into(),
        },
    );
    apply(
        &mut app,
        EditCommand::SetTransform {
            id: ids["part 19"],
            transform: Transform::from_xyz(0.0, 4.0, 0.0).into(),
        },
    );
    let path = dir.join("scene.treelight");
    save_project(app.world_mut(), &path).unwrap();
    // The file exported again with fewer parts: part 19 is gone, and the keys changed.
    assembly::generated_assembly(&dir, 15, 2);
    let mut fresh = editor_world();
    let report = open_project(fresh.world_mut(), &path).unwrap();
    fresh.update();
    assert_eq!(report.missing_nodes, 1);
    assert!(
        report.missing_names.iter().any(|n| n.contains("part 19")),
        "{report:?}"
    );
    assert_eq!(report.changed_sources, vec![file.clone()]);
    let now = ids_by_name(&mut fresh);
    // The edit to a part still there is applied to it, with its id.
    assert_eq!(now["part 1"], ids["part 1"]);
    let e = fresh
        .world()
        .resource::<treelight_document::values::object::SceneIndex>()
        .entity(now["part 1"])
        .unwrap();
    assert_eq!(
        fresh.world().get::<Transform>(e).unwrap().translation,
        Vec3::new(0.0, 3.0, 0.0)
    );
    // No other part took part 19's id, and its edit is kept for the next save.
    assert!(!now.values().any(|id| *id == ids["part 19"]));
    let again = dir.join("again.treelight");
    save_project(fresh.world_mut(), &again).unwrap();
    let resaved = read_project(&again).unwrap();
    assert!(resaved.objects.iter().any(|o| o.id == ids["part 19"]));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_look_is_a_step_with_undo_and_older_projects_open_with_the_default() {
    let dir = temp("look");
    let mut app = editor_world();
    let scrub = |app: &mut App, exposure: f32, continuing: bool| {
        apply_request(
            app.world_mut(),
            EditRequest::Apply {
                command: EditCommand::SetLook {
                    look: SceneLook {
                        exposure,
                        tone: ToneCurve::Filmic,
                        ..SceneLook::default()
                    },
                },
                continuing,
            },
        )
        .unwrap();
    };
    // One scrub of the exposure is one step; a new curve another.
    scrub(&mut app, 0.5, false);
    scrub(&mut app, 1.0, true);
    scrub(&mut app, 2.0, true);
    apply(
        &mut app,
        EditCommand::SetLook {
            look: SceneLook {
                exposure: 2.0,
                tone: ToneCurve::Aces,
                ..SceneLook::default()
            },
        },
    );
    assert_eq!(app.world().resource::<EditHistory>().head(), 2);
    apply_request(app.world_mut(), EditRequest::Undo).unwrap();
    assert_eq!(app.world().resource::<SceneLook>().tone, ToneCurve::Filmic);
    assert_eq!(app.world().resource::<SceneLook>().exposure, 2.0);
    apply_request(app.world_mut(), EditRequest::Undo).unwrap();
    assert_eq!(*app.world().resource::<SceneLook>(), SceneLook::default());
    // Out of range: refused, nothing changes.
    let refused = apply_request(
        app.world_mut(),
        EditRequest::Apply {
            command: EditCommand::SetLook {
                look: SceneLook {
                    exposure: f32::NAN,
                    tone: ToneCurve::None,
                    ..SceneLook::default()
                },
            },
            continuing: false,
        },
    );
    assert!(refused.is_err());
    assert_eq!(*app.world().resource::<SceneLook>(), SceneLook::default());
    // A version 2 project (no look) opens with the default look, whatever the scene had.
    apply_request(app.world_mut(), EditRequest::Redo).unwrap();
    assert_eq!(app.world().resource::<SceneLook>().exposure, 2.0);
    let path = dir.join("old.treelight");
    save_project(app.world_mut(), &path).unwrap();
    let text = std::fs::read_to_string(&path).unwrap();
    assert!(text.contains("look: Some("), "{text}");
    // The look is the file's last field: the file without it ends before it.
    let at = text.find("look: Some(").unwrap();
    assert!(!text[at..].contains("camera:"), "{text}");
    let old = format!("{})\n", &text[..at]).replacen(
        &format!("version: {PROJECT_VERSION}"),
        "version: 2",
        1,
    );
    std::fs::write(&path, old).unwrap();
    open_project(app.world_mut(), &path).unwrap();
    assert_eq!(*app.world().resource::<SceneLook>(), SceneLook::default());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn a_file_s_lights_come_in_as_editor_lights_and_their_edits_are_saved() {
    let dir = temp("lights");
    // The fixture's file beside the project, as a user keeps their sources.
    let file = dir.join("lights.gltf");
    std::fs::copy(
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../import/tests/data/lights.gltf"),
        &file,
    )
    .unwrap();
    let mut app = imported(&file);
    let lights: BTreeMap<String, LightValue> = state(app.world_mut())
        .into_values()
        .filter_map(|o| Some((o.name, o.light?)))
        .collect();
    // Three good lights, the bad one skipped, and no sun added beside them.
    assert_eq!(
        lights.keys().map(String::as_str).collect::<Vec<_>>(),
        ["Lamp", "Spot", "Sun"]
    );
    let lamp = lights["Lamp"];
    assert_eq!(lamp.kind, LightKind::Point);
    // 10 candela are 40π lumens; the file's linear colour is stored as sRGB.
    assert!((lamp.intensity - 40.0 * std::f32::consts::PI).abs() < 1e-3);
    assert!((lamp.color[1] - 0.7353569).abs() < 1e-4, "{:?}", lamp.color);
    assert_eq!(lamp.range, Some(5.0));
    let spot = lights["Spot"];
    assert_eq!(
        (spot.kind, spot.inner_angle, spot.outer_angle),
        (LightKind::Spot, 0.2, 0.5)
    );
    // The spot has no range in the file: unlimited, as glTF means it.
    assert_eq!(spot.range, None);
    assert_eq!(lights["Sun"].kind, LightKind::Directional);
    assert_eq!(lights["Sun"].intensity, 3.0);
    // The spot shines down its node's -z axis, turned to face the floor.
    let ids = ids_by_name(&mut app);
    let spot_entity = app
        .world()
        .resource::<treelight_document::values::object::SceneIndex>()
        .entity(ids["Spot"])
        .unwrap();
    let forward = app
        .world()
        .get::<GlobalTransform>(spot_entity)
        .unwrap()
        .forward();
    assert!(forward.dot(Vec3::NEG_Y) > 0.999, "{forward:?}");

    // The lamp edited into a spot: one step, undone and redone, then saved and opened again.
    let edited = LightValue {
        kind: LightKind::Spot,
        intensity: 500.0,
        outer_angle: 0.9,
        ..lamp
    };
    apply(
        &mut app,
        EditCommand::SetLight {
            id: ids["Lamp"],
            light: edited,
        },
    );
    let light_of = |app: &mut App, name: &str| {
        state(app.world_mut())
            .into_values()
            .find(|o| o.name == name)
            .and_then(|o| o.light)
    };
    assert_eq!(light_of(&mut app, "Lamp"), Some(edited));
    apply_request(app.world_mut(), EditRequest::Undo).unwrap();
    assert_eq!(light_of(&mut app, "Lamp"), Some(lamp));
    apply_request(app.world_mut(), EditRequest::Redo).unwrap();
    let before = state(app.world_mut());
    let path = dir.join("lit.treelight");
    save_project(app.world_mut(), &path).unwrap();
    let mut fresh = editor_world();
    open_project(fresh.world_mut(), &path).unwrap();
    fresh.update();
    assert_eq!(state(fresh.world_mut()), before);
    assert_eq!(light_of(&mut fresh, "Lamp"), Some(edited));
    // Unlimited stays unlimited through the project file.
    assert_eq!(light_of(&mut fresh, "Spot").map(|l| l.range), Some(None));
    // A light that is not one, and values out of range, are refused.
    let refused = apply_request(
        fresh.world_mut(),
        EditRequest::Apply {
            command: EditCommand::SetLight {
                id: ids["Tri"],
                light: edited,
            },
            continuing: false,
        },
    );
    assert!(refused.unwrap_err().to_string().contains("is not a light"));
    let refused = apply_request(
        fresh.world_mut(),
        EditRequest::Apply {
            command: EditCommand::SetLight {
                id: ids["Lamp"],
                light: LightValue {
                    inner_angle: 1.0,
                    outer_angle: 0.5,
                    ..edited
                },
            },
            continuing: false,
        },
    );
    assert!(refused.is_err());
    std::fs::remove_dir_all(&dir).ok();
}

/// An import's mesh asset ids (one per mesh object) and its distinct material asset ids.
type ImportAssets = (Vec<AssetId<Mesh>>, Vec<AssetId<StandardMaterial>>);

/// The mesh and material asset ids of the objects of each import of a file, by import number.
fn assets_by_import(world: &mut World) -> BTreeMap<u32, ImportAssets> {
    use treelight_document::scene::spawn::MeshSource;
    let mut out: BTreeMap<u32, (Vec<_>, Vec<_>)> = BTreeMap::new();
    let mut q = world.query::<(&MeshSource, &Mesh3d, &MeshMaterial3d<StandardMaterial>)>();
    for (source, mesh, material) in q.iter(world) {
        let entry = out.entry(source.0.import).or_default();
        entry.0.push(mesh.0.id());
        entry.1.push(material.0.id());
    }
    for (meshes, materials) in out.values_mut() {
        meshes.sort();
        materials.sort();
        materials.dedup();
    }
    out
}

#[test]
fn a_file_imported_twice_shares_its_meshes_and_saves_as_two_compact_sources() {
    let dir = temp("twice");
    let (file, _) = assembly::generated_assembly(&dir, 300, 2);
    let import = |app: &mut App, x: f32| {
        apply(
            app,
            EditCommand::Import {
                file: file.clone(),
                root: None,
                transform: Some(Transform::from_xyz(x, 0.0, 0.0).into()),
            },
        )
    };
    let mut once = editor_world();
    import(&mut once, 0.0);
    world::settle_tree(&mut once);
    let triangles_once = once
        .world()
        .resource::<treelight_scene::SceneBvh>()
        .stats()
        .triangles;

    let mut app = editor_world();
    import(&mut app, 0.0);
    import(&mut app, 20.0);
    // The second import shows the first one's meshes (the tree holds their triangles once, each
    // placement an instance) under materials of its own.
    let assets = assets_by_import(app.world_mut());
    let imports: Vec<_> = assets.values().collect();
    assert_eq!(imports.len(), 2);
    assert_eq!(imports[0].0.len(), 300);
    assert_eq!(imports[0].0, imports[1].0, "the meshes are not shared");
    assert!(
        imports[0].1.iter().all(|m| !imports[1].1.contains(m)),
        "an import's material edits would show on the other"
    );
    world::settle_tree(&mut app);
    assert_eq!(
        app.world()
            .resource::<treelight_scene::SceneBvh>()
            .stats()
            .triangles,
        triangles_once
    );

    // Unedited, the two imports are two sources of one file, each its root and one run of ids.
    let before = state(app.world_mut());
    let path = dir.join("twice.treelight");
    save_project(app.world_mut(), &path).unwrap();
    let bytes = std::fs::metadata(&path).unwrap().len();
    // One import's project is under 2 KB; the second adds its root and a run.
    assert!(bytes < 3072, "two unedited imports save as {bytes} bytes");
    let saved = read_project(&path).unwrap();
    assert_eq!(saved.sources.len(), 2);
    assert_eq!(saved.sources[0], saved.sources[1]);
    assert_eq!(saved.objects.len(), 3, "{:?}", saved.objects);
    assert_eq!(saved.source_ids.len(), 2);
    assert!(saved.source_ids.iter().all(|s| s.runs.len() == 1));
    let mut fresh = editor_world();
    open_project(fresh.world_mut(), &path).unwrap();
    fresh.update();
    assert_eq!(state(fresh.world_mut()), before);
    let reopened = assets_by_import(fresh.world_mut());
    let reopened: Vec<_> = reopened.values().collect();
    assert_eq!(
        reopened[0].0, reopened[1].0,
        "reopened, the meshes are not shared"
    );

    // Edits to each import stay with that import: a part of the second moved and one renamed, a
    // part of the first deleted. A third import, deleted, is not written.
    let numbers = imports_numbers(&mut app);
    let first = parts_of_import(&mut app, numbers[0]);
    let second = parts_of_import(&mut app, numbers[1]);
    apply(
        &mut app,
        EditCommand::SetTransform {
            id: second[7],
            transform: Transform::from_xyz(1.0, 3.0, 0.0).into(),
        },
    );
    apply(
        &mut app,
        EditCommand::Rename {
            id: second[8],
            name: "renamed".into(),
        },
    );
    apply(
        &mut app,
        EditCommand::Delete {
            ids: vec![first[9]],
        },
    );
    import(&mut app, 40.0);
    let third_root = state(app.world_mut())
        .into_iter()
        .filter(|(_, o)| o.name == "assembly.gltf")
        .map(|(id, _)| id)
        .max()
        .unwrap();
    apply(
        &mut app,
        EditCommand::Delete {
            ids: vec![third_root],
        },
    );
    let edited = state(app.world_mut());
    save_project(app.world_mut(), &path).unwrap();
    let saved = read_project(&path).unwrap();
    assert_eq!(saved.sources.len(), 2, "the deleted import was written");
    assert_eq!(saved.objects.len(), 3 + 2);
    assert_eq!(saved.deleted.len(), 1);
    assert!(std::fs::metadata(&path).unwrap().len() < 4096);
    let mut fresh = editor_world();
    open_project(fresh.world_mut(), &path).unwrap();
    fresh.update();
    assert_eq!(state(fresh.world_mut()), edited);

    // With the file gone, both sources and what they hold are kept apart by the next save, and
    // come back as they were once it is back.
    let kept = dir.join("kept.gltf");
    std::fs::rename(&file, &kept).unwrap();
    let mut missing = editor_world();
    let report = open_project(missing.world_mut(), &path).unwrap();
    assert_eq!(report.missing_sources.len(), 2, "{report:?}");
    save_project(missing.world_mut(), &path).unwrap();
    let resaved = read_project(&path).unwrap();
    assert_eq!(
        (&resaved.sources, &resaved.source_ids, resaved.deleted.len()),
        (&saved.sources, &saved.source_ids, 1)
    );
    std::fs::rename(&kept, &file).unwrap();
    let mut back = editor_world();
    open_project(back.world_mut(), &path).unwrap();
    back.update();
    assert_eq!(state(back.world_mut()), edited);
    std::fs::remove_dir_all(&dir).ok();
}

/// The ids of import `import`'s objects below its root, in key order.
fn parts_of_import(app: &mut App, import: u32) -> Vec<SceneId> {
    use treelight_document::scene::spawn::SourceKey;
    let world = app.world_mut();
    let mut q = world.query::<(&SceneId, &SourceKey)>();
    let mut v: Vec<(u32, SceneId)> = q
        .iter(world)
        .filter(|(_, k)| k.import == import && k.index > 0)
        .map(|(i, k)| (k.index, *i))
        .collect();
    v.sort();
    v.into_iter().map(|(_, i)| i).collect()
}

/// The import numbers of the imports in the scene, in order.
fn imports_numbers(app: &mut App) -> Vec<u32> {
    assets_by_import(app.world_mut()).into_keys().collect()
}
