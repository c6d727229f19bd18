//! Pictures a person would rather look at than read: learning curves, latent spaces and joint
//! trajectories, each written as SVG and PNG (plotters, with an embedded font so that no system
//! font library is needed).

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;

use crate::files::{atomic_write_with, FileError};

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
    /// Filled circles (key poses) rather than crosses (training points).
    pub circles: bool,
    /// The points.
    pub points: Vec<(f64, f64)>,
    /// A text drawn next to each point (empty for none).
    pub annotations: Vec<String>,
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
        layout.panel_size.1 * rows as u32 + 40 + 22 * layout.subtitle.len() as u32,
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

fn draw_all<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    panels: &[Panel],
    layout: &Layout,
    grid: &Grid,
) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(err)?;
    let mut below = root.titled(title, ("sans-serif", 22)).map_err(err)?;
    for line in &layout.subtitle {
        below = below.titled(line, ("sans-serif", 15)).map_err(err)?;
    }
    let (panels_area, legends) = if grid.legend_width > 0 {
        let width = below.dim_in_pixel().0;
        let (left, right) = below.split_horizontally(width.saturating_sub(grid.legend_width));
        (left, Some(right))
    } else {
        (below, None)
    };
    let areas = panels_area.split_evenly((grid.rows, grid.columns));
    for (panel, area) in panels.iter().zip(areas.iter()) {
        if !panel.is_blank() {
            draw_panel(area, panel, legends.is_some()).map_err(err)?;
        }
    }
    if let Some(legends) = legends {
        let strips = legends.split_evenly((grid.rows, 1));
        for (row, strip) in panels.chunks(grid.columns).zip(strips.iter()) {
            if let Some(panel) = row.iter().find(|p| !legend_entries(p).is_empty()) {
                draw_side_legend(strip, panel).map_err(err)?;
            }
        }
    }
    root.present().map_err(err)?;
    Ok(())
}

