//! The frame budget as plain arithmetic: the order in which a view's tiles are traced, how many
//! pixels fit in the time a frame may spend tracing, and how coarse the preview after a restart is.
//! Nothing here touches the GPU, so the unit tests below and the GPU tests drive the kernel with the
//! schedule the plugin uses.

use std::collections::VecDeque;

/// Pixels along each side of a tile: one 8×8 workgroup of the trace kernel.
pub const TILE: u32 = 8;

/// The coarsest preview: one traced pixel per `MAX_PREVIEW_SCALE`² image pixels.
pub const MAX_PREVIEW_SCALE: u32 = 16;

/// Pixel samples a view traces per frame before its first timing arrives.
pub(crate) const FIRST_GUESS_SAMPLES: u64 = 4096;

/// The order in which a view's tiles are traced. Tile `j` of the sequence is `j * stride mod total`,
/// with `stride` near `total` over the golden ratio and coprime with `total`: `total` consecutive
/// entries cover the image exactly once, and any shorter run is spread evenly over it, so a frame
/// that traces a few tiles refines the whole image a little rather than one corner at a time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct TileOrder {
    /// Tiles per row.
    pub tiles_x: u32,
    /// Tiles in the image.
    pub total: u32,
    /// The sequence's step, coprime with `total`.
    pub stride: u32,
}

fn gcd(mut a: u32, mut b: u32) -> u32 {
    while b != 0 {
        (a, b) = (b, a % b);
    }
    a
}

impl TileOrder {
    /// The order for an image of `width` × `height` pixels.
    pub fn new(width: u32, height: u32) -> Self {
        let tiles_x = width.div_ceil(TILE).max(1);
        let total = tiles_x * height.div_ceil(TILE).max(1);
        let mut stride = ((total as f64) * 0.618_033_988_749_895).round() as u32;
        stride = stride.clamp(1, total.saturating_sub(1).max(1));
        while gcd(stride, total) != 1 {
            stride += 1;
        }
        Self {
            tiles_x,
            total,
            stride,
        }
    }

    /// The tile at position `j` of the sequence, as the kernel computes it.
    pub fn tile(&self, j: u32) -> u32 {
        ((j as u64 * self.stride as u64) % self.total as u64) as u32
    }
}

/// Where a view stands in its tile sequence since its accumulation last restarted.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TileCursor {
    /// The next position in the sequence.
    pub next: u32,
    /// Tiles traced since the restart.
    pub traced: u64,
}

impl TileCursor {
    /// Takes the next `count` tiles (at most one sweep) and returns the run's start.
    pub fn take(&mut self, order: &TileOrder, count: u32) -> u32 {
        let start = self.next;
        let count = count.min(order.total);
        self.next = ((start as u64 + count as u64) % order.total as u64) as u32;
        self.traced += count as u64;
        start
    }

    /// Whole sweeps over the image since the restart: every pixel has at least this many
    /// dispatches' samples, and none more than one beyond it.
    pub fn sweeps(&self, order: &TileOrder) -> u64 {
        self.traced / order.total as u64
    }
}

/// How long a frame may spend tracing: the larger of a fixed time and a share of the rest of the
/// frame, so a slow frame (a busy UI, a software adapter) does not starve the preview while the
/// trace never takes the frame rate below `1 / (1 + share)` of what the rest allows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FrameBudget {
    /// Milliseconds a frame may always spend; zero or less (or NaN) traces the whole image every
    /// frame.
    pub millis: f32,
    /// Share of the rest of the frame's time the trace may also take.
    pub share: f32,
    /// The most pixel samples a frame may trace whatever the time allows (`u64::MAX`: no such
    /// bound).
    pub max_samples: u64,
}

/// The most pixel samples a frame traces while new geometry streams into the tree (a preview):
/// the frame times vary too much with the uploads for their fit to show the trace's cost, and a
/// software adapter's timestamps read it a hundred times low.
pub const FILLING_MAX_SAMPLES: u64 = FIRST_GUESS_SAMPLES;

