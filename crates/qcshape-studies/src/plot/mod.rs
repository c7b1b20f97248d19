//! Figures: the MDS map of deformations (Fig. 6), a heat map of the distance matrix, and
//! grouped mean +- SD bars (Fig. 4c).
//!
//! Every function writes the format named by the path's extension: `.svg` (plotters' SVG
//! backend) or `.png` (plotters' bitmap backend, encoded with the `png` crate). Both are pure
//! Rust; text is laid out and (for PNG) rasterized with the bundled DejaVu Sans font
//! (`assets/fonts/`, Bitstream Vera licence, see `LICENSE-DejaVu.txt`), so no system font
//! library is needed. Files are written atomically.

mod bars;
mod heatmap;
mod scatter;

pub use bars::{error_bars, BarGroup};
pub use heatmap::heatmap;
pub use scatter::{scatter_map, scatter_map_with, PointNames};

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::coord::Shift;
use plotters::prelude::*;
use thiserror::Error;

use qcshape::io::{write_atomically, IoError};

/// The bundled font (DejaVu Sans), registered as plotters' `sans-serif`.
static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

/// The font family every figure uses.
pub(crate) const FAMILY: &str = "sans-serif";

/// Data that cannot be plotted ([`PlotError::Invalid`]).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum PlotInput {
    /// No bar in any group.
    #[error("no bars to plot")]
    NoBars,
    /// A bar whose mean or SD is not finite, or whose SD is negative.
    #[error("group {group:?}, series {series:?}: mean {mean} and sd {sd} must be finite, sd >= 0")]
    BadBar {
        /// The group.
        group: String,
        /// The series.
        series: String,
        /// The mean.
        mean: f64,
        /// The SD.
        sd: f64,
    },
    /// A heat map order of another length than the matrix.
    #[error("the order lists {order} items, the matrix has {n}")]
    OrderLength {
        /// Items in the order.
        order: usize,
        /// Rows of the matrix.
        n: usize,
    },
    /// A heat map order that is not a permutation.
    #[error("the order is not a permutation of 0..{n} (at {at})")]
    NotPermutation {
        /// Rows of the matrix.
        n: usize,
        /// The repeated or out-of-range item.
        at: usize,
    },
    /// Not one label per deformation (heat map).
    #[error("{labels} labels for {n} deformations")]
    LabelCount {
        /// Labels given.
        labels: usize,
        /// Deformations.
        n: usize,
    },
    /// No point in a scatter plot.
    #[error("no points to plot")]
    NoPoints,
    /// Not one name, label or name choice per point.
    #[error("{points} points but {found} {what}")]
    PerPoint {
        /// "names", "labels" or "name choices".
        what: &'static str,
        /// Points.
        points: usize,
        /// Entries given.
        found: usize,
    },
    /// A point with a NaN or infinite coordinate.
    #[error("point {point} ({name}) is not finite")]
    NonFinitePoint {
        /// The point.
        point: usize,
        /// Its name.
        name: String,
    },
}

/// Why a figure cannot be made.
#[derive(Debug, Error)]
pub enum PlotError {
    /// The extension is neither `.svg` nor `.png`.
    #[error("{}: unknown figure format: the file name must end in .svg or .png", path.display())]
    UnknownFormat {
        /// The file.
        path: PathBuf,
    },
    /// The data cannot be plotted (lengths differ, non-finite values, nothing to draw).
    #[error("{}: {problem}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        problem: PlotInput,
    },
    /// The plotting library (or the PNG encoder) failed.
    #[error("{}: cannot draw: {error}", path.display())]
    Draw {
        /// The file.
        path: PathBuf,
        /// Its error (boxed: its type depends on the backend, SVG or PNG).
        error: Box<dyn std::error::Error + Send + Sync>,
    },
    /// The file cannot be written.
    #[error(transparent)]
    Write(#[from] IoError),
}

/// An output format, from the file extension.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlotFormat {
    /// Scalable vector graphics.
    Svg,
    /// 8-bit RGB PNG.
    Png,
}

