// The generalized shift-and-sum loop shared by the fragment and compute strategies: for one
// output pixel, sample every view of the draw at its homography, mask samples behind the view's
// camera or outside its image, and return the weighted colour sum (rgb) and weight sum (a).
#include "refocus_interface.glsl"

// How a view is sampled (specialisation constants: each combination is its own pipeline, so
// the unused paths cost nothing).
//   FILTER 0: hardware bilinear (one filtered fetch; positions snap to 8 fractional bits);
//   FILTER 1: nearest texel;
//   FILTER 2: bilinear in the shader with f32 weights from four texel fetches;
//   FILTER 3: bicubic (Catmull-Rom, a = -1/2) in the shader from sixteen texel fetches, the
//             weights of `catmull_rom` (mirrored by refocus::cpu on the host).
// TEXEL: what happens to each texel before filtering (only with FILTER 1, 2 or 3: transforming
// after hardware filtering would be a different image):
//   0: nothing; 1: 8-bit sRGB-encoded texels are decoded exactly through `srgb_to_linear`
//   (uploaded from Rust's `color::decode_table`); 2: linear texels are encoded with the exact
//   sRGB curve (encoded averaging from linear storage).
layout(constant_id = 0) const uint FILTER = 0;
layout(constant_id = 1) const uint TEXEL = 0;
// UNIFORM_WARPS 1: read the warps from the uniform buffer (binding 3, at most UBO_WARPS
// views); 0: from the storage buffer (binding 1, any number). llvmpipe compiles a storage
// buffer load indexed by the loop counter into a loop over the SIMD lanes with a bounds check
// and branch per lane, a uniform buffer load into one gather: measured ~10x faster there.
layout(constant_id = 2) const uint UNIFORM_WARPS = 1;
const uint UBO_WARPS = 256; // refocus::settings::UBO_WARPS
// ANTIALIAS 0: the plain sum (one sample per view, the method's definition). N > 0: each view
// is integrated over its aperture cell's footprint with at most N x N sub-samples
// (refocus::antialias; footprints in binding 4, the scene's inverse depth per reference pixel
// in binding 5, -1 where unknown).
layout(constant_id = 3) const uint ANTIALIAS = 0;
// SURFACE (refocus::surface::SurfaceRule): how the focus surface's inverse depth s along the
// pixel's ray is chosen. 0: the plane alone, s = max(m.x, 0) (no depth read: the single-plane
// path is the same code as before surfaces existed); 1: the plane term nearest the scene's
// sigma; 2: sigma clamped between the far and near boundary planes of a slab; 3: sigma.
// Where sigma is unknown (< 0) every rule falls back to the push constant's plane.
layout(constant_id = 4) const uint SURFACE = 0;
const uint MAX_PLANES = 8u; // refocus::surface::MAX_PLANES
// PREFILTER 1: a footprint's sub-samples farther apart than sqrt(3) pixels read the views'
// box-filtered mip levels at the level of their spacing (refocus::prefilter), each fetch
// standing for its share of the footprint.
layout(constant_id = 5) const uint PREFILTER = 0;
const float LOD_BIAS = 0.7924812503605781; // refocus::prefilter::LOD_BIAS, log2(sqrt(3))
// OCCLUSION 1: sub-samples near a nearer surface follow their own rays and are tested against
// their view's visibility map (refocus::antialias::sub_sample_residual); 0: the plan has no
// front (AntialiasSettings::occlusion off) and the tests are not compiled in. Skipping them at
// run time alone left llvmpipe 1.3-1.6x slower than without their code (the fastest setting
// 14.1 vs 10.8 ms, cap 4 50.5 vs 32.9 ms, one bench run).
layout(constant_id = 6) const uint OCCLUSION = 1;
// DEFOCUS 1 (with ANTIALIAS > 0; refocus::defocus): every view of the draw was box-filtered
// over its footprints by defocus.comp into binding 9, and the sum reads it once per view at the
// cell's centroid instead of sub-sampling the footprint; no occlusion tests.
layout(constant_id = 7) const uint DEFOCUS = 0;
// BOXED 1 (with ANTIALIAS > 0; refocus::boxed): boxed.comp has decided every pixel it can into
// binding 10 before this draw: (sum, weight) there, alpha -1 where the footprints are
// sub-sampled below (its focus test failed there, so it does not run again). The ids 8-11
// belong to refocus_compute.glsl and the stages' own shaders.
layout(constant_id = 12) const uint BOXED = 0;
const float FOCUSED_BLUR_PX = 0.5; // refocus::antialias::FOCUSED_BLUR_PX

