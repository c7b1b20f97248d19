//! A heat map of the distance matrix, rows and columns in a chosen order (e.g. by class).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::{render, Figure, PlotError, PlotInput, FAMILY};
use qcshape::io::heat_colors;
use qcshape::similarity::DistanceMatrix;

/// Row and column names are written up to this many deformations.
const MAX_NAMED: usize = 80;

struct Heatmap {
    n: usize,
    /// Cell colours in display order (n x n, row-major; row 0 at the top).
    cells: Vec<[u8; 3]>,
    names: Vec<String>,
    /// Display positions after which the class changes.
    boundaries: Vec<usize>,
    max: f64,
    title: String,
    value_label: String,
}

/// Writes a heat map of `d` to `path` (`.svg` or `.png`, atomically): cell `(r, c)` shows
/// `d[order[r]][order[c]]` on the viridis scale from 0 (dark) to the largest entry (yellow),
/// with a colour bar. `order` must be a permutation of `0..n` (e.g. the deformations sorted
/// by class). With `labels` (n, in matrix order), axis names read `name (label)` and white
/// lines separate consecutive runs of one label. Names are written up to 80 deformations.
/// `title` is drawn above the map (say which metric and data set), `value_label` beside the
/// colour bar (what the colours measure, e.g. `distance`).
pub fn heatmap(
    path: &Path,
    d: &DistanceMatrix,
    order: &[usize],
    labels: Option<&[String]>,
    title: &str,
    value_label: &str,
) -> Result<(), PlotError> {
    let n = d.len();
    let invalid = |problem: PlotInput| PlotError::Invalid {
        path: path.into(),
        problem,
    };
    let mut seen = vec![false; n];
    if order.len() != n {
        return Err(invalid(PlotInput::OrderLength {
            order: order.len(),
            n,
        }));
    }
    for &i in order {
        if i >= n || seen[i] {
            return Err(invalid(PlotInput::NotPermutation { n, at: i }));
        }
        seen[i] = true;
    }
    if let Some(l) = labels {
        if l.len() != n {
            return Err(invalid(PlotInput::LabelCount { labels: l.len(), n }));
        }
    }
    let max = d.max();
    let values: Vec<f64> = order
        .iter()
        .flat_map(|&i| order.iter().map(move |&j| d.get(i, j)))
        .collect();
    let names = order
        .iter()
        .map(|&i| match labels {
            Some(l) => format!("{} ({})", d.names()[i], l[i]),
            None => d.names()[i].clone(),
        })
        .collect();
    let boundaries = match labels {
        Some(l) => (1..n).filter(|&r| l[order[r]] != l[order[r - 1]]).collect(),
        None => vec![],
    };
    let fig = Heatmap {
        n,
        cells: heat_colors(&values, 0.0, max),
        names,
        boundaries,
        max,
        title: title.to_string(),
        value_label: value_label.to_string(),
    };
    render(path, &fig)
}

