#version 450
// Divides the accumulated colour by the weights actually used. Pixels no view reached get the
// defined background: colour 0, alpha 0. Encoding to sRGB (when wanted) is done by the output
// attachment's format, exactly as the hardware's sRGB conversion rounds.
layout(set = 0, binding = 0) uniform sampler2D accum;
layout(location = 0) out vec4 color;

void main() {
    vec4 a = texelFetch(accum, ivec2(gl_FragCoord.xy), 0);
    color = a.w > 0.0 ? vec4(a.rgb / a.w, 1.0) : vec4(0.0);
}
