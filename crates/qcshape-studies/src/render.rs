//! Offscreen pictures of a per-vertex scalar on a triangle mesh: a small software z-buffer
//! rasterizer (docs/maps.md, "Pictures").
//!
//! The scalar goes through a colour map (diverging blue-white-red, symmetric about 0, for
//! signed values; sequential viridis otherwise), interpolated over each triangle (Gouraud:
//! the scalar and the shading are interpolated, then mapped per pixel) and shaded by a
//! two-sided Lambert term (`0.35 + 0.65 |n . view|`, area-weighted vertex normals). Every view
//! uses one orthographic camera fitted to the mesh's bounding box (centre of the box, scale
//! from the largest vertex distance to it), so the views share one scale. The picture has a
//! title, a subtitle naming the colour map's quantity, the views in a grid of two columns and
//! a colour bar with tick values. Pixels are sampled 2 x 2 per output pixel and averaged.
//! Text uses the bundled DejaVu Sans font through plotters; everything is plain arithmetic in
//! a fixed order, so the same input gives the same PNG bytes.

use std::path::{Path, PathBuf};
use std::sync::Once;

use plotters::prelude::*;
use thiserror::Error;

use qcshape::io::{write_atomically, IoError};

/// The bundled font (the same file as [`crate::plot`]'s).
static FONT: &[u8] = include_bytes!("../assets/fonts/DejaVuSans.ttf");
/// The font family registered with plotters.
const FAMILY: &str = "sans-serif";
/// Background colour (RGB).
pub const BACKGROUND: [u8; 3] = [255, 255, 255];
/// Colour of greyed vertices (RGB, before shading).
pub const GREY: [u8; 3] = [190, 190, 190];
/// Colour of region outlines (RGB).
pub const OUTLINE: [u8; 3] = [20, 20, 20];
/// Supersampling factor per axis.
const SS: usize = 2;

/// The error of drawing text and the colour bar on the bitmap (plotters' own).
pub type DrawError = plotters::drawing::DrawingAreaErrorKind<
    <BitMapBackend<'static> as plotters::backend::DrawingBackend>::ErrorType,
>;

/// Inconsistent or non-finite input to [`render`] ([`RenderError::Invalid`]).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum RenderInput {
    /// Not one value per vertex.
    #[error("{values} values for {vertices} vertices")]
    ValueCount {
        /// Values given.
        values: usize,
        /// Vertices.
        vertices: usize,
    },
    /// A value that is NaN or infinite.
    #[error("the value of vertex {vertex} is {value}")]
    NonFiniteValue {
        /// The vertex.
        vertex: usize,
        /// Its value.
        value: f64,
    },
    /// A vertex with a NaN or infinite coordinate.
    #[error("vertex {0} has a non-finite coordinate")]
    NonFiniteVertex(usize),
    /// A face naming a vertex that does not exist.
    #[error("face {face} names a vertex beyond the {vertices} vertices")]
    FaceIndex {
        /// The face.
        face: usize,
        /// Vertices.
        vertices: usize,
    },
    /// Not one grey or outline flag per vertex.
    #[error("{flags} {name} flags for {vertices} vertices")]
    FlagCount {
        /// "grey" or "outline".
        name: &'static str,
        /// Flags given.
        flags: usize,
        /// Vertices.
        vertices: usize,
    },
    /// No view, or a view size outside 16..4096 pixels.
    #[error("{views} views of {size} pixels: need at least one view of 16..4096 pixels")]
    Views {
        /// Views asked for.
        views: usize,
        /// Pixels per view side.
        size: u32,
    },
    /// A colour range that is not finite and increasing.
    #[error("bad colour range {lo}..{hi}")]
    ColourRange {
        /// Low end.
        lo: f64,
        /// High end.
        hi: f64,
    },
}

