//! PLY (Stanford polygon files) for mesh obstacles: `format ascii`, `binary_little_endian`
//! or `binary_big_endian`; the `vertex` element's `x y z` and the `face` element's
//! `vertex_indices` (or `vertex_index`) list; every other element and property is read
//! past. Problems are located by line in the header and an ASCII body, by element number
//! in a binary body. Coordinates as they are: metres, Y-up (Blender's PLY exporter writes
//! Y-up by default).

use glam::Vec3;

use super::mesh_file::{FileError, MeshData, at, whole};
use crate::geometry::mesh::MAX_TRIANGLES;

#[derive(Clone, Copy, Debug, PartialEq)]
enum Ty {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Ty {
    fn parse(name: &str) -> Option<Ty> {
        Some(match name {
            "char" | "int8" => Ty::I8,
            "uchar" | "uint8" => Ty::U8,
            "short" | "int16" => Ty::I16,
            "ushort" | "uint16" => Ty::U16,
            "int" | "int32" => Ty::I32,
            "uint" | "uint32" => Ty::U32,
            "float" | "float32" => Ty::F32,
            "double" | "float64" => Ty::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Ty::I8 | Ty::U8 => 1,
            Ty::I16 | Ty::U16 => 2,
            Ty::I32 | Ty::U32 | Ty::F32 => 4,
            Ty::F64 => 8,
        }
    }
}

#[derive(Debug)]
enum Prop {
    Scalar(Ty, String),
    List(Ty, Ty, String),
}

#[derive(Debug)]
struct Element {
    name: String,
    count: usize,
    props: Vec<Prop>,
}

#[derive(Clone, Copy, PartialEq)]
enum Format {
    Ascii,
    Little,
    Big,
}

const TYPES: &str = "char, uchar, short, ushort, int, uint, float, double (or int8 … float64)";

/// Reads a PLY file's bytes.
pub fn parse_ply(bytes: &[u8]) -> Result<MeshData, FileError> {
    // The header is text up to and including the `end_header` line.
    let mut pos = 0;
    let mut line_no = 0;
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        let Some(len) = bytes[pos..].iter().position(|&b| b == b'\n') else {
            return Err(whole("the PLY header has no `end_header` line"));
        };
        let raw = &bytes[pos..pos + len];
        pos += len + 1;
        line_no += 1;
        let text = String::from_utf8_lossy(raw)
            .trim_end_matches('\r')
            .to_owned();
        let mut w = text.split_whitespace();
        let first = w.next();
        if line_no == 1 {
            if first != Some("ply") {
                return Err(at(1, &text, "expected `ply`: the first line of a PLY file"));
            }
            continue;
        }
        match first {
            Some("format") => {
                format = Some(match (w.next(), w.next()) {
                    (Some("ascii"), Some("1.0")) => Format::Ascii,
                    (Some("binary_little_endian"), Some("1.0")) => Format::Little,
                    (Some("binary_big_endian"), Some("1.0")) => Format::Big,
                    _ => {
                        return Err(at(
                            line_no,
                            &text,
                            "expected `format ascii 1.0`, `format binary_little_endian 1.0` or `format binary_big_endian 1.0`",
                        ));
                    }
                });
            }
            Some("element") => {
                let (Some(name), Some(count)) = (w.next(), w.next().and_then(|c| c.parse().ok()))
                else {
                    return Err(at(line_no, &text, "expected `element <name> <count>`"));
                };
                elements.push(Element {
                    name: name.to_owned(),
                    count,
                    props: Vec::new(),
                });
            }
            Some("property") => {
                let Some(el) = elements.last_mut() else {
                    return Err(at(line_no, &text, "a property before any `element` line"));
                };
                let words: Vec<&str> = w.collect();
                let bad = || {
                    at(
                        line_no,
                        &text,
                        format!(
                            "expected `property <type> <name>` or `property list <count type> <item type> <name>`, types: {TYPES}"
                        ),
                    )
                };
                let prop = match words[..] {
                    ["list", ct, it, name] => match (Ty::parse(ct), Ty::parse(it)) {
                        (Some(c), Some(i)) if !matches!(c, Ty::F32 | Ty::F64) => {
                            Prop::List(c, i, name.to_owned())
                        }
                        _ => return Err(bad()),
                    },
                    [ty, name] => Prop::Scalar(Ty::parse(ty).ok_or_else(bad)?, name.to_owned()),
                    _ => return Err(bad()),
                };
                el.props.push(prop);
            }
            Some("end_header") => break,
            Some("comment") | Some("obj_info") | None => {}
            Some(other) => {
                return Err(at(
                    line_no,
                    &text,
                    format!(
                        "expected `format`, `element`, `property`, `comment` or `end_header`, found `{other}`"
                    ),
                ));
            }
        }
    }
    let format = format.ok_or_else(|| whole("the PLY header has no `format` line"))?;
    let vertex_el = elements
        .iter()
        .position(|e| e.name == "vertex")
        .ok_or_else(|| whole("the PLY header declares no `element vertex`"))?;
    let coord = |name: &str| {
        elements[vertex_el]
            .props
            .iter()
            .position(|p| matches!(p, Prop::Scalar(_, n) if n == name))
            .ok_or_else(|| {
                whole(format!(
                    "the PLY `element vertex` has no scalar property `{name}` (expected x, y, z)"
                ))
            })
    };
    let xyz = [coord("x")?, coord("y")?, coord("z")?];
    let face_el = elements
        .iter()
        .position(|e| e.name == "face")
        .ok_or_else(|| whole("the PLY file has no `element face`: a point cloud has no surface"))?;
    let list = elements[face_el]
        .props
        .iter()
        .position(
            |p| matches!(p, Prop::List(_, _, n) if n == "vertex_indices" || n == "vertex_index"),
        )
        .ok_or_else(|| {
            whole(
                "the PLY `element face` has no list property `vertex_indices` (or `vertex_index`)",
            )
        })?;
    let n_vertices = elements[vertex_el].count;

