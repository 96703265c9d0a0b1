//! GPU timestamps of a view's trace pass, read back a few frames later without waiting: where the
//! frame budget's [`TraceClock`] learns what a pixel sample costs. Adapters without timestamp
//! queries get no timer, and the clock falls back to frame intervals.

use crate::types::budget::TraceClock;
use bevy::render::render_resource::{Buffer, BufferDescriptor, BufferUsages, MapMode};
use bevy::render::renderer::{RenderDevice, RenderQueue};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU8, Ordering};

/// Frames whose timings may be in flight at once; a frame finding none free goes untimed.
const SLOTS: usize = 3;
/// Where slot `i`'s two timestamps land in the resolve buffer (wgpu's resolve alignment).
const RESOLVE_STRIDE: u64 = wgpu::QUERY_RESOLVE_BUFFER_ALIGNMENT;
const PENDING: u8 = 0;
const MAPPED: u8 = 1;
const FAILED: u8 = 2;

enum SlotState {
    Free,
    /// Handed to this frame's pass, which traces `samples` pixel samples of the scene the clock's
    /// `epoch` is of.
    Assigned {
        samples: u64,
        epoch: u64,
    },
    /// Its copy was submitted and its mapping requested.
    Mapping {
        samples: u64,
        epoch: u64,
    },
}

struct Slot {
    readback: Buffer,
    state: SlotState,
    /// Set by the node once it recorded the pass's timestamps and their copy.
    recorded: AtomicBool,
    /// Set by the mapping's callback: [`MAPPED`] or [`FAILED`].
    mapped: Arc<AtomicU8>,
}

/// One view's timestamp queries and their readback buffers.
pub(crate) struct TraceTimer {
    queries: wgpu::QuerySet,
    resolved: Buffer,
    slots: [Slot; SLOTS],
    period_ns: f64,
}

impl TraceTimer {
    /// A timer, or `None` where the device has no timestamp queries.
    pub fn new(device: &RenderDevice, queue: &RenderQueue) -> Option<Self> {
        if !device.features().contains(wgpu::Features::TIMESTAMP_QUERY) {
            return None;
        }
        let queries = device
            .wgpu_device()
            .create_query_set(&wgpu::QuerySetDescriptor {
                label: Some("treelight trace timestamps"),
                ty: wgpu::QueryType::Timestamp,
                count: 2 * SLOTS as u32,
            });
        let resolved = device.create_buffer(&BufferDescriptor {
            label: Some("treelight trace timestamps resolved"),
            size: RESOLVE_STRIDE * SLOTS as u64,
            usage: BufferUsages::QUERY_RESOLVE | BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let slots = std::array::from_fn(|_| Slot {
            readback: device.create_buffer(&BufferDescriptor {
                label: Some("treelight trace timestamps readback"),
                size: 16,
                usage: BufferUsages::COPY_DST | BufferUsages::MAP_READ,
                mapped_at_creation: false,
            }),
            state: SlotState::Free,
            recorded: AtomicBool::new(false),
            mapped: Arc::new(AtomicU8::new(PENDING)),
        });
        Some(Self {
            queries,
            resolved,
            slots,
            period_ns: queue.get_timestamp_period() as f64,
        })
    }

    /// Feeds the clock every timing that has arrived, freeing its slot.
    pub fn harvest(&mut self, clock: &mut TraceClock) {
        for slot in &mut self.slots {
            let SlotState::Mapping { samples, epoch } = slot.state else {
                continue;
            };
            match slot.mapped.swap(PENDING, Ordering::Acquire) {
                MAPPED => {}
                FAILED => {
                    slot.state = SlotState::Free;
                    continue;
                }
                _ => continue,
            }
            let ticks = {
                let data = slot.readback.slice(..).get_mapped_range();
                let t = |i: usize| u64::from_le_bytes(data[8 * i..8 * i + 8].try_into().unwrap());
                t(1).saturating_sub(t(0))
            };
            slot.readback.unmap();
            slot.state = SlotState::Free;
            // A timing of the scene before it changed size says nothing of this one's cost.
            if epoch == clock.epoch() {
                clock.observe_trace(samples, ticks as f64 * self.period_ns);
            }
        }
    }

    /// A free slot for this frame's pass of `samples` pixel samples, traced with the clock at
    /// `epoch` ([`TraceClock::epoch`]), if any.
    pub fn assign(&mut self, samples: u64, epoch: u64) -> Option<usize> {
        let (i, slot) = self
            .slots
            .iter_mut()
            .enumerate()
            .find(|(_, s)| matches!(s.state, SlotState::Free))?;
        slot.state = SlotState::Assigned { samples, epoch };
        slot.recorded.store(false, Ordering::Relaxed);
        Some(i)
    }

    /// The compute pass's timestamp writes for slot `i`.
    pub fn pass_writes(&self, i: usize) -> wgpu::ComputePassTimestampWrites<'_> {
        wgpu::ComputePassTimestampWrites {
            query_set: &self.queries,
            beginning_of_pass_write_index: Some(2 * i as u32),
            end_of_pass_write_index: Some(2 * i as u32 + 1),
        }
    }

    /// After the pass: resolves slot `i`'s timestamps and copies them where they can be mapped.
    pub fn copy_out(&self, i: usize, encoder: &mut wgpu::CommandEncoder) {
        let at = RESOLVE_STRIDE * i as u64;
        let first = 2 * i as u32;
        encoder.resolve_query_set(&self.queries, first..first + 2, &self.resolved, at);
        encoder.copy_buffer_to_buffer(&self.resolved, at, &self.slots[i].readback, 0, 16);
        self.slots[i].recorded.store(true, Ordering::Relaxed);
    }

    /// After the frame's submission: asks to map what this frame recorded; frees what it did not.
    pub fn request_readback(&mut self) {
        for slot in &mut self.slots {
            let SlotState::Assigned { samples, epoch } = slot.state else {
                continue;
            };
            if !slot.recorded.load(Ordering::Relaxed) {
                slot.state = SlotState::Free;
                continue;
            }
            let mapped = slot.mapped.clone();
            slot.readback
                .slice(..)
                .map_async(MapMode::Read, move |result| {
                    let state = if result.is_ok() { MAPPED } else { FAILED };
                    mapped.store(state, Ordering::Release);
                });
            slot.state = SlotState::Mapping { samples, epoch };
        }
    }
}
