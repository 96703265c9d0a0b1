//! The editor's one placement rule, for new shapes (and the palette's drops): the centre of the
//! object's bounding box's bottom goes on the surface the view looks at, the object upright, then
//! pushed out along the surface's normal until its box clears the surface.

use bevy::math::Ray3d;
use bevy::prelude::*;
use treelight_scene::{SceneBvh, cast_on_filtered};

/// A point on a surface and the surface's unit normal there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Surface {
    /// The point.
    pub point: Vec3,
    /// The unit normal, on the side the object goes.
    pub normal: Vec3,
}

/// Where a ray lands: the first traced surface it hits; else the ground plane (y = 0) if it points
/// down; else a point `fallback_distance` along it, facing back along the ray. Waits for the tree
/// if the worker holds it (a slice of idle work at most): a user's placement must not miss.
pub fn surface_under(scene: &SceneBvh, ray: Ray3d, fallback_distance: f32) -> Surface {
    surface_under_excluding(scene, ray, fallback_distance, &[])
}

/// [`surface_under`], seeing through `exclude` (the objects being placed).
pub fn surface_under_excluding(
    scene: &SceneBvh,
    ray: Ray3d,
    fallback_distance: f32,
    exclude: &[Entity],
) -> Surface {
    // A stopped worker's tree is not read: the object goes on the fallback plane.
    let tree = scene.read_waiting();
    if let Some(hit) = tree
        .as_deref()
        .and_then(|t| cast_on_filtered(t, ray, |e| !exclude.contains(&e)))
    {
        return Surface {
            point: hit.point,
            normal: hit.normal,
        };
    }
    drop(tree);
    let d = Vec3::from(ray.direction);
    if d.y < -1e-4 {
        let t = -ray.origin.y / d.y;
        if t > 0.0 {
            return Surface {
                point: ray.origin + d * t,
                normal: Vec3::Y,
            };
        }
    }
    Surface {
        point: ray.origin + d * fallback_distance,
        normal: -d,
    }
}

/// The eight corners of the box `min..max`.
pub fn box_corners(min: Vec3, max: Vec3) -> [Vec3; 8] {
    std::array::from_fn(|i| {
        Vec3::new(
            if i & 1 == 0 { min.x } else { max.x },
            if i & 2 == 0 { min.y } else { max.y },
            if i & 4 == 0 { min.z } else { max.z },
        )
    })
}

/// The translation that puts an upright object with local bounds `min..max` (scaled by `scale`) on
/// `surface` by the rule.
pub fn place_on(surface: Surface, min: Vec3, max: Vec3, scale: Vec3) -> Vec3 {
    let (min, max) = (
        (min * scale).min(max * scale),
        (min * scale).max(max * scale),
    );
    let bottom = Vec3::new((min.x + max.x) * 0.5, min.y, (min.z + max.z) * 0.5);
    let n = surface.normal.normalize_or(Vec3::Y);
    let mut t = surface.point - bottom;
    // How far the deepest corner is behind the surface's plane.
    let deepest = box_corners(min + t, max + t)
        .iter()
        .fold(0.0f32, |d, c| d.max(-(*c - surface.point).dot(n)));
    t += n * deepest;
    t
}

/// The transform that puts an object with local bounds `min..max` on `surface`: upright by the
/// rule ([`place_on`]), or with `aligned`, turned so its up axis follows the surface's normal and
/// the centre of its box's bottom on the point.
pub fn place_transform(surface: Surface, min: Vec3, max: Vec3, aligned: bool) -> Transform {
    if !aligned {
        return Transform::from_translation(place_on(surface, min, max, Vec3::ONE));
    }
    let n = surface.normal.normalize_or(Vec3::Y);
    let rotation = Quat::from_rotation_arc(Vec3::Y, n);
    let bottom = Vec3::new((min.x + max.x) * 0.5, min.y, (min.z + max.z) * 0.5);
    Transform::from_translation(surface.point - rotation * bottom).with_rotation(rotation)
}

#[cfg(test)]
mod tests {
    use super::*;

    const CUBE: (Vec3, Vec3) = (Vec3::splat(-0.5), Vec3::splat(0.5));

    #[test]
    fn on_a_floor_the_bottom_centre_sits_on_the_point() {
        let s = Surface {
            point: Vec3::new(2.0, 1.0, -3.0),
            normal: Vec3::Y,
        };
        let t = place_on(s, CUBE.0, CUBE.1, Vec3::ONE);
        assert!((t - Vec3::new(2.0, 1.5, -3.0)).length() < 1e-6);
        // Scaled twice as tall, the bottom still sits on the floor.
        let t = place_on(s, CUBE.0, CUBE.1, Vec3::new(1.0, 2.0, 1.0));
        assert!((t.y - 1.0 - 1.0).abs() < 1e-6);
    }

    #[test]
    fn on_a_wall_the_box_is_pushed_out_until_it_clears() {
        let s = Surface {
            point: Vec3::new(-2.5, 1.0, 0.0),
            normal: Vec3::X,
        };
        let t = place_on(s, CUBE.0, CUBE.1, Vec3::ONE);
        // The bottom's centre is at the point's height, the box's back face on the wall.
        assert!((t - Vec3::new(-2.0, 1.5, 0.0)).length() < 1e-6, "{t}");
        // On a slope, no corner ends up behind the surface and one touches it.
        let n = Vec3::new(1.0, 1.0, 0.0).normalize();
        let s = Surface {
            point: Vec3::ZERO,
            normal: n,
        };
        let t = place_on(s, CUBE.0, CUBE.1, Vec3::ONE);
        let depths: Vec<f32> = box_corners(CUBE.0 + t, CUBE.1 + t)
            .iter()
            .map(|c| c.dot(n))
            .collect();
        let min = depths.iter().copied().fold(f32::INFINITY, f32::min);
        assert!(min.abs() < 1e-5, "{depths:?}");
    }

    #[test]
    fn aligned_placement_stands_the_box_on_the_surface_along_its_normal() {
        let n = Vec3::new(1.0, 1.0, 0.0).normalize();
        let s = Surface {
            point: Vec3::new(1.0, 2.0, 3.0),
            normal: n,
        };
        let t = place_transform(s, CUBE.0, CUBE.1, true);
        assert!((t.rotation * Vec3::Y).distance(n) < 1e-6);
        // The bottom face's centre is on the point; the box is on the normal's side.
        let bottom = t.transform_point(Vec3::new(0.0, -0.5, 0.0));
        assert!(bottom.distance(s.point) < 1e-5);
        for c in box_corners(CUBE.0, CUBE.1) {
            assert!((t.transform_point(c) - s.point).dot(n) > -1e-5);
        }
    }
}
