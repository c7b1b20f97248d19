//! The map of deformations: MDS coordinates coloured by class (the paper's Fig. 6).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{
    color, draw_legend, marker_outline, padded, render, Figure, PlotError, PlotInput, Swatch, FAMILY,
};
use qcshape::eval::encode_labels;

/// Without classes, names are written next to the points up to this many points (with
/// classes the legend says which point is which class, and names would overlap inside the
/// clusters).
const MAX_NAMED_POINTS: usize = 30;

/// Which points get their name written next to them.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum PointNames {
    /// None when classes are given (the legend identifies the classes); all up to 30 points
    /// otherwise.
    Auto,
    /// No point.
    None,
    /// The points whose entry is `true` (n entries).
    Some(Vec<bool>),
}

struct Scatter<'a> {
    xy: Vec<(f64, f64)>,
    names: &'a [String],
    shown: Vec<bool>,
    classes: Option<(Vec<usize>, Vec<String>)>,
    title: String,
    range: ((f64, f64), (f64, f64)),
}

/// Writes a scatter plot of embedded deformations to `path` (`.svg` or `.png`, atomically):
/// one marker per deformation at `coords[i][0..2]` (n x dims; a 1-D embedding is drawn on
/// y = 0, a 3-D one by its first two axes), coloured and shaped by `labels[i]` with a legend of
/// the classes (in order of first appearance) outside the data area when labels are given.
/// Point names follow [`PointNames::Auto`] (see [`scatter_map_with`]). Both axes have the same
/// scale. The title gets `stress-1 = ...` appended when `stress` is given.
pub fn scatter_map(
    path: &Path,
    coords: &[Vec<f64>],
    names: &[String],
    labels: Option<&[String]>,
    title: &str,
    stress: Option<f64>,
) -> Result<(), PlotError> {
    scatter_map_with(path, coords, names, labels, title, stress, &PointNames::Auto)
}

/// [`scatter_map`] with the choice of the points whose names are written.
pub fn scatter_map_with(
    path: &Path,
    coords: &[Vec<f64>],
    names: &[String],
    labels: Option<&[String]>,
    title: &str,
    stress: Option<f64>,
    point_names: &PointNames,
) -> Result<(), PlotError> {
    let invalid = |problem: PlotInput| PlotError::Invalid {
        path: path.into(),
        problem,
    };
    let n = coords.len();
    if n == 0 {
        return Err(invalid(PlotInput::NoPoints));
    }
    if names.len() != n {
        return Err(invalid(PlotInput::PerPoint {
            what: "names",
            points: n,
            found: names.len(),
        }));
    }
    if let Some(l) = labels {
        if l.len() != n {
            return Err(invalid(PlotInput::PerPoint {
                what: "labels",
                points: n,
                found: l.len(),
            }));
        }
    }
    let shown = match point_names {
        PointNames::Auto => vec![labels.is_none() && n <= MAX_NAMED_POINTS; n],
        PointNames::None => vec![false; n],
        PointNames::Some(v) if v.len() == n => v.clone(),
        PointNames::Some(v) => {
            return Err(invalid(PlotInput::PerPoint {
                what: "name choices",
                points: n,
                found: v.len(),
            }));
        }
    };
    let mut xy = Vec::with_capacity(n);
    for (i, c) in coords.iter().enumerate() {
        let (x, y) = (
            c.first().copied().unwrap_or(0.0),
            c.get(1).copied().unwrap_or(0.0),
        );
        if !x.is_finite() || !y.is_finite() {
            return Err(invalid(PlotInput::NonFinitePoint {
                point: i,
                name: names[i].clone(),
            }));
        }
        xy.push((x, y));
    }
    let (xmin, xmax) = xy.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
        (a.min(p.0), b.max(p.0))
    });
    let (ymin, ymax) = xy.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
        (a.min(p.1), b.max(p.1))
    });
    // Equal scales: both axes get the larger span, centred on the data; names need room on the
    // right and at the top (they are written right of and above their points).
    let half = 0.5 * (xmax - xmin).max(ymax - ymin);
    let (cx, cy) = (0.5 * (xmin + xmax), 0.5 * (ymin + ymax));
    let named = shown.iter().any(|&s| s);
    let ((x0, x1), (y0, y1)) = (
        padded(cx - half, cx + half, 0.08),
        padded(cy - half, cy + half, 0.08),
    );
    let extra = if named { 0.12 * (x1 - x0) } else { 0.0 };
    let range = ((x0, x1 + extra), (y0, y1 + 0.5 * extra));
    let title = match stress {
        Some(s) => format!("{title} (stress-1 = {s:.3})"),
        None => title.to_string(),
    };
    let fig = Scatter {
        xy,
        names,
        shown,
        classes: labels.map(encode_labels),
        title,
        range,
    };
    render(path, &fig)
}

