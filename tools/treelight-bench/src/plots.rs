//! PNG plots of the benchmark's runs: triangles inserted and SAH cost against time during construction
//! (the paper's Figures 8 and 9), and insertion against full rebuilds in the latency experiment (its
//! Figure 12).

use crate::latency::{LatencyRow, Rebuild};
use plotters::prelude::*;
use std::path::{Path, PathBuf};
use std::sync::Once;

/// One method's construction, sampled: (seconds, triangles inserted, SAH cost).
pub struct Progress {
    pub method: String,
    pub samples: Vec<(f64, usize, f32)>,
}

const SIZE: (u32, u32) = (900, 600);
const FONT: &str = "sans-serif";

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // Bundled with egui: no font is looked up on the system.
        if plotters::style::register_font(
            FONT,
            FontStyle::Normal,
            epaint_default_fonts::UBUNTU_LIGHT,
        )
        .is_err()
        {
            eprintln!(
                "treelight-bench: the bundled font could not be registered; plots have no text"
            );
        }
    });
}

fn colour(k: usize) -> RGBColor {
    const PALETTE: [RGBColor; 10] = [
        RGBColor(31, 119, 180),
        RGBColor(255, 127, 14),
        RGBColor(44, 160, 44),
        RGBColor(214, 39, 40),
        RGBColor(148, 103, 189),
        RGBColor(140, 86, 75),
        RGBColor(227, 119, 194),
        RGBColor(127, 127, 127),
        RGBColor(188, 189, 34),
        RGBColor(23, 190, 207),
    ];
    PALETTE[k % PALETTE.len()]
}

/// A legend entry's swatch: a short line in the series' colour.
fn swatch(c: RGBColor) -> impl Fn((i32, i32)) -> PathElement<(i32, i32)> {
    move |(x, y)| PathElement::new([(x, y), (x + 18, y)], c.stroke_width(2))
}

/// Draws the legend, in the same style on every plot, at `corner`.
fn legend<'a, DB: DrawingBackend + 'a, CT: CoordTranslate>(
    chart: &mut ChartContext<'a, DB, CT>,
    corner: SeriesLabelPosition,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    chart
        .configure_series_labels()
        .position(corner)
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .label_font((FONT, 14))
        .draw()
}

/// A file name from a scene name: letters, digits and dashes only.
fn slug(s: &str) -> String {
    let name = Path::new(s)
        .file_stem()
        .map_or_else(|| s.to_owned(), |n| n.to_string_lossy().into_owned());
    name.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect()
}

fn err(path: &Path, e: impl std::fmt::Display) -> String {
    format!("{}: {e}", path.display())
}

/// Figures 8 and 9 for one scene and order; returns the files written.
pub fn construction(
    dir: &Path,
    scene: &str,
    order: &str,
    runs: &[Progress],
) -> Result<Vec<PathBuf>, String> {
    register_font();
    let times = || runs.iter().flat_map(|r| r.samples.iter().map(|s| s.0));
    let t_max = times().fold(1e-6, f64::max);
    // A log time axis: the post-pass runs ten times longer than any build, and would squash them.
    let t_min = times().fold(t_max, f64::min).max(1e-6);
    let n_max = runs
        .iter()
        .flat_map(|r| r.samples.iter().map(|s| s.1))
        .max()
        .unwrap_or(1) as f64;
    let costs = runs
        .iter()
        .flat_map(|r| r.samples.iter().map(|s| s.2 as f64));
    let c_max = costs.fold(0.0f64, f64::max);
    let mut files = Vec::new();
    for figure in [8, 9] {
        let path = dir.join(format!("fig{figure}-{}-{order}.png", slug(scene)));
        {
            let root = BitMapBackend::new(&path, SIZE).into_drawing_area();
            root.fill(&WHITE).map_err(|e| err(&path, e))?;
            let title = if figure == 8 {
                format!("{scene}, {order} order: triangles inserted over time")
            } else {
                format!("{scene}, {order} order: SAH cost over time")
            };
            let mut chart = ChartBuilder::on(&root)
                .caption(title, (FONT, 20))
                .margin(12)
                .x_label_area_size(40)
                .y_label_area_size(70)
                .build_cartesian_2d(
                    (t_min * 0.8..t_max * 1.25).log_scale(),
                    0.0..if figure == 8 { n_max } else { c_max } * 1.05,
                )
                .map_err(|e| err(&path, e))?;
            chart
                .configure_mesh()
                .x_desc("time [s], log scale")
                .y_desc(if figure == 8 { "triangles" } else { "SAH cost" })
                .y_label_formatter(&|v| {
                    if figure == 8 {
                        format!("{v:.0}")
                    } else {
                        format!("{v:.1}")
                    }
                })
                .label_style((FONT, 14))
                .draw()
                .map_err(|e| err(&path, e))?;
            for (k, run) in runs.iter().enumerate() {
                let c = colour(k);
                let points: Vec<(f64, f64)> = run
                    .samples
                    .iter()
                    .map(|&(t, n, cost)| (t, if figure == 8 { n as f64 } else { cost as f64 }))
                    .collect();
                let series = chart
                    .draw_series(LineSeries::new(points.clone(), c.stroke_width(2)))
                    .map_err(|e| err(&path, e))?;
                series.label(run.method.clone()).legend(swatch(c));
                // Top-down builders have one point: make it visible.
                chart
                    .draw_series(points.last().map(|&p| Circle::new(p, 4, c.filled())))
                    .map_err(|e| err(&path, e))?;
            }
            let corner = if figure == 8 {
                SeriesLabelPosition::LowerRight
            } else {
                SeriesLabelPosition::UpperLeft
            };
            legend(&mut chart, corner).map_err(|e| err(&path, e))?;
            root.present().map_err(|e| err(&path, e))?;
        }
        files.push(path);
    }
    Ok(files)
}