/// Why a picture cannot be made.
#[derive(Debug, Error)]
pub enum RenderError {
    /// No vertex or no face.
    #[error("nothing to render: the mesh has {vertices} vertices and {faces} faces")]
    Empty {
        /// Vertex count.
        vertices: usize,
        /// Face count.
        faces: usize,
    },
    /// Inconsistent or non-finite input.
    #[error("cannot render: {0}")]
    Invalid(RenderInput),
    /// Text or colour-bar drawing failed (plotters' error, kept).
    #[error("cannot draw: {0}")]
    Draw(DrawError),
    /// The PNG cannot be encoded (the png crate's error, kept).
    #[error("cannot encode the PNG: {error}")]
    Encode {
        /// The png crate's error.
        error: png::EncodingError,
    },
    /// The file cannot be written.
    #[error(transparent)]
    Write(#[from] IoError),
}

/// A camera direction. Each names where the viewer stands, with the world axis that points
/// up in the picture.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum View {
    /// From -y, z up (x to the right).
    Front,
    /// From +y, z up.
    Back,
    /// From -x, z up.
    Left,
    /// From +x, z up.
    Right,
    /// From +z, y up (x to the right).
    Top,
    /// From -z, y up.
    Bottom,
}

impl View {
    /// `(toward the viewer, up)` unit vectors in world coordinates.
    fn axes(self) -> ([f64; 3], [f64; 3]) {
        let z = [0.0, 0.0, 1.0];
        let y = [0.0, 1.0, 0.0];
        match self {
            View::Front => ([0.0, -1.0, 0.0], z),
            View::Back => ([0.0, 1.0, 0.0], z),
            View::Left => ([-1.0, 0.0, 0.0], z),
            View::Right => ([1.0, 0.0, 0.0], z),
            View::Top => ([0.0, 0.0, 1.0], y),
            View::Bottom => ([0.0, 0.0, -1.0], y),
        }
    }

    /// The view's name as printed in the picture (`front`, `back`, ...).
    pub fn name(self) -> &'static str {
        match self {
            View::Front => "front (-y)",
            View::Back => "back (+y)",
            View::Left => "left (-x)",
            View::Right => "right (+x)",
            View::Top => "top (+z)",
            View::Bottom => "bottom (-z)",
        }
    }
}

/// Which colour map.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Colormap {
    /// Diverging when the values have both signs, sequential otherwise.
    #[default]
    Auto,
    /// Blue (negative) - white (0) - red (positive), symmetric about 0.
    Diverging,
    /// Viridis from the smallest to the largest value.
    Sequential,
}

/// What to draw besides the mesh.
#[derive(Debug, Clone, PartialEq)]
pub struct RenderOptions {
    /// Title (first line).
    pub title: String,
    /// The scalar's name and unit (second line, beside the colour bar's meaning).
    pub label: String,
    /// Views, in rows of two (up to four views) or three (default: all six, front, right,
    /// top in the first row, back, left, bottom in the second, so every side is seen).
    pub views: Vec<View>,
    /// Side of one view's square in pixels (default 280).
    pub view_size: u32,
    /// Colour map.
    pub colormap: Colormap,
    /// Value range `(lo, hi)` of the colour map (default: from the data; diverging maps use
    /// `+-max|value|`).
    pub range: Option<(f64, f64)>,
    /// Vertices drawn grey instead of coloured (#V; e.g. not significant).
    pub grey: Option<Vec<bool>>,
    /// Vertices whose region's boundary is outlined in black (#V; e.g. a known region).
    pub outline: Option<Vec<bool>>,
}

impl Default for RenderOptions {
    fn default() -> Self {
        RenderOptions {
            title: String::new(),
            label: String::new(),
            views: vec![
                View::Front,
                View::Right,
                View::Top,
                View::Back,
                View::Left,
                View::Bottom,
            ],
            view_size: 280,
            colormap: Colormap::Auto,
            range: None,
            grey: None,
            outline: None,
        }
    }
}

/// An 8-bit RGB picture.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Image {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Row-major RGB bytes (width x height x 3).
    pub rgb: Vec<u8>,
}

impl Image {
    /// The pixel at column `x`, row `y` (row 0 at the top).
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        let i = 3 * (y as usize * self.width as usize + x as usize);
        [self.rgb[i], self.rgb[i + 1], self.rgb[i + 2]]
    }

    /// The PNG encoding.
    pub fn png_bytes(&self) -> Result<Vec<u8>, RenderError> {
        let mut bytes = Vec::new();
        {
            let mut enc = png::Encoder::new(&mut bytes, self.width, self.height);
            enc.set_color(png::ColorType::Rgb);
            enc.set_depth(png::BitDepth::Eight);
            let mut w = enc
                .write_header()
                .map_err(|error| RenderError::Encode { error })?;
            w.write_image_data(&self.rgb)
                .map_err(|error| RenderError::Encode { error })?;
            w.finish().map_err(|error| RenderError::Encode { error })?;
        }
        Ok(bytes)
    }
}