impl PlotFormat {
    /// The format named by `path`'s extension (case-insensitive).
    pub fn from_path(path: &Path) -> Result<PlotFormat, PlotError> {
        match path
            .extension()
            .and_then(|e| e.to_str())
            .map(str::to_ascii_lowercase)
            .as_deref()
        {
            Some("svg") => Ok(PlotFormat::Svg),
            Some("png") => Ok(PlotFormat::Png),
            _ => Err(PlotError::UnknownFormat { path: path.into() }),
        }
    }
}

/// Ten distinguishable colours (matplotlib's "tab10"), cycled for more classes.
const PALETTE: [(u8, u8, u8); 10] = [
    (31, 119, 180),
    (255, 127, 14),
    (44, 160, 44),
    (214, 39, 40),
    (148, 103, 189),
    (140, 86, 75),
    (227, 119, 194),
    (127, 127, 127),
    (188, 189, 34),
    (23, 190, 207),
];

/// The colour of class / series `i`.
pub(crate) fn color(i: usize) -> RGBColor {
    let (r, g, b) = PALETTE[i % PALETTE.len()];
    RGBColor(r, g, b)
}

/// The outline of marker `kind` (cycled: circle, triangle, square, diamond, inverted
/// triangle) of radius `r` pixels, as offsets from its centre.
pub(crate) fn marker_outline(kind: usize, r: i32) -> Vec<(i32, i32)> {
    let polygon = |n: usize, phase: f64, scale: f64| -> Vec<(i32, i32)> {
        (0..n)
            .map(|k| {
                let a = phase + std::f64::consts::TAU * k as f64 / n as f64;
                let rr = scale * r as f64;
                ((rr * a.cos()).round() as i32, (-rr * a.sin()).round() as i32)
            })
            .collect()
    };
    use std::f64::consts::FRAC_PI_2;
    match kind % 5 {
        0 => polygon(16, 0.0, 1.0),
        1 => polygon(3, FRAC_PI_2, 1.25),
        2 => vec![(-r, -r), (r, -r), (r, r), (-r, r)],
        3 => polygon(4, FRAC_PI_2, 1.3),
        _ => polygon(3, -FRAC_PI_2, 1.25),
    }
}

/// The font size of a title: 20 px, smaller (down to 11) when the text would not fit in
/// `width` pixels with a margin (DejaVu Sans averages about 0.58 em per character).
pub(crate) fn title_size(title: &str, width: u32) -> u32 {
    let chars = title.chars().count().max(1) as f64;
    let fit = (width as f64 - 24.0) / (0.58 * chars);
    (fit.floor() as u32).clamp(11, 20)
}

/// What a legend entry shows beside its text.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Swatch {
    /// A marker of [`marker_outline`]'s kind.
    Marker(usize),
    /// A filled box (a bar's colour).
    Box,
}

/// Draws a legend (one row per entry: swatch and text) in `area` from `top` pixels down,
/// outside any chart's data area. Returns the height used.
pub(crate) fn draw_legend<DB: DrawingBackend>(
    area: &DrawingArea<DB, Shift>,
    entries: &[(String, RGBColor, Swatch)],
    top: i32,
    heading: Option<&str>,
) -> DrawResult<i32, DB> {
    use plotters::style::text_anchor::{HPos, Pos, VPos};
    let row = 22;
    let mut y = top;
    let text = TextStyle::from((FAMILY, 14).into_font()).pos(Pos::new(HPos::Left, VPos::Center));
    if let Some(h) = heading {
        area.draw(&Text::new(h.to_string(), (10, y), text.clone()))?;
        y += row;
    }
    for (label, c, swatch) in entries {
        let (cx, cy) = (20, y);
        match swatch {
            Swatch::Marker(kind) => {
                let pts: Vec<(i32, i32)> = marker_outline(*kind, 6)
                    .into_iter()
                    .map(|(dx, dy)| (cx + dx, cy + dy))
                    .collect();
                area.draw(&Polygon::new(pts.clone(), c.filled()))?;
                let mut closed = pts;
                closed.push(closed[0]);
                area.draw(&PathElement::new(closed, BLACK.mix(0.6).stroke_width(1)))?;
            }
            Swatch::Box => {
                area.draw(&Rectangle::new([(cx - 7, cy - 6), (cx + 7, cy + 6)], c.filled()))?;
            }
        }
        area.draw(&Text::new(label.clone(), (cx + 16, cy), text.clone()))?;
        y += row;
    }
    Ok(y - top)
}

