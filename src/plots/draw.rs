//! How a figure is drawn with plotters: the title and grid of panels ([`draw_all`]), each panel's
//! axes and ranges ([`draw_panel`]), its content ([`draw_content`]: vertical lines, series,
//! markers with their annotations, the legend) and the legends drawn beside the grid.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::placement::{legend_rect, place_annotations, place_legend, Rect};
use super::{
    legend_entries, palette, text_size, tick_label, x_tick_label, Grid, Layout, Panel, Sample,
    ANNOTATION_FONT, ENTRY_HEIGHT, SIDE_LEGEND_WIDTH,
};

/// Half the size of a cross in a legend, pixels (the chart's crosses are 3: a little larger to
/// be seen beside the label).
const LEGEND_CROSS: i32 = 4;

pub(super) fn draw_all<DB: DrawingBackend>(
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
pub(super) fn padded_range(values: impl Iterator<Item = f64>, log: bool) -> (f64, f64) {
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
pub(super) fn y_range_values(panel: &Panel) -> impl Iterator<Item = f64> + '_ {
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

/// Minor grid lines between two labelled ones (plotters draws ten, a mesh denser than the data).
const MINOR_GRID_LINES: usize = 4;

/// Draws `panel` in `area`; with `legend_elsewhere` without its legend (the figure draws it).
pub(super) fn draw_panel<DB: DrawingBackend>(
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
            .max_light_lines(MINOR_GRID_LINES)
            // A logarithmic axis's minor lines crowd unevenly towards each decade, where a
            // band of them reads like an interval: its labelled lines alone.
            .y_max_light_lines(0)
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
            .max_light_lines(MINOR_GRID_LINES)
            .draw()?;
        draw_content(&mut chart, panel, corner, legend_inside)?;
    }
    if let Some(legend) = legend_area {
        draw_side_legend(&legend, panel)?;
    }
    Ok(())
}

/// The legend as a column beside the chart: a line sample (or dot) and the label per entry.
pub(super) fn draw_side_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    panel: &Panel,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>> {
    let font = ("sans-serif", 12).into_font().color(&BLACK);
    for (k, (label, color, sample)) in legend_entries(panel).into_iter().enumerate() {
        let y = 48 + (k as f64 * ENTRY_HEIGHT) as i32;
        let color = palette(color);
        match sample {
            Sample::Circle => area.draw(&Circle::new((13, y), 4, color.filled()))?,
            Sample::Cross => {
                area.draw(&Cross::new((13, y), LEGEND_CROSS, color.stroke_width(1)))?
            }
            Sample::DashedLine => {
                area.draw(&PathElement::new(
                    vec![(4, y), (10, y)],
                    color.stroke_width(2),
                ))?;
                area.draw(&PathElement::new(
                    vec![(15, y), (22, y)],
                    color.stroke_width(2),
                ))?;
            }
            Sample::Line => area.draw(&PathElement::new(
                vec![(4, y), (22, y)],
                color.stroke_width(2),
            ))?,
        }
        area.draw(&Text::new(label.to_string(), (28, y - 7), font.clone()))?;
    }
    Ok(())
}

/// Draws what `panel` holds into `chart`: its vertical lines, its series, its markers and their
/// annotations, and, inside the chart (`legend_inside`) at `corner`, its legend.
pub(super) fn draw_content<'a, DB, X, Y>(
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
    draw_vlines(chart, panel)?;
    let labelled_series = draw_series(chart, panel, legend_inside)?;
    let ink = ink_pixels(chart, panel);
    let labelled_markers = draw_markers(chart, panel, &corner, legend_inside, &ink)?;
    if labelled_series || labelled_markers {
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

/// The panel's vertical lines, dashed, across the vertical range of its values.
fn draw_vlines<'a, DB, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    panel: &Panel,
) -> Result<(), DrawingAreaErrorKind<DB::ErrorType>>
where
    DB: DrawingBackend + 'a,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
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
    Ok(())
}

/// The panel's series (with their bands); labelled in the legend when it is inside the chart.
/// Returns whether any was labelled.
fn draw_series<'a, DB, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    panel: &Panel,
    legend_inside: bool,
) -> Result<bool, DrawingAreaErrorKind<DB::ErrorType>>
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
    Ok(labelled)
}

/// Pixels of everything the series and markers draw, for placing the annotations around it.
fn ink_pixels<'a, DB, X, Y>(
    chart: &ChartContext<'a, DB, Cartesian2d<X, Y>>,
    panel: &Panel,
) -> Vec<(f64, f64)>
where
    DB: DrawingBackend + 'a,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
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
    ink
}

/// The panel's markers and their annotations, placed clear of `ink`, of the key poses and of
/// the legend at `corner` when it is inside the chart (where the markers are then labelled).
/// Returns whether any was labelled.
fn draw_markers<'a, DB, X, Y>(
    chart: &mut ChartContext<'a, DB, Cartesian2d<X, Y>>,
    panel: &Panel,
    corner: &SeriesLabelPosition,
    legend_inside: bool,
    ink: &[(f64, f64)],
) -> Result<bool, DrawingAreaErrorKind<DB::ErrorType>>
where
    DB: DrawingBackend + 'a,
    X: Ranged<ValueType = f64>,
    Y: Ranged<ValueType = f64>,
{
    let mut labelled = false;
    let pixel = |p: &(f64, f64)| {
        let (x, y) = chart.backend_coord(p);
        (f64::from(x), f64::from(y))
    };
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
        obstacles.extend(legend_rect(panel, corner, bounds));
    }
    for (m, anchors) in panel.markers.iter().zip(&anchors) {
        let color = palette(m.color);
        // The legend shows the mark the points are drawn with.
        let labelled_here = !m.label.is_empty() && legend_inside;
        match m.sample() {
            Sample::Circle => {
                let drawn = chart
                    .draw_series(m.points.iter().map(|&p| Circle::new(p, 5, color.filled())))?;
                if labelled_here {
                    drawn
                        .label(&m.label)
                        .legend(move |(x, y)| Circle::new((x + 9, y), 4, color.filled()));
                }
            }
            _ => {
                let drawn = chart.draw_series(
                    m.points
                        .iter()
                        .map(|&p| Cross::new(p, 3, color.stroke_width(1))),
                )?;
                if labelled_here {
                    drawn.label(&m.label).legend(move |(x, y)| {
                        Cross::new((x + 9, y), LEGEND_CROSS, color.stroke_width(1))
                    });
                }
            }
        }
        labelled |= labelled_here;
        let sizes: Vec<(f64, f64)> = m
            .annotations
            .iter()
            .map(|t| text_size(t, ANNOTATION_FONT))
            .collect();
        let offsets = place_annotations(anchors, &sizes, ink, &obstacles, bounds);
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
    Ok(labelled)
}
