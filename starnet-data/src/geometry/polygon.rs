//! Convex polygon clipping (Sutherland–Hodgman) and the shoelace area: the core of rotated IoU.

/// Signed-area-free shoelace area of a simple polygon, any orientation.
pub fn polygon_area(poly: &[[f64; 2]]) -> f64 {
    let n = poly.len();
    let twice: f64 = (0..n)
        .map(|i| {
            let (a, b) = (poly[i], poly[(i + 1) % n]);
            a[0] * b[1] - b[0] * a[1]
        })
        .sum();
    0.5 * twice.abs()
}

/// Area of the intersection of two convex polygons given counter-clockwise.
///
/// ```
/// # use starnet_data::geometry::convex_intersection_area;
/// let a = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
/// let b = [[1.0, 1.0], [3.0, 1.0], [3.0, 3.0], [1.0, 3.0]];
/// assert!((convex_intersection_area(&a, &b) - 1.0).abs() < 1e-12);
/// ```
pub fn convex_intersection_area(subject: &[[f64; 2]], clip: &[[f64; 2]]) -> f64 {
    // Each clipping edge adds at most one vertex, so two boxes (8 + 4 at most) stay on the
    // stack: rotated IoU runs this for every anchor near an object, on every training frame.
    let mut out: Polygon = subject.iter().copied().collect();
    let mut input = Polygon::new();
    for i in 0..clip.len() {
        if out.is_empty() {
            return 0.0;
        }
        let (a, b) = (clip[i], clip[(i + 1) % clip.len()]);
        std::mem::swap(&mut input, &mut out);
        out.clear();
        clip_by_edge(&input, a, b, &mut out);
    }
    if out.len() < 3 { 0.0 } else { polygon_area(&out) }
}

/// Whether two counter-clockwise convex polygons are strictly apart: some edge of one has every
/// vertex of the other on its outer side (the separating-axis theorem, with the edges' normals
/// as axes). Cheaper than a clip, and exact where it answers: the intersection is then empty.
///
/// ```
/// # use starnet_data::geometry::convex_separated;
/// let a = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
/// assert!(convex_separated(&a, &[[3.0, 0.0], [4.0, 0.0], [4.0, 1.0], [3.0, 1.0]]));
/// assert!(!convex_separated(&a, &[[1.0, 1.0], [3.0, 1.0], [3.0, 3.0], [1.0, 3.0]]));
/// ```
pub fn convex_separated(a: &[[f64; 2]], b: &[[f64; 2]]) -> bool {
    outside_an_edge(a, b) || outside_an_edge(b, a)
}

/// Whether every vertex of `poly` lies strictly right of one of `edges`' directed edges.
fn outside_an_edge(edges: &[[f64; 2]], poly: &[[f64; 2]]) -> bool {
    (0..edges.len()).any(|i| {
        let (a, b) = (edges[i], edges[(i + 1) % edges.len()]);
        poly.iter().all(|&p| side(a, b, p) < 0.0)
    })
}

/// A clipped polygon's vertices.
type Polygon = smallvec::SmallVec<[[f64; 2]; 12]>;

/// > 0 when `p` is left of the directed line a→b (inside for a counter-clockwise polygon).
fn side(a: [f64; 2], b: [f64; 2], p: [f64; 2]) -> f64 {
    (b[0] - a[0]) * (p[1] - a[1]) - (b[1] - a[1]) * (p[0] - a[0])
}

/// One Sutherland–Hodgman step: keep the part of `poly` left of the line a→b.
fn clip_by_edge(poly: &[[f64; 2]], a: [f64; 2], b: [f64; 2], out: &mut Polygon) {
    for i in 0..poly.len() {
        let (p, q) = (poly[i], poly[(i + 1) % poly.len()]);
        let (sp, sq) = (side(a, b, p), side(a, b, q));
        if sp >= 0.0 {
            out.push(p);
        }
        if (sp >= 0.0) != (sq >= 0.0) {
            let t = sp / (sp - sq);
            out.push([p[0] + t * (q[0] - p[0]), p[1] + t * (q[1] - p[1])]);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn area_of_unit_square_and_triangle() {
        assert_eq!(polygon_area(&[[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]]), 1.0);
        assert_eq!(polygon_area(&[[0.0, 0.0], [0.0, 2.0], [2.0, 0.0]]), 2.0);
    }

    #[test]
    fn disjoint_contained_and_diamond() {
        let sq = [[0.0, 0.0], [2.0, 0.0], [2.0, 2.0], [0.0, 2.0]];
        let far = [[5.0, 5.0], [6.0, 5.0], [6.0, 6.0], [5.0, 6.0]];
        assert_eq!(convex_intersection_area(&sq, &far), 0.0);
        let inner = [[0.5, 0.5], [1.0, 0.5], [1.0, 1.0], [0.5, 1.0]];
        assert!((convex_intersection_area(&sq, &inner) - 0.25).abs() < 1e-12);
        // A diamond centred on the square's corner (2, 2) with half-diagonal 1: a quarter of
        // its area 2 lies inside the square.
        let diamond = [[2.0, 1.0], [3.0, 2.0], [2.0, 3.0], [1.0, 2.0]];
        assert!((convex_intersection_area(&sq, &diamond) - 0.5).abs() < 1e-12);
    }

    /// A square rotated by `t` about (`x`, `y`), half-side `h`, counter-clockwise.
    fn square(x: f64, y: f64, h: f64, t: f64) -> [[f64; 2]; 4] {
        let (s, c) = t.sin_cos();
        [[h, -h], [h, h], [-h, h], [-h, -h]].map(|[u, v]| [x + c * u - s * v, y + s * u + c * v])
    }

    #[test]
    fn separated_exactly_when_the_clip_finds_no_area() {
        // Diamonds whose circles overlap but whose areas do not: the case the test is for.
        let sq = square(0.0, 0.0, 1.0, 0.0);
        assert!(convex_separated(
            &sq,
            &square(2.5, 0.0, 1.0, std::f64::consts::FRAC_PI_4)
        ));
        assert!(!convex_separated(
            &sq,
            &square(2.3, 0.0, 1.0, std::f64::consts::FRAC_PI_4)
        ));
        // An independent oracle, the clip itself, on a lattice of poses: separated boxes have
        // no intersection, and boxes with an intersection are never called separated. The
        // converse (no area, yet not separated) is allowed only for boxes that touch.
        let mut apart = 0;
        for i in 0..40 {
            for k in 0..12 {
                let b = square(0.13 * i as f64 - 2.6, 0.07 * i as f64, 0.6, 0.27 * k as f64);
                let area = convex_intersection_area(&sq, &b);
                if convex_separated(&sq, &b) {
                    apart += 1;
                    assert!(area < 1e-12, "{i},{k}: separated with area {area}");
                } else {
                    assert!(area > 1e-9, "{i},{k}: not separated, yet area {area}");
                }
            }
        }
        assert!(apart > 100, "the lattice has separated pairs: {apart}");
    }
}
