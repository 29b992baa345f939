//! BVH motion capture files of the SMPL skeleton: writing (60 fps, centimetres, `Zrotation Yrotation Xrotation`
//! channels, which Blender and most tools import) and reading back to joint positions.
//!
//! BVH's recursion is the same as SMPL forward kinematics (SPEC §3.3): a joint's position is its parent's plus
//! the parent's global rotation applied to the offset, and its global rotation is the parent's times its own.

use std::fmt::Write as _;
use std::path::Path;

use crate::fk::FkRoot;
use crate::motion::{Motion, FPS};
use crate::rotation::{axis_angle_to_matrix, mat_vec, matmul, matrix_to_euler_zyx_deg, Mat3};
use crate::skeleton::{JOINT_NAMES, NUM_JOINTS, OFFSETS, PARENTS, SMPL_MALE_PELVIS};
use qean_io::error::{Error, Result};
use qean_io::fsutil::atomic_write;

/// BVH length unit: centimetres per metre.
const CM: f64 = 100.0;

/// Largest frame count we accept when reading (a day at 60 fps); guards allocation on malformed headers.
const MAX_FRAMES: usize = 60 * 60 * 60 * 24;

/// End-site offsets (metres) for the leaf joints, roughly continuing each bone.
fn end_site(j: usize) -> [f64; 3] {
    match j {
        10 | 11 => [0.0, -0.02, 0.08], // toes
        15 => [0.0, 0.18, 0.0],        // head top
        22 => [0.08, 0.0, 0.0],        // left fingers
        23 => [-0.08, 0.0, 0.0],       // right fingers
        _ => [0.0, 0.05, 0.0],
    }
}

/// SMPL joints in the depth-first order the hierarchy lists them (and the MOTION channels follow).
pub fn hierarchy_order() -> Vec<usize> {
    fn visit(j: usize, out: &mut Vec<usize>) {
        out.push(j);
        for (c, &p) in PARENTS.iter().enumerate() {
            if p == j as i32 {
                visit(c, out);
            }
        }
    }
    let mut out = Vec::with_capacity(NUM_JOINTS);
    visit(0, &mut out);
    out
}

/// Render a motion as BVH text. The root channel carries the pelvis position under `root`'s convention.
pub fn to_bvh(motion: &Motion, root: FkRoot) -> String {
    let mut s = String::new();
    s.push_str("HIERARCHY\n");
    fn write_joint(s: &mut String, j: usize, depth: usize) {
        let ind = "  ".repeat(depth);
        let o = OFFSETS[j];
        if j == 0 {
            let _ = writeln!(s, "ROOT {}", JOINT_NAMES[j]);
        } else {
            let _ = writeln!(s, "{ind}JOINT {}", JOINT_NAMES[j]);
        }
        let _ = writeln!(s, "{ind}{{");
        let _ = writeln!(
            s,
            "{ind}  OFFSET {:.6} {:.6} {:.6}",
            o[0] * CM,
            o[1] * CM,
            o[2] * CM
        );
        if j == 0 {
            let _ = writeln!(
                s,
                "{ind}  CHANNELS 6 Xposition Yposition Zposition Zrotation Yrotation Xrotation"
            );
        } else {
            let _ = writeln!(s, "{ind}  CHANNELS 3 Zrotation Yrotation Xrotation");
        }
        let children: Vec<usize> = (0..NUM_JOINTS)
            .filter(|&c| PARENTS[c] == j as i32)
            .collect();
        if children.is_empty() {
            let e = end_site(j);
            let _ = writeln!(s, "{ind}  End Site");
            let _ = writeln!(s, "{ind}  {{");
            let _ = writeln!(
                s,
                "{ind}    OFFSET {:.6} {:.6} {:.6}",
                e[0] * CM,
                e[1] * CM,
                e[2] * CM
            );
            let _ = writeln!(s, "{ind}  }}");
        }
        for c in children {
            write_joint(s, c, depth + 1);
        }
        let _ = writeln!(s, "{ind}}}");
    }
    write_joint(&mut s, 0, 0);
    let order = hierarchy_order();
    let shift = match root {
        FkRoot::Smpl => SMPL_MALE_PELVIS,
        FkRoot::Edge => [0.0; 3],
    };
    let _ = writeln!(
        s,
        "MOTION\nFrames: {}\nFrame Time: {:.7}",
        motion.frames,
        1.0 / FPS
    );
    let roots = motion.root_positions();
    for (t, p) in roots.iter().enumerate() {
        let mut line = format!(
            "{:.5} {:.5} {:.5}",
            (p[0] + shift[0]) * CM,
            (p[1] + shift[1]) * CM,
            (p[2] + shift[2]) * CM
        );
        for &j in &order {
            let r = &motion.poses[t * 72 + 3 * j..t * 72 + 3 * j + 3];
            let [z, y, x] = matrix_to_euler_zyx_deg(&axis_angle_to_matrix([r[0], r[1], r[2]]));
            let _ = write!(line, " {z:.5} {y:.5} {x:.5}");
        }
        s.push_str(&line);
        s.push('\n');
    }
    s
}

