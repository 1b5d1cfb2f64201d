//! Loop subdivision (Loop 1987; pbrt-v4's `loopsubdiv` shape): each level splits every
//! triangle into four, moving the old vertices and placing the new ones by Loop's masks, and
//! the result's vertices are then pushed to their places on the limit surface, as pbrt-v4
//! does. Boundary edges follow the cubic B-spline rules, so an open mesh keeps its rim.

use crate::math::Vec3;
use glam::DVec3;
use rustc_hash::FxHashMap;

/// The deepest subdivision asked for (each level has four times the triangles).
pub(crate) const MAX_LEVELS: u32 = 12;

/// The most triangles a subdivision may make (about 3 GiB of mesh).
pub(crate) const MAX_TRIANGLES: u64 = 1 << 26;

/// A subdivided mesh: positions on the limit surface, triangles in the input's winding,
/// and a unit normal per vertex (the area-weighted mean of its triangles' normals).
#[derive(Debug)]
pub(crate) struct Subdivided {
    pub positions: Vec<Vec3>,
    pub triangles: Vec<[u32; 3]>,
    pub normals: Vec<Vec3>,
}

/// Loop's β for a vertex of `valence` neighbours.
fn beta(valence: usize) -> f64 {
    if valence == 3 {
        3.0 / 16.0
    } else {
        3.0 / (8.0 * valence as f64)
    }
}

/// The weight of each neighbour in a vertex's limit position.
fn gamma(valence: usize) -> f64 {
    1.0 / (valence as f64 + 3.0 / (8.0 * beta(valence)))
}

/// An edge's key: its vertices, smaller first.
fn edge(a: u32, b: u32) -> (u32, u32) {
    (a.min(b), a.max(b))
}

/// The mesh's edges with the vertices opposite them (one for a boundary edge, two inside),
/// and each vertex's neighbours and whether it lies on the boundary (then its two
/// neighbours along it).
struct Topology {
    edges: FxHashMap<(u32, u32), Vec<u32>>,
    /// The edges' keys in order, so that what is built from them does not depend on the
    /// hash.
    keys: Vec<(u32, u32)>,
    neighbours: Vec<Vec<u32>>,
    rim: Vec<Option<[u32; 2]>>,
}

impl Topology {
    fn of(vertices: usize, triangles: &[[u32; 3]]) -> Result<Topology, String> {
        let mut edges: FxHashMap<(u32, u32), Vec<u32>> = FxHashMap::default();
        for t in triangles {
            for k in 0..3 {
                let (a, b, c) = (t[k], t[(k + 1) % 3], t[(k + 2) % 3]);
                edges.entry(edge(a, b)).or_default().push(c);
            }
        }
        if let Some(((a, b), _)) = edges.iter().find(|(_, o)| o.len() > 2) {
            return Err(format!(
                "the mesh is not a manifold: edge ({a}, {b}) has more than two triangles"
            ));
        }
        let mut neighbours = vec![Vec::new(); vertices];
        let mut along_rim: Vec<Vec<u32>> = vec![Vec::new(); vertices];
        let mut keys: Vec<_> = edges.keys().copied().collect();
        keys.sort_unstable();
        for &(a, b) in &keys {
            neighbours[a as usize].push(b);
            neighbours[b as usize].push(a);
            if edges[&(a, b)].len() == 1 {
                along_rim[a as usize].push(b);
                along_rim[b as usize].push(a);
            }
        }
        let rim = along_rim
            .iter()
            .map(|r| match r[..] {
                [] => None,
                [a, b] => Some([a, b]),
                // A vertex where the rim pinches: kept where it is (a corner).
                _ => Some([u32::MAX, u32::MAX]),
            })
            .collect();
        Ok(Topology {
            edges,
            keys,
            neighbours,
            rim,
        })
    }

    /// Vertex `v` moved by the mask that keeps `1 − w·n` of it and gives each of its `n`
    /// ring neighbours `w` (`w` from the valence), or on the boundary keeps `1 − 2b` and
    /// gives its two rim neighbours `b`.
    fn smoothed(&self, p: &[DVec3], v: usize, ring: fn(usize) -> f64, rim_weight: f64) -> DVec3 {
        match self.rim[v] {
            Some([a, b]) if a == u32::MAX || b == u32::MAX => p[v],
            Some([a, b]) => {
                p[v] * (1.0 - 2.0 * rim_weight) + (p[a as usize] + p[b as usize]) * rim_weight
            }
            None if self.neighbours[v].is_empty() => p[v],
            None => {
                let ring_vertices = &self.neighbours[v];
                let w = ring(ring_vertices.len());
                let sum: DVec3 = ring_vertices.iter().map(|&u| p[u as usize]).sum();
                p[v] * (1.0 - w * ring_vertices.len() as f64) + sum * w
            }
        }
    }
}