layout(set = 0, binding = 0) uniform sampler2DArray views;
layout(std430, set = 0, binding = 1) readonly buffer Warps { ViewWarp warps[]; };
// A buffer, not a constant array: llvmpipe compiles dynamically indexed constant arrays very
// slowly (minutes per pipeline). A uniform buffer for the reason above; std140 pads float
// arrays to 16 bytes, so the 256 values are packed four to a vec4.
layout(std140, set = 0, binding = 2) uniform Decode { vec4 srgb_to_linear4[64]; };
layout(std140, set = 0, binding = 3) uniform WarpsU { ViewWarp warps_u[UBO_WARPS]; };

layout(std140, set = 0, binding = 4) uniform Footprints { ViewFootprint footprints[UBO_WARPS]; };
// Per reference pixel: the scene's inverse depth sigma and the nearest surface's around it
// (the front), interleaved; -1 where unknown.
// Storage buffers, not images: read with texelFetch from R32F images (this binding and
// binding 8) the anti-aliased sum took 10-20 % longer on llvmpipe (cap 4: 43.5 vs 38.4 ms,
// cap 1: 7.7 vs 6.4 ms, one bench run).
layout(std430, set = 0, binding = 5) readonly buffer SceneDepth { float scene_sigma[]; };
// The focus surface's plane terms (refocus::surface::SurfacePlan::terms): for SURFACE 1 the
// first pc.plane_count, the push constant's plane first; for SURFACE 2 far then near.
layout(std140, set = 0, binding = 6) uniform Surface { vec4 surface_planes[MAX_PLANES]; };
// The same views through a trilinear sampler over every mip level (binding 0 stops at level
// 0, so the plain sum is unchanged by the levels' presence).
layout(set = 0, binding = 7) uniform sampler2DArray views_mip;
// What each view of the anti-aliasing plan sees (refocus::antialias::ViewVisibility): sigma
// per view pixel, view after view in the order of the footprints; -1 where nothing landed.
// Read only for views whose footprint's vis.x is 1; vis.y is the view's map. 16-bit floats,
// two to a word (ViewVisibility::half_words): half the stream of a view's map.
layout(std430, set = 0, binding = 8) readonly buffer Visibility { uint view_sigma_bits[]; };

// Entry i of the maps.
float view_sigma(uint i) {
    vec2 pair = unpackHalf2x16(view_sigma_bits[i >> 1u]);
    return (i & 1u) == 0u ? pair.x : pair.y;
}
// The defocused views (DEFOCUS 1), one layer per view of the plan in the order of the
// footprints (their vis.y), written by defocus.comp; kept in GENERAL layout.
layout(set = 0, binding = 9) uniform sampler2DArray defocused;
// What boxed.comp decided per reference pixel (BOXED 1).
layout(std430, set = 0, binding = 10) readonly buffer BoxedResults { vec4 boxed_results[]; };

// Index of the reference pixel nearest position p (clamped to the views).
int depth_index(vec2 p) {
    ivec2 ip = clamp(ivec2(floor(p + 0.5)), ivec2(0), ivec2(pc.view_size) - 1);
    return ip.y * int(pc.view_size.x) + ip.x;
}

