//! What the device's memory allocator holds: every buffer and texture of the app (the path
//! tracer's, Bevy's meshes and targets) and the staging of uploads, which on a software adapter
//! is the process's own memory. Read now and then into
//! [`PathTracerFigures::gpu_reserved_bytes`](crate::types::figures::PathTracerFigures::gpu_reserved_bytes).

use crate::types::figures::PathTracerStats;
use bevy::prelude::*;
use bevy::render::renderer::RenderDevice;
use bevy::render::{Render, RenderSystems};
use std::time::{Duration, Instant};

/// The shortest time between two reports: one walks every allocation.
const READ_EVERY: Duration = Duration::from_secs(1);

/// When the allocator was last read.
#[derive(Resource, Default)]
struct LastRead(Option<Instant>);

pub(crate) fn build(render_app: &mut SubApp) {
    render_app
        .init_resource::<LastRead>()
        .add_systems(Render, read_allocator.in_set(RenderSystems::Cleanup));
}

fn read_allocator(
    device: Res<RenderDevice>,
    stats: Res<PathTracerStats>,
    mut last: ResMut<LastRead>,
) {
    if last.0.is_some_and(|t| t.elapsed() < READ_EVERY) {
        return;
    }
    last.0 = Some(Instant::now());
    // `None` where the backend keeps no such report (WebGPU, GL).
    let reserved = device
        .wgpu_device()
        .generate_allocator_report()
        .map(|r| r.total_reserved_bytes);
    stats.update(|f| f.gpu_reserved_bytes = reserved);
}
