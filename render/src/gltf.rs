//! glTF 2.0 export of a dance (`.glb`, or `.gltf` with the buffer embedded as a data URI): the SMPL skeleton
//! as a node hierarchy (each joint a node, its rest offset from the parent as the node's translation), animated
//! at 60 fps by one rotation channel per joint (the pose's local rotations as unit quaternions, kept in one
//! hemisphere so that glTF's slerp takes the short way) and the root's translation. A glTF viewer or Blender
//! (File > Import > glTF 2.0) shows the skeleton moving; positions are the motion's forward kinematics.

use std::path::Path;

use qean_io::error::{Error, Result};
use qean_motion::fk::FkRoot;
use qean_motion::motion::{Motion, FPS};
use qean_motion::rotation::matrix_to_quaternion;
use qean_motion::skeleton::{JOINT_NAMES, NUM_JOINTS, OFFSETS, PARENTS, SMPL_MALE_PELVIS};
use qean_motion::vec3::{cross, norm, sub};
use serde_json::{json, Value};

/// glTF's FLOAT component type.
const FLOAT: u32 = 5126;

/// glTF's UNSIGNED_SHORT component type and the buffer-view targets of vertex attributes and indices.
const UNSIGNED_SHORT: u32 = 5123;
const ARRAY_BUFFER: u32 = 34962;
const ELEMENT_ARRAY_BUFFER: u32 = 34963;

/// The binary buffer with one buffer view per accessor, each 4-byte aligned.
#[derive(Default)]
struct Buffer {
    bin: Vec<u8>,
    views: Vec<Value>,
    accessors: Vec<Value>,
}

impl Buffer {
    /// An accessor over `bytes` (little-endian values of `component`), `count` elements of `kind`; `extra`
    /// (min/max) is merged in. Returns its index.
    fn push(
        &mut self,
        bytes: Vec<u8>,
        component: u32,
        count: usize,
        kind: &str,
        target: Option<u32>,
        extra: Value,
    ) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let mut view =
            json!({"buffer": 0, "byteOffset": self.bin.len(), "byteLength": bytes.len()});
        if let Some(t) = target {
            view["target"] = json!(t);
        }
        self.bin.extend(bytes);
        self.views.push(view);
        let mut a = json!({
            "bufferView": self.views.len() - 1,
            "componentType": component,
            "count": count,
            "type": kind,
        });
        if let (Value::Object(a), Value::Object(e)) = (&mut a, extra) {
            a.extend(e);
        }
        self.accessors.push(a);
        self.accessors.len() - 1
    }

    fn floats(&mut self, values: &[f32], kind: &str, target: Option<u32>, extra: Value) -> usize {
        let width = match kind {
            "SCALAR" => 1,
            "VEC3" => 3,
            "VEC4" => 4,
            _ => 16,
        };
        let bytes = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        self.push(bytes, FLOAT, values.len() / width, kind, target, extra)
    }

    fn shorts(&mut self, values: &[u16], kind: &str, target: u32) -> usize {
        let width = if kind == "SCALAR" { 1 } else { 4 };
        let bytes = values.iter().flat_map(|v| v.to_le_bytes()).collect();
        self.push(
            bytes,
            UNSIGNED_SHORT,
            values.len() / width,
            kind,
            Some(target),
            json!({}),
        )
    }
}

/// `a` at unit length (a near-zero vector stays near zero instead of dividing by 0).
fn unit(a: [f64; 3]) -> [f64; 3] {
    let n = norm(a).max(1e-12);
    a.map(|v| v / n)
}