/// Where the parts of the picture are, in output pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Layout {
    /// Height of the title band at the top.
    pub header: u32,
    /// Side of one view.
    pub view: u32,
    /// Columns of views (two for up to four views, else three).
    pub columns: u32,
    /// Rows of views.
    pub rows: u32,
    /// Width of the colour-bar panel at the right.
    pub bar_panel: u32,
}

impl Layout {
    fn new(opts: &RenderOptions) -> Layout {
        let n = opts.views.len().max(1) as u32;
        let columns = if n > 4 { 3 } else { n.min(2) };
        Layout {
            header: 56,
            view: opts.view_size,
            columns,
            rows: n.div_ceil(columns),
            bar_panel: 110,
        }
    }

    /// `(x, y)` of view `k`'s top-left corner.
    pub fn view_origin(&self, k: usize) -> (u32, u32) {
        let k = k as u32;
        (
            (k % self.columns) * self.view,
            self.header + (k / self.columns) * self.view,
        )
    }

    fn size(&self) -> (u32, u32) {
        (
            self.columns * self.view + self.bar_panel,
            self.header + self.rows * self.view,
        )
    }
}

/// The layout [`render`] uses for `opts`.
pub fn layout(opts: &RenderOptions) -> Layout {
    Layout::new(opts)
}

fn lerp3(a: [f64; 3], b: [f64; 3], t: f64) -> [f64; 3] {
    std::array::from_fn(|c| a[c] + (b[c] - a[c]) * t)
}

fn ramp(stops: &[[f64; 3]], t: f64) -> [f64; 3] {
    let t = t.clamp(0.0, 1.0) * (stops.len() - 1) as f64;
    let i = (t.floor() as usize).min(stops.len() - 2);
    lerp3(stops[i], stops[i + 1], t - i as f64)
}

/// Blue-white-red (ColorBrewer RdBu, reversed) at `t` in [0, 1] (0.5 = white), RGB in [0, 1].
pub fn diverging(t: f64) -> [f64; 3] {
    const S: [[f64; 3]; 7] = [
        [0.129, 0.400, 0.675],
        [0.263, 0.576, 0.765],
        [0.573, 0.773, 0.871],
        [0.969, 0.969, 0.969],
        [0.957, 0.647, 0.510],
        [0.839, 0.376, 0.302],
        [0.698, 0.094, 0.169],
    ];
    ramp(&S, t)
}

/// Viridis at `t` in [0, 1] (9 stops, linear between), RGB in [0, 1].
pub fn sequential(t: f64) -> [f64; 3] {
    const S: [[f64; 3]; 9] = [
        [0.267, 0.005, 0.329],
        [0.283, 0.141, 0.458],
        [0.254, 0.265, 0.530],
        [0.207, 0.372, 0.553],
        [0.164, 0.471, 0.558],
        [0.128, 0.567, 0.551],
        [0.135, 0.659, 0.518],
        [0.478, 0.821, 0.319],
        [0.993, 0.906, 0.144],
    ];
    ramp(&S, t)
}

/// The colour map and its value range resolved for `values`.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Scale {
    diverging: bool,
    lo: f64,
    hi: f64,
}

impl Scale {
    fn new(values: &[f64], opts: &RenderOptions) -> Scale {
        let min = values.iter().copied().fold(f64::INFINITY, f64::min);
        let max = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        let diverging = match opts.colormap {
            Colormap::Diverging => true,
            Colormap::Sequential => false,
            Colormap::Auto => min < 0.0 && max > 0.0,
        };
        let (mut lo, mut hi) = match opts.range {
            Some(r) => r,
            None if diverging => {
                let m = min.abs().max(max.abs());
                (-m, m)
            }
            None => (min, max),
        };
        if hi <= lo {
            let pad = if lo == 0.0 { 1.0 } else { 0.5 * lo.abs() };
            lo -= pad;
            hi += pad;
        }
        Scale { diverging, lo, hi }
    }

    fn t(&self, v: f64) -> f64 {
        ((v - self.lo) / (self.hi - self.lo)).clamp(0.0, 1.0)
    }