/// The range of all values, padded a little; a degenerate range is widened.
fn padded_range(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in values.filter(|v| v.is_finite() && (!log || *v > 0.0)) {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !lo.is_finite() {
        return if log { (1e-3, 1.0) } else { (0.0, 1.0) };
    }
    if log {
        return (lo / 1.5, hi * 1.5);
    }
    let pad = if hi > lo {
        0.05 * (hi - lo)
    } else {
        0.5 * lo.abs().max(1.0)
    };
    (lo - pad, hi + pad)
}

/// Every vertical value of a panel: points, band edges and markers.
fn y_range_values(panel: &Panel) -> impl Iterator<Item = f64> + '_ {
    panel
        .series
        .iter()
        .flat_map(|s| {
            s.points
                .iter()
                .map(|p| p.1)
                .chain(s.band.iter().flatten().flat_map(|b| [b.0, b.1]))
        })
        .chain(
            panel
                .markers
                .iter()
                .flat_map(|m| m.points.iter().map(|p| p.1)),
        )
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

/// The labelled entries of a panel's legend: label, colour, dashed, circle marker.
fn legend_entries(panel: &Panel) -> Vec<(&str, usize, bool, bool)> {
    panel
        .series
        .iter()
        .filter(|s| !s.label.is_empty())
        .map(|s| (s.label.as_str(), s.color, s.dashed, false))
        .chain(
            panel
                .markers
                .iter()
                .filter(|m| !m.label.is_empty())
                .map(|m| (m.label.as_str(), m.color, false, true)),
        )
        .collect()
}

/// Everything drawn in a panel, as points in `[0, 1]²` of the chart's ranges (lines sampled
/// between their points, so that a line crossing a corner counts there).
fn normalised_ink(panel: &Panel, x: (f64, f64), y: (f64, f64), log_y: bool) -> Vec<(f64, f64)> {
    let fy = |v: f64| {
        if log_y {
            (v.max(1e-300).ln() - y.0.ln()) / (y.1.ln() - y.0.ln())
        } else {
            (v - y.0) / (y.1 - y.0)
        }
    };
    let norm = |p: &(f64, f64)| ((p.0 - x.0) / (x.1 - x.0), fy(p.1));
    let mut ink = Vec::new();
    // Each line, and the edges of its band.
    let lines = panel.series.iter().flat_map(|s| {
        let band = s.band.iter().flat_map(|band| {
            let edge = |upper: bool| {
                s.points
                    .iter()
                    .zip(band)
                    .map(move |(p, b)| (p.0, if upper { b.1 } else { b.0 }))
                    .collect::<Vec<_>>()
            };
            [edge(false), edge(true)]
        });
        std::iter::once(s.points.clone()).chain(band)
    });
    for line in lines {
        let points: Vec<(f64, f64)> = line.iter().filter(|p| p.1.is_finite()).map(norm).collect();
        ink.extend(points.first().copied());
        for w in points.windows(2) {
            for k in 1..=16 {
                let t = k as f64 / 16.0;
                ink.push((
                    w[0].0 + t * (w[1].0 - w[0].0),
                    w[0].1 + t * (w[1].1 - w[0].1),
                ));
            }
        }
    }
    ink.extend(panel.markers.iter().flat_map(|m| m.points.iter().map(norm)));
    ink
}

/// Where a legend of `size` (fraction of the chart's width and height) covers the fewest of
/// `ink`'s points: the corner, and how many it covers there.
fn best_corner(ink: &[(f64, f64)], size: (f64, f64)) -> (SeriesLabelPosition, usize) {
    let corners = [
        (SeriesLabelPosition::UpperRight, true, true),
        (SeriesLabelPosition::UpperLeft, false, true),
        (SeriesLabelPosition::LowerRight, true, false),
        (SeriesLabelPosition::LowerLeft, false, false),
    ];
    let (w, h) = (size.0 + 0.03, size.1 + 0.03);
    let mut best = (SeriesLabelPosition::UpperRight, usize::MAX);
    for (position, right, upper) in corners {
        let inside = |p: &&(f64, f64)| {
            let in_x = if right { p.0 >= 1.0 - w } else { p.0 <= w };
            let in_y = if upper { p.1 >= 1.0 - h } else { p.1 <= h };
            in_x && in_y
        };
        let covered = ink.iter().filter(inside).count();
        if covered < best.1 {
            best = (position, covered);
        }
    }
    best
}

/// The legend's corner, and the vertical range widened at the top when every corner would
/// cover a curve (the legend then sits above them all).
fn place_legend(
    panel: &Panel,
    chart_pixels: (f64, f64),
    x: (f64, f64),
    y: (f64, f64),
    log_y: bool,
) -> (SeriesLabelPosition, (f64, f64)) {
    let entries = legend_entries(panel);
    let longest = entries
        .iter()
        .map(|e| e.0.chars().count())
        .max()
        .unwrap_or(0);
    let size = (
        (longest as f64 * CHAR_WIDTH + 40.0) / chart_pixels.0.max(1.0),
        (entries.len() as f64 * ENTRY_HEIGHT + 12.0) / chart_pixels.1.max(1.0),
    );
    let ink = normalised_ink(panel, x, y, log_y);
    let (corner, covered) = best_corner(&ink, size);
    if covered == 0 || size.1 >= 0.6 {
        return (corner, y);
    }
    // Room above the highest point: the data keeps the lower (1 - legend height) of the chart.
    let keep = 1.0 - size.1 - 0.04;
    let y = if log_y {
        (y.0, y.0 * (y.1 / y.0).powf(1.0 / keep))
    } else {
        (y.0, y.0 + (y.1 - y.0) / keep)
    };
    let ink = normalised_ink(panel, x, y, log_y);
    let upper = [
        SeriesLabelPosition::UpperRight,
        SeriesLabelPosition::UpperLeft,
    ];
    let (corner, _) = best_corner(&ink, size);
    let corner = if upper
        .iter()
        .any(|u| std::mem::discriminant(u) == std::mem::discriminant(&corner))
    {
        corner
    } else {
        SeriesLabelPosition::UpperRight
    };
    (corner, y)
}

impl Panel {
    /// Nothing to draw: the place of the panel stays empty.
    fn is_blank(&self) -> bool {
        self.title.is_empty() && self.series.is_empty() && self.markers.is_empty()
    }
}

/// Draws `panel` in `area`; with `legend_elsewhere` without its legend (the figure draws it).
fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    panel: &Panel,
    legend_elsewhere: bool,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let (width, height) = area.dim_in_pixel();
    let side_legend = panel.side_legend && !legend_elsewhere;
    let (area, legend_area) = if side_legend && width > 2 * SIDE_LEGEND_WIDTH {
        let (chart, legend) = area.split_horizontally(width - SIDE_LEGEND_WIDTH);
        (chart, Some(legend))
    } else {
        (area.clone(), None)
    };
    let x_range = padded_range(
        panel
            .series
            .iter()
            .flat_map(|s| s.points.iter())
            .chain(panel.markers.iter().flat_map(|m| m.points.iter()))
            .map(|p| p.0),
        false,
    );
    let y_range = padded_range(y_range_values(panel), panel.log_y);
    // A log axis over less than a decade shows almost no tick labels: use a linear one then.
    let log_y = panel.log_y && y_range.1 / y_range.0 > 10.0;
    let y_range = if panel.log_y && !log_y {
        padded_range(y_range_values(panel), false)
    } else {
        y_range
    };
    // The chart inside the panel: the margins, caption and label areas set below.
    let chart_pixels = (
        f64::from(area.dim_in_pixel().0) - 62.0 - 24.0,
        f64::from(height) - 40.0 - 30.0 - 24.0,
    );
    let legend_inside = legend_area.is_none() && !legend_elsewhere;
    let (corner, y_range) = if legend_inside && !legend_entries(panel).is_empty() {
        place_legend(panel, chart_pixels, x_range, y_range, log_y)
    } else {
        (SeriesLabelPosition::UpperRight, y_range)
    };
    let mut builder = ChartBuilder::on(&area);
    builder
        .caption(&panel.title, ("sans-serif", 17))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(62);
    let x_label = |v: &f64| x_tick_label(panel, *v);
    if log_y {
        let mut chart =
            builder.build_cartesian_2d(x_range.0..x_range.1, (y_range.0..y_range.1).log_scale())?;
        chart
            .configure_mesh()
            .x_desc(&panel.x_label)
            .y_desc(&panel.y_label)
            .x_label_formatter(&x_label)
            .y_label_formatter(&|v| format!("{v:.1e}"))
            .label_style(("sans-serif", 12))
            .draw()?;
        draw_content(&mut chart, panel, corner, legend_inside)?;
    } else {
        let mut chart = builder.build_cartesian_2d(x_range.0..x_range.1, y_range.0..y_range.1)?;
        chart
            .configure_mesh()
            .x_desc(&panel.x_label)
            .y_desc(&panel.y_label)
            .x_label_formatter(&x_label)
            .y_label_formatter(&|v| tick_label(*v))
            .label_style(("sans-serif", 12))
            .draw()?;
        draw_content(&mut chart, panel, corner, legend_inside)?;
    }
    if let Some(legend) = legend_area {
        draw_side_legend(&legend, panel)?;
    }
    Ok(())
}

