//! Opening a project in the background: its file is read and checked and its sources parsed on a
//! task (the UI keeps running, with the progress in the status bar and a Cancel), then the scene is
//! replaced in one frame. Until then the open scene is untouched, and a cancel leaves it so.

use crate::edit::history::EditHistory;
use crate::files::job::Job;
use crate::project::format::{
    FileStamp, OpenReport, ProjectError, ProjectFile, ProjectState, read_project,
};
use crate::project::restore::{OpenProgress, ParsedSources, open_project_parsed, parse_sources};
use crate::scene::notice::Notices;
use crate::scene::outbox::DocumentEvent;
use bevy::prelude::*;
use std::path::PathBuf;
use std::sync::Arc;
use std::sync::atomic::Ordering;

/// What the opened file becomes.
#[derive(Clone, Debug, PartialEq)]
pub enum OpenKind {
    /// The project, opened as it was saved.
    Project,
    /// A recovery copy: unsaved work on `owner`, the project it was made for.
    Recovery {
        /// The project the work belongs to (`None` for a scene never saved).
        owner: Option<PathBuf>,
    },
}

type Parsed = Result<(ProjectFile, ParsedSources, Option<FileStamp>), ProjectError>;

/// One project being read.
pub struct OpeningProject {
    /// Its file.
    pub path: PathBuf,
    /// What it becomes.
    pub kind: OpenKind,
    /// How far its sources are read.
    pub progress: Arc<OpenProgress>,
    job: Job<Parsed>,
}

/// The project being opened, if any (a second open replaces the first).
#[derive(Resource, Default)]
pub struct OpeningProjects(pub Option<OpeningProject>);

impl OpeningProjects {
    /// Starts reading `path` in the background.
    pub fn start(&mut self, path: PathBuf, kind: OpenKind) {
        self.cancel();
        let progress = Arc::new(OpenProgress::default());
        let (p, shared) = (path.clone(), progress.clone());
        let job = Job::spawn(format!("opening {}", p.display()), move || {
            // Taken before the read: a save by someone else after it changes the stamp.
            let stamp = FileStamp::of(&p);
            let project = read_project(&p)?;
            let sources = parse_sources(&project, &p, Some(&shared))?;
            Ok((project, sources, stamp))
        });
        self.0 = Some(OpeningProject {
            path,
            kind,
            progress,
            job,
        });
    }

    /// Stops the open under way, leaving the scene as it is.
    pub fn cancel(&mut self) {
        if let Some(o) = self.0.take() {
            o.progress.cancelled.store(true, Ordering::Relaxed);
        }
    }

    /// Whether a project is being read.
    pub fn busy(&self) -> bool {
        self.0.is_some()
    }

    /// `(sources read, sources)` of the open under way.
    pub fn progress(&self) -> Option<(usize, usize)> {
        self.0.as_ref().map(|o| {
            (
                o.progress.done.load(Ordering::Relaxed),
                o.progress.total.load(Ordering::Relaxed),
            )
        })
    }
}

/// Puts a project that finished reading in place of the scene, and tells the user what it found.
pub fn finish_opening(world: &mut World) {
    let done = {
        let mut opening = world.resource_mut::<OpeningProjects>();
        let Some(o) = opening.0.as_mut() else {
            return;
        };
        match o.job.poll() {
            Some(parsed) => opening.0.take().map(|o| {
                // A crash while reading ends this open with an error, not the editor.
                let parsed = parsed.unwrap_or_else(|e| Err(ProjectError::Io(o.path.clone(), e)));
                (o.path, o.kind, parsed)
            }),
            None => None,
        }
    };
    let Some((path, kind, parsed)) = done else {
        return;
    };
    let mut stamp = None;
    let result = parsed.and_then(|(project, sources, s)| {
        stamp = s;
        open_project_parsed(world, project, &path, sources)
    });
    match (result, kind) {
        (Ok(report), OpenKind::Project) => {
            world.resource_mut::<ProjectState>().on_disk = stamp;
            world.write_message(DocumentEvent::Opened(path.clone()));
            tell(world, &path, &report, "opened");
        }
        (Ok(report), OpenKind::Recovery { owner }) => {
            // The recovered scene is unsaved work on the project it came from, as that is now.
            let mut state = world.resource_mut::<ProjectState>();
            state.on_disk = owner.as_deref().and_then(FileStamp::of);
            state.path = owner;
            world.resource_mut::<EditHistory>().mark_unsaved();
            if let Some(mut auto) = world.get_resource_mut::<crate::project::autosave::Autosave>() {
                auto.adopt(path.clone());
            }
            tell(world, &path, &report, "recovered");
        }
        (Err(e), OpenKind::Recovery { .. }) => {
            // A copy that cannot be opened would be offered at every start: it is moved aside
            // (the editor's own file, by its name), and the user told where.
            let aside = match crate::files::own_file::set_aside(&path) {
                Ok(to) => format!("; it was moved to {}", to.display()),
                Err(why) => format!("; it could not be moved aside ({why})"),
            };
            world.resource_mut::<Notices>().error(format!("{e}{aside}"));
        }
        (Err(e), _) => world.resource_mut::<Notices>().error(e.to_string()),
    }
}

fn tell(world: &mut World, path: &std::path::Path, report: &OpenReport, verb: &str) {
    let mut notices = world.resource_mut::<Notices>();
    notices.info(format!("{verb} {}", path.display()));
    for (file, why) in &report.missing_sources {
        notices.warn(format!(
            "{}: source {} is missing ({why}); its objects stay in the project",
            path.display(),
            file.display()
        ));
    }
    if report.missing_nodes > 0 {
        notices.warn(format!(
            "{}: {} objects name nodes their files no longer have ({}{}); they stay in the \
             project",
            path.display(),
            report.missing_nodes,
            report.missing_names.join(", "),
            if report.missing_nodes > report.missing_names.len() {
                ", …"
            } else {
                ""
            }
        ));
    }
    for file in &report.changed_sources {
        notices.warn(format!(
            "{}: {} changed since the project was saved; the nodes it did not change have new ids",
            path.display(),
            file.display()
        ));
    }
}
