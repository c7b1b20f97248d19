//! The bad-input table: every case is a set of files and a command line that must fail with
//! exit status 1, a message naming the file (or option) and the problem, and no output left
//! behind. Cases are data: a name, files, arguments (`{d}` is the case's folder) and the
//! substrings the message must hold.

use std::path::Path;
use std::process::Command;

use qcshape::synth::{genus0_benchmark, write_benchmark, SynthOptions};

/// One row of the table.
struct Case {
    name: String,
    /// Files to write in the case's folder before the run (relative path, bytes).
    files: Vec<(String, Vec<u8>)>,
    /// Whether to write the small synthetic data set (`S/manifest.csv`) first.
    dataset: bool,
    /// Edits of the data set's manifest: (old text, new text), applied in order.
    manifest_edits: Vec<(String, String)>,
    /// Command line; `{d}` is replaced by the case's folder.
    args: Vec<String>,
    /// Substrings the error message must contain (file or option, and the problem).
    expect: Vec<String>,
    /// Paths (relative to the folder) that must not exist after the run.
    no_output: Vec<String>,
    /// The exit status: 1 (an error of the command), or 2 for an option value that the
    /// argument parser refuses (a usage error).
    status: i32,
}

fn case(name: &str, args: &str, expect: &[&str]) -> Case {
    Case {
        name: name.into(),
        files: Vec::new(),
        dataset: false,
        manifest_edits: Vec::new(),
        args: args.split_whitespace().map(String::from).collect(),
        expect: expect.iter().map(|s| s.to_string()).collect(),
        no_output: Vec::new(),
        status: 1,
    }
}

impl Case {
    fn file(mut self, path: &str, bytes: impl Into<Vec<u8>>) -> Self {
        self.files.push((path.into(), bytes.into()));
        self
    }
    fn dataset(mut self) -> Self {
        self.dataset = true;
        self
    }
    fn edit(mut self, old: &str, new: &str) -> Self {
        self.manifest_edits.push((old.into(), new.into()));
        self
    }
    fn usage_error(mut self) -> Self {
        self.status = 2;
        self
    }
    fn no_output(mut self, path: &str) -> Self {
        self.no_output.push(path.into());
        self
    }
}

// ---- valid meshes, as text in every format ----

/// A closed octahedron: 6 vertices, 8 faces (counter-clockwise seen from outside).
fn octahedron() -> (Vec<[f64; 3]>, Vec<Vec<u32>>) {
    let p = vec![
        [1.0, 0.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, -1.0, 0.0],
        [0.0, 0.0, 1.0],
        [0.0, 0.0, -1.0],
    ];
    let f = [
        [0, 2, 4],
        [2, 1, 4],
        [1, 3, 4],
        [3, 0, 4],
        [2, 0, 5],
        [1, 2, 5],
        [3, 1, 5],
        [0, 3, 5],
    ];
    (p, f.iter().map(|t| t.to_vec()).collect())
}

fn obj(p: &[[f64; 3]], f: &[Vec<u32>]) -> String {
    let mut s = String::new();
    for v in p {
        s += &format!("v {:e} {:e} {:e}\n", v[0], v[1], v[2]);
    }
    for t in f {
        let idx: Vec<String> = t.iter().map(|i| (i + 1).to_string()).collect();
        s += &format!("f {}\n", idx.join(" "));
    }
    s
}

fn ply(p: &[[f64; 3]], f: &[Vec<u32>]) -> String {
    let mut s = format!(
        "ply\nformat ascii 1.0\nelement vertex {}\nproperty double x\nproperty double y\nproperty double z\n\
         element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        p.len(),
        f.len()
    );
    for v in p {
        s += &format!("{:e} {:e} {:e}\n", v[0], v[1], v[2]);
    }
    for t in f {
        let idx: Vec<String> = t.iter().map(|i| i.to_string()).collect();
        s += &format!("{} {}\n", t.len(), idx.join(" "));
    }
    s
}

fn off(p: &[[f64; 3]], f: &[Vec<u32>]) -> String {
    let mut s = format!("OFF\n{} {} 0\n", p.len(), f.len());
    for v in p {
        s += &format!("{:e} {:e} {:e}\n", v[0], v[1], v[2]);
    }
    for t in f {
        let idx: Vec<String> = t.iter().map(|i| i.to_string()).collect();
        s += &format!("{} {}\n", t.len(), idx.join(" "));
    }
    s
}