    fn color(&self, t: f64) -> [f64; 3] {
        if self.diverging {
            diverging(t)
        } else {
            sequential(t)
        }
    }
}

fn check(
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    values: &[f64],
    opts: &RenderOptions,
) -> Result<(), RenderError> {
    if positions.is_empty() || faces.is_empty() {
        return Err(RenderError::Empty {
            vertices: positions.len(),
            faces: faces.len(),
        });
    }
    let nv = positions.len();
    if values.len() != nv {
        return Err(RenderError::Invalid(RenderInput::ValueCount {
            values: values.len(),
            vertices: nv,
        }));
    }
    if let Some(v) = values.iter().position(|x| !x.is_finite()) {
        return Err(RenderError::Invalid(RenderInput::NonFiniteValue {
            vertex: v,
            value: values[v],
        }));
    }
    if let Some(v) = positions.iter().position(|p| p.iter().any(|c| !c.is_finite())) {
        return Err(RenderError::Invalid(RenderInput::NonFiniteVertex(v)));
    }
    if let Some(f) = faces.iter().position(|f| f.iter().any(|&i| i as usize >= nv)) {
        return Err(RenderError::Invalid(RenderInput::FaceIndex {
            face: f,
            vertices: nv,
        }));
    }
    for (name, m) in [("grey", &opts.grey), ("outline", &opts.outline)] {
        if let Some(m) = m {
            if m.len() != nv {
                return Err(RenderError::Invalid(RenderInput::FlagCount {
                    name,
                    flags: m.len(),
                    vertices: nv,
                }));
            }
        }
    }
    if opts.views.is_empty() || opts.view_size < 16 || opts.view_size > 4096 {
        return Err(RenderError::Invalid(RenderInput::Views {
            views: opts.views.len(),
            size: opts.view_size,
        }));
    }
    if let Some((lo, hi)) = opts.range {
        if !(lo.is_finite() && hi.is_finite() && lo < hi) {
            return Err(RenderError::Invalid(RenderInput::ColourRange { lo, hi }));
        }
    }
    Ok(())
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Area-weighted unit vertex normals (zero for isolated vertices).
fn vertex_normals(positions: &[[f64; 3]], faces: &[[u32; 3]]) -> Vec<[f64; 3]> {
    let mut n = vec![[0.0; 3]; positions.len()];
    for f in faces {
        let [a, b, c] = f.map(|i| positions[i as usize]);
        let fnrm = cross(sub(b, a), sub(c, a));
        for &i in f {
            for k in 0..3 {
                n[i as usize][k] += fnrm[k];
            }
        }
    }
    for v in &mut n {
        let l = dot(*v, *v).sqrt();
        if l > 0.0 {
            *v = v.map(|c| c / l);
        }
    }
    n
}

/// Per-sample attributes of one view: depth, value, shade, grey and outline weights.
struct Buffers {
    side: usize,
    depth: Vec<f64>,
    attr: Vec<[f64; 4]>,
}

/// Rasterizes one view at `side x side` samples.
#[allow(clippy::too_many_arguments)]
fn raster(
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    normals: &[[f64; 3]],
    vattr: &[[f64; 3]],
    centre: [f64; 3],
    radius: f64,
    view: View,
    side: usize,
) -> Buffers {
    let (toward, up) = view.axes();
    let right = cross(up, toward);
    let scale = 0.47 * side as f64 / radius;
    let half = side as f64 / 2.0;
    // Screen coordinates (x right, y down, depth towards the viewer).
    let screen: Vec<[f64; 3]> = positions
        .iter()
        .map(|&p| {
            let q = sub(p, centre);
            [
                half + scale * dot(q, right),
                half - scale * dot(q, up),
                dot(q, toward),
            ]
        })
        .collect();
    let shade: Vec<f64> = normals
        .iter()
        .map(|&n| 0.35 + 0.65 * dot(n, toward).abs())
        .collect();
    let mut depth = vec![f64::NEG_INFINITY; side * side];
    let mut attr = vec![[0.0; 4]; side * side];
    for f in faces {
        let [a, b, c] = f.map(|i| screen[i as usize]);
        let area = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0]);
        if area.abs() < 1e-12 {
            continue;
        }
        let x0 = a[0].min(b[0]).min(c[0]).floor().max(0.0) as usize;
        let x1 = (a[0].max(b[0]).max(c[0]).ceil() as usize).min(side);
        let y0 = a[1].min(b[1]).min(c[1]).floor().max(0.0) as usize;
        let y1 = (a[1].max(b[1]).max(c[1]).ceil() as usize).min(side);
        let [ia, ib, ic] = f.map(|i| i as usize);
        for y in y0..y1 {
            let py = y as f64 + 0.5;
            for x in x0..x1 {
                let px = x as f64 + 0.5;
                let w0 = ((b[0] - px) * (c[1] - py) - (b[1] - py) * (c[0] - px)) / area;
                let w1 = ((c[0] - px) * (a[1] - py) - (c[1] - py) * (a[0] - px)) / area;
                let w2 = 1.0 - w0 - w1;
                if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                    continue;
                }
                let d = w0 * a[2] + w1 * b[2] + w2 * c[2];
                let k = y * side + x;
                if d <= depth[k] {
                    continue;
                }
                depth[k] = d;
                let mix = |j: usize| w0 * vattr[ia][j] + w1 * vattr[ib][j] + w2 * vattr[ic][j];
                attr[k] = [
                    mix(0),
                    w0 * shade[ia] + w1 * shade[ib] + w2 * shade[ic],
                    mix(1),
                    mix(2),
                ];
            }
        }
    }
    Buffers { side, depth, attr }
}