/// The legend as a column beside the chart: a line sample (or dot) and the label per entry.
fn draw_side_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    panel: &Panel,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let font = ("sans-serif", 12).into_font().color(&BLACK);
    for (k, (label, color, dashed, circle)) in legend_entries(panel).into_iter().enumerate() {
        let y = 48 + (k as f64 * ENTRY_HEIGHT) as i32;
        let color = palette(color);
        if circle {
            area.draw(&Circle::new((13, y), 4, color.filled()))?;
        } else if dashed {
            area.draw(&PathElement::new(
                vec![(4, y), (10, y)],
                color.stroke_width(2),
            ))?;
            area.draw(&PathElement::new(
                vec![(15, y), (22, y)],
                color.stroke_width(2),
            ))?;
        } else {
            area.draw(&PathElement::new(
                vec![(4, y), (22, y)],
                color.stroke_width(2),
            ))?;
        }
        area.draw(&Text::new(label.to_string(), (28, y - 7), font.clone()))?;
    }
    Ok(())
}

/// A pixel rectangle: left, top, right, bottom.
type Rect = (f64, f64, f64, f64);

/// Where an annotation goes: the pixel offset of its text's top-left corner from its point,
/// and the end of a leader line from the point when the text sits away from it.
type Placement = ((i32, i32), Option<(i32, i32)>);

/// Whether two rectangles share any area.
fn overlap(a: &Rect, b: &Rect) -> bool {
    a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
}

/// `r` grown by `by` pixels on every side.
fn grown(r: &Rect, by: f64) -> Rect {
    (r.0 - by, r.1 - by, r.2 + by, r.3 + by)
}

/// Pixels kept free between two annotations.
const ANNOTATION_GAP: f64 = 3.0;
/// Rings of places tried around a point, each [`RING_STEP`] pixels further out.
const RINGS: usize = 40;
/// Distance between two rings of places, pixels.
const RING_STEP: f64 = 9.0;
/// Distance of the nearest ring from its point, pixels.
const FIRST_RING: f64 = 9.0;

