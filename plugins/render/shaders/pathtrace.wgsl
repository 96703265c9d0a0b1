// The path tracer: each dispatch traces a run of 8×8 tiles (as many as the frame's budget allows),
// each pixel adding `view.samples` samples to its running sum, or a coarse preview after a restart.
// Materials are glTF's metallic-roughness model with its maps: a GGX specular lobe compensated for
// the energy single scattering loses, over a Lambert lobe or a thin-walled GGX transmission lobe
// (weighted by what the specular leaves), under an optional clear coat. Punctual lights are
// sampled directly (next-event estimation), a flat sky is found by the BSDF samples; emissive
// triangles and a panorama sky are both sampled directly, in proportion to their power, and found by
// the BSDF samples, the two weighed by multiple importance sampling. The crate appends a traversal
// (traverse_wide.wgsl with wide_compressed.wgsl) and sampling.wgsl.

// A triangle's shading record as the buffer holds it: the pool records of its three corners, each
// with a flag in bit 31 (CORNER_FLAG): on the first, the corners name vertices; on the second, the
// vertices have normals; on the third, each takes two records, the second holding the second UV
// set. Its group is not here: the first corner of its triangle record names it (triangle_group).
struct ShadingRecord {
    corners: array<u32, 3>,
}

// One record of the shading vertices' pool: a vertex's packed normal and tangent and its UV, or,
// as the second record of a vertex with two UV sets, its second set in `uv`.
struct ShadingVertex {
    normal: u32,
    tangent: u32,
    uv: vec2<f32>,
}

// A triangle's shading, gathered from its record and its corners' vertices (attr_at).
struct Attr {
    // Object-space corner normals, octahedral, snorm16x2 each.
    normals: vec3<u32>,
    // HAS_NORMALS when the normals are present, TWO_UV_SETS when the corners have a second UV
    // set.
    flags: u32,
    // The corners' UVs, set 0 then set 1 (set 1 as set 0 without a second set).
    uvs: array<vec2<f32>, 3>,
    uvs1: array<vec2<f32>, 3>,
    // The corners' object-space tangents, three octahedral 10-bit pairs, a sign and a flag
    // (`packed::encode_tangents`); zero without.
    tangents: vec2<u32>,
}

// Bit 31 of each corner of a shading record: a flag (ShadingRecord); the bits below, its record.
const CORNER_FLAG: u32 = 0x80000000u;

// Whether a shading record's corners name vertices (its first corner's flag).
fn record_names_vertices(r: ShadingRecord) -> bool {
    return (r.corners[0] & CORNER_FLAG) != 0u;
}

// Whether each of a shading record's corners takes two pool records, the second holding the second
// UV set (its third corner's flag).
fn record_has_two_uv_sets(r: ShadingRecord) -> bool {
    return (r.corners[2] & CORNER_FLAG) != 0u;
}

// The first pool record of each of a shading record's corners.
fn corner_records(r: ShadingRecord) -> vec3<u32> {
    return vec3<u32>(r.corners[0], r.corners[1], r.corners[2]) & vec3<u32>(~CORNER_FLAG);
}

// Triangle i's shading: its record's corners read from the pool.
fn attr_at(i: u32) -> Attr {
    let r = shading_record_at(i);
    var a: Attr;
    if !record_names_vertices(r) {
        return a;
    }
    a.flags = select(0u, HAS_NORMALS, (r.corners[1] & CORNER_FLAG) != 0u)
        | select(0u, TWO_UV_SETS, record_has_two_uv_sets(r));
    let c = corner_records(r);
    let v0 = shading_vertex_at(c.x);
    let v1 = shading_vertex_at(c.y);
    let v2 = shading_vertex_at(c.z);
    a.normals = vec3<u32>(v0.normal, v1.normal, v2.normal);
    a.uvs = array<vec2<f32>, 3>(v0.uv, v1.uv, v2.uv);
    a.uvs1 = a.uvs;
    if (a.flags & TWO_UV_SETS) != 0u {
        a.uvs1 = corner_uvs_at(i, 1u);
    }
    a.tangents = triangle_tangents(v0.tangent, v1.tangent, v2.tangent);
    return a;
}

// The corners' UVs of set `uv_set` of triangle i (set 0 where it has one), read from the pool
// alone: what a mask or an emission map needs of a candidate hit.
fn corner_uvs_at(i: u32, uv_set: u32) -> array<vec2<f32>, 3> {
    let r = shading_record_at(i);
    if !record_names_vertices(r) {
        return array<vec2<f32>, 3>(vec2<f32>(0.0), vec2<f32>(0.0), vec2<f32>(0.0));
    }
    let second = select(0u, 1u, uv_set == 1u && record_has_two_uv_sets(r));
    let c = corner_records(r);
    return array<vec2<f32>, 3>(
        shading_vertex_at(c.x + second).uv,
        shading_vertex_at(c.y + second).uv,
        shading_vertex_at(c.z + second).uv,
    );
}

// A triangle's tangent words from its corners' (`packed::triangle_tangents`): corner 0's two
// fields, corner 1's x, corner 0's sign and the flag; then corner 1's y and corner 2's two. Zero
// when corner 0 has none.
fn triangle_tangents(a: u32, b: u32, c: u32) -> vec2<u32> {
    if (a & TANGENTS_PRESENT) == 0u {
        return vec2<u32>(0u);
    }
    let f = 0x3ffu;
    return vec2<u32>(
        (a & 0xfffffu) | ((b & f) << 20u) | (a & 0x40000000u) | TANGENTS_PRESENT,
        ((b >> 10u) & f) | ((c & f) << 10u) | (((c >> 10u) & f) << 20u),
    );
}

struct Object {
    // Rows of the object-to-world normal matrix (the inverse transpose of the linear part).
    normal_rows: array<vec4<f32>, 3>,
    base_color: vec4<f32>,
    // Emitted radiance (rgb), before the camera's exposure; w: a masked material's alpha cutoff.
    emissive: vec4<f32>,
    // Metallic, perceptual roughness, reflectance, transmission.
    params: vec4<f32>,
    // Columns of the UV transform's linear part (xy, zw), then its translation.
    uv_matrix: vec4<f32>,
    uv_offset: vec2<f32>,
    // Layer of the base-colour texture array; NONE when untextured.
    texture: u32,
    // Wrap modes, four bits per map (MAP_*; u in the low two: 0 clamp, 1 repeat, 2 mirror); the
    // alpha mode (ALPHA_*) in bits 20-21; from bit 22, one bit per map: it reads UV set 1.
    wrap: u32,
    // Layers of the metallic-roughness, normal, occlusion and emission maps (NONE: none).
    maps: vec4<u32>,
    // Clear coat strength and perceptual roughness, the normal map's green sign.
    coat: vec3<f32>,
    // The set of per-map UV transforms in `map_transforms` its maps read through (NONE: every map
    // through uv_matrix and uv_offset).
    map_transforms: u32,
    // Tint of the dielectric's specular reflection.
    specular: vec3<f32>,
    // The slot a view's guides and outlines know the object by (NONE: its own): a group the scene
    // re-laid without restarting the views keeps the slot of the group it replaced.
    identity: u32,
}

// A punctual light; after the punctual ones, the emitters' table (kind 4, one record per emitting
// group: the cumulative share of the emitters' weight up to and including the group in
// inv_range2, its first triangle's record from the table's start and their count in ids); then
// the emissive triangles (kind 3): corner 0 in position, the edges to corners 1 and 2 in radiance
// and direction, the cumulative share of its group's weight up to and including it in
// inv_range2 (emitters.rs).
struct Light {
    // A point or spot light's position, or the unit direction towards a directional light.
    position: vec3<f32>,
    // 0 point, 1 directional, 2 spot, 3 emissive triangle, 4 emitting group.
    kind: u32,
    // Point and spot: intensity (luminous power / 4π). Directional: illuminance.
    radiance: vec3<f32>,
    // A point or spot light's radius (soft shadows).
    radius: f32,
    // A spot light's axis, the way it shines.
    direction: vec3<f32>,
    // 1 / range² (glTF's smooth window), 0 for no range.
    inv_range2: f32,
    // A spot light's cone: saturate(cos θ * scale + offset)².
    spot_scale: f32,
    spot_offset: f32,
    // An emissive triangle's id and its group's object slot; a group's first triangle record and
    // count; unused by punctual lights.
    ids: vec2<u32>,
}

struct View {
    // Clip space to world space relative to `origin`, the camera's position: rays are made where
    // numbers are small, so a scene far from the world's origin keeps its rays' directions.
    world_from_clip: mat4x4<f32>,
    // The depth the resolve writes comes from this projection of the primary hit (relative to
    // `origin` too).
    clip_from_world: mat4x4<f32>,
    // Sky radiance (rgb) and the camera's exposure (w).
    sky: vec4<f32>,
    width: u32,
    height: u32,
    root: u32,
    max_bounces: u32,
    // Samples each traced pixel adds.
    samples: u32,
    mode: u32,
    light_count: u32,
    // Largest luminance in nits (scene units, before exposure) light reflected clamp_from times or
    // more may add to a sample; 0 disables.
    indirect_clamp: f32,
    // Pixels per preview block along each axis; 0 traces tiles into the accumulation instead.
    preview_scale: u32,
    preview_seed: u32,
    // Tiles tile_start .. tile_start + tile_count of the sequence j -> j * tile_stride mod tile_total.
    tile_start: u32,
    tile_count: u32,
    tiles_x: u32,
    tile_total: u32,
    tile_stride: u32,
    // Records per part of a split buffer: 1 << part_shift (scene_parts.wgsl).
    part_shift: u32,
    // The samples' seed: a pixel's n-th sample depends on the pixel, n and this alone.
    sample_seed: u32,
    // Reflections from which indirect_clamp applies: 2 for images, 1 for the preview.
    clamp_from: u32,
    // Groups in the emitters' table in `lights` after the punctual ones (each names its emissive
    // triangles' records, which follow the table), and the sum of the triangles' weights
    // (luminance times area).
    emitter_groups: u32,
    emitter_weight: f32,
    // The panorama sky: cos and sin of its turn about +Y, its radiance scale, and ENV_* flags as a
    // whole number (environment.rs).
    environment: vec4<f32>,
    // The world point the clip matrices are relative to (xyz).
    origin: vec4<f32>,
}