fn vtk(p: &[[f64; 3]], f: &[Vec<u32>]) -> String {
    let size: usize = f.iter().map(|t| t.len() + 1).sum();
    let mut s = format!(
        "# vtk DataFile Version 3.0\nmesh\nASCII\nDATASET POLYDATA\nPOINTS {} double\n",
        p.len()
    );
    for v in p {
        s += &format!("{:e} {:e} {:e}\n", v[0], v[1], v[2]);
    }
    s += &format!("POLYGONS {} {size}\n", f.len());
    for t in f {
        let idx: Vec<String> = t.iter().map(|i| i.to_string()).collect();
        s += &format!("{} {}\n", t.len(), idx.join(" "));
    }
    s
}

fn stl(p: &[[f64; 3]], f: &[Vec<u32>]) -> String {
    let mut s = String::from("solid mesh\n");
    for t in f {
        s += "facet normal 0 0 0\nouter loop\n";
        for &i in t {
            let v = p[i as usize];
            s += &format!("vertex {:e} {:e} {:e}\n", v[0], v[1], v[2]);
        }
        s += "endloop\nendfacet\n";
    }
    s + "endsolid mesh\n"
}

type Writer = fn(&[[f64; 3]], &[Vec<u32>]) -> String;

const FORMATS: [(&str, Writer); 5] = [
    ("obj", obj),
    ("ply", ply),
    ("off", off),
    ("vtk", vtk),
    ("stl", stl),
];

/// A mesh case run through `geodesic BAD GOOD --out {d}/path` (and so through the loader every
/// command uses): the message must name the bad file.
fn mesh_case(name: &str, file: &str, bytes: impl Into<Vec<u8>>, expect: &[&str]) -> Case {
    let (p, f) = octahedron();
    let mut e = vec![file];
    e.extend_from_slice(expect);
    case(
        name,
        &format!("geodesic {{d}}/{file} {{d}}/good.obj --steps 2 --out {{d}}/path"),
        &e,
    )
    .file(file, bytes)
    .file("good.obj", obj(&p, &f))
    .no_output("path")
}

/// The same bad file through `qcshape info`.
fn info_case(name: &str, file: &str, bytes: impl Into<Vec<u8>>, expect: &[&str]) -> Case {
    let mut e = vec![file];
    e.extend_from_slice(expect);
    case(name, &format!("info {{d}}/{file}"), &e).file(file, bytes)
}

/// A topology defect: name, positions, faces, expected words.
type Variant = (&'static str, Vec<[f64; 3]>, Vec<Vec<u32>>, Vec<&'static str>);

fn topology_cases() -> Vec<Case> {
    let (p, f) = octahedron();
    let mut out = Vec::new();
    // (name, positions, faces, expected words)
    let mut variants: Vec<Variant> = Vec::new();
    let mut dup = f.clone();
    dup.push(vec![2, 4, 0]);
    variants.push((
        "duplicated face",
        p.clone(),
        dup,
        vec!["faces 0 and 8", "duplicated face"],
    ));
    let mut p7 = p.clone();
    p7.push([0.5, 0.5, 0.5]);
    let mut e3 = f.clone();
    e3.push(vec![0, 2, 6]);
    variants.push((
        "edge with three faces",
        p7.clone(),
        e3.clone(),
        vec!["is non-manifold", "shared by 3 faces"],
    ));
    let mut p8 = p7.clone();
    p8.push([0.5, 0.5, -0.5]);
    let mut e4 = e3.clone();
    e4.push(vec![2, 0, 7]);
    variants.push((
        "edge with four faces",
        p8,
        e4,
        vec!["is non-manifold", "shared by 4 faces"],
    ));
    let mut two = f.clone();
    let mut p12 = p.clone();
    p12.extend(p.iter().skip(1).map(|v| [v[0] + 3.0, v[1], v[2]]));
    // Second octahedron on vertices 6..10 plus the shared vertex 0 (its own vertex 0 at x = 1
    // would be at x = 3; it is glued to vertex 0 instead, a bowtie).
    two.extend(
        f.iter()
            .map(|t| t.iter().map(|&i| if i == 0 { 0 } else { i + 5 }).collect()),
    );
    variants.push((
        "two closed surfaces sharing a vertex",
        p12,
        two,
        vec!["vertex 0 is non-manifold", "2 separate fans"],
    ));
    let bow_p = vec![
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [-1.0, 0.0, 0.0],
        [0.0, -1.0, 0.0],
    ];
    variants.push((
        "bowtie of two triangles",
        bow_p,
        vec![vec![0, 1, 2], vec![0, 3, 4]],
        vec!["vertex 0 is non-manifold"],
    ));
    let mut flip = f.clone();
    flip[1] = vec![1, 2, 4];
    variants.push(("flipped face", p.clone(), flip, vec!["inconsistently oriented"]));
    let mut flat = p.clone();
    flat[4] = [0.5, 0.5, 0.0];
    flat[2] = [0.0, 1.0, 0.0];
    flat[0] = [1.0, 0.0, 0.0];
    // Face 0 (0, 2, 4) with vertex 4 on the segment from 0 to 2: zero area.
    variants.push(("zero-area face", flat, f.clone(), vec!["face 0", "degenerate"]));
    let huge: Vec<[f64; 3]> = p.iter().map(|v| v.map(|c| c * 1e150)).collect();
    variants.push(("coordinates of 1e150", huge, f.clone(), vec!["1e150", "overflow"]));
    variants.push((
        "repeated vertex in a face",
        p.clone(),
        {
            let mut g = f.clone();
            g[0] = vec![0, 0, 4];
            g
        },
        vec!["face 0", "repeats a vertex"],
    ));
    for (ext, write) in FORMATS {
        for (name, pos, faces, words) in &variants {
            let file = format!("bad.{ext}");
            out.push(mesh_case(
                &format!("{ext}: {name}"),
                &file,
                write(pos, faces),
                words,
            ));
        }
    }
    // The same through `info` for one format.
    for (name, pos, faces, words) in &variants {
        // `info` reports zero-area faces in its own words.
        let words: Vec<&str> = words
            .iter()
            .map(|w| if *w == "degenerate" { "zero area" } else { w })
            .collect();
        out.push(info_case(
            &format!("info obj: {name}"),
            "bad.obj",
            obj(pos, faces),
            &words,
        ));
    }
    out
}

