//! Panics kept inside the job that had them: a background job (an import, a thumbnail, a dialog,
//! an autosave) that panics ends as an error naming what it was doing, which the editor shows as a
//! notice, instead of taking the editor down with it.

use std::any::Any;
use std::panic::AssertUnwindSafe;

thread_local! {
    /// How many `contain` calls the current thread is inside.
    static CONTAINING: std::cell::Cell<u32> = const { std::cell::Cell::new(0) };
}

/// Whether the current thread is running a contained job (its panic is not a crash).
pub fn is_containing() -> bool {
    CONTAINING.with(|c| c.get() > 0)
}

/// Runs `job`, turning a panic into an error that says what crashed (`what`) and why.
pub fn contain<T>(what: impl FnOnce() -> String, job: impl FnOnce() -> T) -> Result<T, String> {
    CONTAINING.with(|c| c.set(c.get() + 1));
    let result = std::panic::catch_unwind(AssertUnwindSafe(job));
    CONTAINING.with(|c| c.set(c.get() - 1));
    result.map_err(|payload| crashed(what(), &*payload))
}

/// The message for a job that crashed.
pub fn crashed(what: String, payload: &(dyn Any + Send)) -> String {
    format!(
        "{what}: crashed ({}); this is a bug in Treelight, please report it",
        panic_message(payload)
    )
}

/// A panic's message, when it has one.
pub fn panic_message(payload: &(dyn Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_owned()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "no message".into()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_becomes_an_error_naming_the_job() {
        let e = contain(
            || "importing /x/y.glb".to_owned(),
            || -> u32 { panic!("index out of bounds") },
        )
        .unwrap_err();
        assert!(
            e.starts_with("importing /x/y.glb: crashed (index out of bounds)"),
            "{e}"
        );
        assert_eq!(contain(String::new, || 7), Ok(7));
    }
}
