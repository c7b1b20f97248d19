//! What is wrong with a line or token of a text mesh file or text header
//! ([`ParseError::Syntax`](super::ParseError::Syntax)), with the offending values. Tokens are
//! kept as read, at most 40 characters (longer ones end in `...`), and shown quoted.

use thiserror::Error;

/// Why a line or token of a text file (or text header) cannot be read
/// ([`ParseError::Syntax`](super::ParseError::Syntax) gives its line).
#[derive(Debug, Error, Clone, PartialEq)]
pub enum SyntaxError {
    /// A vertex line with fewer than three coordinates (OBJ, OFF).
    #[error("vertex {vertex} has no {axis} coordinate")]
    NoCoordinate {
        /// Vertex number.
        vertex: usize,
        /// `"x"`, `"y"` or `"z"`.
        axis: &'static str,
    },
    /// A vertex coordinate that is not a number (OBJ, OFF).
    #[error("cannot read the {axis} coordinate of vertex {vertex} from {found:?}")]
    Coordinate {
        /// Vertex number.
        vertex: usize,
        /// `"x"`, `"y"` or `"z"`.
        axis: &'static str,
        /// The token.
        found: String,
    },
    /// A triangle corner's coordinate that is not a number (ASCII STL).
    #[error("cannot read the {axis} coordinate of corner {corner} of triangle {triangle} from {found:?}")]
    CornerCoordinate {
        /// Triangle number.
        triangle: usize,
        /// Corner number within the triangle's loop.
        corner: usize,
        /// `"x"`, `"y"` or `"z"`.
        axis: &'static str,
        /// The token.
        found: String,
    },
    /// A face's vertex index that is not an integer (OBJ, OFF).
    #[error("cannot read a vertex index of face {face} from {found:?}")]
    VertexIndex {
        /// Face number.
        face: usize,
        /// The token.
        found: String,
    },
    /// A face's vertex count that is not a count (OFF).
    #[error("cannot read the vertex count of face {face} from {found:?}")]
    FaceSize {
        /// Face number.
        face: usize,
        /// The token.
        found: String,
    },
    /// A header without one of its counts (OFF).
    #[error("the header has no {what} count")]
    NoCount {
        /// Which count (`"vertex"`, `"face"`, ...).
        what: &'static str,
    },
    /// A header count that is not a count (OFF, PLY).
    #[error("cannot read the {what} count from {found:?}")]
    Count {
        /// Which count (`"vertex"`, `"element"`, ...).
        what: &'static str,
        /// The token.
        found: String,
    },
    /// A value that is not a number (PLY, legacy VTK).
    #[error("cannot read {what} from {found:?}")]
    Value {
        /// Which value, e.g. `property x of vertex 3`.
        what: String,
        /// The token.
        found: String,
    },
    /// Value `index` of an array that is not a number (legacy VTK).
    #[error("cannot read value {index} of {what} from {found:?}")]
    ArrayValue {
        /// Value number in the array.
        index: u64,
        /// Which array.
        what: String,
        /// The token.
        found: String,
    },
    /// A token of an ASCII data array that is not a number (VTK XML).
    #[error("cannot read a number of {what} from {found:?}")]
    Number {
        /// Which array.
        what: String,
        /// The token.
        found: String,
    },
    /// The first line is not `ply`.
    #[error("not a PLY file: the first line must be \"ply\"")]
    NotPly,
    /// The first line is not a legacy VTK version line.
    #[error("not a legacy VTK file: the first line must be \"# vtk DataFile Version ...\"")]
    NotVtk,
    /// No face line, and lines with keywords OBJ does not know (another format read as OBJ).
    #[error(
        "not an OBJ file: no face (`f`) lines, and {unknown} line(s) with a keyword OBJ does not know; the first is {first:?}"
    )]
    NotObj {
        /// Lines with an unknown keyword.
        unknown: usize,
        /// The first of them.
        first: String,
    },
    /// A keyword other than the one the format requires here.
    #[error("expected {expected}, found {found:?}")]
    Expected {
        /// What the format requires, e.g. `the OFF keyword`.
        expected: &'static str,
        /// The token.
        found: String,
    },
    /// A name the reader does not know for a setting of the file (a PLY format or property
    /// type, a VTK XML encoding, header type, data type or format).
    #[error("unknown {what} {found:?}")]
    Unknown {
        /// Which setting, e.g. `PLY format`.
        what: &'static str,
        /// The name found.
        found: String,
    },
    /// A legacy VTK section keyword the reader does not know.
    #[error("unexpected VTK keyword {found:?}")]
    Keyword {
        /// The keyword.
        found: String,
    },
    /// A data type the reader does not know (legacy VTK).
    #[error("unknown data type {found:?} for {what}")]
    DataType {
        /// The array it types.
        what: String,
        /// The type found.
        found: String,
    },
    /// A PLY `element` line without a name or a count.
    #[error("an element line needs a name and a count")]
    ElementLine,
    /// A PLY `property` line before any `element` line.
    #[error("a property line comes before any element line")]
    PropertyBeforeElement,
    /// A PLY list whose count type is not an integer type.
    #[error("a list count must have an integer type")]
    ListCountType,
    /// A PLY `property` line without a name.
    #[error("a property line needs a name")]
    PropertyName,
    /// An ASCII PLY element whose values run onto the next line.
    #[error(
        "{element} {item} (of the {count} the header declares) has fewer values than its properties need: it continues on line {next_line}; the file may hold fewer {element} elements than declared, or a wrong list count"
    )]
    ElementContinues {
        /// The element's name.
        element: String,
        /// Its number.
        item: usize,
        /// Elements the header declares.
        count: u64,
        /// The line its values continue on.
        next_line: usize,
    },
    /// An ASCII PLY element line with more values than its properties take.
    #[error(
        "{element} {item} (of the {count} the header declares) has {values} values, but its properties take {needed}; the file may hold fewer {element} elements than declared, or a wrong list count"
    )]
    ElementValues {
        /// The element's name.
        element: String,
        /// Its number.
        item: usize,
        /// Elements the header declares.
        count: u64,
        /// Values on its line.
        values: usize,
        /// Values its properties take.
        needed: usize,
    },
    /// An ASCII PLY face whose vertex count is below 3 and disagrees with its line.
    #[error(
        "face {item} (of the {count} the header declares) starts with a vertex count of {size} (a face needs at least 3), but its line holds {values} values{}, or a wrong list count",
        more_than_declared(.previous)
    )]
    FaceValues {
        /// Face number.
        item: usize,
        /// Faces the header declares.
        count: u64,
        /// The vertex count it starts with.
        size: u64,
        /// Values on its line.
        values: u64,
        /// The last element before the faces that has any, and its declared count: the file
        /// may hold more of them.
        previous: Option<(String, u64)>,
    },
    /// More vertices than 32-bit indices address (OFF).
    #[error("declares {count} vertices, more than 32-bit indices can address")]
    TooManyVertices {
        /// Declared vertices.
        count: u64,
    },
    /// A face line with fewer indices than its count (OFF).
    #[error("face {face} declares {declared} vertices but lists only {listed}")]
    ShortFace {
        /// Face number.
        face: usize,
        /// Its vertex count.
        declared: u64,
        /// Indices on its line.
        listed: u64,
    },
    /// Data after the elements the header declares (OFF).
    #[error(
        "data after the {vertices} vertices and {faces} faces the header declares: the file holds more elements than declared"
    )]
    ExtraData {
        /// Declared vertices.
        vertices: usize,
        /// Declared faces.
        faces: usize,
    },
    /// An OBJ face index 0 (OBJ indices start at 1).
    #[error("face {face} uses vertex index 0, but OBJ indices start at 1")]
    IndexZero {
        /// Face number.
        face: usize,
    },
    /// An OBJ face index past the vertices, in a file where lines with unknown keywords were
    /// skipped (perhaps a mistyped `v` line).
    #[error(
        "face {face} refers to vertex {index}, but there are only {n_vertices} vertices; {unknown} line(s) with a keyword OBJ does not know were skipped, the first is line {unknown_line}: {first:?} (a mistyped `v` line?)"
    )]
    SkippedVertex {
        /// Face number.
        face: usize,
        /// The index as written.
        index: i64,
        /// Number of vertices.
        n_vertices: usize,
        /// Lines with an unknown keyword.
        unknown: usize,
        /// The first of them.
        unknown_line: usize,
        /// Its text.
        first: String,
    },
    /// A legacy VTK section given twice.
    #[error("a second {section} section")]
    Repeated {
        /// `"POINTS"` or `"CELLS"`.
        section: &'static str,
    },
    /// More points than 32-bit indices address (legacy VTK).
    #[error("{count} points are more than 32-bit indices can address")]
    TooManyPoints {
        /// Declared points.
        count: u64,
    },
    /// A legacy VTK cell section before the points.
    #[error("{keyword} comes before POINTS")]
    BeforePoints {
        /// The section's keyword.
        keyword: String,
    },
    /// A legacy VTK `POINT_DATA` count other than the points'.
    #[error("POINT_DATA {count} for {points} points")]
    PointData {
        /// The `POINT_DATA` count.
        count: u64,
        /// Points of the file.
        points: usize,
    },
    /// An array whose value count overflows (legacy VTK).
    #[error("{what}: {count} x {components} values are too many")]
    TooManyValues {
        /// Which array.
        what: String,
        /// Tuples.
        count: u64,
        /// Components per tuple.
        components: u64,
    },
    /// A legacy VTK `SCALARS` array with other than 1 to 4 components.
    #[error("SCALARS {name} has {components} components (1 to 4 allowed)")]
    ScalarComponents {
        /// The array's name.
        name: String,
        /// Its components.
        components: u64,
    },
    /// A legacy VTK `TEXTURE_COORDINATES` array of a dimension the reader does not take.
    #[error("TEXTURE_COORDINATES {name} of dimension {dimension}")]
    TextureDimension {
        /// The array's name.
        name: String,
        /// Its dimension.
        dimension: u64,
    },
    /// A legacy VTK `COLOR_SCALARS` array with a component count the reader does not take.
    #[error("COLOR_SCALARS {name} has {components} components")]
    ColorComponents {
        /// The array's name.
        name: String,
        /// Its components.
        components: u64,
    },
    /// A legacy VTK `FIELD` array with a component count the reader does not take.
    #[error("FIELD array {name} has {components} components")]
    FieldComponents {
        /// The array's name.
        name: String,
        /// Its components.
        components: u64,
    },
    /// A legacy VTK `FIELD` array with other than one tuple per point.
    #[error("FIELD array {name} has {tuples} tuples for {points} points")]
    FieldTuples {
        /// The array's name.
        name: String,
        /// Its tuples.
        tuples: u64,
        /// Points of the file.
        points: u64,
    },
    /// A VTK XML `Points` array with other than 3 components.
    #[error("Points have {components} components, not 3")]
    PointComponents {
        /// Its components.
        components: usize,
    },
    /// A VTK XML cell section whose last offset is not a count.
    #[error("the last {what} offset {last} is not a count")]
    LastOffset {
        /// The section.
        what: String,
        /// The offset.
        last: f64,
    },
    /// A VTK XML cell offset outside the connectivity array or below the one before.
    #[error("{what} offset {index} ({offset}) is not a count between the one before and the {len} connectivity values")]
    Offset {
        /// The section.
        what: String,
        /// Offset number.
        index: usize,
        /// Its value.
        offset: f64,
        /// Length of the connectivity array.
        len: usize,
    },
    /// A VTK XML attribute that should be a count.
    #[error("{key}={value:?} is not a count")]
    NotACount {
        /// The attribute.
        key: String,
        /// Its value.
        value: String,
    },
    /// A VTK XML `DataArray` attribute with a value the reader cannot use.
    #[error("{key}={value:?}")]
    Attribute {
        /// The attribute (`NumberOfComponents`, `offset`).
        key: &'static str,
        /// Its value.
        value: String,
    },
    /// VTK XML `AppendedData` without its `_` marker.
    #[error("AppendedData has no '_' marker")]
    NoMarker,
    /// An appended VTK XML `DataArray` without an `offset`.
    #[error("an appended DataArray has no offset")]
    NoOffset,
    /// A VTK XML ASCII data array with another number of values than declared.
    #[error("{what} has {found} values, expected {expected}")]
    ValueCount {
        /// Which array.
        what: String,
        /// Values read.
        found: usize,
        /// Values declared.
        expected: u64,
    },
    /// An XML comment, tag or attribute value that is not closed.
    #[error("{what} is not closed")]
    Unclosed {
        /// `"a comment"`, `"a tag"` or `"an attribute value"`.
        what: &'static str,
    },
    /// An XML tag without a name.
    #[error("a tag without a name")]
    NoName,
    /// An XML attribute without a value.
    #[error("attribute {attribute} has no value")]
    NoValue {
        /// The attribute.
        attribute: String,
    },
    /// An XML attribute value without quotes.
    #[error("attribute {attribute} is not quoted")]
    Unquoted {
        /// The attribute.
        attribute: String,
    },
}

/// The hint of [`SyntaxError::FaceValues`]: the element before the faces may hold more than the
/// header declares.
fn more_than_declared(previous: &Option<(String, u64)>) -> String {
    match previous {
        Some((name, count)) => {
            format!("; the file may hold more {name} elements than the {count} the header declares")
        }
        None => String::new(),
    }
}
