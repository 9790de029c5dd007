#version 450
// Draws one image into a rectangle of the window (the viewport): the refocus image, the scene
// panel or the text overlay. The swapchain is UNORM and receives sRGB-encoded values: the
// refocus output already holds them (ENCODE = 0, copied), the scene image is an sRGB image
// whose samples are linear light (ENCODE = 1, encoded here).
layout(constant_id = 0) const uint ENCODE = 0;

layout(set = 0, binding = 0) uniform sampler2D image;
layout(push_constant) uniform Push {
    // Destination rectangle in window pixels: x, y, width, height.
    vec4 rect;
} pc;
layout(location = 0) out vec4 colour;

vec3 linear_to_srgb(vec3 c) {
    c = clamp(c, 0.0, 1.0);
    return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, greaterThan(c, vec3(0.0031308)));
}

void main() {
    vec2 uv = (gl_FragCoord.xy - pc.rect.xy) / pc.rect.zw;
    vec4 c = texture(image, uv);
    if (ENCODE == 1u) {
        c.rgb = linear_to_srgb(c.rgb);
    }
    colour = c;
}
