//! Long document work (a file's parse, a project's sources) on a thread of its own, polled once a
//! frame, below the frame's priority as the async-compute pool is (`app::task_pools`). Not on that
//! pool: on a two-core machine it has one thread, and the renderer compiles its pipelines there, so
//! a parse queued first would hold the first picture of what it parses back until the compiles
//! that follow it finish.

use crate::files::contain::{contain, crashed};
use std::collections::BTreeSet;
use std::sync::{Condvar, Mutex, MutexGuard};
use std::thread::JoinHandle;

/// Nice steps below the frame at which background work runs.
pub(crate) const BACKGROUND_NICE: i32 = 10;

/// Jobs take turns in the order they were started, as they did on the pool's one thread, so
/// twenty files dropped at once are not twenty parses in memory at once, and they come in the
/// order they were dropped. A ticket lock: a mutex alone would let any waiter in next.
static TURNS: Mutex<Turns> = Mutex::new(Turns {
    issued: 0,
    serving: 0,
    ended: BTreeSet::new(),
});
/// Woken when a turn ends.
static TURN_ENDED: Condvar = Condvar::new();

/// The ticket lock's state.
struct Turns {
    /// Tickets handed out so far.
    issued: u64,
    /// The ticket whose job may work now.
    serving: u64,
    /// Tickets above `serving` whose jobs ended (or never ran) before their turn came.
    ended: BTreeSet<u64>,
}

fn turns() -> MutexGuard<'static, Turns> {
    TURNS.lock().unwrap_or_else(|p| p.into_inner())
}

/// One job's place in the queue; dropping it ends the turn, whether the job ran or its thread
/// never started, so the queue never waits on a ticket nobody holds.
struct Ticket(u64);

impl Ticket {
    fn take() -> Self {
        let mut t = turns();
        t.issued += 1;
        Self(t.issued - 1)
    }

    fn wait_for_turn(&self) {
        let mut t = turns();
        while t.serving != self.0 {
            t = TURN_ENDED.wait(t).unwrap_or_else(|p| p.into_inner());
        }
    }
}

impl Drop for Ticket {
    fn drop(&mut self) {
        let mut guard = turns();
        let t = &mut *guard;
        t.ended.insert(self.0);
        while t.ended.remove(&t.serving) {
            t.serving += 1;
        }
        TURN_ENDED.notify_all();
    }
}

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
        let ticket = Ticket::take();
        let spawned = std::thread::Builder::new()
            .name("treelight job".into())
            .spawn(move || {
                treelight_scene::priority::lower_current_thread(BACKGROUND_NICE);
                ticket.wait_for_turn();
                let result = contain(|| label, work);
                drop(ticket);
                result
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

        // Jobs take turns in the order they were started: the second starts once the first has
        // ended, whichever thread the system runs first.
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

        // A place in the queue given up without working (a thread that never started) does not
        // hold the jobs behind it.
        let abandoned = Ticket::take();
        let mut behind = Job::spawn("behind".into(), || 1);
        std::thread::sleep(Duration::from_millis(100));
        assert!(behind.poll().is_none(), "went before its turn");
        drop(abandoned);
        assert_eq!(wait(&mut behind), Ok(1));

        let mut job = Job::spawn("importing x.glb".into(), || -> u32 { panic!("bad file") });
        let e = wait(&mut job).unwrap_err();
        assert!(e.starts_with("importing x.glb: crashed (bad file)"), "{e}");
    }
}