// Group 0, the scene: the records and the texture array, shared by every view and bound again only
// when a buffer grows. The nodes, triangles, positions and shading records are declared by
// scene_whole.wgsl and attrs_whole.wgsl, or, for a scene split across bindings, scene_parts.wgsl
// and attrs_parts.wgsl.
@group(0) @binding(2) var<storage, read> instances: array<Instance>;
@group(0) @binding(4) var<storage, read> objects: array<Object>;
@group(0) @binding(5) var<storage, read> lights: array<Light>;
// Base-colour textures, one per layer, resampled to a common size with sRGB-encoded colour (storage
// textures cannot be sRGB, so the kernel decodes).
@group(0) @binding(6) var base_color_textures: texture_2d_array<f32>;
@group(0) @binding(7) var texture_sampler: sampler;
// The GGX lobe's albedo (A, B) over view cosine and perceptual roughness, ENERGY_SIZE² entries two
// to a vec4 (energy.rs): the lobe reflects f0 A + B of the light.
// Sets of five UV transforms, one per map (MAP_*), each its linear part's columns (xy, zw) then its
// translation (xy): for materials whose maps have their own (glTF's KHR_texture_transform).
@group(0) @binding(33) var<storage, read> map_transforms: array<vec4<f32>>;
@group(0) @binding(29) var<uniform> energy: array<vec4<f32>, 512>;
// The panorama sky (equirectangular: rows from the zenith down, the middle column along -Z), its
// sampler (wrapping around the horizon), and its distribution: per row of cells the conditional
// cumulative distribution over the row's cells, then in the last column the marginal's.
@group(0) @binding(30) var environment_map: texture_2d<f32>;
@group(0) @binding(31) var environment_sampler: sampler;
@group(0) @binding(32) var environment_cdf: texture_2d<f32>;
// Group 1, the view: its uniform; per pixel the running sum of its samples (rgb) and their count
// (w); and `aux` (one buffer, as WebGPU allows a stage eight; words, floats by their bits), in four parts: per pixel the depth of
// its first sample's primary hit; per pixel that hit's object slot (the bits of a u32, NONE where the
// ray escaped); per preview block one sample (rgb) and its depth, four floats each, room made for the
// finest scale; per preview block its sample's object slot. The resolve outlines objects by the slots.
@group(1) @binding(0) var<uniform> view: View;
@group(1) @binding(1) var<storage, read_write> accum: array<vec4<f32>>;
@group(1) @binding(2) var<storage, read_write> aux: array<u32>;
// The denoiser's guides (guide_layout.wgsl).
@group(1) @binding(3) var<storage, read_write> guides: array<u32>;

fn part_shift() -> u32 {
    return view.part_shift;
}

const MODE_PATH: u32 = 0u;
const MODE_ALBEDO: u32 = 1u;
const MODE_NORMALS: u32 = 2u;
const MODE_TRIANGLE_ID: u32 = 3u;
const MODE_HEATMAP: u32 = 4u;
// An Attr's flag: its corners have normals.
const HAS_NORMALS: u32 = 0x80000000u;
const MAP_BASE: u32 = 0u;
const MAP_METALLIC_ROUGHNESS: u32 = 1u;
const MAP_NORMAL: u32 = 2u;
const MAP_OCCLUSION: u32 = 3u;
const MAP_EMISSIVE: u32 = 4u;
const ALPHA_MASK: u32 = 1u;
const ALPHA_BLEND: u32 = 2u;
const ENERGY_SIZE: u32 = 32u;
const ENV_PANORAMA: u32 = 1u;
const ENV_SHOWN: u32 = 2u;
const ENV_SAMPLED: u32 = 4u;
// The smallest perceptual roughness shaded (Bevy's clamp; it keeps point-light highlights finite).
const MIN_ROUGHNESS: f32 = 0.089;
// Transmitting surfaces up to this roughness are clear (and blended ones whatever theirs): light
// passes them straight, tinted (shadow rays too, so a window lets the sun in); rougher ones scatter
// what they pass (frosted).
const CLEAR_ROUGHNESS: f32 = 0.15;
// Clear surfaces a path or a shadow ray passes at most (each pane of a window counts).
const MAX_PASSES: u32 = 8u;
// Node records visited (4-wide: about half the binary nodes a ray would visit) that the heatmap shows
// as its hottest colour.
const HEATMAP_MAX: f32 = 80.0;

// A pixel's sample whose primary hit's shading normal is further than this cosine (60°) from the
// mean of those before it met two faces of a crease, not one curved surface: the pixel blends two
// surfaces' light, as a silhouette's does, and is marked mixed for the denoiser.
const CREASE_COSINE: f32 = 0.5;

var<private> rng_state: u32;
// The depth of the current sample's primary hit (0, the far plane, when it escapes).
var<private> primary_depth: f32;
// The object slot of the current sample's primary hit (NONE when it escapes).
var<private> primary_object: u32;
// The denoiser's guides (the mean normal, the albedo summed over samples): the shading
// normal of the current sample's primary hit (zero when it escapes), and the reflectance
// (`reflectance`) of the first surface its path meets that is not smooth (`is_smooth`), times what
// the smooth ones before it
// pass (white when the path escapes at once, black when it leaves through a mirror or glass): in
// a mirror or through clear glass the texture seen is the one behind, and filtering its light
// must leave that texture sharp.
var<private> primary_albedo: vec3<f32>;
var<private> primary_normal: vec3<f32>;
// The light the current sample gathers while its path has met only smooth surfaces (what its
// primary hit emits; through a mirror or clear glass, also the sky, lights and glints seen in
// them), exposed as the samples are: seen, not scattered, it is no noise the denoiser should
// remove, and it passes unfiltered.
var<private> primary_emission: vec3<f32>;
// A shadow ray under way: what the clear surfaces it passed leave of its light (`shadow`).
var<private> shadow_filter: vec3<f32>;
var<private> shadow_origin: vec3<f32>;
var<private> shadow_direction: vec3<f32>;
var<private> shadow_passes: u32;
var<private> filtering_shadow: bool;

fn rand() -> f32 {
    rng_state = pcg(rng_state);
    return f32(rng_state >> 8u) / 16777216.0;
}

fn normal_to_world(o: Object, n: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(dot(o.normal_rows[0].xyz, n), dot(o.normal_rows[1].xyz, n), dot(o.normal_rows[2].xyz, n));
}

// The object-to-world linear part applied to a vector, from the normal matrix's rows: the
// transpose of their inverse (cofactors; the determinant's size does not matter for directions).
fn vector_to_world(o: Object, v: vec3<f32>) -> vec3<f32> {
    let r0 = o.normal_rows[0].xyz;
    let r1 = o.normal_rows[1].xyz;
    let r2 = o.normal_rows[2].xyz;
    let c0 = cross(r1, r2);
    let c1 = cross(r2, r0);
    let c2 = cross(r0, r1);
    return vec3<f32>(dot(c0, v), dot(c1, v), dot(c2, v)) * sign(dot(r0, c0));
}

struct Surface {
    p: vec3<f32>,
    // Geometric normal, facing the incoming ray.
    ng: vec3<f32>,
    // Shading normal (the normal map's, where there is one), on the same side as ng.
    ns: vec3<f32>,
    albedo: vec3<f32>,
    emissive: vec3<f32>,
    metallic: f32,
    // Perceptual roughness and GGX alpha of the specular (and transmission) lobe.
    roughness: f32,
    alpha: f32,
    // The dielectric's reflectance at normal incidence, tinted.
    f0_dielectric: vec3<f32>,
    // Fraction of the dielectric's unreflected light that passes through (thin-walled).
    transmission: f32,
    // It transmits and is smooth enough for light to pass straight (see CLEAR_ROUGHNESS).
    clear: bool,
    clearcoat: f32,
    coat_roughness: f32,
    coat_alpha: f32,
    // What the occlusion map leaves of the light bounced off the surface.
    occlusion: f32,
}

// The slot of the group a hit belongs to: groups sharing triangles share their attributes too, so
// the instance, when there is one, says whose they are here.
fn slot_of(triangle: u32, instance: u32) -> u32 {
    if instance != NONE {
        return instances[instance].group;
    }
    return triangle_group(triangle);
}

fn object_slot(hit: Hit) -> u32 {
    return slot_of(hit.triangle, hit.instance);
}

// The slot a view records for a primary hit: its object's identity.
fn object_identity(hit: Hit) -> u32 {
    let slot = object_slot(hit);
    let identity = objects[slot].identity;
    return select(identity, slot, identity == NONE);
}

fn alpha_mode(o: Object) -> u32 {
    return (o.wrap >> 20u) & 3u;
}

// An Attr's flag: its corners have two UV sets.
const TWO_UV_SETS: u32 = 0x40000000u;