    let mut m = MeshData::default();
    let mut body = Body {
        bytes,
        pos,
        line: line_no,
        format,
        words: Vec::new(),
        word: 0,
    };
    for (e, el) in elements.iter().enumerate() {
        for k in 0..el.count {
            body.start(&el.name, k)?;
            let mut v = [0f64; 3];
            let mut corners: Vec<u32> = Vec::new();
            for (pi, prop) in el.props.iter().enumerate() {
                match prop {
                    Prop::Scalar(ty, _) => {
                        let x = body.value(*ty, &el.name, k)?;
                        if e == vertex_el
                            && let Some(c) = xyz.iter().position(|&c| c == pi)
                        {
                            v[c] = x;
                        }
                    }
                    Prop::List(ct, it, _) => {
                        let n = body.value(*ct, &el.name, k)?;
                        if !(0.0..=1e6).contains(&n) || n.fract() != 0.0 {
                            return Err(body.error(&el.name, k, format!("a list of {n} items")));
                        }
                        for _ in 0..n as usize {
                            let i = body.value(*it, &el.name, k)?;
                            if e == face_el && pi == list {
                                if i.fract() != 0.0 || i < 0.0 || i >= n_vertices as f64 {
                                    return Err(body.error(
                                        &el.name,
                                        k,
                                        format!(
                                            "vertex index {i} does not exist: the file has {n_vertices} vertices"
                                        ),
                                    ));
                                }
                                corners.push(i as u32);
                            }
                        }
                    }
                }
            }
            body.end(&el.name, k)?;
            if e == vertex_el {
                let p = Vec3::new(v[0] as f32, v[1] as f32, v[2] as f32);
                if !p.is_finite() {
                    return Err(body.error(&el.name, k, "a position that is not finite".into()));
                }
                m.vertices.push(p);
            } else if e == face_el {
                if corners.len() < 3 {
                    return Err(body.error(
                        &el.name,
                        k,
                        format!("a face of {} vertices; at least three", corners.len()),
                    ));
                }
                for j in 1..corners.len() - 1 {
                    m.triangles.push([corners[0], corners[j], corners[j + 1]]);
                }
                if m.triangles.len() > MAX_TRIANGLES {
                    return Err(body.error(
                        &el.name,
                        k,
                        format!("more than {MAX_TRIANGLES} triangles; simplify the mesh"),
                    ));
                }
            }
        }
    }
    Ok(m)
}

/// The body after the header: ASCII lines of words, or binary values.
struct Body<'a> {
    bytes: &'a [u8],
    pos: usize,
    /// ASCII: the line of the current element.
    line: usize,
    format: Format,
    words: Vec<String>,
    word: usize,
}

