// Layered anti-aliasing (refocus::layered, docs/antialias.md "Layered footprints"): the f64
// model's four stages, one dispatch each. The including file defines ACCUM_FORMAT (the
// accumulation image's format: layered.comp rgba32f, layered_half.comp rgba16f).
//   STAGE 0 (bin): one invocation per output pixel walks the views [first_view, +view_count):
//            the view's plain sample feeds the focus test's sums; the depth that view sees
//            there (its filled visibility map) gives the residual d; the view is read at its
//            cell's centroid for d (Catmull-Rom where the footprint is under half a pixel) and
//            added to the two nodes around d * scale of its cell's group, weighted by the cell's
//            area and the node's share. accumulate 0 starts the pixel's sums from zero. Each
//            8×8 tile records which layers it holds (Occupancy): a pixel's views reach a few
//            nodes, so most of a layer's image is empty, and what is empty costs nothing after.
//   STAGE 1 (rows): one invocation per (row, layer) runs the layer's box along the row: the
//            mean of the row's linear interpolation over the node's footprint (narrowed by the
//            interpolation's own variance), from running sums of trapezoids; only over the
//            tiles within the box's reach of a tile that holds the layer (the rest is zero).
//   STAGE 2 (columns): the same down the columns of the row-boxed layers.
//   STAGE 3 (composite): one invocation per pixel: where the views' plain samples agree, their
//            mean; else the boxed layers front to back, each covering its share of what the
//            nearer ones left; written to the accumulation image as (colour, 1), which the
//            resolve divides as it divides a sum.
#include "refocus_accumulate.glsl"

layout(constant_id = 8) const uint STAGE = 0u;
layout(local_size_x_id = 9, local_size_y_id = 10) in;

layout(set = 1, binding = 0, ACCUM_FORMAT) uniform image2D accum_image;

const uint MAX_GROUPS = 8u; // refocus::layered::MAX_GROUPS
const uint MAX_NODES = 128u; // refocus::layered::MAX_NODES
const uint MAX_LAYERS = 96u; // refocus::layered::MAX_LAYERS
// refocus::layered::{NODE_STEP_PX, NODE_LINEAR_PX, NODE_RATIO} (a test compares them).
const float NODE_STEP_PX = 1.0;
const float NODE_LINEAR_PX = 3.0;
const float NODE_RATIO = 1.4;

// Mirrored by `GpuLayerParams` (src/passes/refocus/layered.rs).
layout(std140, set = 2, binding = 0) uniform LayerParams {
    ivec4 header;        // first node, node count (the residual's range), group count,
                         // pixels per layer
    vec4 scale;          // x: full-cell footprint px per unit residual; y: guard px (0: a
                         // given depth). Catmull-Rom at footprints under half a pixel where
                         // pc.focused_reach > 0 (the bilinear filters with it on).
    ivec4 slots;         // x: the reachable nodes' count (each a layer per group); yz the
                         // host's (the batch ranges in pc come from them)
    uvec4 sharp;         // a bit per layer: its box is zero wide (sharp())
    // Node first + j of the range: its footprint in pixels and the next node's (signed), and
    // their slots (-1 where no sample reaches it, or past the range): one read a sample.
    vec4 nodes4[MAX_NODES];
    vec4 slot_px4[MAX_LAYERS / 4u]; // slot k's node footprint in pixels, signed
    vec4 units[MAX_GROUPS]; // xy: group g's footprint px per unit residual along x and y
    uvec4 group_of4[UBO_WARPS / 4u]; // view k's group at [k / 4][k % 4]
    // The views in binning order: those whose cell's centroid is the view (centred: the sample
    // is the plain one) ascending, then the others ascending.
    uvec4 order4[UBO_WARPS / 4u];
} lp;
// Per layer (node * groups + group) and pixel: (colour * weight, weight); the sums in the
// first half, the boxes in the second (boxes_base()), so that the composite reads a sharp
// layer's sums and another's box with one load.
layout(std430, set = 2, binding = 1) buffer Layers { vec4 bins[]; };
// Per pixel: (plain sum, plain weight), (Σ w e², binned weight), (Σ w e, 0), (r, 1 once set):
// the focus test's sums over the plain samples and the weight of the binned views. e = √c − r,
// r the root of the pixel's first plain sample: the spread E[e²] − E[e]² then cancels only
// the samples' differences, not their level (E[c] − E[√c]² in f32 lost a part in 10³ of the
// variance, so a pixel at the threshold passed or failed with the views' order).
layout(std430, set = 2, binding = 2) buffer Stats { vec4 stats[]; };
layout(std430, set = 2, binding = 3) buffer Rows { vec4 rows[]; };
// Per stage (0 sums, 1 rows, 2 boxes) and 8×8 tile of the output (TILE_PX): a bit per layer,
// set where the tile of that layer holds what the stage wrote. The rest of a layer's image is
// zero and never read, boxed or composited: at word (stage * tiles + tile) * 4 + layer / 32.
// The pass clears the sums' masks where an accumulation starts, the others before each.
layout(std430, set = 2, binding = 4) buffer Occupancy { uint occ[]; };
// Per pixel: the layers its sums hold (a bit each); elsewhere the sums hold another plan's
// values, which the rows read as zero.
layout(std430, set = 2, binding = 5) buffer PixelLayers { uvec4 pixel_layers[]; };
const uint TILE_PX = 8u;