// The corners' UVs of set `uv_set` (0 or 1) of a triangle's shading; set 0 for either where the
// corners have one.
fn corner_uvs(attr: Attr, uv_set: u32) -> array<vec2<f32>, 3> {
    if uv_set == 1u {
        return attr.uvs1;
    }
    return attr.uvs;
}

// Whether the corners have tangents of their own.
fn has_corner_tangents(attr: Attr) -> bool {
    return (attr.tangents.x & TANGENTS_PRESENT) != 0u;
}

// The UV set material map `map` reads.
fn map_set(o: Object, map: u32) -> u32 {
    return (o.wrap >> (22u + map)) & 1u;
}

// The mesh's UV of set `uv_set` at barycentrics (u, v) of a triangle's shading record.
fn mesh_uv(attr: Attr, uv_set: u32, u: f32, v: f32) -> vec2<f32> {
    let c = corner_uvs(attr, uv_set);
    return c[0] * (1.0 - u - v) + c[1] * u + c[2] * v;
}

// A mesh UV through map `map`'s UV transform: the material's one for all its maps, or the map's own
// where they differ.
fn map_uv(o: Object, map: u32, uv: vec2<f32>) -> vec2<f32> {
    if o.map_transforms == NONE {
        return mat2x2<f32>(o.uv_matrix.xy, o.uv_matrix.zw) * uv + o.uv_offset;
    }
    let at = (o.map_transforms * 5u + map) * 2u;
    let m = map_transforms[at];
    return mat2x2<f32>(m.xy, m.zw) * uv + map_transforms[at + 1u].xy;
}

// Where map `map` is read at a hit whose mesh UVs are uv0 (set 0) and uv1 (set 1).
fn map_coordinate(o: Object, map: u32, uv0: vec2<f32>, uv1: vec2<f32>) -> vec2<f32> {
    return map_uv(o, map, select(uv0, uv1, map_set(o, map) == 1u));
}

// Map `map` of the material (its layer `layer`) at texture coordinate t: colour maps come out linear,
// data maps as stored (the layers hold every map sRGB-encoded, see texture_layer.wgsl).
fn sample_map(o: Object, layer: u32, map: u32, t: vec2<f32>) -> vec4<f32> {
    let bits = o.wrap >> (4u * map);
    let st = vec2<f32>(wrap_coordinate(t.x, bits & 3u), wrap_coordinate(t.y, (bits >> 2u) & 3u));
    let texel = textureSampleLevel(base_color_textures, texture_sampler, st, layer, 0.0);
    return vec4<f32>(srgb_to_linear(texel.rgb), texel.a);
}

// Whether a masked material's alpha is below its cutoff at barycentrics (u, v) of a triangle: there
// the surface is not.
fn masked_out(o: Object, triangle: u32, u: f32, v: f32) -> bool {
    if alpha_mode(o) != ALPHA_MASK {
        return false;
    }
    var a = o.base_color.a;
    if o.texture != NONE {
        let c = corner_uvs_at(triangle, map_set(o, MAP_BASE));
        let uv = c[0] * (1.0 - u - v) + c[1] * u + c[2] * v;
        a *= sample_map(o, o.texture, MAP_BASE, map_uv(o, MAP_BASE, uv)).a;
    }
    return a < o.emissive.w;
}

// Whether the surface is there at a candidate hit: where a masked material's alpha is below its
// cutoff, rays pass through (shadow rays too). A shadow ray passes clear surfaces too, keeping what
// they transmit (`shadow`). Called by the traversal for every candidate.
fn surface_is_there(triangle: u32, instance: u32, u: f32, v: f32) -> bool {
    let slot = slot_of(triangle, instance);
    let o = objects[slot];
    let mode = (o.wrap >> 20u) & 3u;
    if masked_out(o, triangle, u, v) {
        return false;
    }
    if filtering_shadow && (o.params.w > 0.0 || mode == ALPHA_BLEND) {
        let s = surface_at(Hit(0.0, triangle, u, v, 0u, instance), shadow_origin, shadow_direction);
        if s.clear && shadow_passes < MAX_PASSES {
            shadow_passes += 1u;
            shadow_filter *= clear_transmittance(s, abs(dot(s.ng, shadow_direction)));
            return max(shadow_filter.x, max(shadow_filter.y, shadow_filter.z)) <= 0.0;
        }
    }
    return true;
}

// What reaches o + t_max d from o along d (t_max from o): what the clear surfaces on the way
// transmit; zero where anything else is in the way.
fn shadow(o: vec3<f32>, d: vec3<f32>, t_max: f32) -> vec3<f32> {
    shadow_filter = vec3<f32>(1.0);
    shadow_origin = o;
    shadow_direction = d;
    shadow_passes = 0u;
    filtering_shadow = true;
    let blocked = occluded(view.root, o, d, t_max);
    filtering_shadow = false;
    return select(shadow_filter, vec3<f32>(0.0), blocked);
}

// Bit 31 of a shading record's first tangent word: the corners' tangents are there.
const TANGENTS_PRESENT: u32 = 0x80000000u;

// The three corner tangents of a shading record (object space, unit length).
fn corner_tangents(w: vec2<u32>) -> array<vec3<f32>, 3> {
    let e = vec3<f32>(1.0 / 511.0);
    let a = vec3<f32>(vec3<u32>(w.x, w.x >> 10u, w.x >> 20u) & vec3<u32>(0x3ffu)) * e - vec3<f32>(1.0);
    let b = vec3<f32>(vec3<u32>(w.y, w.y >> 10u, w.y >> 20u) & vec3<u32>(0x3ffu)) * e - vec3<f32>(1.0);
    return array<vec3<f32>, 3>(
        octahedral_direction(a.xy),
        octahedral_direction(vec2<f32>(a.z, b.x)),
        octahedral_direction(b.yz),
    );
}

// The shading normal `ns` bent by the material's normal map at `t`, in the frame of tangent `tn`
// and bitangent `b`; kept as it is where the map would tilt it below the surface (`ng`).
fn normal_mapped(
    obj: Object,
    t: vec2<f32>,
    ns: vec3<f32>,
    ng: vec3<f32>,
    tn: vec3<f32>,
    b: vec3<f32>,
) -> vec3<f32> {
    let m = sample_map(obj, obj.maps.y, MAP_NORMAL, t).xyz * 2.0 - vec3<f32>(1.0);
    let mapped = normalize(tn * m.x + b * (m.y * obj.coat.z) + ns * max(m.z, 1e-3));
    return select(ns, mapped, dot(mapped, ng) > 0.0);
}

fn surface_at(hit: Hit, o: vec3<f32>, d: vec3<f32>) -> Surface {
    let tri = tri_at(hit.triangle);
    let attr = attr_at(hit.triangle);
    let obj = objects[object_slot(hit)];
    var s: Surface;
    s.p = o + d * hit.t;
    var ng = cross(tri.v1 - tri.v0, tri.v2 - tri.v0);
    if hit.instance != NONE {
        // Triangles of groups kept whole are stored in object space.
        ng = normal_to_world(obj, ng);
    }
    ng = normalize(ng);
    if dot(ng, d) > 0.0 {
        ng = -ng;
    }
    var ns = ng;
    if (attr.flags & HAS_NORMALS) != 0u {
        let w = 1.0 - hit.u - hit.v;
        let n = decode_normal(attr.normals.x) * w + decode_normal(attr.normals.y) * hit.u
            + decode_normal(attr.normals.z) * hit.v;
        ns = normalize(normal_to_world(obj, n));
        if dot(ns, ng) < 0.0 {
            ns = -ns;
        }
    }
    // The mesh's UVs in each set (the second only where a map reads it).
    let t0 = mesh_uv(attr, 0u, hit.u, hit.v);
    var t1 = t0;
    if ((obj.wrap >> 22u) & 0x1fu) != 0u {
        t1 = mesh_uv(attr, 1u, hit.u, hit.v);
    }
    var base = obj.base_color;
    if obj.texture != NONE {
        base *= sample_map(obj, obj.texture, MAP_BASE, map_coordinate(obj, MAP_BASE, t0, t1));
    }
    s.albedo = base.rgb;
    s.metallic = clamp(obj.params.x, 0.0, 1.0);
    var r = obj.params.y;
    if obj.maps.x != NONE {
        let t = map_coordinate(obj, MAP_METALLIC_ROUGHNESS, t0, t1);
        let mr = sample_map(obj, obj.maps.x, MAP_METALLIC_ROUGHNESS, t);
        r *= mr.g;
        s.metallic *= mr.b;
    }
    let normal_set = map_set(obj, MAP_NORMAL);
    let tn_uv = map_coordinate(obj, MAP_NORMAL, t0, t1);
    if obj.maps.y != NONE && has_corner_tangents(attr) {
        // The mesh's own tangents (the raster view's too), interpolated like the normals.
        let w = 1.0 - hit.u - hit.v;
        let tangents = corner_tangents(attr.tangents);
        // Object space, as the normals are, whether or not the triangles were baked to world space.
        let tu = vector_to_world(obj, tangents[0] * w + tangents[1] * hit.u + tangents[2] * hit.v);
        let tangent = tu - ns * dot(ns, tu);
        if dot(tangent, tangent) > 1e-30 {
            let tn = normalize(tangent);
            let flip = select(1.0, -1.0, ((attr.tangents.x >> 30u) & 1u) != 0u);
            ns = normal_mapped(obj, tn_uv, ns, ng, tn, cross(ns, tn) * flip);
        }
    } else if obj.maps.y != NONE {
        // Tangents per triangle, from its positions and texture coordinates (dP/du, dP/dv).
        let c = corner_uvs(attr, normal_set);
        let c0 = map_uv(obj, MAP_NORMAL, c[0]);
        let d1 = map_uv(obj, MAP_NORMAL, c[1]) - c0;
        let d2 = map_uv(obj, MAP_NORMAL, c[2]) - c0;
        let det = d1.x * d2.y - d1.y * d2.x;
        if abs(det) > 1e-20 {
            let e1 = tri.v1 - tri.v0;
            let e2 = tri.v2 - tri.v0;
            var tu = (e1 * d2.y - e2 * d1.y) / det;
            var tv = (e2 * d1.x - e1 * d2.x) / det;
            if hit.instance != NONE {
                tu = vector_to_world(obj, tu);
                tv = vector_to_world(obj, tv);
            }
            let tangent = tu - ns * dot(ns, tu);
            if dot(tangent, tangent) > 1e-30 {
                let tn = normalize(tangent);
                let b = cross(ns, tn) * select(1.0, -1.0, dot(cross(ns, tn), tv) < 0.0);
                ns = normal_mapped(obj, tn_uv, ns, ng, tn, b);
            }
        }
    }
    s.ng = ng;
    s.ns = ns;
    s.occlusion = 1.0;
    if obj.maps.z != NONE {
        let t = map_coordinate(obj, MAP_OCCLUSION, t0, t1);
        s.occlusion = sample_map(obj, obj.maps.z, MAP_OCCLUSION, t).r;
    }
    s.emissive = obj.emissive.rgb;
    if obj.maps.w != NONE {
        let t = map_coordinate(obj, MAP_EMISSIVE, t0, t1);
        s.emissive *= sample_map(obj, obj.maps.w, MAP_EMISSIVE, t).rgb;
    }
    s.roughness = clamp(r, MIN_ROUGHNESS, 1.0);
    s.alpha = s.roughness * s.roughness;
    let reflectance = obj.params.z;
    s.f0_dielectric = min(vec3<f32>(0.16 * reflectance * reflectance) * obj.specular, vec3<f32>(1.0));
    s.transmission = clamp(obj.params.w, 0.0, 1.0);
    if alpha_mode(obj) == ALPHA_BLEND {
        // Blending lets 1 - alpha through, as transmission of the base colour.
        s.transmission = max(s.transmission, 1.0 - clamp(base.a, 0.0, 1.0));
    }
    s.clearcoat = clamp(obj.coat.x, 0.0, 1.0);
    s.coat_roughness = clamp(obj.coat.y, MIN_ROUGHNESS, 1.0);
    s.coat_alpha = s.coat_roughness * s.coat_roughness;
    // Blending is coverage: what it lets through passes straight, however rough the surface.
    s.clear = s.transmission > 0.0
        && (s.roughness <= CLEAR_ROUGHNESS || alpha_mode(obj) == ALPHA_BLEND);
    return s;
}