impl Body<'_> {
    /// Begins element `k` of `name`: in ASCII, its line.
    fn start(&mut self, name: &str, k: usize) -> Result<(), FileError> {
        if self.format != Format::Ascii {
            return Ok(());
        }
        loop {
            if self.pos >= self.bytes.len() {
                return Err(whole(format!(
                    "the file ends before {name} {} of the header's count",
                    k + 1
                )));
            }
            let len = self.bytes[self.pos..]
                .iter()
                .position(|&b| b == b'\n')
                .unwrap_or(self.bytes.len() - self.pos);
            let text = String::from_utf8_lossy(&self.bytes[self.pos..self.pos + len]).into_owned();
            self.pos += len + 1;
            self.line += 1;
            self.words = text.split_whitespace().map(str::to_owned).collect();
            self.word = 0;
            if !self.words.is_empty() {
                return Ok(());
            }
        }
    }

    /// Ends element `k`: in ASCII, nothing may be left on its line.
    fn end(&mut self, name: &str, k: usize) -> Result<(), FileError> {
        if self.format == Format::Ascii && self.word < self.words.len() {
            return Err(self.error(
                name,
                k,
                format!(
                    "{} more values than the header declares",
                    self.words.len() - self.word
                ),
            ));
        }
        Ok(())
    }

    fn error(&self, name: &str, k: usize, what: String) -> FileError {
        if self.format == Format::Ascii {
            at(
                self.line,
                &self.words.join(" "),
                format!("{name} {}: {what}", k + 1),
            )
        } else {
            whole(format!(
                "{name} {} (binary, byte {}): {what}",
                k + 1,
                self.pos
            ))
        }
    }

    fn value(&mut self, ty: Ty, name: &str, k: usize) -> Result<f64, FileError> {
        if self.format == Format::Ascii {
            let Some(w) = self.words.get(self.word).cloned() else {
                return Err(self.error(name, k, "fewer values than the header declares".into()));
            };
            self.word += 1;
            return match w.parse::<f64>().ok().filter(|x| x.is_finite()) {
                Some(x) if !matches!(ty, Ty::F32 | Ty::F64) && x.fract() != 0.0 => {
                    Err(self.error(name, k, format!("expected an integer, found \"{w}\"")))
                }
                Some(x) => Ok(x),
                None => {
                    Err(self.error(name, k, format!("expected a finite number, found \"{w}\"")))
                }
            };
        }
        let n = ty.size();
        let Some(b) = self.bytes.get(self.pos..self.pos + n) else {
            return Err(whole(format!(
                "the file ends inside {name} {} of the header's count",
                k + 1
            )));
        };
        self.pos += n;
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(b);
        if self.format == Format::Big {
            a[..n].reverse();
        }
        Ok(match ty {
            Ty::I8 => a[0] as i8 as f64,
            Ty::U8 => a[0] as f64,
            Ty::I16 => i16::from_le_bytes([a[0], a[1]]) as f64,
            Ty::U16 => u16::from_le_bytes([a[0], a[1]]) as f64,
            Ty::I32 => i32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Ty::U32 => u32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Ty::F32 => f32::from_le_bytes([a[0], a[1], a[2], a[3]]) as f64,
            Ty::F64 => f64::from_le_bytes(a),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str = "ply\nformat {F} 1.0\ncomment a tetrahedron\nelement vertex 4\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nelement face 4\nproperty list uchar int vertex_indices\nend_header\n";

    fn tetra() -> (Vec<[f32; 3]>, Vec<[i32; 3]>) {
        (
            vec![
                [0.0, 0.0, 0.0],
                [1.0, 0.0, 0.0],
                [0.0, 1.0, 0.0],
                [0.0, 0.0, 1.0],
            ],
            vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]],
        )
    }

    #[test]
    fn ascii_and_binary_of_either_order_read_the_same_mesh() {
        let (v, f) = tetra();
        let mut ascii = HEADER.replace("{F}", "ascii");
        for p in &v {
            ascii += &format!("{} {} {} 255\n", p[0], p[1], p[2]);
        }
        for t in &f {
            ascii += &format!("3 {} {} {}\n", t[0], t[1], t[2]);
        }
        let a = parse_ply(ascii.as_bytes()).unwrap();
        assert_eq!(a.vertices.len(), 4);
        assert_eq!(
            a.triangles,
            vec![[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]]
        );
        for (name, big) in [("binary_little_endian", false), ("binary_big_endian", true)] {
            let mut bin = HEADER.replace("{F}", name).into_bytes();
            for p in &v {
                for c in p {
                    bin.extend(if big {
                        c.to_be_bytes()
                    } else {
                        c.to_le_bytes()
                    });
                }
                bin.push(255);
            }
            for t in &f {
                bin.push(3);
                for i in t {
                    bin.extend(if big {
                        i.to_be_bytes()
                    } else {
                        i.to_le_bytes()
                    });
                }
            }
            assert_eq!(parse_ply(&bin).unwrap(), a, "{name}");
            // Cut short: named by element.
            let e = parse_ply(&bin[..bin.len() - 3]).unwrap_err();
            assert!(e.message.contains("ends inside face 4"), "{e:?}");
        }
    }

    #[test]
    fn errors_name_the_line_and_what_was_expected() {
        let head = HEADER.replace("{F}", "ascii");
        let body = "0 0 0 1\n1 0 0 1\n0 1 0 1\n0 0 1 1\n3 0 2 1\n3 0 1 7\n";
        let e = parse_ply(format!("{head}{body}").as_bytes()).unwrap_err();
        // Header of 11 lines; the bad face is the 6th body line.
        assert_eq!(e.line, 17, "{e:?}");
        assert!(
            e.message.contains("face 2: vertex index 7 does not exist"),
            "{e:?}"
        );
        let e = parse_ply(format!("{head}0 0 x 1\n").as_bytes()).unwrap_err();
        assert_eq!(e.line, 12);
        assert!(
            e.message.contains("expected a finite number, found \"x\""),
            "{e:?}"
        );
        let e = parse_ply(b"ply\nformat ascii 2.0\nend_header\n").unwrap_err();
        assert_eq!(e.line, 2);
        let e = parse_ply(
            b"ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\nend_header\n0\n",
        )
        .unwrap_err();
        assert!(e.message.contains("no scalar property `y`"), "{e:?}");
        let e =
            parse_ply(b"ply\nformat ascii 1.0\nelement vertex 1\nproperty fluffy x\n").unwrap_err();
        assert_eq!(e.line, 4);
        assert!(e.message.contains("types: char"), "{e:?}");
        assert!(
            parse_ply(b"solid x\n")
                .unwrap_err()
                .message
                .contains("`ply`")
        );
        assert!(
            parse_ply(b"ply\nformat ascii 1.0\n")
                .unwrap_err()
                .message
                .contains("end_header")
        );
    }
}