impl Scatter<'_> {
    /// Width of the legend panel right of the chart (0 without classes).
    fn legend_width(&self) -> u32 {
        match &self.classes {
            Some((_, names)) => {
                let longest = names.iter().map(|s| s.chars().count()).max().unwrap_or(0) as u32;
                (48 + 8 * longest).clamp(110, 260)
            }
            None => 0,
        }
    }
}

impl Figure for Scatter<'_> {
    fn size(&self) -> (u32, u32) {
        (760 + self.legend_width(), 760)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<(), DB> {
        let ((x0, x1), (y0, y1)) = self.range;
        let (w, _) = self.size();
        let root = root.titled(&self.title, (FAMILY, super::title_size(&self.title, w)))?;
        let (plot, legend) = root.split_horizontally(w - self.legend_width());
        let mut chart = ChartBuilder::on(&plot)
            .margin(16)
            .margin_right(28)
            .x_label_area_size(44)
            .y_label_area_size(60)
            .build_cartesian_2d(x0..x1, y0..y1)?;
        chart
            .configure_mesh()
            .x_desc("MDS axis 1")
            .y_desc("MDS axis 2")
            .label_style((FAMILY, 13))
            .axis_desc_style((FAMILY, 14))
            .bold_line_style(RGBColor(225, 225, 225))
            .max_light_lines(0)
            .x_labels(8)
            .y_labels(8)
            .x_label_formatter(&|v| super::axis_label(*v, x1 - x0, 8))
            .y_label_formatter(&|v| super::axis_label(*v, y1 - y0, 8))
            .draw()?;
        let groups: Vec<Vec<usize>> = match &self.classes {
            Some((idx, names)) => (0..names.len())
                .map(|c| (0..idx.len()).filter(|&i| idx[i] == c).collect())
                .collect(),
            None => vec![(0..self.xy.len()).collect()],
        };
        let edge = BLACK.mix(0.6).stroke_width(1);
        for (c, members) in groups.iter().enumerate() {
            let fill = color(c).mix(0.9).filled();
            let outline = marker_outline(c, 6);
            let mut closed = outline.clone();
            closed.push(outline[0]);
            chart.draw_series(members.iter().map(|&i| {
                EmptyElement::at(self.xy[i])
                    + Polygon::new(outline.clone(), fill)
                    + PathElement::new(closed.clone(), edge)
            }))?;
        }
        let named: Vec<usize> = (0..self.xy.len()).filter(|&i| self.shown[i]).collect();
        chart.draw_series(named.iter().map(|&i| {
            EmptyElement::at(self.xy[i])
                + Text::new(self.names[i].clone(), (8, -16), (FAMILY, 12).into_font())
        }))?;
        if let Some((_, names)) = &self.classes {
            let entries: Vec<(String, RGBColor, Swatch)> = names
                .iter()
                .enumerate()
                .map(|(c, n)| (n.clone(), color(c), Swatch::Marker(c)))
                .collect();
            draw_legend(&legend, &entries, 40, None)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::{decode_png, n_colors};
    use super::*;

    fn data() -> (Vec<Vec<f64>>, Vec<String>, Vec<String>) {
        let coords: Vec<Vec<f64>> = (0..9)
            .map(|i| vec![(i % 3) as f64 + 0.1 * i as f64, (i / 3) as f64 * 4.0, 0.5])
            .collect();
        let names = (0..9).map(|i| format!("def{i}")).collect();
        let labels = (0..9)
            .map(|i| ["walk", "run", "jump"][i / 3].to_string())
            .collect();
        (coords, names, labels)
    }

    /// Axis labels in the one plain format (issue 50, item 7): MDS coordinates centred on 0 put a
    /// tick at a rounding error of zero, which plotters' own labels printed as `-0.0`.
    #[test]
    fn axis_labels_are_plain_numbers() {
        let dir = tempfile::tempdir().unwrap();
        let coords: Vec<Vec<f64>> = (0..7)
            .map(|i| {
                let t = i as f64 * 0.9;
                vec![0.3 * t.cos() - 1e-17, 0.3 * t.sin() + 0.1]
            })
            .collect();
        let names: Vec<String> = (0..7).map(|i| format!("p{i}")).collect();
        let p = dir.path().join("axes.svg");
        scatter_map(&p, &coords, &names, None, "MDS", None).unwrap();
        let svg = std::fs::read_to_string(&p).unwrap();
        let labels: Vec<&str> = svg
            .split("<text")
            .skip(1)
            .filter_map(|t| t.split_once('>').and_then(|(_, rest)| rest.split_once("</text>")))
            .map(|(text, _)| text.trim())
            .filter(|t| t.parse::<f64>().is_ok())
            .collect();
        assert!(labels.len() >= 8, "{labels:?}");
        assert!(labels.contains(&"0"), "{labels:?}");
        for l in &labels {
            assert!(
                !l.starts_with("-0") || l.starts_with("-0.") && l.parse::<f64>().unwrap() != 0.0,
                "{l}"
            );
            assert!(
                !(l.contains('.') && l.ends_with('0')),
                "trailing zero: {l} in {labels:?}"
            );
            assert!(l.len() <= 6, "long label {l}");
        }
    }

    #[test]
    fn svg_map_has_one_marker_per_point_and_per_class() {
        let dir = tempfile::tempdir().unwrap();
        let (coords, names, labels) = data();
        let p = dir.path().join("map.svg");
        scatter_map(&p, &coords, &names, Some(&labels), "Deformations", Some(0.0123)).unwrap();
        let svg = std::fs::read_to_string(&p).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        // 9 points + 3 legend entries; with classes no point names (the legend says the class).
        assert_eq!(svg.matches("<polygon").count(), 12, "{svg}");
        assert!(!svg.contains("def8") && svg.contains("jump") && svg.contains("stress-1 = 0.012"));
        // Three fill colours for three classes.
        for c in 0..3 {
            let RGBColor(r, g, b) = color(c);
            assert!(svg.contains(&format!("#{r:02X}{g:02X}{b:02X}")), "colour {c}");
        }
        // Without labels: no legend.
        let p = dir.path().join("plain.svg");
        scatter_map(&p, &coords, &names, None, "Deformations", None).unwrap();
        let svg = std::fs::read_to_string(&p).unwrap();
        assert_eq!(svg.matches("<polygon").count(), 9);
        assert!(svg.contains("def8"), "few points without classes are named");
        // Chosen names only.
        let mut some = vec![false; 9];
        some[4] = true;
        let p = dir.path().join("some.svg");
        scatter_map_with(
            &p,
            &coords,
            &names,
            Some(&labels),
            "D",
            None,
            &PointNames::Some(some),
        )
        .unwrap();
        let svg = std::fs::read_to_string(&p).unwrap();
        assert!(svg.contains("def4") && !svg.contains("def3"));
    }

    #[test]
    fn png_map_decodes_to_the_figure_size_with_coloured_pixels() {
        let dir = tempfile::tempdir().unwrap();
        let (coords, names, labels) = data();
        let p = dir.path().join("map.png");
        scatter_map(&p, &coords, &names, Some(&labels), "Deformations", None).unwrap();
        let (w, h, rgb) = decode_png(&p);
        assert_eq!((w, h), (870, 760));
        assert_eq!(rgb.len(), 870 * 760 * 3);
        // Text is rasterized (anti-aliased greys) and the three class colours appear.
        assert!(n_colors(&rgb) > 20);
        for c in 0..3 {
            let RGBColor(r, g, b) = color(c);
            assert!(rgb.chunks_exact(3).any(|p| p == [r, g, b]), "colour {c}");
        }
    }

    #[test]
    fn bad_inputs_are_errors_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let (coords, names, _) = data();
        let p = dir.path().join("map.svg");
        let e = scatter_map(&p, &coords, &names[..3], None, "t", None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("map.svg") && e.contains("names"), "{e}");
        let mut bad = coords.clone();
        bad[2][1] = f64::NAN;
        let e = scatter_map(&p, &bad, &names, None, "t", None)
            .unwrap_err()
            .to_string();
        assert!(e.contains("not finite"), "{e}");
        let e = scatter_map(&dir.path().join("m.jpg"), &coords, &names, None, "t", None).unwrap_err();
        assert!(matches!(e, PlotError::UnknownFormat { .. }));
        assert!(!p.exists());
    }
}
