//! Distances between garment states, shared by Table 1, the comparison with the solver and
//! the stress cases.

use senc_geom::Vec3;

/// Mean Euclidean distance between corresponding points, in the points' unit (0 for none).
pub fn mean_distance(a: &[Vec3], b: &[Vec3]) -> f64 {
    a.iter().zip(b).map(|(p, q)| (p - q).norm()).sum::<f64>() / a.len().min(b.len()).max(1) as f64
}

/// Mean of `a.y − b.y` over corresponding points (0 for none): how far `a` lies above `b`.
pub fn mean_rise(a: &[Vec3], b: &[Vec3]) -> f64 {
    a.iter().zip(b).map(|(p, q)| p.y - q.y).sum::<f64>() / a.len().min(b.len()).max(1) as f64
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
    fn mean_rise_is_signed_and_vertical() {
        let a = [Vec3::new(5.0, 1.0, 0.0), Vec3::new(0.0, -2.0, 9.0)];
        let b = [Vec3::zeros(), Vec3::zeros()];
        assert!((mean_rise(&a, &b) + 0.5).abs() < 1e-12);
        assert!((mean_rise(&b, &a) - 0.5).abs() < 1e-12);
        assert_eq!(mean_rise(&[], &[]), 0.0);
    }
}
