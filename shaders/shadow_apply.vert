#version 300 es
// The shadow catcher's second pass: screen tiles (NDC) that hold shadow factors below 1.
layout(location = 0) in vec2 a_ndc;
void main() { gl_Position = vec4(a_ndc, 0.0, 1.0); }
