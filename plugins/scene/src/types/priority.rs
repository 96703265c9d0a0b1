//! Background threads that yield to the frame: on a machine with few cores the worker's builds and
//! an import's parsing would otherwise take the cores the app's systems need, and frames stall
//! while nothing of ours runs on the main thread.

/// Lowers the calling thread's scheduling priority by `nice` steps (Unix nice values: 0 keeps it,
/// 19 is the lowest). Only the calling thread changes (Linux keeps a nice value per thread), and
/// threads it starts later inherit it. Does nothing where threads have no nice value, or when the
/// system refuses.
pub fn lower_current_thread(nice: i32) {
    if nice <= 0 {
        return;
    }
    #[cfg(target_os = "linux")]
    // SAFETY: plain system calls on the calling thread's own id.
    unsafe {
        let tid = libc::gettid() as libc::id_t;
        let now = libc::getpriority(libc::PRIO_PROCESS, tid);
        libc::setpriority(libc::PRIO_PROCESS, tid, (now + nice).min(19));
    }
}

#[cfg(all(test, target_os = "linux"))]
mod tests {
    use super::*;

    #[test]
    fn only_the_calling_thread_is_lowered() {
        let read =
            || unsafe { libc::getpriority(libc::PRIO_PROCESS, libc::gettid() as libc::id_t) };
        let before = read();
        let lowered = std::thread::spawn(move || {
            lower_current_thread(5);
            read()
        })
        .join()
        .unwrap();
        assert_eq!(lowered, (before + 5).min(19));
        assert_eq!(
            read(),
            before,
            "the calling thread of the test kept its priority"
        );
    }
}
