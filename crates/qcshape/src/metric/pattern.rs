//! The Jacobian sparsity of a metric's residuals ([`Pattern`], built once per topology) and its
//! values in pattern order ([`Jacobian`]).

/// Jacobian sparsity of a metric's residuals: residual `i` depends on the vertices
/// `vertices[offsets[i]..offsets[i+1]]` (unique within a residual). Built once per topology.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Pattern {
    /// Row offsets (#residuals + 1).
    pub offsets: Vec<u32>,
    /// Vertex indices of each residual's entries.
    pub vertices: Vec<u32>,
}

impl Pattern {
    /// Number of residuals.
    pub fn n_residuals(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }
    /// Number of (residual, vertex) entries.
    pub fn n_entries(&self) -> usize {
        self.vertices.len()
    }
    /// Entry range of residual `i`.
    pub fn row(&self, i: usize) -> std::ops::Range<usize> {
        self.offsets[i] as usize..self.offsets[i + 1] as usize
    }
    /// Borrowed view of the pattern.
    pub fn as_ref(&self) -> PatternRef<'_> {
        PatternRef {
            offsets: &self.offsets,
            vertices: &self.vertices,
        }
    }
    /// Builds a pattern from rows of vertex lists.
    pub fn from_rows<I: IntoIterator<Item = R>, R: AsRef<[u32]>>(rows: I) -> Self {
        let mut p = Pattern {
            offsets: vec![0],
            vertices: Vec::new(),
        };
        for r in rows {
            p.vertices.extend_from_slice(r.as_ref());
            p.offsets.push(p.vertices.len() as u32);
        }
        p
    }
    /// Concatenates `other` after `self` (residuals of `other` follow).
    pub fn append(&mut self, other: &Pattern) {
        let base = self.vertices.len() as u32;
        self.vertices.extend_from_slice(&other.vertices);
        self.offsets.extend(other.offsets[1..].iter().map(|o| o + base));
    }
}

/// Borrowed view of a [`Pattern`] (or of a prefix of one: the first residuals).
#[derive(Debug, Clone, Copy)]
pub struct PatternRef<'a> {
    /// Row offsets (#residuals + 1).
    pub offsets: &'a [u32],
    /// Vertex indices of the entries.
    pub vertices: &'a [u32],
}

impl PatternRef<'_> {
    /// Number of residuals.
    pub fn n_residuals(&self) -> usize {
        self.offsets.len().saturating_sub(1)
    }
    /// Entry range of residual `i`.
    pub fn row(&self, i: usize) -> std::ops::Range<usize> {
        self.offsets[i] as usize..self.offsets[i + 1] as usize
    }
}

/// Mutable view of Jacobian values (see [`Jacobian`]).
#[derive(Debug)]
pub struct JacobianMut<'a> {
    /// `dr/da_v` per entry.
    pub da: &'a mut [[f64; 3]],
    /// `dr/db_v` per entry.
    pub db: &'a mut [[f64; 3]],
    /// `dr/daux`, #residuals x n_aux, row-major.
    pub daux: &'a mut [f64],
}

/// Jacobian values in [`Pattern`] order: entry `k` (vertex `pattern.vertices[k]` of its
/// residual) holds `dr/da_v` and `dr/db_v` (3 each); `daux` holds `dr/daux` row-major
/// (#residuals x [`Metric::n_aux`](super::Metric::n_aux)).
#[derive(Debug, Clone, Default)]
pub struct Jacobian {
    /// Derivatives with respect to the first pose's vertex, per entry.
    pub da: Vec<[f64; 3]>,
    /// Derivatives with respect to the second pose's vertex, per entry.
    pub db: Vec<[f64; 3]>,
    /// Derivatives with respect to the auxiliary unknowns.
    pub daux: Vec<f64>,
}

impl Jacobian {
    /// Zeroed storage for `pattern` with `n_aux` auxiliary unknowns.
    pub fn zeros(pattern: &Pattern, n_aux: usize) -> Self {
        Jacobian {
            da: vec![[0.0; 3]; pattern.n_entries()],
            db: vec![[0.0; 3]; pattern.n_entries()],
            daux: vec![0.0; pattern.n_residuals() * n_aux],
        }
    }
    /// Mutable view.
    pub fn as_mut(&mut self) -> JacobianMut<'_> {
        JacobianMut {
            da: &mut self.da,
            db: &mut self.db,
            daux: &mut self.daux,
        }
    }
    /// Sets every value to zero (keeps the storage).
    pub fn clear(&mut self) {
        self.da.fill([0.0; 3]);
        self.db.fill([0.0; 3]);
        self.daux.fill(0.0);
    }
}
