//! An editor at rest costs nothing. The window loop runs a frame only on input or when asked: each
//! source of work says it is busy this frame ([`Activity::busy`], and the loop draws the next
//! frame at once) or when it is next due without input ([`Activity::due_in`], and an alarm wakes
//! the loop then). Threads that finish work while the loop sleeps wake it through a [`Waker`].
//! The sources the lower crates hold (the scene's worker, imports, opens, edits, autosave,
//! notices, the path tracer's views) are read here; each feature reports its own.

use bevy::prelude::*;
use bevy::window::RequestRedraw;
use bevy::winit::{EventLoopProxyWrapper, UpdateMode, WinitSettings, WinitUserEvent};
use std::sync::mpsc::{Receiver, RecvTimeoutError, Sender, channel};
use std::sync::{Arc, OnceLock};
use std::time::{Duration, Instant};
use treelight_document::edit::history::EditRequests;
use treelight_document::import::jobs::TracingImports;
use treelight_document::import::parse::{ParsedImports, PendingImports};
use treelight_document::project::autosave::Autosave;
use treelight_document::project::open::OpeningProjects;
use treelight_document::project::requests::ProjectRequests;
use treelight_document::scene::environment::LoadedEnvironment;
use treelight_document::scene::notice::Notices;
use treelight_render::{PathTraced, PathTracerStats};
use treelight_scene::SceneBvh;

/// Frames drawn after the last busy one or the last input: the effects of a change reach the
/// report, the path tracer's figures and egui's layout a frame or two after it.
pub const SETTLE_FRAMES: u8 = 4;

/// The longest the loop sleeps without input or an alarm while the window has the focus (a safety
/// net, not a source of work), and while it has not.
pub const LONGEST_REST: (Duration, Duration) = (Duration::from_secs(60), Duration::from_secs(300));

/// The window loop's settings for an editor that rests: a frame on input, on a wake or an alarm,
/// or at the latest every [`LONGEST_REST`]; unfocused, mouse motion outside the window wakes it
/// not.
pub fn resting_loop() -> WinitSettings {
    WinitSettings {
        focused_mode: UpdateMode::reactive(LONGEST_REST.0),
        unfocused_mode: UpdateMode::reactive_low_power(LONGEST_REST.1),
    }
}

/// What keeps the editor drawing, gathered each frame.
#[derive(Resource, Debug, Default)]
pub struct Activity {
    /// Why this frame asks for the next one at once (none: the loop may rest).
    busy: Vec<&'static str>,
    /// The earliest time something is due without input.
    due: Option<Instant>,
    /// Frames still to draw after the last busy one.
    settling: u8,
    /// Whether the last frame asked for no other: the loop waits for input or an alarm.
    pub at_rest: bool,
    /// Why the last busy frame was busy (for the state report).
    pub last_busy: Vec<&'static str>,
}

impl Activity {
    /// Asks for the next frame at once: `why` is still working.
    pub fn busy(&mut self, why: &'static str) {
        if !self.busy.contains(&why) {
            self.busy.push(why);
        }
    }

    /// Asks for a frame at `when` (if nothing earlier wakes the loop).
    pub fn due_at(&mut self, when: Instant) {
        self.due = Some(self.due.map_or(when, |d| d.min(when)));
    }

    /// Asks for a frame `after` from now.
    pub fn due_in(&mut self, after: Duration) {
        self.due_at(Instant::now() + after);
    }

    /// Whether something asked for the next frame at once.
    pub fn is_busy(&self) -> bool {
        !self.busy.is_empty()
    }
}

/// Wakes the window loop from any thread (a file watcher, a dialog's thread); does nothing
/// without a window loop (a headless app). Clones taken before the loop starts work once it has.
#[derive(Resource, Clone, Default)]
pub struct Waker(Arc<OnceLock<Sender<Wake>>>);

/// What the alarm thread is told.
enum Wake {
    /// Wake the loop now.
    Now,
    /// Wake the loop at this time (replacing the alarm set before).
    At(Option<Instant>),
}

impl Waker {
    /// Wakes the loop now.
    pub fn wake(&self) {
        if let Some(tx) = self.0.get() {
            let _ = tx.send(Wake::Now);
        }
    }

