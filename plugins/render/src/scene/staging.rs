//! The scene's record writes go to the GPU through staging buffers kept from frame to frame (wgpu's
//! `StagingBelt`). `Queue::write_buffer` makes a new staging buffer for every write; while a large
//! scene streams in, that is tens of megabytes of fresh memory a frame, which the kernel zeroes
//! page by page before the copy lands in it. Once the stream has ended, the belt's buffers are let
//! go, so an idle editor does not hold the largest frame's staging. A frame that writes more than a
//! round ([`ROUND_BYTES`]) hands each round to the GPU and waits for its copies before staging the
//! next in the same buffers: a fill's or a restructuring's frame that rewrites hundreds of megabytes
//! of records would otherwise hold all of them twice, in its writes and in staging.

use wgpu::util::StagingBelt;

/// Bytes of one staging buffer. Larger writes are copied in pieces of this size, so every buffer
/// is the same size and any of them serves any later piece.
pub const CHUNK_BYTES: u64 = 8 << 20;

/// Bytes staged before they are handed to the GPU and the belt waits for their copies.
pub const ROUND_BYTES: u64 = 2 * CHUNK_BYTES;

/// How many bytes of records a frame makes before it hands them to the GPU ([`ROUND_BYTES`]
/// without it), for an app to insert into its main world: a smaller round holds less memory while
/// a large scene streams in, and waits for the GPU more often. At least one record is handed over
/// each time.
#[derive(bevy::prelude::Resource, Clone, Copy, Debug, PartialEq, Eq)]
pub struct UploadRound(pub u64);

impl Default for UploadRound {
    fn default() -> Self {
        UploadRound(ROUND_BYTES)
    }
}

/// The longest wait for a round's copies (behind the frame the queue is still tracing). A round
/// whose copies take longer stays in its buffers, and the next one takes fresh ones.
const ROUND_WAIT: std::time::Duration = std::time::Duration::from_secs(2);

/// A frame that uploads less than this, while nothing streams in, lets the belt's buffers go
/// (when they are more than one chunk's worth).
const QUIET_FRAME_BYTES: u64 = 1 << 20;

/// The belt and what it has been asked to carry.
pub struct UploadBelt {
    device: wgpu::Device,
    belt: StagingBelt,
    /// The most bytes one frame wrote through this belt: what its buffers may add up to.
    largest_frame: u64,
    /// Bytes written through it this frame.
    this_frame: u64,
    /// Bytes staged since the last round was handed over.
    this_round: u64,
    /// Times its buffers were let go.
    releases: u64,
    /// Rounds handed to the GPU before their frame's end.
    rounds: u64,
}

impl UploadBelt {
    /// An empty belt on `device`.
    pub fn new(device: &wgpu::Device) -> Self {
        UploadBelt {
            belt: StagingBelt::new(device.clone(), CHUNK_BYTES),
            device: device.clone(),
            largest_frame: 0,
            this_frame: 0,
            this_round: 0,
            releases: 0,
            rounds: 0,
        }
    }

    /// How many times the belt let its buffers go.
    pub fn releases(&self) -> u64 {
        self.releases
    }

    /// Records into `encoder` the copy of `bytes` to `target` at byte `offset`. Both must be
    /// multiples of 4 bytes (every record is); a write that is not is left out (`false`). Once a
    /// round's worth is staged, the round goes to the GPU through `queue`, a fresh encoder takes
    /// the place of `encoder`, and the belt waits for the round's copies (at most two seconds) so
    /// that the next round reuses its buffers.
    pub fn write(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
        queue: &wgpu::Queue,
        target: &wgpu::Buffer,
        offset: u64,
        bytes: &[u8],
    ) -> bool {
        if !offset.is_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT)
            || !(bytes.len() as u64).is_multiple_of(wgpu::COPY_BUFFER_ALIGNMENT)
        {
            return false;
        }
        let mut at = offset;
        for piece in bytes.chunks(CHUNK_BYTES as usize) {
            let Some(size) = wgpu::BufferSize::new(piece.len() as u64) else {
                continue;
            };
            self.belt
                .write_buffer(encoder, target, at, size)
                .copy_from_slice(piece);
            at += size.get();
            self.this_frame += size.get();
            self.this_round += size.get();
            if self.this_round >= ROUND_BYTES {
                self.end_round(encoder, queue);
            }
        }
        true
    }

    /// Closes the round staged so far, submits what `encoder` holds (a fresh encoder takes its
    /// place) and waits for its copies (at most [`ROUND_WAIT`]), so the next round reuses the same
    /// buffers.
    fn end_round(&mut self, encoder: &mut wgpu::CommandEncoder, queue: &wgpu::Queue) {
        self.belt.finish();
        let fresh = self
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("treelight scene upload"),
            });
        let index = queue.submit([std::mem::replace(encoder, fresh).finish()]);
        self.belt.recall();
        let wait = wgpu::PollType::Wait {
            submission_index: Some(index),
            timeout: Some(ROUND_WAIT),
        };
        if let Err(e) = self.device.poll(wait) {
            bevy::log::debug!("treelight: a staged round's copies not yet done: {e}");
        }
        self.rounds += 1;
        self.this_round = 0;
    }

    /// Rounds handed to the GPU before their frame's end, all frames together.
    pub fn rounds(&self) -> u64 {
        self.rounds
    }

    /// Closes this frame's staging; the encoder's commands may be submitted after it.
    pub fn finish(&mut self) {
        self.belt.finish();
    }

    /// After the submission: the staging buffers come back once the GPU has copied them.
    /// `streaming` says whether new geometry is still on its way; once it is not and the frames
    /// are quiet, a belt grown for a stream is let go.
    pub fn recall(&mut self, streaming: bool) {
        self.belt.recall();
        self.this_round = 0;
        let frame = std::mem::take(&mut self.this_frame);
        self.largest_frame = self.largest_frame.max(frame);
        if !streaming && frame < QUIET_FRAME_BYTES && self.largest_frame > CHUNK_BYTES {
            // Buffers still being copied from stay alive in wgpu until the copy is done.
            self.belt = StagingBelt::new(self.device.clone(), CHUNK_BYTES);
            self.largest_frame = 0;
            self.releases += 1;
        }
    }
}