fn parser_cases() -> Vec<Case> {
    let (p, f) = octahedron();
    let good_obj = obj(&p, &f);
    let good_ply = ply(&p, &f);
    let good_off = off(&p, &f);
    let good_stl = stl(&p, &f);
    let good_vtk = vtk(&p, &f);
    // pyvista's octahedron (inline base64, zlib), from the library's interop fixtures.
    let good_vtp = std::fs::read_to_string(
        std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../qcshape/tests/fixtures/octa_pyvista_binary.vtp"),
    )
    .unwrap();
    let mut c = vec![
        // Files that cannot be read.
        case("missing file", "geodesic {d}/nope.obj {d}/nope2.obj --out {d}/path", &["nope.obj", "cannot read"])
            .no_output("path"),
        case("unknown extension", "info {d}/mesh.xyz", &["mesh.xyz", "unknown mesh format"]).file("mesh.xyz", good_obj.clone()),
        case("a folder as a mesh", "info {d}/dir.obj", &["dir.obj", "cannot read", "a folder"]).file("dir.obj/x", "x"),
        case("a missing folder as a mesh", "info {d}/nope/", &["nope", "cannot read", "No such file"]),
        // OBJ.
        info_case("obj: empty", "e.obj", "", &["empty"]),
        info_case("obj: whitespace only", "e.obj", "  \n\n \t\n", &["empty"]),
        info_case("obj: vertex without z", "e.obj", "v 0 0\n", &["line 1", "no z coordinate"]),
        info_case("obj: bad number", "e.obj", "v 0 x 0\n", &["line 1", "y coordinate", "\"x\""]),
        info_case("obj: nan", "e.obj", good_obj.replacen("v 1e0", "v nan", 1), &["line 1", "non-finite"]),
        info_case("obj: inf", "e.obj", good_obj.replacen("v 1e0", "v inf", 1), &["line 1", "non-finite"]),
        info_case("obj: 1e400", "e.obj", good_obj.replacen("v 1e0", "v 1e400", 1), &["line 1", "non-finite"]),
        info_case("obj: index 0", "e.obj", good_obj.replacen("f 1 3 5", "f 0 3 5", 1), &["line 7", "start at 1"]),
        info_case("obj: index too large", "e.obj", good_obj.replacen("f 1 3 5", "f 9 3 5", 1), &["line 7", "vertex 9", "only 6"]),
        info_case("obj: negative index out of range", "e.obj", good_obj.replacen("f 1 3 5", "f -9 3 5", 1), &["vertex -9", "only 6"]),
        info_case("obj: two corners", "e.obj", good_obj.replacen("f 1 3 5", "f 1 3", 1), &["face 0", "at least 3", "line 7"]),
        info_case("obj: bad index token", "e.obj", good_obj.replacen("f 1 3 5", "f 1 a 5", 1), &["line 7", "vertex index", "\"a\""]),
        info_case("obj: no faces", "e.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\n", &["no faces"]),
        info_case("obj: PLY content", "e.obj", good_ply.clone(), &["not an OBJ file", "\"ply\""]),
        info_case("obj: vv typo", "e.obj", good_obj.replacen("v 0e0 0e0 1e0", "vv 0 0 1", 1), &["vertex 6", "only 5", "line 11", "keyword OBJ does not know", "\"vv 0 0 1\""]),
        info_case("obj: bowtie quad", "e.obj", "v 0 0 0\nv 1 1 0\nv 1 0 0\nv 0 1 0\nf 1 2 3 4\n", &["face 0", "cannot be triangulated", "line 5"]),
        info_case("obj: collinear polygon", "e.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nv 3 0 0\nf 1 2 3 4\n", &["face 0", "cannot be triangulated"]),
        info_case("obj: binary garbage", "e.obj", vec![0u8, 159, 146, 150, 7, 255, 10, 1, 2], &["not an OBJ file"]),
        info_case("obj: 1e308 coordinates", "e.obj", obj(&p.iter().map(|v| v.map(|x| x * 1e308)).collect::<Vec<_>>(), &f), &["1e308", "overflow"]),
        // PLY.
        info_case("ply: no magic", "e.ply", good_ply.replacen("ply\n", "plx\n", 1), &["line 1"]),
        info_case("ply: unknown format", "e.ply", good_ply.replacen("ascii", "binary_middle_endian", 1), &["line 2", "binary_middle_endian"]),
        info_case("ply: bad count", "e.ply", good_ply.replacen("vertex 6", "vertex six", 1), &["line 3", "\"six\""]),
        info_case("ply: no end_header", "e.ply", good_ply.replacen("end_header\n", "", 1), &["end_header"]),
        info_case("ply: fewer vertices than declared", "e.ply", good_ply.replacen("vertex 6", "vertex 7", 1), &["vertex 6", "7", "line"]),
        info_case("ply: more vertices than declared", "e.ply", good_ply.replacen("vertex 6", "vertex 5", 1), &["face 0", "line 15", "more vertex elements than the 5 the header declares"]),
        info_case("ply: fewer faces declared than held", "e.ply", good_ply.replacen("face 8", "face 7", 1), &["more data than its header declares", "7 face", "line 23"]),
        info_case("ply: more faces declared than held", "e.ply", good_ply.replacen("face 8", "face 9", 1), &["face"]),
        info_case("ply: wrong list count", "e.ply", good_ply.replacen("\n3 0 2 4\n", "\n4 0 2 4\n", 1), &["face 0", "8 the header declares", "line 16"]),
        info_case("ply: list count short", "e.ply", good_ply.replacen("\n3 0 2 4\n", "\n2 0 2 4\n", 1), &["face 0", "at least 3"]),
        info_case("ply: index out of range", "e.ply", good_ply.replacen("\n3 0 2 4\n", "\n3 0 2 9\n", 1), &["face 0", "vertex 9"]),
        info_case("ply: negative index", "e.ply", good_ply.replacen("\n3 0 2 4\n", "\n3 0 2 -1\n", 1), &["face 0", "vertex -1"]),
        info_case("ply: fractional index", "e.ply", good_ply.replacen("\n3 0 2 4\n", "\n3 0 2 1.5\n", 1), &["face 0"]),
        info_case("ply: nan", "e.ply", good_ply.replacen("1e0 0e0 0e0", "nan 0e0 0e0", 1), &["vertex 0", "non-finite"]),
        info_case("ply: extra value on a vertex line", "e.ply", good_ply.replacen("1e0 0e0 0e0", "1e0 0e0 0e0 7", 1), &["vertex 0", "4 values", "line 10"]),
        info_case("ply: no vertex element", "e.ply", "ply\nformat ascii 1.0\nelement face 0\nproperty list uchar int vertex_indices\nend_header\n", &["vertex"]),
        info_case("ply: binary truncated", "e.ply", {
            let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 6\nproperty float x\nproperty float y\nproperty float z\nelement face 8\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
            b.extend_from_slice(&[0u8; 30]);
            b
        }, &["truncated", "6 vertex"]),
        info_case("ply: binary trailing bytes", "e.ply", {
            let mut b = b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n".to_vec();
            for v in [[0f32, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]] {
                for c in v {
                    b.extend_from_slice(&c.to_le_bytes());
                }
            }
            b.push(3);
            for i in [0i32, 1, 2] {
                b.extend_from_slice(&i.to_le_bytes());
            }
            b.extend_from_slice(&[1, 2, 3, 4]);
            b
        }, &["more data than its header declares"]),
        info_case("ply: huge declared count", "e.ply", "ply\nformat binary_little_endian 1.0\nelement vertex 4000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n", &["truncated", "4000000000"]),
        // OFF.
        info_case("off: no keyword", "e.off", good_off.replacen("OFF\n", "HELLO\n", 1), &["line 1", "OFF keyword"]),
        info_case("off: bad counts", "e.off", good_off.replacen("6 8 0", "6 x 0", 1), &["line 2"]),
        info_case("off: fewer vertices than declared", "e.off", good_off.replacen("6 8 0", "9 8 0", 1), &["8 faces, found 5"]),
        info_case("off: more faces than declared", "e.off", good_off.replacen("6 8 0", "6 7 0", 1), &["line 16", "more elements than declared", "7 faces"]),
        info_case("off: fewer faces than declared", "e.off", good_off.replacen("6 8 0", "6 9 0", 1), &["9 faces, found 8"]),
        info_case("off: face count short", "e.off", good_off.replacen("\n3 0 2 4\n", "\n2 0 2\n", 1), &["face 0", "at least 3"]),
        info_case("off: face lists fewer", "e.off", good_off.replacen("\n3 0 2 4\n", "\n4 0 2 4\n", 1), &["face 0", "declares 4", "only 3"]),
        info_case("off: index out of range", "e.off", good_off.replacen("\n3 0 2 4\n", "\n3 0 2 6\n", 1), &["face 0", "vertex 6"]),
        info_case("off: nan", "e.off", good_off.replacen("1e0 0e0 0e0", "nan 0e0 0e0", 1), &["vertex 0", "non-finite"]),
        // STL.
        info_case("stl: no endsolid", "e.stl", good_stl.replacen("endsolid mesh\n", "", 1), &["endsolid", "cut short"]),
        info_case("stl: cut in a facet", "e.stl", good_stl[..good_stl.len() / 2].to_string(), &["ends early"]),
        info_case("stl: bad coordinate", "e.stl", good_stl.replacen("vertex 1e0", "vertex 1x0", 1), &["coordinate", "\"1x0\""]),
        info_case("stl: nan", "e.stl", good_stl.replacen("vertex 1e0", "vertex nan", 1), &["non-finite"]),
        info_case("stl: binary truncated", "e.stl", {
            let mut b = vec![0u8; 80];
            b.extend_from_slice(&10u32.to_le_bytes());
            b.extend_from_slice(&[0u8; 120]);
            b
        }, &["truncated", "10 triangles"]),
        info_case("stl: binary nan", "e.stl", {
            let mut b = vec![0u8; 80];
            b.extend_from_slice(&1u32.to_le_bytes());
            b.extend_from_slice(&[0u8; 12]);
            b.extend_from_slice(&f32::NAN.to_le_bytes());
            b.extend_from_slice(&[0u8; 34]);
            b
        }, &["triangle 0", "non-finite"]),
        info_case("stl: too short", "e.stl", vec![1u8, 2, 3], &["truncated"]),
        info_case("stl: loose triangle set (open, repeated corner)", "e.stl", "solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 0 0 0\nvertex 1 0 0\nendloop\nendfacet\nendsolid x\n", &["repeats a vertex"]),
        // VTK.
        info_case("vtk: no POINTS", "e.vtk", "# vtk DataFile Version 3.0\nm\nASCII\nDATASET POLYDATA\n", &["POINTS"]),
        info_case("vtk: fewer points than declared", "e.vtk", good_vtk.replacen("POINTS 6", "POINTS 7", 1), &["POINTS"]),
        info_case("vtk: unstructured grid", "e.vtk", good_vtk.replacen("POLYDATA", "STRUCTURED_GRID", 1), &["STRUCTURED_GRID"]),
        info_case("vtk: index out of range", "e.vtk", good_vtk.replacen("\n3 0 2 4\n", "\n3 0 2 8\n", 1), &["vertex 8"]),
        info_case("vtk: nan", "e.vtk", good_vtk.replacen("1e0 0e0 0e0", "nan 0e0 0e0", 1), &["non-finite"]),
        info_case("vtk: truncated", "e.vtk", good_vtk[..good_vtk.len() - 12].to_string(), &["vtk"]),
        // VTP.
        info_case("vtp: bad base64", "e.vtp", good_vtp.replacen("eF5jYACBD", "eF5*YACBD", 1), &["bad base64", "byte offset"]),
        info_case("vtp: more points than data", "e.vtp", good_vtp.replacen("NumberOfPoints=\"6\"", "NumberOfPoints=\"7\"", 1), &["Points", "declares"]),
        info_case("vtp: cut in half", "e.vtp", good_vtp[..good_vtp.len() / 2].to_string(), &["vtp"]),
        info_case("vtp: not PolyData", "e.vtp", good_vtp.replacen("type=\"PolyData\"", "type=\"ImageData\"", 1), &["ImageData", "only PolyData"]),
    ];
    // Cut files: every format at half its length.
    for (ext, text) in [("ply", &good_ply), ("off", &good_off), ("obj", &good_obj)] {
        let cut = &text[..text.len() * 2 / 3];
        c.push(mesh_case(
            &format!("{ext}: cut at two thirds"),
            &format!("cut.{ext}"),
            cut.to_string(),
            &[],
        ));
    }
    c
}

