//! Distances between garment states, shared by Table 1, the comparison with the solver and
//! the stress cases, and how far a state stretches the garment's surface.

use senc_geom::{TriMesh, Vec3};

/// Mean Euclidean distance between corresponding points, in the points' unit (0 for none).
pub fn mean_distance(a: &[Vec3], b: &[Vec3]) -> f64 {
    a.iter().zip(b).map(|(p, q)| (p - q).norm()).sum::<f64>() / a.len().min(b.len()).max(1) as f64
}

/// Mean of `a.y − b.y` over corresponding points (0 for none): how far `a` lies above `b`.
pub fn mean_rise(a: &[Vec3], b: &[Vec3]) -> f64 {
    a.iter().zip(b).map(|(p, q)| p.y - q.y).sum::<f64>() / a.len().min(b.len()).max(1) as f64
}

/// Growth of the surface area of `rest`'s faces placed at `x` over their rest area,
/// `area(x) / area(rest) − 1` (0 for a mesh of zero area). Cloth barely stretches, so a
/// garment hanging or moving on a body stays within a few per cent; a garment inflated like a
/// balloon (a flared hem stretched wider than its rest length) grows by more.
pub fn area_growth(rest: &TriMesh, x: &[Vec3]) -> f64 {
    let a0 = rest.area();
    if a0 > 0.0 {
        rest.area_at(x) / a0 - 1.0
    } else {
        0.0
    }
}

/// Arithmetic mean (0 for none).
pub fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_distance_averages_point_offsets() {
        let a = [Vec3::zeros(), Vec3::new(1.0, 0.0, 0.0)];
        let b = [Vec3::new(0.0, 3.0, 4.0), Vec3::new(1.0, 0.0, 1.0)];
        assert!((mean_distance(&a, &b) - 3.0).abs() < 1e-12);
        assert_eq!(mean_distance(&[], &[]), 0.0);
    }

    #[test]
    fn area_growth_of_a_scaled_mesh_is_the_square_of_the_scale_minus_one() {
        let rest = TriMesh::new(
            vec![Vec3::zeros(), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0), Vec3::new(1.0, 1.0, 0.3)],
            vec![[0, 1, 2], [1, 3, 2]],
        )
        .unwrap();
        let scaled: Vec<Vec3> = rest.positions().iter().map(|p| p * 1.1 + Vec3::new(5.0, -2.0, 1.0)).collect();
        assert!((area_growth(&rest, &scaled) - 0.21).abs() < 1e-12);
        assert!(area_growth(&rest, rest.positions()).abs() < 1e-15);
        // Folding a face over its neighbour (a half turn about their shared edge) keeps the
        // area: no growth.
        let (a, p) = (rest.positions()[1], rest.positions()[3]);
        let u = (rest.positions()[2] - a).normalize();
        let mut folded = rest.positions().to_vec();
        folded[3] = a + 2.0 * (p - a).dot(&u) * u - (p - a);
        assert!((folded[3] - p).norm() > 0.5);
        assert!(area_growth(&rest, &folded).abs() < 1e-12);
    }

    #[test]
    fn mean_rise_is_signed_and_vertical() {
        let a = [Vec3::new(5.0, 1.0, 0.0), Vec3::new(0.0, -2.0, 9.0)];
        let b = [Vec3::zeros(), Vec3::zeros()];
        assert!((mean_rise(&a, &b) + 0.5).abs() < 1e-12);
        assert!((mean_rise(&b, &a) - 0.5).abs() < 1e-12);
        assert_eq!(mean_rise(&[], &[]), 0.0);
    }
}