// The focus surface's inverse depth along the ray of x (reference pixel coordinates), given
// the plane's s (refocus::surface::SurfacePlan::inverse_depth in f64).
float surface_s(vec3 x, float s) {
    if (SURFACE == 0u) {
        return s;
    }
    float sigma = scene_sigma[2 * depth_index(x.xy)];
    if (sigma < 0.0) {
        return s;
    }
    if (SURFACE == 3u) {
        return sigma;
    }
    if (SURFACE == 2u) {
        float lo = max(dot(surface_planes[0].xyz, x), 0.0);
        float hi = max(dot(surface_planes[1].xyz, x), 0.0);
        return min(max(sigma, lo), hi);
    }
    float best = s;
    float err = abs(s - sigma);
    for (uint k = 1u; k < min(pc.plane_count, MAX_PLANES); ++k) {
        float sk = max(dot(surface_planes[k].xyz, x), 0.0);
        if (abs(sk - sigma) < err) {
            best = sk;
            err = abs(sk - sigma);
        }
    }
    return best;
}

float srgb_to_linear(int i) {
    return srgb_to_linear4[i >> 2][i & 3];
}

vec3 decode(vec3 c) {
    if (TEXEL == 2u) {
        c = clamp(c, 0.0, 1.0);
        return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055,
                   greaterThan(c, vec3(0.0031308)));
    }
    if (TEXEL == 1u) {
        ivec3 i = ivec3(c * 255.0 + 0.5);
        return vec3(srgb_to_linear(i.r), srgb_to_linear(i.g), srgb_to_linear(i.b));
    }
    return c;
}

vec3 texel(ivec2 p, int layer) {
    ivec2 hi = ivec2(pc.view_size) - 1;
    return decode(texelFetch(views, ivec3(clamp(p, ivec2(0), hi), layer), 0).rgb);
}

// Bilinear in the shader at mip level l (position p in level-0 pixels, mapped through
// normalised coordinates as a sampler does; refocus::prefilter::Pyramid::bilinear).
vec3 level_bilinear(vec2 p, int layer, int l) {
    ivec2 size = textureSize(views, l).xy;
    vec2 q = (p + 0.5) * vec2(size) / pc.view_size - 0.5;
    vec2 f0 = floor(q);
    vec2 f = q - f0;
    ivec2 i = ivec2(f0);
    ivec2 hi = size - 1;
    vec3 c00 = decode(texelFetch(views, ivec3(clamp(i, ivec2(0), hi), layer), l).rgb);
    vec3 c10 = decode(texelFetch(views, ivec3(clamp(i + ivec2(1, 0), ivec2(0), hi), layer), l).rgb);
    vec3 c01 = decode(texelFetch(views, ivec3(clamp(i + ivec2(0, 1), ivec2(0), hi), layer), l).rgb);
    vec3 c11 = decode(texelFetch(views, ivec3(clamp(i + ivec2(1, 1), ivec2(0), hi), layer), l).rgb);
    return mix(mix(c00, c10, f.x), mix(c01, c11, f.x), f.y);
}

// Catmull-Rom weights of the four texels at offsets -1, 0, 1, 2 from floor(p), for the
// fraction t in [0, 1). They sum to 1; at t = 0 they are (0, 1, 0, 0).
vec4 catmull_rom(float t) {
    float t2 = t * t;
    float t3 = t2 * t;
    return vec4(-0.5 * t3 + t2 - 0.5 * t,
                1.5 * t3 - 2.5 * t2 + 1.0,
                -1.5 * t3 + 2.0 * t2 + 0.5 * t,
                0.5 * t3 - 0.5 * t2);
}

// Catmull-Rom bicubic of the view in layer l at p from sixteen texel fetches.
vec3 bicubic(vec2 p, int l) {
    vec2 f0 = floor(p);
    vec2 f = p - f0;
    ivec2 i = ivec2(f0);
    vec4 wx = catmull_rom(f.x);
    vec4 wy = catmull_rom(f.y);
    vec3 c = vec3(0.0);
    for (int j = 0; j < 4; ++j) {
        ivec2 r = i + ivec2(-1, j - 1);
        vec3 row = wx.x * texel(r, l) + wx.y * texel(r + ivec2(1, 0), l)
                 + wx.z * texel(r + ivec2(2, 0), l) + wx.w * texel(r + ivec2(3, 0), l);
        c += wy[j] * row;
    }
    return c;
}

