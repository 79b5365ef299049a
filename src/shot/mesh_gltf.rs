//! glTF 2.0 for mesh obstacles (`.gltf` with external or embedded buffers, or `.glb`):
//! the triangles of every mesh the default scene (else the first scene) places, each in
//! its node's world transform, through the `gltf` crate. `node` keeps the meshes of the
//! node of that name and of its children. glTF is metres and Y-up by definition, as the
//! world is. Errors name the JSON line (syntax) or the key they are about.

use glam::{Mat4, Vec3};
use std::path::Path;

use super::mesh_file::{FileError, MeshData, at, whole};
use crate::geometry::mesh::MAX_TRIANGLES;

/// Nodes may nest this deep (a deeper chain is taken for a cycle).
const MAX_DEPTH: usize = 256;

/// The tests' shorthand: parse and take the meshes of `node`.
#[cfg(test)]
fn parse_gltf(bytes: &[u8], dir: Option<&Path>, node: Option<&str>) -> Result<MeshData, FileError> {
    Document::parse(bytes, dir)?.meshes(node)
}

/// A parsed glTF file and its buffers' bytes: read once, however many of its nodes a shot
/// takes as obstacles (the Blender add-on writes every mesh obstacle into one .glb).
pub struct Document {
    gltf: gltf::Gltf,
    buffers: Vec<Vec<u8>>,
}

impl Document {
    /// Parses a glTF or GLB file's bytes; external buffers are read beside it, in `dir`.
    pub fn parse(bytes: &[u8], dir: Option<&Path>) -> Result<Document, FileError> {
        parse_document(bytes, dir)
    }

    /// The triangles of node `node` and its children, or of every mesh of the scene.
    pub fn meshes(&self, node: Option<&str>) -> Result<MeshData, FileError> {
        scene_meshes(&self.gltf, &self.buffers, node)
    }
}

fn parse_document(bytes: &[u8], dir: Option<&Path>) -> Result<Document, FileError> {
    let gltf = gltf::Gltf::from_slice(bytes).map_err(|e| match e {
        gltf::Error::Deserialize(e) if !bytes.starts_with(b"glTF") => {
            // A .gltf file is its JSON: point at the line.
            let text = String::from_utf8_lossy(bytes);
            let line = text.lines().nth(e.line().saturating_sub(1)).unwrap_or("");
            at(e.line(), line, format!("invalid glTF JSON: {e}"))
        }
        gltf::Error::Deserialize(e) => {
            whole(format!("invalid glTF JSON in the GLB's JSON chunk: {e}"))
        }
        gltf::Error::Validation(errs) => {
            let list: Vec<String> = errs
                .iter()
                .take(5)
                .map(|(path, e)| format!("`{path}`: {e}"))
                .collect();
            whole(format!(
                "invalid glTF: {}{}",
                list.join("; "),
                if errs.len() > 5 {
                    format!(" (and {} more)", errs.len() - 5)
                } else {
                    String::new()
                }
            ))
        }
        gltf::Error::Binary(e) => whole(format!("not a valid GLB file: {e}")),
        e => whole(format!("not a valid glTF file: {e}")),
    })?;
    // Every buffer's bytes, checked against its declared length so that no accessor can
    // read past them.
    let mut buffers: Vec<Vec<u8>> = Vec::new();
    for b in gltf.buffers() {
        let key = format!("buffers[{}]", b.index());
        let data = match b.source() {
            gltf::buffer::Source::Bin => gltf.blob.clone().ok_or_else(|| {
                whole(format!(
                    "`{key}` is the GLB's binary chunk, which this file does not have"
                ))
            })?,
            gltf::buffer::Source::Uri(uri) => {
                if let Some(rest) = uri.strip_prefix("data:") {
                    let b64 = rest.split_once(";base64,").map(|(_, d)| d).ok_or_else(|| {
                        whole(format!(
                            "`{key}.uri`: expected a base64 data URI (data:…;base64,…)"
                        ))
                    })?;
                    base64(b64).ok_or_else(|| {
                        whole(format!("`{key}.uri`: the base64 data is malformed"))
                    })?
                } else {
                    let path = dir.unwrap_or(Path::new(".")).join(percent_decode(uri));
                    std::fs::read(&path).map_err(|e| {
                        whole(format!("`{key}.uri`: cannot read {}: {e}", path.display()))
                    })?
                }
            }
        };
        if data.len() < b.length() {
            return Err(whole(format!(
                "`{key}`: byteLength is {} bytes but the data has {}",
                b.length(),
                data.len()
            )));
        }
        buffers.push(data);
    }
    Ok(Document { gltf, buffers })
}