/// Colours one view's samples and averages them into the output picture at `(ox, oy)`.
fn compose(buf: &Buffers, scale: &Scale, img: &mut Image, ox: u32, oy: u32, outline: bool) {
    let side = buf.side;
    let inside = |k: usize| buf.depth[k] > f64::NEG_INFINITY;
    let out_side = side / SS;
    for y in 0..out_side {
        for x in 0..out_side {
            let mut acc = [0.0; 3];
            for sy in 0..SS {
                for sx in 0..SS {
                    let (px, py) = (x * SS + sx, y * SS + sy);
                    let k = py * side + px;
                    let c = if !inside(k) {
                        BACKGROUND.map(|c| c as f64 / 255.0)
                    } else {
                        let [v, shade, g, o] = buf.attr[k];
                        // The outline: a sample on one side of the 0.5 level of the region
                        // weight with a neighbour on the other side (on the mesh).
                        let edge = outline
                            && o >= 0.5
                            && [
                                (1i64, 0i64),
                                (-1, 0),
                                (0, 1),
                                (0, -1),
                                (2, 0),
                                (-2, 0),
                                (0, 2),
                                (0, -2),
                                (3, 0),
                                (-3, 0),
                                (0, 3),
                                (0, -3),
                            ]
                            .iter()
                            .any(|&(dx, dy)| {
                                let (qx, qy) = (px as i64 + dx, py as i64 + dy);
                                if qx < 0 || qy < 0 || qx >= side as i64 || qy >= side as i64 {
                                    return false;
                                }
                                let q = qy as usize * side + qx as usize;
                                inside(q) && buf.attr[q][3] < 0.5
                            });
                        if edge {
                            OUTLINE.map(|c| c as f64 / 255.0)
                        } else {
                            let base = lerp3(
                                scale.color(scale.t(v)),
                                GREY.map(|c| c as f64 / 255.0),
                                g.clamp(0.0, 1.0),
                            );
                            base.map(|c| c * shade)
                        }
                    };
                    for j in 0..3 {
                        acc[j] += c[j];
                    }
                }
            }
            let i = 3 * ((oy as usize + y) * img.width as usize + ox as usize + x);
            for (out, a) in img.rgb[i..i + 3].iter_mut().zip(acc) {
                *out = (a / (SS * SS) as f64 * 255.0).round().clamp(0.0, 255.0) as u8;
            }
        }
    }
}

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        let _ = plotters::style::register_font(FAMILY, FontStyle::Normal, FONT);
    });
}

/// A colour bar's tick value: 3 significant digits in the one plain format of
/// [`qcshape::numfmt`] (`0` for zero of either sign).
fn tick(v: f64) -> String {
    qcshape::numfmt::significant(v, 3)
}