// Where the boxes start in the layer buffer (its second half).
uint boxes_base() {
    return uint(bins.length()) / 2u;
}

uint tiles_x() {
    return (uint(pc.view_size.x) + TILE_PX - 1u) / TILE_PX;
}

uint tiles_y() {
    return (uint(pc.view_size.y) + TILE_PX - 1u) / TILE_PX;
}

// The tile of output pixel px.
uint tile_of(ivec2 px) {
    return uint(px.y) / TILE_PX * tiles_x() + uint(px.x) / TILE_PX;
}

// Layer l's bit in its word of a layer mask (word l / 32).
uint layer_bit(uint l) {
    return 1u << (l & 31u);
}

uint occ_word(uint tile, uint stage, uint l) {
    return (stage * tiles_x() * tiles_y() + tile) * 4u + (l >> 5u);
}

bool occupied(uint tile, uint stage, uint l) {
    return (occ[occ_word(tile, stage, l)] & layer_bit(l)) != 0u;
}

// The binning pixel's layers: those it held before this batch (none when the batch starts
// the sums) and those it has written since. A layer's first write stores, so the sums need
// no clearing.
uvec4 held_before = uvec4(0u);
uvec4 written = uvec4(0u);

void add_bin(uint l, uint n, uint pix, vec4 v) {
    uint word = l >> 5u;
    uint bit = layer_bit(l);
    uint i = l * n + pix;
    // One store either way (llvmpipe runs both sides of a branch, each store a loop over lanes).
    bool held = ((held_before[word] | written[word]) & bit) != 0u;
    bins[i] = held ? bins[i] + v : v;
    written[word] |= bit;
}

// The node below footprint px and the share f of the one above (refocus::layered::node_of),
// as the two nodes' slots (reachable by construction, refocus::layered::LayerPlan::slots).
// The nodes' footprints come from a table: llvmpipe evaluates a power in software.
ivec2 node_slots(float px, out float f, out int j) {
    float k = abs(px);
    float linear = NODE_LINEAR_PX / NODE_STEP_PX;
    float t = k <= NODE_LINEAR_PX ? k / NODE_STEP_PX
                                  : linear + log(k / NODE_LINEAR_PX) / log(NODE_RATIO);
    j = clamp(int(floor(px < 0.0 ? -t : t)) - lp.header.x, 0, lp.header.y - 1);
    vec4 e = lp.nodes4[j];
    f = e.y > e.x ? clamp((px - e.x) / (e.y - e.x), 0.0, 1.0) : 0.0;
    return ivec2(e.zw);
}

// The centred views' samples of the binning pixel, summed in registers over a window of
// RUN_NODES consecutive nodes of one group (run_j: the window's first node, -1 before the first
// sample, placed so that the first sample's nodes lie in its middle) and written once at the
// end of bin_pixel: most of a pixel's views see one surface, so their nodes lie within a few of
// each other, and llvmpipe stores a layer sum lane by lane (each view's two read-modify-writes
// were about a fifth of backgammon's time). A sample outside the window goes to memory at
// once, in a loop that a SIMD group without one skips. Six nodes: four were no faster, eight
// the same. The rim cells' views (other groups, interleaved) write as before.
int run_j = -1;
uint run_g = 0u;
const int RUN_NODES = 6;
vec4 runs[RUN_NODES] = vec4[RUN_NODES](vec4(0.0), vec4(0.0), vec4(0.0), vec4(0.0), vec4(0.0), vec4(0.0));

