//! The map of deformations: MDS coordinates coloured by class (the paper's Fig. 6).

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::{color, msg, padded, render, Figure, PlotError, FAMILY};
use crate::eval::encode_labels;

/// Names are written next to the points up to this many points.
const MAX_NAMED_POINTS: usize = 120;

struct Scatter<'a> {
    xy: Vec<(f64, f64)>,
    names: &'a [String],
    classes: Option<(Vec<usize>, Vec<String>)>,
    title: String,
    range: ((f64, f64), (f64, f64)),
}

/// Writes a scatter plot of embedded deformations to `path` (`.svg` or `.png`, atomically):
/// one filled circle per deformation at `coords[i][0..2]` (n x dims; a 1-D embedding is drawn
/// on y = 0, a 3-D one by its first two axes), named by `names[i]` (up to 120 points),
/// coloured by `labels[i]` with a legend of the classes (in order of first appearance) when
/// labels are given. Both axes have the same scale. The title gets `stress-1 = ...` appended
/// when `stress` is given.
pub fn scatter_map(
    path: &Path,
    coords: &[Vec<f64>],
    names: &[String],
    labels: Option<&[String]>,
    title: &str,
    stress: Option<f64>,
) -> Result<(), PlotError> {
    let invalid = |message: String| PlotError::Invalid {
        path: path.into(),
        message,
    };
    let n = coords.len();
    if n == 0 {
        return Err(invalid("no points to plot".into()));
    }
    if names.len() != n {
        return Err(invalid(format!("{n} points but {} names", names.len())));
    }
    if let Some(l) = labels {
        if l.len() != n {
            return Err(invalid(format!("{n} points but {} labels", l.len())));
        }
    }
    let mut xy = Vec::with_capacity(n);
    for (i, c) in coords.iter().enumerate() {
        let (x, y) = (
            c.first().copied().unwrap_or(0.0),
            c.get(1).copied().unwrap_or(0.0),
        );
        if !x.is_finite() || !y.is_finite() {
            return Err(invalid(format!("point {} ({}) is not finite", i, names[i])));
        }
        xy.push((x, y));
    }
    let (xmin, xmax) = xy.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
        (a.min(p.0), b.max(p.0))
    });
    let (ymin, ymax) = xy.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), p| {
        (a.min(p.1), b.max(p.1))
    });
    // Equal scales: both axes get the larger span, centred on the data.
    let half = 0.5 * (xmax - xmin).max(ymax - ymin);
    let (cx, cy) = (0.5 * (xmin + xmax), 0.5 * (ymin + ymax));
    let range = (
        padded(cx - half, cx + half, 0.08),
        padded(cy - half, cy + half, 0.08),
    );
    let title = match stress {
        Some(s) => format!("{title} (stress-1 = {s:.4})"),
        None => title.to_string(),
    };
    let fig = Scatter {
        xy,
        names,
        classes: labels.map(encode_labels),
        title,
        range,
    };
    render(path, &fig)
}

impl Figure for Scatter<'_> {
    fn size(&self) -> (u32, u32) {
        (820, 760)
    }

    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> Result<(), String> {
        let ((x0, x1), (y0, y1)) = self.range;
        let mut chart = ChartBuilder::on(root)
            .caption(&self.title, (FAMILY, 22))
            .margin(16)
            .x_label_area_size(36)
            .y_label_area_size(56)
            .build_cartesian_2d(x0..x1, y0..y1)
            .map_err(msg)?;
        chart
            .configure_mesh()
            .x_desc("MDS axis 1")
            .y_desc("MDS axis 2")
            .label_style((FAMILY, 13))
            .light_line_style(RGBColor(235, 235, 235))
            .draw()
            .map_err(msg)?;
        let show_names = self.xy.len() <= MAX_NAMED_POINTS;
        let groups: Vec<(Vec<usize>, Option<&str>)> = match &self.classes {
            Some((idx, names)) => (0..names.len())
                .map(|c| {
                    (
                        (0..idx.len()).filter(|&i| idx[i] == c).collect(),
                        Some(names[c].as_str()),
                    )
                })
                .collect(),
            None => vec![((0..self.xy.len()).collect(), None)],
        };
        for (c, (members, label)) in groups.iter().enumerate() {
            let style = color(c).filled();
            let series = chart
                .draw_series(members.iter().map(|&i| {
                    let name = if show_names { self.names[i].as_str() } else { "" };
                    EmptyElement::at(self.xy[i])
                        + Circle::new((0, 0), 5, style)
                        + Text::new(name.to_string(), (7, -14), (FAMILY, 11).into_font())
                }))
                .map_err(msg)?;
            if let Some(label) = label {
                series
                    .label(*label)
                    .legend(move |(x, y)| Circle::new((x + 6, y), 5, style));
            }
        }
        if self.classes.is_some() {
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .label_font((FAMILY, 13))
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .draw()
                .map_err(msg)?;
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

    #[test]
    fn svg_map_has_one_marker_per_point_and_per_class() {
        let dir = tempfile::tempdir().unwrap();
        let (coords, names, labels) = data();
        let p = dir.path().join("map.svg");
        scatter_map(&p, &coords, &names, Some(&labels), "Deformations", Some(0.0123)).unwrap();
        let svg = std::fs::read_to_string(&p).unwrap();
        assert!(svg.starts_with("<svg") && svg.trim_end().ends_with("</svg>"));
        // 9 points + 3 legend entries.
        assert_eq!(svg.matches("<circle").count(), 12, "{svg}");
        assert!(svg.contains("def8") && svg.contains("jump") && svg.contains("stress-1 = 0.0123"));
        // Three fill colours for three classes.
        for c in 0..3 {
            let RGBColor(r, g, b) = color(c);
            assert!(svg.contains(&format!("#{r:02X}{g:02X}{b:02X}")), "colour {c}");
        }
        // Without labels: no legend.
        let p = dir.path().join("plain.svg");
        scatter_map(&p, &coords, &names, None, "Deformations", None).unwrap();
        let svg = std::fs::read_to_string(&p).unwrap();
        assert_eq!(svg.matches("<circle").count(), 9);
    }

    #[test]
    fn png_map_decodes_to_the_figure_size_with_coloured_pixels() {
        let dir = tempfile::tempdir().unwrap();
        let (coords, names, labels) = data();
        let p = dir.path().join("map.png");
        scatter_map(&p, &coords, &names, Some(&labels), "Deformations", None).unwrap();
        let (w, h, rgb) = decode_png(&p);
        assert_eq!((w, h), (820, 760));
        assert_eq!(rgb.len(), 820 * 760 * 3);
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
