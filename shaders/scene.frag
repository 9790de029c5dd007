#version 450
// Linear-light colour into an sRGB attachment: the hardware encodes and blends in linear light.
layout(location = 0) in vec4 v_colour;
layout(location = 0) out vec4 colour;

void main() {
    colour = v_colour;
}