fn dataset_cases() -> Vec<Case> {
    let sim = "similarity {d}/S/manifest.csv --steps 2 -o {d}/D.csv";
    let mut c = vec![
        case("manifest missing", "similarity {d}/nope.csv -o {d}/D.csv", &["nope.csv", "cannot read"]).no_output("D.csv"),
        case("manifest without pose column", sim, &["manifest.csv", "missing column \"pose\""]).dataset().edit("deformation,label,pose,path", "deformation,label,frame,path"),
        case("pose not a number", sim, &["manifest.csv", "line 2", "\"zero\""]).dataset().edit(",0,sphere-twist/pose000.ply", ",zero,sphere-twist/pose000.ply"),
        case("negative pose", sim, &["manifest.csv", "line 2", "negative pose index -1"]).dataset().edit(",0,sphere-twist/pose000.ply", ",-1,sphere-twist/pose000.ply"),
        case("pose gap", sim, &["manifest.csv", "sphere-twist", "no pose 2"]).dataset().edit(",2,sphere-twist/pose002.ply", ",5,sphere-twist/pose002.ply"),
        case("pose starting at 1", sim, &["manifest.csv", "sphere-twist", "no pose 0"]).dataset().edit(",0,sphere-twist/pose000.ply", ",3,sphere-twist/pose000.ply"),
        case("duplicate pose", sim, &["manifest.csv", "pose 1 twice"]).dataset().edit(",2,sphere-twist/pose002.ply", ",1,sphere-twist/pose002.ply"),
        case("missing pose file", sim, &["manifest.csv", "line 3", "does not exist"]).dataset().edit("sphere-twist/pose001.ply", "sphere-twist/none.ply"),
        case("classify: one deformation without a label", "classify {d}/S/manifest.csv --k 2 --steps 2", &["manifest.csv", "needs a label for every deformation", "\"sphere-twist\""]).dataset()
            .edit("sphere-twist,twist,", "sphere-twist,,").edit("sphere-twist,twist,", "sphere-twist,,").edit("sphere-twist,twist,", "sphere-twist,,"),
        case("run: one deformation without a label", "run {d}/S/manifest.csv --steps 2 --out {d}/R", &["manifest.csv", "needs a label for every deformation", "\"sphere-twist\""]).dataset()
            .edit("sphere-twist,twist,", "sphere-twist,,").edit("sphere-twist,twist,", "sphere-twist,,").edit("sphere-twist,twist,", "sphere-twist,,").no_output("R"),
        case("label differs within a deformation", sim, &["manifest.csv", "line 3", "label"]).dataset().edit("sphere-twist,twist,1", "sphere-twist,bulge,1"),
        // Issue 60: messages that said what failed but not why.
        case("manifest separated by semicolons", sim, &["manifest.csv", "missing column \"deformation\"", "the manifest's separator is a comma, not ';'"]).dataset().edit("deformation,label,pose,path", "deformation;label;pose;path").no_output("D.csv"),
        case("a mesh file given as the data set", "similarity {d}/S/sphere-twist/pose000.ply --steps 2 -o {d}/D.csv", &["pose000.ply", "is a mesh file, not a data set"]).dataset().no_output("D.csv"),
        case("deformations with different pose counts", sim, &["manifest.csv", "\"sphere-twist\"", "poses but", "same number of key poses"]).dataset().edit("sphere-twist,twist,2,sphere-twist/pose002.ply\n", "").no_output("D.csv"),
        case("pose with another vertex count", sim, &["odd.ply", "vertices", "manifest", "line 3"]).dataset().edit("sphere-twist/pose001.ply", "odd.ply").file("S/odd.ply", {
            let (p, f) = octahedron();
            ply(&p, &f)
        }),
        case("only one deformation", sim, &["manifest.csv", "at least two deformations"]).dataset().file(
            "S/manifest.csv",
            "deformation,label,pose,path\nsphere-twist,twist,0,sphere-twist/pose000.ply\nsphere-twist,twist,1,sphere-twist/pose001.ply\nsphere-twist,twist,2,sphere-twist/pose002.ply\n",
        ),
        case("a broken pose file", sim, &["pose001.ply"]).dataset().file("S/sphere-twist/pose001.ply", "ply\nformat ascii 1.0\nend_header\n"),
        case("header only", sim, &["manifest.csv"]).file("S/manifest.csv", "deformation,label,pose,path\n"),
        case("-o is the manifest", "similarity {d}/S/manifest.csv --steps 2 -o {d}/S/manifest.csv", &["-o", "overwrite the input", "manifest.csv"]).dataset(),
        case("-o is a pose file", "similarity {d}/S/manifest.csv --steps 2 -o {d}/S/sphere-twist/pose000.ply", &["-o", "overwrite the input", "pose000.ply"]).dataset(),
        case("-o names a pose file by another path", "similarity {d}/S/manifest.csv --steps 2 -o {d}/S/../S/sphere-twist/pose001.ply", &["-o", "overwrite the input"]).dataset(),
        case("--details is a pose file", "similarity {d}/S/manifest.csv --steps 2 -o {d}/D.csv --details {d}/S/sphere-twist/pose002.ply", &["--details", "overwrite the input"]).dataset().no_output("D.csv"),
        case("--details is -o", "similarity {d}/S/manifest.csv --steps 2 -o {d}/D.csv --details {d}/D.csv", &["--details", "same file as -o"]).dataset().no_output("D.csv"),
        case("unknown --base", "similarity {d}/S/manifest.csv --steps 2 -o {d}/D.csv --base nope", &["--base \"nope\""]).dataset().no_output("D.csv"),
        case("resume from a garbage journal", "similarity {d}/S/manifest.csv --steps 2 -o {d}/D.csv --resume", &["D.csv.journal", "not a qcshape similarity journal"]).dataset().file("D.csv.journal", "hello\nworld\n").no_output("D.csv"),
        case("resume from another run's journal", "similarity {d}/S/manifest.csv --steps 2 -o {d}/D.csv --resume", &["D.csv.journal", "another run", "different settings", "steps=2"]).dataset().file("D.csv.journal", "# qcshape similarity journal v2\nkey,0000000000000001\nn,2\nsettings,QuasiConformal|steps=3\n").no_output("D.csv"),
        case("resume with another deformation count", "similarity {d}/S/manifest.csv --steps 2 -o {d}/D.csv --resume", &["D.csv.journal", "another run", "n = 5"]).dataset().file("D.csv.journal", "# qcshape similarity journal v2\nkey,0000000000000001\nn,5\nsettings,x\n").no_output("D.csv"),
    ];
    for (opt, value, words) in [
        // Bounded options are refused by the argument parser (status 2), naming the bound.
        ("--lambda", "inf", vec!["--lambda must be at most"]),
        ("--lambda", "-1", vec!["--lambda must be >= 0"]),
        ("--lambda", "nan", vec!["--lambda"]),
        ("--tolerance", "inf", vec!["--tolerance must be at most"]),
        ("--tolerance", "-1e-3", vec!["--tolerance must be >= 0"]),
        ("--energy-tolerance", "nan", vec!["--energy-tolerance"]),
        (
            "--length-tolerance",
            "-1e-8",
            vec!["--length-tolerance must be >= 0"],
        ),
        ("--steps", "0", vec!["--steps", "at least 1"]),
        ("--threads", "0", vec!["--threads", "at least 1"]),
        ("--levels", "0", vec!["--levels", "at least 1"]),
    ] {
        let w: Vec<&str> = words.to_vec();
        c.push(
            case(
                &format!("similarity {opt} {value}"),
                &format!("similarity {{d}}/S/manifest.csv -o {{d}}/D.csv {opt}={value}"),
                &w,
            )
            .dataset()
            .usage_error()
            .no_output("D.csv"),
        );
        c.push(
            case(
                &format!("geodesic {opt} {value}"),
                &format!("geodesic --demo --demo-level 0 {opt}={value} --out {{d}}/path"),
                &w,
            )
            .usage_error()
            .no_output("path"),
        );
    }
    // geodesic has no --levels.
    c.retain(|k| k.name != "geodesic --levels 0");
    c.push(
        case(
            "geodesic: meshes of two connectivities",
            "geodesic {d}/a.obj {d}/b.obj --out {d}/path",
            &["a.obj and", "b.obj", "cannot be compared"],
        )
        .file("a.obj", {
            let (p, f) = octahedron();
            obj(&p, &f)
        })
        .file(
            "b.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 3 2\nf 1 2 4\nf 2 3 4\nf 3 1 4\n",
        )
        .no_output("path"),
    );
    c
}

