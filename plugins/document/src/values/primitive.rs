//! The built-in shapes: their meshes, materials and bounds, and the component that marks an object
//! made from one.

use bevy::prelude::*;
use serde::{Deserialize, Serialize};

/// The built-in shapes of the Add menu, each fitting a unit cube centred on its origin.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Primitive {
    /// A unit cube.
    Cube,
    /// A sphere of diameter 1.
    Sphere,
    /// A 1 × 1 square facing up.
    Plane,
    /// A cylinder of diameter 1 and height 1.
    Cylinder,
    /// A 1 × 1 square facing up that emits white light.
    EmissivePanel,
}

impl Primitive {
    /// Every shape, in menu order.
    pub const ALL: [Primitive; 5] = [
        Primitive::Cube,
        Primitive::Sphere,
        Primitive::Plane,
        Primitive::Cylinder,
        Primitive::EmissivePanel,
    ];

    /// A name for menus and the outliner.
    pub fn label(self) -> &'static str {
        match self {
            Primitive::Cube => "Cube",
            Primitive::Sphere => "Sphere",
            Primitive::Plane => "Plane",
            Primitive::Cylinder => "Cylinder",
            Primitive::EmissivePanel => "Emissive panel",
        }
    }

    /// The shape's mesh.
    pub fn mesh(self) -> Mesh {
        match self {
            Primitive::Cube => Cuboid::new(1.0, 1.0, 1.0).into(),
            Primitive::Sphere => Sphere::new(0.5)
                .mesh()
                .ico(4)
                .expect("a valid subdivision count"),
            Primitive::Plane | Primitive::EmissivePanel => {
                Plane3d::default().mesh().size(1.0, 1.0).into()
            }
            Primitive::Cylinder => Cylinder::new(0.5, 1.0).into(),
        }
    }

    /// The shape's material: grey, or for the panel a white emitter.
    pub fn material(self) -> StandardMaterial {
        match self {
            Primitive::EmissivePanel => StandardMaterial {
                base_color: Color::WHITE,
                emissive: LinearRgba::rgb(8.0, 8.0, 8.0),
                double_sided: true,
                cull_mode: None,
                ..default()
            },
            _ => StandardMaterial {
                base_color: Color::srgb(0.8, 0.8, 0.8),
                perceptual_roughness: 0.6,
                ..default()
            },
        }
    }

    /// The mesh's bounding box in its own space: minimum and maximum corners.
    pub fn bounds(self) -> (Vec3, Vec3) {
        match self {
            Primitive::Plane | Primitive::EmissivePanel => {
                (Vec3::new(-0.5, 0.0, -0.5), Vec3::new(0.5, 0.0, 0.5))
            }
            _ => (Vec3::splat(-0.5), Vec3::splat(0.5)),
        }
    }
}

/// Which built-in shape an object's mesh is (added ones and their copies), so a project can make
/// it again.
#[derive(Component, Clone, Copy, Debug, PartialEq, Eq)]
pub struct PrimitiveShape(pub Primitive);
