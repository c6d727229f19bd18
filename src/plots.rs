//! Pictures a person would rather look at than read: learning curves, latent spaces and joint
//! trajectories, each written as SVG and PNG (plotters, with an embedded font so that no system
//! font library is needed).
//!
//! This file holds what a figure is made of ([`Panel`], [`Series`], [`Markers`], [`Layout`]) and
//! writes it; the drawing is in `draw`, where legends and annotations go in `placement`.

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::prelude::*;

use crate::files::{atomic_write_with, FileError};

mod draw;
mod placement;

use draw::draw_all;

const FONT: &[u8] = include_bytes!("../data/fonts/DejaVuSans.ttf");
static REGISTER_FONT: Once = Once::new();

/// One line of a panel, optionally with a shaded band (for example mean ± one standard deviation).
#[derive(Debug, Clone, Default)]
pub struct Series {
    /// Legend label.
    pub label: String,
    /// Index into the palette, so that one model keeps one colour across panels.
    pub color: usize,
    /// Draw dashed (for example "desired" against "predicted").
    pub dashed: bool,
    /// Points of the line.
    pub points: Vec<(f64, f64)>,
    /// Lower and upper edge of a band drawn under the line, the same length as `points`.
    pub band: Option<Vec<(f64, f64)>>,
}

/// A scatter of labelled or unlabelled markers.
#[derive(Debug, Clone, Default)]
pub struct Markers {
    /// Legend label.
    pub label: String,
    /// Palette index.
    pub color: usize,
    /// Filled circles (key poses) rather than crosses (training points); the legend shows the
    /// same ([`Markers::sample`]).
    pub circles: bool,
    /// The points.
    pub points: Vec<(f64, f64)>,
    /// A text drawn next to each point (empty for none).
    pub annotations: Vec<String>,
}

impl Markers {
    /// The mark its points are drawn with, which its legend entry shows too.
    pub fn sample(&self) -> Sample {
        if self.circles {
            Sample::Circle
        } else {
            Sample::Cross
        }
    }
}

/// What a legend entry shows: a sample of the line, or the mark the points are drawn with.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Sample {
    /// A solid line.
    Line,
    /// A dashed line.
    DashedLine,
    /// A filled circle.
    Circle,
    /// A cross (×).
    Cross,
}

/// One chart of a figure.
#[derive(Debug, Clone, Default)]
pub struct Panel {
    /// Title over the chart.
    pub title: String,
    /// Label of the horizontal axis.
    pub x_label: String,
    /// Label of the vertical axis.
    pub y_label: String,
    /// Logarithmic vertical axis (errors spanning decades).
    pub log_y: bool,
    /// Lines.
    pub series: Vec<Series>,
    /// Scatters.
    pub markers: Vec<Markers>,
    /// Horizontal positions of thin dashed vertical lines (e.g. the joins between motions
    /// drawn one after another).
    pub vlines: Vec<f64>,
    /// The horizontal axis counts (iterations): ticks between whole numbers are not labelled.
    pub integer_x: bool,
    /// Names of the horizontal axis's positions 1, 2, … (e.g. source robots): its ticks there
    /// are labelled with them, and no other tick is labelled.
    pub x_categories: Vec<String>,
    /// Draw the legend in a column to the right of the chart (many entries, e.g. one per
    /// joint) instead of in the corner of the chart that covers the fewest points.
    pub side_legend: bool,
}

/// How many distinct colours [`palette`] has before it repeats.
pub const PALETTE_SIZE: usize = 10;

/// How a figure is laid out: the grid, each panel's size, the lines under the title and where
/// the legends go.
#[derive(Debug, Clone)]
pub struct Layout {
    /// Panels per row (at least 1).
    pub columns: usize,
    /// Pixels of one panel, width and height (SVG and PNG alike).
    pub panel_size: (u32, u32),
    /// Lines drawn under the title (e.g. what the figure shows and what its line styles mean).
    pub subtitle: Vec<String>,
    /// One legend per row of panels, in a column to the right of the grid, from the row's first
    /// panel that has labelled entries; the panels themselves then draw no legend. For rows of
    /// panels that share their lines (the same joints on different motions).
    pub legend_column: bool,
}

impl Layout {
    /// `columns` panels of the default size per row, no subtitle, legends in the panels.
    pub fn grid(columns: usize) -> Self {
        Self {
            columns,
            panel_size: (520, 380),
            subtitle: Vec::new(),
            legend_column: false,
        }
    }
}