/// Where each annotation's text goes. A text of `sizes[k]` pixels belongs to the point
/// `anchors[k]`; it never overlaps another annotation or an `obstacles` rectangle (markers that
/// must stay visible, the legend) and stays inside `bounds`. Among the places that do, on
/// rings ever further from the point in 16 directions, it takes the one that covers the fewest
/// drawn points (`ink`) and other texts' leader lines, nearer places preferred. Points among
/// many others choose first. A text set away from its point gets a leader line, to the point of
/// its box nearest the anchor (which later texts avoid as they avoid ink). Only when no place
/// on any ring is free is the whole of `bounds` searched for the free place nearest the point;
/// a text overlaps another only if there is none at all.
fn place_annotations(
    anchors: &[(f64, f64)],
    sizes: &[(f64, f64)],
    ink: &[(f64, f64)],
    obstacles: &[Rect],
    bounds: Rect,
) -> Vec<Placement> {
    let n = anchors.len().min(sizes.len());
    let mut placed: Vec<Rect> = Vec::new();
    let mut leaders: Vec<(f64, f64)> = Vec::new();
    let mut placements = vec![((0, 0), None); n];
    let crowd = |k: usize| {
        anchors[..n]
            .iter()
            .filter(|a| (a.0 - anchors[k].0).hypot(a.1 - anchors[k].1) < 80.0)
            .count()
    };
    let edge = |&(px, py): &(f64, f64)| {
        (px - bounds.0)
            .min(bounds.2 - px)
            .min(py - bounds.1)
            .min(bounds.3 - py)
    };
    let mut order: Vec<usize> = (0..n).collect();
    order.sort_by(|&a, &b| {
        crowd(b)
            .cmp(&crowd(a))
            .then(edge(&anchors[a]).total_cmp(&edge(&anchors[b])))
    });
    for k in order {
        let (px, py) = anchors[k];
        let (w, h) = sizes[k];
        let free = |rect: &Rect| {
            rect.0 >= bounds.0
                && rect.2 <= bounds.2
                && rect.1 >= bounds.1
                && rect.3 <= bounds.3
                && !placed
                    .iter()
                    .any(|o| overlap(rect, &grown(o, ANNOTATION_GAP)))
                && !obstacles.iter().any(|o| overlap(rect, &grown(o, 1.0)))
        };
        let covered = |rect: &Rect| {
            let inside = |p: &&(f64, f64)| {
                p.0 >= rect.0 - 1.0
                    && p.0 <= rect.2 + 1.0
                    && p.1 >= rect.1 - 1.0
                    && p.1 <= rect.3 + 1.0
            };
            (ink.iter().filter(inside).count() + 3 * leaders.iter().filter(inside).count()) as f64
        };
        let mut best: Option<(f64, Rect)> = None;
        let mut rings_since_found = 0;
        for ring in 0..RINGS {
            let r = FIRST_RING + RING_STEP * ring as f64;
            for direction in 0..16 {
                let angle = direction as f64 * std::f64::consts::PI / 8.0;
                let (c, s) = (angle.cos(), angle.sin());
                // Whole pixels from the point, as the text is drawn.
                let left = px + (c * (r + w / 2.0) - w / 2.0).round();
                let top = py + (s * (r + h / 2.0) - h / 2.0).round();
                let rect = (left, top, left + w, top + h);
                if !free(&rect) {
                    continue;
                }
                // Nearer is better; to the right of the point, as a reader expects, slightly so.
                let cost = covered(&rect) + 0.3 * r + if c < -0.3 { 1.0 } else { 0.0 };
                if best.is_none_or(|(b, _)| cost < b) {
                    best = Some((cost, rect));
                }
            }
            if best.is_some() {
                rings_since_found += 1;
                if rings_since_found > 2 {
                    break;
                }
            }
        }
        let rect = best.map(|(_, r)| r).or_else(|| {
            // Every ring is taken: the free place nearest the point, anywhere in the chart.
            let mut nearest: Option<(f64, Rect)> = None;
            let mut y = bounds.1;
            while y + h <= bounds.3 {
                let mut x = bounds.0;
                while x + w <= bounds.2 {
                    let (left, top) = (px + (x - px).round(), py + (y - py).round());
                    let rect = (left, top, left + w, top + h);
                    let d = (left + w / 2.0 - px).hypot(top + h / 2.0 - py);
                    if nearest.is_none_or(|(b, _)| d < b) && free(&rect) {
                        nearest = Some((d, rect));
                    }
                    x += 4.0;
                }
                y += 4.0;
            }
            nearest.map(|(_, r)| r)
        });
        let rect = rect.unwrap_or((
            px + FIRST_RING,
            py - h / 2.0,
            px + FIRST_RING + w,
            py + h / 2.0,
        ));
        placed.push(rect);
        // The point of the box nearest the anchor; a leader line when it is not right there.
        let nearest = (px.clamp(rect.0, rect.2), py.clamp(rect.1, rect.3));
        let away = (nearest.0 - px).hypot(nearest.1 - py) > FIRST_RING + RING_STEP / 2.0;
        if away {
            for t in 1..16 {
                let t = f64::from(t) / 16.0;
                leaders.push((px + t * (nearest.0 - px), py + t * (nearest.1 - py)));
            }
        }
        placements[k] = (
            ((rect.0 - px).round() as i32, (rect.1 - py).round() as i32),
            away.then(|| {
                (
                    (nearest.0 - px).round() as i32,
                    (nearest.1 - py).round() as i32,
                )
            }),
        );
    }
    placements
}