impl FrameBudget {
    /// Whether the budget limits the trace at all.
    pub fn is_bounded(&self) -> bool {
        self.millis > 0.0
    }
}

/// What tracing costs on this view's adapter: an estimate of the time per pixel sample, the larger
/// of two measures. GPU timestamps of the trace pass, where the adapter has them, see the pass alone
/// but can read low (a software adapter that runs compute work outside the timed span); a
/// least-squares fit of frame intervals against the samples each frame traced sees what the frame
/// really waited for, wherever the trace limits the frame rate.
#[derive(Clone, Debug, Default)]
pub struct TraceClock {
    /// Nanoseconds per pixel sample from GPU timestamps (a moving average).
    timed: Option<f64>,
    /// Nanoseconds per pixel sample from the frame-interval fit (a moving average).
    fitted: Option<f64>,
    /// The frame interval, nanoseconds (a moving average).
    frame_ns: Option<f64>,
    /// Pixel samples of the latest frame.
    last_samples: u64,
    /// Recent (samples traced, frame interval) pairs, for the fit.
    frames: VecDeque<(f64, f64)>,
    /// Frames observed: the dither's parity (the window above stops growing).
    observed: u64,
    /// The most pixel samples an observed frame traced since the figures were last forgotten.
    peak_samples: u64,
    /// The size of the scene these figures are of ([`TraceClock::scene_size`]).
    scene_size: u64,
    /// Raised each time the figures are forgotten: timings of frames from before are not used.
    epoch: u64,
}

const SMOOTHING: f64 = 0.3;
const FIT_FRAMES: usize = 24;

fn blend(old: Option<f64>, new: f64) -> f64 {
    old.map_or(new, |o| o + SMOOTHING * (new - o))
}

/// Where a [`TraceClock`]'s estimate comes from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CostSource {
    /// GPU timestamps of the trace pass.
    Timestamps,
    /// The fit of frame intervals.
    FrameTimes,
}

impl TraceClock {
    /// Tells the clock the size of the scene the next frame traces (its triangle records'
    /// capacity, which grows in steps of an eighth or more). At a new size the clock forgets what a sample cost: a
    /// scene that grew from empty to millions of triangles costs hundreds of times more a sample,
    /// and one frame traced at the old cost would stall the editor for a second. Until a timing
    /// of the new scene arrives, a frame traces a first guess's samples.
    pub fn scene_size(&mut self, size: u64) {
        if size != self.scene_size {
            *self = Self {
                scene_size: size,
                epoch: self.epoch + 1,
                ..Self::default()
            };
        }
    }

    /// Which of the scene sizes seen this clock's figures are of: a GPU timing of a frame traced
    /// before it changed is not fed to [`TraceClock::observe_trace`].
    pub fn epoch(&self) -> u64 {
        self.epoch
    }

    /// A GPU timing: `samples` pixel samples took `ns` nanoseconds.
    pub fn observe_trace(&mut self, samples: u64, ns: f64) {
        if samples == 0 || !ns.is_finite() || ns <= 0.0 {
            return;
        }
        self.timed = Some(blend(self.timed, ns / samples as f64));
    }

    /// A frame ended `ns` after the one before; it traced `samples` pixel samples.
    pub fn observe_frame(&mut self, samples: u64, ns: f64) {
        if !ns.is_finite() || ns <= 0.0 {
            return;
        }
        self.frame_ns = Some(blend(self.frame_ns, ns));
        self.last_samples = samples;
        self.peak_samples = self.peak_samples.max(samples);
        self.observed += 1;
        self.frames.push_back((samples as f64, ns));
        if self.frames.len() > FIT_FRAMES {
            self.frames.pop_front();
        }
        // interval = rest + cost * samples, fitted over the recent frames.
        let n = self.frames.len() as f64;
        if n < 4.0 {
            return;
        }
        let (sx, sy) = self
            .frames
            .iter()
            .fold((0.0, 0.0), |(a, b), &(x, y)| (a + x, b + y));
        let (mx, my) = (sx / n, sy / n);
        let (mut sxx, mut sxy) = (0.0, 0.0);
        for &(x, y) in &self.frames {
            sxx += (x - mx) * (x - mx);
            sxy += (x - mx) * (y - my);
        }
        if sxx > 0.0 && sxy > 0.0 {
            self.fitted = Some(blend(self.fitted, sxy / sxx));
        }
    }

