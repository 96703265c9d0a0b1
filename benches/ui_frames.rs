//! The editor's own main-thread time while a user drags a 1M-triangle mesh with the gizmo, on its
//! real window: the editor binary under Xvfb, driven through the X server (XTEST) as the input tests
//! drive it, reading the main-world frame time and the UI system's share from its `--state` report
//! (`main_ms`: `First` to `Last`, everything but rendering; `ui_ms`: the panels, menus and the
//! viewport's input and overlay).
//!
//! Run: `cargo bench -p treelight --bench ui_frames` (needs Xvfb and Mesa's software Vulkan, as the
//! tests do). Prints a markdown table.

#[path = "../tests/support/mod.rs"]
mod support;
#[path = "../tests/support/xdrive.rs"]
mod xdrive;

use std::io::Write;
use std::path::Path;
use std::time::Duration;
use xdrive::{Session, handle};

/// A binary PLY of a bumpy `n` × `n` grid (2 n² triangles) in `dir`.
fn grid_ply(dir: &Path, n: usize) -> std::path::PathBuf {
    let path = dir.join("grid.ply");
    let verts = (n + 1) * (n + 1);
    let faces = 2 * n * n;
    let mut out = std::io::BufWriter::new(std::fs::File::create(&path).unwrap());
    write!(
        out,
        "ply\nformat binary_little_endian 1.0\nelement vertex {verts}\nproperty float x\nproperty float y\nproperty float z\nelement face {faces}\nproperty list uchar int vertex_indices\nend_header\n"
    )
    .unwrap();
    for j in 0..=n {
        for i in 0..=n {
            let (x, z) = (
                i as f32 / n as f32 * 4.0 - 2.0,
                j as f32 / n as f32 * 4.0 - 2.0,
            );
            let y = 0.6 + 0.1 * (x * 7.0).sin() * (z * 5.0).cos();
            for v in [x, y, z] {
                out.write_all(&v.to_le_bytes()).unwrap();
            }
        }
    }
    for j in 0..n {
        for i in 0..n {
            let a = (j * (n + 1) + i) as i32;
            let (b, c, d) = (a + 1, a + n as i32 + 1, a + n as i32 + 2);
            for tri in [[a, c, b], [b, c, d]] {
                out.write_all(&[3u8]).unwrap();
                for v in tri {
                    out.write_all(&v.to_le_bytes()).unwrap();
                }
            }
        }
    }
    path
}

fn median(mut v: Vec<f32>) -> f32 {
    v.sort_by(f32::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let dir = support::temp_dir("ui-frames");
    let file = grid_ply(&dir, 708);
    let mut s = Session::start("ui-frames", &[file.to_str().unwrap()]);
    let st = s.wait_until("the grid in the tree", Duration::from_secs(300), |st| {
        st.settled && st.objects.iter().any(|o| o.mesh)
    });
    let mesh = st.objects.iter().find(|o| o.mesh).unwrap().clone();
    let at = mesh.screen.expect("the grid on screen");
    s.click(at[0], at[1]);
    let st = s.frames(2);
    assert_eq!(st.selection, vec![mesh.id], "the grid selected");
    // Idle frames with the grid selected, for comparison.
    let mut idle = Vec::new();
    for _ in 0..20 {
        let st = s.frames(1);
        idle.push((st.main_ms, st.ui_ms));
    }
    let arrow = handle(&st, "axis 0").to_vec();
    let grab = (
        arrow[0][0] + (arrow[1][0] - arrow[0][0]) * 0.7,
        arrow[0][1] + (arrow[1][1] - arrow[0][1]) * 0.7,
    );
    s.move_to(grab.0, grab.1);
    s.press(1);
    let mut drag = Vec::new();
    for k in 1..=40 {
        s.move_to(grab.0 + k as f32 * 3.0, grab.1);
        let st = s.frames(1);
        drag.push((st.main_ms, st.ui_ms));
    }
    s.release(1);
    let moved = s.frames(2);
    let after = moved.objects.iter().find(|o| o.id == mesh.id).unwrap();
    assert_ne!(
        after.world_translation, mesh.world_translation,
        "the drag moved the grid"
    );
    println!(
        "## The editor's main thread during a gizmo drag of a {}-triangle mesh (window under Xvfb)\n",
        2 * 708 * 708
    );
    println!(
        "| frames | main world median (ms) | main world max (ms) | UI median (ms) | UI max (ms) |"
    );
    println!("|---|---|---|---|---|");
    for (what, v) in [("idle, selected", &idle), ("dragging", &drag)] {
        let main: Vec<f32> = v.iter().map(|x| x.0).collect();
        let ui: Vec<f32> = v.iter().map(|x| x.1).collect();
        println!(
            "| {what} ({}) | {:.2} | {:.2} | {:.2} | {:.2} |",
            v.len(),
            median(main.clone()),
            main.iter().copied().fold(0.0, f32::max),
            median(ui.clone()),
            ui.iter().copied().fold(0.0, f32::max)
        );
    }
    drop(s);
    std::fs::remove_dir_all(&dir).ok();
}
