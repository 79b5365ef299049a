//! Mesh files for `type = "mesh"` obstacles: Wavefront OBJ, STL (binary or ASCII), PLY
//! (ASCII or binary) and glTF 2.0 (`.gltf` with its buffers, or `.glb`) read into
//! vertices and triangles, every problem located by line (OBJ, ASCII STL, PLY header and
//! ASCII body), element (binary STL and PLY) or JSON key/line (glTF). Coordinates are
//! taken as they are: metres, Y-up (what Blender's OBJ and PLY exporters write with their
//! default "Y up" option, what glTF defines, and what the add-on writes).
//!
//! The OBJ, STL and PLY readers are small and our own rather than a crate's (`tobj` was
//! considered) so that a bad file is reported at its line, like a bad shot. glTF goes
//! through the `gltf` crate (JSON, GLB container, accessors), its errors located by the
//! JSON line or the key (`meshes[0].primitives[1]`) they are about.

use glam::Vec3;
use std::path::Path;

use crate::geometry::mesh::MAX_TRIANGLES;

/// Largest mesh file read, bytes: ~5 M triangles of binary STL, or a dense OBJ.
pub const MAX_FILE_BYTES: u64 = 512 * 1024 * 1024;

/// Vertices and triangles (indices into the vertices) as the file gives them.
#[derive(Debug, Default, PartialEq)]
pub struct MeshData {
    pub vertices: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
}

/// A problem in a mesh file: 1-based line (0: the whole file) and that line's text.
#[derive(Debug, PartialEq)]
pub struct FileError {
    pub line: usize,
    pub source_line: Option<String>,
    pub message: String,
}

impl FileError {
    fn whole(message: impl Into<String>) -> Self {
        FileError {
            line: 0,
            source_line: None,
            message: message.into(),
        }
    }
}

/// How errors about the `node` key begin (so the shot can point at that key).
pub const NODE_ERROR: &str = "no node";

/// The extensions [`read`] knows.
pub const EXTENSIONS: &[&str] = &["obj", "stl", "ply", "gltf", "glb"];

/// Reads `path` by its extension (see [`EXTENSIONS`]). `node`: glTF only, the meshes of
/// the node of that name and of its children (all of the default scene's when `None`).
/// glTF files already parsed, by path: `documents` keeps them for the next obstacle that
/// names the same file (one parse, not one per node).
pub fn read(
    path: &Path,
    node: Option<&str>,
    documents: &mut Documents,
) -> Result<MeshData, FileError> {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .unwrap_or_default();
    if !EXTENSIONS.contains(&ext.as_str()) {
        return Err(FileError::whole(
            "expected a .obj, .stl, .ply, .gltf or .glb mesh file (Blender: File > Export > glTF 2.0)",
        ));
    }
    if node.is_some() && ext != "gltf" && ext != "glb" {
        return Err(FileError::whole(format!(
            "no nodes in a .{ext} file: `node` picks a node of a .gltf or .glb file"
        )));
    }
    let gltf = ext == "gltf" || ext == "glb";
    if gltf && let Some(doc) = documents.0.get(path) {
        return non_empty(doc.meshes(node)?);
    }
    let len = std::fs::metadata(path)
        .map_err(|e| FileError::whole(format!("cannot read it: {e}")))?
        .len();
    if len > MAX_FILE_BYTES {
        return Err(FileError::whole(format!(
            "the file is {len} bytes; mesh files up to {MAX_FILE_BYTES} bytes are read"
        )));
    }
    let bytes =
        std::fs::read(path).map_err(|e| FileError::whole(format!("cannot read it: {e}")))?;
    let data = match ext.as_str() {
        "obj" => {
            let text = std::str::from_utf8(&bytes).map_err(|e| {
                FileError::whole(format!(
                    "not a text OBJ file: byte {} is not UTF-8",
                    e.valid_up_to()
                ))
            })?;
            parse_obj(text)?
        }
        "stl" => parse_stl(&bytes)?,
        "ply" => super::mesh_ply::parse_ply(&bytes)?,
        _ => {
            let doc = super::mesh_gltf::Document::parse(&bytes, path.parent())?;
            let data = doc.meshes(node);
            documents.0.insert(path.to_path_buf(), doc);
            data?
        }
    };
    non_empty(data)
}

fn non_empty(data: MeshData) -> Result<MeshData, FileError> {
    if data.triangles.is_empty() {
        return Err(FileError::whole("the file has no triangles"));
    }
    Ok(data)
}

