//! Grouped bars of means with +- one standard deviation (the paper's Fig. 4c: interpolation
//! error per deformation type, one bar per metric).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{color, msg, padded, render, Figure, PlotError, FAMILY};

/// One group: its name and `(series, mean, sd)` entries.
pub type BarGroup = (String, Vec<(String, f64, f64)>);

struct Bars<'a> {
    groups: &'a [BarGroup],
    series: Vec<String>,
    title: String,
    y_label: String,
    y_range: (f64, f64),
}

/// Writes grouped bars to `path` (`.svg` or `.png`, atomically): along x one group per entry
/// of `groups` (e.g. a deformation type), inside it one bar per series (e.g. a metric) of
/// height `mean` with an error bar from `mean - sd` to `mean + sd`. Series keep one colour
/// across groups (legend in order of first appearance); a group may lack some series. Means
/// and SDs must be finite, SDs non-negative.
pub fn error_bars(path: &Path, groups: &[BarGroup], title: &str, y_label: &str) -> Result<(), PlotError> {
    let invalid = |message: String| PlotError::Invalid {
        path: path.into(),
        message,
    };
    if groups.iter().all(|g| g.1.is_empty()) {
        return Err(invalid("no bars to plot".into()));
    }
    let mut series: Vec<String> = Vec::new();
    let (mut lo, mut hi) = (0.0f64, 0.0f64);
    for (g, entries) in groups {
        for (s, mean, sd) in entries {
            if !mean.is_finite() || !sd.is_finite() || *sd < 0.0 {
                return Err(invalid(format!(
                    "group {g:?}, series {s:?}: mean {mean} and sd {sd} must be finite, sd >= 0"
                )));
            }
            if !series.contains(s) {
                series.push(s.clone());
            }
            lo = lo.min(mean - sd);
            hi = hi.max(mean + sd);
        }
    }
    let (plo, phi) = padded(lo, hi, 0.08);
    let y_range = (
        if lo >= 0.0 { 0.0 } else { plo },
        if hi <= 0.0 { 0.0 } else { phi },
    );
    let fig = Bars {
        groups,
        series,
        title: title.to_string(),
        y_label: y_label.to_string(),
        y_range,
    };
    render(path, &fig)
}

impl Figure for Bars<'_> {
    fn size(&self) -> (u32, u32) {
        (
            (160 + 90 * self.groups.len() as u32 * self.series.len().max(1) as u32 / 2).clamp(640, 1800),
            600,
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let ng = self.groups.len();
        // Integer x coordinates (plotters formats key points only on integer axes): group g
        // spans [g U, (g + 1) U], its label sits at its centre.
        const U: i32 = 1000;
        let m = self.series.len() as i32;
        let centres: Vec<i32> = (0..ng as i32).map(|g| g * U + U / 2).collect();
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, (FAMILY, 22))
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(70)
            .build_cartesian_2d(
                (0..ng as i32 * U).with_key_points(centres),
                self.y_range.0..self.y_range.1,
            )
            .map_err(msg)?;
        let group_name = |v: &i32| {
            let g = (v / U).clamp(0, ng as i32 - 1) as usize;
            self.groups[g].0.clone()
        };
        chart
            .configure_mesh()
            .disable_x_mesh()
            .x_labels(ng)
            .x_label_formatter(&group_name)
            .y_desc(self.y_label.as_str())
            .label_style((FAMILY, 13))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(msg)?;
        let width = 8 * U / 10 / m;
        for (s, name) in self.series.iter().enumerate() {
            let style = color(s).filled();
            let mut bars = Vec::new();
            for (g, (_, entries)) in self.groups.iter().enumerate() {
                if let Some((_, mean, sd)) = entries.iter().find(|e| &e.0 == name) {
                    let x0 = g as i32 * U + U / 10 + s as i32 * width;
                    bars.push((x0, *mean, *sd));
                }
            }
            chart
                .draw_series(
                    bars.iter()
                        .map(|&(x0, mean, _)| Rectangle::new([(x0, 0.0), (x0 + width, mean)], style)),
                )
                .map_err(msg)?
                .label(name.as_str())
                .legend(move |(x, y)| Rectangle::new([(x, y - 5), (x + 12, y + 5)], style));
            let whisker = BLACK.stroke_width(1);
            chart
                .draw_series(bars.iter().map(|&(x0, mean, sd)| {
                    let (xc, cap) = (x0 + width / 2, width / 4);
                    PathElement::new(
                        vec![
                            (xc - cap, mean - sd),
                            (xc + cap, mean - sd),
                            (xc, mean - sd),
                            (xc, mean + sd),
                            (xc - cap, mean + sd),
                            (xc + cap, mean + sd),
                        ],
                        whisker,
                    )
                }))
                .map_err(msg)?;
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font((FAMILY, 13))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(msg)?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::decode_png;
    use super::*;

    fn groups() -> Vec<BarGroup> {
        let g = |name: &str, qc: f64, iso: f64| {
            (
                name.to_string(),
                vec![
                    ("quasi-conformal".to_string(), qc, 0.1 * qc),
                    ("isometric".to_string(), iso, 0.2 * iso),
                ],
            )
        };
        vec![g("bend", 0.5, 1.5), g("twist", 0.7, 2.0), g("stretch", 0.2, 0.9)]
    }

    #[test]
    fn svg_bars_have_one_bar_and_one_whisker_per_entry() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bars.svg");
        error_bars(&p, &groups(), "Interpolation error", "mean error").unwrap();
        let svg = std::fs::read_to_string(&p).unwrap();
        for (s, n_bars) in [(0, 3), (1, 3)] {
            let RGBColor(r, g, b) = color(s);
            let fill = format!("fill=\"#{r:02X}{g:02X}{b:02X}\"");
            // Bars plus the legend swatch.
            let rects = svg.split("<rect").skip(1).filter(|t| t.contains(&fill)).count();
            assert_eq!(rects, n_bars + 1, "series {s}");
        }
        // 6 whiskers, drawn as black 6-point polylines.
        let whiskers = svg
            .split("<polyline")
            .skip(1)
            .filter(|t| {
                t.contains("stroke=\"#000000\"")
                    && t.split("points=\"")
                        .nth(1)
                        .is_some_and(|p| p.split('"').next().unwrap().split_whitespace().count() == 6)
            })
            .count();
        assert_eq!(whiskers, 6);
        assert!(svg.contains("twist") && svg.contains("isometric") && svg.contains("mean error"));
    }

    #[test]
    fn png_bars_and_bad_values() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bars.png");
        error_bars(&p, &groups(), "Interpolation error", "mean error").unwrap();
        let (w, h, _) = decode_png(&p);
        assert_eq!((w, h), (640, 600));
        let mut bad = groups();
        bad[1].1[0].2 = -1.0;
        let e = error_bars(&p, &bad, "t", "y").unwrap_err().to_string();
        assert!(e.contains("bars.png") && e.contains("twist"), "{e}");
        assert!(error_bars(&p, &[], "t", "y").is_err());
    }
}