/// Draws the title, the view names and the colour bar.
fn annotate(img: &mut Image, lay: &Layout, scale: &Scale, opts: &RenderOptions) -> Result<(), RenderError> {
    register_font();
    let (w, h) = (img.width, img.height);
    let root = BitMapBackend::with_buffer(&mut img.rgb, (w, h)).into_drawing_area();
    let black = RGBColor(0, 0, 0);
    // Title and subtitle: the font shrinks (down to 9 px) until the line fits the width,
    // then the line is cut with an ellipsis.
    let fit = |text: &str, size: u32| -> (String, u32) {
        let room = w.saturating_sub(16);
        let width = |t: &str, s: u32| {
            root.estimate_text_size(t, &TextStyle::from((FAMILY, s).into_font()))
                .map_or(u32::MAX, |(tw, _)| tw)
        };
        let mut s = size;
        while s > 9 && width(text, s) > room {
            s -= 1;
        }
        let mut t: String = text.to_string();
        while width(&t, s) > room && t.chars().count() > 1 {
            t.pop();
            while t.ends_with('\u{2026}') {
                t.pop();
            }
            t.pop();
            t.push('\u{2026}');
        }
        (t, s)
    };
    let (title, size) = fit(&opts.title, 19);
    root.draw(&Text::new(
        title,
        (8, 8),
        (FAMILY, size).into_font().color(&black),
    ))
    .map_err(RenderError::Draw)?;
    let sub = format!(
        "colour: {} ({} map)",
        if opts.label.is_empty() {
            "value"
        } else {
            &opts.label
        },
        if scale.diverging {
            "diverging"
        } else {
            "sequential"
        },
    );
    let (sub, size) = fit(&sub, 13);
    root.draw(&Text::new(sub, (8, 32), (FAMILY, size).into_font().color(&black)))
        .map_err(RenderError::Draw)?;
    for (k, v) in opts.views.iter().enumerate() {
        let (x, y) = lay.view_origin(k);
        root.draw(&Text::new(
            v.name(),
            (x as i32 + 6, y as i32 + 4),
            (FAMILY, 12).into_font().color(&RGBColor(90, 90, 90)),
        ))
        .map_err(RenderError::Draw)?;
    }
    // The bar: a vertical gradient, high values at the top.
    let bx = (lay.columns * lay.view) as i32 + 14;
    let (top, bottom) = (lay.header as i32 + 20, h as i32 - 20);
    let bw = 18;
    for y in top..=bottom {
        let t = (bottom - y) as f64 / (bottom - top) as f64;
        let c = scale.color(t).map(|c| (c * 255.0).round() as u8);
        root.draw(&Rectangle::new(
            [(bx, y), (bx + bw, y + 1)],
            RGBColor(c[0], c[1], c[2]).filled(),
        ))
        .map_err(RenderError::Draw)?;
    }
    root.draw(&Rectangle::new([(bx, top), (bx + bw, bottom + 1)], black))
        .map_err(RenderError::Draw)?;
    let mut ticks = vec![scale.lo, scale.hi];
    if scale.diverging && scale.lo < 0.0 && scale.hi > 0.0 {
        ticks.push(0.0);
    } else {
        ticks.push(0.5 * (scale.lo + scale.hi));
    }
    for v in ticks {
        let y = bottom - (scale.t(v) * (bottom - top) as f64).round() as i32;
        root.draw(&PathElement::new(vec![(bx + bw, y), (bx + bw + 5, y)], black))
            .map_err(RenderError::Draw)?;
        root.draw(&Text::new(
            tick(v),
            (bx + bw + 7, y - 6),
            (FAMILY, 12).into_font().color(&black),
        ))
        .map_err(RenderError::Draw)?;
    }
    root.present().map_err(RenderError::Draw)?;
    Ok(())
}

