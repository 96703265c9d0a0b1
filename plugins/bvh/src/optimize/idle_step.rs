//! Global updates in bounded steps, for an owner that must release the tree between them (the
//! scene worker's idle time).

use super::update::{Move, share, worst_first};
use crate::Bvh;
use crate::tree::node::NodeKind;

/// Where [`Bvh::optimize_step`] goes on: a sweep position over the inner-node slots, and scratch
/// space, so global updates can be spread over many short calls between edits.
#[derive(Clone, Debug, Default)]
pub struct OptimizeCursor {
    next: u32,
    sweep: u32,
    candidates: Vec<(f32, u32)>,
}

impl OptimizeCursor {
    /// Complete sweeps over the inner-node slots so far.
    pub fn sweeps(&self) -> u32 {
        self.sweep
    }
}

impl Bvh {
    /// A bounded slice of the post-pass: scans the next `scan` inner-node slots after the cursor and
    /// moves the `fraction` most inefficient live nodes among them (children re-insertion on even
    /// sweeps, subtree re-insertion on odd ones), keeping only moves that lower the cost. Its time is
    /// O(scan + moves · search), whatever the tree's size, so a caller holding a lock can release it
    /// between steps. Returns the number of moves tried.
    pub fn optimize_step(&mut self, cursor: &mut OptimizeCursor, scan: u32, fraction: f32) -> u32 {
        let slots = self.inner.len() as u32;
        if slots == 0 || self.root.kind() != NodeKind::Inner {
            return 0;
        }
        let start = cursor.next.min(slots);
        let end = start.saturating_add(scan.max(1)).min(slots);
        let candidates = &mut cursor.candidates;
        candidates.clear();
        for i in start..end {
            // Free slots and the root are skipped here; nodes inside kept-whole groups below.
            if self.inner[i as usize].has_parent() {
                candidates.push((self.inefficiency(i), i));
            }
        }
        let kind = Move::alternating(cursor.sweep);
        if end == slots {
            cursor.next = 0;
            cursor.sweep += 1;
        } else {
            cursor.next = end;
        }
        let k = share(fraction, candidates.len());
        worst_first(candidates, k);
        let saved = std::mem::replace(&mut self.config.keep_only_improving, true);
        let moves = self.reinsert_each(&cursor.candidates[..k], kind);
        self.config.keep_only_improving = saved;
        moves
    }
}