/// One level: every triangle into four.
fn refine(p: &[DVec3], triangles: &[[u32; 3]]) -> Result<(Vec<DVec3>, Vec<[u32; 3]>), String> {
    let topo = Topology::of(p.len(), triangles)?;
    let mut next: Vec<DVec3> = (0..p.len())
        .map(|v| topo.smoothed(p, v, beta, 1.0 / 8.0))
        .collect();
    let mut edge_vertex: FxHashMap<(u32, u32), u32> = FxHashMap::default();
    for &(a, b) in &topo.keys {
        let (pa, pb) = (p[a as usize], p[b as usize]);
        let q = match topo.edges[&(a, b)][..] {
            [c, d] => (pa + pb) * (3.0 / 8.0) + (p[c as usize] + p[d as usize]) * (1.0 / 8.0),
            _ => (pa + pb) * 0.5,
        };
        edge_vertex.insert((a, b), next.len() as u32);
        next.push(q);
    }
    let mut out = Vec::with_capacity(triangles.len() * 4);
    for &[v0, v1, v2] in triangles {
        let e = |a: u32, b: u32| edge_vertex[&edge(a, b)];
        let (e01, e12, e20) = (e(v0, v1), e(v1, v2), e(v2, v0));
        out.extend([
            [v0, e01, e20],
            [v1, e12, e01],
            [v2, e20, e12],
            [e01, e12, e20],
        ]);
    }
    Ok((next, out))
}