/// Renders `values` (#V, any unit) on the mesh `positions` (#V x 3) / `faces` (#F x 3) from
/// the views of `opts` into an RGB picture (module docs). Errors: an empty mesh, mismatched
/// lengths, a non-finite value or coordinate, a face naming a missing vertex.
pub fn render(
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    values: &[f64],
    opts: &RenderOptions,
) -> Result<Image, RenderError> {
    check(positions, faces, values, opts)?;
    let lay = Layout::new(opts);
    let (w, h) = lay.size();
    let mut img = Image {
        width: w,
        height: h,
        rgb: BACKGROUND.repeat((w * h) as usize),
    };
    let scale = Scale::new(values, opts);
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in positions {
        for c in 0..3 {
            lo[c] = lo[c].min(p[c]);
            hi[c] = hi[c].max(p[c]);
        }
    }
    let centre: [f64; 3] = std::array::from_fn(|c| 0.5 * (lo[c] + hi[c]));
    let radius = positions
        .iter()
        .map(|&p| dot(sub(p, centre), sub(p, centre)).sqrt())
        .fold(0.0, f64::max)
        .max(1e-12);
    let normals = vertex_normals(positions, faces);
    let flag = |m: &Option<Vec<bool>>, v: usize| m.as_ref().map_or(0.0, |m| f64::from(u8::from(m[v])));
    let vattr: Vec<[f64; 3]> = (0..positions.len())
        .map(|v| [values[v], flag(&opts.grey, v), flag(&opts.outline, v)])
        .collect();
    for (k, &view) in opts.views.iter().enumerate() {
        let buf = raster(
            positions,
            faces,
            &normals,
            &vattr,
            centre,
            radius,
            view,
            lay.view as usize * SS,
        );
        let (ox, oy) = lay.view_origin(k);
        compose(&buf, &scale, &mut img, ox, oy, opts.outline.is_some());
    }
    annotate(&mut img, &lay, &scale, opts)?;
    Ok(img)
}

/// [`render`] written as a PNG to `path` (atomically).
pub fn render_png(
    path: &Path,
    positions: &[[f64; 3]],
    faces: &[[u32; 3]],
    values: &[f64],
    opts: &RenderOptions,
) -> Result<PathBuf, RenderError> {
    let img = render(positions, faces, values, opts)?;
    let bytes = img.png_bytes()?;
    write_atomically(path, |w| w.write_all(&bytes))?;
    Ok(path.to_path_buf())
}

#[cfg(test)]
mod tests {
    use super::*;
    use qcshape::synth::icosphere;

    fn sphere() -> (Vec<[f64; 3]>, Vec<[u32; 3]>, Vec<f64>) {
        let s = icosphere(3);
        let z: Vec<f64> = s.positions.iter().map(|p| p[2]).collect();
        (s.positions.clone(), s.topology.faces().to_vec(), z)
    }

    fn dist(a: [u8; 3], b: [f64; 3]) -> f64 {
        (0..3)
            .map(|c| (a[c] as f64 - 255.0 * b[c]).abs())
            .fold(0.0, f64::max)
    }

    #[test]
    fn a_sphere_coloured_by_height_shows_the_ends_of_the_map() {
        let (p, f, z) = sphere();
        let opts = RenderOptions {
            title: "sphere".into(),
            label: "z".into(),
            views: vec![View::Front, View::Back, View::Left, View::Top],
            view_size: 320,
            ..Default::default()
        };
        let img = render(&p, &f, &z, &opts).unwrap();
        if let Ok(dir) = std::env::var("QCSHAPE_RENDER_DEBUG") {
            std::fs::write(format!("{dir}/sphere.png"), img.png_bytes().unwrap()).unwrap();
        }
        let lay = layout(&opts);
        assert_eq!((img.width, img.height), (2 * 320 + 110, 56 + 2 * 320));
        // Front view (z up): near the top of the sphere red, near the bottom blue.
        let (ox, oy) = lay.view_origin(0);
        let c = 160;
        let top = img.pixel(ox + c, oy + c - 120);
        let bottom = img.pixel(ox + c, oy + c + 120);
        assert!(top[0] > 120 && top[0] > top[2] + 60, "top {top:?}");
        assert!(bottom[2] > 100 && bottom[2] > bottom[0] + 40, "bottom {bottom:?}");
        // The middle is near white (z = 0), shaded.
        let mid = img.pixel(ox + c, oy + c);
        assert!(mid.iter().all(|&v| v > 200), "mid {mid:?}");
        // Background in the view's corners.
        for (x, y) in [(2, 300), (317, 317), (317, 30)] {
            assert_eq!(img.pixel(ox + x, oy + y), BACKGROUND, "({x}, {y})");
        }
        // Whole upper half of the front view warm, lower half cool (mesh pixels only).
        let (mut warm_up, mut cool_down, mut n_up, mut n_down) = (0, 0, 0, 0);
        for y in 20..300 {
            for x in 20..300 {
                let q = img.pixel(ox + x, oy + y);
                if q == BACKGROUND || (y as i32 - 160).abs() < 20 {
                    continue;
                }
                if y < 160 {
                    n_up += 1;
                    warm_up += usize::from(q[0] >= q[2]);
                } else {
                    n_down += 1;
                    cool_down += usize::from(q[2] >= q[0]);
                }
            }
        }
        assert!(n_up > 10_000 && n_down > 10_000);
        assert_eq!(warm_up, n_up);
        assert_eq!(cool_down, n_down);
        // Top view (+z): the pole, red, at the centre.
        let (tx, ty) = lay.view_origin(3);
        let pole = img.pixel(tx + c, ty + c);
        assert!(dist(pole, diverging(1.0)) < 40.0, "pole {pole:?}");
    }

