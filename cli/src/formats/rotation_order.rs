//! The order in which three angles about x, y and z compose a rotation (docs/formats.md,
//! "Files in other layouts"): any of the six products of Rx, Ry, Rz, written like
//! `"Rx*Ry*Rz"`. kinecal's own is `"Rz*Ry*Rx"` (R = Rz(rz)·Ry(ry)·Rx(rx), the fixed-axis
//! roll-pitch-yaw of a robot file's `rpy_deg`).

use kinecal::Frame;
use nalgebra::{Matrix3, Rotation3, Vector3};

/// One of the six orders: `axes[0]` is the leftmost factor of the product.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct RotationOrder {
    /// Axis indices (0 = x, 1 = y, 2 = z), leftmost factor first.
    pub axes: [usize; 3],
}

impl RotationOrder {
    /// kinecal's own order, R = Rz(rz)·Ry(ry)·Rx(rx).
    pub const KINECAL: RotationOrder = RotationOrder { axes: [2, 1, 0] };

    /// All six orders, kinecal's first.
    pub fn all() -> [RotationOrder; 6] {
        [
            [2, 1, 0],
            [0, 1, 2],
            [0, 2, 1],
            [1, 0, 2],
            [1, 2, 0],
            [2, 0, 1],
        ]
        .map(|axes| RotationOrder { axes })
    }

    /// Parses `"Rx*Ry*Rz"` (also `·` or `.` between the factors, any case, spaces allowed).
    pub fn parse(text: &str) -> Option<RotationOrder> {
        let t: String = text
            .chars()
            .filter(|c| !c.is_whitespace())
            .collect::<String>()
            .to_ascii_lowercase();
        let parts: Vec<&str> = t.split(['*', '·', '.']).collect();
        if parts.len() != 3 {
            return None;
        }
        let mut axes = [0usize; 3];
        for (k, p) in parts.iter().enumerate() {
            axes[k] = match *p {
                "rx" => 0,
                "ry" => 1,
                "rz" => 2,
                _ => return None,
            };
        }
        let mut seen = [false; 3];
        axes.iter().for_each(|a| seen[*a] = true);
        seen.iter().all(|s| *s).then_some(RotationOrder { axes })
    }

    /// `"Rx*Ry*Rz"`: the text [`RotationOrder::parse`] reads.
    pub fn text(self) -> String {
        self.axes.map(|a| ["Rx", "Ry", "Rz"][a]).join("*")
    }

    /// The rotation of angles `deg` (about x, y, z, degrees) composed in this order.
    pub fn matrix(self, deg: [f64; 3]) -> Matrix3<f64> {
        let factor = |a: usize| {
            let axis = Vector3::ith_axis(a);
            *Rotation3::from_axis_angle(&axis, deg[a].to_radians()).matrix()
        };
        factor(self.axes[0]) * factor(self.axes[1]) * factor(self.axes[2])
    }

    /// kinecal's angles (degrees, `rx_deg`, `ry_deg`, `rz_deg`) of the rotation that the angles
    /// `deg` (about x, y, z) compose in this order; the same numbers for kinecal's own order.
    pub fn to_kinecal_deg(self, deg: [f64; 3]) -> [f64; 3] {
        if self == Self::KINECAL || deg.iter().any(|a| !a.is_finite()) {
            return deg;
        }
        Frame::from_parts(&self.matrix(deg), Vector3::zeros())
            .rpy()
            .map(f64::to_degrees)
    }

    /// The angles (degrees, about x, y, z) that compose `m` in this order: the inverse of
    /// [`Self::matrix`], the middle angle within ±90°. For `R = R_i(a)·R_j(b)·R_k(c)` with
    /// parity `s` (+1 for a cyclic order of x, y, z): `b = asin(s·R_ik)`,
    /// `c = atan2(−s·R_ij, R_ii)` (0 at `b = ±90°`, where only `a ± c` is determined), and
    /// `a` the angle of what is left, `R·R_k(c)ᵀ·R_j(b)ᵀ`.
    pub fn angles_deg(self, m: &Matrix3<f64>) -> [f64; 3] {
        let [i, j, k] = self.axes;
        let s = if (j + 3 - i) % 3 == 1 { 1.0 } else { -1.0 };
        let b = (s * m[(i, k)]).clamp(-1.0, 1.0).asin();
        let c = if b.cos() > 1e-9 {
            (-s * m[(i, j)]).atan2(m[(i, i)])
        } else {
            0.0
        };
        let factor = |axis: usize, angle: f64| {
            *Rotation3::from_axis_angle(&Vector3::ith_axis(axis), angle).matrix()
        };
        let rest = m * factor(k, c).transpose() * factor(j, b).transpose();
        let (i1, i2) = ((i + 1) % 3, (i + 2) % 3);
        let a = rest[(i2, i1)].atan2(rest[(i1, i1)]);
        let mut out = [0.0; 3];
        out[i] = a.to_degrees();
        out[j] = b.to_degrees();
        out[k] = c.to_degrees();
        out
    }
}
