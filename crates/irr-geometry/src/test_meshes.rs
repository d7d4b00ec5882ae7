//! The meshes and scenes the unit tests share: quads, grids, nested triangles, a thin slab, a
//! mix of meshes for the build paths, and a reproducible stream of random numbers.

use glam::Vec3;

use crate::{Geometry, TriangleMesh, build};

/// A unit quad in the plane z = 0 facing +z, as two triangles.
pub(crate) fn quad(z: f32, material: u32) -> TriangleMesh {
    TriangleMesh {
        positions: vec![
            Vec3::new(0.0, 0.0, z),
            Vec3::new(1.0, 0.0, z),
            Vec3::new(1.0, 1.0, z),
            Vec3::new(0.0, 1.0, z),
        ],
        indices: vec![[0, 1, 2], [0, 2, 3]],
        normals: None,
        material_ids: vec![material, material],
    }
}

/// A closed box of 1e-4 × 1e-7 × 1e-4 rotated about a tilted axis, faces numbered as
/// material ids 0..6 (−x, +x, −y, +y, −z, +z).
pub(crate) fn thin_slab() -> Geometry {
    let q = glam::Quat::from_axis_angle(Vec3::new(0.3, 0.2, 1.0).normalize(), 0.4);
    let h = Vec3::new(0.5e-4, 0.5e-7, 0.5e-4);
    let corner = |i: usize| {
        let s = |bit: usize| if i & bit == 0 { -1.0 } else { 1.0 };
        q * (Vec3::new(s(1), s(2), s(4)) * h)
    };
    let mesh = box_mesh(corner);
    Geometry::build(&[mesh]).unwrap_or_else(|e| panic!("{e}"))
}

/// A closed box of the eight corners `corner(i)` (bit 1 of `i` the x side, 2 the y side, 4 the
/// z side), its faces numbered as material ids 0..6 (−x, +x, −y, +y, −z, +z).
pub(crate) fn box_mesh(corner: impl Fn(usize) -> Vec3) -> TriangleMesh {
    let faces: [[u32; 4]; 6] = [
        [0, 4, 6, 2],
        [1, 3, 7, 5],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 2, 3, 1],
        [4, 5, 7, 6],
    ];
    let mut mesh = TriangleMesh {
        positions: (0..8).map(corner).collect(),
        ..TriangleMesh::default()
    };
    for (f, [a, b, c, d]) in faces.into_iter().enumerate() {
        mesh.indices.extend([[a, b, c], [a, c, d]]);
        mesh.material_ids.extend([f as u32; 2]);
    }
    mesh
}

/// A reproducible stream of numbers in [−1, 1] (xorshift32 from `seed`).
pub(crate) fn xorshift(mut seed: u32) -> impl FnMut() -> f32 {
    move || {
        seed ^= seed << 13;
        seed ^= seed >> 17;
        seed ^= seed << 5;
        seed as f32 / u32::MAX as f32 * 2.0 - 1.0
    }
}

/// An `n × n`-quad grid, vertex `(i, j)` at `vertex(i, j)`, two triangles per quad,
/// material 0.
pub(crate) fn grid(n: u32, mut vertex: impl FnMut(u32, u32) -> Vec3) -> TriangleMesh {
    let mut m = TriangleMesh::default();
    for j in 0..=n {
        for i in 0..=n {
            m.positions.push(vertex(i, j));
        }
    }
    for j in 0..n {
        for i in 0..n {
            let v = j * (n + 1) + i;
            m.indices
                .extend([[v, v + n + 1, v + 1], [v + 1, v + n + 1, v + n + 2]]);
        }
    }
    m.material_ids = vec![0; m.indices.len()];
    m
}

/// `n` coplanar triangles nested about one centroid (also their boxes' centre), each
/// 1.001 times the previous: the input that stalled PLOC.
pub(crate) fn nested(n: u32) -> TriangleMesh {
    let shape = [
        Vec3::new(-1.0, -1.0, -1.0),
        Vec3::new(1.0, 0.0, 1.0),
        Vec3::new(0.0, 1.0, 0.0),
    ];
    let mut mesh = TriangleMesh::default();
    let mut scale = 1.0f32;
    for k in 0..n {
        mesh.positions.extend(shape.map(|p| p * scale));
        mesh.indices.push([3 * k, 3 * k + 1, 3 * k + 2]);
        scale *= 1.001;
    }
    mesh.material_ids = vec![0; n as usize];
    mesh
}

/// The build's primitives (box and index) of `mesh`'s triangles.
pub(crate) fn prims_of(mesh: &TriangleMesh) -> Vec<build::Prim> {
    mesh.indices
        .iter()
        .enumerate()
        .map(|(k, t)| {
            let p = t.map(|i| mesh.positions[i as usize]);
            build::Prim::new(p[0].min(p[1]).min(p[2]), p[0].max(p[1]).max(p[2]), k as u32)
        })
        .collect()
}

/// Meshes for the build-path tests: a soup with shading normals (one triangle
/// degenerate, one non-finite), an empty mesh, a heightfield without normals, and a quad with
/// normals; `soup` triangles in the soup.
pub(crate) fn mixed_meshes(soup: u32) -> Vec<TriangleMesh> {
    let mut next = xorshift(0x2545_f491_u32);
    let mut a = TriangleMesh::default();
    for k in 0..soup {
        let c = Vec3::new(next(), next(), next()) * 3.0;
        for _ in 0..3 {
            a.positions
                .push(c + Vec3::new(next(), next(), next()) * 0.2);
        }
        a.indices.push([3 * k, 3 * k + 1, 3 * k + 2]);
        a.material_ids.push(k % 5);
    }
    a.indices[3] = [0, 0, 1];
    a.positions[5] = Vec3::new(f32::NAN, 0.0, 0.0);
    a.normals = Some(
        (0..a.positions.len())
            .map(|_| Vec3::new(next(), next(), next()))
            .collect(),
    );
    let mut grid = grid(20, |i, j| {
        Vec3::new(i as f32 * 0.1, 0.05 * next() - 2.0, j as f32 * 0.1)
    });
    grid.material_ids.fill(7);
    let mut top = quad(4.0, 9);
    top.normals = Some(vec![Vec3::new(0.1, 0.2, 1.0); 4]);
    vec![a, TriangleMesh::default(), grid, top]
}

/// `layers` wavy 16 × 16-quad grids over [−1, 1]² in x and z, stacked 0.3 apart in y (each
/// its own material id), so that most rays cross several: a scene where rejecting hits
/// changes which one is closest.
pub(crate) fn stacked_grids(layers: u32) -> TriangleMesh {
    let mut mesh = TriangleMesh::default();
    for layer in 0..layers {
        let y = 0.3 * (layer as f32 - (layers - 1) as f32 / 2.0);
        let g = grid(16, |i, j| {
            let (x, z) = (i as f32 / 8.0 - 1.0, j as f32 / 8.0 - 1.0);
            Vec3::new(
                x,
                y + 0.1 * (3.0 * x + layer as f32).sin() * (2.0 * z).cos(),
                z,
            )
        });
        let base = mesh.positions.len() as u32;
        mesh.positions.extend(g.positions);
        mesh.indices
            .extend(g.indices.iter().map(|t| t.map(|v| v + base)));
        mesh.material_ids
            .extend(std::iter::repeat_n(layer, g.material_ids.len()));
    }
    mesh
}