/// Figure 12 for one scene: insertion time against the share of the scene inserted, with the full
/// rebuilds as horizontal lines.
pub fn latency(
    dir: &Path,
    scene: &str,
    rows: &[LatencyRow],
    rebuilds: &[Rebuild],
) -> Result<PathBuf, String> {
    register_font();
    let path = dir.join(format!("fig12-{}.png", slug(scene)));
    let y_max = rows
        .iter()
        .flat_map(|r| [r.incru_ms, r.incrupb_ms])
        .chain(rebuilds.iter().map(|r| r.ms))
        .fold(1e-3, f64::max);
    {
        let root = BitMapBackend::new(&path, SIZE).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(&path, e))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(
                format!("{scene}: inserting p% of the scene vs rebuilding it"),
                (FONT, 20),
            )
            .margin(12)
            .x_label_area_size(40)
            .y_label_area_size(70)
            .build_cartesian_2d(
                (0.05f64..15.0).log_scale(),
                (0.1f64..y_max * 2.0).log_scale(),
            )
            .map_err(|e| err(&path, e))?;
        chart
            .configure_mesh()
            .x_desc("inserted [% of the scene]")
            .y_desc("time [ms]")
            .label_style((FONT, 14))
            .draw()
            .map_err(|e| err(&path, e))?;
        let lines: [(&str, Vec<(f64, f64)>); 2] = [
            (
                "IncrU insertion",
                rows.iter().map(|r| (r.percent, r.incru_ms)).collect(),
            ),
            (
                "IncrUPB insertion",
                rows.iter().map(|r| (r.percent, r.incrupb_ms)).collect(),
            ),
        ];
        for (k, (name, points)) in lines.into_iter().enumerate() {
            let c = colour(k);
            chart
                .draw_series(LineSeries::new(points.clone(), c.stroke_width(2)))
                .map_err(|e| err(&path, e))?
                .label(name)
                .legend(swatch(c));
            chart
                .draw_series(points.into_iter().map(|p| Circle::new(p, 4, c.filled())))
                .map_err(|e| err(&path, e))?;
        }
        for (k, r) in rebuilds.iter().enumerate() {
            let c = colour(k + 3);
            chart
                .draw_series(LineSeries::new(
                    [(0.05, r.ms), (15.0, r.ms)],
                    c.stroke_width(2),
                ))
                .map_err(|e| err(&path, e))?
                .label(format!("full rebuild, {}", r.method))
                .legend(swatch(c));
        }
        legend(&mut chart, SeriesLabelPosition::UpperLeft).map_err(|e| err(&path, e))?;
        root.present().map_err(|e| err(&path, e))?;
    }
    Ok(path)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn plots_are_written_as_png() {
        let dir = std::env::temp_dir().join(format!("treelight-plots-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let runs = vec![
            Progress {
                method: "incru".into(),
                samples: (1..=10)
                    .map(|k| (k as f64 * 0.01, k * 100, 10.0 + k as f32))
                    .collect(),
            },
            Progress {
                method: "sah".into(),
                samples: vec![(0.05, 1000, 15.0)],
            },
        ];
        let files = construction(&dir, "../scenes/x.obj", "as-is", &runs).unwrap();
        let rows: Vec<LatencyRow> = [0.1, 1.0]
            .iter()
            .map(|&percent| LatencyRow {
                percent,
                inserted: 10,
                incru_ms: percent,
                incru_cost: 1.0,
                incrupb_ms: 2.0 * percent,
                incrupb_cost: 1.0,
            })
            .collect();
        let rebuilds = [Rebuild {
            method: "binned",
            ms: 3.0,
            cost: 1.0,
        }];
        let fig12 = latency(&dir, "x.obj", &rows, &rebuilds).unwrap();
        assert_eq!(files.len(), 2);
        for f in files.iter().chain([&fig12]) {
            assert!(
                f.file_name().unwrap().to_str().unwrap().contains('x'),
                "{f:?}"
            );
            let bytes = std::fs::read(f).unwrap();
            assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n", "{f:?}");
            assert!(bytes.len() > 10_000, "{f:?}: {} bytes", bytes.len());
        }
        std::fs::remove_dir_all(&dir).ok();
    }
}