// The slot of node m of the range (-1: unreachable or past it).
int slot_of_node(int m) {
    return m >= 0 && m < lp.header.y ? int(lp.nodes4[m].z) : -1;
}

uint order_at(int i) {
    return lp.order4[i >> 2][i & 3];
}

uint group_of(uint k) {
    return lp.group_of4[k >> 2u][k & 3u];
}

float slot_px(uint k) {
    return lp.slot_px4[k >> 2u][k & 3u];
}

// View k's sample of output pixel pix (x, focus s, the pixel's own depth where the guard keeps
// it): the focus test's sums and the layer sums. `cr`: Catmull-Rom for footprints under half a
// pixel (a pixel whose own surface is in focus).
// `centred`: the cell's centroid is the view, so its sample is the plain one (a literal at
// every call: the centred views' loops carry none of the rim cells' code).
void bin_view(uint k, vec3 x, float s, float own, vec2 lo, vec2 hi, bool cr, bool centred, uint n, uint pix, inout vec4 st0, inout vec4 st1, inout vec4 st2, inout vec4 st3) {
    uint groups = uint(lp.header.z);
    float scale = lp.scale.x;
    ViewWarp w = warp_of(k);
    vec3 y0 = mat3(w.a0.xyz, w.a1.xyz, w.a2.xyz) * x + w.b_weight.xyz * s;
    if (!(y0.z > 0.0)) {
        return;
    }
    float wk = w.b_weight.w;
    vec2 p0 = y0.xy / y0.z;
    bool in0 = all(greaterThanEqual(p0, lo)) && all(lessThanEqual(p0, hi));
    vec3 c0 = vec3(0.0);
    if (in0) {
        c0 = fetch(p0, w.a0.w);
        vec3 cp = max(c0, vec3(0.0));
        st0 += vec4(wk * c0, wk);
        vec3 root = sqrt(cp);
        st3 = st3.w > 0.0 ? st3 : vec4(root, 1.0);
        vec3 e = root - st3.rgb;
        st1.rgb += wk * e * e;
        st2.rgb += wk * e;
    }
    float seen = visible_sigma(uint(footprints[k].vis.y), p0);
    float sigma = own >= 0.0 ? (seen > own ? seen : own) : seen;
    float d = sigma >= 0.0 ? s - sigma : 0.0;
    // The cell's centroid (a rim cell's; a centred cell's is the view itself).
    vec2 p = p0;
    if (!centred) {
        vec3 cell_centre = footprints[k].origin.xyz
                         + 0.5 * (footprints[k].span_s.xyz + footprints[k].span_t.xyz);
        if (cell_centre != vec3(0.0)) {
            vec3 q = y0 + cell_centre * d;
            if (!(q.z > 0.0)) {
                return;
            }
            p = q.xy / q.z;
        }
    }
    if (any(lessThan(p, lo)) || any(greaterThan(p, hi))) {
        return;
    }
    uint g = group_of(k);
    // The footprint's longer side from its group's extent per unit residual.
    float blur = abs(d) * max(lp.units[g].x, lp.units[g].y);
    vec3 col;
    if (cr && blur < FOCUSED_BLUR_PX) {
        col = bicubic(p, int(w.a0.w));
    } else if (centred || (in0 && p == p0)) {
        col = c0;
    } else {
        col = fetch(p, w.a0.w);
    }
    float f;
    int j;
    ivec2 slot = node_slots(d * scale, f, j);
    vec4 below = vec4(wk * (1.0 - f) * col, wk * (1.0 - f));
    vec4 above = vec4(wk * f * col, wk * f);
    bool hit = false;
    if (centred) {
        bool first = run_j < 0;
        run_j = first ? max(j - RUN_NODES / 2 + 1, 0) : run_j;
        run_g = first ? g : run_g;
        int o = j - run_j;
        hit = g == run_g && o >= 0 && o < RUN_NODES - 1;
        for (int i = 0; i < RUN_NODES; ++i) {
            runs[i] += hit && o == i ? below : (hit && o + 1 == i ? above : vec4(0.0));
        }
    }
    for (int once = 0; once < (hit ? 0 : 1); ++once) {
        if (f < 1.0 && slot.x >= 0) {
            add_bin(uint(slot.x) * groups + g, n, pix, below);
        }
        if (f > 0.0 && slot.y >= 0) {
            add_bin(uint(slot.y) * groups + g, n, pix, above);
        }
    }
    st1.w += wk;
}

