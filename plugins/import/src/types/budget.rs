//! One import's memory budget: every large allocation a reader makes is charged here first, so a
//! small file that claims gigabytes is refused with the figure before the memory is asked for.

use crate::types::error::ImportError;
use std::path::Path;

/// The variable that overrides the default budget, in MiB.
pub const BUDGET_VARIABLE: &str = "TREELIGHT_IMPORT_MEMORY_MIB";

/// How an import may behave.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ImportOptions {
    /// Most bytes the import may allocate for what it reads and decodes (files, buffers, decoded
    /// meshes and images, the parsed document); a file that needs more is refused with its name
    /// and the figure.
    pub memory_budget: u64,
}

impl Default for ImportOptions {
    /// Half the memory the machine has free now, or `TREELIGHT_IMPORT_MEMORY_MIB` when it is set.
    fn default() -> Self {
        Self {
            memory_budget: default_memory_budget(),
        }
    }
}

/// The default budget: [`BUDGET_VARIABLE`] (MiB) when set, else half the memory available now
/// (`MemAvailable` on Linux; 4 GiB where that cannot be read).
pub fn default_memory_budget() -> u64 {
    if let Some(mib) = std::env::var(BUDGET_VARIABLE)
        .ok()
        .and_then(|v| v.trim().parse::<u64>().ok())
    {
        return mib.saturating_mul(1 << 20);
    }
    available_memory().map_or(4 << 30, |free| free / 2)
}

/// Bytes of memory available to a new allocation now, as the system reports it.
pub fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// What one import has charged so far against its limit.
pub(crate) struct Budget<'a> {
    file: &'a Path,
    limit: u64,
    used: u64,
    refused: bool,
}

impl<'a> Budget<'a> {
    pub fn new(file: &'a Path, options: &ImportOptions) -> Self {
        Self {
            file,
            limit: options.memory_budget,
            used: 0,
            refused: false,
        }
    }

    /// Records `bytes` about to be allocated for `what`, or refuses when they would pass the limit.
    pub fn charge(&mut self, bytes: u64, what: impl FnOnce() -> String) -> Result<(), ImportError> {
        match self.used.checked_add(bytes) {
            Some(total) if total <= self.limit => {
                self.used = total;
                Ok(())
            }
            _ => {
                self.refused = true;
                Err(ImportError::new(
                    self.file,
                    format!(
                        "needs more memory than the import may use: {} needs {}, with {} already \
                     taken of the budget of {} (half the free memory by default; {BUDGET_VARIABLE} \
                     sets it)",
                        what(),
                        mib(bytes),
                        mib(self.used),
                        mib(self.limit)
                    ),
                ))
            }
        }
    }

    /// Gives back `bytes` charged for memory freed since (a decoder's full-size image once the
    /// kept one is made), so the budget bounds what is held at once, not what passed through.
    pub fn release(&mut self, bytes: u64) {
        self.used = self.used.saturating_sub(bytes);
    }

    /// Whether a charge was refused: the file as a whole does not fit, so a reader that would
    /// skip one bad part (a mesh, a texture) stops instead.
    pub fn refused(&self) -> bool {
        self.refused
    }

    /// `count` elements of `size` bytes each, charged as one allocation.
    pub fn charge_elements(
        &mut self,
        count: usize,
        size: usize,
        what: impl FnOnce() -> String,
    ) -> Result<(), ImportError> {
        self.charge((count as u64).saturating_mul(size as u64), what)
    }

    /// Bytes left before the limit.
    pub fn remaining(&self) -> u64 {
        self.limit - self.used
    }
}

/// A byte count as MiB with one decimal, for messages.
fn mib(bytes: u64) -> String {
    format!("{:.1} MiB", bytes as f64 / (1u64 << 20) as f64)
}
