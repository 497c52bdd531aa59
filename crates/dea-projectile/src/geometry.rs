//! Closest point of a triangle to a point, with the feature it lies on.

use dea_core::Vec3;

/// Which part of a triangle the closest point lies on: the seed's node-to-surface,
/// node-to-line and node-to-node contact cases (§4.2.2).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Feature {
    /// inside the face
    Face,
    /// on the edge from vertex k to vertex (k + 1) % 3
    Edge(u8),
    /// at vertex k
    Vertex(u8),
}

/// The closest point of triangle (a, b, c) to `p`, its barycentric weights (the area
/// weights that share a contact force over the triangle's nodes, seed 4-1) and its feature.
/// Follows the Voronoi-region tests of Ericson, *Real-Time Collision Detection* §5.1.5.
pub fn closest_point_on_triangle(p: &Vec3, a: &Vec3, b: &Vec3, c: &Vec3) -> (Vec3, [f64; 3], Feature) {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return (*a, [1.0, 0.0, 0.0], Feature::Vertex(0));
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return (*b, [0.0, 1.0, 0.0], Feature::Vertex(1));
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let t = d1 / (d1 - d3);
        return (a + ab * t, [1.0 - t, t, 0.0], Feature::Edge(0));
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return (*c, [0.0, 0.0, 1.0], Feature::Vertex(2));
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let t = d2 / (d2 - d6);
        return (a + ac * t, [1.0 - t, 0.0, t], Feature::Edge(2));
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && d4 - d3 >= 0.0 && d5 - d6 >= 0.0 {
        let t = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return (b + (c - b) * t, [0.0, 1.0 - t, t], Feature::Edge(1));
    }
    let denominator = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denominator, vc * denominator);
    (a + ab * v + ac * w, [1.0 - v - w, v, w], Feature::Face)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};

    fn random_vector(rng: &mut impl Rng, scale: f64) -> Vec3 {
        Vec3::new(rng.random_range(-scale..scale), rng.random_range(-scale..scale), rng.random_range(-scale..scale))
    }

    /// The closest of a dense sample of the triangle's points.
    fn brute_force(p: &Vec3, a: &Vec3, b: &Vec3, c: &Vec3) -> f64 {
        let n = 200;
        let mut best = f64::INFINITY;
        for i in 0..=n {
            for j in 0..=n - i {
                let (u, v) = (i as f64 / n as f64, j as f64 / n as f64);
                best = best.min((a + (b - a) * u + (c - a) * v - p).norm());
            }
        }
        best
    }

    #[test]
    fn closest_point_matches_brute_force_on_random_triangles() {
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(17);
        let mut features = std::collections::BTreeSet::new();
        for _ in 0..300 {
            let (a, b, c) = (random_vector(&mut rng, 1.0), random_vector(&mut rng, 1.0), random_vector(&mut rng, 1.0));
            let p = random_vector(&mut rng, 2.0);
            let (q, weights, feature) = closest_point_on_triangle(&p, &a, &b, &c);
            features.insert(format!("{feature:?}").chars().next().unwrap());
            // the point is the weighted vertices, the weights a partition of unity in [0, 1]
            assert!((a * weights[0] + b * weights[1] + c * weights[2] - q).norm() < 1e-12);
            assert!((weights.iter().sum::<f64>() - 1.0).abs() < 1e-12 && weights.iter().all(|&w| (-1e-12..=1.0 + 1e-12).contains(&w)));
            // no sampled point is closer (the sample spacing bounds the error)
            let (exact, sampled) = ((q - p).norm(), brute_force(&p, &a, &b, &c));
            let spacing = ((b - a).norm() + (c - a).norm()) / 200.0;
            assert!(exact <= sampled + 1e-12 && sampled - exact <= spacing, "{exact} vs {sampled}");
            // the feature agrees with the weights
            match feature {
                Feature::Face => assert!(weights.iter().all(|&w| w > 0.0)),
                Feature::Edge(k) => assert_eq!(weights[(k as usize + 2) % 3], 0.0),
                Feature::Vertex(k) => assert_eq!(weights[k as usize], 1.0),
            }
        }
        assert_eq!(features.len(), 3, "faces, edges and vertices all occur: {features:?}");
    }

    #[test]
    fn points_above_the_face_project_straight_down() {
        let (a, b, c) = (Vec3::zeros(), Vec3::x(), Vec3::y());
        let (q, weights, feature) = closest_point_on_triangle(&Vec3::new(0.25, 0.25, 3.0), &a, &b, &c);
        assert_eq!(feature, Feature::Face);
        assert!((q - Vec3::new(0.25, 0.25, 0.0)).norm() < 1e-15);
        assert!((weights[0] - 0.5).abs() < 1e-15);
        assert_eq!(closest_point_on_triangle(&Vec3::new(2.0, -1.0, 0.0), &a, &b, &c).2, Feature::Vertex(1));
        assert_eq!(closest_point_on_triangle(&Vec3::new(0.8, 0.8, 0.3), &a, &b, &c).2, Feature::Edge(1));
    }
}