void bin_pixel(ivec2 px) {
    uint n = uint(lp.header.w);
    uint pix = uint(px.y) * uint(pc.view_size.x) + uint(px.x);
    vec4 st0 = vec4(0.0);
    vec4 st1 = vec4(0.0);
    vec4 st2 = vec4(0.0);
    vec4 st3 = vec4(0.0);
    if (pc.accumulate != 0u) {
        st0 = stats[4u * pix];
        st1 = stats[4u * pix + 1u];
        st2 = stats[4u * pix + 2u];
        st3 = stats[4u * pix + 3u];
    }
    vec3 x = vec3((vec2(px) + 0.5) * pc.out_scale - 0.5, 1.0);
    float s = max(dot(pc.plane.xyz, x), 0.0);
    vec2 lo = vec2(-0.5);
    vec2 hi = pc.view_size - 0.5;
    float scale = lp.scale.x;
    // On an estimate, a pixel whose own surface is in focus keeps its own depth in every view
    // that sees something farther there (the estimate's silhouettes).
    float own = -1.0;
    if (lp.scale.y > 0.0) {
        float sg = scene_sigma[2 * depth_index(x.xy)];
        if (sg >= 0.0 && abs((s - sg) * scale) < lp.scale.y) {
            own = sg;
        }
    }
    // Pixels whose own surface is in focus read footprints under half a pixel with
    // Catmull-Rom; they take a loop of their own, so a SIMD group without them never runs its
    // code (llvmpipe runs both sides of a per-lane branch).
    float sigma_x = scene_sigma[2 * depth_index(x.xy)];
    bool focused = pc.focused_reach > 0.0 && sigma_x >= 0.0 && abs(s - sigma_x) < pc.focused_reach;
    // The batch's views in binning order (the host's ranges): centred [c.x, c.y), the others
    // [r.x, r.y).
    ivec2 c = ivec2(pc.centred_from, pc.centred_to);
    ivec2 r = ivec2(pc.rim_from, pc.rim_to);
    for (int i = c.x; i < (focused ? c.y : c.x); ++i) {
        bin_view(order_at(i), x, s, own, lo, hi, true, true, n, pix, st0, st1, st2, st3);
    }
    for (int i = c.x; i < (focused ? c.x : c.y); ++i) {
        bin_view(order_at(i), x, s, own, lo, hi, false, true, n, pix, st0, st1, st2, st3);
    }
    for (int i = r.x; i < (focused ? r.y : r.x); ++i) {
        bin_view(order_at(i), x, s, own, lo, hi, true, false, n, pix, st0, st1, st2, st3);
    }
    for (int i = r.x; i < (focused ? r.x : r.y); ++i) {
        bin_view(order_at(i), x, s, own, lo, hi, false, false, n, pix, st0, st1, st2, st3);
    }
    if (run_j >= 0) {
        uint groups = uint(lp.header.z);
        for (int i = 0; i < RUN_NODES; ++i) {
            int slot = slot_of_node(run_j + i);
            if (runs[i].w > 0.0 && slot >= 0) {
                add_bin(uint(slot) * groups + run_g, n, pix, runs[i]);
            }
        }
    }
    stats[4u * pix] = st0;
    stats[4u * pix + 1u] = st1;
    stats[4u * pix + 2u] = st2;
    stats[4u * pix + 3u] = st3;
}

// The layer's box width along one axis: the node's footprint narrowed by the linear
// interpolation's variance (refocus::layered, `narrow`).
float box_of(uint l, uint axis) {
    uint groups = uint(lp.header.z);
    uint g = l % groups;
    float d = slot_px(l / groups) / max(lp.scale.x, 1e-12);
    float e = abs(d) * (axis == 0u ? lp.units[g].x : lp.units[g].y);
    return sqrt(max(e * e - 2.0, 0.0));
}

// A layer whose box is zero wide along both axes (box_of 0: a footprint within the
// interpolation's own blur, the nodes near the focus) is its sums as they are: the rows and
// columns skip it and the composite reads its sums where the pixel holds it. Near the focus lie
// most samples, so this is most of what the boxes would copy. The plan marks them once
// (GpuLayerParams::new), so the composite's loop over layers pays one read, not two boxes.
bool sharp(uint l) {
    return (lp.sharp[l >> 5u] & layer_bit(l)) != 0u;
}