/// Where plotters draws a panel's legend at `corner` of the plotting area `bounds` (pixels),
/// grown by a few pixels; `None` for an unlabelled panel.
fn legend_rect(panel: &Panel, corner: &SeriesLabelPosition, bounds: Rect) -> Option<Rect> {
    let entries = legend_entries(panel);
    if entries.is_empty() {
        return None;
    }
    let longest = entries
        .iter()
        .map(|e| text_size(e.0, LEGEND_FONT).0)
        .fold(0.0, f64::max);
    // plotters: the labels, a 30-pixel sample area and 10-pixel margins, 5 pixels from the edge.
    let (w, h) = (
        longest + 50.0,
        entries.len() as f64 * (LEGEND_FONT + 4.0) + 20.0,
    );
    let (right, lower) = match corner {
        SeriesLabelPosition::UpperLeft => (false, false),
        SeriesLabelPosition::LowerLeft => (false, true),
        SeriesLabelPosition::LowerRight => (true, true),
        _ => (true, false),
    };
    let x = if right {
        bounds.2 - 5.0 - w
    } else {
        bounds.0 + 5.0
    };
    let y = if lower {
        bounds.3 - 5.0 - h
    } else {
        bounds.1 + 5.0
    };
    Some(grown(&(x, y, x + w, y + h), 4.0))
}

fn draw_content<'a, DB, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    panel: &Panel,
    corner: SeriesLabelPosition,
    legend_inside: bool,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>>
