// Ray casting of volumes placed by coordinate axes: spherical shells and wedges (SPHERICAL) on
// (radius, latitude, longitude) axes, and rectilinear boxes (otherwise) with non-uniform axes.
// Each ray is cut analytically to the domain (a shell: outer and inner sphere, latitude cones and
// longitude planes; a box: its faces); the segments of the whole ray, as volume.wgsl marches
// them, are cut to those parts and each piece is sampled at its middle, so a constant field
// integrates to the exact chord. A sample maps through the axes to fractional voxel indices and
// is interpolated trilinearly in index space, the longitude of a full circle periodic. Keep in
// sync with src/render/cpu_reference.rs and src/model/geometry.rs (the f64 reference).
#include "shared/optics.wgsl"
#include "shared/camera.wgsl"
#include "shared/march.wgsl"
#include "shared/volume_params.wgsl"

// Keep in sync with MappedParams in src/render/mapped.rs.
struct Mapped {
    // SPHERICAL: x inner radius, y outer radius, z lowest latitude, w highest (degrees).
    // Otherwise: xyz the box's lower corner in world coordinates.
    domain_lo: vec4<f32>,
    // SPHERICAL: x lowest longitude, y highest (degrees), z 1 when the longitude wraps, w the
    // whole turns between x and [-180, 180).
    domain_hi: vec4<f32>,
    // Per coordinate (x: radius or x, y: latitude or y, z: longitude or z): its texture axis,
    // and the same as one-hot rows (texture index = sum of f.c * row c), so no vector is indexed
    // by a runtime value (CPU rasterizers spill such vectors to memory).
    axis_of: vec4<u32>,
    row_x: vec4<f32>,
    row_y: vec4<f32>,
    row_z: vec4<f32>,
    // Per coordinate: the number of centres and where they start in `coords` (uneven axes).
    count: vec4<u32>,
    offset: vec4<u32>,
    // Per coordinate: the first centre and 1 / step of an even axis; 0 marks an uneven one.
    first: vec4<f32>,
    inv_step: vec4<f32>,
    // Per coordinate: +1 or -1, the centres in `coords` times this run upward.
    dir: vec4<f32>,
    // The longitude seam of a full circle: x the first centre, y the last, z the first one
    // turn later (in the axis's direction).
    seam: vec4<f32>,
    // 1 / the texture's size along x, y and z.
    inv_dims: vec4<f32>,
    // The cut-away of a SPHERICAL volume (model::cut::Cut): x, y its latitudes, z its first
    // longitude, w its longitude span (degrees).
    cut: vec4<f32>,
    // x, y the inner and outer radius of its depths.
    cut_r: vec4<f32>,
    // 1 where the cut has a latitude (x), longitude (y) or depth (z) range; w 1 when it exists.
    cut_on: vec4<u32>,
    // The cut-away of a box (model::cut::Cut's x, y, z): the removed box's corners relative to
    // the volume's corner (an absent range spans far beyond the volume); w 1 when it exists.
    box_cut_lo: vec4<f32>,
    box_cut_hi: vec4<f32>,
    // Its planes (Cut::planes_in_frame): the removed half-space n·p >= c as (n, c); unused
    // slots (0, 0, 0, -1) hold everywhere.
    box_cut_planes: array<vec4<f32>, 3>,
    // The skip grid's world cells (render::mapped_skipping): xyz its lower corner in this frame
    // and cells per unit length.
    skip_lo: vec4<f32>,
    skip_cells: vec4<f32>,
    // The cut's faces (model::cut::CutFaces): x 1 when drawn, y fringes per unit of the value
    // (0: none), z how far before a part's start the removed region is probed, w half the
    // width of the depth rings' lines (world units).
    faces: vec4<f32>,
    // The depth rings' radii (0: none).
    rings: vec4<f32>,
}

@group(0) @binding(0) var<uniform> P: Params;
@group(0) @binding(1) var volume_tex: texture_3d<f32>;
@group(0) @binding(2) var lut: texture_2d<f32>;
@group(0) @binding(3) var out_image: texture_storage_2d<rgba32float, write>;
#if HW_FILTER
// Clamped to the edges; the longitude's texture axis repeats where the circle closes.
@group(0) @binding(4) var volume_sampler: sampler;
#endif
@group(0) @binding(5) var<uniform> G: Mapped;
@group(0) @binding(6) var<storage, read> coords: array<f32>;
#if SKIPPING
// Per octant of ray directions, the edge of the cube of empty world cells from each cell
// (render::skipping::octant_extents), read through a nearest-texel sampler.
@group(0) @binding(7) var skip_grid: texture_3d<f32>;
@group(0) @binding(8) var skip_sampler: sampler;
#endif

const DEG: f32 = 57.295779513;

// Fractional index of value x along coordinate c: i at centre i, linear between centres and
// beyond the ends (CoordAxis::fractional_index).
fn axis_index(c: u32, x: f32) -> f32 {
#if UNEVEN
    if (G.inv_step[c] != 0.0) {
        return (x - G.first[c]) * G.inv_step[c];
    }
    return uneven_index(c, x);
#else
    return (x - G.first[c]) * G.inv_step[c];
#endif
}