/// Parsed glTF files by path, for [`read`]; dropped with the shot's resolution.
#[derive(Default)]
pub struct Documents(std::collections::HashMap<std::path::PathBuf, super::mesh_gltf::Document>);

pub(super) fn whole(message: impl Into<String>) -> FileError {
    FileError::whole(message)
}

pub(super) fn at(line: usize, text: &str, message: impl Into<String>) -> FileError {
    FileError {
        line,
        source_line: Some(text.to_owned()),
        message: message.into(),
    }
}

fn too_many(line: usize, text: &str) -> FileError {
    at(
        line,
        text,
        format!("more than {MAX_TRIANGLES} triangles; simplify the mesh"),
    )
}

/// Three finite coordinates from `words`.
fn xyz<'a>(
    mut words: impl Iterator<Item = &'a str>,
    line: usize,
    text: &str,
) -> Result<Vec3, FileError> {
    let mut v = [0f32; 3];
    for c in &mut v {
        let w = words
            .next()
            .ok_or_else(|| at(line, text, "expected three coordinates x y z"))?;
        *c = w
            .parse::<f32>()
            .ok()
            .filter(|x| x.is_finite())
            .ok_or_else(|| {
                at(
                    line,
                    text,
                    format!("expected a finite number, found \"{w}\""),
                )
            })?;
    }
    Ok(Vec3::from_array(v))
}

/// Wavefront OBJ: `v` and `f` statements (polygons fanned into triangles, indices
/// 1-based or negative from the end, `v/vt/vn` forms); everything else is ignored.
pub fn parse_obj(text: &str) -> Result<MeshData, FileError> {
    let mut m = MeshData::default();
    for (n, raw) in text.lines().enumerate() {
        let line = n + 1;
        let content = raw.split('#').next().unwrap_or("");
        let mut words = content.split_whitespace();
        match words.next() {
            Some("v") => m.vertices.push(xyz(words, line, raw)?),
            Some("f") => {
                let mut corners = Vec::new();
                for w in words {
                    let i = w.split('/').next().unwrap_or("");
                    let i: i64 = i.parse().map_err(|_| {
                        at(line, raw, format!("expected a vertex index, found \"{w}\""))
                    })?;
                    let count = m.vertices.len() as i64;
                    let k = if i > 0 { i - 1 } else { count + i };
                    if i == 0 || k < 0 || k >= count {
                        return Err(at(
                            line,
                            raw,
                            format!(
                                "vertex index {i} does not exist: {count} vertices are defined above this line"
                            ),
                        ));
                    }
                    corners.push(k as u32);
                }
                if corners.len() < 3 {
                    return Err(at(line, raw, "expected a face of at least three vertices"));
                }
                for k in 1..corners.len() - 1 {
                    m.triangles.push([corners[0], corners[k], corners[k + 1]]);
                }
                if m.triangles.len() > MAX_TRIANGLES {
                    return Err(too_many(line, raw));
                }
            }
            _ => {}
        }
    }
    Ok(m)
}

/// STL, binary (84-byte header and 50 bytes a triangle) or ASCII (`vertex x y z` lines,
/// three to a facet). Vertices are not shared in STL; the mesh welds them.
pub fn parse_stl(bytes: &[u8]) -> Result<MeshData, FileError> {
    if bytes.len() >= 84 {
        let n = u32::from_le_bytes([bytes[80], bytes[81], bytes[82], bytes[83]]) as u64;
        if 84 + 50 * n == bytes.len() as u64 {
            return parse_binary_stl(&bytes[84..], n as usize);
        }
    }
    if bytes.trim_ascii_start().starts_with(b"solid") {
        let text = std::str::from_utf8(bytes).map_err(|e| {
            FileError::whole(format!(
                "neither binary STL (size does not match its triangle count) nor ASCII STL \
                 (byte {} is not text)",
                e.valid_up_to()
            ))
        })?;
        return parse_ascii_stl(text);
    }
    Err(FileError::whole(
        "not an STL file: too short or its size does not match the triangle count in its header",
    ))
}

