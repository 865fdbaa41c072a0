//! The point-cloud layer as one binary little-endian PLY: every instance's fused points
//! (`x`, `y`, `z` float32, world frame, metres), coloured by class (SemanticKITTI's colours)
//! or by instance (a fixed colour per node id), with the instance's node id in `node`.
//! The header's comments say the frame and the colouring.

use std::io::Write;

use graphstore::GraphRead;

use super::MapLayers;
use crate::classes::class_colour;
use crate::names::payload;

/// How points are coloured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum PlyColour {
    /// By the instance's SemanticKITTI class.
    #[default]
    Class,
    /// One colour per instance, fixed by its node id.
    Instance,
}

/// What a PLY export wrote.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PlyExport {
    /// Points written.
    pub points: u64,
    /// Instances that had points.
    pub instances: u64,
}

/// A bright colour fixed by `id` (splitmix64 of the id, each channel in 64..=255).
pub fn instance_colour(id: u64) -> (u8, u8, u8) {
    let mut z = id.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^= z >> 31;
    let c = |s: u32| 64 + ((z >> s) & 0xff) as u8 % 192;
    (c(0), c(8), c(16))
}

fn io(e: std::io::Error) -> crate::Error {
    crate::Error::Store(graphstore::Error::Io {
        path: "<ply>".into(),
        error: e,
    })
}

/// Writes every instance's points as PLY to `out`.
///
/// # Errors
/// The store fails, a node id does not fit the `node` property (32 bits), or `out` fails.
pub fn write(
    r: &impl GraphRead,
    m: &MapLayers,
    colour: PlyColour,
    out: &mut dyn Write,
) -> crate::Result<PlyExport> {
    let mut clouds = Vec::new();
    let mut n = 0u64;
    for (id, i) in &m.instances {
        let Some(pc) = r.point_cloud(*id, payload::POINTS)? else {
            continue;
        };
        if pc.xyz.is_empty() {
            continue;
        }
        let node = u32::try_from(*id).map_err(|_| {
            crate::Error::Invalid(format!("node id {id} does not fit the PLY's uint node"))
        })?;
        let rgb = match colour {
            PlyColour::Class => class_colour(&i.semantic_class),
            PlyColour::Instance => instance_colour(*id),
        };
        n += pc.xyz.len() as u64;
        clouds.push((node, rgb, pc.xyz));
    }
    let header = format!(
        "ply\nformat binary_little_endian 1.0\n\
         comment OpenGraph point-cloud layer: every instance's fused points\n\
         comment frame: {}\n\
         comment colour: {}\n\
         element vertex {n}\n\
         property float x\nproperty float y\nproperty float z\n\
         property uchar red\nproperty uchar green\nproperty uchar blue\n\
         property uint node\nend_header\n",
        m.frame_words(),
        match colour {
            PlyColour::Class => "by SemanticKITTI class",
            PlyColour::Instance => "by instance",
        }
    );
    out.write_all(header.as_bytes()).map_err(io)?;
    let mut buf = Vec::with_capacity(19 * 4096);
    for (node, (r8, g8, b8), xyz) in &clouds {
        for p in xyz {
            for c in p {
                buf.extend_from_slice(&c.to_le_bytes());
            }
            buf.extend_from_slice(&[*r8, *g8, *b8]);
            buf.extend_from_slice(&node.to_le_bytes());
            if buf.len() >= 19 * 4096 {
                out.write_all(&buf).map_err(io)?;
                buf.clear();
            }
        }
    }
    out.write_all(&buf).map_err(io)?;
    Ok(PlyExport {
        points: n,
        instances: clouds.len() as u64,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn instance_colours_are_fixed_and_bright() {
        assert_eq!(instance_colour(7), instance_colour(7));
        assert_ne!(instance_colour(7), instance_colour(8));
        for id in 0..100 {
            let (r, g, b) = instance_colour(id);
            assert!(r >= 64 && g >= 64 && b >= 64);
        }
    }
}