#if UNEVEN
fn uneven_index(c: u32, x: f32) -> f32 {
    let y = x * G.dir[c];
    let off = G.offset[c];
    var lo = 0u;
    var hi = G.count[c] - 1u;
    // Largest centre at or below y, by bisection (at most 17 halvings for 65536 centres).
    for (var i = 0u; i < 17u; i++) {
        if (hi - lo <= 1u) {
            break;
        }
        let mid = (lo + hi) / 2u;
        if (coords[off + mid] <= y) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let a = coords[off + lo];
    let b = coords[off + lo + 1u];
    return f32(lo) + (y - a) / (b - a);
}
#endif

#if SPHERICAL
// Longitude (degrees, in [-180, 180]) moved by whole turns into [lo, lo + 360):
// one turn up where it lies below lo moved into [-180, 180), then the turns between the two.
fn wrap_lon(lon: f32) -> f32 {
    let turns = G.domain_hi.w;
    return lon + select(0.0, 360.0, lon < G.domain_hi.x - turns) + turns;
}

// Fractional longitude index, across the seam from the last centre to the first one a turn
// later when the axis wraps.
fn lon_index(lon: f32) -> f32 {
#if SEAM
    if (G.domain_hi.z > 0.5) {
        let rising = G.dir.z > 0.0;
        let first = G.seam.x;
        let last = G.seam.y;
        let beyond = select(lon < last || lon > first, lon > last || lon < first, rising);
        if (beyond) {
            var l = lon;
            if (rising && lon < first) {
                l = lon + 360.0;
            } else if (!rising && lon > first) {
                l = lon - 360.0;
            }
            return f32(G.count.z - 1u) + (l - last) / (G.seam.z - last);
        }
    }
#endif
    // Without SEAM an even circle's gap across the seam is one step: the index runs on past
    // the last centre and the texel wrap below joins it to the first.
    return axis_index(2u, lon);
}

// atan(x) for |x| <= 1 as x + x³ q(x²), q fitted to atan within 5e-8 rad over [0, 1] (near the
// f32 rounding of the result), evaluated by Estrin's scheme: a short dependency chain, which is
// what a CPU rasterizer's sample waits on. The builtin atan2 is longer in both (two divisions,
// a longer polynomial by Horner's scheme).
fn atan_unit(x: f32) -> f32 {
    let z = x * x;
    let z2 = z * z;
    let q01 = -0.3333165869 + 0.1996269845 * z;
    let q23 = -0.1397655037 + 0.0979414761 * z;
    let q45 = -0.0577723594 + 0.0230392673 * z;
    let q = (q01 + q23 * z2) + (q45 - 0.0043551637 * z2) * (z2 * z2);
    return x + x * z * q;
}

// (radius, latitude°, longitude° in the domain's turn) of a world point. The latitude from its
// half angle, tan(lat / 2) = z / (r + rho), whose argument never leaves [-1, 1]; the longitude
// from the smaller over the larger of |x| and |y|, put into its octant.
fn spherical(p: vec3<f32>) -> vec3<f32> {
    let rho = length(p.xy);
    let r = length(p);
    let lat = 2.0 * atan_unit(p.z / max(r + rho, 1e-30));
    let ax = abs(p.x);
    let ay = abs(p.y);
    let a = atan_unit(min(ax, ay) / max(max(ax, ay), 1e-30));
    var lon = select(a, 1.5707963268 - a, ay > ax);
    lon = select(lon, 3.1415926536 - lon, p.x < 0.0);
    lon = select(lon, -lon, p.y < 0.0);
    return vec3<f32>(r, lat * DEG, wrap_lon(lon * DEG));
}

fn inside(p: vec3<f32>) -> bool {
    let s = spherical(p);
    return s.x >= G.domain_lo.x && s.x <= G.domain_lo.y && s.y >= G.domain_lo.z
        && s.y <= G.domain_lo.w && (G.domain_hi.z > 0.5 || s.z <= G.domain_hi.y);
}

// Whether the cut-away removes world point p: every range it has holds there.
fn in_cut(p: vec3<f32>) -> bool {
    if (G.cut_on.w == 0u) {
        return false;
    }
    let s = spherical(p);
    let lat_in = G.cut_on.x == 0u || (s.y >= G.cut.x && s.y <= G.cut.y);
    let east = s.z - G.cut.z;
    let lon_in = G.cut_on.y == 0u || east - 360.0 * floor(east / 360.0) <= G.cut.w;
    let r_in = G.cut_on.z == 0u || (s.x >= G.cut_r.x && s.x <= G.cut_r.y);
    return lat_in && lon_in && r_in;
}

// Whether world point p lies in the domain and in the region the cut removes.
fn removed_in_domain(p: vec3<f32>) -> bool {
    return inside(p) && in_cut(p);
}
#else
fn removed_in_domain(p: vec3<f32>) -> bool {
    var removed = G.box_cut_lo.w > 0.5 && all(p >= vec3<f32>(0.0)) && all(p <= P.box_size.xyz)
        && all(p >= G.box_cut_lo.xyz) && all(p <= G.box_cut_hi.xyz);
    for (var i = 0u; i < 3u; i++) {
        removed = removed && dot(G.box_cut_planes[i].xyz, p) >= G.box_cut_planes[i].w;
    }
    return removed;
}
#endif

#if RENORMALISE
const FINITE_ONLY: bool = true;
#else
const FINITE_ONLY: bool = false;
#endif

// The value at world point p under the render's missing-data rule (RENORMALISE: the finite
// voxels' weights renormalised; else strict).
fn sample_at(p: vec3<f32>) -> f32 {
    return sample_with(p, FINITE_ONLY);
}

// The value at world point p (relative to the box's corner for boxes, to the planet's centre
// for shells): trilinear in index space, clamped at the edges, periodic in a full longitude;
// with finite_only over the finite voxels alone (never with the texture unit's filter).
fn sample_with(p: vec3<f32>, finite_only: bool) -> f32 {
#if SPHERICAL
    let s = spherical(p);
    let f = vec3<f32>(axis_index(0u, s.x), axis_index(1u, s.y), lon_index(s.z));
#else
    let w = p + G.domain_lo.xyz;
    let f = vec3<f32>(axis_index(0u, w.x), axis_index(1u, w.y), axis_index(2u, w.z));
#endif
#if CF_AXES
    let g = f.zyx;
#else
    let g = f.x * G.row_x.xyz + f.y * G.row_y.xyz + f.z * G.row_z.xyz;
#endif
#if HW_FILTER
    // The texture unit's trilinear filter at index g (texel centres at i + 0.5).
    return textureSampleLevel(volume_tex, volume_sampler, (g + 0.5) * G.inv_dims.xyz, 0.0).r;
#else
    let dims = vec3<i32>(textureDimensions(volume_tex));
    let g0 = floor(g);
    let t = g - g0;
    let top = dims - vec3<i32>(1);
    var a = clamp(vec3<i32>(g0), vec3<i32>(0), top);
    var b = clamp(vec3<i32>(g0) + vec3<i32>(1), vec3<i32>(0), top);
#if SPHERICAL
    if (G.domain_hi.z > 0.5) {
        // The longitude's texel pair, wrapped (its index lies in [-1, n]): selects, not an
        // integer remainder, which CPU rasterizers do lane by lane.
        let lon_axis = vec3<i32>(G.row_z.xyz);
        let g0i = vec3<i32>(g0);
        let wa = select(g0i, g0i + dims, g0i < vec3<i32>(0));
        let wb = select(g0i + 1, g0i + 1 - dims, g0i + 1 >= dims);
        let on = lon_axis == vec3<i32>(1);
        a = select(a, wa, on);
        b = select(b, wb, on);
    }
#endif
    if (finite_only) {
        return trilinear_finite(volume_tex, a, b, t);
    }
    return trilinear_texels(volume_tex, a, b, t);
#endif
}

#if SHADING
// Blinn–Phong factor under a headlight from the world-space gradient by central differences
// one length unit (P.march.y⁻¹) apart (Volume::gradient_world), sampled strictly under either
// missing-data rule, as the f64 reference does.
fn shading_factor(p: vec3<f32>, dir: vec3<f32>) -> f32 {
    let h = 1.0 / P.march.y;
    let x = vec3<f32>(h, 0.0, 0.0);
    let y = vec3<f32>(0.0, h, 0.0);
    let z = vec3<f32>(0.0, 0.0, h);
    let gx = sample_with(p + x, false) - sample_with(p - x, false);
    let gy = sample_with(p + y, false) - sample_with(p - y, false);
    let gz = sample_with(p + z, false) - sample_with(p - z, false);
    return headlight(vec3<f32>(gx, gy, gz) / (2.0 * h), dir);
}
#endif

#if PREINTEGRATED
#include "shared/preintegrate.wgsl"
#endif

// The parts of a ray inside the domain, in order.
const MAX_PARTS: u32 = 6u;
struct Parts {
    span: array<vec2<f32>, 6>,
    n: u32,
}

#if SPHERICAL
// Entry and exit of the ray on the sphere of radius r, roots without cancellation.
fn sphere_hit(o: vec3<f32>, d: vec3<f32>, r: f32) -> vec2<f32> {
    let a = dot(d, d);
    let b = dot(o, d);
    let c = dot(o, o) - r * r;
    let disc = b * b - a * c;
    if (disc <= 0.0) {
        return vec2<f32>(1.0, -1.0);
    }
    let q = -(b + select(-1.0, 1.0, b >= 0.0) * sqrt(disc));
    if (q == 0.0) {
        return vec2<f32>(0.0);
    }
    let x = q / a;
    let y = c / q;
    return vec2<f32>(min(x, y), max(x, y));
}

// Crossings of the ray with the cone of latitude lat (degrees), both nappes; NaN for none.
fn cone_hits(o: vec3<f32>, d: vec3<f32>, lat: f32) -> vec2<f32> {
    let s = sin(lat / DEG);
    let cs = cos(lat / DEG);
    let s2 = s * s;
    let c2 = cs * cs;
    let a = c2 * d.z * d.z - s2 * dot(d.xy, d.xy);
    let b = c2 * o.z * d.z - s2 * dot(o.xy, d.xy);
    let cc = c2 * o.z * o.z - s2 * dot(o.xy, o.xy);
    let none = bitcast<f32>(0x7fc00000u);
    if (abs(a) < 1e-30) {
        return vec2<f32>(select(none, -cc / (2.0 * b), b != 0.0), none);
    }
    let disc = b * b - a * cc;
    if (disc < 0.0) {
        return vec2<f32>(none);
    }
    let q = -(b + select(-1.0, 1.0, b >= 0.0) * sqrt(disc));
    if (q == 0.0) {
        return vec2<f32>(0.0, none);
    }
    return vec2<f32>(q / a, cc / q);
}

// The crossings of a cut's latitude cone: the equator's is the plane z = 0 (whose double root
// rounding can lose), a pole's none (NaN).
fn cut_cone(o: vec3<f32>, d: vec3<f32>, lat: f32) -> vec2<f32> {
    let none = bitcast<f32>(0x7fc00000u);
    if (lat == 0.0) {
        return vec2<f32>(-o.z / d.z, none);
    }
    if (abs(lat) < 90.0) {
        return cone_hits(o, d, lat);
    }
    return vec2<f32>(none);
}

// The crossings of the cut-away's cones, longitude planes and spheres, into extra[8..18]
// (Cut::crossings).
fn cut_crossings(extra: ptr<function, array<f32, 18>>, o: vec3<f32>, d: vec3<f32>) {
    if (G.cut_on.w == 0u) {
        return;
    }
    if (G.cut_on.x != 0u) {
        (*extra)[8] = cut_cone(o, d, G.cut.x).x;
        (*extra)[9] = cut_cone(o, d, G.cut.x).y;
        (*extra)[10] = cut_cone(o, d, G.cut.y).x;
        (*extra)[11] = cut_cone(o, d, G.cut.y).y;
    }
    if (G.cut_on.y != 0u) {
        for (var j = 0u; j < 2u; j++) {
            let lon = (G.cut.z + select(0.0, G.cut.w, j == 1u)) / DEG;
            let no = -sin(lon) * o.x + cos(lon) * o.y;
            let nd = -sin(lon) * d.x + cos(lon) * d.y;
            if (nd != 0.0) {
                (*extra)[12u + j] = -no / nd;
            }
        }
    }
    if (G.cut_on.z != 0u) {
        if (G.cut_r.x > 0.0) {
            let s = sphere_hit(o, d, G.cut_r.x);
            if (s.y > s.x) {
                (*extra)[14] = s.x;
                (*extra)[15] = s.y;
            }
        }
        let s = sphere_hit(o, d, G.cut_r.y);
        if (s.y > s.x) {
            (*extra)[16] = s.x;
            (*extra)[17] = s.y;
        }
    }
}

// The ray's chord through the outer sphere from the eye on (empty where it misses).
fn outer_chord(o: vec3<f32>, d: vec3<f32>) -> vec2<f32> {
    let outer = sphere_hit(o, d, G.domain_lo.y);
    return vec2<f32>(max(outer.x, 0.0), outer.y);
}

#if SHELL
// A whole shell: the outer sphere's chord less the inner sphere's, the parts
// SphericalGrid::ray_intervals finds for it (a crossing of the inner sphere counts only strictly
// inside the chord; a tangent ray passes whole).
fn ray_parts(o: vec3<f32>, d: vec3<f32>) -> Parts {
    var out = Parts(array<vec2<f32>, 6>(), 0u);
    let chord = outer_chord(o, d);
    let t0 = chord.x;
    let t1 = chord.y;
    if (!(t1 > t0)) {
        return out;
    }
    var inner = vec2<f32>(1.0, -1.0);
    if (G.domain_lo.x > 0.0) {
        inner = sphere_hit(o, d, G.domain_lo.x);
    }
    if (!(inner.y > inner.x) || inner.y <= t0 || inner.x >= t1) {
        out.span[0] = vec2<f32>(t0, t1);
        out.n = 1u;
        return out;
    }
    // The part in front of the core (where the ray starts outside it), then the one behind it;
    // constant indices, as walk_after reads them.
    let front = inner.x > t0;
    let back = t1 > inner.y;
    out.span[0] = select(vec2<f32>(inner.y, t1), vec2<f32>(t0, inner.x), front);
    out.span[1] = vec2<f32>(inner.y, t1);
    out.n = select(0u, 1u, front) + select(0u, 1u, back);
    return out;
}
#else
// SphericalGrid::ray_intervals: the crossings of every boundary, sorted; the pieces between
// them whose middles are inside, neighbours merged.
fn ray_parts(o: vec3<f32>, d: vec3<f32>) -> Parts {
    var out = Parts(array<vec2<f32>, 6>(), 0u);
    let chord = outer_chord(o, d);
    let t0 = chord.x;
    let t1 = chord.y;
    if (!(t1 > t0)) {
        return out;
    }
    var cuts = array<f32, 20>();
    cuts[0] = t0;
    cuts[1] = t1;
    var n = 2u;
    var extra = array<f32, 18>();
    let none = bitcast<f32>(0x7fc00000u);
    for (var i = 0u; i < 18u; i++) {
        extra[i] = none;
    }
    if (G.domain_lo.x > 0.0) {
        let inner = sphere_hit(o, d, G.domain_lo.x);
        if (inner.y > inner.x) {
            extra[0] = inner.x;
            extra[1] = inner.y;
        }
    }
    if (abs(G.domain_lo.z) < 90.0) {
        let c = cone_hits(o, d, G.domain_lo.z);
        extra[2] = c.x;
        extra[3] = c.y;
    }
    if (abs(G.domain_lo.w) < 90.0) {
        let c = cone_hits(o, d, G.domain_lo.w);
        extra[4] = c.x;
        extra[5] = c.y;
    }
    if (G.domain_hi.z < 0.5) {
        for (var j = 0u; j < 2u; j++) {
            let lon = select(G.domain_hi.x, G.domain_hi.y, j == 1u) / DEG;
            let no = -sin(lon) * o.x + cos(lon) * o.y;
            let nd = -sin(lon) * d.x + cos(lon) * d.y;
            if (nd != 0.0) {
                extra[6u + j] = -no / nd;
            }
        }
    }
    cut_crossings(&extra, o, d);
    // Insertion of the crossings within [t0, t1] into the sorted list.
    for (var i = 0u; i < 18u; i++) {
        let t = extra[i];
        if (!(t > t0 && t < t1)) {
            continue;
        }
        var j = n;
        while (j > 0u && cuts[j - 1u] > t) {
            cuts[j] = cuts[j - 1u];
            j -= 1u;
        }
        cuts[j] = t;
        n += 1u;
    }
    for (var i = 0u; i + 1u < n; i++) {
        let a = cuts[i];
        let b = cuts[i + 1u];
        let middle = o + d * (0.5 * (a + b));
        if (!(b > a) || !inside(middle) || in_cut(middle)) {
            continue;
        }
        if (out.n > 0u && out.span[out.n - 1u].y == a) {
            out.span[out.n - 1u].y = b;
        } else if (out.n < MAX_PARTS) {
            out.span[out.n] = vec2<f32>(a, b);
            out.n += 1u;
        }
    }
    return out;
}
#endif
#else
// Where the ray crosses the cut-away's box and planes (Cut::clip_box's slab method): [enter,
// leave], empty where it misses; a ray parallel to a slab is inside it or misses it.
fn box_cut_hit(o: vec3<f32>, d: vec3<f32>) -> vec2<f32> {
    var c = vec2<f32>(-3.0e38, 3.0e38);
    for (var a = 0u; a < 3u; a++) {
        let lo = G.box_cut_lo[a];
        let hi = G.box_cut_hi[a];
        if (d[a] == 0.0) {
            if (o[a] < lo || o[a] > hi) {
                return vec2<f32>(1.0, -1.0);
            }
            continue;
        }
        let ta = (lo - o[a]) / d[a];
        let tb = (hi - o[a]) / d[a];
        c = vec2<f32>(max(c.x, min(ta, tb)), min(c.y, max(ta, tb)));
    }
    // Each plane is a slab open on one side (Cut::clip_box).
    for (var i = 0u; i < 3u; i++) {
        let pl = G.box_cut_planes[i];
        let no = dot(pl.xyz, o);
        let nd = dot(pl.xyz, d);
        if (nd == 0.0) {
            if (no < pl.w) {
                return vec2<f32>(1.0, -1.0);
            }
        } else if (nd > 0.0) {
            c.x = max(c.x, (pl.w - no) / nd);
        } else {
            c.y = min(c.y, (pl.w - no) / nd);
        }
    }
    return c;
}

// The ray's piece inside the box, less its piece inside the cut-away: none, one or two parts.
fn ray_parts(o: vec3<f32>, d: vec3<f32>) -> Parts {
    var out = Parts(array<vec2<f32>, 6>(), 0u);
    let hit = box_hit(o, d, P.box_size.xyz);
    let t0 = max(hit.x, 0.0);
    let t1 = hit.y;
    if (!(t1 > t0)) {
        return out;
    }
    var c = vec2<f32>(1.0, -1.0);
    if (G.box_cut_lo.w > 0.5) {
        c = box_cut_hit(o, d);
    }
    if (!(c.y > c.x)) {
        out.span[0] = vec2<f32>(t0, t1);
        out.n = 1u;
        return out;
    }
    let front = vec2<f32>(t0, min(c.x, t1));
    let back = vec2<f32>(max(c.y, t0), t1);
    let has_front = front.y > front.x;
    out.span[0] = select(back, front, has_front);
    out.span[1] = back;
    out.n = select(0u, 1u, has_front) + select(0u, 1u, back.y > back.x);
    return out;
}
#endif

// The fixed quantities of one ray: origin and unit direction, where its segment grid starts,
// its first segment, its step (world units) and the step's inverse.
struct Ray2 {
    o: vec3<f32>,
    d: vec3<f32>,
    t_enter: f32,
    first: f32,
    ds: f32,
    inv_ds: f32,
}

fn seg_end(r: Ray2, k: u32) -> f32 {
    return r.t_enter + r.first + f32(k) * r.ds;
}

fn seg_start(r: Ray2, k: u32) -> f32 {
    return select(seg_end(r, k - 1u), r.t_enter, k == 0u);
}

// The segment before the one holding a part's start u, in case rounding put u past its start
// (an empty piece is passed over).
fn first_piece(r: Ray2, u: f32) -> u32 {
    let k = u32(max(floor((u - r.t_enter - r.first) * r.inv_ds), 0.0));
    return select(0u, k, u > seg_end(r, 0u));
}

// Where a ray's march stands: segment k of its grid within part i, [u, v].
struct Walk {
    i: u32,
    k: u32,
    u: f32,
    v: f32,
}

// The walk one segment on: the next segment, or where this part ends, `k_next`, the first
// segment of the next part, `next`. Selects, not a branch: CPU rasterizers would run a branch's
// body on every step anyway.
fn walk_next(w: Walk, r: Ray2, next: vec2<f32>, k_next: u32) -> Walk {
    let ends = seg_end(r, w.k) >= w.v;
    return Walk(select(w.i, w.i + 1u, ends), select(w.k + 1u, k_next, ends), select(w.u, next.x, ends), select(w.v, next.y, ends));
}

// The piece the walk stands on: its segment cut to its part (empty where rounding leaves none).
fn walk_piece(w: Walk, r: Ray2) -> vec2<f32> {
    return vec2<f32>(max(seg_start(r, w.k), w.u), min(seg_end(r, w.k), w.v));
}

// Where piece ab is sampled: its middle.
fn piece_point(r: Ray2, ab: vec2<f32>) -> vec3<f32> {
    return r.o + r.d * (0.5 * (ab.x + ab.y));
}

// Composites piece ab, whose value at its middle is `value`.
fn piece(s: ptr<function, RayState>, r: Ray2, ab: vec2<f32>, value: f32) {
    if ((*s).stopped || !(ab.y > ab.x)) {
        return;
    }
    var ea = select(vec4<f32>(0.0), transfer(value), is_finite_f32(value));
#if SHADING
    if (any(ea.rgb > vec3<f32>(0.0))) {
        ea = vec4<f32>(ea.rgb * shading_factor(piece_point(r, ab), r.d), ea.a);
    }
#endif
    composite(s, ea, (ab.y - ab.x) * P.march.y, P.march.z);
}

#if PREINTEGRATED
// Piece ab pre-integrated between its end values (the front one carried).
fn piece_pre(s: ptr<function, RayState>, front: ptr<function, Front>, r: Ray2, ab: vec2<f32>) {
    if ((*s).stopped || !(ab.y > ab.x)) {
        return;
    }
    let len = (ab.y - ab.x) * P.march.y;
    let back = front_at(sample_at(r.o + r.d * ab.y));
    let piece = segment_between(*front, back, len);
    var ea = piece.ea;
#if SHADING
    if (any(ea.rgb > vec3<f32>(0.0))) {
        ea = vec4<f32>(ea.rgb * shading_factor(piece_point(r, ab), r.d), ea.a);
    }
#endif
    *front = back;
    composite(s, ea, piece.len, P.march.z);
}
#endif

// The walk one segment on (walk_next) through the ray's parts. A whole shell has at most two,
// the second one's first segment found once per ray (`second`); other domains index the parts
// with a runtime value, which CPU rasterizers do through memory.
fn walk_after(w: Walk, r: Ray2, parts: Parts, second: u32) -> Walk {
#if SHELL
    return walk_next(w, r, parts.span[1], second);
#else
    let next = parts.span[min(w.i + 1u, MAX_PARTS - 1u)];
    return walk_next(w, r, next, first_piece(r, next.x));
#endif
}

#if SKIPPING
// The ray in skip-grid cells: the origin at q0, dq cells per unit of t, its inverse (huge along
// an axis the ray does not move on, whose exit then never comes first), the cube's exit faces
// (`up`), the last cell, the first z of the ray's octant in the grid, the grid's texel size and
// a step of t that moves the ray about 1e-3 of a cell (`nudge`).
struct SkipRay {
    q0: vec3<f32>,
    dq: vec3<f32>,
    inv_dq: vec3<f32>,
    up: vec3<bool>,
    top: vec3<i32>,
    layer: i32,
    inv_cells: vec3<f32>,
    nudge: f32,
}

fn skip_ray(r: Ray2) -> SkipRay {
    let dq = r.d * G.skip_cells.xyz;
    let moves = abs(dq) > vec3<f32>(1e-20);
    let inv_dq = select(vec3<f32>(1.0e30), 1.0 / dq, moves);
    let up = select(vec3<bool>(true), dq >= vec3<f32>(0.0), moves);
    let cells = vec3<i32>(textureDimensions(skip_grid)) / vec3<i32>(1, 1, 8);
    let octant = select(1, 0, up.x) + select(2, 0, up.y) + select(4, 0, up.z);
    let fastest = max(abs(dq.x), max(abs(dq.y), abs(dq.z)));
    return SkipRay((r.o - G.skip_lo.xyz) * G.skip_cells.xyz, dq, inv_dq, up, cells - vec3<i32>(1), octant * cells.z, 1.0 / vec3<f32>(textureDimensions(skip_grid)), 1e-3 / fastest);
}

// From t, where the ray leaves its cell, or, where that cell is empty, the cube of empty cells
// around it (render::skipping::octant_extents); w 1 where the cell is empty. The cell is the one
// a nudge ahead of t, so that a point on a face counts in the cell it moves into.
fn skip_step(sr: SkipRay, t: f32) -> vec2<f32> {
    let tp = t + sr.nudge;
    let q = sr.q0 + sr.dq * tp;
    let cell = clamp(vec3<i32>(floor(q)), vec3<i32>(0), sr.top);
    let d = round(255.0 * textureSampleLevel(skip_grid, skip_sampler, (vec3<f32>(cell + vec3<i32>(0, 0, sr.layer)) + 0.5) * sr.inv_cells, 0.0).r);
    let c = vec3<f32>(cell);
    let reach = max(d, 1.0);
    let exits = (select(c - (reach - 1.0), c + reach, sr.up) - q) * sr.inv_dq;
    return vec2<f32>(tp + max(min(exits.x, min(exits.y, exits.z)), 0.0), select(0.0, 1.0, d > 0.0));
}

#endif

// Steps one loop may take: llvmpipe ends any loop after 65535 iterations, so the march is a loop
// of such loops.
const LOOP_STEPS: u32 = 65000u;

// Marches the ray's parts, one loop over all of their segments, moving on to the next part where
// one ends: the lanes of a SIMD group then take as many iterations as their longest ray, not the
// sum over parts of each part's longest (a ray through the core has two parts, its neighbour
// past the core one). One segment per iteration, and the next one's sample is taken before this
// one is composited: on a CPU rasterizer the sample's latency (the map to indices, the texel
// loads) then overlaps the compositing; more segments per iteration measured slower there.
fn march_parts(s: ptr<function, RayState>, r: Ray2, parts: Parts) {
    let span = parts.span[0];
    var w = Walk(0u, first_piece(r, span.x), span.x, span.y);
    var ab = walk_piece(w, r);
    let second = first_piece(r, parts.span[1].x);
#if PREINTEGRATED
    var front = front_at(sample_at(r.o + r.d * span.x));
#if SHELL
    let front_second = front_at(sample_at(r.o + r.d * parts.span[1].x));
#endif
#else
    var value = sample_at(piece_point(r, ab));
#endif
    loop {
        var j = 0u;
        loop {
            if ((*s).stopped || w.i >= parts.n || j >= LOOP_STEPS) {
                break;
            }
            j += 1u;
#if PREINTEGRATED
            piece_pre(s, &front, r, ab);
            let w_next = walk_after(w, r, parts, second);
            // A new part starts from the value at its entry (a copy for a shell: CPU rasterizers
            // run this body on every step).
            if (w_next.i != w.i && w_next.i < parts.n) {
#if SHELL
                front = front_second;
#else
                front = front_at(sample_at(r.o + r.d * w_next.u));
#endif
            }
            w = w_next;
            ab = walk_piece(w, r);
#else
            let w_next = walk_after(w, r, parts, second);
            let ab_next = walk_piece(w_next, r);
            let value_next = sample_at(piece_point(r, ab_next));
            piece(s, r, ab, value);
            w = w_next;
            ab = ab_next;
            value = value_next;
#endif
        }
        if ((*s).stopped || w.i >= parts.n) {
            break;
        }
    }
}

#if SKIPPING
// What one run hands the next: the pre-integration's front value (nothing otherwise).
#if PREINTEGRATED
alias Carried = Front;
#else
alias Carried = f32;
#endif

// Marches segments k.. of part `span` up to segment k_end (its pieces: the plain march's), the
// first from `front` when it continues the last run and from the value at its start otherwise;
// returns the segment after the last one marched.
fn march_run(s: ptr<function, RayState>, front: ptr<function, Carried>, r: Ray2, span: vec2<f32>, k0: u32, k_end: u32, continues: bool) -> u32 {
    var k = k0;
    var ab = walk_piece(Walk(0u, k, span.x, span.y), r);
#if PREINTEGRATED
    var f = front_at(sample_at(r.o + r.d * ab.x));
    if (continues) {
        f = *front;
    }
#else
    var value = sample_at(piece_point(r, ab));
#endif
    loop {
        var j = 0u;
        loop {
            if ((*s).stopped || k > k_end || ab.x >= span.y || j >= LOOP_STEPS) {
                break;
            }
            j += 1u;
            k += 1u;
            let ab_next = walk_piece(Walk(0u, k, span.x, span.y), r);
#if PREINTEGRATED
            piece_pre(s, &f, r, ab);
#else
            let value_next = sample_at(piece_point(r, ab_next));
            piece(s, r, ab, value);
            value = value_next;
#endif
            ab = ab_next;
        }
        if ((*s).stopped || k > k_end || ab.x >= span.y) {
            break;
        }
    }
#if PREINTEGRATED
    *front = f;
#endif
    return k;
}

// Marches the ray's parts over the runs of skip-grid cells that are not empty, found as the
// march goes (a walk over the grid that jumps cubes of empty cells): each run widened to whole
// segments of the ray's grid, and one more each side (its ends are found to a nudge), so that
// its pieces are the plain march's and the pieces left out lie in empty cells, where they would
// composite exactly nothing.
fn march_skipping(s: ptr<function, RayState>, r: Ray2, parts: Parts) {
    let sr = skip_ray(r);
    var front: Carried;
    for (var i = 0u; i < parts.n; i += 1u) {
        let span = parts.span[i];
        var t = span.x;
        // The next segment to march, and whether the last run ended just before it.
        var k_next = first_piece(r, span.x);
        var marched = false;
        for (var runs = 0u; runs < 4096u; runs += 1u) {
            if ((*s).stopped || t >= span.y) {
                break;
            }
            var step = skip_step(sr, t);
            for (var j = 0u; j < 1024u && step.y > 0.5 && step.x < span.y; j += 1u) {
                t = step.x;
                step = skip_step(sr, t);
            }
            if (step.y > 0.5) {
                break;
            }
            let a = t;
            for (var j = 0u; j < 1024u && step.y < 0.5 && t < span.y; j += 1u) {
                t = step.x;
                step = skip_step(sr, t);
            }
            let ka = first_piece(r, a);
            let k0 = max(select(ka, ka - 1u, ka > 0u), k_next);
            let k_end = u32(max(floor((t - r.t_enter - r.first) * r.inv_ds), 0.0)) + 2u;
            let continues = marched && k0 == k_next;
            k_next = march_run(s, &front, r, span, k0, k_end, continues);
            marched = true;
        }
    }
}
#endif

// The first face of the cut that is drawn (model::cut::CutFaces): a part that starts where the
// point just before it is in the domain and removed, whose value absorbs; its part's index
// (parts.n for none) and radiance, emission over extinction times the fringes. A loop, not a
// branch: with faces off no lane enters it.
struct Face {
    i: u32,
    radiance: vec3<f32>,
}

fn first_face(r: Ray2, parts: Parts) -> Face {
    var face = Face(parts.n, vec3<f32>(0.0));
    let checks = select(0u, parts.n, G.faces.x > 0.5);
    for (var i = 0u; i < checks; i += 1u) {
        let u = parts.span[i].x;
        if (!removed_in_domain(r.o + r.d * (u - G.faces.z))) {
            continue;
        }
        let v = sample_at(r.o + r.d * u);
        let ea = transfer(v);
        if (is_finite_f32(v) && ea.a > 0.0) {
            let fringe = select(1.0, 1.0 + cos(6.2831853 * G.faces.y * v), G.faces.y > 0.0);
            let ring = abs(vec4<f32>(length(r.o + r.d * u)) - G.rings) < vec4<f32>(G.faces.w);
            let on_ring = any(ring & (G.rings > vec4<f32>(0.0)));
            face = Face(i, select(ea.rgb / ea.a * fringe, vec3<f32>(0.0), on_ring));
            break;
        }
    }
    return face;
}

// Closes the ray on an opaque face of radiance `radiance`, in the arithmetic PRECISION selects.
fn composite_face(s: ptr<function, RayState>, radiance: vec3<f32>) {
    let c = (*s).color + (*s).transmittance * radiance;
    if (PRECISION == 1u) {
        (*s).color = vec3<f32>(quantize8(c.x), quantize8(c.y), quantize8(c.z));
    } else if (PRECISION == 2u) {
        (*s).color = vec3<f32>(round16(c.x), round16(c.y), round16(c.z));
    } else {
        (*s).color = c;
    }
    (*s).transmittance = 0.0;
    (*s).tau = 1e30;
    (*s).stopped = true;
}

// One invocation per pixel, in 8 x 8 tiles (shared/camera.wgsl tile_pixel).
@compute @workgroup_size(64, 1, 1)
fn main(@builtin(workgroup_id) tile: vec3<u32>, @builtin(local_invocation_index) l: u32) {
    let gid = tile_pixel(tile, l);
    let w = P.image.x;
    let h = P.image.y;
    if (gid.x >= w || gid.y >= h) {
        return;
    }
    let ray = camera_ray(gid.x, gid.y, w, h, P.eye.xyz, P.forward.xyz, P.right.xyz, P.up.xyz, P.proj);
    let parts = ray_parts(ray.origin, ray.dir);
    var s = RayState(vec3<f32>(0.0), vec3<f32>(0.0), 0.0, 0.0, 1.0, 0.0, false);
    if (parts.n > 0u) {
        let ds = P.march.x;
        let r = Ray2(ray.origin, ray.dir, parts.span[0].x, first_segment(gid.xy, w, h, ds), ds, 1.0 / ds);
        // The parts in front of the first face drawn, if any.
        let face = first_face(r, parts);
        var marched = parts;
        marched.n = face.i;
#if SKIPPING
        march_skipping(&s, r, marched);
#else
        march_parts(&s, r, marched);
#endif
        if (face.i < parts.n && !s.stopped) {
            composite_face(&s, face.radiance);
        }
    }
    textureStore(out_image, vec2<i32>(gid.xy), ray_pixel(s));
}
