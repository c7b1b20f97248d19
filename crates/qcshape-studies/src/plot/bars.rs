//! Grouped bars of means with +- one standard deviation (the paper's Fig. 4c: interpolation
//! error per deformation type, one bar per metric).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{color, draw_legend, padded, render, Figure, PlotError, PlotInput, Swatch, FAMILY};

/// One group: its name and `(series, mean, sd)` entries.
pub type BarGroup = (String, Vec<(String, f64, f64)>);

struct Bars<'a> {
    groups: &'a [BarGroup],
    series: Vec<String>,
    title: String,
    y_label: String,
    y_range: (f64, f64),
    /// Whether every mean is >= 0 (then lower whiskers stop at 0).
    non_negative: bool,
}

/// Writes grouped bars to `path` (`.svg` or `.png`, atomically): along x one group per entry
/// of `groups` (e.g. a deformation type), inside it one bar per series (e.g. a metric) of
/// height `mean` with an error bar from `mean - sd` to `mean + sd`. When every mean is
/// non-negative (errors, distances, times) the quantity is taken as non-negative and the lower
/// whisker is clipped at 0 (asymmetric bars: `max(mean - sd, 0)` to `mean + sd`); say so in the
/// caption. Series keep one colour across groups (legend in order of first appearance, right
/// of the chart, outside the data); a group may lack some series. Means and SDs must be
/// finite, SDs non-negative.
pub fn error_bars(path: &Path, groups: &[BarGroup], title: &str, y_label: &str) -> Result<(), PlotError> {
    let invalid = |problem: PlotInput| PlotError::Invalid {
        path: path.into(),
        problem,
    };
    if groups.iter().all(|g| g.1.is_empty()) {
        return Err(invalid(PlotInput::NoBars));
    }
    let mut series: Vec<String> = Vec::new();
    let non_negative = groups.iter().all(|g| g.1.iter().all(|e| e.1 >= 0.0));
    let (mut lo, mut hi) = (0.0f64, 0.0f64);
    for (g, entries) in groups {
        for (s, mean, sd) in entries {
            if !mean.is_finite() || !sd.is_finite() || *sd < 0.0 {
                return Err(invalid(PlotInput::BadBar {
                    group: g.clone(),
                    series: s.clone(),
                    mean: *mean,
                    sd: *sd,
                }));
            }
            if !series.contains(s) {
                series.push(s.clone());
            }
            lo = lo.min(if non_negative { 0.0 } else { mean - sd });
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
        non_negative,
    };
    render(path, &fig)
}

/// The lower end of a whisker: `mean - sd`, clipped at 0 for a non-negative quantity.
fn whisker_low(mean: f64, sd: f64, non_negative: bool) -> f64 {
    if non_negative {
        (mean - sd).max(0.0)
    } else {
        mean - sd
    }
}

impl Bars<'_> {
    /// Width of the legend panel right of the chart.
    fn legend_width(&self) -> u32 {
        let longest = self.series.iter().map(|s| s.chars().count()).max().unwrap_or(0) as u32;
        (44 + 8 * longest).clamp(100, 320)
    }
}

impl Figure for Bars<'_> {
    fn size(&self) -> (u32, u32) {
        (
            (160 + 90 * self.groups.len() as u32 * self.series.len().max(1) as u32 / 2).clamp(640, 1800)
                + self.legend_width(),
            600,
        )
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<(), DB> {
        let ng = self.groups.len();
        // Integer x coordinates (plotters formats key points only on integer axes): group g
        // spans [g U, (g + 1) U], its label sits at its centre.
        const U: i32 = 1000;
        let m = self.series.len() as i32;
        let centres: Vec<i32> = (0..ng as i32).map(|g| g * U + U / 2).collect();
        let (w, _) = self.size();
        let root = root.titled(&self.title, (FAMILY, super::title_size(&self.title, w)))?;
        let (plot, legend) = root.split_horizontally(w - self.legend_width());
        let mut chart = ChartBuilder::on(&plot)
            .margin(16)
            .x_label_area_size(48)
            .y_label_area_size(70)
            .build_cartesian_2d(
                (0..ng as i32 * U).with_key_points(centres),
                self.y_range.0..self.y_range.1,
            )?;
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
            .y_label_formatter(&|v| super::axis_label(*v, self.y_range.1 - self.y_range.0, 10))
            .label_style((FAMILY, 13))
            .axis_desc_style((FAMILY, 14))
            .bold_line_style(RGBColor(225, 225, 225))
            .max_light_lines(0)
            .draw()?;
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
            chart.draw_series(
                bars.iter()
                    .map(|&(x0, mean, _)| Rectangle::new([(x0, 0.0), (x0 + width, mean)], style)),
            )?;
            let whisker = BLACK.stroke_width(1);
            chart.draw_series(bars.iter().map(|&(x0, mean, sd)| {
                let (xc, cap) = (x0 + width / 2, width / 4);
                let low = whisker_low(mean, sd, self.non_negative);
                PathElement::new(
                    vec![
                        (xc - cap, low),
                        (xc + cap, low),
                        (xc, low),
                        (xc, mean + sd),
                        (xc - cap, mean + sd),
                        (xc + cap, mean + sd),
                    ],
                    whisker,
                )
            }))?;
        }
        let entries: Vec<(String, RGBColor, Swatch)> = self
            .series
            .iter()
            .enumerate()
            .map(|(s, n)| (n.clone(), color(s), Swatch::Box))
            .collect();
        draw_legend(&legend, &entries, 40, None)?;
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
    fn whiskers_of_non_negative_data_stop_at_zero() {
        assert_eq!(whisker_low(0.1, 0.5, true), 0.0);
        assert_eq!(whisker_low(0.6, 0.5, true), 0.6 - 0.5);
        assert_eq!(whisker_low(0.1, 0.5, false), 0.1 - 0.5);
        // The axis of non-negative data starts at 0 even when mean - sd < 0.
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("b.svg");
        let g = vec![("a".to_string(), vec![("s".to_string(), 0.1, 0.5)])];
        error_bars(&p, &g, "t", "y").unwrap();
        let svg = std::fs::read_to_string(&p).unwrap();
        assert!(!svg.contains(">-0."), "no negative tick labels");
    }

    #[test]
    fn png_bars_and_bad_values() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bars.png");
        error_bars(&p, &groups(), "Interpolation error", "mean error").unwrap();
        let (w, h, _) = decode_png(&p);
        assert_eq!((w, h), (640 + 164, 600));
        let mut bad = groups();
        bad[1].1[0].2 = -1.0;
        let e = error_bars(&p, &bad, "t", "y").unwrap_err().to_string();
        assert!(e.contains("bars.png") && e.contains("twist"), "{e}");
        assert!(error_bars(&p, &[], "t", "y").is_err());
    }
}
