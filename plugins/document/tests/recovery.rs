//! Recovery copies in the document's own app: the offer is decided from the scene named at
//! start, before its open finishes; a copy's work belongs to the scene it was made for, never to
//! the scene open when it is accepted; a recovered copy goes once saved; autosave never writes
//! over a copy offered, another running editor's, or through a link planted in its place.

#[path = "support/world.rs"]
mod world;

use bevy::prelude::*;
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};
use treelight_document::edit::history::EditHistory;
use treelight_document::project::autosave::{Autosave, autosave, find_recovery};
use treelight_document::project::capture::save_project;
use treelight_document::project::format::ProjectState;
use treelight_document::project::recovery::{
    HEADER, recovery_beside, recovery_beside_for, unsaved_recovery_in,
};
use treelight_document::project::requests::{ProjectRequest, ProjectRequests};
use treelight_document::scene::notice::Notices;
use world::{editor_world, fresh_dir};

/// An editor world with autosave keeping its locks and unsaved copies in `cache`, copies every
/// 20 ms.
fn app_with_autosave(cache: &Path) -> App {
    let mut app = editor_world();
    let mut auto = Autosave::with_cache(cache.to_owned());
    auto.interval = Duration::from_millis(20);
    app.insert_resource(auto)
        .add_systems(Update, (autosave, find_recovery));
    app
}

/// A saved project with one shape in `dir`, written `age` ago.
fn saved_project(dir: &Path, name: &str, age: Duration) -> PathBuf {
    let mut app = editor_world();
    treelight_document::default_scene::open_default_scene(app.world_mut());
    app.update();
    let path = dir.join(name);
    save_project(app.world_mut(), &path).unwrap();
    let f = std::fs::File::options().write(true).open(&path).unwrap();
    f.set_modified(SystemTime::now() - age).unwrap();
    path
}

/// A recovery copy at `at` of the project at `of` (its scene as saved), written by editor process
/// `pid` (gone), `age` ago.
fn copy_of(of: &Path, at: &Path, pid: u32, age: Duration) {
    let body = std::fs::read_to_string(of).unwrap();
    std::fs::write(at, format!("{HEADER}{pid}\n{body}")).unwrap();
    let f = std::fs::File::options().write(true).open(at).unwrap();
    f.set_modified(SystemTime::now() - age).unwrap();
}

fn offered(app: &App) -> Vec<PathBuf> {
    app.world()
        .resource::<Autosave>()
        .offer
        .iter()
        .map(|c| c.path.clone())
        .collect()
}

fn run_until(app: &mut App, what: &str, done: impl Fn(&mut App) -> bool) {
    let start = std::time::Instant::now();
    while !done(app) {
        assert!(start.elapsed().as_secs() < 60, "{what} never happened");
        app.update();
        std::thread::sleep(Duration::from_millis(2));
    }
}

#[test]
fn a_projects_copy_is_offered_from_the_first_frame_and_no_other_scenes_copy() {
    let (dir, cache) = (
        fresh_dir("recovery", "first"),
        fresh_dir("recovery", "first-cache"),
    );
    let minute = Duration::from_secs(60);
    let house = saved_project(&dir, "house.treelight", 10 * minute);
    copy_of(&house, &recovery_beside(&house), 4_000_601, minute);
    // An unsaved scene's copy, newer still: another scene's work, not offered for the house.
    copy_of(
        &house,
        &unsaved_recovery_in(&cache, 4_000_602),
        4_000_602,
        Duration::ZERO,
    );
    let mut app = app_with_autosave(&cache);
    treelight_document::app::open_at_start(app.world_mut(), &house);
    app.update();
    // Decided at once from the name, however long the open takes.
    assert_eq!(offered(&app), vec![recovery_beside(&house)]);
    // Once the open is done, nothing new is offered, and the copy stays.
    run_until(&mut app, "the open", |a| {
        a.world().resource::<ProjectState>().path.is_some()
    });
    app.update();
    assert_eq!(offered(&app), vec![recovery_beside(&house)]);
    assert!(recovery_beside(&house).exists());
    std::fs::remove_dir_all(&dir).ok();
    std::fs::remove_dir_all(&cache).ok();
}