// What a clear surface passes of light crossing it at cosine `c` to its normal: the base colour's
// transmitted share of what the dielectric and the coat do not reflect.
fn clear_transmittance(s: Surface, c: f32) -> vec3<f32> {
    let coat = s.clearcoat * schlick(vec3<f32>(0.04), c).x;
    return (1.0 - s.metallic) * s.transmission * s.albedo
        * (vec3<f32>(1.0) - schlick(s.f0_dielectric, c)) * (1.0 - coat);
}

// Folds a texture coordinate into 0..1: 0 clamp, 1 repeat, 2 mirror.
fn wrap_coordinate(x: f32, mode: u32) -> f32 {
    if mode == 1u {
        return fract(x);
    }
    if mode == 2u {
        let t = fract(x * 0.5) * 2.0;
        return 1.0 - abs(t - 1.0);
    }
    return clamp(x, 0.0, 1.0);
}

fn srgb_to_linear(c: vec3<f32>) -> vec3<f32> {
    return select(pow((c + vec3<f32>(0.055)) / 1.055, vec3<f32>(2.4)), c / 12.92, c <= vec3<f32>(0.04045));
}

fn luminance(c: vec3<f32>) -> f32 {
    return dot(c, vec3<f32>(0.2126, 0.7152, 0.0722));
}

fn energy_at(i: u32, j: u32) -> vec2<f32> {
    let k = j * ENERGY_SIZE + i;
    let v = energy[k >> 1u];
    return select(v.xy, v.zw, (k & 1u) == 1u);
}

// (A, B) of the GGX lobe at view cosine mu and perceptual roughness r, bilinear in the table.
fn split_sum(mu: f32, r: f32) -> vec2<f32> {
    let last = f32(ENERGY_SIZE - 1u);
    // The table's points lie at mu = (i / last)², denser towards grazing.
    let x = sqrt(clamp(mu, 0.0, 1.0)) * last;
    let y = clamp(r, 0.0, 1.0) * last;
    let i = min(u32(x), ENERGY_SIZE - 2u);
    let j = min(u32(y), ENERGY_SIZE - 2u);
    let fx = x - f32(i);
    let fy = y - f32(j);
    let a = mix(energy_at(i, j), energy_at(i + 1u, j), fx);
    let b = mix(energy_at(i, j + 1u), energy_at(i + 1u, j + 1u), fx);
    return mix(a, b, fy);
}

fn ggx_d(nh: f32, a2: f32) -> f32 {
    let k = nh * nh * (a2 - 1.0) + 1.0;
    return a2 / (PI * k * k);
}

fn smith_g1(nx: f32, a2: f32) -> f32 {
    return 2.0 * nx / (nx + sqrt(a2 + (1.0 - a2) * nx * nx));
}

fn schlick(f0: vec3<f32>, vh: f32) -> vec3<f32> {
    return f0 + (vec3<f32>(1.0) - f0) * pow(1.0 - vh, 5.0);
}

// The single-scattering GGX lobe without its Fresnel term: D G / (4 nl nv).
fn microfacet(ns: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>, a2: f32) -> f32 {
    let nl = dot(ns, wi);
    let nv = dot(ns, wo);
    let h = normalize(wo + wi);
    let nh = max(dot(ns, h), 0.0);
    return ggx_d(nh, a2) * smith_g1(nl, a2) * smith_g1(nv, a2) / (4.0 * nl * nv);
}

// The density of sampling wi by reflecting wo about a GGX half vector.
fn microfacet_pdf(ns: vec3<f32>, wo: vec3<f32>, wi: vec3<f32>, a2: f32) -> f32 {
    let half = wo + wi;
    // wi = -wo (a grazing microfacet) has no half vector.
    if dot(half, half) < 1e-12 {
        return 0.0;
    }
    let h = normalize(half);
    let nh = dot(ns, h);
    // Half vectors are drawn above the surface only.
    if nh <= 0.0 {
        return 0.0;
    }
    let vh = max(dot(wo, h), 1e-6);
    return ggx_d(nh, a2) * nh / (4.0 * vh);
}

// What a surface's lobes weigh as seen from one direction (wo): shared by evaluation and sampling.
struct Lobes {
    // Reflectance at normal incidence of the specular lobe (metal and dielectric mixed).
    f0: vec3<f32>,
    // Multiple-scattering compensation of the specular lobe: 1 + f0 (1 - E) / E.
    compensation: vec3<f32>,
    // The specular lobe's directional albedo (what it reflects of even white light).
    specular: vec3<f32>,
    // Weight of what lies under the dielectric's specular reflection (diffuse and transmission).
    base: vec3<f32>,
    // 1 / E with f0 = 1: makes the thin transmission lobe pass all it receives.
    inv_e: f32,
    // What the clear coat leaves to the layers below it.
    under: f32,
    // Probabilities of sampling the specular, diffuse, transmission and coat lobes.
    p: vec4<f32>,
}

fn lobes_at(s: Surface, wo: vec3<f32>) -> Lobes {
    var l: Lobes;
    let nv = max(dot(s.ns, wo), 1e-4);
    let ss = split_sum(nv, s.roughness);
    let e = max(ss.x + ss.y, 1e-3);
    l.f0 = mix(s.f0_dielectric, s.albedo, s.metallic);
    l.compensation = vec3<f32>(1.0) + l.f0 * ((1.0 - e) / e);
    let comp_d = vec3<f32>(1.0) + s.f0_dielectric * ((1.0 - e) / e);
    let e_dielectric = comp_d * (s.f0_dielectric * ss.x + vec3<f32>(ss.y));
    l.base = (1.0 - s.metallic) * max(vec3<f32>(1.0) - e_dielectric, vec3<f32>(0.0));
    l.inv_e = 1.0 / e;
    let cc = split_sum(nv, s.coat_roughness);
    let coat = s.clearcoat * (0.04 * cc.x + cc.y);
    l.under = 1.0 - coat;
    l.specular = l.compensation * (l.f0 * ss.x + vec3<f32>(ss.y));
    let spec = luminance(l.specular) * l.under;
    let below = luminance(l.base * s.albedo) * l.under;
    let w = vec4<f32>(spec, below * (1.0 - s.transmission), below * s.transmission, coat);
    let total = w.x + w.y + w.z + w.w;
    if total > 0.0 {
        l.p = w / total;
    }
    return l;
}