/// A figure that can draw itself on any plotters backend.
pub(crate) trait Figure {
    /// Width and height in pixels.
    fn size(&self) -> (u32, u32);
    /// Draws on the root area (already filled white).
    fn draw<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>) -> DrawResult<(), DB>;
}

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TrueType file; a failure would show as a drawing error.
        let _ = plotters::style::register_font(FAMILY, FontStyle::Normal, FONT);
    });
}

/// Draws `fig` and writes it to `path` (format from the extension), atomically.
pub(crate) fn render<F: Figure>(path: &Path, fig: &F) -> Result<(), PlotError> {
    let format = PlotFormat::from_path(path)?;
    register_font();
    let (w, h) = fig.size();
    let draw_err = |error: Box<dyn std::error::Error + Send + Sync>| PlotError::Draw {
        path: path.into(),
        error,
    };
    match format {
        PlotFormat::Svg => {
            let mut svg = String::new();
            {
                let root = SVGBackend::with_string(&mut svg, (w, h)).into_drawing_area();
                root.fill(&WHITE).map_err(|e| draw_err(Box::new(e)))?;
                fig.draw(&root).map_err(|e| draw_err(Box::new(e)))?;
                root.present().map_err(|e| draw_err(Box::new(e)))?;
            }
            write_atomically(path, |out| out.write_all(svg.as_bytes()))?;
        }
        PlotFormat::Png => {
            let mut rgb = vec![0u8; w as usize * h as usize * 3];
            {
                let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
                root.fill(&WHITE).map_err(|e| draw_err(Box::new(e)))?;
                fig.draw(&root).map_err(|e| draw_err(Box::new(e)))?;
                root.present().map_err(|e| draw_err(Box::new(e)))?;
            }
            let mut bytes = Vec::new();
            {
                let mut enc = png::Encoder::new(&mut bytes, w, h);
                enc.set_color(png::ColorType::Rgb);
                enc.set_depth(png::BitDepth::Eight);
                let mut writer = enc.write_header().map_err(|e| draw_err(Box::new(e)))?;
                writer.write_image_data(&rgb).map_err(|e| draw_err(Box::new(e)))?;
                writer.finish().map_err(|e| draw_err(Box::new(e)))?;
            }
            write_atomically(path, |out| out.write_all(&bytes))?;
        }
    }
    Ok(())
}

/// The label of the value `v` on an axis spanning `span` with about `n` labels: plain numbers
/// ([`qcshape::numfmt::tick`]), so a tick at a rounding error of zero reads `0`, never `-0.0`.
pub(crate) fn axis_label(v: f64, span: f64, n: usize) -> String {
    qcshape::numfmt::tick(v, span / n.max(1) as f64)
}

/// An axis range `[lo, hi]` padded by `pad` of its span (a unit span around a single value).
pub(crate) fn padded(lo: f64, hi: f64, pad: f64) -> (f64, f64) {
    let span = hi - lo;
    if span > 0.0 {
        (lo - pad * span, hi + pad * span)
    } else {
        (lo - 0.5, hi + 0.5)
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// Decodes a PNG file: (width, height, RGB or RGBA bytes).
    pub(crate) fn decode_png(path: &Path) -> (u32, u32, Vec<u8>) {
        let file = std::io::BufReader::new(std::fs::File::open(path).unwrap());
        let mut reader = png::Decoder::new(file).read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        buf.truncate(info.buffer_size());
        (info.width, info.height, buf)
    }

    /// Number of distinct colours in an RGB buffer.
    pub(crate) fn n_colors(rgb: &[u8]) -> usize {
        let mut set = std::collections::HashSet::new();
        for p in rgb.chunks_exact(3) {
            set.insert([p[0], p[1], p[2]]);
        }
        set.len()
    }

    #[test]
    fn formats_come_from_the_extension() {
        assert_eq!(
            PlotFormat::from_path(Path::new("a.SVG")).unwrap(),
            PlotFormat::Svg
        );
        assert_eq!(
            PlotFormat::from_path(Path::new("a.png")).unwrap(),
            PlotFormat::Png
        );
        let e = PlotFormat::from_path(Path::new("dir/a.pdf"))
            .unwrap_err()
            .to_string();
        assert!(e.contains("a.pdf") && e.contains(".svg or .png"), "{e}");
    }
}