#[test]
fn an_unsaved_scenes_copy_accepted_over_a_project_is_saved_nowhere_but_where_asked() {
    let (dir, cache) = (
        fresh_dir("recovery", "owner"),
        fresh_dir("recovery", "owner-cache"),
    );
    let house = saved_project(&dir, "house.treelight", Duration::from_secs(600));
    let unsaved = unsaved_recovery_in(&cache, 4_000_611);
    copy_of(&house, &unsaved, 4_000_611, Duration::from_secs(60));
    let mut app = app_with_autosave(&cache);
    treelight_document::app::open_at_start(app.world_mut(), &house);
    run_until(&mut app, "the open", |a| {
        a.world().resource::<ProjectState>().path.is_some()
    });
    // The unsaved copy opened while the house is open: its work is a scene never saved.
    app.world_mut()
        .resource_mut::<ProjectRequests>()
        .0
        .push(ProjectRequest::OpenRecovery(unsaved.clone()));
    run_until(&mut app, "the recovery", |a| {
        a.world().resource::<EditHistory>().is_dirty()
    });
    assert_eq!(app.world().resource::<ProjectState>().path, None);
    // Saved where the user points: the recovered copy goes, the house is untouched.
    let before = std::fs::read(&house).unwrap();
    let mine = dir.join("mine.treelight");
    app.world_mut()
        .resource_mut::<ProjectRequests>()
        .0
        .push(ProjectRequest::Save(mine.clone()));
    app.update();
    app.update();
    assert!(mine.exists());
    assert!(
        !unsaved.exists(),
        "the recovered copy was left to be offered again"
    );
    assert_eq!(std::fs::read(&house).unwrap(), before);
    std::fs::remove_dir_all(&dir).ok();
    std::fs::remove_dir_all(&cache).ok();
}

#[test]
fn autosave_never_writes_over_a_copy_offered_another_editors_or_through_a_link() {
    let (dir, cache) = (
        fresh_dir("recovery", "writes"),
        fresh_dir("recovery", "writes-cache"),
    );
    let house = saved_project(&dir, "house.treelight", Duration::from_secs(600));
    let usual = recovery_beside(&house);
    let own = recovery_beside_for(&house, std::process::id());
    let edit = |app: &mut App| {
        app.world_mut().resource_mut::<EditHistory>().mark_unsaved();
    };
    // 1. A copy offered (left by a crash): autosave writes beside it, not over it.
    copy_of(&house, &usual, 4_000_621, Duration::from_secs(60));
    let offered_text = std::fs::read(&usual).unwrap();
    let mut app = app_with_autosave(&cache);
    treelight_document::app::open_at_start(app.world_mut(), &house);
    run_until(&mut app, "the open", |a| {
        a.world().resource::<ProjectState>().path.is_some()
    });
    assert_eq!(offered(&app), vec![usual.clone()]);
    edit(&mut app);
    run_until(&mut app, "a copy of its own", |_| own.exists());
    assert_eq!(std::fs::read(&usual).unwrap(), offered_text);
    // Saving removes this editor's copy, and only it.
    app.world_mut()
        .resource_mut::<ProjectRequests>()
        .0
        .push(ProjectRequest::Save(house.clone()));
    app.update();
    app.update();
    assert!(!own.exists() && usual.exists());
    drop(app);
    std::fs::remove_file(&usual).unwrap();

    // 2. A link planted under the usual name: never written through.
    let victim = dir.join("victim.txt");
    std::fs::write(&victim, "the user's").unwrap();
    #[cfg(unix)]
    std::os::unix::fs::symlink(&victim, &usual).unwrap();
    let mut app = app_with_autosave(&cache);
    treelight_document::app::open_at_start(app.world_mut(), &house);
    run_until(&mut app, "the open", |a| {
        a.world().resource::<ProjectState>().path.is_some()
    });
    edit(&mut app);
    run_until(&mut app, "a copy under its own name", |_| own.exists());
    assert_eq!(std::fs::read_to_string(&victim).unwrap(), "the user's");
    let notices = &app.world().resource::<Notices>().0;
    assert!(
        notices.iter().any(|n| n.text.contains("link")),
        "{notices:?}"
    );
    std::fs::remove_dir_all(&dir).ok();
    std::fs::remove_dir_all(&cache).ok();
}