where
    DB: DrawingBackend + 'a,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let mut labelled = false;
    let (y_low, y_high) = {
        let values: Vec<f64> = y_range_values(panel).filter(|v| v.is_finite()).collect();
        (
            values.iter().copied().fold(f64::INFINITY, f64::min),
            values.iter().copied().fold(f64::NEG_INFINITY, f64::max),
        )
    };
    for &x in &panel.vlines {
        if y_low.is_finite() && y_high.is_finite() {
            chart.draw_series(DashedLineSeries::new(
                [(x, y_low), (x, y_high)],
                3,
                3,
                ShapeStyle::from(&BLACK.mix(0.35)).stroke_width(1),
            ))?;
        }
    }
    for s in &panel.series {
        let color = palette(s.color);
        if let Some(band) = &s.band {
            let polygon: Vec<(f64, f64)> = s
                .points
                .iter()
                .zip(band)
                .map(|(p, b)| (p.0, b.1))
                .chain(s.points.iter().zip(band).rev().map(|(p, b)| (p.0, b.0)))
                .filter(|p| p.1.is_finite())
                .collect();
            chart.draw_series(std::iter::once(Polygon::new(
                polygon,
                color.mix(0.18).filled(),
            )))?;
        }
        let style = ShapeStyle::from(&color).stroke_width(2);
        let points = s.points.iter().copied().filter(|p| p.1.is_finite());
        let drawn = if s.points.len() == 1 {
            // A line of one point draws nothing (e.g. a model shipped at iteration 0).
            chart.draw_series(points.map(|p| Circle::new(p, 4, color.filled())))?
        } else if s.dashed {
            chart.draw_series(DashedLineSeries::new(points, 6, 4, style))?
        } else {
            chart.draw_series(LineSeries::new(points, style))?
        };
        if !s.label.is_empty() && legend_inside {
            labelled = true;
            let dashed = s.dashed;
            drawn.label(&s.label).legend(move |(x, y)| {
                // A dashed line's sample has a gap.
                let gap = if dashed { 5 } else { 0 };
                EmptyElement::at((x, y))
                    + PathElement::new(vec![(0, 0), (7, 0)], color.stroke_width(2))
                    + PathElement::new(vec![(7 + gap, 0), (18, 0)], color.stroke_width(2))
            });
        }
    }
    // Pixels of everything drawn so far, for placing the annotations around it.
    let pixel = |p: &(f64, f64)| {
        let (x, y) = chart.backend_coord(p);
        (f64::from(x), f64::from(y))
    };
    let mut ink: Vec<(f64, f64)> = Vec::new();
    for s in &panel.series {
        let points: Vec<(f64, f64)> = s
            .points
            .iter()
            .filter(|p| p.1.is_finite())
            .map(pixel)
            .collect();
        ink.extend(points.first().copied());
        for w in points.windows(2) {
            let steps = ((w[1].0 - w[0].0).hypot(w[1].1 - w[0].1) / 3.0)
                .ceil()
                .max(1.0) as usize;
            for k in 1..=steps {
                let t = k as f64 / steps as f64;
                ink.push((
                    w[0].0 + t * (w[1].0 - w[0].0),
                    w[0].1 + t * (w[1].1 - w[0].1),
                ));
            }
        }
    }
    ink.extend(
        panel
            .markers
            .iter()
            .flat_map(|m| m.points.iter().map(pixel)),
    );
    let (xs, ys) = chart.plotting_area().get_pixel_range();
    let bounds = (
        f64::from(xs.start),
        f64::from(ys.start),
        f64::from(xs.end),
        f64::from(ys.end),
    );
    let anchors: Vec<Vec<(f64, f64)>> = panel
        .markers
        .iter()
        .map(|m| m.points.iter().map(pixel).collect())
        .collect();
    // What no annotation may cover: every filled circle (a key pose), and the legend.
    let mut obstacles: Vec<Rect> = panel
        .markers
        .iter()
        .zip(&anchors)
        .filter(|(m, _)| m.circles)
        .flat_map(|(_, a)| {
            a.iter()
                .map(|p| (p.0 - 7.0, p.1 - 7.0, p.0 + 7.0, p.1 + 7.0))
        })
        .collect();
    if legend_inside {
        obstacles.extend(legend_rect(panel, &corner, bounds));
    }
    for (m, anchors) in panel.markers.iter().zip(&anchors) {
        let color = palette(m.color);
        let drawn = if m.circles {
            chart.draw_series(m.points.iter().map(|&p| Circle::new(p, 5, color.filled())))?
        } else {
            chart.draw_series(
                m.points
                    .iter()
                    .map(|&p| Cross::new(p, 3, color.stroke_width(1))),
            )?
        };
        if !m.label.is_empty() && legend_inside {
            labelled = true;
            drawn
                .label(&m.label)
                .legend(move |(x, y)| Circle::new((x + 9, y), 4, color.filled()));
        }
        let sizes: Vec<(f64, f64)> = m
            .annotations
            .iter()
            .map(|t| text_size(t, ANNOTATION_FONT))
            .collect();
        let offsets = place_annotations(anchors, &sizes, &ink, &obstacles, bounds);
        for (((p, text), (offset, leader)), anchor) in m
            .points
            .iter()
            .zip(&m.annotations)
            .zip(offsets)
            .zip(anchors)
        {
            if text.is_empty() {
                continue;
            }
            // Texts of a later set of markers keep clear of these.
            let (w, h) = text_size(text, ANNOTATION_FONT);
            let (x, y) = (
                anchor.0 + f64::from(offset.0),
                anchor.1 + f64::from(offset.1),
            );
            obstacles.push((x, y, x + w, y + h));
            if let Some(end) = leader {
                // A text set away from its point: a thin line says whose it is.
                chart.draw_series(std::iter::once(
                    EmptyElement::at(*p)
                        + PathElement::new(vec![(0, 0), end], BLACK.mix(0.5).stroke_width(1)),
                ))?;
            }
            let font = ("sans-serif", ANNOTATION_FONT).into_font().color(&BLACK);
            chart.draw_series(std::iter::once(
                EmptyElement::at(*p) + Text::new(text.clone(), offset, font),
            ))?;
        }
    }
    if labelled {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.9))
            .border_style(BLACK.mix(0.3))
            .label_font(("sans-serif", 12))
            .position(corner)
            .draw()?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
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
