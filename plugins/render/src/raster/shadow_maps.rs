//! While every active 3D camera is path traced, the raster lights' shadow maps are neither drawn
//! nor kept: the tracer traces its own shadows, and Bevy would still clear a 2048² depth layer per
//! sun cascade and keep a 1024² cube per point light every frame. The render world's lights are
//! marked shadowless and its shadow-map sizes set to one texel, so Bevy makes no shadow views and
//! its shadow textures shrink to nothing; the main world's lights and sizes are left as they are
//! (the document reads them back), and they apply again as soon as a camera rasterises.

use bevy::light::{DirectionalLightShadowMap, PointLightShadowMap};
use bevy::pbr::{ExtractedDirectionalLight, ExtractedPointLight};
use bevy::platform::collections::HashMap;
use bevy::prelude::*;
use bevy::render::sync_world::RenderEntity;
use bevy::render::{Extract, ExtractSchedule, Render, RenderApp, RenderSystems};

use crate::raster::raster_meshes::HeldMeshes;

/// What the render world knows of the main world's raster state this frame.
#[derive(Resource, Clone, Debug, Default, PartialEq, Eq)]
struct RasterShadows {
    /// Whether a camera rasterises (or meshes are not held back): shadows as the lights say.
    rasterised: bool,
    /// The main world's sun cascade size.
    directional: usize,
    /// The main world's point-light cube face size.
    point: usize,
    /// Each light's own shadow flag, by its render-world entity: Bevy extracts a light only when
    /// it changes, so the flag cleared here is set back from this.
    casts: HashMap<Entity, bool>,
}

pub(crate) fn build(app: &mut App) {
    let Some(render_app) = app.get_sub_app_mut(RenderApp) else {
        return;
    };
    render_app
        .init_resource::<RasterShadows>()
        .add_systems(ExtractSchedule, extract_raster_shadows)
        .add_systems(
            Render,
            shadows_only_where_rasterised
                .after(RenderSystems::ExtractCommands)
                .before(RenderSystems::CreateViews),
        );
}

#[allow(clippy::type_complexity)]
fn extract_raster_shadows(
    held: Extract<Option<Res<HeldMeshes>>>,
    directional: Extract<Option<Res<DirectionalLightShadowMap>>>,
    point: Extract<Option<Res<PointLightShadowMap>>>,
    lights: Extract<
        Query<(
            &RenderEntity,
            Option<&DirectionalLight>,
            Option<&PointLight>,
            Option<&SpotLight>,
        )>,
    >,
    mut state: ResMut<RasterShadows>,
) {
    let state = &mut *state;
    state.rasterised = held.as_ref().is_none_or(|h| h.rasterised);
    state.directional = directional.as_ref().map_or(2048, |d| d.size);
    state.point = point.as_ref().map_or(1024, |p| p.size);
    state.casts.clear();
    for (entity, sun, point, spot) in &lights {
        let casts = sun
            .map(|l| l.shadow_maps_enabled)
            .or(point.map(|l| l.shadow_maps_enabled))
            .or(spot.map(|l| l.shadow_maps_enabled));
        if let Some(casts) = casts {
            state.casts.insert(entity.id(), casts);
        }
    }
}

