// Interference surfaces, step 1 (the data pass): one invocation per pixel finds the grid point
// it shows — in map view directly (pixel centres on grid nodes at the default size), in the
// perspective view by marching the camera ray over the relief and refining the hit by bisection,
// in the globe view where the ray meets the unit sphere (latitude and longitude to nodes) —
// and writes up to four properties there into float targets in one pass: the f32 part `hi` of
// (d − d_ref) and the f32 remainder `rest`, so the fringe pass can keep f64 precision through the
// phase. Missing nodes never leak into neighbours: interpolation weights only valid corners, and a
// pixel is missing when its nearest node is. Keep Params in sync with
// src/render/surface/params.rs (DataParams).
#include "shared/camera.wgsl"

struct Params {
    eye: vec4<f32>,
    forward: vec4<f32>,
    right: vec4<f32>,
    up: vec4<f32>,
    proj: vec4<f32>,
    // x, y: world spacing of nodes; z: world units per height unit (exaggeration); w: height at z = 0
    cell: vec4<f32>,
    // xyz: direction towards the light; w: ambient fraction
    light: vec4<f32>,
    // box size in world units (relief box), w unused
    box_size: vec4<f32>,
    // globe view: first longitude, longitude spacing, first latitude, latitude spacing (degrees)
    globe: vec4<f32>,
    // x: nx, y: ny, z: width, w: height
    dims: vec4<u32>,
    // x: number of properties written; y: 1 when the longitudes close the circle (globe view);
    // z: 1 when y runs downward in map view (a depth axis: row 0 is the first node)
    counts: vec4<u32>,
    // globe view: rows of the rotation from true to the grid's longitude–latitude frame (the
    // identity unless the grid is on a rotated pole)
    globe_rotation: array<vec4<f32>, 3>,
}

// 1: map view (top-down orthographic, pixel centres spread evenly over the nodes); 0: perspective
// over the relief; 2: globe (the grid draped on the unit sphere).
override VIEW: u32 = 1u;

@group(0) @binding(0) var<uniform> params: Params;
// Storage buffers rather than textures: plain loads and stores are several times faster on
// Mesa's CPU rasterizers. Nodes are row-major (x fastest), pixels row-major from the top.
@group(0) @binding(1) var<storage, read> node_hi: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> node_rest: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> node_valid: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> node_height: array<f32>;
// Outputs are planes, one per property (index slot · width · height + pixel), so the fringe
// pass reads only the property it shows; the mask holds (valid bits, shading) per pixel,
// shading −1 where the ray meets no surface.
@group(0) @binding(5) var<storage, read_write> out_hi: array<f32>;
@group(0) @binding(6) var<storage, read_write> out_rest: array<f32>;
@group(0) @binding(7) var<storage, read_write> out_mask: array<vec2<f32>>;

fn node(c: vec2<u32>) -> u32 {
    return c.y * params.dims.x + c.x;
}

struct Sample {
    hi: vec4<f32>,
    rest: vec4<f32>,
    mask: u32,
}

// Bilinear sample of the properties at continuous node coordinates (u along x, v along y),
// weighting valid corners only; `mask` has bit p set when property p's nearest node is valid.
fn sample_props(u: f32, v: f32) -> Sample {
    // With closed longitudes u runs up to nx (the wrap back to the first node).
    let umax = select(f32(params.dims.x - 1u), f32(params.dims.x), params.counts.y == 1u);
    let uv = clamp(vec2<f32>(u, v), vec2<f32>(0.0), vec2<f32>(umax, f32(params.dims.y - 1u)));
    let base = min(vec2<u32>(floor(uv)), params.dims.xy - vec2<u32>(1u));
    let f = min(uv - vec2<f32>(base), vec2<f32>(1.0));
    var next = min(base + vec2<u32>(1u), params.dims.xy - vec2<u32>(1u));
    if (params.counts.y == 1u && base.x + 1u == params.dims.x) {
        // Longitudes that close the circle: the last node's neighbour is the first.
        next.x = 0u;
    }
    if (all(f == vec2<f32>(0.0))) {
        // On a node (map view at the default size): the node's values, untouched.
        let k = node(base);
        let ok = node_valid[k] > vec4<f32>(0.5);
        var mask = 0u;
        for (var p = 0u; p < 4u; p++) {
            if (ok[p]) {
                mask |= 1u << p;
            }
        }
        return Sample(select(vec4<f32>(0.0), node_hi[k], ok), select(vec4<f32>(0.0), node_rest[k], ok), mask);
    }
    let c = array<vec2<u32>, 4>(base, vec2<u32>(next.x, base.y), vec2<u32>(base.x, next.y), next);
    let w = array<f32, 4>((1.0 - f.x) * (1.0 - f.y), f.x * (1.0 - f.y), (1.0 - f.x) * f.y, f.x * f.y);
    var hi = vec4<f32>(0.0);
    var rest = vec4<f32>(0.0);
    var wsum = vec4<f32>(0.0);
    for (var k = 0u; k < 4u; k++) {
        let n = node(c[k]);
        let wk = w[k] * node_valid[n];
        hi += wk * node_hi[n];
        rest += wk * node_rest[n];
        wsum += wk;
    }
    let near = select(base, next, f >= vec2<f32>(0.5));
    let nv = node_valid[node(near)];
    let ok = nv > vec4<f32>(0.5) & wsum > vec4<f32>(0.0);
    let safe = select(vec4<f32>(1.0), wsum, ok);
    var mask = 0u;
    for (var p = 0u; p < 4u; p++) {
        if (ok[p]) {
            mask |= 1u << p;
        }
    }
    return Sample(select(vec4<f32>(0.0), hi / safe, ok), select(vec4<f32>(0.0), rest / safe, ok), mask);
}