fn parse_binary_stl(body: &[u8], n: usize) -> Result<MeshData, FileError> {
    if n > MAX_TRIANGLES {
        return Err(FileError::whole(format!(
            "{n} triangles; at most {MAX_TRIANGLES} are supported; simplify the mesh"
        )));
    }
    let mut m = MeshData::default();
    for (k, rec) in body.chunks_exact(50).enumerate() {
        let f = |o: usize| f32::from_le_bytes([rec[o], rec[o + 1], rec[o + 2], rec[o + 3]]);
        for c in 0..3 {
            let o = 12 + 12 * c;
            let v = Vec3::new(f(o), f(o + 4), f(o + 8));
            if !v.is_finite() {
                return Err(FileError::whole(format!(
                    "triangle {} has a corner that is not a finite position",
                    k + 1
                )));
            }
            m.vertices.push(v);
        }
        let b = 3 * k as u32;
        m.triangles.push([b, b + 1, b + 2]);
    }
    Ok(m)
}

fn parse_ascii_stl(text: &str) -> Result<MeshData, FileError> {
    let mut m = MeshData::default();
    let mut facet: Vec<u32> = Vec::new();
    for (n, raw) in text.lines().enumerate() {
        let line = n + 1;
        let mut words = raw.split_whitespace();
        match words.next() {
            Some("vertex") => {
                m.vertices.push(xyz(words, line, raw)?);
                facet.push(m.vertices.len() as u32 - 1);
            }
            Some("endloop") => {
                if facet.len() < 3 {
                    return Err(at(line, raw, "expected at least three vertices in a loop"));
                }
                for k in 1..facet.len() - 1 {
                    m.triangles.push([facet[0], facet[k], facet[k + 1]]);
                }
                facet.clear();
                if m.triangles.len() > MAX_TRIANGLES {
                    return Err(too_many(line, raw));
                }
            }
            _ => {}
        }
    }
    Ok(m)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn obj_faces_are_fanned_and_indices_resolved() {
        let m = parse_obj(
            "# a quad\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1 4//1\nf -4 -3 -2\n",
        )
        .unwrap();
        assert_eq!(m.vertices.len(), 4);
        assert_eq!(m.triangles, vec![[0, 1, 2], [0, 2, 3], [0, 1, 2]]);
    }

    #[test]
    fn obj_errors_name_the_line() {
        let e = parse_obj("v 0 0 0\nv 1 0 nan\n").unwrap_err();
        assert_eq!(e.line, 2);
        assert!(e.message.contains("finite number"), "{e:?}");
        let e = parse_obj("v 0 0 0\nv 1 0 0\nf 1 2 3\n").unwrap_err();
        assert_eq!(e.line, 3);
        assert!(e.message.contains("index 3 does not exist"), "{e:?}");
        let e = parse_obj("v 0 0\n").unwrap_err();
        assert!(e.message.contains("three coordinates"));
        let e = parse_obj("v 0 0 0\nf 1 1\n").unwrap_err();
        assert!(e.message.contains("at least three"));
    }

    #[test]
    fn stl_binary_and_ascii_read_the_same_triangle() {
        let mut bin = vec![0u8; 80];
        bin.extend(1u32.to_le_bytes());
        for x in [0f32, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0] {
            bin.extend(x.to_le_bytes());
        }
        bin.extend([0, 0]);
        let a = parse_stl(&bin).unwrap();
        let b = parse_stl(
            b"solid t\nfacet normal 0 0 1\nouter loop\nvertex 1 0 0\nvertex 0 1 0\nvertex 0 0 1\nendloop\nendfacet\nendsolid t\n",
        )
        .unwrap();
        assert_eq!(a, b);
        assert_eq!(a.triangles, vec![[0, 1, 2]]);
        assert!(parse_stl(&bin[..100]).is_err());
        let e = parse_stl(b"solid t\nouter loop\nvertex 1 0 x\n").unwrap_err();
        assert_eq!(e.line, 3);
    }

    #[test]
    fn a_gltf_file_is_parsed_once_for_all_its_nodes() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("set.gltf");
        let text = super::super::mesh_gltf::tests::tetra_gltf(12, None);
        std::fs::write(&path, &text).unwrap();
        let mut docs = Documents::default();
        let rock = read(&path, Some("rock"), &mut docs).unwrap();
        assert_eq!(rock.triangles.len(), 4);
        // Later nodes come from the parsed file, not from the disk.
        std::fs::write(&path, "not glTF").unwrap();
        assert_eq!(read(&path, Some("set"), &mut docs).unwrap(), rock);
        assert_eq!(read(&path, None, &mut docs).unwrap(), rock);
        let e = read(&path, Some("tree"), &mut docs).unwrap_err();
        assert!(e.message.starts_with(NODE_ERROR), "{}", e.message);
        // A fresh resolution reads the file again.
        assert!(read(&path, Some("rock"), &mut Documents::default()).is_err());
    }
}
