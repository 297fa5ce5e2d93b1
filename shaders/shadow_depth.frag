#version 300 es
// Depth only (the shadow map has no colour attachment).
precision mediump float;
void main() {}