fn scene_meshes(
    gltf: &gltf::Gltf,
    buffers: &[Vec<u8>],
    node: Option<&str>,
) -> Result<MeshData, FileError> {
    let scene = gltf
        .default_scene()
        .or_else(|| gltf.scenes().next())
        .ok_or_else(|| whole("the glTF file has no scene"))?;
    let mut out = MeshData::default();
    let mut found = node.is_none();
    for root in scene.nodes() {
        walk(
            &root,
            Mat4::IDENTITY,
            node,
            node.is_none(),
            0,
            buffers,
            &mut out,
            &mut found,
        )?;
    }
    if !found {
        let names: Vec<&str> = gltf.nodes().filter_map(|n| n.name()).take(20).collect();
        return Err(whole(format!(
            "no node named \"{}\" in the scene; its nodes: {}",
            node.unwrap_or_default(),
            if names.is_empty() {
                "none named".to_owned()
            } else {
                names.join(", ")
            }
        )));
    }
    Ok(out)
}

#[allow(clippy::too_many_arguments)]
fn walk(
    n: &gltf::Node,
    parent: Mat4,
    node: Option<&str>,
    mut selected: bool,
    depth: usize,
    buffers: &[Vec<u8>],
    out: &mut MeshData,
    found: &mut bool,
) -> Result<(), FileError> {
    if depth > MAX_DEPTH {
        return Err(whole(format!(
            "`nodes[{}]`: nodes nest deeper than {MAX_DEPTH} (a cycle?)",
            n.index()
        )));
    }
    let world = parent * Mat4::from_cols_array_2d(&n.transform().matrix());
    if node.is_some() && n.name() == node {
        selected = true;
        *found = true;
    }
    if selected && let Some(mesh) = n.mesh() {
        for prim in mesh.primitives() {
            add_primitive(&prim, mesh.index(), world, buffers, out)?;
        }
    }
    for c in n.children() {
        walk(&c, world, node, selected, depth + 1, buffers, out, found)?;
    }
    Ok(())
}

fn add_primitive(
    prim: &gltf::Primitive,
    mesh: usize,
    world: Mat4,
    buffers: &[Vec<u8>],
    out: &mut MeshData,
) -> Result<(), FileError> {
    use gltf::mesh::Mode;
    let key = format!("meshes[{mesh}].primitives[{}]", prim.index());
    let mode = prim.mode();
    if !matches!(
        mode,
        Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
    ) {
        // Points and lines have no surface (helpers, wires): not an obstacle.
        return Ok(());
    }
    let reader = prim.reader(|b| buffers.get(b.index()).map(|d| d.as_slice()));
    let positions: Vec<[f32; 3]> = reader
        .read_positions()
        .ok_or_else(|| {
            whole(format!(
                "`{key}.attributes.POSITION`: expected vertex positions"
            ))
        })?
        .collect();
    let count = prim
        .get(&gltf::Semantic::Positions)
        .map_or(0, |a| a.count());
    if positions.len() != count {
        return Err(whole(format!(
            "`{key}.attributes.POSITION`: {count} positions declared, {} readable",
            positions.len()
        )));
    }
    let indices: Vec<u32> = match reader.read_indices() {
        Some(i) => i.into_u32().collect(),
        None if prim.indices().is_some() => {
            return Err(whole(format!(
                "`{key}.indices`: the indices cannot be read from their buffer"
            )));
        }
        None => (0..positions.len() as u32).collect(),
    };
    if let Some(bad) = indices.iter().find(|&&i| i as usize >= positions.len()) {
        return Err(whole(format!(
            "`{key}.indices`: vertex index {bad} does not exist: the primitive has {} positions",
            positions.len()
        )));
    }
    let base = out.vertices.len() as u32;
    for (k, p) in positions.iter().enumerate() {
        let v = world.transform_point3(Vec3::from_array(*p));
        if !v.is_finite() {
            return Err(whole(format!(
                "`{key}`: vertex {k} is not a finite position (in the world, after its nodes' transforms)"
            )));
        }
        out.vertices.push(v);
    }
    let tri = |a: u32, b: u32, c: u32| [base + a, base + b, base + c];
    match mode {
        Mode::Triangles => out
            .triangles
            .extend(indices.chunks_exact(3).map(|t| tri(t[0], t[1], t[2]))),
        Mode::TriangleStrip => {
            out.triangles
                .extend(indices.windows(3).enumerate().map(|(k, t)| {
                    // Every other triangle of a strip is wound the other way round.
                    if k % 2 == 0 {
                        tri(t[0], t[1], t[2])
                    } else {
                        tri(t[1], t[0], t[2])
                    }
                }))
        }
        _ => {
            if let Some((&first, rest)) = indices.split_first() {
                out.triangles
                    .extend(rest.windows(2).map(|t| tri(first, t[0], t[1])));
            }
        }
    }
    if out.triangles.len() > MAX_TRIANGLES {
        return Err(whole(format!(
            "`{key}`: more than {MAX_TRIANGLES} triangles; simplify the mesh"
        )));
    }
    Ok(())
}