// Colour of the view in `layer` at pixel position p (pixel centres at integers).
vec3 fetch(vec2 p, float layer) {
    if (FILTER == 1u) {
        return texel(ivec2(floor(p + 0.5)), int(layer));
    }
    if (FILTER == 2u) {
        vec2 f0 = floor(p);
        vec2 f = p - f0;
        ivec2 i = ivec2(f0);
        int l = int(layer);
        vec3 top = mix(texel(i, l), texel(i + ivec2(1, 0), l), f.x);
        vec3 bottom = mix(texel(i + ivec2(0, 1), l), texel(i + ivec2(1, 1), l), f.x);
        return mix(top, bottom, f.y);
    }
    if (FILTER == 3u) {
        return bicubic(p, int(layer));
    }
    return textureLod(views, vec3((p + 0.5) / pc.view_size, layer), 0.0).rgb;
}

// The colour of the view at p averaged over the prefilter level `lod` (> 0): the hardware's
// trilinear fetch, or with the shader's own filters the same from texel fetches
// (refocus::prefilter::Pyramid::trilinear; the last level beyond the pyramid).
vec3 fetch_lod(vec2 p, float layer, float lod) {
    if (FILTER == 0u) {
        return textureLod(views_mip, vec3((p + 0.5) / pc.view_size, layer), lod).rgb;
    }
    int last = textureQueryLevels(views) - 1;
    int l0 = min(int(floor(lod)), last);
    float f = l0 == last ? 0.0 : lod - float(l0);
    vec3 a = level_bilinear(p, int(layer), l0);
    if (f == 0.0) {
        return a;
    }
    return mix(a, level_bilinear(p, int(layer), l0 + 1), f);
}

// Sub-samples per axis of a footprint span (refocus::antialias::samples): its length in
// pixels rounded up, from 1 to ANTIALIAS.
uint samples(vec3 span, float d, float yz) {
    if (ANTIALIAS == 1u || yz <= 0.0) {
        return 1u;
    }
    float len = length(span.xy * d) / yz;
    return uint(clamp(ceil(len), 1.0, float(ANTIALIAS)));
}

// The scene depth sigma a view sees at its image position p (nearest pixel), -1 outside the
// image or where nothing landed (refocus::antialias::ViewVisibility::at).
float visible_sigma(uint map, vec2 p) {
    ivec2 ip = ivec2(floor(p + 0.5));
    ivec2 size = ivec2(pc.view_size);
    if (any(lessThan(ip, ivec2(0))) || any(greaterThanEqual(ip, size))) {
        return -1.0;
    }
    uint n = uint(size.x) * uint(size.y);
    return view_sigma(map * n + uint(ip.y) * uint(size.x) + uint(ip.x));
}

// Whether the reference sees inverse depth c where the ray (parallax `ray` per unit of s - c)
// through x meets it, within tolerance `tol(c)` (step 1 of sub_sample_residual).
bool hits(vec3 x, vec3 ray, float s, float c, float reach) {
    vec3 q = x + ray * (s - c);
    if (q.z <= 0.0) {
        return false;
    }
    float r = scene_sigma[2 * depth_index(q.xy / q.z)];
    return r >= 0.0 && abs(r - c) <= min(reach, 0.05 * c);
}