impl Figure for Heatmap {
    fn size(&self) -> (u32, u32) {
        (940, 800)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<(), DB> {
        let n = self.n;
        // Integer coordinates (plotters formats key points only on integer axes): cell k spans
        // [2k, 2k + 2], its centre is 2k + 1; display row r occupies y in [2(n-r-1), 2(n-r)].
        let span = 2 * n as i32;
        let (main, bar) = root.split_horizontally(800);
        // The title spans the whole figure (the map and its colour bar).
        let (main, bar) = {
            let title_h = 40;
            root.draw(&Text::new(
                self.title.clone(),
                (470, 12),
                TextStyle::from((FAMILY, super::title_size(&self.title, 940)).into_font())
                    .pos(Pos::new(HPos::Center, VPos::Top)),
            ))?;
            (main.margin(title_h, 0, 0, 0), bar.margin(title_h, 0, 0, 0))
        };
        let named = n <= MAX_NAMED;
        let label_area = if named {
            let longest = self.names.iter().map(|s| s.chars().count()).max().unwrap_or(0);
            (longest as u32 * 6 + 16).min(200)
        } else {
            30
        };
        let centres: Vec<i32> = (0..n as i32).map(|i| 2 * i + 1).collect();
        let mut chart = ChartBuilder::on(&main)
            .margin(12)
            .x_label_area_size(label_area)
            .y_label_area_size(label_area)
            .build_cartesian_2d(
                (0..span).with_key_points(centres.clone()),
                (0..span).with_key_points(centres),
            )?;
        let name_at = |v: i32, flip: bool| -> String {
            let k = (v / 2).clamp(0, n as i32 - 1) as usize;
            let k = if flip { n - 1 - k } else { k };
            if named {
                self.names[k].clone()
            } else {
                String::new()
            }
        };
        chart
            .configure_mesh()
            .disable_mesh()
            .x_labels(n)
            .y_labels(n)
            // x names are drawn below, rotated (the mesh centres rotated labels on the tick).
            .x_label_formatter(&|_| String::new())
            .y_label_formatter(&|v| name_at(*v, true))
            .y_label_style((FAMILY, 10))
            .draw()?;
        chart.draw_series((0..n * n).map(|k| {
            let (r, c) = (k / n, k % n);
            let [red, g, b] = self.cells[k];
            let (x, y) = (2 * c as i32, span - 2 * r as i32);
            Rectangle::new([(x, y - 2), (x + 2, y)], RGBColor(red, g, b).filled())
        }))?;
        if named {
            let style = TextStyle::from((FAMILY, 10).into_font().transform(FontTransform::Rotate90))
                .pos(Pos::new(HPos::Left, VPos::Center));
            for c in 0..n {
                // `main` starts at the backend's origin, so chart pixels are root pixels.
                let (px, py) = chart.backend_coord(&(2 * c as i32 + 1, 0));
                root.draw(&Text::new(
                    name_at(2 * c as i32, false),
                    (px, py + 8),
                    style.clone(),
                ))?;
            }
        }
        let line = WHITE.stroke_width(2);
        for &b in &self.boundaries {
            let (x, y) = (2 * b as i32, span - 2 * b as i32);
            chart.draw_series([
                PathElement::new(vec![(x, 0), (x, span)], line),
                PathElement::new(vec![(0, y), (span, y)], line),
            ])?;
        }
        // Colour bar.
        let steps = 64;
        let top = if self.max > 0.0 { self.max } else { 1.0 };
        let mut cb = ChartBuilder::on(&bar)
            .margin_top(12)
            .margin_bottom(label_area as i32 + 12)
            .margin_left(6)
            .margin_right(4)
            .right_y_label_area_size(90)
            .build_cartesian_2d(0f64..1f64, 0f64..top)?;
        cb.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_labels(6)
            .y_label_formatter(&|v| super::axis_label(*v, top, 6))
            .y_label_style((FAMILY, 11))
            .y_desc(self.value_label.as_str())
            .axis_desc_style((FAMILY, 13))
            .draw()?;
        let levels: Vec<f64> = (0..steps)
            .map(|s| (s as f64 + 0.5) / steps as f64 * top)
            .collect();
        let colors = heat_colors(&levels, 0.0, top);
        cb.draw_series((0..steps).map(|s| {
            let [r, g, b] = colors[s];
            let (lo, hi) = (s as f64 / steps as f64 * top, (s + 1) as f64 / steps as f64 * top);
            Rectangle::new([(0.0, lo), (1.0, hi)], RGBColor(r, g, b).filled())
        }))?;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::decode_png;
    use super::*;

    fn svg_has_text(p: &Path, text: &str) -> bool {
        std::fs::read_to_string(p).unwrap().contains(text)
    }

    fn matrix() -> (DistanceMatrix, Vec<String>) {
        let labels: Vec<String> = (0..6).map(|i| ["a", "b"][i % 2].to_string()).collect();
        let names = (0..6).map(|i| format!("m{i}")).collect();
        let d = DistanceMatrix::from_fn(names, |i, j| if i % 2 == j % 2 { 1.0 } else { 4.0 }).unwrap();
        (d, labels)
    }

    #[test]
    fn svg_heatmap_has_one_cell_per_entry_in_the_given_order() {
        let dir = tempfile::tempdir().unwrap();
        let (d, labels) = matrix();
        let p = dir.path().join("h.svg");
        let order = [0, 2, 4, 1, 3, 5];
        heatmap(
            &p,
            &d,
            &order,
            Some(&labels),
            "Test distances",
            "distance (units)",
        )
        .unwrap();
        assert!(svg_has_text(&p, "Test distances") && svg_has_text(&p, "distance (units)"));
        let svg = std::fs::read_to_string(&p).unwrap();
        let [r0, g0, b0] = heat_colors(&[0.0], 0.0, 4.0)[0];
        let [r1, g1, b1] = heat_colors(&[4.0], 0.0, 4.0)[0];
        let dark = format!("fill=\"#{r0:02X}{g0:02X}{b0:02X}\"");
        let bright = format!("fill=\"#{r1:02X}{g1:02X}{b1:02X}\"");
        // 6 zero diagonal cells and 2 x 3 x 3 = 18 cross-class cells (the colour bar has
        // neither exact extreme colour).
        assert_eq!(svg.matches(&dark).count(), 6, "{svg}");
        assert_eq!(svg.matches(&bright).count(), 18);
        assert!(svg.contains("m4 (a)") && svg.contains("m5 (b)"));
        // Row 0 of the display is d(0, order[c]): 0, 1, 1, 4, 4, 4 (cells come first in the file).
        let mid = heat_colors(&[1.0], 0.0, 4.0)[0];
        let fills: Vec<[u8; 3]> = svg
            .split("<rect")
            .skip(1)
            .filter_map(|r| r.split("fill=\"#").nth(1))
            .map(|f| {
                let h = |k: usize| u8::from_str_radix(&f[k..k + 2], 16).unwrap();
                [h(0), h(2), h(4)]
            })
            .filter(|c| [[r0, g0, b0], mid, [r1, g1, b1]].contains(c))
            .take(6)
            .collect();
        assert_eq!(
            fills,
            vec![[r0, g0, b0], mid, mid, [r1, g1, b1], [r1, g1, b1], [r1, g1, b1]]
        );
        let e = heatmap(&p, &d, &[0, 0, 1, 2, 3, 4], None, "t", "v")
            .unwrap_err()
            .to_string();
        assert!(e.contains("permutation"), "{e}");
    }

    #[test]
    fn png_heatmap_decodes() {
        let dir = tempfile::tempdir().unwrap();
        let (d, _) = matrix();
        let p = dir.path().join("h.png");
        heatmap(&p, &d, &[0, 1, 2, 3, 4, 5], None, "t", "v").unwrap();
        let (w, h, rgb) = decode_png(&p);
        assert_eq!((w, h), (940, 800));
        let [r, g, b] = heat_colors(&[4.0], 0.0, 4.0)[0];
        let bright = rgb.chunks_exact(3).filter(|p| *p == [r, g, b]).count();
        assert!(bright > 18 * 100, "cells should cover many pixels: {bright}");
    }
}
