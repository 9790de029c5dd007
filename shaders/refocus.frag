#version 450
// Generalized shift-and-sum: for this output pixel, sample every view of the draw at its
// homography, mask samples behind the view's camera or outside its image, and add the
// weighted colours (rgb) and weights (a) into the float accumulation target (additive blend).
#include "refocus_interface.glsl"

layout(set = 0, binding = 0) uniform sampler2DArray views;
layout(std430, set = 0, binding = 1) readonly buffer Warps { ViewWarp warps[]; };

layout(location = 0) out vec4 accum;

void main() {
    // Pixel-index coordinates of the reference view: pixel (i, j)'s centre is at (i, j).
    vec3 x = vec3(gl_FragCoord.xy * pc.out_scale - 0.5, 1.0);
    // Inverse depth of the plane along this pixel's ray; <= 0 past the horizon, where the
    // documented rule focuses at infinity.
    float s = max(dot(pc.plane.xyz, x), 0.0);
    vec2 lo = vec2(-0.5);
    vec2 hi = pc.view_size - 0.5;
    vec3 sum = vec3(0.0);
    float wsum = 0.0;
    for (uint k = pc.first_view; k < pc.first_view + pc.view_count; ++k) {
        ViewWarp w = warps[k];
        vec3 y = mat3(w.a0.xyz, w.a1.xyz, w.a2.xyz) * x + w.b_weight.xyz * s;
        if (y.z <= 0.0) {
            continue; // behind camera i
        }
        vec2 p = y.xy / y.z;
        if (any(lessThan(p, lo)) || any(greaterThan(p, hi))) {
            continue; // outside view i
        }
        vec3 c = textureLod(views, vec3((p + 0.5) / pc.view_size, w.a0.w), 0.0).rgb;
        sum += w.b_weight.w * c;
        wsum += w.b_weight.w;
    }
    accum = vec4(sum, wsum);
}