    #[test]
    fn sequential_map_for_positive_values_and_greying() {
        let (p, f, z) = sphere();
        let v: Vec<f64> = z.iter().map(|z| z + 1.0).collect();
        let opts = RenderOptions {
            views: vec![View::Front],
            view_size: 320,
            grey: Some(z.iter().map(|&z| z < 0.0).collect()),
            outline: Some(z.iter().map(|&z| z > 0.5).collect()),
            ..Default::default()
        };
        let img = render(&p, &f, &v, &opts).unwrap();
        assert_eq!((img.width, img.height), (320 + 110, 56 + 320));
        let (ox, oy) = layout(&opts).view_origin(0);
        // Top: viridis yellow-green (green > blue); bottom: grey (channels equal).
        let top = img.pixel(ox + 160, oy + 60);
        assert!(top[1] > top[2] && top[1] > 100, "{top:?}");
        let bottom = img.pixel(ox + 160, oy + 280);
        assert!(bottom[0] == bottom[1] && bottom[1] == bottom[2], "{bottom:?}");
        // The outline of z > 0.5 crosses the vertical centre line near z = 0.5.
        let dark = (30..160)
            .filter(|&y| img.pixel(ox + 160, oy + y).iter().all(|&c| c < 90))
            .count();
        assert!(dark >= 1, "no outline pixel");
        if let Ok(dir) = std::env::var("QCSHAPE_RENDER_DEBUG") {
            std::fs::write(format!("{dir}/sequential.png"), img.png_bytes().unwrap()).unwrap();
        }
    }

    #[test]
    fn same_bytes_twice() {
        let (p, f, z) = sphere();
        let dir = tempfile::tempdir().unwrap();
        let opts = RenderOptions {
            title: "twice".into(),
            ..Default::default()
        };
        let a = render_png(&dir.path().join("a.png"), &p, &f, &z, &opts).unwrap();
        let b = render_png(&dir.path().join("b.png"), &p, &f, &z, &opts).unwrap();
        let (a, b) = (std::fs::read(a).unwrap(), std::fs::read(b).unwrap());
        // The default: six views in two rows of three.
        let lay = layout(&opts);
        assert_eq!((lay.columns, lay.rows, lay.view), (3, 2, 280));
        assert_eq!(a, b);
        assert_eq!(&a[1..4], b"PNG");
    }

    #[test]
    fn errors_are_typed() {
        let (p, f, z) = sphere();
        let opts = RenderOptions::default();
        let dir = tempfile::tempdir().unwrap();
        let bad = dir.path().join("no/such/folder/x.png");
        assert!(matches!(
            render_png(&bad, &p, &f, &z, &opts),
            Err(RenderError::Write(_))
        ));
        assert!(matches!(
            render(&[], &[], &[], &opts),
            Err(RenderError::Empty { vertices: 0, .. })
        ));
        assert!(matches!(
            render(&p, &[], &z, &opts),
            Err(RenderError::Empty { faces: 0, .. })
        ));
        let mut nan = z.clone();
        nan[5] = f64::NAN;
        let e = render(&p, &f, &nan, &opts).unwrap_err();
        assert!(matches!(e, RenderError::Invalid(_)));
        assert!(e.to_string().contains("vertex 5"), "{e}");
        assert!(matches!(
            render(&p, &f, &z[1..], &opts),
            Err(RenderError::Invalid(_))
        ));
    }
}
