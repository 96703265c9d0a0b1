//! The scene's record writes go to the GPU through staging buffers kept from frame to frame (wgpu's
//! `StagingBelt`). `Queue::write_buffer` makes a new staging buffer for every write; while a large
//! scene streams in, that is tens of megabytes of fresh memory a frame, which the kernel zeroes
//! page by page before the copy lands in it. Once the stream has ended, the belt's buffers are let
//! go, so an idle editor does not hold the largest frame's staging.

use wgpu::util::StagingBelt;

/// Bytes of one staging buffer. Larger writes are copied in pieces of this size, so every buffer
/// is the same size and any of them serves any later piece.
pub const CHUNK_BYTES: u64 = 8 << 20;

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
    /// Times its buffers were let go.
    releases: u64,
}

impl UploadBelt {
    /// An empty belt on `device`.
    pub fn new(device: &wgpu::Device) -> Self {
        UploadBelt {
            belt: StagingBelt::new(device.clone(), CHUNK_BYTES),
            device: device.clone(),
            largest_frame: 0,
            this_frame: 0,
            releases: 0,
        }
    }

    /// How many times the belt let its buffers go.
    pub fn releases(&self) -> u64 {
        self.releases
    }

    /// Records into `encoder` the copy of `bytes` to `target` at byte `offset`. Both must be
    /// multiples of 4 bytes (every record is); a write that is not is left out (`false`).
    pub fn write(
        &mut self,
        encoder: &mut wgpu::CommandEncoder,
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
        }
        self.this_frame += bytes.len() as u64;
        true
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