fn height_at(u: f32, v: f32) -> f32 {
    let nmax = vec2<f32>(f32(params.dims.x - 1u), f32(params.dims.y - 1u));
    let uv = clamp(vec2<f32>(u, v), vec2<f32>(0.0), nmax);
    let base = min(vec2<u32>(floor(uv)), params.dims.xy - vec2<u32>(1u));
    let f = uv - vec2<f32>(base);
    let next = min(base + vec2<u32>(1u), params.dims.xy - vec2<u32>(1u));
    let h00 = node_height[node(base)];
    let h10 = node_height[node(vec2<u32>(next.x, base.y))];
    let h01 = node_height[node(vec2<u32>(base.x, next.y))];
    let h11 = node_height[node(next)];
    let h = mix(mix(h00, h10, f.x), mix(h01, h11, f.x), f.y);
    return (h - params.cell.w) * params.cell.z;
}

// Where the ray first meets the unit sphere in front of the eye (x: distance, y: 1 on a hit), the
// near root taken without cancellation as in geometry::sphere_hit.
fn globe_hit(o: vec3<f32>, d: vec3<f32>) -> vec2<f32> {
    let a = dot(d, d);
    let b = dot(o, d);
    let c = dot(o, o) - 1.0;
    let disc = b * b - a * c;
    if (disc <= 0.0) {
        return vec2<f32>(0.0);
    }
    let q = -(b + select(-1.0, 1.0, b >= 0.0) * sqrt(disc));
    let t = min(q / a, c / q);
    return vec2<f32>(t, select(0.0, 1.0, t >= 0.0));
}

// Fractional node coordinates of a sphere point (GlobeFrame::node_coords); z < 0 when the point
// lies outside the grid's cells.
fn globe_nodes(p_true: vec3<f32>) -> vec3<f32> {
    let deg = 57.29577951308232;
    let r = params.globe_rotation;
    let p = vec3<f32>(dot(r[0].xyz, p_true), dot(r[1].xyz, p_true), dot(r[2].xyz, p_true));
    let lat = atan2(p.z, length(p.xy)) * deg;
    let lon = atan2(p.y, p.x) * deg;
    let g = params.globe;
    let n = vec2<f32>(params.dims.xy);
    let v = (lat - g.z) / g.w;
    if (v < -0.5 || v > n.y - 0.5) {
        return vec3<f32>(0.0, 0.0, -1.0);
    }
    let rel = (lon - g.x) / g.y;
    var u: f32;
    if (params.counts.y == 1u) {
        u = rel - n.x * floor(rel / n.x);
        u = select(u, 0.0, u >= n.x);
    } else {
        let turn = 360.0 / g.y;
        let r = rel + 0.5;
        u = r - turn * floor(r / turn) - 0.5;
        if (u > n.x - 0.5) {
            return vec3<f32>(0.0, 0.0, -1.0);
        }
        u = clamp(u, 0.0, n.x - 1.0);
    }
    return vec3<f32>(u, clamp(v, 0.0, n.y - 1.0), 1.0);
}

