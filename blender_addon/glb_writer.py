"""A minimal binary glTF (.glb) writer for the obstacle meshes the add-on exports.

One node per obstacle object, named after the object, holding one mesh of triangles
(POSITION and uint32 indices, no normals or materials: the bake only needs the surface).
Vertices are already in world space, Y-up, metres — glTF's own frame — so every node has
the identity transform and the loader's node-transform chain adds nothing on top.

Why not `bpy.ops.export_scene.gltf`: it needs the glTF add-on enabled, a selection and a
view-layer context, names nodes as it sees fit and writes the file itself; the add-on
already holds each object's evaluated, world-space triangles, and this writes exactly
them, byte-identically for the same scene, in every supported Blender.
"""
import json
import struct

import numpy as np

_ARRAY_BUFFER, _ELEMENT_ARRAY_BUFFER = 34962, 34963
_FLOAT, _UNSIGNED_INT = 5126, 5125
_TRIANGLES = 4


def _pad(data, fill):
    return data + fill * (-len(data) % 4)


def glb_bytes(meshes, generator="beeswarm Blender add-on"):
    """The .glb of `meshes`: a list of (node name, float32 (n, 3) positions, (t, 3) vertex
    indices). Raises ValueError for an empty mesh or an index out of range."""
    doc = {"asset": {"version": "2.0", "generator": generator},
           "scene": 0, "scenes": [{"nodes": list(range(len(meshes)))}],
           "nodes": [], "meshes": [], "accessors": [], "bufferViews": [], "buffers": []}
    blob = bytearray()
    for k, (name, positions, triangles) in enumerate(meshes):
        pos = np.ascontiguousarray(positions, dtype="<f4").reshape(-1, 3)
        idx = np.ascontiguousarray(triangles, dtype="<u4").reshape(-1)
        if not len(pos) or not len(idx):
            raise ValueError(f"'{name}' has no triangles")
        if int(idx.max()) >= len(pos):
            raise ValueError(f"'{name}': vertex index {int(idx.max())} of {len(pos)} vertices")
        views = []
        for data, target in ((pos.tobytes(), _ARRAY_BUFFER), (idx.tobytes(), _ELEMENT_ARRAY_BUFFER)):
            views.append(len(doc["bufferViews"]))
            doc["bufferViews"].append({"buffer": 0, "byteOffset": len(blob),
                                       "byteLength": len(data), "target": target})
            blob += _pad(data, b"\0")
        a = len(doc["accessors"])
        doc["accessors"] += [
            {"bufferView": views[0], "componentType": _FLOAT, "count": len(pos), "type": "VEC3",
             # Required for POSITION; float32 values so they match the data exactly.
             "min": [float(x) for x in pos.min(axis=0)],
             "max": [float(x) for x in pos.max(axis=0)]},
            {"bufferView": views[1], "componentType": _UNSIGNED_INT, "count": len(idx),
             "type": "SCALAR"},
        ]
        doc["meshes"].append({"name": name, "primitives": [
            {"attributes": {"POSITION": a}, "indices": a + 1, "mode": _TRIANGLES}]})
        doc["nodes"].append({"name": name, "mesh": k})
    doc["buffers"].append({"byteLength": len(blob)})
    body = _pad(json.dumps(doc, separators=(",", ":")).encode("utf-8"), b" ")
    chunks = (struct.pack("<I4s", len(body), b"JSON") + body
              + struct.pack("<I4s", len(blob), b"BIN\0") + bytes(blob))
    return struct.pack("<4sII", b"glTF", 2, 12 + len(chunks)) + chunks
