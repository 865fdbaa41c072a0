//! Rigid transforms and camera projections on nalgebra.
//!
//! Names say which frame a transform maps from and to: `world_from_velo` takes a point in the
//! Velodyne frame to the world frame. Files and the store keep them as 12 row-major numbers
//! `[R | t]` (KITTI's `poses.txt` and `calib.txt` layout); [`rigid_from_row_major`] and
//! [`row_major`] convert exactly, with no re-orthonormalisation, so a stored pose reads back
//! bit for bit.

use nalgebra::{Matrix3, Matrix3x4, Point3, Rotation3, Translation3};

/// A rigid transform `[R | t]` with its rotation kept as a matrix.
pub type Rigid3 = nalgebra::IsometryMatrix3<f64>;

/// A 3 × 4 camera projection `P`: homogeneous image point = `P · [x y z 1]ᵀ`.
pub type Projection = Matrix3x4<f64>;

/// The rigid transform of 12 row-major values `[r00 r01 r02 t0 r10 … t2]`; `None` unless
/// there are exactly 12. The rotation block is taken as given (KITTI's are orthonormal to
/// the printed precision).
pub fn rigid_from_row_major(v: &[f64]) -> Option<Rigid3> {
    let m = projection_from_row_major(v)?;
    let r = Rotation3::from_matrix_unchecked(Matrix3::from(m.fixed_view::<3, 3>(0, 0)));
    Some(Rigid3::from_parts(
        Translation3::new(m[(0, 3)], m[(1, 3)], m[(2, 3)]),
        r,
    ))
}

/// The 3 × 4 matrix of 12 row-major values; `None` unless there are exactly 12.
pub fn projection_from_row_major(v: &[f64]) -> Option<Projection> {
    (v.len() == 12).then(|| Projection::from_row_slice(v))
}

/// The 12 row-major values of a rigid transform, `[R | t]`.
pub fn row_major(t: &Rigid3) -> [f64; 12] {
    matrix_row_major(&t.to_matrix().fixed_view::<3, 4>(0, 0).into_owned())
}

/// The 12 row-major values of a 3 × 4 matrix.
pub fn matrix_row_major(m: &Projection) -> [f64; 12] {
    std::array::from_fn(|i| m[(i / 4, i % 4)])
}

/// `t` applied to the point `p`.
pub fn apply(t: &Rigid3, p: [f64; 3]) -> [f64; 3] {
    (t * Point3::from(p)).into()
}

#[cfg(test)]
// exact values are expected: they are copied or computed from exact inputs
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;

    #[test]
    fn row_major_round_trips_bit_for_bit_and_composes() {
        // a KITTI-style pose: a rotation printed to 6 digits, not exactly orthonormal
        let v = [
            9.999978e-01,
            5.272628e-04,
            -2.066935e-03,
            -4.690294e-02,
            -5.296506e-04,
            9.999992e-01,
            -1.154865e-03,
            -2.839928e-02,
            2.066324e-03,
            1.155958e-03,
            9.999971e-01,
            8.586941e-01,
        ];
        let t = rigid_from_row_major(&v).unwrap();
        assert_eq!(row_major(&t), v);
        assert!(rigid_from_row_major(&v[..11]).is_none());
        // composition and inverse agree with applying in turn
        let s = rigid_from_row_major(&[0., -1., 0., 1., 1., 0., 0., 2., 0., 0., 1., 3.]).unwrap();
        let p = [0.5, -0.25, 2.0];
        let a = apply(&(t * s), p);
        let b = apply(&t, apply(&s, p));
        let back = apply(&(t * s).inverse(), a);
        for k in 0..3 {
            assert!((a[k] - b[k]).abs() < 1e-12);
            assert!((back[k] - p[k]).abs() < 1e-5, "inverse of a near-rotation");
        }
        assert_eq!(apply(&s, [0.0; 3]), [1.0, 2.0, 3.0]);
        // a projection composes with the homogeneous matrix of a pose
        let k =
            projection_from_row_major(&[2., 0., 1., 0., 0., 2., 1., 0., 0., 0., 1., 0.]).unwrap();
        let h = k * s.to_homogeneous() * nalgebra::Vector4::new(p[0], p[1], p[2], 1.0);
        let q = apply(&s, p);
        assert!((h.x - (2.0 * q[0] + q[2])).abs() < 1e-12 && (h.z - q[2]).abs() < 1e-12);
        assert_eq!(matrix_row_major(&k)[0], 2.0);
    }
}
