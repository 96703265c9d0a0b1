//! egui tells a click from a press held still by the time between the frames that read the press
//! and the release, so on slow frames (a software adapter, a large scene loading) a quick click
//! spans a frame interval or two and read as a hold: the viewport ignored it. The click and
//! double-click windows widen by the recent frame interval.

use bevy::prelude::*;
use bevy_egui::EguiContexts;

/// egui's own windows, seconds: what a click gets at a smooth frame rate.
const CLICK: f64 = 0.8;
const DOUBLE_CLICK: f64 = 0.3;
/// A frame longer than this is a stall (a file dialog, a suspend), not the pace of input.
const LONGEST_FRAME: f64 = 5.0;

/// Widens egui's click windows by the slowest recent frame (decaying over a few seconds, so a
/// slow frame between a press and a release is still counted after it).
pub fn widen_click_windows(
    mut contexts: EguiContexts,
    time: Res<Time<Real>>,
    mut slowest: Local<f64>,
) -> Result {
    let frame = time.delta_secs_f64().min(LONGEST_FRAME);
    *slowest = frame.max(*slowest * 0.9);
    let ctx = contexts.ctx_mut()?;
    let (click, double) = click_windows(*slowest);
    ctx.options_mut(|o| {
        o.input_options.max_click_duration = click;
        o.input_options.max_double_click_delay = double;
    });
    Ok(())
}

/// The click and double-click windows for frames up to `frame` seconds long: a press and its
/// release are read up to two frames apart, a release and the next press one.
pub fn click_windows(frame: f64) -> (f64, f64) {
    (CLICK + 2.0 * frame, DOUBLE_CLICK + frame)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn smooth_frames_keep_egui_s_windows_and_slow_ones_widen_them() {
        let (click, double) = click_windows(1.0 / 60.0);
        assert!((click - 0.8).abs() < 0.05 && (double - 0.3).abs() < 0.02);
        // At 1.4 frames a second, a press read one frame and its release two frames later.
        let (click, double) = click_windows(0.7);
        assert!(click > 1.4 && double > 0.7);
    }
}