// The residual s - c of the sub-sample at cell coordinates uv of view k
// (refocus::antialias::sub_sample_residual): c is what its aperture point's ray hits, the
// nearer surface around (front) or the pixel's own (sigma), or what the view sees at the
// sub-sample when the ray hits that too. False: the view cannot see the ray's point (dropped).
bool sub_residual(vec3 x, vec3 y0, uint k, float s, float sigma, float front, vec3 cell,
                  out float d) {
    d = 0.0;
    if (sigma < 0.0) {
        return true;
    }
    d = s - sigma;
    if (OCCLUSION == 0u || !(front > sigma + 1e-6)) {
        return true; // no nearer surface around: nothing can occlude the ray or the view
    }
    vec3 g = vec3(footprints[k].origin.w, footprints[k].span_s.w, footprints[k].span_t.w);
    float reach = 0.5 / max(length(g.xy), 1e-9);
    vec3 ray = g + cell;
    float c = sigma;
    if (hits(x, ray, s, front, reach)) {
        c = front;
    }
    if (footprints[k].vis.x > 0.5) {
        vec3 q = y0 + cell * (s - c);
        // Within the guard (estimated depth) of the plain sample: what the view's own ray
        // sees, no test.
        float moved = length(q.xy / q.z - y0.xy / y0.z);
        if (q.z > 0.0 && y0.z > 0.0 && moved >= footprints[k].vis.z) {
            float seen = visible_sigma(uint(footprints[k].vis.y), q.xy / q.z);
            if (seen >= 0.0 && seen > c + min(reach, 0.05 * c)) {
                if (!hits(x, ray, s, seen, reach)) {
                    return false;
                }
                c = seen;
            }
        }
    }
    d = s - c;
    return true;
}

// Adds one sub-sample of view k's cell at cell coordinates uv (an n_s x n_t grid), masked
// like a plain sample, weighing wk. In a `focused` cell a sub-sample whose footprint is under
// half a pixel takes `sharp`, the cell's Catmull-Rom value (refocus::antialias::focused_sub_sample).
void sub_sample(vec3 x, vec3 y0, uint k, float s, float sigma, float front, vec2 uv, uint ns,
                uint nt, float layer, float wk, vec2 lo, vec2 hi, bool focused, vec3 sharp,
                inout vec3 sum, inout float wsum) {
    vec3 cell = footprints[k].origin.xyz + uv.x * footprints[k].span_s.xyz
              + uv.y * footprints[k].span_t.xyz;
    float d;
    if (!sub_residual(x, y0, k, s, sigma, front, cell, d)) {
        return;
    }
    vec3 y = y0 + cell * d;
    if (y.z <= 0.0) {
        return;
    }
    vec2 p = y.xy / y.z;
    if (any(lessThan(p, lo)) || any(greaterThan(p, hi))) {
        return;
    }
    // The spans' lengths at this residual (refocus::antialias::span_px, before the division
    // by y0.z) serve the level and the Catmull-Rom choice alike.
    float len_s = length(footprints[k].span_s.xy * d);
    float len_t = length(footprints[k].span_t.xy * d);
    // The prefilter level of the larger sub-sample spacing at this sub-sample's residual
    // (refocus::antialias::footprint_lod).
    float lod = 0.0;
    if (PREFILTER != 0u && y0.z > 0.0) {
        float spacing = max(len_s / (y0.z * float(ns)), len_t / (y0.z * float(nt)));
        lod = spacing > 0.0 ? max(log2(spacing) - LOD_BIAS, 0.0) : 0.0;
    }
    // With the hardware filter every sub-sample goes through the trilinear sampler (at level 0
    // it is the bilinear fetch): a branch between the two fetches made llvmpipe run both for
    // every lane (cap 4 measured 1.5x slower).
    float blur = y0.z > 0.0 ? max(len_s, len_t) / y0.z : 1.0;
    vec3 c = focused && y0.z > 0.0 && blur < FOCUSED_BLUR_PX
        ? sharp
        : PREFILTER != 0u && (FILTER == 0u || lod > 0.0) ? fetch_lod(p, layer, lod)
                                                         : fetch(p, layer);
    sum += wk * c;
    wsum += wk;
}

