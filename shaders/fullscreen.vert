#version 330 core
// One triangle that covers the viewport, with no vertex buffer: corners (0,0), (2,0), (0,2) in uv from gl_VertexID.
// uv is (0,0) at the bottom-left and (1,1) at the top-right of the viewport.
out vec2 v_uv;

void main() {
  vec2 p = vec2(float((gl_VertexID << 1) & 2), float(gl_VertexID & 2));
  v_uv = p;
  gl_Position = vec4(p * 2.0 - 1.0, 0.0, 1.0);
}