// Running box along a line of `count` samples at `base + i * stride` (refocus::layered::
// tent_box_1d): STAGE 1 reads bins and writes rows, STAGE 2 reads rows and writes the boxes. The
// line's tiles are `line_tile0 + t * line_tile_step`. STAGE 1 reads a pixel's sums only where
// the pixel holds the line's layer, STAGE 2 the rows only in the tiles STAGE 1 wrote:
// elsewhere the memory holds another plan's values, and the sample is zero.
uint line_base;
uint line_stride;
uint line_pixel0;
uint line_layer;
uint line_tile0;
uint line_tile_step;

bool line_tile_on(int t) {
    return occupied(line_tile0 + uint(t) * line_tile_step, STAGE - 1u, line_layer);
}

vec4 line_value(int i) {
    uint at = line_base + uint(i) * line_stride;
    if (STAGE == 1u) {
        uint held = pixel_layers[line_pixel0 + uint(i) * line_stride][line_layer >> 5u];
        return (held & layer_bit(line_layer)) != 0u ? bins[at] : vec4(0.0);
    }
    return line_tile_on(i / int(TILE_PX)) ? rows[at] : vec4(0.0);
}

void store_line(int i, vec4 v) {
    uint at = line_base + uint(i) * line_stride;
    if (STAGE == 1u) {
        rows[at] = v;
    } else {
        bins[boxes_base() + at] = v;
    }
}

// A cursor over the line's integral: k the sample below, t the integral over [0, k], a and b
// the samples k and k + 1 (kept, so each sample is read once per cursor).
struct Cursor {
    int k;
    vec4 t;
    vec4 a;
    vec4 b;
};

// The integral over [0, t] (t within [c.k, count - 1] at the first call, non-decreasing
// between calls).
vec4 integral(inout Cursor c, float t, int count) {
    int k = min(int(floor(t)), count - 2);
    while (c.k < k) {
        c.t += 0.5 * (c.a + c.b);
        c.k += 1;
        c.a = c.b;
        c.b = line_value(c.k + 1);
    }
    float f = t - float(c.k);
    return c.t + f * c.a + 0.5 * f * f * (c.b - c.a);
}

// The box of the line's outputs [lo, hi), every sample at or below `zero` being zero (so the
// integrals start there, at exactly what a sum of the zeros before gives: 0).
void box_line(int count, float width, int lo, int hi, int zero) {
    if (count < 2 || !(width > 0.0)) {
        for (int i = lo; i < hi; ++i) {
            store_line(i, line_value(i));
        }
        return;
    }
    float last = float(count - 1);
    int k0 = min(zero, count - 2);
    Cursor lower = Cursor(k0, vec4(0.0), line_value(k0), line_value(k0 + 1));
    Cursor upper = lower;
    float from = float(k0);
    for (int i = lo; i < hi; ++i) {
        float a = max(float(i) - 0.5 * width, 0.0);
        float b = min(float(i) + 0.5 * width, last);
        vec4 ib = integral(upper, max(b, from), count);
        vec4 ia = integral(lower, max(a, from), count);
        store_line(i, (ib - ia) / (b - a));
    }
}

// One line of layer l (STAGE 1: a row, STAGE 2: a column): only the span of tiles within the
// box's reach of a tile the stage before wrote; its tiles marked for the next stage (by the
// line first in its tile, as the tile's other lines find the same span).
void layer_line(uint l, uint line, uint count, uint tiles, float width) {
    if (sharp(l)) {
        return;
    }
    line_layer = l;
    int first_on = -1;
    int last_on = -1;
    for (int t = 0; t < int(tiles); ++t) {
        if (line_tile_on(t)) {
            first_on = first_on < 0 ? t : first_on;
            last_on = t;
        }
    }
    if (first_on < 0) {
        return;
    }
    // An output reads samples up to ceil(width / 2) + 1 away: that many tiles and one more.
    int reach = int(ceil(0.5 * max(width, 0.0))) / int(TILE_PX) + 1;
    int t0 = max(first_on - reach, 0);
    int t1 = min(last_on + reach, int(tiles) - 1);
    int lo = t0 * int(TILE_PX);
    int hi = min((t1 + 1) * int(TILE_PX), int(count));
    box_line(int(count), width, lo, hi, max(first_on * int(TILE_PX) - 1, 0));
    if (line % TILE_PX == 0u) {
        for (int t = t0; t <= t1; ++t) {
            atomicOr(occ[occ_word(line_tile0 + uint(t) * line_tile_step, STAGE, l)], layer_bit(l));
        }
    }
}