// The BSDF (without the cosine) for light arriving along wi and leaving along wo: reflection
// when wi is above the surface, thin-walled transmission when it is below.
fn bsdf(s: Surface, l: Lobes, wo: vec3<f32>, wi: vec3<f32>) -> vec3<f32> {
    let nl = dot(s.ns, wi);
    let nv = dot(s.ns, wo);
    if nv <= 0.0 || nl == 0.0 {
        return vec3<f32>(0.0);
    }
    if nl < 0.0 {
        // A clear surface passes light straight (path_radiance, shadow), not through a lobe.
        if s.transmission <= 0.0 || s.clear {
            return vec3<f32>(0.0);
        }
        // Through a thin wall: the reflection lobe mirrored to the far side, tinted by the base colour.
        let mirrored = wi - 2.0 * nl * s.ns;
        let a2 = s.alpha * s.alpha;
        return l.under * l.base * s.transmission * s.albedo * (microfacet(s.ns, wo, mirrored, a2) * l.inv_e);
    }
    let h = normalize(wo + wi);
    let vh = max(dot(wo, h), 0.0);
    let a2 = s.alpha * s.alpha;
    let spec = l.compensation * schlick(l.f0, vh) * microfacet(s.ns, wo, wi, a2);
    let diffuse = l.base * (1.0 - s.transmission) * s.albedo / PI;
    var f = l.under * (spec + diffuse);
    if s.clearcoat > 0.0 {
        let c2 = s.coat_alpha * s.coat_alpha;
        f += vec3<f32>(s.clearcoat * schlick(vec3<f32>(0.04), vh).x * microfacet(s.ns, wo, wi, c2));
    }
    return f;
}

// The density of sample_direction choosing wi: every lobe that can produce wi counts, including
// a reflection lobe's draws that fall below the surface (worth nothing there, but the transmission
// lobe's estimate must know they happen) and the transmission lobe's mirrored draws above it.
fn pdf(s: Surface, l: Lobes, wo: vec3<f32>, wi: vec3<f32>) -> f32 {
    let nl = dot(s.ns, wi);
    if nl == 0.0 {
        return 0.0;
    }
    let a2 = s.alpha * s.alpha;
    var p = l.p.x * microfacet_pdf(s.ns, wo, wi, a2)
        + l.p.w * microfacet_pdf(s.ns, wo, wi, s.coat_alpha * s.coat_alpha);
    // A clear surface's transmission is a choice apart (passing straight), not a direction drawn.
    if !s.clear {
        p += l.p.z * microfacet_pdf(s.ns, wo, wi - 2.0 * nl * s.ns, a2);
    }
    if nl > 0.0 {
        p += l.p.y * nl / PI;
    }
    return p;
}

// wo reflected about a GGX half vector of alpha a; zero (ending the path) for a half vector facing
// away from wo, whose reflection pdf() could not account for.
fn ggx_reflection(frame: mat3x3<f32>, wo: vec3<f32>, a: f32, u1: f32, u2: f32) -> vec3<f32> {
    let a2 = a * a;
    let cos_t = sqrt((1.0 - u1) / (1.0 + (a2 - 1.0) * u1));
    let sin_t = sqrt(max(0.0, 1.0 - cos_t * cos_t));
    let phi = 2.0 * PI * u2;
    let h = frame * vec3<f32>(sin_t * cos(phi), sin_t * sin(phi), cos_t);
    let vh = dot(wo, h);
    if vh <= 0.0 {
        return vec3<f32>(0.0);
    }
    return 2.0 * vh * h - wo;
}

// A direction from the mixture of the lobes; the caller weights it by bsdf * |cos| / pdf.
fn sample_direction(s: Surface, l: Lobes, wo: vec3<f32>) -> vec3<f32> {
    let frame = basis(s.ns);
    let u1 = rand();
    let u2 = rand();
    var pick = rand();
    if s.clear {
        // The lobes other than transmission (passing straight was not chosen), in proportion.
        pick *= 1.0 - l.p.z;
        if pick >= l.p.x + l.p.y {
            pick += l.p.z;
        }
    }
    if pick < l.p.x {
        return ggx_reflection(frame, wo, s.alpha, u1, u2);
    }
    if pick < l.p.x + l.p.y {
        return cosine_direction(frame, u1, u2);
    }
    if pick < l.p.x + l.p.y + l.p.z {
        let r = ggx_reflection(frame, wo, s.alpha, u1, u2);
        return r - 2.0 * dot(r, s.ns) * s.ns;
    }
    return ggx_reflection(frame, wo, s.coat_alpha, u1, u2);
}

fn uniform_sphere() -> vec3<f32> {
    let z = 1.0 - 2.0 * rand();
    let r = sqrt(max(0.0, 1.0 - z * z));
    let phi = 2.0 * PI * rand();
    return vec3<f32>(r * cos(phi), r * sin(phi), z);
}

fn env_flags() -> u32 {
    return u32(view.environment.w);
}

// The panorama's own direction of a world direction, and back (its turn about +Y).
fn env_from_world(w: vec3<f32>) -> vec3<f32> {
    let c = view.environment.x;
    let s = view.environment.y;
    return vec3<f32>(w.x * c - w.z * s, w.y, w.x * s + w.z * c);
}

fn env_to_world(m: vec3<f32>) -> vec3<f32> {
    let c = view.environment.x;
    let s = view.environment.y;
    return vec3<f32>(m.x * c + m.z * s, m.y, -m.x * s + m.z * c);
}

fn env_uv(m: vec3<f32>) -> vec2<f32> {
    return vec2<f32>(0.5 + atan2(m.x, -m.z) / (2.0 * PI), acos(clamp(m.y, -1.0, 1.0)) / PI);
}

fn env_direction(uv: vec2<f32>) -> vec3<f32> {
    let theta = uv.y * PI;
    let phi = (uv.x - 0.5) * 2.0 * PI;
    return vec3<f32>(sin(theta) * sin(phi), cos(theta), -sin(theta) * cos(phi));
}

// Radiance arriving from the sky along world direction d (towards the sky).
fn sky_radiance(d: vec3<f32>) -> vec3<f32> {
    if (env_flags() & ENV_PANORAMA) == 0u {
        return view.sky.rgb;
    }
    let uv = env_uv(env_from_world(d));
    return textureSampleLevel(environment_map, environment_sampler, uv, 0.0).rgb * view.environment.z;
}

// What a camera ray that leaves the scene sees: the sky, or the flat sky colour where a panorama
// lights the scene unseen.
fn background(d: vec3<f32>) -> vec3<f32> {
    let flags = env_flags();
    if (flags & ENV_PANORAMA) != 0u && (flags & ENV_SHOWN) == 0u {
        return view.sky.rgb;
    }
    return sky_radiance(d);
}

fn env_cdf(x: u32, y: u32) -> f32 {
    return textureLoad(environment_cdf, vec2<u32>(x, y), 0).r;
}

// The probability of the distribution's cell (x, y) (of cw across).
fn env_cell_probability(x: u32, y: u32, cw: u32) -> f32 {
    var row = env_cdf(cw, y);
    if y > 0u {
        row -= env_cdf(cw, y - 1u);
    }
    var cell = env_cdf(x, y);
    if x > 0u {
        cell -= env_cdf(x - 1u, y);
    }
    return row * cell;
}

// The density per steradian of env_sample drawing world direction d.
fn env_pdf(d: vec3<f32>) -> f32 {
    let dims = textureDimensions(environment_cdf);
    let cw = dims.x - 1u;
    let ch = dims.y;
    let uv = env_uv(env_from_world(d));
    let s = sin(uv.y * PI);
    if !(s > 0.0) {
        return 0.0;
    }
    let x = min(u32(fract(uv.x) * f32(cw)), cw - 1u);
    let y = min(u32(uv.y * f32(ch)), ch - 1u);
    return env_cell_probability(x, y, cw) * f32(cw * ch) / (2.0 * PI * PI * s);
}