fn run(c: &Case, data: &Path) {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    if c.dataset {
        copy_dir(data, &d.join("S"));
        let m = d.join("S/manifest.csv");
        let mut text = std::fs::read_to_string(&m).unwrap();
        for (old, new) in &c.manifest_edits {
            assert!(
                text.contains(old.as_str()),
                "{}: {old:?} not in the manifest",
                c.name
            );
            text = text.replacen(old.as_str(), new, 1);
        }
        std::fs::write(&m, text).unwrap();
    }
    for (path, bytes) in &c.files {
        let p = d.join(path);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(&p, bytes).unwrap();
    }
    let before: Vec<(std::path::PathBuf, Vec<u8>)> = walk(d)
        .into_iter()
        .map(|p| {
            let b = std::fs::read(&p).unwrap();
            (p, b)
        })
        .collect();
    let args: Vec<String> = c
        .args
        .iter()
        .map(|a| a.replace("{d}", d.to_str().unwrap()))
        .collect();
    let r = Command::new(env!("CARGO_BIN_EXE_qcshape"))
        .args(&args)
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&r.stderr);
    assert_eq!(
        r.status.code(),
        Some(c.status),
        "{}: exit status {:?}\n{stderr}",
        c.name,
        r.status
    );
    assert!(!stderr.contains("panicked"), "{}: {stderr}", c.name);
    let err = stderr
        .lines()
        .filter(|l| l.starts_with("error"))
        .collect::<Vec<_>>()
        .join("\n");
    for e in &c.expect {
        assert!(
            err.contains(e.as_str()),
            "{}: the message lacks {e:?}:\n{stderr}",
            c.name
        );
    }
    for o in &c.no_output {
        assert!(!d.join(o).exists(), "{}: {o} was left", c.name);
    }
    // No input was changed and no new file (or temporary) was left anywhere.
    let after = walk(d);
    for (p, b) in &before {
        assert_eq!(
            std::fs::read(p).ok().as_ref(),
            Some(b),
            "{}: {} changed",
            c.name,
            p.display()
        );
    }
    for p in &after {
        assert!(
            before.iter().any(|(q, _)| q == p) || (p.extension().is_some_and(|e| e == "journal")),
            "{}: {} was left",
            c.name,
            p.display()
        );
    }
}