/// Write a motion as a BVH file, atomically.
pub fn write(path: &Path, motion: &Motion, root: FkRoot) -> Result<()> {
    atomic_write(path, to_bvh(motion, root).as_bytes())
}

/// A parsed BVH file reduced to what we need: joint names, parents, and world joint positions per frame.
#[derive(Debug, Clone)]
pub struct BvhMotion {
    pub names: Vec<String>,
    pub parents: Vec<i32>,
    pub frame_time: f64,
    pub frames: usize,
    /// frames × joints, metres (the file's units divided by `unit_scale`).
    pub positions: Vec<[f64; 3]>,
}

struct JointDef {
    parent: i32,
    offset: [f64; 3],
    channels: Vec<String>,
}

impl BvhMotion {
    /// Positions (frames × 24) in SMPL joint order, if the file's joints are exactly the SMPL joints by name.
    pub fn smpl_positions(&self) -> Option<Vec<[f64; 3]>> {
        if self.names.len() != NUM_JOINTS {
            return None;
        }
        let idx: Option<Vec<usize>> = JOINT_NAMES
            .iter()
            .map(|n| self.names.iter().position(|m| m == n))
            .collect();
        let idx = idx?;
        let n = self.names.len();
        Some(
            (0..self.frames)
                .flat_map(|t| idx.iter().map(move |&k| self.positions[t * n + k]))
                .collect(),
        )
    }
}

/// Whitespace-separated BVH tokens; running out is an error naming what was expected.
struct Tokens<'a>(std::str::SplitWhitespace<'a>);

impl<'a> Tokens<'a> {
    fn next(&mut self, what: &str) -> std::result::Result<&'a str, String> {
        self.0
            .next()
            .ok_or_else(|| format!("unexpected end of file reading {what}"))
    }
}

/// The HIERARCHY section: joints (parent, offset, channels) in file order, and their names.
fn parse_hierarchy(
    tokens: &mut Tokens,
    unit_scale: f64,
) -> std::result::Result<(Vec<JointDef>, Vec<String>), String> {
    let mut next = |what: &str| tokens.next(what);
    if next("HIERARCHY")? != "HIERARCHY" {
        return Err("missing HIERARCHY".into());
    }
    let mut joints: Vec<JointDef> = Vec::new();
    let mut names = Vec::new();
    let mut stack: Vec<i32> = Vec::new();
    let mut in_end_site = false;
    let mut pending: Option<(String, i32)> = None;
    loop {
        let tok = next("hierarchy")?;
        match tok {
            "ROOT" | "JOINT" => {
                let name = next("joint name")?.to_string();
                let parent = if tok == "ROOT" {
                    if !joints.is_empty() {
                        return Err("more than one ROOT".into());
                    }
                    -1
                } else {
                    *stack.last().ok_or("JOINT outside ROOT")?
                };
                pending = Some((name, parent));
            }
            "End" => {
                next("Site")?;
                in_end_site = true;
            }
            "{" => {
                if in_end_site {
                    continue;
                }
                let (name, parent) = pending.take().ok_or("unexpected '{'")?;
                joints.push(JointDef {
                    parent,
                    offset: [0.0; 3],
                    channels: vec![],
                });
                names.push(name);
                stack.push(joints.len() as i32 - 1);
                if joints.len() > 1000 {
                    return Err("too many joints".into());
                }
            }
            "}" => {
                if in_end_site {
                    in_end_site = false;
                } else {
                    stack.pop().ok_or("unbalanced '}'")?;
                    if stack.is_empty() {
                        break;
                    }
                }
            }
            "OFFSET" => {
                let mut o = [0.0; 3];
                for v in o.iter_mut() {
                    *v = next("offset")?
                        .parse::<f64>()
                        .map_err(|_| "bad OFFSET value")?
                        / unit_scale;
                }
                if !in_end_site {
                    let j = *stack.last().ok_or("OFFSET outside a joint")? as usize;
                    joints[j].offset = o;
                }
            }
            "CHANNELS" => {
                let n: usize = next("channel count")?
                    .parse()
                    .map_err(|_| "bad CHANNELS count")?;
                if n > 6 {
                    return Err("more than 6 channels".into());
                }
                let j = *stack.last().ok_or("CHANNELS outside a joint")? as usize;
                for _ in 0..n {
                    joints[j].channels.push(next("channel")?.to_string());
                }
            }
            other => return Err(format!("unexpected token '{other}' in HIERARCHY")),
        }
    }
    Ok((joints, names))
}

/// The MOTION header: frame count and frame time.
fn parse_motion_header(tokens: &mut Tokens) -> std::result::Result<(usize, f64), String> {
    let mut next = |what: &str| tokens.next(what);
    if next("MOTION")? != "MOTION" {
        return Err("missing MOTION".into());
    }
    if next("Frames:")? != "Frames:" {
        return Err("missing 'Frames:'".into());
    }
    let frames: usize = next("frame count")?
        .parse()
        .map_err(|_| "bad frame count")?;
    if frames > MAX_FRAMES {
        return Err(format!("frame count {frames} is implausibly large"));
    }
    if next("Frame")? != "Frame" || next("Time:")? != "Time:" {
        return Err("missing 'Frame Time:'".into());
    }
    let frame_time: f64 = next("frame time")?.parse().map_err(|_| "bad frame time")?;
    Ok((frames, frame_time))
}