/// Errors while drawing a figure.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The figure could not be rendered.
    #[error("could not draw {path}: {message}")]
    Draw {
        /// The file being written.
        path: PathBuf,
        /// What plotters reported.
        message: String,
    },
    /// The file could not be written.
    #[error(transparent)]
    File(#[from] FileError),
}

/// Colours that stay apart for colour-blind readers: Okabe–Ito's eight, then Paul Tol's wine
/// and olive, so that a panel of up to ten lines (an arm of the human model has nine joints)
/// tells them apart by colour alone and keeps dashes for another meaning.
pub fn palette(index: usize) -> RGBColor {
    const COLORS: [RGBColor; PALETTE_SIZE] = [
        RGBColor(0, 114, 178),
        RGBColor(213, 94, 0),
        RGBColor(0, 158, 115),
        RGBColor(204, 121, 167),
        RGBColor(230, 159, 0),
        RGBColor(86, 180, 233),
        RGBColor(120, 120, 120),
        RGBColor(0, 0, 0),
        RGBColor(136, 34, 85),
        RGBColor(153, 153, 51),
    ];
    COLORS[index % COLORS.len()]
}

/// Draws `panels` in a grid of `columns` columns and writes `<stem>.svg` and `<stem>.png`.
/// Returns the two paths. Files are written whole or not at all.
pub fn write_figure(
    stem: &Path,
    title: &str,
    panels: &[Panel],
    columns: usize,
) -> Result<[PathBuf; 2], PlotError> {
    write_figure_with(stem, title, panels, &Layout::grid(columns))
}

/// Draws `panels` row by row as `layout` says and writes `<stem>.svg` and `<stem>.png` of the
/// same size. A blank panel (`Panel::default()`) leaves its place in the grid empty. Returns
/// the two paths. Files are written whole or not at all.
pub fn write_figure_with(
    stem: &Path,
    title: &str,
    panels: &[Panel],
    layout: &Layout,
) -> Result<[PathBuf; 2], PlotError> {
    register_font();
    let columns = layout.columns.max(1);
    let rows = panels.len().div_ceil(columns).max(1);
    let legend_width = if layout.legend_column {
        legend_column_width(panels)
    } else {
        0
    };
    let size = (
        layout.panel_size.0 * columns as u32 + legend_width,
        layout.panel_size.1 * rows as u32 + title_height(layout.subtitle.len()),
    );
    let svg_path = stem.with_extension("svg");
    let png_path = stem.with_extension("png");
    let grid = Grid {
        columns,
        rows,
        legend_width,
    };

    atomic_write_with(&svg_path, |tmp| {
        let root = SVGBackend::new(tmp, size).into_drawing_area();
        draw_all(&root, title, panels, layout, &grid)
            .map_err(|message| draw_error(&svg_path, message))
    })?;
    atomic_write_with(&png_path, |tmp| {
        let root = BitMapBackend::new(tmp, size).into_drawing_area();
        draw_all(&root, title, panels, layout, &grid)
            .map_err(|message| draw_error(&png_path, message))
    })?;
    Ok([svg_path, png_path])
}

/// Pixels the title and `subtitle_lines` lines under it take above the panels: a figure is
/// `panel_size.1 × rows + title_height(subtitle lines)` pixels high.
pub fn title_height(subtitle_lines: usize) -> u32 {
    40 + 22 * subtitle_lines as u32
}