fn walk(d: &Path) -> Vec<std::path::PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![d.to_path_buf()];
    while let Some(p) = stack.pop() {
        for e in std::fs::read_dir(&p).unwrap() {
            let e = e.unwrap().path();
            if e.is_dir() {
                stack.push(e);
            } else {
                out.push(e);
            }
        }
    }
    out.sort();
    out
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let p = e.unwrap().path();
        let t = to.join(p.file_name().unwrap());
        if p.is_dir() {
            copy_dir(&p, &t);
        } else {
            std::fs::copy(&p, &t).unwrap();
        }
    }
}

#[test]
fn every_bad_input_is_refused_clearly() {
    let data = tempfile::tempdir().unwrap();
    let defs = genus0_benchmark(&SynthOptions {
        level: 0,
        ..Default::default()
    })
    .unwrap();
    // Two deformations of three poses: sphere-twist and ellipsoid-twist.
    write_benchmark(data.path(), &defs[..2], qcshape::io::Format::Ply).unwrap();
    let mut cases = topology_cases();
    cases.extend(parser_cases());
    cases.extend(dataset_cases());
    assert!(cases.len() >= 120, "{} cases", cases.len());
    let mut names = std::collections::HashSet::new();
    let mut failed = Vec::new();
    for c in &cases {
        assert!(names.insert(c.name.clone()), "two cases named {}", c.name);
        if std::panic::catch_unwind(|| run(c, data.path())).is_err() {
            failed.push(c.name.clone());
        }
    }
    assert!(
        failed.is_empty(),
        "{} of {} cases failed: {failed:?}",
        failed.len(),
        cases.len()
    );
    println!("{} bad-input cases refused", cases.len());
}
