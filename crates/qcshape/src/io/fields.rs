//! Named per-vertex fields: what the writers emit ([`Field`]) and what the VTK readers return
//! ([`PointArray`]).

/// The values of one per-vertex field.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FieldValues<'a> {
    /// One number per vertex (#V).
    Scalar(&'a [f64]),
    /// One 3-vector per vertex (#V x 3), e.g. a displacement in the mesh's length unit.
    Vector(&'a [[f64; 3]]),
}

/// A named per-vertex field to write (see [`super::write_mesh_fields`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Field<'a> {
    /// The array name (PLY property and VTK array names replace characters they cannot hold
    /// by `_`).
    pub name: &'a str,
    /// The values.
    pub values: FieldValues<'a>,
}

impl<'a> Field<'a> {
    /// A scalar field (#V values).
    pub fn scalar(name: &'a str, values: &'a [f64]) -> Self {
        Field {
            name,
            values: FieldValues::Scalar(values),
        }
    }

    /// A vector field (#V x 3 values).
    pub fn vector(name: &'a str, values: &'a [[f64; 3]]) -> Self {
        Field {
            name,
            values: FieldValues::Vector(values),
        }
    }

    /// Number of vertices the field covers.
    pub fn len(&self) -> usize {
        match self.values {
            FieldValues::Scalar(v) => v.len(),
            FieldValues::Vector(v) => v.len(),
        }
    }

    /// Whether the field has no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// 1 for scalars, 3 for vectors.
    pub fn components(&self) -> usize {
        match self.values {
            FieldValues::Scalar(_) => 1,
            FieldValues::Vector(_) => 3,
        }
    }

    /// Component `c` of vertex `v`.
    pub(crate) fn get(&self, v: usize, c: usize) -> f64 {
        match self.values {
            FieldValues::Scalar(s) => s[v],
            FieldValues::Vector(x) => x[v][c],
        }
    }

    pub(crate) fn kind(&self) -> &'static str {
        match self.values {
            FieldValues::Scalar(_) => "scalar",
            FieldValues::Vector(_) => "vector",
        }
    }
}

/// A named per-vertex array read from a file: `values` holds #V x `components` numbers,
/// vertex-major (`values[v * components + c]`).
#[derive(Debug, Clone, PartialEq)]
pub struct PointArray {
    /// The array name as written in the file.
    pub name: String,
    /// Components per vertex (1 for scalars, 3 for vectors).
    pub components: usize,
    /// The values (#V x components), converted to `f64`.
    pub values: Vec<f64>,
}

impl PointArray {
    /// The values of a 3-component array as #V x 3 vectors; `None` for other component counts.
    pub fn as_vectors(&self) -> Option<Vec<[f64; 3]>> {
        (self.components == 3).then(|| self.values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect())
    }
}