/// Registers the embedded font as `sans-serif` (once per process).
fn register_font() {
    REGISTER_FONT.call_once(|| {
        // The font is compiled in; failing to parse it would be a build defect, and text is then
        // simply not drawn, which is better than no figure.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

/// Pixels `text` takes in the embedded font at `size`: measured, or estimated when the font
/// cannot measure it.
fn text_size(text: &str, size: f64) -> (f64, f64) {
    register_font();
    match ("sans-serif", size).into_font().box_size(text) {
        Ok((w, h)) => (f64::from(w), f64::from(h).max(size)),
        Err(_) => (text.chars().count() as f64 * size * 0.55, size),
    }
}

/// The rows and columns of a figure's grid, and the width of its legend column (0: none).
struct Grid {
    columns: usize,
    rows: usize,
    legend_width: u32,
}

/// Width of a legend column that fits the longest label of every panel's legend.
fn legend_column_width(panels: &[Panel]) -> u32 {
    let longest = panels
        .iter()
        .flat_map(legend_entries)
        .map(|e| text_size(e.0, LEGEND_FONT).0)
        .fold(0.0, f64::max);
    (longest + 40.0).max(f64::from(SIDE_LEGEND_WIDTH)).ceil() as u32
}

fn draw_error(path: &Path, message: String) -> std::io::Error {
    std::io::Error::other(format!("drawing {}: {message}", path.display()))
}

/// Width of a side legend, pixels.
const SIDE_LEGEND_WIDTH: u32 = 150;
/// Font size of legends, pixels.
const LEGEND_FONT: f64 = 12.0;
/// Font size of the texts next to markers (e.g. key-pose names), pixels.
const ANNOTATION_FONT: f64 = 14.0;
/// Approximate width of a character of the 12-pixel legend and annotation font, pixels.
const CHAR_WIDTH: f64 = 6.6;
/// Height of a legend entry, pixels.
const ENTRY_HEIGHT: f64 = 17.0;

/// A tick label: the shortest decimal that shows the value (`10` not `10.0`, `0.25`, never
/// `-0`), scientific for tiny magnitudes.
pub fn tick_label(v: f64) -> String {
    // Ticks computed as sums of steps land a rounding error off zero (-1.1e-16).
    if v.abs() < 1e-10 || !v.is_finite() {
        return if v.is_finite() {
            "0".into()
        } else {
            v.to_string()
        };
    }
    if v.abs() < 1e-3 || v.abs() >= 1e6 {
        return format!("{v:.1e}");
    }
    let text = format!("{v:.4}");
    let text = text.trim_end_matches('0').trim_end_matches('.');
    if text == "-0" {
        "0".into()
    } else {
        text.to_string()
    }
}

/// The label of `panel`'s horizontal tick at `v`: a category's name, nothing between whole
/// numbers of a counting axis, or the number.
fn x_tick_label(panel: &Panel, v: f64) -> String {
    let whole = (v - v.round()).abs() <= 1e-9;
    if !panel.x_categories.is_empty() {
        let k = v.round() as i64 - 1;
        return match usize::try_from(k)
            .ok()
            .and_then(|k| panel.x_categories.get(k))
        {
            Some(name) if whole => name.clone(),
            _ => String::new(),
        };
    }
    if panel.integer_x && !whole {
        String::new()
    } else {
        tick_label(v)
    }
}

/// The labelled entries of a panel's legend: label, colour and what it shows (a series' line,
/// dashed or not; the mark its markers are drawn with).
fn legend_entries(panel: &Panel) -> Vec<(&str, usize, Sample)> {
    panel
        .series
        .iter()
        .filter(|s| !s.label.is_empty())
        .map(|s| {
            let sample = if s.dashed {
                Sample::DashedLine
            } else {
                Sample::Line
            };
            (s.label.as_str(), s.color, sample)
        })
        .chain(
            panel
                .markers
                .iter()
                .filter(|m| !m.label.is_empty())
                .map(|m| (m.label.as_str(), m.color, m.sample())),
        )
        .collect()
}

impl Panel {
    /// Nothing to draw: the place of the panel stays empty.
    fn is_blank(&self) -> bool {
        self.title.is_empty() && self.series.is_empty() && self.markers.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::draw::padded_range;
    use super::placement::{grown, overlap, place_annotations, place_legend, Placement, Rect};
    use super::*;

    #[test]
    fn figure_is_written_as_svg_and_png() {
        let dir = std::env::temp_dir().join(format!("sgplvm-plot-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let panel = Panel {
            title: "test".into(),
            x_label: "iteration".into(),
            y_label: "MSE".into(),
            log_y: true,
            series: vec![Series {
                label: "a".into(),
                points: vec![(0.0, 1.0), (1.0, 0.1), (2.0, 0.01)],
                band: Some(vec![(0.5, 1.5), (0.05, 0.2), (0.005, 0.02)]),
                ..Default::default()
            }],
            markers: vec![Markers {
                label: "poses".into(),
                circles: true,
                points: vec![(1.0, 0.5)],
                annotations: vec!["P1".into()],
                ..Default::default()
            }],
            vlines: vec![1.5],
            ..Default::default()
        };
        let [svg, png] =
            write_figure(&dir.join("fig"), "Figure", &[panel.clone(), panel], 2).unwrap();
        let svg_text = std::fs::read_to_string(&svg).unwrap();
        assert!(svg_text.contains("<svg") && svg_text.contains("iteration"));
        let png_bytes = std::fs::read(&png).unwrap();
        assert_eq!(&png_bytes[1..4], b"PNG");
        // No temporary files are left behind.
        let leftovers: Vec<_> = std::fs::read_dir(&dir)
            .unwrap()
            .filter_map(|e| e.ok())
            .filter(|e| e.file_name().to_string_lossy().contains(".tmp"))
            .collect();
        assert!(leftovers.is_empty());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The SVG of one panel drawn alone (with `side_legend`, its legend beside the chart).
    fn panel_svg(panel: Panel, name: &str) -> String {
        let dir = std::env::temp_dir().join(format!("sgplvm-plot-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let [svg, _] = write_figure(&dir.join("fig"), "Figure", &[panel], 1).unwrap();
        let text = std::fs::read_to_string(svg).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        text
    }

    #[test]
    fn legends_show_the_mark_the_points_are_drawn_with() {
        let crosses = Markers {
            label: "training frames".into(),
            points: vec![(0.0, 0.0), (1.0, 1.0), (2.0, 0.5)],
            ..Markers::default()
        };
        let circles = Markers {
            label: "key poses".into(),
            circles: true,
            points: vec![(0.5, 0.5), (1.5, 0.2)],
            ..Markers::default()
        };
        let dashed = Series {
            label: "desired".into(),
            dashed: true,
            points: vec![(0.0, 1.0), (2.0, 0.0)],
            ..Series::default()
        };
        let panel = Panel {
            title: "marks".into(),
            series: vec![dashed],
            markers: vec![crosses.clone(), circles.clone()],
            ..Panel::default()
        };
        let samples: Vec<Sample> = legend_entries(&panel).iter().map(|e| e.2).collect();
        assert_eq!(samples, [Sample::DashedLine, Sample::Cross, Sample::Circle]);
        assert_eq!(
            (crosses.sample(), circles.sample()),
            (Sample::Cross, Sample::Circle)
        );
        // Drawn: crosses only, in the chart and in its legend (inside the chart or beside it),
        // so the picture holds no circle at all; with key poses, one circle per pose and one in
        // the legend.
        for side_legend in [false, true] {
            let only_crosses = Panel {
                markers: vec![crosses.clone()],
                side_legend,
                ..panel.clone()
            };
            let svg = panel_svg(only_crosses, &format!("crosses-{side_legend}"));
            assert_eq!(
                svg.matches("<circle").count(),
                0,
                "side legend {side_legend}"
            );
            let both = Panel {
                side_legend,
                ..panel.clone()
            };
            let svg = panel_svg(both, &format!("both-{side_legend}"));
            assert_eq!(
                svg.matches("<circle").count(),
                2 + 1,
                "side legend {side_legend}"
            );
        }
    }

    #[test]
    fn tick_labels_are_the_shortest_decimal() {
        assert_eq!(tick_label(10.0), "10");
        assert_eq!(tick_label(0.25), "0.25");
        assert_eq!(tick_label(-1.1e-16), "0");
        assert_eq!(tick_label(-0.0), "0");
        assert_eq!(tick_label(-1.5), "-1.5");
        assert_eq!(tick_label(2.5e-5), "2.5e-5");
    }

    #[test]
    fn category_ticks_name_their_positions_and_nothing_else() {
        let panel = Panel {
            x_categories: vec!["coman".into(), "centauro".into()],
            integer_x: true,
            ..Panel::default()
        };
        let labels: Vec<String> = [0.5, 1.0, 1.5, 2.0, 2.5, 3.0]
            .iter()
            .map(|&v| x_tick_label(&panel, v))
            .collect();
        assert_eq!(labels, ["", "coman", "", "centauro", "", ""]);
        // Without categories a counting axis labels whole numbers only.
        let counting = Panel {
            integer_x: true,
            ..Panel::default()
        };
        assert_eq!(x_tick_label(&counting, 2.0), "2");
        assert_eq!(x_tick_label(&counting, 2.5), "");
    }

    /// The boxes `place_annotations` gave texts of `sizes` at `anchors`.
    fn boxes(anchors: &[(f64, f64)], sizes: &[(f64, f64)], placed: &[Placement]) -> Vec<Rect> {
        anchors
            .iter()
            .zip(sizes)
            .zip(placed)
            .map(|((a, s), ((dx, dy), _))| {
                let (x, y) = (a.0 + f64::from(*dx), a.1 + f64::from(*dy));
                (x, y, x + s.0, y + s.1)
            })
            .collect()
    }

    #[test]
    fn annotations_avoid_each_other_and_the_lines() {
        // Two labels on one point, a line running right of it: neither label on the line, nor
        // on the other.
        let ink: Vec<(f64, f64)> = (0..100).map(|i| (100.0 + i as f64, 100.0)).collect();
        let anchors = [(100.0, 100.0), (100.0, 100.0)];
        let sizes = [(40.0, 14.0), (52.0, 14.0)];
        let placed = place_annotations(&anchors, &sizes, &ink, &[], (0.0, 0.0, 400.0, 400.0));
        let b = boxes(&anchors, &sizes, &placed);
        assert!(!overlap(&b[0], &b[1]), "{b:?}");
        for r in &b {
            assert!(
                !ink.iter()
                    .any(|p| p.0 >= r.0 && p.0 <= r.2 && p.1 >= r.1 && p.1 <= r.3),
                "{r:?}"
            );
        }
    }

    #[test]
    fn crowded_annotations_never_overlap_and_get_leader_lines() {
        // Sixteen key poses, eight of them within 30 pixels of one another (as near the
        // latent space's origin), long names, and a legend in the upper right corner.
        let mut anchors: Vec<(f64, f64)> = (0..8)
            .map(|k| {
                let a = f64::from(k) * 0.8;
                (500.0 + 15.0 * a.cos(), 400.0 + 15.0 * a.sin())
            })
            .collect();
        anchors.extend((0..8).map(|k| {
            (
                150.0 + 100.0 * f64::from(k),
                150.0 + 20.0 * f64::from(k % 3),
            )
        }));
        let sizes: Vec<(f64, f64)> = (0..16)
            .map(|k| (60.0 + 7.0 * f64::from(k % 5), 16.0))
            .collect();
        let circles: Vec<Rect> = anchors
            .iter()
            .map(|p| (p.0 - 7.0, p.1 - 7.0, p.0 + 7.0, p.1 + 7.0))
            .collect();
        let legend = (800.0, 20.0, 990.0, 120.0);
        let mut obstacles = circles.clone();
        obstacles.push(legend);
        let bounds = (0.0, 0.0, 1000.0, 800.0);
        let placed = place_annotations(&anchors, &sizes, &[], &obstacles, bounds);
        let b = boxes(&anchors, &sizes, &placed);
        for (i, r) in b.iter().enumerate() {
            assert!(
                r.0 >= bounds.0 && r.2 <= bounds.2 && r.1 >= bounds.1 && r.3 <= bounds.3,
                "{r:?}"
            );
            for (j, other) in b.iter().enumerate().skip(i + 1) {
                assert!(
                    !overlap(r, other),
                    "texts {i} and {j} overlap: {r:?} {other:?}"
                );
            }
            for (j, o) in obstacles.iter().enumerate() {
                assert!(!overlap(r, o), "text {i} covers obstacle {j}: {r:?} {o:?}");
            }
        }
        // In the cluster not every text fits beside its point: those set away have a leader
        // line ending on their box.
        let led: Vec<usize> = (0..16).filter(|&k| placed[k].1.is_some()).collect();
        assert!(!led.is_empty());
        for k in led {
            let (ex, ey) = placed[k].1.unwrap();
            let end = (anchors[k].0 + f64::from(ex), anchors[k].1 + f64::from(ey));
            assert!(
                overlap(
                    &grown(&b[k], 1.0),
                    &grown(&(end.0, end.1, end.0, end.1), 0.5)
                ),
                "{k}"
            );
        }
    }

    #[test]
    fn the_legend_goes_where_it_covers_no_curve() {
        // A curve rising to the upper right: the legend goes to the upper left.
        let panel = Panel {
            series: vec![Series {
                label: "rising".into(),
                points: (0..=10).map(|i| (i as f64, (i * i) as f64)).collect(),
                ..Default::default()
            }],
            ..Default::default()
        };
        let (corner, y) = place_legend(&panel, (400.0, 300.0), (0.0, 10.0), (0.0, 100.0), false);
        assert!(
            matches!(corner, SeriesLabelPosition::UpperLeft),
            "{corner:?}"
        );
        assert_eq!(y, (0.0, 100.0));
        // Curves through every corner: the range grows above them.
        let panel = Panel {
            series: vec![
                Series {
                    label: "a long label for a wide legend".into(),
                    points: vec![(0.0, 0.0), (10.0, 100.0)],
                    ..Default::default()
                },
                Series {
                    label: "b".into(),
                    points: vec![(0.0, 100.0), (10.0, 0.0)],
                    ..Default::default()
                },
            ],
            ..Default::default()
        };
        let (_, y) = place_legend(&panel, (400.0, 300.0), (0.0, 10.0), (0.0, 100.0), false);
        assert!(y.1 > 110.0, "{y:?}");
    }

    #[test]
    fn degenerate_ranges_are_widened() {
        assert_eq!(padded_range([2.0, 2.0].into_iter(), false), (1.0, 3.0));
        let (lo, hi) = padded_range([0.0, -1.0, 1e-2].into_iter(), true);
        assert!(lo > 0.0 && hi > lo);
    }
}