    /// Nanoseconds per pixel sample and where the figure comes from, once known.
    pub fn cost(&self) -> Option<(f64, CostSource)> {
        match (self.timed, self.fitted) {
            (Some(t), Some(f)) if f > t => Some((f, CostSource::FrameTimes)),
            (Some(t), _) => Some((t, CostSource::Timestamps)),
            (None, Some(f)) => Some((f, CostSource::FrameTimes)),
            (None, None) => None,
        }
        .filter(|(c, _)| *c > 0.0)
    }

    /// Nanoseconds per pixel sample, once known.
    pub fn ns_per_sample(&self) -> Option<f64> {
        self.cost().map(|(c, _)| c)
    }

    /// The estimated time the latest frame spent tracing, nanoseconds.
    pub fn last_trace_ns(&self) -> Option<f64> {
        self.ns_per_sample().map(|c| c * self.last_samples as f64)
    }

    /// Pixel samples the next frame may trace under `budget` (`u64::MAX` when it is unbounded):
    /// what fits at the estimated cost, and no more than twice what a frame traced since the
    /// figures were last forgotten. The cost of a sample is only ever seen at the samples traced:
    /// a software adapter's timestamps can read a hundred times low, and the frame intervals
    /// show it only once a frame traces enough for the trace to tell in them. Doubling, each frame
    /// shows the fit how the interval grows with the samples before one costs seconds.
    pub fn sample_budget(&self, budget: &FrameBudget) -> u64 {
        if !budget.is_bounded() {
            return u64::MAX;
        }
        let ramp = self
            .peak_samples
            .saturating_mul(2)
            .max(FIRST_GUESS_SAMPLES)
            .min(budget.max_samples.max(TILE as u64 * TILE as u64));
        let Some(cost) = self.ns_per_sample() else {
            return FIRST_GUESS_SAMPLES.min(ramp);
        };
        let fixed = budget.millis as f64 * 1e6;
        let rest = self
            .frame_ns
            .map_or(0.0, |f| (f - cost * self.last_samples as f64).max(0.0));
        let share = if budget.share.is_finite() {
            budget.share.max(0.0) as f64
        } else {
            0.0
        };
        let ns = fixed.max(share * rest);
        ((ns / cost) as u64).clamp(TILE as u64 * TILE as u64, ramp)
    }

    /// Tiles of `per_tile` samples the next frame traces when it may trace `allowed` samples: at
    /// least one, at most a sweep of the `total`, [`dithered`](TraceClock::dither) within those
    /// bounds. A budget past a whole sweep still alternates a sweep with 85% of one: frames that
    /// all traced the same samples would leave the frame-interval fit nothing to fit, and a cost
    /// that timestamps read low (a software adapter) would never be corrected.
    /// An unbounded budget (`u64::MAX`) traces whole sweeps, undithered.
    pub fn tiles(&self, allowed: u64, per_tile: u64, total: u32) -> u32 {
        if allowed == u64::MAX {
            return total.max(1);
        }
        let per_tile = per_tile.max(1);
        let count = (allowed / per_tile).clamp(1, total as u64);
        (self.dither(count * per_tile) / per_tile).clamp(1, total as u64) as u32
    }

