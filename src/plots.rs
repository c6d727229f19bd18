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

/// Colours that stay apart for colour-blind readers (Okabe–Ito).
pub fn palette(index: usize) -> RGBColor {
    const COLORS: [RGBColor; 8] = [
        RGBColor(0, 114, 178),
        RGBColor(213, 94, 0),
        RGBColor(0, 158, 115),
        RGBColor(204, 121, 167),
        RGBColor(230, 159, 0),
        RGBColor(86, 180, 233),
        RGBColor(120, 120, 120),
        RGBColor(0, 0, 0),
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
    REGISTER_FONT.call_once(|| {
        // The font is compiled in; failing to parse it would be a build defect, and text is then
        // simply not drawn, which is better than no figure.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
    let columns = columns.max(1);
    let rows = panels.len().div_ceil(columns).max(1);
    let size = (520 * columns as u32, 380 * rows as u32 + 40);
    let svg_path = stem.with_extension("svg");
    let png_path = stem.with_extension("png");

    atomic_write_with(&svg_path, |tmp| {
        let root = SVGBackend::new(tmp, size).into_drawing_area();
        draw_all(&root, title, panels, columns, rows)
            .map_err(|message| draw_error(&svg_path, message))
    })?;
    atomic_write_with(&png_path, |tmp| {
        let root = BitMapBackend::new(tmp, size).into_drawing_area();
        draw_all(&root, title, panels, columns, rows)
            .map_err(|message| draw_error(&png_path, message))
    })?;
    Ok([svg_path, png_path])
}

fn draw_error(path: &Path, message: String) -> std::io::Error {
    std::io::Error::other(format!("drawing {}: {message}", path.display()))
}

fn draw_all<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    panels: &[Panel],
    columns: usize,
    rows: usize,
) -> Result<(), String> {
    let err = |e: DrawingAreaErrorKind<DB::ErrorType>| e.to_string();
    root.fill(&WHITE).map_err(err)?;
    let root = root.titled(title, ("sans-serif", 22)).map_err(err)?;
    let areas = root.split_evenly((rows, columns));
    for (panel, area) in panels.iter().zip(areas.iter()) {
        draw_panel(area, panel).map_err(err)?;
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

fn draw_panel<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    panel: &Panel,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
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
    let mut builder = ChartBuilder::on(area);
    builder
        .caption(&panel.title, ("sans-serif", 17))
        .margin(12)
        .x_label_area_size(40)
        .y_label_area_size(62);
    if log_y {
        let mut chart =
            builder.build_cartesian_2d(x_range.0..x_range.1, (y_range.0..y_range.1).log_scale())?;
        chart
            .configure_mesh()
            .x_desc(&panel.x_label)
            .y_desc(&panel.y_label)
            .y_label_formatter(&|v| format!("{v:.1e}"))
            .label_style(("sans-serif", 12))
            .draw()?;
        draw_content(&mut chart, panel)?;
    } else {
        let mut chart = builder.build_cartesian_2d(x_range.0..x_range.1, y_range.0..y_range.1)?;
        chart
            .configure_mesh()
            .x_desc(&panel.x_label)
            .y_desc(&panel.y_label)
            .label_style(("sans-serif", 12))
            .draw()?;
        draw_content(&mut chart, panel)?;
    }
    Ok(())
}

fn draw_content<'a, DB, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    panel: &Panel,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>>
where
    DB: DrawingBackend + 'a,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let mut labelled = false;
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
        if !s.label.is_empty() {
            labelled = true;
            drawn.label(&s.label).legend(move |(x, y)| {
                PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(2))
            });
        }
    }
    for m in &panel.markers {
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
        if !m.label.is_empty() {
            labelled = true;
            drawn
                .label(&m.label)
                .legend(move |(x, y)| Circle::new((x + 9, y), 4, color.filled()));
        }
        for (p, text) in m.points.iter().zip(&m.annotations) {
            if !text.is_empty() {
                chart.draw_series(std::iter::once(Text::new(
                    text.clone(),
                    *p,
                    ("sans-serif", 12).into_font().color(&BLACK),
                )))?;
            }
        }
    }
    if labelled {
        chart
            .configure_series_labels()
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK.mix(0.3))
            .label_font(("sans-serif", 12))
            .position(SeriesLabelPosition::UpperRight)
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
    fn degenerate_ranges_are_widened() {
        assert_eq!(padded_range([2.0, 2.0].into_iter(), false), (1.0, 3.0));
        let (lo, hi) = padded_range([0.0, -1.0, 1e-2].into_iter(), true);
        assert!(lo > 0.0 && hi > lo);
    }
}