/// The render world's shadow-map sizes and the lights' shadow flags for this frame: one texel and
/// none while nothing rasterises, else the main world's (Bevy extracts its sizes and a light's
/// flag only when the main world changes them).
fn shadows_only_where_rasterised(
    state: Res<RasterShadows>,
    directional_map: Option<ResMut<DirectionalLightShadowMap>>,
    point_map: Option<ResMut<PointLightShadowMap>>,
    mut suns: Query<(Entity, &mut ExtractedDirectionalLight)>,
    mut points: Query<(Entity, &mut ExtractedPointLight)>,
) {
    let (directional, point) = if state.rasterised {
        (state.directional, state.point)
    } else {
        (1, 1)
    };
    if let Some(mut map) = directional_map
        && map.size != directional
    {
        map.size = directional;
    }
    if let Some(mut map) = point_map
        && map.size != point
    {
        map.size = point;
    }
    let casts = |e: Entity| state.rasterised && state.casts.get(&e).copied().unwrap_or(false);
    for (e, mut sun) in &mut suns {
        let c = casts(e);
        if sun.shadow_maps_enabled != c {
            sun.shadow_maps_enabled = c;
        }
    }
    for (e, mut light) in &mut points {
        let c = casts(e);
        if light.shadow_maps_enabled != c {
            light.shadow_maps_enabled = c;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use bevy::ecs::system::RunSystemOnce;
    use bevy::light::CascadeShadowConfig;
    use bevy::render::MainWorld;

    fn sun(casts: bool) -> ExtractedDirectionalLight {
        ExtractedDirectionalLight {
            color: LinearRgba::WHITE,
            illuminance: 1.0,
            transform: GlobalTransform::IDENTITY,
            shadow_maps_enabled: casts,
            contact_shadows_enabled: false,
            volumetric: false,
            affects_lightmapped_mesh_diffuse: true,
            shadow_depth_bias: 0.0,
            shadow_normal_bias: 0.0,
            cascade_shadow_config: CascadeShadowConfig::default(),
            cascades: Default::default(),
            frusta: Default::default(),
            soft_shadow_size: None,
            occlusion_culling: false,
            sun_disk_angular_size: 0.0,
            sun_disk_intensity: 0.0,
        }
    }

    fn lamp(casts: bool) -> ExtractedPointLight {
        ExtractedPointLight {
            color: LinearRgba::WHITE,
            intensity: 1.0,
            range: 10.0,
            radius: 0.0,
            transform: GlobalTransform::IDENTITY,
            shadow_maps_enabled: casts,
            contact_shadows_enabled: false,
            shadow_depth_bias: 0.0,
            shadow_normal_bias: 0.0,
            shadow_map_near_z: 0.1,
            spot_light_angles: None,
            volumetric: false,
            soft_shadows_enabled: false,
            affects_lightmapped_mesh_diffuse: true,
        }
    }

    /// One frame's extraction and the render world's override, as the render app runs them.
    fn frame(main: &mut World, render: &mut World) {
        let mut moved = MainWorld::default();
        std::mem::swap(&mut *moved, main);
        render.insert_resource(moved);
        render.run_system_once(extract_raster_shadows).unwrap();
        let mut moved = render.remove_resource::<MainWorld>().unwrap();
        std::mem::swap(&mut *moved, main);
        render
            .run_system_once(shadows_only_where_rasterised)
            .unwrap();
    }

    fn flags(render: &mut World, sun: Entity, lamps: [Entity; 2]) -> [bool; 3] {
        let s = render.get::<ExtractedDirectionalLight>(sun).unwrap();
        let [a, b] = lamps.map(|e| {
            render
                .get::<ExtractedPointLight>(e)
                .unwrap()
                .shadow_maps_enabled
        });
        [s.shadow_maps_enabled, a, b]
    }

    fn sizes(render: &World) -> [usize; 2] {
        [
            render.resource::<DirectionalLightShadowMap>().size,
            render.resource::<PointLightShadowMap>().size,
        ]
    }

    #[test]
    fn shadow_maps_go_while_nothing_rasterises_and_come_back_as_the_lights_say() {
        let (mut main, mut render) = (World::new(), World::new());
        main.insert_resource(HeldMeshes::default());
        main.insert_resource(DirectionalLightShadowMap { size: 4096 });
        main.insert_resource(PointLightShadowMap { size: 512 });
        // As Bevy extracted them: the render world's copies, the lights' own flags.
        render.insert_resource(DirectionalLightShadowMap { size: 4096 });
        render.insert_resource(PointLightShadowMap { size: 512 });
        render.init_resource::<RasterShadows>();
        let r_sun = render.spawn(sun(true)).id();
        let r_lamps = [
            render.spawn(lamp(true)).id(),
            render.spawn(lamp(false)).id(),
        ];
        let m_sun = main
            .spawn((
                DirectionalLight {
                    shadow_maps_enabled: true,
                    ..default()
                },
                RenderEntity::from(r_sun),
            ))
            .id();
        main.spawn((
            PointLight {
                shadow_maps_enabled: true,
                ..default()
            },
            RenderEntity::from(r_lamps[0]),
        ));
        main.spawn((
            SpotLight {
                shadow_maps_enabled: false,
                ..default()
            },
            RenderEntity::from(r_lamps[1]),
        ));

        // Every camera path traced: no shadow views, one-texel maps.
        frame(&mut main, &mut render);
        assert_eq!(flags(&mut render, r_sun, r_lamps), [false; 3]);
        assert_eq!(sizes(&render), [1, 1]);
        // The main world's lights keep their own flags (the document reads them).
        assert!(
            main.get::<DirectionalLight>(m_sun)
                .unwrap()
                .shadow_maps_enabled
        );

        // A camera rasterises: each light casts as it says, at the main world's sizes, with no
        // new extraction of the lights (Bevy extracts a light only when it changes).
        main.resource_mut::<HeldMeshes>().rasterised = true;
        frame(&mut main, &mut render);
        assert_eq!(flags(&mut render, r_sun, r_lamps), [true, true, false]);
        assert_eq!(sizes(&render), [4096, 512]);

        // And back.
        main.resource_mut::<HeldMeshes>().rasterised = false;
        frame(&mut main, &mut render);
        assert_eq!(flags(&mut render, r_sun, r_lamps), [false; 3]);
        assert_eq!(sizes(&render), [1, 1]);
    }
}
