#version 450
// Divides the accumulated colour by the weights actually used. Pixels no view reached get the
// defined background: colour 0, alpha 0.
//
// MODE 0: write the float average (EXR, or 8-bit when the attachment's own conversion is
//         wanted); MODE 1: round the average to the nearest 8-bit level (encoded averaging);
// MODE 2: encode linear light with the exact sRGB curve, then round to the nearest 8-bit level.
// The explicit rounding makes 8-bit output independent of how a device's sRGB attachments or
// UNORM conversions round: the attachment receives exact multiples of 1/255.
layout(constant_id = 0) const uint MODE = 0;

layout(set = 0, binding = 0) uniform sampler2D accum;
layout(location = 0) out vec4 color;

vec3 linear_to_srgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, greaterThan(c, vec3(0.0031308)));
}

void main() {
    vec4 a = texelFetch(accum, ivec2(gl_FragCoord.xy), 0);
    vec4 c = a.w > 0.0 ? vec4(a.rgb / a.w, 1.0) : vec4(0.0);
    if (MODE == 2u) {
        c.rgb = linear_to_srgb(c.rgb);
    }
    if (MODE != 0u) {
        c.rgb = floor(clamp(c.rgb, 0.0, 1.0) * 255.0 + 0.5) / 255.0;
    }
    color = c;
}