/// Joint positions of one frame from its channel values (positions divided by `unit_scale`).
fn frame_positions(
    joints: &[JointDef],
    values: &[f64],
    unit_scale: f64,
) -> std::result::Result<Vec<[f64; 3]>, String> {
    let mut k = 0;
    let mut global: Vec<Mat3> = Vec::with_capacity(joints.len());
    let mut pos: Vec<[f64; 3]> = Vec::with_capacity(joints.len());
    for j in joints {
        let mut local = crate::rotation::IDENTITY;
        let mut p = j.offset;
        for ch in &j.channels {
            let v = values[k];
            k += 1;
            let rad = v.to_radians();
            match ch.as_str() {
                "Xposition" => p[0] = v / unit_scale,
                "Yposition" => p[1] = v / unit_scale,
                "Zposition" => p[2] = v / unit_scale,
                "Xrotation" => local = matmul(&local, &axis_angle_to_matrix([rad, 0.0, 0.0])),
                "Yrotation" => local = matmul(&local, &axis_angle_to_matrix([0.0, rad, 0.0])),
                "Zrotation" => local = matmul(&local, &axis_angle_to_matrix([0.0, 0.0, rad])),
                other => return Err(format!("unknown channel '{other}'")),
            }
        }
        if j.parent < 0 {
            global.push(local);
            pos.push(p);
        } else {
            let pj = j.parent as usize;
            let o = mat_vec(&global[pj], j.offset);
            pos.push([pos[pj][0] + o[0], pos[pj][1] + o[1], pos[pj][2] + o[2]]);
            global.push(matmul(&global[pj], &local));
        }
    }
    Ok(pos)
}

/// Parse BVH text; positions are divided by `unit_scale` (100 for centimetre files).
pub fn parse(text: &str, unit_scale: f64) -> std::result::Result<BvhMotion, String> {
    let mut tokens = Tokens(text.split_whitespace());
    let (joints, names) = parse_hierarchy(&mut tokens, unit_scale)?;
    let (frames, frame_time) = parse_motion_header(&mut tokens)?;
    let nch: usize = joints.iter().map(|j| j.channels.len()).sum();
    let mut positions = Vec::with_capacity(frames * joints.len());
    let mut values = vec![0.0f64; nch];
    for f in 0..frames {
        for v in values.iter_mut() {
            *v = tokens
                .next("motion data")?
                .parse()
                .map_err(|_| format!("bad number in frame {f}"))?;
        }
        positions.extend(frame_positions(&joints, &values, unit_scale)?);
    }
    Ok(BvhMotion {
        parents: joints.iter().map(|j| j.parent).collect(),
        names,
        frame_time,
        frames,
        positions,
    })
}

/// Read a centimetre BVH file (as we write them) into joint positions in metres.
pub fn read(path: &Path) -> Result<BvhMotion> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    parse(&text, CM).map_err(|m| Error::at(path, format!("not a readable BVH file: {m}")))
}

#[cfg(test)]
mod tests {
    use super::*;
    use qean_io::testdata::shared_dir;

    #[test]
    fn bvh_round_trip_reproduces_forward_kinematics() {
        let m = Motion::read_pkl(
            &shared_dir().join("aistpp/motions/softcat477_SMPL-to-FBX_sample.pkl"),
        )
        .unwrap();
        for root in [FkRoot::Smpl, FkRoot::Edge] {
            let text = to_bvh(&m, root);
            let b = parse(&text, CM).unwrap();
            assert_eq!(b.frames, 127);
            assert_eq!(b.names.len(), 24);
            let order = hierarchy_order();
            for (k, &j) in order.iter().enumerate() {
                assert_eq!(b.names[k], JOINT_NAMES[j]);
            }
            assert!((b.frame_time - 1.0 / 60.0).abs() < 1e-7);
            let fk = m.joints(root);
            let err = fk
                .iter()
                .zip(&b.smpl_positions().unwrap())
                .flat_map(|(a, c)| (0..3).map(move |k| (a[k] - c[k]).abs()))
                .fold(0.0, f64::max);
            // Text rounding: 1e-5 degrees and 1e-5 cm.
            assert!(err < 1e-5, "max joint error {err} m");
        }
    }

    #[test]
    fn malformed_bvh() {
        let m = Motion::read_pkl(
            &shared_dir().join("aistpp/motions/softcat477_SMPL-to-FBX_sample.pkl"),
        )
        .unwrap();
        let text = to_bvh(&m.slice(0, 3), FkRoot::Smpl);
        for cut in [0, 10, text.len() / 2, text.len() - 20] {
            assert!(parse(&text[..cut], CM).is_err(), "prefix {cut} parsed");
        }
        assert!(parse(&text.replace("Frames: 3", "Frames: 99999999999"), CM).is_err());
        assert!(parse("HIERARCHY ROOT a { OFFSET 0 0 0 CHANNELS 9", CM).is_err());
    }
}