    fn alarm(&self, at: Option<Instant>) {
        if let Some(tx) = self.0.get() {
            let _ = tx.send(Wake::At(at));
        }
    }
}

/// Starts the alarm thread once the window loop's proxy exists.
fn start_waker(proxy: Option<Res<EventLoopProxyWrapper>>, waker: Res<Waker>) {
    let Some(proxy) = proxy else {
        return;
    };
    let proxy = (**proxy).clone();
    let (tx, rx) = channel();
    let started = std::thread::Builder::new()
        .name("treelight-alarm".into())
        .spawn(move || {
            run_alarm(rx, move || {
                let _ = proxy.send_event(WinitUserEvent::WakeUp);
            })
        });
    if started.is_ok() {
        let _ = waker.0.set(tx);
    }
}

/// Sleeps until the alarm set last is due or a wake is asked for, and wakes the loop then; ends
/// when the app drops its [`Waker`].
fn run_alarm(rx: Receiver<Wake>, wake: impl Fn()) {
    let mut at: Option<Instant> = None;
    loop {
        let next = match at {
            Some(t) => rx.recv_timeout(t.saturating_duration_since(Instant::now())),
            None => rx.recv().map_err(|_| RecvTimeoutError::Disconnected),
        };
        match next {
            Ok(Wake::Now) => wake(),
            Ok(Wake::At(t)) => at = t,
            Err(RecvTimeoutError::Timeout) => {
                at = None;
                wake();
            }
            Err(RecvTimeoutError::Disconnected) => return,
        }
    }
}

/// Starts the frame's gathering.
fn clear_activity(mut activity: ResMut<Activity>) {
    activity.busy.clear();
    activity.due = None;
}

/// What the document and the scene hold.
#[derive(bevy::ecs::system::SystemParam)]
pub struct DocumentWork<'w> {
    scene: Res<'w, SceneBvh>,
    pending: Res<'w, PendingImports>,
    parsed: Res<'w, ParsedImports>,
    tracing: Res<'w, TracingImports>,
    opening: Res<'w, OpeningProjects>,
    edits: Res<'w, EditRequests>,
    projects: Res<'w, ProjectRequests>,
    notices: Res<'w, Notices>,
    environment: Res<'w, LoadedEnvironment>,
    autosave: Option<Res<'w, Autosave>>,
}

/// The lower crates' sources: the scene's worker, imports, opens, requests, autosave, notices.
fn document_activity(
    work: DocumentWork,
    mut seen_version: Local<u64>,
    mut activity: ResMut<Activity>,
) {
    let version = work.scene.version();
    if !work.scene.is_resting() || std::mem::replace(&mut *seen_version, version) != version {
        activity.busy("scene worker");
    }
    if !work.pending.0.is_empty() || !work.parsed.0.is_empty() || !work.tracing.is_empty() {
        activity.busy("imports");
    }
    if work.environment.loading() {
        activity.busy("reading the sky");
    }
    if work.opening.busy() {
        activity.busy("opening a project");
    }
    if !work.edits.0.is_empty() || !work.projects.0.is_empty() {
        activity.busy("requests");
    }
    if let Some(auto) = work.autosave {
        if auto.is_writing() {
            activity.busy("autosave");
        }
        if let Some(due) = auto.next_due() {
            activity.due_at(due);
        }
    }
    if let Some(fade) = work.notices.next_fade() {
        activity.due_at(fade);
    }
}

/// Every path-traced view short of its sample limit keeps drawing, or whose denoiser owes its
/// picture passes (a kernel still compiling too).
fn tracer_activity(
    views: Query<(Entity, &PathTraced)>,
    stats: Option<Res<PathTracerStats>>,
    scene: Res<SceneBvh>,
    mut activity: ResMut<Activity>,
) {
    let Some(stats) = stats else {
        return;
    };
    let figures = stats.figures();
    if figures.trace_off.is_some() || views.is_empty() {
        return;
    }
    if figures.preparing_kernel.is_some() {
        activity.busy("path tracer kernel");
    }
    if figures.uploaded_version < scene.version() {
        activity.busy("path tracer upload");
    }
    if views.iter().any(|(camera, traced)| {
        figures.samples.get(&camera).copied().unwrap_or(0) < traced.max_samples
    }) {
        activity.busy("path tracing");
    }
    if views
        .iter()
        .any(|(camera, _)| figures.traces.get(&camera).is_some_and(|t| t.denoising))
    {
        activity.busy("denoiser");
    }
}

