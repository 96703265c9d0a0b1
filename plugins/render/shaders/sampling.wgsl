// Random numbers, frames and ray offsets shared by the kernels that spawn secondary rays (appended by
// the crate after traverse.wgsl).

const PI: f32 = 3.14159265358979;

// A PCG hash: one well-mixed 32-bit value per input.
fn pcg(v: u32) -> u32 {
    let state = v * 747796405u + 2891336453u;
    let word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// Moves a ray origin off the surface it leaves, scaled to the coordinates' magnitude.
fn offset(p: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    let scale = max(1.0, max(abs(p.x), max(abs(p.y), abs(p.z))));
    return p + n * (2e-4 * scale);
}

// An orthonormal basis around n (Duff et al. 2017); n is the third column.
fn basis(n: vec3<f32>) -> mat3x3<f32> {
    let sign = select(-1.0, 1.0, n.z >= 0.0);
    let a = -1.0 / (sign + n.z);
    let b = n.x * n.y * a;
    let t = vec3<f32>(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
    let bt = vec3<f32>(b, sign + n.y * n.y * a, -n.y);
    return mat3x3<f32>(t, bt, n);
}

// A cosine-distributed direction around the frame's third axis, from two uniform numbers.
fn cosine_direction(frame: mat3x3<f32>, u1: f32, u2: f32) -> vec3<f32> {
    let r = sqrt(u1);
    let phi = 2.0 * PI * u2;
    return frame * vec3<f32>(r * cos(phi), r * sin(phi), sqrt(max(0.0, 1.0 - u1)));
}