    /// `samples` nudged up or down by 15 %, alternately, so the frame-interval fit can tell the
    /// trace's cost from the rest of the frame (the tiles take this; the preview's scale does not,
    /// so it holds still while the camera moves).
    pub fn dither(&self, samples: u64) -> u64 {
        if samples == u64::MAX {
            return samples;
        }
        let f = if self.observed.is_multiple_of(2) {
            0.85
        } else {
            1.15
        };
        (samples as f64 * f) as u64
    }
}

/// The preview's scale for an image of `pixels` pixels when a frame may trace `budget` samples: the
/// finest integer scale (2 at least) whose one sample per block fits, at most
/// [`MAX_PREVIEW_SCALE`].
pub fn preview_scale(width: u32, height: u32, budget: u64) -> u32 {
    (2..MAX_PREVIEW_SCALE)
        .find(|k| width.div_ceil(*k) as u64 * height.div_ceil(*k) as u64 <= budget)
        .unwrap_or(MAX_PREVIEW_SCALE)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn after_a_new_size_the_samples_grow_no_faster_than_the_frames_show_their_cost() {
        // A grown scene on a software adapter: its timestamps say 20 ns a sample, a sample
        // really costs 10 µs; the rest of the frame takes 300 ms, and the trace may have a tenth.
        let budget = FrameBudget {
            millis: 4.0,
            share: 0.1,
            max_samples: u64::MAX,
        };
        let (per_tile, total) = (64, 2160);
        let mut clock = TraceClock::default();
        clock.scene_size(1 << 22);
        let (mut slowest, mut settled) = (0.0f64, 0.0);
        for frame in 0..40 {
            let allowed = clock.sample_budget(&budget);
            assert!(
                allowed <= (2 * clock.peak_samples).max(FIRST_GUESS_SAMPLES),
                "frame {frame}: {allowed} samples after at most {}",
                clock.peak_samples
            );
            let samples = clock.tiles(allowed, per_tile, total) as u64 * per_tile;
            let trace = samples as f64 * 1e4;
            slowest = f64::max(slowest, trace);
            if frame >= 30 {
                settled += trace / 10.0;
            }
            clock.observe_trace(samples, samples as f64 * 20.0);
            clock.observe_frame(samples, 3e8 + trace);
        }
        // Taken at the timestamps' word, the first timed frame would trace a whole sweep: 1.4 s.
        assert!(slowest < 0.5e9, "a frame traced for {:.2} s", slowest / 1e9);
        assert!(
            settled < 0.06e9,
            "settled at {:.0} ms a frame",
            settled / 1e6
        );
    }

    #[test]
    fn a_sweep_covers_every_tile_once_and_runs_spread_out() {
        for (w, h) in [
            (1, 1),
            (8, 8),
            (9, 7),
            (640, 360),
            (1917, 1001),
            (3840, 2160),
        ] {
            let order = TileOrder::new(w, h);
            assert_eq!(gcd(order.stride, order.total), 1);
            let mut seen = vec![false; order.total as usize];
            for j in 0..order.total {
                let t = order.tile(j) as usize;
                assert!(!seen[t], "{w}x{h}: tile {t} twice");
                seen[t] = true;
            }
            if order.total >= 64 {
                // The first eighth of a sweep touches every eighth of the image's rows of tiles.
                let rows = order.total / order.tiles_x;
                let mut bands = [false; 8];
                for j in 0..order.total / 8 {
                    let row = order.tile(j) / order.tiles_x;
                    bands[(row * 8 / rows) as usize] = true;
                }
                assert!(bands.iter().all(|b| *b), "{w}x{h}: {bands:?}");
            }
        }
    }

    #[test]
    fn the_cursor_counts_sweeps_across_uneven_runs() {
        let order = TileOrder::new(100, 60);
        let mut cursor = TileCursor::default();
        let mut per_tile = vec![0u32; order.total as usize];
        for count in [1, 7, 30, 2, 200, 5, 13].into_iter().cycle().take(40) {
            let start = cursor.take(&order, count);
            for i in 0..count.min(order.total) {
                per_tile[order.tile((start + i) % order.total) as usize] += 1;
            }
        }
        let sweeps = cursor.sweeps(&order) as u32;
        assert!(per_tile.iter().all(|&n| n == sweeps || n == sweeps + 1));
    }

    /// A budget of `millis` a frame and `share` of the rest of it, without a bound on samples.
    fn budget(millis: f32, share: f32) -> FrameBudget {
        FrameBudget {
            millis,
            share,
            max_samples: u64::MAX,
        }
    }

    /// Runs `frames` frames of `clock` under `budget`: a sample costs `trace_ns` by the pass's
    /// timestamps (`None`: the adapter has none) and `frame_ns` in a frame whose rest takes
    /// `rest_ns`.
    fn run(
        clock: &mut TraceClock,
        budget: &FrameBudget,
        frames: usize,
        trace_ns: Option<f64>,
        (rest_ns, frame_ns): (f64, f64),
    ) {
        for _ in 0..frames {
            let samples = clock.dither(clock.sample_budget(budget));
            if let Some(t) = trace_ns {
                clock.observe_trace(samples, samples as f64 * t);
            }
            clock.observe_frame(samples, rest_ns + samples as f64 * frame_ns);
        }
    }

    #[test]
    fn the_budget_follows_the_gpu_timing_and_the_rest_of_the_frame() {
        let budget = budget(4.0, 0.25);
        let mut clock = TraceClock::default();
        assert_eq!(clock.sample_budget(&budget), FIRST_GUESS_SAMPLES);
        // 100 ns a sample; the rest of the frame takes 8 ms, and overlaps part of the trace (so
        // the frames alone would say 60 ns): the fixed 4 ms wins.
        run(&mut clock, &budget, 40, Some(100.0), (8e6, 60.0));
        let n = clock.sample_budget(&budget) as f64;
        assert!((39_000.0..=41_000.0).contains(&n), "{n}");
        assert_eq!(clock.cost().unwrap().1, CostSource::Timestamps);
        // A slow rest of the frame (200 ms) lets the trace take a quarter of it.
        run(&mut clock, &budget, 80, Some(100.0), (200e6, 100.0));
        let n = clock.sample_budget(&budget) as f64;
        assert!((480_000.0..=520_000.0).contains(&n), "{n}");
        // No fixed time: the whole image every frame.
        let whole = FrameBudget {
            millis: 0.0,
            ..budget
        };
        assert_eq!(clock.sample_budget(&whole), u64::MAX);
    }

    #[test]
    fn without_timestamps_the_fit_finds_the_cost_from_frame_intervals() {
        let budget = budget(4.0, 0.0);
        let mut clock = TraceClock::default();
        run(&mut clock, &budget, 200, None, (30e6, 50.0));
        let cost = clock.ns_per_sample().unwrap();
        assert!((cost - 50.0).abs() < 2.5, "{cost}");
        let n = clock.sample_budget(&budget) as f64;
        assert!((76_000.0..=84_000.0).contains(&n), "{n}");
    }

    #[test]
    fn timestamps_that_read_low_lose_to_the_frame_intervals() {
        let budget = budget(4.0, 0.0);
        let mut clock = TraceClock::default();
        // The pass's timestamps say 1 ns a sample; the frames show 50.
        run(&mut clock, &budget, 200, Some(1.0), (30e6, 50.0));
        let (cost, source) = clock.cost().unwrap();
        assert_eq!(source, CostSource::FrameTimes);
        assert!((cost - 50.0).abs() < 2.5, "{cost}");
    }

    #[test]
    fn the_preview_is_the_finest_scale_that_fits() {
        assert_eq!(preview_scale(640, 360, u64::MAX), 2);
        assert_eq!(preview_scale(640, 360, 320 * 180), 2);
        assert_eq!(preview_scale(640, 360, 320 * 180 - 1), 3);
        assert_eq!(preview_scale(640, 360, 1), MAX_PREVIEW_SCALE);
    }
}