/// A box of half-width `w` from `a` to `b` (8 corners, 12 outward-facing triangles), appended to `verts`
/// and `tris`, every corner bound to joint `joint`.
fn bone_box(
    a: [f64; 3],
    b: [f64; 3],
    w: f64,
    joint: u16,
    verts: &mut Vec<([f64; 3], u16)>,
    tris: &mut Vec<u16>,
) {
    let dir = unit(sub(b, a));
    let helper = if dir[1].abs() < 0.9 {
        [0.0, 1.0, 0.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let u = unit(cross(dir, helper));
    let v = cross(dir, u);
    let base = verts.len() as u16;
    for end in [a, b] {
        for (su, sv) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
            verts.push((
                std::array::from_fn(|k| end[k] + w * (su * u[k] + sv * v[k])),
                joint,
            ));
        }
    }
    let centre: [f64; 3] = std::array::from_fn(|k| (a[k] + b[k]) / 2.0);
    let faces = [
        [0, 1, 2, 3],
        [4, 5, 6, 7],
        [0, 1, 5, 4],
        [1, 2, 6, 5],
        [2, 3, 7, 6],
        [3, 0, 4, 7],
    ];
    for f in faces {
        for t in [[f[0], f[1], f[2]], [f[0], f[2], f[3]]] {
            let p = t.map(|i| verts[base as usize + i].0);
            let normal = cross(sub(p[1], p[0]), sub(p[2], p[0]));
            let out = sub(p[0], centre);
            let flip = normal.iter().zip(&out).map(|(x, y)| x * y).sum::<f64>() < 0.0;
            let t = if flip { [t[0], t[2], t[1]] } else { t };
            tris.extend(t.map(|i| base + i as u16));
        }
    }
}

/// A simple body skinned to the skeleton: a box along every bone, bound rigidly to the bone's parent joint, and
/// a head. Returns the mesh and the skin (bind pose: the rest pose with the pelvis at the origin).
fn body(buf: &mut Buffer) -> (Value, Value) {
    let rest = qean_motion::skeleton::rest_joints([0.0; 3]);
    let (mut verts, mut tris) = (Vec::new(), Vec::new());
    for j in 1..NUM_JOINTS {
        let p = PARENTS[j] as usize;
        let w = if [3, 6, 9, 1, 2].contains(&j) {
            0.07
        } else {
            0.035
        };
        bone_box(rest[p], rest[j], w, p as u16, &mut verts, &mut tris);
    }
    let head = rest[15];
    bone_box(
        head,
        [head[0], head[1] + 0.2, head[2]],
        0.09,
        15,
        &mut verts,
        &mut tris,
    );
    let positions: Vec<f32> = verts
        .iter()
        .flat_map(|(p, _)| p.map(|v| v as f32))
        .collect();
    let (mut lo, mut hi) = ([f32::MAX; 3], [f32::MIN; 3]);
    for p in positions.chunks_exact(3) {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let position = buf.floats(
        &positions,
        "VEC3",
        Some(ARRAY_BUFFER),
        json!({"min": lo, "max": hi}),
    );
    let joints: Vec<u16> = verts.iter().flat_map(|(_, j)| [*j, 0, 0, 0]).collect();
    let joints = buf.shorts(&joints, "VEC4", ARRAY_BUFFER);
    let weights: Vec<f32> = verts.iter().flat_map(|_| [1.0, 0.0, 0.0, 0.0]).collect();
    let weights = buf.floats(&weights, "VEC4", Some(ARRAY_BUFFER), json!({}));
    let indices = buf.shorts(&tris, "SCALAR", ELEMENT_ARRAY_BUFFER);
    // Inverse bind matrices: the inverse of each joint's rest transform (a translation), column-major.
    let ibm: Vec<f32> = rest
        .iter()
        .flat_map(|p| {
            let mut m = [0.0f32; 16];
            m[0] = 1.0;
            m[5] = 1.0;
            m[10] = 1.0;
            m[15] = 1.0;
            for k in 0..3 {
                m[12 + k] = -p[k] as f32;
            }
            m
        })
        .collect();
    let ibm = buf.floats(&ibm, "MAT4", None, json!({}));
    let mesh = json!({
        "name": "body",
        "primitives": [{
            "attributes": {"POSITION": position, "JOINTS_0": joints, "WEIGHTS_0": weights},
            "indices": indices,
            "material": 0,
        }],
    });
    let skin = json!({"joints": (0..NUM_JOINTS).collect::<Vec<_>>(), "inverseBindMatrices": ibm, "skeleton": 0});
    (mesh, skin)
}

/// The binary buffer and the JSON document (without its buffer URI) of a motion.
fn document(motion: &Motion, root: FkRoot) -> (Vec<u8>, Value) {
    let frames = motion.frames;
    let mut buf = Buffer::default();
    let mut push = |values: &[f32], kind: &str, extra: Value| -> usize {
        buf.floats(values, kind, None, extra)
    };
    let times: Vec<f32> = (0..frames).map(|f| (f as f64 / FPS) as f32).collect();
    let last = *times.last().unwrap_or(&0.0);
    let time = push(&times, "SCALAR", json!({"min": [0.0], "max": [last]}));
    let pelvis = match root {
        FkRoot::Smpl => SMPL_MALE_PELVIS,
        FkRoot::Edge => [0.0; 3],
    };
    let roots: Vec<[f32; 3]> = motion
        .root_positions()
        .iter()
        .map(|p| std::array::from_fn(|k| (p[k] + pelvis[k]) as f32))
        .collect();
    let translation = push(&roots.concat(), "VEC3", json!({}));
    let rotations = motion.rotations();
    let mut samplers =
        vec![json!({"input": time, "output": translation, "interpolation": "LINEAR"})];
    let mut channels = vec![json!({"sampler": 0, "target": {"node": 0, "path": "translation"}})];
    let mut first = Vec::new();
    for j in 0..NUM_JOINTS {
        let mut q_prev = [0.0f64, 0.0, 0.0, 1.0];
        let mut values = Vec::with_capacity(4 * frames);
        for f in 0..frames {
            let [w, x, y, z] = matrix_to_quaternion(&rotations[f * NUM_JOINTS + j]);
            let mut q = [x, y, z, w];
            if f > 0 && q.iter().zip(&q_prev).map(|(a, b)| a * b).sum::<f64>() < 0.0 {
                q = q.map(|v| -v);
            }
            values.extend(q.iter().map(|&v| v as f32));
            q_prev = q;
        }
        first.push(values[..4].to_vec());
        let output = push(&values, "VEC4", json!({}));
        samplers.push(json!({"input": time, "output": output, "interpolation": "LINEAR"}));
        channels.push(
            json!({"sampler": samplers.len() - 1, "target": {"node": j, "path": "rotation"}}),
        );
    }
    let mut nodes: Vec<Value> = (0..NUM_JOINTS)
        .map(|j| {
            let t: [f64; 3] = if j == 0 {
                roots[0].map(|v| v as f64)
            } else {
                OFFSETS[j]
            };
            let children: Vec<usize> = (0..NUM_JOINTS)
                .filter(|&c| PARENTS[c] == j as i32)
                .collect();
            let mut n = json!({"name": JOINT_NAMES[j], "translation": t, "rotation": first[j]});
            if !children.is_empty() {
                n["children"] = json!(children);
            }
            n
        })
        .collect();
    let (mesh, skin) = body(&mut buf);
    nodes.push(json!({"name": "body", "mesh": 0, "skin": 0}));
    let doc = json!({
        "asset": {"version": "2.0", "generator": concat!("qean ", env!("CARGO_PKG_VERSION"))},
        "scene": 0,
        "scenes": [{"name": "dance", "nodes": [0, NUM_JOINTS]}],
        "nodes": nodes,
        "meshes": [mesh],
        "skins": [skin],
        "materials": [{
            "name": "figure",
            "doubleSided": true,
            "pbrMetallicRoughness": {"baseColorFactor": [0.35, 0.55, 0.85, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.8},
        }],
        "animations": [{"name": "dance", "samplers": samplers, "channels": channels}],
        "buffers": [{"byteLength": buf.bin.len()}],
        "bufferViews": buf.views,
        "accessors": buf.accessors,
    });
    (buf.bin, doc)
}

/// The motion as a binary glTF (GLB): header, JSON chunk (space-padded), BIN chunk (zero-padded).
pub fn to_glb(motion: &Motion, root: FkRoot) -> Vec<u8> {
    let (mut bin, doc) = document(motion, root);
    let mut json = serde_json::to_vec(&doc).expect("JSON values serialise");
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

/// Standard base64 with padding.
pub(crate) fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::with_capacity(bytes.len().div_ceil(3) * 4);
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for (i, shift) in [18, 12, 6, 0].into_iter().enumerate() {
            if i <= c.len() {
                s.push(A[(n >> shift & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// The motion as a `.gltf` JSON document with its buffer embedded as a data URI.
pub fn to_gltf(motion: &Motion, root: FkRoot) -> String {
    let (bin, mut doc) = document(motion, root);
    doc["buffers"][0]["uri"] = json!(format!(
        "data:application/octet-stream;base64,{}",
        base64(&bin)
    ));
    serde_json::to_string_pretty(&doc).expect("JSON values serialise")
}

/// Writes `.glb` or `.gltf` (by the extension) atomically.
pub fn write(path: &Path, motion: &Motion, root: FkRoot) -> Result<()> {
    let bytes = match qean_io::fsutil::extension_lower(path).as_str() {
        "glb" => to_glb(motion, root),
        "gltf" => to_gltf(motion, root).into_bytes(),
        _ => return Err(Error::at(path, "a glTF file ends in .glb or .gltf")),
    };
    qean_io::fsutil::atomic_write(path, &bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A moving test motion: every joint turning about a different axis, the root travelling.
    fn motion(frames: usize) -> Motion {
        let mut poses = Vec::new();
        let mut trans = Vec::new();
        for f in 0..frames {
            let t = f as f64 / 60.0;
            for j in 0..NUM_JOINTS {
                let a = 0.8 * (t * 3.0 + j as f64).sin();
                poses.extend([a * 0.6, a * 0.3 * (j % 3) as f64, -a * 0.5]);
            }
            trans.extend([0.3 * t, 0.9 + 0.05 * (t * 5.0).sin(), -0.2 * t]);
        }
        Motion::new(poses, trans, 1.0).unwrap()
    }

    fn chunk_json(glb: &[u8]) -> (Value, &[u8]) {
        let u32_at = |i: usize| u32::from_le_bytes(glb[i..i + 4].try_into().unwrap()) as usize;
        assert_eq!(&glb[..4], b"glTF");
        assert_eq!(u32_at(4), 2);
        assert_eq!(u32_at(8), glb.len());
        let json_len = u32_at(12);
        assert_eq!(&glb[16..20], b"JSON");
        let doc = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
        let b = 20 + json_len;
        assert_eq!(&glb[b + 4..b + 8], b"BIN\0");
        (doc, &glb[b + 8..b + 8 + u32_at(b)])
    }

    fn accessor(doc: &Value, bin: &[u8], i: usize) -> Vec<f32> {
        let a = &doc["accessors"][i];
        let v = &doc["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
        let (off, len) = (
            v["byteOffset"].as_u64().unwrap() as usize,
            v["byteLength"].as_u64().unwrap() as usize,
        );
        bin[off..off + len]
            .chunks_exact(4)
            .map(|c| f32::from_le_bytes(c.try_into().unwrap()))
            .collect()
    }

    fn rotate(q: [f64; 4], v: [f64; 3]) -> [f64; 3] {
        let [x, y, z, w] = q;
        // v + 2w(u × v) + 2u × (u × v), u = (x, y, z).
        let u = [x, y, z];
        let t = cross(u, v).map(|c| 2.0 * c);
        let ut = cross(u, t);
        std::array::from_fn(|k| v[k] + w * t[k] + ut[k])
    }

    fn mul(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
        let [ax, ay, az, aw] = a;
        let [bx, by, bz, bw] = b;
        [
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
            aw * bw - ax * bx - ay * by - az * bz,
        ]
    }

    /// Reading the GLB back through its node transforms reproduces the motion's joint positions (to 1e-4 m)
    /// at 60 fps keys, for both root conventions.
    #[test]
    fn glb_round_trips_the_joint_positions() {
        for root in [FkRoot::Smpl, FkRoot::Edge] {
            let m = motion(90);
            let glb = to_glb(&m, root);
            let (doc, bin) = chunk_json(&glb);
            assert_eq!(doc["nodes"].as_array().unwrap().len(), NUM_JOINTS + 1);
            let anim = &doc["animations"][0];
            let times = accessor(&doc, bin, 0);
            assert_eq!(times.len(), 90);
            for (f, t) in times.iter().enumerate() {
                assert!((*t as f64 - f as f64 / 60.0).abs() < 1e-6);
            }
            let channel_of = |node: usize, path: &str| -> Vec<f32> {
                let c = anim["channels"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .find(|c| c["target"]["node"] == node && c["target"]["path"] == path)
                    .unwrap();
                let s = &anim["samplers"][c["sampler"].as_u64().unwrap() as usize];
                accessor(&doc, bin, s["output"].as_u64().unwrap() as usize)
            };
            let root_t = channel_of(0, "translation");
            let rots: Vec<Vec<f32>> = (0..NUM_JOINTS).map(|j| channel_of(j, "rotation")).collect();
            let want = m.joints(root);
            for f in [0, 1, 45, 89] {
                let mut world_q = vec![[0.0, 0.0, 0.0, 1.0]; NUM_JOINTS];
                let mut world_p = vec![[0.0; 3]; NUM_JOINTS];
                for j in 0..NUM_JOINTS {
                    let q: [f64; 4] = std::array::from_fn(|k| rots[j][4 * f + k] as f64);
                    if j == 0 {
                        world_p[0] = std::array::from_fn(|k| root_t[3 * f + k] as f64);
                        world_q[0] = q;
                    } else {
                        let p = PARENTS[j] as usize;
                        let off = rotate(world_q[p], OFFSETS[j]);
                        world_p[j] = std::array::from_fn(|k| world_p[p][k] + off[k]);
                        world_q[j] = mul(world_q[p], q);
                    }
                    let w = want[f * NUM_JOINTS + j];
                    let d = (0..3)
                        .map(|k| (world_p[j][k] - w[k]).powi(2))
                        .sum::<f64>()
                        .sqrt();
                    assert!(d < 1e-4, "{root:?} frame {f} joint {j}: {d}");
                }
            }
            // Consecutive keys stay in one hemisphere (slerp takes the short way).
            for r in &rots {
                for f in 1..90 {
                    let dot: f32 = (0..4).map(|k| r[4 * f + k] * r[4 * (f - 1) + k]).sum();
                    assert!(dot >= 0.0);
                }
            }
        }
    }

    #[test]
    fn gltf_embeds_the_same_buffer() {
        let m = motion(5);
        let text = to_gltf(&m, FkRoot::Smpl);
        let doc: Value = serde_json::from_str(&text).unwrap();
        let uri = doc["buffers"][0]["uri"].as_str().unwrap();
        assert!(uri.starts_with("data:application/octet-stream;base64,"));
        assert_eq!(base64(b"glTF!"), "Z2xURiE=");
        assert_eq!(base64(b"ab"), "YWI=");
        assert_eq!(base64(b"abc"), "YWJj");
    }
}
