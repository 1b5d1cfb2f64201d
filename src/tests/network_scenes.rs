//! Scene files of the network tests that both the library's tests (`src/tests/network_*.rs`)
//! and the command line's (`tests/illumination_network.rs`, which includes this file) use:
//! the unit cube's walls and closed boxes made of them.

use glam::Vec3;

pub(crate) const CAMERA: &str = r#"
[camera]
position = [0.5, 0.5, 0.95]
look_at = [0.5, 0.5, 0]
fov = 60
width = 16
height = 16
"#;

/// A quad facing the inside of the unit cube on face `axis` = `side`.
pub(crate) fn wall(axis: usize, side: f32, material: &str) -> String {
    let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
    let corner = |a: f32, b: f32| {
        let mut p = [0.0; 3];
        p[axis] = side;
        p[u] = a;
        p[v] = b;
        p
    };
    let mut vs = vec![
        corner(0., 0.),
        corner(1., 0.),
        corner(1., 1.),
        corner(0., 1.),
    ];
    // Wind so the normal (v1−v0)×(v2−v0) points inside.
    let n = (Vec3::from(vs[1]) - Vec3::from(vs[0])).cross(Vec3::from(vs[2]) - Vec3::from(vs[0]));
    if (n[axis] > 0.0) != (side == 0.0) {
        vs.reverse();
    }
    format!("[[shapes]]\ntype = \"quad\"\nmaterial = \"{material}\"\nvertices = {vs:?}\n")
}

/// The unit cube, closed, every wall of material `m` except the floor (y = 0) of `floor`:
/// its scene file (`network_common::closed_box` parses it).
pub(crate) fn closed_box_text(materials: &str, m: &str, floor: &str) -> String {
    let mut text = format!("{CAMERA}\n{materials}\n");
    for axis in 0..3 {
        for side in [0.0, 1.0] {
            let mat = if axis == 1 && side == 0.0 { floor } else { m };
            text += &wall(axis, side, mat);
        }
    }
    text
}

/// A closed box (walls `m`, floor of diffuse colour `floor`, every wall emitting) sealed
/// inside an open scene: it stands above a ground that absorbs half the light and whose
/// lines escape.
pub(crate) fn sealed_box_text(floor: &str) -> String {
    let ground = "[[shapes]]\ntype = \"quad\"\nmaterial = \"ground\"\n\
                  vertices = [[-1, -0.5, -1], [-1, -0.5, 2], [2, -0.5, 2], [2, -0.5, -1]]\n";
    let materials = format!(
        "[materials.m]\ndiffuse = [1, 0.5, 0.5]\nemission = 1\n[materials.floor]\n\
         diffuse = {floor}\n[materials.ground]\ndiffuse = 0.5\n"
    );
    closed_box_text(&materials, "m", "floor") + ground
}
