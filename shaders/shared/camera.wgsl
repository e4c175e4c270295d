// Camera rays and the ray–box test. Keep in sync with src/model/camera.rs (Camera::ray) and
// src/model/volume.rs (Aabb::intersect). Positions are relative to the volume's lower corner.

// The pixel of invocation l of workgroup `tile` (workgroups of 64 over the image's 8 x 8
// tiles): each run of 8 invocations (a SIMD vector on lavapipe, a quarter warp on NVIDIA) is a
// 4 x 2 block of the tile rather than a row of 8, so neighbouring rays in both directions share
// a vector and its lanes meet walls at nearer depths and finish closer together (in-core ray
// caster: opaque wall 4 %, sparse blobs 5 % faster than rows).
fn tile_pixel(tile: vec3<u32>, l: u32) -> vec2<u32> {
    let block = l / 8u;
    let lane = l % 8u;
    return vec2<u32>(tile.x * 8u + (block % 2u) * 4u + lane % 4u, tile.y * 8u + (block / 2u) * 2u + lane / 4u);
}

struct Ray {
    origin: vec3<f32>,
    dir: vec3<f32>,
}

// proj.x > 0.5: perspective with proj.y, proj.z = tan of the half angles in x and y;
// otherwise orthographic with proj.y, proj.z = half width and half height.
fn camera_ray(px: u32, py: u32, w: u32, h: u32, eye: vec3<f32>, forward: vec3<f32>,
              right: vec3<f32>, up: vec3<f32>, proj: vec4<f32>) -> Ray {
    let sx = 2.0 * (f32(px) + 0.5) / f32(w) - 1.0;
    let sy = 1.0 - 2.0 * (f32(py) + 0.5) / f32(h);
    if (proj.x > 0.5) {
        return Ray(eye, normalize(forward + (sx * proj.y) * right + (sy * proj.z) * up));
    }
    return Ray(eye + (sx * proj.y) * right + (sy * proj.z) * up, forward);
}

// Entry and exit distances of the ray through the box [0, size]; empty when x >= y.
fn box_hit(o: vec3<f32>, d: vec3<f32>, size: vec3<f32>) -> vec2<f32> {
    // Axis-parallel rays have zero components; a tiny stand-in avoids 0 * inf = NaN.
    let safe = select(d, vec3<f32>(1e-30), abs(d) < vec3<f32>(1e-30));
    let inv = 1.0 / safe;
    let ta = -o * inv;
    let tb = (size - o) * inv;
    let near = min(ta, tb);
    let far = max(ta, tb);
    return vec2<f32>(max(max(near.x, near.y), near.z), min(min(far.x, far.y), far.z));
}