/// Decides: draw the next frame now, settle a few more, or rest until input or the alarm.
fn rest_or_draw(
    mut activity: ResMut<Activity>,
    waker: Res<Waker>,
    mut redraw: MessageWriter<RequestRedraw>,
) {
    let activity = &mut *activity;
    if activity.is_busy() {
        activity.settling = SETTLE_FRAMES;
        activity.last_busy.clone_from(&activity.busy);
    }
    if activity.settling > 0 {
        activity.settling -= 1;
        activity.at_rest = false;
        redraw.write(RequestRedraw);
    } else {
        activity.at_rest = true;
    }
    waker.alarm(activity.due);
}

/// The system that decides, at the end of each frame, whether the loop rests.
#[derive(SystemSet, Debug, Clone, PartialEq, Eq, Hash)]
pub struct RestDecision;

/// Systems in `Last` that report a source of work: they run before the decision. (Any system in
/// an earlier schedule may report too.)
#[derive(SystemSet, Debug, Clone, PartialEq, Eq, Hash)]
pub struct ActivitySources;

/// Gathers the sources each frame and rests the loop when none is busy.
pub struct RestPlugin;

impl Plugin for RestPlugin {
    fn build(&self, app: &mut App) {
        app.configure_sets(Last, ActivitySources.before(RestDecision))
            .init_resource::<Activity>()
            .init_resource::<Waker>()
            .add_systems(Startup, start_waker)
            .add_systems(First, clear_activity)
            .add_systems(
                PreUpdate,
                input_is_activity.after(bevy::input::InputSystems),
            )
            .add_systems(
                Last,
                (
                    (document_activity, tracer_activity).in_set(ActivitySources),
                    rest_or_draw.in_set(RestDecision),
                )
                    .chain(),
            );
    }
}

/// New input was read this frame: the frames after it settle its effects.
pub fn input_is_activity(
    keys: Res<ButtonInput<KeyCode>>,
    buttons: Res<ButtonInput<MouseButton>>,
    mut moved: MessageReader<bevy::input::mouse::MouseMotion>,
    mut cursor: MessageReader<CursorMoved>,
    mut activity: ResMut<Activity>,
) {
    let pressed = keys.get_pressed().len() + buttons.get_pressed().len() > 0;
    if pressed || moved.read().count() > 0 || cursor.read().count() > 0 {
        activity.busy("input");
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::{AtomicUsize, Ordering};

    #[test]
    fn the_alarm_wakes_at_its_time_and_a_later_alarm_replaces_an_earlier() {
        let (tx, rx) = channel();
        let woken = Arc::new(AtomicUsize::new(0));
        let w = woken.clone();
        let alarm = std::thread::spawn(move || {
            run_alarm(rx, move || {
                w.fetch_add(1, Ordering::SeqCst);
            })
        });
        let start = Instant::now();
        tx.send(Wake::At(Some(start + Duration::from_millis(100))))
            .unwrap();
        tx.send(Wake::At(Some(start + Duration::from_millis(400))))
            .unwrap();
        std::thread::sleep(Duration::from_millis(250));
        assert_eq!(woken.load(Ordering::SeqCst), 0, "the replaced alarm rang");
        std::thread::sleep(Duration::from_millis(300));
        assert_eq!(woken.load(Ordering::SeqCst), 1, "the alarm did not ring");
        tx.send(Wake::Now).unwrap();
        tx.send(Wake::At(None)).unwrap();
        std::thread::sleep(Duration::from_millis(100));
        assert_eq!(woken.load(Ordering::SeqCst), 2);
        // Set again after ringing, it rings again.
        tx.send(Wake::At(Some(Instant::now() + Duration::from_millis(100))))
            .unwrap();
        std::thread::sleep(Duration::from_millis(300));
        assert_eq!(
            woken.load(Ordering::SeqCst),
            3,
            "the alarm set again never rang"
        );
        drop(tx);
        alarm.join().unwrap();
    }
}