// Adds view k's footprint integral: stratified sub-samples of its aperture cell, as many per
// axis as the largest footprint any of them may take (`reach`, refocus::antialias::cell_reach)
// needs, each weighing weight / (n_s n_t).
void footprint(vec3 x, vec3 y0, uint k, float s, float sigma, float front, float reach,
               ViewWarp w, vec2 lo, vec2 hi, bool focused, inout vec3 sum, inout float wsum) {
    uint ns = samples(footprints[k].span_s.xyz, reach, y0.z);
    uint nt = samples(footprints[k].span_t.xyz, reach, y0.z);
    float wk = w.b_weight.w / float(ns * nt);
    vec2 inv = 1.0 / vec2(float(ns), float(nt));
    float layer = w.a0.w;
    // In a focused pixel (a constant at each call site: only the focused loop of `accumulate`
    // compiles this fetch in) one Catmull-Rom read at the cell's centre, at the pixel's own
    // residual, serves every in-focus sub-sample of the cell: they lie within a quarter pixel
    // of it, and a read per sub-sample made pixels near a nearer surface (16 sub-samples)
    // twice as slow.
    vec3 sharp = vec3(0.0);
    bool focused_cell = false;
    if (focused) {
        vec3 centre = footprints[k].origin.xyz
                    + 0.5 * (footprints[k].span_s.xyz + footprints[k].span_t.xyz);
        vec3 yc = y0 + centre * (s - sigma);
        focused_cell = yc.z > 0.0;
        sharp = focused_cell ? bicubic(yc.xy / yc.z, int(layer)) : vec3(0.0);
    }
    // Cap 1 (a specialisation constant: no lane runs the loop) takes its one sub-sample
    // directly. Cap 2 used to be unrolled the same way (1.4-2x faster than the loop while a
    // sub-sample was one fetch); with the occlusion tests in every sub-sample the unrolled
    // copies made it slower than the loop (measured 11.7x vs 9.7x the plain sum).
    if (ANTIALIAS == 1u) {
        sub_sample(x, y0, k, s, sigma, front, vec2(0.5), 1u, 1u, layer, wk, lo, hi, focused_cell,
                   sharp, sum, wsum);
        return;
    }
    // One flat loop over the n_s x n_t grid: on llvmpipe a nested loop of per-lane trip counts
    // took 24 % longer (23.3 vs 18.8 ms, 21 views of 128^2, at most 4 x 4), and a loop bounded
    // by the specialisation constant (unrolled, with an early exit) 19 % longer.
    uint n = ns * nt;
    for (uint j = 0u; j < n; ++j) {
        uint b = j / ns;
        vec2 uv = (vec2(float(j - b * ns), float(b)) + 0.5) * inv;
        sub_sample(x, y0, k, s, sigma, front, uv, ns, nt, layer, wk, lo, hi, focused_cell, sharp,
                   sum, wsum);
    }
}

// The focus test (refocus::antialias::focus_spread): whether the plain samples at the focus
// surface of every view of the plan (not only this draw's, so that batches decide alike)
// agree, their weighted standard deviation in square-root units (close to sRGB levels) at most
// `threshold` in every channel: then the pixel is in focus whatever the depth map says.
// `sum` and `wsum` return the samples' weighted sum and weight: the plain sum of the plan.
bool views_agree(vec3 x, float s, vec2 lo, vec2 hi, float threshold, out vec3 sum,
                 out float wsum) {
    vec3 lin = vec3(0.0);
    vec3 root = vec3(0.0);
    sum = vec3(0.0);
    wsum = 0.0;
    for (uint k = 0u; k < pc.total_views; ++k) {
        vec4 b = UNIFORM_WARPS != 0u ? warps_u[k].b_weight : warps[k].b_weight;
        mat3 a = UNIFORM_WARPS != 0u
            ? mat3(warps_u[k].a0.xyz, warps_u[k].a1.xyz, warps_u[k].a2.xyz)
            : mat3(warps[k].a0.xyz, warps[k].a1.xyz, warps[k].a2.xyz);
        float layer = UNIFORM_WARPS != 0u ? warps_u[k].a0.w : warps[k].a0.w;
        vec3 y = a * x + b.xyz * s;
        if (y.z <= 0.0) {
            continue;
        }
        vec2 p = y.xy / y.z;
        if (any(lessThan(p, lo)) || any(greaterThan(p, hi))) {
            continue;
        }
        vec3 c = fetch(p, layer);
        sum += b.w * c;
        // A bicubic fetch may overshoot below 0.
        vec3 cp = max(c, vec3(0.0));
        lin += b.w * cp;
        root += b.w * sqrt(cp);
        wsum += b.w;
    }
    if (wsum <= 0.0) {
        return false;
    }
    vec3 mean = root / wsum;
    vec3 spread = max(lin / wsum - mean * mean, vec3(0.0));
    return max(spread.r, max(spread.g, spread.b)) <= threshold * threshold;
}