// The first of `n` cumulative values (column `column` of the distribution, or row `row`'s cells)
// above `r`.
fn env_search(n: u32, r: f32, column: u32, row: u32, in_column: bool) -> u32 {
    var lo = 0u;
    var hi = n - 1u;
    while lo < hi {
        let mid = (lo + hi) / 2u;
        var c: f32;
        if in_column {
            c = env_cdf(column, mid);
        } else {
            c = env_cdf(mid, row);
        }
        if c > r {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    return lo;
}

// A world direction drawn in proportion to the panorama's brightness (xyz) and its density (w).
fn env_sample(r1: f32, r2: f32) -> vec4<f32> {
    let dims = textureDimensions(environment_cdf);
    let cw = dims.x - 1u;
    let ch = dims.y;
    let y = env_search(ch, r2, cw, 0u, true);
    var below = 0.0;
    if y > 0u {
        below = env_cdf(cw, y - 1u);
    }
    let fy = clamp((r2 - below) / max(env_cdf(cw, y) - below, 1e-30), 0.0, 0.999999);
    let x = env_search(cw, r1, 0u, y, false);
    var left = 0.0;
    if x > 0u {
        left = env_cdf(x - 1u, y);
    }
    let fx = clamp((r1 - left) / max(env_cdf(x, y) - left, 1e-30), 0.0, 0.999999);
    let uv = vec2<f32>((f32(x) + fx) / f32(cw), (f32(y) + fy) / f32(ch));
    let s = sin(uv.y * PI);
    if !(s > 0.0) {
        return vec4<f32>(0.0, 1.0, 0.0, 0.0);
    }
    let p = env_cell_probability(x, y, cw) * f32(cw * ch) / (2.0 * PI * PI * s);
    return vec4<f32>(env_to_world(env_direction(uv)), p);
}

// The weight of a sample drawn with density `a` where another strategy would have drawn it with
// density `b` (Veach's power heuristic, exponent 2).
fn power_heuristic(a: f32, b: f32) -> f32 {
    return a * a / (a * a + b * b);
}

// One shadow ray's worth of light at a surface: the direction wi it comes from, how far away its
// source is (FAR: infinitely), the radiance it brings over the density it was drawn with, and that
// density per solid angle (0: a punctual light, which no BSDF sample finds, so unweighed). An
// emitter's sample also has the triangle's normal facing the surface (zero for the others), to
// lift the shadow ray's far end off the emitter.
struct LightSample {
    wi: vec3<f32>,
    dist: f32,
    li: vec3<f32>,
    p_light: f32,
    toward: vec3<f32>,
}

fn no_light() -> LightSample {
    return LightSample(vec3<f32>(0.0, 0.0, 1.0), 0.0, vec3<f32>(0.0), 0.0, vec3<f32>(0.0));
}

// Punctual light i seen from p: a point on its sphere (its radius), through glTF's range window and
// a spot's cone; a directional light from its direction.
fn punctual_sample(i: u32, p: vec3<f32>) -> LightSample {
    let light = lights[i];
    if light.kind == 1u {
        return LightSample(light.position, FAR, light.radiance, 0.0, vec3<f32>(0.0));
    }
    let spot = light.position + uniform_sphere() * light.radius;
    let to = spot - p;
    let d2 = max(dot(to, to), 1e-8);
    let dist = sqrt(d2);
    let wi = to / dist;
    // glTF's range window, as Bevy's rasteriser has it: (1 - (d / range)^4)^2.
    let f = d2 * light.inv_range2;
    let window = saturate(1.0 - f * f);
    var li = light.radiance * (window * window / d2);
    if light.kind == 2u {
        let cone = saturate(dot(light.direction, -wi) * light.spot_scale + light.spot_offset);
        li *= cone * cone;
    }
    return LightSample(wi, dist, li, 0.0, vec3<f32>(0.0));
}

// The panorama's light: a direction drawn from its distribution.
fn environment_sample() -> LightSample {
    let e = env_sample(rand(), rand());
    if !(e.w > 0.0) {
        return no_light();
    }
    return LightSample(e.xyz, FAR, sky_radiance(e.xyz) / e.w, e.w, vec3<f32>(0.0));
}

// The light a material emits at barycentrics (u, v) of a triangle: its emission times its map
// there; none where a mask cuts the surface away.
fn emitted(o: Object, triangle: u32, u: f32, v: f32) -> vec3<f32> {
    if masked_out(o, triangle, u, v) {
        return vec3<f32>(0.0);
    }
    var e = o.emissive.rgb;
    if o.maps.w != NONE {
        let c = corner_uvs_at(triangle, map_set(o, MAP_EMISSIVE));
        let t = c[0] * (1.0 - u - v) + c[1] * u + c[2] * v;
        e *= sample_map(o, o.maps.w, MAP_EMISSIVE, map_uv(o, MAP_EMISSIVE, t)).rgb;
    }
    return e;
}

// The density, per solid angle at a point `dist` away seen at cosine `cos_e` to the emitter's
// normal, of drawing that point of a triangle of a material emitting `emissive`: the triangle's
// share of the list (its luminance times its area over the total) over its area.
fn emitter_pdf(emissive: vec3<f32>, dist: f32, cos_e: f32) -> f32 {
    if view.emitter_groups == 0u || !(view.emitter_weight > 0.0) || !(cos_e > 0.0) {
        return 0.0;
    }
    return luminance(emissive) / view.emitter_weight * dist * dist / cos_e;
}

// The record in lights[lo..=hi] whose cumulative share first exceeds r.
fn cumulative_pick(first: u32, last: u32, r: f32) -> u32 {
    var lo = first;
    var hi = last;
    loop {
        if lo >= hi {
            break;
        }
        let mid = (lo + hi) / 2u;
        if lights[mid].inv_range2 > r {
            hi = mid;
        } else {
            lo = mid + 1u;
        }
    }
    return lo;
}

// An emissive triangle's record: a group by its share of the list's power (r1), then one of its
// triangles by its share of the group's (r2).
fn emitter_pick(r1: f32, r2: f32) -> u32 {
    let table = view.light_count;
    let g = cumulative_pick(table, table + view.emitter_groups - 1u, r1);
    let range = lights[g].ids;
    let first = table + range.x;
    return cumulative_pick(first, first + max(range.y, 1u) - 1u, r2);
}

// The emissive triangles' light at p: a uniform point on a triangle drawn in proportion to its
// power. Emission is two-sided, as the BSDF's samples see it.
fn emitter_sample(p: vec3<f32>) -> LightSample {
    let pick_group = rand();
    let pick_triangle = rand();
    let e = lights[emitter_pick(pick_group, pick_triangle)];
    // A uniform point: barycentrics u (corner 1) and v (corner 2).
    let r = sqrt(rand());
    let r2 = rand();
    let u = r * (1.0 - r2);
    let v = r * r2;
    let q = e.position + e.radiance * u + e.direction * v;
    let n = cross(e.radiance, e.direction);
    let to = q - p;
    let d2 = dot(to, to);
    let n_len = length(n);
    if !(d2 > 0.0) || !(n_len > 0.0) {
        return no_light();
    }
    let dist = sqrt(d2);
    let wi = to / dist;
    let cos_e = abs(dot(n, wi)) / n_len;
    if !(cos_e > 1e-6) {
        return no_light();
    }
    let o = objects[e.ids.y];
    let p_light = emitter_pdf(o.emissive.rgb, dist, cos_e);
    if !(p_light > 0.0) {
        return no_light();
    }
    let le = emitted(o, e.ids.x, u, v);
    return LightSample(wi, dist, le / p_light, p_light, -n * sign(dot(n, wi)) / n_len);
}

// Light sample k at s: the punctual lights first, then the panorama, then the emitters.
fn light_sample(s: Surface, k: u32) -> LightSample {
    if k < view.light_count {
        return punctual_sample(k, s.p);
    }
    // The occlusion map dims ambient and emitted light, as it dims the BSDF's samples of them.
    var ls = no_light();
    if k == view.light_count {
        if (env_flags() & ENV_SAMPLED) != 0u {
            ls = environment_sample();
        }
    } else if view.emitter_groups > 0u && view.emitter_weight > 0.0 {
        ls = emitter_sample(s.p);
    }
    ls.li *= s.occlusion;
    return ls;
}

// Light arriving at s from every light, through shadow rays, reflected (or passed through a thin
// wall) towards wo. A sample of the panorama or of the emitters is weighed against the BSDF's
// samples, which find the same light (power heuristic). One loop traces every shadow ray: llvmpipe
// inlines the traversal wherever it is called, and the kernel split across bindings already takes
// it minutes to compile.
fn direct_light(s: Surface, l: Lobes, wo: vec3<f32>) -> vec3<f32> {
    var sum = vec3<f32>(0.0);
    for (var k = 0u; k < view.light_count + 2u; k += 1u) {
        let ls = light_sample(s, k);
        if max(ls.li.x, max(ls.li.y, ls.li.z)) <= 0.0 {
            continue;
        }
        let wi = ls.wi;
        let cos_l = dot(s.ns, wi);
        let cos_g = dot(s.ng, wi);
        // The shading and geometric normals must agree on the side; the far side only counts
        // through a transmitting surface.
        if cos_l * cos_g <= 0.0 || (cos_l < 0.0 && (s.transmission <= 0.0 || s.clear)) {
            continue;
        }
        let f = bsdf(s, l, wo, wi);
        if max(f.x, max(f.y, f.z)) <= 0.0 {
            continue;
        }
        let start = offset(s.p, select(-s.ng, s.ng, cos_g > 0.0));
        var d = wi;
        var t_max = ls.dist;
        if any(ls.toward != vec3<f32>(0.0)) {
            // Both ends moved off their surfaces: a shadow ray stopped short of the point by a
            // fraction of its length would still meet the emitter where it passes close to
            // another surface.
            let span = offset(s.p + wi * ls.dist, ls.toward) - start;
            t_max = length(span);
            if !(dot(span, wi) > 0.0) {
                continue;
            }
            d = span / t_max;
        } else if ls.dist < FAR {
            t_max = ls.dist * 0.999;
        }
        let through = shadow(start, d, t_max);
        if max(through.x, max(through.y, through.z)) <= 0.0 {
            continue;
        }
        var w = 1.0;
        if ls.p_light > 0.0 {
            w = power_heuristic(ls.p_light, pdf(s, l, wo, wi));
        }
        sum += f * through * ls.li * (abs(cos_l) * w);
    }
    return sum;
}

// What a surface returns of white light arriving evenly from everywhere, seen from the direction
// its lobes were weighed for (`lobes_at`): their directional albedo (what the furnace measures), the denoiser's albedo guide. The base colour
// alone would leave out the specular sheen, which no texel tints: divided by each pixel's texels
// and multiplied back after filtering, a textured glossy wall's sheen would follow its texture
// (too much on the light texels, too little on the dark).
fn reflectance(s: Surface, l: Lobes) -> vec3<f32> {
    // The diffuse and thin-transmission lobes share l.base × albedo; the coat reflects what it
    // does not leave to the layers below.
    return l.under * (l.specular + l.base * s.albedo) + vec3<f32>(1.0 - l.under);
}

// A surface that scatters nothing diffusely and reflects or passes light nearly undisturbed (a
// mirror, clear glass): what is seen in it is as sharp as what is seen directly.
fn is_smooth(s: Surface, l: Lobes) -> bool {
    return s.roughness <= CLEAR_ROUGHNESS && l.p.y <= 0.01 && (s.transmission <= 0.0 || s.clear)
        && (s.clearcoat <= 0.0 || s.coat_roughness <= CLEAR_ROUGHNESS);
}

// Caps light that reaches the eye after `reflections` reflections, from clamp_from on: rare paths
// that find a light from up close after a bounce otherwise show as speckles for thousands of
// samples. Direct light (seen, or reflected once) is never capped in an image, and the cap is in
// scene units, so the exposure changes no radiance. Biased, so the reference tests turn it off.
fn indirect(c: vec3<f32>, reflections: u32) -> vec3<f32> {
    let l = luminance(c);
    if reflections < view.clamp_from || view.indirect_clamp <= 0.0 || l <= view.indirect_clamp {
        return c;
    }
    return c * (view.indirect_clamp / l);
}

fn path_radiance(o0: vec3<f32>, d0: vec3<f32>) -> vec3<f32> {
    var o = o0;
    var d = d0;
    var throughput = vec3<f32>(1.0);
    var radiance = vec3<f32>(0.0);
    // The density of the BSDF sample that gave d (for the panorama's weight where it escapes).
    var last_pdf = 0.0;
    var bounce = 0u;
    // Clear surfaces passed straight: not bounces (a window does not cost the light behind it one).
    var passes = 0u;
    // How far the path has come since its last bounce (through the clear surfaces it passed).
    var travelled = 0.0;
    // Whether every surface met so far was smooth (`is_smooth`): light gathered meanwhile is
    // seen, not scattered (primary_emission).
    var seen = true;
    loop {
        let hit = closest_hit(view.root, o, d, FAR);
        if hit.triangle == NONE {
            var sky = vec3<f32>(0.0);
            if bounce == 0u {
                sky = throughput * background(d);
            } else {
                var w = 1.0;
                if (env_flags() & ENV_SAMPLED) != 0u {
                    let p_light = env_pdf(d);
                    w = power_heuristic(last_pdf, p_light);
                }
                sky = indirect(throughput * sky_radiance(d) * w, bounce);
            }
            radiance += sky;
            // Sky seen directly is the denoiser's sky pixel (its own albedo, white); seen in a
            // mirror or through glass, it is light the smooth surfaces show.
            if seen && !(bounce == 0u && passes == 0u) {
                primary_emission += sky * view.sky.w;
            }
            break;
        }
        let primary = bounce == 0u && passes == 0u;
        if primary {
            primary_depth = clip_depth(o + d * hit.t);
            primary_object = object_identity(hit);
        }
        let s = surface_at(hit, o, d);
        if primary {
            primary_albedo = vec3<f32>(0.0);
            primary_normal = s.ns;
        }
        let wo = -d;
        var w_emitted = 1.0;
        if bounce > 0u && max(s.emissive.x, max(s.emissive.y, s.emissive.z)) > 0.0 {
            // The emitters' shadow rays find this light too: weigh the two (power heuristic).
            let factor = objects[object_slot(hit)].emissive.rgb;
            let p_light = emitter_pdf(factor, travelled + hit.t, abs(dot(s.ng, d)));
            w_emitted = power_heuristic(last_pdf, p_light);
        }
        let emitted = indirect(throughput * s.emissive * w_emitted, bounce);
        radiance += emitted;
        let last = bounce == view.max_bounces;
        let l = lobes_at(s, wo);
        if seen {
            primary_emission += emitted * view.sky.w;
            if !is_smooth(s, l) {
                seen = false;
                primary_albedo = throughput * reflectance(s, l);
            }
        }
        if !last {
            // Light found by a shadow ray from this hit reaches the eye after bounce + 1
            // reflections.
            let direct = indirect(throughput * direct_light(s, l, wo), bounce + 1u);
            radiance += direct;
            if seen {
                primary_emission += direct * view.sky.w;
            }
        }
        // A clear surface passes the path straight on, with its transmission lobe's probability;
        // the light beyond counts as seen from the last bounce (its pdf weighs the sky's share).
        if s.clear && rand() < l.p.z {
            if passes == MAX_PASSES {
                break;
            }
            passes += 1u;
            travelled += hit.t;
            throughput *= clear_transmittance(s, abs(dot(s.ng, wo))) / l.p.z;
            o = offset(s.p, -s.ng);
            continue;
        }
        if last {
            break;
        }
        let wi = sample_direction(s, l, wo);
        let p = pdf(s, l, wo, wi);
        let cos_s = dot(s.ns, wi);
        let cos_g = dot(s.ng, wi);
        // Written so that a NaN pdf also ends the path; the normals must agree on the side.
        if !(p > 0.0) || cos_s * cos_g <= 0.0 {
            break;
        }
        // The occlusion map dims the light bounced off the surface, not what lights strike it.
        throughput *= bsdf(s, l, wo, wi) * (abs(cos_s) * s.occlusion / p);
        last_pdf = p;
        // Russian roulette once the path has done most of its work.
        if bounce >= 2u {
            let q = min(max(throughput.x, max(throughput.y, throughput.z)), 0.95);
            if rand() >= q {
                break;
            }
            throughput /= q;
        }
        o = offset(s.p, select(-s.ng, s.ng, cos_g > 0.0));
        d = wi;
        bounce += 1u;
        travelled = 0.0;
    }
    return radiance * view.sky.w;
}

fn id_colour(id: u32) -> vec3<f32> {
    let h = pcg(id + 1u);
    return vec3<f32>(f32(h & 255u), f32((h >> 8u) & 255u), f32((h >> 16u) & 255u)) / 255.0;
}

fn heat(x: f32) -> vec3<f32> {
    let t = clamp(x, 0.0, 1.0);
    return clamp(vec3<f32>(1.5 * t - 0.25, 1.5 - abs(3.0 * t - 1.5), 1.25 - 2.5 * t), vec3<f32>(0.0), vec3<f32>(1.0))
        + vec3<f32>(max(t - 0.8, 0.0) * 5.0);
}

// What the debug views show at the primary hit.
fn debug_value(o: vec3<f32>, d: vec3<f32>) -> vec3<f32> {
    let hit = closest_hit(view.root, o, d, FAR);
    if hit.triangle != NONE {
        primary_depth = clip_depth(o + d * hit.t);
        primary_object = object_identity(hit);
    }
    if view.mode == MODE_HEATMAP {
        return heat(f32(hit.visited) / HEATMAP_MAX);
    }
    if hit.triangle == NONE {
        return vec3<f32>(0.0);
    }
    if view.mode == MODE_TRIANGLE_ID {
        return id_colour(hit.triangle);
    }
    let s = surface_at(hit, o, d);
    if view.mode == MODE_NORMALS {
        return s.ns * 0.5 + vec3<f32>(0.5);
    }
    return s.albedo;
}

// The camera ray through `uv` (0..1 across the view, y down): from the near plane, through a point
// further along, so perspective and orthographic projections both work.
fn camera_ray(uv: vec2<f32>) -> array<vec3<f32>, 2> {
    let ndc = vec2<f32>(uv.x * 2.0 - 1.0, 1.0 - uv.y * 2.0);
    let near = view.world_from_clip * vec4<f32>(ndc, 1.0, 1.0);
    let mid = view.world_from_clip * vec4<f32>(ndc, 0.5, 1.0);
    // Both relative to the camera: their difference keeps its digits however far out it stands.
    let o = near.xyz / near.w;
    return array<vec3<f32>, 2>(view.origin.xyz + o, normalize(mid.xyz / mid.w - o));
}

// Reversed-z depth of a world-space point, as Bevy's depth buffer holds it.
fn clip_depth(p: vec3<f32>) -> f32 {
    let c = view.clip_from_world * vec4<f32>(p - view.origin.xyz, 1.0);
    return clamp(c.z / c.w, 0.0, 1.0);
}

// a * b mod m without overflow (m < 2^31), by doubling: the tile sequence's products exceed 32 bits
// on large images.
fn mul_mod(a: u32, b: u32, m: u32) -> u32 {
    var r = 0u;
    var x = a % m;
    var y = b;
    loop {
        if y == 0u {
            break;
        }
        if (y & 1u) != 0u {
            r = (r + x) % m;
        }
        x = (x + x) % m;
        y = y >> 1u;
    }
    return r;
}

// One sample through the image point `at` (pixels, continuous): its value, or zero for a bad path
// sample (inf or NaN), which would otherwise stain the pixel until the next restart. Sets
// primary_depth.
fn trace_sample(at: vec2<f32>) -> vec3<f32> {
    primary_depth = 0.0;
    primary_object = NONE;
    primary_albedo = vec3<f32>(1.0);
    primary_normal = vec3<f32>(0.0);
    primary_emission = vec3<f32>(0.0);
    let ray = camera_ray(at / vec2<f32>(f32(view.width), f32(view.height)));
    if view.mode == MODE_PATH {
        let l = path_radiance(ray[0], ray[1]);
        if all(l == l) && all(abs(l) < vec3<f32>(FAR)) {
            return l;
        }
        return vec3<f32>(0.0);
    }
    return debug_value(ray[0], ray[1]);
}

// Ids and heat are per pixel centre: averaging them across edges would mean nothing.
fn jittered() -> bool {
    return view.mode == MODE_PATH || view.mode == MODE_ALBEDO || view.mode == MODE_NORMALS;
}

// The n-th sample's position in pixel `pixel` (0..1 each way): the 2D Sobol sequence shifted by
// an offset of the pixel's own (Cranley-Patterson rotation), so each power-of-two run of a pixel's
// samples covers it evenly (its edges' coverage converges faster than by random positions) while
// neighbours' patterns stay unrelated.
fn pixel_position(pixel: u32, n: u32) -> vec2<f32> {
    var second = 0u;
    var v = 0x80000000u;
    var i = n;
    while i != 0u {
        if (i & 1u) != 0u {
            second ^= v;
        }
        i >>= 1u;
        v ^= v >> 1u;
    }
    let sobol = vec2<f32>(f32(reverseBits(n) >> 8u), f32(second >> 8u)) * (1.0 / 16777216.0);
    let h = pcg(pixel ^ pcg(view.sample_seed + 0x5bd1e995u));
    let shift = vec2<f32>(f32(h >> 8u), f32(pcg(h) >> 8u)) * (1.0 / 16777216.0);
    return fract(sobol + shift);
}

// A pixel's n-th sample draws its random numbers from (pixel, n) and the view's seed alone, so the
// image after n samples per pixel is the same however the frames split the work into tiles.
fn seed(pixel: u32, n: u32) -> u32 {
    return pcg(pixel ^ pcg(n * 0x9e3779b9u + 0x632be5abu + view.sample_seed * 0x85ebca6bu));
}

// A preview frame's sample for block q of preview_scale² pixels, overwriting the preview.
fn trace_preview_block(q: vec2<u32>) {
    let k = view.preview_scale;
    let pw = (view.width + k - 1u) / k;
    let ph = (view.height + k - 1u) / k;
    if q.x >= pw || q.y >= ph {
        return;
    }
    let block = q.y * pw + q.x;
    rng_state = pcg(block ^ pcg(view.preview_seed * 0x85ebca6bu + 0x27d4eb2fu));
    var sub = vec2<f32>(0.5);
    if jittered() {
        sub = vec2<f32>(rand(), rand());
    }
    let lo = vec2<f32>(q * k);
    let hi = min(vec2<f32>((q + 1u) * k), vec2<f32>(f32(view.width), f32(view.height)));
    let value = trace_sample(lo + (hi - lo) * sub);
    let pixels = view.width * view.height;
    let at = 2u * pixels + 4u * block;
    aux[at] = bitcast<u32>(value.r);
    aux[at + 1u] = bitcast<u32>(value.g);
    aux[at + 2u] = bitcast<u32>(value.b);
    aux[at + 3u] = bitcast<u32>(primary_depth);
    aux[block_objects_start(view.width, view.height) + block] = primary_object;
}

// One workgroup per tile of the sequence; or, in a preview frame, one invocation per block of
// preview_scale² pixels (trace_preview_block).
@compute @workgroup_size(8, 8, 1)
fn path_trace(
    @builtin(workgroup_id) group: vec3<u32>,
    @builtin(num_workgroups) groups: vec3<u32>,
    @builtin(local_invocation_id) local: vec3<u32>,
) {
    if view.preview_scale > 0u {
        trace_preview_block(group.xy * 8u + local.xy);
        return;
    }
    let linear = group.y * groups.x + group.x;
    if linear >= view.tile_count {
        return;
    }
    let j = (view.tile_start + linear) % view.tile_total;
    let tile = mul_mod(j, view.tile_stride, view.tile_total);
    let p = vec2<u32>(tile % view.tiles_x, tile / view.tiles_x) * 8u + local.xy;
    if p.x >= view.width || p.y >= view.height {
        return;
    }
    let pixel = p.y * view.width + p.x;
    let acc = accum[pixel];
    let first = u32(acc.w);
    var sum = vec3<f32>(0.0);
    // The summed luminance of the light the first P samples reflect, P the largest power of two
    // below the count, and their mean albedo luminance: they and the rest are two independent
    // estimates of the pixel's lighting, each covering it evenly (a power-of-two run of the Sobol
    // sequence, and the start of the next), so their difference tells the denoiser the noise of
    // the mean (the samples' spread cannot: what varies across the pixel, a texture or an edge,
    // spreads them while the even cover averages it out). Each part is divided by its own albedo
    // and less its own emission, so the texels a part's samples met, or whether a pane passed or
    // reflected them, is not taken for noise. The head's sign bit is set once the pixel's samples
    // have met more than one surface (a silhouette, or a crease: `CREASE_COSINE`): the denoiser
    // keeps such mixed pixels from standing in for their neighbours.
    var head = 0.0;
    var head_albedo = 0.0;
    // The first P / 2 samples' share of the head sum and their mean albedo luminance: the head
    // split in two, so the denoiser has three parts (four with the tail's split, below), and a
    // firefly must be in all of them to pass for lighting the samples agree on (two parts of 8
    // samples each both catch a path that one sample in 20 finds one time in nine; four parts of
    // 4 samples, one time in 850).
    var split = vec2<f32>(0.0);
    // The tail's split (the samples after the head): the first half of a head's count of them,
    // their share of the tail's sum and their mean albedo luminance, so the denoiser has four
    // parts once the tail is past that half. Kept as a share of the tail as it stands, so each
    // frame turns it back into a sum (`tail_first`) and the sum into a share again.
    var tail_split = vec2<f32>(0.0);
    var tail_first = 0.0;
    var mixed = false;
    // And the sums of the primary hits' albedo and emission (kept as a mean): lighting is
    // filtered apart from the one, and the other passes unfiltered.
    var albedo = vec3<f32>(0.0);
    var emission = vec3<f32>(0.0);
    let g = GUIDE_WORDS * pixel;
    let slot_at = view.width * view.height + pixel;
    if first > 0u {
        let m = guides[g + GUIDE_HEAD];
        head = bitcast<f32>(m & 0x7fffffffu);
        mixed = (m >> 31u) != 0u;
        albedo = vec3<f32>(
            bitcast<f32>(guides[g + GUIDE_ALBEDO]),
            bitcast<f32>(guides[g + GUIDE_ALBEDO + 1u]),
            bitcast<f32>(guides[g + GUIDE_ALBEDO + 2u]),
        );
        emission = guide_emission(pixel) * f32(first);
        head_albedo = guide_head_albedo(pixel);
        split = unpack2x16unorm(aux[head_split_at(view.width, view.height, pixel)]);
        tail_split = unpack2x16unorm(aux[tail_split_at(view.width, view.height, pixel)]);
        if four_parts(first) {
            tail_first = tail_split.x * max(luminance(acc.rgb - emission) - head, 0.0);
        }
    }
    for (var k = 0u; k < view.samples; k += 1u) {
        rng_state = seed(pixel, first + k);
        var sub = vec2<f32>(0.5);
        if jittered() {
            sub = pixel_position(pixel, first + k);
        }
        let value = trace_sample(vec2<f32>(p) + sub);
        let index = first + k;
        if index != 0u && (index & (index - 1u)) == 0u {
            // Not below 0 (the emission's rounding): the sign bit is the mixed flag.
            let whole = max(luminance(acc.rgb + sum - emission), 0.0);
            // The old head covered the first index / 2 samples.
            split = vec2<f32>(select(0.5, head / whole, whole > 0.0), head_albedo);
            head = whole;
            head_albedo = luminance(albedo) / f32(index);
            tail_first = 0.0;
            tail_split = vec2<f32>(0.0);
        } else if four_parts(index + 1u) && !four_parts(index) {
            // The tail's first half is complete.
            let a = f32(head_count(index + 1u));
            tail_first = max(luminance(acc.rgb + sum - emission) - head, 0.0);
            tail_split.y = max(luminance(albedo) - head_albedo * a, 0.0) / (0.5 * a);
        }
        sum += value;
        albedo += clamp(primary_albedo, vec3<f32>(0.0), vec3<f32>(1.0));
        emission += primary_emission;
        if first + k == 0u {
            aux[pixel] = bitcast<u32>(primary_depth);
            aux[slot_at] = primary_object;
            guides[g + GUIDE_NORMAL] = encode_normal(primary_normal);
        } else if primary_object != aux[slot_at] {
            mixed = true;
        } else if primary_object != NONE {
            // The normal guide is the mean of the normals met on the first sample's object
            // (weighed as every sample before: close enough for a guide), and a sample far from
            // it found a crease.
            let mean = decode_normal(guides[g + GUIDE_NORMAL]);
            if dot(primary_normal, mean) < CREASE_COSINE {
                mixed = true;
            }
            let summed = mean * f32(first + k) + primary_normal;
            if dot(summed, summed) > 1e-12 {
                guides[g + GUIDE_NORMAL] = encode_normal(normalize(summed));
            }
        }
    }
    guides[g + GUIDE_HEAD] = bitcast<u32>(head) | select(0u, 0x80000000u, mixed);
    for (var c = 0u; c < 3u; c += 1u) {
        guides[g + GUIDE_ALBEDO + c] = bitcast<u32>(albedo[c]);
    }
    // f16's largest finite value bounds it: an infinity would poison the subtraction.
    let mean = min(emission / f32(first + view.samples), vec3<f32>(65504.0));
    guides[g + GUIDE_EMISSION] = pack2x16float(mean.rg);
    guides[g + GUIDE_EMISSION + 1u] = pack2x16float(vec2<f32>(mean.b, head_albedo));
    aux[head_split_at(view.width, view.height, pixel)] = pack2x16unorm(split);
    let n = first + view.samples;
    if four_parts(n) {
        let tail = max(luminance(acc.rgb + sum - emission) - head, 0.0);
        tail_split.x = select(0.5, tail_first / tail, tail > 0.0);
    } else {
        tail_split = vec2<f32>(0.0);
    }
    aux[tail_split_at(view.width, view.height, pixel)] = pack2x16unorm(tail_split);
    accum[pixel] = vec4<f32>(acc.rgb + sum, acc.w + f32(view.samples));
}
