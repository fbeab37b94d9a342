//! Distances between garment states, shared by Table 1, the comparison with the solver and
//! the stress cases, and how far a state stretches the garment's surface (its area, its
//! principal strains).

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

/// Root-mean-square principal strain of `rest`'s faces placed at `x`, weighted by rest
/// area: per face, `√(((σ₁ − 1)² + (σ₂ − 1)²) / 2)` with `σ₁, σ₂` the principal stretches of
/// the deformation from the rest triangle (the square roots of the eigenvalues of the right
/// Cauchy–Green tensor `FᵀF`, `F` the 3×2 deformation gradient in the rest triangle's own
/// plane). Rigid motions and isometric bending or folding give 0; a uniform scale by `s`
/// gives `|s − 1|`. Unlike [`area_growth`] it does not let a stretch in one direction hide
/// behind a compression in the other (a skirt widened round the hoop and shortened down the
/// meridian keeps its area). Faces of zero rest area (which [`TriMesh::new`] refuses) are
/// left out; 0 for a mesh of zero area.
pub fn mean_strain(rest: &TriMesh, x: &[Vec3]) -> f64 {
    let p = rest.positions();
    let (mut sum, mut area) = (0.0, 0.0);
    for &[a, b, c] in rest.faces() {
        let [a, b, c] = [a as usize, b as usize, c as usize];
        let (e1, e2) = (p[b] - p[a], p[c] - p[a]);
        let (l1, cross) = (e1.norm(), e1.cross(&e2).norm());
        if l1 == 0.0 || cross == 0.0 || !cross.is_finite() {
            continue;
        }
        // The rest triangle in its own plane: e1 along the first axis.
        let (u, v) = (e2.dot(&e1) / l1, cross / l1);
        // F = [E1 E2] · Dm⁻¹ with Dm = [[l1, u], [0, v]].
        let (f1, f2) = (x[b] - x[a], x[c] - x[a]);
        let g1 = f1 / l1;
        let g2 = (f2 - g1 * u) / v;
        let (c11, c12, c22) = (g1.dot(&g1), g1.dot(&g2), g2.dot(&g2));
        let (m, d) = (0.5 * (c11 + c22), (0.25 * (c11 - c22).powi(2) + c12 * c12).sqrt());
        let (s1, s2) = ((m + d).max(0.0).sqrt(), (m - d).max(0.0).sqrt());
        let w = 0.5 * cross;
        sum += w * (0.5 * ((s1 - 1.0).powi(2) + (s2 - 1.0).powi(2))).sqrt();
        area += w;
    }
    if area > 0.0 {
        sum / area
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

    /// Two faces of a unit square, the fourth corner lifted by `lift` (bent along their
    /// shared diagonal).
    fn square(lift: f64) -> TriMesh {
        TriMesh::new(
            vec![Vec3::zeros(), Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 1.0, 0.0), Vec3::new(1.0, 1.0, lift)],
            vec![[0, 1, 2], [1, 3, 2]],
        )
        .unwrap()
    }

    /// `square`'s second face folded over the first (a half turn about their shared edge).
    fn folded(rest: &TriMesh) -> Vec<Vec3> {
        let (a, p) = (rest.positions()[1], rest.positions()[3]);
        let u = (rest.positions()[2] - a).normalize();
        let mut x = rest.positions().to_vec();
        x[3] = a + 2.0 * (p - a).dot(&u) * u - (p - a);
        assert!((x[3] - p).norm() > 0.5);
        x
    }

    #[test]
    fn area_growth_of_a_scaled_mesh_is_the_square_of_the_scale_minus_one() {
        let rest = square(0.3);
        let scaled: Vec<Vec3> = rest.positions().iter().map(|p| p * 1.1 + Vec3::new(5.0, -2.0, 1.0)).collect();
        assert!((area_growth(&rest, &scaled) - 0.21).abs() < 1e-12);
        assert!(area_growth(&rest, rest.positions()).abs() < 1e-15);
        // Folding keeps the area: no growth.
        assert!(area_growth(&rest, &folded(&rest)).abs() < 1e-12);
    }

    #[test]
    fn strain_is_zero_for_rigid_motions_and_folds_and_the_scale_for_a_uniform_scale() {
        let rest = square(0.3);
        // A rotation by 1.2 rad about a tilted axis (Rodrigues).
        let (k, t) = (Vec3::new(1.0, -2.0, 0.5).normalize(), 1.2f64);
        let r = |p: &Vec3| p * t.cos() + k.cross(p) * t.sin() + k * k.dot(p) * (1.0 - t.cos());
        let moved: Vec<Vec3> = rest.positions().iter().map(|p| r(p) + Vec3::new(5.0, -2.0, 1.0)).collect();
        assert!(mean_strain(&rest, &moved) < 1e-12);
        for s in [0.7, 1.1, 2.0] {
            let scaled: Vec<Vec3> = rest.positions().iter().map(|p| r(p) * s).collect();
            assert!((mean_strain(&rest, &scaled) - (s - 1.0f64).abs()).abs() < 1e-12, "scale {s}");
        }
        // Folding one face over the other about their shared edge is an isometry.
        assert!(mean_strain(&rest, &folded(&rest)) < 1e-12);
    }

    #[test]
    fn strain_sees_a_stretch_that_a_compression_hides_from_the_area() {
        // A flat sheet stretched by 1.25 along x and compressed by 0.8 along y keeps its area;
        // its principal strains are +0.25 and -0.2: RMS √((0.0625 + 0.04) / 2).
        let rest = square(0.0);
        let x: Vec<Vec3> = rest.positions().iter().map(|p| Vec3::new(1.25 * p.x, 0.8 * p.y, 0.0)).collect();
        assert!(area_growth(&rest, &x).abs() < 1e-12);
        assert!((mean_strain(&rest, &x) - (0.5f64 * (0.0625 + 0.04)).sqrt()).abs() < 1e-12);
        // A shear x += 0.5 y: principal stretches of [[1, 0.5], [0, 1]], singular values
        // (√(1 + 1/16) ± 1/4).
        let sheared: Vec<Vec3> = rest.positions().iter().map(|p| Vec3::new(p.x + 0.5 * p.y, p.y, 0.0)).collect();
        let r = (1.0f64 + 1.0 / 16.0).sqrt();
        let expected = (0.5 * ((r + 0.25 - 1.0).powi(2) + (r - 0.25 - 1.0).powi(2))).sqrt();
        assert!((mean_strain(&rest, &sheared) - expected).abs() < 1e-12);
        // Every face collapsed to a point: both principal stretches 0, strain 1 (not NaN).
        let collapsed = vec![Vec3::new(0.3, 0.3, 0.3); 4];
        assert!((mean_strain(&rest, &collapsed) - 1.0).abs() < 1e-12);
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