// The warp of view k from whichever buffer holds the warps. Member by member, not
// `UNIFORM_WARPS != 0u ? warps_u[k] : warps[k]`: the two blocks' structs have different
// layouts (std140, std430), and glslang 12 with the SPIR-V optimizer (Debian 12's shaderc)
// rejects a conditional choosing between them.
ViewWarp warp_of(uint k) {
    ViewWarp w;
    if (UNIFORM_WARPS != 0u) {
        w.a0 = warps_u[k].a0;
        w.a1 = warps_u[k].a1;
        w.a2 = warps_u[k].a2;
        w.b_weight = warps_u[k].b_weight;
    } else {
        w.a0 = warps[k].a0;
        w.a1 = warps[k].a1;
        w.a2 = warps[k].a2;
        w.b_weight = warps[k].b_weight;
    }
    return w;
}

// View k's contribution with defocused views (refocus::cpu::defocused_with): one read of the
// defocused view at the cell's centroid for the pixel's residual s - sigma; in a `focused`
// pixel a footprint under half a pixel reads the view itself with Catmull-Rom there.
void defocused_sample(vec3 y0, uint k, float s, float sigma, float layer, float wk, vec2 lo,
                      vec2 hi, bool focused, inout vec3 sum, inout float wsum) {
    vec3 centre = footprints[k].origin.xyz
                + 0.5 * (footprints[k].span_s.xyz + footprints[k].span_t.xyz);
    float d = s - sigma;
    vec3 y = y0 + centre * d;
    if (y.z <= 0.0) {
        return;
    }
    vec2 p = y.xy / y.z;
    if (any(lessThan(p, lo)) || any(greaterThan(p, hi))) {
        return;
    }
    float blur = y0.z > 0.0
        ? max(length(footprints[k].span_s.xy * d), length(footprints[k].span_t.xy * d)) / y0.z
        : 1.0;
    vec3 c = focused && y0.z > 0.0 && blur < FOCUSED_BLUR_PX
        ? bicubic(p, int(layer))
        : textureLod(defocused, vec3((p + 0.5) / pc.view_size, footprints[k].vis.y), 0.0).rgb;
    sum += wk * c;
    wsum += wk;
}