/// `triangles` over `positions` subdivided `levels` times (at most [`MAX_LEVELS`]) and
/// pushed to the limit surface; an error for a mesh that is not a manifold (an edge of
/// more than two triangles) or an index out of range.
pub(crate) fn subdivide(
    positions: &[Vec3],
    triangles: &[[u32; 3]],
    levels: u32,
) -> Result<Subdivided, String> {
    if levels > MAX_LEVELS {
        return Err(format!("at most {MAX_LEVELS} levels, got {levels}"));
    }
    if let Some(k) = triangles
        .iter()
        .flatten()
        .find(|&&k| k as usize >= positions.len())
    {
        return Err(format!("vertex index {k} out of range"));
    }
    let mut p: Vec<DVec3> = positions.iter().map(|v| v.as_dvec3()).collect();
    let mut tris = triangles.to_vec();
    for _ in 0..levels {
        (p, tris) = refine(&p, &tris)?;
    }
    let topo = Topology::of(p.len(), &tris)?;
    // The rim's limit is the cubic B-spline's, (1, 4, 1)/6 (pbrt-v4 takes 1/5 for the
    // neighbours, which moves boundary points off the limit by a little less each level).
    let limit: Vec<DVec3> = (0..p.len())
        .map(|v| topo.smoothed(&p, v, gamma, 1.0 / 6.0))
        .collect();
    let mut normals = vec![DVec3::ZERO; limit.len()];
    for &[a, b, c] in &tris {
        let (pa, pb, pc) = (limit[a as usize], limit[b as usize], limit[c as usize]);
        let n = (pb - pa).cross(pc - pa);
        for v in [a, b, c] {
            normals[v as usize] += n;
        }
    }
    Ok(Subdivided {
        positions: limit.iter().map(|v| v.as_vec3()).collect(),
        triangles: tris,
        normals: normals
            .iter()
            .map(|n| n.normalize_or_zero().as_vec3())
            .collect(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A unit cube, 12 triangles wound outwards.
    fn cube() -> (Vec<Vec3>, Vec<[u32; 3]>) {
        let p = (0..8)
            .map(|i| Vec3::new((i & 1) as f32, ((i >> 1) & 1) as f32, ((i >> 2) & 1) as f32))
            .collect();
        let quads = [
            [0, 2, 3, 1],
            [4, 5, 7, 6],
            [0, 1, 5, 4],
            [2, 6, 7, 3],
            [0, 4, 6, 2],
            [1, 3, 7, 5],
        ];
        let t = quads
            .iter()
            .flat_map(|&[a, b, c, d]| [[a, b, c], [a, c, d]])
            .collect();
        (p, t)
    }

    fn area(s: &Subdivided) -> f64 {
        s.triangles
            .iter()
            .map(|&[a, b, c]| {
                let [pa, pb, pc] = [a, b, c].map(|i| s.positions[i as usize].as_dvec3());
                0.5 * (pb - pa).cross(pc - pa).length()
            })
            .sum()
    }

    /// Every directed edge once and its reverse once: closed, consistently wound.
    fn watertight(triangles: &[[u32; 3]]) -> bool {
        let mut directed = FxHashMap::default();
        for t in triangles {
            for k in 0..3 {
                *directed.entry((t[k], t[(k + 1) % 3])).or_insert(0) += 1;
            }
        }
        directed
            .iter()
            .all(|(&(a, b), &n)| n == 1 && directed.get(&(b, a)) == Some(&1))
    }

    /// The subdivided cube's area converges to the limit surface's (taken at 7 levels):
    /// within 0.5% at four levels, each level closer than the one before, below the
    /// cube's 6 (the surface shrinks inside its control mesh), and the mesh stays closed.
    #[test]
    fn a_subdivided_cube_converges_to_its_limit_surface() {
        let (p, t) = cube();
        let limit = area(&subdivide(&p, &t, 7).unwrap());
        assert!(limit < 6.0 && limit > 2.0, "{limit}");
        let mut last = f64::INFINITY;
        for levels in 1..=4 {
            let s = subdivide(&p, &t, levels).unwrap();
            assert_eq!(s.triangles.len(), 12 << (2 * levels));
            assert!(watertight(&s.triangles), "{levels} levels");
            let off = (area(&s) / limit - 1.0).abs();
            assert!(off < last, "{levels} levels: {off} after {last}");
            last = off;
        }
        assert!(last < 0.005, "four levels: {last}");
    }

    /// A regular tetrahedron around the origin: each corner's limit point is, by Loop's
    /// limit mask with valence 3 (γ = 1/5), (1 − 3/5)·v + 1/5·(the other three) = v/5,
    /// whatever the levels; the limit surface is closed and its normals point outwards.
    #[test]
    fn a_tetrahedron_corners_reach_their_known_limit_points() {
        let p = vec![
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(1.0, -1.0, -1.0),
            Vec3::new(-1.0, 1.0, -1.0),
            Vec3::new(-1.0, -1.0, 1.0),
        ];
        let t = vec![[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]];
        for levels in [0, 1, 3, 5] {
            let s = subdivide(&p, &t, levels).unwrap();
            for (i, v) in p.iter().enumerate() {
                let got = s.positions[i];
                assert!(
                    (got - *v / 5.0).length() < 1e-5,
                    "{levels}: corner {i} at {got}"
                );
                assert!(
                    s.normals[i].dot(*v) > 0.99 * v.length(),
                    "{levels}: normal {i}"
                );
            }
            assert!(watertight(&s.triangles), "{levels} levels");
        }
    }

    /// An open square (two triangles): its rim follows the boundary rules (the cubic
    /// B-spline of the rim), so the surface stays flat and inside the square and a corner's
    /// limit point is the same whatever the levels; a non-manifold edge, an index out of
    /// range and too many levels are errors.
    #[test]
    fn boundaries_keep_their_rim_and_non_manifolds_are_refused() {
        let p = vec![
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(1.0, 1.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        for levels in [0, 1, 3] {
            let s = subdivide(&p, &[[0, 1, 2], [0, 2, 3]], levels).unwrap();
            assert!(s.positions.iter().all(|v| v.z == 0.0));
            let inside = |x: f32| (0.0..=1.0).contains(&x);
            assert!(s.positions.iter().all(|v| inside(v.x) && inside(v.y)));
            // Corner 0's limit point, the same at every level: the B-spline's
            // (v₁ + 4·v₀ + v₃)/6 over its rim neighbours.
            let want = Vec3::new(1.0, 1.0, 0.0) / 6.0;
            assert!(
                (s.positions[0] - want).length() < 1e-6,
                "{levels}: {}",
                s.positions[0]
            );
        }
        let fin = [[0, 1, 2], [0, 2, 3], [0, 2, 1]];
        assert!(subdivide(&p, &fin, 1)
            .unwrap_err()
            .contains("not a manifold"));
        assert!(subdivide(&p, &[[0, 1, 9]], 1).is_err());
        assert!(subdivide(&p, &[[0, 1, 2]], MAX_LEVELS + 1).is_err());
    }
}
