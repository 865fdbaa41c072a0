//! How the ground plane sits in a world frame.

/// Which world axes span the ground and which way is up.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum GroundFrame {
    /// KITTI's cam0 world: x right, y down, z forward; ground (x, z), up is -y.
    KittiCam,
    /// East-north-up style: ground (x, y), up is +z.
    Enu,
}

impl GroundFrame {
    /// From the `Environment.ground_frame` name (`kitti_cam` or `enu`).
    pub fn from_name(s: &str) -> Option<GroundFrame> {
        match s {
            "kitti_cam" => Some(GroundFrame::KittiCam),
            "enu" => Some(GroundFrame::Enu),
            _ => None,
        }
    }

    /// The `Environment.ground_frame` name.
    pub fn name(self) -> &'static str {
        match self {
            GroundFrame::KittiCam => "kitti_cam",
            GroundFrame::Enu => "enu",
        }
    }

    /// Ground-plane coordinates of a world point.
    pub fn ground(self, p: [f64; 3]) -> [f64; 2] {
        match self {
            GroundFrame::KittiCam => [p[0], p[2]],
            GroundFrame::Enu => [p[0], p[1]],
        }
    }

    /// Height of a world point (positive up).
    pub fn height(self, p: [f64; 3]) -> f64 {
        match self {
            GroundFrame::KittiCam => -p[1],
            GroundFrame::Enu => p[2],
        }
    }

    /// The world point at ground coordinates `g` and height `h`.
    pub fn world(self, g: [f64; 2], h: f64) -> [f64; 3] {
        match self {
            GroundFrame::KittiCam => [g[0], -h, g[1]],
            GroundFrame::Enu => [g[0], g[1], h],
        }
    }

    /// The world axes that span the ground plane, in ground-coordinate order (0 = x, 1 = y,
    /// 2 = z): `[0, 2]` for `kitti_cam`, `[0, 1]` for `enu`.
    pub fn ground_axes(self) -> [usize; 2] {
        match self {
            GroundFrame::KittiCam => [0, 2],
            GroundFrame::Enu => [0, 1],
        }
    }

    /// Which axis is up and what ground coordinates are, in words for people and agents.
    pub fn describe(self) -> &'static str {
        match self {
            GroundFrame::KittiCam => {
                "ground_frame kitti_cam: points are metres in the world frame of KITTI's camera 0 at the first key frame. \
                 The ground plane is world x and z; up is -y (the camera's y axis points down, so a higher point has a smaller y). \
                 Ground coordinates 'x,z' in the tools are world x and z; distances the tools report are on the ground plane unless they say otherwise."
            }
            GroundFrame::Enu => {
                "ground_frame enu: points are metres in an east-north-up world frame. The ground plane is x and y; up is +z. \
                 Ground coordinates 'x,z' in the tools are world x and y (the two ground axes, in order); distances the tools report are on the ground plane unless they say otherwise."
            }
        }
    }

    /// The ground direction to the left of heading `d` (looking along `d`, up as above).
    pub fn left_of(self, d: [f64; 2]) -> [f64; 2] {
        // up x d, expressed in ground coordinates, is the same rotation in both frames
        [-d[1], d[0]]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: [f64; 2], b: [f64; 2]) -> bool {
        (a[0] - b[0]).abs() < 1e-12 && (a[1] - b[1]).abs() < 1e-12
    }

    #[test]
    fn kitti_left_is_minus_x_when_driving_forward() {
        let f = GroundFrame::KittiCam;
        assert!(close(f.left_of([0.0, 1.0]), [-1.0, 0.0]));
        let p = f.world([3.0, 4.0], 1.5);
        assert!(close(f.ground(p), [3.0, 4.0]));
        assert!((f.height(p) - 1.5).abs() < 1e-12);
        assert!((p[1] + 1.5).abs() < 1e-12, "KITTI y points down");
        assert!(close(GroundFrame::Enu.left_of([1.0, 0.0]), [0.0, 1.0]));
        for f in [GroundFrame::KittiCam, GroundFrame::Enu] {
            assert_eq!(GroundFrame::from_name(f.name()), Some(f));
        }
        assert_eq!(GroundFrame::from_name("ned"), None);
    }
}
