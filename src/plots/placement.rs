//! Where a panel's legend and annotations go: the legend in the corner that covers the fewest
//! drawn points ([`place_legend`]), each annotation's text on the nearest free place around its
//! point, clear of other texts, markers and the legend ([`place_annotations`]).

use plotters::prelude::*;

use super::{legend_entries, text_size, Panel, CHAR_WIDTH, ENTRY_HEIGHT, LEGEND_FONT};

/// Everything drawn in a panel, as points in `[0, 1]²` of the chart's ranges (lines sampled
/// between their points, so that a line crossing a corner counts there).
pub(super) fn normalised_ink(
    panel: &Panel,
    x: (f64, f64),
    y: (f64, f64),
    log_y: bool,
) -> Vec<(f64, f64)> {
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
pub(super) fn best_corner(ink: &[(f64, f64)], size: (f64, f64)) -> (SeriesLabelPosition, usize) {
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
pub(super) fn place_legend(
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

/// Where plotters draws a panel's legend at `corner` of the plotting area `bounds` (pixels),
/// grown by a few pixels; `None` for an unlabelled panel.
pub(super) fn legend_rect(
    panel: &Panel,
    corner: &SeriesLabelPosition,
    bounds: Rect,
) -> Option<Rect> {
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

/// A pixel rectangle: left, top, right, bottom.
pub(super) type Rect = (f64, f64, f64, f64);

/// Where an annotation goes: the pixel offset of its text's top-left corner from its point,
/// and the end of a leader line from the point when the text sits away from it.
pub(super) type Placement = ((i32, i32), Option<(i32, i32)>);

/// Whether two rectangles share any area.
pub(super) fn overlap(a: &Rect, b: &Rect) -> bool {
    a.0 < b.2 && b.0 < a.2 && a.1 < b.3 && b.1 < a.3
}

/// `r` grown by `by` pixels on every side.
pub(super) fn grown(r: &Rect, by: f64) -> Rect {
    (r.0 - by, r.1 - by, r.2 + by, r.3 + by)
}

/// Pixels kept free between two annotations.
pub(super) const ANNOTATION_GAP: f64 = 3.0;

/// Rings of places tried around a point, each [`RING_STEP`] pixels further out.
pub(super) const RINGS: usize = 40;

/// Distance between two rings of places, pixels.
pub(super) const RING_STEP: f64 = 9.0;

/// Distance of the nearest ring from its point, pixels.
pub(super) const FIRST_RING: f64 = 9.0;

/// Where each annotation's text goes. A text of `sizes[k]` pixels belongs to the point
/// `anchors[k]`; it never overlaps another annotation or an `obstacles` rectangle (markers that
/// must stay visible, the legend) and stays inside `bounds`. Among the places that do, on
/// rings ever further from the point in 16 directions, it takes the one that covers the fewest
/// drawn points (`ink`) and other texts' leader lines, nearer places preferred. Points among
/// many others choose first. A text set away from its point gets a leader line, to the point of
/// its box nearest the anchor (which later texts avoid as they avoid ink). Only when no place
/// on any ring is free is the whole of `bounds` searched for the free place nearest the point;
/// a text overlaps another only if there is none at all.
pub(super) fn place_annotations(
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
