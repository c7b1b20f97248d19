//! `--format`: the mesh format of the poses a command writes, one value enum for every
//! mesh-writing command (`interpolate`, `transfer`, `geodesic`, `synth`, `lv mesh`).

use qcshape::io::Format;

/// A mesh format the library writes ([`qcshape::io`]): the value of `--format`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum MeshFormat {
    /// Stanford PLY, binary little endian (MeshLab; per-vertex fields, `quality`).
    Ply,
    /// Wavefront OBJ (text; positions and faces only).
    Obj,
    /// Object File Format (text; positions and faces only).
    Off,
    /// Legacy VTK POLYDATA (ParaView; per-vertex fields).
    Vtk,
    /// VTK XML PolyData (ParaView, pyvista; per-vertex fields).
    Vtp,
    /// VTK XML UnstructuredGrid of triangles (pyvista's and meshio's default; per-vertex fields).
    Vtu,
}

impl MeshFormat {
    /// The file name extension (without the dot).
    pub fn extension(self) -> &'static str {
        match self {
            MeshFormat::Ply => "ply",
            MeshFormat::Obj => "obj",
            MeshFormat::Off => "off",
            MeshFormat::Vtk => "vtk",
            MeshFormat::Vtp => "vtp",
            MeshFormat::Vtu => "vtu",
        }
    }

    /// The library's format.
    pub fn format(self) -> Format {
        Format::from_extension(self.extension()).expect("every MeshFormat is a library format")
    }

    /// Whether the format holds per-vertex fields (OBJ and OFF do not).
    pub fn has_fields(self) -> bool {
        !matches!(self, MeshFormat::Obj | MeshFormat::Off)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::ValueEnum;

    #[test]
    fn every_value_names_its_extension_and_a_library_format() {
        for f in MeshFormat::value_variants() {
            let name = f.to_possible_value().unwrap().get_name().to_string();
            assert_eq!(name, f.extension());
            assert_eq!(Format::from_extension(&name), Some(f.format()));
        }
    }
}