#[test]
fn a_second_editor_on_a_project_is_told_and_sees_a_save_made_elsewhere() {
    let (dir, cache) = (
        fresh_dir("recovery", "two"),
        fresh_dir("recovery", "two-cache"),
    );
    let house = saved_project(&dir, "house.treelight", Duration::from_secs(600));
    // Another editor running, with the house open: its lock held, naming it.
    let lock = cache.join("editor-4000900.lock");
    let mut other = std::fs::File::create(&lock).unwrap();
    other.lock().unwrap();
    std::io::Write::write_all(
        &mut other,
        std::fs::canonicalize(&house)
            .unwrap()
            .display()
            .to_string()
            .as_bytes(),
    )
    .unwrap();
    let mut app = app_with_autosave(&cache);
    treelight_document::app::open_at_start(app.world_mut(), &house);
    run_until(&mut app, "the notice", |a| {
        a.world()
            .resource::<Notices>()
            .0
            .iter()
            .any(|n| n.text.contains("open in another editor"))
    });
    run_until(&mut app, "the open", |a| {
        a.world().resource::<ProjectState>().path.is_some()
    });
    assert!(!app.world().resource::<ProjectState>().changed_on_disk());
    // The other editor saves: this one's next save would replace that, so it is told.
    std::thread::sleep(Duration::from_millis(20));
    let mut elsewhere = editor_world();
    treelight_document::default_scene::open_default_scene(elsewhere.world_mut());
    elsewhere.update();
    save_project(elsewhere.world_mut(), &house).unwrap();
    assert!(app.world().resource::<ProjectState>().changed_on_disk());
    // Once this editor saves (the user said so), its stamp is the file's again.
    save_project(app.world_mut(), &house).unwrap();
    assert!(!app.world().resource::<ProjectState>().changed_on_disk());
    drop(other);
    std::fs::remove_dir_all(&dir).ok();
    std::fs::remove_dir_all(&cache).ok();
}

#[test]
fn a_copy_that_cannot_be_opened_is_moved_aside_not_offered_again() {
    let (dir, cache) = (
        fresh_dir("recovery", "broken"),
        fresh_dir("recovery", "broken-cache"),
    );
    let copy = unsaved_recovery_in(&cache, 4_000_631);
    std::fs::write(
        &copy,
        format!("{HEADER}4000631\n(version: 1, objects: [oops"),
    )
    .unwrap();
    let mut app = app_with_autosave(&cache);
    app.world_mut()
        .resource_mut::<Autosave>()
        .look_for_start(None);
    app.update();
    assert_eq!(offered(&app), vec![copy.clone()]);
    app.world_mut()
        .resource_mut::<ProjectRequests>()
        .0
        .push(ProjectRequest::OpenRecovery(copy.clone()));
    run_until(&mut app, "the failure", |a| {
        a.world().resource::<Notices>().has_errors()
    });
    assert!(!copy.exists());
    let aside = copy.with_file_name("unsaved-4000631.recovery.treelight.bad");
    assert!(aside.exists());
    let notices = &app.world().resource::<Notices>().0;
    assert!(
        notices.iter().any(|n| n.text.contains(".bad")),
        "{notices:?}"
    );
    // The next start offers nothing.
    let mut next = app_with_autosave(&cache);
    next.world_mut()
        .resource_mut::<Autosave>()
        .look_for_start(None);
    next.update();
    assert!(offered(&next).is_empty());
    std::fs::remove_dir_all(&dir).ok();
    std::fs::remove_dir_all(&cache).ok();
}