void composite_pixel(ivec2 px) {
    uint n = uint(lp.header.w);
    uint pix = uint(px.y) * uint(pc.view_size.x) + uint(px.x);
    vec4 st0 = stats[4u * pix];
    vec4 st1 = stats[4u * pix + 1u];
    vec4 st2 = stats[4u * pix + 2u];
    vec3 x = vec3((vec2(px) + 0.5) * pc.out_scale - 0.5, 1.0);
    uint tile = tile_of(px);
    float threshold = footprints[0].vis.w;
    if (threshold > 0.0 && st0.w > 0.0 && scene_sigma[2 * depth_index(x.xy)] >= 0.0) {
        vec3 mean = st2.rgb / st0.w;
        vec3 spread = max(st1.rgb / st0.w - mean * mean, vec3(0.0));
        if (max(spread.r, max(spread.g, spread.b)) <= threshold * threshold) {
            imageStore(accum_image, px, st0);
            return;
        }
    }
    float total = st1.w;
    vec4 result = vec4(0.0);
    if (total > 0.0) {
        uint groups = uint(lp.header.z);
        // The tile's boxed layers, read once (not once a layer), and the pixel's sharp ones.
        uvec3 boxed_in = uvec3(occ[occ_word(tile, 2u, 0u)], occ[occ_word(tile, 2u, 32u)],
                               occ[occ_word(tile, 2u, 64u)]);
        uvec3 summed_in = pixel_layers[pix].xyz;
        vec3 acc = vec3(0.0);
        float uncovered = 1.0;
        for (int slot = 0; slot < lp.slots.x; ++slot) {
            vec4 cw = vec4(0.0);
            for (uint g = 0u; g < groups; ++g) {
                uint l = uint(slot) * groups + g;
                bool as_summed = sharp(l);
                uvec3 held = as_summed ? summed_in : boxed_in;
                if ((held[l >> 5u] & layer_bit(l)) != 0u) {
                    cw += bins[(as_summed ? 0u : boxes_base()) + l * n + pix];
                }
            }
            if (cw.w <= 1e-12) {
                continue;
            }
            float a = min(cw.w / (uncovered * total), 1.0);
            acc += uncovered * a * cw.rgb / cw.w;
            uncovered *= 1.0 - a;
            if (uncovered <= 1e-12) {
                break;
            }
        }
        float covered = 1.0 - uncovered;
        if (covered > 0.0) {
            result = vec4(acc / covered, 1.0);
        }
    }
    imageStore(accum_image, px, result);
}

// STAGE 0: the pixel's views binned, the layers it holds recorded, and its tile's.
void bin_tile(ivec2 px) {
    uint pix = uint(px.y) * uint(pc.view_size.x) + uint(px.x);
    if (pc.accumulate != 0u) {
        held_before = pixel_layers[pix];
    }
    bin_pixel(px);
    pixel_layers[pix] = held_before | written;
    uint tile = tile_of(px);
    for (uint w = 0u; w < 3u; ++w) {
        if ((written[w] & ~held_before[w]) != 0u) {
            atomicOr(occ[occ_word(tile, 0u, w * 32u)], written[w]);
        }
    }
}

void main() {
    ivec2 size = ivec2(pc.view_size);
    uvec3 id = gl_GlobalInvocationID;
    uint layers = uint(lp.slots.x) * uint(lp.header.z);
    uint n = uint(lp.header.w);
    if (STAGE == 0u || STAGE == 3u) {
        ivec2 px = ivec2(id.xy);
        if (any(greaterThanEqual(px, size))) {
            return;
        }
        if (STAGE == 0u) {
            bin_tile(px);
        } else {
            composite_pixel(px);
        }
        return;
    }
    uint l = id.y;
    if (l >= layers) {
        return;
    }
    uint tx = tiles_x();
    uint ty = tiles_y();
    if (STAGE == 1u) {
        if (id.x >= uint(size.y)) {
            return;
        }
        line_base = l * n + id.x * uint(size.x);
        line_pixel0 = id.x * uint(size.x);
        line_stride = 1u;
        line_tile0 = id.x / TILE_PX * tx;
        line_tile_step = 1u;
        layer_line(l, id.x, uint(size.x), tx, box_of(l, 0u));
    } else {
        if (id.x >= uint(size.x)) {
            return;
        }
        line_base = l * n + id.x;
        line_stride = uint(size.x);
        line_tile0 = id.x / TILE_PX;
        line_tile_step = tx;
        layer_line(l, id.x, uint(size.y), ty, box_of(l, 1u));
    }
}