// frag: the output pixel's centre in output pixels (gl_FragCoord.xy, or id + 0.5).
vec4 accumulate(vec2 frag) {
    // Pixel-index coordinates of the reference view: pixel (i, j)'s centre is at (i, j).
    vec3 x = vec3(frag * pc.out_scale - 0.5, 1.0);
    // Inverse depth of the plane along this pixel's ray; <= 0 past the horizon, where the
    // documented rule focuses at infinity.
    float s = surface_s(x, max(dot(pc.plane.xyz, x), 0.0));
    vec2 lo = vec2(-0.5);
    vec2 hi = pc.view_size - 0.5;
    vec3 sum = vec3(0.0);
    float wsum = 0.0;
    // The scene's inverse depth at this pixel (nearest texel: never interpolated across a
    // depth edge; < 0 unknown: no footprint) and the nearest surface around it, and the largest
    // residual a sub-sample may take (refocus::antialias::cell_reach).
    float sigma = -1.0;
    float front = -1.0;
    float reach = 0.0;
    if (ANTIALIAS != 0u) {
        int i = depth_index(x.xy);
        sigma = scene_sigma[2 * i];
        front = OCCLUSION != 0u ? scene_sigma[2 * i + 1] : -1.0;
        if (sigma >= 0.0) {
            reach = abs(s - sigma);
            if (front > sigma + 1e-6) {
                reach = max(reach, abs(s - front));
            }
        }
        // The boxed stage's pixels are its whole sum, added by the first batch of views.
        bool tested = false;
        if (BOXED != 0u) {
            vec4 decided = boxed_results[depth_index(x.xy)];
            if (decided.a >= 0.0) {
                return pc.first_view == 0u ? decided : vec4(0.0);
            }
            tested = true;
        }
        // Views that agree at the focus surface see it in focus: the plain sum with the cells'
        // weights (sigma < 0 gives every sub-sample the plain sample's residual 0).
        float threshold = tested ? 0.0 : footprints[0].vis.w;
        vec3 agreed;
        float agreed_w;
        if (threshold > 0.0 && sigma >= 0.0
            && views_agree(x, s, lo, hi, threshold, agreed, agreed_w)) {
            // A draw of the whole plan has its result already (the loop below would fetch
            // the same samples again); a batch adds its own views' plain samples.
            if (pc.first_view == 0u && pc.view_count == pc.total_views) {
                return vec4(agreed, agreed_w);
            }
            sigma = -1.0;
            front = -1.0;
            reach = 0.0;
        }
    }
    // A pixel whose own surface is in focus (refocus::antialias::AntialiasPlan::focused_reach;
    // 0 when off or with the bicubic and nearest filters) reads its in-focus sub-samples with
    // Catmull-Rom. llvmpipe runs both sides of a branch for every lane of a SIMD group, but
    // leaves a loop once no lane has an iteration left: so focused and other pixels take
    // separate loops over the views, and a group with no focused pixel passes the first with
    // one masked iteration (measured over the anti-aliasing test set: 1.04-1.06x the time of
    // bilinear sub-samples, where a choice per sub-sample in one loop took about 2.5x).
    bool focused = ANTIALIAS != 0u && sigma >= 0.0 && abs(s - sigma) < pc.focused_reach;
    uint k_end = pc.first_view + pc.view_count;
    if (ANTIALIAS != 0u && DEFOCUS != 0u && sigma >= 0.0) {
        // As for sub-samples, focused pixels take a loop of their own (the Catmull-Rom reads).
        for (uint k = pc.first_view; k < (focused ? k_end : pc.first_view); ++k) {
            ViewWarp w = warp_of(k);
            vec3 y = mat3(w.a0.xyz, w.a1.xyz, w.a2.xyz) * x + w.b_weight.xyz * s;
            defocused_sample(y, k, s, sigma, w.a0.w, w.b_weight.w, lo, hi, true, sum, wsum);
        }
        for (uint k = pc.first_view; k < (focused ? pc.first_view : k_end); ++k) {
            ViewWarp w = warp_of(k);
            vec3 y = mat3(w.a0.xyz, w.a1.xyz, w.a2.xyz) * x + w.b_weight.xyz * s;
            defocused_sample(y, k, s, sigma, w.a0.w, w.b_weight.w, lo, hi, false, sum, wsum);
        }
        return vec4(sum, wsum);
    }
    if (ANTIALIAS != 0u && DEFOCUS == 0u) {
        for (uint k = pc.first_view; k < (focused ? k_end : pc.first_view); ++k) {
            ViewWarp w = warp_of(k);
            vec3 y = mat3(w.a0.xyz, w.a1.xyz, w.a2.xyz) * x + w.b_weight.xyz * s;
            footprint(x, y, k, s, sigma, front, reach, w, lo, hi, true, sum, wsum);
        }
        if (focused) {
            k_end = pc.first_view;
        }
    }
    for (uint k = pc.first_view; k < k_end; ++k) {
        ViewWarp w = warp_of(k);
        vec3 y = mat3(w.a0.xyz, w.a1.xyz, w.a2.xyz) * x + w.b_weight.xyz * s;
        if (ANTIALIAS != 0u && DEFOCUS == 0u) {
            footprint(x, y, k, s, sigma, front, reach, w, lo, hi, false, sum, wsum);
            continue;
        }
        if (y.z <= 0.0) {
            continue; // behind camera i
        }
        vec2 p = y.xy / y.z;
        if (any(lessThan(p, lo)) || any(greaterThan(p, hi))) {
            continue; // outside view i
        }
        sum += w.b_weight.w * fetch(p, w.a0.w);
        wsum += w.b_weight.w;
    }
    return vec4(sum, wsum);
}
