//! The binary number types of PLY, legacy VTK and VTK XML (`.vtp`, `.vtu`): one type for the
//! three readers, with each format's names for it, its size in bytes and the reading of one
//! value from bytes in either byte order.

/// A number type as the mesh formats store it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Number {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    I64,
    U64,
    F32,
    F64,
}

/// A file format's way of naming the number types.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Names {
    /// PLY: `char` .. `double` and `int8` .. `float64` (no 64-bit integers).
    Ply,
    /// Legacy VTK: `char` .. `double`, `unsigned_*` and `vtktype*`, matched without case.
    Vtk,
    /// VTK XML: `Int8` .. `Float64` (and `Char`, `UChar`).
    VtkXml,
}

/// A type with its names in PLY, legacy VTK (lower case) and VTK XML.
type Row = (
    Number,
    &'static [&'static str],
    &'static [&'static str],
    &'static [&'static str],
);

#[rustfmt::skip]
const NAMES: [Row; 10] = [
    (Number::I8,  &["char", "int8"],       &["char", "vtktypeint8"],                &["Int8", "Char"]),
    (Number::U8,  &["uchar", "uint8"],     &["unsigned_char", "vtktypeuint8"],      &["UInt8", "UChar"]),
    (Number::I16, &["short", "int16"],     &["short", "vtktypeint16"],              &["Int16"]),
    (Number::U16, &["ushort", "uint16"],   &["unsigned_short", "vtktypeuint16"],    &["UInt16"]),
    (Number::I32, &["int", "int32"],       &["int", "vtktypeint32"],                &["Int32"]),
    (Number::U32, &["uint", "uint32"],     &["unsigned_int", "vtktypeuint32"],      &["UInt32"]),
    (Number::I64, &[],                     &["long", "vtktypeint64", "vtkidtype"],  &["Int64"]),
    (Number::U64, &[],                     &["unsigned_long", "vtktypeuint64"],     &["UInt64"]),
    (Number::F32, &["float", "float32"],   &["float", "vtktypefloat32"],            &["Float32"]),
    (Number::F64, &["double", "float64"],  &["double", "vtktypefloat64"],           &["Float64"]),
];

impl Number {
    /// The type a format names `name`, if any.
    pub(super) fn parse(names: Names, name: &[u8]) -> Option<Number> {
        let lower;
        let name = if names == Names::Vtk {
            lower = name.to_ascii_lowercase();
            &lower[..]
        } else {
            name
        };
        NAMES.iter().find_map(|(ty, ply, vtk, xml)| {
            let list = match names {
                Names::Ply => ply,
                Names::Vtk => vtk,
                Names::VtkXml => xml,
            };
            list.iter().any(|n| n.as_bytes() == name).then_some(*ty)
        })
    }

    /// Bytes one value takes.
    pub(super) fn size(self) -> usize {
        match self {
            Number::I8 | Number::U8 => 1,
            Number::I16 | Number::U16 => 2,
            Number::I32 | Number::U32 | Number::F32 => 4,
            Number::I64 | Number::U64 | Number::F64 => 8,
        }
    }

    /// Whether it is a floating-point type.
    pub(super) fn is_float(self) -> bool {
        matches!(self, Number::F32 | Number::F64)
    }

    /// The value stored in `b` (exactly [`Number::size`] bytes), big or little endian. Every
    /// type up to 32 bits is exact in `f64`; 64-bit integers beyond 2^53 lose precision, which
    /// only matters for indices that are out of range anyway.
    pub(super) fn read(self, b: &[u8], big: bool) -> f64 {
        macro_rules! num {
            ($t:ty, $n:expr) => {{
                let mut a = [0u8; $n];
                a.copy_from_slice(b);
                (if big {
                    <$t>::from_be_bytes(a)
                } else {
                    <$t>::from_le_bytes(a)
                }) as f64
            }};
        }
        match self {
            Number::I8 => b[0] as i8 as f64,
            Number::U8 => b[0] as f64,
            Number::I16 => num!(i16, 2),
            Number::U16 => num!(u16, 2),
            Number::I32 => num!(i32, 4),
            Number::U32 => num!(u32, 4),
            Number::I64 => num!(i64, 8),
            Number::U64 => num!(u64, 8),
            Number::F32 => num!(f32, 4),
            Number::F64 => num!(f64, 8),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_format_names_its_types() {
        assert_eq!(Number::parse(Names::Ply, b"uchar"), Some(Number::U8));
        assert_eq!(Number::parse(Names::Ply, b"float64"), Some(Number::F64));
        assert_eq!(Number::parse(Names::Ply, b"Float64"), None);
        assert_eq!(
            Number::parse(Names::Ply, b"long"),
            None,
            "PLY has no 64-bit integers"
        );
        assert_eq!(Number::parse(Names::Vtk, b"vtkIdType"), Some(Number::I64));
        assert_eq!(Number::parse(Names::Vtk, b"UNSIGNED_SHORT"), Some(Number::U16));
        assert_eq!(Number::parse(Names::VtkXml, b"UInt64"), Some(Number::U64));
        assert_eq!(
            Number::parse(Names::VtkXml, b"float"),
            None,
            "VTK XML names are exact"
        );
        for (ty, ply, vtk, xml) in NAMES {
            for (names, list) in [(Names::Ply, ply), (Names::Vtk, vtk), (Names::VtkXml, xml)] {
                for n in list {
                    assert_eq!(Number::parse(names, n.as_bytes()), Some(ty), "{names:?} {n}");
                }
            }
        }
    }

    #[test]
    fn a_value_reads_in_either_byte_order() {
        assert_eq!(Number::I16.read(&(-2i16).to_be_bytes(), true), -2.0);
        assert_eq!(Number::I16.read(&(-2i16).to_le_bytes(), false), -2.0);
        assert_eq!(Number::U32.read(&[0, 0, 1, 0], true), 256.0);
        assert_eq!(Number::U32.read(&[0, 0, 1, 0], false), 65536.0);
        assert_eq!(Number::F32.read(&1.5f32.to_le_bytes(), false), 1.5);
        assert_eq!(Number::F64.read(&(-0.25f64).to_be_bytes(), true), -0.25);
        assert_eq!(Number::I8.read(&[0xff], true), -1.0);
        assert_eq!(Number::U8.read(&[0xff], false), 255.0);
        assert_eq!(Number::U64.read(&u64::MAX.to_le_bytes(), false), u64::MAX as f64);
        for (ty, ..) in NAMES {
            assert_eq!(ty.read(&vec![0; ty.size()], true), 0.0);
        }
    }
}