/// `%20` and the like in a relative URI.
fn percent_decode(uri: &str) -> String {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        let hex = |c: u8| (c as char).to_digit(16);
        if b[i] == b'%'
            && i + 2 < b.len()
            && let (Some(h), Some(l)) = (hex(b[i + 1]), hex(b[i + 2]))
        {
            out.push((h * 16 + l) as u8);
            i += 3;
            continue;
        }
        out.push(b[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Standard base64 (with or without padding); `None` on any other character.
fn base64(s: &str) -> Option<Vec<u8>> {
    let val = |c: u8| -> Option<u32> {
        Some(match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' => 62,
            b'/' => 63,
            _ => return None,
        } as u32)
    };
    let s = s.trim_end_matches('=').as_bytes();
    let mut out = Vec::with_capacity(s.len() * 3 / 4);
    for chunk in s.chunks(4) {
        if chunk.len() == 1 {
            return None;
        }
        let mut acc = 0u32;
        for (k, &c) in chunk.iter().enumerate() {
            acc |= val(c)? << (18 - 6 * k);
        }
        let bytes = [(acc >> 16) as u8, (acc >> 8) as u8, acc as u8];
        out.extend(&bytes[..chunk.len() - 1]);
    }
    Some(out)
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    fn b64(data: &[u8]) -> String {
        const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
        let mut s = String::new();
        for c in data.chunks(3) {
            let n = c
                .iter()
                .enumerate()
                .fold(0u32, |a, (k, &b)| a | (b as u32) << (16 - 8 * k));
            for k in 0..=c.len() {
                s.push(A[(n >> (18 - 6 * k) & 63) as usize] as char);
            }
        }
        s
    }

    /// A tetrahedron as a .gltf with an embedded buffer: 4 positions, 12 u16 indices,
    /// placed by a parent node (translated by +2 in x) and a child named "rock".
    pub(in crate::shot) fn tetra_gltf(index_count: usize, extra_index: Option<u16>) -> String {
        let mut buf = Vec::new();
        for p in [
            [0f32, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [0.0, 1.0, 0.0],
            [0.0, 0.0, 1.0],
        ] {
            for c in p {
                buf.extend(c.to_le_bytes());
            }
        }
        let mut idx: Vec<u16> = vec![0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3];
        if let Some(i) = extra_index {
            idx[11] = i;
        }
        for i in &idx {
            buf.extend(i.to_le_bytes());
        }
        format!(
            r#"{{
  "asset": {{"version": "2.0"}},
  "scene": 0,
  "scenes": [{{"nodes": [0]}}],
  "nodes": [{{"name": "set", "translation": [2, 0, 0], "children": [1]}}, {{"name": "rock", "mesh": 0}}],
  "meshes": [{{"primitives": [{{"attributes": {{"POSITION": 0}}, "indices": 1}}]}}],
  "buffers": [{{"byteLength": {len}, "uri": "data:application/octet-stream;base64,{data}"}}],
  "bufferViews": [{{"buffer": 0, "byteOffset": 0, "byteLength": 48}}, {{"buffer": 0, "byteOffset": 48, "byteLength": 24}}],
  "accessors": [
    {{"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 1]}},
    {{"bufferView": 1, "componentType": 5123, "count": {index_count}, "type": "SCALAR"}}
  ]
}}"#,
            len = buf.len(),
            data = b64(&buf)
        )
    }

    #[test]
    fn a_node_tree_is_read_in_world_space_and_a_node_can_be_picked() {
        let text = tetra_gltf(12, None);
        let m = parse_gltf(text.as_bytes(), None, None).unwrap();
        assert_eq!(m.triangles.len(), 4);
        assert_eq!(
            m.vertices[1],
            Vec3::new(3.0, 0.0, 0.0),
            "the parent's translation"
        );
        assert_eq!(parse_gltf(text.as_bytes(), None, Some("rock")).unwrap(), m);
        let e = parse_gltf(text.as_bytes(), None, Some("tree")).unwrap_err();
        assert!(
            e.message.contains("no node named \"tree\"") && e.message.contains("set, rock"),
            "{e:?}"
        );
        // The same as a GLB: JSON chunk and binary chunk.
        let json = text.replace(
            &text[text.find("\"uri\"").unwrap() - 2..text.find("}],\n  \"bufferViews\"").unwrap()],
            "",
        );
        let bin: Vec<u8> = base64(
            text.split("base64,")
                .nth(1)
                .unwrap()
                .split('"')
                .next()
                .unwrap(),
        )
        .unwrap();
        let mut j = json.into_bytes();
        while !j.len().is_multiple_of(4) {
            j.push(b' ');
        }
        let mut glb = Vec::new();
        glb.extend(b"glTF");
        glb.extend(2u32.to_le_bytes());
        glb.extend(((12 + 8 + j.len() + 8 + bin.len()) as u32).to_le_bytes());
        glb.extend((j.len() as u32).to_le_bytes());
        glb.extend(b"JSON");
        glb.extend(&j);
        glb.extend((bin.len() as u32).to_le_bytes());
        glb.extend(b"BIN\0");
        glb.extend(&bin);
        assert_eq!(parse_gltf(&glb, None, None).unwrap(), m);
    }

    #[test]
    fn bad_files_are_located_by_line_or_key() {
        let e = parse_gltf(
            b"{\n  \"asset\": {\"version\": \"2.0\"},\n  \"nodes\": [,]\n}",
            None,
            None,
        )
        .unwrap_err();
        assert_eq!(e.line, 3, "{e:?}");
        assert!(e.message.contains("invalid glTF JSON"), "{e:?}");
        let e = parse_gltf(tetra_gltf(12, Some(9)).as_bytes(), None, None).unwrap_err();
        assert!(
            e.message
                .contains("`meshes[0].primitives[0].indices`: vertex index 9 does not exist"),
            "{e:?}"
        );
        // More indices than the view holds: not readable, not a panic.
        let e = parse_gltf(tetra_gltf(40, None).as_bytes(), None, None).unwrap_err();
        assert!(
            e.message.contains("meshes[0].primitives[0]") || e.message.contains("accessors[1]"),
            "{e:?}"
        );
        let short = tetra_gltf(12, None).replace("\"byteLength\": 72", "\"byteLength\": 99");
        let e = parse_gltf(short.as_bytes(), None, None).unwrap_err();
        assert!(
            e.message
                .contains("`buffers[0]`: byteLength is 99 bytes but the data has 72"),
            "{e:?}"
        );
        let e = parse_gltf(b"glTF\x02\0\0\0\x0c\0\0\0", None, None).unwrap_err();
        assert!(e.message.contains("GLB"), "{e:?}");
    }

    #[test]
    fn base64_decodes() {
        assert_eq!(base64("aGVsbG8=").unwrap(), b"hello");
        assert_eq!(base64(&b64(b"ab")).unwrap(), b"ab");
        assert!(base64("a$==").is_none());
    }
}
