//! The files of one per-vertex map with p-values (`qcshape localize`, the LV report): a CSV,
//! meshes with named point data and a picture, all on the common base mesh.

use std::fmt::Write as _;
use std::path::Path;

use thiserror::Error;

use crate::render::{render_png, RenderError, RenderOptions};
use qcshape::io::{write_atomically, write_mesh_fields, Field, IoError};

/// Why a map's files cannot be written.
#[derive(Debug, Error)]
pub enum MapFileError {
    /// The CSV or a mesh file.
    #[error(transparent)]
    Write(#[from] IoError),
    /// The picture.
    #[error(transparent)]
    Render(#[from] RenderError),
}

/// A per-vertex map with its tests (#V each).
#[derive(Debug, Clone, Copy)]
pub struct VertexMap<'a> {
    /// Name of the value column and point-data array (`score`, `difference`).
    pub name: &'a str,
    /// The map (#V).
    pub values: &'a [f64],
    /// Its p-values (#V).
    pub p_value: &'a [f64],
    /// Its significance decisions (#V).
    pub significant: &'a [bool],
}

impl VertexMap<'_> {
    /// Significant vertices.
    pub fn n_significant(&self) -> usize {
        self.significant.iter().filter(|&&s| s).count()
    }
}

/// Writes `DIR/STEM.csv` (`vertex,NAME,p_value,significant`), `DIR/STEM.EXT` for every
/// extension in `meshes` (point data NAME, p_value, significant as 0/1, then `extra`) and
/// `DIR/STEM.png` (the map rendered with `picture`; when some vertex is significant, the
/// others are grey) on the base mesh `base` (#V x 3) / `faces` (#F x 3).
#[allow(clippy::too_many_arguments)]
pub fn write_map(
    dir: &Path,
    stem: &str,
    base: &[[f64; 3]],
    faces: &[[u32; 3]],
    map: &VertexMap,
    extra: &[Field],
    meshes: &[&str],
    picture: RenderOptions,
) -> Result<(), MapFileError> {
    let mut csv = format!("vertex,{},p_value,significant\n", map.name);
    for (v, ((x, p), s)) in map
        .values
        .iter()
        .zip(map.p_value)
        .zip(map.significant)
        .enumerate()
    {
        // Writing to a String cannot fail.
        let _ = writeln!(csv, "{v},{x:.12e},{p:.6},{s}");
    }
    write_atomically(&dir.join(format!("{stem}.csv")), |w| w.write_all(csv.as_bytes()))?;
    let sig: Vec<f64> = map.significant.iter().map(|&s| f64::from(u8::from(s))).collect();
    let mut fields = vec![
        Field::scalar(map.name, map.values),
        Field::scalar("p_value", map.p_value),
        Field::scalar("significant", &sig),
    ];
    fields.extend_from_slice(extra);
    for ext in meshes {
        write_mesh_fields(&dir.join(format!("{stem}.{ext}")), base, faces, &fields)?;
    }
    let picture = RenderOptions {
        grey: (map.n_significant() > 0).then(|| map.significant.iter().map(|&s| !s).collect()),
        ..picture
    };
    render_png(
        &dir.join(format!("{stem}.png")),
        base,
        faces,
        map.values,
        &picture,
    )?;
    Ok(())
}