@compute @workgroup_size(8, 8, 1)
fn main(@builtin(global_invocation_id) gid: vec3<u32>) {
    let w = params.dims.z;
    let h = params.dims.w;
    if (gid.x >= w || gid.y >= h) {
        return;
    }
    let px = gid.y * w + gid.x;
    var u: f32;
    var v: f32;
    var shade = 1.0;
    var hit = true;
    if (VIEW == 1u) {
        // Pixel centres spread evenly over the node range; at the default size (one pixel per
        // node) u and v are exact integers. Row 0 is the northern (largest y) row, or the first
        // node on a depth axis (SurfaceGeometry::map_v).
        let scale = vec2<f32>(f32(params.dims.x), f32(params.dims.y)) / vec2<f32>(f32(w), f32(h));
        u = (f32(gid.x) + 0.5) * scale.x - 0.5;
        let row = (f32(gid.y) + 0.5) * scale.y - 0.5;
        v = select(f32(params.dims.y - 1u) - row, row, params.counts.z == 1u);
    } else if (VIEW == 2u) {
        let ray = camera_ray(gid.x, gid.y, w, h, params.eye.xyz, params.forward.xyz,
                             params.right.xyz, params.up.xyz, params.proj);
        let sphere = globe_hit(ray.origin, ray.dir);
        hit = false;
        if (sphere.y > 0.5) {
            let p = ray.origin + sphere.x * ray.dir;
            let nodes = globe_nodes(p);
            if (nodes.z > 0.0) {
                u = nodes.x;
                v = nodes.y;
                hit = true;
                // Headlight (GlobeFrame::shade): the normal of the unit sphere is p.
                let amb = params.light.w;
                shade = amb + (1.0 - amb) * max(-dot(p, ray.dir), 0.0);
            }
        }
    } else {
        let ray = camera_ray(gid.x, gid.y, w, h, params.eye.xyz, params.forward.xyz,
                             params.right.xyz, params.up.xyz, params.proj);
        let span = box_hit(ray.origin, ray.dir, params.box_size.xyz);
        hit = false;
        if (span.x < span.y) {
            let t0 = max(span.x, 0.0);
            let horiz = max(length(ray.dir.xy), 1e-6);
            let cell = min(params.cell.x, params.cell.y);
            let dt = max(0.5 * cell / horiz, (span.y - t0) / 4096.0);
            let steps = u32(ceil((span.y - t0) / dt));
            var prev = t0;
            for (var s = 0u; s <= steps; s++) {
                let t = min(t0 + f32(s) * dt, span.y);
                let p = ray.origin + t * ray.dir;
                if (p.z <= height_at(p.x / params.cell.x, p.y / params.cell.y)) {
                    var lo = prev;
                    var hi_t = t;
                    for (var k = 0; k < 12; k++) {
                        let mid = 0.5 * (lo + hi_t);
                        let q = ray.origin + mid * ray.dir;
                        if (q.z <= height_at(q.x / params.cell.x, q.y / params.cell.y)) {
                            hi_t = mid;
                        } else {
                            lo = mid;
                        }
                    }
                    let q = ray.origin + hi_t * ray.dir;
                    u = q.x / params.cell.x;
                    v = q.y / params.cell.y;
                    hit = true;
                    break;
                }
                prev = t;
            }
        }
        if (hit) {
            let dzdx = (height_at(u + 1.0, v) - height_at(u - 1.0, v)) / (2.0 * params.cell.x);
            let dzdy = (height_at(u, v + 1.0) - height_at(u, v - 1.0)) / (2.0 * params.cell.y);
            let n = normalize(vec3<f32>(-dzdx, -dzdy, 1.0));
            let amb = params.light.w;
            shade = amb + (1.0 - amb) * max(dot(n, normalize(params.light.xyz)), 0.0);
        }
    }
    if (!hit) {
        for (var p = 0u; p < params.counts.x; p++) {
            out_hi[p * w * h + px] = 0.0;
            out_rest[p * w * h + px] = 0.0;
        }
        // Shading −1: no surface here (the background), not a hole in it; a missing colour
        // paints holes only.
        out_mask[px] = vec2<f32>(0.0, -1.0);
        return;
    }
    let s = sample_props(u, v);
    for (var p = 0u; p < params.counts.x; p++) {
        out_hi[p * w * h + px] = s.hi[p];
        out_rest[p * w * h + px] = s.rest[p];
    }
    out_mask[px] = vec2<f32>(f32(s.mask), shade);
}
