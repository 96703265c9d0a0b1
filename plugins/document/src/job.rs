//! Long document work (a file's parse, a project's sources) on a thread of its own, polled once a
//! frame, below the frame's priority as the async-compute pool is (`app::task_pools`). Not on that
//! pool: on a two-core machine it has one thread, and the renderer compiles its pipelines there, so
//! a parse queued first would hold the first picture of what it parses back until the compiles
//! that follow it finish.

use crate::contain::{contain, crashed};
use std::sync::Mutex;
use std::thread::JoinHandle;

/// Held by the job that is working: jobs take turns, as they did on the pool's one thread, so
/// twenty files dropped at once are not twenty parses in memory at once.
static TURN: Mutex<()> = Mutex::new(());

/// One piece of work running on its own thread; a panic in it ends it as an error naming what it
/// was doing ([`contain`]).
pub struct Job<T> {
    what: String,
    state: Option<Result<JoinHandle<Result<T, String>>, String>>,
}

impl<T: Send + 'static> Job<T> {
    /// Starts `work` on a new thread; `what` names it in errors ("importing model.glb").
    pub fn spawn(what: String, work: impl FnOnce() -> T + Send + 'static) -> Self {
        let label = what.clone();
        let spawned = std::thread::Builder::new()
            .name("treelight job".into())
            .spawn(move || {
                treelight_scene::priority::lower_current_thread(crate::app::BACKGROUND_NICE);
                let _turn = TURN.lock().unwrap_or_else(|p| p.into_inner());
                contain(|| label, work)
            })
            .map_err(|e| format!("{what}: could not start a thread for it ({e})"));
        Self {
            what,
            state: Some(spawned),
        }
    }

    /// The work's result once it has ended (`Err` when it panicked or never started), once;
    /// `None` while it runs and after the result was taken.
    pub fn poll(&mut self) -> Option<Result<T, String>> {
        if let Some(Ok(handle)) = &self.state
            && !handle.is_finished()
        {
            return None;
        }
        match self.state.take()? {
            Ok(handle) => Some(
                handle
                    .join()
                    .unwrap_or_else(|p| Err(crashed(self.what.clone(), &*p))),
            ),
            Err(e) => Some(Err(e)),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::time::{Duration, Instant};

    fn wait<T: Send + 'static>(job: &mut Job<T>) -> Result<T, String> {
        let start = Instant::now();
        loop {
            if let Some(r) = job.poll() {
                return r;
            }
            assert!(
                start.elapsed() < Duration::from_secs(10),
                "the job never ended"
            );
            std::thread::sleep(Duration::from_millis(1));
        }
    }

    #[test]
    fn a_job_gives_its_result_once_and_a_panic_as_an_error_naming_it() {
        let (tx, rx) = std::sync::mpsc::channel::<()>();
        let mut job = Job::spawn("adding".into(), move || {
            rx.recv().unwrap();
            2 + 2
        });
        assert!(job.poll().is_none(), "still waiting for its go");
        tx.send(()).unwrap();
        assert_eq!(wait(&mut job), Ok(4));
        assert!(job.poll().is_none(), "the result is given once");

        // Jobs take turns: the second starts once the first has ended.
        let (tx, rx) = std::sync::mpsc::channel::<()>();
        let started = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let mut first = Job::spawn("first".into(), move || rx.recv().is_ok());
        let flag = started.clone();
        let mut second = Job::spawn("second".into(), move || {
            flag.store(true, std::sync::atomic::Ordering::SeqCst)
        });
        std::thread::sleep(Duration::from_millis(200));
        assert!(
            !started.load(std::sync::atomic::Ordering::SeqCst),
            "ran beside the first"
        );
        tx.send(()).unwrap();
        assert_eq!(wait(&mut first), Ok(true));
        assert_eq!(wait(&mut second), Ok(()));

        let mut job = Job::spawn("importing x.glb".into(), || -> u32 { panic!("bad file") });
        let e = wait(&mut job).unwrap_err();
        assert!(e.starts_with("importing x.glb: crashed (bad file)"), "{e}");
    }
}
